//! Checkpoints: the state a run needs to go on from the end of a step as if
//! it had never stopped, so that a long run survives the loss of its
//! process (a job scheduler's time limit, a reboot) and picks up where its
//! last checkpoint was written.
//!
//! What is kept: every particle array, the clock and the energy
//! bookkeeping, the run loop's next row and snapshot, the bins' particle
//! order (the order in which particles are summed into the grid), the
//! phase fields' nodal c (PCG's warm start), whether c is current, the
//! crack-tip trackers, the energy released by damage, and the positions
//! DFG's neighbour lists were built at. What is rebuilt: what follows from
//! the scene alone (the seeding, which the saved particle arrays then
//! overwrite; the bodies' particle lists, DFG's surface flags, the
//! traction particles), the grid, the neighbour lists (from the saved
//! positions) and the phase-field solver's analysis and factor.
//!
//! A resumed run repeats the uninterrupted one bit for bit, except that
//! the phase-field solver starts without a factor: with the direct
//! solver nothing changes (the factor is a function of the matrix), with
//! PCG the first solve after resuming refactorizes where the uninterrupted
//! run would have iterated with its older factor, so c agrees to the PCG
//! tolerance, not bit for bit. The solver's counts and the stage times in
//! the run summary are those since the resume.
//!
//! On disk: `b"CLEAVECKPT3\n"`, the [`Checkpoint`] in postcard (serde's
//! compact binary format), then a trailer: the length of what precedes it
//! (u64, little-endian) and the CRC-32 (IEEE) of everything before the
//! CRC itself, header included (u32, little-endian). A file from another
//! format version or another scene is refused with the reason; a file
//! whose length or checksum does not match (a flipped bit, a truncated or
//! appended tail) is refused as damaged before anything is decoded, so
//! that a resume never silently computes something else. The header's
//! number names the layout of the saved types, which
//! `checkpoint_layout.json` beside this file holds (a test fails when a
//! saved type changes without it); format 2 added the trailer.

use super::{Simulation, StageTimes};
use crate::diagnostics::SeriesRow;
use crate::fracture::model::RestoreContext;
use crate::particles::Particles;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::io::{Read, Write};

const MAGIC: &[u8; 12] = b"CLEAVECKPT3\n";
/// The headers of formats this build no longer reads.
const OLDER: &[&[u8; 12]] = &[b"CLEAVECKPT1\n", b"CLEAVECKPT2\n"];
/// The trailer: the length before it (u64) and the CRC-32 (u32).
const TRAILER: usize = 8 + 4;

/// Why a checkpoint could not be written, read or resumed from.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    #[error("{0}")]
    Io(#[from] std::io::Error),
    #[error("not a cleave checkpoint (no CLEAVECKPT3 header)")]
    NotACheckpoint,
    #[error("the checkpoint was written in an older format ({0}); this build reads CLEAVECKPT3: rerun from the start")]
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

/// A run's state at the end of a step (see the module docs). The one a
/// run hands its observer borrows the particle arrays from the simulation
/// (nothing is copied to save it); one read from a file owns them
/// (`Checkpoint<'static>`).
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Checkpoint<'a> {
    /// The cleave version that wrote it.
    pub version: String,
    /// The state of whoever writes the run's results, saved and loaded
    /// with the checkpoint (opaque to the engine; the CLI keeps its
    /// output writer's, [`crate::output::OutputWriter::checkpoint_state`]).
    pub observer: Vec<u8>,
    /// The scene file it was written for, as JSON.
    scene: String,
    pub(super) state: State<'a>,
}

/// The run loop's position: the next series row and snapshot to write,
/// and the last row written.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct RunClock {
    pub next_row: u64,
    pub next_snap: u64,
    pub last: SeriesRow,
}

#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct State<'a> {
    pub step: u64,
    pub time: f64,
    pub dt: f64,
    pub max_signal: f64,
    pub external_work: f64,
    pub abs_work: f64,
    pub initial_energy: f64,
    pub contact_steps: u64,
    pub snapshot_index: u32,
    pub times: StageTimes,
    pub clock: RunClock,
    pub parts: Cow<'a, Particles>,
    pub bins_order: Cow<'a, [u32]>,
    /// Each fracture model's own state ([`FractureModel::save`]), in the
    /// order of `mpm::models`.
    pub models: Vec<SavedModel>,
}

/// One fracture model's state in a checkpoint.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub(super) struct SavedModel {
    /// [`FractureModel::name`].
    pub name: String,
    /// Its postcard bytes.
    pub state: Vec<u8>,
}

impl Checkpoint<'_> {
    /// The step it was written at.
    pub fn step(&self) -> u64 {
        self.state.step
    }

    /// The simulated time it was written at, s.
    pub fn time(&self) -> f64 {
        self.state.time
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
        postcard::to_io(self, &mut out).map_err(|e| CheckpointError::Decode(e.to_string()))?;
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
        postcard::from_bytes(body).map_err(|e| CheckpointError::Decode(e.to_string()))
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

/// The scene file as the checkpoint stores it.
fn scene_json(scene: &Scene) -> String {
    serde_json::to_string(&scene.file).unwrap_or_default()
}

/// The scene's table that a resume may change ([`Simulation::resume`]).
const SOLVER_KEY: &str = "phase_field_solver";

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

/// The first particle array whose length differs between `a` and `b`.
fn other_layout(a: &Particles, b: &Particles) -> Option<&'static str> {
    let lengths = |p: &Particles| {
        [
            ("id", p.id.len()),
            ("body", p.body.len()),
            ("material", p.material.len()),
            ("group", p.group.len()),
            ("x", p.x.len()),
            ("v", p.v.len()),
            ("mass", p.mass.len()),
            ("vol", p.vol.len()),
            ("vol0", p.vol0.len()),
            ("stress", p.stress.len()),
            ("strain", p.strain.len()),
            ("def_grad", p.def_grad.len()),
            ("affine", p.affine.len()),
            ("half_size", p.half_size.len()),
            ("phase", p.phase.len()),
            ("history", p.history.len()),
            ("damage", p.damage.len()),
            ("strength", p.strength.len()),
        ]
    };
    lengths(a)
        .into_iter()
        .zip(lengths(b))
        .find(|(x, y)| x.1 != y.1)
        .map(|(x, _)| x.0)
}

impl Simulation {
    /// The state at the end of the present step, with the run loop at
    /// `clock`.
    pub(super) fn checkpoint_at(&self, clock: RunClock) -> Checkpoint<'_> {
        Checkpoint {
            version: crate::VERSION.to_string(),
            observer: Vec::new(),
            scene: scene_json(&self.scene),
            state: State {
                step: self.step,
                time: self.time,
                dt: self.dt,
                max_signal: self.max_signal,
                external_work: self.external_work,
                abs_work: self.abs_work,
                initial_energy: self.initial_energy,
                contact_steps: self.contact_steps,
                snapshot_index: self.snapshot_index,
                times: self.times.clone(),
                clock,
                parts: Cow::Borrowed(&self.parts),
                bins_order: Cow::Borrowed(&self.bins.order),
                models: self
                    .model_list()
                    .map(|m| SavedModel {
                        name: m.name().to_string(),
                        state: m.save(),
                    })
                    .collect(),
            },
        }
    }

    /// The simulation of `scene` at the checkpoint: [`Simulation::run`]
    /// then goes on from its step, writing the rows and snapshots that
    /// follow (not the series' header nor the rows before). The scene must
    /// be the one the checkpoint was written for, but for its
    /// `[phase_field_solver]` (then the results agree with the straight
    /// run's to the solvers' tolerance, not bit for bit).
    pub fn resume(scene: &Scene, cp: Checkpoint<'_>) -> Result<Simulation, CheckpointError> {
        let mut now = serde_json::to_value(&scene.file).unwrap_or_default();
        let mut then: serde_json::Value = serde_json::from_str(&cp.scene)
            .map_err(|e| CheckpointError::Decode(format!("its scene: {e}")))?;
        // The phase-field solver may change: it decides how c is solved
        // for, to its tolerance, not what is simulated (a long run can go on
        // with a faster method).
        let solver =
            |v: &mut serde_json::Value| v.as_object_mut().and_then(|o| o.remove(SOLVER_KEY));
        if let (Some(a), Some(b)) = (solver(&mut then), solver(&mut now)) {
            if a != b {
                tracing::info!(checkpoint = %a, scene = %b, "resuming with another phase-field solver");
            }
        }
        if let Some((path, checkpoint, scene)) = first_difference("", &then, &now) {
            return Err(CheckpointError::SceneMismatch {
                path,
                scene,
                checkpoint,
            });
        }
        let mut sim = Simulation::new(scene);
        let s = cp.state;
        let bad = |m: String| CheckpointError::Inconsistent(m);
        if s.parts.len() != sim.parts.len() || s.parts.id != sim.parts.id {
            return Err(bad(format!(
                "{} particles in the checkpoint, {} seeded from the scene (or in another order)",
                s.parts.len(),
                sim.parts.len()
            )));
        }
        if let Some(array) = other_layout(&s.parts, &sim.parts) {
            return Err(bad(format!(
                "its particle array `{array}` does not have the scene's length"
            )));
        }
        if !s
            .models
            .iter()
            .map(|m| m.name.as_str())
            .eq(sim.model_list().map(|m| m.name()))
            || !s
                .times
                .stages
                .iter()
                .map(|t| t.stage)
                .eq(sim.times.stages.iter().map(|t| t.stage))
        {
            return Err(bad("its stages are not the scene's".into()));
        }
        sim.parts = s.parts.into_owned();
        sim.group_of = sim.parts.group.clone();
        sim.bins
            .restore(&sim.geom, &sim.parts.x, s.bins_order.into_owned())
            .map_err(bad)?;
        let Simulation {
            geom,
            parts,
            phase,
            dfg,
            damage,
            ..
        } = &mut sim;
        let at = || RestoreContext { geom, parts };
        for (model, saved) in super::models(phase, dfg, damage).zip(&s.models) {
            model
                .restore(&saved.state, at())
                .map_err(|e| bad(format!("{}: {e}", saved.name)))?;
        }
        sim.step = s.step;
        sim.time = s.time;
        sim.dt = s.dt;
        sim.max_signal = s.max_signal;
        sim.external_work = s.external_work;
        sim.abs_work = s.abs_work;
        sim.initial_energy = s.initial_energy;
        sim.contact_steps = s.contact_steps;
        sim.snapshot_index = s.snapshot_index;
        sim.times = s.times;
        sim.resumed = Some(s.clock);
        Ok(sim)
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

    /// postcard writes no field names nor types: a file read with another
    /// layout fails to decode, or worse decodes into other values. The
    /// header's number (`CLEAVECKPT3`) names the layout, so that older files
    /// are refused as another format; this test holds the layout that
    /// number stands for (the checkpoint's types and the observers' states
    /// it carries) and fails when a saved type changes.
    #[test]
    fn the_file_layout_is_the_one_its_header_names() {
        use serde_reflection::{Tracer, TracerConfig};
        // a stage is saved by its name: any stage's name stands for a string
        let config = TracerConfig::default().default_string_value("p2g".into());
        let mut tracer = Tracer::new(config);
        tracer
            .trace_simple_type::<Checkpoint>()
            .expect("trace the checkpoint's types");
        // the observers' own state, saved in `Checkpoint::observer`
        tracer
            .trace_simple_type::<crate::output::WriterState>()
            .expect("trace the CLI writer's state");
        tracer
            .trace_simple_type::<crate::jobs::ObserverState>()
            .expect("trace a job's state");
        // the fracture models' states, saved as bytes in `State::models`
        tracer
            .trace_simple_type::<crate::fracture::phase_field::model::PhaseState>()
            .expect("trace the phase field's state");
        tracer
            .trace_simple_type::<crate::fracture::damage::model::DamageSaved>()
            .expect("trace the damage model's state");
        tracer
            .trace_simple_type::<crate::fracture::dfg::model::DfgSaved>()
            .expect("trace DFG's state");
        let registry = tracer.registry().expect("every saved type is known");
        let layout = serde_json::to_string_pretty(&registry).expect("layout as JSON") + "\n";
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src/mpm/checkpoint_layout.json");
        let held = std::fs::read_to_string(&path).unwrap_or_default();
        if layout != held {
            let fresh = path.with_extension("json.new");
            std::fs::write(&fresh, &layout).expect("write the new layout");
            panic!(
                "the checkpoint's saved types changed (new layout in {}): raise the number in MAGIC \
                 (CLEAVECKPT3 -> CLEAVECKPT4, with the old header in OLDER, so that files in the old layout are refused) and replace {} with it",
                fresh.display(),
                path.display()
            );
        }
        assert!(MAGIC.starts_with(b"CLEAVECKPT"));
    }

    #[test]
    fn a_file_without_the_header_is_refused() {
        let r = Checkpoint::read_from(&mut &b"CLEAVESNAP1\nxyz"[..]);
        assert!(matches!(r, Err(CheckpointError::NotACheckpoint)), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT1\n\x01\x02"[..]);
        assert!(matches!(r, Err(CheckpointError::OlderFormat(_))), "{r:?}");
        let r = Checkpoint::read_from(&mut &b"CLEAVECKPT3\n\x01\x02"[..]);
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
