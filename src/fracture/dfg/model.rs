//! DFG partitioning as a [`FractureModel`]: its series columns. Its two
//! stages (`damage_field`, `field_partition`) decide the velocity field of
//! every particle–node pair before the scatter, so the step runs them
//! where it builds its field slots (`mpm::Simulation`), not through
//! [`FractureModel::run`].

use super::Dfg;
use crate::fracture::model::{
    decode, encode, FractureModel, RestoreContext, RowContext, SeriesOut, StepContext,
};
use crate::scene::Stage;

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
}
