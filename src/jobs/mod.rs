//! Jobs: the queue, the runner threads, cancellation, the event log every
//! watcher reads, and the persistent store.
//!
//! Entry point: [`JobManager::start`]. A job goes QUEUED → RUNNING →
//! SUCCEEDED | FAILED | CANCELLED. At most `max_concurrent` jobs run at
//! once, each on its own OS thread (outside any async runtime) with its own
//! rayon pool. A job that fails numerically or panics ends FAILED with the
//! diagnosis; the manager keeps serving.
//!
//! With `checkpoint_every`, a running job saves its state
//! (`mpm::checkpoint`, with its observer's: the series' length, the
//! snapshot and row counts) to `jobs/<id>/checkpoint.bin` at that interval
//! of wall time, and when the server stops (shut down or killed) a job with
//! a checkpoint is not lost: the next server queues it first and resumes
//! it from there, with the same results as a run that never stopped. A
//! shut-down server checkpoints its running jobs before it stops them.

mod bus;
pub mod snapfile;
mod store;

pub use bus::{JobBus, JobEvent};
pub use store::Store;

use crate::diagnostics::{Control, Observer, Progress, SeriesRow, Snapshot};
use crate::scene::{Format, Scene, SceneError};
use serde::{Deserialize, Serialize};
use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// The life of a job.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "SCREAMING_SNAKE_CASE")]
pub enum JobState {
    Queued,
    Running,
    Succeeded,
    Failed,
    Cancelled,
}

impl JobState {
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "QUEUED",
            JobState::Running => "RUNNING",
            JobState::Succeeded => "SUCCEEDED",
            JobState::Failed => "FAILED",
            JobState::Cancelled => "CANCELLED",
        }
    }

    pub fn parse(s: &str) -> Option<JobState> {
        Some(match s {
            "QUEUED" => JobState::Queued,
            "RUNNING" => JobState::Running,
            "SUCCEEDED" => JobState::Succeeded,
            "FAILED" => JobState::Failed,
            "CANCELLED" => JobState::Cancelled,
            _ => return None,
        })
    }

    pub fn is_final(self) -> bool {
        matches!(
            self,
            JobState::Succeeded | JobState::Failed | JobState::Cancelled
        )
    }
}

/// How a finished job ended.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct JobSummary {
    pub steps: u64,
    pub time: f64,
    pub wall_seconds: f64,
    pub kinetic_energy: f64,
    pub strain_energy: f64,
    pub external_work: f64,
    pub energy_error: f64,
    pub snapshots: u32,
    pub series_rows: u32,
}

/// Progress of a running job.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct JobProgress {
    pub step: u64,
    pub time: f64,
    pub end_time: f64,
    pub fraction: f64,
    pub eta_seconds: f64,
    pub kinetic_energy: f64,
    pub strain_energy: f64,
    pub wall_seconds: f64,
}

/// A job as the store and the API see it.
#[derive(Debug, Clone, PartialEq)]
pub struct JobRecord {
    pub id: String,
    pub label: String,
    pub state: JobState,
    pub scene: String,
    pub created_at: f64,
    pub started_at: Option<f64>,
    pub finished_at: Option<f64>,
    pub error: Option<String>,
    pub particles: u64,
    pub stages: Vec<String>,
    pub summary: Option<JobSummary>,
    /// Latest progress (kept in memory while the server runs).
    pub progress: Option<JobProgress>,
    /// The scene's `meta.name` (empty if it has none).
    pub scene_name: String,
}

/// What can go wrong with a request.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{0}")]
    Invalid(#[from] SceneError),
    #[error("{0}")]
    NotFound(String),
    #[error("{0}")]
    Precondition(String),
    #[error("{0}")]
    Exhausted(String),
    #[error("{0}")]
    Store(String),
}

/// Limits and sizes of the job runner.
#[derive(Debug, Clone)]
pub struct JobConfig {
    pub data_dir: PathBuf,
    pub max_concurrent: usize,
    pub threads_per_job: usize,
    pub max_particles: u64,
    /// Bytes a job's run may take by its scene's estimate (None: only the
    /// process's own limits and the memory available).
    pub max_memory: Option<u64>,
    pub max_queued: usize,
    /// Wall time between a running job's checkpoints (None: none).
    pub checkpoint_every: Option<std::time::Duration>,
}

/// Seconds since the Unix epoch.
pub fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

struct Queue {
    waiting: VecDeque<String>,
    /// Cancellation flags of the running jobs.
    running: HashMap<String, Arc<AtomicBool>>,
    shutdown: bool,
}

struct Inner {
    config: JobConfig,
    store: Store,
    queue: Mutex<Queue>,
    wake: Condvar,
    buses: Mutex<HashMap<String, Arc<JobBus>>>,
    /// The server is shutting down: running jobs checkpoint, then stop.
    stopping: AtomicBool,
}

/// Owns the jobs: submit, query, cancel, watch.
#[derive(Clone)]
pub struct JobManager {
    inner: Arc<Inner>,
}

/// Snapshot metadata of a finished or running job.
pub type SnapshotHeader = snapfile::SnapshotHeader;

impl JobManager {
    /// Opens the store, settles jobs a previous server left behind (running
    /// ones resume from their checkpoint, first in the queue, or without
    /// one become FAILED "server stopped"; queued ones are queued again),
    /// and starts the runner threads.
    pub fn start(config: JobConfig) -> Result<JobManager, JobError> {
        let store = Store::open(&config.data_dir)?;
        let queued = store.ids_in_state(JobState::Queued)?;
        let mut waiting = VecDeque::new();
        for id in store.ids_in_state(JobState::Running)? {
            if checkpoint_path(&store.job_dir(&id)).exists() {
                store.set_state(&id, JobState::Queued)?;
                tracing::warn!(job = %id, "the server stopped while it was running: queued to resume from its checkpoint");
                waiting.push_back(id);
            } else {
                store.finish(
                    &id,
                    JobState::Failed,
                    now(),
                    Some("server stopped while the job was running"),
                    None,
                )?;
                tracing::warn!(job = %id, "marked FAILED: the server stopped while it was running");
            }
        }
        waiting.extend(queued);
        let inner = Arc::new(Inner {
            store,
            queue: Mutex::new(Queue {
                waiting,
                running: HashMap::new(),
                shutdown: false,
            }),
            wake: Condvar::new(),
            buses: Mutex::new(HashMap::new()),
            stopping: AtomicBool::new(false),
            config,
        });
        for k in 0..inner.config.max_concurrent.max(1) {
            let inner = inner.clone();
            std::thread::Builder::new()
                .name(format!("cleave-runner-{k}"))
                .spawn(move || runner(inner))
                .map_err(|e| JobError::Store(format!("cannot start a runner thread: {e}")))?;
        }
        Ok(JobManager { inner })
    }

    /// Stops taking jobs from the queue. Running jobs finish their step and
    /// stop; with checkpoints on, they save one first and the next server
    /// resumes them, otherwise they are cancelled.
    pub fn shutdown(&self) {
        let mut q = lock(&self.inner.queue);
        q.shutdown = true;
        self.inner.stopping.store(true, Ordering::SeqCst);
        for flag in q.running.values() {
            flag.store(true, Ordering::SeqCst);
        }
        self.inner.wake.notify_all();
    }

    /// Waits (up to `limit`) until no job runs, after [`Self::shutdown`];
    /// whether they all stopped.
    pub fn wait_stopped(&self, limit: std::time::Duration) -> bool {
        let t0 = Instant::now();
        loop {
            if lock(&self.inner.queue).running.is_empty() {
                return true;
            }
            if t0.elapsed() >= limit {
                return false;
            }
            std::thread::sleep(std::time::Duration::from_millis(20));
        }
    }

    pub fn config(&self) -> &JobConfig {
        &self.inner.config
    }

    /// Checks a scene, its memory estimate against this server's budget
    /// (`--max-memory`) and what the process may still use.
    pub fn validate(&self, text: &str, format: Option<Format>) -> Result<Scene, SceneError> {
        let mut budget = crate::scene::MemoryBudget::process();
        if let Some(bytes) = self.inner.config.max_memory {
            budget = budget.min(crate::scene::MemoryBudget::of(
                bytes,
                "the server's --max-memory",
            ));
        }
        Scene::from_text_within(text, format, &budget)
    }

    /// Validates and queues a scene.
    pub fn submit(
        &self,
        text: &str,
        format: Option<Format>,
        label: &str,
    ) -> Result<JobRecord, JobError> {
        let scene = self.validate(text, format)?;
        self.enqueue(&scene, text, label)
    }

    /// Queues a scene already validated from `text` (the service validates
    /// first, so that a request whose client has gone by then queues
    /// nothing).
    pub fn enqueue(&self, scene: &Scene, text: &str, label: &str) -> Result<JobRecord, JobError> {
        // a valid scene no method runs (a 3D one) is refused here, not
        // failed by its runner
        crate::methods::runnable(scene)?;
        let particles = scene.total_particles() as u64;
        if particles > self.inner.config.max_particles {
            return Err(JobError::Exhausted(format!(
                "the scene has {particles} particles; this server accepts at most {}",
                self.inner.config.max_particles
            )));
        }
        let mut q = lock(&self.inner.queue);
        if q.waiting.len() >= self.inner.config.max_queued {
            return Err(JobError::Exhausted(format!(
                "{} jobs are already queued (the limit is {})",
                q.waiting.len(),
                self.inner.config.max_queued
            )));
        }
        let stages: Vec<String> = scene.plan.names().into_iter().map(String::from).collect();
        let id = self.inner.store.insert(
            label,
            text,
            &scene.file.meta.name,
            now(),
            particles,
            &stages,
        )?;
        let bus = Arc::new(JobBus::new());
        bus.push_state(JobState::Queued, None);
        lock(&self.inner.buses).insert(id.clone(), bus);
        q.waiting.push_back(id.clone());
        self.inner.wake.notify_one();
        drop(q);
        tracing::info!(job = %id, particles, "queued");
        self.get(&id)
    }

    /// A job with its latest progress.
    pub fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        let mut r = self.inner.store.get(id)?;
        if let Some(bus) = lock(&self.inner.buses).get(id) {
            r.progress = bus.last_progress();
        }
        Ok(r)
    }

    pub fn list(
        &self,
        page_size: usize,
        token: &str,
        state: Option<JobState>,
        with_scene: bool,
    ) -> Result<(Vec<JobRecord>, String), JobError> {
        let after = if token.is_empty() {
            None
        } else {
            Some(
                token
                    .parse::<i64>()
                    .map_err(|_| JobError::Precondition(format!("invalid page_token {token:?}")))?,
            )
        };
        let (jobs, next) =
            self.inner
                .store
                .list(page_size.clamp(1, 1000), after, state, with_scene)?;
        Ok((jobs, next.map(|n| n.to_string()).unwrap_or_default()))
    }

    /// Cancels a queued or running job; a finished job is returned as is.
    pub fn cancel(&self, id: &str) -> Result<JobRecord, JobError> {
        let record = self.inner.store.get(id)?;
        let mut q = lock(&self.inner.queue);
        if let Some(pos) = q.waiting.iter().position(|j| j == id) {
            q.waiting.remove(pos);
            drop(q);
            self.inner.store.finish(
                id,
                JobState::Cancelled,
                now(),
                Some("cancelled before it started"),
                None,
            )?;
            self.bus(id).push_state(
                JobState::Cancelled,
                Some("cancelled before it started".into()),
            );
        } else if let Some(flag) = q.running.get(id) {
            flag.store(true, Ordering::SeqCst);
        } else if !record.state.is_final() {
            tracing::warn!(job = %id, state = record.state.as_str(), "cancel: job neither queued nor running");
        }
        self.get(id)
    }

    /// The event log of a job (rebuilt from the store for jobs of an
    /// earlier server).
    pub fn bus(&self, id: &str) -> Arc<JobBus> {
        let mut buses = lock(&self.inner.buses);
        if let Some(b) = buses.get(id) {
            return b.clone();
        }
        let bus = Arc::new(JobBus::new());
        if let Ok(r) = self.inner.store.get(id) {
            bus.push_state(JobState::Queued, None);
            if r.started_at.is_some() {
                bus.push_state(JobState::Running, None);
            }
            if r.state.is_final() {
                if let Some(s) = r.summary {
                    bus.push(JobEvent::Summary(s));
                }
                bus.push_state(r.state, r.error.clone());
            }
        }
        buses.insert(id.to_string(), bus.clone());
        bus
    }

    /// Checks that the job exists and returns its event log.
    pub fn watch(&self, id: &str) -> Result<Arc<JobBus>, JobError> {
        self.inner.store.get(id)?;
        Ok(self.bus(id))
    }

    /// Headers of a job's snapshots, in order.
    pub fn snapshots(&self, id: &str) -> Result<Vec<SnapshotHeader>, JobError> {
        self.inner.store.get(id)?;
        let mut out = Vec::new();
        for k in 0.. {
            let path = snapshot_path(&self.inner.store.job_dir(id), k);
            if !path.exists() {
                break;
            }
            out.push(
                snapfile::SnapshotReader::open(&path)
                    .map_err(JobError::Store)?
                    .header,
            );
        }
        Ok(out)
    }

    /// The index of a job's newest snapshot so far.
    pub fn latest_snapshot(&self, id: &str) -> Result<u32, JobError> {
        let record = self.inner.store.get(id)?;
        let dir = self.inner.store.job_dir(id);
        let count = (0u32..)
            .take_while(|&k| snapshot_path(&dir, k).exists())
            .count() as u32;
        match count.checked_sub(1) {
            Some(last) => Ok(last),
            None if record.state == JobState::Queued => Err(JobError::Precondition(format!(
                "{id} has not started: it has no snapshots yet"
            ))),
            None => Err(JobError::NotFound(format!("{id} has no snapshots"))),
        }
    }

    /// Opens one snapshot of a job.
    pub fn open_snapshot(
        &self,
        id: &str,
        index: u32,
    ) -> Result<snapfile::SnapshotReader, JobError> {
        let record = self.inner.store.get(id)?;
        let path = snapshot_path(&self.inner.store.job_dir(id), index);
        if !path.exists() {
            return Err(if record.state == JobState::Queued {
                JobError::Precondition(format!("{id} has not started: it has no snapshots yet"))
            } else {
                JobError::NotFound(format!("{id} has no snapshot {index}"))
            });
        }
        snapfile::SnapshotReader::open(&path).map_err(JobError::Store)
    }

    /// A job's time series so far: the column names and the rows.
    pub fn series(&self, id: &str) -> Result<(Vec<String>, Vec<SeriesRow>), JobError> {
        let record = self.inner.store.get(id)?;
        let path = self.inner.store.job_dir(id).join("series.csv");
        match crate::output::read_series(&path) {
            Ok(s) => Ok(s),
            Err(e)
                if e.error.kind() != std::io::ErrorKind::InvalidData
                    && (!record.state.is_final() || record.state == JobState::Cancelled) =>
            {
                Err(JobError::Precondition(format!(
                    "{id} has no time series yet"
                )))
            }
            Err(e) => Err(JobError::Store(e.to_string())),
        }
    }
}

fn snapshot_path(dir: &Path, index: u32) -> PathBuf {
    dir.join(format!("snapshot_{index:04}.bin"))
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A runner thread: takes queued jobs one at a time until shutdown.
fn runner(inner: Arc<Inner>) {
    loop {
        let (id, cancel) = {
            let mut q = lock(&inner.queue);
            loop {
                if q.shutdown {
                    return;
                }
                if let Some(id) = q.waiting.pop_front() {
                    let flag = Arc::new(AtomicBool::new(false));
                    q.running.insert(id.clone(), flag.clone());
                    break (id, flag);
                }
                q = inner.wake.wait(q).unwrap_or_else(|p| p.into_inner());
            }
        };
        let manager = JobManager {
            inner: inner.clone(),
        };
        let bus = manager.bus(&id);
        if let Err(e) = run_job(&inner, &id, &bus, &cancel) {
            tracing::error!(job = %id, error = %e, "job bookkeeping failed");
            let msg = format!("internal error: {e}");
            let _ = inner
                .store
                .finish(&id, JobState::Failed, now(), Some(&msg), None);
            bus.push_state(JobState::Failed, Some(msg));
        }
        lock(&inner.queue).running.remove(&id);
    }
}

/// Runs one job to its end and records the outcome.
fn run_job(
    inner: &Inner,
    id: &str,
    bus: &JobBus,
    cancel: &Arc<AtomicBool>,
) -> Result<(), JobError> {
    let record = inner.store.get(id)?;
    let scene = Scene::from_text(&record.scene, None)?;
    inner.store.set_running(id, now())?;
    bus.push_state(JobState::Running, None);
    tracing::info!(job = %id, "running");
    let dir = inner.store.job_dir(id);
    std::fs::create_dir_all(&dir)
        .map_err(|e| JobError::Store(format!("{}: {e}", dir.display())))?;
    let cp_path = checkpoint_path(&dir);
    let resume = if cp_path.exists() {
        match resume_job(&dir) {
            Ok(r) => Some(r),
            Err(e) => {
                let msg = format!("cannot resume from its checkpoint: {e}");
                inner
                    .store
                    .finish(id, JobState::Failed, now(), Some(&msg), None)?;
                bus.push_state(JobState::Failed, Some(msg));
                return Ok(());
            }
        }
    } else {
        None
    };
    let (series, saved, cp) = match resume {
        Some((series, saved, cp)) => {
            tracing::info!(job = %id, step = cp.step(), time = cp.time(), "resumes from its checkpoint");
            (series, saved, Some(cp))
        }
        None => {
            let series = std::fs::File::create(dir.join("series.csv"))
                .map_err(|e| JobError::Store(format!("{}: {e}", dir.display())))?;
            (series, ObserverState::default(), None)
        }
    };
    let mut observer = JobObserver {
        dir: dir.clone(),
        series: std::io::BufWriter::new(series),
        bus,
        cancel: cancel.clone(),
        started: Instant::now(),
        last_emit: None,
        snapshots: saved.snapshots,
        rows: saved.rows,
        last_row: saved.last_row,
        wall_before: saved.wall_seconds,
        checkpoints: crate::checkpoint::CheckpointTimer::new(inner.config.checkpoint_every),
        stopping: &inner.stopping,
        stop_next: false,
    };
    let threads = inner.config.threads_per_job.max(1);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(move |k| format!("cleave-job-{k}"))
        .build()
        .map_err(|e| JobError::Store(format!("cannot build a thread pool: {e}")))?;
    let outcome = pool.install(|| {
        std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let mut sim = match cp {
                Some(cp) => crate::methods::resume(&scene, cp)
                    .map_err(|e| format!("cannot resume from its checkpoint: {e}"))?,
                None => crate::methods::build(&scene).map_err(|e| e.to_string())?,
            };
            sim.run(&mut observer).map_err(|e| e.to_string())
        }))
    });
    let _ = std::io::Write::flush(&mut observer.series);
    let wall = observer.wall_before + observer.started.elapsed().as_secs_f64();
    if inner.stopping.load(Ordering::SeqCst)
        && observer.stop_next
        && matches!(&outcome, Ok(Ok(s)) if s.cancelled)
    {
        // stopped by the server's shutdown after a checkpoint: the next
        // server resumes it (the store keeps it RUNNING until then)
        bus.push_state(
            JobState::Queued,
            Some(
                "the server is stopping; the job resumes from its checkpoint when it starts again"
                    .into(),
            ),
        );
        tracing::info!(job = %id, "checkpointed for the next server");
        return Ok(());
    }
    let _ = std::fs::remove_file(&cp_path);
    let mut summary = JobSummary {
        wall_seconds: wall,
        snapshots: observer.snapshots,
        series_rows: observer.rows,
        ..Default::default()
    };
    if let Some(r) = observer.last_row {
        summary.steps = r.step;
        summary.time = r.time;
        summary.kinetic_energy = r.kinetic_energy;
        summary.strain_energy = r.strain_energy;
        summary.external_work = r.external_work;
        summary.energy_error = r.energy_error;
    }
    let (state, error) = match outcome {
        Ok(Ok(s)) if s.cancelled => (
            JobState::Cancelled,
            Some("cancelled while running".to_string()),
        ),
        Ok(Ok(s)) => {
            summary.steps = s.steps;
            summary.time = s.time;
            (JobState::Succeeded, None)
        }
        Ok(Err(e)) => (JobState::Failed, Some(e)),
        Err(panic) => {
            let what = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".into());
            (
                JobState::Failed,
                Some(format!("internal error (panic): {what}")),
            )
        }
    };
    inner
        .store
        .finish(id, state, now(), error.as_deref(), Some(&summary))?;
    bus.push(JobEvent::Summary(summary));
    bus.push_state(state, error.clone());
    tracing::info!(job = %id, state = state.as_str(), error = error.as_deref().unwrap_or(""), wall, "finished");
    Ok(())
}

/// A job's checkpoint file in its directory.
fn checkpoint_path(dir: &Path) -> PathBuf {
    dir.join(crate::output::CHECKPOINT_FILE)
}

/// What a job's checkpoint keeps of its observer.
#[derive(Debug, Default, Serialize, Deserialize)]
pub(crate) struct ObserverState {
    /// Length of `series.csv` at the checkpoint.
    series_bytes: u64,
    snapshots: u32,
    rows: u32,
    last_row: Option<SeriesRow>,
    /// Wall time the job had run, s.
    wall_seconds: f64,
}

/// A job's checkpoint, read back: its series cut back to the checkpoint
/// (and opened to append), the observer's counts, and the checkpoint for
/// [`crate::methods::resume`].
fn resume_job(
    dir: &Path,
) -> Result<
    (
        std::fs::File,
        ObserverState,
        crate::checkpoint::Checkpoint<'static>,
    ),
    String,
> {
    let cp =
        crate::checkpoint::Checkpoint::load(&checkpoint_path(dir)).map_err(|e| e.to_string())?;
    let saved: ObserverState =
        postcard::from_bytes(&cp.observer).map_err(|e| format!("its observer state: {e}"))?;
    let series = crate::output::reopen_series(&dir.join("series.csv"), saved.series_bytes)
        .map_err(|e| e.to_string())?;
    Ok((series, saved, cp))
}

/// Streams a running job's results to its directory and its event log.
struct JobObserver<'a> {
    dir: PathBuf,
    series: std::io::BufWriter<std::fs::File>,
    bus: &'a JobBus,
    cancel: Arc<AtomicBool>,
    started: Instant,
    last_emit: Option<(Instant, f64)>,
    snapshots: u32,
    rows: u32,
    last_row: Option<SeriesRow>,
    /// Wall time of the job before its resume, s.
    wall_before: f64,
    checkpoints: crate::checkpoint::CheckpointTimer,
    stopping: &'a AtomicBool,
    /// A checkpoint for the server's shutdown was saved: stop.
    stop_next: bool,
}

impl Observer for JobObserver<'_> {
    fn checkpoint(&mut self, mut cp: crate::checkpoint::Checkpoint<'_>) -> Result<(), String> {
        let series_bytes =
            crate::output::flushed_len(&mut self.series, &self.dir.join("series.csv"))
                .map_err(|e| e.to_string())?;
        let state = ObserverState {
            series_bytes,
            snapshots: self.snapshots,
            rows: self.rows,
            last_row: self.last_row.clone(),
            wall_seconds: self.wall_before + self.started.elapsed().as_secs_f64(),
        };
        cp.observer = postcard::to_stdvec(&state).map_err(|e| e.to_string())?;
        crate::output::save_checkpoint(&checkpoint_path(&self.dir), &cp).map_err(|e| e.to_string())
    }

    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        use std::io::Write;
        writeln!(self.series, "{}", columns.join(","))
            .map_err(|e| format!("{}: {e}", self.dir.join("series.csv").display()))
    }

    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        use std::io::Write;
        crate::output::write_series_line(&mut self.series, row)
            .and_then(|_| self.series.flush())
            .map_err(|e| format!("{}: {e}", self.dir.join("series.csv").display()))?;
        self.rows += 1;
        self.last_row = Some(row.clone());
        Ok(())
    }

    fn snapshot(&mut self, snap: &Snapshot) -> Result<(), String> {
        if self.cancel.load(Ordering::SeqCst) {
            return Ok(()); // cancelled: write nothing more
        }
        snapfile::write(&snapshot_path(&self.dir, snap.index), snap)?;
        self.snapshots += 1;
        Ok(())
    }

    fn progress(&mut self, p: &Progress) -> Control {
        if self.cancel.load(Ordering::SeqCst) {
            // a shutdown (not a user's cancel) saves a checkpoint first
            if self.checkpoints.enabled()
                && self.stopping.load(Ordering::SeqCst)
                && !self.stop_next
                && p.time < p.end_time
            {
                self.stop_next = true;
                return Control::Checkpoint;
            }
            return Control::Stop;
        }
        // At most one progress event per 1 % or 0.25 s.
        let now = Instant::now();
        let fraction = p.fraction();
        let due = match self.last_emit {
            None => true,
            Some((t, f)) => {
                fraction - f >= 0.01 || (now - t).as_secs_f64() >= 0.25 || fraction >= 1.0
            }
        };
        if due {
            let wall = (now - self.started).as_secs_f64();
            let eta = if fraction > 0.0 {
                wall * (1.0 - fraction) / fraction
            } else {
                0.0
            };
            self.bus.push(JobEvent::Progress(JobProgress {
                step: p.step,
                time: p.time,
                end_time: p.end_time,
                fraction,
                eta_seconds: eta,
                kinetic_energy: p.kinetic_energy,
                strain_energy: p.strain_energy,
                wall_seconds: wall,
            }));
            self.last_emit = Some((now, fraction));
        }
        if self.checkpoints.due(p) {
            Control::Checkpoint
        } else {
            Control::Continue
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::output::parse_series;

    #[test]
    fn series_files_read_back_with_the_scenes_columns() {
        let core = SeriesRow::COLUMNS.join(",");
        let ones = vec!["1"; SeriesRow::COLUMNS.len()].join(",");
        // a phase-field series: two extra columns; the last row was cut
        // short by a crash
        let text = format!(
            "{core},pf_residual,crack_length\n{ones},NaN,0.05\n{ones},1e-3,0.06\n{ones},2e-3\n"
        );
        let (columns, rows) = parse_series(&text).unwrap();
        assert_eq!(columns.len(), SeriesRow::COLUMNS.len() + 2);
        assert_eq!(rows.len(), 2);
        assert!(rows[0].get(&columns, "pf_residual").unwrap().is_nan());
        assert_eq!(rows[1].get(&columns, "crack_length"), Some(0.06));
        assert_eq!(rows[1].get(&columns, "kinetic_energy"), Some(1.0));
        // a job that failed before its first row: no header yet
        let (columns, rows) = parse_series("").unwrap();
        assert_eq!(columns, SeriesRow::COLUMNS);
        assert!(rows.is_empty());
        // a foreign file is an error
        assert!(parse_series("a,b\n1,2\n").is_err());
    }
}
