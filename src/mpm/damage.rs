//! The damage stage (seed 000, section 2.7) as the step runs it: the
//! per-material laws of [`crate::fracture::damage`], the energy they have
//! released, and the crack tips of the bodies that track one.

use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::fragments::{FragmentFinder, Fragments};
use crate::fracture::damage::{DamageLaw, DamageStep};
use crate::particles::Particles;
use crate::scene::Scene;

/// Damage above this counts as cracked for the crack tip.
const TIP_D: f64 = 0.9;

pub(super) struct DamageState {
    law: DamageLaw,
    /// Energy released by damage since t = 0, J.
    pub dissipated: f64,
    /// Bodies with a crack origin: (body, its particles, tracker).
    tips: Vec<(usize, Vec<u32>, TipTracker)>,
    /// Damage below which a particle counts as intact for fragments.
    fragment_damage: f64,
    /// Initial particle spacing per body, m.
    spacing: Vec<f64>,
    finder: FragmentFinder,
}

impl DamageState {
    /// The laws of the scene's materials, or `None` without damage. Fills
    /// `parts.damage` and `parts.strength` (particles in seeding order).
    pub(super) fn new(scene: &Scene, parts: &mut Particles) -> Option<DamageState> {
        let models: Vec<_> = scene.materials.iter().map(|m| m.damage.clone()).collect();
        if models.iter().all(Option::is_none) {
            return None;
        }
        let h = scene.file.grid.cell_size;
        let law = DamageLaw {
            models,
            failed_volume: 0.5 * h * h * scene.file.analysis.thickness,
        };
        parts.damage = vec![0.0; parts.len()];
        parts.strength = law.strengths(&parts.material, &parts.vol0);
        Some(DamageState {
            law,
            dissipated: 0.0,
            tips: Vec::new(),
            fragment_damage: scene.file.output.fragment_damage,
            spacing: (0..scene.file.bodies.len()).map(|b| h / scene.lattice(b).per_dir as f64).collect(),
            finder: FragmentFinder::default(),
        })
    }

    /// Marks the initial cracks as fully damaged particles (those within
    /// 0.55 particle spacings of a body's crack polylines) and starts the
    /// crack-tip trackers of bodies with a crack origin (default: the first
    /// crack point). The tip is the particle with D > 0.9 farthest from the
    /// origin among those not on an initial crack. Call with the particles
    /// in their final order.
    pub(super) fn place_cracks(&mut self, scene: &Scene, parts: &mut Particles) {
        for (b, spec) in scene.file.bodies.iter().enumerate() {
            if scene
                .materials
                .get(scene.body_material[b])
                .is_none_or(|m| m.damage.is_none())
            {
                continue;
            }
            let particles: Vec<u32> = (0..parts.len() as u32)
                .filter(|&p| parts.body[p as usize] as usize == b)
                .collect();
            let spacing = scene.file.grid.cell_size / scene.lattice(b).per_dir as f64;
            for &p in &particles {
                if crate::geometry::on_cracks(parts.x[p as usize], &spec.cracks, spacing) {
                    parts.damage[p as usize] = 1.0;
                }
            }
            if let Some(o) = spec
                .crack_origin
                .or_else(|| spec.cracks.first().and_then(|c| c.points.first().copied()))
            {
                self.tips.push((b, particles, TipTracker::new(o)));
            }
        }
    }

    pub(super) fn update(&mut self, parts: &mut Particles, dt: f64) -> DamageStep {
        let s = self.law.update(parts, dt);
        self.dissipated += s.dissipated;
        s
    }

    /// Bodies with a crack tip.
    pub(super) fn tracked(&self) -> Vec<usize> {
        self.tips.iter().map(|t| t.0).collect()
    }

    /// The fragments of undamaged material of the damage-model materials
    /// ([`crate::diagnostics::fragments`]).
    pub(super) fn fragments(&mut self, parts: &Particles) -> Fragments {
        let (models, limit) = (&self.law.models, self.fragment_damage);
        self.finder.find(&parts.x, &parts.v, &parts.mass, &parts.vol, &self.spacing, &parts.body, |p| {
            models[parts.material[p] as usize].is_some() && parts.damage[p] < limit
        })
    }

    /// Mass-weighted mean speed of the particles of damage-model materials
    /// (the paper's "average material velocity magnitude", Fig. 18), m/s.
    pub(super) fn mean_speed(&self, parts: &Particles) -> f64 {
        let (mut m, mut mv) = (0.0, 0.0);
        for p in 0..parts.len() {
            if self.law.models[parts.material[p] as usize].is_some() {
                m += parts.mass[p];
                mv += parts.mass[p] * (parts.v[p][0] * parts.v[p][0] + parts.v[p][1] * parts.v[p][1]).sqrt();
            }
        }
        if m > 0.0 { mv / m } else { 0.0 }
    }

    pub(super) fn crack_tips(&mut self, parts: &Particles, time: f64) -> Vec<CrackTip> {
        self.tips
            .iter_mut()
            .map(|(_, ps, tr)| tr.measure(&parts.x, ps, |p| parts.damage[p] > TIP_D, time))
            .collect()
    }
}
