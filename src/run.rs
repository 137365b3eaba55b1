//! The seam between a simulation method and what drives one: the CLI,
//! the server's jobs, `cleave study`, the benchmarks. A method steps a
//! scene, reports series rows, snapshots and progress to an
//! [`Observer`], hands it checkpoints ([`crate::checkpoint`]) and ends
//! with a [`RunSummary`]; [`crate::methods`] builds the one a scene asks
//! for, or resumes one from a checkpoint. The grid MPM
//! ([`crate::mpm::Simulation`]) is one; a meshfree method (the damage
//! particle method of Wei & Chen) plugs in beside it and gets the series,
//! snapshots, the service, studies and checkpoints for free.
//!
//! The types every method shares live here too: why a run stopped
//! ([`SimError`]), the time per stage of its plan ([`StageTimes`]), the
//! summary.

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::diagnostics::{Observer, SeriesRow};
use crate::fracture::model::AsAny;
use crate::scene::{Plan, Scene, Stage};
use serde::Serialize;

/// A simulation method running a scene.
pub trait Method: Send + AsAny {
    /// The method's name, as checkpoints record it.
    fn name(&self) -> &'static str;

    fn scene(&self) -> &Scene;

    /// How many particles the run has.
    fn particle_count(&self) -> usize;

    /// Simulated time reached, s.
    fn time(&self) -> f64;

    /// Steps taken.
    fn steps(&self) -> u64;

    /// The series' column names: [`SeriesRow::COLUMNS`], then the fracture
    /// models'.
    fn series_columns(&mut self) -> Vec<String>;

    /// One step of the size the scene asks for, clipped to land on
    /// `time.end`; returns the Δt taken. Reports nothing (see
    /// [`Method::run`]).
    fn step(&mut self) -> Result<f64, SimError>;

    /// Runs to `time.end` (or on from a checkpoint), reporting rows,
    /// snapshots, progress and checkpoints to `obs`. Returns early (with
    /// `cancelled`) when the observer asks to stop.
    fn run(&mut self, obs: &mut dyn Observer) -> Result<RunSummary, SimError>;

    /// Wall time spent in each stage of the plan so far.
    fn stage_times(&self) -> &StageTimes;

    /// The series row of the present state (as [`Method::run`] writes
    /// one), with a value for every one of [`Method::series_columns`].
    fn row(&mut self) -> SeriesRow;
}

/// The run loop's position, as a checkpoint keeps it: the next series row
/// and snapshot to write, and the last row written.
#[derive(Debug, Clone, Serialize, serde::Deserialize)]
pub struct RunClock {
    pub next_row: u64,
    pub next_snap: u64,
    pub last: SeriesRow,
}

/// A method's run resumed from a checkpoint it wrote.
pub type Resumed = Result<Box<dyn Method>, CheckpointError>;

/// A simulation method as the registry knows it.
pub struct MethodEntry {
    /// Its name, as checkpoints record it ([`Method::name`]).
    pub name: &'static str,
    /// Whether a validated scene runs this method.
    pub runs: fn(&Scene) -> bool,
    /// Sets up the scene's run, or says why the scene cannot run (what
    /// only setting it up finds, such as a support too small for the
    /// damage particle method's moment matrices).
    pub build: fn(&Scene) -> Result<Box<dyn Method>, crate::scene::SceneError>,
    /// The run at a checkpoint this method wrote.
    pub resume: fn(&Scene, Checkpoint<'_>) -> Resumed,
}

/// A point of an error message: `(x, y)` in 2D, `(x, y, z)` in 3D.
fn point(x: f64, y: f64, z: Option<f64>) -> String {
    match z {
        Some(z) => format!("({x:.6e}, {y:.6e}, {z:.6e})"),
        None => format!("({x:.6e}, {y:.6e})"),
    }
}

/// Why a run stopped early.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    #[error("step {step}, t = {time:.6e} s: particle {particle} has a non-finite {quantity}")]
    NonFinite {
        step: u64,
        time: f64,
        particle: u32,
        quantity: &'static str,
    },
    #[error(
        "step {step}, t = {time:.6e} s: particle {particle} left the grid at {} m",
        point(*x, *y, *z)
    )]
    LeftGrid {
        step: u64,
        time: f64,
        particle: u32,
        x: f64,
        y: f64,
        /// 3D only.
        z: Option<f64>,
    },
    #[error("step {step}, t = {time:.6e} s: particle {particle} volume vanished or inverted (J = {j:.3e})")]
    VolumeVanished {
        step: u64,
        time: f64,
        particle: u32,
        j: f64,
    },
    #[error(
        "step {step}, t = {time:.6e} s: negative nodal mass {mass:.3e} kg at node {node} {} m",
        point(*x, *y, *z)
    )]
    NegativeMass {
        step: u64,
        time: f64,
        node: usize,
        mass: f64,
        x: f64,
        y: f64,
        /// 3D only.
        z: Option<f64>,
    },
    #[error(
        "step {step}, t = {time:.6e} s: runaway energy: kinetic + strain = {energy:.6e} J exceeds {bound:.6e} J \
         (guards.energy_growth × (initial energy + |external work|))"
    )]
    EnergyRunaway {
        step: u64,
        time: f64,
        energy: f64,
        bound: f64,
    },
    #[error(
        "step {step}, t = {time:.6e} s: time.dt = {dt:.3e} s exceeds the CFL stability limit {limit:.3e} s \
         (h / max(c + |v|), reached at particle {particle})"
    )]
    CflViolated {
        step: u64,
        time: f64,
        dt: f64,
        limit: f64,
        particle: u32,
    },
    #[error("step {step}, t = {time:.6e} s: reached time.max_steps = {step} before time.end")]
    MaxSteps { step: u64, time: f64 },
    #[error(
        "step {step}, t = {time:.6e} s: the time step dt = {dt:e} s does not advance the clock \
         (cell size {h:e} m, signal speed max(c + |v|) = {signal:e} m/s, reached at particle {particle})"
    )]
    NoProgress {
        step: u64,
        time: f64,
        dt: f64,
        h: f64,
        signal: f64,
        particle: u32,
    },
    /// A fracture model's stage failed (a phase-field solve, say).
    #[error("step {step}, t = {time:.6e} s: {message}")]
    Fracture {
        step: u64,
        time: f64,
        message: String,
    },
    #[error("writing results failed: {0}")]
    Observer(String),
}

/// Wall time spent in each stage of the plan, s, in the plan's order, and
/// in the diagnostics (series rows and snapshots, not a stage).
#[derive(Debug, Clone, Default, Serialize, serde::Deserialize)]
pub struct StageTimes {
    pub stages: Vec<StageTime>,
    pub diagnostics: f64,
}

/// One stage's wall time, s.
#[derive(Debug, Clone, Copy, Serialize, serde::Deserialize)]
pub struct StageTime {
    pub stage: Stage,
    pub seconds: f64,
    /// Steps in which the stage ran its code.
    pub runs: u64,
}

impl StageTimes {
    /// Zero for every stage of `plan`.
    pub fn new(plan: &Plan) -> StageTimes {
        StageTimes {
            stages: plan
                .stages
                .iter()
                .map(|&stage| StageTime {
                    stage,
                    seconds: 0.0,
                    runs: 0,
                })
                .collect(),
            diagnostics: 0.0,
        }
    }

    /// The seconds spent in the stages `pick` selects.
    pub fn sum(&self, pick: impl Fn(Stage) -> bool) -> f64 {
        self.stages
            .iter()
            .filter(|t| pick(t.stage))
            .map(|t| t.seconds)
            .sum()
    }

    /// The seconds spent in `stage` (0 when the plan does not have it).
    pub fn get(&self, stage: Stage) -> f64 {
        self.stages
            .iter()
            .find(|t| t.stage == stage)
            .map_or(0.0, |t| t.seconds)
    }
}

/// What a finished (or cancelled) run reports.
#[derive(Debug, Clone, Serialize)]
pub struct RunSummary {
    pub steps: u64,
    /// Simulated time reached, s.
    pub time: f64,
    pub wall_seconds: f64,
    pub particles: usize,
    /// The plan's stage names.
    pub stages: Vec<&'static str>,
    pub cancelled: bool,
    pub last_row: SeriesRow,
    pub stage_seconds: StageTimes,
    /// Steps in which at least one node had fields in contact.
    pub contact_steps: u64,
    /// Each fracture model's part ([`FractureModel::summary`]) under its
    /// name: `phase_field` (the solver's times and counts, `SolveStats`),
    /// `dfg` (neighbour-list builds, separated nodes, `DfgStats`), `damage`.
    pub fracture: serde_json::Map<String, serde_json::Value>,
}

impl RunSummary {
    /// A model's part of the summary read as `T` (e.g. `SolveStats` for
    /// `phase_field`); None when the scene has no such model.
    pub fn model<T: serde::de::DeserializeOwned>(&self, name: &str) -> Option<T> {
        self.fracture
            .get(name)
            .and_then(|v| serde_json::from_value(v.clone()).ok())
    }
}
