//! The grid MPM's checkpoint state ([`crate::checkpoint`] is the file):
//! what a run needs to go on from the end of a step as if it had never
//! stopped.
//!
//! What is kept: every particle array, the clock and the energy
//! bookkeeping, the run loop's next row and snapshot, the bins' particle
//! order (the order in which particles are summed into the grid), and each
//! fracture model's own state ([`crate::fracture::model::FractureModel::save`]:
//! the phase fields' nodal c (PCG's warm start) and whether c is current,
//! the crack-tip trackers, the energy released by damage, the positions
//! DFG's neighbour lists were built at). What is rebuilt: what follows
//! from the scene alone (the seeding, which the saved particle arrays then
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

use super::{Saved, Simulation, StageTimes};
use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::fracture::model::RestoreContext;
use crate::particles::Particles;
use crate::scene::Scene;
use serde::{Deserialize, Serialize};
use std::borrow::Cow;
use std::sync::Arc;

pub(super) use crate::run::RunClock;

#[derive(Debug, Clone, Serialize, Deserialize)]
#[serde(bound(
    serialize = "Particles<D, V>: Serialize",
    deserialize = "Particles<D, V>: Deserialize<'de>"
))]
pub(super) struct State<'a, const D: usize = 2, const V: usize = 3> {
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
    pub parts: Cow<'a, Particles<D, V>>,
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

/// The first particle array whose length differs between `a` and `b`.
fn other_layout<const D: usize, const V: usize>(
    a: &Particles<D, V>,
    b: &Particles<D, V>,
) -> Option<&'static str> {
    let lengths = |p: &Particles<D, V>| {
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
            ("grad_u", p.grad_u.len()),
            ("softening", p.softening.len()),
            ("accel", p.accel.len()),
        ]
    };
    lengths(a)
        .into_iter()
        .zip(lengths(b))
        .find(|(x, y)| x.1 != y.1)
        .map(|(x, _)| x.0)
}

impl Simulation {
    /// The simulation of a 2D `scene` at the checkpoint
    /// ([`Simulation::resume_in`]).
    pub fn resume(scene: &Scene, cp: Checkpoint<'_>) -> Result<Simulation, CheckpointError> {
        Simulation::resume_in(scene, cp)
    }
}

impl<const D: usize, const V: usize> Simulation<D, V>
where
    Particles<D, V>: Saved,
{
    /// The state at the end of the present step, with the run loop at
    /// `clock`.
    pub(super) fn checkpoint_at(&self, clock: RunClock) -> Checkpoint<'_> {
        let state = State {
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
        };
        Checkpoint::new(
            &self.scene,
            super::METHOD.name,
            self.step,
            self.time,
            Arc::new(state),
        )
    }

    /// The simulation of `scene` at the checkpoint: [`Simulation::run`]
    /// then goes on from its step, writing the rows and snapshots that
    /// follow (not the series' header nor the rows before). The scene must
    /// be the one the checkpoint was written for, but for its
    /// `[phase_field_solver]` (then the results agree with the straight
    /// run's to the solvers' tolerance, not bit for bit).
    pub fn resume_in(
        scene: &Scene,
        cp: Checkpoint<'_>,
    ) -> Result<Simulation<D, V>, CheckpointError> {
        // the scene's models say which of their tables may change
        let mut sim = Simulation::<D, V>::build(scene);
        let may_change: Vec<&str> = sim
            .model_list()
            .flat_map(|m| m.may_change_on_resume().iter().copied())
            .collect();
        cp.check_scene(scene, &may_change)?;
        if cp.method() != super::METHOD.name {
            return Err(CheckpointError::Inconsistent(format!(
                "it was written by the {} method, the scene runs {}",
                cp.method(),
                super::METHOD.name
            )));
        }
        let s: State<'static, D, V> = postcard::from_bytes(cp.state_bytes().unwrap_or_default())
            .map_err(|e| CheckpointError::Decode(e.to_string()))?;
        let bad = |m: String| CheckpointError::Inconsistent(m);
        // with `grid.resort_every` the particles were saved in the order of
        // their last re-sort (matched by id below)
        let resorts = scene.file.grid.resort_every > 0;
        if s.parts.len() != sim.parts.len() || (!resorts && s.parts.id != sim.parts.id) {
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
        let setup_ids = std::mem::take(&mut sim.parts.id);
        sim.parts = s.parts.into_owned();
        sim.group_of = sim.parts.group.clone();
        if sim.parts.id != setup_ids {
            // a run with `grid.resort_every` saved its particles in
            // another order than setup's: the sides' traction lists follow
            let mut setup_of = vec![u32::MAX; setup_ids.len()];
            for (k, &id) in setup_ids.iter().enumerate() {
                if let Some(s) = setup_of.get_mut(id as usize) {
                    *s = k as u32;
                }
            }
            let order: Vec<u32> = sim
                .parts
                .id
                .iter()
                .map(|&id| setup_of.get(id as usize).copied().unwrap_or(u32::MAX))
                .collect();
            let mut seen = vec![false; order.len()];
            let every_once = order.iter().all(|&k| {
                (k as usize) < seen.len() && !std::mem::replace(&mut seen[k as usize], true)
            });
            if !every_once {
                return Err(bad(
                    "its particles are not the ones seeded from the scene".to_string()
                ));
            }
            sim.tractions.renumber(&order);
        }
        sim.bins
            .restore(&sim.geom, &sim.parts.x, s.bins_order.into_owned())
            .map_err(bad)?;
        let Simulation {
            geom,
            parts,
            models,
            ..
        } = &mut sim;
        let at = || RestoreContext { geom, parts };
        for (model, saved) in models.iter_mut().zip(&s.models) {
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

    /// postcard writes no field names nor types: a file read with another
    /// layout fails to decode, or worse decodes into other values. The
    /// header's number (`CLEAVECKPT8`) names the layout, so that older files
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
            .trace_simple_type::<crate::checkpoint::Header>()
            .expect("trace the checkpoint's header");
        tracer
            .trace_simple_type::<State>()
            .expect("trace the grid method's state");
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
        tracer
            .trace_simple_type::<crate::fracture::cracks::model::CrampSaved>()
            .expect("trace the explicit cracks' state");
        tracer
            .trace_simple_type::<crate::fracture::eigen::model::EigenSaved>()
            .expect("trace the eigen models' state");
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
                 (CLEAVECKPT8 -> CLEAVECKPT9, with the old header in OLDER, so that files in the old layout are refused) and replace {} with it",
                fresh.display(),
                path.display()
            );
        }
        assert!(crate::checkpoint::MAGIC.starts_with(b"CLEAVECKPT"));
    }

    /// F and the APIC matrix became `[[f64; 2]; 2]` (they were `[f64; 4]`,
    /// the same numbers row-major) when the particles became generic over
    /// the dimension. postcard writes an array's elements without a
    /// length, so the bytes are the same and CLEAVECKPT4 files still load:
    /// the layout file changed, the format did not.
    #[test]
    fn nested_matrices_keep_the_flat_arrays_bytes() {
        let flat = [1.5f64, -2.0, 0.25, 3.0];
        let nested = [[1.5f64, -2.0], [0.25, 3.0]];
        let a = postcard::to_allocvec(&vec![flat; 3]).expect("flat");
        let b = postcard::to_allocvec(&vec![nested; 3]).expect("nested");
        assert_eq!(a, b);
        let back: Vec<[[f64; 2]; 2]> = postcard::from_bytes(&a).expect("read");
        assert_eq!(back, vec![nested; 3]);
    }
}
