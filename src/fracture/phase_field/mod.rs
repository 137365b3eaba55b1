//! Phase-field fracture (Kakouris & Triantafyllou, seed 001): 2nd-order and
//! 4th-order anisotropic crack density functionals.
//!
//! So far: the anisotropy tensor and the effective surface energy Gc(θ)
//! (eq. 8), [`anisotropy`]; the assembled system of eq. 57 with its sparse
//! Cholesky solve and the fracture energy, [`system`]. The coupling to the
//! explicit step (staggered loop, history, degradation) is next.

pub mod anisotropy;
pub mod system;
