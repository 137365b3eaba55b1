//! The checkpoint file, whatever the method: a run's state at the end of a
//! step, so that a long run survives the loss of its process (a job
//! scheduler's time limit, a reboot) and picks up where its last
//! checkpoint was written. What a method keeps in it, and how a resumed
//! run repeats the uninterrupted one, is the method's (for the grid MPM,
//! `mpm/checkpoint.rs`); this module holds the container, which
//! [`crate::diagnostics::Observer::checkpoint`] hands to whoever writes
//! the run's results.
//!
//! On disk: `b"CLEAVECKPT8\n"`, the header (version, observer state,
//! scene, method, step, time) in postcard (serde's compact binary
//! format), the method's state in postcard, then a trailer: the length of
//! what precedes it (u64, little-endian) and the CRC-32 (IEEE) of
//! everything before the CRC itself, header included (u32,
//! little-endian). A file from another format version or another scene is
//! refused with the reason; a file whose length or checksum does not
//! match (a flipped bit, a truncated or appended tail) is refused as
//! damaged before anything is decoded, so that a resume never silently
//! computes something else. The header's number names the layout of the
//! saved types, which `mpm/checkpoint_layout.json` holds (a test fails
//! when a saved type changes without it); format 2 added the trailer,
//! format 4 the method's name and its state after the header, format 5
//! the particles' displacement gradient (explicit cracks' J integral),
//! format 8 the explicit cracks' released energy.

use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::io::{Read, Write};
use std::sync::Arc;

pub(crate) const MAGIC: &[u8; 12] = b"CLEAVECKPT8\n";
/// The headers of formats this build no longer reads.
const OLDER: &[&[u8; 12]] = &[
    b"CLEAVECKPT1\n",
    b"CLEAVECKPT2\n",
    b"CLEAVECKPT3\n",
    b"CLEAVECKPT4\n",
    b"CLEAVECKPT5\n",
    b"CLEAVECKPT6\n",
    b"CLEAVECKPT7\n",
];
/// The trailer: the length before it (u64) and the CRC-32 (u32).
const TRAILER: usize = 8 + 4;

/// Why a checkpoint could not be written, read or resumed from.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("not a cleave checkpoint (no CLEAVECKPT8 header)")]
    NotACheckpoint,
    #[error("the checkpoint was written in an older format ({0}); this build reads CLEAVECKPT8: rerun from the start")]
    OlderFormat(String),
    #[error("{file} is damaged ({reason}): refused, and the results written so far are kept")]
    Damaged { file: String, reason: String },
    #[error("checkpoint is damaged or from another format: {0}")]
    Decode(String),
    #[error("the scene is not the one the checkpoint was written for: {path} is {scene} in the scene, {checkpoint} in the checkpoint")]
    SceneMismatch {
        path: String,
        scene: String,
        checkpoint: String,
    },
    #[error("checkpoint does not fit the scene: {0}")]
    Inconsistent(String),
}

/// What a method saves: it writes itself (postcard) into the file. Every
/// serialisable state does so as postcard.
pub trait SaveState: Send + Sync {
    fn write(&self, out: &mut dyn Write) -> Result<(), String>;
}

impl<T: Serialize + Send + Sync> SaveState for T {
    fn write(&self, out: &mut dyn Write) -> Result<(), String> {
        postcard::to_io(self, out)
            .map(|_| ())
            .map_err(|e| e.to_string())
    }
}

/// The method's state in a checkpoint.
#[derive(Clone)]
enum Payload<'a> {
    /// Handed over by a running method (borrowing its arrays: nothing is
    /// copied to save it).
    Save(Arc<dyn SaveState + 'a>),
    /// Read from a file: the file's bytes and where the state's postcard
    /// lies in them (kept in place: a state can be gigabytes).
    Bytes(Vec<u8>, std::ops::Range<usize>),
}

/// The header of a checkpoint: what a reader needs before the method's
/// state.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(crate) struct Header {
    /// The cleave version that wrote it.
    pub version: String,
    pub observer: Vec<u8>,
    /// The scene file it was written for, as JSON.
    pub scene: String,
    /// The method that wrote it ([`crate::run::Method::name`]).
    pub method: String,
    pub step: u64,
    pub time: f64,
}

/// A run's state at the end of a step. The one a run hands its observer
/// borrows the method's arrays (nothing is copied to save it); one read
/// from a file owns its bytes (`Checkpoint<'static>`), which the method
/// decodes when it resumes.
#[derive(Clone)]
pub struct Checkpoint<'a> {
    header: Header,
    /// The state of whoever writes the run's results, saved and loaded
    /// with the checkpoint (opaque to the engine; the CLI keeps its
    /// output writer's, [`crate::output::OutputWriter`]'s state).
    pub observer: Vec<u8>,
    state: Payload<'a>,
}

impl std::fmt::Debug for Checkpoint<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Checkpoint")
            .field("method", &self.header.method)
            .field("step", &self.header.step)
            .field("time", &self.header.time)
            .finish_non_exhaustive()
    }
}

/// The scene file as the checkpoint stores it.
fn scene_json(scene: &Scene) -> String {
    serde_json::to_string(&scene.file).unwrap_or_default()
}

impl<'a> Checkpoint<'a> {
    /// A checkpoint of `method` running `scene`, at `step` and `time`,
    /// whose state `state` writes.
    pub fn new(
        scene: &Scene,
        method: &str,
        step: u64,
        time: f64,
        state: Arc<dyn SaveState + 'a>,
    ) -> Checkpoint<'a> {
        Checkpoint {
            header: Header {
                version: crate::VERSION.to_string(),
                observer: Vec::new(),
                scene: scene_json(scene),
                method: method.to_string(),
                step,
                time,
            },
            observer: Vec::new(),
            state: Payload::Save(state),
        }
    }

    /// The step it was written at.
    pub fn step(&self) -> u64 {
        self.header.step
    }

    /// The simulated time it was written at, s.
    pub fn time(&self) -> f64 {
        self.header.time
    }

    /// The cleave version that wrote it.
    pub fn version(&self) -> &str {
        &self.header.version
    }

    /// The method that wrote it.
    pub fn method(&self) -> &str {
        &self.header.method
    }

    /// The method's state as read from a file (None for one handed over
    /// by a running method).
    pub fn state_bytes(&self) -> Option<&[u8]> {
        match &self.state {
            Payload::Bytes(b, at) => Some(&b[at.clone()]),
            Payload::Save(_) => None,
        }
    }

    /// Whether `scene` is the one the checkpoint was written for, but for
    /// its top-level tables named in `may_change` (settings that decide
    /// how something is solved for, to a tolerance, not what is
    /// simulated: a long run can go on with a faster solver). A
    /// difference is named by its field path.
    pub fn check_scene(&self, scene: &Scene, may_change: &[&str]) -> Result<(), CheckpointError> {
        let mut now = serde_json::to_value(&scene.file).unwrap_or_default();
        let mut then: serde_json::Value = serde_json::from_str(&self.header.scene)
            .map_err(|e| CheckpointError::Decode(format!("its scene: {e}")))?;
        for key in may_change {
            let take = |v: &mut serde_json::Value| v.as_object_mut().and_then(|o| o.remove(*key));
            if let (Some(a), Some(b)) = (take(&mut then), take(&mut now)) {
                if a != b {
                    tracing::info!(table = key, checkpoint = %a, scene = %b, "resuming with another setting");
                }
            }
        }
        match first_difference("", &then, &now) {
            Some((path, checkpoint, scene)) => Err(CheckpointError::SceneMismatch {
                path,
                scene,
                checkpoint,
            }),
            None => Ok(()),
        }
    }

    /// Writes the checkpoint (header, postcard, then the length and the
    /// CRC-32 of all of it), streaming: nothing is copied to checksum it.
    pub fn write_to(&self, w: &mut impl Write) -> Result<(), CheckpointError> {
        let mut out = Summed {
            inner: w,
            crc: crc32fast::Hasher::new(),
            len: 0,
        };
        out.write_all(MAGIC)?;
        let mut header = self.header.clone();
        header.observer.clone_from(&self.observer);
        postcard::to_io(&header, &mut out).map_err(|e| CheckpointError::Decode(e.to_string()))?;
        match &self.state {
            Payload::Save(s) => s.write(&mut out).map_err(CheckpointError::Decode)?,
            Payload::Bytes(b, at) => out.write_all(&b[at.clone()])?,
        }
        let len = out.len;
        out.write_all(&len.to_le_bytes())?;
        let crc = out.crc.clone().finalize();
        out.inner.write_all(&crc.to_le_bytes())?;
        out.inner.flush()?;
        Ok(())
    }

    /// Reads a checkpoint written by [`Checkpoint::write_to`], checking its
    /// length and checksum before decoding it.
    pub fn read_from(r: &mut impl Read) -> Result<Checkpoint<'static>, CheckpointError> {
        Self::read_named(r, "the checkpoint")
    }

    fn read_named(r: &mut impl Read, file: &str) -> Result<Checkpoint<'static>, CheckpointError> {
        let mut bytes = Vec::new();
        r.read_to_end(&mut bytes)?;
        let body = verified(&bytes, file)?;
        let (header, rest): (Header, &[u8]) =
            postcard::take_from_bytes(body).map_err(|e| CheckpointError::Decode(e.to_string()))?;
        let end = MAGIC.len() + body.len();
        let at = end - rest.len()..end;
        Ok(Checkpoint {
            observer: header.observer.clone(),
            header,
            state: Payload::Bytes(bytes, at),
        })
    }

    /// Reads the checkpoint at `path` (a damaged file is refused naming it).
    pub fn load(path: &std::path::Path) -> Result<Checkpoint<'static>, CheckpointError> {
        let mut f = std::io::BufReader::new(std::fs::File::open(path)?);
        Checkpoint::read_named(&mut f, &path.display().to_string())
    }
}

/// A writer that checksums and counts what goes through it.
struct Summed<'w, W: Write> {
    inner: &'w mut W,
    crc: crc32fast::Hasher,
    len: u64,
}

impl<W: Write> Write for Summed<'_, W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.crc.update(&buf[..n]);
        self.len += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}

/// The postcard body of a checkpoint file's `bytes`, once its header,
/// length and checksum are found right; `file` names it in the refusal.
fn verified<'b>(bytes: &'b [u8], file: &str) -> Result<&'b [u8], CheckpointError> {
    if !bytes.starts_with(MAGIC) {
        if let Some(old) = OLDER.iter().find(|h| bytes.starts_with(h.as_slice())) {
            let name = String::from_utf8_lossy(&old[..old.len() - 1]).into_owned();
            return Err(CheckpointError::OlderFormat(name));
        }
        return Err(CheckpointError::NotACheckpoint);
    }
    let damaged = |reason: String| CheckpointError::Damaged {
        file: file.to_string(),
        reason,
    };
    if bytes.len() < MAGIC.len() + TRAILER {
        return Err(damaged(format!(
            "{} bytes, shorter than any checkpoint",
            bytes.len()
        )));
    }
    let (content, crc) = bytes.split_at(bytes.len() - 4);
    let (before, len) = content.split_at(content.len() - 8);
    let mut word = [0u8; 8];
    word.copy_from_slice(len);
    let len = u64::from_le_bytes(word);
    if len != before.len() as u64 {
        return Err(damaged(format!(
            "{} bytes where its trailer says {}: cut short or appended to",
            bytes.len(),
            len.saturating_add(TRAILER as u64)
        )));
    }
    let mut word = [0u8; 4];
    word.copy_from_slice(crc);
    let (held, found) = (u32::from_le_bytes(word), crc32fast::hash(content));
    if held != found {
        return Err(damaged(format!(
            "its CRC-32 is {found:08x}, the file says {held:08x}"
        )));
    }
    Ok(&before[MAGIC.len()..])
}

/// When an observer asks for its next checkpoint: every `every` of wall
/// time, never at the last step (the run's results are complete then and
/// its checkpoint is removed). The one rule of the CLI's writer, the
/// server's jobs and `cleave study`'s runs.
#[derive(Debug, Clone)]
pub struct CheckpointTimer {
    every: Option<std::time::Duration>,
    last: std::time::Instant,
}

impl CheckpointTimer {
    /// A timer that starts now; `None` never asks.
    pub fn new(every: Option<std::time::Duration>) -> CheckpointTimer {
        CheckpointTimer {
            every,
            last: std::time::Instant::now(),
        }
    }

    /// The interval a command line's `--checkpoint-every SECONDS` asks
    /// for, or why it is not one.
    pub fn interval(seconds: f64) -> Result<std::time::Duration, String> {
        if seconds.is_finite() && seconds >= 0.0 {
            Ok(std::time::Duration::from_secs_f64(seconds))
        } else {
            Err(format!(
                "--checkpoint-every: must be a number of seconds >= 0, got {seconds}"
            ))
        }
    }

    /// Whether checkpoints are asked for at all.
    pub fn enabled(&self) -> bool {
        self.every.is_some()
    }

    /// Whether a checkpoint is due at `p`; if so the interval starts again.
    pub fn due(&mut self, p: &crate::diagnostics::Progress) -> bool {
        match self.every {
            Some(every) if self.last.elapsed() >= every && p.time < p.end_time => {
                self.last = std::time::Instant::now();
                true
            }
            _ => false,
        }
    }
}

/// The first place where two JSON values differ, as a field path and the
/// two values (None if they are equal).
fn first_difference(
    path: &str,
    a: &serde_json::Value,
    b: &serde_json::Value,
) -> Option<(String, String, String)> {
    use serde_json::Value;
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                match y.get(k) {
                    Some(vb) => {
                        if let Some(d) = first_difference(&join(k), va, vb) {
                            return Some(d);
                        }
                    }
                    None => return Some((join(k), va.to_string(), "absent".into())),
                }
            }
            y.keys()
                .find(|k| !x.contains_key(*k))
                .map(|k| (join(k), "absent".into(), y[k].to_string()))
        }
        (Value::Array(x), Value::Array(y)) if x.len() == y.len() => x
            .iter()
            .zip(y)
            .enumerate()
            .find_map(|(i, (va, vb))| first_difference(&format!("{path}[{i}]"), va, vb)),
        _ if a == b => None,
        _ => Some((
            if path.is_empty() {
                "(the scene)".into()
            } else {
                path.to_string()
            },
            a.to_string(),
            b.to_string(),
        )),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn the_first_difference_names_the_field() {
        let a = json!({"time": {"end": 1.0, "dt": 2.0}, "bodies": [{"name": "a"}, {"name": "b"}]});
        let b = json!({"time": {"end": 1.0, "dt": 2.0}, "bodies": [{"name": "a"}, {"name": "c"}]});
        assert_eq!(first_difference("", &a, &a), None);
        assert_eq!(
            first_difference("", &a, &b),
            Some(("bodies[1].name".into(), "\"b\"".into(), "\"c\"".into()))
        );
        let c = json!({"time": {"end": 2.0, "dt": 2.0}});
        assert_eq!(
            first_difference("", &json!({"time": {"end": 1.0, "dt": 2.0}}), &c).map(|d| d.0),
            Some("time.end".into())
        );
    }

    #[test]
    fn a_file_without_the_header_is_refused() {
        let r = Checkpoint::read_from(&mut &b"CLEAVESNAP1\nxyz"[..]);
        assert!(matches!(r, Err(CheckpointError::NotACheckpoint)), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT1\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT4\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT5\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT6\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT7\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT8\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::Damaged { .. })), "{r:?}");
    }

    /// A body that is not a checkpoint, with a right length and checksum,
    /// gets as far as the decoder (which refuses it).
    #[test]
    fn a_sound_trailer_passes_to_the_decoder() {
        let mut bytes = MAGIC.to_vec();
        bytes.extend_from_slice(&[0x01, 0x02]);
        bytes.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        let crc = crc32fast::hash(&bytes);
        bytes.extend_from_slice(&crc.to_le_bytes());
        assert_eq!(verified(&bytes, "x").ok(), Some(&[0x01u8, 0x02][..]));
        let r = Checkpoint::read_from(&mut &bytes[..]);
        assert!(matches!(r, Err(CheckpointError::Decode(_))), "{r:?}");
    }
}
