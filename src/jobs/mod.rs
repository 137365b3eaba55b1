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
//!
//! The result files live in the data directory or, with
//! [`ResultsSpec::Bucket`], in an S3-compatible bucket ([`results`]).

mod bus;
pub mod pg;
pub mod results;
pub mod snapfile;
mod store;

pub use bus::{JobBus, JobEvent};
pub use pg::PgStore;
pub use results::ResultsSpec;
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
    /// In a fleet, the server (`host-pid`) that runs it or ran it last;
    /// empty otherwise.
    pub worker: String,
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
    /// The job database cannot be reached (for now).
    #[error("{0}")]
    Unavailable(String),
    /// A worker's claim on a job was taken over by another worker.
    #[error("{0}")]
    Fenced(String),
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
    /// Where the job records live.
    pub store: StoreSpec,
    /// Where the result files live.
    pub results: ResultsSpec,
}

/// Where a server keeps its job records.
#[derive(Debug, Clone, PartialEq)]
pub enum StoreSpec {
    /// `cleave.sqlite` in the data directory: one server.
    Sqlite,
    /// A PostgreSQL database that several servers share (a fleet), with
    /// the data directory on storage they all reach; a job's claim is
    /// leased for `lease` and renewed every [`RENEW_EVERY`].
    Postgres {
        url: String,
        lease: std::time::Duration,
    },
}

impl StoreSpec {
    /// `sqlite` (or empty), or a `postgres://` / `postgresql://` URL (or
    /// key=value connection string starting with `host=`), leased for
    /// `lease_s` seconds.
    pub fn parse(text: &str, lease_s: f64) -> Result<StoreSpec, String> {
        let t = text.trim();
        if t.is_empty() || t == "sqlite" {
            return Ok(StoreSpec::Sqlite);
        }
        if !(t.starts_with("postgres://")
            || t.starts_with("postgresql://")
            || t.starts_with("host="))
        {
            return Err(format!(
                "--store: {t:?} is neither `sqlite` nor a PostgreSQL URL (postgres://user@host/db)"
            ));
        }
        if !(lease_s.is_finite() && (1.0..=3600.0).contains(&lease_s)) {
            return Err(format!(
                "--lease: {lease_s} s; a lease is 1 to 3600 s (renewed every {} ms)",
                RENEW_EVERY.as_millis()
            ));
        }
        Ok(StoreSpec::Postgres {
            url: t.to_string(),
            lease: std::time::Duration::from_secs_f64(lease_s),
        })
    }
}

/// Seconds since the Unix epoch.
pub fn now() -> f64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64())
}

struct Queue {
    /// Jobs waiting to run (one server; a fleet's queue is its database).
    waiting: VecDeque<String>,
    /// Cancellation flags of the running jobs.
    running: HashMap<String, Arc<AtomicBool>>,
    shutdown: bool,
}

/// Where a manager keeps its jobs.
enum Backend {
    Local(Store),
    Fleet(Box<Fleet>),
}

/// A server's part in a fleet.
struct Fleet {
    /// The connection of the API's calls.
    api: PgStore,
    /// This server's name in claims (`host-pid`).
    worker: String,
    lease: std::time::Duration,
    /// The jobs this server runs, by id.
    held: Mutex<HashMap<String, Held>>,
    /// The database answered the last renewal or ping.
    reachable: AtomicBool,
}

/// A job this server has claimed.
struct Held {
    token: i64,
    cancel: Arc<AtomicBool>,
    /// The claim is no longer ours (or may not be): write nothing more.
    lost: Arc<AtomicBool>,
}

impl Backend {
    fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        match self {
            Backend::Local(s) => s.get(id),
            Backend::Fleet(f) => f.api.get(id),
        }
    }

    fn job_dir(&self, id: &str) -> PathBuf {
        match self {
            Backend::Local(s) => s.job_dir(id),
            Backend::Fleet(f) => f.api.job_dir(id),
        }
    }
}

struct Inner {
    config: JobConfig,
    store: Backend,
    /// The results' bucket (None: the data directory).
    bucket: Option<results::Bucket>,
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

/// How often an idle fleet runner asks the database for a job.
const CLAIM_POLL: std::time::Duration = std::time::Duration::from_millis(250);
/// How often a fleet server renews its leases (and so learns of a cancel
/// asked for on another server).
const RENEW_EVERY: std::time::Duration = std::time::Duration::from_millis(250);
/// How often a fleet server reads the new events of the jobs watched on it.
pub const EVENT_POLL: std::time::Duration = std::time::Duration::from_millis(100);

/// This process's name in a fleet: the host's name and the process id.
fn worker_name() -> String {
    let host = std::fs::read_to_string("/proc/sys/kernel/hostname")
        .ok()
        .or_else(|| std::env::var("HOSTNAME").ok())
        .map(|h| h.trim().to_string())
        .filter(|h| !h.is_empty())
        .unwrap_or_else(|| "host".into());
    format!("{host}-{}", std::process::id())
}

impl JobManager {
    /// Opens the store and starts the runner threads. With SQLite (one
    /// server) it first settles the jobs a previous server left behind:
    /// running ones resume from their checkpoint, first in the queue, or
    /// without one become FAILED "server stopped"; queued ones are queued
    /// again. In a fleet there is nothing to settle: a job whose server
    /// died is claimed again when its lease lapses.
    pub fn start(config: JobConfig) -> Result<JobManager, JobError> {
        let mut waiting = VecDeque::new();
        let bucket = match &config.results {
            ResultsSpec::DataDir => None,
            ResultsSpec::Bucket { url } => {
                let b = results::Bucket::open(url, &config.data_dir)?;
                tracing::info!(results = %url, "results in a bucket");
                Some(b)
            }
        };
        let store = match &config.store {
            StoreSpec::Sqlite => {
                let store = Store::open(&config.data_dir)?;
                let queued = store.ids_in_state(JobState::Queued)?;
                for id in store.ids_in_state(JobState::Running)? {
                    let checkpointed = match &bucket {
                        None => checkpoint_path(&store.job_dir(&id)).exists(),
                        Some(b) => b
                            .objects(&id)?
                            .iter()
                            .any(|o| o.name == crate::output::CHECKPOINT_FILE),
                    };
                    if checkpointed {
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
                Backend::Local(store)
            }
            StoreSpec::Postgres { url, lease } => {
                let worker = worker_name();
                tracing::info!(%worker, lease_s = lease.as_secs_f64(), "a worker of the fleet");
                Backend::Fleet(Box::new(Fleet {
                    api: PgStore::open(url, &config.data_dir)?,
                    worker,
                    lease: *lease,
                    held: Mutex::new(HashMap::new()),
                    reachable: AtomicBool::new(true),
                }))
            }
        };
        let inner = Arc::new(Inner {
            store,
            bucket,
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
        let spawn = |name: String, f: Box<dyn FnOnce() + Send>| {
            std::thread::Builder::new()
                .name(name)
                .spawn(f)
                .map(|_| ())
                .map_err(|e| JobError::Store(format!("cannot start a thread: {e}")))
        };
        for k in 0..inner.config.max_concurrent.max(1) {
            let inner = inner.clone();
            spawn(
                format!("cleave-runner-{k}"),
                Box::new(move || runner(inner)),
            )?;
        }
        if let Backend::Fleet(f) = &inner.store {
            let (keeper, pump) = (f.api.connection(), f.api.connection());
            let i = inner.clone();
            spawn(
                "cleave-leases".into(),
                Box::new(move || keeper_loop(i, keeper)),
            )?;
            let i = inner.clone();
            spawn("cleave-events".into(), Box::new(move || pump_loop(i, pump)))?;
        }
        Ok(JobManager { inner })
    }

    /// Stops taking jobs from the queue. Running jobs finish their step and
    /// stop; with checkpoints on, they save one first and the next server
    /// resumes them (in a fleet, any server: the job goes back to the
    /// queue), otherwise they are cancelled (in a fleet, queued again to
    /// run from the start).
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

    /// Whether the job store answers (always, for SQLite; in a fleet, the
    /// database answered within the last renewal period).
    pub fn store_reachable(&self) -> bool {
        match &self.inner.store {
            Backend::Local(_) => true,
            Backend::Fleet(f) => f.reachable.load(Ordering::SeqCst),
        }
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
        let max_queued = self.inner.config.max_queued;
        let too_many = |n: usize| {
            JobError::Exhausted(format!(
                "{n} jobs are already queued (the limit is {max_queued})"
            ))
        };
        let stages: Vec<String> = scene.plan.names().into_iter().map(String::from).collect();
        let name = &scene.file.meta.name;
        let id = match &self.inner.store {
            Backend::Local(store) => {
                let mut q = lock(&self.inner.queue);
                if q.waiting.len() >= max_queued {
                    return Err(too_many(q.waiting.len()));
                }
                let id = store.insert(label, text, name, now(), particles, &stages)?;
                let bus = Arc::new(JobBus::new());
                bus.push_state(JobState::Queued, None);
                lock(&self.inner.buses).insert(id.clone(), bus);
                q.waiting.push_back(id.clone());
                id
            }
            Backend::Fleet(f) => {
                // the fleet's queue: its limit is checked, not held, while
                // other servers queue too
                let n = f.api.count_in_state(JobState::Queued)?;
                if n >= max_queued {
                    return Err(too_many(n));
                }
                f.api.insert(label, text, name, now(), particles, &stages)?
            }
        };
        self.inner.wake.notify_one();
        tracing::info!(job = %id, particles, "queued");
        self.get(&id)
    }

    /// A job with its latest progress.
    pub fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        let mut r = self.inner.store.get(id)?;
        r.progress = match &self.inner.store {
            Backend::Local(_) => lock(&self.inner.buses)
                .get(id)
                .and_then(|bus| bus.last_progress()),
            Backend::Fleet(f) => f.api.last_progress(id)?,
        };
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
        let size = page_size.clamp(1, 1000);
        let (jobs, next) = match &self.inner.store {
            Backend::Local(s) => s.list(size, after, state, with_scene)?,
            Backend::Fleet(f) => f.api.list(size, after, state, with_scene)?,
        };
        Ok((jobs, next.map(|n| n.to_string()).unwrap_or_default()))
    }

    /// Cancels a queued or running job; a finished job is returned as is.
    /// In a fleet, a job running on another server stops at that server's
    /// next lease renewal (within [`RENEW_EVERY`]).
    pub fn cancel(&self, id: &str) -> Result<JobRecord, JobError> {
        let store = match &self.inner.store {
            Backend::Local(store) => store,
            Backend::Fleet(f) => {
                if f.api.cancel(id, now())? == JobState::Running {
                    if let Some(flag) = lock(&self.inner.queue).running.get(id) {
                        flag.store(true, Ordering::SeqCst);
                    }
                }
                return self.get(id);
            }
        };
        let record = store.get(id)?;
        let mut q = lock(&self.inner.queue);
        if let Some(pos) = q.waiting.iter().position(|j| j == id) {
            q.waiting.remove(pos);
            drop(q);
            store.finish(
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
    /// earlier server; in a fleet, read from the database and kept up to
    /// date every [`EVENT_POLL`] while someone watches it).
    pub fn bus(&self, id: &str) -> Arc<JobBus> {
        let mut buses = lock(&self.inner.buses);
        if let Some(b) = buses.get(id) {
            return b.clone();
        }
        let bus = Arc::new(JobBus::new());
        match &self.inner.store {
            Backend::Local(store) => {
                if let Ok(r) = store.get(id) {
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
            }
            Backend::Fleet(f) => match f.api.events_since(id, 0) {
                Ok(events) => events.into_iter().for_each(|e| bus.push(e)),
                Err(e) => tracing::warn!(job = %id, error = %e, "cannot read the job's events yet"),
            },
        }
        buses.insert(id.to_string(), bus.clone());
        bus
    }

    /// Checks that the job exists and returns its event log.
    pub fn watch(&self, id: &str) -> Result<Arc<JobBus>, JobError> {
        self.inner.store.get(id)?;
        Ok(self.bus(id))
    }

    /// A local path of job `id`'s result file `name` for the API to read
    /// (None: the job has no such file, or not yet). From a bucket, a copy
    /// in the cache, fetched again if `fresh` (a file that grows).
    fn result_file(&self, id: &str, name: &str, fresh: bool) -> Result<Option<PathBuf>, JobError> {
        match &self.inner.bucket {
            None => {
                let path = self.inner.store.job_dir(id).join(name);
                Ok(path.exists().then_some(path))
            }
            Some(b) => b.cached(id, name, fresh),
        }
    }

    /// How many snapshots job `id` has so far (numbered from 0 on).
    fn snapshot_count(&self, id: &str) -> Result<u32, JobError> {
        let count = match &self.inner.bucket {
            None => {
                let dir = self.inner.store.job_dir(id);
                (0u32..)
                    .take_while(|&k| dir.join(snapshot_name(k)).exists())
                    .count()
            }
            Some(b) => {
                let objects = b.objects(id)?;
                (0u32..)
                    .take_while(|&k| objects.iter().any(|o| o.name == snapshot_name(k)))
                    .count()
            }
        };
        Ok(count as u32)
    }

    /// Headers of a job's snapshots, in order.
    pub fn snapshots(&self, id: &str) -> Result<Vec<SnapshotHeader>, JobError> {
        self.inner.store.get(id)?;
        let mut out = Vec::new();
        for k in 0..self.snapshot_count(id)? {
            let Some(path) = self.result_file(id, &snapshot_name(k), false)? else {
                break;
            };
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
        match self.snapshot_count(id)?.checked_sub(1) {
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
        let Some(path) = self.result_file(id, &snapshot_name(index), false)? else {
            return Err(if record.state == JobState::Queued {
                JobError::Precondition(format!("{id} has not started: it has no snapshots yet"))
            } else {
                JobError::NotFound(format!("{id} has no snapshot {index}"))
            });
        };
        snapfile::SnapshotReader::open(&path).map_err(JobError::Store)
    }

    /// A job's time series so far: the column names and the rows.
    pub fn series(&self, id: &str) -> Result<(Vec<String>, Vec<SeriesRow>), JobError> {
        let record = self.inner.store.get(id)?;
        let not_yet = !record.state.is_final() || record.state == JobState::Cancelled;
        let no_series = || JobError::Precondition(format!("{id} has no time series yet"));
        let Some(path) = self.result_file(id, SERIES_FILE, true)? else {
            return Err(if not_yet {
                no_series()
            } else {
                JobError::Store(format!("{id}: its time series is missing"))
            });
        };
        match crate::output::read_series(&path) {
            Ok(s) => Ok(s),
            Err(e) if e.error.kind() != std::io::ErrorKind::InvalidData && not_yet => {
                Err(no_series())
            }
            Err(e) => Err(JobError::Store(e.to_string())),
        }
    }
}

/// A job's snapshot file name.
fn snapshot_name(index: u32) -> String {
    format!("snapshot_{index:04}.bin")
}

fn snapshot_path(dir: &Path, index: u32) -> PathBuf {
    dir.join(snapshot_name(index))
}

/// A job's series file name.
const SERIES_FILE: &str = "series.csv";

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
}

/// A runner thread: takes jobs one at a time until shutdown, from the
/// server's queue or, in a fleet, by claiming them in the database.
fn runner(inner: Arc<Inner>) {
    let fleet_conn = match &inner.store {
        Backend::Local(_) => None,
        Backend::Fleet(f) => Some(f.api.connection()),
    };
    let mut last_warning: Option<Instant> = None;
    loop {
        let taken = {
            let mut q = lock(&inner.queue);
            loop {
                if q.shutdown {
                    return;
                }
                let Some(pg) = &fleet_conn else {
                    if let Some(id) = q.waiting.pop_front() {
                        break (id, None);
                    }
                    q = inner.wake.wait(q).unwrap_or_else(|p| p.into_inner());
                    continue;
                };
                let Backend::Fleet(f) = &inner.store else {
                    unreachable!("a fleet connection is made only for a fleet")
                };
                drop(q);
                match pg.claim(&f.worker, f.lease.as_secs_f64(), now()) {
                    Ok(Some(claim)) => {
                        q = lock(&inner.queue);
                        if q.shutdown {
                            // taken as the server stopped: give it back
                            drop(q);
                            let _ = pg.release(&claim.id, claim.token, "the server is stopping");
                            return;
                        }
                        break (claim.id.clone(), Some(claim));
                    }
                    Ok(None) => {}
                    Err(e) => {
                        if last_warning.is_none_or(|t| t.elapsed().as_secs() >= 10) {
                            tracing::warn!(error = %e, "cannot claim jobs");
                            last_warning = Some(Instant::now());
                        }
                    }
                }
                q = lock(&inner.queue);
                if !q.shutdown {
                    q = inner
                        .wake
                        .wait_timeout(q, CLAIM_POLL)
                        .unwrap_or_else(|p| p.into_inner())
                        .0;
                }
            }
        };
        let (id, claim) = taken;
        let cancel = Arc::new(AtomicBool::new(false));
        lock(&inner.queue)
            .running
            .insert(id.clone(), cancel.clone());
        let manager = JobManager {
            inner: inner.clone(),
        };
        match (&inner.store, claim, &fleet_conn) {
            (Backend::Local(store), _, _) => {
                let bus = manager.bus(&id);
                let ledger = Ledger::Local { store, bus: &bus };
                if let Err(e) = run_job(&inner, &id, &ledger, &cancel, None) {
                    tracing::error!(job = %id, error = %e, "job bookkeeping failed");
                    let msg = format!("internal error: {e}");
                    let _ = ledger.end(&id, JobState::Failed, Some(&msg), None);
                }
            }
            (Backend::Fleet(f), Some(claim), Some(pg)) => {
                let lost = Arc::new(AtomicBool::new(false));
                lock(&f.held).insert(
                    id.clone(),
                    Held {
                        token: claim.token,
                        cancel: cancel.clone(),
                        lost: lost.clone(),
                    },
                );
                if claim.rerun {
                    tracing::warn!(job = %id, token = claim.token, "claimed a job that ran before (its server stopped or died)");
                }
                let ledger = Ledger::Fleet {
                    store: pg,
                    token: claim.token,
                    lost: &lost,
                };
                match run_job(&inner, &id, &ledger, &cancel, Some(&lost)) {
                    Ok(()) => {}
                    // the claim is gone: the job is its next owner's
                    Err(JobError::Fenced(e)) => {
                        tracing::warn!(job = %id, error = %e, "left to another server")
                    }
                    Err(e) => {
                        tracing::error!(job = %id, error = %e, "job bookkeeping failed");
                        let msg = format!("internal error: {e}");
                        let _ = ledger.end(&id, JobState::Failed, Some(&msg), None);
                    }
                }
                lock(&f.held).remove(&id);
            }
            _ => unreachable!("a fleet's runner always has a claim and a connection"),
        }
        lock(&inner.queue).running.remove(&id);
    }
}

/// A fleet server's lease keeper: every [`RENEW_EVERY`] it renews the
/// leases of the jobs it runs, passes on cancels asked for on any server,
/// and stops a job whose claim was taken over. If the database cannot be
/// reached for half a lease, it stops its jobs: their leases may lapse
/// and another server take them, so this one must write nothing more (it
/// has half a lease of margin for the step in progress). The job stays
/// RUNNING in the database and is claimed again when its lease lapses.
fn keeper_loop(inner: Arc<Inner>, pg: PgStore) {
    let Backend::Fleet(f) = &inner.store else {
        return;
    };
    let lease = f.lease.as_secs_f64();
    let mut last_ok = Instant::now();
    loop {
        let held: Vec<(String, i64)> = lock(&f.held)
            .iter()
            .map(|(id, h)| (id.clone(), h.token))
            .collect();
        if held.is_empty() && lock(&inner.queue).shutdown {
            return;
        }
        let asked = Instant::now();
        let answer = if held.is_empty() {
            pg.ping().map(|_| Vec::new())
        } else {
            pg.renew(&f.worker, &held, lease)
        };
        match answer {
            Ok(leases) => {
                last_ok = asked;
                if !f.reachable.swap(true, Ordering::SeqCst) {
                    tracing::info!("the database answers again");
                }
                let mut lost_now = Vec::new();
                let map = lock(&f.held);
                for ((id, _), l) in held.iter().zip(leases) {
                    let Some(h) = map.get(id) else { continue };
                    match l {
                        pg::Lease::Held { cancel: true } => h.cancel.store(true, Ordering::SeqCst),
                        pg::Lease::Held { cancel: false } => {}
                        pg::Lease::Lost => {
                            if !h.lost.swap(true, Ordering::SeqCst) {
                                lost_now.push(id);
                            }
                            h.cancel.store(true, Ordering::SeqCst);
                        }
                    }
                }
                // (the database is asked with the runners' map released)
                drop(map);
                for id in lost_now {
                    // a job that ended between the list and the renewal is
                    // lost too, and harmlessly: its end is recorded
                    if !pg.get(id).is_ok_and(|r| r.state.is_final()) {
                        tracing::warn!(job = %id, "another server claimed the job: stopping it");
                    }
                }
            }
            Err(e) => {
                if f.reachable.swap(false, Ordering::SeqCst) {
                    tracing::warn!(error = %e, "the database does not answer");
                }
                if last_ok.elapsed().as_secs_f64() > 0.5 * lease {
                    for (id, h) in lock(&f.held).iter() {
                        if !h.lost.swap(true, Ordering::SeqCst) {
                            tracing::warn!(job = %id, "no lease renewal for half a lease: stopping the job, another server will resume it");
                        }
                        h.cancel.store(true, Ordering::SeqCst);
                    }
                }
            }
        }
        std::thread::sleep(RENEW_EVERY);
    }
}

/// A fleet server's event pump: every [`EVENT_POLL`] it appends the new
/// events of each job watched on this server to its log, from the
/// database, and forgets the logs no one watches.
fn pump_loop(inner: Arc<Inner>, pg: PgStore) {
    loop {
        if lock(&inner.queue).shutdown {
            return;
        }
        let buses: Vec<(String, Arc<JobBus>)> = {
            let mut map = lock(&inner.buses);
            // a log only the map holds has no watcher
            map.retain(|_, b| Arc::strong_count(b) > 1);
            map.iter()
                .filter(|(_, b)| !b.is_final())
                .map(|(id, b)| (id.clone(), b.clone()))
                .collect()
        };
        for (id, bus) in buses {
            match pg.events_since(&id, bus.len()) {
                Ok(events) => events.into_iter().for_each(|e| bus.push(e)),
                Err(e) => {
                    tracing::debug!(job = %id, error = %e, "cannot read events");
                    break;
                }
            }
        }
        std::thread::sleep(EVENT_POLL);
    }
}

/// Where a running job's record and events go.
enum Ledger<'a> {
    /// One server: the SQLite store and the in-memory log.
    Local { store: &'a Store, bus: &'a JobBus },
    /// A fleet: the database, every write fenced by the claim's token.
    Fleet {
        store: &'a PgStore,
        token: i64,
        lost: &'a AtomicBool,
    },
}

impl Ledger<'_> {
    /// Appends an event (a progress event that the database does not take
    /// is dropped: the next one carries the news).
    fn event(&self, id: &str, e: JobEvent) {
        match self {
            Ledger::Local { bus, .. } => bus.push(e),
            Ledger::Fleet { store, token, lost } => {
                if lost.load(Ordering::SeqCst) {
                    return;
                }
                match store.push(id, *token, &e) {
                    Ok(()) => {}
                    Err(JobError::Fenced(_)) => lost.store(true, Ordering::SeqCst),
                    Err(err) => {
                        tracing::debug!(job = %id, error = %err, "an event was not recorded")
                    }
                }
            }
        }
    }

    /// The job's record. In a fleet the database may be away for a moment
    /// (a restart): asked again until it answers or the claim is lost.
    fn record(&self, id: &str) -> Result<JobRecord, JobError> {
        match self {
            Ledger::Local { store, .. } => store.get(id),
            Ledger::Fleet { store, lost, .. } => {
                Self::retried(id, lost, "read the job", || store.get(id))
            }
        }
    }

    /// `f` until it does not fail for want of the database, or the claim
    /// is lost.
    fn retried<T>(
        id: &str,
        lost: &AtomicBool,
        what: &str,
        mut f: impl FnMut() -> Result<T, JobError>,
    ) -> Result<T, JobError> {
        loop {
            if lost.load(Ordering::SeqCst) {
                return Err(JobError::Fenced(format!(
                    "{id}: this server's claim lapsed before it could {what}"
                )));
            }
            match f() {
                Err(JobError::Unavailable(e)) => {
                    tracing::warn!(job = %id, error = %e, "cannot {what} yet: retrying");
                    std::thread::sleep(RENEW_EVERY);
                }
                other => return other,
            }
        }
    }

    /// The job has started (a fleet's claim recorded it already).
    fn started(&self, id: &str) -> Result<(), JobError> {
        if let Ledger::Local { store, bus } = self {
            store.set_running(id, now())?;
            bus.push_state(JobState::Running, None);
        }
        Ok(())
    }

    /// Records a job's end: its state, error and summary, and the events
    /// that tell it. In a fleet the database may be away for a moment (a
    /// restart): the end is retried until it is recorded or the claim is
    /// lost (the job's next owner then runs it from its checkpoint).
    fn end(
        &self,
        id: &str,
        state: JobState,
        error: Option<&str>,
        summary: Option<&JobSummary>,
    ) -> Result<(), JobError> {
        match self {
            Ledger::Local { store, bus } => {
                store.finish(id, state, now(), error, summary)?;
                if let Some(s) = summary {
                    bus.push(JobEvent::Summary(*s));
                }
                bus.push_state(state, error.map(String::from));
                Ok(())
            }
            Ledger::Fleet { store, token, lost } => {
                Self::retried(id, lost, "record the job's end", || {
                    store.finish(id, *token, state, now(), error, summary)
                })
            }
        }
    }

    /// The server is stopping: the job waits for the next server (one
    /// server: the store keeps it RUNNING until this server starts again;
    /// a fleet: it goes back to the queue for any server).
    fn stopped(&self, id: &str, why: &str) -> Result<(), JobError> {
        match self {
            Ledger::Local { bus, .. } => {
                bus.push_state(JobState::Queued, Some(why.into()));
                Ok(())
            }
            Ledger::Fleet { store, token, lost } => {
                Self::retried(id, lost, "give the job back", || {
                    store.release(id, *token, why)
                })
            }
        }
    }

    fn is_fleet(&self) -> bool {
        matches!(self, Ledger::Fleet { .. })
    }
}

/// Runs one job to its end and records the outcome. `lost` (a fleet) is
/// set when this server's claim is no longer safe: the job stops and
/// writes nothing more.
fn run_job(
    inner: &Inner,
    id: &str,
    ledger: &Ledger<'_>,
    cancel: &Arc<AtomicBool>,
    lost: Option<&Arc<AtomicBool>>,
) -> Result<(), JobError> {
    let record = ledger.record(id)?;
    let scene = Scene::from_text(&record.scene, None)?;
    ledger.started(id)?;
    tracing::info!(job = %id, "running");
    let dir = inner.store.job_dir(id);
    std::fs::create_dir_all(&dir)
        .map_err(|e| JobError::Store(format!("{}: {e}", dir.display())))?;
    if let Some(b) = &inner.bucket {
        // the job's files as the bucket has them: another server's
        // checkpoint, series and snapshots if it ran the job before
        if let Err(e) = b.pull(id, &dir) {
            let msg = format!("cannot read its results from the bucket: {e}");
            return ledger.end(id, JobState::Failed, Some(&msg), None);
        }
    }
    let cp_path = checkpoint_path(&dir);
    let resume = if cp_path.exists() {
        match resume_job(&dir) {
            Ok(r) => Some(r),
            Err(e) => {
                let msg = format!("cannot resume from its checkpoint: {e}");
                return ledger.end(id, JobState::Failed, Some(&msg), None);
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
            let series = std::fs::File::create(dir.join(SERIES_FILE))
                .map_err(|e| JobError::Store(format!("{}: {e}", dir.display())))?;
            (series, ObserverState::default(), None)
        }
    };
    let mut observer = JobObserver {
        id,
        dir: dir.clone(),
        bucket: inner.bucket.as_ref(),
        series: std::io::BufWriter::new(series),
        ledger,
        cancel: cancel.clone(),
        lost: lost.cloned(),
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
    if observer.is_lost() {
        // another server owns the job now: its files and record are its
        // (what the series writer still buffers is dropped, not flushed)
        let JobObserver { series, .. } = observer;
        drop(series.into_parts());
        tracing::warn!(job = %id, "stopped without recording anything: the claim was lost");
        return Ok(());
    }
    let _ = std::io::Write::flush(&mut observer.series);
    let wall = observer.wall_before + observer.started.elapsed().as_secs_f64();
    let stopped_by_server = inner.stopping.load(Ordering::SeqCst)
        && matches!(&outcome, Ok(Ok(s)) if s.cancelled)
        // one server resumes only what it checkpointed; a fleet runs an
        // unsaved job again from the start
        && (observer.stop_next || ledger.is_fleet());
    if stopped_by_server {
        let why = if observer.stop_next {
            "the server is stopping; the job resumes from its checkpoint when it starts again"
        } else {
            "the server is stopping; the job runs again from the start on the next server"
        };
        ledger.stopped(id, why)?;
        tracing::info!(job = %id, "checkpointed for the next server");
        return Ok(());
    }
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
    let (mut state, mut error) = match outcome {
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
    if let Some(b) = &inner.bucket {
        if let Err(e) = b.put_file(id, &dir.join(SERIES_FILE)) {
            state = JobState::Failed;
            error = Some(format!("cannot store its time series: {e}"));
        }
    }
    // the checkpoint goes once the end is recorded: a server that dies
    // between the two leaves a job that resumes, not one that restarts
    ledger.end(id, state, error.as_deref(), Some(&summary))?;
    let _ = std::fs::remove_file(&cp_path);
    if let Some(b) = &inner.bucket {
        if let Err(e) = b.delete(id, crate::output::CHECKPOINT_FILE) {
            tracing::warn!(job = %id, error = %e, "the finished job's checkpoint stays in the bucket");
        }
    }
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
    let series = crate::output::reopen_series(&dir.join(SERIES_FILE), saved.series_bytes)
        .map_err(|e| e.to_string())?;
    Ok((series, saved, cp))
}

/// Streams a running job's results to its directory and its event log.
struct JobObserver<'a> {
    id: &'a str,
    dir: PathBuf,
    /// The results' bucket, which each file is copied to once written.
    bucket: Option<&'a results::Bucket>,
    series: std::io::BufWriter<std::fs::File>,
    ledger: &'a Ledger<'a>,
    cancel: Arc<AtomicBool>,
    /// A fleet: the claim is lost, write nothing more.
    lost: Option<Arc<AtomicBool>>,
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

impl JobObserver<'_> {
    fn is_lost(&self) -> bool {
        self.lost.as_ref().is_some_and(|l| l.load(Ordering::SeqCst))
    }
}

impl Observer for JobObserver<'_> {
    fn checkpoint(&mut self, mut cp: crate::checkpoint::Checkpoint<'_>) -> Result<(), String> {
        if self.is_lost() {
            return Ok(());
        }
        let series_bytes =
            crate::output::flushed_len(&mut self.series, &self.dir.join(SERIES_FILE))
                .map_err(|e| e.to_string())?;
        let state = ObserverState {
            series_bytes,
            snapshots: self.snapshots,
            rows: self.rows,
            last_row: self.last_row.clone(),
            wall_seconds: self.wall_before + self.started.elapsed().as_secs_f64(),
        };
        cp.observer = postcard::to_stdvec(&state).map_err(|e| e.to_string())?;
        let path = checkpoint_path(&self.dir);
        crate::output::save_checkpoint(&path, &cp).map_err(|e| e.to_string())?;
        if let Some(b) = self.bucket {
            // the series first: the bucket's checkpoint never names series
            // bytes the bucket lacks
            b.put_file(self.id, &self.dir.join(SERIES_FILE))
                .and_then(|_| b.put_file(self.id, &path))
                .map_err(|e| format!("cannot store its checkpoint: {e}"))?;
        }
        Ok(())
    }

    fn series_columns(&mut self, columns: &[String]) -> Result<(), String> {
        use std::io::Write;
        writeln!(self.series, "{}", columns.join(","))
            .map_err(|e| format!("{}: {e}", self.dir.join(SERIES_FILE).display()))
    }

    fn series_row(&mut self, row: &SeriesRow) -> Result<(), String> {
        use std::io::Write;
        if self.is_lost() {
            return Ok(());
        }
        crate::output::write_series_line(&mut self.series, row)
            .and_then(|_| self.series.flush())
            .map_err(|e| format!("{}: {e}", self.dir.join(SERIES_FILE).display()))?;
        self.rows += 1;
        self.last_row = Some(row.clone());
        Ok(())
    }

    fn snapshot(&mut self, snap: &Snapshot) -> Result<(), String> {
        if self.cancel.load(Ordering::SeqCst) || self.is_lost() {
            return Ok(()); // cancelled: write nothing more
        }
        let path = snapshot_path(&self.dir, snap.index);
        snapfile::write(&path, snap)?;
        if let Some(b) = self.bucket {
            b.put_file(self.id, &path)
                .map_err(|e| format!("cannot store snapshot {}: {e}", snap.index))?;
        }
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
        // At most one progress event per 1 % or 0.25 s. In a fleet each
        // is a database transaction and watchers read them every
        // EVENT_POLL, so they are also that far apart (but the last).
        let now = Instant::now();
        let fraction = p.fraction();
        let gap = if self.ledger.is_fleet() {
            EVENT_POLL.as_secs_f64()
        } else {
            0.0
        };
        let due = match self.last_emit {
            None => true,
            Some((t, f)) => {
                let since = (now - t).as_secs_f64();
                (fraction - f >= 0.01 && since >= gap) || since >= 0.25 || fraction >= 1.0
            }
        };
        if due {
            let wall = (now - self.started).as_secs_f64();
            let eta = if fraction > 0.0 {
                wall * (1.0 - fraction) / fraction
            } else {
                0.0
            };
            self.ledger.event(
                self.id,
                JobEvent::Progress(JobProgress {
                    step: p.step,
                    time: p.time,
                    end_time: p.end_time,
                    fraction,
                    eta_seconds: eta,
                    kinetic_energy: p.kinetic_energy,
                    strain_energy: p.strain_energy,
                    wall_seconds: wall,
                }),
            );
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
