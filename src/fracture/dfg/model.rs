//! DFG partitioning as a [`FractureModel`]. Its two stages
//! (`damage_field`, `field_partition`) decide the velocity field of every
//! particle–node pair before the scatter, so they run through its
//! [`FieldSplit`] (where the step builds its field slots), not through
//! [`FractureModel::run`]. One model for 2D and 3D (`Dfg<D>`,
//! `FractureModel<D, V>`).

use super::{Dfg, DfgFields, DfgParams};
use crate::fracture::model::{
    decode, encode, FieldSplit, FractureModel, RestoreContext, RowContext, ScatterContext,
    SeriesOut, SetupContext, SlotContext, SplitSlots, StepContext,
};
use crate::grid::shape::by_kernel;
use crate::grid::MultiField;
use crate::scene::Stage;

/// DFG partitioning for a scene with a `[dfg]` table: the kernel radius
/// in cell diagonals (h√2 in 2D, h√3 in 3D: the paper's one diagonal,
/// Homel & Herbold 2017, section 2.2), and the materials that can be
/// damaged (those with a fracture model).
pub(crate) fn build<const D: usize, const V: usize>(
    at: &mut SetupContext<'_, D, V>,
) -> Option<Box<dyn FractureModel<D, V>>>
where
    [f64; D]: serde::Serialize + serde::de::DeserializeOwned,
{
    let (scene, file) = (at.scene, &at.scene.file);
    let spec = file.dfg.as_ref()?;
    let diagonal = if D == 2 {
        std::f64::consts::SQRT_2
    } else {
        (D as f64).sqrt()
    };
    let params = DfgParams {
        radius: spec.radius * file.grid.cell_size * diagonal,
        rebuild_fraction: spec.rebuild_fraction,
        separability: spec.separability,
        self_friction: spec.friction,
    };
    let damaged: Vec<bool> = scene
        .materials
        .iter()
        .map(|m| m.fracture.is_some())
        .collect();
    Some(Box::new(Dfg::<D>::new(
        params,
        at.geom,
        at.parts,
        spec.self_contact.then_some(spec.surface_threshold),
        &damaged,
    )))
}

impl<const D: usize, const V: usize> FieldSplit<D, V> for Dfg<D> {
    fn self_friction(&self) -> f64 {
        self.params.self_friction
    }

    fn before_scatter(
        &mut self,
        stage: Stage,
        at: ScatterContext<'_, D, V>,
        multi: &mut MultiField,
    ) -> Option<usize> {
        let ScatterContext {
            geom,
            parts,
            bins,
            kernel,
            ..
        } = at;
        match stage {
            Stage::DamageField => {
                by_kernel!(kernel, K => self.field::<K, V>(geom, parts, bins));
                Some(geom.node_count())
            }
            Stage::FieldPartition => {
                Some(by_kernel!(kernel, K => self.partition::<K, V>(geom, parts, bins, multi)))
            }
            _ => None,
        }
    }

    fn slots<'a>(&'a self, at: SlotContext<'a>) -> SplitSlots<'a, D> {
        SplitSlots::Dfg(DfgFields {
            x: &self.x_partition,
            cut: &self.cut,
            balanced: &self.balanced,
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
#[serde(bound(
    serialize = "[f64; D]: serde::Serialize",
    deserialize = "[f64; D]: serde::Deserialize<'de>"
))]
pub(crate) struct DfgSaved<const D: usize = 2> {
    pub x_built: Vec<[f64; D]>,
    pub builds: u64,
}

impl<const D: usize, const V: usize> FractureModel<D, V> for Dfg<D>
where
    [f64; D]: serde::Serialize + serde::de::DeserializeOwned,
{
    fn name(&self) -> &'static str {
        "dfg"
    }

    fn stages(&self) -> &'static [Stage] {
        &[]
    }

    fn run(&mut self, _stage: Stage, _ctx: StepContext<'_, D, V>) -> Result<(), String> {
        Ok(())
    }

    /// The nodes where a group's two sides were separate fields in the last
    /// step (`dfg_separated_nodes`) and the neighbour-list builds so far
    /// (`dfg_neighbour_builds`).
    fn series(&mut self, _at: &RowContext<'_, D, V>, out: &mut SeriesOut) {
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
    fn restore(&mut self, state: &[u8], at: RestoreContext<'_, D, V>) -> Result<(), String> {
        let s: DfgSaved<D> = decode(state)?;
        if s.x_built.len() != at.parts.len() && !s.x_built.is_empty() {
            return Err("DFG's neighbour positions are not one per particle".into());
        }
        self.restore_neighbours(at.geom, at.parts, &s.x_built, s.builds);
        Ok(())
    }

    fn field_split(&mut self) -> Option<&mut dyn FieldSplit<D, V>> {
        Some(self)
    }
}
