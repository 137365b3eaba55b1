//! The `cleave` command line: exit codes, error messages that name the
//! field, outputs, and byte-identical results for any thread count.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

fn cleave() -> Command {
    Command::new(env!("CARGO_BIN_EXE_cleave"))
}

fn scenes() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("..")
        .join("scenes")
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// A valid scene to mutate.
const GOOD: &str = r#"
[grid]
cell_size = 0.1
max = [1.0, 1.0]

[time]
end = 0.01

[[bodies]]
shape = { type = "box", min = [0.2, 0.2], max = [0.8, 0.8] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
"#;

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).expect("write the scene");
    p
}

/// Every kind of bad input: exit code 2 from both `validate` and `run`,
/// and a message that names the field (or the file's problem).
#[test]
fn bad_input_exits_2_and_names_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let cases: Vec<(&str, Vec<u8>, &str)> = vec![
        ("empty", b"".to_vec(), "the scene is empty"),
        ("blank", b"   \n\n".to_vec(), "the scene is empty"),
        ("garbage", vec![0xff, 0xfe, 0x00, 0x12, 0x89, 0x50, 0x4e, 0x47], "not UTF-8"),
        ("nul", b"[grid]\0\0".to_vec(), "NUL"),
        ("missing grid", GOOD.replace("[grid]\ncell_size = 0.1\nmax = [1.0, 1.0]\n", "").into_bytes(), "missing field `grid`"),
        ("negative cell", GOOD.replace("cell_size = 0.1", "cell_size = -0.1").into_bytes(), "grid.cell_size: must be > 0, got -0.1"),
        ("unknown key", GOOD.replace("end = 0.01", "end = 0.01\nfinish = 3").into_bytes(), "unknown field `finish`"),
        ("unknown nested key", GOOD.replace("poissons_ratio = 0.3", "poissons_ratio = 0.3, youngs = 3").into_bytes(), "bodies[0].material"),
        ("nan", GOOD.replace("youngs_modulus = 1.0e6", "youngs_modulus = nan").into_bytes(), "bodies[0].material.youngs_modulus: must be a finite number"),
        ("negative modulus", GOOD.replace("youngs_modulus = 1.0e6", "youngs_modulus = -3").into_bytes(), "bodies[0].material.youngs_modulus: must be > 0, got -3"),
        ("poisson", GOOD.replace("poissons_ratio = 0.3", "poissons_ratio = 0.5").into_bytes(), "bodies[0].material.poissons_ratio: must be in (-1, 0.5)"),
        ("outside", GOOD.replace("max = [0.8, 0.8]", "max = [1.3, 0.8]").into_bytes(), "bodies[0].shape: extends outside the grid"),
        ("wrong type", GOOD.replace("end = 0.01", "end = \"soon\"").into_bytes(), "time.end"),
        ("unknown material", GOOD.replace("material = { model = \"linear_elastic\", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }", "material = \"steel\"").into_bytes(), "bodies[0].material: no material named `steel`"),
        ("ppc", GOOD.replace("[[bodies]]", "[[bodies]]\nparticles_per_cell = 5").into_bytes(), "bodies[0].particles_per_cell: must be a perfect square"),
        ("cfl", GOOD.replace("end = 0.01", "end = 0.01\ncfl = 1.5").into_bytes(), "time.cfl: must be <= 1"),
        ("cfl and dt", GOOD.replace("end = 0.01", "end = 0.01\ncfl = 0.5\ndt = 1e-5").into_bytes(), "time: give either `cfl` or `dt`"),
        ("negative end", GOOD.replace("end = 0.01", "end = -1.0").into_bytes(), "time.end: must be > 0"),
        ("shape type", GOOD.replace("type = \"box\"", "type = \"blob\"").into_bytes(), "bodies[0].shape"),
        ("disk radius", GOOD.replace("{ type = \"box\", min = [0.2, 0.2], max = [0.8, 0.8] }", "{ type = \"disk\", center = [0.5, 0.5], radius = -0.1 }").into_bytes(), "bodies[0].shape.radius: must be > 0"),
        ("inverted box", GOOD.replace("max = [0.8, 0.8]", "max = [0.1, 0.8]").into_bytes(), "bodies[0].shape: max must exceed min"),
        ("no bodies", GOOD.split("[[bodies]]").next().unwrap().to_string().into_bytes(), "missing field `bodies`"),
        ("grid too small", GOOD.replace("max = [1.0, 1.0]", "max = [0.05, 1.0]").into_bytes(), "grid.max[0]"),
        ("toml syntax", b"[grid\ncell_size = ".to_vec(), "line 1"),
        ("plane stress neo", GOOD.replace("model = \"linear_elastic\"", "model = \"neo_hookean\"").replace("[time]", "[analysis]\nplane = \"plane_stress\"\nthickness = 0.01\n\n[time]").into_bytes(), "bodies[0].material.model"),
        ("contact group", GOOD.replace("[time]", "[contact]\npairs = [{ groups = [0, 7], friction = 0.2 }]\n\n[time]").into_bytes(), "contact.pairs[0].groups: no body is in contact group 7"),
        ("side", GOOD.replace("max = [1.0, 1.0]", "max = [1.0, 1.0]\nboundary = { left = \"sticky\" }").into_bytes(), "grid.boundary.left"),
        ("velocity table", GOOD.replace("max = [1.0, 1.0]", "max = [1.0, 1.0]\nboundary = { left = { type = \"velocity\", x = { table = [[1.0, 0.0], [0.5, 1.0]] } } }").into_bytes(), "grid.boundary.left.x.table[1]: times must not decrease"),
    ];
    for (name, bytes, expected) in &cases {
        let path = write(
            dir.path(),
            &format!("{}.toml", name.replace(' ', "_")),
            bytes,
        );
        for cmd in ["validate", "run"] {
            let mut c = cleave();
            c.arg(cmd).arg(&path);
            if cmd == "run" {
                c.arg("--out").arg(dir.path().join("out"));
            }
            let out = c.output().unwrap();
            assert_eq!(
                out.status.code(),
                Some(2),
                "{name} ({cmd}): exit code {:?}, stderr: {}",
                out.status.code(),
                stderr(&out)
            );
            assert!(
                stderr(&out).contains(expected),
                "{name} ({cmd}): expected `{expected}` in: {}",
                stderr(&out)
            );
        }
    }
    // JSON scenes get the same treatment.
    let json = write(dir.path(), "bad.json", br#"{"grid": {"cell_size": 0.1, "max": [1, 1]}, "time": {"end": 0.01}, "bodies": [{"shape": {"type": "box", "min": [0.2, 0.2], "max": [0.8, 0.8]}, "material": {"model": "linear_elastic", "density": -1, "youngs_modulus": 1e6, "poissons_ratio": 0.3}}]}"#);
    let out = cleave().arg("validate").arg(&json).output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(
        stderr(&out).contains("bodies[0].material.density: must be > 0, got -1"),
        "{}",
        stderr(&out)
    );
    let json = write(dir.path(), "broken.json", b"{\"grid\": ");
    assert_eq!(
        cleave()
            .arg("validate")
            .arg(&json)
            .output()
            .unwrap()
            .status
            .code(),
        Some(2)
    );
    // A missing file and a bad flag are invalid input too.
    let out = cleave()
        .arg("validate")
        .arg(dir.path().join("nope.toml"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("cannot read scene file"));
    assert_eq!(
        cleave()
            .arg("run")
            .arg("--frobnicate")
            .output()
            .unwrap()
            .status
            .code(),
        Some(2)
    );
    // --json reports the errors as JSON on stdout.
    let path = write(
        dir.path(),
        "json_errors.toml",
        GOOD.replace("cell_size = 0.1", "cell_size = 0").as_bytes(),
    );
    let out = cleave()
        .args(["validate", "--json"])
        .arg(&path)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert_eq!(v["status"], "invalid");
    assert_eq!(v["errors"][0]["path"], "grid.cell_size");
}

/// A 3D scene validates (exit 0, its particles and its three cell counts
/// printed) and runs (`series.csv` with the 3D columns, 3D VTK files);
/// with a phase field's material angle (still 2D) `run` refuses it as it refuses an invalid
/// scene (exit 2), naming the key, and writes nothing; so does a study.
#[test]
fn a_3d_scene_validates_and_runs_and_what_is_still_2d_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let text = r#"
[grid]
cell_size = 0.1
max = [1.0, 1.0, 1.0]

[time]
end = 0.01

[[bodies]]
shape = { type = "sphere", center = [0.5, 0.5, 0.5], radius = 0.3 }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity = [0.5, 0.0, -0.25]
"#;
    let scene = write(dir.path(), "block.toml", text.as_bytes());
    let out = cleave().arg("validate").arg(&scene).output().unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    assert!(stdout.contains("10 x 10 x 10 cells"), "{stdout}");
    assert!(!stdout.contains("cannot be run yet"), "{stdout}");
    let out = cleave()
        .args(["validate", "--json"])
        .arg(&scene)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["cells"], serde_json::json!([10, 10, 10]));
    // the sphere's volume over the spacing cubed (8 per cell: 0.05 m)
    let n = v["particles"].as_u64().unwrap() as f64;
    let expected = 4.0 / 3.0 * std::f64::consts::PI * 0.3f64.powi(3) / 0.05f64.powi(3);
    assert!((n - expected).abs() < 0.03 * expected, "{n} vs {expected}");

    // a phase field's material angle is still 2D: refused by run and study,
    // naming the key, before anything is written
    let cracking = write(
        dir.path(),
        "cracking.toml",
        text.replace(
            "poissons_ratio = 0.3 }",
            "poissons_ratio = 0.3, phase_field = { gc = 1.0, l0 = 0.2, angle = 30.0 } }",
        )
        .as_bytes(),
    );
    let results = dir.path().join("out");
    let out = cleave()
        .arg("run")
        .arg(&cracking)
        .arg("--out")
        .arg(&results)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("bodies[0].material.phase_field.angle")
            && stderr(&out).contains("not run yet"),
        "{}",
        stderr(&out)
    );
    assert!(!results.exists());
    let out = cleave()
        .arg("study")
        .arg(&cracking)
        .args(["--vary", "bodies[0].particles_per_cell=1,8"])
        .args(["--metric", "final:momentum_x", "--out"])
        .arg(dir.path().join("study"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("bodies[0].material.phase_field.angle"),
        "{}",
        stderr(&out)
    );

    // the elastic sphere runs: the series has the 3D columns, the momentum
    // is the sphere's m v₀, and the snapshots are 3D (ParaView's shapes: a
    // 3-vector velocity, a 6-component stress, points with their z, a grid
    // over three axes)
    let out = cleave()
        .arg("run")
        .arg(&scene)
        .arg("--out")
        .arg(&results)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let vtp = std::fs::read(results.join("particles_0000.vtp")).unwrap();
    let vtp = String::from_utf8_lossy(&vtp);
    for array in [
        "Name=\"velocity\" NumberOfComponents=\"3\"",
        "Name=\"stress\" NumberOfComponents=\"6\"",
        "Name=\"strain\" NumberOfComponents=\"6\"",
        "Name=\"position\" NumberOfComponents=\"3\"",
    ] {
        assert!(vtp.contains(array), "{array} not in the particles' file");
    }
    assert!(vtp.contains(&format!("NumberOfPoints=\"{}\"", n as u64)));
    // the grid of the last snapshot (the first, at t = 0, has none yet)
    let mut grids: Vec<_> = std::fs::read_dir(&results)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|x| x == "vti"))
        .collect();
    grids.sort();
    let vti = std::fs::read(grids.last().expect("a grid file")).unwrap();
    let vti = String::from_utf8_lossy(&vti);
    // 10 cells and the padding (PAD nodes) on each side, along every axis
    let extent = vti
        .split("WholeExtent=\"")
        .nth(1)
        .and_then(|t| t.split('"').next())
        .unwrap()
        .split(' ')
        .map(|v| v.parse::<usize>().unwrap())
        .collect::<Vec<_>>();
    assert_eq!(extent.len(), 6);
    assert!(
        extent[1] >= 10 && extent[1] == extent[3] && extent[3] == extent[5],
        "{extent:?}"
    );
    assert!(vti.contains("Name=\"velocity\" NumberOfComponents=\"3\""));
    let series = std::fs::read_to_string(results.join("series.csv")).unwrap();
    let mut lines = series.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    for c in [
        "momentum_z",
        "angular_momentum_x",
        "angular_momentum_y",
        "angular_momentum_z",
    ] {
        assert!(header.contains(&c), "{c} in {header:?}");
    }
    let last: Vec<f64> = lines
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    let at = |c: &str| last[header.iter().position(|h| *h == c).unwrap()];
    let m = at("total_mass");
    assert!((at("momentum_x") - 0.5 * m).abs() < 1e-9 * m);
    assert!((at("momentum_z") + 0.25 * m).abs() < 1e-9 * m);
}

#[test]
fn run_writes_results_and_reports_json() {
    let dir = tempfile::tempdir().unwrap();
    let out_dir = dir.path().join("out");
    let out = cleave()
        .args(["run", "--json"])
        .arg(scenes().join("wave_bar.toml"))
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let v: serde_json::Value =
        serde_json::from_slice(&out.stdout).expect("one JSON object on stdout");
    assert_eq!(v["status"], "succeeded");
    assert!(v["steps"].as_u64().unwrap() > 100);
    assert_eq!(v["particles"], 1600);
    assert_eq!(
        v["stages"],
        serde_json::json!(["p2g", "grid_update", "g2p", "rebin"])
    );
    // each stage's time and runs, in the plan's order
    let timed: Vec<_> = v["stage_seconds"]["stages"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| (t["stage"].clone(), t["runs"].as_u64().unwrap()))
        .collect();
    let steps = v["steps"].as_u64().unwrap();
    assert_eq!(
        timed,
        ["p2g", "grid_update", "g2p", "rebin"].map(|s| (serde_json::json!(s), steps))
    );
    assert!(v["wall_seconds"].as_f64().unwrap() > 0.0);
    assert!(v["kinetic_energy"].as_f64().unwrap() > 0.0);
    let csv = std::fs::read_to_string(out_dir.join("series.csv")).unwrap();
    let header = csv.lines().next().unwrap();
    for col in [
        "time",
        "kinetic_energy",
        "strain_energy",
        "external_work",
        "total_mass",
        "momentum_x",
        "angular_momentum",
    ] {
        assert!(
            header.split(',').any(|c| c == col),
            "series.csv lacks {col}: {header}"
        );
    }
    assert_eq!(csv.lines().count(), 1 + 101, "header + 101 rows");
    for f in [
        "particles.pvd",
        "grid.pvd",
        "energies.png",
        "particles_0000.vtp",
        "particles_0005.vtp",
        "grid_0005.vti",
    ] {
        assert!(out_dir.join(f).is_file(), "missing {f}");
    }
    let pvd = std::fs::read_to_string(out_dir.join("particles.pvd")).unwrap();
    assert_eq!(pvd.matches("<DataSet").count(), 6);
}

#[test]
fn a_failing_simulation_exits_1_with_a_diagnosis() {
    // A fixed time step far beyond the CFL limit.
    let dir = tempfile::tempdir().unwrap();
    // h / c = 0.1 m / 36.7 m/s = 2.7 ms
    let path = write(
        dir.path(),
        "cfl.toml",
        GOOD.replace("end = 0.01", "end = 0.05\ndt = 5e-3")
            .as_bytes(),
    );
    let out = cleave()
        .arg("run")
        .arg(&path)
        .arg("--out")
        .arg(dir.path().join("o"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(
        stderr(&out).contains("exceeds the CFL stability limit"),
        "{}",
        stderr(&out)
    );
    // A body pushed out of the grid.
    let path = write(
        dir.path(),
        "leave.toml",
        GOOD.replace("[[bodies]]", "[[bodies]]\nvelocity = [500.0, 0.0]")
            .replace("end = 0.01", "end = 0.01\ncfl = 0.5")
            .as_bytes(),
    );
    let out = cleave()
        .args(["run", "--json"])
        .arg(&path)
        .arg("--out")
        .arg(dir.path().join("o2"))
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1), "{}", stderr(&out));
    assert!(stderr(&out).contains("left the grid"), "{}", stderr(&out));
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["status"], "failed");
    assert!(v["error"].as_str().unwrap().contains("particle"));
    // The rows up to the failure are kept.
    assert!(
        std::fs::read_to_string(dir.path().join("o2").join("series.csv"))
            .unwrap()
            .lines()
            .count()
            >= 2
    );
}

fn run_with_threads(scene: &Path, threads: &str, out: &Path) {
    let o = cleave()
        .env("RAYON_NUM_THREADS", threads)
        .args(["run", "--quiet"])
        .arg(scene)
        .arg("--out")
        .arg(out)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(0), "{}", stderr(&o));
}

/// Every output file is byte-identical with 1 and 2 threads (contact,
/// MUSL and phase-field paths included), except the wall-clock columns
/// (`*_s`, the phase-field solver's seconds per step) of `series.csv`.
#[test]
fn outputs_are_byte_identical_for_one_and_two_threads() {
    let dir = tempfile::tempdir().unwrap();
    // the first 10 µs of the coarse P1 plate (the coloured phase-field assembly)
    let p1 = dir.path().join("p1_short.toml");
    std::fs::write(
        &p1,
        std::fs::read_to_string(scenes().join("p1_plate_coarse.toml"))
            .unwrap()
            .replace("end = 8.0e-5", "end = 1.0e-5"),
    )
    .unwrap();
    for scene in [
        scenes().join("sliding_block.toml"),
        scenes().join("two_disks.toml"),
        p1,
    ] {
        let dir = tempfile::tempdir().unwrap();
        let (a, b) = (dir.path().join("t1"), dir.path().join("t2"));
        run_with_threads(&scene, "1", &a);
        run_with_threads(&scene, "2", &b);
        let mut names: Vec<_> = std::fs::read_dir(&a)
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        names.sort();
        assert!(
            names.len() >= 5,
            "{}: too few outputs {names:?}",
            scene.display()
        );
        for name in names {
            let (x, y) = (
                std::fs::read(a.join(&name)).unwrap(),
                std::fs::read(b.join(&name)).unwrap(),
            );
            let (x, y) = if name == "series.csv" {
                (without_timings(&x), without_timings(&y))
            } else {
                (x, y)
            };
            assert!(
                x == y,
                "{}: {name:?} differs between 1 and 2 threads",
                scene.display()
            );
        }
    }
}

/// A series' text without its wall-clock columns (names ending in `_s`).
fn without_timings(csv: &[u8]) -> Vec<u8> {
    let text = String::from_utf8(csv.to_vec()).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep: Vec<bool> = header.iter().map(|c| !c.ends_with("_s")).collect();
    assert!(
        keep.iter().any(|k| !k) || !header.iter().any(|c| c.starts_with("pf_")),
        "no timing columns in {header:?}"
    );
    let pick = |line: &str| {
        line.split(',')
            .zip(&keep)
            .filter(|(_, k)| **k)
            .map(|(v, _)| v)
            .collect::<Vec<_>>()
            .join(",")
    };
    std::iter::once(pick(&header.join(",")))
        .chain(lines.map(pick))
        .collect::<Vec<_>>()
        .join("\n")
        .into_bytes()
}

/// `cleave gc-polar` reproduces the paper's Gc_min / Gc_max pairs (seed 001,
/// section 5) within 1 %.
#[test]
fn gc_polar_reproduces_the_published_extremes() {
    let dir = tempfile::tempdir().unwrap();
    for (gamma, gc_bar, min, max) in [
        ("1,1,0,74", "0.002121", 0.003, 0.0049),
        ("1,80,0,74", "0.002121", 0.003, 0.0067),
        ("1,2900,0,74", "4.175", 5.9067, 30.9044),
        ("80,1,0,74", "7.5", 10.6066, 23.6892),
    ] {
        let png = dir.path().join("polar.png");
        let o = cleave()
            .args([
                "gc-polar",
                "--gamma",
                gamma,
                "--gc-bar",
                gc_bar,
                "--angle-step",
                "0.25",
                "--json",
                "--out",
            ])
            .arg(&png)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", stderr(&o));
        let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let (lo, hi) = (v["gc_min"].as_f64().unwrap(), v["gc_max"].as_f64().unwrap());
        assert!(
            (lo / min - 1.0).abs() < 0.01,
            "{gamma}: Gc_min {lo} vs {min}"
        );
        assert!(
            (hi / max - 1.0).abs() < 0.01,
            "{gamma}: Gc_max {hi} vs {max}"
        );
        assert!(png.is_file());
    }
    // 4th-order isotropic: Gc = √2 Ḡc in every direction
    let o = cleave()
        .args([
            "gc-polar", "--gamma", "1,1,0,2", "--gc-bar", "1", "--json", "--out",
        ])
        .arg(dir.path().join("i.png"))
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for row in v["table"].as_array().unwrap() {
        assert!((row["gc"].as_f64().unwrap() - 2f64.sqrt()).abs() < 1e-9);
    }
    // bad input
    for args in [["--gamma", "1,2,3"], ["--gamma", "1,1,-5,0"]] {
        let o = cleave()
            .arg("gc-polar")
            .args(args)
            .args(["--gc-bar", "1"])
            .output()
            .unwrap();
        assert_eq!(o.status.code(), Some(2));
        assert!(stderr(&o).contains("--gamma"), "{}", stderr(&o));
    }
    let o = cleave()
        .args(["gc-polar", "--gamma", "1,1,0,2", "--gc-bar", "-1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
}

/// `cleave study`: every combination runs, study.csv has a row per run
/// with the settings, wall time, metric and error against the analytic
/// value, the Pareto front is marked, the plot is written, and each
/// variant's scene is kept to rerun alone.
#[test]
fn study_runs_every_combination_and_marks_the_front() {
    let dir = tempfile::tempdir().unwrap();
    // the wave bar, short and coarse: the momentum the pushed end has put
    // in at 50 us is rho A c v t = 8000 · 1e-4 · 5000 · 1 · 5e-5 = 0.2
    let scene = std::fs::read_to_string(scenes().join("wave_bar.toml"))
        .unwrap()
        .replace("cell_size = 0.005", "cell_size = 0.01")
        .replace("end = 2.5e-4", "end = 5.0e-5");
    let path = write(dir.path(), "bar.toml", scene.as_bytes());
    let out = dir.path().join("study");
    let o = cleave()
        .args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "time.cfl=0.2,0.5",
            "--vary",
            "transfer.scheme=pic,flip",
        ])
        .args([
            "--metric",
            "final:momentum_x",
            "--reference",
            "analytic:0.2",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    let lines: Vec<&str> = csv.lines().collect();
    assert_eq!(lines[0], "run,time.cfl,transfer.scheme,status,wall_seconds,steps,particles,metric,error,reference,pareto");
    assert_eq!(lines.len(), 5, "{csv}");
    let mut front = 0;
    for (k, line) in lines[1..].iter().enumerate() {
        let f: Vec<&str> = line.split(',').collect();
        assert_eq!(f[0], k.to_string());
        assert_eq!(f[3], "ok", "{line}");
        let (wall, steps, metric, error): (f64, u64, f64, f64) = (
            f[4].parse().unwrap(),
            f[5].parse().unwrap(),
            f[7].parse().unwrap(),
            f[8].parse().unwrap(),
        );
        assert!(wall > 0.0 && steps > 0);
        // the wave carries the momentum the analytic value says, within 10 %
        assert!((metric / 0.2 - 1.0).abs() < 0.1, "{line}");
        assert!((error - (metric / 0.2 - 1.0).abs()).abs() < 1e-12, "{line}");
        front += usize::from(f[10] == "true");
    }
    assert!(front >= 1, "{csv}");
    // the smaller CFL factor takes more steps
    let steps = |k: usize| {
        lines[1 + k]
            .split(',')
            .nth(5)
            .unwrap()
            .parse::<u64>()
            .unwrap()
    };
    assert!(steps(0) > steps(2), "{csv}");
    assert!(out.join("study.png").exists());
    let variant = out.join("runs").join("003").join("scene.json");
    let text = std::fs::read_to_string(&variant).unwrap();
    assert!(
        text.contains("\"cfl\": 0.5") && text.contains("\"scheme\": \"flip\""),
        "{text}"
    );
    assert!(out.join("runs").join("003").join("series.csv").exists());
    let o = cleave()
        .args(["validate", variant.to_str().unwrap()])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
}

/// A study with a bad setting stops before running anything, names the
/// field and the setting, and exits 2; so does a metric the series lacks.
#[test]
fn study_rejects_bad_settings_before_running() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "good.toml", GOOD.as_bytes());
    let out = dir.path().join("study");
    let o = cleave()
        .args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "grid.cell_size=0.1,-0.2",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    let e = stderr(&o);
    assert!(
        e.contains("grid.cell_size: must be > 0") && e.contains("with grid.cell_size=-0.2"),
        "{e}"
    );
    assert!(!out.join("study.csv").exists());
    let o = cleave()
        .args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "time.cfl=0.2",
            "--metric",
            "max:crack_speed",
        ])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("no column \"crack_speed\""),
        "{}",
        stderr(&o)
    );
    let o = cleave()
        .args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "bodies[2].particles_per_cell=4",
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("bodies[2].particles_per_cell: index 2 out of range"),
        "{}",
        stderr(&o)
    );
}

/// A study outlives its process: killed while its second run is under way
/// (after that run's first checkpoint), `--resume` keeps the first run as
/// it was, takes the second up from its checkpoint, and ends with the
/// series a run of that variant alone writes. Without `--resume` the
/// directory of an earlier study is refused; with other settings too.
#[test]
fn a_killed_study_resumes_keeping_its_finished_runs() {
    let dir = tempfile::tempdir().unwrap();
    // a spinning square: 25 600 particles, about 1.4e-4 s a step
    let scene = r#"
[grid]
cell_size = 0.01
max = [1.0, 1.0]
[time]
end = 0.002
cfl = 0.5
[[bodies]]
shape = { type = "box", min = [0.1, 0.1], max = [0.9, 0.9] }
material = { model = "linear_elastic", density = 1000.0, youngs_modulus = 1.0e6, poissons_ratio = 0.3 }
velocity_gradient = [[0.0, -0.5], [0.5, 0.0]]
[output]
series_rows = 200
"#;
    let path = write(dir.path(), "spin.toml", scene.as_bytes());
    let out = dir.path().join("study");
    let args = |extra: &[&str]| {
        let mut c = cleave();
        c.args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "time.end=0.002,0.06",
            "--metric",
            "kinetic_energy",
        ])
        .args(["--out", out.to_str().unwrap()])
        .args(extra);
        c
    };
    let mut child = args(&["--checkpoint-every", "0.1"])
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    let run1 = out.join("runs").join("001");
    let t0 = std::time::Instant::now();
    while !run1.join("checkpoint.bin").exists() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the study ended before its second run's first checkpoint: make it longer"
        );
        assert!(
            t0.elapsed() < std::time::Duration::from_secs(120),
            "no checkpoint"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL: no chance to tidy up
    child.wait().unwrap();
    assert!(
        !run1.join("outcome.json").exists(),
        "the second run finished before the kill: make it longer"
    );
    let kept = std::fs::read_to_string(out.join("runs").join("000").join("outcome.json")).unwrap();

    // not resumed: refused, nothing touched
    let o = args(&[]).output().unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("holds the runs of an earlier study: --resume"),
        "{}",
        stderr(&o)
    );
    // other settings: refused
    let o = cleave()
        .args([
            "study",
            path.to_str().unwrap(),
            "--vary",
            "time.end=0.002,0.05",
            "--metric",
            "kinetic_energy",
            "--resume",
        ])
        .args(["--out", out.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("is not this study's run 1 (time.end=0.05)"),
        "{}",
        stderr(&o)
    );
    assert!(run1.join("checkpoint.bin").exists());

    let o = args(&["--resume"]).output().unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("finished by the earlier study, kept")
            && e.contains("from its checkpoint at step"),
        "{e}"
    );
    assert_eq!(
        std::fs::read_to_string(out.join("runs").join("000").join("outcome.json")).unwrap(),
        kept
    );
    assert!(
        !run1.join("checkpoint.bin").exists(),
        "the checkpoint outlived the finished run"
    );
    let csv = std::fs::read_to_string(out.join("study.csv")).unwrap();
    assert_eq!(csv.lines().count(), 3, "{csv}");
    assert!(
        csv.lines()
            .skip(1)
            .all(|l| l.split(',').nth(2) == Some("ok")),
        "{csv}"
    );

    // the resumed run's series is the straight run's
    let alone = dir.path().join("alone");
    let o = cleave()
        .args(["run", "--quiet"])
        .arg(run1.join("scene.json"))
        .arg("--out")
        .arg(&alone)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let (a, b) = (
        std::fs::read(run1.join("series.csv")).unwrap(),
        std::fs::read(alone.join("series.csv")).unwrap(),
    );
    assert!(
        a == b,
        "the resumed run's series differs from the straight run's"
    );
}

/// `cleave metric` measures a series as `cleave study` does: the value
/// of each metric (here the last kinetic energy, read back from the
/// file), its signed difference from a reference; exit 1 when a metric
/// cannot be taken, 2 for a bad one.
#[test]
fn metric_measures_a_series_as_a_study_does() {
    let dir = tempfile::tempdir().unwrap();
    let path = write(
        dir.path(),
        "good.toml",
        GOOD.replace("[[bodies]]", "[[bodies]]\nvelocity = [1.0, 0.0]")
            .as_bytes(),
    );
    let out = dir.path().join("out");
    let o = cleave()
        .args([
            "run",
            "--quiet",
            path.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let series = out.join("series.csv");
    let text = std::fs::read_to_string(&series).unwrap();
    let last: f64 = text
        .lines()
        .last()
        .unwrap()
        .split(',')
        .nth(2)
        .unwrap()
        .parse()
        .unwrap();
    assert!(last > 0.0);
    let o = cleave()
        .args([
            "metric",
            series.to_str().unwrap(),
            "--metric",
            "final:kinetic_energy",
            "--metric",
            "max:kinetic_energy",
        ])
        .args(["--reference", &format!("analytic:{}", 2.0 * last), "--json"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = v["metrics"].as_array().unwrap();
    assert_eq!(m[0]["value"].as_f64(), Some(last));
    assert!(
        (m[0]["difference"].as_f64().unwrap() + 0.5).abs() < 1e-12,
        "{v}"
    );
    assert!(m[1]["value"].as_f64().unwrap() >= last);
    // no crack column in this series: exit 1, and says why
    let o = cleave()
        .args([
            "metric",
            series.to_str().unwrap(),
            "--metric",
            "propagation_energy",
        ])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("propagation_energy"), "{}", stderr(&o));
    // the same series with a crack that starts at row 2 and is through at
    // row 4: the window names those rows
    let cracked = dir.path().join("cracked.csv");
    let mut lines = text.lines();
    let mut csv = format!(
        "{},fracture_energy_b0,crack_length\n",
        lines.next().unwrap()
    );
    let times: Vec<f64> = text
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(1).unwrap().parse().unwrap())
        .collect();
    assert!(times.len() > 5);
    for (i, l) in lines.enumerate() {
        let length = [0.0, 0.0, 0.05, 0.5, 1.0].get(i).copied().unwrap_or(1.0);
        csv.push_str(&format!("{l},{},{length}\n", i as f64));
    }
    std::fs::write(&cracked, csv).unwrap();
    let o = cleave()
        .args([
            "metric",
            cracked.to_str().unwrap(),
            "--metric",
            "propagation_energy:fracture_energy_b0",
            "--json",
        ])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let m = &v["metrics"][0];
    assert_eq!(m["value"].as_f64(), Some(2.0), "{v}");
    assert_eq!(m["window"]["from"]["time"].as_f64(), Some(times[2]), "{v}");
    assert_eq!(m["window"]["to"]["time"].as_f64(), Some(times[4]), "{v}");
    assert_eq!(m["window"]["to"]["length"].as_f64(), Some(1.0), "{v}");
    let o = cleave()
        .args(["metric", series.to_str().unwrap(), "--metric", "bogus:x"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("unknown kind \"bogus\""),
        "{}",
        stderr(&o)
    );
}

/// Every argument and option of every command has a help line, and the
/// server's options are offered only by the commands that talk to one.
#[test]
fn every_argument_has_help_and_server_options_only_where_they_apply() {
    let o = cleave().arg("--help").output().unwrap();
    let top = String::from_utf8_lossy(&o.stdout).into_owned();
    let offers_server = |help: &str| help.lines().any(|l| l.trim_start().starts_with("--server"));
    assert!(!offers_server(&top), "{top}");
    let commands: Vec<String> = top
        .lines()
        .skip_while(|l| !l.starts_with("Commands:"))
        .skip(1)
        .take_while(|l| l.starts_with("  "))
        .filter_map(|l| l.split_whitespace().next().map(String::from))
        .filter(|c| c != "help")
        .collect();
    assert!(commands.len() >= 15, "{commands:?}");
    let remote = [
        "run", "validate", "study", "submit", "watch", "fetch", "list", "get", "cancel",
    ];
    for c in &commands {
        let o = cleave().args([c.as_str(), "--help"]).output().unwrap();
        let help = String::from_utf8_lossy(&o.stdout).into_owned();
        assert!(o.status.success(), "{c}: {help}");
        assert_eq!(
            help.contains("--server"),
            remote.contains(&c.as_str()),
            "{c}: {help}"
        );
        // an entry's first line: "  <NAME>  text" or "  -x, --name <V>  text";
        // or, where clap puts help on the next line, the entry alone with
        // its text indented below it
        let lines: Vec<&str> = help.lines().collect();
        let is_entry = |l: &str| {
            let t = l.trim_start();
            l.starts_with("  ") && (t.starts_with('<') || t.starts_with('-') || t.starts_with('['))
        };
        let indent = |l: &str| l.len() - l.trim_start().len();
        for (k, l) in lines.iter().enumerate().filter(|(_, l)| is_entry(l)) {
            let t = l.trim();
            let inline = t.split("  ").filter(|p| !p.trim().is_empty()).count() >= 2;
            let below = lines
                .get(k + 1)
                .is_some_and(|n| !n.trim().is_empty() && !is_entry(n) && indent(n) > indent(l));
            assert!(inline || below, "{c}: no help for {t:?}");
        }
    }
}

/// A server named by CLEAVE_SERVER that cannot be reached: exit 3, and the
/// error says the variable sent the command there and how to run locally.
#[test]
fn an_unreachable_server_from_the_environment_is_named() {
    let o = cleave()
        .args(["validate"])
        .arg(scenes().join("two_disks.toml"))
        .env("CLEAVE_SERVER", "127.0.0.1:9")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3), "{}", stderr(&o));
    let e = stderr(&o);
    assert!(
        e.contains("http://127.0.0.1:9") && e.contains("CLEAVE_SERVER is set"),
        "{e}"
    );
    // named on the command line, it is not blamed on the variable
    let o = cleave()
        .args(["validate", "--server", "127.0.0.1:9"])
        .arg(scenes().join("two_disks.toml"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(3));
    assert!(!stderr(&o).contains("CLEAVE_SERVER"), "{}", stderr(&o));
}

/// `cleave plot` says which files it wrote, and why it drew no crack plot.
#[test]
fn plot_says_what_it_wrote() {
    let dir = tempfile::tempdir().unwrap();
    let o = cleave()
        .args(["run", "--quiet"])
        .arg(scenes().join("two_disks.toml"))
        .arg("--out")
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let plots = dir.path().join("plots");
    let o = cleave()
        .arg("plot")
        .arg(dir.path().join("series.csv"))
        .arg("--out")
        .arg(&plots)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let text = String::from_utf8_lossy(&o.stdout).into_owned();
    assert!(
        text.contains(&format!("wrote {}", plots.join("energies.png").display())),
        "{text}"
    );
    assert!(text.contains("no crack.png: "), "{text}");
    assert!(plots.join("energies.png").metadata().unwrap().len() > 1000);
}

/// `cleave bench --dim 3` on a tiny block (4³ cells × 8 = 512 particles,
/// below the real sizes, which `--largest` under 16 selects) writes the
/// table with the bytes-per-particle column; `--threads` measures the
/// counts given, in that order; a transfer other than APIC, a thread
/// count of 0 and a dimension other than 2 or 3 are refused.
#[test]
fn bench_3d_writes_the_table_with_bytes_per_particle() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("perf3d.md");
    let o = cleave()
        .args([
            "bench",
            "--dim",
            "3",
            "--largest",
            "4",
            "--steps",
            "2",
            "--out",
        ])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = std::fs::read_to_string(&out).unwrap();
    assert!(doc.contains("bytes / particle"), "{doc}");
    assert!(doc.contains("bench --dim 3 --steps 2 --largest 4"), "{doc}");
    for threads in [1, 2] {
        let row = doc
            .lines()
            .find(|l| l.starts_with(&format!("| 512 | {threads} |")))
            .unwrap_or_else(|| panic!("no 512-particle row for {threads} threads: {doc}"));
        // the bytes column: "total (particles + grid)", all positive
        let bytes = row.split('|').nth(9).unwrap().trim();
        let total: f64 = bytes.split(' ').next().unwrap().parse().unwrap();
        assert!(total > 200.0, "{row}");
    }
    let o = cleave()
        .args([
            "bench",
            "--dim",
            "3",
            "--transfer",
            "flip",
            "--largest",
            "4",
            "--out",
        ])
        .arg(dir.path().join("no.md"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("APIC only"), "{}", stderr(&o));
    let o = cleave().args(["bench", "--dim", "4"]).output().unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // other thread counts, in the order given, quoted in the command line
    let three = dir.path().join("three.md");
    let o = cleave()
        .args(["bench", "--dim", "3", "--largest", "4", "--steps", "1"])
        .args(["--threads", "2,1,3", "--out"])
        .arg(&three)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = std::fs::read_to_string(&three).unwrap();
    assert!(
        doc.contains("--threads 2,1,3") && doc.contains("2, 1 and 3 threads"),
        "{doc}"
    );
    let rows: Vec<&str> = doc.lines().filter(|l| l.starts_with("| 512 |")).collect();
    assert_eq!(rows.len(), 3, "{doc}");
    assert!(rows[0].starts_with("| 512 | 2 |") && rows[2].starts_with("| 512 | 3 |"));
    let o = cleave()
        .args(["bench", "--dim", "3", "--threads", "1,0", "--out"])
        .arg(dir.path().join("no.md"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("--threads"), "{}", stderr(&o));
    // the 2D peer problem against Taichi is fixed: no --transfer beside it;
    // a Python without Taichi is named, and nothing is written
    let o = cleave()
        .args([
            "bench",
            "--taichi",
            "python3",
            "--transfer",
            "flip",
            "--out",
        ])
        .arg(dir.path().join("no.md"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("drop --transfer"), "{}", stderr(&o));
    let o = cleave()
        .args(["bench", "--taichi", "/nonexistent/python", "--largest", "8"])
        .args(["--steps", "1", "--out"])
        .arg(dir.path().join("no.md"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(
        stderr(&o).contains("running /nonexistent/python"),
        "{}",
        stderr(&o)
    );
    assert!(!dir.path().join("no.md").exists());
}

/// A reader that closes `cleave`'s output first (`cleave validate … |
/// head -1`) ends it quietly with 141, as SIGPIPE ends a Unix tool, not
/// with a panic and a backtrace.
#[test]
fn a_closed_stdout_ends_the_command_quietly() {
    // a pipe whose reader has gone before cleave starts: the write end of
    // `true`'s standard input, once `true` has exited
    let mut sink = Command::new("true")
        .stdin(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    let write_end = sink.stdin.take().unwrap();
    sink.wait().unwrap();
    let o = cleave()
        .arg("validate")
        .arg(scenes().join("two_disks.toml"))
        .stdout(std::process::Stdio::from(write_end))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(141), "{:?} {}", o.status, stderr(&o));
    assert!(stderr(&o).is_empty(), "{}", stderr(&o));
}

/// `cleave bench --scene`: any scene's steps at each thread count, with a
/// row for every stage of its plan (here a phase-field one, whose plan is
/// not the explicit step's) and the parallel efficiency; the options of
/// the built-in block are refused beside it, and a scene that ends in the
/// warm-up has nothing to time.
#[test]
fn bench_scene_times_every_stage_of_the_plan() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("scene.md");
    let scene = scenes().join("p1_plate_coarse.toml");
    let o = cleave()
        .args(["bench", "--scene"])
        .arg(&scene)
        .args(["--steps", "3", "--threads", "1,2", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    let doc = std::fs::read_to_string(&out).unwrap();
    assert!(doc.contains("--steps 3 --threads 1,2"), "{doc}");
    let plan = cleave()
        .args(["validate", "--json"])
        .arg(&scene)
        .output()
        .unwrap();
    let v: serde_json::Value = serde_json::from_slice(&plan.stdout).unwrap();
    let stages = v["stages"].as_array().expect("the plan's stages");
    assert!(stages.iter().any(|s| s == "phase_field_stagger"), "{v}");
    for s in stages {
        let row = format!("| {} |", s.as_str().unwrap());
        assert!(
            doc.lines().any(|l| l.starts_with(&row)),
            "no row {row}: {doc}"
        );
    }
    for threads in ["| 1 | 3 |", "| 2 | 3 |"] {
        let row = doc.lines().find(|l| l.starts_with(threads)).unwrap();
        // the first count's efficiency is 100 % by definition
        assert!(
            threads != "| 1 | 3 |" || row.ends_with("| 1.00 | 100 % |"),
            "{row}"
        );
    }
    let o = cleave()
        .args(["bench", "--dim", "3", "--scene"])
        .arg(&scene)
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2), "{}", stderr(&o));
    // one step long
    let o = cleave()
        .args(["bench", "--scene"])
        .arg(scenes().join("pf_straight_crack.toml"))
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1));
    assert!(stderr(&o).contains("warm-up"), "{}", stderr(&o));
}

/// `cleave bench --scene FILE --after T` runs the scene untimed to T and
/// times its steps there (the table's command says so); a T past the
/// scene's end leaves nothing to time, and a negative T, or `--after`
/// without a scene, is refused before anything runs.
#[test]
fn bench_scene_after_times_the_late_steps() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("late.md");
    let scene = scenes().join("spinning_disk.toml");
    let o = cleave()
        .args(["bench", "--scene"])
        .arg(&scene)
        .args(["--after", "0.15", "--steps", "2", "--threads", "1", "--out"])
        .arg(&out)
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(stderr(&o).contains("(from t = 1.5e-1 s)"), "{}", stderr(&o));
    let doc = std::fs::read_to_string(&out).unwrap();
    assert!(doc.contains("--after 1.5e-1 --steps 2"), "{doc}");
    assert!(doc.contains("run untimed to t = 1.5e-1 s"), "{doc}");
    assert!(doc.lines().any(|l| l.starts_with("| 1 | 2 |")), "{doc}");
    let o = cleave()
        .args(["bench", "--scene"])
        .arg(&scene)
        .args(["--after", "5", "--threads", "1"])
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(1), "{}", stderr(&o));
    assert!(stderr(&o).contains("lower --after"), "{}", stderr(&o));
    for args in [
        vec!["bench", "--after", "0.1"],
        vec!["bench", "--scene", "x.toml", "--after=-1"],
    ] {
        let o = cleave().args(&args).output().unwrap();
        assert_eq!(o.status.code(), Some(2), "{args:?}: {}", stderr(&o));
    }
}

/// `cleave gc-polar` with a 3D tensor (9 numbers): Gc of a plane by its
/// normal and the extremes over the sphere, from the 1D profile along n.
/// γ with a(n) = 1 + 3 n_z⁴: Gc_min = √2 Ḡc (a = 1) with n in the xy plane,
/// Gc_max = G(4) Ḡc along z; the 4th-order isotropic tensor gives √2 Ḡc
/// everywhere; `--normal` with a 2D tensor is refused.
#[test]
fn gc_polar_in_3d_gives_gc_by_normal_and_its_extremes_over_the_sphere() {
    let run = |args: &[&str]| cleave().arg("gc-polar").args(args).output().unwrap();
    let o = run(&[
        "--gamma",
        "1,1,4,0,0,0,2,2,2",
        "--gc-bar",
        "2",
        "--normal",
        "0,0,1",
        "--normal",
        "1,1,0",
        "--json",
    ]);
    assert!(o.status.success(), "{}", stderr(&o));
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    let g4 = cleave::fracture::phase_field::anisotropy::profile_factor(4.0);
    let (lo, hi) = (v["gc_min"].as_f64().unwrap(), v["gc_max"].as_f64().unwrap());
    assert!((lo - 2.0 * 2f64.sqrt()).abs() < 1e-9, "{v}");
    assert!((hi - 2.0 * g4).abs() < 1e-9, "{v}");
    assert!(v["normal_min"][2].as_f64().unwrap().abs() < 1e-3, "{v}");
    assert!(v["normal_max"][2].as_f64().unwrap().abs() > 0.999, "{v}");
    let rows = v["normals"].as_array().unwrap();
    assert!((rows[0]["gc"].as_f64().unwrap() - 2.0 * g4).abs() < 1e-9);
    assert!((rows[1]["a"].as_f64().unwrap() - 1.0).abs() < 1e-12, "{v}");
    let o = run(&["--gamma", "1,1,1,0,0,0,2,2,2", "--gc-bar", "1", "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
    for k in ["gc_min", "gc_max"] {
        assert!((v[k].as_f64().unwrap() - 2f64.sqrt()).abs() < 1e-9, "{v}");
    }
    let o = run(&["--gamma", "1,1,0,2", "--gc-bar", "1", "--normal", "0,0,1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(stderr(&o).contains("--normal"), "{}", stderr(&o));
}
