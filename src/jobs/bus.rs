//! A job's event log. Events are appended, never dropped; every watcher
//! reads the log from the start at its own pace and waits for new events,
//! so all watchers see the complete, ordered stream (however many, however
//! slow).

use super::{JobProgress, JobState, JobSummary};
use std::sync::Mutex;
use tokio::sync::watch;

/// One event of a job (as JSON in a fleet's database).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum JobEvent {
    State {
        state: JobState,
        error: Option<String>,
    },
    Progress(JobProgress),
    Summary(JobSummary),
}

impl JobEvent {
    /// The last event of a job.
    pub fn is_final(&self) -> bool {
        matches!(self, JobEvent::State { state, .. } if state.is_final())
    }
}

/// The append-only log and a signal carrying its length.
pub struct JobBus {
    events: Mutex<Vec<JobEvent>>,
    len: watch::Sender<usize>,
}

impl Default for JobBus {
    fn default() -> Self {
        Self::new()
    }
}

impl JobBus {
    pub fn new() -> JobBus {
        JobBus {
            events: Mutex::new(Vec::new()),
            len: watch::channel(0).0,
        }
    }

    pub fn push(&self, e: JobEvent) {
        let mut events = self.events.lock().unwrap_or_else(|p| p.into_inner());
        events.push(e);
        let n = events.len();
        drop(events);
        self.len.send_replace(n);
    }

    pub fn push_state(&self, state: JobState, error: Option<String>) {
        self.push(JobEvent::State { state, error });
    }

    /// Events from index `from` on.
    pub fn since(&self, from: usize) -> Vec<JobEvent> {
        let events = self.events.lock().unwrap_or_else(|p| p.into_inner());
        events
            .get(from..)
            .map(<[JobEvent]>::to_vec)
            .unwrap_or_default()
    }

    /// A receiver that changes whenever an event is appended.
    pub fn subscribe(&self) -> watch::Receiver<usize> {
        self.len.subscribe()
    }

    /// Number of events so far.
    pub fn len(&self) -> usize {
        *self.len.borrow()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether the job's last event has been appended.
    pub fn is_final(&self) -> bool {
        let events = self.events.lock().unwrap_or_else(|p| p.into_inner());
        events.last().is_some_and(JobEvent::is_final)
    }

    pub fn last_progress(&self) -> Option<JobProgress> {
        let events = self.events.lock().unwrap_or_else(|p| p.into_inner());
        events.iter().rev().find_map(|e| match e {
            JobEvent::Progress(p) => Some(*p),
            _ => None,
        })
    }
}
