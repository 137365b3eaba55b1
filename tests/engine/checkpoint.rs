//! Checkpoint and resume (`mpm::checkpoint`): a run that loses its process
//! after a checkpoint and is resumed from it writes what the uninterrupted
//! run writes, bit for bit (with PCG, to the solver's tolerance).

use crate::common;
use crate::common::Interrupted;

use cleave::checkpoint::{Checkpoint, CheckpointError};
use cleave::mpm::Simulation;
use cleave::output::OutputWriter;
use cleave::particles::Particles;
use cleave::scene::Scene;
use std::path::Path;

fn scene_text(file: &str, edits: &[(&str, &str)]) -> String {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut text = std::fs::read_to_string(dir.join(file)).unwrap();
    for (from, to) in edits {
        assert!(text.contains(from), "{file} has no {from:?}");
        text = text.replace(from, to);
    }
    text
}

/// What a run in `dir` leaves: the series, the snapshot collection, the
/// last snapshot's particles, and the final particles.
struct Outcome {
    series: String,
    pvd: String,
    last_vtp: Vec<u8>,
    parts: Particles,
    steps: u64,
}

fn outcome(dir: &Path, sim: &Simulation) -> Outcome {
    let series = std::fs::read_to_string(dir.join("series.csv")).unwrap();
    let pvd = std::fs::read_to_string(dir.join("particles.pvd")).unwrap();
    let mut vtps: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "vtp"))
        .collect();
    vtps.sort();
    let last_vtp = std::fs::read(vtps.last().unwrap()).unwrap();
    Outcome {
        series,
        pvd,
        last_vtp,
        parts: sim.particles().clone(),
        steps: sim.steps(),
    }
}

/// Runs `text` through to the end, and again with a checkpoint at step
/// `at`, the process lost `lost` steps later, and a resume in the same
/// directory; returns both outcomes.
fn straight_and_resumed(text: &str, at: u64, lost: u64) -> (Outcome, Outcome) {
    straight_and_resumed_as(text, text, at, lost)
}

/// [`straight_and_resumed`], resumed with the scene `resumed` (which may
/// differ in its `[phase_field_solver]`).
fn straight_and_resumed_as(text: &str, resumed: &str, at: u64, lost: u64) -> (Outcome, Outcome) {
    let scene = Scene::from_text(text, None).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("straight"), tmp.path().join("resumed"));

    let mut w = OutputWriter::create(&a).unwrap();
    let mut sim = Simulation::new(&scene);
    let s = sim.run(&mut w).unwrap();
    assert!(!s.cancelled);
    w.finish().unwrap();
    let straight = outcome(&a, &sim);
    assert!(
        straight.steps > at + lost,
        "the run has {} steps",
        straight.steps
    );

    let mut obs = Interrupted {
        writer: OutputWriter::create(&b).unwrap(),
        at,
        lost,
    };
    let mut sim = Simulation::new(&scene);
    let s = sim.run(&mut obs).unwrap();
    assert!(s.cancelled);
    assert_eq!(s.steps, at + lost);
    obs.writer.finish().unwrap();
    let lost_series = std::fs::read_to_string(b.join("series.csv")).unwrap();
    assert!(lost_series.lines().count() > 2, "the lost run wrote rows");

    let mut cp = OutputWriter::load_checkpoint(&b).unwrap();
    assert_eq!(cp.step(), at);
    let state = std::mem::take(&mut cp.observer);
    let mut sim = Simulation::resume(&Scene::from_text(resumed, None).unwrap(), cp).unwrap();
    let mut w = OutputWriter::resume(&b, &state).unwrap();
    let s = sim.run(&mut w).unwrap();
    assert!(!s.cancelled);
    w.finish().unwrap();
    (straight, outcome(&b, &sim))
}

/// The series without its wall-time columns (`pf_*_s`), which no two runs
/// share.
fn without_wall_times(series: &str) -> Vec<Vec<String>> {
    let mut lines = series.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let keep = |k: usize| !(header[k].starts_with("pf_") && header[k].ends_with("_s"));
    std::iter::once(series.lines().next().unwrap())
        .chain(lines)
        .map(|l| {
            l.split(',')
                .enumerate()
                .filter(|&(k, _)| keep(k))
                .map(|(_, v)| v.to_string())
                .collect()
        })
        .collect()
}

fn assert_same(a: &Outcome, b: &Outcome) {
    assert_eq!(a.steps, b.steps);
    let (sa, sb) = (without_wall_times(&a.series), without_wall_times(&b.series));
    assert_eq!(
        sa.len(),
        sb.len(),
        "series.csv has {} lines straight, {} resumed",
        sa.len(),
        sb.len()
    );
    for (k, (x, y)) in sa.iter().zip(&sb).enumerate() {
        assert_eq!(x, y, "series.csv line {k} differs");
    }
    assert_eq!(a.pvd, b.pvd, "particles.pvd differs");
    assert!(a.last_vtp == b.last_vtp, "the last snapshot differs");
    assert!(a.parts == b.parts, "the final particles differ");
}

/// With `grid.resort_every` the checkpoint holds the particles in the
/// order of their last re-sort, not setup's: the resume takes them by id,
/// and the sliding block (two contact groups) repeats bit for bit.
#[test]
fn a_resumed_run_with_resorts_repeats_the_straight_one_bit_for_bit() {
    let text = scene_text(
        "sliding_block.toml",
        &[
            ("end = 0.12", "end = 0.05"),
            ("[grid]\n", "[grid]\nresort_every = 5\n"),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 403, 31);
    assert_same(&a, &b);
}

#[test]
fn a_resumed_phase_field_run_repeats_the_straight_one_bit_for_bit() {
    // P1 coarse (one phase field, direct solver, crack tip): 10 us
    let text = scene_text(
        "p1_plate_coarse.toml",
        &[
            ("end = 8.0e-5", "end = 1.0e-5"),
            ("snapshots = 9", "snapshots = 4"),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 40, 15);
    assert_same(&a, &b);
}

#[test]
fn a_resumed_damage_run_with_dfg_and_contact_repeats_the_straight_one_bit_for_bit() {
    // the dynamic Brazilian disk (time-to-failure damage with Weibull
    // strengths, DFG partitioning, platens in contact), to 10 us where
    // the disk has cracked
    let text = scene_text(
        "d4_brazilian.toml",
        &[
            ("end = 1.5e-5", "end = 1.0e-5"),
            ("series_rows = 151", "series_rows = 41"),
            ("snapshots = 16", "snapshots = 5"),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 150, 20);
    let failed = |o: &Outcome| o.parts.damage.iter().filter(|&&d| d >= 1.0).count();
    assert!(
        failed(&a) > 0,
        "no particle failed: the test would not exercise the damage state"
    );
    assert_same(&a, &b);
}

/// The eigensoftening strip, checkpointed while its weak row softens and
/// resumed: the softening state follows the particles, and the
/// ε-neighbour lists, built again at the resume, give the same sums.
#[test]
fn a_resumed_eigensoftening_run_repeats_the_straight_one_bit_for_bit() {
    let text = scene_text(
        "eigen_strip.toml",
        &[
            ("end = 6.0e-3", "end = 2.6e-3"),
            ("series_rows = 121", "series_rows = 53"),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 1800, 200);
    let softening = |o: &Outcome| o.parts.softening.iter().filter(|s| s.chi > 0.0).count();
    assert!(
        softening(&a) > 0,
        "no point softened: the test would not exercise the eigen state"
    );
    assert_same(&a, &b);
}

/// The same strip under Newmark's predictor–corrector: each particle's
/// acceleration, which the next step's predictor reads, is saved with it
/// (format 7); without it the resumed predictor would start from a = 0.
#[test]
fn a_resumed_newmark_run_repeats_the_straight_one_bit_for_bit() {
    let text = scene_text(
        "eigen_strip.toml",
        &[
            ("end = 6.0e-3", "end = 2.6e-3"),
            ("series_rows = 121", "series_rows = 53"),
            ("stress_update = \"musl\"", "stress_update = \"newmark\""),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 1800, 200);
    assert!(
        a.parts.accel.iter().any(|q| q[1] != 0.0),
        "no particle accelerates: the test would not exercise the saved a_p"
    );
    assert_same(&a, &b);
}

#[test]
fn a_resumed_run_with_explicit_cracks_repeats_the_straight_one_bit_for_bit() {
    // the centre-cracked plate to 0.1 ms, resumed at step 300: the crack
    // surfaces, their velocities (XPIC(1) reads them), the plane and the
    // particles' ∇u travel in the checkpoint; the series has the crack's
    // ends and length and the tips' J (whose volume term reads the step
    // before each row)
    let text = scene_text(
        "cramp_center_crack.toml",
        &[
            ("end = 2.0e-3", "end = 1.0e-4"),
            ("series_rows = 101", "series_rows = 11"),
            ("snapshots = 7", "snapshots = 3"),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 300, 40);
    assert!(a.series.contains("crack0_length"), "no crack column");
    assert!(a.series.contains("crack0_end_J8"), "no J column");
    assert_same(&a, &b);
}

/// The first and last rows' values of a series' column `name`.
fn first_and_last(series: &str, name: &str) -> (f64, f64) {
    let lines: Vec<&str> = series.lines().collect();
    let at = lines[0].split(',').position(|c| c == name);
    let value = |row: &str| -> f64 { row.split(',').nth(at.unwrap()).unwrap().parse().unwrap() };
    (value(lines[1]), value(lines[lines.len() - 1]))
}

#[test]
fn a_resumed_run_whose_crack_grows_repeats_the_straight_one_bit_for_bit() {
    // the growing edge crack, resumed at step 420 (the crack has grown
    // since step ~340): the grown points, their surfaces and the energy
    // released so far (the series' fracture_energy) travel in the
    // checkpoint, and growth goes on as in the straight run
    let text = scene_text(
        "cramp_edge_growth.toml",
        &[("end = 6.0e-4", "end = 4.0e-4")],
    );
    let (a, b) = straight_and_resumed(&text, 420, 40);
    let (first, last) = first_and_last(&a.series, "crack0_length");
    assert!(
        last > first + 5e-3,
        "the crack grew from {first} m to {last} m"
    );
    let (_, released) = first_and_last(&a.series, "fracture_energy");
    assert!(released > 0.0, "nothing released");
    assert_same(&a, &b);
}

#[test]
fn a_resumed_run_whose_growing_crack_carries_a_pressure_repeats_the_straight_one() {
    // the growing edge crack with a pressure on its faces too (the forces
    // at the grown points, which carry it, and J's pressure term), resumed
    // after it has grown; to 0.3 ms, by which it has grown 6 mm
    // (cracks::a_growing_crack_with_pressed_faces_runs_on goes to 0.4 ms)
    let text = scene_text(
        "cramp_edge_growth.toml",
        &[
            ("end = 6.0e-4", "end = 3.0e-4"),
            (
                "[0.005, 0.0151]] }]",
                "[0.005, 0.0151]], pressure = { table = [[0.0, 0.0], [4.0e-4, 3.0e5]] } }]",
            ),
        ],
    );
    let (a, b) = straight_and_resumed(&text, 280, 40);
    let (first, last) = first_and_last(&a.series, "crack0_length");
    assert!(
        last > first + 5e-3,
        "the crack grew from {first} m to {last} m"
    );
    assert_same(&a, &b);
}

#[test]
fn with_pcg_a_resumed_run_agrees_to_the_solver_tolerance() {
    // the PCG's factor is not in the checkpoint: the first solve after the
    // resume refactorizes, so c differs within the tolerance; with [dfg]
    let text = scene_text(
        "p1_plate_coarse.toml",
        &[
            ("end = 8.0e-5", "end = 1.0e-5"),
            ("snapshots = 9", "snapshots = 2"),
        ],
    ) + "\n[phase_field_solver]\nmethod = \"pcg\"\ntolerance = 1e-10\n\n[dfg]\n";
    let (a, b) = straight_and_resumed(&text, 40, 15);
    assert_eq!(a.steps, b.steps);
    assert_within(&a, &b, 1e-6, "resuming with PCG");
}

/// The particles' c, v and H agree within `tol`, relative to each field's
/// largest magnitude.
fn assert_within(a: &Outcome, b: &Outcome, tol: f64, what: &str) {
    let worst = |f: fn(&Particles) -> Vec<f64>| {
        let (x, y) = (f(&a.parts), f(&b.parts));
        let scale = x.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        x.iter()
            .zip(&y)
            .map(|(p, q)| (p - q).abs())
            .fold(0.0, f64::max)
            / scale
    };
    let dc = worst(|p| p.phase.clone());
    let dv = worst(|p| p.v.iter().flatten().copied().collect());
    let dh = worst(|p| p.history.clone());
    println!("relative differences after {what}: c {dc:.2e}, v {dv:.2e}, H {dh:.2e}");
    assert!(
        dc < tol && dv < tol && dh < tol,
        "{what}: c {dc:e}, v {dv:e}, H {dh:e}"
    );
    assert!(
        a.parts.phase.iter().any(|&c| c < 0.5),
        "no damage: the test would not exercise c"
    );
}

#[test]
fn a_run_resumes_with_another_phase_field_solver_and_agrees_to_its_tolerance() {
    // the direct solve, resumed with the multigrid-preconditioned CG: the
    // solver is not part of what the checkpoint must match
    let text = scene_text(
        "p1_plate_coarse.toml",
        &[
            ("end = 8.0e-5", "end = 1.0e-5"),
            ("snapshots = 9", "snapshots = 2"),
        ],
    );
    let resumed =
        format!("{text}\n[phase_field_solver]\nmethod = \"multigrid\"\ntolerance = 1e-10\n");
    let (a, b) = straight_and_resumed_as(&text, &resumed, 40, 15);
    assert_eq!(a.steps, b.steps);
    assert_within(&a, &b, 1e-6, "resuming with the multigrid");
}

#[test]
fn resuming_refuses_another_scene_and_names_the_field() {
    let text = scene_text("two_disks.toml", &[("end = 3.0", "end = 0.05")]);
    let scene = Scene::from_text(&text, None).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let mut obs = Interrupted {
        writer: OutputWriter::create(tmp.path()).unwrap(),
        at: 3,
        lost: 1,
    };
    Simulation::new(&scene).run(&mut obs).unwrap();
    let cp = OutputWriter::load_checkpoint(tmp.path()).unwrap();
    let other = Scene::from_text(&text.replace("end = 0.05", "end = 0.06"), None).unwrap();
    let e = Simulation::resume(&other, cp.clone()).err().unwrap();
    assert!(matches!(e, CheckpointError::SceneMismatch { .. }), "{e}");
    let msg = e.to_string();
    assert!(
        msg.contains("time.end") && msg.contains("0.06") && msg.contains("0.05"),
        "{msg}"
    );
    // the same scene resumes
    assert!(Simulation::resume(&scene, cp).is_ok());
    // a damaged file is refused with the reason, not a panic
    let path = OutputWriter::checkpoint_path(tmp.path());
    let bytes = std::fs::read(&path).unwrap();
    std::fs::write(&path, &bytes[..bytes.len() / 2]).unwrap();
    let e = OutputWriter::load_checkpoint(tmp.path())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("checkpoint.bin") && e.contains("damaged"), "{e}");
}

/// A state that writes a few bytes: the checkpoint of a method that is
/// not the scene's.
struct OtherState;

impl cleave::checkpoint::SaveState for OtherState {
    fn write(&self, out: &mut dyn std::io::Write) -> Result<(), String> {
        out.write_all(&[1, 2, 3]).map_err(|e| e.to_string())
    }
}

#[test]
fn a_checkpoint_resumes_only_with_the_method_that_wrote_it() {
    let text = scene_text("two_disks.toml", &[("end = 3.0", "end = 0.05")]);
    let scene = Scene::from_text(&text, None).unwrap();
    let cp = Checkpoint::new(&scene, "meshfree", 7, 0.01, std::sync::Arc::new(OtherState));
    let mut bytes = Vec::new();
    cp.write_to(&mut bytes).unwrap();
    let back = Checkpoint::read_from(&mut &bytes[..]).unwrap();
    assert_eq!(
        (back.method(), back.step(), back.time()),
        ("meshfree", 7, 0.01)
    );
    assert_eq!(back.state_bytes(), Some(&[1u8, 2, 3][..]));
    let e = cleave::methods::resume(&scene, back)
        .err()
        .unwrap()
        .to_string();
    assert!(
        e.contains("meshfree") && e.contains(cleave::mpm::METHOD.name),
        "{e}"
    );
    // through the registry, the grid method resumes its own checkpoint
    let tmp = tempfile::tempdir().unwrap();
    let mut obs = Interrupted {
        writer: OutputWriter::create(tmp.path()).unwrap(),
        at: 3,
        lost: 1,
    };
    cleave::methods::build(&scene)
        .unwrap()
        .run(&mut obs)
        .unwrap();
    let cp = OutputWriter::load_checkpoint(tmp.path()).unwrap();
    assert_eq!(cp.method(), cleave::mpm::METHOD.name);
    let resumed = cleave::methods::resume(&scene, cp).unwrap();
    assert_eq!(
        (resumed.name(), resumed.steps()),
        (cleave::mpm::METHOD.name, 3)
    );
}

/// A 3D run (`Simulation<3, 6>` through the method registry) resumes bit
/// for bit: the series and the particles of a run checkpointed, lost some
/// steps later and resumed are the straight run's. Two elastic spheres, and
/// the notched bar while its damage grows (the damage model's saved state:
/// the energy released so far, the particles' damage and strengths), and a
/// sphere striking a beam with a phase field in both.
#[test]
fn a_resumed_3d_run_repeats_the_straight_one_bit_for_bit() {
    resumes_3d(
        scene_text("two_spheres_3d.toml", &[("end = 3.0", "end = 0.9")]),
        40,
        20,
    );
    let bar = scene_text("notched_bar_3d.toml", &[("end = 2.4e-3", "end = 1.0e-3")]);
    assert!(bar.contains("damage"));
    resumes_3d(bar, 1500, 200);
    // a 3D phase field, solved directly (the checkpoint keeps each body's
    // nodal c; the factor is made afresh, the same bits with "direct")
    resumes_3d(common::PF_IMPACT_3D.to_string(), 40, 15);
}

fn resumes_3d(text: String, at: u64, lost: u64) {
    let scene = Scene::from_text(&text, None).unwrap();
    assert_eq!(scene.dimension(), 3);
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("straight"), tmp.path().join("resumed"));
    let parts = |m: &dyn cleave::run::Method| {
        m.as_any()
            .downcast_ref::<Simulation<3, 6>>()
            .expect("the grid method in 3D")
            .particles()
            .clone()
    };

    let mut w = OutputWriter::create(&a).unwrap();
    let mut sim = cleave::methods::build(&scene).unwrap();
    sim.run(&mut w).unwrap();
    w.finish().unwrap();
    let straight = (
        std::fs::read_to_string(a.join("series.csv")).unwrap(),
        parts(sim.as_ref()),
    );

    let mut obs = Interrupted {
        writer: OutputWriter::create(&b).unwrap(),
        at,
        lost,
    };
    let mut sim = cleave::methods::build(&scene).unwrap();
    assert!(sim.run(&mut obs).unwrap().cancelled);
    obs.writer.finish().unwrap();
    let mut cp = OutputWriter::load_checkpoint(&b).unwrap();
    assert_eq!(cp.step(), at);
    let state = std::mem::take(&mut cp.observer);
    let mut sim = cleave::methods::resume(&scene, cp).unwrap();
    let mut w = OutputWriter::resume(&b, &state).unwrap();
    assert!(!sim.run(&mut w).unwrap().cancelled);
    w.finish().unwrap();
    let resumed = (
        std::fs::read_to_string(b.join("series.csv")).unwrap(),
        parts(sim.as_ref()),
    );
    // The solver's counts per row (`pf_*_factorizations`, `pf_fallbacks`)
    // are counted since the last row in the process: on the first row after
    // a resume they count the steps since the checkpoint only (the
    // checkpoint does not keep the interval's counts). Everything computed
    // is the same bits.
    let physics = |series: &str| {
        let rows = without_wall_times(series);
        let keep: Vec<usize> = (0..rows[0].len())
            .filter(|&k| !(rows[0][k].ends_with("_factorizations") || rows[0][k] == "pf_fallbacks"))
            .collect();
        rows.iter()
            .map(|r| keep.iter().map(|&k| r[k].clone()).collect::<Vec<_>>())
            .collect::<Vec<_>>()
    };
    assert_eq!(physics(&straight.0), physics(&resumed.0));
    assert!(straight.0.lines().count() > 5);
    assert!(straight.1 == resumed.1, "the particles differ");
}

/// The damage particle method resumes bit for bit: its bar checkpointed
/// while its weak plane is damaging, lost 500 steps later and resumed,
/// writes the straight run's series and snapshots (the SCNI tables are
/// rebuilt from the scene; the checkpoint keeps d, v, a, the walls'
/// reactions and the damage state).
#[test]
fn a_resumed_damage_particle_run_repeats_the_straight_one_bit_for_bit() {
    let text = scene_text("dpm_bar.toml", &[("end = 22.3", "end = 14.0")]);
    dpm_resumes_bit_for_bit(&text, 8000);
}

/// The same with tractions (the branching plate at 8e-4 m spacing, its
/// tractions ramped up over 20 µs, checkpointed while its crack grows):
/// the loads at the checkpoint's time, not the initial ones, are set
/// again on resuming.
#[test]
fn a_resumed_damage_particle_run_under_tractions_repeats_the_straight_one() {
    let text = scene_text(
        "dpm_branching.toml",
        &[
            ("cell_size = 4.0e-4", "cell_size = 8.0e-4"),
            (
                "[[0.0, 0.0202], [0.05, 0.0202]]",
                "[[0.0, 0.0204], [0.05, 0.0204]]",
            ),
            (
                "min = [0.0494, 0.0196], max = [0.0506, 0.0208]",
                "min = [0.0488, 0.0192], max = [0.0512, 0.0216]",
            ),
            ("end = 8.0e-5", "end = 4.0e-5"),
            (
                "normal = 1.0e6 }",
                "normal = { table = [[0.0, 0.0], [2.0e-5, 1.0e6], [1.0, 1.0e6]] } }",
            ),
        ],
    );
    dpm_resumes_bit_for_bit(&text, 300);
}

/// The static solve resumes bit for bit: the static bar checkpointed
/// while its weak plane softens (the damage history of the last converged
/// step is the state; the iterations start again from the saved d).
#[test]
fn a_resumed_static_damage_particle_run_repeats_the_straight_one() {
    let text = scene_text("dpm_bar_static.toml", &[("dt = 1.0e-4", "dt = 5.0e-5")]);
    dpm_resumes_bit_for_bit(&text, 240);
}

/// Runs a damage particle scene straight, then again stopped 500 steps
/// after a checkpoint at step `at` and resumed from it: the series, the
/// snapshot list and the last snapshot are the same bytes. Damage has
/// started by the checkpoint.
fn dpm_resumes_bit_for_bit(text: &str, at: u64) {
    let scene = Scene::from_text(text, None).unwrap();
    let tmp = tempfile::tempdir().unwrap();
    let (a, b) = (tmp.path().join("straight"), tmp.path().join("resumed"));
    let mut w = OutputWriter::create(&a).unwrap();
    let mut sim = cleave::methods::build(&scene).unwrap();
    assert_eq!(sim.name(), "damage_particle");
    let summary = sim.run(&mut w).unwrap();
    w.finish().unwrap();
    let lost = 500.min((summary.steps - at) / 2);
    assert!(summary.steps > at + 100, "{} steps", summary.steps);
    let mut obs = Interrupted {
        writer: OutputWriter::create(&b).unwrap(),
        at,
        lost,
    };
    let mut sim = cleave::methods::build(&scene).unwrap();
    assert!(sim.run(&mut obs).unwrap().cancelled);
    obs.writer.finish().unwrap();
    let mut cp = OutputWriter::load_checkpoint(&b).unwrap();
    assert_eq!((cp.method(), cp.step()), ("damage_particle", at));
    let state = std::mem::take(&mut cp.observer);
    let mut sim = cleave::methods::resume(&scene, cp).unwrap();
    let mut w = OutputWriter::resume(&b, &state).unwrap();
    assert!(!sim.run(&mut w).unwrap().cancelled);
    w.finish().unwrap();
    let read = |d: &Path, f: &str| std::fs::read(d.join(f)).unwrap();
    let series = String::from_utf8(read(&a, "series.csv")).unwrap();
    let column = series
        .lines()
        .next()
        .unwrap()
        .split(',')
        .position(|c| c == "fracture_energy")
        .unwrap();
    let fracture: Vec<f64> = series
        .lines()
        .skip(1)
        .map(|l| l.split(',').nth(column).unwrap().parse().unwrap())
        .collect();
    let k = (fracture.len() as f64 * at as f64 / summary.steps as f64) as usize;
    assert!(fracture[k] > 0.0, "no damage at the checkpoint");
    assert_eq!(read(&a, "series.csv"), read(&b, "series.csv"));
    assert_eq!(read(&a, "particles.pvd"), read(&b, "particles.pvd"));
    let last = std::fs::read_dir(&a)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".vtp"))
        .max()
        .unwrap();
    assert_eq!(read(&a, &last), read(&b, &last));
}
