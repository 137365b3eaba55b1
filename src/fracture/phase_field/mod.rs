//! Phase-field fracture (Kakouris & Triantafyllou, seed 001): 2nd-order and
//! 4th-order anisotropic crack density functionals.
//!
//! So far: the anisotropy tensor and the effective surface energy Gc(θ)
//! (eq. 8), [`anisotropy`]. The staggered implicit solve is next.

pub mod anisotropy;
