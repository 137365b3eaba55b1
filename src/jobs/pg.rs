//! The fleet's store: jobs, their events and the workers' leases in
//! PostgreSQL, so that several servers serve one queue.
//!
//! - **Claims.** A worker takes the oldest claimable job with
//!   `SELECT … FOR UPDATE SKIP LOCKED`: a queued one, or a running one whose
//!   lease has lapsed (its host died). Jobs that have run before (released
//!   at a shutdown or lapsed) come first, as the single server resumes its
//!   interrupted jobs first. Every claim adds one to the job's `token`.
//! - **Leases.** The holder renews `lease_until` (the database's clock, so
//!   hosts' clocks never compare); a renewal answers whether a cancel was
//!   asked for from any server.
//! - **Fencing.** Every write a worker makes for a job (its events, its
//!   end, its release) names the token of its claim and changes nothing
//!   if another worker has claimed the job since: a worker that comes back
//!   from a pause cannot write over the new owner's record.
//! - **Events.** A job's events are rows numbered from 0 in the order they
//!   were committed (the counter is on the job's row, so two writers of one
//!   job's events queue on its row lock); watchers on any server read them.
//!
//! The schema has a version; [`MIGRATIONS`] brings an older database up to
//! date when a server starts, under an advisory lock so that servers
//! starting together do not race.
//!
//! The `postgres` client is synchronous (it drives its connection on a
//! runtime of its own), so it is called from the runner threads and from
//! the service's blocking pool, never from an async task.

use super::{JobError, JobEvent, JobRecord, JobState, JobSummary};
use postgres::{Client, NoTls};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The schema, one entry per version: entry k takes a database from
/// version k to k + 1. Never edit an entry once released; add one.
pub const MIGRATIONS: &[&str] = &["
CREATE TABLE jobs (
    seq BIGSERIAL PRIMARY KEY,
    id TEXT UNIQUE NOT NULL,
    label TEXT NOT NULL,
    state TEXT NOT NULL,
    scene TEXT NOT NULL,
    scene_name TEXT NOT NULL DEFAULT '',
    created_at DOUBLE PRECISION NOT NULL,
    started_at DOUBLE PRECISION,
    finished_at DOUBLE PRECISION,
    error TEXT,
    particles BIGINT NOT NULL,
    stages TEXT NOT NULL,
    summary TEXT,
    worker TEXT NOT NULL DEFAULT '',
    token BIGINT NOT NULL DEFAULT 0,
    lease_until TIMESTAMPTZ,
    cancel_requested BOOLEAN NOT NULL DEFAULT FALSE,
    events BIGINT NOT NULL DEFAULT 0
);
CREATE INDEX jobs_state ON jobs (state, seq);
CREATE TABLE job_events (
    job_id TEXT NOT NULL REFERENCES jobs (id),
    seq BIGINT NOT NULL,
    body TEXT NOT NULL,
    PRIMARY KEY (job_id, seq)
);
"];

/// Key of the advisory lock the migrations run under.
const MIGRATION_LOCK: i64 = 0x636c_6561_7665; // "cleave"

const COLUMNS: &str = "id, label, state, scene, created_at, started_at, finished_at, error, particles, stages, summary, scene_name, worker";
const COLUMNS_BASIC: &str = "id, label, state, '' AS scene, created_at, started_at, finished_at, error, particles, stages, summary, scene_name, worker";

fn db_err(e: postgres::Error) -> JobError {
    JobError::Store(format!("database: {e}"))
}

fn record(row: &postgres::Row) -> JobRecord {
    let state: String = row.get(2);
    let stages: String = row.get(9);
    let summary: Option<String> = row.get(10);
    let worker: String = row.get(12);
    JobRecord {
        id: row.get(0),
        label: row.get(1),
        state: JobState::parse(&state).unwrap_or(JobState::Failed),
        scene: row.get(3),
        created_at: row.get(4),
        started_at: row.get(5),
        finished_at: row.get(6),
        error: row.get(7),
        particles: row.get::<_, i64>(8) as u64,
        stages: stages
            .split(',')
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect(),
        summary: summary.and_then(|s| serde_json::from_str(&s).ok()),
        progress: None,
        scene_name: row.get(11),
        // the server that runs it, or ran it last
        worker,
    }
}

/// A job a worker has claimed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Claim {
    pub id: String,
    /// The fencing token of this claim.
    pub token: i64,
    /// The job had run before (a lapsed lease or a release).
    pub rerun: bool,
}

/// What a lease renewal found for one held job.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Lease {
    /// Still ours; whether a cancel was asked for.
    Held { cancel: bool },
    /// Another worker claimed it, or it ended: stop, write nothing more.
    Lost,
}

/// One connection to the fleet's database (reconnected on the next call
/// after it breaks) and the shared result directory.
pub struct PgStore {
    url: String,
    client: Mutex<Option<Client>>,
    dir: PathBuf,
}

impl PgStore {
    /// Connects, brings the schema up to date and makes the result
    /// directory.
    pub fn open(url: &str, dir: &Path) -> Result<PgStore, JobError> {
        std::fs::create_dir_all(dir.join("jobs"))
            .map_err(|e| JobError::Store(format!("cannot create {}: {e}", dir.display())))?;
        let store = PgStore {
            url: url.to_string(),
            client: Mutex::new(None),
            dir: dir.to_path_buf(),
        };
        if let Some(version) = store.with(migrate)? {
            return Err(JobError::Store(format!(
                "the database has schema version {version}; this server knows versions up to {}: upgrade the server",
                MIGRATIONS.len()
            )));
        }
        Ok(store)
    }

    /// Another connection to the same database and directory.
    pub fn connection(&self) -> PgStore {
        PgStore {
            url: self.url.clone(),
            client: Mutex::new(None),
            dir: self.dir.clone(),
        }
    }

    /// Runs `f` on the connection, connecting first if there is none or it
    /// broke. A connection kept from an earlier call may have died unseen
    /// (the database restarted meanwhile: the client notices only when it
    /// uses it), so a call that finds it closed is made once more on a new
    /// one. PostgreSQL rolls back what a dead connection had not committed;
    /// the only call made twice is one whose commit went through and whose
    /// answer was lost with the connection.
    fn with<T>(
        &self,
        mut f: impl FnMut(&mut Client) -> Result<T, postgres::Error>,
    ) -> Result<T, JobError> {
        let mut guard = self.client.lock().unwrap_or_else(|p| p.into_inner());
        let mut kept = guard.as_ref().is_some_and(|c| !c.is_closed());
        loop {
            if !kept {
                *guard = None;
                let client = Client::connect(&self.url, NoTls).map_err(|e| {
                    JobError::Unavailable(format!("cannot reach the database: {e}"))
                })?;
                *guard = Some(client);
            }
            let client = guard.as_mut().expect("connected above");
            match f(client) {
                Ok(v) => return Ok(v),
                Err(_) if kept && client.is_closed() => kept = false,
                Err(e) if client.is_closed() => {
                    *guard = None;
                    return Err(JobError::Unavailable(format!("lost the database: {e}")));
                }
                Err(e) => return Err(db_err(e)),
            }
        }
    }

    /// Whether the database answers.
    pub fn ping(&self) -> Result<(), JobError> {
        self.with(|c| c.simple_query("SELECT 1").map(|_| ()))
    }

    /// The schema version of the database.
    pub fn schema_version(&self) -> Result<usize, JobError> {
        self.with(|c| {
            Ok(c.query_one("SELECT version FROM cleave_schema", &[])?
                .get::<_, i32>(0) as usize)
        })
    }

    pub fn job_dir(&self, id: &str) -> PathBuf {
        self.dir.join("jobs").join(id)
    }

    /// Inserts a queued job with its first event and returns its id.
    pub fn insert(
        &self,
        label: &str,
        scene: &str,
        scene_name: &str,
        created_at: f64,
        particles: u64,
        stages: &[String],
    ) -> Result<String, JobError> {
        let id = self.with(|c| {
            let mut tx = c.transaction()?;
            let row = tx.query_one(
                "WITH s AS (SELECT nextval(pg_get_serial_sequence('jobs', 'seq')) AS seq)
                 INSERT INTO jobs (seq, id, label, state, scene, scene_name, created_at, particles, stages)
                 SELECT s.seq, 'job-' || lpad(s.seq::text, 6, '0'), $1, $2, $3, $4, $5, $6, $7 FROM s
                 RETURNING id",
                &[&label, &JobState::Queued.as_str(), &scene, &scene_name, &created_at, &(particles as i64), &stages.join(",")],
            )?;
            let id: String = row.get(0);
            push_event(&mut tx, &id, None, &JobEvent::State { state: JobState::Queued, error: None })?;
            tx.commit()?;
            Ok(id)
        })?;
        std::fs::create_dir_all(self.job_dir(&id))
            .map_err(|e| JobError::Store(format!("cannot create the directory of {id}: {e}")))?;
        Ok(id)
    }

    pub fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        self.with(|c| c.query_opt(&format!("SELECT {COLUMNS} FROM jobs WHERE id = $1"), &[&id]))?
            .map(|r| record(&r))
            .ok_or_else(|| JobError::NotFound(format!("no job {id}")))
    }

    /// As [`super::Store::list`].
    pub fn list(
        &self,
        page_size: usize,
        after: Option<i64>,
        state: Option<JobState>,
        with_scene: bool,
    ) -> Result<(Vec<JobRecord>, Option<i64>), JobError> {
        let columns = if with_scene { COLUMNS } else { COLUMNS_BASIC };
        let rows = self.with(|c| {
            c.query(
                &format!(
                    "SELECT {columns}, seq FROM jobs WHERE seq < $1 AND ($2::text IS NULL OR state = $2)
                     ORDER BY seq DESC LIMIT $3"
                ),
                &[
                    &after.unwrap_or(i64::MAX),
                    &state.map(|s| s.as_str()),
                    &(page_size as i64 + 1),
                ],
            )
        })?;
        let mut out: Vec<(JobRecord, i64)> = rows
            .iter()
            .map(|r| (record(r), r.get::<_, i64>(13)))
            .collect();
        let more = out.len() > page_size;
        out.truncate(page_size);
        let next = if more {
            out.last().map(|(_, seq)| *seq)
        } else {
            None
        };
        Ok((out.into_iter().map(|(r, _)| r).collect(), next))
    }

    pub fn count_in_state(&self, state: JobState) -> Result<usize, JobError> {
        self.with(|c| {
            c.query_one(
                "SELECT COUNT(*) FROM jobs WHERE state = $1",
                &[&state.as_str()],
            )
            .map(|r| r.get::<_, i64>(0) as usize)
        })
    }

    /// Claims the next job for `worker` under a lease of `lease_s` seconds,
    /// recording the RUNNING event; None if there is none to take.
    pub fn claim(
        &self,
        worker: &str,
        lease_s: f64,
        started_at: f64,
    ) -> Result<Option<Claim>, JobError> {
        self.with(|c| {
            let mut tx = c.transaction()?;
            let row = tx.query_opt(
                "WITH next AS (
                     SELECT seq, started_at IS NOT NULL AS rerun FROM jobs
                     WHERE state = 'QUEUED' OR (state = 'RUNNING' AND lease_until < now())
                     ORDER BY started_at IS NULL, seq
                     LIMIT 1
                     FOR UPDATE SKIP LOCKED
                 )
                 UPDATE jobs SET state = 'RUNNING', worker = $1, token = token + 1,
                     lease_until = now() + $2 * interval '1 second',
                     started_at = COALESCE(started_at, $3)
                 FROM next WHERE jobs.seq = next.seq
                 RETURNING jobs.id, jobs.token, next.rerun",
                &[&worker, &lease_s, &started_at],
            )?;
            let Some(row) = row else {
                return Ok(None);
            };
            let claim = Claim {
                id: row.get(0),
                token: row.get(1),
                rerun: row.get(2),
            };
            push_event(
                &mut tx,
                &claim.id,
                Some(claim.token),
                &JobEvent::State {
                    state: JobState::Running,
                    error: None,
                },
            )?;
            tx.commit()?;
            Ok(Some(claim))
        })
    }

    /// Renews the leases of the jobs `worker` holds, for `lease_s` seconds
    /// from now (the database's clock).
    pub fn renew(
        &self,
        worker: &str,
        held: &[(String, i64)],
        lease_s: f64,
    ) -> Result<Vec<Lease>, JobError> {
        if held.is_empty() {
            return Ok(Vec::new());
        }
        let ids: Vec<&str> = held.iter().map(|(id, _)| id.as_str()).collect();
        let tokens: Vec<i64> = held.iter().map(|(_, t)| *t).collect();
        let rows = self.with(|c| {
            c.query(
                "UPDATE jobs SET lease_until = now() + $2 * interval '1 second'
                 FROM unnest($3::text[], $4::bigint[]) AS h (id, token)
                 WHERE jobs.id = h.id AND jobs.token = h.token AND jobs.worker = $1
                   AND jobs.state = 'RUNNING'
                 RETURNING jobs.id, jobs.cancel_requested",
                &[&worker, &lease_s, &ids, &tokens],
            )
        })?;
        Ok(held
            .iter()
            .map(|(id, _)| {
                rows.iter()
                    .find(|r| r.get::<_, &str>(0) == id)
                    .map_or(Lease::Lost, |r| Lease::Held { cancel: r.get(1) })
            })
            .collect())
    }

    /// Appends an event of a job this worker holds (fenced by its token).
    pub fn push(&self, id: &str, token: i64, e: &JobEvent) -> Result<(), JobError> {
        self.with(|c| {
            let mut tx = c.transaction()?;
            let pushed = push_event(&mut tx, id, Some(token), e)?;
            tx.commit()?;
            Ok(pushed)
        })?
        .then_some(())
        .ok_or_else(|| fenced(id))
    }

    /// Records the end of a job this worker holds, with its summary and
    /// last events, if the claim still holds.
    pub fn finish(
        &self,
        id: &str,
        token: i64,
        state: JobState,
        finished_at: f64,
        error: Option<&str>,
        summary: Option<&JobSummary>,
    ) -> Result<(), JobError> {
        let text = summary.map(|s| serde_json::to_string(s).unwrap_or_default());
        let mut events: Vec<JobEvent> =
            summary.map(|s| JobEvent::Summary(*s)).into_iter().collect();
        events.push(JobEvent::State {
            state,
            error: error.map(String::from),
        });
        self.fenced_transition(
            id,
            token,
            "UPDATE jobs SET state = $3, finished_at = $4, error = $5,
                 summary = COALESCE($6, summary), lease_until = NULL
             WHERE id = $1 AND token = $2 AND state = 'RUNNING'",
            &[&state.as_str(), &finished_at, &error, &text],
            &events,
        )
    }

    /// Gives a held job back to the queue (this server is stopping): the
    /// next claim runs it again, from its checkpoint if it saved one.
    pub fn release(&self, id: &str, token: i64, why: &str) -> Result<(), JobError> {
        self.fenced_transition(
            id,
            token,
            "UPDATE jobs SET state = 'QUEUED', worker = '', lease_until = NULL
             WHERE id = $1 AND token = $2 AND state = 'RUNNING'",
            &[],
            &[JobEvent::State {
                state: JobState::Queued,
                error: Some(why.to_string()),
            }],
        )
    }

    /// Moves a running job on with `update` (whose `$1`, `$2` are the id
    /// and the claim's token, followed by `params`) and records `events`,
    /// in one transaction, if the claim is still this token's; `Fenced`
    /// if another claim took the job (nothing is written then).
    fn fenced_transition(
        &self,
        id: &str,
        token: i64,
        update: &str,
        params: &[&(dyn postgres::types::ToSql + Sync)],
        events: &[JobEvent],
    ) -> Result<(), JobError> {
        let mut all: Vec<&(dyn postgres::types::ToSql + Sync)> = vec![&id, &token];
        all.extend_from_slice(params);
        self.with(|c| {
            let mut tx = c.transaction()?;
            if tx.execute(update, &all)? == 0 {
                return Ok(false);
            }
            for e in events {
                push_event(&mut tx, id, Some(token), e)?;
            }
            tx.commit()?;
            Ok(true)
        })?
        .then_some(())
        .ok_or_else(|| fenced(id))
    }

    /// Cancels a job from any server: a queued one ends CANCELLED here, a
    /// running one is flagged and its worker stops at its next renewal.
    /// The job's state before.
    pub fn cancel(&self, id: &str, finished_at: f64) -> Result<JobState, JobError> {
        let state = self.with(|c| {
            let mut tx = c.transaction()?;
            let Some(row) = tx.query_opt("SELECT state FROM jobs WHERE id = $1 FOR UPDATE", &[&id])?
            else {
                return Ok(None);
            };
            let state = JobState::parse(row.get(0)).unwrap_or(JobState::Failed);
            match state {
                JobState::Queued => {
                    let why = "cancelled before it started";
                    tx.execute(
                        "UPDATE jobs SET state = 'CANCELLED', finished_at = $2, error = $3 WHERE id = $1",
                        &[&id, &finished_at, &why],
                    )?;
                    push_event(
                        &mut tx,
                        id,
                        None,
                        &JobEvent::State {
                            state: JobState::Cancelled,
                            error: Some(why.into()),
                        },
                    )?;
                }
                JobState::Running => {
                    tx.execute("UPDATE jobs SET cancel_requested = TRUE WHERE id = $1", &[&id])?;
                }
                _ => {}
            }
            tx.commit()?;
            Ok(Some(state))
        })?;
        state.ok_or_else(|| JobError::NotFound(format!("no job {id}")))
    }

    /// A job's events from number `from` on.
    pub fn events_since(&self, id: &str, from: usize) -> Result<Vec<JobEvent>, JobError> {
        let rows = self.with(|c| {
            c.query(
                "SELECT body FROM job_events WHERE job_id = $1 AND seq >= $2 ORDER BY seq",
                &[&id, &(from as i64)],
            )
        })?;
        rows.iter()
            .map(|r| {
                serde_json::from_str(r.get(0))
                    .map_err(|e| JobError::Store(format!("an event of {id}: {e}")))
            })
            .collect()
    }

    /// The latest progress event of a job.
    pub fn last_progress(&self, id: &str) -> Result<Option<super::JobProgress>, JobError> {
        let row = self.with(|c| {
            c.query_opt(
                "SELECT body FROM job_events WHERE job_id = $1 AND body LIKE '{\"Progress\"%'
                 ORDER BY seq DESC LIMIT 1",
                &[&id],
            )
        })?;
        Ok(row.and_then(|r| match serde_json::from_str(r.get(0)) {
            Ok(JobEvent::Progress(p)) => Some(p),
            _ => None,
        }))
    }
}

fn fenced(id: &str) -> JobError {
    JobError::Fenced(format!(
        "{id} was claimed by another worker (this worker's lease lapsed)"
    ))
}

/// Appends an event to a job's log, numbered after the last; with a token,
/// only if the job's claim still has it. Whether it was appended.
fn push_event(
    tx: &mut postgres::Transaction<'_>,
    id: &str,
    token: Option<i64>,
    e: &JobEvent,
) -> Result<bool, postgres::Error> {
    let Some(row) = tx.query_opt(
        "UPDATE jobs SET events = events + 1 WHERE id = $1 AND ($2::bigint IS NULL OR token = $2)
         RETURNING events - 1",
        &[&id, &token],
    )?
    else {
        return Ok(false);
    };
    let seq: i64 = row.get(0);
    let body = serde_json::to_string(e).unwrap_or_default();
    tx.execute(
        "INSERT INTO job_events (job_id, seq, body) VALUES ($1, $2, $3)",
        &[&id, &seq, &body],
    )?;
    Ok(true)
}

/// Brings the schema to the newest version. A database that a newer
/// server has migrated past what this one knows is left as it is: its
/// version is returned.
fn migrate(c: &mut Client) -> Result<Option<usize>, postgres::Error> {
    let mut tx = c.transaction()?;
    tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])?;
    tx.batch_execute("CREATE TABLE IF NOT EXISTS cleave_schema (version INTEGER NOT NULL)")?;
    let version = match tx.query_opt("SELECT version FROM cleave_schema", &[])? {
        Some(r) => r.get::<_, i32>(0) as usize,
        None => {
            tx.execute("INSERT INTO cleave_schema (version) VALUES (0)", &[])?;
            0
        }
    };
    if version > MIGRATIONS.len() {
        return Ok(Some(version));
    }
    for (k, m) in MIGRATIONS.iter().enumerate().skip(version) {
        tx.batch_execute(m)?;
        tx.execute(
            "UPDATE cleave_schema SET version = $1",
            &[&((k + 1) as i32)],
        )?;
        tracing::info!(version = k + 1, "database schema migrated");
    }
    tx.commit()?;
    Ok(None)
}
