//! Continuum damage for brittle failure (Homel & Herbold 2017,
//! section 2.7), evaluated per particle after the G2P stress update.
//!
//! - Rankine with linear strain softening (eq. 23, after Cervera et al.):
//!   D = (1 + H_s)(1 − σ_f / σ₁ᴱ), never decreasing, with
//!   H_s = H̄ l_ch /(1 − H̄ l_ch), H̄ = σ_f²/(2 E G_f). In uniaxial tension
//!   the degraded stress falls linearly from σ_f to zero and a particle
//!   dissipates G_f / l_ch per unit volume, so a band of width l_ch
//!   dissipates G_f per unit crack area.
//! - Time to failure (eq. 24): D ← min(1, D + Δt/τ) in every step in which
//!   σ₁ᴱ exceeds the particle's strength, τ = l_ch / c_f.
//! - Weibull strength (eq. 25): σ_f = σ̄_f (V̄/V · ln R / ln ½)^(1/m), R
//!   uniform in (0, 1) from a seeded generator, drawn once per particle in
//!   seeding order (the same seed gives the same strengths).
//! - Tensile-only degradation (eqs. 26–27): the positive principal stresses
//!   of the elastic trial stress σᴱ are scaled by (1 − D), the compressive
//!   ones kept, and σ rebuilt on the same eigenvectors.
//! - Domain scaling (section 2.6): a fully failed particle's volume is
//!   capped so that its diagonal does not exceed the cell size (area h²/2);
//!   our shape functions (B-splines, uGIMP) do not stretch particle
//!   domains, so the volume is the only thing that would.
//!
//! Energy: the stored energy of a particle is ½ σ:ε with the degraded σ
//! (what the series' `strain_energy` sums). A damage increment at fixed
//! strain releases V·½(σ(D_old) − σ(D_new)):ε, which is summed as the
//! dissipated energy; kinetic + strain + dissipated − external work is then
//! constant up to the discretization's own error.

pub mod model;
pub mod section;

use crate::particles::Particles;
use crate::scene::{DamageModel, ResolvedDamage};
use rand_core::{RngCore, SeedableRng};
use rayon::prelude::*;

/// Damage at or above this is "fully damaged" (a failed particle).
pub const FAILED: f64 = 1.0 - 1e-9;

const CHUNK: usize = 4096;

/// Per-material damage constants, indexed like the materials.
#[derive(Debug, Clone, Default)]
pub struct DamageLaw {
    pub models: Vec<Option<ResolvedDamage>>,
    /// Volume cap of a failed particle, m³ (h²/2 · thickness).
    pub failed_volume: f64,
}

/// What one damage update did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DamageStep {
    /// Energy released by damage growth this step, J.
    pub dissipated: f64,
}

/// Principal stresses (σ₁ ≥ σ₂) of an in-plane stress (xx, yy, xy) and the
/// angle of σ₁'s direction from x.
#[inline(always)]
pub fn principal(s: [f64; 3]) -> (f64, f64, f64) {
    let c = 0.5 * (s[0] + s[1]);
    let d = 0.5 * (s[0] - s[1]);
    let r = (d * d + s[2] * s[2]).sqrt();
    (c + r, c - r, 0.5 * s[2].atan2(d))
}

/// Eqs. 26–27: the tensile principal stresses scaled by (1 − D).
#[inline(always)]
pub fn degrade(s: [f64; 3], d: f64) -> [f64; 3] {
    if d <= 0.0 {
        return s;
    }
    let (s1, s2, theta) = principal(s);
    if s1 <= 0.0 {
        return s; // all compressive: untouched
    }
    let a = if s1 > 0.0 { (1.0 - d) * s1 } else { s1 };
    let b = if s2 > 0.0 { (1.0 - d) * s2 } else { s2 };
    let (sn, cs) = theta.sin_cos();
    [
        a * cs * cs + b * sn * sn,
        a * sn * sn + b * cs * cs,
        (a - b) * sn * cs,
    ]
}

/// The damage after one step of the model `m` for the elastic trial stress
/// with largest principal value `s1`, strength `sf` and step `dt`.
#[inline(always)]
pub fn grow(m: &ResolvedDamage, d: f64, s1: f64, sf: f64, dt: f64) -> f64 {
    if s1 <= sf {
        return d;
    }
    match m.model {
        DamageModel::Rankine => d.max(((1.0 + m.softening) * (1.0 - sf / s1)).clamp(0.0, 1.0)),
        DamageModel::TimeToFailure => (d + dt / m.tau).min(1.0),
    }
}

impl DamageLaw {
    /// Particle strengths (eq. 25 where a material asks for Weibull), drawn
    /// in the order the particles are given (seeding order).
    pub fn strengths(&self, material: &[u16], vol0: &[f64]) -> Vec<f64> {
        let mut rngs: Vec<Option<rand_pcg::Pcg64>> = self
            .models
            .iter()
            .map(|m| {
                m.as_ref()
                    .and_then(|m| m.weibull.as_ref())
                    .map(|w| rand_pcg::Pcg64::seed_from_u64(w.seed))
            })
            .collect();
        material
            .iter()
            .zip(vol0)
            .map(|(&mi, &v)| {
                let Some(m) = &self.models[mi as usize] else {
                    return f64::INFINITY;
                };
                match (&m.weibull, &mut rngs[mi as usize]) {
                    (Some(w), Some(rng)) => {
                        // R uniform in the open interval (0, 1)
                        let r = ((rng.next_u64() >> 11) as f64 + 0.5) * (1.0 / (1u64 << 53) as f64);
                        m.strength * (w.ref_volume / v * r.ln() / 0.5f64.ln()).powf(1.0 / w.modulus)
                    }
                    _ => m.strength,
                }
            })
            .collect()
    }

    /// The damage stage: grows D from the elastic trial stress G2P left in
    /// `parts.stress`, degrades the stress (eqs. 23–27), caps failed
    /// volumes, and returns the energy released.
    pub fn update(&self, parts: &mut Particles, dt: f64) -> DamageStep {
        let n = parts.len();
        let (material, strain, strength) = (&parts.material, &parts.strain, &parts.strength);
        let cap = self.failed_volume;
        let dissipated: Vec<f64> = parts.stress[..n]
            .par_chunks_mut(CHUNK)
            .zip(parts.damage.par_chunks_mut(CHUNK))
            .zip(parts.vol.par_chunks_mut(CHUNK))
            .enumerate()
            .map(|(k, ((stress, damage), vol))| {
                let mut released = 0.0;
                for i in 0..stress.len() {
                    let p = k * CHUNK + i;
                    let Some(m) = &self.models[material[p] as usize] else {
                        continue;
                    };
                    let se = stress[i];
                    let (s1, _, _) = principal(se);
                    let d_old = damage[i];
                    let d = grow(m, d_old, s1, strength[p], dt);
                    let s = degrade(se, d);
                    if d > d_old {
                        let s_old = degrade(se, d_old);
                        let e = strain[p];
                        let de = 0.5
                            * ((s_old[0] - s[0]) * e[0]
                                + (s_old[1] - s[1]) * e[1]
                                + 2.0 * (s_old[2] - s[2]) * e[2]);
                        released += vol[i] * de;
                        damage[i] = d;
                    }
                    if d >= FAILED && vol[i] > cap {
                        vol[i] = cap;
                    }
                    stress[i] = s;
                }
                released
            })
            .collect();
        // summed in chunk order: the same total for any thread count
        DamageStep {
            dissipated: dissipated.iter().sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rankine(softening: f64) -> ResolvedDamage {
        ResolvedDamage {
            model: DamageModel::Rankine,
            strength: 1.0,
            char_length: 1.0,
            softening,
            tau: 0.0,
            weibull: None,
        }
    }

    #[test]
    fn degradation_scales_only_tensile_principal_stresses() {
        // principal (3, −1) rotated by 30°
        let (a, b, t) = (3.0f64, -1.0f64, 30f64.to_radians());
        let (sn, cs) = t.sin_cos();
        let s = [
            a * cs * cs + b * sn * sn,
            a * sn * sn + b * cs * cs,
            (a - b) * sn * cs,
        ];
        let (s1, s2, theta) = principal(s);
        assert!((s1 - 3.0).abs() < 1e-12 && (s2 + 1.0).abs() < 1e-12 && (theta - t).abs() < 1e-12);
        let g = degrade(s, 0.75);
        let (g1, g2, gt) = principal(g);
        assert!((g1 - 0.75).abs() < 1e-12, "{g1}");
        assert!((g2 + 1.0).abs() < 1e-12, "{g2}");
        assert!((gt - t).abs() < 1e-9);
        // compression is untouched, full damage removes tension
        assert_eq!(degrade([-2.0, -1.0, 0.0], 1.0), [-2.0, -1.0, 0.0]);
        let f = degrade([2.0, 1.0, 0.0], 1.0);
        assert!(f.iter().all(|v| v.abs() < 1e-12));
    }

    /// Uniaxial strain history through eq. 23: the degraded stress softens
    /// linearly from σ_f to 0, and the energy released plus the energy
    /// stored equals ∫σ dε = G_f / l_ch at failure.
    #[test]
    fn rankine_dissipates_gf_over_lch_per_volume() {
        let (e, sf, gf, l) = (100.0, 1.0, 0.02, 1.0);
        let hb = sf * sf / (2.0 * e * gf) * l;
        let m = ResolvedDamage {
            softening: hb / (1.0 - hb),
            strength: sf,
            ..rankine(0.0)
        };
        let eu = sf * (1.0 + m.softening) / (m.softening * e);
        let (mut d, mut work, mut released, mut last_s) = (0.0, 0.0, 0.0, 0.0);
        let n = 100_000;
        for k in 1..=n {
            let eps = 1.2 * eu * k as f64 / n as f64;
            let se = e * eps;
            let d_new = grow(&m, d, se, sf, 0.0);
            let s = (1.0 - d_new) * se;
            released += 0.5 * (d_new - d) * se * eps;
            work += 0.5 * (s + last_s) * 1.2 * eu / n as f64;
            d = d_new;
            last_s = s;
            if (eps - sf / e).abs() < 1e-3 * eu {
                assert!(d < 1e-2);
            }
        }
        assert!(d >= FAILED);
        assert!(
            (work - gf / l).abs() < 1e-3 * gf / l,
            "work {work} vs {}",
            gf / l
        );
        assert!(
            (released - gf / l).abs() < 1e-3 * gf / l,
            "released {released} vs {}",
            gf / l
        );
    }

    #[test]
    fn weibull_strengths_repeat_with_the_seed_and_scale_with_volume() {
        let mut m = rankine(1.0);
        m.strength = 100.0;
        m.weibull = Some(crate::scene::WeibullSpec {
            modulus: 6.0,
            ref_volume: 1.0,
            seed: 7,
        });
        let law = DamageLaw {
            models: vec![Some(m.clone())],
            failed_volume: 1.0,
        };
        let mat = vec![0u16; 20_000];
        let a = law.strengths(&mat, &vec![1.0; 20_000]);
        assert_eq!(a, law.strengths(&mat, &vec![1.0; 20_000]));
        // the median at the reference volume is σ̄_f
        let mut s = a.clone();
        s.sort_by(f64::total_cmp);
        assert!(
            (s[10_000] / 100.0 - 1.0).abs() < 0.01,
            "median {}",
            s[10_000]
        );
        // a volume 64× smaller is 64^(1/6) = 2× stronger
        let b = law.strengths(&mat, &vec![1.0 / 64.0; 20_000]);
        assert!((b[17] / a[17] - 2.0).abs() < 1e-12);
        let other = DamageLaw {
            models: vec![Some(crate::scene::ResolvedDamage {
                weibull: Some(crate::scene::WeibullSpec {
                    seed: 8,
                    ..m.weibull.clone().unwrap()
                }),
                ..m
            })],
            failed_volume: 1.0,
        };
        assert_ne!(a, other.strengths(&mat, &vec![1.0; 20_000]));
    }
}
