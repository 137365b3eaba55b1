//! DFG partitioning as a [`FractureModel`]: its series columns. Its two
//! stages (`damage_field`, `field_partition`) decide the velocity field of
//! every particle–node pair before the scatter, so the step runs them
//! where it builds its field slots (`mpm::Simulation`), not through
//! [`FractureModel::run`].

use super::Dfg;
use crate::fracture::model::{FractureModel, RowContext, SeriesOut, StepContext};
use crate::scene::Stage;

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
}
