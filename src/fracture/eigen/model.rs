//! The eigen stage as the step runs it: the laws of [`crate::fracture::eigen`],
//! the ε-neighbour lists, the energy released, fragments and crack tips.
//! One model for 2D and 3D (initial cracks and crack tips as for continuum
//! damage: [`CrackTracks`]).

use super::softening::Softening;
use super::{EigenLaw, Scratch, SKIN};
use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::fragments::{FragmentFinder, Fragments};
use crate::diagnostics::{Field, FieldData};
use crate::fracture::model::{
    decode, encode, FractureModel, RestoreContext, RowContext, SeriesOut, SetupContext, StepContext,
};
use crate::fracture::tracks::CrackTracks;
use crate::grid::GridGeom;
use crate::neighbours::Neighbours;
use crate::particles::Particles;
use crate::scene::Stage;

/// χ above this counts as cracked for the crack tip.
const TIP_CHI: f64 = 0.9;

pub(crate) struct EigenState<const D: usize> {
    law: EigenLaw,
    /// Energy released since t = 0, J.
    dissipated: f64,
    /// Points that started softening, and points eroded, since t = 0
    /// (initial cracks not counted).
    started: u64,
    failed: u64,
    /// Each point's neighbour key: its dense contact group where its
    /// material has an eigen model, [`Neighbours::NONE`] elsewhere.
    key: Vec<u16>,
    neighbours: Neighbours<D>,
    scratch: Scratch,
    tips: CrackTracks<D>,
    /// χ below which a point counts as intact for fragments.
    fragment_chi: f64,
    /// Initial particle spacing per body, m.
    spacing: Vec<f64>,
    finder: FragmentFinder,
}

/// What a checkpoint keeps beyond the particle arrays: the energy and the
/// counters, and the crack-tip trackers. The neighbour lists are built
/// again (their sums do not depend on when they were built).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct EigenSaved<const D: usize = 2> {
    dissipated: f64,
    started: u64,
    failed: u64,
    tips: Vec<TipTracker<D>>,
}

/// The eigen stage for a scene whose plan has it, with the initial cracks
/// eroded.
pub(crate) fn build<const D: usize, const V: usize>(
    at: &mut SetupContext<'_, D, V>,
) -> Option<Box<dyn FractureModel<D, V>>> {
    let scene = at.scene;
    if !scene.plan.has(Stage::Eigen) {
        return None;
    }
    let parts = &mut *at.parts;
    let law = EigenLaw {
        models: scene.materials.iter().map(|m| m.eigen().copied()).collect(),
    };
    let key: Vec<u16> = (0..parts.len())
        .map(|p| {
            if law.models[parts.material[p] as usize].is_some() {
                parts.group[p] as u16
            } else {
                Neighbours::<D>::NONE
            }
        })
        .collect();
    parts.softening = vec![Softening::default(); parts.len()];
    let h = scene.file.grid.cell_size;
    let (tips, on_crack) = CrackTracks::place(scene, parts, 2.0 * h, |b| {
        law.models[scene.body_material[b]].is_some()
    });
    for p in on_crack {
        parts.softening[p] = Softening {
            onset: None,
            chi: 1.0,
            d: 1.0,
        };
    }
    Some(Box::new(EigenState {
        law,
        dissipated: 0.0,
        started: 0,
        failed: 0,
        key,
        neighbours: Neighbours::default(),
        scratch: Scratch::default(),
        tips,
        fragment_chi: scene.file.output.fragment_damage,
        spacing: (0..scene.file.bodies.len())
            .map(|b| scene.particle_spacing(b))
            .collect(),
        finder: FragmentFinder::default(),
    }))
}

impl<const D: usize> EigenState<D> {
    /// Rebuilds the ε-neighbour lists where a point moved more than half
    /// the skin since they were built, then runs the update.
    fn step<const V: usize>(&mut self, geom: &GridGeom<D>, parts: &mut Particles<D, V>) {
        let eps = self.law.reach();
        if self.neighbours.stale(&parts.x, 0.5 * SKIN * eps) {
            self.neighbours.build(
                &parts.x,
                &self.key,
                eps * (1.0 + SKIN),
                geom.domain_min,
                geom.domain_max,
            );
            self.neighbours.sort();
        }
        let s = self.law.update(parts, &self.neighbours, &mut self.scratch);
        self.dissipated += s.dissipated;
        self.started += s.started as u64;
        self.failed += s.failed as u64;
    }

    fn fragments<const V: usize>(&mut self, parts: &Particles<D, V>) -> Fragments<D> {
        let key = &self.key;
        let limit = self.fragment_chi;
        self.finder.find(
            &parts.x,
            &parts.v,
            &parts.mass,
            &parts.vol,
            &self.spacing,
            &parts.body,
            |p| key[p] != Neighbours::<D>::NONE && parts.softening[p].chi < limit,
        )
    }
}

impl<const D: usize, const V: usize> FractureModel<D, V> for EigenState<D> {
    fn name(&self) -> &'static str {
        "eigen"
    }

    fn stages(&self) -> &'static [Stage] {
        &[Stage::Eigen]
    }

    fn run(&mut self, stage: Stage, ctx: StepContext<'_, D, V>) -> Result<(), String> {
        if stage == Stage::Eigen {
            self.step(ctx.geom, ctx.parts);
        }
        Ok(())
    }

    /// `energy_balance` (kinetic + strain + dissipated − initial − external
    /// work; 0 at t = 0), `eroded_particles` (χ = 1, initial cracks
    /// included), `softening_particles` (softening started, χ < 1),
    /// `fragments` (connected components of points with χ below
    /// `output.fragment_damage`), and the crack tips of bodies with
    /// cracks or a crack origin. The core `fracture_energy` is the energy
    /// dissipated. (The neighbour lists' builds are in the summary: a
    /// resumed run builds them once more than the straight one.)
    fn series(&mut self, at: &RowContext<'_, D, V>, out: &mut SeriesOut) {
        let tracked = self.tips.bodies();
        let (values, tips) = if out.declaring() {
            ([0.0; 4], vec![CrackTip::UNKNOWN; tracked.len()])
        } else {
            out.set_fracture_energy(self.dissipated);
            let (mut eroded, mut softening) = (0usize, 0usize);
            for (p, s) in at.parts.softening.iter().enumerate() {
                if self.key[p] == Neighbours::<D>::NONE {
                    continue;
                }
                if s.chi >= 1.0 {
                    eroded += 1;
                } else if s.onset.is_some() {
                    softening += 1;
                }
            }
            let fragments = self.fragments(at.parts).list.len();
            let softening_ = &at.parts.softening;
            let tips = self
                .tips
                .tips(&mut self.finder, &self.spacing, at.parts, at.time, |p| {
                    softening_[p].chi > TIP_CHI
                });
            let values = [
                at.energy_balance(self.dissipated),
                eroded as f64,
                softening as f64,
                fragments as f64,
            ];
            (values, tips)
        };
        let names = [
            "energy_balance",
            "eroded_particles",
            "softening_particles",
            "fragments",
        ];
        for (n, v) in names.into_iter().zip(values) {
            out.push(n, v);
        }
        out.push_tips(&tracked, &tips);
    }

    /// The energy dissipated, J, the points that started softening and
    /// that were eroded in the run, and the neighbour-list builds.
    fn summary(&self) -> serde_json::Value {
        serde_json::json!({
            "dissipated": self.dissipated,
            "softening_started": self.started,
            "eroded": self.failed,
            "neighbour_builds": self.neighbours.builds,
            "tracked_cracks": self.tips.bodies().len(),
        })
    }

    fn save(&self) -> Vec<u8> {
        encode(&EigenSaved {
            dissipated: self.dissipated,
            started: self.started,
            failed: self.failed,
            tips: self.tips.trackers(),
        })
    }

    fn restore(&mut self, state: &[u8], _at: RestoreContext<'_, D, V>) -> Result<(), String> {
        let s: EigenSaved<D> = decode(state)?;
        self.tips.restore(s.tips)?;
        self.dissipated = s.dissipated;
        self.started = s.started;
        self.failed = s.failed;
        Ok(())
    }

    /// `chi` (χ, 0 intact to 1 eroded), `stress_scale` (1 − d: the share
    /// of the elastic stress a point carries) and `fragment`.
    fn snapshot(&mut self, at: &RowContext<'_, D, V>, fields: &mut Vec<Field>) {
        let s = &at.parts.softening;
        fields.push(Field {
            name: "chi".into(),
            components: 1,
            data: FieldData::F64(s.iter().map(|s| s.chi).collect()),
        });
        fields.push(Field {
            name: "stress_scale".into(),
            components: 1,
            data: FieldData::F64(s.iter().map(|s| 1.0 - s.d).collect()),
        });
        fields.push(Field {
            name: "fragment".into(),
            components: 1,
            data: FieldData::U32(self.fragments(at.parts).label),
        });
    }
}
