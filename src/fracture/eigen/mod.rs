//! Eigenerosion and eigensoftening (Molinos et al., after Pandolfi &
//! Ortiz and Navas et al.): material points fail when the energy released
//! (eigenerosion) or the mean principal stress (eigensoftening) over their
//! ε-neighbourhood ([`crate::neighbours`]) reaches the material's
//! toughness or strength. The stage runs after the gather, on the elastic
//! stress the gather left (σ = C:ε of the total strain), like continuum
//! damage: each point carries (1 − d)σ (eq. 17) with d its stress scale
//! ([`softening::Softening`]).
//!
//! - **Eigenerosion** (eqs. 11–12): G_p = C_ε/m_p Σ_{q ∈ B_ε(x_p)} m_q W_q,
//!   m_p = Σ_{q ∈ B_ε} m_q, with W_q the free energy per unit mass of the
//!   points not yet eroded. The paper calls C_ε a normalising constant and
//!   leaves it open. **Choice: C_ε = 2ερ/κ**, so that
//!   G_p = 2εψ̄_ε/κ, ψ̄_ε the energy per unit reference volume of the ball
//!   (m_q/ρ = V⁰_q). 2ε: the ε-neighbourhood of a crack of area A has
//!   volume 2εA (Schmidt, Fraternali & Ortiz's eigenfracture, which
//!   Pandolfi & Ortiz's erosion discretises). κ ([`tip_ball_factor`]):
//!   in a crack tip's singular field the ball's energy grows as ε, so
//!   2εψ̄_ε does not depend on ε but reads only κG (0.28 G in plane
//!   strain at ν = 1/3); dividing by κ makes a point at a crack tip read
//!   G, so that the crack grows at Griffith's G = G_c. A point whose G_p
//!   reaches G_c is eroded: it keeps its mass and carries no stress from
//!   then on. Every point that reaches G_c in a step is eroded in that
//!   step (the neighbourhood sums are taken before any of them).
//! - **Eigensoftening** (eqs. 13–20, Algorithm 2): σ_ε,p = 1/m_p Σ m_q σ_q,I
//!   over the points with χ_q < 1 (m_p over all of B_ε, as Algorithm 2
//!   sums it), σ_q,I the largest principal value of the stress q carries;
//!   past f_t the point softens by the law of [`softening`] (the paper's χ,
//!   the stress capped at (1 − χ)f_t; docs/eigen.md says why).
//!
//! Energy: a point stores ½σ:ε V with the stress it carries (what the
//! series' `strain_energy` sums), so a step that raises its d from d₀ to
//! d₁ at fixed strain releases ½(d₁ − d₀)σ_E:ε V: summed as the energy
//! dissipated, as continuum damage does.
//!
//! The ε-neighbourhoods are taken in the present configuration among the
//! points of eigen materials in the same contact group (one velocity
//! field, one continuum); the lists reach ε(1 + [`SKIN`]), are rebuilt
//! when a point moved more than half the skin, and are sorted by
//! particle index, so that each sum runs in an order that does not depend
//! on when the lists were built (a resumed run repeats the straight one
//! bit for bit).

pub mod model;
pub mod section;
pub mod softening;

use crate::fracture::damage::Principal;
use crate::neighbours::Neighbours;
use crate::particles::Particles;
use crate::tensor::{contract, dot, sub};
use rayon::prelude::*;
use section::{EigenModel, ResolvedEigen};

/// The neighbour lists reach ε(1 + SKIN); a point may move SKIN·ε/2
/// before they are rebuilt.
pub const SKIN: f64 = 0.25;

const CHUNK: usize = 2048;

/// κ = 2εψ̄_ε / G at the tip of a mode I crack (the Williams field), for
/// Poisson's ratio `nu` in plane strain or plane stress (`dim` 2) or at a
/// straight crack front in 3D (plane strain there): eigenerosion's C_ε is
/// 2ερ/κ. The energy density is W = K²w(θ)/(2πrE) with r the distance to
/// the tip (front); with A = (1/2π)∮w dθ the ball of radius ε about the
/// tip holds K²Aε/E in 2D (per unit thickness), so 2εψ̄_ε = 2K²A/(πE),
/// and K²A/E·πε²/2 in 3D, so 2εψ̄_ε = 3K²A/(4E); Griffith's G is
/// K²(1 − ν²)/E in plane strain, K²/E in plane stress. κ is 0.279 in plane
/// strain and 0.318 in plane stress at ν = 0.333
/// (`docs/scripts/eigen_tip_ball.py` computes the same).
pub fn tip_ball_factor(nu: f64, plane: crate::material::PlaneKind, dim: usize) -> f64 {
    let strain = dim == 3 || plane == crate::material::PlaneKind::PlaneStrain;
    // the midpoint rule on a smooth periodic integrand: exact to round-off
    let n = 720;
    let mut a = 0.0;
    for i in 0..n {
        let t = -std::f64::consts::PI + (i as f64 + 0.5) * std::f64::consts::TAU / n as f64;
        let (s, c) = (0.5 * t).sin_cos();
        let (s3, c3) = (1.5 * t).sin_cos();
        let (sx, sy, sxy) = (c * (1.0 - s * s3), c * (1.0 + s * s3), c * s * c3);
        let sz = if strain { nu * (sx + sy) } else { 0.0 };
        a += 0.5 * (sx * sx + sy * sy + sz * sz - 2.0 * nu * (sx * sy + sy * sz + sz * sx))
            + (1.0 + nu) * sxy * sxy;
    }
    a /= n as f64;
    let griffith = if strain { 1.0 - nu * nu } else { 1.0 };
    if dim == 3 {
        0.75 * a / griffith
    } else {
        2.0 * a / (std::f64::consts::PI * griffith)
    }
}

/// The eigen models of the scene's materials, indexed like them.
#[derive(Debug, Clone, Default)]
pub struct EigenLaw {
    pub models: Vec<Option<ResolvedEigen>>,
}

/// What one eigen update did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct EigenStep {
    /// Energy released this step, J.
    pub dissipated: f64,
    /// Points eroded (χ reached 1) this step.
    pub failed: usize,
    /// Points whose softening started this step.
    pub started: usize,
}

/// Per-point values of one update, kept between steps so that the stage
/// does not allocate.
#[derive(Debug, Clone, Default)]
pub struct Scratch {
    /// Erosion: ½σ:ε V (J); softening: m σ_I of the stress carried, or 0
    /// for a point with χ = 1.
    value: Vec<f64>,
    /// Erosion: V⁰ (m³); softening: m (kg).
    weight: Vec<f64>,
}

impl EigenLaw {
    /// The largest ε of the scene's eigen materials, m.
    pub fn reach(&self) -> f64 {
        self.models
            .iter()
            .flatten()
            .map(|m| m.epsilon)
            .fold(0.0, f64::max)
    }

    /// The eigen stage: evaluates every eigen point's ε-neighbourhood on
    /// the elastic stress the gather left in `parts.stress`, advances its
    /// state and scales its stress (eq. 17). `nb` lists, for each point,
    /// at least the points of its key within its material's ε.
    pub fn update<const D: usize, const V: usize>(
        &self,
        parts: &mut Particles<D, V>,
        nb: &Neighbours<D>,
        scratch: &mut Scratch,
    ) -> EigenStep {
        let n = parts.len();
        scratch.value.resize(n, 0.0);
        scratch.weight.resize(n, 0.0);
        let models = &self.models;
        {
            let p = &*parts;
            scratch
                .value
                .par_iter_mut()
                .zip(scratch.weight.par_iter_mut())
                .enumerate()
                .for_each(|(q, (value, weight))| {
                    let Some(m) = &models[p.material[q] as usize] else {
                        return;
                    };
                    let keep = 1.0 - p.softening[q].d;
                    let s = &p.stress[q];
                    match m.model {
                        EigenModel::Erosion => {
                            *value = keep * 0.5 * contract::<D, V>(s, &p.strain[q]) * p.vol[q];
                            *weight = p.vol0[q];
                        }
                        EigenModel::Softening => {
                            *value = if p.softening[q].chi < 1.0 {
                                p.mass[q] * keep * Principal::of::<D, V>(s).max()
                            } else {
                                0.0
                            };
                            *weight = p.mass[q];
                        }
                    }
                });
        }
        let (value, weight) = (&scratch.value, &scratch.weight);
        let (x, material, strain, vol) = (&parts.x, &parts.material, &parts.strain, &parts.vol);
        let steps: Vec<EigenStep> = parts.stress[..n]
            .par_chunks_mut(CHUNK)
            .zip(parts.softening.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(k, (stress, state))| {
                let mut step = EigenStep::default();
                for i in 0..stress.len() {
                    let p = k * CHUNK + i;
                    let Some(m) = &models[material[p] as usize] else {
                        continue;
                    };
                    let s = &mut state[i];
                    if s.d >= 1.0 {
                        stress[i] = [0.0; V];
                        continue;
                    }
                    // Σ over B_ε(x_p): the lists reach beyond ε by the skin
                    let r2 = m.epsilon * m.epsilon;
                    let (mut a, mut b) = (0.0, 0.0);
                    for &q in nb.of(p) {
                        let q = q as usize;
                        let d = sub(x[q], x[p]);
                        if dot(d, d) < r2 {
                            a += value[q];
                            b += weight[q];
                        }
                    }
                    let d_old = s.d;
                    let se = stress[i];
                    match (m.model, &m.softening) {
                        (EigenModel::Erosion, _) => {
                            // eq. 11 with C_ε = 2ερ/κ: 2ε Σ ψ_q V_q / (κ Σ V⁰_q)
                            if 2.0 * m.epsilon * a / (b * m.tip_factor) >= m.fracture_energy {
                                *s = softening::Softening {
                                    onset: None,
                                    chi: 1.0,
                                    d: 1.0,
                                };
                            }
                        }
                        (EigenModel::Softening, Some(law)) => {
                            let started = s.onset.is_some();
                            let e_1 = Principal::of::<D, V>(&strain[p]).max();
                            law.update(s, a / b, e_1, Principal::of::<D, V>(&se).max());
                            step.started += usize::from(!started && s.onset.is_some());
                        }
                        // validation gives softening its law
                        (EigenModel::Softening, None) => {}
                    }
                    if s.d > d_old {
                        step.dissipated +=
                            0.5 * (s.d - d_old) * contract::<D, V>(&se, &strain[p]) * vol[p];
                        step.failed += usize::from(s.d >= 1.0);
                    }
                    if s.d > 0.0 {
                        let keep = 1.0 - s.d;
                        stress[i] = se.map(|c| keep * c);
                    }
                }
                step
            })
            .collect();
        // summed in chunk order: the same total for any thread count
        steps.iter().fold(EigenStep::default(), |t, s| EigenStep {
            dissipated: t.dissipated + s.dissipated,
            failed: t.failed + s.failed,
            started: t.started + s.started,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::softening::{Softening, SofteningLaw};
    use super::*;
    use crate::tensor::norm;

    /// An n × n lattice of points `s` apart (2D, 10 mm thick, ρ = 1000),
    /// all of material 0 in group 0, at the uniaxial strain `ex` with the
    /// stress E·ex (ν = 0).
    fn lattice(n: usize, s: f64, e: f64, ex: f64) -> Particles {
        let mut p = Particles::default();
        for j in 0..n {
            for i in 0..n {
                p.id.push(p.x.len() as u32);
                p.x.push([i as f64 * s, j as f64 * s]);
                p.v.push([0.0; 2]);
                p.body.push(0);
                p.material.push(0);
                p.group.push(0);
                let vol = s * s * 0.01;
                p.vol.push(vol);
                p.vol0.push(vol);
                p.mass.push(1000.0 * vol);
                p.strain.push([ex, 0.0, 0.0]);
                p.stress.push([e * ex, 0.0, 0.0]);
                p.softening.push(Softening::default());
            }
        }
        p
    }

    /// Eigenerosion with ε, G_c and κ as the only material.
    fn erosion(eps: f64, gc: f64, tip_factor: f64) -> EigenLaw {
        EigenLaw {
            models: vec![Some(ResolvedEigen {
                model: EigenModel::Erosion,
                epsilon: eps,
                fracture_energy: gc,
                softening: None,
                tip_factor,
            })],
        }
    }

    fn lists(p: &Particles, reach: f64) -> Neighbours {
        let mut nb = Neighbours::default();
        let key = vec![0u16; p.len()];
        nb.build(&p.x, &key, reach * (1.0 + SKIN), [-1.0; 2], [1.0; 2]);
        nb.sort();
        nb
    }

    /// Eq. 11 with C_ε = 2ερ (κ = 1) on a uniform strain: G_p = 2εψ at every
    /// point, so a G_c just above it erodes nothing and one just below it
    /// erodes every point, releasing all the stored energy ½σ:ε V.
    #[test]
    fn erosion_releases_two_epsilon_times_the_energy_density() {
        let (e, ex, s, eps) = (1.0e9, 1.0e-3, 0.01, 0.025);
        let psi = 0.5 * e * ex * ex;
        let erosion = |gc: f64| erosion(eps, gc, 1.0);
        let mut p = lattice(12, s, e, ex);
        let nb = lists(&p, eps);
        let mut scratch = Scratch::default();
        let step = erosion(2.0 * eps * psi * (1.0 + 1e-9)).update(&mut p, &nb, &mut scratch);
        assert_eq!(step, EigenStep::default());
        assert!(p.stress.iter().all(|s| *s == [e * ex, 0.0, 0.0]));
        let step = erosion(2.0 * eps * psi * (1.0 - 1e-9)).update(&mut p, &nb, &mut scratch);
        assert_eq!(step.failed, p.len());
        let stored: f64 = p.vol.iter().map(|v| psi * v).sum();
        assert!((step.dissipated / stored - 1.0).abs() < 1e-12);
        assert!(p.stress.iter().all(|s| *s == [0.0; 3]));
        assert!(p.softening.iter().all(|s| s.chi == 1.0 && s.d == 1.0));
    }

    /// Eqs. 15–16 as Algorithm 2 sums them: the mean principal stress over
    /// the points with χ < 1, divided by the mass of the whole ball. With
    /// every third point eroded, a point starts softening exactly where
    /// that mean (brute force over all pairs) passes f_t.
    #[test]
    fn softening_starts_where_the_neighbourhood_mean_passes_the_strength() {
        let (e, ex, s, eps) = (1.0e9, 1.0e-3, 0.01, 0.025);
        let mut p = lattice(12, s, e, ex);
        for q in (0..p.len()).step_by(3) {
            p.softening[q] = Softening {
                onset: None,
                chi: 1.0,
                d: 1.0,
            };
        }
        let mean = |p: &Particles, a: usize| {
            let (mut num, mut m) = (0.0, 0.0);
            for b in 0..p.len() {
                let d = sub(p.x[b], p.x[a]);
                if dot(d, d) < eps * eps {
                    if p.softening[b].chi < 1.0 {
                        num += p.mass[b] * e * ex;
                    }
                    m += p.mass[b];
                }
            }
            num / m
        };
        let means: Vec<f64> = (0..p.len()).map(|a| mean(&p, a)).collect();
        // a strength between the smallest and largest mean
        let mut sorted = means.clone();
        sorted.sort_by(f64::total_cmp);
        let ft = 0.5 * (sorted[0] + sorted[sorted.len() - 1]);
        assert!(sorted[0] < ft && ft < sorted[sorted.len() - 1]);
        let law = EigenLaw {
            models: vec![Some(ResolvedEigen {
                model: EigenModel::Softening,
                epsilon: eps,
                fracture_energy: 100.0,
                softening: Some(SofteningLaw::linear(ft, 100.0, s)),
                tip_factor: 1.0,
            })],
        };
        let nb = lists(&p, eps);
        let before = p.softening.clone();
        let step = law.update(&mut p, &nb, &mut Scratch::default());
        let mut started = 0;
        for q in 0..p.len() {
            if before[q].chi >= 1.0 {
                assert_eq!(p.softening[q], before[q]);
                assert_eq!(p.stress[q], [0.0; 3]);
                continue;
            }
            let expect = (means[q] - ft).abs() > 1e-6 * ft;
            if expect {
                assert_eq!(p.softening[q].onset.is_some(), means[q] > ft, "point {q}");
            }
            started += usize::from(p.softening[q].onset.is_some());
        }
        assert_eq!(step.started, started);
        assert!(started > 0 && started < p.len());
    }

    /// κ against the quadrature of `docs/scripts/eigen_tip_ball.py`.
    #[test]
    fn the_tip_factor_is_the_williams_field_quadrature() {
        use crate::material::PlaneKind::{PlaneStrain, PlaneStress};
        assert!((tip_ball_factor(0.333, PlaneStrain, 2) - 0.2787).abs() < 1e-4);
        assert!((tip_ball_factor(0.333, PlaneStress, 2) - 0.3184).abs() < 1e-4);
        let three = tip_ball_factor(0.333, PlaneStrain, 3);
        let two = tip_ball_factor(0.333, PlaneStrain, 2);
        assert!((three / two - 3.0 * std::f64::consts::PI / 8.0).abs() < 1e-12);
    }

    /// The normalisation in a discrete field: points ε/10 apart
    /// carry the mode I Williams field (plane strain, ν = 0.333) of a
    /// crack along −x with its tip between them; with C_ε = 2ερ/κ the
    /// points at the tip read G = K²(1 − ν²)/E to a few per cent: G_c 6 %
    /// above it erodes nothing, 6 % below it erodes the points about the
    /// tip (the four nearest it among them).
    #[test]
    fn a_point_at_a_crack_tip_reads_griffiths_g() {
        let (e, nu, k, s) = (1.0e9, 0.333, 1.0e6, 0.001);
        let eps = 10.0 * s;
        let g = k * k * (1.0 - nu * nu) / e;
        let mut p = lattice(60, s, e, 0.0);
        for q in 0..p.len() {
            // the tip at the middle of the lattice, between points
            p.x[q] = [p.x[q][0] - 29.5 * s, p.x[q][1] - 29.5 * s];
            let [x, y] = p.x[q];
            let (r, t) = ((x * x + y * y).sqrt(), y.atan2(x));
            let f = k / (std::f64::consts::TAU * r).sqrt();
            let (sn, c) = (0.5 * t).sin_cos();
            let (s3, c3) = (1.5 * t).sin_cos();
            let sig = [
                f * c * (1.0 - sn * s3),
                f * c * (1.0 + sn * s3),
                f * c * sn * c3,
            ];
            let a = (1.0 + nu) / e;
            p.stress[q] = sig;
            p.strain[q] = [
                a * ((1.0 - nu) * sig[0] - nu * sig[1]),
                a * ((1.0 - nu) * sig[1] - nu * sig[0]),
                a * sig[2],
            ];
        }
        let kappa = tip_ball_factor(nu, crate::material::PlaneKind::PlaneStrain, 2);
        let erosion = |gc: f64| erosion(eps, gc, kappa);
        let nb = lists(&p, eps);
        let mut q = p.clone();
        let step = erosion(1.06 * g).update(&mut q, &nb, &mut Scratch::default());
        assert_eq!(step.failed, 0, "G_c 6 % above G");
        let step = erosion(0.94 * g).update(&mut p, &nb, &mut Scratch::default());
        assert!(step.failed >= 4, "G_c 6 % below G: {} eroded", step.failed);
        for q in 0..p.len() {
            if norm(p.x[q]) < s {
                assert_eq!(p.softening[q].chi, 1.0, "the point at {:?}", p.x[q]);
            }
        }
    }
}
