//! Hard cases (issue 6): each run either completes with bounded energy
//! (kinetic + strain never above the initial energy plus the work done on
//! the system), conserved mass, conserved momentum where nothing external
//! acts, and no NaN; or it stops with the designed diagnosis. Never a
//! panic, a hang or a silent explosion.
//!
//! `CLEAVE_STABILITY_LONG=1 cargo test --release --test engine stability::` runs
//! the longer variants (finer, longer in time); the default ones are sized
//! for CI.

use crate::common;
use cleave::diagnostics::Recorder;
use cleave::mpm::Simulation;
use cleave::run::SimError;
use cleave::scene::{MemoryBudget, Scene};
use std::time::{Duration, Instant};

fn long() -> bool {
    std::env::var_os("CLEAVE_STABILITY_LONG").is_some_and(|v| v != "0")
}

fn parse(text: &str) -> Scene {
    Scene::from_text(text, None).unwrap_or_else(|e| panic!("{e}"))
}

/// What a completed run must show.
struct Expect {
    /// No external force or boundary acts: momentum is conserved.
    free: bool,
    /// Allowed growth of kinetic + strain over initial + |work| (numerical
    /// heating of the scheme), as a fraction.
    energy_tolerance: f64,
}

/// How a case ended.
// made once per case and matched at once: its size costs nothing
#[allow(clippy::large_enum_variant)]
enum End {
    Completed(Simulation, Recorder),
    Stopped(SimError, Recorder),
}

/// Runs `scene` and checks the invariants of whatever came out: a
/// completed run's rows are finite, its mass constant, its energy bounded
/// (and its momentum constant if `free`); a stopped run stopped with an
/// error that names the step and time, and its rows up to then are finite.
fn run_checked(name: &str, scene: &Scene, expect: Expect) -> End {
    let mut sim = Simulation::new(scene);
    let mut rec = Recorder::default();
    let result = sim.run(&mut rec);
    let rows = &rec.rows;
    assert!(!rows.is_empty(), "{name}: no series rows");
    let first = &rows[0];
    let e0 = first.kinetic_energy + first.strain_energy;
    // the energy the run has had to work with, at most
    let scale = rows
        .iter()
        .map(|r| e0 + r.external_work.abs())
        .fold(f64::MIN_POSITIVE, f64::max);
    let (mut worst, mut worst_t) = (0.0f64, 0.0);
    let core = cleave::diagnostics::SeriesRow::COLUMNS.len();
    for r in rows {
        // (the model columns may be NaN by design, e.g. no crack tip yet)
        assert!(
            r.values()[..core].iter().all(|v| v.is_finite()),
            "{name}: a non-finite value in the row at t = {}",
            r.time
        );
        let growth = (r.kinetic_energy + r.strain_energy - e0 - r.external_work.abs()) / scale;
        if growth > worst {
            (worst, worst_t) = (growth, r.time);
        }
    }
    let mass_drift = rows
        .iter()
        .map(|r| (r.total_mass / first.total_mass - 1.0).abs())
        .fold(0.0, f64::max);
    let p_scale = rows
        .iter()
        .map(|r| r.momentum_x.abs().max(r.momentum_y.abs()))
        .fold(0.0, f64::max)
        .max(
            // a body at rest: compare with the momentum its energy could carry
            (2.0 * first.total_mass * e0.max(f64::MIN_POSITIVE)).sqrt(),
        );
    let p_drift = rows
        .iter()
        .map(|r| {
            ((r.momentum_x - first.momentum_x).abs()).max((r.momentum_y - first.momentum_y).abs())
                / p_scale
        })
        .fold(0.0, f64::max);
    println!(
        "{name}: {} to t = {:.4e} s in {} steps; energy growth {worst:+.2e} (at t = {worst_t:.3e} s), mass drift {mass_drift:.1e}, momentum drift {p_drift:.1e}",
        match &result {
            Ok(_) => "completed".to_string(),
            Err(e) => format!("stopped ({e})"),
        },
        sim.time(),
        sim.steps()
    );
    match result {
        Ok(_) => {
            assert!(
                worst <= expect.energy_tolerance,
                "{name}: energy grew by {worst:.3e} at t = {worst_t:.3e} s"
            );
            assert!(mass_drift < 1e-12, "{name}: mass drifted by {mass_drift:e}");
            if expect.free {
                assert!(
                    p_drift < 1e-9,
                    "{name}: momentum drifted by {p_drift:e} of its scale"
                );
            }
            End::Completed(sim, rec)
        }
        Err(e) => {
            assert!(
                e.to_string().starts_with("step "),
                "{name}: the diagnosis does not say when: {e}"
            );
            End::Stopped(e, rec)
        }
    }
}

fn completed(name: &str, end: End) -> (Simulation, Recorder) {
    match end {
        End::Completed(s, r) => (s, r),
        End::Stopped(e, _) => panic!("{name} stopped: {e}"),
    }
}

/// Two steel disks meet head on at 1 km/s (±500 m/s): the contact shocks
/// them far beyond the elastic range the material is meant for. Either
/// the run completes with its energy bounded and momentum conserved, or
/// it stops on an inverted particle.
#[test]
fn a_1_km_per_s_impact() {
    let (h, end) = if long() {
        (0.5e-3, 20e-6)
    } else {
        (1e-3, 10e-6)
    };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = {h}
max = [0.1, 0.06]
shape_function = "quadratic_bspline"
[time]
end = {end}
cfl = 0.4
[materials.steel]
model = "neo_hookean"
density = 7800.0
youngs_modulus = 2.0e11
poissons_ratio = 0.3
[[bodies]]
shape = {{ type = "disk", center = [0.035, 0.03], radius = 0.01 }}
material = "steel"
velocity = [500.0, 0.0]
contact_group = 0
[[bodies]]
shape = {{ type = "disk", center = [0.0561, 0.03], radius = 0.01 }}
material = "steel"
velocity = [-500.0, 0.0]
contact_group = 1
[output]
series_rows = 101
"#
    ));
    match run_checked(
        "1 km/s impact",
        &scene,
        Expect {
            free: true,
            energy_tolerance: 1e-3,
        },
    ) {
        End::Completed(sim, _) => {
            // they did meet: the disks' centres have moved towards each other and bounced
            let p = sim.particles();
            assert!(
                p.v.iter().any(|v| v[0].abs() < 400.0),
                "no particle was slowed: the disks never met"
            );
        }
        End::Stopped(e, _) => assert!(
            matches!(e, SimError::VolumeVanished { .. }),
            "unexpected diagnosis: {e}"
        ),
    }
}

/// A beam one cell thick with one particle per cell, bending under its
/// initial velocity: the thinnest body MPM can represent.
#[test]
fn a_thin_body_with_one_particle_per_cell() {
    let end = if long() { 0.1 } else { 0.02 };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = 0.01
max = [1.2, 1.2]
shape_function = "quadratic_bspline"
[time]
end = {end}
cfl = 0.5
[[bodies]]
shape = {{ type = "box", min = [0.1, 0.6], max = [1.1, 0.61] }}
material = {{ model = "neo_hookean", density = 1000.0, youngs_modulus = 1.0e7, poissons_ratio = 0.3 }}
particles_per_cell = 1
velocity_gradient = [[0.0, 0.0], [-10.0, 0.0]]
[output]
series_rows = 101
"#
    ));
    let (sim, _) = completed(
        "thin body",
        run_checked(
            "thin body",
            &scene,
            Expect {
                free: true,
                energy_tolerance: 1e-3,
            },
        ),
    );
    assert_eq!(sim.particles().len(), 100);
}

/// A very soft block flying at 200 m/s, thirty times its wave speed,
/// with CFL 0.9: every particle crosses more than 0.8 of a cell per step. It must keep
/// its shape, its speed and its energy.
#[test]
fn particles_crossing_cells_every_step() {
    let end = if long() { 2.5e-3 } else { 1.0e-3 };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = 0.005
max = [1.0, 0.1]
shape_function = "quadratic_bspline"
[time]
end = {end}
cfl = 0.9
[[bodies]]
shape = {{ type = "box", min = [0.05, 0.03], max = [0.15, 0.07] }}
material = {{ model = "neo_hookean", density = 1000.0, youngs_modulus = 3.0e4, poissons_ratio = 0.3 }}
velocity = [200.0, 0.0]
[output]
series_rows = 51
"#
    ));
    let (sim, rec) = completed(
        "cell crossing",
        run_checked(
            "cell crossing",
            &scene,
            Expect {
                free: true,
                energy_tolerance: 1e-9,
            },
        ),
    );
    let dt = rec.column("dt").unwrap();
    // (the first row is t = 0, the last step is cut to land on time.end)
    let crossing = dt[1..dt.len() - 1]
        .iter()
        .map(|d| 200.0 * d / 0.005)
        .fold(f64::INFINITY, f64::min);
    assert!(
        crossing > 0.8,
        "particles cross only {crossing} cells per step"
    );
    let p = sim.particles();
    let mean_x = p.x.iter().map(|x| x[0]).sum::<f64>() / p.len() as f64;
    assert!(
        (mean_x - (0.1 + 200.0 * sim.time())).abs() < 1e-9,
        "the block drifted: centre at {mean_x} m"
    );
    let ke = rec.column("kinetic_energy").unwrap();
    assert!(
        (ke[ke.len() - 1] / ke[0] - 1.0).abs() < 1e-9,
        "kinetic energy changed in a rigid translation"
    );
}

/// Linear shape functions, one particle per cell and a spinning square:
/// the nodes at the free surface carry slivers of mass as the corners
/// sweep past them, the classic source of v = p/m blow-ups.
#[test]
fn near_empty_nodes_at_a_free_surface() {
    let end = if long() { 0.5 } else { 0.1 };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = 0.02
max = [1.0, 1.0]
shape_function = "linear"
[time]
end = {end}
cfl = 0.4
[transfer]
scheme = "flip"
flip_blend = 0.95
[[bodies]]
shape = {{ type = "box", min = [0.35, 0.35], max = [0.65, 0.65] }}
material = {{ model = "neo_hookean", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
particles_per_cell = 1
velocity_gradient = [[0.0, -8.0], [8.0, 0.0]]
[output]
series_rows = 101
"#
    ));
    match run_checked(
        "near-empty nodes",
        &scene,
        Expect {
            free: true,
            energy_tolerance: 1e-3,
        },
    ) {
        End::Completed(..) => {}
        End::Stopped(e, _) => assert!(
            matches!(
                e,
                SimError::EnergyRunaway { .. }
                    | SimError::VolumeVanished { .. }
                    | SimError::NonFinite { .. }
            ),
            "unexpected diagnosis: {e}"
        ),
    }
    // the remedy: shape functions whose weight (and so the force) at a
    // node vanishes smoothly with the node's mass
    let mut smooth = scene.file.clone();
    smooth.grid.shape_function = cleave::scene::ShapeFunctionKind::QuadraticBspline;
    let smooth = Scene::validate(smooth).unwrap_or_else(|e| panic!("{e}"));
    completed(
        "near-empty nodes, B-splines",
        run_checked(
            "near-empty nodes, B-splines",
            &smooth,
            Expect {
                free: true,
                energy_tolerance: 1e-3,
            },
        ),
    );
}

/// A disk whose Weibull strengths are so low that it shatters into dozens
/// of fragments when it hits a wall at 100 m/s, with DFG partitioning.
#[test]
fn a_fully_fragmented_disk() {
    let h = if long() { 2.5e-4 } else { 5e-4 };
    // Weibull: smaller particles are stronger (V^(-1/m)); keep the
    // strength distribution of the coarse run at any h
    let strength = 1.0e7 * (h / 5e-4f64).powf(2.0 / 3.0);
    let scene = parse(&format!(
        r#"
[grid]
cell_size = {h}
max = [0.03, 0.03]
shape_function = "quadratic_bspline"
[grid.boundary]
right = "roller"
[analysis]
plane = "plane_strain"
[time]
end = 3.0e-5
cfl = 0.4
[materials.glass]
model = "linear_elastic"
density = 2500.0
youngs_modulus = 7.0e10
poissons_ratio = 0.22
damage = {{ model = "time_to_failure", strength = {strength}, crack_speed = 3000.0, weibull = {{ modulus = 3.0, ref_volume = 1.0e-6, seed = 7 }} }}
[[bodies]]
shape = {{ type = "disk", center = [0.019, 0.015], radius = 0.008 }}
material = "glass"
velocity = [100.0, 0.0]
[dfg]
friction = 0.3
[output]
series_rows = 61
"#
    ));
    let (sim, rec) = completed(
        "fragmented disk",
        run_checked(
            "fragmented disk",
            &scene,
            Expect {
                free: false,
                energy_tolerance: 1e-3,
            },
        ),
    );
    let p = sim.particles();
    let failed = p.damage.iter().filter(|&&d| d >= 1.0).count() as f64 / p.len() as f64;
    let fragments = rec.column("fragments").unwrap();
    println!(
        "fragmented disk: {:.0} % failed, {} fragments",
        100.0 * failed,
        fragments[fragments.len() - 1]
    );
    // (the cracks are one particle wide: the failed fraction halves with h)
    assert!(
        failed > 0.15,
        "only {:.0} % of the disk failed",
        100.0 * failed
    );
    assert!(
        fragments[fragments.len() - 1] >= 20.0,
        "the disk did not shatter"
    );
}

/// The composite anisotropy γ2222 = 2900 (Gc_max/Gc_min ≈ 5): a plate with
/// a crack at 45° to the fibres, pulled; the 4th-order system is stiff
/// but must stay positive definite and the run bounded.
#[test]
fn the_composite_anisotropy() {
    let (h, end) = if long() {
        (2.5e-4, 3e-5)
    } else {
        (5e-4, 1.5e-5)
    };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = {h}
min = [-0.001, -0.001]
max = [0.021, 0.021]
shape_function = "quadratic_bspline"
[grid.boundary]
top = {{ type = "traction", normal = 2.0e7 }}
bottom = {{ type = "traction", normal = 2.0e7 }}
[analysis]
plane = "plane_strain"
[time]
end = {end}
cfl = 0.5
[materials.composite]
model = "linear_elastic"
density = 1600.0
youngs_modulus = 5.0e10
poissons_ratio = 0.3
phase_field = {{ gc = 4175.0, l0 = 5.0e-4, k_f = 0.0, gamma = [1.0, 2900.0, 0.0, 74.0], angle = 45.0 }}
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0], max = [0.02, 0.02] }}
material = "composite"
cracks = [{{ points = [[0.0, 0.01], [0.005, 0.01]] }}]
[output]
series_rows = 31
"#
    ));
    let (sim, _) = completed(
        "composite anisotropy",
        run_checked(
            "composite anisotropy",
            &scene,
            Expect {
                free: false,
                energy_tolerance: 1e-3,
            },
        ),
    );
    let p = sim.particles();
    assert!(
        p.phase
            .iter()
            .all(|c| c.is_finite() && (-1e-9..=1.0 + 1e-9).contains(c)),
        "c left [0, 1]"
    );
}

/// A neo-Hookean block squeezed to a fifth of its height or less by a heavy platen
/// (1000 times denser, same stiffness) that comes down at 5 m/s, on a
/// roller floor. Every particle must stay uninverted (J > 0) or the run
/// stop on the first one that does not.
#[test]
fn eighty_percent_compression_of_a_neo_hookean_block() {
    let h = if long() { 2.5e-3 } else { 5e-3 };
    let scene = parse(&format!(
        r#"
[grid]
cell_size = {h}
max = [0.4, 0.16]
shape_function = "quadratic_bspline"
[grid.boundary]
bottom = "roller"
[analysis]
plane = "plane_strain"
[time]
end = 0.021
cfl = 0.5
[materials.rubber]
model = "neo_hookean"
density = 1000.0
youngs_modulus = 1.0e6
poissons_ratio = 0.3
[materials.platen]
model = "neo_hookean"
density = 1.0e6
youngs_modulus = 1.0e8
poissons_ratio = 0.3
[[bodies]]
name = "block"
shape = {{ type = "box", min = [0.15, 0.0], max = [0.25, 0.1] }}
material = "rubber"
[[bodies]]
name = "platen"
shape = {{ type = "box", min = [0.05, 0.1], max = [0.35, 0.12] }}
material = "platen"
velocity = [0.0, -5.0]
[output]
series_rows = 101
"#
    ));
    let end = run_checked(
        "80 % compression",
        &scene,
        Expect {
            free: false,
            energy_tolerance: 1e-3,
        },
    );
    match end {
        End::Completed(sim, _) => {
            let p = sim.particles();
            let block: Vec<usize> = (0..p.len()).filter(|&k| p.body[k] == 0).collect();
            let top = block.iter().map(|&k| p.x[k][1]).fold(0.0f64, f64::max);
            let jmin = block
                .iter()
                .map(|&k| {
                    let [[f11, f12], [f21, f22]] = p.def_grad[k];
                    f11 * f22 - f12 * f21
                })
                .fold(f64::INFINITY, f64::min);
            println!(
                "80 % compression: block top at {:.4} m (was 0.1), min J {jmin:.3}",
                top
            );
            assert!(
                top < 0.03,
                "the block was not squeezed to 20 %: its top is at {top} m"
            );
            assert!(jmin > 0.0);
        }
        End::Stopped(e, _) => assert!(
            matches!(e, SimError::VolumeVanished { .. }),
            "unexpected diagnosis: {e}"
        ),
    }
}

/// A block flying into the grid's edge: with a free boundary it stops with
/// the particle that left and where; with a roller wall it bounces and
/// completes.
#[test]
fn a_body_that_reaches_the_grid_edge() {
    let scene = |right: &str| {
        parse(&format!(
            r#"
[grid]
cell_size = 0.01
max = [0.5, 0.2]
shape_function = "quadratic_bspline"
[grid.boundary]
right = "{right}"
[time]
end = 0.03
cfl = 0.5
[[bodies]]
shape = {{ type = "box", min = [0.2, 0.05], max = [0.3, 0.15] }}
material = {{ model = "neo_hookean", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity = [10.0, 0.0]
[output]
series_rows = 61
"#
        ))
    };
    match run_checked(
        "grid edge, free",
        &scene("free"),
        Expect {
            free: true,
            energy_tolerance: 1e-3,
        },
    ) {
        End::Stopped(SimError::LeftGrid { x, .. }, rec) => {
            assert!(x >= 0.49, "left at x = {x}");
            assert!(rec.rows.len() > 2, "the rows before the failure are kept");
        }
        End::Stopped(e, _) => panic!("unexpected diagnosis: {e}"),
        End::Completed(..) => {
            panic!("the block flew 0.3 m at 10 m/s towards an edge 0.2 m away and did not leave")
        }
    }
    let (sim, _) = completed(
        "grid edge, wall",
        run_checked(
            "grid edge, wall",
            &scene("roller"),
            Expect {
                free: false,
                energy_tolerance: 1e-3,
            },
        ),
    );
    let p = sim.particles();
    let vx =
        p.v.iter().zip(&p.mass).map(|(v, m)| v[0] * m).sum::<f64>() / p.mass.iter().sum::<f64>();
    assert!(
        vx < 0.0,
        "the block did not bounce off the wall (mean v_x = {vx} m/s)"
    );
}

/// The CFL factor at the explicit step's limit and beyond: 1.0 either runs
/// bounded or stops with the runaway-energy diagnosis; above 1 the scene
/// is rejected naming time.cfl; a fixed dt beyond the limit stops at the
/// first step with the CFL diagnosis.
#[test]
fn the_cfl_factor_at_one_and_beyond() {
    let bar = |time: &str| {
        format!(
            r#"
[grid]
cell_size = 0.005
max = [1.0, 0.02]
shape_function = "quadratic_bspline"
[grid.boundary]
left = {{ type = "velocity", x = 1.0 }}
[analysis]
plane = "plane_stress"
thickness = 0.01
[time]
end = 1.5e-4
{time}
[transfer]
scheme = "flip"
flip_blend = 1.0
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.005], max = [1.0, 0.015] }}
material = {{ model = "linear_elastic", density = 8000.0, youngs_modulus = 2.0e11, poissons_ratio = 0.0 }}
[output]
series_rows = 101
"#
        )
    };
    for scheme in ["pic", "flip", "apic"] {
        let text = bar("cfl = 1.0").replace("scheme = \"flip\"", &format!("scheme = \"{scheme}\""));
        match run_checked(
            &format!("CFL 1.0, {scheme}"),
            &parse(&text),
            Expect {
                free: false,
                energy_tolerance: 1e-3,
            },
        ) {
            End::Completed(..) => {}
            End::Stopped(e, _) => assert!(
                matches!(
                    e,
                    SimError::EnergyRunaway { .. } | SimError::NonFinite { .. }
                ),
                "{e}"
            ),
        }
    }
    let e = Scene::from_text(&bar("cfl = 1.2"), None).unwrap_err();
    assert_eq!(e.errors[0].path, "time.cfl");
    // dt = 2 h / c, twice the limit
    match run_checked(
        "dt beyond CFL",
        &parse(&bar("dt = 2.0e-6")),
        Expect {
            free: false,
            energy_tolerance: 1e-3,
        },
    ) {
        End::Stopped(
            SimError::CflViolated {
                step, dt, limit, ..
            },
            _,
        ) => {
            assert!(step <= 1 && dt > limit, "step {step}, dt {dt} vs {limit}");
        }
        End::Stopped(e, _) => panic!("unexpected diagnosis: {e}"),
        End::Completed(..) => panic!("a dt twice the CFL limit ran to the end"),
    }
}

// ---- Hostile input: bounded validation, zero time steps, memory, damaged
// checkpoints. Each scene here was once accepted and then ran for minutes,
// aborted or resumed into other results.

/// A disk of soft material in a square grid, with `edits` applied.
fn small_scene(edits: &[(&str, &str)]) -> String {
    let mut text = r#"
[grid]
cell_size = 0.02
max = [1.0, 1.0]

[time]
end = 0.01
cfl = 0.5

[materials.soft]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e6
poissons_ratio = 0.3

[[bodies]]
shape = { type = "disk", center = [0.5, 0.5], radius = 0.2 }
material = "soft"
particles_per_cell = 4
velocity = [1.0, 0.0]
"#
    .to_string();
    for (from, to) in edits {
        assert!(text.contains(from), "no {from:?} in the scene");
        text = text.replacen(from, to, 1);
    }
    text
}

fn refusal(text: &str) -> String {
    match Scene::from_text(text, None) {
        Ok(s) => panic!(
            "accepted: {} particles, dt {:e}",
            s.total_particles(),
            s.time_step.dt
        ),
        Err(e) => e.to_string(),
    }
}

/// Validation's estimate of the first Δt is the run's.
#[test]
fn the_validated_time_step_is_the_runs_first() {
    for file in ["two_disks.toml", "wave_bar.toml", "sliding_block.toml"] {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("scenes")
            .join(file);
        let scene = Scene::from_path(&path).unwrap();
        let estimate = scene.time_step.clone();
        let dt = Simulation::new(&scene).step().unwrap();
        assert!(
            (dt - estimate.dt).abs() <= 1e-12 * dt,
            "{file}: the run's first dt {dt:e}, validation's {:e}",
            estimate.dt
        );
        assert!(estimate.steps <= scene.file.time.end / dt * (1.0 + 1e-12));
    }
}

/// A wave speed that overflows f64, a subnormal CFL factor, and a step
/// count beyond max_steps: each is refused at validation naming Δt, the
/// wave speed and the cell size, where they used to run ten million empty
/// steps.
#[test]
fn a_time_step_of_zero_is_refused_at_validation() {
    // a density near zero: the wave speed is 1e153 m/s, Δt 1e-155 s
    let e = refusal(&small_scene(&[("density = 1000.0", "density = 1.0e-300")]));
    assert!(
        e.contains("materials.soft") && e.contains("wave speed") && e.contains("cell size"),
        "{e}"
    );
    // λ + 2μ overflows: the wave speed is infinite, Δt = 0
    let e = refusal(&small_scene(&[(
        "youngs_modulus = 1.0e6",
        "youngs_modulus = 1.7e308",
    )]));
    assert!(
        e.contains("materials.soft") && e.contains("wave speed inf"),
        "{e}"
    );
    // a subnormal CFL factor
    let e = refusal(&small_scene(&[("cfl = 0.5", "cfl = 1e-320")]));
    assert!(
        e.contains("time step would be")
            && e.contains("cell size 2e-2")
            && e.contains("wave speed"),
        "{e}"
    );
    // a stiffness near f64's limit: Δt is tiny and time.end is ten million
    // steps away and more
    let e = refusal(&small_scene(&[(
        "youngs_modulus = 1.0e6",
        "youngs_modulus = 1.0e300",
    )]));
    assert!(
        e.contains("time.max_steps")
            && e.contains("Δt = ")
            && e.contains("wave speed 3.")
            && e.contains("cell size"),
        "{e}"
    );
    // an explicit max_steps below the estimate
    let e = refusal(&small_scene(&[("cfl = 0.5", "cfl = 0.5\nmax_steps = 10")]));
    assert!(e.contains("more than max_steps = 10"), "{e}");
    // and just above it, the scene is valid
    let scene = Scene::from_text(&small_scene(&[]), None).unwrap();
    let steps = scene.time_step.steps.ceil() as u64;
    let at = format!("cfl = 0.5\nmax_steps = {steps}");
    assert!(Scene::from_text(&small_scene(&[("cfl = 0.5", &at)]), None).is_ok());
}

/// The run loop's own guard, for a Δt validation could not foresee: the
/// run stops at step 0 naming dt instead of stepping in place.
#[test]
fn a_run_that_cannot_advance_stops_at_once() {
    let mut scene = Scene::from_text(&small_scene(&[]), None).unwrap();
    // what validation refuses, forced past it
    scene.file.time.cfl = Some(1e-320);
    let t0 = Instant::now();
    let e = Simulation::new(&scene)
        .run(&mut Recorder::default())
        .unwrap_err();
    let msg = e.to_string();
    assert!(matches!(e, SimError::NoProgress { step: 0, .. }), "{msg}");
    assert!(
        msg.contains("dt = 5e-324") && msg.contains("cell size 2e-2"),
        "{msg}"
    );
    let mut scene = Scene::from_text(&small_scene(&[]), None).unwrap();
    scene.materials[0].wave_speed = f64::INFINITY;
    let e = Simulation::new(&scene)
        .run(&mut Recorder::default())
        .unwrap_err();
    assert!(e.to_string().contains("dt = 0e0"), "{e}");
    assert!(t0.elapsed() < Duration::from_secs(5));
}

/// A 500-byte scene describing 3.1e9 particles, and one with many such
/// bodies, are refused from their areas before anything is seeded (they
/// took 10–16 s, and 10 s more per body).
#[test]
fn a_scene_describing_billions_of_particles_is_refused_at_once() {
    let huge = small_scene(&[
        ("cell_size = 0.02", "cell_size = 0.0002"),
        ("max = [1.0, 1.0]", "max = [1.0, 1.0]"),
        ("radius = 0.2", "radius = 0.5"),
        ("particles_per_cell = 4", "particles_per_cell = 64"),
    ]);
    assert!(huge.len() < 500);
    let t0 = Instant::now();
    let e = refusal(&huge);
    let one = t0.elapsed();
    assert!(e.contains("about 1.257e9 particles"), "{e}");
    let body = &huge[huge.find("[[bodies]]").unwrap()..];
    let many = huge.clone() + &body.repeat(9);
    let t0 = Instant::now();
    let e = refusal(&many);
    let ten = t0.elapsed();
    assert!(e.contains("about 1.257e10 particles"), "{e}");
    // seeding 1.3e9 particles took seconds; the estimate takes microseconds
    assert!(one + ten < Duration::from_secs(1), "{one:?} {ten:?}");
}

/// A polygon of 300 000 vertices over a large area: its seeding would
/// cost rows × edges, and is refused for it before seeding, naming the
/// body; its particles alone would be allowed.
#[test]
fn a_polygon_too_costly_to_seed_is_refused_before_seeding() {
    let n = 300_000;
    let vertices: Vec<String> = (0..n)
        .map(|k| {
            let a = k as f64 * std::f64::consts::TAU / n as f64;
            format!("[{:.9}, {:.9}]", 0.5 + 0.49 * a.cos(), 0.5 + 0.49 * a.sin())
        })
        .collect();
    let text = small_scene(&[
        ("cell_size = 0.02", "cell_size = 0.00025"),
        (
            r#"{ type = "disk", center = [0.5, 0.5], radius = 0.2 }"#,
            &format!(
                r#"{{ type = "polygon", vertices = [{}] }}"#,
                vertices.join(", ")
            ),
        ),
        ("particles_per_cell = 4", "particles_per_cell = 1"),
    ]);
    let t0 = Instant::now();
    let e = refusal(&text);
    assert!(
        e.starts_with("bodies[0].shape: seeding would test") && e.contains("polygon"),
        "{e}"
    );
    // parsing 300 000 vertices is most of it
    assert!(t0.elapsed() < Duration::from_secs(5), "{:?}", t0.elapsed());
}

/// A scene larger than the memory a process may use is refused naming its
/// estimate (a server's own budget here), never an abort mid-run.
#[test]
fn a_scene_larger_than_the_memory_budget_is_refused() {
    let text = small_scene(&[]);
    let scene = Scene::from_text(&text, None).unwrap();
    let need = scene.memory.total();
    assert!(need > 0 && scene.memory.particles > 0 && scene.memory.grid > 0);
    let file = cleave::scene::parse(&text, cleave::scene::Format::Toml).unwrap();
    let budget = MemoryBudget::of(need - 1, "the server's --max-memory");
    let e = Scene::validate_within(file.clone(), &budget)
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("bodies: a run needs about") && e.contains("the server's --max-memory"),
        "{e}"
    );
    assert!(Scene::validate_within(file, &MemoryBudget::of(need, "x")).is_ok());
}

/// The process's own address-space limit (`ulimit -v`): this test runs
/// itself again under a 2 GB limit, where a scene of 20 M particles used
/// to abort with "memory allocation failed" (exit 134); there it is
/// refused at validation.
#[cfg(target_os = "linux")]
#[test]
fn a_scene_beyond_the_address_space_limit_is_refused() {
    let text = small_scene(&[
        ("cell_size = 0.02", "cell_size = 0.00025"),
        ("radius = 0.2", "radius = 0.45"),
    ]);
    if common::in_child() {
        let e = refusal(&text);
        assert!(e.contains("address-space limit"), "{e}");
        return;
    }
    let name = common::test_name(
        module_path!(),
        "a_scene_beyond_the_address_space_limit_is_refused",
    );
    common::run_in_child(&name, "ulimit -v 2000000 && ", &[]);
}

/// A checkpoint of two_disks, as bytes, and its scene.
fn checkpoint_bytes() -> (Scene, Vec<u8>) {
    struct Keep(Vec<u8>);
    impl cleave::diagnostics::Observer for Keep {
        fn series_columns(&mut self, _: &[String]) -> Result<(), String> {
            Ok(())
        }
        fn series_row(&mut self, _: &cleave::diagnostics::SeriesRow) -> Result<(), String> {
            Ok(())
        }
        fn snapshot(&mut self, _: &cleave::diagnostics::Snapshot) -> Result<(), String> {
            Ok(())
        }
        fn progress(&mut self, p: &cleave::diagnostics::Progress) -> cleave::diagnostics::Control {
            match p.step {
                3 => cleave::diagnostics::Control::Checkpoint,
                4 => cleave::diagnostics::Control::Stop,
                _ => cleave::diagnostics::Control::Continue,
            }
        }
        fn checkpoint(&mut self, cp: cleave::checkpoint::Checkpoint<'_>) -> Result<(), String> {
            cp.write_to(&mut self.0).map_err(|e| e.to_string())
        }
    }
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/two_disks.toml");
    let scene = Scene::from_path(&path).unwrap();
    let mut keep = Keep(Vec::new());
    Simulation::new(&scene).run(&mut keep).unwrap();
    (scene, keep.0)
}

/// Single bit flips anywhere in a checkpoint, appended bytes and a cut
/// tail: every damaged file is refused (13 of 34 such files used to
/// resume into other results).
#[test]
fn every_damaged_checkpoint_is_refused() {
    use cleave::checkpoint::{Checkpoint, CheckpointError};
    let (scene, good) = checkpoint_bytes();
    let cp = Checkpoint::read_from(&mut &good[..]).unwrap();
    assert_eq!(cp.step(), 3);
    assert!(Simulation::resume(&scene, cp).is_ok());
    let n = good.len();
    // every byte of the header and the trailer, and 400 offsets between
    let mut offsets: Vec<usize> = (0..12).chain(n - 12..n).collect();
    offsets.extend((0..400).map(|k| 12 + k * (n - 24) / 400));
    let mut refused = 0;
    for (k, &at) in offsets.iter().enumerate() {
        let mut bad = good.clone();
        bad[at] ^= 1 << (k % 8);
        match Checkpoint::read_from(&mut &bad[..]) {
            Ok(_) => panic!("a bit flipped at byte {at} of {n} was accepted"),
            Err(
                CheckpointError::Damaged { .. }
                | CheckpointError::NotACheckpoint
                | CheckpointError::OlderFormat(_),
            ) => refused += 1,
            Err(e) => panic!("byte {at}: refused, but not as damaged: {e}"),
        }
    }
    let mut tails = Vec::new();
    for extra in [&b"\n"[..], &[0u8; 1], &[0u8; 4096]] {
        let mut bad = good.clone();
        bad.extend_from_slice(extra);
        tails.push(bad);
    }
    for cut in [1, 12, n / 2, n - 12] {
        tails.push(good[..n - cut].to_vec());
    }
    for bad in &tails {
        let e = Checkpoint::read_from(&mut &bad[..]).err();
        assert!(
            matches!(e, Some(CheckpointError::Damaged { .. })),
            "{} bytes: {e:?}",
            bad.len()
        );
        refused += 1;
    }
    assert_eq!(refused, offsets.len() + 7);
}

/// A damaged checkpoint in an output directory is refused naming the file
/// and saying it is damaged; the series written so far is left as it was.
#[test]
fn a_damaged_checkpoint_names_its_file_and_keeps_the_results() {
    use cleave::output::OutputWriter;
    let (_, good) = checkpoint_bytes();
    let dir = tempfile::tempdir().unwrap();
    let path = OutputWriter::checkpoint_path(dir.path());
    let series = dir.path().join("series.csv");
    std::fs::write(&series, "time,kinetic_energy\n0,1\n").unwrap();
    let mut bad = good.clone();
    let at = bad.len() / 3;
    bad[at] ^= 0x10;
    std::fs::write(&path, &bad).unwrap();
    let e = cleave::checkpoint::Checkpoint::load(&path)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains(&path.display().to_string()) && e.contains("is damaged") && e.contains("CRC-32"),
        "{e}"
    );
    let e = OutputWriter::load_checkpoint(dir.path())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("checkpoint.bin") && e.contains("damaged"), "{e}");
    assert_eq!(
        std::fs::read_to_string(&series).unwrap(),
        "time,kinetic_energy\n0,1\n"
    );
}

/// A crack of 100 000 points through a body of 50 000 particles: the run's
/// setup would measure 5e9 particle–segment distances; refused at
/// validation, naming the body.
#[test]
fn a_crack_too_costly_to_place_is_refused() {
    let points: Vec<String> = (0..100_000)
        .map(|k| format!("[{:.6}, 0.5]", 0.35 + 0.3 * k as f64 / 100_000.0))
        .collect();
    let text = small_scene(&[
        ("cell_size = 0.02", "cell_size = 0.002"),
        (
            "poissons_ratio = 0.3",
            "poissons_ratio = 0.3\ndamage = { model = \"time_to_failure\", strength = 1.0e6, crack_speed = 1000.0 }",
        ),
        (
            "velocity = [1.0, 0.0]",
            &format!(
                "velocity = [1.0, 0.0]\ncracks = [{{ points = [{}] }}]",
                points.join(", ")
            ),
        ),
    ]);
    let e = refusal(&text);
    assert!(
        e.starts_with("bodies[0].shape: seeding would test") && e.contains("crack points"),
        "{e}"
    );
    // with ten points it is valid
    let short = text.replace(&points[10..].join(", "), "[0.65, 0.5]");
    assert!(Scene::from_text(&short, None).is_ok());
}
