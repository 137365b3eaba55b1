//! DFG partitioning as a [`FractureModel`]. Its two stages
//! (`damage_field`, `field_partition`) decide the velocity field of every
//! particle–node pair before the scatter, so they run through its
//! [`FieldSplit`] (where the step builds its field slots), not through
//! [`FractureModel::run`].

use super::{Dfg, DfgFields, DfgParams};
use crate::fracture::model::{
    decode, encode, FieldSplit, FractureModel, RestoreContext, RowContext, ScatterContext,
    SeriesOut, SetupContext, SlotContext, SplitSlots, StepContext,
};
use crate::grid::shape::by_kernel;
use crate::grid::MultiField;
use crate::scene::Stage;

/// DFG partitioning for a scene with a `[dfg]` table: the kernel radius
/// in cells of the diagonal, and the materials that can be damaged (those
/// with a fracture model).
pub(crate) fn build(at: &mut SetupContext<'_>) -> Option<Box<dyn FractureModel>> {
    let (scene, file) = (at.scene, &at.scene.file);
    let spec = file.dfg.as_ref()?;
    let params = DfgParams {
        radius: spec.radius * file.grid.cell_size * std::f64::consts::SQRT_2,
        rebuild_fraction: spec.rebuild_fraction,
        separability: spec.separability,
        self_friction: spec.friction,
    };
    let damaged: Vec<bool> = scene
        .materials
        .iter()
        .map(|m| m.fracture.is_some())
        .collect();
    Some(Box::new(Dfg::new(
        params,
        at.geom,
        at.parts,
        spec.self_contact.then_some(spec.surface_threshold),
        &damaged,
    )))
}

impl FieldSplit for Dfg {
    fn self_friction(&self) -> f64 {
        self.params.self_friction
    }

    fn before_scatter(
        &mut self,
        stage: Stage,
        at: ScatterContext<'_>,
        multi: &mut MultiField,
    ) -> Option<usize> {
        let ScatterContext {
            geom,
            parts,
            bins,
            kernel,
        } = at;
        match stage {
            Stage::DamageField => {
                by_kernel!(kernel, K => self.field::<K>(geom, parts, bins));
                Some(geom.node_count())
            }
            Stage::FieldPartition => {
                Some(by_kernel!(kernel, K => self.partition::<K>(geom, parts, bins, multi)))
            }
            _ => None,
        }
    }

    fn slots<'a>(&'a self, at: SlotContext<'a>) -> SplitSlots<'a> {
        SplitSlots::Dfg(DfgFields {
            x: &self.x_partition,
            cut: &self.cut,
            normal: self.normals(),
            nodes: at.nodes,
            multi: at.multi,
            group: at.group,
            grad: &self.grad,
            node_grad: &self.node_grad,
        })
    }
}

/// What a checkpoint keeps of DFG: the positions its neighbour lists were
/// built at and the builds so far.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub(crate) struct DfgSaved {
    pub x_built: Vec<[f64; 2]>,
    pub builds: u64,
}

impl FractureModel for Dfg {
    fn name(&self) -> &'static str {
        "dfg"
    }

    fn stages(&self) -> &'static [Stage] {
        &[]
    }

    fn run(&mut self, _stage: Stage, _ctx: StepContext<'_>) -> Result<(), String> {
        Ok(())
    }

    /// The nodes where a group's two sides were separate fields in the last
    /// step (`dfg_separated_nodes`) and the neighbour-list builds so far
    /// (`dfg_neighbour_builds`).
    fn series(&mut self, _at: &RowContext<'_>, out: &mut SeriesOut) {
        let st = self.stats();
        out.push("dfg_separated_nodes", st.separated_nodes as f64);
        out.push("dfg_neighbour_builds", st.neighbour_builds as f64);
    }

    /// Neighbour-list builds, separated nodes, surface particles
    /// ([`super::DfgStats`]).
    fn summary(&self) -> serde_json::Value {
        serde_json::to_value(self.stats()).unwrap_or_default()
    }

    fn save(&self) -> Vec<u8> {
        let (x_built, builds) = self.neighbour_state();
        encode(&DfgSaved { x_built, builds })
    }

    /// The neighbour lists built again at the saved positions.
    fn restore(&mut self, state: &[u8], at: RestoreContext<'_>) -> Result<(), String> {
        let s: DfgSaved = decode(state)?;
        if s.x_built.len() != at.parts.len() && !s.x_built.is_empty() {
            return Err("DFG's neighbour positions are not one per particle".into());
        }
        self.restore_neighbours(at.geom, at.parts, &s.x_built, s.builds);
        Ok(())
    }

    fn field_split(&mut self) -> Option<&mut dyn FieldSplit> {
        Some(self)
    }
}
