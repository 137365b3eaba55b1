//! Damage-field-gradient partitioning in 3D (issue 32; Homel & Herbold
//! 2017, section 2): the 3D versions of `tests/engine/dfg.rs`'s failed band and
//! notched bar, and the thread count not changing a 3D DFG run.

use crate::common;

use cleave::diagnostics::Recorder;
use cleave::mpm::Simulation;
use cleave::scene::{Format, Scene, Stage};

type Sim3 = Simulation<3, 6>;

fn scene(text: &str) -> Scene {
    match Scene::from_text(text, Some(Format::Toml)) {
        Ok(s) => s,
        Err(e) => panic!("{e}\n{text}"),
    }
}

fn run(s: &Scene) -> (Sim3, Recorder) {
    let mut sim = Sim3::build(s);
    let mut rec = Recorder::default();
    sim.run(&mut rec).unwrap_or_else(|e| panic!("{e}"));
    (sim, rec)
}

/// A bar stretched by its initial velocity (v_x = 100 s⁻¹ (x − 0.15 m),
/// ±10 m/s at the ends) with a band of failed particles across its
/// middle: the band is a body of its own (not an initial crack), one
/// cell (two particle layers) wide, of a material that fails as soon as it
/// is stretched (time to failure, eq. 24, with σ_f = 1 Pa and c_f = 10⁹
/// m/s: failed in the first step). All three bodies are one contact group
/// (one velocity field without DFG).
const BAR: &str = r#"
[grid]
cell_size = 0.005
max = [0.3, 0.06, 0.03]
shape_function = "quadratic_bspline"
[time]
end = 2.0e-3
cfl = 0.4
[materials.m]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e9
poissons_ratio = 0.0
damage = { model = "time_to_failure", strength = 1.0e12, crack_speed = 1000.0 }
[materials.weak]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e9
poissons_ratio = 0.0
damage = { model = "time_to_failure", strength = 1.0, crack_speed = 1.0e9 }
[[bodies]]
name = "left"
shape = { type = "box", min = [0.05, 0.01, 0.005], max = [0.1475, 0.05, 0.025] }
material = "m"
velocity_gradient = [[100.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
velocity_origin = [0.15, 0.03, 0.015]
[[bodies]]
name = "band"
shape = { type = "box", min = [0.1475, 0.01, 0.005], max = [0.1525, 0.05, 0.025] }
material = "weak"
velocity_gradient = [[100.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
velocity_origin = [0.15, 0.03, 0.015]
[[bodies]]
name = "right"
shape = { type = "box", min = [0.1525, 0.01, 0.005], max = [0.25, 0.05, 0.025] }
material = "m"
velocity_gradient = [[100.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]]
velocity_origin = [0.15, 0.03, 0.015]
[output]
series_rows = 41
"#;

/// The paper's motivation (section 1.2) in 3D: a single velocity field
/// binds the material across a failed band; DFG partitioning lets it
/// separate.
#[test]
fn a_3d_bar_separates_through_a_failed_band_with_dfg_and_holds_together_without() {
    let single = scene(BAR);
    let dfg = scene(&format!("{BAR}\n[dfg]\n"));
    assert_eq!(dfg.dimension(), 3);
    assert!(!single.plan.has(Stage::DamageField) && !single.plan.has(Stage::Contact));
    assert!(dfg.plan.has(Stage::DamageField) && dfg.plan.has(Stage::Contact));
    let (mut s_sim, s_rec) = run(&single);
    let (mut d_sim, d_rec) = run(&dfg);
    let k0 = d_rec.rows[0].kinetic_energy;
    let peak_strain = |r: &Recorder| r.rows.iter().map(|r| r.strain_energy).fold(0.0, f64::max);
    let (ds, ss) = (peak_strain(&d_rec), peak_strain(&s_rec));
    println!(
        "3D bar: peak strain energy {ds:.4} J (DFG) vs {ss:.4} J (single field), initial kinetic {k0:.4} J"
    );
    // With DFG each half keeps its centre-of-mass motion (±5 m/s, 3/4 of
    // the kinetic energy) and only its internal stretch rings as strain.
    assert!(ds < 0.26 * k0, "DFG stored {ds} J of {k0} J");
    // Without it the band carries load: the bar stops and stores nearly
    // all its kinetic energy as strain energy.
    assert!(ss > 0.9 * k0, "single field stored only {ss} J of {k0} J");
    let (dv, sv) = (
        common::mean_vx_right_of(d_sim.particles(), 0.16),
        common::mean_vx_right_of(s_sim.particles(), 0.16),
    );
    println!("3D bar: right half's mean velocity {dv:.3} m/s (DFG) vs {sv:.3} m/s (single field)");
    assert!(dv > 4.0, "DFG right half at {dv} m/s (initially 5 m/s)");
    assert!(sv.abs() < 0.5 * dv);
    // the failed band is the same set of particles in both runs: two
    // layers of 16 × 8 particles
    let failed = |r: &Recorder, cols: &[String]| common::last_value(r, cols, "failed_particles");
    assert_eq!(failed(&d_rec, &d_sim.series_columns()), 256.0);
    assert_eq!(failed(&s_rec, &s_sim.series_columns()), 256.0);
    // the band's nodes were split while the halves parted
    let cols = d_sim.series_columns();
    assert!(d_rec
        .rows
        .iter()
        .any(|r| r.get(&cols, "dfg_separated_nodes").unwrap() > 0.0));
}

fn notched_bar_dfg() -> String {
    let path =
        std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/notched_bar_dfg_3d.toml");
    std::fs::read_to_string(&path).expect("scenes/notched_bar_dfg_3d.toml")
}

/// The notched bar of `tests/engine/damage3d.rs` with DFG partitioning
/// (`scenes/notched_bar_dfg_3d.toml`): Rankine softening scaled by l_ch
/// (eq. 23) dissipates G_f × the 6 × 12 mm ligament = 7.2 mJ, within 10 %
/// (docs/dfg.md, "In 3D", has the measured value); the two sides of the
/// failed band are separate fields and the bar ends in two pieces.
#[test]
fn a_notched_3d_bar_broken_by_damage_with_dfg_dissipates_gf_times_its_ligament() {
    let s = scene(&notched_bar_dfg());
    assert_eq!(s.dimension(), 3);
    assert!(s.plan.has(Stage::Damage) && s.plan.has(Stage::DamageField));
    let (mut sim, rec) = run(&s);
    let cols = sim.series_columns();
    let last = rec.rows.last().unwrap();
    let expected = 100.0 * 0.006 * 0.012; // G_f × ligament (y) × depth (z)
    let d = last.fracture_energy;
    let balance = last.get(&cols, "energy_balance").unwrap();
    let fragments = last.get(&cols, "fragments").unwrap();
    let separated = rec
        .rows
        .iter()
        .map(|r| r.get(&cols, "dfg_separated_nodes").unwrap())
        .fold(0.0, f64::max);
    println!(
        "3D notched bar with DFG: dissipated {d:.5} J vs G_f A = {expected:.5} J ({:+.1} %); \
         energy balance {balance:.2e} J; work {:.5} J; {fragments} fragments, \
         strain energy {:.2e} J, up to {separated} separated nodes",
        100.0 * (d / expected - 1.0),
        last.external_work,
        last.strain_energy
    );
    assert!(
        (d / expected - 1.0).abs() < 0.10,
        "dissipated {d} J vs G_f A = {expected} J"
    );
    assert_eq!(fragments, 2.0);
    assert!(separated > 0.0, "no node separated");
    assert!(last.strain_energy < 0.1 * expected);
    assert!(balance.abs() < 0.02 * expected, "balance {balance} J");
    assert!(rec
        .rows
        .windows(2)
        .all(|w| w[1].fracture_energy >= w[0].fracture_energy));
}

/// 1 and 2 threads give the same bits for a 3D DFG run: the band bar cut
/// at 0.5 ms, once as the paper's DFG and once with self-contact (surface
/// flags, the balanced direction over the half sphere's candidates).
#[test]
fn a_3d_dfg_run_does_not_depend_on_the_thread_count() {
    for extra in ["", "self_contact = true\n"] {
        let text = format!(
            "{}\n[dfg]\n{extra}",
            BAR.replace("end = 2.0e-3", "end = 5.0e-4")
        );
        let s = scene(&text);
        let go = |threads: usize| {
            common::on_threads(threads, || {
                let (mut sim, rec) = run(&s);
                let rows: Vec<Vec<f64>> = rec.rows.iter().map(|r| r.values()).collect();
                let cols = sim.series_columns();
                (rows, sim.particles().clone(), cols)
            })
        };
        let (a, b) = (go(1), go(2));
        let col = |name: &str| a.2.iter().position(|c| c == name).expect(name);
        let last = a.0.last().unwrap();
        println!(
            "3D DFG {extra:?}, 1 and 2 threads: {} separated nodes, {} neighbour builds",
            last[col("dfg_separated_nodes")],
            last[col("dfg_neighbour_builds")]
        );
        assert!(last[col("dfg_separated_nodes")] > 0.0, "nothing separated");
        assert!(a.0 == b.0, "series differ ({extra:?})");
        assert!(a.1 == b.1, "particles differ ({extra:?})");
    }
}

/// Section 2.4 in 3D: the incline of `tests/engine/verification3d.rs` (θ = 30°,
/// μ = 0.3) with block and plane in ONE contact group and `[dfg]
/// self_contact`: the block should slide at a = g(sin θ − μ cos θ) as two
/// contact groups do (within 3 %). It does not yet: since the 3D rules of
/// docs/dfg.md ("Why it welds", items 6–10) the block slides, but a =
/// 2.212 m/s² after 20 ms (−6.1 %; two groups −3.3 % by the series'
/// momentum). Run with `cargo test --release --test engine dfg3d:: -- --ignored`
/// (85 s on 2 cores).
#[test]
#[ignore = "3D self-contact: the block slides, 6 % slow: docs/dfg.md, Why it welds"]
fn a_block_in_one_group_slides_down_an_incline_with_3d_self_contact() {
    let s = scene(
        r#"
body_force = [4.905, -8.495709, 0.0]
[grid]
cell_size = 0.01
min = [0.0, 0.0, 0.0]
max = [0.4, 0.12, 0.05]
boundary = { bottom = "fixed" }
[time]
end = 0.06
cfl = 0.4
[transfer]
scheme = "flip"
flip_blend = 0.99
[materials.rubbery]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 2.0e7
poissons_ratio = 0.3
[[bodies]]
shape = { type = "box", min = [0.0, 0.0, 0.0], max = [0.4, 0.04, 0.05] }
material = "rubbery"
[[bodies]]
shape = { type = "box", min = [0.04, 0.04, 0.0], max = [0.09, 0.09, 0.05] }
material = "rubbery"
[output]
snapshots = 0
[dfg]
self_contact = true
friction = 0.3
surface_threshold = 0.99
"#,
    );
    let theta = 30f64.to_radians();
    let expected = 9.81 * (theta.sin() - 0.3 * theta.cos());
    let a = common::body_acceleration_x::<3, 6>(&s, 1, 0.02);
    println!(
        "3D self-contact block: a = {a:.4} m/s² vs g(sin θ − μ cos θ) = {expected:.4} m/s² ({:+.2} %)",
        100.0 * (a / expected - 1.0)
    );
    assert!((a / expected - 1.0).abs() < 0.03, "a = {a} vs {expected}");
}
