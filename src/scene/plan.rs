//! The [`Plan`]: the ordered stages of one explicit step, built once from
//! the scene. The step executes this list and nothing else
//! ([`crate::mpm::Simulation`] walks it and times each entry), so what
//! `cleave validate` prints is what runs: a stage that no body or option
//! asks for is not in the plan and its code never runs.

use super::schema::{MethodKind, SceneFile, SideCondition, StressUpdate};
use crate::dpm::section::Integration;
use crate::grid::shape::ShapeFunctionKind;
use serde::{Deserialize, Serialize};
use std::fmt;

/// One stage of the explicit step. The variants are listed in the order a
/// step runs them; a plan holds a subsequence of this order. Saved and
/// printed by its [`name`](Stage::name) (so a checkpoint's layout does not
/// change when a stage is added).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Stage {
    /// Every particle's support evaluated once, at the step's start
    /// positions, and kept for the step's transfers, which read it back
    /// until the particle moves (the same bits as evaluating it again).
    /// Only with `shape_function = "lme"`, whose evaluation is two Newton
    /// solves.
    Supports,
    /// The kernel damage field and its gradient at the particles, and the
    /// nodal gradient (Homel & Herbold 2017, eqs. 17–19, Algorithm 1); only
    /// with `[dfg]`.
    DamageField,
    /// Assigns each particle–node pair a velocity field (one per contact
    /// group present at the node, each split in two by the damage-field
    /// gradient with `[dfg]`, Algorithm 2 and the separability rule; with
    /// explicit cracks, by the cracks the line from particle to node
    /// crosses, Nairn & Aimene's appendix); only with more than one
    /// contact group, `[dfg]` or explicit cracks.
    FieldPartition,
    /// Particle-to-grid: clears the nodes the last scatter wrote, then
    /// scatters mass, momentum, internal and external force.
    P2g,
    /// Surface tractions on the outermost particles of traction sides.
    Traction,
    /// Explicit cracks' face pressures: each loaded crack point's two
    /// surfaces push the material either side apart with P·A n̂, spread to
    /// the nodes of their own side's velocity field (Nairn & Aimene, eqs.
    /// 7–8). Only with a crack that has a `pressure`.
    CrackTraction,
    /// The implicit phase-field solve per body (Kakouris & Triantafyllou):
    /// assemble K(H) c = F, factorize, solve, map c to the particles
    /// (skipped inside when the last stagger already solved this state).
    PhaseFieldSolve,
    /// Nodal momentum update and boundary conditions.
    GridUpdate,
    /// Newmark's predictor (Molinos et al., Algorithm 1, steps 2–3): the
    /// nodal velocities of the scattered Σ N m_p (v_p + (1 − γ) Δt a_p),
    /// then the walls. Only with `stress_update = "newmark"`.
    NewmarkPredictor,
    /// Explicit cracks' first contact pass, on the scattered momenta
    /// (Nairn & Aimene §2.1.3, after Nairn, Bardenhagen & Smith 2018): the
    /// fields' velocities p/m before the forces' increment are corrected
    /// where a crack's faces are closed and approaching, and the
    /// correction is carried into the updated velocities; the particles'
    /// FLIP increment leaves it out. Only with explicit cracks and
    /// `[cramp] contact_passes = 2`.
    ContactMomenta,
    /// Frictional contact between velocity fields (Bardenhagen et al.
    /// 2001), then the walls again. Under Newmark, on the predictor's
    /// velocities: the particles move with the contacted predictor and
    /// take their strain from it (the corrector starts from the walled
    /// one).
    Contact,
    /// Update-stress-last grid-to-particle: velocity, position, velocity
    /// gradient and stress in one gather, then the particle guards.
    G2p,
    /// Modified USL, first gather: particle velocities and positions.
    G2pVelocity,
    /// Modified USL: the updated particle momenta scattered back to the
    /// grid (Sulsky et al. 1995), and the walls imposed on them.
    Remap,
    /// Modified USL, second gather: the velocity gradient from the
    /// remapped velocities, the stress, then the particle guards.
    G2pStress,
    /// Newmark's strain and stress (Algorithm 1, steps 4–6): the velocity
    /// gradient of the predictor velocities at the particles, which stay
    /// where they are until the step's last gather.
    NewmarkStress,
    /// The phase field's history H = max ψ⁺ and the degraded stress.
    PhaseFieldHistory,
    /// Damage update and tensile stress degradation (Homel & Herbold 2017,
    /// eqs. 23–27).
    Damage,
    /// Eigenerosion and eigensoftening (Molinos et al., eqs. 11–20,
    /// Algorithm 2): each point's ε-neighbourhood against G_c or f_t, the
    /// softening law, and the stress the point then carries.
    Eigen,
    /// Newmark's forces (Algorithm 1, step 7): the internal force of the
    /// stress just computed, −Σ V_p σ_p ∇N, added to the tractions.
    NewmarkForce,
    /// Newmark's corrector (Algorithm 1, step 8): v_I = v_I^pred +
    /// γ Δt (f_I/m_I + g), then the walls.
    NewmarkCorrector,
    /// Contact between the velocity fields of contact groups on the
    /// corrected velocities (Newmark with more than one group; the
    /// predictor's are contacted in `contact`), then the walls again: the
    /// particles' accelerations S(v̄ − v⁰)/(γΔt) carry the contact's
    /// impulse.
    NewmarkContact,
    /// Newmark's particle update (Algorithm 1, step 9, as docs/eigen.md
    /// reads it): a_p, v_p and x_p from the nodal accelerations and the
    /// predictor velocities, then the particle guards.
    NewmarkG2p,
    /// The particles that changed tile are re-binned (a no-op when none
    /// did).
    Rebin,
    /// Every `grid.resort_every` steps, the particle arrays are permuted
    /// into the bins' order (by tile, then by support), so that the
    /// scatter reads each tile's particles from one range again; later
    /// scatters may add in another order (results to round-off).
    Resort,
    /// The staggered scheme's residual; more phase-field solves and
    /// history updates while it is above the tolerance.
    PhaseFieldStagger,
    /// Explicit cracks: the crack surfaces move with the grid velocities of
    /// their own velocity fields, the crack plane with their mean (Nairn &
    /// Aimene, eqs. 3–6). Runs after the step's field slots are released,
    /// on the nodal fields the step left.
    CrackSurfaces,
    /// Explicit cracks that grow: each tip's J, K_I, K_II on its first
    /// contour, and a new segment in the maximum-hoop-stress direction
    /// where K_I^max reaches K_Ic (Nairn & Aimene, section 3.5). Only in
    /// a scene with `[cramp] growth`.
    CrackGrowth,
    /// The damage particle method (Wei & Chen; no grid): the first half
    /// of central differences, v ← v + Δt/2 a with the held components,
    /// then d ← d + Δt v.
    DpmAdvance,
    /// The damage particle method: each smoothing cell's strain by SCNI
    /// (eq. 37) and its elastic stress.
    DpmStrain,
    /// The damage particle method's damage (eqs. 2–6, 33): the degraded
    /// stress (eq. 35) and the candidates of criterion 27. Only with
    /// `[damage_particle.damage]`.
    DpmDamage,
    /// The damage particle method's tractions: the traction of each
    /// `traction` side at t + Δt on the outline faces facing it, spread to
    /// the particles by the shape functions at the faces' centres (the
    /// points SCNI integrates with), and its work over the step. Only
    /// with a traction side.
    DpmTraction,
    /// The damage particle method: the internal force (eq. 39), the
    /// accelerations, v ← v + Δt/2 a and the held components.
    DpmForce,
    /// The damage particle method's static solve (`integration =
    /// "static"`), first stage: the held components moved by Δt × their
    /// velocity at t + Δt/2, the tractions at t + Δt.
    DpmLoad,
    /// The damage particle method's static solve: iterations to
    /// equilibrium, each the strain (eq. 37), the damage it gives from the
    /// last step's history (eqs. 2–6, 33), the internal force (eq. 39)
    /// and a solve with the secant stiffness (faer's sparse Cholesky);
    /// then the candidates of criterion 27, the reactions and the work.
    DpmEquilibrium,
}

impl Stage {
    /// Every stage, in execution order: the order [`Plan::build`] takes
    /// (a new stage goes here, at its place, and gets its arm there).
    pub const ALL: [Stage; 35] = [
        Stage::Supports,
        Stage::DamageField,
        Stage::FieldPartition,
        Stage::P2g,
        Stage::Traction,
        Stage::CrackTraction,
        Stage::PhaseFieldSolve,
        Stage::GridUpdate,
        Stage::NewmarkPredictor,
        Stage::ContactMomenta,
        Stage::Contact,
        Stage::G2p,
        Stage::G2pVelocity,
        Stage::Remap,
        Stage::G2pStress,
        Stage::NewmarkStress,
        Stage::PhaseFieldHistory,
        Stage::Damage,
        Stage::Eigen,
        Stage::NewmarkForce,
        Stage::NewmarkCorrector,
        Stage::NewmarkContact,
        Stage::NewmarkG2p,
        Stage::Rebin,
        Stage::Resort,
        Stage::PhaseFieldStagger,
        Stage::CrackSurfaces,
        Stage::CrackGrowth,
        Stage::DpmAdvance,
        Stage::DpmStrain,
        Stage::DpmDamage,
        Stage::DpmTraction,
        Stage::DpmForce,
        Stage::DpmLoad,
        Stage::DpmEquilibrium,
    ];

    /// The stage of a [`name`](Stage::name).
    pub fn from_name(name: &str) -> Option<Stage> {
        Stage::ALL.into_iter().find(|s| s.name() == name)
    }

    pub fn name(self) -> &'static str {
        match self {
            Stage::Supports => "supports",
            Stage::DamageField => "damage_field",
            Stage::FieldPartition => "field_partition",
            Stage::P2g => "p2g",
            Stage::Traction => "traction",
            Stage::CrackTraction => "crack_traction",
            Stage::PhaseFieldSolve => "phase_field_solve",
            Stage::GridUpdate => "grid_update",
            Stage::NewmarkPredictor => "newmark_predictor",
            Stage::ContactMomenta => "contact_momenta",
            Stage::Contact => "contact",
            Stage::G2p => "g2p",
            Stage::G2pVelocity => "g2p_velocity",
            Stage::Remap => "remap",
            Stage::G2pStress => "g2p_stress",
            Stage::NewmarkStress => "newmark_stress",
            Stage::PhaseFieldHistory => "phase_field_history",
            Stage::Damage => "damage",
            Stage::Eigen => "eigen",
            Stage::NewmarkForce => "newmark_force",
            Stage::NewmarkCorrector => "newmark_corrector",
            Stage::NewmarkContact => "newmark_contact",
            Stage::NewmarkG2p => "newmark_g2p",
            Stage::Rebin => "rebin",
            Stage::Resort => "resort",
            Stage::PhaseFieldStagger => "phase_field_stagger",
            Stage::CrackSurfaces => "crack_surfaces",
            Stage::CrackGrowth => "crack_growth",
            Stage::DpmAdvance => "dpm_advance",
            Stage::DpmStrain => "dpm_strain",
            Stage::DpmDamage => "dpm_damage",
            Stage::DpmTraction => "dpm_traction",
            Stage::DpmForce => "dpm_force",
            Stage::DpmLoad => "dpm_load",
            Stage::DpmEquilibrium => "dpm_equilibrium",
        }
    }

    /// The phase field's stages (solve, history, stagger).
    pub fn is_phase_field(self) -> bool {
        matches!(
            self,
            Stage::PhaseFieldSolve | Stage::PhaseFieldHistory | Stage::PhaseFieldStagger
        )
    }

    /// Stages that decide the velocity fields and so run before the
    /// scatter's field slots exist.
    pub fn before_scatter(self) -> bool {
        matches!(
            self,
            Stage::Supports | Stage::DamageField | Stage::FieldPartition
        )
    }

    /// Stages of a model that splits the velocity fields which run after
    /// the step's field slots are released, on the nodal fields the step
    /// left (they come last in the plan).
    pub fn after_slots(self) -> bool {
        matches!(self, Stage::CrackSurfaces | Stage::CrackGrowth)
    }
}

impl Serialize for Stage {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.name())
    }
}

impl<'de> Deserialize<'de> for Stage {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Stage, D::Error> {
        let name = String::deserialize(d)?;
        Stage::from_name(&name)
            .ok_or_else(|| serde::de::Error::custom(format!("no stage is named `{name}`")))
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The stages of one step for a scene, in execution order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Plan {
    pub stages: Vec<Stage>,
}

impl Plan {
    pub(super) fn build(file: &SceneFile, contact_groups: &[u32]) -> Plan {
        let b = &file.grid.boundary;
        let traction = [&b.left, &b.right, &b.bottom, &b.top]
            .into_iter()
            .chain(b.back.as_ref())
            .chain(b.front.as_ref())
            .any(|s| matches!(s, SideCondition::Traction { .. }));
        if file.method == MethodKind::DamageParticle {
            // a method without a grid: none of the grid MPM's stages
            let damage = file
                .damage_particle
                .as_ref()
                .is_some_and(|d| d.damage.is_some());
            let statics = file
                .damage_particle
                .as_ref()
                .is_some_and(|d| d.integration == Integration::Static);
            let stages = Stage::ALL
                .into_iter()
                .filter(|s| match s {
                    Stage::DpmAdvance | Stage::DpmStrain | Stage::DpmForce => !statics,
                    Stage::DpmDamage => damage && !statics,
                    Stage::DpmTraction => traction && !statics,
                    Stage::DpmLoad | Stage::DpmEquilibrium => statics,
                    _ => false,
                })
                .collect();
            return Plan { stages };
        }
        let dfg = file.dfg.is_some();
        let cracks = file.bodies.iter().any(|b| !b.explicit_cracks.is_empty());
        let contact = contact_groups.len() > 1 || dfg || cracks;
        let pressure = file
            .bodies
            .iter()
            .flat_map(|b| &b.explicit_cracks)
            .any(|c| c.pressure.is_some());
        let growth = cracks && file.cramp.as_ref().is_some_and(|c| c.growth.is_some());
        let two_passes = cracks && file.cramp.as_ref().is_some_and(|c| c.contact_passes == 2);
        let uses = |f: fn(&super::schema::MaterialSpec) -> bool| {
            file.bodies
                .iter()
                .any(|b| file.material_of(&b.material).is_some_and(f))
        };
        let phase_field = uses(|m| m.phase_field.is_some());
        let damage = uses(|m| m.damage.is_some());
        let eigen = uses(|m| m.eigen.is_some());
        let musl = file.transfer.stress_update == StressUpdate::Musl;
        let newmark = file.transfer.stress_update == StressUpdate::Newmark;
        // the order is `Stage::ALL`'s; each stage's condition, one arm each
        let stages = Stage::ALL
            .into_iter()
            .filter(|s| match s {
                Stage::Supports => file.grid.shape_function == ShapeFunctionKind::Lme,
                Stage::DamageField => dfg,
                Stage::FieldPartition | Stage::Contact => contact,
                Stage::P2g | Stage::Rebin => true,
                Stage::Resort => file.grid.resort_every > 0,
                Stage::GridUpdate => !newmark,
                Stage::G2p => !musl && !newmark,
                Stage::Traction => traction,
                Stage::CrackTraction => pressure,
                Stage::ContactMomenta => two_passes,
                Stage::PhaseFieldSolve | Stage::PhaseFieldHistory | Stage::PhaseFieldStagger => {
                    phase_field
                }
                Stage::NewmarkPredictor
                | Stage::NewmarkStress
                | Stage::NewmarkForce
                | Stage::NewmarkCorrector
                | Stage::NewmarkG2p => newmark,
                Stage::NewmarkContact => newmark && contact,
                Stage::G2pVelocity | Stage::Remap | Stage::G2pStress => musl,
                Stage::Damage => damage,
                Stage::Eigen => eigen,
                Stage::CrackSurfaces => cracks,
                Stage::CrackGrowth => growth,
                Stage::DpmAdvance
                | Stage::DpmStrain
                | Stage::DpmDamage
                | Stage::DpmTraction
                | Stage::DpmForce
                | Stage::DpmLoad
                | Stage::DpmEquilibrium => false,
            })
            .collect();
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

#[cfg(test)]
mod tests {
    use super::*;

    /// `ALL` is in execution order and names every stage once; a name reads
    /// back as its stage.
    #[test]
    fn stages_are_named_once_and_read_back() {
        let names: Vec<_> = Stage::ALL.iter().map(|s| s.name()).collect();
        let mut unique = names.clone();
        unique.sort();
        unique.dedup();
        assert_eq!(unique.len(), names.len());
        for s in Stage::ALL {
            assert_eq!(Stage::from_name(s.name()), Some(s));
            let json = serde_json::to_string(&s).unwrap();
            assert_eq!(json, format!("\"{}\"", s.name()));
            assert_eq!(serde_json::from_str::<Stage>(&json).unwrap(), s);
        }
        assert!(serde_json::from_str::<Stage>("\"phase_field\"").is_err());
    }
}
