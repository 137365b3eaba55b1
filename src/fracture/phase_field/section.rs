//! The phase field's scene section: a material's `phase_field` table, its
//! types (serde, as the scene file names them) and its checks, which
//! [`crate::scene::Scene::validate`] calls with the material's field path.

use super::anisotropy::{Gamma, Gamma3};
use crate::material::{MaterialModel, PlaneKind};
use crate::scene::Checker;
use serde::{Deserialize, Serialize};

/// Phase-field fracture parameters (Kakouris & Triantafyllou).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PhaseFieldSpec {
    /// Ḡc of the functional, J/m² (N/m). For γ = 0 it is the fracture energy.
    pub gc: f64,
    /// Length scale l₀, m.
    pub l0: f64,
    /// Residual stiffness k_f of g(c) = (1 − k_f) c² + k_f, in [0, 1).
    #[serde(default)]
    pub k_f: f64,
    /// The anisotropy tensor in Voigt form. 2D: [γ1111, γ2222, γ1122,
    /// γ1212] or with [γ1112, γ2212] appended; 3D: 9 numbers (orthotropic:
    /// γ1111, γ2222, γ3333, γ1122, γ1133, γ2233, γ2323, γ1313, γ1212) or the
    /// 21 entries of the 6 × 6 matrix's upper triangle
    /// ([`super::anisotropy::Gamma3`]); absent or all zero: 2nd order.
    #[serde(default)]
    pub gamma: Vec<f64>,
    /// Material angle φ, degrees counter-clockwise from x.
    #[serde(default)]
    pub angle: f64,
    /// How the tensile energy ψ⁺ of Miehe's split sees a plane-stress
    /// particle (no effect, and rejected, in plane strain).
    #[serde(default)]
    pub plane_stress_split: PlaneStressSplit,
    /// The particle volumes the functional is integrated over: eq. 57's
    /// assembly, Ψ_f and the stagger residual.
    #[serde(default)]
    pub volumes: PhaseFieldVolumes,
}

/// Which volume V_p a particle brings to the phase field's integrals.
/// Kakouris & Triantafyllou integrate the functional by the particles
/// (eq. 57) without saying which volume; the crack density of Bourdin et
/// al.'s functional is defined on the body, and an opened crack's band
/// of broken particles stretches (V_p = J V_p⁰ grows) where the material
/// has parted: docs/phase-field.md, "P3 (i): the present volumes against
/// the reference ones".
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseFieldVolumes {
    /// The present volume J V_p⁰, as the momentum equation uses (the
    /// default).
    #[default]
    Present,
    /// The reference volume V_p⁰: the functional over the undeformed body.
    Reference,
}

/// Miehe's spectral split in plane stress, where Kakouris & Triantafyllou do not say
/// which strain it decomposes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PlaneStressSplit {
    /// The 3D strain, with ε_zz = −ν/(1−ν)(εxx + εyy) as a third
    /// principal strain (Miehe et al. 2010's split of the 3D state): an
    /// in-plane compression thickens the plate, and μ⟨ε_zz⟩₊² is tensile
    /// energy that can damage it.
    #[default]
    WithZz,
    /// The in-plane strain alone, with the plane-stress modulus
    /// λ* = 2λμ/(λ + 2μ) (the 2D split many plane-stress codes use): the
    /// thickness strain drives no damage.
    InPlane,
}

/// The anisotropy tensor of a phase-field spec (not yet rotated).
pub fn phase_field_gamma(pf: &PhaseFieldSpec) -> Gamma {
    let g = |k: usize| pf.gamma.get(k).copied().unwrap_or(0.0);
    Gamma {
        g1111: g(0),
        g2222: g(1),
        g1122: g(2),
        g1212: g(3),
        g1112: g(4),
        g2212: g(5),
    }
}

/// Checks a material's phase-field table (`path` is the material's
/// field path; its `model`, the scene's `plane` and its dimension `dim`
/// constrain it).
pub(crate) fn check(
    c: &mut Checker,
    path: &str,
    pf: &PhaseFieldSpec,
    model: MaterialModel,
    plane: PlaneKind,
    dim: usize,
) {
    let q = format!("{path}.phase_field");
    c.positive(&format!("{q}.gc"), pf.gc);
    c.positive(&format!("{q}.l0"), pf.l0);
    if c.finite(&format!("{q}.k_f"), pf.k_f) && !(0.0..1.0).contains(&pf.k_f) {
        c.err(
            &format!("{q}.k_f"),
            format!("must be in [0, 1), got {}", pf.k_f),
        );
    }
    c.finite(&format!("{q}.angle"), pf.angle);
    if dim == 3 {
        match Gamma3::from_list(&pf.gamma) {
            None => c.err(
                &format!("{q}.gamma"),
                format!(
                    "give 9 numbers in 3D (orthotropic: g1111, g2222, g3333, g1122, g1133, g2233, \
                     g2323, g1313, g1212) or the 21 of the 6 x 6 matrix's upper triangle, got {}",
                    pf.gamma.len()
                ),
            ),
            // no list: the 2nd order (g = 0), nothing to search
            Some(_) if pf.gamma.is_empty() => {}
            Some(g) => {
                if pf
                    .gamma
                    .iter()
                    .enumerate()
                    .all(|(k, g)| c.finite(&format!("{q}.gamma[{k}]"), *g))
                    && g.extremes().0 .0 < 0.0
                {
                    c.err(&format!("{q}.gamma"), "the crack-profile coefficient a(n) is negative for some direction: the functional is unbounded below");
                }
            }
        }
    } else if !(pf.gamma.is_empty() || pf.gamma.len() == 4 || pf.gamma.len() == 6) {
        c.err(
            &format!("{q}.gamma"),
            format!(
                "give 4 or 6 numbers [g1111, g2222, g1122, g1212, (g1112, g2212)], got {}",
                pf.gamma.len()
            ),
        );
    } else if pf
        .gamma
        .iter()
        .enumerate()
        .all(|(k, g)| c.finite(&format!("{q}.gamma[{k}]"), *g))
    {
        let g = phase_field_gamma(pf);
        if g.min_along() < 0.0 {
            c.err(&format!("{q}.gamma"), "the crack-profile coefficient a(n) is negative for some direction: the functional is unbounded below");
        }
    }
    if model != MaterialModel::LinearElastic {
        c.err(
            &format!("{path}.model"),
            "phase-field fracture is implemented for linear_elastic materials",
        );
    }
    if pf.plane_stress_split != PlaneStressSplit::WithZz && plane != PlaneKind::PlaneStress {
        c.err(&format!("{q}.plane_stress_split"), "applies to analysis.plane = \"plane_stress\" only (plane strain has no thickness strain)");
    }
}
