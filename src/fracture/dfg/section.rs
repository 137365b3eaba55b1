//! DFG partitioning's scene section: the `[dfg]` table, its types (serde,
//! as the scene file names them) and its checks, which
//! [`crate::scene::Scene::validate`] calls.

use crate::scene::Checker;
use serde::{Deserialize, Serialize};

/// Options of damage-field-gradient partitioning (Homel & Herbold 2017, section 2).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DfgSpec {
    /// Separability threshold D_min of section 2.3, in (0, 1): the two
    /// sides of a node separate only where one particle is fully damaged
    /// and both sides' mean damage exceeds it.
    #[serde(default = "default_separability")]
    pub separability: f64,
    /// Coulomb friction μ between the two sides (crack faces, self-contact).
    #[serde(default)]
    pub friction: f64,
    /// Kernel radius of the damage field (eq. 18) in cell diagonals
    /// (the paper: 1, one cell diagonal).
    #[serde(default = "default_radius")]
    pub radius: f64,
    /// The neighbour lists are rebuilt when a particle has moved this
    /// fraction of the kernel radius since the last build (section 2.5).
    #[serde(default = "default_rebuild_fraction")]
    pub rebuild_fraction: f64,
    /// Self-contact (section 2.4): particles whose kernel sum (eq. 19,
    /// over their own body) is below `surface_threshold` times the
    /// interior value are surface particles, and max(s_p, D_p) builds the
    /// field, so one body can slide on itself and on others. The default
    /// 0.99 flags every particle whose kernel reaches past the surface, a
    /// layer as thick as the kernel radius (the paper's choice); it must
    /// be at least two particles thick for the two sides of a contact to
    /// be separable one node into either body.
    #[serde(default)]
    pub self_contact: bool,
    #[serde(default = "default_surface_threshold")]
    pub surface_threshold: f64,
}

fn default_separability() -> f64 {
    0.25
}
fn default_radius() -> f64 {
    1.0
}
fn default_rebuild_fraction() -> f64 {
    0.1
}
fn default_surface_threshold() -> f64 {
    0.99
}

/// Checks the `[dfg]` table: its ranges, the contact groups it can split
/// (two fields each, out of `max_groups`), and that something can be
/// partitioned (`any_fracture`: a body's material has a fracture model).
pub(crate) fn check(
    c: &mut Checker,
    dfg: &DfgSpec,
    groups: usize,
    max_groups: usize,
    any_fracture: bool,
) {
    c.in_range("dfg.separability", dfg.separability, 0.0, 1.0);
    c.in_range("dfg.friction", dfg.friction, 0.0, 1e3);
    c.in_range("dfg.radius", dfg.radius, 0.5, 4.0);
    c.in_range("dfg.rebuild_fraction", dfg.rebuild_fraction, 0.0, 1.0);
    c.in_range("dfg.surface_threshold", dfg.surface_threshold, 0.0, 1.0);
    if groups > max_groups / 2 {
        c.err(
            "dfg",
            format!(
                "{groups} contact groups; with DFG partitioning at most {} are supported",
                max_groups / 2
            ),
        );
    }
    if !any_fracture && !dfg.self_contact {
        c.err("dfg", "partitioning needs a material with damage or a phase field, or dfg.self_contact = true: nothing would be partitioned");
    }
}
