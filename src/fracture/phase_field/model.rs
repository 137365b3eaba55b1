//! The phase-field stage (Kakouris & Triantafyllou, Algorithm 1):
//!
//! - [`PhaseFields::solve`], after P2G: per phase-field body, assemble
//!   K(H) c = F on its active nodes (eq. 57), solve, and map c to its
//!   particles (skipped when the last stagger iteration of the previous
//!   step already solved with today's positions and history);
//! - [`PhaseFields::degrade`], after G2P: per particle, the tensile energy
//!   ψ⁺ of the new strain (Miehe split), the history H = max(H, ψ⁺), and the
//!   degraded stress σ = g(c) σ⁺ + σ⁻ with g(c) = (1 − k_f) c² + k_f, which
//!   the next P2G uses;
//! - [`PhaseFields::stagger`], after the particles were re-binned: the
//!   staggered iterations. The residual of eq. 50 with the updated history
//!   is measured; while it exceeds the tolerance (and the iteration limit
//!   allows), c is solved again with the new history and the stress
//!   degraded again. In this explicit scheme the step's momentum update
//!   used the stress of the previous step, so the strain and hence H do not
//!   change between iterations: a second solve leaves only the linear
//!   solver's residual, and it replaces the next step's first solve.
//!
//! One phase field per body (discrete fields). The particles' c and H live
//! in `Particles::phase` and `Particles::history`.

use crate::diagnostics::crack::{CrackTip, TipTracker};
use crate::diagnostics::{Field, FieldData};
use crate::fracture::model::{
    decode, encode, FractureModel, RestoreContext, RowContext, SeriesOut, SetupContext, StepContext,
};
use crate::fracture::phase_field::anisotropy::{Gamma, Gamma3};
use crate::fracture::phase_field::system::{
    self, FactorKind, FactorOrdering, FieldParticles, PhaseFieldError, PhaseFieldParams,
    PhaseFieldSystem, SolveMethod, SolveStats,
};
use crate::geometry::CrackGeometry;
use crate::grid::shape::{by_kernel, Kernel};
use crate::grid::{Bins, GridGeom, SyncPtr};
use crate::material::{miehe_split, miehe_split_3d, Elastic};
use crate::particles::Particles;
use crate::scene::{
    phase_field_gamma, CrackProfile, FactorOrdering as FactorOrderingSpec, PhaseFieldMethod,
    PhaseFieldVolumes, PlaneKind, PlaneStressSplit, Scene, Stage,
};
use crate::tensor::resize;
use rayon::prelude::*;

/// B of a `line` crack: the history on it is B·Ḡc/(4l₀), which drives c to
/// about 1/(1 + B) there.
const CRACK_B: f64 = 1e6;

/// Borden et al.'s B for a `borden` crack profile.
const BORDEN_B: f64 = 1e3;

/// The initial history of a particle at `x` (its 2 or 3 coordinates) from
/// a body's initial cracks (the largest over the cracks; 0 off them), by
/// each crack's profile ([`CrackProfile`]) and geometry (a polyline in 2D,
/// a flat polygon in 3D); `spacing` is the body's particle spacing.
fn initial_history(
    x: &[f64],
    cracks: &[(CrackProfile, CrackGeometry)],
    params: &PhaseFieldParams,
    spacing: f64,
) -> f64 {
    let unit = params.gc_bar / (4.0 * params.l0);
    cracks
        .iter()
        .map(|(profile, c)| match profile {
            CrackProfile::Line => {
                if c.holds(x, spacing) {
                    CRACK_B * unit
                } else {
                    0.0
                }
            }
            CrackProfile::Borden => {
                let d = c.distance(x);
                BORDEN_B * unit * (1.0 - 2.0 * d / params.l0).max(0.0)
            }
        })
        .fold(0.0, f64::max)
}

/// One body's phase field on a `D`-dimensional grid.
struct Body<const D: usize> {
    /// The body's index in the scene.
    body: u16,
    /// Indices of the body's particles.
    particles: Vec<u32>,
    params: PhaseFieldParams,
    system: PhaseFieldSystem<D>,
    /// Nodal c of the last solve (all grid nodes).
    c: Vec<f64>,
    /// The crack-tip diagnostic, if tracked.
    tip: Option<TipTracker<D>>,
    /// Plane stress with the in-plane split ([`PlaneStressSplit::InPlane`]).
    in_plane: bool,
    /// The functional over the reference volumes V_p⁰
    /// ([`PhaseFieldVolumes::Reference`]) instead of the present ones.
    reference: bool,
}

impl<const D: usize> Body<D> {
    /// The volumes this body's integrals take ([`PhaseFieldVolumes`]).
    fn volumes<'a, const V: usize>(&self, parts: &'a Particles<D, V>) -> &'a [f64] {
        self.volumes_of(&parts.vol, &parts.vol0)
    }

    /// [`Self::volumes`] from the two arrays, for a caller that holds
    /// other fields of the particles mutably.
    fn volumes_of<'a>(&self, present: &'a [f64], reference: &'a [f64]) -> &'a [f64] {
        if self.reference {
            reference
        } else {
            present
        }
    }
}

/// Particles with c below this count as cracked for the crack tip.
const TIP_C: f64 = crate::fracture::phase_field::CRACKED_C;

/// Solver work since the last series row.
#[derive(Debug, Clone, Copy, Default)]
struct Interval {
    steps: u64,
    /// The most solves any step of the interval did.
    max_staggers: u32,
    /// The residual after the last step's stagger loop (NaN if it was not
    /// measured: one iteration allowed and no row due).
    residual: f64,
    /// Solver totals at the start of the interval.
    mark: SolveStats,
}

/// Per-step phase-field figures of a series row.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct RowStats {
    /// Mean wall seconds per step since the last row.
    pub assembly: f64,
    /// Symbolic analysis plus numeric factorization.
    pub factorization: f64,
    /// Triangular solves and PCG.
    pub solve: f64,
    /// The most stagger iterations (solves) of one step since the last row.
    pub staggers: u32,
    /// Numeric factorizations since the last row by kind, and the mean
    /// seconds of one (0 without any), and the fall-backs to a direct solve.
    pub preconditioner_factorizations: u64,
    pub preconditioner_factorization: f64,
    pub direct_factorizations: u64,
    pub direct_factorization: f64,
    pub fallbacks: u64,
    /// ‖K(H)c − F‖/‖F‖ after the last step's stagger loop, as far as the
    /// history update is concerned (the linear solver's own residual is
    /// bounded by its tolerance and not included).
    pub residual: f64,
}

/// The phase fields of a simulation in `D` dimensions (2 or 3; in 3D no
/// material angle: [`crate::methods::runnable`] refuses it).
pub struct PhaseFields<const D: usize = 2> {
    bodies: Vec<Body<D>>,
    method: SolveMethod,
    max_staggers: u32,
    stagger_tolerance: f64,
    /// Per particle, w_p of [`PhaseFieldSystem::history_residual`] for the
    /// last history update.
    dh: Vec<f64>,
    /// c was solved with the present positions and history: the next
    /// step's first solve would repeat it.
    current: bool,
    /// Solves in the present step.
    staggers: u32,
    interval: Interval,
    /// Ψ_f measured where c was solved ([`Self::solve`] and
    /// [`Self::stagger`] with `record`): per particle V_p Ḡc Z_p (J, 0 off
    /// the phase-field bodies), per body their sum (J), and whether the
    /// present step recorded them.
    energy: Vec<f64>,
    body_energy: Vec<f64>,
    recorded: bool,
}

/// What a checkpoint keeps of the phase fields (`mpm::checkpoint`): per
/// body the nodal c of the last solve (PCG's warm start; the particles'
/// c and H are in the particle arrays) and the crack-tip tracker, and
/// whether c is current for the next step.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct PhaseState<const D: usize = 2> {
    c: Vec<Vec<f64>>,
    tips: Vec<Option<TipTracker<D>>>,
    current: bool,
}

/// One body's particles as the phase-field system reads them.
fn of_body<'a, const D: usize, const V: usize>(
    parts: &'a Particles<D, V>,
    vol: &'a [f64],
    body: u16,
    bins: Option<&'a Bins>,
) -> FieldParticles<'a, D> {
    FieldParticles {
        x: &parts.x,
        vol,
        history: &parts.history,
        body: Some((&parts.body, body)),
        bins,
    }
}

/// The phase fields of a scene's phase-field bodies, if it has any.
pub(crate) fn build<const D: usize, const V: usize>(
    at: &mut SetupContext<'_, D, V>,
) -> Option<Box<dyn FractureModel<D, V>>> {
    PhaseFields::<D>::new(at.scene, at.parts).map(|m| Box::new(m) as Box<dyn FractureModel<D, V>>)
}

impl<const D: usize> PhaseFields<D> {
    /// Builds the phase fields of the scene's phase-field bodies, sets up the
    /// particles' c (1) and history (with the initial cracks). None if
    /// no body has a phase field.
    pub(crate) fn new<const V: usize>(
        scene: &Scene,
        parts: &mut Particles<D, V>,
    ) -> Option<PhaseFields<D>> {
        let mut bodies = Vec::new();
        for (b, spec) in scene.file.bodies.iter().enumerate() {
            let mat = &scene.materials[scene.body_material[b]];
            let Some(pf) = mat.phase_field() else {
                continue;
            };
            // 2D: the Voigt γ turned by the material angle; 3D: the 6 × 6
            // one as given (runnable refuses an angle in 3D)
            let (gamma, gamma3) = if D == 2 {
                let g = phase_field_gamma(pf).rotated(pf.angle.to_radians());
                (g, Gamma3::default())
            } else {
                let g = Gamma3::from_list(&pf.gamma).unwrap_or_default();
                (Gamma::default(), g)
            };
            let params = PhaseFieldParams {
                gc_bar: pf.gc,
                l0: pf.l0,
                k_f: pf.k_f,
                gamma,
                gamma3,
            };
            let particles: Vec<u32> = (0..parts.len() as u32)
                .filter(|&p| parts.body[p as usize] as usize == b)
                .collect();
            let origin = spec
                .crack_origin
                .or_else(|| spec.cracks.first().and_then(|c| c.points.first().copied()));
            let in_plane = pf.plane_stress_split == PlaneStressSplit::InPlane;
            let reference = pf.volumes == PhaseFieldVolumes::Reference;
            let cracks: Vec<_> = spec
                .cracks
                .iter()
                .map(|c| c.profile)
                .zip(scene.cracks[b].iter().cloned())
                .collect();
            bodies.push((b, cracks, params, particles, origin, in_plane, reference));
        }
        if bodies.is_empty() {
            return None;
        }
        parts.phase = vec![1.0; parts.len()];
        parts.history = vec![0.0; parts.len()];
        let ordering = match scene.file.phase_field_solver.ordering {
            FactorOrderingSpec::Amd => FactorOrdering::Amd,
            FactorOrderingSpec::Dissection => FactorOrdering::Dissection,
        };
        let out = bodies
            .into_iter()
            .map(
                |(b, cracks, params, particles, origin, in_plane, reference)| {
                    let spacing = scene.particle_spacing(b);
                    for &p in &particles {
                        let p = p as usize;
                        parts.history[p] = initial_history(&parts.x[p], &cracks, &params, spacing);
                    }
                    Body {
                        body: b as u16,
                        particles,
                        params,
                        system: {
                            let mut system = PhaseFieldSystem::new();
                            system.set_ordering(ordering);
                            system
                        },
                        c: Vec::new(),
                        tip: origin.map(|o| TipTracker::new(o.get::<D>())),
                        in_plane,
                        reference,
                    }
                },
            )
            .collect();
        let o = &scene.file.phase_field_solver;
        let method = match o.method {
            PhaseFieldMethod::Direct => SolveMethod::Direct,
            PhaseFieldMethod::Pcg => SolveMethod::Pcg {
                tolerance: o.tolerance,
                max_iterations: o.max_iterations as usize,
                refactor_after: o.refactor_after as usize,
            },
            PhaseFieldMethod::Multigrid => SolveMethod::Multigrid {
                tolerance: o.tolerance,
                max_iterations: o.max_iterations as usize,
                rebuild_after: o.refactor_after as usize,
            },
            PhaseFieldMethod::Auto => SolveMethod::Auto {
                tolerance: o.tolerance,
                max_iterations: o.max_iterations as usize,
                refactor_after: o.refactor_after as usize,
            },
        };
        let n = parts.len();
        Some(PhaseFields {
            bodies: out,
            method,
            max_staggers: o.max_staggers,
            stagger_tolerance: o.stagger_tolerance,
            dh: vec![0.0; n],
            current: false,
            staggers: 0,
            interval: Interval {
                residual: f64::NAN,
                ..Default::default()
            },
            energy: Vec::new(),
            body_energy: Vec::new(),
            recorded: false,
        })
    }

    fn state(&self) -> PhaseState<D> {
        PhaseState {
            c: self.bodies.iter().map(|b| b.c.clone()).collect(),
            tips: self.bodies.iter().map(|b| b.tip).collect(),
            current: self.current,
        }
    }

    /// Takes up a checkpoint's [`PhaseState`] for a grid of `nodes` nodes;
    /// the solver starts afresh (analysis and factor on the next solve).
    fn restore_state(&mut self, s: PhaseState<D>, nodes: usize) -> Result<(), String> {
        if s.c.len() != self.bodies.len() || s.tips.len() != self.bodies.len() {
            return Err(format!(
                "{} phase-field bodies in the checkpoint, {} in the scene",
                s.c.len(),
                self.bodies.len()
            ));
        }
        if let Some(c) = s.c.iter().find(|c| !c.is_empty() && c.len() != nodes) {
            return Err(format!(
                "a phase field of {} nodes, the grid has {nodes}",
                c.len()
            ));
        }
        for ((body, c), tip) in self.bodies.iter_mut().zip(s.c).zip(s.tips) {
            if tip.is_some() != body.tip.is_some() {
                return Err(format!(
                    "body {}: the crack tip is tracked in one and not the other",
                    body.body
                ));
            }
            body.c = c;
            body.tip = tip;
        }
        self.current = s.current;
        Ok(())
    }

    /// The step's first stagger iteration: solves every body's phase field
    /// and maps c to its particles, unless the last stagger iteration of
    /// the previous step already did so for the same positions and history.
    /// With `record` (the step ends on a series row or a snapshot), also
    /// measures Ψ_f ([`Self::fracture_energies`]).
    pub(crate) fn solve<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        bins: &Bins,
        parts: &mut Particles<D, V>,
        record: bool,
    ) -> Result<(), PhaseFieldError> {
        self.staggers = 1;
        self.recorded = false;
        if !std::mem::take(&mut self.current) {
            self.solve_all::<K, V>(geom, bins, parts)?;
        }
        if record {
            self.record::<K, V>(geom, parts);
        }
        Ok(())
    }

    /// Ψ_f of each body (and its density per particle) with the c just
    /// solved, at the positions it was solved for. Measured later, after
    /// G2P has moved the particles, a 4th-order body's Ψ_f jumped: a
    /// particle whose support moves onto a node that was not in the system
    /// (c = 1 there) next to cracked ones (c ≈ 0) gets the quadratic
    /// B-spline's second derivative, 1/h², on the jump, and l₀³ γ (∇²c)²
    /// of the few such particles added 12 % to the beam's Ψ_f for one row
    /// (`scenes/p3_sphere_beam_iii.toml` at the paper's resolution: 0.210 → 0.235 → 0.210 J over
    /// three rows 0.5 µs apart, before this).
    fn record<K: Kernel, const V: usize>(&mut self, geom: &GridGeom<D>, parts: &Particles<D, V>) {
        self.energy.resize(parts.len(), 0.0);
        self.body_energy.resize(self.bodies.len(), 0.0);
        for (b, body) in self.bodies.iter().enumerate() {
            if body.c.is_empty() {
                for &p in &body.particles {
                    self.energy[p as usize] = 0.0;
                }
                self.body_energy[b] = 0.0;
                continue;
            }
            let energy = SyncPtr::new(&mut self.energy);
            let (c, xs, vol) = (&body.c, &parts.x, body.volumes(parts));
            body.particles.par_iter().for_each(|&p| {
                let p = p as usize;
                let v =
                    vol[p] * system::fracture_energy_density::<K, D>(geom, c, &body.params, xs[p]);
                // SAFETY: each particle index appears once in the body's list.
                unsafe { *energy.at(p) = v };
            });
            // in the particles' order, as system::fracture_energy sums
            self.body_energy[b] = body
                .particles
                .iter()
                .map(|&p| self.energy[p as usize])
                .fold(0.0, |a, v| a + v); // (an empty f64 sum is −0.0)
        }
        self.recorded = true;
    }

    fn solve_all<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        bins: &Bins,
        parts: &mut Particles<D, V>,
    ) -> Result<(), PhaseFieldError> {
        for body in &mut self.bodies {
            let fp = of_body(parts, body.volumes(parts), body.body, Some(bins));
            body.system.assemble::<K>(geom, &fp, &body.params);
            body.system
                .solve_into(geom.node_count(), self.method, &mut body.c)?;
            let phase = SyncPtr::new(&mut parts.phase);
            let (c, xs) = (&body.c, &parts.x);
            body.particles.par_iter().for_each(|&p| {
                let v = system::value_at::<K, D>(geom, c, xs[p as usize]);
                // SAFETY: each particle index appears once in the body's list.
                unsafe { *phase.at(p as usize) = v.clamp(0.0, 1.0) };
            });
        }
        Ok(())
    }

    /// The staggered iterations after the history update (see the module
    /// docs); `bins` must hold the particles' present tiles. With a row
    /// due (`measure`), the residual is measured even when one iteration is
    /// allowed; with `record`, a new solve measures Ψ_f again.
    pub(crate) fn stagger<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        bins: &Bins,
        parts: &mut Particles<D, V>,
        mats: &[Elastic],
        measure: bool,
        record: bool,
    ) -> Result<(), PhaseFieldError> {
        let mut residual = f64::NAN;
        if self.max_staggers > 1 || measure {
            loop {
                residual = self.history_residual::<K, V>(geom, bins, parts);
                if residual <= self.stagger_tolerance || self.staggers >= self.max_staggers {
                    break;
                }
                self.solve_all::<K, V>(geom, bins, parts)?;
                if record {
                    self.record::<K, V>(geom, parts);
                }
                self.degrade(parts, mats);
                self.staggers += 1;
                self.current = true;
            }
        }
        let i = &mut self.interval;
        i.steps += 1;
        i.max_staggers = i.max_staggers.max(self.staggers);
        i.residual = residual;
        Ok(())
    }

    /// max over bodies of ‖ΔK c‖/‖F‖ for the last history update.
    fn history_residual<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        bins: &Bins,
        parts: &Particles<D, V>,
    ) -> f64 {
        let mut r: f64 = 0.0;
        for body in &mut self.bodies {
            let fp = of_body(parts, body.volumes(parts), body.body, Some(bins));
            r = r.max(body.system.history_residual::<K>(geom, &fp, &self.dh));
        }
        r
    }

    /// History update and stress degradation after the particles' strains
    /// were updated (linear elastic, small strain). Also records each
    /// particle's history increment for the stagger residual.
    pub(crate) fn degrade<const V: usize>(
        &mut self,
        parts: &mut Particles<D, V>,
        mats: &[Elastic],
    ) {
        let history = SyncPtr::new(&mut parts.history);
        let stress = SyncPtr::new(&mut parts.stress);
        let dh = SyncPtr::new(&mut self.dh);
        let (strain, phase, material) = (&parts.strain, &parts.phase, &parts.material);
        let (vol, vol0) = (&parts.vol, &parts.vol0);
        for body in &self.bodies {
            let vol = body.volumes_of(vol, vol0);
            let k_f = body.params.k_f;
            let reaction = 4.0 * body.params.l0 * (1.0 - k_f) / body.params.gc_bar;
            let in_plane = body.in_plane;
            body.particles.par_iter().for_each(|&p| {
                let p = p as usize;
                let m = &mats[material[p] as usize];
                let (psi, sp, sn): (f64, [f64; V], [f64; V]) = if D == 2 {
                    let e = resize(strain[p]);
                    let (psi, sp, sn) = match m.plane {
                        PlaneKind::PlaneStrain => miehe_split(m.lambda, m.mu, e, 0.0),
                        // c12 of plane stress is λ* = 2λμ/(λ + 2μ)
                        PlaneKind::PlaneStress if in_plane => miehe_split(m.c12, m.mu, e, 0.0),
                        PlaneKind::PlaneStress => miehe_split(m.lambda, m.mu, e, m.strain_zz(e)),
                    };
                    (psi, resize(sp), resize(sn))
                } else {
                    let (psi, sp, sn) = miehe_split_3d(m.lambda, m.mu, resize(strain[p]));
                    (psi, resize(sp), resize(sn))
                };
                let c = phase[p];
                let g = (1.0 - k_f) * c * c + k_f;
                // SAFETY: each particle index appears once in the body's list.
                unsafe {
                    let h = history.at(p);
                    *dh.at(p) = if psi > *h {
                        vol[p] * reaction * (psi - *h) * c
                    } else {
                        0.0
                    };
                    if psi > *h {
                        *h = psi;
                    }
                    *stress.at(p) = std::array::from_fn(|k| g * sp[k] + sn[k]);
                }
            });
        }
    }

    /// Ψ_f of each phase-field body with the nodal c of the last solve, J
    /// (0 before the first solve): as recorded at the positions c was
    /// solved for when the present step was asked to ([`Self::record`]),
    /// otherwise recorded now, at the present positions (the t = 0 row, or
    /// a caller's own row between output steps).
    pub(crate) fn fracture_energies<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
    ) -> Vec<f64> {
        if !self.recorded {
            self.record::<K, V>(geom, parts);
        }
        self.body_energy.clone()
    }

    /// Per particle, the fracture energy density Ḡc·Z of its body's last
    /// solve, J/m³ (0 for particles of bodies without a phase field, and
    /// before the first solve), from the same record as
    /// [`Self::fracture_energies`]: V_p times it, summed over a body's
    /// particles, is the body's Ψ_f, and over a region, the energy
    /// dissipated there.
    pub(crate) fn fracture_energy_densities<K: Kernel, const V: usize>(
        &mut self,
        geom: &GridGeom<D>,
        parts: &Particles<D, V>,
    ) -> Vec<f64> {
        if !self.recorded {
            self.record::<K, V>(geom, parts);
        }
        // per the present volume, so that V_p times it still sums to Ψ_f
        self.energy
            .iter()
            .zip(&parts.vol)
            .map(|(e, v)| if *v > 0.0 { e / v } else { 0.0 })
            .collect()
    }

    /// The scene indices of the phase-field bodies, and of those whose
    /// crack tip is tracked.
    pub(crate) fn bodies(&self) -> (Vec<usize>, Vec<usize>) {
        let all = self.bodies.iter().map(|b| b.body as usize).collect();
        let tracked = self
            .bodies
            .iter()
            .filter(|b| b.tip.is_some())
            .map(|b| b.body as usize)
            .collect();
        (all, tracked)
    }

    /// The crack tips of the tracked bodies at `time`; the speeds are
    /// measured from the previous call.
    pub(crate) fn crack_tips<const V: usize>(
        &mut self,
        parts: &Particles<D, V>,
        time: f64,
    ) -> Vec<CrackTip<D>> {
        let mut tips = Vec::new();
        for body in &mut self.bodies {
            let Some(tracker) = body.tip.as_mut() else {
                continue;
            };
            tips.push(if body.c.is_empty() {
                CrackTip::UNKNOWN // before the first solve c is not known yet
            } else {
                tracker.measure(&parts.x, &body.particles, |p| parts.phase[p] < TIP_C, time)
            });
        }
        tips
    }

    /// The per-step solver figures since the last call.
    pub(crate) fn row_stats(&mut self) -> RowStats {
        let now = self.stats();
        let i = std::mem::replace(
            &mut self.interval,
            Interval {
                residual: f64::NAN,
                mark: now,
                ..Default::default()
            },
        );
        let per = |a: f64, b: f64| {
            if i.steps > 0 {
                (a - b) / i.steps as f64
            } else {
                0.0
            }
        };
        let mean = |seconds: f64, count: u64| {
            if count > 0 {
                seconds / count as f64
            } else {
                0.0
            }
        };
        RowStats {
            assembly: per(now.assembly, i.mark.assembly),
            factorization: per(
                now.analysis + now.factorization,
                i.mark.analysis + i.mark.factorization,
            ),
            solve: per(now.solve, i.mark.solve),
            staggers: i.max_staggers,
            preconditioner_factorizations: now.preconditioner_factorizations
                - i.mark.preconditioner_factorizations,
            preconditioner_factorization: mean(
                now.preconditioner_factorization - i.mark.preconditioner_factorization,
                now.preconditioner_factorizations - i.mark.preconditioner_factorizations,
            ),
            direct_factorizations: now.direct_factorizations - i.mark.direct_factorizations,
            direct_factorization: mean(
                now.direct_factorization - i.mark.direct_factorization,
                now.direct_factorizations - i.mark.direct_factorizations,
            ),
            fallbacks: now.fallbacks - i.mark.fallbacks,
            residual: i.residual,
        }
    }

    /// Solver times and counts summed over the bodies.
    pub fn stats(&self) -> SolveStats {
        let mut s = SolveStats::default();
        for b in &self.bodies {
            let t = b.system.stats;
            s.assembly += t.assembly;
            s.analysis += t.analysis;
            s.factorization += t.factorization;
            s.solve += t.solve;
            s.analyses += t.analyses;
            s.factorizations += t.factorizations;
            s.pcg_solves += t.pcg_solves;
            s.pcg_iterations += t.pcg_iterations;
            s.preconditioner_factorizations += t.preconditioner_factorizations;
            s.preconditioner_factorization += t.preconditioner_factorization;
            s.direct_factorizations += t.direct_factorizations;
            s.direct_factorization += t.direct_factorization;
            s.fallbacks += t.fallbacks;
            s.auto_trial += t.auto_trial;
            s.auto_factor += t.auto_factor;
            s.auto_multigrid += t.auto_multigrid;
        }
        s
    }

    /// Unknowns of the last assemblies, summed over the bodies.
    pub fn unknowns(&self) -> usize {
        self.bodies.iter().map(|b| b.system.len()).sum()
    }

    /// One numeric factorization of the given kind of every body's
    /// system, counted in [`Self::stats`] (`cleave bench-phase-field`).
    pub fn factorize_kind(&mut self, kind: FactorKind) -> Result<(), PhaseFieldError> {
        for b in &mut self.bodies {
            b.system.factorize_kind(kind)?;
        }
        Ok(())
    }
}

impl<const D: usize, const V: usize> FractureModel<D, V> for PhaseFields<D> {
    fn name(&self) -> &'static str {
        "phase_field"
    }

    /// `[phase_field_solver]`: the method and its tolerances decide how c
    /// is solved for, to the solver's tolerance (a resumed run then agrees
    /// with the straight one to that tolerance, not bit for bit).
    fn may_change_on_resume(&self) -> &'static [&'static str] {
        &["phase_field_solver"]
    }

    fn stages(&self) -> &'static [Stage] {
        &[
            Stage::PhaseFieldSolve,
            Stage::PhaseFieldHistory,
            Stage::PhaseFieldStagger,
        ]
    }

    fn run(&mut self, stage: Stage, ctx: StepContext<'_, D, V>) -> Result<(), String> {
        let StepContext {
            geom,
            bins,
            parts,
            mats,
            kernel,
            row_due,
            output_due,
            ..
        } = ctx;
        let r = match stage {
            Stage::PhaseFieldSolve => {
                by_kernel!(kernel, K => self.solve::<K, V>(geom, bins, parts, output_due))
            }
            Stage::PhaseFieldHistory => {
                self.degrade(parts, mats);
                Ok(())
            }
            Stage::PhaseFieldStagger => by_kernel!(kernel, K => {
                self.stagger::<K, V>(geom, bins, parts, mats, row_due, output_due)
            }),
            _ => Ok(()),
        };
        r.map_err(|e| e.to_string())
    }

    /// The solver's mean seconds per step since the last row
    /// (`pf_assembly_s`, `pf_factorization_s`, `pf_solve_s`), the most
    /// stagger iterations of a step (`pf_stagger_iterations`), the last
    /// stagger residual (`pf_residual`), the numeric factorizations since
    /// the last row by kind and the mean seconds of one
    /// (`pf_preconditioner_factorizations`,
    /// `pf_preconditioner_factorization_s`, `pf_direct_factorizations`,
    /// `pf_direct_factorization_s`), the fall-backs to a direct solve
    /// (`pf_fallbacks`), Ψ_f per body (`fracture_energy_b<i>`, with two or
    /// more phase-field bodies), and per tracked body the crack tip
    /// (`crack_tip_x`, `crack_tip_y`, `crack_length`, `crack_speed`,
    /// suffixed `_b<i>` with two or more). The core `fracture_energy` is
    /// Σ Ψ_f.
    fn series(&mut self, at: &RowContext<'_, D, V>, out: &mut SeriesOut) {
        let (all, tracked) = self.bodies();
        let (energies, s, tips) = if out.declaring() {
            (
                vec![0.0; all.len()],
                RowStats::default(),
                vec![CrackTip::UNKNOWN; tracked.len()],
            )
        } else {
            let energies =
                by_kernel!(at.kernel, K => self.fracture_energies::<K, V>(at.geom, at.parts));
            // (an empty f64 sum is −0.0)
            out.set_fracture_energy(energies.iter().fold(0.0, |a, b| a + b));
            let s = self.row_stats();
            (energies, s, self.crack_tips(at.parts, at.time))
        };
        out.push("pf_assembly_s", s.assembly);
        out.push("pf_factorization_s", s.factorization);
        out.push("pf_solve_s", s.solve);
        out.push("pf_stagger_iterations", s.staggers as f64);
        out.push("pf_residual", s.residual);
        out.push(
            "pf_preconditioner_factorizations",
            s.preconditioner_factorizations as f64,
        );
        out.push(
            "pf_preconditioner_factorization_s",
            s.preconditioner_factorization,
        );
        out.push("pf_direct_factorizations", s.direct_factorizations as f64);
        out.push("pf_direct_factorization_s", s.direct_factorization);
        out.push("pf_fallbacks", s.fallbacks as f64);
        if all.len() > 1 {
            for (b, e) in all.iter().zip(&energies) {
                out.push(&format!("fracture_energy_b{b}"), *e);
            }
        }
        out.push_tips(&tracked, &tips);
    }

    /// The solver's times and counts ([`SolveStats`]).
    fn summary(&self) -> serde_json::Value {
        serde_json::to_value(self.stats()).unwrap_or_default()
    }

    fn save(&self) -> Vec<u8> {
        encode(&self.state())
    }

    fn restore(&mut self, state: &[u8], at: RestoreContext<'_, D, V>) -> Result<(), String> {
        self.restore_state(decode(state)?, at.geom.node_count())
    }

    /// `fracture_energy_density`: Ḡc·Z per particle, J/m³
    /// ([`PhaseFields::fracture_energy_densities`]).
    fn snapshot(&mut self, at: &RowContext<'_, D, V>, fields: &mut Vec<Field>) {
        fields.push(Field {
            name: "fracture_energy_density".into(),
            components: 1,
            data: FieldData::F64(by_kernel!(at.kernel, K => {
                self.fracture_energy_densities::<K, V>(at.geom, at.parts)
            })),
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_initial_history_follows_the_crack_profile() {
        let params = PhaseFieldParams {
            gc_bar: 3.0,
            l0: 2.5e-4,
            k_f: 0.0,
            gamma: Gamma::default(),
            gamma3: Default::default(),
        };
        let unit = 3.0 / (4.0 * 2.5e-4);
        let crack = |profile| {
            let pts = [[0.0, 0.0].into(), [1.0e-3, 0.0].into()];
            vec![(profile, CrackGeometry::new(&pts, 2).unwrap())]
        };
        let spacing = 1.0e-4;
        // line: the particles within 0.55 spacings, all at B = 1e6
        let line = crack(CrackProfile::Line);
        assert_eq!(
            initial_history(&[5e-4, 0.5e-4], &line, &params, spacing),
            CRACK_B * unit
        );
        assert_eq!(
            initial_history(&[5e-4, 0.6e-4], &line, &params, spacing),
            0.0
        );
        // Borden: B = 1e3 on the line, falling linearly to 0 at l0/2
        let borden = crack(CrackProfile::Borden);
        let h = |y: f64| initial_history(&[5e-4, y], &borden, &params, spacing);
        assert!((h(0.0) - BORDEN_B * unit).abs() < 1e-9 * h(0.0));
        assert!((h(-0.625e-4) - 0.5 * BORDEN_B * unit).abs() < 1e-9 * h(0.0));
        assert_eq!(h(1.3e-4), 0.0);
        // beyond the crack's end the distance is to its end point
        let past = initial_history(&[1.0e-3 + 0.625e-4, 0.0], &borden, &params, spacing);
        assert!((past - 0.5 * BORDEN_B * unit).abs() < 1e-9 * past);
        // 3D: the same profile across a square face in the plane x = 0;
        // past its edge the distance is to the edge
        let face: Vec<crate::geometry::Vector> = vec![
            [0.0, 0.0, 0.0].into(),
            [0.0, 1.0e-3, 0.0].into(),
            [0.0, 1.0e-3, 1.0e-3].into(),
            [0.0, 0.0, 1.0e-3].into(),
        ];
        let face = vec![(CrackProfile::Borden, CrackGeometry::new(&face, 3).unwrap())];
        let h3 = |x: [f64; 3]| initial_history(&x, &face, &params, spacing);
        assert!((h3([0.0, 5e-4, 5e-4]) - BORDEN_B * unit).abs() < 1e-9 * h(0.0));
        assert!((h3([-0.625e-4, 2e-4, 9e-4]) - 0.5 * BORDEN_B * unit).abs() < 1e-9 * h(0.0));
        assert!((h3([0.0, 5e-4, 1.0e-3 + 0.625e-4]) - 0.5 * BORDEN_B * unit).abs() < 1e-9 * h(0.0));
        assert_eq!(h3([1.3e-4, 5e-4, 5e-4]), 0.0);
    }

    /// A series row reports Ψ_f where c was solved, not where G2P has
    /// since moved the particles: there a 4th-order crack that reaches a
    /// free face gains a spurious jump (see [`PhaseFields::record`]).
    #[test]
    fn the_row_reports_the_fracture_energy_where_c_was_solved() {
        use crate::grid::shape::QuadraticBspline as K;
        // 4 x 4 mm, h = 0.25 mm, 3 x 3 particles per cell, 4th-order
        // isotropic, a crack across at y = 2 mm from face to face
        let text = r#"
[grid]
cell_size = 2.5e-4
min = [-0.001, -0.001]
max = [0.005, 0.005]
shape_function = "quadratic_bspline"
[analysis]
plane = "plane_strain"
thickness = 1.0
[time]
end = 1.0e-8
dt = 1.0e-8
[materials.m]
model = "linear_elastic"
density = 2450.0
youngs_modulus = 3.2e10
poissons_ratio = 0.2
phase_field = { gc = 1.0, l0 = 5.0e-4, k_f = 0.0, gamma = [1.0, 1.0, 0.0, 2.0] }
[[bodies]]
name = "plate"
shape = { type = "box", min = [0.0, 0.0], max = [0.004, 0.004] }
material = "m"
particles_per_cell = 9
cracks = [{ points = [[0.0, 0.002], [0.004, 0.002]] }]
"#;
        let scene = Scene::from_text(text, None).unwrap();
        let mut sim = crate::mpm::Simulation::new(&scene);
        let pf = crate::fracture::model::find_mut::<PhaseFields, 2, 3>(&mut sim.models).unwrap();
        pf.solve::<K, 3>(&sim.geom, &sim.bins, &mut sim.parts, true)
            .unwrap();
        let c = pf.bodies[0].c.clone();
        let at = |parts: &Particles| {
            let fp = of_body(parts, &parts.vol, 0, None);
            system::fracture_energy::<K, 2>(&sim.geom, &c, &fp, &pf.bodies[0].params, |_| true)
        };
        let solved = at(&sim.parts);
        // the crack holds √2·Ḡc per unit length, about: 4 mm · 1 m · √2 J/m²
        assert!(
            (solved / (0.004 * 2f64.sqrt()) - 1.0).abs() < 0.2,
            "Ψ_f = {solved}"
        );
        // The left face's particles sit h/6 inside it. Moved out by 0.3 h
        // their supports keep their nodes, and Ψ_f hardly changes; by
        // 0.7 h, they take in the node column 2 h out of the face, never in
        // the system (c = 1 there), and Ψ_f doubles.
        let h = 2.5e-4;
        let face: Vec<usize> = (0..sim.parts.len())
            .filter(|&p| sim.parts.x[p][0] < h / 3.0)
            .collect();
        for &p in &face {
            sim.parts.x[p][0] -= 0.3 * h;
        }
        let near = at(&sim.parts);
        assert!(
            (near / solved - 1.0).abs() < 0.02,
            "{near} against {solved}"
        );
        for &p in &face {
            sim.parts.x[p][0] -= 0.4 * h;
        }
        let moved = at(&sim.parts);
        assert!(
            moved > 1.5 * solved,
            "measured after the move: {moved} against {solved}"
        );
        let pf = crate::fracture::model::find_mut::<PhaseFields, 2, 3>(&mut sim.models).unwrap();
        assert_eq!(
            pf.fracture_energies::<K, 3>(&sim.geom, &sim.parts),
            vec![solved]
        );
        let densities = pf.fracture_energy_densities::<K, 3>(&sim.geom, &sim.parts);
        let sum: f64 = (0..sim.parts.len())
            .map(|p| sim.parts.vol[p] * densities[p])
            .sum();
        assert!((sum - solved).abs() < 1e-12 * solved);
        // the next step starts without the record
        let pf = crate::fracture::model::find_mut::<PhaseFields, 2, 3>(&mut sim.models).unwrap();
        pf.current = true;
        pf.solve::<K, 3>(&sim.geom, &sim.bins, &mut sim.parts, false)
            .unwrap();
        assert_eq!(
            pf.fracture_energies::<K, 3>(&sim.geom, &sim.parts),
            vec![moved]
        );
    }
}
