//! 3D scenes (issue 32, the scene side): a scene whose `grid.max` has
//! three components describes a 3D problem; it validates with errors that
//! name their field, seeds its bodies, and runs the explicit core,
//! continuum damage, DFG partitioning, the phase field, initial cracks
//! (flat polygons), crack tips and snapshots; what is still 2D (a phase
//! field's material angle, the damage particle method's cracks) is refused
//! naming its key. 2D scenes serialise as before.

use cleave::jobs::{JobConfig, JobError, JobManager};
use cleave::scene::{Format, Scene, SceneError};

/// A small valid 3D scene: a 0.4 × 0.3 × 0.2 m block, its faces on the
/// cells' boundaries (h = 0.05 m), with the default particles per cell.
const BLOCK: &str = r#"
[grid]
cell_size = 0.05
min = [0.0, 0.0, 0.0]
max = [0.6, 0.5, 0.4]
boundary = { bottom = "fixed", back = "roller", front = { type = "velocity", z = -0.1 } }

[time]
end = 1e-3

[[bodies]]
shape = { type = "box", min = [0.1, 0.1, 0.1], max = [0.5, 0.4, 0.3] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity = [0.0, 0.0, -1.0]
"#;

/// A small valid 2D scene.
const FLAT: &str = r#"
[grid]
cell_size = 0.05
max = [0.6, 0.5]

[time]
end = 1e-3

[[bodies]]
shape = { type = "box", min = [0.1, 0.1], max = [0.5, 0.4] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
"#;

fn errors(text: &str) -> SceneError {
    match Scene::from_text(text, Some(Format::Toml)) {
        Ok(s) => panic!(
            "expected a refusal, it validated with {} particles:\n{text}",
            s.total_particles()
        ),
        Err(e) => e,
    }
}

/// `text`'s refusal has an entry at `path` whose reason contains `why`.
fn refused_at(text: &str, path: &str, why: &str) {
    let e = errors(text);
    assert!(
        e.errors
            .iter()
            .any(|f| f.path == path && f.reason.contains(why)),
        "expected `{path}: ...{why}...` in:\n{e}\nfor:\n{text}"
    );
}

fn replace(text: &str, from: &str, to: &str) -> String {
    assert!(text.contains(from), "{from:?} not in the scene");
    text.replacen(from, to, 1)
}

#[test]
fn a_3d_block_validates_with_its_particle_count() {
    let scene = Scene::from_text(BLOCK, Some(Format::Toml)).unwrap();
    assert_eq!(scene.dimension(), 3);
    assert_eq!(scene.cell_counts(), vec![12, 10, 8]);
    // 8 x 6 x 4 cells of 8 particles (the 3D default, 2 per direction)
    assert_eq!(scene.total_particles(), 8 * 6 * 4 * 8);
    assert_eq!(scene.file.bodies[0].particles_per_cell, Some(8));
    assert_eq!(scene.particle_spacing(0), 0.025);
    assert!(scene.memory.particles > 0 && scene.memory.grid > 0);
    // the wave speed is the 3D dilatational one, √((λ+2μ)/ρ), plus |v|
    let (e, nu, rho): (f64, f64, f64) = (1.0e6, 0.3, 1000.0);
    let c = (e * (1.0 - nu) / ((1.0 + nu) * (1.0 - 2.0 * nu) * rho)).sqrt();
    assert!((scene.time_step.signal_speed - (c + 1.0)).abs() < 1e-9 * c);
}

/// A spherical hole takes exactly the lattice points inside it, counted
/// here point by point (without the seeding's row tests), and 27
/// particles per cell put 3 per direction.
#[test]
fn a_3d_block_with_a_spherical_hole_loses_the_lattice_points_in_it() {
    let text = replace(
        BLOCK,
        "velocity = [0.0, 0.0, -1.0]",
        "velocity = [0.0, 0.0, -1.0]\nparticles_per_cell = 27\nholes = [{ type = \"sphere\", center = [0.3, 0.25, 0.2], radius = 0.08 }]",
    );
    let scene = Scene::from_text(&text, Some(Format::Toml)).unwrap();
    let s = 0.05 / 3.0;
    let mut inside = 0;
    for i in 0..24 {
        for j in 0..18 {
            for k in 0..12 {
                let p = [
                    0.1 + (i as f64 + 0.5) * s,
                    0.1 + (j as f64 + 0.5) * s,
                    0.1 + (k as f64 + 0.5) * s,
                ];
                let d2 = (p[0] - 0.3).powi(2) + (p[1] - 0.25).powi(2) + (p[2] - 0.2).powi(2);
                if d2 <= 0.08 * 0.08 {
                    inside += 1;
                }
            }
        }
    }
    assert!(inside > 400, "{inside}");
    assert_eq!(scene.total_particles(), 24 * 18 * 12 - inside);
    // and the hole's share is its volume over s³, to a few per cent
    let hole = 4.0 / 3.0 * std::f64::consts::PI * 0.08f64.powi(3) / s.powi(3);
    assert!(
        (inside as f64 - hole).abs() < 0.05 * hole,
        "{inside} vs {hole}"
    );
}

#[test]
fn every_3d_shape_validates_as_a_body() {
    for shape in [
        "{ type = \"sphere\", center = [0.3, 0.25, 0.2], radius = 0.15 }",
        "{ type = \"cylinder\", start = [0.1, 0.1, 0.1], end = [0.5, 0.4, 0.3], radius = 0.05 }",
        "{ type = \"prism\", vertices = [[0.1, 0.1], [0.5, 0.1], [0.3, 0.4]], z_min = 0.1, z_max = 0.3 }",
    ] {
        let text = replace(
            BLOCK,
            "{ type = \"box\", min = [0.1, 0.1, 0.1], max = [0.5, 0.4, 0.3] }",
            shape,
        );
        let scene = Scene::from_text(&text, Some(Format::Toml))
            .unwrap_or_else(|e| panic!("{shape}: {e}"));
        assert!(scene.total_particles() > 100, "{shape}");
    }
}

/// A validated scene serialises with its defaults written in, and reads
/// back to the same scene: in 2D with every key a 2D scene always had
/// (a checkpoint compares them), in 3D without the 2D-only ones.
#[test]
fn validated_scenes_serialise_and_read_back() {
    let flat = Scene::from_text(FLAT, Some(Format::Toml)).unwrap();
    let json = serde_json::to_string(&flat.file).unwrap();
    for key in [
        r#""min":[0.0,0.0]"#,
        r#""boundary":{"left":{"type":"free"},"right":{"type":"free"},"bottom":{"type":"free"},"top":{"type":"free"}}"#,
        r#""analysis":{"plane":"plane_strain","thickness":1.0}"#,
        r#""particles_per_cell":4,"velocity":[0.0,0.0],"velocity_gradient":[[0.0,0.0],[0.0,0.0]],"velocity_origin":null"#,
        r#""body_force":[0.0,0.0]"#,
    ] {
        assert!(json.contains(key), "{key} not in {json}");
    }
    let back = Scene::from_text(&json, Some(Format::Json)).unwrap();
    assert_eq!(serde_json::to_string(&back.file).unwrap(), json);

    let block = Scene::from_text(BLOCK, Some(Format::Toml)).unwrap();
    let json = serde_json::to_string(&block.file).unwrap();
    for key in [
        r#""analysis":{}"#,
        r#""back":{"type":"roller"},"front":{"type":"velocity","x":null,"y":null,"z":-0.1}"#,
        r#""velocity_gradient":[[0.0,0.0,0.0],[0.0,0.0,0.0],[0.0,0.0,0.0]]"#,
        r#""body_force":[0.0,0.0,0.0]"#,
    ] {
        assert!(json.contains(key), "{key} not in {json}");
    }
    let back = Scene::from_text(&json, Some(Format::Json)).unwrap();
    assert_eq!(serde_json::to_string(&back.file).unwrap(), json);
    assert_eq!(back.total_particles(), block.total_particles());
}

#[test]
fn a_vector_of_the_wrong_length_is_refused_at_its_field() {
    // not 2 or 3 numbers: a parse error at the field's path
    let e = errors(&replace(
        BLOCK,
        "velocity = [0.0, 0.0, -1.0]",
        "velocity = [0.0, 0.0, -1.0, 2.0]",
    ));
    assert_eq!(e.errors[0].path, "bodies[0].velocity", "{e}");
    assert!(e.errors[0].reason.contains("3 numbers [x, y, z]"), "{e}");
    // 2 numbers in a 3D scene, 3 in a 2D one
    refused_at(
        &replace(
            BLOCK,
            "velocity = [0.0, 0.0, -1.0]",
            "velocity = [0.0, -1.0]",
        ),
        "bodies[0].velocity",
        "has 2 components, but the grid is 3D",
    );
    refused_at(
        &format!("body_force = [0.0, -9.81]\n{BLOCK}"),
        "body_force",
        "has 2 components, but the grid is 3D",
    );
    refused_at(
        &format!("body_force = [0.0, -9.81, 0.0]\n{FLAT}"),
        "body_force",
        "has 3 components, but the grid is 2D",
    );
    refused_at(
        &replace(BLOCK, "min = [0.0, 0.0, 0.0]", "min = [0.0, 0.0]"),
        "grid.min",
        "has 2 components, but the grid is 3D",
    );
    refused_at(
        &replace(
            BLOCK,
            "velocity = [0.0, 0.0, -1.0]",
            "velocity_gradient = [[0.0, 1.0], [-1.0, 0.0]]",
        ),
        "bodies[0].velocity_gradient",
        "has 2 rows, but the grid is 3D",
    );
    refused_at(
        &replace(
            BLOCK,
            "velocity = [0.0, 0.0, -1.0]",
            "velocity_gradient = [[0.0, 1.0, 0.0], [-1.0, 0.0], [0.0, 0.0, 0.0]]",
        ),
        "bodies[0].velocity_gradient[1]",
        "has 2 components",
    );
    refused_at(
        &replace(
            BLOCK,
            "velocity = [0.0, 0.0, -1.0]",
            "velocity_origin = [0.3, 0.2]",
        ),
        "bodies[0].velocity_origin",
        "has 2 components",
    );
    refused_at(
        &replace(FLAT, "max = [0.5, 0.4] }", "max = [0.5, 0.4, 0.3] }"),
        "bodies[0].shape.max",
        "has 3 components, but the grid is 2D",
    );
    // a damage body's crack and tip origin: 3 components in 3D
    let damaged = replace(
        BLOCK,
        "poissons_ratio = 0.3 }",
        "poissons_ratio = 0.3, damage = { model = \"rankine\", strength = 1.0e4, fracture_energy = 10.0 } }\ncracks = [{ points = [[0.2, 0.2, 0.2], [0.3, 0.2]] }]\ncrack_origin = [0.2, 0.2]",
    );
    refused_at(
        &damaged,
        "bodies[0].cracks[0].points[1]",
        "has 2 components",
    );
    refused_at(&damaged, "bodies[0].crack_origin", "has 2 components");
    // a 3D crack is a flat polygon: three points or more, in one plane,
    // enclosing an area
    let crack = |points: &str| {
        replace(
            BLOCK,
            "poissons_ratio = 0.3 }",
            &format!("poissons_ratio = 0.3, damage = {{ model = \"rankine\", strength = 1.0e4, fracture_energy = 10.0 }} }}\ncracks = [{{ points = {points} }}]"),
        )
    };
    refused_at(
        &crack("[[0.2, 0.2, 0.2], [0.3, 0.2, 0.2]]"),
        "bodies[0].cracks[0].points",
        "at least 3 points, got 2",
    );
    refused_at(
        &crack("[[0.2, 0.2, 0.2], [0.3, 0.2, 0.2], [0.4, 0.2, 0.2]]"),
        "bodies[0].cracks[0].points",
        "no area",
    );
    refused_at(
        &crack("[[0.3, 0.1, 0.1], [0.3, 0.25, 0.1], [0.3, 0.25, 0.3], [0.31, 0.1, 0.3]]"),
        "bodies[0].cracks[0].points",
        "off the plane",
    );
    let flat = crack("[[0.3, 0.1, 0.1], [0.3, 0.25, 0.1], [0.3, 0.25, 0.3], [0.3, 0.1, 0.3]]");
    Scene::from_text(&flat, Some(Format::Toml)).expect("a flat 3D crack validates");
}

#[test]
fn two_d_keys_are_refused_in_3d_and_3d_keys_in_2d() {
    refused_at(
        &format!("[analysis]\nplane = \"plane_strain\"\n{BLOCK}"),
        "analysis.plane",
        "is a 2D setting",
    );
    refused_at(
        &format!("[analysis]\nthickness = 0.01\n{BLOCK}"),
        "analysis.thickness",
        "but the grid is 3D",
    );
    for (shape, type_name) in [
        (
            "{ type = \"disk\", center = [0.3, 0.25], radius = 0.1 }",
            "disk",
        ),
        (
            "{ type = \"ring\", center = [0.3, 0.25], inner_radius = 0.05, outer_radius = 0.1 }",
            "ring",
        ),
        (
            "{ type = \"polygon\", vertices = [[0.1, 0.1], [0.5, 0.1], [0.3, 0.4]] }",
            "polygon",
        ),
        (
            "{ type = \"slot\", start = [0.1, 0.1], end = [0.5, 0.1], width = 0.05 }",
            "slot",
        ),
    ] {
        let text = replace(
            BLOCK,
            "{ type = \"box\", min = [0.1, 0.1, 0.1], max = [0.5, 0.4, 0.3] }",
            shape,
        );
        refused_at(
            &text,
            "bodies[0].shape.type",
            &format!("{type_name} is a 2D shape, but the grid is 3D"),
        );
    }
    for (shape, type_name) in [
        ("{ type = \"sphere\", center = [0.3, 0.25, 0.2], radius = 0.1 }", "sphere"),
        ("{ type = \"cylinder\", start = [0.1, 0.1, 0.1], end = [0.5, 0.4, 0.3], radius = 0.05 }", "cylinder"),
        ("{ type = \"prism\", vertices = [[0.1, 0.1], [0.5, 0.1], [0.3, 0.4]], z_min = 0.0, z_max = 0.1 }", "prism"),
    ] {
        let text = replace(FLAT, "[[bodies]]", &format!("[[bodies]]\nholes = [{shape}]"));
        refused_at(
            &text,
            "bodies[0].holes[0].type",
            &format!("{type_name} is a 3D shape, but the grid is 2D"),
        );
    }
    for side in ["back", "front"] {
        refused_at(
            &replace(
                FLAT,
                "max = [0.6, 0.5]",
                &format!("max = [0.6, 0.5]\nboundary = {{ {side} = \"fixed\" }}"),
            ),
            &format!("grid.boundary.{side}"),
            "the grid is 2D",
        );
    }
    refused_at(
        &replace(
            FLAT,
            "max = [0.6, 0.5]",
            "max = [0.6, 0.5]\nboundary = { top = { type = \"velocity\", z = 1.0 } }",
        ),
        "grid.boundary.top.z",
        "needs a 3D grid",
    );
    // a 3D wall takes the 2D walls' conditions, and their checks
    refused_at(
        &replace(
            BLOCK,
            "front = { type = \"velocity\", z = -0.1 }",
            "front = { type = \"velocity\" }",
        ),
        "grid.boundary.front",
        "needs `x`, `y` and/or `z`",
    );
    refused_at(
        &replace(BLOCK, "back = \"roller\"", "back = \"sticky\""),
        "grid.boundary.back",
        "unknown variant",
    );
}

#[test]
fn particles_per_cell_is_a_perfect_cube_in_3d() {
    for ppc in [4, 9, 16, 125] {
        refused_at(
            &replace(
                BLOCK,
                "[[bodies]]",
                &format!("[[bodies]]\nparticles_per_cell = {ppc}"),
            ),
            "bodies[0].particles_per_cell",
            "must be a perfect cube from 1 to 64",
        );
    }
    for ppc in [1, 8, 27, 64] {
        let text = replace(
            BLOCK,
            "[[bodies]]",
            &format!("[[bodies]]\nparticles_per_cell = {ppc}"),
        );
        let scene = Scene::from_text(&text, Some(Format::Toml)).unwrap();
        assert_eq!(scene.total_particles(), 8 * 6 * 4 * ppc);
    }
}

#[test]
fn bad_3d_shapes_name_their_field() {
    let with = |shape: &str| {
        replace(
            BLOCK,
            "{ type = \"box\", min = [0.1, 0.1, 0.1], max = [0.5, 0.4, 0.3] }",
            shape,
        )
    };
    refused_at(
        &with("{ type = \"sphere\", center = [0.3, 0.25, 0.2], radius = -0.1 }"),
        "bodies[0].shape.radius",
        "must be > 0",
    );
    refused_at(
        &with("{ type = \"cylinder\", start = [0.1, 0.1, 0.1], end = [0.1, 0.1, 0.1], radius = 0.05 }"),
        "bodies[0].shape.end",
        "must differ from start",
    );
    refused_at(
        &with("{ type = \"prism\", vertices = [[0.1, 0.1], [0.5, 0.1], [0.3, 0.4]], z_min = 0.3, z_max = 0.1 }"),
        "bodies[0].shape.z_max",
        "must exceed z_min",
    );
    refused_at(
        &with(
            "{ type = \"prism\", vertices = [[0.1, 0.1], [0.5, 0.1]], z_min = 0.1, z_max = 0.3 }",
        ),
        "bodies[0].shape.vertices",
        "at least 3 vertices",
    );
    refused_at(
        &with("{ type = \"box\", min = [0.1, 0.1, 0.3], max = [0.5, 0.4, 0.1] }"),
        "bodies[0].shape",
        "max must exceed min in x, y and z",
    );
    refused_at(
        &with("{ type = \"sphere\", center = [0.3, 0.25, 0.35], radius = 0.1 }"),
        "bodies[0].shape",
        "extends outside the grid along z",
    );
}

/// A 3D scene runs the explicit core (and writes its snapshots), continuum
/// damage, DFG partitioning and the phase field, but what is still 2D is
/// refused, naming its key: here a phase field's material angle and a
/// crack origin. A server's submit refuses it alike.
#[test]
fn a_3d_scene_with_what_is_still_2d_is_refused_by_the_methods_and_the_job_queue() {
    let scene = Scene::from_text(BLOCK, Some(Format::Toml)).unwrap();
    let mut run = cleave::methods::build(&scene).expect("a 3D scene runs");
    run.step().expect("a 3D step");
    assert_eq!(run.particle_count(), 8 * 6 * 4 * 8);
    let quiet = BLOCK.to_string();
    let phase_field = BLOCK.replace(
        "poissons_ratio = 0.3 }",
        "poissons_ratio = 0.3, phase_field = { gc = 1.0, l0 = 0.1, angle = 30.0 } }",
    );
    let scene = Scene::from_text(&phase_field, Some(Format::Toml))
        .expect("a 3D phase-field scene validates");
    match cleave::methods::build(&scene) {
        Ok(_) => panic!("a 3D phase field with a material angle was built"),
        Err(e) => {
            assert_eq!(
                e.errors[0].path, "bodies[0].material.phase_field.angle",
                "{e}"
            );
            assert!(e.errors[0].reason.contains("not run yet"), "{e}");
        }
    }
    // continuum damage runs in 3D
    let damaged = quiet.replace(
        "poissons_ratio = 0.3 }",
        "poissons_ratio = 0.3, damage = { model = \"rankine\", strength = 1.0e4, fracture_energy = 10.0 } }",
    );
    let scene =
        Scene::from_text(&damaged, Some(Format::Toml)).expect("a 3D damage scene validates");
    let mut run = cleave::methods::build(&scene).expect("a 3D damage scene runs");
    run.step().expect("a 3D step with damage");
    // and DFG partitioning on top of it
    let scene = Scene::from_text(&format!("{damaged}\n[dfg]\n"), Some(Format::Toml))
        .expect("a 3D DFG scene validates");
    let mut run = cleave::methods::build(&scene).expect("a 3D DFG scene runs");
    run.step().expect("a 3D step with DFG");
    // an initial crack (a flat polygon) and a tracked crack tip run in 3D:
    // the particles on the face start broken, the tip has three coordinates
    let text = damaged.replace(
        "velocity = [0.0, 0.0, -1.0]",
        "velocity = [0.0, 0.0, -1.0]\ncrack_origin = [0.3, 0.1, 0.2]\n\
         cracks = [{ points = [[0.3, 0.1, 0.1], [0.3, 0.25, 0.1], [0.3, 0.25, 0.3], [0.3, 0.1, 0.3]] }]",
    );
    let scene = Scene::from_text(&text, Some(Format::Toml)).expect("the 3D scene validates");
    let mut run = cleave::methods::build(&scene).expect("a 3D crack runs");
    let columns = run.series_columns();
    let tip: Vec<&str> = columns
        .iter()
        .filter(|c| c.starts_with("crack_"))
        .map(|c| c.as_str())
        .collect();
    assert_eq!(
        tip,
        [
            "crack_tip_x",
            "crack_tip_y",
            "crack_tip_z",
            "crack_length",
            "crack_speed"
        ]
    );
    run.step().expect("a 3D step with an initial crack");
    let flat = Scene::from_text(FLAT, Some(Format::Toml)).unwrap();
    assert!(cleave::methods::build(&flat).is_ok());

    let dir = tempfile::tempdir().unwrap();
    let jobs = JobManager::start(JobConfig {
        data_dir: dir.path().to_path_buf(),
        max_concurrent: 1,
        threads_per_job: 1,
        max_particles: 1_000_000,
        max_memory: None,
        max_queued: 4,
        store: cleave::jobs::StoreSpec::Sqlite,
        results: cleave::jobs::ResultsSpec::DataDir,
        checkpoint_every: None,
    })
    .unwrap();
    match jobs.submit(&phase_field, Some(Format::Toml), "block") {
        Err(JobError::Invalid(e)) => {
            assert_eq!(
                e.errors[0].path, "bodies[0].material.phase_field.angle",
                "{e}"
            );
        }
        other => panic!("expected a refusal naming the phase field, got {other:?}"),
    }
}
