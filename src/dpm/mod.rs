//! The damage particle method of Wei & Chen: a Galerkin meshfree method
//! whose particles carry the unknowns, with reproducing-kernel shape
//! functions ([`rk`]) and stabilized conforming nodal integration
//! ([`scni`]). It has no background grid (no P2G or G2P) and plugs in at
//! the method seam ([`crate::run::Method`]) beside the grid MPM.
//!
//! Built so far (issue 35's first slice): the discretisation, verified by
//! the reproducing conditions and the patch test. The method itself (its
//! scene section, time stepping, boundary conditions, damage with the
//! energy regularisation) comes next; docs/dpm.md keeps the record.

pub mod damage;
pub mod explicit;
pub mod rk;
pub mod scni;
