//! Constitutive models, evaluated per particle in the G2P stage.
//!
//! - Linear elastic small strain (Hooke's law) in plane strain
//!   (σ_zz = λ(ε_xx + ε_yy)) and plane stress (σ_zz = 0), updated
//!   incrementally: ε ← ε + Δt·sym(L), which leaves rigid rotations free of
//!   strain (the update-stress-last scheme of Sulsky et al. 1994).
//! - The same two in 3D (`hooke_3d`, `neo_hookean_3d`), stresses and
//!   strains in Voigt order (xx, yy, zz, yz, xz, xy).
//! - Compressible neo-Hookean (plane strain, F_zz = 1):
//!   σ = μ/J (F Fᵀ − I) + λ ln J / J · I, ψ = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)².

use serde::{Deserialize, Serialize};

/// The constitutive model of a material (a scene material's `model`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum MaterialModel {
    /// Small-strain isotropic linear elasticity.
    LinearElastic,
    /// Compressible neo-Hookean: σ = μ/J (F Fᵀ − I) + λ ln J / J · I.
    NeoHookean,
}

/// Plane strain or plane stress (a scene's `analysis.plane`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneKind {
    #[default]
    PlaneStrain,
    PlaneStress,
}

/// A material's model and constants as given and derived, which
/// [`Elastic::new`] takes (the scene's `ResolvedMaterial` gives them).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ElasticConstants {
    pub model: MaterialModel,
    /// Mass density, kg/m³.
    pub density: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    pub poissons_ratio: f64,
    /// Lamé constants, Pa.
    pub lambda: f64,
    pub mu: f64,
    /// Dilatational wave speed of the 2D model at rest, m/s.
    pub wave_speed: f64,
}

/// Per-material constants in the form the hot loop wants.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Elastic {
    pub model: MaterialModel,
    pub plane: PlaneKind,
    /// In-plane stiffness: σxx = c11 εxx + c12 εyy, σxy = c33 εxy.
    pub c11: f64,
    pub c12: f64,
    pub c33: f64,
    pub lambda: f64,
    pub mu: f64,
    pub density: f64,
    pub poissons_ratio: f64,
    /// Wave speed at rest, m/s.
    pub wave_speed: f64,
}

impl ElasticConstants {
    /// The constants of an isotropic linear elastic material from its
    /// density, Young's modulus and Poisson's ratio: the Lamé constants
    /// and the dilatational wave speed √((λ + 2μ)/ρ).
    pub fn linear_elastic(
        density: f64,
        youngs_modulus: f64,
        poissons_ratio: f64,
    ) -> ElasticConstants {
        let (e, nu) = (youngs_modulus, poissons_ratio);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        ElasticConstants {
            model: MaterialModel::LinearElastic,
            density,
            youngs_modulus: e,
            poissons_ratio: nu,
            lambda,
            mu,
            wave_speed: ((lambda + 2.0 * mu) / density).sqrt(),
        }
    }
}

impl Elastic {
    pub fn new(m: &ElasticConstants, plane: PlaneKind) -> Elastic {
        let (lambda, mu, e, nu) = (m.lambda, m.mu, m.youngs_modulus, m.poissons_ratio);
        let (c11, c12) = match plane {
            PlaneKind::PlaneStrain => (lambda + 2.0 * mu, lambda),
            PlaneKind::PlaneStress => (e / (1.0 - nu * nu), e * nu / (1.0 - nu * nu)),
        };
        Elastic {
            model: m.model,
            plane,
            c11,
            c12,
            c33: 2.0 * mu,
            lambda,
            mu,
            density: m.density,
            poissons_ratio: nu,
            wave_speed: m.wave_speed,
        }
    }

    /// Hooke's law for the small strain (xx, yy, xy).
    #[inline(always)]
    pub fn hooke(&self, e: [f64; 3]) -> [f64; 3] {
        [
            self.c11 * e[0] + self.c12 * e[1],
            self.c12 * e[0] + self.c11 * e[1],
            self.c33 * e[2],
        ]
    }

    /// Neo-Hookean Cauchy stress (xx, yy, xy) and J for the 2D F (plane
    /// strain, F_zz = 1).
    #[inline(always)]
    pub fn neo_hookean(&self, f: [[f64; 2]; 2]) -> ([f64; 3], f64) {
        let [[f11, f12], [f21, f22]] = f;
        let j = f11 * f22 - f12 * f21;
        let b = [
            f11 * f11 + f12 * f12,
            f21 * f21 + f22 * f22,
            f11 * f21 + f12 * f22,
        ];
        let lnj = j.ln();
        let a = self.mu / j;
        let p = self.lambda * lnj / j;
        ([a * (b[0] - 1.0) + p, a * (b[1] - 1.0) + p, a * b[2]], j)
    }

    /// Out-of-plane stress σ_zz.
    pub fn stress_zz(
        &self,
        stress: [f64; 3],
        strain: Option<[f64; 3]>,
        def_grad: Option<[[f64; 2]; 2]>,
    ) -> f64 {
        match (self.model, self.plane) {
            (_, PlaneKind::PlaneStress) => 0.0,
            (MaterialModel::LinearElastic, PlaneKind::PlaneStrain) => {
                let e = strain.unwrap_or([0.0; 3]);
                self.lambda * (e[0] + e[1])
            }
            (MaterialModel::NeoHookean, PlaneKind::PlaneStrain) => {
                let [[f11, f12], [f21, f22]] = def_grad.unwrap_or([[1.0, 0.0], [0.0, 1.0]]);
                let j = f11 * f22 - f12 * f21;
                let _ = stress;
                self.lambda * j.ln() / j
            }
        }
    }

    /// Out-of-plane small strain ε_zz (plane stress: −ν/(1−ν)(εxx+εyy)).
    pub fn strain_zz(&self, e: [f64; 3]) -> f64 {
        match self.plane {
            PlaneKind::PlaneStrain => 0.0,
            PlaneKind::PlaneStress => {
                -self.poissons_ratio / (1.0 - self.poissons_ratio) * (e[0] + e[1])
            }
        }
    }

    /// Strain energy density ψ, J/m³, of a linear elastic particle:
    /// ½ σ:ε (the zz terms vanish in both plane strain and plane stress).
    #[inline]
    pub fn energy_linear(stress: [f64; 3], e: [f64; 3]) -> f64 {
        0.5 * (stress[0] * e[0] + stress[1] * e[1] + 2.0 * stress[2] * e[2])
    }

    /// Neo-Hookean strain energy density for the 2D F (plane strain).
    pub fn energy_neo_hookean(&self, f: [[f64; 2]; 2]) -> f64 {
        let [[f11, f12], [f21, f22]] = f;
        let j = f11 * f22 - f12 * f21;
        let trc = f11 * f11 + f12 * f12 + f21 * f21 + f22 * f22 + 1.0;
        let lnj = j.ln();
        0.5 * self.mu * (trc - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj
    }

    /// Hooke's law in 3D for the small strain in Voigt order (xx, yy, zz,
    /// yz, xz, xy; tensor components): σ = λ tr ε I + 2μ ε.
    #[inline(always)]
    pub fn hooke_3d(&self, e: [f64; 6]) -> [f64; 6] {
        let le = self.lambda * (e[0] + e[1] + e[2]);
        let m2 = 2.0 * self.mu;
        [
            le + m2 * e[0],
            le + m2 * e[1],
            le + m2 * e[2],
            m2 * e[3],
            m2 * e[4],
            m2 * e[5],
        ]
    }

    /// Neo-Hookean Cauchy stress (Voigt order) and J for a 3D F:
    /// σ = μ/J (F Fᵀ − I) + λ ln J / J · I.
    #[inline(always)]
    pub fn neo_hookean_3d(&self, f: [[f64; 3]; 3]) -> ([f64; 6], f64) {
        let j = det3(f);
        let b = |r: usize, c: usize| f[r][0] * f[c][0] + f[r][1] * f[c][1] + f[r][2] * f[c][2];
        let lnj = j.ln();
        let a = self.mu / j;
        let p = self.lambda * lnj / j;
        (
            [
                a * (b(0, 0) - 1.0) + p,
                a * (b(1, 1) - 1.0) + p,
                a * (b(2, 2) - 1.0) + p,
                a * b(1, 2),
                a * b(0, 2),
                a * b(0, 1),
            ],
            j,
        )
    }

    /// Neo-Hookean strain energy density for a 3D F.
    pub fn energy_neo_hookean_3d(&self, f: [[f64; 3]; 3]) -> f64 {
        let j = det3(f);
        let trc: f64 = f.iter().flatten().map(|v| v * v).sum();
        let lnj = j.ln();
        0.5 * self.mu * (trc - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj
    }

    /// Strain energy density ½ σ:ε of a 3D linear elastic particle
    /// (Voigt order, tensor shear strains).
    #[inline]
    pub fn energy_linear_3d(stress: [f64; 6], e: [f64; 6]) -> f64 {
        0.5 * (stress[0] * e[0]
            + stress[1] * e[1]
            + stress[2] * e[2]
            + 2.0 * (stress[3] * e[3] + stress[4] * e[4] + stress[5] * e[5]))
    }

    /// Dilatational wave speed at volume ratio J (neo-Hookean stiffens in
    /// compression: c² = (λ + 2μ − 2λ ln J)/ρ₀).
    #[inline(always)]
    pub fn wave_speed_at(&self, j: f64) -> f64 {
        match self.model {
            MaterialModel::LinearElastic => self.wave_speed,
            MaterialModel::NeoHookean => {
                let m = self.lambda + 2.0 * self.mu - 2.0 * self.lambda * j.ln();
                (m.max(self.lambda + 2.0 * self.mu) / self.density).sqrt()
            }
        }
    }
}

/// det F of a 3 × 3 matrix.
#[inline(always)]
pub fn det3(f: [[f64; 3]; 3]) -> f64 {
    f[0][0] * (f[1][1] * f[2][2] - f[1][2] * f[2][1])
        - f[0][1] * (f[1][0] * f[2][2] - f[1][2] * f[2][0])
        + f[0][2] * (f[1][0] * f[2][1] - f[1][1] * f[2][0])
}

/// Miehe's spectral split of the small-strain energy (Miehe et al. 2010,
/// as used by Kakouris & Triantafyllou, eqs. 14–16): with principal strains ε_a (the two
/// in-plane ones and ε_zz),
/// ψ⁺ = λ/2 ⟨tr ε⟩₊² + μ Σ ⟨ε_a⟩₊², and the in-plane stresses
/// σ± = λ⟨tr ε⟩± I + 2μ Σ_{a in-plane} ⟨ε_a⟩± n_a⊗n_a.
/// `e` is (xx, yy, xy); `ezz` is 0 in plane strain and −ν/(1−ν)(εxx+εyy)
/// in plane stress, which makes σ⁺ + σ⁻ the plane-stress Hooke's law.
/// Returns (ψ⁺, σ⁺, σ⁻) with stresses as (xx, yy, xy).
pub fn miehe_split(lambda: f64, mu: f64, e: [f64; 3], ezz: f64) -> (f64, [f64; 3], [f64; 3]) {
    let (a, b, c) = (e[0], e[1], e[2]);
    let mean = 0.5 * (a + b);
    let r = (0.25 * (a - b) * (a - b) + c * c).sqrt();
    let (e1, e2) = (mean + r, mean - r);
    // n⊗n of the unit eigenvector n = (cos θ, sin θ) of e1, from
    // cos 2θ = (a − b)/2r and sin 2θ = c/r without trigonometric calls
    // (x-axis when the strain is isotropic)
    let (nxx, nyy, nxy) = if r > 1e-300 {
        let q = 0.25 * (a - b) / r;
        (0.5 + q, 0.5 - q, 0.5 * c / r)
    } else {
        (1.0, 0.0, 0.0)
    };
    let tr = e1 + e2 + ezz;
    let pos = |x: f64| x.max(0.0);
    let neg = |x: f64| x.min(0.0);
    let psi = 0.5 * lambda * pos(tr).powi(2)
        + mu * (pos(e1).powi(2) + pos(e2).powi(2) + pos(ezz).powi(2));
    // s1 n1⊗n1 + s2 n2⊗n2, with n2⊗n2 = (nyy, nxx, −nxy)
    let proj = |s1: f64, s2: f64| [s1 * nxx + s2 * nyy, s1 * nyy + s2 * nxx, (s1 - s2) * nxy];
    let sp = proj(2.0 * mu * pos(e1), 2.0 * mu * pos(e2));
    let sn = proj(2.0 * mu * neg(e1), 2.0 * mu * neg(e2));
    let (lp, ln) = (lambda * pos(tr), lambda * neg(tr));
    (
        psi,
        [sp[0] + lp, sp[1] + lp, sp[2]],
        [sn[0] + ln, sn[1] + ln, sn[2]],
    )
}

/// Miehe's spectral split in 3D (Miehe et al. 2010, as Kakouris & Triantafyllou use it,
/// eqs. 14–16, with all three principal strains of the full strain):
/// ψ⁺ = λ/2 ⟨tr ε⟩₊² + μ Σ_a ⟨ε_a⟩₊², σ± = λ⟨tr ε⟩± I + 2μ Σ_a ⟨ε_a⟩± n_a⊗n_a.
/// `e` is the strain in Voigt order (xx, yy, zz, yz, xz, xy; tensor shear
/// components); returns (ψ⁺, σ⁺, σ⁻) in the same order. The principal
/// axes are [`crate::tensor::sym_eigen3`]'s (exact for a diagonal strain).
pub fn miehe_split_3d(lambda: f64, mu: f64, e: [f64; 6]) -> (f64, [f64; 6], [f64; 6]) {
    let (ev, n) = crate::tensor::sym_eigen3(e);
    let tr = e[0] + e[1] + e[2];
    let pos = |x: f64| x.max(0.0);
    let neg = |x: f64| x.min(0.0);
    let psi = 0.5 * lambda * pos(tr).powi(2)
        + mu * (pos(ev[0]).powi(2) + pos(ev[1]).powi(2) + pos(ev[2]).powi(2));
    // Σ_a s_a n_a⊗n_a in Voigt order; n[a] is the unit vector n_a
    let proj = |s: [f64; 3]| {
        let at = |i: usize, j: usize| {
            s[0] * n[0][i] * n[0][j] + s[1] * n[1][i] * n[1][j] + s[2] * n[2][i] * n[2][j]
        };
        [at(0, 0), at(1, 1), at(2, 2), at(1, 2), at(0, 2), at(0, 1)]
    };
    let m2 = 2.0 * mu;
    let sp = proj([m2 * pos(ev[0]), m2 * pos(ev[1]), m2 * pos(ev[2])]);
    let sn = proj([m2 * neg(ev[0]), m2 * neg(ev[1]), m2 * neg(ev[2])]);
    let (lp, ln) = (lambda * pos(tr), lambda * neg(tr));
    (
        psi,
        [sp[0] + lp, sp[1] + lp, sp[2] + lp, sp[3], sp[4], sp[5]],
        [sn[0] + ln, sn[1] + ln, sn[2] + ln, sn[3], sn[4], sn[5]],
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn miehe_split_sums_to_hooke_and_separates_tension() {
        let (lambda, mu) = (1.2e9, 0.8e9);
        for e in [
            [1e-3, -2e-4, 3e-4],
            [-1e-3, -5e-4, 1e-4],
            [2e-3, 2e-3, 0.0],
            [0.0, 0.0, 5e-4],
        ] {
            let (psi, sp, sn) = super::miehe_split(lambda, mu, e, 0.0);
            let hooke = [
                (lambda + 2.0 * mu) * e[0] + lambda * e[1],
                lambda * e[0] + (lambda + 2.0 * mu) * e[1],
                2.0 * mu * e[2],
            ];
            for k in 0..3 {
                assert!(
                    (sp[k] + sn[k] - hooke[k]).abs() < 1e-6 * 1e9 * 1e-3,
                    "{e:?}: {k}"
                );
            }
            let total = 0.5 * (hooke[0] * e[0] + hooke[1] * e[1] + 2.0 * hooke[2] * e[2]);
            assert!(
                psi >= 0.0 && psi <= total + 1e-9,
                "{e:?}: psi+ {psi} of {total}"
            );
            // ψ⁺ = ½ σ⁺ : ε
            let half = 0.5 * (sp[0] * e[0] + sp[1] * e[1] + 2.0 * sp[2] * e[2]);
            assert!(
                (psi - half).abs() < 1e-9 * total.max(1.0),
                "{e:?}: {psi} vs {half}"
            );
        }
        // pure compression has no tensile energy
        let (psi, sp, _) = super::miehe_split(lambda, mu, [-1e-3, -1e-3, 0.0], 0.0);
        assert_eq!(psi, 0.0);
        assert_eq!(sp, [0.0; 3]);
    }

    use super::*;

    fn steel(model: MaterialModel, plane: PlaneKind) -> Elastic {
        let (e, nu) = (200e9, 0.3);
        let m = ElasticConstants {
            model,
            density: 7800.0,
            youngs_modulus: e,
            poissons_ratio: nu,
            lambda: e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu)),
            mu: e / (2.0 * (1.0 + nu)),
            wave_speed: 5000.0,
        };
        Elastic::new(&m, plane)
    }

    #[test]
    fn plane_stress_uniaxial_gives_e() {
        let m = steel(MaterialModel::LinearElastic, PlaneKind::PlaneStress);
        // uniaxial stress: εyy = −ν εxx
        let s = m.hooke([1e-3, -0.3e-3, 0.0]);
        assert!((s[0] - 200e9 * 1e-3).abs() < 1e-3 * 200e6);
        assert!(s[1].abs() < 1e-6 * 200e6);
    }

    #[test]
    fn both_plane_stress_splits_sum_to_plane_stress_hooke() {
        let m = steel(MaterialModel::LinearElastic, PlaneKind::PlaneStress);
        for e in [
            [1e-3, -2e-4, 3e-4],
            [-1e-3, -5e-4, 1e-4],
            [2e-3, -4e-3, 0.0],
        ] {
            let hooke = m.hooke(e);
            // with ε_zz (the default) and in-plane with λ* = c12
            for (lambda, ezz) in [(m.lambda, m.strain_zz(e)), (m.c12, 0.0)] {
                let (psi, sp, sn) = miehe_split(lambda, m.mu, e, ezz);
                for k in 0..3 {
                    assert!(
                        (sp[k] + sn[k] - hooke[k]).abs() < 1e-9 * 200e9 * 1e-3,
                        "{e:?} {lambda}: {k}"
                    );
                }
                let total = Elastic::energy_linear(hooke, e);
                assert!(
                    psi >= 0.0 && psi <= total * (1.0 + 1e-12),
                    "{e:?}: psi+ {psi} of {total}"
                );
            }
        }
        // in-plane biaxial compression thickens the plate: tensile energy
        // μ ε_zz² with ε_zz, none in plane
        let e = [-1e-3, -1e-3, 0.0];
        let ezz = m.strain_zz(e);
        let (with_zz, _, _) = miehe_split(m.lambda, m.mu, e, ezz);
        assert!(
            (with_zz - m.mu * ezz * ezz).abs() < 1e-9 * with_zz,
            "{with_zz}"
        );
        let (in_plane, _, _) = miehe_split(m.c12, m.mu, e, 0.0);
        assert_eq!(in_plane, 0.0);
    }

    #[test]
    fn neo_hookean_small_strain_matches_hooke() {
        let lin = steel(MaterialModel::LinearElastic, PlaneKind::PlaneStrain);
        let neo = steel(MaterialModel::NeoHookean, PlaneKind::PlaneStrain);
        let e = 1e-6;
        let (s, _) = neo.neo_hookean([[1.0 + e, 0.5 * e], [0.5 * e, 1.0 - 0.5 * e]]);
        let h = lin.hooke([e, -0.5 * e, 0.5 * e]);
        for k in 0..3 {
            assert!(
                (s[k] - h[k]).abs() < 1e-4 * 200e9 * e,
                "{k}: {} vs {}",
                s[k],
                h[k]
            );
        }
        // energy density of the unstrained state is zero
        assert_eq!(neo.energy_neo_hookean([[1.0, 0.0], [0.0, 1.0]]), 0.0);
    }

    /// In 3D: neo-Hookean at small strain is Hooke's law, a plane-strain F
    /// (F_zz = 1) gives the 2D stresses, and energies agree.
    #[test]
    fn three_d_laws_agree_with_hooke_and_with_plane_strain() {
        let lin = steel(MaterialModel::LinearElastic, PlaneKind::PlaneStrain);
        let neo = steel(MaterialModel::NeoHookean, PlaneKind::PlaneStrain);
        let e = 1e-6;
        // F = I + ε with a symmetric small ε (Voigt xx, yy, zz, yz, xz, xy)
        let eps = [e, -0.3 * e, 0.2 * e, 0.4 * e, -0.1 * e, 0.25 * e];
        let f = [
            [1.0 + eps[0], eps[5], eps[4]],
            [eps[5], 1.0 + eps[1], eps[3]],
            [eps[4], eps[3], 1.0 + eps[2]],
        ];
        let (s, j) = neo.neo_hookean_3d(f);
        let h = lin.hooke_3d(eps);
        for k in 0..6 {
            assert!(
                (s[k] - h[k]).abs() < 1e-4 * 200e9 * e,
                "{k}: {} vs {}",
                s[k],
                h[k]
            );
        }
        assert!(
            (j - det3(f)).abs() < 1e-15 && (j - 1.0 - (eps[0] + eps[1] + eps[2])).abs() < 1e-11
        );
        let psi = Elastic::energy_linear_3d(h, eps);
        assert!(
            (neo.energy_neo_hookean_3d(f) - psi).abs() < 1e-3 * psi,
            "energies"
        );
        // plane strain: the 3D law on (F, F_zz = 1) is the 2D law
        let f2 = [[1.01, 0.02], [-0.015, 0.98]];
        let (s2, j2) = neo.neo_hookean(f2);
        let (s3, j3) =
            neo.neo_hookean_3d([[1.01, 0.02, 0.0], [-0.015, 0.98, 0.0], [0.0, 0.0, 1.0]]);
        assert!((j2 - j3).abs() < 1e-15);
        for (a, b) in [(s2[0], s3[0]), (s2[1], s3[1]), (s2[2], s3[5])] {
            assert!((a - b).abs() < 1e-6 * a.abs().max(1.0), "{a} vs {b}");
        }
        assert_eq!((s3[3], s3[4]), (0.0, 0.0));
        assert!(
            (neo.energy_neo_hookean(f2)
                - neo.energy_neo_hookean_3d([
                    [1.01, 0.02, 0.0],
                    [-0.015, 0.98, 0.0],
                    [0.0, 0.0, 1.0]
                ]))
            .abs()
                < 1e-3
        );
        let e2 = [1e-4, -2e-4, 5e-5];
        let (h2, h3) = (
            lin.hooke(e2),
            lin.hooke_3d([e2[0], e2[1], 0.0, 0.0, 0.0, e2[2]]),
        );
        assert_eq!([h2[0], h2[1], h2[2]], [h3[0], h3[1], h3[5]]);
    }

    /// The 3D split sums to Hooke's law, ψ⁺ = ½ σ⁺ : ε, pure compression
    /// has no tensile energy, and a plane strain state splits as the 2D
    /// split does.
    #[test]
    fn miehe_split_3d_sums_to_hooke_and_agrees_with_plane_strain() {
        let (lambda, mu) = (1.2e9, 0.8e9);
        let m = Elastic {
            lambda,
            mu,
            ..steel(MaterialModel::LinearElastic, PlaneKind::PlaneStrain)
        };
        let dot = |s: [f64; 6], e: [f64; 6]| {
            s[0] * e[0]
                + s[1] * e[1]
                + s[2] * e[2]
                + 2.0 * (s[3] * e[3] + s[4] * e[4] + s[5] * e[5])
        };
        for e in [
            [1e-3, -2e-4, 4e-4, 1e-4, -3e-4, 3e-4],
            [-1e-3, -5e-4, -2e-4, 1e-4, 0.0, 2e-4],
            [2e-3, 2e-3, 2e-3, 0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0, 5e-4, 0.0, 0.0],
        ] {
            let (psi, sp, sn) = super::miehe_split_3d(lambda, mu, e);
            let hooke = m.hooke_3d(e);
            for k in 0..6 {
                assert!((sp[k] + sn[k] - hooke[k]).abs() < 1e-9 * 1e7, "{e:?}: {k}");
            }
            let total = 0.5 * dot(hooke, e);
            assert!(psi >= 0.0 && psi <= total + 1e-9, "{e:?}: {psi} of {total}");
            let half = 0.5 * dot(sp, e);
            assert!(
                (psi - half).abs() < 1e-9 * total.max(1.0),
                "{e:?}: {psi} vs {half}"
            );
        }
        let (psi, sp, _) = super::miehe_split_3d(lambda, mu, [-1e-3, -1e-3, -2e-4, 0.0, 0.0, 0.0]);
        assert_eq!(psi, 0.0);
        assert_eq!(sp, [0.0; 6]);
        // plane strain: ε_zz = ε_yz = ε_xz = 0
        let e2 = [1e-3, -2e-4, 3e-4];
        let (p2, sp2, sn2) = super::miehe_split(lambda, mu, e2, 0.0);
        let (p3, sp3, sn3) =
            super::miehe_split_3d(lambda, mu, [e2[0], e2[1], 0.0, 0.0, 0.0, e2[2]]);
        assert!((p2 - p3).abs() < 1e-12 * p2);
        for (a, b) in [(0, 0), (1, 1), (2, 5)] {
            assert!((sp2[a] - sp3[b]).abs() < 1e-9 * 1e7 && (sn2[a] - sn3[b]).abs() < 1e-9 * 1e7);
        }
    }
}
