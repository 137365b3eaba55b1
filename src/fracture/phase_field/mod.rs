//! Phase-field fracture (Kakouris & Triantafyllou): 2nd-order and
//! 4th-order anisotropic crack density functionals.
//!
//! The anisotropy tensor and the effective surface energy Gc(θ) (eq. 8),
//! [`anisotropy`]; the assembled system of eq. 57 with its sparse Cholesky
//! solve and the fracture energy, [`system`]. The coupling to the explicit
//! step (staggered loop, history, degradation) is [`model`], the phase
//! field's [`crate::fracture::model::FractureModel`].

pub mod anisotropy;
pub mod model;
pub mod multigrid;
pub mod ordering;
pub mod section;
pub mod split;
pub mod system;
pub mod trisolve;

/// Particles with c below this are cracked: the set whose farthest point
/// is the crack tip, and, with `[dfg]`, the "fully damaged" particles of
/// the partitioning (see [`dfg_damage`]).
pub const CRACKED_C: f64 = 0.1;

/// The damage a phase-field particle contributes to DFG partitioning
/// (Homel & Herbold 2017, eqs. 17–21): 1 − c scaled so that a cracked particle
/// (c ≤ [`CRACKED_C`]) is fully damaged, d = min(1, (1 − c)/(1 − CRACKED_C)).
pub fn dfg_damage(c: f64) -> f64 {
    ((1.0 - c) / (1.0 - CRACKED_C)).clamp(0.0, 1.0)
}
