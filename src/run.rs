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
use crate::diagnostics::{Control, Observer, Progress, SeriesRow};
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
    /// A static solve did not reach equilibrium (the damage particle
    /// method's `integration = "static"`).
    #[error("step {step}, t = {time:.6e} s: {message}")]
    Equilibrium {
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

/// What the one run loop ([`drive`]) needs of a method: its clock, a step,
/// its rows, snapshots, guards and checkpoints. Every method runs a scene
/// through the same loop, so that rows, snapshots, progress, cancelling
/// and checkpoints mean the same whatever the method.
pub(crate) trait Stepper {
    fn scene(&self) -> &Scene;
    /// Simulated time reached, s.
    fn now(&self) -> f64;
    /// Steps taken.
    fn steps_taken(&self) -> u64;
    /// The loop's position a resume left (taken once).
    fn take_resumed(&mut self) -> Option<RunClock>;
    /// The kinetic + strain energy of the first row, which the energy
    /// guard and the energy error count from.
    fn set_initial_energy(&mut self, energy: f64);
    fn series_columns(&mut self) -> Vec<String>;
    /// The next Δt, clipped to land on `end`.
    fn next_dt(&self, end: f64) -> Result<f64, SimError>;
    /// Told before each step whether it ends on a series row and on any
    /// output (row or snapshot).
    fn step_ends_on(&mut self, _row: bool, _output: bool) {}
    /// One step of Δt.
    fn advance(&mut self, dt: f64) -> Result<(), SimError>;
    fn row(&mut self) -> SeriesRow;
    /// The runaway-energy guard on a row ([`energy_guard`]).
    fn check_energy(&self, row: &SeriesRow) -> Result<(), SimError>;
    fn emit_snapshot(&mut self, obs: &mut dyn Observer) -> Result<(), SimError>;
    fn checkpoint_at(&self, clock: RunClock) -> Checkpoint<'_>;
    /// The summary's method-specific parts: the particle count, the steps
    /// with contact, each fracture model's part.
    fn summary_parts(&self) -> (usize, u64, serde_json::Map<String, serde_json::Value>);
    fn times(&self) -> &StageTimes;
}

/// Runs `m` to `time.end` (or on from a checkpoint): rows at
/// `output.series_rows` evenly spaced times, snapshots likewise, progress
/// after every step, checkpoints when the observer asks. Returns early
/// (with `cancelled`) when the observer asks to stop.
pub(crate) fn drive<S: Stepper + ?Sized>(
    m: &mut S,
    obs: &mut dyn Observer,
) -> Result<RunSummary, SimError> {
    let wall = std::time::Instant::now();
    let file = &m.scene().file;
    let end = file.time.end;
    let rows = file.output.series_rows.max(2) as u64;
    let snaps = file.output.snapshots as u64;
    let max_steps = file.time.max_steps.unwrap_or(10_000_000);
    let row_time = |k: u64| end * k as f64 / (rows - 1) as f64;
    let snap_time = |k: u64| {
        if snaps <= 1 {
            end
        } else {
            end * k as f64 / (snaps - 1) as f64
        }
    };
    let (mut last, mut next_row, mut next_snap) = match m.take_resumed() {
        // a resumed run's header, rows and snapshots up to the
        // checkpoint were written before it
        Some(c) => (c.last, c.next_row, c.next_snap),
        None => {
            obs.series_columns(&m.series_columns())
                .map_err(SimError::Observer)?;
            let last = m.row();
            m.set_initial_energy(last.kinetic_energy + last.strain_energy);
            obs.series_row(&last).map_err(SimError::Observer)?;
            let mut next_snap = 0;
            if snaps > 0 && snap_time(0) <= 0.0 {
                m.emit_snapshot(obs)?;
                next_snap = 1;
            }
            (last, 1, next_snap)
        }
    };
    let mut cancelled = false;
    while m.now() < end * (1.0 - 1e-12) {
        if m.steps_taken() >= max_steps {
            return Err(SimError::MaxSteps {
                step: m.steps_taken(),
                time: m.now(),
            });
        }
        let dt = m.next_dt(end)?;
        let t = m.now() + dt;
        let ends = t >= end * (1.0 - 1e-12);
        let row_due = next_row < rows && (t >= row_time(next_row) * (1.0 - 1e-12) || ends);
        let output_due =
            row_due || (next_snap < snaps && (t >= snap_time(next_snap) * (1.0 - 1e-12) || ends));
        m.step_ends_on(row_due, output_due);
        m.advance(dt)?;
        let time = m.now();
        let at_end = time >= end * (1.0 - 1e-12);
        if next_row < rows && (time >= row_time(next_row) * (1.0 - 1e-12) || at_end) {
            while next_row < rows && row_time(next_row) <= time * (1.0 + 1e-12) {
                next_row += 1;
            }
            last = m.row();
            m.check_energy(&last)?;
            obs.series_row(&last).map_err(SimError::Observer)?;
        }
        if next_snap < snaps && (time >= snap_time(next_snap) * (1.0 - 1e-12) || at_end) {
            while next_snap < snaps && snap_time(next_snap) <= time * (1.0 + 1e-12) {
                next_snap += 1;
            }
            m.emit_snapshot(obs)?;
        }
        let progress = Progress {
            step: m.steps_taken(),
            time,
            end_time: end,
            kinetic_energy: last.kinetic_energy,
            strain_energy: last.strain_energy,
        };
        match obs.progress(&progress) {
            Control::Continue => {}
            Control::Stop => {
                cancelled = true;
                break;
            }
            Control::Checkpoint => {
                let cp = m.checkpoint_at(RunClock {
                    next_row,
                    next_snap,
                    last: last.clone(),
                });
                obs.checkpoint(cp).map_err(SimError::Observer)?;
            }
        }
    }
    if !cancelled && last.step != m.steps_taken() {
        last = m.row();
        obs.series_row(&last).map_err(SimError::Observer)?;
    }
    let (particles, contact_steps, fracture) = m.summary_parts();
    Ok(RunSummary {
        steps: m.steps_taken(),
        time: m.now(),
        wall_seconds: wall.elapsed().as_secs_f64(),
        particles,
        stages: m.scene().plan.names(),
        cancelled,
        last_row: last,
        stage_seconds: m.times().clone(),
        contact_steps,
        fracture,
    })
}

/// The step a method takes next: the scene's fixed `time.dt` (refused
/// above the stability `limit`, h / max(c + |v|)) or `time.cfl` × the
/// limit, clipped to land on `end` (a step within 1e-9 of what is left
/// takes all of it). A zero, subnormal or non-finite step, or one too
/// small to move the clock, would repeat until `max_steps`: it stops the
/// run at once and says why. `fastest` names the particle that sets the
/// limit (asked only for an error).
#[allow(clippy::too_many_arguments)]
pub(crate) fn clip_dt(
    scene: &Scene,
    step: u64,
    time: f64,
    end: f64,
    h: f64,
    signal: f64,
    fastest: impl Fn() -> u32,
) -> Result<f64, SimError> {
    let limit = h / signal.max(1e-300);
    let dt = match scene.file.time.dt {
        Some(dt) if dt > limit => {
            return Err(SimError::CflViolated {
                step,
                time,
                dt,
                limit,
                particle: fastest(),
            })
        }
        Some(dt) => dt,
        None => scene.cfl() * limit,
    };
    let left = end - time;
    let dt = if dt > left || left - dt < 1e-9 * dt {
        left
    } else {
        dt
    };
    if !dt.is_normal() || time + dt == time {
        return Err(SimError::NoProgress {
            step,
            time,
            dt,
            h,
            signal,
            particle: fastest(),
        });
    }
    Ok(dt)
}

/// The runaway-energy guard: a row's kinetic + strain energy above
/// `guards.energy_growth` × (the initial energy + the work put in, in
/// absolute value, + a floor) stops the run.
pub(crate) fn energy_guard(
    scene: &Scene,
    row: &SeriesRow,
    initial_energy: f64,
    abs_work: f64,
    floor: f64,
) -> Result<(), SimError> {
    let energy = row.kinetic_energy + row.strain_energy;
    let bound = scene.file.guards.energy_growth * (initial_energy + abs_work + floor);
    if !(energy <= bound) {
        return Err(SimError::EnergyRunaway {
            step: row.step,
            time: row.time,
            energy,
            bound,
        });
    }
    Ok(())
}
