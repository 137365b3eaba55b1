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
/// The error a shipped scene gives with `from` replaced by `to`: from
/// validation, or else from setting the method up (what only setup finds,
/// such as a shape that holds no particle).
fn refused(scene: &str, from: &str, to: &str) -> String {
    let text = scene_text(scene);
    assert!(text.contains(from), "no {from:?}");
    match Scene::from_text(&text.replace(from, to), None) {
        Ok(s) => match cleave::methods::build(&s) {
            Ok(_) => panic!("{to:?} was accepted"),
            Err(e) => e.to_string(),
        },
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
        ("tol = 0.3", "tol = 0.3\nnormal_radius = 0.5", "damage_particle.damage.normal_radius"),
        ("tol = 0.3", "tol = 0.3\ntrack_at = 0.0", "damage_particle.damage.track_at"),
        ("support = 1.5", "support = 1.5\njitter = 0.5", "damage_particle.jitter"),
        ("strength = 200.0", "strength = -200.0", "damage_particle.damage.strength"),
        ("strength_factor = 0.999", "strength_factor = 1.5", "strength_factor"),
        (
            "material = \"bar\"",
            "material = \"bar\"\nparticles_per_cell = 4",
            "bodies[0].particles_per_cell",
        ),
        // a body that is not a box: its particles at the cells' centres,
        // which the paper's support of 1.5 does not cover at the outline
        (
            "shape = { type = \"box\", min = [0.0, 0.0], max = [100.0, 8.0] }",
            "shape = { type = \"disk\", center = [50.0, 4.0], radius = 4.0 }",
            "damage_particle.support",
        ),
        // one whose shape holds no cell's centre (the grid MPM's seeding,
        // two particles a cell along each axis, would find four)
        (
            "shape = { type = \"box\", min = [0.0, 0.0], max = [100.0, 8.0] }",
            "shape = { type = \"disk\", center = [50.0, 4.0], radius = 1.5 }",
            "bodies[0].shape: holds no centre of a grid cell",
        ),
        (
            "max = [100.0, 8.0] }",
            "max = [100.0, 7.0] }",
            "bodies[0].shape.max[1]",
        ),
        ("[analysis]", "[transfer]\nscheme = \"apic\"\n\n[analysis]", "transfer"),
        ("cell_size = 4.0", "cell_size = 4.0\nshape_function = \"linear\"", "grid.shape_function"),
        ("poissons_ratio = 0.0", "poissons_ratio = 0.0\ndamage = { model = \"rankine\", strength = 1.0, fracture_energy = 1.0 }", "materials.bar.damage"),
        ("model = \"linear_elastic\"", "model = \"neo_hookean\"", "materials.bar.model"),
    ];
    for (from, to, field) in cases {
        let e = refused("dpm_bar.toml", from, to);
        assert!(e.contains(field), "{to:?}: {e}");
    }
    // the method's table without the method, and an unknown method
    let e = refused("dpm_bar.toml", "method = \"damage_particle\"", "");
    assert!(e.contains("damage_particle") && e.contains("method"), "{e}");
    let e = refused(
        "dpm_bar.toml",
        "method = \"damage_particle\"",
        "method = \"sph\"",
    );
    assert!(e.contains("method"), "{e}");
}

/// A bar scene's 2D bar as a 3D box, 8 × 8 in section (A = 64).
fn bar_in_3d(text: &str) -> String {
    text.replace("min = [0.0, -4.0]", "min = [0.0, -4.0, -4.0]")
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
        .replace("[analysis]\n", "")
}

#[test]
fn the_bar_in_3d_dissipates_its_fracture_energy() {
    // the same bar as a 3D box, 8 × 8 in section (A = 64): one code path
    // for both dimensions, the 3D section of each cell (eq. 33's A_L)
    let text = bar_in_3d(&scene_text("dpm_bar.toml"));
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
fn a_crack_in_a_3d_bar_is_refused_naming_its_key() {
    // the method diffracts its kernels about 2D crack tips only
    let text = bar_in_3d(&scene_text("dpm_bar.toml")).replace(
        "material = \"bar\"\n",
        "material = \"bar\"\ncracks = [{ points = [[50.0, 0.0, 0.0], [50.0, 4.0, 0.0], [50.0, 4.0, 8.0]] }]\n",
    );
    match Scene::from_text(&text, None) {
        Ok(_) => panic!("a 3D damage-particle scene with a crack validated"),
        Err(e) => {
            assert_eq!(e.errors[0].path, "bodies[0].cracks", "{e}");
            assert!(e.errors[0].reason.contains("are 2D"), "{e}");
        }
    }
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

/// A validated scene run to its end, with its snapshots.
fn solved(scene: &Scene) -> Recorder {
    let mut sim = cleave::methods::build(scene).unwrap();
    let mut rec = Recorder::default();
    sim.run(&mut rec).unwrap();
    rec
}

/// Runs a scene with snapshots and checks that the energy balance with
/// the dissipation (`energy_balance`) closes at the end to `share` of the
/// work done.
fn run_balanced(text: &str, share: f64) -> Recorder {
    let rec = solved(&Scene::from_text(text, None).unwrap());
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let work = *col("external_work").last().unwrap();
    let balance = col("energy_balance").last().unwrap().abs();
    assert!(
        balance < share * work,
        "energy balance {balance} of work {work}"
    );
    rec
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
    let rec = run_balanced(&scene_text("dpm_kalthoff.toml"), 0.02);
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let work = *col("external_work").last().unwrap();
    let balance = col("energy_balance").last().unwrap().abs();
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
    let cases = [
        ("x = 16.5\n", "\n", "damage_particle.held[0]"),
        ("x = 16.5\n", "x = 16.5\nz = 1.0\n", "damage_particle.held[0].z"),
        (
            "x = 16.5\n",
            "x = { table = [[0.0, 16.5], [-1.0, 16.5]] }\n",
            "damage_particle.held[0].x.table[1]",
        ),
        ("x = 16.5\n", "y = nan\n", "damage_particle.held[0].y"),
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
        let e = refused("dpm_kalthoff.toml", from, to);
        assert!(e.contains(path), "{to:?}: {e}");
    }
    // a crack that the jitter puts a particle across (a fifth of a spacing
    // below a row: 0.3 spacings move some of that row's particles below
    // it, away from their cells) says which and why; without the jitter
    // it is taken
    let text = scene_text("dpm_kalthoff.toml").replace(
        "[[0.0, 0.025], [0.05, 0.025]]",
        "[[0.0, 0.0252], [0.05, 0.0252]]",
    );
    let build =
        |text: &str| cleave::methods::build(&Scene::from_text(text, None).unwrap()).map(|_| ());
    assert!(build(&text).is_ok());
    let e = build(&text.replace("support = 2.5", "support = 2.5\njitter = 0.3"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("bodies[0].cracks[0]") && e.contains("passes between the particle"),
        "{e}"
    );
    // a crack through a particle says which and why
    let e = refused(
        "dpm_kalthoff.toml",
        "[[0.0, 0.025], [0.05, 0.025]]",
        "[[0.0, 0.02], [0.05, 0.02]]",
    );
    assert!(e.contains("passes through the particle"), "{e}");
}

/// The branching plate without its damage at 8e-4 m spacing, `options`
/// added to `[damage_particle]` and `output` to `[output]`.
fn elastic_plate(options: &str, output: &str) -> String {
    let text = scene_text("dpm_branching.toml");
    let elastic = &text[..text.find("[damage_particle.damage]").unwrap()];
    let out = &text[text.find("[output]").unwrap()..];
    format!("{elastic}{options}{out}{output}").replace("cell_size = 4.0e-4", "cell_size = 8.0e-4")
}

#[test]
fn a_jittered_arrangement_keeps_its_outline_and_a_stable_step() {
    // `jitter`: every particle within jitter × h of its lattice vertex, a
    // coordinate on the plate's outline kept there, the same arrangement
    // on every run. At a support of 1.6 spacings the jittered
    // arrangement's highest frequency is far above the lattice's (a face
    // point nearly outside its cover), and the explicit step shrinks to
    // match it: the plate under its tractions keeps its energy balance
    // where the spacing's CFL step blew it up within a few dozen steps
    // (docs/dpm.md)
    let h = 8.0e-4;
    let run = |options: &str, support: &str| {
        let text = elastic_plate(options, "")
            .replace("support = 2.5", support)
            .replace("end = 8.0e-5", "end = 4.0e-6");
        let scene = Scene::from_text(&text, None).unwrap();
        let mut sim = cleave::methods::build(&scene).unwrap();
        let mut rec = Recorder::default();
        sim.run(&mut rec).unwrap();
        rec
    };
    let lattice = run("", "support = 2.5");
    let jittered = run("jitter = 0.25\n", "support = 2.5");
    let at_start = |rec: &Recorder| {
        assert_eq!(rec.snapshots[0].time, 0.0);
        rec.snapshots[0].positions.clone()
    };
    let (p0, p1) = (at_start(&lattice), at_start(&jittered));
    assert_eq!(p0.len(), p1.len());
    let mut moved = 0;
    for (a, b) in p0.iter().zip(&p1) {
        for k in 0..2 {
            let off = (b[k] - a[k]).abs();
            assert!(off <= 0.25 * h * (1.0 + 1e-9), "{b:?} is {off} m off {a:?}");
            let outline = [0.0, [0.1, 0.04][k]]
                .iter()
                .any(|e| (a[k] - e).abs() < 1e-12);
            if outline {
                assert_eq!(a[k], b[k], "an outline coordinate moved: {a:?} to {b:?}");
            }
            moved += usize::from(off > 0.01 * h);
        }
    }
    assert!(moved > p0.len(), "only {moved} coordinates moved");
    assert_eq!(at_start(&run("jitter = 0.25\n", "support = 2.5")), p1);
    // the small support: a step far below the spacing's, and the books close
    let small = run("jitter = 0.25\n", "support = 1.6");
    let col = |rec: &Recorder, name: &str| rec.column(name).unwrap().to_vec();
    let dt_lattice = col(&lattice, "dt")[1];
    let dt_small = col(&small, "dt")[1];
    assert!(
        dt_small < 0.1 * dt_lattice,
        "dt {dt_small} against {dt_lattice}"
    );
    let work = *col(&small, "external_work").last().unwrap();
    let error = col(&small, "energy_error").last().unwrap().abs();
    assert!(
        work > 0.0 && error < 1e-6 * work,
        "energy error {error} of work {work}"
    );
}

#[test]
fn a_traction_on_a_free_plate_gives_its_impulse_and_does_its_work() {
    // the branching plate, elastic, at 8e-4 m spacing, pulled by 1 MPa on
    // its top edge only: nothing else acts, so its momentum is the
    // traction's impulse σ L t (the internal forces sum to zero, central
    // differences integrate a constant force exactly), and the work the
    // traction does is the kinetic and strain energy it leaves
    let text = elastic_plate("", "")
        .replace("bottom = { type = \"traction\", normal = 1.0e6 }\n", "")
        .replace("end = 8.0e-5", "end = 2.0e-5");
    let scene = Scene::from_text(&text, None).unwrap();
    assert_eq!(
        scene.plan.names(),
        ["dpm_advance", "dpm_strain", "dpm_traction", "dpm_force"]
    );
    let mut sim = cleave::methods::build(&scene).unwrap();
    let mut rec = Recorder::series_only();
    sim.run(&mut rec).unwrap();
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let (t, py, px) = (col("time"), col("momentum_y"), col("momentum_x"));
    for k in 1..t.len() {
        let impulse = 1.0e6 * 0.1 * 1.0 * t[k];
        assert!(
            (py[k] / impulse - 1.0).abs() < 1e-9,
            "t = {}: momentum {} of impulse {impulse}",
            t[k],
            py[k]
        );
        assert!(px[k].abs() < 1e-9 * impulse, "momentum_x {}", px[k]);
    }
    let work = *col("external_work").last().unwrap();
    let energy = col("kinetic_energy").last().unwrap() + col("strain_energy").last().unwrap();
    assert!(work > 0.0);
    assert!(
        (energy / work - 1.0).abs() < 1e-3,
        "kinetic + strain {energy} of work {work}"
    );
}

/// `dpm_branching.toml` at the paper's coarsest spacing, 8e-4 m: the
/// crack half a spacing above y = 0.02 and the initiation box 1.5 spacings
/// about its tip, as `docs/scripts/dpm_branching.sh` rewrites it.
fn coarse_branching() -> String {
    scene_text("dpm_branching.toml")
        .replace("cell_size = 4.0e-4", "cell_size = 8.0e-4")
        .replace(
            "[[0.0, 0.0202], [0.05, 0.0202]]",
            "[[0.0, 0.0204], [0.05, 0.0204]]",
        )
        .replace(
            "min = [0.0494, 0.0196], max = [0.0506, 0.0208]",
            "min = [0.0488, 0.0192], max = [0.0512, 0.0216]",
        )
}

#[test]
fn the_branching_plate_s_crack_runs_from_the_notch_and_splits() {
    // Wei & Chen, section 4.3 (R3) at their coarsest spacing, 8e-4 m: the
    // crack grows from the notch tip only, runs most of the way to the
    // right edge in 80 µs, and splits: at x = 80 mm it is broken both
    // well above and well below the notch's line (docs/dpm.md, R3); the
    // energy balance with the dissipation holds to 1 % of the work
    let h = 8.0e-4;
    let y = 0.02 + 0.5 * h;
    let text = coarse_branching();
    let rec = run_balanced(&text, 0.01);
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let dissipated = *col("fracture_energy").last().unwrap();
    assert!(dissipated > 0.0);
    let snap = rec.snapshots.last().unwrap();
    let (d, u) = (field(snap, "damage"), field(snap, "displacement"));
    let broken: Vec<[f64; 2]> = snap
        .positions
        .iter()
        .enumerate()
        .filter(|(p, _)| d[*p] >= 0.9)
        .map(|(p, x)| [x[0] - u[2 * p], x[1] - u[2 * p + 1]])
        .collect();
    assert!(
        broken.iter().all(|q| q[0] > 0.05 - 2.0 * h),
        "broken behind the notch tip"
    );
    let front = broken.iter().map(|q| q[0]).fold(0.0, f64::max);
    assert!(front > 0.09, "the crack front is at {front} m");
    let column: Vec<f64> = broken
        .iter()
        .filter(|q| (q[0] - 0.08).abs() <= h)
        .map(|q| q[1] - y)
        .collect();
    let (low, high) = column
        .iter()
        .fold((0.0f64, 0.0f64), |(l, hi), &v| (l.min(v), hi.max(v)));
    assert!(
        low < -2.5e-3 && high > 1.5e-3,
        "at x = 80 mm the crack spans {low}..{high} m about the notch's line: {column:?}"
    );
}

/// The damage stage runs particle by particle in parallel: the coarse
/// branching plate, cut at 30 µs (the crack running, the damage of many
/// particles growing at once), with the normals from the averaged stress
/// as well, gives every series value and the last snapshot's damage to the
/// bit on one thread and on three (6 426 particles: several tasks).
#[test]
fn the_damage_stage_gives_the_same_bits_on_any_thread_count() {
    for options in ["\ntol = 0.5\n", "\ntol = 0.5\nnormal_radius = 1.5\n"] {
        let text = coarse_branching()
            .replace("end = 8.0e-5", "end = 3.0e-5")
            .replace("\ntol = 0.5\n", options);
        let scene = Scene::from_text(&text, None).unwrap();
        let run = |threads: usize| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap()
                .install(|| {
                    let mut sim = cleave::methods::build(&scene).unwrap();
                    let mut rec = Recorder::default();
                    sim.run(&mut rec).unwrap();
                    let bits: Vec<Vec<u64>> = rec
                        .rows
                        .iter()
                        .map(|r| r.values().iter().map(|v| v.to_bits()).collect())
                        .collect();
                    let damage: Vec<u64> = field(rec.snapshots.last().unwrap(), "damage")
                        .iter()
                        .map(|d| d.to_bits())
                        .collect();
                    let dissipated = *rec.column("fracture_energy").unwrap().last().unwrap();
                    (bits, damage, dissipated)
                })
        };
        let (one, three) = (run(1), run(3));
        assert!(one.2 > 0.0, "{options}: nothing dissipated by 30 µs");
        assert!(one.1.iter().filter(|&&d| f64::from_bits(d) > 0.0).count() > 20);
        assert!(one.0 == three.0, "{options}: the series differ");
        assert!(one.1 == three.1, "{options}: the damage differs");
    }
}

#[test]
fn with_track_at_one_damage_starts_only_beside_a_broken_particle() {
    // criterion 27 fed by broken particles only (`track_at = 1`): every
    // damaged particle outside the notch tip's initiation box has a
    // broken one (D = 1) within the support (2.5 spacings), which is not
    // so by default (the partial damage ahead of the front, docs/dpm.md
    // R3); the branching plate at 8e-4 m
    let h = 8.0e-4;
    let text = coarse_branching().replace("end = 8.0e-5", "end = 5.0e-5");
    let lonely = |text: &str| {
        let rec = run_balanced(text, 0.01);
        let snap = rec.snapshots.last().unwrap();
        let (d, u) = (field(snap, "damage"), field(snap, "displacement"));
        let x: Vec<[f64; 2]> = snap
            .positions
            .iter()
            .enumerate()
            .map(|(p, x)| [x[0] - u[2 * p], x[1] - u[2 * p + 1]])
            .collect();
        let broken: Vec<[f64; 2]> = (0..x.len())
            .filter(|&p| d[p] >= 1.0)
            .map(|p| x[p])
            .collect();
        let damaged = (0..x.len()).filter(|&p| d[p] > 0.0).count();
        let alone = (0..x.len())
            .filter(|&p| {
                d[p] > 0.0 && (x[p][0] - 0.05).abs().max((x[p][1] - 0.0204).abs()) > 1.5 * h
            })
            .filter(|&p| {
                !broken.iter().any(|b| {
                    let r = ((b[0] - x[p][0]).powi(2) + (b[1] - x[p][1]).powi(2)).sqrt();
                    r > 0.0 && r <= 2.5 * h * (1.0 + 1e-9)
                })
            })
            .count();
        (damaged, broken.len(), alone)
    };
    let (damaged, broken, alone) =
        lonely(&text.replace("\ntol = 0.5\n", "\ntol = 0.5\ntrack_at = 1.0\n"));
    assert!(broken > 20, "{broken} broken of {damaged} damaged");
    assert_eq!(
        alone, 0,
        "{alone} of {damaged} damaged particles have no broken neighbour"
    );
    let (damaged, _, alone) = lonely(&text);
    assert!(alone > 0, "by default: {alone} of {damaged}");
}

/// `dpm_bar_static.toml` with `nodes` particles along the bar (three rows,
/// the middle plane between two columns), steps of `du`, and with
/// `regularised = false` and the constant `kappa_c` when given.
fn static_bar_text(nodes: usize, du: f64, kappa_c: Option<f64>) -> String {
    let h = 100.0 / (nodes - 1) as f64;
    let text = scene_text("dpm_bar_static.toml");
    let mut text = text
        .replace("cell_size = 4.0", &format!("cell_size = {h:?}"))
        .replace("min = [0.0, -4.0]", &format!("min = [0.0, {:?}]", -h))
        .replace(
            "max = [100.0, 12.0]",
            &format!("max = [100.0, {:?}]", 3.0 * h),
        )
        .replace(
            "max = [100.0, 8.0]",
            &format!("max = [100.0, {:?}]", 2.0 * h),
        )
        .replace(
            "thickness = 1.25",
            &format!("thickness = {:?}", 10.0 / (2.0 * h)),
        )
        .replace(
            "min = [47.0, -1.0], max = [53.0, 9.0]",
            &format!(
                "min = [{:?}, {:?}], max = [{:?}, {:?}]",
                50.0 - 0.75 * h,
                -h,
                50.0 + 0.75 * h,
                3.0 * h
            ),
        )
        .replace("dt = 1.0e-4", &format!("dt = {du:?}"))
        .replace("series_rows = 221", "series_rows = 100000");
    if let Some(k) = kappa_c {
        text = text.replace(
            "tol = 0.3",
            &format!("tol = 0.3\nregularised = false\nkappa_c = {k:?}"),
        );
    }
    text
}

/// What the static bar gives: the peak force, the end displacement where
/// the force is gone (the linear softening's zero, from its last two
/// rows), the work ∫F du, the dissipation, the worst |energy_balance| and
/// the static solve's iterations.
struct StaticBar {
    peak: f64,
    gone: f64,
    work: f64,
    dissipated: f64,
    worst: f64,
    iterations: u64,
    steps: u64,
}

fn static_bar(text: &str) -> StaticBar {
    let scene = Scene::from_text(text, None).unwrap();
    let mut sim = cleave::methods::build(&scene).unwrap();
    let mut rec = Recorder::series_only();
    let summary = sim.run(&mut rec).unwrap();
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    // the right end moves at a "velocity" of 1: u = t
    let (u, f) = (col("time"), col("reaction_right_x"));
    let peak = f.iter().cloned().fold(0.0, f64::max);
    let top = f.iter().position(|&x| x == peak).unwrap();
    let last = (top..f.len())
        .take_while(|&k| f[k] > 1e-6 * peak)
        .last()
        .unwrap();
    assert!(last + 1 < f.len(), "the force never fell to zero");
    let gone = if last > top {
        let slope = (f[last] - f[last - 1]) / (u[last] - u[last - 1]);
        u[last] - f[last] / slope
    } else {
        u[last + 1]
    };
    let work = (1..f.len())
        .map(|k| 0.5 * (f[k] + f[k - 1]) * (u[k] - u[k - 1]))
        .sum();
    let worst = col("energy_balance")
        .iter()
        .map(|b| b.abs())
        .fold(0.0, f64::max);
    let iterations = summary.fracture["damage_particle"]["equilibrium_iterations"]
        .as_u64()
        .unwrap();
    StaticBar {
        peak,
        gone,
        work,
        dissipated: *col("fracture_energy").last().unwrap(),
        worst,
        iterations,
        steps: summary.steps,
    }
}

#[test]
fn the_static_bar_dissipates_its_fracture_energy_at_every_resolution() {
    // Wei & Chen, section 4.1 and Fig. 9, solved as they solve it: the
    // force is gone at u = 2 G_F / f_t = 1.885e-2 and the bar dissipates
    // G_F A = 18.85 at 16, 32, 64 and 128 nodes along it
    let scene = Scene::from_text(&scene_text("dpm_bar_static.toml"), None).unwrap();
    assert_eq!(scene.plan.names(), ["dpm_load", "dpm_equilibrium"]);
    for nodes in [16, 32, 64, 128] {
        let b = static_bar(&static_bar_text(nodes, 1e-4, None));
        eprintln!(
            "{nodes} nodes: peak {:.2}, u at F = 0 {:.5e} ({:+.3} %), work {:.4}, dissipated {:.4} ({:+.3} %), |balance| <= {:.2e}, {} steps, {} iterations",
            b.peak,
            b.gone,
            100.0 * (b.gone / 1.885e-2 - 1.0),
            b.work,
            b.dissipated,
            100.0 * (b.dissipated / 18.85 - 1.0),
            b.worst,
            b.steps,
            b.iterations
        );
        assert!((b.peak / 2000.0 - 1.0).abs() < 5e-3, "peak {}", b.peak);
        assert!(
            (b.gone / 1.885e-2 - 1.0).abs() < 5e-3,
            "u at F = 0: {}",
            b.gone
        );
        assert!((b.work / 18.85 - 1.0).abs() < 5e-3, "work {}", b.work);
        assert!(
            (b.dissipated / 18.85 - 1.0).abs() < 5e-3,
            "dissipated {}",
            b.dissipated
        );
        assert!(b.worst < 1e-3 * 18.85, "energy balance off by {}", b.worst);
    }
}

#[test]
fn without_the_regularisation_the_static_bar_s_dissipation_falls_with_refinement() {
    // the paper's contrast (Fig. 9a): a constant κ_c (here the regularised
    // one of the 16-node bar's cells) dissipates in proportion to the
    // spacing: the finer the bar, the more brittle
    let h16 = 100.0 / 15.0;
    let kappa_c = 1.885 / 200.0 / h16;
    let mut last = f64::INFINITY;
    for nodes in [16, 32, 64, 128] {
        let h = 100.0 / (nodes - 1) as f64;
        let b = static_bar(&static_bar_text(nodes, 1e-4, Some(kappa_c)));
        eprintln!(
            "{nodes} nodes, kappa_c {kappa_c:.4e}: peak {:.2}, dissipated {:.4} (G_F A h / h16 = {:.4}), u at F = 0 {:.5e}",
            b.peak,
            b.dissipated,
            18.85 * h / h16,
            b.gone
        );
        assert!(b.dissipated < 0.75 * last, "{} after {last}", b.dissipated);
        assert!(
            (b.dissipated / (18.85 * h / h16) - 1.0).abs() < 0.02,
            "dissipated {}",
            b.dissipated
        );
        last = b.dissipated;
    }
}

#[test]
fn static_scenes_are_validated_and_a_loose_piece_is_a_clear_error() {
    let cases = [
        ("dt = 1.0e-4", "cfl = 0.5", "time.dt"),
        ("dt = 1.0e-4", "dt = 1.0e-4\ncfl = 0.5", "time.cfl"),
        (
            "integration = \"static\"",
            "integration = \"explicit\"",
            "damage_particle.equilibrium",
        ),
        (
            "integration = \"static\"",
            "integration = \"implicit\"",
            "integration",
        ),
        (
            "tolerance = 1e-8",
            "tolerance = 0.5",
            "damage_particle.equilibrium.tolerance",
        ),
        (
            "max_iterations = 500",
            "max_iterations = 0",
            "damage_particle.equilibrium.max_iterations",
        ),
        (
            "max_iterations = 500",
            "max_iterations = 500\nnewton = true",
            "newton",
        ),
        (
            "material = \"bar\"",
            "material = \"bar\"\nvelocity = [1.0, 0.0]",
            "bodies[0].velocity",
        ),
    ];
    for (from, to, field) in cases {
        let e = refused("dpm_bar_static.toml", from, to);
        assert!(e.contains(field), "{to:?}: {e}");
    }
    // a bar held by nothing under gravity: its stiffness is singular, and
    // the run stops at its first step saying so
    let text = scene_text("dpm_bar_static.toml")
        .replace("left = \"fixed\"", "left = \"free\"")
        .replace(
            "right = { type = \"velocity\", x = 1.0, y = 0.0 }",
            "right = \"free\"",
        )
        .replace(
            "method = \"damage_particle\"",
            "method = \"damage_particle\"\nbody_force = [0.0, -9.81]",
        );
    let scene = Scene::from_text(&text, None).unwrap();
    let mut sim = cleave::methods::build(&scene).unwrap();
    let e = sim
        .run(&mut Recorder::series_only())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("step 1,") && e.contains("singular") && e.contains("held by no wall"),
        "{e}"
    );
}

#[test]
fn the_static_bar_in_3d_dissipates_its_fracture_energy() {
    // the static solve in 3D: the same code path, the 3D sections
    let text = bar_in_3d(&scene_text("dpm_bar_static.toml"));
    let scene = Scene::from_text(&text, None).unwrap();
    assert_eq!(scene.total_particles(), 26 * 3 * 3);
    let b = static_bar(&text);
    let (ga, fa) = (1.885 * 64.0, 200.0 * 64.0);
    eprintln!(
        "3D static: peak {:.2} (f_t A {fa}), u at F = 0 {:.5e}, dissipated {:.4} (G_F A {ga}), {} steps, {} iterations",
        b.peak, b.gone, b.dissipated, b.steps, b.iterations
    );
    assert!((b.peak / fa - 1.0).abs() < 5e-3, "peak {}", b.peak);
    assert!(
        (b.gone / 1.885e-2 - 1.0).abs() < 5e-3,
        "u at F = 0: {}",
        b.gone
    );
    assert!(
        (b.dissipated / ga - 1.0).abs() < 5e-3,
        "dissipated {}",
        b.dissipated
    );
    assert!(b.worst < 1e-3 * ga, "energy balance off by {}", b.worst);
}

#[test]
fn a_normal_from_the_averaged_stress_keeps_the_bar_s_fracture_energy() {
    // normal_radius: each starting segment's normal from the stress
    // averaged over 1.5 spacings; in the bar that is still along it
    let text =
        static_bar_text(16, 1e-4, None).replace("tol = 0.3", "tol = 0.3\nnormal_radius = 1.5");
    let b = static_bar(&text);
    assert!(
        (b.gone / 1.885e-2 - 1.0).abs() < 5e-3,
        "u at F = 0: {}",
        b.gone
    );
    assert!(
        (b.dissipated / 18.85 - 1.0).abs() < 5e-3,
        "dissipated {}",
        b.dissipated
    );
}

#[test]
fn a_static_plate_under_a_ramped_traction_is_nearly_the_patch_test() {
    // the branching plate, elastic and uncut, solved statically: the left
    // side and the bottom on rollers, the top pulled by σ ramped to 1 MPa
    // in four steps. The exact solution is linear: σ_yy = σ everywhere,
    // the strain energy ½ σ² (1 − ν²)/E V. Singular kernels hold the
    // rollers' components at the particles only: between two held
    // particles the free ones' shape functions still reach the edge, so
    // next to it the discrete solution is off the linear one (at most
    // 0.6 % of the top's displacement, two spacings from the corner) and
    // the energy 2e-7 high. The static solve's own books close exactly:
    // the traction's work (the trapezoid is exact for a linear ramp) is
    // the strain energy, the rollers' reactions balance the traction
    let text = elastic_plate("integration = \"static\"\n\n", "reactions = true\n")
        .replace(
            "bottom = { type = \"traction\", normal = 1.0e6 }",
            "bottom = \"roller\"\nleft = \"roller\"",
        )
        .replace(
            "top = { type = \"traction\", normal = 1.0e6 }",
            "top = { type = \"traction\", normal = { table = [[0.0, 0.0], [1.0, 1.0e6]] } }",
        )
        .replace(
            "cracks = [{ points = [[0.0, 0.0202], [0.05, 0.0202]] }]\n",
            "",
        )
        // the walls on the plate's left and bottom edges
        .replace("min = [-0.0024, -0.0024]", "min = [0.0, 0.0]")
        .replace("end = 8.0e-5\ncfl = 0.4", "end = 1.0\ndt = 0.25");
    let scene = Scene::from_text(&text, None).unwrap();
    assert_eq!(scene.plan.names(), ["dpm_load", "dpm_equilibrium"]);
    let rec = solved(&scene);
    let col = |name: &str| rec.column(name).unwrap_or_else(|| panic!("no {name}"));
    let (s, e, nu) = (1.0e6, 3.2e10, 0.2);
    let (l, hgt) = (0.1, 0.04);
    let (exx, eyy) = (-nu * (1.0 + nu) * s / e, (1.0 - nu * nu) * s / e);
    let snap = rec.snapshots.last().unwrap();
    let d = field(snap, "displacement");
    let mut worst = 0.0f64;
    for (p, q) in snap.positions.iter().enumerate() {
        let (x0, y0) = (q[0] - d[2 * p], q[1] - d[2 * p + 1]);
        worst = worst
            .max((d[2 * p] - exx * x0).abs())
            .max((d[2 * p + 1] - eyy * y0).abs());
    }
    let want = 0.5 * s * s * (1.0 - nu * nu) / e * l * hgt;
    let strain = *col("strain_energy").last().unwrap();
    let work = *col("external_work").last().unwrap();
    let bottom = *col("reaction_bottom_y").last().unwrap();
    let left = *col("reaction_left_x").last().unwrap();
    eprintln!(
        "worst displacement error {worst:.3e} m ({:.3} % of the top's), strain energy {strain:.9e} (want {want:.9e}), work {work:.9e}, bottom {bottom:.9e}, left {left:.3e}",
        100.0 * worst / (eyy * hgt)
    );
    assert!(worst < 1e-2 * eyy * hgt, "displacement off by {worst}");
    assert!(
        (strain / want - 1.0).abs() < 1e-6,
        "strain energy {strain} of {want}"
    );
    assert!(
        (work / strain - 1.0).abs() < 1e-9,
        "work {work} of {strain}"
    );
    assert!(
        (bottom / (-s * l) - 1.0).abs() < 1e-9,
        "bottom reaction {bottom}"
    );
    assert!(left.abs() < 1e-9 * s * l, "left reaction {left}");
    assert_eq!(*col("kinetic_energy").last().unwrap(), 0.0);
}

/// Kirsch's infinite plate (hole radius `a`, σ along x): σ_θθ on θ = 90°,
/// which is σ_xx on x = 0, and on θ = 0, σ_yy on y = 0, at radius r.
fn kirsch(a: f64, r: f64) -> (f64, f64) {
    let q = (a / r).powi(2);
    (1.0 + 0.5 * q + 1.5 * q * q, 0.5 * q - 1.5 * q * q)
}

/// (r, σ_xx/σ) on x = 0 above the hole, (r, σ_yy/σ) on y = 0 right of
/// it, and the work over the strain energy.
type KirschLines = (Vec<(f64, f64)>, Vec<(f64, f64)>, f64);

/// `dpm_plate_hole.toml` (half-width 0.16 m, spacing 1.25 mm, support 2)
/// at spacing `h`, `support` and half-width `w` (plus half a spacing, so
/// that the symmetry lines are rows of particles), without the hole when
/// `hole` is false (then a polygon, so that its particles still sit at
/// the cells' centres), solved: (r, σ_xx/σ) along x = 0 above the hole
/// and (r, σ_yy/σ) along y = 0 right of it, by r; and the two tractions'
/// work over the strain energy.
fn kirsch_plate(h: f64, support: f64, w: f64, hole: bool) -> KirschLines {
    let half = w + 0.5 * h;
    let mut text = scene_text("dpm_plate_hole.toml")
        .replace("cell_size = 1.25e-3", &format!("cell_size = {h:e}"))
        .replace("0.160625", &format!("{half:e}"))
        .replace("support = 2.0", &format!("support = {support:e}"));
    if !hole {
        let (b, e) = (
            text.find("shape = { type = \"box\"").unwrap(),
            text.find("material = \"steel\"").unwrap(),
        );
        text.replace_range(
            b..e,
            &format!("shape = {{ type = \"polygon\", vertices = [[-{half:e}, -{half:e}], [{half:e}, -{half:e}], [{half:e}, {half:e}], [-{half:e}, {half:e}]] }}\n"),
        );
    }
    let scene = Scene::from_text(&text, None).unwrap();
    let rec = solved(&scene);
    let snap = rec.snapshots.last().unwrap();
    // 2D: displacement x y; stress xx yy xy zz
    let s = field(snap, "stress");
    let d = field(snap, "displacement");
    assert_eq!(s.len(), 4 * snap.positions.len());
    let sigma = 1.0e6;
    let (mut on_y, mut on_x) = (Vec::new(), Vec::new());
    for (p, q) in snap.positions.iter().enumerate() {
        let (x0, y0) = (q[0] - d[2 * p], q[1] - d[2 * p + 1]);
        if x0.abs() < 0.25 * h && y0 > 0.0 {
            on_y.push((y0, s[4 * p] / sigma));
        }
        if y0.abs() < 0.25 * h && x0 > 0.0 {
            on_x.push((x0, s[4 * p + 1] / sigma));
        }
    }
    on_y.sort_by(|a, b| a.0.total_cmp(&b.0));
    on_x.sort_by(|a, b| a.0.total_cmp(&b.0));
    let col = |name: &str| *rec.column(name).unwrap().last().unwrap();
    (on_y, on_x, col("external_work") / col("strain_energy"))
}

#[test]
fn a_plate_with_a_hole_carries_kirsch_s_stress() {
    // a body that is not a box: its particles at the centres of the cells
    // inside it (a staircase about the hole, a/h = 8.32), support 2. Pulled
    // by σ on both sides and held only on its symmetry lines. Along x = 0
    // σ_xx, along y = 0 σ_yy follow Kirsch's infinite plate. With
    // DPM_KIRSCH_CSV set, the two lines are written there for
    // docs/scripts/dpm_kirsch.py
    let scene = Scene::from_text(&scene_text("dpm_plate_hole.toml"), None).unwrap();
    // the cells whose centre (i h, j h) lies outside the hole
    let (h, a) = (1.25e-3, 0.0104);
    let outside = (-128i64..=128)
        .flat_map(|i| (-128i64..=128).map(move |j| (i, j)))
        .filter(|&(i, j)| ((i * i + j * j) as f64).sqrt() * h > a)
        .count();
    assert_eq!(scene.total_particles(), outside);
    let (on_y, on_x, books) = kirsch_plate(h, 2.0, 0.16, true);
    assert_eq!((on_y.len(), on_x.len()), (128 - 8, 128 - 8));
    let mut csv = String::from("r_over_a,sxx_over_sigma,kirsch_xx,syy_over_sigma,kirsch_yy\n");
    for (&(r, sxx), &(rx, syy)) in on_y.iter().zip(&on_x) {
        assert!((r - rx).abs() < 1e-12);
        let (kxx, kyy) = kirsch(a, r);
        csv += &format!("{},{sxx},{kxx},{syy},{kyy}\n", r / a);
    }
    if let Ok(path) = std::env::var("DPM_KIRSCH_CSV") {
        std::fs::write(&path, &csv).unwrap();
    }
    // away from the staircase (r ≥ 2a) Kirsch's stresses, within what the
    // finite plate's edges add (about (a/W)², docs/dpm.md; measured: 2.6 %
    // and 0.046 σ)
    let (mut far_xx, mut far_yy) = (0.0f64, 0.0f64);
    for (&(r, sxx), &(_, syy)) in on_y.iter().zip(&on_x) {
        if r >= 2.0 * a {
            let (kxx, kyy) = kirsch(a, r);
            far_xx = far_xx.max((sxx / kxx - 1.0).abs());
            far_yy = far_yy.max((syy - kyy).abs());
        }
    }
    // the ligament above the hole carries the half-plate's load: cells
    // of height h from the hole's staircase to the top edge, W + h/2
    let carried: f64 = on_y.iter().map(|p| p.1 * h).sum();
    let load = 0.16 + 0.5 * h;
    // and the line right of the hole no net σ_yy (the quarter plate's
    // balance along y: its other edges carry no shear, the hole nothing)
    let across: f64 = on_x.iter().map(|p| p.1 * h).sum();
    eprintln!(
        "r ≥ 2a: σxx off Kirsch by {:.2} % at most, σyy by {far_yy:.4} σ; next to the hole σxx {:.3} σ (Kirsch at the particle {:.3}); ligament carries {:.5} of its load; Σ σyy h {:.2e} σ W",
        100.0 * far_xx,
        on_y[0].1,
        kirsch(a, on_y[0].0).0,
        carried / load,
        across / 0.16
    );
    assert!(far_xx < 0.04, "σxx off Kirsch by {far_xx}");
    assert!(far_yy < 0.06, "σyy off Kirsch by {far_yy} σ");
    // next to the hole the staircase's steps decide (docs/dpm.md): a
    // concentration, not Kirsch's value at the particle
    assert!(on_y[0].1 > 1.5, "σxx next to the hole {}", on_y[0].1);
    assert!(
        (carried / load - 1.0).abs() < 0.01,
        "the ligament carries {carried} of {load}"
    );
    assert!(across.abs() < 0.01 * 0.16, "Σ σyy h = {across}");
    // the plate's books: the two tractions' work is the strain energy
    assert!(
        (books - 1.0).abs() < 1e-9,
        "work over strain energy {books}"
    );
}

/// The study behind docs/dpm.md's Kirsch table: three spacings, three
/// plate sizes, three supports and the plate without its hole (`cargo
/// test --release --test engine dpm::kirsch_study -- --ignored
/// --nocapture`, about a minute).
#[test]
#[ignore]
fn kirsch_study() {
    let a = 0.0104;
    eprintln!("| a/h | support | half-width, m | hole | particles on the line | σxx next to the hole | worst σxx/Kirsch − 1 for r ≥ 1.5a | σxx at the top edge | σyy at the loaded edge | worst |σyy − Kirsch| for r ≥ 1.5a |");
    for (h, support, w, hole) in [
        // the spacing, at half-width 0.08
        (2.5e-3, 2.0, 0.08, true),
        (1.25e-3, 2.0, 0.08, true),
        (6.25e-4, 2.0, 0.08, true),
        // the plate's size, at a/h = 4.16
        (2.5e-3, 2.0, 0.16, true),
        (2.5e-3, 2.0, 0.32, true),
        // the scene, then its support
        (1.25e-3, 2.0, 0.16, true),
        (1.25e-3, 2.5, 0.16, true),
        (1.25e-3, 3.0, 0.16, true),
        // no hole
        (1.25e-3, 2.0, 0.16, false),
    ] {
        let (on_y, on_x, books) = kirsch_plate(h, support, w, hole);
        let kirsch = |a: f64, r: f64| if hole { kirsch(a, r) } else { (1.0, 0.0) };
        assert!((books - 1.0).abs() < 1e-9);
        let far_xx = on_y
            .iter()
            .filter(|p| p.0 >= 1.5 * a)
            .map(|&(r, s)| (s / kirsch(a, r).0 - 1.0).abs())
            .fold(0.0, f64::max);
        let far_yy = on_x
            .iter()
            .filter(|p| p.0 >= 1.5 * a)
            .map(|&(r, s)| (s - kirsch(a, r).1).abs())
            .fold(0.0, f64::max);
        eprintln!(
            "| {} | {support} | {w} | {hole} | {} | {:.3} (Kirsch {:.3}) | {:.4} | {:.4} | {:.4} | {:.4} |",
            a / h,
            on_y.len(),
            on_y[0].1,
            kirsch(a, on_y[0].0).0,
            far_xx,
            on_y.last().unwrap().1,
            on_x.last().unwrap().1,
            far_yy
        );
    }
}

#[test]
fn a_cylinder_pulled_at_both_ends_is_the_patch_test_in_3d() {
    // a 3D body that is not a box: a cylinder along x, its particles at
    // the centres of the cells inside it (a staircase of 37 cells in
    // section), both ends pulled by σ, held only on its three symmetry
    // planes (the particles on x = 5.5, y = 0, z = 0 keep that
    // component). Uniaxial stress: every particle's displacement is the
    // linear field u = (σ/E)(x − 5.5, −ν y, −ν z), which the RK functions
    // reproduce, SCNI integrates and the tractions balance particle by
    // particle, so the static solution is that field to round-off
    let text = r#"
method = "damage_particle"
[grid]
cell_size = 1.0
min = [0.0, -3.5, -3.5]
max = [11.0, 3.5, 3.5]
[grid.boundary]
left = { type = "traction", normal = 2.0e6 }
right = { type = "traction", normal = 2.0e6 }
[time]
end = 1.0
dt = 1.0
[materials.m]
model = "linear_elastic"
density = 1000.0
youngs_modulus = 1.0e9
poissons_ratio = 0.25
[[bodies]]
shape = { type = "cylinder", start = [0.0, 0.0, 0.0], end = [11.0, 0.0, 0.0], radius = 3.2 }
material = "m"
[damage_particle]
support = 2.0
integration = "static"
[[damage_particle.held]]
shape = { type = "box", min = [5.4, -3.5, -3.5], max = [5.6, 3.5, 3.5] }
x = 0.0
[[damage_particle.held]]
shape = { type = "box", min = [0.0, -0.1, -3.5], max = [11.0, 0.1, 3.5] }
y = 0.0
[[damage_particle.held]]
shape = { type = "box", min = [0.0, -3.5, -0.1], max = [11.0, 3.5, 0.1] }
z = 0.0
[output]
series_rows = 2
snapshots = 2
"#;
    let scene = Scene::from_text(text, None).unwrap();
    assert_eq!(scene.dimension(), 3);
    // the cells whose centre lies within 3.2 of the axis: 37 per section
    assert_eq!(scene.total_particles(), 11 * 37);
    let rec = solved(&scene);
    let snap = rec.snapshots.last().unwrap();
    let d = field(snap, "displacement");
    let s = field(snap, "stress");
    let (sigma, e, nu) = (2.0e6, 1.0e9, 0.25);
    let eps = sigma / e;
    let mut worst = 0.0f64;
    let mut worst_stress = 0.0f64;
    for (p, q) in snap.positions.iter().enumerate() {
        let x0: [f64; 3] = std::array::from_fn(|k| q[k] - d[3 * p + k]);
        let want = [eps * (x0[0] - 5.5), -nu * eps * x0[1], -nu * eps * x0[2]];
        for k in 0..3 {
            worst = worst.max((d[3 * p + k] - want[k]).abs());
        }
        let want_s = [sigma, 0.0, 0.0, 0.0, 0.0, 0.0];
        for k in 0..6 {
            worst_stress = worst_stress.max((s[6 * p + k] - want_s[k]).abs());
        }
    }
    eprintln!(
        "worst displacement error {worst:.3e} m of {:.3e}, worst stress error {worst_stress:.3e} Pa",
        eps * 5.5
    );
    assert!(worst < 1e-9 * eps * 5.5, "displacement off by {worst}");
    assert!(worst_stress < 1e-8 * sigma, "stress off by {worst_stress}");
}

#[test]
fn a_crack_across_a_body_that_is_not_a_box_parts_it() {
    // a polygon plate (its particles at the cells' centres) cut from edge
    // to edge along the faces between two columns of cells: the crack's
    // ends lie outside the body, so neither is a tip and the faces are
    // cut outright. Its right half pulled by its wall,
    // its left half feels nothing: not a single bit of displacement
    let text = r#"
method = "damage_particle"
[grid]
cell_size = 1.0e-3
min = [0.0, 0.0]
max = [0.02, 0.01]
[grid.boundary]
right = { type = "velocity", x = 1.0, y = 0.0 }
[analysis]
plane = "plane_strain"
[time]
end = 8.0e-6
cfl = 0.4
[materials.m]
model = "linear_elastic"
density = 2450.0
youngs_modulus = 3.2e10
poissons_ratio = 0.2
[[bodies]]
shape = { type = "polygon", vertices = [[0.0, 0.0], [0.02, 0.0], [0.02, 0.01], [0.0, 0.01]] }
material = "m"
cracks = [{ points = [[0.01, -0.001], [0.01, 0.011]] }]
[damage_particle]
support = 2.0
[output]
series_rows = 2
snapshots = 2
"#;
    // the pulled half's wave reaches the crack after about 2.7 μs
    let largest = |text: &str| {
        let scene = Scene::from_text(text, None).unwrap();
        assert_eq!(scene.total_particles(), 200);
        let rec = solved(&scene);
        let snap = rec.snapshots.last().unwrap();
        let d = field(snap, "displacement");
        let (mut left, mut right) = (0.0f64, 0.0f64);
        for (p, q) in snap.positions.iter().enumerate() {
            let u = d[2 * p].abs().max(d[2 * p + 1].abs());
            if q[0] < 0.01 {
                left = left.max(u);
            } else {
                right = right.max(u);
            }
        }
        (left, right)
    };
    let (left, right) = largest(text);
    // the same crack stopping inside the body: its upper end is a tip,
    // and the halves stay joined above it
    let (joined, _) = largest(&text.replace("[0.01, 0.011]", "[0.01, 0.0065]"));
    eprintln!(
        "largest displacement: left {left:e} m, right {right:e} m; with a tip, left {joined:e} m"
    );
    assert_eq!(left, 0.0, "the cut-off half moved");
    assert!(right > 1e-7, "the pulled half did not move: {right}");
    assert!(
        joined > 1e-7,
        "the half joined above the tip did not move: {joined}"
    );
}
