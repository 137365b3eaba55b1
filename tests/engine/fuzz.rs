//! Hostile scenes: the shipped scenes (`scenes/*.toml`) mutated at random
//! (numbers scaled by extreme factors or replaced by 0, ∞, NaN or a
//! subnormal, signs flipped, keys deleted, array entries duplicated,
//! strings and types replaced) and then validated and, when valid and
//! small, run for a few steps. Every case must end, in bounded time,
//! without a panic, as a success (exit 0), a run that stopped with a
//! diagnosis naming the step (exit 1) or a refusal naming the field
//! (exit 2).
//!
//! `cargo test --release --test engine fuzz::` runs a few hundred cases (seeded:
//! the same cases every time); the long version, ten thousand and more,
//! is `CLEAVE_FUZZ_CASES=10000 cargo test --release --test engine fuzz:: -- --ignored --nocapture`
//! (`docs/stability.md`). A failing case prints its seed and writes its
//! scene to the temporary directory.

use cleave::diagnostics::{Control, Observer, Progress, SeriesRow, Snapshot};
use cleave::scene::{Format, Scene};
use rand_core::{RngCore, SeedableRng};
use rand_pcg::Pcg64;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::Path;
use std::time::{Duration, Instant};

/// Runs at most this many particles (larger valid scenes are validated
/// only).
const RUN_PARTICLES: usize = 100_000;
/// Steps per run.
const RUN_STEPS: u64 = 5;
/// A case (validation and the short run) that takes longer fails.
const CASE_LIMIT: Duration = Duration::from_secs(20);

/// The shipped scenes, parsed.
fn shipped() -> Vec<(String, toml::Table)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes");
    let mut names: Vec<_> = std::fs::read_dir(&dir)
        .expect("scenes/")
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "toml"))
        .collect();
    names.sort();
    names
        .into_iter()
        .map(|p| {
            let text = std::fs::read_to_string(&p).expect("read scene");
            let table: toml::Table = toml::from_str(&text).expect("a shipped scene parses");
            (p.file_name().unwrap().to_string_lossy().into_owned(), table)
        })
        .collect()
}

fn pick<'a, T>(rng: &mut Pcg64, v: &'a [T]) -> &'a T {
    &v[(rng.next_u64() % v.len() as u64) as usize]
}

/// A path into a TOML tree: table keys and array indices.
#[derive(Debug, Clone)]
enum Step {
    Key(String),
    Index(usize),
}

/// Every node of the tree below `v` (not `v` itself), by path.
fn paths(v: &toml::Value, at: &mut Vec<Step>, out: &mut Vec<Vec<Step>>) {
    match v {
        toml::Value::Table(t) => {
            for (k, x) in t {
                at.push(Step::Key(k.clone()));
                out.push(at.clone());
                paths(x, at, out);
                at.pop();
            }
        }
        toml::Value::Array(a) => {
            for (i, x) in a.iter().enumerate() {
                at.push(Step::Index(i));
                out.push(at.clone());
                paths(x, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn node<'a>(v: &'a mut toml::Value, path: &[Step]) -> Option<&'a mut toml::Value> {
    path.iter().try_fold(v, |v, s| match (s, v) {
        (Step::Key(k), toml::Value::Table(t)) => t.get_mut(k),
        (Step::Index(i), toml::Value::Array(a)) => a.get_mut(*i),
        _ => None,
    })
}

const FACTORS: [f64; 14] = [
    0.0, -1.0, 0.5, 2.0, 1e-300, 1e-30, 1e-8, 1e8, 1e30, 1e300, 1e308, 4.9e-324, 1e-310, 1e154,
];
const STRINGS: [&str; 10] = [
    "",
    "nonsense",
    "box",
    "disk",
    "polygon",
    "linear",
    "neo_hookean",
    "fixed",
    "plane_stress",
    "\u{1F4A5}",
];

/// One random mutation of `root`.
fn mutate(rng: &mut Pcg64, root: &mut toml::Value) {
    let mut all = Vec::new();
    paths(root, &mut Vec::new(), &mut all);
    if all.is_empty() {
        return;
    }
    let path = pick(rng, &all).clone();
    let kind = rng.next_u64() % 10;
    // the parent, to delete or duplicate the node
    if kind == 0 || kind == 1 {
        let (last, parent) = path.split_last().expect("a path has a step");
        let Some(p) = node(root, parent) else { return };
        match (last, p) {
            (Step::Key(k), toml::Value::Table(t)) => {
                if kind == 0 {
                    t.remove(k);
                } else if let Some(v) = t.get(k).cloned() {
                    // the same value under another, unknown key
                    t.insert(format!("{k}_again"), v);
                }
            }
            (Step::Index(i), toml::Value::Array(a)) => {
                if kind == 0 {
                    a.remove(*i);
                } else {
                    let v = a[*i].clone();
                    let copies = 1 + (rng.next_u64() % 40) as usize;
                    for _ in 0..copies {
                        a.push(v.clone());
                    }
                }
            }
            _ => {}
        }
        return;
    }
    let Some(v) = node(root, &path) else { return };
    match v {
        toml::Value::Float(x) => {
            *x = match kind {
                2 => -*x,
                3 => *pick(rng, &[f64::NAN, f64::INFINITY, f64::NEG_INFINITY, f64::MAX]),
                _ => *x * *pick(rng, &FACTORS),
            }
        }
        toml::Value::Integer(n) => {
            *n = match kind {
                2 => -*n,
                3 => *pick(rng, &[0, 1, 3, 65, 1 << 31, 1 << 40, i64::MAX, i64::MIN]),
                _ => n.saturating_mul(*pick(rng, &[0, 2, 10, 1000, 1 << 20])),
            }
        }
        toml::Value::String(s) => *s = pick(rng, &STRINGS).to_string(),
        toml::Value::Boolean(b) => *b = !*b,
        other => {
            // another type in place of a table or an array
            *other = match kind {
                2 => toml::Value::Float(1.0),
                3 => toml::Value::String("x".into()),
                4 => toml::Value::Array(Vec::new()),
                _ => return,
            }
        }
    }
}

/// Stops a run after [`RUN_STEPS`].
struct Short;

impl Observer for Short {
    fn series_columns(&mut self, _: &[String]) -> Result<(), String> {
        Ok(())
    }
    fn series_row(&mut self, _: &SeriesRow) -> Result<(), String> {
        Ok(())
    }
    fn snapshot(&mut self, _: &Snapshot) -> Result<(), String> {
        Ok(())
    }
    fn progress(&mut self, p: &Progress) -> Control {
        if p.step >= RUN_STEPS {
            Control::Stop
        } else {
            Control::Continue
        }
    }
}

/// How a case ended: the CLI's exit code and its message.
#[derive(Debug)]
enum Outcome {
    /// Exit 0: valid (and, if small, ran its steps).
    Ran,
    /// Exit 0: valid, too large to run here.
    Valid,
    /// Exit 1: the run stopped; the message names the step.
    Stopped(String),
    /// Exit 2: refused; each entry names a field.
    Refused(Vec<String>),
}

/// Validates and, when small enough, runs the scene `text`.
fn one_case(text: &str) -> Outcome {
    let scene = match Scene::from_text(text, Some(Format::Toml)) {
        Ok(s) => s,
        Err(e) => return Outcome::Refused(e.errors.iter().map(|f| f.to_string()).collect()),
    };
    if scene.total_particles() > RUN_PARTICLES {
        return Outcome::Valid;
    }
    // what `run` does: the method for the scene's dimension, or the
    // refusal of what it does not run yet (a 3D fracture model, say)
    let mut sim = match cleave::methods::build(&scene) {
        Ok(sim) => sim,
        Err(e) => return Outcome::Refused(e.errors.iter().map(|f| f.to_string()).collect()),
    };
    match sim.run(&mut Short) {
        Ok(_) => Outcome::Ran,
        Err(e) => Outcome::Stopped(e.to_string()),
    }
}

/// Whether a refusal's entry names where the problem is: a field path
/// (`grid.cell_size: ...`), a field in its message (toml's `missing field
/// \`end\``) or a line and column.
fn names_a_field(entry: &str) -> bool {
    let path = entry.split(": ").next().unwrap_or("");
    let is_path = !path.is_empty()
        && !path.contains(' ')
        && path.chars().next().is_some_and(|c| c.is_ascii_lowercase());
    is_path || entry.contains('`') || entry.contains("line ")
}

/// Runs `cases` mutated scenes from `seed`; panics naming the first bad one.
fn fuzz(seed: u64, cases: usize) {
    let scenes = shipped();
    let mut rng = Pcg64::seed_from_u64(seed);
    let (mut ran, mut valid, mut stopped, mut refused) = (0, 0, 0, 0);
    let mut slowest = (Duration::ZERO, 0);
    let wall = Instant::now();
    for case in 0..cases {
        let (name, table) = pick(&mut rng, &scenes);
        let mut root = toml::Value::Table(table.clone());
        let mutations = 1 + rng.next_u64() % 3;
        for _ in 0..mutations {
            mutate(&mut rng, &mut root);
        }
        let text = toml::to_string(&root).unwrap_or_default();
        let fail = |why: String| -> ! {
            let file = std::env::temp_dir().join(format!("cleave-fuzz-{seed}-{case}.toml"));
            let _ = std::fs::write(&file, &text);
            panic!(
                "case {case} (seed {seed}, from {name}, scene in {}): {why}",
                file.display()
            );
        };
        let t0 = Instant::now();
        let outcome = match catch_unwind(AssertUnwindSafe(|| one_case(&text))) {
            Ok(o) => o,
            Err(p) => {
                let msg = p
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| p.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                fail(format!("panicked: {msg}"))
            }
        };
        let took = t0.elapsed();
        if took > slowest.0 {
            slowest = (took, case);
        }
        if took > CASE_LIMIT {
            fail(format!("took {took:?} ({outcome:?})"));
        }
        match outcome {
            Outcome::Ran => ran += 1,
            Outcome::Valid => valid += 1,
            Outcome::Stopped(msg) => {
                if !msg.starts_with("step ") {
                    fail(format!("exit 1 without naming the step: {msg}"));
                }
                stopped += 1;
            }
            Outcome::Refused(errors) => {
                if errors.is_empty() {
                    fail("exit 2 without a reason".into());
                }
                if let Some(e) = errors.iter().find(|e| !names_a_field(e)) {
                    fail(format!("exit 2 without naming the field: {e}"));
                }
                refused += 1;
            }
        }
    }
    println!(
        "{cases} cases from seed {seed} in {:.1} s: {ran} ran {RUN_STEPS} steps, {valid} valid but not run, \
         {stopped} stopped with a diagnosis, {refused} refused; slowest case {} ({:?})",
        wall.elapsed().as_secs_f64(),
        slowest.1,
        slowest.0
    );
}

#[test]
fn every_shipped_scene_validates_unmutated() {
    for (name, table) in shipped() {
        let text = toml::to_string(&table).unwrap();
        match Scene::from_text(&text, Some(Format::Toml)) {
            Ok(s) => println!(
                "{name}: {} particles, dt {:.3e} s, {:.3e} steps at least, memory {}",
                s.total_particles(),
                s.time_step.dt,
                s.time_step.steps,
                s.memory
            ),
            Err(e) => panic!("{name}: {e}"),
        }
    }
}

#[test]
fn refusals_name_their_field() {
    assert!(names_a_field("grid.cell_size: must be > 0, got 0"));
    assert!(names_a_field("bodies[0].shape: holds no particle"));
    assert!(names_a_field("missing field `end`"));
    assert!(!names_a_field("the scene is wrong"));
}

#[test]
fn mutated_scenes_end_with_a_diagnosis() {
    fuzz(2026, 300);
}

/// The long version: `CLEAVE_FUZZ_CASES` cases (10 000 by default) from
/// `CLEAVE_FUZZ_SEED` (1).
#[test]
#[ignore = "long: thousands of cases (docs/stability.md)"]
fn mutated_scenes_long() {
    let env = |k: &str, d: u64| {
        std::env::var(k)
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(d)
    };
    fuzz(
        env("CLEAVE_FUZZ_SEED", 1),
        env("CLEAVE_FUZZ_CASES", 10_000) as usize,
    );
}
