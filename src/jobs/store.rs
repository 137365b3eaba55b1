//! Persistent job records (SQLite) and result files beside them.
//!
//! Layout of the data directory:
//! - `cleave.sqlite`: one row per job (scene, state, times, summary);
//! - `jobs/<id>/series.csv`: the time series, appended as the job runs;
//! - `jobs/<id>/snapshot_NNNN.bin`: snapshots in [`super::snapfile`] format,
//!   each written atomically (a `.tmp` file renamed into place).

use super::{JobError, JobRecord, JobState, JobSummary};
use rusqlite::{params, Connection, OptionalExtension};
use std::path::{Path, PathBuf};
use std::sync::Mutex;

/// The job database and the result directory.
pub struct Store {
    conn: Mutex<Connection>,
    dir: PathBuf,
}

fn db_err(e: rusqlite::Error) -> JobError {
    JobError::Store(format!("database: {e}"))
}

const COLUMNS: &str = "id, label, state, scene, created_at, started_at, finished_at, error, particles, stages, summary, scene_name";

/// [`COLUMNS`] without the scene text, which may be megabytes a job: a
/// page of jobs is listed without reading it from the database.
const COLUMNS_BASIC: &str = "id, label, state, '' AS scene, created_at, started_at, finished_at, error, particles, stages, summary, scene_name";

fn record(row: &rusqlite::Row<'_>) -> rusqlite::Result<JobRecord> {
    let state: String = row.get(2)?;
    let stages: String = row.get(9)?;
    let summary: Option<String> = row.get(10)?;
    Ok(JobRecord {
        id: row.get(0)?,
        label: row.get(1)?,
        state: JobState::parse(&state).unwrap_or(JobState::Failed),
        scene: row.get(3)?,
        created_at: row.get(4)?,
        started_at: row.get(5)?,
        finished_at: row.get(6)?,
        error: row.get(7)?,
        particles: row.get::<_, i64>(8)? as u64,
        stages: stages
            .split(',')
            .filter(|s| !s.is_empty())
            .map(String::from)
            .collect(),
        summary: summary.and_then(|s| serde_json::from_str(&s).ok()),
        progress: None,
        scene_name: row.get(11)?,
        worker: String::new(),
    })
}

impl Store {
    /// Opens (or creates) the store in `dir`.
    pub fn open(dir: &Path) -> Result<Store, JobError> {
        std::fs::create_dir_all(dir.join("jobs"))
            .map_err(|e| JobError::Store(format!("cannot create {}: {e}", dir.display())))?;
        let conn = Connection::open(dir.join("cleave.sqlite")).map_err(db_err)?;
        conn.execute_batch(
            "PRAGMA journal_mode = WAL;
             PRAGMA synchronous = NORMAL;
             CREATE TABLE IF NOT EXISTS jobs (
                 seq INTEGER PRIMARY KEY AUTOINCREMENT,
                 id TEXT UNIQUE NOT NULL,
                 label TEXT NOT NULL,
                 state TEXT NOT NULL,
                 scene TEXT NOT NULL,
                 created_at REAL NOT NULL,
                 started_at REAL,
                 finished_at REAL,
                 error TEXT,
                 particles INTEGER NOT NULL,
                 stages TEXT NOT NULL,
                 summary TEXT
             );
             CREATE INDEX IF NOT EXISTS jobs_state ON jobs(state);",
        )
        .map_err(db_err)?;
        // Data directories written before jobs had a scene name gain the
        // column; their jobs show an empty name.
        let has_name: bool = conn
            .query_row(
                "SELECT COUNT(*) FROM pragma_table_info('jobs') WHERE name = 'scene_name'",
                [],
                |r| r.get::<_, i64>(0),
            )
            .map_err(db_err)?
            > 0;
        if !has_name {
            conn.execute(
                "ALTER TABLE jobs ADD COLUMN scene_name TEXT NOT NULL DEFAULT ''",
                [],
            )
            .map_err(db_err)?;
        }
        Ok(Store {
            conn: Mutex::new(conn),
            dir: dir.to_path_buf(),
        })
    }

    fn conn(&self) -> std::sync::MutexGuard<'_, Connection> {
        // A panic while holding the lock cannot leave SQLite inconsistent
        // (each statement is atomic), so a poisoned lock is still usable.
        self.conn.lock().unwrap_or_else(|p| p.into_inner())
    }

    /// The directory of a job's result files.
    pub fn job_dir(&self, id: &str) -> PathBuf {
        self.dir.join("jobs").join(id)
    }

    /// Inserts a new queued job and returns its id (`job-000001`, ...).
    pub fn insert(
        &self,
        label: &str,
        scene: &str,
        scene_name: &str,
        created_at: f64,
        particles: u64,
        stages: &[String],
    ) -> Result<String, JobError> {
        let conn = self.conn();
        let tx = conn.unchecked_transaction().map_err(db_err)?;
        tx.execute(
            "INSERT INTO jobs (id, label, state, scene, scene_name, created_at, particles, stages) VALUES ('', ?1, ?2, ?3, ?4, ?5, ?6, ?7)",
            params![label, JobState::Queued.as_str(), scene, scene_name, created_at, particles as i64, stages.join(",")],
        )
        .map_err(db_err)?;
        let seq = tx.last_insert_rowid();
        let id = format!("job-{seq:06}");
        tx.execute("UPDATE jobs SET id = ?1 WHERE seq = ?2", params![id, seq])
            .map_err(db_err)?;
        tx.commit().map_err(db_err)?;
        std::fs::create_dir_all(self.job_dir(&id))
            .map_err(|e| JobError::Store(format!("cannot create the directory of {id}: {e}")))?;
        Ok(id)
    }

    pub fn get(&self, id: &str) -> Result<JobRecord, JobError> {
        self.conn()
            .query_row(
                &format!("SELECT {COLUMNS} FROM jobs WHERE id = ?1"),
                params![id],
                record,
            )
            .optional()
            .map_err(db_err)?
            .ok_or_else(|| JobError::NotFound(format!("no job {id}")))
    }

    /// Jobs newest first, after the page token (the sequence number of the
    /// last job of the previous page), optionally in one state; with their
    /// scene text only if `with_scene`.
    pub fn list(
        &self,
        page_size: usize,
        after: Option<i64>,
        state: Option<JobState>,
        with_scene: bool,
    ) -> Result<(Vec<JobRecord>, Option<i64>), JobError> {
        let conn = self.conn();
        let columns = if with_scene { COLUMNS } else { COLUMNS_BASIC };
        let mut stmt = conn
            .prepare(&format!(
                "SELECT {columns}, seq FROM jobs WHERE seq < ?1 AND (?2 IS NULL OR state = ?2) ORDER BY seq DESC LIMIT ?3"
            ))
            .map_err(db_err)?;
        let rows = stmt
            .query_map(
                params![
                    after.unwrap_or(i64::MAX),
                    state.map(|s| s.as_str()),
                    page_size as i64 + 1
                ],
                |row| Ok((record(row)?, row.get::<_, i64>(12)?)),
            )
            .map_err(db_err)?;
        let mut out = Vec::new();
        for r in rows {
            out.push(r.map_err(db_err)?);
        }
        let more = out.len() > page_size;
        out.truncate(page_size);
        let next = if more {
            out.last().map(|(_, seq)| *seq)
        } else {
            None
        };
        Ok((out.into_iter().map(|(r, _)| r).collect(), next))
    }

    /// Ids of jobs in a state, oldest first.
    pub fn ids_in_state(&self, state: JobState) -> Result<Vec<String>, JobError> {
        let conn = self.conn();
        let mut stmt = conn
            .prepare("SELECT id FROM jobs WHERE state = ?1 ORDER BY seq")
            .map_err(db_err)?;
        let rows = stmt
            .query_map(params![state.as_str()], |r| r.get(0))
            .map_err(db_err)?;
        rows.collect::<Result<Vec<String>, _>>().map_err(db_err)
    }

    pub fn count_in_state(&self, state: JobState) -> Result<usize, JobError> {
        self.conn()
            .query_row(
                "SELECT COUNT(*) FROM jobs WHERE state = ?1",
                params![state.as_str()],
                |r| r.get::<_, i64>(0),
            )
            .map(|n| n as usize)
            .map_err(db_err)
    }

    /// Sets a job's state alone (a job queued again to resume).
    pub fn set_state(&self, id: &str, state: JobState) -> Result<(), JobError> {
        self.conn()
            .execute(
                "UPDATE jobs SET state = ?1 WHERE id = ?2",
                params![state.as_str(), id],
            )
            .map(|_| ())
            .map_err(db_err)
    }

    pub fn set_running(&self, id: &str, started_at: f64) -> Result<(), JobError> {
        self.conn()
            .execute(
                "UPDATE jobs SET state = ?1, started_at = COALESCE(started_at, ?2) WHERE id = ?3",
                params![JobState::Running.as_str(), started_at, id],
            )
            .map(|_| ())
            .map_err(db_err)
    }

    /// Records a job's end.
    pub fn finish(
        &self,
        id: &str,
        state: JobState,
        finished_at: f64,
        error: Option<&str>,
        summary: Option<&JobSummary>,
    ) -> Result<(), JobError> {
        let summary = summary.map(|s| serde_json::to_string(s).unwrap_or_default());
        self.conn()
            .execute(
                "UPDATE jobs SET state = ?1, finished_at = ?2, error = ?3, summary = COALESCE(?4, summary) WHERE id = ?5",
                params![state.as_str(), finished_at, error, summary, id],
            )
            .map(|_| ())
            .map_err(db_err)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A data directory written before jobs had a scene name opens, keeps
    /// its jobs, and lists them with an empty name; new jobs get theirs.
    #[test]
    fn a_data_directory_from_before_scene_names_opens() {
        let dir = tempfile::tempdir().unwrap();
        let conn = Connection::open(dir.path().join("cleave.sqlite")).unwrap();
        conn.execute_batch(
            "CREATE TABLE jobs (
                 seq INTEGER PRIMARY KEY AUTOINCREMENT,
                 id TEXT UNIQUE NOT NULL,
                 label TEXT NOT NULL,
                 state TEXT NOT NULL,
                 scene TEXT NOT NULL,
                 created_at REAL NOT NULL,
                 started_at REAL,
                 finished_at REAL,
                 error TEXT,
                 particles INTEGER NOT NULL,
                 stages TEXT NOT NULL,
                 summary TEXT
             );
             INSERT INTO jobs (id, label, state, scene, created_at, particles, stages)
                 VALUES ('job-000001', 'old', 'SUCCEEDED', '[grid]', 1.0, 10, 'p2g,g2p');",
        )
        .unwrap();
        drop(conn);
        let store = Store::open(dir.path()).unwrap();
        let old = store.get("job-000001").unwrap();
        assert_eq!((old.label.as_str(), old.scene_name.as_str()), ("old", ""));
        let id = store
            .insert("new", "[meta]\nname = \"x\"", "x", 2.0, 5, &[])
            .unwrap();
        let (jobs, _) = store.list(10, None, None, false).unwrap();
        assert_eq!(jobs.len(), 2);
        assert_eq!(
            (jobs[0].id.as_str(), jobs[0].scene_name.as_str()),
            (id.as_str(), "x")
        );
        assert_eq!(jobs[0].scene, "", "a basic list reads no scene text");
        let (full, _) = store.list(10, None, None, true).unwrap();
        assert_eq!(full[1].scene, "[grid]");
        // opening again does not add the column twice
        drop(store);
        assert!(Store::open(dir.path()).is_ok());
    }
}
