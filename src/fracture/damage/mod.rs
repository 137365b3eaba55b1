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
//!   ones kept, and σ rebuilt on the same eigenvectors. In 2D the in-plane
//!   pair in closed form ([`principal`], [`degrade`]); in 3D all three by
//!   Jacobi rotations ([`crate::tensor::sym_eigen3`], [`degrade_3d`]):
//!   σ ← σ − D Σ_{σ_i > 0} σ_i n_i ⊗ n_i, the same law on three axes.
//! - Domain scaling (section 2.6): a fully failed particle's volume is
//!   capped so that its diagonal does not exceed the cell size (area h²/2
//!   in 2D, volume h³/(3√3) in 3D, [`failed_volume`]); our shape functions
//!   (B-splines, uGIMP) do not stretch particle domains, so the volume is
//!   the only thing that would.
//!
//! One code path for 2D and 3D (`D`, `V` as in [`crate::particles`]): the
//! dimension enters through the principal stresses, the default l_ch (the
//! cell diagonal, h√2 or h√3), the failed volume, and the particle volume
//! of eq. 25 (spacing² × thickness in 2D, spacing³ in 3D, `vol0`). The 2D
//! arithmetic is the one it was before 3D, to the bit.
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
use crate::tensor::{contract, resize, sub, sym_eigen3, voigt};
use rand_core::{RngCore, SeedableRng};
use rayon::prelude::*;

/// Damage at or above this is "fully damaged" (a failed particle).
pub const FAILED: f64 = 1.0 - 1e-9;

const CHUNK: usize = 4096;

/// Per-material damage constants, indexed like the materials.
#[derive(Debug, Clone, Default)]
pub struct DamageLaw {
    pub models: Vec<Option<ResolvedDamage>>,
    /// Volume cap of a failed particle, m³ ([`failed_volume`]).
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

/// The volume cap of a fully failed particle (Homel & Herbold 2017,
/// section 2.6, domain scaling): a failed particle's domain may not grow
/// beyond the one whose diagonal is the cell size h, so that it cannot
/// span more than a cell and bridge the crack through the shape
/// functions. In 2D that domain is the square of diagonal h, area h²/2
/// (× the thickness t: m³). In 3D the diagonal of a cube is its space
/// diagonal (the longest chord, the extent that must stay within a cell),
/// so the cube of space diagonal h has side h/√3 and volume
/// h³/(3√3) ≈ 0.192 h³. (A cube of face diagonal h, h³/(2√2), would still
/// reach √(3/2) h across its corners.)
pub fn failed_volume<const D: usize>(h: f64, thickness: f64) -> f64 {
    if D == 2 {
        0.5 * h * h * thickness
    } else {
        h * h * h / (3.0 * 3f64.sqrt())
    }
}

/// The principal stresses of a stress in Voigt order as the damage update
/// uses them: `values` largest first; in 3D with their unit directions
/// (`vectors[i]` belongs to `values[i]`). In 2D `values` are the in-plane
/// pair of [`principal`] (σ_zz is not part of the plane law; `values[2]` is
/// 0) and `vectors` are unused: [`Principal::degrade`] calls [`degrade`],
/// which works from the stress as it always has.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Principal {
    pub values: [f64; 3],
    pub vectors: [[f64; 3]; 3],
}

impl Principal {
    /// The principal stresses of `s` (2D: xx, yy, xy; 3D: xx, yy, zz, yz,
    /// xz, xy).
    #[inline(always)]
    pub fn of<const D: usize, const V: usize>(s: &[f64; V]) -> Principal {
        if D == 2 {
            let (a, b, _) = principal(resize(*s));
            Principal {
                values: [a, b, 0.0],
                vectors: [[0.0; 3]; 3],
            }
        } else {
            let (values, vectors) = sym_eigen3(resize(*s));
            Principal { values, vectors }
        }
    }

    /// The largest principal stress σ₁, Pa.
    #[inline(always)]
    pub fn max(&self) -> f64 {
        self.values[0]
    }

    /// `s` (whose principal stresses these are) with its tensile principal
    /// stresses scaled by (1 − d) (eqs. 26–27).
    #[inline(always)]
    pub fn degrade<const D: usize, const V: usize>(&self, s: &[f64; V], d: f64) -> [f64; V] {
        if D == 2 {
            resize(degrade(resize(*s), d))
        } else {
            resize(degrade_3d(&resize(*s), self, d))
        }
    }
}

/// Eqs. 26–27 in 3D: σ − d Σ_{σ_i > 0} σ_i n_i ⊗ n_i for the principal
/// stresses `p` of `s`, i.e. the tensile principal stresses scaled by
/// (1 − d) and the compressive ones kept, on the same directions. Written
/// as a correction of σ so that an untouched part keeps its bits: no
/// damage or no tension returns `s` itself.
#[inline(always)]
pub fn degrade_3d(s: &[f64; 6], p: &Principal, d: f64) -> [f64; 6] {
    if d <= 0.0 || p.values[0] <= 0.0 {
        return *s;
    }
    let mut out = *s;
    for i in 0..3 {
        let a = p.values[i];
        if a <= 0.0 {
            break; // largest first: the rest are compressive too
        }
        let n = p.vectors[i];
        for (r, c) in [(0, 0), (1, 1), (2, 2), (1, 2), (0, 2), (0, 1)] {
            out[voigt::<3>(r, c)] -= d * a * n[r] * n[c];
        }
    }
    out
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
    /// in the order the particles are given (seeding order). `vol0` is each
    /// particle's initial volume V of eq. 25 (2D: spacing² × thickness; 3D:
    /// spacing³), so a finer 3D lattice is stronger by 8^(1/m) per halving
    /// of the spacing, against 4^(1/m) in 2D at fixed thickness.
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
    pub fn update<const D: usize, const V: usize>(
        &self,
        parts: &mut Particles<D, V>,
        dt: f64,
    ) -> DamageStep {
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
                    let pr = Principal::of::<D, V>(&se);
                    let d_old = damage[i];
                    let d = grow(m, d_old, pr.max(), strength[p], dt);
                    let s = pr.degrade::<D, V>(&se, d);
                    if d > d_old {
                        let s_old = pr.degrade::<D, V>(&se, d_old);
                        // ½ Δσ:ε
                        let de = 0.5 * contract::<D, V>(&sub(s_old, s), &strain[p]);
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
    /// Eqs. 26–27 in 3D: principal stresses (3, 0.5, −1) on a skew frame,
    /// D = 0.75 scales the two tensile ones and keeps the compressive one
    /// and the directions; an in-plane stress degrades as the 2D law does;
    /// compression is returned bit for bit.
    #[test]
    fn degradation_in_3d_scales_only_tensile_principal_stresses() {
        let (a, b) = (0.4f64, 0.9f64);
        let rz = [
            [a.cos(), -a.sin(), 0.0],
            [a.sin(), a.cos(), 0.0],
            [0.0, 0.0, 1.0],
        ];
        let ry = [
            [b.cos(), 0.0, b.sin()],
            [0.0, 1.0, 0.0],
            [-b.sin(), 0.0, b.cos()],
        ];
        // the frame's axes are the columns of rz·ry
        let n: [[f64; 3]; 3] = std::array::from_fn(|i| {
            std::array::from_fn(|r| (0..3).map(|k| rz[r][k] * ry[k][i]).sum())
        });
        let build = |vals: [f64; 3]| -> [f64; 6] {
            let c = |r: usize, s: usize| (0..3).map(|i| vals[i] * n[i][r] * n[i][s]).sum::<f64>();
            [c(0, 0), c(1, 1), c(2, 2), c(1, 2), c(0, 2), c(0, 1)]
        };
        let s = build([3.0, 0.5, -1.0]);
        let p = Principal::of::<3, 6>(&s);
        assert!((p.max() - 3.0).abs() < 1e-12);
        let g = p.degrade::<3, 6>(&s, 0.75);
        let want = build([0.75, 0.125, -1.0]);
        for k in 0..6 {
            assert!((g[k] - want[k]).abs() < 1e-12, "{g:?} vs {want:?}");
        }
        // the 2D law on an in-plane stress (σ_zz = σ_yz = σ_xz = 0)
        let plane = [2.0, -0.5, 0.7];
        let g3 = Principal::of::<3, 6>(&[plane[0], plane[1], 0.0, 0.0, 0.0, plane[2]])
            .degrade::<3, 6>(&[plane[0], plane[1], 0.0, 0.0, 0.0, plane[2]], 0.6);
        let g2 = Principal::of::<2, 3>(&plane).degrade::<2, 3>(&plane, 0.6);
        assert_eq!(g2, degrade(plane, 0.6));
        for (x, y) in [(g3[0], g2[0]), (g3[1], g2[1]), (g3[5], g2[2])] {
            assert!((x - y).abs() < 1e-12, "{g3:?} vs {g2:?}");
        }
        assert!(g3[2].abs() < 1e-12 && g3[3].abs() < 1e-12 && g3[4].abs() < 1e-12);
        // compression untouched, full damage removes all tension
        let c = build([-0.5, -1.0, -2.0]);
        assert_eq!(Principal::of::<3, 6>(&c).degrade::<3, 6>(&c, 1.0), c);
        let t = build([2.0, 1.0, 0.5]);
        let f = Principal::of::<3, 6>(&t).degrade::<3, 6>(&t, 1.0);
        assert!(f.iter().all(|v| v.abs() < 1e-12), "{f:?}");
    }

    /// The failed volume is the domain whose diagonal is the cell size:
    /// the square of diagonal h in 2D (× thickness), the cube of space
    /// diagonal h in 3D.
    #[test]
    fn the_failed_volume_has_the_cell_size_as_its_diagonal() {
        let (h, t) = (0.002, 0.01);
        assert_eq!(failed_volume::<2>(h, t), 0.5 * h * h * t);
        let side = failed_volume::<3>(h, t).cbrt();
        assert!((side * 3f64.sqrt() - h).abs() < 1e-15, "{side}");
    }
}
