//! The damage particle method (Wei & Chen) run from scene files: the bar
//! of their section 4.1 through the method registry, and the scene
//! section's checks.

use cleave::diagnostics::Recorder;
use cleave::scene::Scene;
use std::path::Path;

fn scene_text(file: &str) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    std::fs::read_to_string(dir.join(file)).unwrap()
}

/// The right end's displacement at `t` under `dpm_bar.toml`'s pull: a
/// linear ramp of the speed to `v` over `ramp`, then `v`.
fn pulled(t: f64) -> f64 {
    let (v, ramp) = (1.0370899e-3, 2.1213203);
    if t < ramp {
        0.5 * v * t * t / ramp
    } else {
        v * (t - 0.5 * ramp)
    }
}

#[test]
fn the_bar_scene_dissipates_its_fracture_energy() {
    // Wei & Chen, section 4.1: the force is gone at u = 2 G_F / f_t =
    // 1.885e-2, the work done and the energy dissipated are G_F A = 18.85
    let scene = Scene::from_text(&scene_text("dpm_bar.toml"), None).unwrap();
    assert_eq!(
        scene.plan.names(),
        ["dpm_advance", "dpm_strain", "dpm_damage", "dpm_force"]
    );
    assert_eq!(scene.total_particles(), 26 * 3);
    let mut sim = cleave::methods::build(&scene).unwrap();
    assert_eq!(sim.name(), "damage_particle");
    let mut rec = Recorder::series_only();
    let summary = sim.run(&mut rec).unwrap();
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let (t, f) = (col("time"), col("reaction_right_x"));
    let u: Vec<f64> = t.iter().map(|&t| pulled(t)).collect();
    let peak = f.iter().cloned().fold(0.0, f64::max);
    let top = f.iter().position(|&x| x == peak).unwrap();
    let gone = (top..f.len())
        .find(|&k| f[k] < 1e-3 * peak)
        .map(|k| u[k])
        .expect("the force never fell to zero");
    let work: f64 = (1..f.len())
        .map(|k| 0.5 * (f[k] + f[k - 1]) * (u[k] - u[k - 1]))
        .sum();
    let dissipated = *col("fracture_energy").last().unwrap();
    let balance = col("energy_balance");
    let worst = balance.iter().map(|b| b.abs()).fold(0.0, f64::max);
    eprintln!(
        "peak {peak:.2}, u at F = 0 {gone:.5e}, work {work:.4}, dissipated {dissipated:.4}, \
         |balance| <= {worst:.3e}, {} steps, damaged {:?}",
        summary.steps,
        col("damaged_particles").last()
    );
    assert!((peak / 2000.0 - 1.0).abs() < 5e-3, "peak {peak}");
    assert!((gone / 1.885e-2 - 1.0).abs() < 5e-3, "u at F = 0: {gone}");
    assert!((work / 18.85 - 1.0).abs() < 5e-3, "work {work}");
    assert!(
        (dissipated / 18.85 - 1.0).abs() < 5e-3,
        "dissipated {dissipated}"
    );
    assert!(worst < 5e-3 * 18.85, "energy balance off by {worst}");
    assert_eq!(*col("broken_particles").last().unwrap(), 6.0);
}

/// The scene with `from` replaced by `to`, validated: the errors' paths
/// and reasons, joined.
fn refused(from: &str, to: &str) -> String {
    let text = scene_text("dpm_bar.toml");
    assert!(text.contains(from), "no {from:?}");
    match Scene::from_text(&text.replace(from, to), None) {
        Ok(_) => panic!("{to:?} was accepted"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn damage_particle_scenes_are_validated() {
    let cases = [
        ("support = 1.5", "support = 1.0", "damage_particle.support"),
        ("support = 1.5", "support = 1.5\nspacing = 2.0", "spacing"),
        ("tol = 0.3", "tol = 0.3\nkappa_c = 1e-3", "damage_particle.damage.kappa_c"),
        ("tol = 0.3", "tol = 0.3\nregularised = false", "damage_particle.damage.kappa_c"),
        ("tol = 0.3", "tol = 0.3\ntracking_radius = 0.5", "damage_particle.damage.tracking_radius"),
        ("strength = 200.0", "strength = -200.0", "damage_particle.damage.strength"),
        ("strength_factor = 0.999", "strength_factor = 1.5", "strength_factor"),
        (
            "material = \"bar\"",
            "material = \"bar\"\nparticles_per_cell = 4",
            "bodies[0].particles_per_cell",
        ),
        (
            "shape = { type = \"box\", min = [0.0, 0.0], max = [100.0, 8.0] }",
            "shape = { type = \"disk\", center = [50.0, 4.0], radius = 4.0 }",
            "bodies[0].shape",
        ),
        (
            "max = [100.0, 8.0] }",
            "max = [100.0, 7.0] }",
            "bodies[0].shape.max[1]",
        ),
        ("[analysis]", "[transfer]\nscheme = \"apic\"\n\n[analysis]", "transfer"),
        ("cell_size = 4.0", "cell_size = 4.0\nshape_function = \"linear\"", "grid.shape_function"),
        (
            "left = \"fixed\"",
            "left = { type = \"traction\", normal = 1.0 }",
            "grid.boundary.left",
        ),
        ("poissons_ratio = 0.0", "poissons_ratio = 0.0\ndamage = { model = \"rankine\", strength = 1.0, fracture_energy = 1.0 }", "materials.bar.damage"),
        ("model = \"linear_elastic\"", "model = \"neo_hookean\"", "materials.bar.model"),
    ];
    for (from, to, field) in cases {
        let e = refused(from, to);
        assert!(e.contains(field), "{to:?}: {e}");
    }
    // the method's table without the method, and an unknown method
    let e = refused("method = \"damage_particle\"", "");
    assert!(e.contains("damage_particle") && e.contains("method"), "{e}");
    let e = refused("method = \"damage_particle\"", "method = \"sph\"");
    assert!(e.contains("method"), "{e}");
}

#[test]
fn the_bar_in_3d_dissipates_its_fracture_energy() {
    // the same bar as a 3D box, 8 × 8 in section (A = 64): one code path
    // for both dimensions, the 3D section of each cell (eq. 33's A_L)
    let text = scene_text("dpm_bar.toml")
        .replace("min = [0.0, -4.0]", "min = [0.0, -4.0, -4.0]")
        .replace("max = [100.0, 12.0]", "max = [100.0, 12.0, 12.0]")
        .replace(
            "min = [0.0, 0.0], max = [100.0, 8.0]",
            "min = [0.0, 0.0, 0.0], max = [100.0, 8.0, 8.0]",
        )
        .replace(
            "min = [47.0, -1.0], max = [53.0, 9.0]",
            "min = [47.0, -1.0, -1.0], max = [53.0, 9.0, 9.0]",
        )
        .replace("y = 0.0 }", "y = 0.0, z = 0.0 }")
        .replace("plane = \"plane_stress\"\n", "")
        .replace("thickness = 1.25\n", "")
        .replace("[analysis]\n", "");
    let scene = Scene::from_text(&text, None).unwrap();
    assert_eq!(scene.dimension(), 3);
    assert_eq!(scene.total_particles(), 26 * 3 * 3);
    let mut sim = cleave::methods::build(&scene).unwrap();
    let mut rec = Recorder::series_only();
    sim.run(&mut rec).unwrap();
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let (t, f) = (col("time"), col("reaction_right_x"));
    let u: Vec<f64> = t.iter().map(|&t| pulled(t)).collect();
    let peak = f.iter().cloned().fold(0.0, f64::max);
    let top = f.iter().position(|&x| x == peak).unwrap();
    let gone = (top..f.len())
        .find(|&k| f[k] < 1e-3 * peak)
        .map(|k| u[k])
        .expect("the force never fell to zero");
    let dissipated = *col("fracture_energy").last().unwrap();
    let (ga, fa) = (1.885 * 64.0, 200.0 * 64.0);
    eprintln!(
        "3D: peak {peak:.2} (f_t A {fa}), u at F = 0 {gone:.5e}, dissipated {dissipated:.4} (G_F A {ga}), broken {:?}",
        col("broken_particles").last()
    );
    assert!((peak / fa - 1.0).abs() < 5e-3, "peak {peak}");
    assert!((gone / 1.885e-2 - 1.0).abs() < 5e-3, "u at F = 0: {gone}");
    assert!(
        (dissipated / ga - 1.0).abs() < 5e-3,
        "dissipated {dissipated}"
    );
}

#[test]
fn a_support_too_small_for_the_moment_matrix_is_a_clear_error() {
    // validation keeps the support in [1.2, 4]; below it (here forced
    // past validation) a face point of a cell is covered by one row of
    // particles: the setup refuses the scene, naming the key, the body,
    // the particle and the condition, instead of a singular solve
    let mut scene = Scene::from_text(&scene_text("dpm_bar.toml"), None).unwrap();
    scene.file.damage_particle.as_mut().unwrap().support = 0.9;
    let e = match cleave::methods::build(&scene) {
        Ok(_) => panic!("a support of 0.9 spacings was set up"),
        Err(e) => e.to_string(),
    };
    eprintln!("{e}");
    assert!(
        e.contains("damage_particle.support")
            && e.contains("bodies[0]")
            && e.contains("particle at"),
        "{e}"
    );
}

/// A snapshot's f64 field by name.
fn field<'a>(snap: &'a cleave::diagnostics::Snapshot, name: &str) -> &'a [f64] {
    match snap.fields.iter().find(|f| f.name == name).map(|f| &f.data) {
        Some(cleave::diagnostics::FieldData::F64(v)) => v,
        _ => panic!("no f64 field {name}"),
    }
}

#[test]
fn kalthoff_s_crack_leaves_the_notch_tip_at_an_angle_and_nowhere_else() {
    // Wei & Chen, section 4.2 (R2) at 150 × 150 cells: the edge crack cut
    // into the supports by diffraction, the edge below it held at
    // 16.5 m/s. The crack grows from the tip only (criterion 27 keeps
    // damage off the rest of the plate), up and to the right at 50–75°
    // to the x axis (experiment about 70°; 55° here, 61° at 250 and 350
    // cells: docs/dpm.md), and the energy balance with the dissipation
    // holds to 2 % of the work done
    let scene = Scene::from_text(&scene_text("dpm_kalthoff.toml"), None).unwrap();
    let mut sim = cleave::methods::build(&scene).unwrap();
    let mut rec = Recorder::default();
    sim.run(&mut rec).unwrap();
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let work = *col("external_work").last().unwrap();
    let balance = col("energy_balance").last().unwrap().abs();
    assert!(
        balance < 0.02 * work,
        "energy balance {balance} of work {work}"
    );
    // the impact pushes: the held edge's reaction is along +x at first
    let push = col("reaction_impact_x");
    assert!(push[1..20].iter().all(|&f| f > 0.0), "{:?}", &push[..20]);
    let snap = rec.snapshots.last().unwrap();
    let (d, u) = (field(snap, "damage"), field(snap, "displacement"));
    let h = 0.1 / 150.0;
    let (tip_x, tip_y) = (0.05, 0.025);
    let broken: Vec<[f64; 2]> = snap
        .positions
        .iter()
        .enumerate()
        .filter(|(p, _)| d[*p] >= 0.99)
        .map(|(p, x)| [x[0] - u[2 * p] - tip_x, x[1] - u[2 * p + 1] - tip_y])
        .collect();
    assert!(broken.len() > 100, "{} broken", broken.len());
    for q in &broken {
        assert!(
            q[0] > -1.5 * h && q[1] > -1.5 * h,
            "broken off the path at {q:?}"
        );
    }
    // the crack's direction: the principal axis of the broken particles
    // about the tip, and its reach
    let (mut sxx, mut sxy, mut syy) = (0.0, 0.0, 0.0);
    for q in &broken {
        sxx += q[0] * q[0];
        sxy += q[0] * q[1];
        syy += q[1] * q[1];
    }
    let angle = (0.5 * (2.0 * sxy).atan2(sxx - syy)).to_degrees();
    let reach = broken.iter().map(|q| q[0].hypot(q[1])).fold(0.0, f64::max);
    eprintln!(
        "{} broken, angle {angle:.1}°, reach {reach:.4} m, dissipated {:.1} J/m, balance {balance:.1} of {work:.1} J/m",
        broken.len(),
        col("fracture_energy").last().unwrap()
    );
    assert!((50.0..=75.0).contains(&angle), "angle {angle}");
    assert!(reach > 0.05, "reach {reach}");
}

#[test]
fn held_regions_and_cracks_are_checked() {
    let text = scene_text("dpm_kalthoff.toml");
    let refused = |from: &str, to: &str| -> String {
        assert!(text.contains(from), "no {from:?}");
        match Scene::from_text(&text.replace(from, to), None) {
            Ok(s) => match cleave::methods::build(&s) {
                Ok(_) => panic!("{to:?} was accepted"),
                Err(e) => e.to_string(),
            },
            Err(e) => e.to_string(),
        }
    };
    let cases = [
        ("x = 16.5\n", "\n", "damage_particle.held[0]"),
        ("x = 16.5\n", "x = 16.5\nz = 1.0\n", "damage_particle.held[0].z"),
        (
            "max = [1.0e-6, 0.025] }",
            "max = [1.0e-6, 0.025] }\n\n[[damage_particle.held]]\nname = \"impact\"\nshape = { type = \"box\", min = [0.09, 0.0], max = [0.2, 0.1] }\ny = 0.0",
            "damage_particle.held[1].name",
        ),
        (
            "min = [-0.001, -0.001], max = [1.0e-6, 0.025] }",
            "min = [0.0001, 0.001], max = [0.0002, 0.002] }",
            "damage_particle.held[0].shape",
        ),
        (
            "[[0.0, 0.025], [0.05, 0.025]]",
            "[[0.0, 0.02], [0.05, 0.02]]",
            "bodies[0].cracks[0]",
        ),
        (
            "[[0.0, 0.025], [0.05, 0.025]] }",
            "[[0.0, 0.025], [0.05, 0.025]], profile = \"borden\" }",
            "bodies[0].cracks[0].profile",
        ),
    ];
    for (from, to, path) in cases {
        let e = refused(from, to);
        assert!(e.contains(path), "{to:?}: {e}");
    }
    // a crack through a particle says which and why
    let e = refused(
        "[[0.0, 0.025], [0.05, 0.025]]",
        "[[0.0, 0.02], [0.05, 0.02]]",
    );
    assert!(e.contains("passes through the particle"), "{e}");
}
