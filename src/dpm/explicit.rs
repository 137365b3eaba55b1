//! Explicit central differences for the damage particle method (Wei &
//! Chen, eq. 40 and section 4: "the explicit central difference method is
//! adopted for time integration"): M d̈ = f_ext − f_int with the lumped
//! mass m_I = ρ V_I of each particle's smoothing cell, the internal force
//! of eq. 39 from the SCNI tables ([`Scni`]), and essential conditions on
//! particles that carry a singular kernel (their coefficient is their
//! displacement, [`super::rk::shape_values`]).
//!
//! The step is the velocity-Verlet form of central differences
//! (Belytschko, Liu & Moran, Nonlinear Finite Elements, box 6.1):
//! v ← v + Δt/2 a; prescribed components set; d ← d + Δt v; strain, stress
//! and force at the new d; a = (f_ext − f_int)/m + g; v ← v + Δt/2 a;
//! prescribed components set again. Stable for Δt below the highest
//! frequency's 2/ω_max; the caller picks Δt from the wave speed and the
//! spacing.

use super::scni::Scni;
use crate::material::Elastic;
use crate::tensor::{check_voigt, contract, resize};
use rayon::prelude::*;

/// A velocity component held fixed: particle, axis, velocity (m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Held {
    pub particle: u32,
    pub axis: u8,
    pub velocity: f64,
}

/// The state of an explicit run of the damage particle method.
#[derive(Debug, Clone)]
pub struct Explicit<const D: usize, const V: usize> {
    pub scni: Scni<D>,
    /// Lumped mass of each particle, kg (eq. 40: ρ V_I).
    pub mass: Vec<f64>,
    /// Each smoothing cell's volume, m³ (2D: area × thickness).
    pub vol: Vec<f64>,
    /// Each particle's material.
    pub material: Vec<u16>,
    pub materials: Vec<Elastic>,
    /// The coefficients d_I (eq. 17), their rates and accelerations.
    pub d: Vec<[f64; D]>,
    pub v: Vec<[f64; D]>,
    pub a: Vec<[f64; D]>,
    /// Smoothed strain and stress of each cell (Voigt, tensor shear).
    pub strain: Vec<[f64; V]>,
    pub stress: Vec<[f64; V]>,
    /// Internal force of the last step (eq. 39).
    pub force: Vec<[f64; D]>,
    /// External force on each particle, N (tractions).
    pub external: Vec<[f64; D]>,
    pub body_force: [f64; D],
    pub held: Vec<Held>,
}

impl<const D: usize, const V: usize> Explicit<D, V> {
    /// A body at rest in its reference configuration.
    pub fn new(scni: Scni<D>, vol: Vec<f64>, material: Vec<u16>, materials: Vec<Elastic>) -> Self {
        check_voigt::<D, V>();
        let n = vol.len();
        let mass = vol
            .iter()
            .zip(&material)
            .map(|(v, &m)| materials[m as usize].density * v)
            .collect();
        Explicit {
            scni,
            mass,
            vol,
            material,
            materials,
            d: vec![[0.0; D]; n],
            v: vec![[0.0; D]; n],
            a: vec![[0.0; D]; n],
            strain: vec![[0.0; V]; n],
            stress: vec![[0.0; V]; n],
            force: vec![[0.0; D]; n],
            external: vec![[0.0; D]; n],
            body_force: [0.0; D],
            held: Vec::new(),
        }
    }

    /// Strain, stress, internal force and acceleration at the present d
    /// (once before the first step, and inside every step).
    pub fn accelerations(&mut self) {
        self.scni.strain(&self.d, &mut self.strain);
        let (mats, material) = (&self.materials, &self.material);
        self.stress
            .par_iter_mut()
            .zip(&self.strain)
            .zip(material)
            .for_each(|((s, e), &m)| *s = hooke::<D, V>(&mats[m as usize], *e));
        self.scni
            .internal_force(&self.stress, &self.vol, &mut self.force);
        let g = self.body_force;
        self.a
            .par_iter_mut()
            .zip(&self.force)
            .zip(&self.external)
            .zip(&self.mass)
            .for_each(|(((a, f), e), &m)| {
                for k in 0..D {
                    a[k] = (e[k] - f[k]) / m + g[k];
                }
            });
    }

    /// One step of Δt = `dt`.
    pub fn step(&mut self, dt: f64) {
        self.kick(0.5 * dt);
        self.d.par_iter_mut().zip(&self.v).for_each(|(d, v)| {
            for k in 0..D {
                d[k] += dt * v[k];
            }
        });
        self.accelerations();
        self.kick(0.5 * dt);
    }

    /// v ← v + h a, then the held components.
    fn kick(&mut self, h: f64) {
        self.v.par_iter_mut().zip(&self.a).for_each(|(v, a)| {
            for k in 0..D {
                v[k] += h * a[k];
            }
        });
        for c in &self.held {
            self.v[c.particle as usize][c.axis as usize] = c.velocity;
        }
    }

    /// Kinetic energy ½ Σ m |ḋ|², J (the lumped mass's).
    pub fn kinetic_energy(&self) -> f64 {
        self.v
            .iter()
            .zip(&self.mass)
            .map(|(v, m)| 0.5 * m * v.iter().map(|c| c * c).sum::<f64>())
            .sum()
    }

    /// Strain energy ½ Σ_L σ_L : ε_L V_L, J (eq. 34's nodal integration).
    pub fn strain_energy(&self) -> f64 {
        self.stress
            .iter()
            .zip(&self.strain)
            .zip(&self.vol)
            .map(|((s, e), v)| 0.5 * contract::<D, V>(s, e) * v)
            .sum()
    }
}

/// Hooke's law of `m` for a small strain in D dimensions.
#[inline]
fn hooke<const D: usize, const V: usize>(m: &Elastic, e: [f64; V]) -> [f64; V] {
    if D == 2 {
        resize(m.hooke(resize(e)))
    } else {
        resize(m.hooke_3d(resize(e)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::material::{ElasticConstants, MaterialModel, PlaneKind};

    /// A column of material in uniaxial strain: nodes on the vertices of
    /// [0, L] × [0, H], rollers on the left (x held) and on the top and
    /// bottom (y held), the right end free; singular kernels on the held
    /// particles.
    fn column(nx: usize, ny: usize, l: f64) -> (Explicit<2, 3>, Vec<[f64; 2]>, f64) {
        let s = l / nx as f64;
        let h = ny as f64 * s;
        let (mut x, mut lo, mut hi) = (vec![], vec![], vec![]);
        for j in 0..=ny {
            for i in 0..=nx {
                let p = [i as f64 * s, j as f64 * s];
                x.push(p);
                lo.push([(p[0] - 0.5 * s).max(0.0), (p[1] - 0.5 * s).max(0.0)]);
                hi.push([(p[0] + 0.5 * s).min(l), (p[1] + 0.5 * s).min(h)]);
            }
        }
        let n = x.len();
        let singular: Vec<bool> = x
            .iter()
            .map(|p| p[0] == 0.0 || p[1] == 0.0 || p[1] == h)
            .collect();
        let scni = Scni::build(&x, &lo, &hi, &vec![1.5 * s; n], &singular, &vec![0; n]).unwrap();
        let (e, nu, rho): (f64, f64, f64) = (2.0e9, 0.25, 2000.0);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        let c = ((lambda + 2.0 * mu) / rho).sqrt();
        let m = Elastic::new(
            &ElasticConstants {
                model: MaterialModel::LinearElastic,
                density: rho,
                youngs_modulus: e,
                poissons_ratio: nu,
                lambda,
                mu,
                wave_speed: c,
            },
            PlaneKind::PlaneStrain,
        );
        let vol = scni.cell.clone();
        let mut run = Explicit::<2, 3>::new(scni, vol, vec![0; n], vec![m]);
        for (p, q) in x.iter().enumerate() {
            if q[0] == 0.0 {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 0,
                    velocity: 0.0,
                });
            }
            if q[1] == 0.0 || q[1] == h {
                run.held.push(Held {
                    particle: p as u32,
                    axis: 1,
                    velocity: 0.0,
                });
            }
        }
        (run, x, c)
    }

    #[test]
    fn a_column_rings_at_its_first_mode_and_keeps_its_energy() {
        // u_x = A sin(πx/2L) cos(ωt), ω = πc/2L: half a period later the
        // free end is at −A; the energy stays (central differences are
        // symplectic: it oscillates by O(Δt²) without drift)
        let (nx, l, amp) = (40, 1.0, 1e-4);
        let (mut run, x, c) = column(nx, 4, l);
        let k = std::f64::consts::PI / (2.0 * l);
        for (d, p) in run.d.iter_mut().zip(&x) {
            d[0] = amp * (k * p[0]).sin();
        }
        run.accelerations();
        let e0 = run.kinetic_energy() + run.strain_energy();
        // the analytic strain energy of the mode at rest: ½ (λ+2μ) ∫ (∂u/∂x)² = (λ+2μ) A² k² L H / 4
        let m = run.materials[0];
        let analytic = m.c11 * amp * amp * k * k * l * (4.0 * l / nx as f64) / 4.0;
        assert!(
            (e0 / analytic - 1.0).abs() < 5e-3,
            "energy {e0} vs {analytic}"
        );
        let period = 4.0 * l / c;
        let dt = 0.3 * (l / nx as f64) / c;
        let steps = (0.5 * period / dt).round() as usize;
        let dt = 0.5 * period / steps as f64;
        let (mut lo, mut hi) = (f64::INFINITY, 0.0f64);
        for _ in 0..steps {
            run.step(dt);
            let e = run.kinetic_energy() + run.strain_energy();
            lo = lo.min(e);
            hi = hi.max(e);
        }
        let mut u = vec![[0.0; 2]; x.len()];
        run.scni.interpolate(&run.d, &mut u);
        let tip: Vec<f64> = x
            .iter()
            .zip(&u)
            .filter(|(p, _)| p[0] == l)
            .map(|(_, u)| u[0])
            .collect();
        for t in &tip {
            assert!((t / amp + 1.0).abs() < 5e-3, "free end at {} A", t / amp);
        }
        assert!(
            (hi - lo) / e0 < 2e-3,
            "energy between {lo} and {hi} of {e0}"
        );
        // the held components did not move; y stays near zero (the
        // corner cells' outline points lie between held particles, where
        // the second row's functions do not vanish: 1e-4 of A)
        for c in &run.held {
            assert_eq!(run.d[c.particle as usize][c.axis as usize], 0.0);
        }
        let uy = run.d.iter().map(|d| d[1].abs()).fold(0.0, f64::max);
        assert!(uy < 1e-3 * amp, "transverse motion {}", uy / amp);
    }
}
