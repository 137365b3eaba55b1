//! Explicit cracks (Nairn & Aimene's CRAMP, issue 33): the crack velocity
//! fields keep the two sides of a crack apart, crack contact keeps closed
//! faces from interpenetrating, the crack surfaces follow the material,
//! and bad crack input is refused naming the field.

use crate::common;

use cleave::diagnostics::Recorder;
use cleave::fracture::cracks::Cramp;
use cleave::mpm::Simulation;
use cleave::scene::{Scene, Stage};

/// The soft elastic material every scene here is made of.
const SOFT: &str = r#"[materials.m]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e8
poissons_ratio = 0.3
"#;

fn parse(text: &str) -> Scene {
    Scene::from_text(text, None).unwrap_or_else(|e| panic!("{e}"))
}

/// Two blocks of one contact group stacked at y = 15.1 mm, cut apart by an
/// explicit crack along their interface and 2.9 mm beyond their x-edges
/// (an edge crack must reach past the body by the kernel's reach, else a
/// line from a corner particle to a node outside the body passes round
/// its end: with 0.4 mm the corners leaked 0.1 % of the top block's
/// velocity per step into the bottom one); the
/// top block moves with `TOP_V`, the bottom one is at rest. One contact
/// group: without the crack they would share one velocity field (welded).
fn stacked(top_v: [f64; 2], friction: f64) -> String {
    format!(
        r#"
[grid]
cell_size = 0.001
max = [0.03, 0.03]
shape_function = "quadratic_bspline"
[analysis]
plane = "plane_strain"
[time]
end = 1.0e-4
cfl = 0.3
{SOFT}[[bodies]]
name = "bottom"
shape = {{ type = "box", min = [0.005, 0.005], max = [0.025, 0.0151] }}
material = "m"
explicit_cracks = [{{ points = [[0.0021, 0.0151], [0.0055, 0.0151], [0.0101, 0.0151], [0.0152, 0.0151], [0.0203, 0.0151], [0.0245, 0.0151], [0.0279, 0.0151]], friction = {friction} }}]
[[bodies]]
name = "top"
shape = {{ type = "box", min = [0.005, 0.0151], max = [0.025, 0.025] }}
material = "m"
velocity = [{}, {}]
[output]
series_rows = 5
"#,
        top_v[0], top_v[1]
    )
}

fn run(scene: &Scene) -> (Simulation, Recorder) {
    let mut sim = Simulation::new(scene);
    let mut rec = Recorder::default();
    sim.run(&mut rec).unwrap_or_else(|e| panic!("{e}"));
    (sim, rec)
}

/// The number of series rows from `t0` on (the load's hold) and the mean
/// of a column over them.
fn hold_means(rec: &Recorder, t0: f64) -> (usize, impl Fn(&str) -> f64 + '_) {
    let hold: Vec<_> = rec
        .rows
        .iter()
        .filter(|r| r.time > t0 * (1.0 - 1e-9))
        .collect();
    let n = hold.len();
    let mean = move |name: &str| {
        hold.iter()
            .map(|r| r.get(&rec.columns, name).expect(name))
            .sum::<f64>()
            / n as f64
    };
    (n, mean)
}

fn body_velocities(sim: &Simulation, body: u16) -> Vec<[f64; 2]> {
    let p = sim.particles();
    (0..p.len())
        .filter(|&i| p.body[i] == body)
        .map(|i| p.v[i])
        .collect()
}

/// The top block pulls away: the crack keeps it off the bottom block's
/// velocity field, so the bottom block stays exactly at rest and the top
/// one moves rigidly; the upper crack surface follows the top block, the
/// lower one stays, the plane goes halfway.
#[test]
fn a_crack_lets_the_sides_separate_freely() {
    let scene = parse(&stacked([0.0, 1.0], 0.0));
    assert!(scene.plan.has(Stage::FieldPartition));
    assert!(scene.plan.has(Stage::Contact));
    assert!(scene.plan.has(Stage::CrackSurfaces));
    let (sim, rec) = run(&scene);
    // both ends lie outside the blocks: no tips, no J
    for end in ["start", "end"] {
        for col in ["J", "KI", "KII"] {
            let v = common::last_value(&rec, &rec.columns, &format!("crack0_{end}_{col}"));
            assert!(
                v.is_nan(),
                "crack0_{end}_{col} = {v} at an end outside the material"
            );
        }
    }
    let t = sim.time();
    let cramp = sim.model::<Cramp>().expect("the crack model");
    assert_eq!(cramp.warnings, Default::default());
    for v in body_velocities(&sim, 0) {
        assert_eq!(v, [0.0, 0.0], "the bottom block moved");
    }
    for v in body_velocities(&sim, 1) {
        assert!(
            (v[0]).abs() < 1e-12 && (v[1] - 1.0).abs() < 1e-12,
            "the top block is not rigid: {v:?}"
        );
    }
    let crack = &cramp.cracks[0];
    // the ends stick out of the blocks: they have no material to follow
    // and stay; the points inside move
    let last = crack.plane.len() - 1;
    assert_eq!(crack.plane[0], [0.0021, 0.0151]);
    assert_eq!(crack.plane[last], [0.0279, 0.0151]);
    for k in 1..last {
        let (a, b, p) = (crack.above[k], crack.below[k], crack.plane[k]);
        assert!((b[1] - 0.0151).abs() < 1e-15, "lower surface moved: {b:?}");
        assert!(
            (a[1] - (0.0151 + t)).abs() < 1e-9,
            "upper surface {a:?}, expected y = {}",
            0.0151 + t
        );
        assert!((p[1] - (0.0151 + 0.5 * t)).abs() < 1e-9, "plane {p:?}");
    }
    assert_eq!(cramp.warnings.wrong_side + cramp.warnings.third_crack, 0);
}

/// Without the crack the two blocks of one group share a field: the
/// bottom block is dragged along (the control of the test above).
#[test]
fn without_the_crack_the_blocks_are_welded() {
    let text = stacked([0.0, 1.0], 0.0).replace(
        "explicit_cracks = [{ points = [[0.0021, 0.0151], [0.0055, 0.0151], [0.0101, 0.0151], [0.0152, 0.0151], [0.0203, 0.0151], [0.0245, 0.0151], [0.0279, 0.0151]], friction = 0 }]",
        "",
    );
    let scene = parse(&text);
    assert!(!scene.plan.has(Stage::Contact));
    let (sim, _) = run(&scene);
    let dragged = body_velocities(&sim, 0)
        .iter()
        .map(|v| v[1])
        .fold(0.0, f64::max);
    assert!(
        dragged > 0.1,
        "bottom block's fastest particle {dragged} m/s"
    );
}

/// The top block pushes down on the bottom one: the closed crack carries
/// the compression (momentum goes into the bottom block, the total is
/// kept) and the faces do not pass through each other.
#[test]
fn a_closed_crack_carries_compression_without_interpenetration() {
    let scene = parse(&stacked([0.0, -1.0], 0.0));
    let (sim, _) = run(&scene);
    let p = sim.particles();
    let (mut bottom, mut total) = (0.0, 0.0);
    for i in 0..p.len() {
        total += p.mass[i] * p.v[i][1];
        if p.body[i] == 0 {
            bottom += p.mass[i] * p.v[i][1];
        }
    }
    let top_mass: f64 = (0..p.len())
        .filter(|&i| p.body[i] == 1)
        .map(|i| p.mass[i])
        .sum();
    let p0 = -top_mass;
    assert!(
        (total - p0).abs() < 1e-9 * p0.abs(),
        "momentum {total} vs {p0}"
    );
    assert!(
        bottom < 0.2 * p0,
        "the bottom block took {bottom} of {p0} kg·m/s"
    );
    let cramp = sim.model::<Cramp>().expect("the crack model");
    let crack = &cramp.cracks[0];
    let h = 0.001;
    for k in 0..crack.plane.len() - 1 {
        let gap = crack.opening(k, 0.5);
        assert!(
            gap > -0.05 * h,
            "faces interpenetrate by {gap} m at segment {k}"
        );
    }
    // the bottom block's top row is not above the top block's bottom row
    let lowest_top = (0..p.len())
        .filter(|&i| p.body[i] == 1)
        .map(|i| p.x[i][1])
        .fold(f64::INFINITY, f64::min);
    let highest_bottom = (0..p.len())
        .filter(|&i| p.body[i] == 0)
        .map(|i| p.x[i][1])
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(
        lowest_top > highest_bottom,
        "{lowest_top} ≤ {highest_bottom}"
    );
}

/// Crack contact twice per step (Nairn & Aimene §2.1.3) or once (the
/// default): the plan has the `contact_momenta` stage only for two passes,
/// both conserve momentum and keep the faces apart, and the first pass
/// changes what is computed (it ran). The bottom block's momentum at
/// 0.1 ms against the impulse σAt = 0.0367 kg·m/s an intact block takes
/// by 10 µs: docs/cracks.md has the comparison.
#[test]
fn crack_contact_runs_in_one_or_two_passes() {
    let one = parse(&stacked([0.0, -1.0], 0.0));
    let two = parse(&format!(
        "{}\n[cramp]\ncontact_passes = 2\n",
        stacked([0.0, -1.0], 0.0)
    ));
    assert!(two.plan.has(Stage::ContactMomenta) && two.plan.has(Stage::Contact));
    assert!(!one.plan.has(Stage::ContactMomenta) && one.plan.has(Stage::Contact));
    let mut bottoms = vec![];
    for scene in [&one, &two] {
        let (sim, _) = run(scene);
        let p = sim.particles();
        let (mut bottom, mut total, mut top_mass) = (0.0, 0.0, 0.0);
        for i in 0..p.len() {
            total += p.mass[i] * p.v[i][1];
            if p.body[i] == 0 {
                bottom += p.mass[i] * p.v[i][1];
            } else {
                top_mass += p.mass[i];
            }
        }
        assert!(
            (total + top_mass).abs() < 1e-9 * top_mass,
            "momentum {total}"
        );
        let crack = &sim.model::<Cramp>().expect("the crack model").cracks[0];
        for k in 0..crack.plane.len() - 1 {
            let gap = crack.opening(k, 0.5);
            assert!(gap > -0.05 * 0.001, "faces interpenetrate by {gap} m");
        }
        bottoms.push(bottom);
    }
    println!(
        "bottom block's momentum at 0.1 ms: one pass {}, two {}",
        bottoms[0], bottoms[1]
    );
    assert!(bottoms.iter().all(|&b| b < -0.5 * 0.198), "{bottoms:?}");
    assert!(
        (bottoms[0] - bottoms[1]).abs() > 1e-4,
        "the first pass changed nothing: {bottoms:?}"
    );
}

/// The top block slides along a closed frictionless crack: nothing pulls
/// the bottom block along (the control: with one field it would be).
#[test]
fn a_frictionless_crack_lets_the_faces_slide() {
    let scene = parse(&stacked([1.0, 0.0], 0.0));
    let (sim, _) = run(&scene);
    for v in body_velocities(&sim, 0) {
        assert!(v[0].abs() < 1e-12, "the bottom block was dragged: {v:?}");
    }
}

/// A cracked plate that translates: its crack moves with it, exactly.
#[test]
fn a_crack_in_a_translating_body_moves_with_it() {
    let text = format!(
        r#"
[grid]
cell_size = 0.001
max = [0.04, 0.03]
[analysis]
plane = "plane_strain"
[time]
end = 2.0e-4
cfl = 0.3
{SOFT}[[bodies]]
shape = {{ type = "box", min = [0.005, 0.005], max = [0.025, 0.025] }}
material = "m"
velocity = [20.0, 10.0]
explicit_cracks = [{{ points = [[0.0101, 0.0143], [0.0152, 0.0151], [0.0198, 0.0162]] }}]
"#
    );
    for update in ["xpic1", "flip"] {
        let scene = parse(&format!("{text}\n[cramp]\nsurface_update = \"{update}\"\n"));
        let (sim, _) = run(&scene);
        let t = sim.time();
        let cramp = sim.model::<Cramp>().expect("the crack model");
        let start = [[0.0101, 0.0143], [0.0152, 0.0151], [0.0198, 0.0162]];
        for (k, x0) in start.iter().enumerate() {
            for s in [
                cramp.cracks[0].plane[k],
                cramp.cracks[0].above[k],
                cramp.cracks[0].below[k],
            ] {
                let want = [x0[0] + 20.0 * t, x0[1] + 10.0 * t];
                assert!(
                    (s[0] - want[0]).abs() < 1e-12 && (s[1] - want[1]).abs() < 1e-12,
                    "{update}: point {k} at {s:?}, expected {want:?}"
                );
            }
        }
    }
}

/// Bad crack input: each a clear error naming the field.
#[test]
fn bad_cracks_are_refused_naming_the_field() {
    let base = stacked([0.0, 1.0], 0.0);
    let line = "explicit_cracks = [{ points = [[0.0021, 0.0151], [0.0055, 0.0151], [0.0101, 0.0151], [0.0152, 0.0151], [0.0203, 0.0151], [0.0245, 0.0151], [0.0279, 0.0151]], friction = 0 }]";
    assert!(base.contains(line));
    let refused = |with: &str, path: &str, words: &str| {
        let text = base.replace(line, with);
        let err = Scene::from_text(&text, None)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(path), "{err}");
        assert!(err.contains(words), "{err}");
    };
    refused(
        "explicit_cracks = [{ points = [[0.0046, 0.0151]] }]",
        "bodies[0].explicit_cracks[0].points",
        "at least 2 points",
    );
    refused(
        "explicit_cracks = [{ points = [[0.001, 0.028], [0.003, 0.029]] }]",
        "bodies[0].explicit_cracks[0]",
        "outside its body",
    );
    refused(
        "explicit_cracks = [{ points = [[0.01, 0.01], [0.05, 0.01]] }]",
        "bodies[0].explicit_cracks[0].points[1]",
        "outside the grid",
    );
    refused(
        "explicit_cracks = [{ points = [[0.01, 0.01], [0.02, 0.01]], friction = -1 }]",
        "bodies[0].explicit_cracks[0].friction",
        "",
    );
    refused(
        "explicit_cracks = [{ points = [[0.01, 0.01], [0.02, 0.01]], pressure = { table = [] } }]",
        "bodies[0].explicit_cracks[0].pressure.table",
        "at least one",
    );
    refused(
        "explicit_cracks = [{ points = [[0.01, 0.01], [0.02, 0.01]], pressure = { table = [[1e-4, 1.0], [0.0, 2.0]] } }]",
        "bodies[0].explicit_cracks[0].pressure.table[1]",
        "must not decrease",
    );
    // three cracks through one node's reach
    refused(
        "explicit_cracks = [{ points = [[0.01, 0.01], [0.02, 0.0101]] }, { points = [[0.01, 0.0103], [0.02, 0.0104]] }, { points = [[0.015, 0.007], [0.0151, 0.013]] }]",
        "bodies[0].explicit_cracks[2]",
        "sees 3 cracks",
    );
    // a second contact group
    let text = base.replace("name = \"top\"", "name = \"top\"\ncontact_group = 1");
    let err = Scene::from_text(&text, None)
        .expect_err("refused")
        .to_string();
    assert!(err.contains("one contact group"), "{err}");
    // with DFG
    let err = Scene::from_text(&format!("{base}\n[dfg]\nself_contact = true\n"), None)
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("dfg") && err.contains("explicit cracks"),
        "{err}"
    );
    // a 3D scene
    let text3 = format!(
        r#"
[grid]
cell_size = 0.002
max = [0.02, 0.02, 0.02]
[time]
end = 1.0e-4
{SOFT}[[bodies]]
shape = {{ type = "box", min = [0.004, 0.004, 0.004], max = [0.016, 0.016, 0.016] }}
material = "m"
explicit_cracks = [{{ points = [[0.005, 0.01, 0.01], [0.015, 0.01, 0.01]] }}]
"#
    );
    let err = Scene::from_text(&text3, None)
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("bodies[0].explicit_cracks") && err.contains("2D"),
        "{err}"
    );
    // J contours that are not an even number of cells, or twice the same
    for (list, at, why) in [
        ("[3]", "cramp.j_contours[0]", "even number of cells"),
        ("[4, 70]", "cramp.j_contours[1]", "even number of cells"),
        ("[4, 4]", "cramp.j_contours[1]", "twice"),
        ("[]", "cramp.j_contours", "at least one"),
    ] {
        let err = Scene::from_text(&format!("{base}\n[cramp]\nj_contours = {list}\n"), None)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(at) && err.contains(why), "{list}: {err}");
    }
    // contact passes other than 1 or 2
    let err = Scene::from_text(&format!("{base}\n[cramp]\ncontact_passes = 3\n"), None)
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("cramp.contact_passes") && err.contains("3 contact passes"),
        "{err}"
    );
    // growth with no toughness, with two, with a bad one or segment
    for (table, at, why) in [
        ("{}", "cramp.growth", "needs the toughness"),
        (
            "{ j_ic = 1.0, k_ic = 1.0 }",
            "cramp.growth",
            "both j_ic and k_ic",
        ),
        ("{ j_ic = -1.0 }", "cramp.growth.j_ic", "> 0"),
        ("{ k_ic = 0.0 }", "cramp.growth.k_ic", "> 0"),
        (
            "{ j_ic = 1.0, segment = 2.0 }",
            "cramp.growth.segment",
            "[0.1, 1]",
        ),
    ] {
        let err = Scene::from_text(&format!("{base}\n[cramp]\ngrowth = {table}\n"), None)
            .expect_err("refused")
            .to_string();
        assert!(err.contains(at) && err.contains(why), "{table}: {err}");
    }
    let err = Scene::from_text(&format!("{base}\n[cramp]\nk_split = \"j2\"\n"), None)
        .expect_err("refused")
        .to_string();
    assert!(
        err.contains("cramp.k_split") && err.contains("interaction") && err.contains("cod"),
        "{err}"
    );
    // options without cracks
    let plain = base.replace(line, "");
    let err = Scene::from_text(&format!("{plain}\n[cramp]\n"), None)
        .expect_err("refused")
        .to_string();
    assert!(err.contains("cramp"), "{err}");
}

/// The shipped centre-cracked plate (`scenes/cramp_center_crack.toml`,
/// the traction raised smoothly to 1 MPa over 1.5 ms, then held to 2 ms),
/// against the static solution of a centre crack 2a in a strip of width
/// W (2a/W = 0.2): over the hold (1.5–2 ms, 26 rows) the mean J of both
/// tips on the 4- and 8-cell contours (PIJC: no other crack crosses them)
/// equals K²/E′, K = σ√(πa)·√(sec(πa/W)) = 1.1496e5 Pa√m, 12.03 J/m²,
/// within 3 % (the issue's figure), K_I equals K within 1.5 % and K_II is
/// below 1 % of it (the interaction integral's split: 0.78 %, of opposite
/// sign at the two tips, which sit differently on the grid); at the end the crack's centre opens by
/// δ = 4σa/E′ · V(2a/W) (Tada, Paris & Irwin's centre-cracked strip,
/// V = −0.071 − 0.535α + 0.169α² + 0.02α³ − 1.071 ln(1 − α)/α: 1.024 at
/// α = 0.2; 14.91 µm) within 5 %. About 80 s in release:
/// `cargo test --release --test engine cracks:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn the_centre_crack_gives_griffiths_opening_and_j() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cramp_center_crack.toml"
    );
    let scene = Scene::from_path(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
    let (sim, rec) = run(&scene);
    let (sigma, a, w, e, nu): (f64, f64, f64, f64, f64) = (1.0e6, 0.004, 0.04, 1.0e9, 0.3);
    let e_star = e / (1.0 - nu * nu);
    let pi = std::f64::consts::PI;
    let al = 2.0 * a / w;
    let v =
        -0.071 - 0.535 * al + 0.169 * al * al + 0.02 * al.powi(3) - 1.071 * (1.0 - al).ln() / al;
    let want = 4.0 * sigma * a / e_star * v;
    let crack = &sim.model::<Cramp>().expect("the crack model").cracks[0];
    let opening = crack.opening(crack.plane.len() / 2, 0.0);
    println!("centre opening {opening:e} m at 2 ms, static {want:e} m");
    assert!(
        (opening / want - 1.0).abs() < 0.05,
        "centre opening {opening:e} m, static {want:e} m"
    );
    let k = sigma * (pi * a).sqrt() * (1.0 / (pi * a / w).cos()).sqrt();
    let j_static = k * k / e_star;
    let (rows, mean) = hold_means(&rec, 1.5e-3);
    assert!(rows >= 25, "{rows} rows in the hold");
    for end in ["start", "end"] {
        for col in ["J", "J8"] {
            let j = mean(&format!("crack0_{end}_{col}"));
            println!("{end} {col}: {j:.4} J/m² over the hold, K²/E′ = {j_static:.4}");
            assert!(
                (j / j_static - 1.0).abs() < 0.03,
                "{end} {col} {j} against {j_static}"
            );
        }
        let (k1, k2) = (
            mean(&format!("crack0_{end}_KI")),
            mean(&format!("crack0_{end}_KII")),
        );
        println!("{end}: K_I {k1:.5e}, K_II {k2:.3e} Pa√m, K = {k:.5e}");
        assert!((k1 / k - 1.0).abs() < 0.015, "{end} K_I {k1} against {k}");
        assert!(k2.abs() < 0.01 * k, "{end} K_II {k2}");
    }
}

/// A mixed-mode case (`scenes/cramp_inclined_crack.toml`: the centre
/// crack turned by β = 30°), against the inclined Griffith crack of an
/// infinite plate, K_I = σ√(πa)cos²β, K_II = σ√(πa)sinβcosβ: over the
/// hold, J of both tips within 8 % of cos²β·K²/E′ with the straight
/// crack's finite-width factor (sec(πa/W) at the crack's projected
/// half-width a·cosβ; measured +5 %); K_I and K_II each within 5 % of
/// the handbook's with that factor (measured +2.1/+3.5 % and +3.0/+0.9 %:
/// J's excess shared out); and K_II/K_I, which the split by the
/// interaction integral sets, within 3 % of tan β at both tips (measured
/// +1.4 %, −1.9 %; the plate, five crack lengths wide, moves the
/// handbook's ratio by less than the width factor moves either K). The
/// first split, by the tracked surfaces' opening (`k_split = "cod"`),
/// gave +8 % and +25 % (docs/cracks.md). Prints the crack's opening
/// profile (δ_t/δ_n per crack point, which is tan β all along an inclined
/// Griffith crack). About 80 s in release:
/// `cargo test --release --test engine cracks:: -- --ignored --nocapture`.
#[test]
#[ignore]
fn an_inclined_crack_splits_j_into_both_modes() {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/cramp_inclined_crack.toml"
    );
    let scene = Scene::from_path(std::path::Path::new(path)).unwrap_or_else(|e| panic!("{e}"));
    let (sim, rec) = run(&scene);
    let (sigma, a, w, e, nu): (f64, f64, f64, f64, f64) = (1.0e6, 0.004, 0.04, 1.0e9, 0.3);
    let beta = 30f64.to_radians();
    let pi = std::f64::consts::PI;
    let e_star = e / (1.0 - nu * nu);
    let k0 = sigma * (pi * a).sqrt() * (1.0 / (pi * a * beta.cos() / w).cos()).sqrt();
    let want = beta.cos().powi(2) * k0 * k0 / e_star;
    let crack = &sim.model::<Cramp>().expect("the crack model").cracks[0];
    let n = crack.plane.len();
    let t = {
        let (p, q) = (crack.plane[0], crack.plane[n - 1]);
        let l = ((q[0] - p[0]).powi(2) + (q[1] - p[1]).powi(2)).sqrt();
        [(q[0] - p[0]) / l, (q[1] - p[1]) / l]
    };
    let nrm = [-t[1], t[0]];
    let profile: Vec<String> = (0..n)
        .map(|k| {
            let d = [
                crack.above[k][0] - crack.below[k][0],
                crack.above[k][1] - crack.below[k][1],
            ];
            let (dn, dt) = (d[0] * nrm[0] + d[1] * nrm[1], d[0] * t[0] + d[1] * t[1]);
            format!("{k}: δn {dn:.3e} δt/δn {:.3}", dt / dn)
        })
        .collect();
    println!("opening profile at 2 ms:\n{}", profile.join("\n"));
    let (_, mean) = hold_means(&rec, 1.5e-3);
    for end in ["start", "end"] {
        let j = mean(&format!("crack0_{end}_J"));
        let (k1, k2) = (
            mean(&format!("crack0_{end}_KI")),
            mean(&format!("crack0_{end}_KII")),
        );
        println!(
            "{end}: J {j:.4} J/m² (J8 {:.4}), expected about {want:.4}; K_I {k1:.4e}, K_II {k2:.4e}, \
             K_II/K_I {:.3} (tan β {:.3})",
            mean(&format!("crack0_{end}_J8")),
            k2 / k1,
            beta.tan()
        );
        assert!((j / want - 1.0).abs() < 0.08, "{end}: J {j} against {want}");
        let (k1_want, k2_want) = (k0 * beta.cos().powi(2), k0 * beta.sin() * beta.cos());
        assert!(
            (k1 / k1_want - 1.0).abs() < 0.05,
            "{end}: K_I {k1} against {k1_want}"
        );
        assert!(
            (k2 / k2_want - 1.0).abs() < 0.05,
            "{end}: K_II {k2} against {k2_want}"
        );
        assert!(
            ((k2 / k1) / beta.tan() - 1.0).abs() < 0.03,
            "{end}: K_II/K_I {} against tan β {}",
            k2 / k1,
            beta.tan()
        );
    }
}

/// The growing edge crack of `scenes/cramp_edge_growth.toml` (a 20 × 30
/// mm plate of the soft material, the crack 5 mm into its left edge at
/// mid-height, pulled at top and bottom by a traction rising linearly to
/// 1 MPa over 0.6 ms), with J_Ic = `j_ic` and `extra` after the crack in
/// the body's list (a second crack).
fn edge_cracked(j_ic: f64, extra: &str) -> String {
    let text = include_str!("../../scenes/cramp_edge_growth.toml");
    let crack = "[0.005, 0.0151]] }";
    let tough = "growth = { j_ic = 100.0 }";
    assert!(text.contains(crack) && text.contains(tough));
    text.replace(crack, &format!("{crack}{extra}"))
        .replace(tough, &format!("growth = {{ j_ic = {j_ic:?} }}"))
}

/// Mode I growth: the edge crack of [`edge_cracked`] (J_Ic = 100 J/m²,
/// K_Ic = √(J_Ic E*) = 1.05e5 Pa√m, reached near 0.55 MPa by the
/// handbook's K = 1.50 σ√(πa)) keeps its length while its J is below
/// J_Ic, then runs straight across the ligament (every new point within
/// a quarter cell of the crack's line) in half-cell segments until it
/// leaves the plate. As tough as J_Ic = 10⁶ J/m², it never grows.
#[test]
fn an_edge_crack_grows_straight_once_j_reaches_the_toughness() {
    let j_ic = 100.0;
    let scene = parse(&edge_cracked(j_ic, ""));
    assert!(scene.plan.has(Stage::CrackGrowth));
    let (sim, rec) = run(&scene);
    let crack = &sim.model::<Cramp>().expect("the crack model").cracks[0];
    let y0 = 0.0151;
    let grown = &crack.plane[7..];
    println!(
        "{} points grown, tip at {:?}",
        grown.len(),
        crack.plane.last()
    );
    assert!(grown.len() >= 20, "{} points grown", grown.len());
    for p in grown {
        assert!(
            (p[1] - y0).abs() < 0.25e-3,
            "a grown point off the line: {p:?}"
        );
    }
    // half-cell segments (each new one 0.5 mm; the plate has stretched
    // them since by under a tenth)
    for w in crack.plane[6..crack.plane.len() - 1].windows(2) {
        let l = ((w[1][0] - w[0][0]).powi(2) + (w[1][1] - w[0][1]).powi(2)).sqrt();
        assert!((l / 0.5e-3 - 1.0).abs() < 0.1, "a segment of {l} m");
    }
    assert!(
        crack.plane.last().unwrap()[0] > 0.0195,
        "{:?}",
        crack.plane.last()
    );
    // before the first growth, J stayed below J_Ic and came close to it
    let get = |r: &cleave::diagnostics::SeriesRow, name: &str| r.get(&rec.columns, name).unwrap();
    let len0 = get(&rec.rows[0], "crack0_length");
    let before: Vec<f64> = rec
        .rows
        .iter()
        .take_while(|r| get(r, "crack0_length") < len0 + 0.25e-3)
        .map(|r| get(r, "crack0_end_J"))
        .filter(|j| j.is_finite())
        .collect();
    let top = before.iter().copied().fold(0.0, f64::max);
    println!(
        "J before growth up to {top:.2} J/m² ({} rows)",
        before.len()
    );
    assert!(
        top < 1.02 * j_ic && top > 0.8 * j_ic,
        "J up to {top} before growth"
    );
    // the released energy Σ J Δa t: nothing before growth; at the end at
    // least J_Ic times the grown length (each event's J is at least
    // J_Ic) and not far above it; and, on the row where the tip has
    // crossed the plate, the mechanical energy the load's work did not
    // leave in the plate (W − K − U) within a tenth of it (the plate's
    // energy lags a new segment by a few steps, and it takes no account of
    // the numerical dissipation that follows)
    let last = rec.rows.last().unwrap();
    let thickness = 1.0;
    let grown_length = get(last, "crack0_length") - len0;
    let released = last.fracture_energy;
    let floor = j_ic * grown_length * thickness;
    println!("released {released:.4} J, J_Ic Δa t = {floor:.4} J");
    assert!(
        released > 0.97 * floor && released < 1.15 * floor,
        "released {released} J against J_Ic Δa t = {floor} J"
    );
    for r in &rec.rows {
        if get(r, "crack0_length") < len0 + 0.25e-3 {
            assert_eq!(r.fracture_energy, 0.0, "released before growth");
        }
    }
    let across = rec
        .rows
        .iter()
        .find(|r| get(r, "crack0_end_x") > 0.0195)
        .expect("a row with the tip across");
    let lost = across.external_work - across.kinetic_energy - across.strain_energy;
    println!(
        "at {:.3} ms: W − K − U = {lost:.4} J, released {:.4} J",
        across.time * 1e3,
        across.fracture_energy
    );
    assert!(
        (lost / across.fracture_energy - 1.0).abs() < 0.1,
        "W − K − U = {lost} J against {} J released",
        across.fracture_energy
    );
    // a tough plate keeps its crack
    let (sim, _) = run(&parse(&edge_cracked(1e6, "")));
    assert_eq!(
        sim.model::<Cramp>().expect("the crack model").cracks[0]
            .plane
            .len(),
        7
    );
}

/// A crack that grows toward another stops at it: the edge crack of
/// [`edge_cracked`] runs toward an interior crack across its path
/// (x = 12.05 mm, 8 mm long), comes within 1.5 cells of it and no point
/// of it passes that crack (it stops half a cell short, where its J
/// falls below J_Ic).
#[test]
fn a_growing_crack_stops_at_the_crack_it_meets() {
    let wall = ", { points = [[0.01205, 0.0111], [0.01205, 0.0151], [0.01205, 0.0191]] }";
    let (sim, _) = run(&parse(&edge_cracked(100.0, wall)));
    let cracks = &sim.model::<Cramp>().expect("the crack model").cracks;
    let tip = *cracks[0].plane.last().unwrap();
    println!("tip at {tip:?}, {} points", cracks[0].plane.len());
    assert!(tip[0] > 0.01205 - 1.5e-3, "it stopped at {tip:?}");
    assert!(cracks[0].plane.iter().all(|p| p[0] < 0.01205), "{tip:?}");
}

/// The edge-cracked plate of [`edge_cracked`] with `cracks` in place of
/// its crack, without growth, on a grid 5 mm beyond the plate (room for
/// cracks drawn from outside it), J of crack 0's end on the contours of
/// 4, 6, 8, 12 and 16 cells by `method`: the means of its `_J`, `_J6`,
/// `_J8`, `_J12`, `_J16` over the last third of the ramp (0.4–0.6 ms, the
/// load still rising: every contour sees the same instants).
fn edge_plate_j(cracks: &str, method: &str) -> [f64; 5] {
    let mut text = include_str!("../../scenes/cramp_edge_growth.toml").to_string();
    for (from, to) in [
        (
            "min = [-0.004, -0.002]",
            "min = [-0.004, -0.005]".to_string(),
        ),
        ("max = [0.022, 0.032]", "max = [0.025, 0.035]".to_string()),
        (
            "growth = { j_ic = 100.0 }",
            format!("j_contours = [4, 6, 8, 12, 16]\nj_method = \"{method}\""),
        ),
    ] {
        assert!(text.contains(from), "{from}");
        text = text.replace(from, &to);
    }
    let line = text
        .lines()
        .find(|l| l.starts_with("explicit_cracks"))
        .expect("the crack")
        .to_string();
    let text = text.replace(&line, &format!("explicit_cracks = [{cracks}]"));
    let (_, rec) = run(&parse(&text));
    let (_, mean) = hold_means(&rec, 4.0e-4);
    ["J", "J6", "J8", "J12", "J16"].map(|c| mean(&format!("crack0_end_{c}")))
}

/// Every J of `js` (the contours in order) within 10 % of the first's.
fn within_tenth_of_first(method: &str, js: &[f64]) {
    for (k, j) in js.iter().enumerate().skip(1) {
        assert!(
            (j / js[0] - 1.0).abs() < 0.1,
            "{method} contour {k}: {j} against {}",
            js[0]
        );
    }
}

/// The edge crack of [`edge_cracked`] as a polyline from outside the
/// plate to its tip at x = 5 mm.
const EDGE_CRACK: &str = "{ points = [[-0.0039, 0.0151], [-0.002, 0.0151], [0.0, 0.0151], [0.002, 0.0151], [0.004, 0.0151], [0.005, 0.0151]] }";

/// The patch test (Nairn & Aimene's Table 1, scaled to the small plate):
/// a vertical crack through the whole plate 2.55 mm ahead of the edge
/// crack's tip cuts every contour but the 4-cell one. FIJC (the vertical
/// crack's faces integrated inside the contour) keeps J on the 6-, 8- and
/// 12-cell contours within 10 % of the 4-cell J (measured: −4.5, −8.9,
/// −7.1 %); PIJC falls 18 % below it at 8 cells (the paper: PIJC 0.943
/// and 0.773 of the reference at 16 and 32 cells, FIJC 1.064 and 1.061).
#[test]
fn fijc_keeps_j_where_a_crack_cuts_the_contour() {
    let cracks = format!(
        "{EDGE_CRACK}, {{ points = [[0.00755, -0.0039], [0.00755, 0.0151], [0.00755, 0.0339]] }}"
    );
    let fijc = edge_plate_j(&cracks, "fijc");
    let pijc = edge_plate_j(&cracks, "pijc");
    println!("FIJC J4, 6, 8, 12, 16 {fijc:?}\nPIJC J4, 6, 8, 12, 16 {pijc:?}");
    assert_eq!(fijc[0], pijc[0], "the 4-cell contour meets no other crack");
    // (the 16-cell contour runs 3 mm outside the plate's cracked edge and
    // has no J in the last rows: left out)
    within_tenth_of_first("FIJC", &fijc[..4]);
    assert!(
        pijc[2] < 0.85 * pijc[0],
        "PIJC 8 cells {} against {}",
        pijc[2],
        pijc[0]
    );
}

/// Contour adaptation (Nairn & Aimene's DENT example, scaled): two edge
/// cracks 7 mm into either edge on one line (a symmetric double-edge
/// notch; an eccentric ligament would bend shut one tip), their tips 6
/// cells apart. Adaptive FIJC moves the right edge of the contours that
/// would hold the other tip (12 and 16 cells) to two cells short of it:
/// J on every contour within 10 % of the 4-cell J (measured: within
/// 4.3 %); without adaptation the 12-cell J is 38 % low and the 16-cell J
/// near 0 (the paper: J goes to 0 for contours of 14 cells and more, 40 %
/// low at 12).
#[test]
fn adaptive_fijc_leaves_out_the_other_tip() {
    let cracks = "{ points = [[-0.0039, 0.0151], [-0.002, 0.0151], [0.0, 0.0151], [0.002, 0.0151], [0.004, 0.0151], [0.006, 0.0151], [0.007, 0.0151]] }, \
         { points = [[0.0239, 0.0151], [0.022, 0.0151], [0.02, 0.0151], [0.018, 0.0151], [0.016, 0.0151], [0.014, 0.0151], [0.013, 0.0151]] }";
    let fijc = edge_plate_j(cracks, "fijc");
    let fixed = edge_plate_j(cracks, "fijc_fixed");
    println!("FIJC J4, 6, 8, 12, 16 {fijc:?}\nnon-adaptive J4, 6, 8, 12, 16 {fixed:?}");
    within_tenth_of_first("FIJC", &fijc);
    assert!(
        fixed[4] < 0.8 * fijc[0],
        "non-adaptive 16 cells {} against {}",
        fixed[4],
        fijc[0]
    );
}

/// The growing edge crack of `scenes/cramp_edge_growth.toml` with a
/// pressure on its faces rising to 0.3 MPa over 0.4 ms runs to 0.4 ms,
/// the crack growing across most of the plate. With the face forces
/// spread by N alone over the nodes with mass (eq. 4's S*) a particle
/// under the pressed face near the mouth collapsed at step 413
/// (0.334 ms): the nodes in the opened gap, nearly empty, took a full
/// share of the force (docs/cracks.md). Before the crack grows, the
/// pressure's work as counted is the energy the plate holds to 1 % of
/// the work (measured 0.08 %; with S*, 1.2 % and rising).
#[test]
fn a_growing_crack_with_pressed_faces_runs_on() {
    let text = include_str!("../../scenes/cramp_edge_growth.toml")
        .replace("end = 6.0e-4", "end = 4.0e-4")
        .replace(
            "[0.005, 0.0151]] }]",
            "[0.005, 0.0151]], pressure = { table = [[0.0, 0.0], [4.0e-4, 3.0e5]] } }]",
        );
    assert!(text.contains("pressure = { table"));
    let (sim, rec) = run(&parse(&text));
    assert!(sim.time() >= 4.0e-4 * (1.0 - 1e-9), "{}", sim.time());
    let col =
        |r: &cleave::diagnostics::SeriesRow, name: &str| r.get(&rec.columns, name).expect(name);
    let first = col(&rec.rows[0], "crack0_length");
    let last = col(rec.rows.last().expect("rows"), "crack0_length");
    println!("the crack grew from {first:.4e} m to {last:.4e} m");
    assert!(last > first + 0.01, "{first} → {last}");
    // the last row before the first growth (the tip only moves with the
    // material until then: its length changes by less than a µm)
    let before = rec
        .rows
        .iter()
        .take_while(|r| col(r, "crack0_length") < first + 1e-6)
        .last()
        .expect("rows before growth");
    let (work, err) = (col(before, "external_work"), col(before, "energy_error"));
    println!("before growth: work {work:.4e} J, energy error {err:.3e} J");
    assert!(work > 0.1 && err.abs() < 0.01 * work, "{err} of {work}");
}

/// The small plate of [`edge_cracked`] with a centre crack 2a = 10 mm
/// (x = 5–15 mm, 2a/W = 0.5) and J on 4- and 8-cell contours, loaded by
/// `load`: a traction on its top and bottom, or a pressure on the crack's
/// faces, each rising linearly to 1 MPa over 0.6 ms.
fn centre_cracked(load: &str) -> String {
    let mut text = include_str!("../../scenes/cramp_edge_growth.toml").to_string();
    let line = text
        .lines()
        .find(|l| l.starts_with("explicit_cracks"))
        .expect("the crack")
        .to_string();
    let pts: Vec<String> = (0..=20)
        .map(|k| format!("[{:.4}, 0.0151]", 0.005 + 0.0005 * k as f64))
        .collect();
    let mut crack = format!("{{ points = [{}]", pts.join(", "));
    let ramp = "{ table = [[0.0, 0.0], [6.0e-4, 1.0e6]] }";
    if load == "pressure" {
        crack += &format!(", pressure = {ramp}");
        for side in ["top", "bottom"] {
            let bc = format!("[grid.boundary.{side}]\ntype = \"traction\"\nnormal = {ramp}\n");
            assert!(text.contains(&bc), "{bc}");
            text = text.replace(&bc, "");
        }
    }
    text = text.replace(&line, &format!("explicit_cracks = [{crack} }}]"));
    let tough = "growth = { j_ic = 100.0 }";
    assert!(text.contains(tough));
    text.replace(tough, "j_contours = [4, 8]")
}

/// A pressure on the crack's faces (eqs. 7–8) loads a centre crack as
/// the same traction on the plate's ends does (superposition: the
/// uncracked plate under the end traction has that stress on the crack's
/// line), so the crack opens the same and J is the same, on both
/// contours only with the pressure's own term (step 9, eq. 11; without
/// it J4 and J8 came out 21 and −5 J/m² where the ends give 161). Means
/// over the last third of the ramp, both tips: the pressure-loaded J on
/// both contours within 3 % of the end-loaded J4 (measured +1.2 %,
/// +0.4 %), the middle's opening at the end within 7 % (+5.4 %). The
/// pressure's work as the step counts it (F·v_s Δt) is the energy the
/// plate holds, to 1 % of it (measured 0.3 %). With the forces spread by
/// N alone over the nodes with mass (eq. 4's S*, this code's first
/// spreading) J was −3.6 %, −3.2 %, the opening +1.6 % and the work
/// 6.6 % short of the energy: docs/cracks.md. The plan gains
/// `crack_traction` only with a pressure, and the pressure's forces
/// cancel: the plate's momentum stays zero.
#[test]
fn a_pressure_on_the_faces_loads_the_crack_as_the_ends_traction_does() {
    let ends = parse(&centre_cracked("ends"));
    let faces = parse(&centre_cracked("pressure"));
    assert!(!ends.plan.has(Stage::CrackTraction));
    assert!(faces.plan.has(Stage::CrackTraction));
    let (sim_e, rec_e) = run(&ends);
    let (sim, rec_p) = run(&faces);
    // superposition: the same opening too (the middle of the crack)
    let middle = |s: &Simulation| {
        let c = &s.model::<Cramp>().expect("cracks").cracks[0];
        c.opening(c.plane.len() / 2, 0.0)
    };
    let (d_e, d_p) = (middle(&sim_e), middle(&sim));
    println!("opening at the middle: end traction {d_e:.4e} m, face pressure {d_p:.4e} m");
    assert!((d_p / d_e - 1.0).abs() < 0.07, "{d_p} against {d_e}");
    let (_, mean_e) = hold_means(&rec_e, 4.0e-4);
    let (n, mean_p) = hold_means(&rec_p, 4.0e-4);
    assert!(n >= 20, "{n} rows");
    for end in ["start", "end"] {
        let reference = mean_e(&format!("crack0_{end}_J"));
        let (j4, j8) = (
            mean_p(&format!("crack0_{end}_J")),
            mean_p(&format!("crack0_{end}_J8")),
        );
        println!(
            "{end}: end traction J4 {reference:.3}, J8 {:.3}; face pressure J4 {j4:.3}, J8 {j8:.3} J/m²",
            mean_e(&format!("crack0_{end}_J8"))
        );
        for j in [j4, j8] {
            assert!(
                (j / reference - 1.0).abs() < 0.03,
                "{end}: {j} against {reference}"
            );
        }
    }
    let last = rec_p.rows.last().expect("rows");
    let col = |name: &str| last.get(&rec_p.columns, name).expect(name);
    let (work, held) = (
        col("external_work"),
        col("kinetic_energy") + col("strain_energy"),
    );
    println!("pressure's work {work:.5} J, kinetic + strain {held:.5} J");
    assert!((work - held).abs() < 0.01 * work, "{work} against {held}");
    let p = sim.particles();
    let mut momentum = [0.0; 2];
    let mut scale = 0.0;
    for i in 0..p.len() {
        for d in 0..2 {
            momentum[d] += p.mass[i] * p.v[i][d];
        }
        scale += p.mass[i] * (p.v[i][0].powi(2) + p.v[i][1].powi(2)).sqrt();
    }
    println!("momentum {momentum:?}, Σ m|v| {scale:e}");
    assert!(
        momentum.iter().all(|m| m.abs() < 1e-6 * scale),
        "{momentum:?} against {scale}"
    );
}
