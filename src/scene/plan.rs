//! The [`Plan`]: the stages a scene needs, built once from the scene. A
//! stage that no body or option asks for is not in the plan and its code
//! never runs.

use super::schema::{SceneFile, SideCondition};
use serde::Serialize;
use std::fmt;

/// One stage of the explicit step, in execution order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// The kernel damage field and its gradient at the particles, and the
    /// nodal gradient (seed 000 eqs. 17–19, Algorithm 1); only with `[dfg]`.
    DamageField,
    /// Assigns each particle–node pair a velocity field (one per contact
    /// group present at the node, each split in two by the damage-field
    /// gradient with `[dfg]`, Algorithm 2 and the separability rule); only
    /// with more than one contact group or with `[dfg]`.
    FieldPartition,
    /// Particle-to-grid: mass, momentum, internal and external force.
    P2g,
    /// Surface tractions on the outermost particles of traction sides.
    Traction,
    /// The implicit phase-field solve per body (seed 001): assemble
    /// K(H) c = F, factorize, solve, map c to the particles.
    PhaseField,
    /// Nodal momentum update and boundary conditions.
    GridUpdate,
    /// Frictional contact between velocity fields (Bardenhagen/Nairn).
    Contact,
    /// Grid-to-particle: velocity, position, velocity gradient, stress.
    G2p,
    /// Damage update and tensile stress degradation (seed 000 eqs. 23–27).
    Damage,
}

impl Stage {
    pub fn name(self) -> &'static str {
        match self {
            Stage::DamageField => "damage_field",
            Stage::FieldPartition => "field_partition",
            Stage::P2g => "p2g",
            Stage::Traction => "traction",
            Stage::PhaseField => "phase_field",
            Stage::GridUpdate => "grid_update",
            Stage::Contact => "contact",
            Stage::G2p => "g2p",
            Stage::Damage => "damage",
        }
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The stages of one step for a scene.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Plan {
    pub stages: Vec<Stage>,
}

impl Plan {
    pub(super) fn build(file: &SceneFile, contact_groups: &[u32]) -> Plan {
        let b = &file.grid.boundary;
        let traction = [&b.left, &b.right, &b.bottom, &b.top]
            .iter()
            .any(|s| matches!(s, SideCondition::Traction { .. }));
        let dfg = file.dfg.is_some();
        let contact = contact_groups.len() > 1 || dfg;
        let mut stages = Vec::new();
        if dfg {
            stages.push(Stage::DamageField);
        }
        if contact {
            stages.push(Stage::FieldPartition);
        }
        stages.push(Stage::P2g);
        if traction {
            stages.push(Stage::Traction);
        }
        let phase_field = file.bodies.iter().any(|b| {
            file.material_of(&b.material)
                .is_some_and(|m| m.phase_field.is_some())
        });
        if phase_field {
            stages.push(Stage::PhaseField);
        }
        stages.push(Stage::GridUpdate);
        if contact {
            stages.push(Stage::Contact);
        }
        stages.push(Stage::G2p);
        let damage = file.bodies.iter().any(|b| {
            file.material_of(&b.material)
                .is_some_and(|m| m.damage.is_some())
        });
        if damage {
            stages.push(Stage::Damage);
        }
        Plan { stages }
    }

    pub fn has(&self, stage: Stage) -> bool {
        self.stages.contains(&stage)
    }

    /// Stage names in order.
    pub fn names(&self) -> Vec<&'static str> {
        self.stages.iter().map(|s| s.name()).collect()
    }
}

impl fmt::Display for Plan {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.names().join(" → "))
    }
}
