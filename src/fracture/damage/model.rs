//! The damage stage (Homel & Herbold 2017, section 2.7) as the step runs it: the
//! per-material laws of [`crate::fracture::damage`], the energy they have
//! released, and the crack tips of the bodies that track one.

use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::fragments::{FragmentFinder, Fragments, NONE};
use crate::diagnostics::{Field, FieldData};
use crate::fracture::damage::{DamageLaw, DamageStep};
use crate::fracture::model::{
    body_suffix, decode, encode, FractureModel, RestoreContext, RowContext, SeriesOut,
    SetupContext, StepContext,
};
use crate::particles::Particles;
use crate::scene::{Scene, Stage};
use rayon::prelude::*;

/// Damage above this counts as cracked for the crack tip.
const TIP_D: f64 = 0.9;

pub(crate) struct DamageState {
    law: DamageLaw,
    /// Energy released by damage since t = 0, J.
    pub dissipated: f64,
    /// The bodies with a crack origin.
    tips: Vec<TrackedCrack>,
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
pub(crate) struct DamageSaved {
    dissipated: f64,
    tips: Vec<TipTracker>,
}

/// A body whose crack tip is tracked ([`DamageState::crack_tips`]).
struct TrackedCrack {
    body: usize,
    /// Its particles not on an initial crack.
    particles: Vec<u32>,
    /// The same, as a mask over all particles.
    member: Vec<bool>,
    /// Those of them that started within `seed_radius` of the origin.
    roots: Vec<u32>,
    tracker: TipTracker,
}

/// The damage stage for a scene whose plan has it, with the initial
/// cracks placed.
pub(crate) fn build(at: &mut SetupContext<'_>) -> Option<Box<dyn FractureModel>> {
    let mut state = DamageState::new(at.scene, at.parts)?;
    state.place_cracks(at.scene, at.parts);
    Some(Box::new(state))
}

impl DamageState {
    /// The laws of the scene's materials, or `None` without damage. Fills
    /// `parts.damage` and `parts.strength` (drawn in seeding order, that
    /// of `parts.id`, whatever order the particles are stored in).
    pub(crate) fn new(scene: &Scene, parts: &mut Particles) -> Option<DamageState> {
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
            failed_volume: 0.5 * h * h * scene.file.analysis.thickness,
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
            tips: Vec::new(),
            seed_radius: 2.0 * h,
            fragment_damage: scene.file.output.fragment_damage,
            spacing: (0..scene.file.bodies.len())
                .map(|b| scene.particle_spacing(b))
                .collect(),
            finder: FragmentFinder::default(),
        })
    }

    /// Marks the initial cracks as fully damaged particles (those within
    /// 0.55 particle spacings of a body's crack polylines) and starts the
    /// crack-tip trackers of bodies with a crack origin (default: the first
    /// crack point; see [`DamageState::crack_tips`]). Call with the
    /// particles in their final order.
    pub(crate) fn place_cracks(&mut self, scene: &Scene, parts: &mut Particles) {
        for (b, spec) in scene.file.bodies.iter().enumerate() {
            if scene
                .materials
                .get(scene.body_material[b])
                .is_none_or(|m| m.damage().is_none())
            {
                continue;
            }
            let spacing = scene.particle_spacing(b);
            let mut particles = Vec::new();
            for p in (0..parts.len()).filter(|&p| parts.body[p] as usize == b) {
                if crate::geometry::on_cracks(parts.x[p], &spec.cracks, spacing) {
                    parts.damage[p] = 1.0;
                } else {
                    particles.push(p as u32);
                }
            }
            if let Some(o) = spec
                .crack_origin
                .or_else(|| spec.cracks.first().and_then(|c| c.points.first().copied()))
            {
                let mut member = vec![false; parts.len()];
                particles.iter().for_each(|&p| member[p as usize] = true);
                let r2 = self.seed_radius * self.seed_radius;
                let x = &parts.x;
                let roots: Vec<u32> = particles
                    .iter()
                    .copied()
                    .filter(|&p| {
                        (x[p as usize][0] - o[0]).powi(2) + (x[p as usize][1] - o[1]).powi(2) < r2
                    })
                    .collect();
                self.tips.push(TrackedCrack {
                    body: b,
                    particles,
                    member,
                    roots,
                    tracker: TipTracker::new(o.xy()),
                });
            }
        }
    }

    fn saved(&self) -> DamageSaved {
        DamageSaved {
            dissipated: self.dissipated,
            tips: self.tips.iter().map(|t| t.tracker).collect(),
        }
    }

    fn restore_saved(&mut self, s: DamageSaved) -> Result<(), String> {
        if s.tips.len() != self.tips.len() {
            return Err(format!(
                "{} tracked cracks in the checkpoint, {} in the scene",
                s.tips.len(),
                self.tips.len()
            ));
        }
        self.dissipated = s.dissipated;
        for (t, tracker) in self.tips.iter_mut().zip(s.tips) {
            t.tracker = tracker;
        }
        Ok(())
    }

    pub(crate) fn update(&mut self, parts: &mut Particles, dt: f64) -> DamageStep {
        let s = self.law.update(parts, dt);
        self.dissipated += s.dissipated;
        s
    }

    /// Bodies with a crack tip.
    pub(crate) fn tracked(&self) -> Vec<usize> {
        self.tips.iter().map(|t| t.body).collect()
    }

    /// The fragments of undamaged material of the damage-model materials
    /// ([`crate::diagnostics::fragments`]).
    pub(crate) fn fragments(&mut self, parts: &Particles) -> Fragments {
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
    pub(crate) fn mean_speed(&self, parts: &Particles) -> f64 {
        let (mut m, mut mv) = (0.0, 0.0);
        for p in 0..parts.len() {
            if self.law.models[parts.material[p] as usize].is_some() {
                m += parts.mass[p];
                mv += parts.mass[p]
                    * (parts.v[p][0] * parts.v[p][0] + parts.v[p][1] * parts.v[p][1]).sqrt();
            }
        }
        if m > 0.0 {
            mv / m
        } else {
            0.0
        }
    }

    /// The crack tips at `time`. A body's crack is the set of broken
    /// particles (D > 0.9, not on an initial crack) connected, through
    /// broken particles at most 1.5 spacings apart, to one of the particles
    /// that started within two cells of the crack origin (material points,
    /// so the crack's root is found however far the body has moved): the
    /// crack that grows from the origin, not damage elsewhere (at an impact
    /// face, say). Its tip is its particle farthest from the origin.
    pub(crate) fn crack_tips(&mut self, parts: &Particles, time: f64) -> Vec<CrackTip> {
        let (finder, spacing) = (&mut self.finder, &self.spacing);
        self.tips
            .iter_mut()
            .map(|t| {
                let broken = finder.find(
                    &parts.x,
                    &parts.v,
                    &parts.mass,
                    &parts.vol,
                    spacing,
                    &parts.body,
                    |p| t.member[p] && parts.damage[p] > TIP_D,
                );
                let mut seeds: Vec<u32> = t
                    .roots
                    .iter()
                    .map(|&p| broken.label[p as usize])
                    .filter(|&l| l != NONE)
                    .collect();
                seeds.sort_unstable();
                seeds.dedup();
                t.tracker.measure(
                    &parts.x,
                    &t.particles,
                    |p| seeds.binary_search(&broken.label[p]).is_ok(),
                    time,
                )
            })
            .collect()
    }
}

impl FractureModel for DamageState {
    fn name(&self) -> &'static str {
        "damage"
    }

    fn stages(&self) -> &'static [Stage] {
        &[Stage::Damage]
    }

    fn run(&mut self, stage: Stage, ctx: StepContext<'_>) -> Result<(), String> {
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
    fn series(&mut self, at: &RowContext<'_>, out: &mut SeriesOut) {
        let tracked = self.tracked();
        let (values, tips) = if out.declaring() {
            ([0.0; 4], vec![CrackTip::UNKNOWN; tracked.len()])
        } else {
            out.set_fracture_energy(self.dissipated);
            let balance = at.energy + self.dissipated - at.initial_energy - at.external_work;
            let failed = at
                .parts
                .damage
                .par_iter()
                .filter(|&&x| x >= crate::fracture::damage::FAILED)
                .count();
            let fragments = self.fragments(at.parts).list.len();
            let values = [
                if at.step == 0 { 0.0 } else { balance },
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
        for (b, tip) in tracked.iter().zip(&tips) {
            out.push_tip(&body_suffix(*b, tracked.len()), tip);
        }
    }

    /// The energy dissipated, J, and the number of tracked cracks.
    fn summary(&self) -> serde_json::Value {
        serde_json::json!({
            "dissipated": self.dissipated,
            "tracked_cracks": self.tips.len(),
        })
    }

    fn save(&self) -> Vec<u8> {
        encode(&self.saved())
    }

    fn restore(&mut self, state: &[u8], _at: RestoreContext<'_>) -> Result<(), String> {
        self.restore_saved(decode(state)?)
    }

    /// `fragment`: each particle's fragment label.
    fn snapshot(&mut self, at: &RowContext<'_>, fields: &mut Vec<Field>) {
        fields.push(Field {
            name: "fragment".into(),
            components: 1,
            data: FieldData::U32(self.fragments(at.parts).label),
        });
    }
}
