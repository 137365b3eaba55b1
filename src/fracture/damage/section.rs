//! The damage model's scene section: a material's `damage` table, its
//! types (serde, as the scene file names them), its checks and the
//! constants derived from it, which [`crate::scene::Scene::validate`]
//! resolves with the material's field path.

use crate::material::MaterialModel;
use crate::scene::Checker;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum DamageModel {
    /// Rankine with linear strain softening scaled by the characteristic
    /// length (eq. 23, Cervera et al.): dissipates G_f per unit crack area.
    Rankine,
    /// Time to failure (eq. 24): once the strength is exceeded, damage
    /// grows at Δt/τ with τ = l_ch / c_f (a crack crosses a particle at c_f).
    TimeToFailure,
}

/// Damage parameters (Homel & Herbold 2017, section 2.7).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DamageSpec {
    pub model: DamageModel,
    /// Tensile strength σ_f (the Weibull median at the reference volume), Pa.
    pub strength: f64,
    /// Mode I fracture energy G_f, J/m² (rankine).
    #[serde(default)]
    pub fracture_energy: Option<f64>,
    /// Crack speed c_f, m/s (time_to_failure).
    #[serde(default)]
    pub crack_speed: Option<f64>,
    /// Characteristic length l_ch, m; default the cell diagonal (as in the
    /// paper): h√2 in 2D, h√3 in 3D.
    #[serde(default)]
    pub char_length: Option<f64>,
    /// Size-dependent random strength (eq. 25).
    #[serde(default)]
    pub weibull: Option<WeibullSpec>,
}

/// Weibull strength: σ_f/σ̄_f = (V̄/V · ln R / ln ½)^(1/m), R uniform in (0, 1).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct WeibullSpec {
    /// Weibull modulus m.
    pub modulus: f64,
    /// Reference volume V̄ of the median strength, m³.
    pub ref_volume: f64,
    /// Seed of the random generator (same seed, same strengths).
    #[serde(default)]
    pub seed: u64,
}

/// A damage model with the constants the update uses (Homel & Herbold 2017, section 2.7).
#[derive(Debug, Clone, PartialEq)]
pub struct ResolvedDamage {
    pub model: DamageModel,
    /// σ̄_f, Pa.
    pub strength: f64,
    /// l_ch, m (given, or the cell diagonal: h√2 in 2D, h√3 in 3D).
    pub char_length: f64,
    /// Rankine: the scaled softening modulus H_s = H̄ l/(1 − H̄ l) of eq. 23,
    /// H̄ = σ_f²/(2 E G_f). Zero for time to failure.
    pub softening: f64,
    /// Time to failure: τ = l_ch / c_f, s. Zero for Rankine.
    pub tau: f64,
    pub weibull: Option<WeibullSpec>,
}

/// Checks a material's damage table (`q` is its field path) and derives
/// its constants; `h` is the cell size and `dim` the scene's dimension:
/// the default l_ch is the cell's diagonal, h√2 in 2D (the paper's choice,
/// Homel & Herbold 2017 section 2.7) and h√3 in 3D: a cell's extent across
/// a crack of any orientation is at most its diagonal, the space diagonal
/// in 3D, so a band one cell wide is at most that wide. A crack along the
/// cells' faces opens a narrower band (about h with GIMP in one velocity
/// field, `docs/verification.md` "Damage in 3D"), where the default
/// dissipates less than G_f per area; `char_length` sets the band width.
pub(crate) fn resolve(
    c: &mut Checker,
    q: &str,
    d: &DamageSpec,
    model: MaterialModel,
    youngs_modulus: f64,
    h: f64,
    dim: usize,
) -> Option<ResolvedDamage> {
    let before = c.errors.len();
    c.positive(&format!("{q}.strength"), d.strength);
    let char_length = match d.char_length {
        Some(l) => {
            c.positive(&format!("{q}.char_length"), l);
            l
        }
        None if dim == 3 => h * 3f64.sqrt(),
        None => h * std::f64::consts::SQRT_2,
    };
    if model != MaterialModel::LinearElastic {
        c.err(
            &format!("{q}.model"),
            "damage models are implemented for linear_elastic materials (the damaged neo-Hookean energy is not)",
        );
    }
    let (mut softening, mut tau) = (0.0, 0.0);
    match d.model {
        DamageModel::Rankine => {
            if d.crack_speed.is_some() {
                c.err(
                    &format!("{q}.crack_speed"),
                    "belongs to model = \"time_to_failure\", not rankine",
                );
            }
            match d.fracture_energy {
                None => c.err(
                    &format!("{q}.fracture_energy"),
                    "the rankine model needs the fracture energy G_f, J/m²",
                ),
                Some(gf) => {
                    if c.positive(&format!("{q}.fracture_energy"), gf)
                        && d.strength > 0.0
                        && youngs_modulus > 0.0
                    {
                        let hb =
                            d.strength * d.strength / (2.0 * youngs_modulus * gf) * char_length;
                        if hb >= 1.0 {
                            c.err(
                                &format!("{q}.char_length"),
                                format!(
                                    "σ_f² l_ch / (2 E G_f) = {hb:.3} ≥ 1: the softening branch snaps back; \
                                     use a smaller char_length or cell size, or a larger fracture_energy"
                                ),
                            );
                        } else {
                            softening = hb / (1.0 - hb);
                        }
                    }
                }
            }
        }
        DamageModel::TimeToFailure => {
            if d.fracture_energy.is_some() {
                c.err(
                    &format!("{q}.fracture_energy"),
                    "belongs to model = \"rankine\", not time_to_failure",
                );
            }
            match d.crack_speed {
                None => c.err(
                    &format!("{q}.crack_speed"),
                    "the time_to_failure model needs the crack speed c_f, m/s",
                ),
                Some(cf) => {
                    if c.positive(&format!("{q}.crack_speed"), cf) {
                        tau = char_length / cf;
                    }
                }
            }
        }
    }
    if let Some(w) = &d.weibull {
        c.positive(&format!("{q}.weibull.modulus"), w.modulus);
        c.positive(&format!("{q}.weibull.ref_volume"), w.ref_volume);
    }
    (c.errors.len() == before).then(|| ResolvedDamage {
        model: d.model,
        strength: d.strength,
        char_length,
        softening,
        tau,
        weibull: d.weibull.clone(),
    })
}
