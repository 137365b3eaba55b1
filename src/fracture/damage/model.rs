//! The damage stage (Homel & Herbold 2017, section 2.7) as the step runs it: the
//! per-material laws of [`crate::fracture::damage`], the energy they have
//! released, and the crack tips of the bodies that track one.
//!
//! One model for 2D and 3D (`FractureModel<D, V>`): initial cracks are
//! polylines in 2D and flat polygons in 3D, the tip tracker and the
//! fragments measure in either ([`CrackTracks`]).

use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::fragments::{FragmentFinder, Fragments};
use crate::diagnostics::{Field, FieldData};
use crate::fracture::damage::{DamageLaw, DamageStep};
use crate::fracture::model::{
    decode, encode, FractureModel, RestoreContext, RowContext, SeriesOut, SetupContext, StepContext,
};
use crate::fracture::tracks::CrackTracks;
use crate::particles::Particles;
use crate::scene::{Scene, Stage};
use crate::tensor::norm;
use rayon::prelude::*;

/// Damage above this counts as cracked for the crack tip.
const TIP_D: f64 = 0.9;

pub(crate) struct DamageState<const D: usize = 2> {
    law: DamageLaw,
    /// Energy released by damage since t = 0, J.
    pub dissipated: f64,
    /// The bodies with a crack origin.
    tips: CrackTracks<D>,
    /// Particles that start this close to a crack origin root its crack, m.
    seed_radius: f64,
    /// Damage below which a particle counts as intact for fragments.
    fragment_damage: f64,
    /// Initial particle spacing per body, m.
    spacing: Vec<f64>,
    finder: FragmentFinder,
}

/// What a checkpoint keeps of the damage stage: the energy released so
/// far and the crack-tip trackers (the rest follows from the scene and the
/// particle arrays).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct DamageSaved<const D: usize = 2> {
    dissipated: f64,
    tips: Vec<TipTracker<D>>,
}

/// The damage stage for a scene whose plan has it, with the initial
/// cracks placed.
pub(crate) fn build<const D: usize, const V: usize>(
    at: &mut SetupContext<'_, D, V>,
) -> Option<Box<dyn FractureModel<D, V>>> {
    let mut state = DamageState::new(at.scene, at.parts)?;
    state.place_cracks(at.scene, at.parts);
    Some(Box::new(state))
}

impl<const D: usize> DamageState<D> {
    /// The laws of the scene's materials, or `None` without damage. Fills
    /// `parts.damage` and `parts.strength` (drawn in seeding order, that
    /// of `parts.id`, whatever order the particles are stored in).
    pub(crate) fn new<const V: usize>(
        scene: &Scene,
        parts: &mut Particles<D, V>,
    ) -> Option<DamageState<D>> {
        // the plan decides: a named damage material no body uses adds nothing
        if !scene.plan.has(crate::scene::Stage::Damage) {
            return None;
        }
        let models: Vec<_> = scene
            .materials
            .iter()
            .map(|m| m.damage().cloned())
            .collect();
        let h = scene.file.grid.cell_size;
        let law = DamageLaw {
            models,
            failed_volume: crate::fracture::damage::failed_volume::<D>(
                h,
                scene.file.analysis.thickness,
            ),
        };
        parts.damage = vec![0.0; parts.len()];
        let mut seeded: Vec<usize> = (0..parts.len()).collect();
        seeded.sort_unstable_by_key(|&p| parts.id[p]);
        let material: Vec<u16> = seeded.iter().map(|&p| parts.material[p]).collect();
        let vol0: Vec<f64> = seeded.iter().map(|&p| parts.vol0[p]).collect();
        parts.strength = vec![0.0; parts.len()];
        for (&p, s) in seeded.iter().zip(law.strengths(&material, &vol0)) {
            parts.strength[p] = s;
        }
        Some(DamageState {
            law,
            dissipated: 0.0,
            tips: CrackTracks::default(),
            seed_radius: 2.0 * h,
            fragment_damage: scene.file.output.fragment_damage,
            spacing: (0..scene.file.bodies.len())
                .map(|b| scene.particle_spacing(b))
                .collect(),
            finder: FragmentFinder::default(),
        })
    }

    /// Marks the initial cracks as fully damaged particles and starts the
    /// crack-tip trackers of bodies with a crack origin
    /// ([`CrackTracks::place`]). Call with the particles in their final
    /// order.
    pub(crate) fn place_cracks<const V: usize>(
        &mut self,
        scene: &Scene,
        parts: &mut Particles<D, V>,
    ) {
        let (tips, on_crack) = CrackTracks::place(scene, parts, self.seed_radius, |b| {
            scene
                .materials
                .get(scene.body_material[b])
                .is_some_and(|m| m.damage().is_some())
        });
        for p in on_crack {
            parts.damage[p] = 1.0;
        }
        self.tips = tips;
    }

    fn saved(&self) -> DamageSaved<D> {
        DamageSaved {
            dissipated: self.dissipated,
            tips: self.tips.trackers(),
        }
    }

    fn restore_saved(&mut self, s: DamageSaved<D>) -> Result<(), String> {
        self.tips.restore(s.tips)?;
        self.dissipated = s.dissipated;
        Ok(())
    }

    pub(crate) fn update<const V: usize>(
        &mut self,
        parts: &mut Particles<D, V>,
        dt: f64,
    ) -> DamageStep {
        let s = self.law.update(parts, dt);
        self.dissipated += s.dissipated;
        s
    }

    /// Bodies with a crack tip.
    pub(crate) fn tracked(&self) -> Vec<usize> {
        self.tips.bodies()
    }

    /// The fragments of undamaged material of the damage-model materials
    /// ([`crate::diagnostics::fragments`]).
    pub(crate) fn fragments<const V: usize>(&mut self, parts: &Particles<D, V>) -> Fragments<D> {
        let (models, limit) = (&self.law.models, self.fragment_damage);
        self.finder.find(
            &parts.x,
            &parts.v,
            &parts.mass,
            &parts.vol,
            &self.spacing,
            &parts.body,
            |p| models[parts.material[p] as usize].is_some() && parts.damage[p] < limit,
        )
    }

    /// Mass-weighted mean speed of the particles of damage-model materials
    /// (the paper's "average material velocity magnitude", Fig. 18), m/s.
    pub(crate) fn mean_speed<const V: usize>(&self, parts: &Particles<D, V>) -> f64 {
        let (mut m, mut mv) = (0.0, 0.0);
        for p in 0..parts.len() {
            if self.law.models[parts.material[p] as usize].is_some() {
                m += parts.mass[p];
                mv += parts.mass[p] * norm(parts.v[p]);
            }
        }
        if m > 0.0 {
            mv / m
        } else {
            0.0
        }
    }

    /// The crack tips at `time`: a body's crack is its broken particles
    /// (D > 0.9) connected to the origin ([`CrackTracks::tips`]).
    pub(crate) fn crack_tips<const V: usize>(
        &mut self,
        parts: &Particles<D, V>,
        time: f64,
    ) -> Vec<CrackTip<D>> {
        let damage = &parts.damage;
        self.tips
            .tips(&mut self.finder, &self.spacing, parts, time, |p| {
                damage[p] > TIP_D
            })
    }
}

impl<const D: usize, const V: usize> FractureModel<D, V> for DamageState<D> {
    fn name(&self) -> &'static str {
        "damage"
    }

    fn stages(&self) -> &'static [Stage] {
        &[Stage::Damage]
    }

    fn run(&mut self, stage: Stage, ctx: StepContext<'_, D, V>) -> Result<(), String> {
        if stage == Stage::Damage {
            self.update(ctx.parts, ctx.dt);
        }
        Ok(())
    }

    /// `energy_balance` (kinetic + strain + dissipated − initial − external
    /// work; 0 at t = 0), `failed_particles`, `fragments` (connected
    /// components of intact material), `mean_speed` (mass-weighted mean |v|
    /// of the damage-model materials), and the crack tips of bodies with a
    /// crack origin. The core `fracture_energy` is the energy dissipated.
    fn series(&mut self, at: &RowContext<'_, D, V>, out: &mut SeriesOut) {
        let tracked = self.tracked();
        let (values, tips) = if out.declaring() {
            ([0.0; 4], vec![CrackTip::UNKNOWN; tracked.len()])
        } else {
            out.set_fracture_energy(self.dissipated);
            let failed = at
                .parts
                .damage
                .par_iter()
                .filter(|&&x| x >= crate::fracture::damage::FAILED)
                .count();
            let fragments = self.fragments(at.parts).list.len();
            let values = [
                at.energy_balance(self.dissipated),
                failed as f64,
                fragments as f64,
                self.mean_speed(at.parts),
            ];
            (values, self.crack_tips(at.parts, at.time))
        };
        let names = [
            "energy_balance",
            "failed_particles",
            "fragments",
            "mean_speed",
        ];
        for (n, v) in names.into_iter().zip(values) {
            out.push(n, v);
        }
        out.push_tips(&tracked, &tips);
    }

    /// The energy dissipated, J, and the number of tracked cracks.
    fn summary(&self) -> serde_json::Value {
        serde_json::json!({
            "dissipated": self.dissipated,
            "tracked_cracks": self.tips.bodies().len(),
        })
    }

    fn save(&self) -> Vec<u8> {
        encode(&self.saved())
    }

    fn restore(&mut self, state: &[u8], _at: RestoreContext<'_, D, V>) -> Result<(), String> {
        self.restore_saved(decode(state)?)
    }

    /// `fragment`: each particle's fragment label.
    fn snapshot(&mut self, at: &RowContext<'_, D, V>, fields: &mut Vec<Field>) {
        fields.push(Field {
            name: "fragment".into(),
            components: 1,
            data: FieldData::U32(self.fragments(at.parts).label),
        });
    }
}
