//! Constitutive models, evaluated per particle in the G2P stage.
//!
//! - Linear elastic small strain (Hooke's law) in plane strain
//!   (σ_zz = λ(ε_xx + ε_yy)) and plane stress (σ_zz = 0), updated
//!   incrementally: ε ← ε + Δt·sym(L), which leaves rigid rotations free of
//!   strain (the update-stress-last scheme of Sulsky et al. 1994).
//! - Compressible neo-Hookean (plane strain, F_zz = 1):
//!   σ = μ/J (F Fᵀ − I) + λ ln J / J · I, ψ = μ/2 (tr C − 3) − μ ln J + λ/2 (ln J)².

use crate::scene::{MaterialModel, PlaneKind, ResolvedMaterial};

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

impl Elastic {
    pub fn new(m: &ResolvedMaterial, plane: PlaneKind) -> Elastic {
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

    /// Neo-Hookean Cauchy stress (xx, yy, xy) and J for F = (F11, F12, F21, F22).
    #[inline(always)]
    pub fn neo_hookean(&self, f: [f64; 4]) -> ([f64; 3], f64) {
        let j = f[0] * f[3] - f[1] * f[2];
        let b = [f[0] * f[0] + f[1] * f[1], f[2] * f[2] + f[3] * f[3], f[0] * f[2] + f[1] * f[3]];
        let lnj = j.ln();
        let a = self.mu / j;
        let p = self.lambda * lnj / j;
        ([a * (b[0] - 1.0) + p, a * (b[1] - 1.0) + p, a * b[2]], j)
    }

    /// Out-of-plane stress σ_zz.
    pub fn stress_zz(&self, stress: [f64; 3], strain: Option<[f64; 3]>, def_grad: Option<[f64; 4]>) -> f64 {
        match (self.model, self.plane) {
            (_, PlaneKind::PlaneStress) => 0.0,
            (MaterialModel::LinearElastic, PlaneKind::PlaneStrain) => {
                let e = strain.unwrap_or([0.0; 3]);
                self.lambda * (e[0] + e[1])
            }
            (MaterialModel::NeoHookean, PlaneKind::PlaneStrain) => {
                let f = def_grad.unwrap_or([1.0, 0.0, 0.0, 1.0]);
                let j = f[0] * f[3] - f[1] * f[2];
                let _ = stress;
                self.lambda * j.ln() / j
            }
        }
    }

    /// Out-of-plane small strain ε_zz (plane stress: −ν/(1−ν)(εxx+εyy)).
    pub fn strain_zz(&self, e: [f64; 3]) -> f64 {
        match self.plane {
            PlaneKind::PlaneStrain => 0.0,
            PlaneKind::PlaneStress => -self.poissons_ratio / (1.0 - self.poissons_ratio) * (e[0] + e[1]),
        }
    }

    /// Strain energy density ψ, J/m³, of a linear elastic particle:
    /// ½ σ:ε (the zz terms vanish in both plane strain and plane stress).
    #[inline]
    pub fn energy_linear(stress: [f64; 3], e: [f64; 3]) -> f64 {
        0.5 * (stress[0] * e[0] + stress[1] * e[1] + 2.0 * stress[2] * e[2])
    }

    /// Neo-Hookean strain energy density for F (plane strain).
    pub fn energy_neo_hookean(&self, f: [f64; 4]) -> f64 {
        let j = f[0] * f[3] - f[1] * f[2];
        let trc = f[0] * f[0] + f[1] * f[1] + f[2] * f[2] + f[3] * f[3] + 1.0;
        let lnj = j.ln();
        0.5 * self.mu * (trc - 3.0) - self.mu * lnj + 0.5 * self.lambda * lnj * lnj
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

#[cfg(test)]
mod tests {
    use super::*;

    fn steel(model: MaterialModel, plane: PlaneKind) -> Elastic {
        let (e, nu) = (200e9, 0.3);
        let m = ResolvedMaterial {
            name: "s".into(),
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
    fn neo_hookean_small_strain_matches_hooke() {
        let lin = steel(MaterialModel::LinearElastic, PlaneKind::PlaneStrain);
        let neo = steel(MaterialModel::NeoHookean, PlaneKind::PlaneStrain);
        let e = 1e-6;
        let (s, _) = neo.neo_hookean([1.0 + e, 0.5 * e, 0.5 * e, 1.0 - 0.5 * e]);
        let h = lin.hooke([e, -0.5 * e, 0.5 * e]);
        for k in 0..3 {
            assert!((s[k] - h[k]).abs() < 1e-4 * 200e9 * e, "{k}: {} vs {}", s[k], h[k]);
        }
        // energy density of the unstrained state is zero
        assert_eq!(neo.energy_neo_hookean([1.0, 0.0, 0.0, 1.0]), 0.0);
    }
}
