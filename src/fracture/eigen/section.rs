//! The eigen models' scene section: a material's `eigen` table, its checks
//! and the constants derived from it, which
//! [`crate::scene::Scene::validate`] resolves with the material's field
//! path.
//!
//! ```toml
//! eigen = { model = "erosion", fracture_energy = 1.0e-4, epsilon = 0.05 }
//! eigen = { model = "softening", strength = 3.0e6, fracture_energy = 100.0,
//!           epsilon = 0.02, band_width = 0.01 }
//! ```

use super::softening::SofteningLaw;
use crate::material::{MaterialModel, PlaneKind};
use crate::scene::schema::MaterialSpec;
use crate::scene::Checker;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum EigenModel {
    /// Eigenerosion (Pandolfi & Ortiz; Molinos et al. eqs. 11–12): a point
    /// fails outright when the energy its ε-neighbourhood would release
    /// reaches G_c.
    Erosion,
    /// Eigensoftening (Navas et al.; Molinos et al. eqs. 13–20, Algorithm
    /// 2): a point starts to soften when its ε-neighbourhood's mean
    /// principal stress passes f_t, then follows a linear cohesive law to
    /// the critical opening.
    Softening,
}

impl EigenModel {
    /// As the scene spells it.
    pub fn name(self) -> &'static str {
        match self {
            EigenModel::Erosion => "erosion",
            EigenModel::Softening => "softening",
        }
    }
}

/// A material's `eigen` table.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct EigenSpec {
    pub model: EigenModel,
    /// The radius ε of the neighbourhood, m. No default: it is the
    /// model's length scale (the paper's convergence is in ε → 0 with the
    /// particle spacing well below ε).
    #[serde(default)]
    pub epsilon: Option<f64>,
    /// G_c (erosion) or G_F (softening), J/m².
    pub fracture_energy: f64,
    /// Tensile strength f_t, Pa (softening).
    #[serde(default)]
    pub strength: Option<f64>,
    /// The band width h_ε over which a softening point's strain is taken
    /// as the crack's opening (eq. 19), m; default the cell size (the
    /// width over which the grid resolves a jump of velocity, so that a
    /// crack opens a band about one cell wide).
    #[serde(default)]
    pub band_width: Option<f64>,
}

/// An eigen model with the constants the stage uses.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ResolvedEigen {
    pub model: EigenModel,
    /// ε, m.
    pub epsilon: f64,
    /// G_c or G_F, J/m².
    pub fracture_energy: f64,
    /// Softening: the law (f_t, w_c = 2G_F/f_t, h_ε); None for erosion.
    pub softening: Option<SofteningLaw>,
    /// Erosion: κ, the share of G that 2εψ̄_ε reads at a crack tip
    /// ([`super::tip_ball_factor`]); C_ε = 2ερ/κ. 1 for softening.
    pub tip_factor: f64,
}

/// Checks a material's eigen table (`q` is its field path) and derives its
/// constants; `h` is the cell size, `plane` the 2D analysis and `dim` the
/// scene's dimension.
pub(crate) fn resolve(
    c: &mut Checker,
    q: &str,
    e: &EigenSpec,
    material: &MaterialSpec,
    plane: PlaneKind,
    h: f64,
    dim: usize,
) -> Option<ResolvedEigen> {
    let before = c.errors.len();
    if material.model != MaterialModel::LinearElastic {
        c.err(
            &format!("{q}.model"),
            "the eigen models are implemented for linear_elastic materials (their released energy is the small-strain energy)",
        );
    }
    let epsilon = match e.epsilon {
        None => {
            c.err(
                &format!("{q}.epsilon"),
                format!(
                    "the {} model needs the neighbourhood radius ε, m (several particle spacings, e.g. {:.3e} = two cells)",
                    e.model.name(),
                    2.0 * h
                ),
            );
            0.0
        }
        Some(eps) => {
            c.positive(&format!("{q}.epsilon"), eps);
            eps
        }
    };
    c.positive(&format!("{q}.fracture_energy"), e.fracture_energy);
    let softening = match e.model {
        EigenModel::Erosion => {
            for (key, given) in [
                ("strength", e.strength.is_some()),
                ("band_width", e.band_width.is_some()),
            ] {
                if given {
                    c.err(
                        &format!("{q}.{key}"),
                        "belongs to model = \"softening\", not erosion",
                    );
                }
            }
            None
        }
        EigenModel::Softening => {
            let band = match e.band_width {
                Some(b) => {
                    c.positive(&format!("{q}.band_width"), b);
                    b
                }
                None => h,
            };
            match e.strength {
                None => {
                    c.err(
                        &format!("{q}.strength"),
                        "the softening model needs the tensile strength f_t, Pa",
                    );
                    None
                }
                Some(ft) => c
                    .positive(&format!("{q}.strength"), ft)
                    .then(|| SofteningLaw::linear(ft, e.fracture_energy, band)),
            }
        }
    };
    let tip_factor = match e.model {
        EigenModel::Erosion => super::tip_ball_factor(material.poissons_ratio, plane, dim),
        EigenModel::Softening => 1.0,
    };
    (c.errors.len() == before).then_some(ResolvedEigen {
        model: e.model,
        epsilon,
        fracture_energy: e.fracture_energy,
        softening,
        tip_factor,
    })
}
