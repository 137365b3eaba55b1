//! The damage particle method of Wei & Chen: a Galerkin meshfree method
//! whose particles carry the unknowns, with reproducing-kernel shape
//! functions ([`rk`]) and stabilized conforming nodal integration
//! ([`scni`]). It has no background grid (no P2G or G2P) and plugs in at
//! the method seam ([`crate::run::Method`]) beside the grid MPM.
//!
//! Built so far (issue 35's first slices): the discretisation, verified by
//! the reproducing conditions and the patch test; explicit central
//! differences ([`explicit`]) with held particles (singular kernels) and
//! the damage of [`damage`] with its energy regularisation, verified on
//! the paper's bar; its scene section ([`section`]: `method =
//! "damage_particle"`) and its [`crate::run::Method`] ([`method`]); the
//! static solve of the paper's quasi-static bar ([`implicit`]).
//! docs/dpm.md keeps the record.

pub mod crack;
pub mod damage;
pub mod explicit;
pub mod implicit;
pub mod method;
pub mod rk;
pub mod scni;
pub mod section;

/// SplitMix64's finaliser (Steele, Lea & Flood 2014): a well-mixed 64-bit
/// value of `s`, for the fixed pseudo-random sequences indexed by particle
/// (the jittered arrangement, the power method's start): the same value
/// for the same index on any run and thread count.
pub(crate) fn mix(mut s: u64) -> u64 {
    s = (s ^ (s >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    s = (s ^ (s >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    s ^ (s >> 31)
}
