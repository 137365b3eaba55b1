//! Verification of the explicit MPM core against theory (issue 2).
//! Each test compares with an analytic value, not with a stored output.

use crate::common;

use cleave::diagnostics::Recorder;
use cleave::mpm::Simulation;
use cleave::scene::{Scene, Stage};
use std::path::Path;

fn scene(name: &str) -> Scene {
    let path = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("scenes")
        .join(name);
    match Scene::from_path(&path) {
        Ok(s) => s,
        Err(e) => panic!("{}: {e}", path.display()),
    }
}

/// Mean x-velocity of the particles with x in [a, b].
fn mean_vx(sim: &Simulation, a: f64, b: f64) -> f64 {
    let p = sim.particles();
    let (mut s, mut n) = (0.0, 0usize);
    for k in 0..p.len() {
        if p.x[k][0] >= a && p.x[k][0] <= b {
            s += p.v[k][0];
            n += 1;
        }
    }
    s / n.max(1) as f64
}

/// Time at which `f` first crosses `level` upward, linearly interpolated
/// between steps.
fn crossing(samples: &[(f64, f64)], level: f64) -> Option<f64> {
    samples
        .windows(2)
        .find(|w| w[0].1 < level && w[1].1 >= level)
        .map(|w| {
            let (t0, v0, t1, v1) = (w[0].0, w[0].1, w[1].0, w[1].1);
            t0 + (level - v0) / (v1 - v0) * (t1 - t0)
        })
}

#[test]
fn compressive_wave_travels_at_bar_speed() {
    let scene = scene("wave_bar.toml");
    let c = (2.0e11f64 / 8000.0).sqrt();
    let h = scene.file.grid.cell_size;
    let mut sim = Simulation::new(&scene);
    let stations = [0.25, 0.75];
    let mut at_station: Vec<Vec<(f64, f64)>> = vec![Vec::new(); 2];
    let mut at_end = Vec::new();
    while sim.time() < scene.file.time.end * (1.0 - 1e-12) {
        sim.step().expect("the wave bar runs");
        for (k, &x) in stations.iter().enumerate() {
            at_station[k].push((sim.time(), mean_vx(&sim, x - 0.5 * h, x + 0.5 * h)));
        }
        at_end.push((sim.time(), mean_vx(&sim, 1.0 - 0.5 * h, 1.0)));
    }
    // Interior: the half-amplitude point of the front (piston speed 1 m/s).
    let t1 = crossing(&at_station[0], 0.5).expect("front reaches x = 0.25");
    let t2 = crossing(&at_station[1], 0.5).expect("front reaches x = 0.75");
    let speed = 0.5 / (t2 - t1);
    println!(
        "wave: front speed {speed:.1} m/s vs sqrt(E/rho) = {c:.1} m/s ({:+.2} %)",
        100.0 * (speed / c - 1.0)
    );
    assert!(
        (speed / c - 1.0).abs() < 0.02,
        "front speed {speed} m/s vs sqrt(E/rho) = {c} m/s"
    );
    // Far (free) end: the velocity doubles on reflection, 0 -> 2 m/s; the
    // wave arrives when it passes half of that jump.
    let t_end = crossing(&at_end, 1.0).expect("front reaches the far end");
    let arrival = 1.0 / c;
    println!(
        "wave: arrival at the far end {:.2} us vs L/c = {:.2} us ({:+.2} %)",
        1e6 * t_end,
        1e6 * arrival,
        100.0 * (t_end / arrival - 1.0)
    );
    assert!(
        (t_end / arrival - 1.0).abs() < 0.02,
        "arrival {t_end} s vs L/c = {arrival} s"
    );
}

/// `grid.resort_every`: the `resort` stage is in the plan, the particle
/// arrays end in another order than without it, and each particle (by
/// id) ends where it ends without it, to round-off (the scatter may add a
/// tile's particles in another order): on the spinning disk, on a plate
/// pulled by a side traction (whose particle list must follow the
/// permutation) and on the sliding block (two contact groups, whose copy
/// must follow). A re-sort that lost a particle's traction or group would
/// move the particles by far more than round-off.
#[test]
fn a_resort_changes_the_order_of_the_arrays_not_where_the_particles_go() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let file = |name: &str| std::fs::read_to_string(dir.join(name)).unwrap();
    let plate = PULLED_PLATE.replace(
        "particles_per_cell = 4\n",
        "particles_per_cell = 4\nvelocity = [0.0, 400.0]\n",
    );
    let cases = [
        ("spinning_disk", file("spinning_disk.toml"), 7),
        ("plate", plate, 3),
        (
            "sliding_block",
            file("sliding_block.toml").replace("end = 0.12", "end = 0.06"),
            5,
        ),
    ];
    for (name, text, every) in cases {
        let with = text.replacen("[grid]\n", &format!("[grid]\nresort_every = {every}\n"), 1);
        assert_ne!(with, text, "{name}");
        let (plain, sorted) = (
            Scene::from_text(&text, None).unwrap(),
            Scene::from_text(&with, None).unwrap(),
        );
        assert!(!plain.plan.has(Stage::Resort));
        assert!(sorted.plan.has(Stage::Resort), "{name}: {:?}", sorted.plan);
        let run = |scene: &Scene| {
            let mut sim = Simulation::new(scene);
            let mut rec = Recorder::default();
            sim.run(&mut rec).unwrap();
            (sim.particles().clone(), rec)
        };
        let ((a, ra), (b, rb)) = (run(&plain), run(&sorted));
        assert_ne!(a.id, b.id, "{name}: the re-sort permuted nothing");
        assert_eq!(ra.rows.len(), rb.rows.len());
        // by id
        let mut at = vec![0usize; b.len()];
        for (k, &id) in b.id.iter().enumerate() {
            at[id as usize] = k;
        }
        let size =
            a.x.iter()
                .flat_map(|x| x.iter())
                .fold(0.0f64, |m, v| m.max(v.abs()));
        let speed =
            a.v.iter()
                .flat_map(|v| v.iter())
                .fold(0.0f64, |m, v| m.max(v.abs()));
        let (mut dx, mut dv) = (0.0f64, 0.0f64);
        for (p, &id) in a.id.iter().enumerate() {
            let q = at[id as usize];
            assert_eq!(a.body[p], b.body[q]);
            for d in 0..2 {
                dx = dx.max((a.x[p][d] - b.x[q][d]).abs());
                dv = dv.max((a.v[p][d] - b.v[q][d]).abs());
            }
        }
        println!("{name}: |dx| <= {dx:.2e} of {size:.2e} m, |dv| <= {dv:.2e} of {speed:.2e} m/s");
        assert!(dx <= 1e-9 * size, "{name}: positions differ by {dx}");
        assert!(dv <= 1e-6 * speed, "{name}: velocities differ by {dv}");
        let (ea, eb) = (
            ra.rows.last().unwrap().kinetic_energy,
            rb.rows.last().unwrap().kinetic_energy,
        );
        assert!(
            (ea - eb).abs() <= 1e-9 * ea.abs(),
            "{name}: {ea} against {eb}"
        );
    }
    // scenes with fracture models are refused, naming the field
    let e = Scene::from_text(
        &file("p1_plate_coarse.toml").replacen("[grid]\n", "[grid]\nresort_every = 10\n", 1),
        None,
    )
    .expect_err("a phase field with a re-sort")
    .to_string();
    assert!(
        e.contains("grid.resort_every") && e.contains("phase field"),
        "{e}"
    );
}

#[test]
fn free_spinning_disk_conserves_mass_momentum_and_angular_momentum() {
    let scene = scene("spinning_disk.toml");
    let mut sim = Simulation::new(&scene);
    let mut rec = Recorder::default();
    let summary = sim.run(&mut rec).expect("the disk flies");
    assert!(summary.steps > 50);
    let (first, last) = (&rec.rows[0], rec.rows.last().unwrap());
    for r in &rec.rows {
        assert_eq!(
            r.total_mass.to_bits(),
            first.total_mass.to_bits(),
            "mass changes at t = {}",
            r.time
        );
        let scale = first.total_mass * 1.0;
        assert!(
            (r.momentum_x - first.momentum_x).abs() < 1e-12 * scale,
            "px drifts: {} vs {}",
            r.momentum_x,
            first.momentum_x
        );
        assert!(
            (r.momentum_y - first.momentum_y).abs() < 1e-12 * scale,
            "py drifts: {} vs {}",
            r.momentum_y,
            first.momentum_y
        );
        let dl = (r.angular_momentum - first.angular_momentum).abs() / first.angular_momentum.abs();
        assert!(
            dl < 0.01,
            "angular momentum drifts by {:.3} % at t = {}",
            100.0 * dl,
            r.time
        );
    }
    // It really flew and spun: the centre moved by v t.
    assert!(last.time > 0.199);
    let worst = |f: fn(&cleave::diagnostics::SeriesRow) -> f64| {
        rec.rows
            .iter()
            .map(|r| ((f(r) - f(first)) / f(first)).abs())
            .fold(0.0, f64::max)
    };
    println!(
        "spinning disk ({} steps): max relative drift: mass {:.1e}, px {:.1e}, py {:.1e}, angular momentum {:.2e}",
        summary.steps,
        worst(|r| r.total_mass),
        worst(|r| r.momentum_x),
        worst(|r| r.momentum_y),
        worst(|r| r.angular_momentum)
    );
}

#[test]
fn sulsky_disks_conserve_momentum_and_energy() {
    let scene = scene("two_disks.toml");
    let mut sim = Simulation::new(&scene);
    let mut rec = Recorder::default();
    sim.run(&mut rec).expect("the disks collide");
    let first = &rec.rows[0];
    let e0 = first.kinetic_energy + first.strain_energy;
    let mut min_ke = f64::INFINITY;
    let (mut worst_e, mut worst_p) = (0.0f64, 0.0f64);
    for r in &rec.rows {
        worst_e = worst_e.max(((r.kinetic_energy + r.strain_energy - e0) / e0).abs());
        worst_p = worst_p.max(r.momentum_x.abs().max(r.momentum_y.abs()));
        assert!(
            r.momentum_x.abs() < 1e-13 && r.momentum_y.abs() < 1e-13,
            "momentum {} {}",
            r.momentum_x,
            r.momentum_y
        );
        let e = r.kinetic_energy + r.strain_energy;
        assert!(
            (e - e0).abs() / e0 < 0.05,
            "energy drifts by {:.2} % at t = {}",
            100.0 * (e - e0) / e0,
            r.time
        );
        min_ke = min_ke.min(r.kinetic_energy);
    }
    // They did collide: kinetic energy went into strain energy and came back.
    assert!(
        min_ke < 0.6 * first.kinetic_energy,
        "no collision: min kinetic {min_ke} of {}",
        first.kinetic_energy
    );
    let last = rec.rows.last().unwrap();
    assert!(
        last.kinetic_energy > 0.7 * first.kinetic_energy,
        "no rebound"
    );
    println!(
        "Sulsky disks: max |total energy drift| {:.2} %, final {:+.2} %, max |momentum| {worst_p:.1e} kg m/s, min KE/KE0 {:.3}",
        100.0 * worst_e,
        100.0 * (last.kinetic_energy + last.strain_energy - e0) / e0,
        min_ke / first.kinetic_energy
    );
}

#[test]
fn block_slides_with_coulomb_friction() {
    let scene = scene("sliding_block.toml");
    assert!(scene.plan.has(Stage::Contact));
    let theta = 30f64.to_radians();
    let (g, mu) = (9.81, 0.3);
    let expected = g * (theta.sin() - mu * theta.cos());
    // the slope of the block's velocity after the first 20 ms of settling
    let a = common::body_acceleration_x::<2, 3>(&scene, 1, 0.02);
    println!(
        "sliding block: a = {a:.4} m/s^2 vs g(sin t - mu cos t) = {expected:.4} m/s^2 ({:+.2} %)",
        100.0 * (a / expected - 1.0)
    );
    assert!(
        (a / expected - 1.0).abs() < 0.03,
        "acceleration {a} m/s² vs g(sin θ − μ cos θ) = {expected} m/s²"
    );
}

#[test]
fn one_body_without_contact_runs_only_the_core_stages() {
    let scene = scene("wave_bar.toml");
    assert_eq!(
        scene.plan.stages,
        vec![Stage::P2g, Stage::GridUpdate, Stage::G2p, Stage::Rebin]
    );
    let two = scene_two_groups();
    assert!(two.plan.has(Stage::Contact) && two.plan.has(Stage::FieldPartition));
    let mut sim = Simulation::new(&scene);
    let summary = sim.run(&mut Recorder::default()).unwrap();
    assert_eq!(summary.stages, vec!["p2g", "grid_update", "g2p", "rebin"]);
    assert_eq!(summary.contact_steps, 0);
    assert_eq!(summary.stage_seconds.get(Stage::Contact), 0.0);
    assert_eq!(summary.stage_seconds.get(Stage::FieldPartition), 0.0);
}

fn scene_two_groups() -> Scene {
    scene("sliding_block.toml")
}

/// A free steel plate pulled by 1 MPa (ramped over 20 µs) on its right
/// face.
const PULLED_PLATE: &str = r#"
[grid]
cell_size = 0.01
max = [0.5, 0.2]
[grid.boundary]
right = { type = "traction", normal = { table = [[0.0, 0.0], [2e-5, 1.0e6]] } }
[analysis]
plane = "plane_stress"
thickness = 0.01
[time]
end = 8e-5
cfl = 0.5
[[bodies]]
shape = { type = "box", min = [0.1, 0.05], max = [0.5, 0.15] }
material = { model = "linear_elastic", density = 7800.0, youngs_modulus = 2.0e11, poissons_ratio = 0.3 }
particles_per_cell = 4
[output]
series_rows = 41
"#;

#[test]
fn traction_side_delivers_its_impulse_and_work() {
    // A free plate pulled by 1 MPa on its right face: Σ m v_x = σ A t
    // exactly (nothing else acts), and the work done balances the energy.
    let scene = Scene::from_text(PULLED_PLATE, None).unwrap();
    assert!(scene.plan.has(Stage::Traction));
    let mut rec = Recorder::default();
    Simulation::new(&scene).run(&mut rec).unwrap();
    let area = 0.1 * 0.01; // face height × thickness
    for r in rec.rows.iter().skip(1) {
        // impulse of the ramp (0 → 1 MPa over 20 µs) then the constant
        let t = r.time;
        let impulse = if t <= 2e-5 {
            0.5 * 1e6 * t * t / 2e-5
        } else {
            1e6 * (t - 1e-5)
        } * area;
        assert!(
            (r.momentum_x - impulse).abs() < 0.02 * impulse,
            "t = {t}: p = {} vs σAt = {impulse}",
            r.momentum_x
        );
        assert!(r.momentum_y.abs() < 1e-9 * impulse);
    }
    let last = rec.rows.last().unwrap();
    let e = last.kinetic_energy + last.strain_energy;
    println!(
        "traction: momentum {:.6e} vs sigma A t {:.6e}; energy {e:.6e} J vs work {:.6e} J",
        last.momentum_x,
        1e6 * (last.time - 1e-5) * area,
        last.external_work
    );
    assert!(
        (e - last.external_work).abs() < 0.02 * last.external_work,
        "energy {e} vs work {}",
        last.external_work
    );
}

#[test]
fn a_traction_edges_work_is_the_energy_it_stores_under_usl_musl_and_newmark() {
    // A plate on a roller, pushed by 10 MPa on its right edge (ramped over
    // 0.5 ms, then held): the energy in it must be the traction's work
    // under either stress update. Counted as F·v_p Δt with the particles'
    // own FLIP velocities, MUSL's work came out 67 J/m against 105 J/m
    // stored; counted along the particles' displacement (the grid
    // velocities they move with) it is within 0.03 %.
    for update in ["usl", "musl", "newmark"] {
        let text = format!(
            r#"
[grid]
cell_size = 0.002
max = [0.056, 0.1]
[grid.boundary]
left = "roller"
right = {{ type = "traction", normal = {{ table = [[0.0, 0.0], [5e-4, -1.0e7], [1e-3, -1.0e7]] }} }}
[analysis]
plane = "plane_stress"
[time]
end = 1e-3
cfl = 0.3
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0], max = [0.05, 0.1] }}
material = {{ model = "linear_elastic", density = 1005.0, youngs_modulus = 2.5e9, poissons_ratio = 0.33 }}
[transfer]
stress_update = "{update}"
[output]
series_rows = 11
"#
        );
        let scene = Scene::from_text(&text, None).unwrap();
        let mut rec = Recorder::default();
        Simulation::new(&scene).run(&mut rec).unwrap();
        for r in rec.rows.iter().skip(3) {
            let e = r.kinetic_energy + r.strain_energy;
            println!(
                "{update} t = {:.1e}: energy {e:.4} J/m, work {:.4} J/m",
                r.time, r.external_work
            );
            assert!(
                (e - r.external_work).abs() < 0.01 * r.external_work,
                "{update} at t = {}: energy {e} vs work {}",
                r.time,
                r.external_work
            );
        }
    }
}

#[test]
fn xpic1_fmpm1_and_newmark_move_a_falling_block_second_order_where_flip_is_first() {
    // A free block under gravity and an initial velocity: the grid
    // acceleration is g everywhere, so a second-order position update
    // lands every particle on x0 + v0 t + g t²/2 to round-off; FLIP's
    // x += Δt S v̄ runs ahead by g Δt t / 2 (here ~1e-6 m). Velocities are
    // v0 + g t for all four. Newmark's predictor v + Δt a/2 is the
    // particles' rate (their first acceleration is g).
    let g = [3.0, -9.81];
    let v0 = [1.5, 2.0];
    for (scheme, update, second_order) in [
        ("flip", "usl", false),
        ("xpic1", "usl", true),
        ("fmpm1", "usl", true),
        ("flip", "newmark", true),
    ] {
        let text = format!(
            r#"
body_force = [{}, {}]
[grid]
cell_size = 0.01
min = [-0.2, -0.2]
max = [0.4, 0.4]
[time]
end = 0.02
dt = 1e-4
[transfer]
scheme = "{scheme}"
stress_update = "{update}"
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.0], max = [0.1, 0.05] }}
material = {{ model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity = [{}, {}]
[output]
series_rows = 2
"#,
            g[0], g[1], v0[0], v0[1]
        );
        let scene = Scene::from_text(&text, None).unwrap();
        let mut sim = Simulation::new(&scene);
        let x0 = sim.particles().x.clone();
        let mut rec = Recorder::default();
        sim.run(&mut rec).unwrap();
        let t = rec.rows.last().unwrap().time;
        let p = sim.particles();
        let mut worst: f64 = 0.0;
        for k in 0..p.len() {
            for a in 0..2 {
                let want = x0[k][a] + v0[a] * t + 0.5 * g[a] * t * t;
                worst = worst.max((p.x[k][a] - want).abs());
                assert!(
                    (p.v[k][a] - (v0[a] + g[a] * t)).abs() < 1e-10,
                    "{scheme} {update}: v {:?}",
                    p.v[k]
                );
            }
        }
        println!("{scheme} {update}: worst position error {worst:.3e} m at t = {t}");
        if second_order {
            assert!(worst < 1e-12, "{scheme} {update}: position off by {worst}");
        } else {
            let lag = 0.5 * 9.81 * 1e-4 * t;
            assert!(
                worst > 0.5 * lag,
                "FLIP's first-order position was expected to lag by {lag}: {worst}"
            );
        }
    }
}

#[test]
fn a_block_crossing_many_tiles_keeps_its_velocity_exactly() {
    // A free block translating across a large grid: tiles become active and
    // inactive as it passes, and only active nodes are cleared and updated.
    // A uniform velocity must survive the transfers exactly.
    let text = r#"
[grid]
cell_size = 0.01
max = [2.0, 0.5]
[time]
end = 0.1
cfl = 0.5
[[bodies]]
shape = { type = "box", min = [0.1, 0.2], max = [0.3, 0.3] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity = [15.0, 0.0]
[output]
series_rows = 11
snapshots = 2
"#;
    let scene = Scene::from_text(text, None).unwrap();
    let mut sim = Simulation::new(&scene);
    let mut rec = Recorder::default();
    sim.run(&mut rec).unwrap();
    let p = sim.particles();
    for k in 0..p.len() {
        assert!(
            (p.v[k][0] - 15.0).abs() < 1e-12 && p.v[k][1].abs() < 1e-12,
            "particle {k}: v = {:?}",
            p.v[k]
        );
    }
    // 1.5 m travelled: the block crossed 150 cells (about 19 tiles).
    let xmin = p.x.iter().map(|x| x[0]).fold(f64::INFINITY, f64::min);
    assert!(
        (xmin - (0.1 + 0.0025 + 1.5)).abs() < 1e-9,
        "leftmost particle at {xmin}"
    );
    // The last grid snapshot has mass only near the block's final place.
    let grid = rec.snapshots.last().unwrap().grid.as_ref().unwrap();
    let cleave::diagnostics::FieldData::F64(mass) = &grid.fields[0].data else {
        panic!()
    };
    for (n, &m) in mass.iter().enumerate() {
        let x = grid.origin[0] + (n % grid.dims[0]) as f64 * grid.spacing;
        if m != 0.0 {
            assert!(x > 1.55 && x < 1.85, "stale mass {m} at x = {x}");
        }
    }
    let total: f64 = mass.iter().sum();
    assert!((total - rec.rows[0].total_mass).abs() < 1e-12 * total);
}

/// Every scene shipped in `scenes/` parses and validates (the README and
/// the docs run them by name; a setting renamed in the schema must not
/// leave one behind).
#[test]
fn every_shipped_scene_is_valid() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut n = 0;
    for entry in std::fs::read_dir(&dir).unwrap() {
        let path = entry.unwrap().path();
        if path.extension().is_some_and(|e| e == "toml") {
            if let Err(e) = cleave::scene::Scene::from_path(&path) {
                panic!("{}: {e}", path.display());
            }
            n += 1;
        }
    }
    assert!(n >= 17, "only {n} scenes found in {}", dir.display());
}

#[test]
fn wall_reactions_and_body_momenta_balance_the_momentum() {
    // Two blocks in one velocity field fall under gravity onto a fixed
    // floor: each step the walls' forces times Δt plus the weight's
    // impulse is the change of the total momentum (pure FLIP conserves it
    // to round-off on the grid; under Newmark the step's impulse is
    // Δt((1 − γ)R_k + γR_{k+1}), the force it reports being R_{k+1}), and
    // the bodies' momenta sum to the total.
    for update in ["usl", "musl", "newmark"] {
        let text = format!(
            r#"
body_force = [0.0, -9.81]
[grid]
cell_size = 0.01
min = [0.0, 0.0]
max = [0.3, 0.2]
[grid.boundary]
bottom = "fixed"
left = "roller"
[time]
end = 0.02
cfl = 0.4
[transfer]
flip_blend = 1.0
stress_update = "{update}"
[[bodies]]
name = "lower"
shape = {{ type = "box", min = [0.0, 0.0], max = [0.1, 0.05] }}
material = {{ model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity = [0.5, -1.0]
[[bodies]]
shape = {{ type = "box", min = [0.0, 0.05], max = [0.1, 0.1] }}
material = {{ model = "linear_elastic", density = 2000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }}
velocity = [0.5, -1.0]
[output]
reactions = true
body_momenta = true
"#
        );
        let scene = Scene::from_text(&text, None).unwrap();
        let mut sim = Simulation::new(&scene);
        let cols = sim.series_columns();
        for name in [
            "reaction_left_x",
            "reaction_left_y",
            "reaction_bottom_x",
            "reaction_bottom_y",
            "momentum_y_lower",
            "momentum_x_b1",
        ] {
            assert!(
                cols.iter().any(|c| c == name),
                "{update}: no {name} in {cols:?}"
            );
        }
        let r0 = sim.row();
        let mass = r0.total_mass;
        let mut p = [r0.momentum_x, r0.momentum_y];
        let (mut worst, mut scale): (f64, f64) = (0.0, 0.0);
        let mut pushed = 0.0;
        let mut before = [0.0; 2];
        let gamma = if update == "newmark" { 0.5 } else { 1.0 };
        while sim.time() < scene.file.time.end {
            let t0 = sim.time();
            sim.step().unwrap();
            let dt = sim.time() - t0;
            let r = sim.row();
            let get = |n: &str| r.get(&cols, n).unwrap();
            let walls = [
                get("reaction_left_x") + get("reaction_bottom_x"),
                get("reaction_left_y") + get("reaction_bottom_y"),
            ];
            let now = [r.momentum_x, r.momentum_y];
            let weight = [0.0, -9.81 * mass];
            for a in 0..2 {
                let impulse = (1.0 - gamma) * before[a] + gamma * walls[a];
                let want = p[a] + (impulse + weight[a]) * dt;
                worst = worst.max((now[a] - want).abs());
                scale = scale.max(now[a].abs());
            }
            pushed = f64::max(pushed, get("reaction_bottom_y"));
            let bodies = get("momentum_y_lower") + get("momentum_y_b1");
            assert!(
                (bodies - r.momentum_y).abs() <= 1e-12 * r.momentum_y.abs().max(1e-9),
                "{update}: bodies {bodies} vs total {}",
                r.momentum_y
            );
            p = now;
            before = walls;
        }
        println!("{update}: worst momentum balance error {worst:.2e} kg m/s of {scale:.2e}, floor's largest push {pushed:.3} N");
        assert!(
            pushed > 9.81 * mass,
            "{update}: the floor never stopped the blocks"
        );
        assert!(worst < 1e-9 * scale, "{update}: momentum off by {worst}");
    }
}

/// The uniaxial-tension plate of [`driven_grips_pull_along_y_and_let_the_edges_slide`]:
/// a 0.1 × 0.16 m plate between two 2-cell grips ten times as dense (so
/// that the nodes they share with the plate are theirs) and a thousandth
/// as stiff (so that their material does not hold the plate's edges in x:
/// the drive moves them along y), the base driven at v_y = 0 and the grip
/// at v_y ramped to 10 mm/s over 5 ms; `x` is the grips' `x` component
/// (`None`: left free).
fn gripped_plate(x: Option<f64>) -> String {
    let x = x.map_or(String::new(), |v| format!("x = {v:?}, "));
    format!(
        r#"
[grid]
cell_size = 0.005
min = [-0.01, -0.01]
max = [0.11, 0.21]
[analysis]
plane = "plane_stress"
thickness = 0.01
[time]
end = 0.02
cfl = 0.4
[materials.plate]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e7
poissons_ratio = 0.3
[materials.grip]
model = "linear_elastic"
density = 10000.0
youngs_modulus = 1.0e4
poissons_ratio = 0.3
[[bodies]]
name = "plate"
shape = {{ type = "box", min = [0.0, 0.02], max = [0.1, 0.18] }}
material = "plate"
[[bodies]]
name = "base"
shape = {{ type = "box", min = [0.0, 0.0], max = [0.1, 0.02] }}
material = "grip"
drive = {{ {x}y = 0.0 }}
[[bodies]]
name = "grip"
shape = {{ type = "box", min = [0.0, 0.18], max = [0.1, 0.2] }}
material = "grip"
drive = {{ {x}y = {{ table = [[0.0, 0.0], [0.005, 0.01], [1.0, 0.01]] }} }}
[output]
reactions = true
"#
    )
}

#[test]
fn driven_grips_pull_along_y_and_let_the_edges_slide() {
    // Grips that drive only y are rollers that move: the plate between
    // them is in uniaxial tension (σ_xx ≈ 0, its width shrinks by ν ε at
    // the grips too) and the grip's reaction is the plate's force σ_yy W t.
    // Grips that also drive x = 0 clamp the edges' width.
    // (Measured: rollers −3.282e-4 against −ν ε = −3.283e-4, σ_xx/σ_yy
    // 3e-4, grip force 1 % below σ_yy W t; clamped 0.13 × −ν ε.)
    let (w, t, e, nu) = (0.1, 0.01, 1.0e7, 0.3);
    let mut widths = Vec::new();
    for x in [None, Some(0.0)] {
        let scene = Scene::from_text(&gripped_plate(x), None).unwrap();
        let mut sim = Simulation::new(&scene);
        let cols = sim.series_columns();
        for name in ["reaction_base_y", "reaction_grip_x", "reaction_grip_y"] {
            assert!(cols.iter().any(|c| c == name), "no {name} in {cols:?}");
        }
        // the plate's two top rows of particles (the cell under the grip)
        let p = sim.particles();
        let top: Vec<usize> = (0..p.len())
            .filter(|&k| p.body[k] == 0 && p.x[k][1] > 0.175)
            .collect();
        // their left and right halves' mean x apart, and the grip's mean y
        let grip = |sim: &Simulation| {
            let p = sim.particles();
            let (mut l, mut r, mut nl, mut nr) = (0.0, 0.0, 0.0, 0.0);
            for &k in &top {
                if p.x[k][0] < 0.05 {
                    (l, nl) = (l + p.x[k][0], nl + 1.0);
                } else {
                    (r, nr) = (r + p.x[k][0], nr + 1.0);
                }
            }
            let g: Vec<f64> = (0..p.len())
                .filter(|&k| p.body[k] == 2)
                .map(|k| p.x[k][1])
                .collect();
            (r / nr - l / nl, g.iter().sum::<f64>() / g.len() as f64)
        };
        let (d0, y0) = grip(&sim);
        let (mut force, mut stress, mut across, mut n) = (0.0, 0.0, 0.0, 0.0);
        while sim.time() < scene.file.time.end * (1.0 - 1e-12) {
            sim.step().unwrap();
            let r = sim.row();
            if sim.time() > 0.005 {
                let p = sim.particles();
                let plate = (0..p.len()).filter(|&k| p.body[k] == 0);
                let (sxx, syy, m) = plate.fold((0.0, 0.0, 0.0), |(a, b, c), k| {
                    (a + p.stress[k][0], b + p.stress[k][1], c + 1.0)
                });
                force += r.get(&cols, "reaction_grip_y").unwrap();
                stress += syy / m;
                across += sxx / m;
                n += 1.0;
            }
        }
        let (d1, y1) = grip(&sim);
        let strain = (y1 - y0) / 0.16;
        let (force, stress, across) = (force / n, stress / n, across / n);
        println!(
            "x {x:?}: strain {strain:.3e}, width strain under the grip {:.3e} (−ν ε = {:.3e}), \
             mean grip force {force:.4} N, mean σ_yy W t {:.4} N, mean σ_xx/σ_yy {:.4}",
            (d1 - d0) / d0,
            -nu * strain,
            stress * w * t,
            across / stress
        );
        if x.is_none() {
            assert!(
                across.abs() < 0.03 * stress,
                "rollers: mean σ_xx {across} against σ_yy {stress}"
            );
        }
        // the grip moved as driven: 10 mm/s over 17.5 ms of its 20
        assert!((y1 - y0 - 1.75e-4).abs() < 1e-6, "grip moved {}", y1 - y0);
        assert!(
            (force / (stress * w * t) - 1.0).abs() < 0.05,
            "grip force {force} against the plate's {}",
            stress * w * t
        );
        assert!(
            stress > 0.5 * e * strain,
            "the plate is not pulled: {stress}"
        );
        widths.push((d1 - d0) / d0 / (-nu * strain));
    }
    assert!(
        (widths[0] - 1.0).abs() < 0.15,
        "the plate's width strain under the rolling grip is {} × −ν ε",
        widths[0]
    );
    // (the rows a cell from the driven nodes still shrink a little)
    assert!(
        widths[1].abs() < 0.25,
        "the plate's width strain under the clamping grip is {} × −ν ε",
        widths[1]
    );
}

#[test]
fn a_bad_drive_is_refused_naming_it() {
    let plate = gripped_plate(None);
    let empty = plate.replace("drive = { y = 0.0 }", "drive = {}");
    common::refused(&empty, &["bodies[1].drive", "a drive needs `x` and/or `y`"]);
    let z = plate.replace("drive = { y = 0.0 }", "drive = { y = 0.0, z = 1.0 }");
    common::refused(&z, &["bodies[1].drive.z", "needs a 3D grid"]);
    let table = plate.replace("drive = { y = 0.0 }", "drive = { y = { table = [] } }");
    common::refused(&table, &["bodies[1].drive.y"]);
    let named = plate.replace("name = \"base\"", "name = \"top\"");
    common::refused(&named, &["bodies[1].drive", "`top` names a grid side"]);
    let unknown = plate.replace("drive = { y = 0.0 }", "drive = { y = 0.0, w = 1.0 }");
    common::refused(&unknown, &["unknown field `w`"]);
}

/// Newmark's predictor–corrector with two contact groups (`contact` on the
/// predictor, `newmark_contact` on the corrector): two elastic blocks meet
/// head on and part again, with the rebound MUSL gives them under the
/// same contact and the total momentum zero to round-off at every step.
/// Without a contact pass their two fields would let them pass through
/// each other (A's momentum would stay its first).
#[test]
fn newmark_contacts_two_groups_as_musl_does() {
    // (A's final momentum, the gap between the blocks at the start and at
    // the end, the worst |total momentum| over the run)
    let run = |update: &str, cfl: f64| -> (f64, f64, f64, f64) {
        let text = format!(
            r#"
[grid]
cell_size = 0.005
min = [0.0, 0.0]
max = [0.3, 0.1]
[time]
end = 0.012
cfl = {cfl}
[transfer]
flip_blend = 0.99
stress_update = "{update}"
[materials.soft]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e6
poissons_ratio = 0.3
[[bodies]]
name = "a"
shape = {{ type = "box", min = [0.05, 0.03], max = [0.1, 0.07] }}
material = "soft"
velocity = [1.0, 0.0]
contact_group = 0
[[bodies]]
name = "b"
shape = {{ type = "box", min = [0.105, 0.03], max = [0.155, 0.07] }}
material = "soft"
velocity = [-1.0, 0.0]
contact_group = 1
[output]
body_momenta = true
"#,
        );
        let scene = Scene::from_text(&text, None).unwrap();
        assert_eq!(scene.plan.has(Stage::NewmarkContact), update == "newmark");
        let mut sim = Simulation::new(&scene);
        let cols = sim.series_columns();
        let gap = |sim: &Simulation| {
            let p = sim.particles();
            let (mut a, mut b) = (f64::MIN, f64::MAX);
            for (x, &body) in p.x.iter().zip(&p.body) {
                if body == 0 {
                    a = a.max(x[0]);
                } else {
                    b = b.min(x[0]);
                }
            }
            b - a
        };
        let start = gap(&sim);
        let p0 = sim.row().get(&cols, "momentum_x_a").unwrap();
        let mut worst: f64 = 0.0;
        while sim.time() < scene.file.time.end {
            sim.step().unwrap();
            worst = worst.max(sim.row().momentum_x.abs());
        }
        let pa = sim.row().get(&cols, "momentum_x_a").unwrap();
        (pa / p0, start, gap(&sim), worst / p0)
    };
    let (newmark, start, end, worst) = run("newmark", 0.4);
    assert!(worst < 1e-12, "total momentum {worst:e} of A's");
    // they met and parted: A goes back, the gap opens again
    assert!(
        newmark < -0.5,
        "A's momentum at the end: {newmark} of its first"
    );
    assert!(end > start, "gap {end} at the end against {start}");
    // as MUSL with the same contact
    let (musl, _, musl_end, _) = run("musl", 0.4);
    assert!(
        (newmark - musl).abs() < 0.1 * musl.abs(),
        "A's rebound: Newmark {newmark}, MUSL {musl}"
    );
    assert!(musl_end > start);
    println!(
        "A's momentum at the end (of its first): Newmark {newmark:.4}, MUSL {musl:.4}; gap {start:.5} -> {end:.5} (MUSL {musl_end:.5}); worst total momentum {worst:.1e}"
    );
    // at smaller steps too: the rebound itself depends on the step (MUSL
    // alone goes from -0.97 to -0.70), Newmark stays within 10 % of MUSL
    for cfl in [0.1, 0.025] {
        let (n, _, _, _) = run("newmark", cfl);
        let (m, _, _, _) = run("musl", cfl);
        println!("CFL {cfl}: Newmark {n:.4}, MUSL {m:.4}");
        assert!(
            (n - m).abs() < 0.1 * m.abs(),
            "CFL {cfl}: Newmark {n}, MUSL {m}"
        );
    }
}
