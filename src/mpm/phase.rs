//! The phase-field stage (seed 001, Algorithm 1 with one stagger iteration,
//! which the paper found sufficient at explicit time steps):
//!
//! - [`PhaseFields::solve`], after P2G: per phase-field body, assemble
//!   K(H) c = F on its active nodes (eq. 57), solve, and map c to its
//!   particles;
//! - [`PhaseFields::degrade`], after G2P: per particle, the tensile energy
//!   ψ⁺ of the new strain (Miehe split), the history H = max(H, ψ⁺), and the
//!   degraded stress σ = g(c) σ⁺ + σ⁻ with g(c) = (1 − k_f) c² + k_f, which
//!   the next P2G uses.
//!
//! One phase field per body (discrete fields). The particles' c and H live
//! in `Particles::phase` and `Particles::history`.

use crate::fracture::phase_field::system::{self, FieldParticles, PhaseFieldError, PhaseFieldParams, PhaseFieldSystem, SolveMethod, SolveStats};
use crate::grid::shape::Kernel;
use crate::grid::{Bins, GridGeom, SyncPtr};
use crate::material::{miehe_split, Elastic};
use crate::particles::Particles;
use crate::scene::{phase_field_gamma, PhaseFieldMethod, PlaneKind, Scene};
use rayon::prelude::*;

/// Borden's B: the history on an initial crack is B·Ḡc/(4l₀), which drives
/// c to about 1/(1 + B) there.
const CRACK_B: f64 = 1e6;

/// One body's phase field.
struct Body {
    /// The body's index in the scene.
    body: u16,
    /// Indices of the body's particles.
    particles: Vec<u32>,
    params: PhaseFieldParams,
    system: PhaseFieldSystem,
    /// Nodal c of the last solve (all grid nodes).
    c: Vec<f64>,
}

/// The phase fields of a simulation.
pub(super) struct PhaseFields {
    bodies: Vec<Body>,
    method: SolveMethod,
}

fn distance_to_polyline(p: [f64; 2], pts: &[[f64; 2]]) -> f64 {
    pts.windows(2)
        .map(|w| {
            let (a, b) = (w[0], w[1]);
            let ab = [b[0] - a[0], b[1] - a[1]];
            let len2 = ab[0] * ab[0] + ab[1] * ab[1];
            let t = if len2 > 0.0 { (((p[0] - a[0]) * ab[0] + (p[1] - a[1]) * ab[1]) / len2).clamp(0.0, 1.0) } else { 0.0 };
            ((p[0] - a[0] - t * ab[0]).powi(2) + (p[1] - a[1] - t * ab[1]).powi(2)).sqrt()
        })
        .fold(f64::INFINITY, f64::min)
}

impl PhaseFields {
    /// Builds the phase fields of the scene's phase-field bodies, sets up the
    /// particles' c (1) and history (with the initial cracks). None if no
    /// body has a phase field.
    pub(super) fn new(scene: &Scene, parts: &mut Particles) -> Option<PhaseFields> {
        let mut bodies = Vec::new();
        for (b, spec) in scene.file.bodies.iter().enumerate() {
            let mat = &scene.materials[scene.body_material[b]];
            let Some(pf) = &mat.phase_field else { continue };
            let gamma = phase_field_gamma(pf).rotated(pf.angle.to_radians());
            let params = PhaseFieldParams { gc_bar: pf.gc, l0: pf.l0, k_f: pf.k_f, gamma };
            let particles: Vec<u32> = (0..parts.len() as u32).filter(|&p| parts.body[p as usize] as usize == b).collect();
            bodies.push((b, spec.cracks.clone(), params, particles));
        }
        if bodies.is_empty() {
            return None;
        }
        parts.phase = vec![1.0; parts.len()];
        parts.history = vec![0.0; parts.len()];
        let out = bodies
            .into_iter()
            .map(|(b, cracks, params, particles)| {
                let spacing = scene.file.grid.cell_size / scene.lattice(b).per_dir as f64;
                let h0 = CRACK_B * params.gc_bar / (4.0 * params.l0);
                for &p in &particles {
                    let x = parts.x[p as usize];
                    if cracks.iter().any(|c| distance_to_polyline(x, &c.points) < 0.55 * spacing) {
                        parts.history[p as usize] = h0;
                    }
                }
                Body { body: b as u16, particles, params, system: PhaseFieldSystem::new(), c: Vec::new() }
            })
            .collect();
        let o = &scene.file.phase_field_solver;
        let method = match o.method {
            PhaseFieldMethod::Direct => SolveMethod::Direct,
            PhaseFieldMethod::Pcg => SolveMethod::Pcg {
                tolerance: o.tolerance,
                max_iterations: o.max_iterations as usize,
                refactor_after: o.refactor_after as usize,
            },
        };
        Some(PhaseFields { bodies: out, method })
    }

    /// Solves every body's phase field and maps c to its particles.
    pub(super) fn solve<K: Kernel>(&mut self, geom: &GridGeom, bins: &Bins, parts: &mut Particles) -> Result<(), PhaseFieldError> {
        for body in &mut self.bodies {
            let fp = FieldParticles {
                x: &parts.x,
                vol: &parts.vol,
                history: &parts.history,
                body: Some((&parts.body, body.body)),
                bins: Some(bins),
            };
            body.system.assemble::<K>(geom, &fp, &body.params);
            body.c = body.system.solve_with(geom.node_count(), self.method)?;
            let phase = SyncPtr::new(&mut parts.phase);
            let (c, xs) = (&body.c, &parts.x);
            body.particles.par_iter().for_each(|&p| {
                let (v, _, _) = system::field_at::<K>(geom, c, xs[p as usize]);
                // SAFETY: each particle index appears once in the body's list.
                unsafe { *phase.at(p as usize) = v.clamp(0.0, 1.0) };
            });
        }
        Ok(())
    }

    /// History update and stress degradation after the particles' strains
    /// were updated (linear elastic, small strain).
    pub(super) fn degrade(&self, parts: &mut Particles, mats: &[Elastic]) {
        let history = SyncPtr::new(&mut parts.history);
        let stress = SyncPtr::new(&mut parts.stress);
        let (strain, phase, material) = (&parts.strain, &parts.phase, &parts.material);
        for body in &self.bodies {
            let k_f = body.params.k_f;
            body.particles.par_iter().for_each(|&p| {
                let p = p as usize;
                let m = &mats[material[p] as usize];
                let e = strain[p];
                let ezz = match m.plane {
                    PlaneKind::PlaneStrain => 0.0,
                    PlaneKind::PlaneStress => m.strain_zz(e),
                };
                let (psi, sp, sn) = miehe_split(m.lambda, m.mu, e, ezz);
                let c = phase[p];
                let g = (1.0 - k_f) * c * c + k_f;
                // SAFETY: each particle index appears once in the body's list.
                unsafe {
                    let h = history.at(p);
                    if psi > *h {
                        *h = psi;
                    }
                    *stress.at(p) = [g * sp[0] + sn[0], g * sp[1] + sn[1], g * sp[2] + sn[2]];
                }
            });
        }
    }

    /// Ψ_f over all phase-field bodies with the nodal c of the last solve, J.
    pub(super) fn fracture_energy<K: Kernel>(&self, geom: &GridGeom, parts: &Particles) -> f64 {
        self.bodies
            .iter()
            .filter(|b| !b.c.is_empty())
            .map(|b| {
                let fp = FieldParticles {
                    x: &parts.x,
                    vol: &parts.vol,
                    history: &parts.history,
                    body: Some((&parts.body, b.body)),
                    bins: None,
                };
                system::fracture_energy::<K>(geom, &b.c, &fp, &b.params, |_| true)
            })
            .fold(0.0, |a, b| a + b) // (an empty f64 sum is −0.0)
    }

    /// Solver times and counts summed over the bodies.
    pub(super) fn stats(&self) -> SolveStats {
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
        }
        s
    }
}
