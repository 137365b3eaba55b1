//! The explicit MPM step and the run loop.
//!
//! One step is the scene's [`Plan`]: [`Simulation::advance`] walks its
//! stages in order and times each one ([`StageTimes`]); nothing else runs.
//! The core of every step is `p2g → grid_update → g2p → rebin` (update
//! stress last), or `p2g → grid_update → g2p_velocity → remap → g2p_stress
//! → rebin` with MUSL; contact adds `field_partition` and `contact`, a
//! traction side `traction`, the fracture models their own stages (see
//! [`Stage`]).
//!
//! Entry points: [`Simulation::new`] then [`Simulation::run`].

mod checkpoint;
mod g2p;
mod grid_update;
mod p2g;
mod setup;
#[cfg(test)]
mod tests3d;

pub use g2p::BadKind;

use crate::contact::{self, ContactLaw};
use crate::diagnostics::{measure, Observer, SeriesRow};
use crate::fracture::model::{
    self as fm, AfterContext, ContactContext, FieldSplit, ForceContext, FractureModel, RowContext,
    ScatterContext, SeriesOut, SlotContext, StepContext,
};
use crate::grid::shape::{by_kernel, Kernel};
use crate::grid::{Bins, FieldSlots, GridFields, GridGeom, GroupFields, MultiField, SingleField};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::run::{Method, MethodEntry, RunClock, RunSummary, SimError, StageTime, StageTimes};
use crate::scene::{Scene, ShapeFunctionKind, Stage};
use grid_update::Boundary;
use std::time::Instant;

/// The grid MPM in the method registry ([`crate::methods`]): it runs
/// every scene that does not ask for another method.
pub const METHOD: MethodEntry = MethodEntry {
    name: "grid_mpm",
    runs: |scene| scene.file.method == crate::scene::MethodKind::GridMpm,
    build: |scene| {
        Ok(if scene.dimension() == 3 {
            Box::new(Simulation::<3, 6>::build(scene))
        } else {
            Box::new(Simulation::new(scene))
        })
    },
    resume: |scene, cp| {
        if scene.dimension() == 3 {
            Ok(Box::new(Simulation::<3, 6>::resume_in(scene, cp)?))
        } else {
            Ok(Box::new(Simulation::resume(scene, cp)?))
        }
    },
};

/// The series' columns after [`SeriesRow::COLUMNS`] in 3D, where
/// `angular_momentum` is |L|.
pub const COLUMNS_3D: [&str; 4] = SeriesRow::COLUMNS_3D;

/// What a particle array must be to go into a checkpoint: every concrete
/// dimension's is (serde's arrays stop at length 32, so a generic `D`
/// cannot promise it by itself).
pub trait Saved:
    serde::Serialize + serde::de::DeserializeOwned + Clone + Send + Sync + 'static
{
}
impl<T: serde::Serialize + serde::de::DeserializeOwned + Clone + Send + Sync + 'static> Saved
    for T
{
}

impl<const D: usize, const V: usize> Method for Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    fn name(&self) -> &'static str {
        METHOD.name
    }
    fn scene(&self) -> &Scene {
        Simulation::scene(self)
    }
    fn particle_count(&self) -> usize {
        self.parts.len()
    }
    fn time(&self) -> f64 {
        Simulation::time(self)
    }
    fn steps(&self) -> u64 {
        Simulation::steps(self)
    }
    fn series_columns(&mut self) -> Vec<String> {
        Simulation::series_columns(self)
    }
    fn step(&mut self) -> Result<f64, SimError> {
        Simulation::step(self)
    }
    fn run(&mut self, obs: &mut dyn Observer) -> Result<RunSummary, SimError> {
        Simulation::run(self, obs)
    }
    fn stage_times(&self) -> &StageTimes {
        Simulation::stage_times(self)
    }
    fn row(&mut self) -> SeriesRow {
        Simulation::row(self)
    }
}

impl<const D: usize, const V: usize> crate::run::Stepper for Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    fn scene(&self) -> &Scene {
        &self.scene
    }
    fn now(&self) -> f64 {
        self.time
    }
    fn steps_taken(&self) -> u64 {
        self.step
    }
    fn take_resumed(&mut self) -> Option<RunClock> {
        self.resumed.take()
    }
    fn set_initial_energy(&mut self, energy: f64) {
        self.initial_energy = energy;
    }
    fn series_columns(&mut self) -> Vec<String> {
        Simulation::series_columns(self)
    }
    fn next_dt(&self, end: f64) -> Result<f64, SimError> {
        Simulation::next_dt(self, end)
    }
    fn step_ends_on(&mut self, row: bool, output: bool) {
        // the phase field measures its stagger residual on a row's step;
        // the grid fields are kept for a snapshot's
        self.row_due = row;
        self.output_due = output;
    }
    fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        Simulation::advance(self, dt)
    }
    fn row(&mut self) -> SeriesRow {
        Simulation::row(self)
    }
    fn check_energy(&self, row: &SeriesRow) -> Result<(), SimError> {
        Simulation::check_energy(self, row)
    }
    fn emit_snapshot(&mut self, obs: &mut dyn Observer) -> Result<(), SimError> {
        Simulation::emit_snapshot(self, obs)
    }
    fn checkpoint_at(&self, clock: RunClock) -> crate::checkpoint::Checkpoint<'_> {
        Simulation::checkpoint_at(self, clock)
    }
    fn summary_parts(&self) -> (usize, u64, serde_json::Map<String, serde_json::Value>) {
        (
            self.parts.len(),
            self.contact_steps,
            self.model_list()
                .map(|m| (m.name().to_string(), m.summary()))
                .collect(),
        )
    }
    fn times(&self) -> &StageTimes {
        &self.times
    }
}

/// Heap bytes held by a simulation, from [`Simulation::heap_bytes`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeapBytes {
    /// The particle arrays.
    pub particles: usize,
    /// The nodal fields, the tile bins and per-step scratch.
    pub grid: usize,
}

/// A simulation in progress: the particles, the grid, and the clock, in
/// `D` = 2 or 3 dimensions (`V`: the Voigt length, 3 or 6; see
/// [`crate::tensor`]).
pub struct Simulation<const D: usize = 2, const V: usize = 3> {
    scene: Scene,
    // (crate-visible: the phase-field model's tests step one by hand)
    pub(crate) geom: GridGeom<D>,
    mats: Vec<Elastic>,
    pub(crate) parts: Particles<D, V>,
    grid: GridFields<D>,
    /// Present iff the plan has contact.
    multi: Option<MultiField>,
    friction: ContactLaw,
    pub(crate) bins: Bins,
    boundary: Boundary,
    tractions: setup::Tractions<D>,
    /// The scene's fracture models, in the order of
    /// [`crate::fracture::MODELS`].
    pub(crate) models: Vec<Box<dyn FractureModel<D, V>>>,
    /// Dense contact group of each particle (a copy of `parts.group` the
    /// field slots borrow while the step mutates the particles).
    group_of: Vec<u8>,
    /// A re-sort happened this step: `group_of` is copied anew once the
    /// step has given it back (it may be lent to the slots meanwhile).
    resorted: bool,
    apic: bool,
    /// MUSL scratch: where the particles move this step.
    x_next: Vec<[f64; D]>,
    /// Node runs the last scatter wrote (cleared at the next reset).
    written: Vec<std::ops::Range<usize>>,
    flip: f64,
    update: g2p::ParticleUpdate,
    body_force: [f64; D],
    /// Newmark's γ under the predictor–corrector (`stress_update =
    /// "newmark"`), else None.
    newmark: Option<f64>,
    /// With `[output] reactions`: each constrained side's force on the
    /// material over the last step, N (in `Boundary::names`' order); else
    /// empty.
    reactions: Vec<[f64; D]>,
    /// Scratch for the sides' impulses (as `reactions`).
    impulses: Vec<[f64; D]>,
    m_min: f64,
    time: f64,
    step: u64,
    /// The last step's Δt.
    dt: f64,
    /// max (c + |v|) after the last G2P.
    max_signal: f64,
    external_work: f64,
    abs_work: f64,
    /// The traction forces this step put on the grid, slot by slot: their
    /// work is F·v Δt with the grid velocities the particles then move
    /// with, counted at the gather.
    applied: Vec<(usize, [f64; D])>,
    initial_energy: f64,
    energy_floor: f64,
    times: StageTimes,
    contact_steps: u64,
    snapshot_index: u32,
    grid_valid: bool,
    /// The step about to run ends on a series row (the phase field then
    /// measures its stagger residual even with one iteration allowed).
    row_due: bool,
    /// The step about to run ends on a series row or a snapshot (the phase
    /// field then measures Ψ_f where it solves c).
    output_due: bool,
    /// Resumed from a checkpoint: where [`Simulation::run`] goes on.
    resumed: Option<checkpoint::RunClock>,
}

impl Simulation {
    /// Seeds the particles and builds the grid for a validated 2D scene
    /// (a 3D one: [`Simulation::build`]).
    pub fn new(scene: &Scene) -> Simulation {
        Simulation::build(scene)
    }
}

impl<const D: usize, const V: usize> Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    /// Seeds the particles and builds the grid for a validated scene of
    /// `D` dimensions.
    pub fn build(scene: &Scene) -> Simulation<D, V> {
        setup::build(scene)
    }

    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    pub fn particles(&self) -> &Particles<D, V> {
        &self.parts
    }

    /// Heap bytes of the step's big arrays: the particle arrays, and the
    /// grid side (nodal fields, the tile bins and the MUSL scratch of
    /// positions), each as capacity × element size. Small per-material
    /// and per-model state, and the contact fields (absent without
    /// contact, as in the bench), are left out. `cleave bench` divides these by
    /// the particle count.
    pub fn heap_bytes(&self) -> HeapBytes {
        let x_next = self.x_next.capacity() * std::mem::size_of::<[f64; D]>();
        let written = self.written.capacity() * std::mem::size_of::<std::ops::Range<usize>>();
        HeapBytes {
            particles: self.parts.heap_bytes(),
            grid: self.grid.heap_bytes() + self.bins.heap_bytes() + x_next + written,
        }
    }

    pub fn time(&self) -> f64 {
        self.time
    }

    pub fn steps(&self) -> u64 {
        self.step
    }

    /// The scene's fracture model of type `T` (e.g.
    /// [`crate::fracture::phase_field::model::PhaseFields`], whose solver
    /// counters `cleave bench-phase-field` reads), if it has one.
    pub fn model<T: std::any::Any>(&self) -> Option<&T> {
        fm::find(&self.models)
    }

    /// [`Self::model`], mutable.
    pub fn model_mut<T: std::any::Any>(&mut self) -> Option<&mut T> {
        fm::find_mut(&mut self.models)
    }

    /// Wall time spent in each stage so far.
    pub fn stage_times(&self) -> &StageTimes {
        &self.times
    }

    /// The series' column names: [`SeriesRow::COLUMNS`], then each
    /// fracture model's ([`FractureModel::series`], in the order of
    /// [`crate::fracture::MODELS`]).
    pub fn series_columns(&mut self) -> Vec<String> {
        let mut c: Vec<String> = SeriesRow::COLUMNS.iter().map(|s| s.to_string()).collect();
        if D == 3 {
            c.extend(COLUMNS_3D.iter().map(|s| s.to_string()));
        }
        c.extend(self.measured_columns());
        let mut out = SeriesOut::declare();
        let (at, models) = self.reporting(0.0);
        for m in models {
            m.series(&at, &mut out);
        }
        c.extend(out.names());
        c
    }

    /// The columns `[output] reactions` and `body_momenta` ask for: each
    /// constrained side's force, then each body's momentum (a body by its
    /// name, or `b<index>` without one).
    fn measured_columns(&self) -> Vec<String> {
        const AXES: [&str; 3] = ["x", "y", "z"];
        let mut c = Vec::new();
        if !self.reactions.is_empty() {
            for side in self.boundary.names() {
                c.extend(AXES[..D].iter().map(|a| format!("reaction_{side}_{a}")));
            }
        }
        if self.scene.file.output.body_momenta {
            for (i, b) in self.scene.file.bodies.iter().enumerate() {
                let name = if b.name.is_empty() {
                    format!("b{i}")
                } else {
                    b.name.clone()
                };
                c.extend(AXES[..D].iter().map(|a| format!("momentum_{a}_{name}")));
            }
        }
        c
    }

    /// The values of [`Simulation::measured_columns`], in their order.
    fn measured_values(&self) -> Vec<f64> {
        let mut v: Vec<f64> = self.reactions.iter().flatten().copied().collect();
        if self.scene.file.output.body_momenta {
            let p = &self.parts;
            let mut per_body = vec![[0.0; D]; self.scene.file.bodies.len()];
            for k in 0..p.len() {
                let b = &mut per_body[p.body[k] as usize];
                for a in 0..D {
                    b[a] += p.mass[k] * p.v[k][a];
                }
            }
            v.extend(per_body.iter().flatten());
        }
        v
    }

    /// The scene's fracture models, read-only.
    fn model_list(&self) -> impl Iterator<Item = &dyn FractureModel<D, V>> {
        self.models.iter().map(|m| m.as_ref())
    }

    /// What the models report from (with kinetic + strain `energy` now),
    /// and the models.
    fn reporting(
        &mut self,
        energy: f64,
    ) -> (
        RowContext<'_, D, V>,
        impl Iterator<Item = &mut (dyn FractureModel<D, V> + 'static)> + '_,
    ) {
        let Simulation {
            scene,
            geom,
            parts,
            mats,
            models,
            step,
            time,
            initial_energy,
            external_work,
            ..
        } = self;
        let at = RowContext {
            geom,
            parts,
            mats,
            kernel: scene.file.grid.shape_function,
            step: *step,
            time: *time,
            energy,
            initial_energy: *initial_energy,
            external_work: *external_work,
        };
        (at, models.iter_mut().map(|m| m.as_mut()))
    }

    /// Runs to `time.end`, reporting rows, snapshots and progress to `obs`
    /// (the loop every method shares, [`crate::run::drive`]). Returns
    /// early (with `cancelled`) when the observer asks to stop.
    pub fn run(&mut self, obs: &mut dyn Observer) -> Result<RunSummary, SimError> {
        crate::run::drive(self, obs)
    }

    /// The next time step: fixed (checked against the CFL limit) or
    /// α·h / max(c + |v|), clipped to land on `end`.
    fn next_dt(&self, end: f64) -> Result<f64, SimError> {
        crate::run::clip_dt(
            &self.scene,
            self.step,
            self.time,
            end,
            self.geom.h,
            self.max_signal,
            || self.fastest_particle(),
        )
    }

    fn fastest_particle(&self) -> u32 {
        let mut best = (0usize, -1.0);
        for p in 0..self.parts.len() {
            let m = &self.mats[self.parts.material[p] as usize];
            let s = m.wave_speed + crate::tensor::norm(self.parts.v[p]);
            if s > best.1 {
                best = (p, s);
            }
        }
        self.parts.id.get(best.0).copied().unwrap_or(0)
    }

    /// One step of the size the scene asks for (fixed or CFL), clipped to
    /// land on `time.end`; returns the Δt taken. Does not report to an
    /// observer nor check the energy guard (see [`Simulation::run`]).
    pub fn step(&mut self) -> Result<f64, SimError> {
        let dt = self.next_dt(self.scene.file.time.end)?;
        self.advance(dt)?;
        Ok(dt)
    }

    /// One explicit step of size `dt`.
    pub fn advance(&mut self, dt: f64) -> Result<(), SimError> {
        // Called from outside the thread pool, the whole step moves onto a
        // worker: one hand-off per step instead of one (and a sleep and
        // wake-up of this thread) per parallel loop, which with the DFG's
        // many short loops on a small scene cost more than the loops.
        if rayon::current_thread_index().is_none() {
            return rayon::scope(|_| self.advance(dt));
        }
        by_kernel!(self.scene.file.grid.shape_function, K => self.advance_k::<K>(dt))
    }

    /// Runs the plan's stages in order, each timed on its own. The stages
    /// before the scatter (the damage field, the field partition) decide
    /// the field slots the rest of the step uses, so they run first and
    /// the slots are built from their result.
    fn advance_k<K: Kernel>(&mut self, dt: f64) -> Result<(), SimError> {
        let mut times = std::mem::take(&mut self.times.stages);
        let split = times
            .iter()
            .position(|t| !t.stage.before_scatter())
            .unwrap_or(times.len());
        let after = times
            .iter()
            .position(|t| t.stage.after_slots())
            .unwrap_or(times.len());
        let (head, post) = times.split_at_mut(after);
        let (pre, rest) = head.split_at_mut(split);
        let r = self.execute::<K>(dt, pre, rest, post);
        // (after `execute`, which may have lent `group_of` to the slots)
        if std::mem::take(&mut self.resorted) {
            self.group_of.clone_from(&self.parts.group);
        }
        self.times.stages = times;
        r
    }

    fn execute<K: Kernel>(
        &mut self,
        dt: f64,
        pre: &mut [StageTime],
        rest: &mut [StageTime],
        post: &mut [StageTime],
    ) -> Result<(), SimError> {
        // the supports the rest of the step reads back (LME), first of all
        let pre = match pre.split_first_mut() {
            Some((t, after)) if t.stage == Stage::Supports => {
                let t0 = Instant::now();
                let parts = &mut self.parts;
                parts
                    .supports
                    .fill::<K>(&self.geom, &parts.x, &parts.half_size);
                t.seconds += t0.elapsed().as_secs_f64();
                t.runs += 1;
                after
            }
            _ => pre,
        };
        let nodes = self.geom.node_count();
        let Some(mut multi) = self.multi.take() else {
            debug_assert!(
                pre.is_empty() && post.is_empty(),
                "stages before and after the slots need contact"
            );
            return self.stages::<K, _>(dt, &SingleField, None, None, nodes, rest);
        };
        let group = std::mem::take(&mut self.group_of);
        // A model that splits the fields runs the stages before the
        // scatter and decides the slots; it is out of `self.models` for
        // the step, so that the others run while its slots are borrowed.
        let at = self
            .models
            .iter_mut()
            .position(|m| m.field_split().is_some());
        let mut split = at.map(|i| self.models.remove(i));
        let mut slots_n = nodes;
        for t in pre.iter_mut() {
            let t0 = Instant::now();
            let ctx = ScatterContext {
                geom: &self.geom,
                parts: &self.parts,
                bins: &self.bins,
                kernel: self.scene.file.grid.shape_function,
                dt,
                row_due: self.row_due,
            };
            let by_model = split
                .as_mut()
                .and_then(|m| m.field_split())
                .and_then(|s| s.before_scatter(t.stage, ctx, &mut multi));
            let ran = match (t.stage, by_model) {
                (Stage::FieldPartition, Some(n)) => {
                    slots_n = n;
                    true
                }
                (_, Some(_)) => true,
                (Stage::FieldPartition, None) => {
                    slots_n = p2g::partition_fields::<K, D, V>(
                        &self.geom,
                        &self.parts,
                        &self.bins,
                        &mut multi,
                    );
                    true
                }
                _ => false,
            };
            t.seconds += t0.elapsed().as_secs_f64();
            t.runs += u64::from(ran);
        }
        let at_slots = SlotContext {
            nodes,
            multi: &multi,
            group: &group,
        };
        let r = match split.as_mut().and_then(|m| m.field_split()) {
            Some(s) => {
                let s: &dyn FieldSplit<D, V> = s;
                s.slots(at_slots).visit(Rest::<K, D, V> {
                    sim: self,
                    dt,
                    multi: &multi,
                    split: s,
                    slots_n,
                    plan: rest,
                    kernel: std::marker::PhantomData,
                })
            }
            None => {
                let slots = GroupFields {
                    nodes,
                    multi: &multi,
                    group: &group,
                };
                self.stages::<K, _>(dt, &slots, Some(&multi), None, slots_n, rest)
            }
        };
        // the split's stages on the nodal fields the step left
        if r.is_ok() {
            for t in post.iter_mut() {
                let t0 = Instant::now();
                let at = AfterContext {
                    geom: &self.geom,
                    parts: &self.parts,
                    mats: &self.mats,
                    grid: &self.grid,
                    multi: &multi,
                    kernel: self.scene.file.grid.shape_function,
                    time: self.time,
                    dt,
                };
                let ran = split
                    .as_mut()
                    .and_then(|m| m.field_split())
                    .is_some_and(|s| s.after_slots(t.stage, at));
                t.seconds += t0.elapsed().as_secs_f64();
                t.runs += u64::from(ran);
            }
        }
        if let (Some(i), Some(m)) = (at, split) {
            self.models.insert(i, m);
        }
        self.multi = Some(multi);
        self.group_of = group;
        r
    }
}

/// The stages from the scatter on, run with a splitting model's slots
/// ([`fm::SplitSlots::visit`]: compiled for its concrete slot rule).
struct Rest<'s, K, const D: usize, const V: usize> {
    sim: &'s mut Simulation<D, V>,
    dt: f64,
    multi: &'s MultiField,
    /// The split whose slots these are (its contact law).
    split: &'s dyn FieldSplit<D, V>,
    slots_n: usize,
    plan: &'s mut [StageTime],
    kernel: std::marker::PhantomData<K>,
}

impl<K: Kernel, const D: usize, const V: usize> fm::SlotsVisitor for Rest<'_, K, D, V>
where
    Particles<D, V>: Saved,
{
    type Output = Result<(), SimError>;
    fn visit<S: FieldSlots>(self, slots: &S) -> Self::Output {
        self.sim.stages::<K, S>(
            self.dt,
            slots,
            Some(self.multi),
            Some(self.split),
            self.slots_n,
            self.plan,
        )
    }
}

impl<const D: usize, const V: usize> Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    /// The stages from the scatter on, with the field slots `slots`
    /// (`slots_n` of them) fixed for the step, and the splitting model
    /// that made them (if one did: its contact law).
    fn stages<K: Kernel, S: FieldSlots>(
        &mut self,
        dt: f64,
        slots: &S,
        multi: Option<&MultiField>,
        split: Option<&dyn FieldSplit<D, V>>,
        slots_n: usize,
        plan: &mut [StageTime],
    ) -> Result<(), SimError> {
        let t_bc = self.time + dt;
        let transfer = g2p::Transfer {
            flip: self.flip,
            update: self.update,
        };
        let mut moved_tile = false;
        let step_before = self.step;
        for t in plan.iter_mut() {
            let t0 = Instant::now();
            // whether the stage found its state and ran
            let ran = 'stage: {
                match t.stage {
                    Stage::P2g => {
                        let mgrad = multi.is_some() && split.is_none_or(|s| s.mass_gradients());
                        match self.newmark {
                            Some(gamma) => self.scatter_predictor::<K, S>(
                                slots,
                                mgrad,
                                slots_n,
                                (1.0 - gamma) * dt,
                            ),
                            None => self.scatter::<K, S>(slots, mgrad, slots_n),
                        }
                        if self.boundary.has_drives() {
                            let (geom, parts) = (&self.geom, &self.parts);
                            self.boundary
                                .find_driven::<K, D, V>(geom, parts, &self.grid, multi);
                        }
                        true
                    }
                    // Tractions at mid-step: the impulse of a linear ramp is then exact
                    Stage::Traction => {
                        let t_mid = self.time + 0.5 * dt;
                        self.tractions.apply::<K, S, V>(
                            t_mid,
                            &self.geom,
                            &self.parts,
                            slots,
                            &mut self.grid,
                            &mut self.applied,
                        );
                        true
                    }
                    // a split's own forces (crack-face pressure), at mid-step
                    // like the tractions; their work is the split's own
                    // (crack faces are not particles: F·v of the surface)
                    Stage::CrackTraction => {
                        let (Some(s), Some(m)) = (split, multi) else {
                            break 'stage false;
                        };
                        let at = ForceContext {
                            geom: &self.geom,
                            grid: &mut self.grid,
                            multi: m,
                            kernel: self.scene.file.grid.shape_function,
                            time: self.time + 0.5 * dt,
                            dt,
                        };
                        match s.forces(t.stage, at) {
                            Some(w) => {
                                self.add_work(w);
                                true
                            }
                            None => false,
                        }
                    }
                    Stage::GridUpdate => {
                        self.grid_update(dt, self.body_force, t_bc, multi, true)?;
                        true
                    }
                    // v = p/m without forces (Δt = 0), the walls (their
                    // work is the corrector's), and the walled predictor
                    // kept as the step's v⁰
                    Stage::NewmarkPredictor => {
                        self.grid_update(0.0, [0.0; D], t_bc, multi, false)?;
                        self.keep_predictor();
                        true
                    }
                    Stage::NewmarkStress => {
                        let stats = g2p::musl_stress::<K, S, D, V>(
                            &self.geom,
                            &mut self.parts,
                            &mut self.bins,
                            None,
                            slots,
                            &self.grid,
                            &self.mats,
                            dt,
                        );
                        // a bad stress ends the step here; else the last
                        // gather's guards and signal speed count
                        if stats.bad.is_some() {
                            self.finish_gather(dt, stats)?;
                        }
                        true
                    }
                    Stage::NewmarkForce => {
                        let (geom, parts, bins) = (&self.geom, &self.parts, &self.bins);
                        p2g::scatter_forces::<K, S, D, V>(geom, parts, bins, slots, &mut self.grid);
                        true
                    }
                    Stage::NewmarkCorrector => {
                        let Some(gamma) = self.newmark else {
                            break 'stage false;
                        };
                        let w = grid_update::correct(
                            &mut self.grid,
                            &self.bins.active,
                            self.geom.node_count(),
                            gamma * dt,
                            dt,
                            self.body_force,
                            self.m_min,
                        );
                        self.add_work(w);
                        // The walls hold the node against γ Δt (f + m g) here:
                        // that impulse over γ is the reaction's work over the
                        // step, −Δt R·v_bc. (The predictor's wall correction
                        // is not work: the particles never take it, their
                        // accelerations are the walled nodes'. Newmark's
                        // weighting (1 − γ) R_k + γ R_{k+1} differs from R_{k+1}
                        // by a telescoping sum: one step's worth in a run.)
                        let w = self.walls(t_bc, multi, gamma * dt, true);
                        self.add_work(w / gamma);
                        true
                    }
                    Stage::NewmarkG2p => {
                        let Some(gamma) = self.newmark else {
                            break 'stage false;
                        };
                        // the particles move with the predictor
                        self.applied_work(dt, true);
                        let contacted = self.scene.plan.has(Stage::NewmarkContact);
                        let stats = g2p::newmark::<K, S, D, V>(
                            &self.geom,
                            &mut self.parts,
                            &mut self.bins,
                            slots,
                            &self.grid,
                            &self.mats,
                            self.flip,
                            gamma,
                            dt,
                            contacted.then_some(self.grid.vel_moved.as_slice()),
                        );
                        moved_tile = self.finish_gather(dt, stats)?;
                        true
                    }
                    // the split's first pass; the walls come again in `contact`
                    Stage::ContactMomenta => {
                        let (Some(s), Some(m)) = (split, multi) else {
                            break 'stage false;
                        };
                        let floor = self.contact_floor();
                        let at = ContactContext {
                            grid: &mut self.grid,
                            multi: m,
                            floor,
                            momenta: true,
                        };
                        s.contact(at).is_some()
                    }
                    Stage::Contact => {
                        let Some(m) = multi else {
                            break 'stage false;
                        };
                        let floor = self.contact_floor();
                        let own = split.and_then(|s| {
                            s.contact(ContactContext {
                                grid: &mut self.grid,
                                multi: m,
                                floor,
                                momenta: false,
                            })
                        });
                        let touched = match own {
                            Some(n) => n,
                            None => contact::apply(&mut self.grid, m, &self.friction, self.m_min),
                        };
                        if touched > 0 {
                            self.contact_steps += 1;
                        }
                        if self.newmark.is_some() {
                            // the predictor's walls again (not work, as in
                            // `newmark_predictor`); the particles move with
                            // the contacted predictor (`vel_moved`), while
                            // the corrector and the accelerations start from
                            // the walled one (`vel_old`): the impulse the
                            // velocities take is `newmark_contact`'s
                            self.boundary.apply(t_bc, &mut self.grid, multi);
                            let g = &mut self.grid;
                            g.vel_moved.resize(g.vel.len(), [0.0; D]);
                            keep_active(
                                &g.vel,
                                &mut g.vel_moved,
                                &self.bins.active,
                                self.geom.node_count(),
                            );
                            break 'stage true;
                        }
                        // contact must not undo the walls
                        let w = self.walls(t_bc, multi, dt, false);
                        self.add_work(w);
                        true
                    }
                    Stage::NewmarkContact => {
                        let (Some(m), Some(gamma)) = (multi, self.newmark) else {
                            break 'stage false;
                        };
                        if contact::apply(&mut self.grid, m, &self.friction, self.m_min) > 0 {
                            self.contact_steps += 1;
                        }
                        // the walls again, as the corrector imposes them:
                        // their impulse over γΔt is the reaction, over γ
                        // its work
                        let w = self.walls(t_bc, multi, gamma * dt, false);
                        self.add_work(w / gamma);
                        true
                    }
                    Stage::G2p => {
                        self.applied_work(dt, false);
                        let stats = if self.apic {
                            g2p::g2p::<K, S, true, D, V>(
                                &self.geom,
                                &mut self.parts,
                                &mut self.bins,
                                slots,
                                &self.grid,
                                &self.mats,
                                transfer,
                                dt,
                            )
                        } else {
                            g2p::g2p::<K, S, false, D, V>(
                                &self.geom,
                                &mut self.parts,
                                &mut self.bins,
                                slots,
                                &self.grid,
                                &self.mats,
                                transfer,
                                dt,
                            )
                        };
                        moved_tile = self.finish_gather(dt, stats)?;
                        true
                    }
                    Stage::G2pVelocity => {
                        self.applied_work(dt, false);
                        self.musl_velocities::<K, S>(dt, slots, transfer);
                        true
                    }
                    Stage::Remap => {
                        self.remap::<K, S>(slots);
                        // The walls hold the remapped velocities too (no work:
                        // that was counted when they were first imposed).
                        self.boundary.apply(t_bc, &mut self.grid, multi);
                        true
                    }
                    Stage::G2pStress => {
                        let stats = g2p::musl_stress::<K, S, D, V>(
                            &self.geom,
                            &mut self.parts,
                            &mut self.bins,
                            Some(&self.x_next),
                            slots,
                            &self.grid,
                            &self.mats,
                            dt,
                        );
                        moved_tile = self.finish_gather(dt, stats)?;
                        true
                    }
                    Stage::Rebin => {
                        if moved_tile {
                            self.bins.rebuild(&self.geom, &self.parts.x, K::N);
                        }
                        true
                    }
                    Stage::Resort => {
                        let every = u64::from(self.scene.file.grid.resort_every.max(1));
                        if self.step % every == 0 {
                            self.resort(K::N);
                        }
                        true
                    }
                    // these run before the scatter and after the slots (`execute`)
                    Stage::Supports
                    | Stage::DamageField
                    | Stage::FieldPartition
                    | Stage::CrackSurfaces
                    | Stage::CrackGrowth => false,
                    // the fracture models' own stages
                    stage => {
                        let ctx = StepContext {
                            geom: &self.geom,
                            bins: &self.bins,
                            parts: &mut self.parts,
                            mats: &self.mats,
                            kernel: self.scene.file.grid.shape_function,
                            dt,
                            row_due: self.row_due,
                            output_due: self.output_due,
                        };
                        let mut owner = self
                            .models
                            .iter_mut()
                            .filter(|m| m.stages().contains(&stage));
                        let Some(model) = owner.next() else {
                            break 'stage false;
                        };
                        // the step being computed: the clock moves at the gather
                        let (step, time) = if self.step != step_before {
                            (self.step, self.time)
                        } else {
                            (self.step + 1, self.time + dt)
                        };
                        model
                            .run(stage, ctx)
                            .map_err(|message| SimError::Fracture {
                                step,
                                time,
                                message,
                            })?;
                        true
                    }
                }
            };
            t.seconds += t0.elapsed().as_secs_f64();
            t.runs += u64::from(ran);
        }
        Ok(())
    }

    /// Clears the nodes the last scatter wrote, then P2G (with the mass
    /// gradients of contact where `contact`).
    fn scatter<K: Kernel, S: FieldSlots>(&mut self, slots: &S, contact: bool, slots_n: usize) {
        self.grid
            .reset(self.geom.node_count(), slots_n, contact, &self.written);
        self.written.clone_from(&self.bins.active);
        let (geom, parts, bins, grid) = (&self.geom, &self.parts, &self.bins, &mut self.grid);
        match (self.apic, contact) {
            (false, false) => p2g::p2g::<K, S, false, false, D, V>(geom, parts, bins, slots, grid),
            (true, false) => p2g::p2g::<K, S, true, false, D, V>(geom, parts, bins, slots, grid),
            (false, true) => p2g::p2g::<K, S, false, true, D, V>(geom, parts, bins, slots, grid),
            (true, true) => p2g::p2g::<K, S, true, true, D, V>(geom, parts, bins, slots, grid),
        }
    }

    /// Newmark's predictor scatter: clears the nodes the last scatter
    /// wrote, then the mass and the momentum of v_p + `lead` a_p (and the
    /// mass gradients contact takes its normals from).
    fn scatter_predictor<K: Kernel, S: FieldSlots>(
        &mut self,
        slots: &S,
        contact: bool,
        slots_n: usize,
        lead: f64,
    ) {
        self.grid
            .reset(self.geom.node_count(), slots_n, contact, &self.written);
        self.written.clone_from(&self.bins.active);
        let (geom, parts, bins, grid) = (&self.geom, &self.parts, &self.bins, &mut self.grid);
        if contact {
            p2g::p2g_predictor::<K, S, true, D, V>(geom, parts, bins, slots, grid, lead);
        } else {
            p2g::p2g_predictor::<K, S, false, D, V>(geom, parts, bins, slots, grid, lead);
        }
    }

    /// Newmark: the walled predictor velocities kept as the step's v⁰
    /// (`vel_old`), which the corrector starts from.
    fn keep_predictor(&mut self) {
        let g = &mut self.grid;
        keep_active(
            &g.vel,
            &mut g.vel_old,
            &self.bins.active,
            self.geom.node_count(),
        );
    }

    /// Nodal velocities, body force `g`, the negative-mass guard and the
    /// walls, whose work counts where `wall_work`.
    fn grid_update(
        &mut self,
        dt: f64,
        g: [f64; D],
        t_bc: f64,
        multi: Option<&MultiField>,
        wall_work: bool,
    ) -> Result<(), SimError> {
        let nodes = self.geom.node_count();
        let (w, negative) =
            grid_update::update(&mut self.grid, &self.bins.active, nodes, dt, g, self.m_min);
        if let Some((slot, mass)) = negative {
            let node = match multi {
                Some(m) if slot >= nodes => m.extra_node[slot - nodes] as usize,
                _ => slot,
            };
            let at = self.geom.node_position(node);
            return Err(SimError::NegativeMass {
                step: self.step + 1,
                time: self.time + dt,
                node,
                mass,
                x: at[0],
                y: at[1],
                z: (D == 3).then(|| at[D - 1]),
            });
        }
        self.add_work(w);
        if wall_work {
            let w = self.walls(t_bc, multi, dt, true);
            self.add_work(w);
        } else {
            self.boundary.apply(t_bc, &mut self.grid, multi);
        }
        Ok(())
    }

    /// The walls at `t_bc`, returning their work; with `[output]
    /// reactions`, each side's impulse over `span` (the step, or the share
    /// of it the impulse stands for) is its force, put in
    /// `self.reactions` (`fresh`: the step's first imposition) or added to
    /// it.
    fn walls(&mut self, t_bc: f64, multi: Option<&MultiField>, span: f64, fresh: bool) -> f64 {
        if self.reactions.is_empty() {
            return self.boundary.apply(t_bc, &mut self.grid, multi);
        }
        let mut imp = std::mem::take(&mut self.impulses);
        imp.fill([0.0; D]);
        let w = self
            .boundary
            .apply_measured(t_bc, &mut self.grid, multi, &mut imp);
        for (r, i) in self.reactions.iter_mut().zip(&imp) {
            for a in 0..D {
                let f = i[a] / span;
                r[a] = if fresh { f } else { r[a] + f };
            }
        }
        self.impulses = imp;
        w
    }

    /// Stage `resort`: the particle arrays permuted into the bins' order
    /// (tile by tile, and by support in a tile: the order setup stores
    /// them in), with what refers to particles by index (the sides'
    /// traction lists, the contact groups' copy), and the bins made anew.
    /// The scatter then reads each tile's particles from one contiguous
    /// range again. Within a tile the bins keep the particles of one
    /// support in index order, which the permutation changes, so later
    /// scatters may add in another order: results agree to round-off,
    /// not bit for bit. Validation keeps it to scenes without fracture
    /// models, whose per-particle state would have to follow.
    fn resort(&mut self, support: usize) {
        let order = &self.bins.order;
        if order.iter().enumerate().all(|(k, &p)| p as usize == k) {
            return;
        }
        let order = std::mem::take(&mut self.bins.order);
        setup::permute(&mut self.parts, &order);
        self.tractions.renumber(&order);
        // (`group_of` may be lent to the slots now: copied after the step)
        self.resorted = true;
        self.bins = Bins::new(&self.geom, &self.parts.x, support);
    }

    /// After the gather that moves the particles: the clock advances, then
    /// the particle guards (non-finite values, leaving the grid, vanished
    /// volume) turn a bad particle into the run's error. Returns whether a
    /// particle changed tile (the re-binning's cue).
    fn finish_gather(&mut self, dt: f64, stats: g2p::G2pStats<D>) -> Result<bool, SimError> {
        self.step += 1;
        self.time += dt;
        self.dt = dt;
        self.grid_valid = true;
        self.max_signal = stats.max_signal;
        let Some((p, kind)) = stats.bad else {
            return Ok(stats.moved_tile);
        };
        let (step, time, particle) = (self.step, self.time, self.parts.id[p]);
        Err(match kind {
            BadKind::NonFinite(quantity) => SimError::NonFinite {
                step,
                time,
                particle,
                quantity,
            },
            BadKind::LeftGrid(x) => SimError::LeftGrid {
                step,
                time,
                particle,
                x: x[0],
                y: x[1],
                z: (D == 3).then(|| x[D - 1]),
            },
            BadKind::VolumeVanished(j) => SimError::VolumeVanished {
                step,
                time,
                particle,
                j,
            },
        })
    }

    /// The MUSL first gather: particle velocities and where they move.
    fn musl_velocities<K: Kernel, S: FieldSlots>(
        &mut self,
        dt: f64,
        slots: &S,
        transfer: g2p::Transfer,
    ) {
        self.x_next.resize(self.parts.len(), [0.0; D]);
        let args = (
            &self.geom,
            &mut self.parts,
            &mut self.bins,
            &mut self.x_next,
        );
        if self.apic {
            g2p::musl_velocities::<K, S, true, D, V>(
                args.0, args.1, args.2, args.3, slots, &self.grid, &self.mats, transfer, dt,
            );
        } else {
            g2p::musl_velocities::<K, S, false, D, V>(
                args.0, args.1, args.2, args.3, slots, &self.grid, &self.mats, transfer, dt,
            );
        }
    }

    /// The MUSL remap: the updated particle momenta back to the grid.
    fn remap<K: Kernel, S: FieldSlots>(&mut self, slots: &S) {
        let (geom, parts, bins, grid) = (&self.geom, &self.parts, &self.bins, &mut self.grid);
        if self.apic {
            p2g::remap_velocities::<K, S, true, D, V>(
                geom,
                parts,
                bins,
                slots,
                grid,
                &self.written,
                self.m_min,
            );
        } else {
            p2g::remap_velocities::<K, S, false, D, V>(
                geom,
                parts,
                bins,
                slots,
                grid,
                &self.written,
                self.m_min,
            );
        }
    }

    /// The work of the traction forces the step put on the grid
    /// (`applied`), Σ F_i·v_i Δt with the grid velocities after the update
    /// and contact: under PIC, FLIP and APIC a particle moves by
    /// Δt Σ_i S_ip v_i, so this is each force's work along its particle's
    /// own displacement (XPIC(1) and FMPM(1) move it by a second-order
    /// rate; the grid's is then the step's first-order estimate). F·v_p Δt
    /// with the particles' own velocities is not: under FLIP and MUSL the
    /// particle velocity drifts from the rate the particle moves at, and a
    /// traction edge's work came out at two thirds of the strain energy it
    /// stored (`tests/engine/verification.rs`). Crack-face pressures count their
    /// own work by the surfaces' velocities: they are not forces on
    /// particles, and Σ F_i·v_i over their nodes over-counts where a share
    /// lands on a node of little field mass (docs/cracks-c3.md). Under
    /// Newmark (`predictor`) the particles move with the predictor
    /// velocities, and the work is counted along those.
    fn applied_work(&mut self, dt: f64, predictor: bool) {
        if self.applied.is_empty() {
            return;
        }
        let vel = if !predictor {
            &self.grid.vel
        } else if self.scene.plan.has(Stage::NewmarkContact) {
            // with contact the particles move with the contacted predictor
            &self.grid.vel_moved
        } else {
            &self.grid.vel_old
        };
        let w: f64 = self
            .applied
            .iter()
            .map(|&(s, f)| crate::tensor::dot(f, vel[s]))
            .sum::<f64>()
            * dt;
        self.applied.clear();
        self.add_work(w);
    }

    /// The least field mass crack contact acts on (both of its passes):
    /// the grid's floor, or a fraction of a full node's mass if larger.
    fn contact_floor(&self) -> f64 {
        self.m_min
            .max(contact::MIN_FIELD_FRACTION * self.friction.full_node_mass)
    }

    fn add_work(&mut self, w: f64) {
        self.external_work += w;
        self.abs_work += w.abs();
    }

    /// The current series row.
    pub fn row(&mut self) -> SeriesRow {
        let t0 = Instant::now();
        let apic_d = if self.apic {
            match self.scene.file.grid.shape_function {
                ShapeFunctionKind::QuadraticBspline => Some(0.25 * self.geom.h * self.geom.h),
                ShapeFunctionKind::CubicBspline => Some(self.geom.h * self.geom.h / 3.0),
                _ => None,
            }
        } else {
            None
        };
        let m = measure::measure(&self.parts, &self.mats, apic_d);
        let mut out = SeriesOut::fill();
        let (at, models) = self.reporting(m.kinetic + m.strain);
        for model in models {
            model.series(&at, &mut out);
        }
        let (mut extra, fracture_energy) = out.values();
        // 3D: |L| in the core column, then the components (after the core
        // columns, before the models')
        let angular = if D == 3 {
            let l = m.angular;
            extra.splice(0..0, [m.momentum[2], l[0], l[1], l[2]]);
            crate::tensor::norm(l)
        } else {
            m.angular[2]
        };
        // the measured columns after the 3D ones, before the models'
        let at = if D == 3 { 4 } else { 0 };
        extra.splice(at..at, self.measured_values());
        let fracture_energy = fracture_energy.unwrap_or(0.0);
        let e = m.kinetic + m.strain;
        let row = SeriesRow {
            step: self.step,
            time: self.time,
            kinetic_energy: m.kinetic,
            strain_energy: m.strain,
            external_work: self.external_work,
            energy_error: if self.step == 0 {
                0.0
            } else {
                e - self.initial_energy - self.external_work
            },
            total_mass: m.mass,
            momentum_x: m.momentum[0],
            momentum_y: m.momentum[1],
            angular_momentum: angular,
            dt: self.dt,
            fracture_energy,
            extra,
        };
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        row
    }

    fn check_energy(&self, row: &SeriesRow) -> Result<(), SimError> {
        crate::run::energy_guard(
            &self.scene,
            row,
            self.initial_energy,
            self.abs_work,
            self.energy_floor,
        )
    }

    /// A snapshot to `obs`: the particles (and the grid, with
    /// `output.grid_fields`) in the run's dimension, and what the fracture
    /// models add (fields, and lines such as explicit cracks).
    fn emit_snapshot(&mut self, obs: &mut dyn Observer) -> Result<(), SimError> {
        let t0 = Instant::now();
        let grid = if self.scene.file.output.grid_fields && self.grid_valid {
            Some(measure::grid_snapshot(
                &self.geom,
                &self.grid,
                self.multi.as_ref(),
            ))
        } else {
            None
        };
        let mut snap = measure::snapshot(
            self.snapshot_index,
            self.step,
            self.time,
            &self.parts,
            &self.mats,
            grid,
        );
        let (at, models) = self.reporting(0.0);
        for model in models {
            model.snapshot(&at, &mut snap.fields);
            model.snapshot_lines(&mut snap.lines);
        }
        self.snapshot_index += 1;
        self.times.diagnostics += t0.elapsed().as_secs_f64();
        obs.snapshot(&snap).map_err(SimError::Observer)
    }
}

/// Copies the active node ranges and every extra field slot (from `nodes`
/// on) of `from` into `to`, which has `from`'s length.
fn keep_active<const D: usize>(
    from: &[[f64; D]],
    to: &mut [[f64; D]],
    active: &[std::ops::Range<usize>],
    nodes: usize,
) {
    for r in active {
        to[r.clone()].copy_from_slice(&from[r.clone()]);
    }
    to[nodes..].copy_from_slice(&from[nodes..]);
}
