//! The plan a scene prints is the list its step runs: for every shipped
//! scene, two steps run exactly the plan's stages, in the plan's order,
//! each once per step, and its series has a value for every column.

use cleave::diagnostics::SeriesRow;
use cleave::mpm::Simulation;
use cleave::run::Method;
use cleave::scene::{Scene, Stage};

#[test]
fn every_shipped_scene_runs_the_plan_it_prints() {
    let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut paths: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    paths.sort();
    assert!(paths.len() >= 20, "{} scenes", paths.len());
    for path in paths {
        let mut scene = Scene::from_path(&path).unwrap();
        // two whole steps of the scene's size, even where it ends sooner
        scene.file.time.end *= 1e6;
        // each scene by its method, in its own dimension
        // (two_spheres_3d.toml is 3D, dpm_bar.toml the damage particle method)
        runs_its_plan(cleave::methods::build(&scene).unwrap(), &scene, &path);
    }
}

/// Two steps of `sim`: the stages that ran are the plan's, the series
/// columns match a row, and the method's core stages are there.
fn runs_its_plan(mut sim: Box<dyn Method>, scene: &Scene, path: &std::path::Path) {
    for _ in 0..2 {
        sim.step()
            .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    }
    let ran: Vec<(Stage, u64)> = sim
        .stage_times()
        .stages
        .iter()
        .map(|t| (t.stage, t.runs))
        .collect();
    let planned: Vec<(Stage, u64)> = scene.plan.stages.iter().map(|&s| (s, 2)).collect();
    assert_eq!(ran, planned, "{}", path.display());
    // the fracture models declare and fill their columns in one function
    let columns = sim.series_columns();
    let row = sim.row();
    assert_eq!(
        columns.len(),
        SeriesRow::COLUMNS.len() + row.extra.len(),
        "{}: {columns:?}",
        path.display()
    );
    if sim.name() == "damage_particle" {
        // central differences' two halves about the strain, or a static
        // solve's load and equilibrium; no grid
        let explicit = [Stage::DpmAdvance, Stage::DpmStrain, Stage::DpmForce];
        let statics = [Stage::DpmLoad, Stage::DpmEquilibrium];
        let has = |list: &[Stage]| list.iter().all(|&s| scene.plan.has(s));
        let has_none = |list: &[Stage]| list.iter().all(|&s| !scene.plan.has(s));
        assert!(
            (has(&explicit) && has_none(&statics)) || (has(&statics) && has_none(&explicit)),
            "{}: {:?}",
            path.display(),
            scene.plan.names()
        );
        assert!(!scene.plan.has(Stage::P2g), "{}", path.display());
        return;
    }
    // the core of every explicit step, whatever else the scene asks for
    for core in [Stage::P2g, Stage::Rebin] {
        assert!(scene.plan.has(core), "{}: no {core}", path.display());
    }
    // one stress update: USL, MUSL or Newmark's predictor–corrector
    let usl = scene.plan.has(Stage::GridUpdate) && scene.plan.has(Stage::G2p);
    let musl = scene.plan.has(Stage::GridUpdate)
        && scene.plan.has(Stage::G2pVelocity)
        && scene.plan.has(Stage::G2pStress);
    let newmark = scene.plan.has(Stage::NewmarkPredictor)
        && scene.plan.has(Stage::NewmarkCorrector)
        && scene.plan.has(Stage::NewmarkG2p);
    assert_eq!(
        [usl, musl, newmark].iter().filter(|&&b| b).count(),
        1,
        "{}: one of USL, MUSL and Newmark",
        path.display()
    );
}

/// A steel block at rest in a 0.1 m grid, with the grid's shape function
/// `kernel` and the stress update `update`: a scene with no fracture and
/// no contact.
fn steel_block(kernel: &str, update: &str) -> String {
    format!(
        r#"
[grid]
cell_size = 0.01
min = [0.0, 0.0]
max = [0.1, 0.1]
shape_function = "{kernel}"
[time]
end = 1e-6
[transfer]
stress_update = "{update}"
[materials.steel]
model = "linear_elastic"
density = 8000.0
youngs_modulus = 2.0e11
poissons_ratio = 0.3
[[bodies]]
shape = {{ type = "box", min = [0.02, 0.02], max = [0.08, 0.08] }}
material = "steel"
"#
    )
}

/// A scene without fracture or contact runs the three core stages and the
/// re-binning, nothing else; with MUSL the gather is split around the
/// remap; Newmark's predictor–corrector has its own five.
#[test]
fn a_plain_scene_runs_only_the_core_stages() {
    let text = |update: &str| steel_block("quadratic_bspline", update);
    let usl = Scene::from_text(&text("usl"), None).unwrap();
    assert_eq!(usl.plan.names(), ["p2g", "grid_update", "g2p", "rebin"]);
    let musl = Scene::from_text(&text("musl"), None).unwrap();
    assert_eq!(
        musl.plan.names(),
        [
            "p2g",
            "grid_update",
            "g2p_velocity",
            "remap",
            "g2p_stress",
            "rebin"
        ]
    );
    let mut sim = Simulation::new(&musl);
    sim.step().unwrap();
    assert!(sim.stage_times().stages.iter().all(|t| t.runs == 1));
    let newmark = Scene::from_text(&text("newmark"), None).unwrap();
    assert_eq!(
        newmark.plan.names(),
        [
            "p2g",
            "newmark_predictor",
            "newmark_stress",
            "newmark_force",
            "newmark_corrector",
            "newmark_g2p",
            "rebin"
        ]
    );
    let mut sim = Simulation::new(&newmark);
    sim.step().unwrap();
    assert!(sim.stage_times().stages.iter().all(|t| t.runs == 1));
}

/// LME shape functions add one stage before all others: every particle's
/// support, kept for the step's transfers (and only they: a B-spline scene
/// keeps nothing).
#[test]
fn lme_keeps_the_step_s_supports() {
    for update in ["usl", "musl", "newmark"] {
        let lme = Scene::from_text(&steel_block("lme", update), None).unwrap();
        assert_eq!(lme.plan.names()[0], "supports", "{update}");
        let plain = Scene::from_text(&steel_block("quadratic_bspline", update), None).unwrap();
        assert_eq!(&lme.plan.names()[1..], plain.plan.names(), "{update}");
        for (scene, kept) in [(&lme, true), (&plain, false)] {
            let mut sim = Simulation::new(scene);
            sim.step().unwrap();
            sim.step().unwrap();
            assert!(sim.stage_times().stages.iter().all(|t| t.runs == 2));
            let parts = sim.particles();
            assert_eq!(parts.supports.len(), if kept { parts.len() } else { 0 });
        }
    }
}
