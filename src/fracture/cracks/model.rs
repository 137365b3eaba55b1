//! Explicit cracks (CRAMP) as a [`FractureModel`] that splits the velocity
//! fields: its `field_partition` runs before the scatter, its
//! `crack_traction` (faces under pressure) adds forces after it, its
//! contact law takes the `contact` stage's place, and its
//! `crack_surfaces` and `crack_growth` stages run after the step's slots
//! are released, all through its [`FieldSplit`].
//! 2D only (validation refuses explicit cracks in a 3D scene).

use super::contour::{tip_j, End, JOptions};
use super::traction::outside_ends;
use super::{Crack, Cramp, Warnings};
use crate::fracture::model::{
    decode, encode, AfterContext, ContactContext, FieldSplit, ForceContext, FractureModel,
    RestoreContext, RowContext, ScatterContext, SeriesOut, SetupContext, SlotContext, SplitSlots,
    StepContext,
};
use crate::grid::shape::by_kernel;
use crate::grid::MultiField;
use crate::scene::Stage;

/// The model for a scene whose bodies list `explicit_cracks`.
pub(crate) fn build(at: &mut SetupContext<'_>) -> Option<Box<dyn FractureModel>> {
    let file = &at.scene.file;
    let (mut cracks, mut pressure, mut outside) = (Vec::new(), Vec::new(), Vec::new());
    for (b, body) in file.bodies.iter().enumerate() {
        for spec in &body.explicit_cracks {
            let xy = spec.xy();
            outside.push(outside_ends(&xy, &body.shape, &body.holes));
            pressure.push(spec.pressure.clone());
            cracks.push(Crack::new(b as u16, spec.friction, xy));
        }
    }
    if cracks.is_empty() {
        return None;
    }
    let spec = file.cramp.clone().unwrap_or_default();
    // the J integral's ∇u, summed by the step's constitutive update
    at.parts.grad_u = vec![[[0.0; 2]; 2]; at.parts.len()];
    let mut cramp = Cramp::new(cracks, spec.surface_update, spec.j_contours);
    cramp.thickness = file.analysis.thickness;
    cramp.growth = spec.growth;
    cramp.j_method = spec.j_method;
    cramp.k_split = spec.k_split;
    cramp.pressure = pressure;
    cramp.outside = outside;
    Some(Box::new(cramp))
}

impl FieldSplit for Cramp {
    /// Unused: crack contact has its own law ([`Cramp::contact`]), with
    /// each crack's friction.
    fn self_friction(&self) -> f64 {
        0.0
    }

    fn before_scatter(
        &mut self,
        stage: Stage,
        at: ScatterContext<'_>,
        multi: &mut MultiField,
    ) -> Option<usize> {
        match stage {
            Stage::FieldPartition => {
                let (geom, parts, bins) = (at.geom, at.parts, at.bins);
                // J's volume term needs the step's start where J is due:
                // on a row, and after every step of a growing crack
                if at.row_due || self.growth.is_some() {
                    self.keep_before_row(parts, at.dt);
                } else {
                    self.before_row = None;
                }
                Some(by_kernel!(at.kernel, K => self.partition::<K, 3>(geom, parts, bins, multi)))
            }
            _ => None,
        }
    }

    fn slots<'a>(&'a self, at: SlotContext<'a>) -> SplitSlots<'a> {
        SplitSlots::Cramp(self.slots(at.nodes, at.multi))
    }

    /// Crack contact takes its normals from the cracks: the scatter need
    /// not sum mass gradients.
    fn mass_gradients(&self) -> bool {
        false
    }

    fn contact(&self, at: ContactContext<'_>) -> Option<usize> {
        Some(Cramp::contact(
            self, at.grid, at.multi, at.floor, at.momenta,
        ))
    }

    fn forces(&self, stage: Stage, at: ForceContext<'_>) -> Option<f64> {
        match stage {
            Stage::CrackTraction => {
                let (geom, grid, multi) = (at.geom, at.grid, at.multi);
                Some(
                    by_kernel!(at.kernel, K => self.face_forces::<K>(geom, grid, multi, at.time, at.dt)),
                )
            }
            _ => None,
        }
    }

    fn after_slots(&mut self, stage: Stage, at: AfterContext<'_>) -> bool {
        match stage {
            Stage::CrackSurfaces => {
                by_kernel!(at.kernel, K => self.move_surfaces::<K>(at.geom, at.grid, at.multi, at.dt));
                true
            }
            Stage::CrackGrowth => {
                let (geom, parts, mats) = (at.geom, at.parts, at.mats);
                by_kernel!(at.kernel, K => self.grow::<K, 3>(geom, parts, mats, at.time));
                true
            }
            _ => false,
        }
    }
}

/// What a checkpoint keeps of the explicit cracks: every crack's points,
/// surfaces and surface velocities, whether the surfaces have moved, the
/// counters and the energy growth has released.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub(crate) struct CrampSaved {
    pub cracks: Vec<Crack>,
    pub started: bool,
    pub warnings: Warnings,
    pub released: f64,
}

impl FractureModel for Cramp {
    fn name(&self) -> &'static str {
        "explicit_cracks"
    }

    fn stages(&self) -> &'static [Stage] {
        &[]
    }

    fn run(&mut self, _stage: Stage, _ctx: StepContext<'_>) -> Result<(), String> {
        Ok(())
    }

    /// Per crack c (in the order of the bodies and their lists), its two
    /// ends' positions, `crack{c}_start_x`, `_start_y`, `crack{c}_end_x`,
    /// `_end_y` (m), and its length along the plane, `crack{c}_length`;
    /// then per end its J on the first contour of `j_contours` (eq. 10,
    /// J/m²) and K_I, K_II from it (Pa·√m), `crack{c}_{end}_J`, `_KI`,
    /// `_KII`, and J on each further contour of N cells,
    /// `crack{c}_{end}_J{N}`. An end outside the material (an edge
    /// crack's mouth), or one whose contour leaves the grid or meets more
    /// than PIJC handles, has NaN there. The core `fracture_energy` is
    /// the energy growth has released, Σ J Δa t ([`Cramp::grow`]); 0
    /// where nothing grows.
    fn series(&mut self, at: &RowContext<'_>, out: &mut SeriesOut) {
        if !out.declaring() {
            out.set_fracture_energy(self.released);
        }
        for (c, crack) in self.cracks.iter().enumerate() {
            let ends = [
                ("start", crack.plane[0]),
                ("end", crack.plane[crack.plane.len() - 1]),
            ];
            for (end, x) in ends {
                out.push(&format!("crack{c}_{end}_x"), x[0]);
                out.push(&format!("crack{c}_{end}_y"), x[1]);
            }
            out.push(&format!("crack{c}_length"), crack.length());
        }
        let pressures = self.pressures(at.time);
        for c in 0..self.cracks.len() {
            for end in End::BOTH {
                let js = if out.declaring() {
                    Vec::new()
                } else {
                    let (geom, parts, mats, sides) = (at.geom, at.parts, at.mats, &self.j_contours);
                    let tip = (c, end);
                    let how = JOptions {
                        before: self.before_row.as_ref(),
                        method: self.j_method,
                        split: self.k_split,
                        pressure: &pressures,
                    };
                    by_kernel!(at.kernel, K => tip_j::<K, 3>(geom, parts, mats, &self.cracks, how, tip, sides))
                };
                let got = |k: usize| js.get(k).and_then(|r| r.ok());
                let name = format!("crack{c}_{}", end.name());
                let first = got(0);
                out.push(&format!("{name}_J"), first.map_or(f64::NAN, |t| t.j));
                out.push(&format!("{name}_KI"), first.map_or(f64::NAN, |t| t.k1));
                out.push(&format!("{name}_KII"), first.map_or(f64::NAN, |t| t.k2));
                for (k, side) in self.j_contours.iter().enumerate().skip(1) {
                    out.push(&format!("{name}_J{side}"), got(k).map_or(f64::NAN, |t| t.j));
                }
            }
        }
    }

    fn summary(&self) -> serde_json::Value {
        serde_json::json!({
            "cracks": self.cracks.len(),
            "crack_points": self.cracks.iter().map(|c| c.plane.len()).sum::<usize>(),
            "crack_points_grown": self.cracks.iter().map(|c| c.plane.len()).sum::<usize>()
                - self.initial_points,
            "warnings_wrong_side": self.warnings.wrong_side,
            "warnings_third_crack": self.warnings.third_crack,
            "released_energy": self.released,
        })
    }

    fn save(&self) -> Vec<u8> {
        encode(&CrampSaved {
            cracks: self.cracks.clone(),
            started: self.started,
            warnings: self.warnings,
            released: self.released,
        })
    }

    fn restore(&mut self, state: &[u8], _at: RestoreContext<'_>) -> Result<(), String> {
        let s: CrampSaved = decode(state)?;
        if s.cracks.len() != self.cracks.len() {
            return Err(format!(
                "the checkpoint has {} explicit cracks, the scene {}",
                s.cracks.len(),
                self.cracks.len()
            ));
        }
        self.cracks = s.cracks;
        self.started = s.started;
        self.warnings = s.warnings;
        self.released = s.released;
        Ok(())
    }

    fn field_split(&mut self) -> Option<&mut dyn FieldSplit> {
        Some(self)
    }

    fn snapshot_lines(&self, out: &mut Vec<crate::diagnostics::Polyline>) {
        self.polylines(out) // plane, above, below per crack: snapshot.rs
    }
}
