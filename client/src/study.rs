//! `cleave study`: one scene at every combination of a few settings, each
//! run's metric against a reference, and the error against wall time
//! (issue 6). The runs happen in this process, one after the other (each
//! with every thread, so that the wall times compare), or on a server,
//! which runs them in parallel up to its own limit.
//!
//! Writes `DIR/study.csv` (a row per run), `DIR/study.png` (error against
//! wall time, log–log, the Pareto front marked) and, per run,
//! `DIR/runs/NNN/scene.json` (the variant, to rerun alone),
//! `DIR/runs/NNN/series.csv` and `DIR/runs/NNN/outcome.json` (how it
//! ended, once it has).
//!
//! A study outlives its process: `--resume` keeps the runs an earlier
//! `cleave study` into the same DIR finished (same scene and settings,
//! checked against their `scene.json`) and runs the others; with
//! `--checkpoint-every` a run in this process saves its state in
//! `DIR/runs/NNN/checkpoint.bin`, and `--resume` goes on from there. On a
//! server each run's job id is kept in `DIR/runs/NNN/job`; `--resume`
//! follows a job the server still has rather than submitting it again.

use crate::remote::{self, Client};
use crate::{report_invalid, EXIT_FAILED, EXIT_INVALID};
use anyhow::Context;
use cleave::checkpoint::CheckpointTimer;
use cleave::diagnostics::{Control, Observer, Progress, Recorder, SeriesRow, Snapshot};
use cleave::run::Method;
use cleave::scene::{Format, SceneError};
use cleave::study::{self, Axis, Metric, Reference, Variant};
use serde_json::json;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

/// What the command line asks for.
pub struct Options {
    pub scene: PathBuf,
    pub vary: Vec<String>,
    pub metric: String,
    pub reference: String,
    pub out: PathBuf,
    pub json: bool,
    /// Keep the runs an earlier study into `out` finished, go on from the
    /// checkpoints of those it did not.
    pub resume: bool,
    /// Save a running variant's state every this many seconds of wall
    /// time (runs in this process only).
    pub checkpoint_every: Option<f64>,
}

/// The variants, validated and written to `DIR/runs`, with the metric and
/// the reference.
pub struct Prepared {
    opts: Options,
    axes: Vec<Axis>,
    metric: Metric,
    reference: Reference,
    variants: Vec<Variant>,
    /// In this process: the first variant's simulation, built to check the
    /// metric's column and then run (seeded once).
    first: Option<Box<dyn Method>>,
    /// With `--resume`: the runs an earlier study finished, kept.
    done: Vec<Option<Outcome>>,
}

/// How one run ended.
pub struct Outcome {
    /// None: finished; Some(reason): failed (the simulation's diagnosis).
    pub failure: Option<String>,
    pub wall_seconds: f64,
    pub steps: u64,
    pub particles: u64,
    pub columns: Vec<String>,
    pub rows: Vec<SeriesRow>,
}

fn run_dir(out: &Path, k: usize) -> PathBuf {
    out.join("runs").join(format!("{k:03}"))
}

/// How a finished run ended, beside its series.
const OUTCOME_FILE: &str = "outcome.json";

/// The server's job id of a run (`--server`).
const JOB_FILE: &str = "job";

/// Writes `outcome.json` of run `k` (after its series).
fn save_outcome(dir: &Path, o: &Outcome) -> std::io::Result<()> {
    let v = json!({"failure": o.failure, "wall_seconds": o.wall_seconds, "steps": o.steps, "particles": o.particles});
    let tmp = dir.join(format!("{OUTCOME_FILE}.tmp"));
    std::fs::write(&tmp, v.to_string())?;
    std::fs::rename(&tmp, dir.join(OUTCOME_FILE))
}

/// A finished run of an earlier study: its `outcome.json` and series.
/// None if it has no outcome yet; Err if what is there cannot be read.
fn load_outcome(dir: &Path) -> Result<Option<Outcome>, String> {
    let path = dir.join(OUTCOME_FILE);
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("{}: {e}", path.display())),
    };
    let bad = |why: String| format!("{}: {why}", path.display());
    let v: serde_json::Value = serde_json::from_str(&text).map_err(|e| bad(e.to_string()))?;
    let number = |key: &str| {
        v.get(key)
            .and_then(|x| x.as_f64())
            .ok_or_else(|| bad(format!("no number {key:?}")))
    };
    let failure = v
        .get("failure")
        .and_then(|f| f.as_str())
        .map(str::to_string);
    let (columns, rows) = match cleave::output::read_series(&dir.join("series.csv")) {
        Ok(s) => s,
        // a run that failed before its first row has no series
        Err(e) if e.error.kind() == std::io::ErrorKind::NotFound && failure.is_some() => {
            (Vec::new(), Vec::new())
        }
        Err(e) => return Err(e.to_string()),
    };
    Ok(Some(Outcome {
        failure,
        wall_seconds: number("wall_seconds")?,
        steps: number("steps")? as u64,
        particles: number("particles")? as u64,
        columns,
        rows,
    }))
}

/// Parses the options, builds and validates every variant (all problems
/// at once, before anything runs) and writes their scenes. `local`: the
/// runs happen here, so the metric's column is checked on the first
/// variant's simulation (against a server that would mean seeding the
/// scene in the client only to ask; there a missing column shows in the
/// rows).
pub fn prepare(opts: Options, local: bool) -> Result<Prepared, ExitCode> {
    let usage = |msg: String| {
        eprintln!("error: {msg}");
        ExitCode::from(EXIT_INVALID)
    };
    if opts.vary.is_empty() {
        return Err(usage("give at least one --vary KEY=V1,V2,…".into()));
    }
    if let Some(s) = opts.checkpoint_every {
        CheckpointTimer::interval(s).map_err(usage)?;
    }
    let axes = opts
        .vary
        .iter()
        .map(|s| Axis::parse(s))
        .collect::<Result<Vec<_>, _>>()
        .map_err(usage)?;
    let metric = Metric::parse(&opts.metric).map_err(usage)?;
    let reference = Reference::parse(&opts.reference).map_err(usage)?;
    let text = match std::fs::read_to_string(&opts.scene) {
        Ok(t) => t,
        Err(e) => {
            return Err(report_invalid(
                &opts.scene,
                &SceneError::single("", format!("cannot read the scene: {e}")),
                opts.json,
            ))
        }
    };
    let format = match opts.scene.extension().and_then(|e| e.to_str()) {
        Some("json") => Format::Json,
        Some("toml") => Format::Toml,
        _ => Format::sniff(&text),
    };
    let variants = study::scene_document(&text, format)
        .and_then(|doc| study::variants(&doc, &axes))
        .map_err(|e| report_invalid(&opts.scene, &e, opts.json))?;
    // the metric's column must exist (the first variant's columns; a
    // setting such as dfg=off can still drop it for others: their rows say so)
    // every variant must run here: refused before anything is written
    if local {
        for v in &variants {
            cleave::methods::runnable(&v.scene)
                .map_err(|e| report_invalid(&opts.scene, &e, opts.json))?;
        }
    }
    let mut first = local
        .then(|| cleave::methods::build(&variants[0].scene))
        .transpose()
        .map_err(|e| report_invalid(&opts.scene, &e, opts.json))?;
    let columns = first.as_mut().map_or_else(
        || vec![metric.column().to_string()],
        |sim| sim.series_columns(),
    );
    if !columns.iter().any(|c| c == metric.column()) {
        return Err(usage(format!(
            "--metric {}: the scene's series has no column {:?} (it has: {})",
            opts.metric,
            metric.column(),
            columns.join(", ")
        )));
    }
    // what an earlier study left in `out`: refused unless resumed, and
    // resumed only with the same variants (nothing stored is overwritten)
    let mut done = Vec::with_capacity(variants.len());
    for (k, v) in variants.iter().enumerate() {
        let dir = run_dir(&opts.out, k);
        let scene_path = dir.join("scene.json");
        let earlier = std::fs::read_to_string(&scene_path).ok();
        let has_results = [OUTCOME_FILE, cleave::output::CHECKPOINT_FILE, JOB_FILE]
            .iter()
            .any(|f| dir.join(f).exists());
        if !opts.resume {
            if has_results {
                return Err(usage(format!(
                    "{} holds the runs of an earlier study: --resume goes on with it (its finished runs are kept), or give another --out",
                    opts.out.display()
                )));
            }
            done.push(None);
            continue;
        }
        match earlier {
            Some(text) if text != v.text => {
                return Err(usage(format!(
                    "--resume: {} is not this study's run {k} ({}): the scene or the --vary settings changed; resume with the ones it was started with, or give another --out",
                    scene_path.display(),
                    label(v)
                )))
            }
            Some(_) => done.push(load_outcome(&dir).map_err(|e| usage(format!("--resume: {e}")))?),
            None => done.push(None),
        }
    }
    // the first variant's simulation, built for the column check, is run
    // only if that variant is to run from its start
    if done[0].is_some()
        || (opts.resume
            && run_dir(&opts.out, 0)
                .join(cleave::output::CHECKPOINT_FILE)
                .exists())
    {
        first = None;
    }
    for (k, v) in variants.iter().enumerate() {
        let dir = run_dir(&opts.out, k);
        if let Err(e) = std::fs::create_dir_all(&dir)
            .and_then(|_| std::fs::write(dir.join("scene.json"), &v.text))
        {
            eprintln!("error: cannot write {}: {e}", dir.display());
            return Err(ExitCode::from(EXIT_FAILED));
        }
    }
    Ok(Prepared {
        opts,
        axes,
        metric,
        reference,
        variants,
        first,
        done,
    })
}

fn label(v: &Variant) -> String {
    v.settings
        .iter()
        .map(|(k, v)| format!("{k}={v}"))
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs the variants one after the other in this process (those an
/// earlier study finished are kept; one it checkpointed goes on from its
/// checkpoint).
pub fn run_local(p: &mut Prepared) -> Vec<Outcome> {
    let n = p.variants.len();
    let mut first = p.first.take();
    let every = p
        .opts
        .checkpoint_every
        .map(std::time::Duration::from_secs_f64);
    let mut out = Vec::with_capacity(n);
    for k in 0..n {
        let v = &p.variants[k];
        if let Some(o) = p.done[k].take() {
            eprintln!(
                "[{}/{n}] {}: finished by the earlier study, kept",
                k + 1,
                label(v)
            );
            out.push(o);
            continue;
        }
        let dir = run_dir(&p.opts.out, k);
        let mut obs = StudyObserver {
            rec: Recorder::series_only(),
            timer: CheckpointTimer::new(every),
            dir: &dir,
            wall_before: 0.0,
            started: std::time::Instant::now(),
        };
        let resumed = match resume_run(v, &dir, &mut obs) {
            Ok(sim) => sim,
            Err(e) => {
                eprintln!(
                    "[{}/{n}] {}: cannot resume ({e}); running it from the start",
                    k + 1,
                    label(v)
                );
                None
            }
        };
        match &resumed {
            Some(sim) => eprintln!(
                "[{}/{n}] {} ({} particles), from its checkpoint at step {}",
                k + 1,
                label(v),
                v.scene.total_particles(),
                sim.steps()
            ),
            None => eprintln!(
                "[{}/{n}] {} ({} particles)",
                k + 1,
                label(v),
                v.scene.total_particles()
            ),
        }
        let sim = match resumed.or_else(|| first.take()) {
            Some(sim) => Ok(sim),
            None => cleave::methods::build(&v.scene),
        };
        first = None;
        obs.started = std::time::Instant::now();
        let result = sim
            .map_err(|e| e.to_string())
            .and_then(|mut sim| sim.run(&mut obs).map_err(|e| e.to_string()));
        let wall = obs.wall_before + obs.started.elapsed().as_secs_f64();
        let (failure, steps) = match result {
            Ok(s) => (None, s.steps),
            Err(e) => (
                Some(e.to_string()),
                obs.rec.rows.last().map_or(0, |r| r.step),
            ),
        };
        let o = Outcome {
            failure,
            wall_seconds: wall,
            steps,
            particles: v.scene.total_particles() as u64,
            columns: obs.rec.columns,
            rows: obs.rec.rows,
        };
        keep(p, k, &o);
        out.push(o);
    }
    out
}

/// The simulation of run `dir` at its checkpoint, with the observer's rows
/// and wall time taken back; None without a checkpoint.
fn resume_run(
    v: &Variant,
    dir: &Path,
    obs: &mut StudyObserver,
) -> Result<Option<Box<dyn Method>>, String> {
    if !cleave::output::OutputWriter::checkpoint_path(dir).exists() {
        return Ok(None);
    }
    let cp = cleave::output::OutputWriter::load_checkpoint(dir).map_err(|e| e.to_string())?;
    let saved: SavedRun =
        serde_json::from_slice(&cp.observer).map_err(|e| format!("its study state: {e}"))?;
    let series = dir.join("series.csv");
    let (columns, mut rows) = cleave::output::read_series(&series).map_err(|e| e.to_string())?;
    if rows.len() < saved.rows {
        return Err(format!(
            "{} has {} rows, the checkpoint {}",
            series.display(),
            rows.len(),
            saved.rows
        ));
    }
    rows.truncate(saved.rows);
    let sim = cleave::methods::resume(&v.scene, cp).map_err(|e| e.to_string())?;
    obs.rec.columns = columns;
    obs.rec.rows = rows;
    obs.wall_before = saved.wall_seconds;
    Ok(Some(sim))
}

/// What a study run's checkpoint keeps of its observer (JSON in
/// `Checkpoint::observer`): the rows then in `series.csv` and the wall
/// time so far.
#[derive(serde::Serialize, serde::Deserialize)]
struct SavedRun {
    rows: usize,
    wall_seconds: f64,
}

/// Keeps a run's series in memory and, when its timer says so, saves the
/// series so far and a checkpoint into the run's directory.
struct StudyObserver<'a> {
    rec: Recorder,
    timer: CheckpointTimer,
    dir: &'a Path,
    /// Wall seconds of the run before it was resumed.
    wall_before: f64,
    started: std::time::Instant,
}

impl Observer for StudyObserver<'_> {
    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        self.rec.series_columns(columns)
    }
    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        self.rec.series_row(row)
    }
    fn snapshot(&mut self, _snapshot: &Snapshot) -> Result<(), String> {
        Ok(())
    }
    fn progress(&mut self, p: &Progress) -> Control {
        if self.timer.due(p) {
            Control::Checkpoint
        } else {
            Control::Continue
        }
    }
    fn checkpoint(&mut self, mut cp: cleave::checkpoint::Checkpoint<'_>) -> Result<(), String> {
        let wall_seconds = self.wall_before + self.started.elapsed().as_secs_f64();
        cleave::output::write_series_csv(
            &self.dir.join("series.csv"),
            &self.rec.columns,
            &self.rec.rows,
        )
        .map_err(|e| e.to_string())?;
        cp.observer = serde_json::to_vec(&SavedRun {
            rows: self.rec.rows.len(),
            wall_seconds,
        })
        .map_err(|e| e.to_string())?;
        cleave::output::save_checkpoint(
            &cleave::output::OutputWriter::checkpoint_path(self.dir),
            &cp,
        )
        .map_err(|e| e.to_string())
    }
}

/// Writes a finished run's series at once (a study cut short keeps the
/// runs it finished) and says how it went.
fn keep(p: &Prepared, k: usize, o: &Outcome) {
    let dir = run_dir(&p.opts.out, k);
    let path = dir.join("series.csv");
    let series = if o.columns.is_empty() {
        Ok(())
    } else {
        cleave::output::write_series_csv(&path, &o.columns, &o.rows)
    };
    match series {
        // the outcome only once the series is whole: `--resume` keeps it
        Ok(()) => {
            if let Err(e) = save_outcome(&dir, o) {
                eprintln!(
                    "warning: cannot write {}: {e}",
                    dir.join(OUTCOME_FILE).display()
                );
            }
            let _ = std::fs::remove_file(cleave::output::OutputWriter::checkpoint_path(&dir));
            let _ = std::fs::remove_file(dir.join(JOB_FILE));
        }
        Err(e) => eprintln!("warning: cannot write {}: {e}", path.display()),
    }
    let metric = match measure(p, o) {
        Ok((v, None)) => format!("metric {v:.6e}"),
        Ok((v, Some(w))) => format!(
            "metric {v:.6e} (from t = {:.4e} s to {:.4e} s)",
            w.from.0, w.to.0
        ),
        Err(e) => format!("no metric: {e}"),
    };
    eprintln!(
        "      {} steps in {:.1} s, {metric}",
        o.steps, o.wall_seconds
    );
}

/// A run's metric, or why it has none (the run failed, or the metric
/// cannot be taken from its series).
fn metric_of(p: &Prepared, o: &Outcome) -> Result<f64, String> {
    measure(p, o).map(|(v, _)| v)
}

/// A run's metric with the rows it spans (`Metric::measure`).
fn measure(p: &Prepared, o: &Outcome) -> Result<(f64, Option<cleave::study::Window>), String> {
    match &o.failure {
        Some(f) => Err(format!("failed: {f}")),
        None => p.metric.measure(&o.columns, &o.rows),
    }
}

/// Submits every variant to the server at once (it runs them up to its
/// limit in parallel), then follows each to its end and fetches its series.
pub async fn run_remote(
    client: &mut Client,
    p: &mut Prepared,
) -> Result<Vec<Outcome>, remote::RemoteError> {
    let n = p.variants.len();
    let mut jobs: Vec<Option<String>> = Vec::with_capacity(n);
    for k in 0..n {
        if p.done[k].is_some() {
            jobs.push(None);
            continue;
        }
        let dir = run_dir(&p.opts.out, k);
        // a job an earlier study submitted, if the server still knows it
        if p.opts.resume {
            if let Ok(id) = std::fs::read_to_string(dir.join(JOB_FILE)) {
                let id = id.trim().to_string();
                match remote::get(client, &id).await {
                    Ok(_) => {
                        eprintln!(
                            "[{}/{n}] {}: following job {id}, submitted by the earlier study",
                            k + 1,
                            label(&p.variants[k])
                        );
                        jobs.push(Some(id));
                        continue;
                    }
                    Err(e) if e.code == crate::EXIT_INVALID => {} // not found: submit again
                    Err(e) => return Err(e),
                }
            }
        }
        let job = remote::submit(
            client,
            &dir.join("scene.json"),
            &format!("study {k:03}: {}", label(&p.variants[k])),
        )
        .await?;
        if let Err(e) = std::fs::write(dir.join(JOB_FILE), &job.id) {
            eprintln!(
                "warning: cannot write {}: {e}",
                dir.join(JOB_FILE).display()
            );
        }
        jobs.push(Some(job.id));
    }
    let mut out = Vec::with_capacity(n);
    for (k, id) in jobs.iter().enumerate() {
        let Some(id) = id else {
            eprintln!(
                "[{}/{n}] {}: finished by the earlier study, kept",
                k + 1,
                label(&p.variants[k])
            );
            out.push(p.done[k].take().expect("a kept run"));
            continue;
        };
        let job = remote::watch(client, id, false, false).await?;
        let s = job.summary.unwrap_or_default();
        let succeeded = job.state == cleave::service::proto::JobState::Succeeded as i32;
        let (columns, rows) = remote::fetch_series(client, id).await?;
        eprintln!(
            "[{}/{n}] {} job {id}: {}",
            k + 1,
            label(&p.variants[k]),
            if succeeded { "done" } else { "ended" }
        );
        out.push(Outcome {
            failure: (!succeeded).then(|| {
                if job.error.is_empty() {
                    "cancelled".to_string()
                } else {
                    job.error.clone()
                }
            }),
            wall_seconds: s.wall_seconds,
            steps: s.steps,
            particles: job.particles,
            columns,
            rows,
        });
        keep(p, k, &out[k]);
    }
    Ok(out)
}

/// One row of `study.csv`.
struct Row {
    status: String,
    metric: f64,
    error: f64,
    reference: bool,
    pareto: bool,
}

/// Writes `study.csv` and `study.png` (each run's series is written as it
/// ends), and prints the table (or JSON).
pub fn finish(p: &Prepared, outcomes: &[Outcome]) -> anyhow::Result<ExitCode> {
    let metrics: Vec<Result<f64, String>> = outcomes.iter().map(|o| metric_of(p, o)).collect();
    // the reference value and which run it is
    let (reference, ref_run) = match p.reference {
        Reference::Analytic(v) => (Some(v), None),
        Reference::Finest => {
            let best = outcomes
                .iter()
                .enumerate()
                .filter(|(k, _)| metrics[*k].is_ok())
                .max_by(|(_, a), (_, b)| {
                    (a.particles as f64 * a.steps as f64)
                        .total_cmp(&(b.particles as f64 * b.steps as f64))
                        .then(a.wall_seconds.total_cmp(&b.wall_seconds))
                })
                .map(|(k, _)| k);
            (best.and_then(|k| metrics[k].clone().ok()), best)
        }
    };
    let errors: Vec<f64> = metrics
        .iter()
        .enumerate()
        .map(|(k, m)| match (m, reference) {
            (Ok(m), Some(r)) if Some(k) != ref_run => study::error(*m, r),
            _ => f64::NAN,
        })
        .collect();
    let points: Vec<(f64, f64)> = outcomes
        .iter()
        .zip(&errors)
        .map(|(o, e)| (o.wall_seconds, *e))
        .collect();
    let front = study::pareto(&points);
    let rows: Vec<Row> = (0..outcomes.len())
        .map(|k| Row {
            status: match &metrics[k] {
                Ok(_) => "ok".into(),
                Err(e) => e.clone(),
            },
            metric: metrics[k].clone().unwrap_or(f64::NAN),
            error: errors[k],
            reference: Some(k) == ref_run,
            pareto: front[k],
        })
        .collect();
    write_csv(p, outcomes, &rows)?;
    let plot_path = p.opts.out.join("study.png");
    let labels: Vec<(f64, f64, String)> = points
        .iter()
        .enumerate()
        .map(|(k, q)| {
            (
                q.0,
                q.1,
                format!(
                    "{k:03} {}",
                    p.variants[k]
                        .settings
                        .iter()
                        .map(|s| s.1.as_str())
                        .collect::<Vec<_>>()
                        .join(" ")
                ),
            )
        })
        .collect();
    let reference_text = match (p.reference, ref_run) {
        (Reference::Analytic(v), _) => format!("{v:e}"),
        (Reference::Finest, Some(k)) => format!("run {k:03}"),
        (Reference::Finest, None) => "none".into(),
    };
    let title = format!("{} against {reference_text}", p.opts.metric);
    let plotted = cleave::output::plot_pareto(
        &plot_path,
        &title,
        "wall time (s)",
        "relative error",
        &labels,
        &front,
    )?;
    if p.opts.json {
        let runs: Vec<_> = (0..outcomes.len())
            .map(|k| {
                let settings: serde_json::Map<String, serde_json::Value> = p.variants[k]
                    .settings
                    .iter()
                    .map(|(a, b)| (a.clone(), json!(b)))
                    .collect();
                json!({
                    "run": k, "settings": settings, "status": rows[k].status,
                    "wall_seconds": outcomes[k].wall_seconds, "steps": outcomes[k].steps,
                    "particles": outcomes[k].particles,
                    "metric": finite(rows[k].metric), "error": finite(rows[k].error),
                    "reference": rows[k].reference, "pareto": rows[k].pareto,
                })
            })
            .collect();
        println!(
            "{}",
            json!({"metric": p.opts.metric, "reference": reference_text, "runs": runs,
                   "csv": p.opts.out.join("study.csv"), "plot": plotted.then(|| plot_path.clone())})
        );
    } else {
        let w = p
            .variants
            .iter()
            .map(|v| label(v).len())
            .max()
            .unwrap_or(8)
            .max(8);
        println!(
            "{:>3}  {:<w$} {:>10} {:>8} {:>10} {:>14} {:>10}",
            "run", "settings", "wall (s)", "steps", "particles", "metric", "error"
        );
        for (k, (o, r)) in outcomes.iter().zip(&rows).enumerate() {
            let err = if r.reference {
                "reference".to_string()
            } else if r.error.is_finite() {
                format!("{:.3e}", r.error)
            } else {
                "-".into()
            };
            let status = if r.status == "ok" {
                String::new()
            } else {
                format!("  {}", r.status)
            };
            println!(
                "{k:>3}  {:<w$} {:>10.3} {:>8} {:>10} {:>14.6e} {:>10}{}{status}",
                label(&p.variants[k]),
                o.wall_seconds,
                o.steps,
                o.particles,
                r.metric,
                err,
                if r.pareto { "  *" } else { "" }
            );
        }
        eprintln!(
            "(* on the Pareto front) wrote {} and {}",
            p.opts.out.join("study.csv").display(),
            plot_path.display()
        );
    }
    Ok(if metrics.iter().any(|m| m.is_ok()) {
        ExitCode::SUCCESS
    } else {
        ExitCode::from(EXIT_FAILED)
    })
}

fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

fn write_csv(p: &Prepared, outcomes: &[Outcome], rows: &[Row]) -> anyhow::Result<()> {
    let path = p.opts.out.join("study.csv");
    let mut w = std::io::BufWriter::new(
        std::fs::File::create(&path).with_context(|| format!("cannot write {}", path.display()))?,
    );
    let keys: Vec<&str> = p.axes.iter().map(|a| a.key.as_str()).collect();
    writeln!(
        w,
        "run,{},status,wall_seconds,steps,particles,metric,error,reference,pareto",
        keys.join(",")
    )?;
    let csv = |s: &str| {
        if s.contains([',', '"', '\n']) {
            format!("\"{}\"", s.replace('"', "\"\""))
        } else {
            s.to_string()
        }
    };
    let num = |v: f64| {
        if v.is_finite() {
            format!("{v:?}")
        } else {
            String::new()
        }
    };
    for (k, (o, r)) in outcomes.iter().zip(rows).enumerate() {
        let settings: Vec<String> = p.variants[k].settings.iter().map(|s| csv(&s.1)).collect();
        writeln!(
            w,
            "{k},{},{},{:?},{},{},{},{},{},{}",
            settings.join(","),
            csv(&r.status),
            o.wall_seconds,
            o.steps,
            o.particles,
            num(r.metric),
            num(r.error),
            r.reference,
            r.pareto
        )?;
    }
    w.flush()?;
    Ok(())
}

/// `cleave study` in this process.
pub fn main_local(opts: Options) -> ExitCode {
    let mut p = match prepare(opts, true) {
        Ok(p) => p,
        Err(code) => return code,
    };
    let outcomes = run_local(&mut p);
    report(finish(&p, &outcomes))
}

/// `cleave study --server URL`.
pub async fn main_remote(
    client: &mut Client,
    opts: Options,
) -> Result<ExitCode, remote::RemoteError> {
    if opts.checkpoint_every.is_some() {
        return Err(remote::RemoteError::new(
            crate::EXIT_INVALID,
            "--checkpoint-every works on runs in this process; a server checkpoints its jobs itself (cleave-server --checkpoint-every)",
        ));
    }
    let mut p = match prepare(opts, false) {
        Ok(p) => p,
        Err(code) => return Ok(code),
    };
    let outcomes = run_remote(client, &mut p).await?;
    Ok(report(finish(&p, &outcomes)))
}

fn report(r: anyhow::Result<ExitCode>) -> ExitCode {
    r.unwrap_or_else(|e| {
        eprintln!("error: {e:#}");
        ExitCode::from(EXIT_FAILED)
    })
}
