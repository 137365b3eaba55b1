//! The seam every fracture model plugs into: [`FractureModel`].
//!
//! A model is built from the scene by its [`Build`] function (listed once,
//! in [`crate::fracture::MODELS`]); it runs the plan stages it owns
//! ([`FractureModel::stages`]), adds its series columns and their values
//! in one function ([`FractureModel::series`], so the header and the rows
//! cannot drift apart), its snapshot fields and lines, its part of the summary and
//! its checkpoint state. A model that splits the velocity fields at the
//! nodes it cuts (DFG partitioning; explicit cracks to come) also offers
//! a [`FieldSplit`]. The step, the run loop, the series, the snapshots,
//! the summary and the checkpoints call models only through these traits.

use crate::diagnostics::crack::CrackTip;
use crate::diagnostics::{Field, Polyline};
use crate::grid::{Bins, FieldSlots, GridFields, GridGeom, MultiField};
use crate::material::Elastic;
use crate::particles::Particles;
use crate::scene::{Scene, ShapeFunctionKind, Stage};
use std::any::Any;

/// What a model is built from: the validated scene, the grid, and the
/// seeded particles in their final order (a model sets up its own
/// particle arrays, e.g. `Particles::phase`).
pub struct SetupContext<'a, const D: usize = 2, const V: usize = 3> {
    pub scene: &'a Scene,
    pub geom: &'a GridGeom<D>,
    pub parts: &'a mut Particles<D, V>,
}

/// Builds a model for a scene, or None when the scene's plan does not ask
/// for it.
pub type Build<const D: usize = 2, const V: usize = 3> =
    fn(&mut SetupContext<'_, D, V>) -> Option<Box<dyn FractureModel<D, V>>>;

/// What a model's stage works on: the step's particles (mutable), grid
/// geometry, bins, materials and kernel, and where the step is.
pub struct StepContext<'a, const D: usize = 2, const V: usize = 3> {
    pub geom: &'a GridGeom<D>,
    pub bins: &'a Bins,
    pub parts: &'a mut Particles<D, V>,
    pub mats: &'a [Elastic],
    pub kernel: ShapeFunctionKind,
    /// The step's Δt, s.
    pub dt: f64,
    /// The step ends on a series row.
    pub row_due: bool,
    /// The step ends on a series row or a snapshot.
    pub output_due: bool,
}

/// What a model reports from: the present particles and the run's energy
/// account at a series row or snapshot.
pub struct RowContext<'a, const D: usize = 2, const V: usize = 3> {
    pub geom: &'a GridGeom<D>,
    pub parts: &'a Particles<D, V>,
    pub mats: &'a [Elastic],
    pub kernel: ShapeFunctionKind,
    pub step: u64,
    pub time: f64,
    /// Kinetic + strain energy now, J.
    pub energy: f64,
    /// Kinetic + strain energy at t = 0, J.
    pub initial_energy: f64,
    /// Work of the boundary conditions and tractions so far, J.
    pub external_work: f64,
}

impl<const D: usize, const V: usize> RowContext<'_, D, V> {
    /// Kinetic + strain + `dissipated` − initial energy − external work,
    /// J: what a model that releases energy has lost beyond it (0 at
    /// t = 0).
    pub fn energy_balance(&self, dissipated: f64) -> f64 {
        if self.step == 0 {
            0.0
        } else {
            self.energy + dissipated - self.initial_energy - self.external_work
        }
    }
}

/// The columns a model adds to the series. Called once to declare the
/// names ([`SeriesOut::declaring`]: the values are ignored, and a model
/// must skip work with side effects, such as measuring a crack tip's
/// speed), then at every row to fill the values in the same order.
#[derive(Debug, Default)]
pub struct SeriesOut {
    declaring: bool,
    names: Vec<String>,
    values: Vec<f64>,
    fracture_energy: Option<f64>,
}

impl SeriesOut {
    /// A sink that collects the column names.
    pub fn declare() -> SeriesOut {
        SeriesOut {
            declaring: true,
            ..SeriesOut::default()
        }
    }

    /// A sink that collects one row's values.
    pub fn fill() -> SeriesOut {
        SeriesOut::default()
    }

    /// Only the names are wanted.
    pub fn declaring(&self) -> bool {
        self.declaring
    }

    pub fn push(&mut self, name: &str, value: f64) {
        if self.declaring {
            self.names.push(name.to_string());
        } else {
            self.values.push(value);
        }
    }

    /// The crack-tip columns `crack_tip_x`, `crack_tip_y` (and in 3D
    /// `crack_tip_z`), `crack_length`, `crack_speed`, each followed by
    /// `suffix`.
    pub fn push_tip<const D: usize>(&mut self, suffix: &str, tip: &CrackTip<D>) {
        let axes = ["crack_tip_x", "crack_tip_y", "crack_tip_z"];
        let names = axes[..D].iter().chain(&["crack_length", "crack_speed"]);
        let rest = [tip.length, tip.speed];
        let values = tip.x.iter().chain(&rest);
        for (n, &v) in names.zip(values) {
            if self.declaring {
                self.names.push(format!("{n}{suffix}"));
            } else {
                self.values.push(v);
            }
        }
    }

    /// The crack-tip columns of each tracked body ([`Self::push_tip`]),
    /// suffixed `_b<i>` when several bodies report one ([`body_suffix`]).
    pub fn push_tips<const D: usize>(&mut self, bodies: &[usize], tips: &[CrackTip<D>]) {
        for (b, tip) in bodies.iter().zip(tips) {
            self.push_tip(&body_suffix(*b, bodies.len()), tip);
        }
    }

    /// The core column `fracture_energy` (J); with two models in a scene,
    /// the later one's value stands.
    pub fn set_fracture_energy(&mut self, e: f64) {
        self.fracture_energy = Some(e);
    }

    pub fn names(self) -> Vec<String> {
        self.names
    }

    /// The values and the fracture energy (if a model set one).
    pub fn values(self) -> (Vec<f64>, Option<f64>) {
        (self.values, self.fracture_energy)
    }
}

/// The suffix of a per-body column: `_b<i>` when several bodies report it,
/// none for one.
pub fn body_suffix(body: usize, bodies: usize) -> String {
    if bodies > 1 {
        format!("_b{body}")
    } else {
        String::new()
    }
}

/// A model's concrete type, for the callers that need more than the trait
/// (a benchmark reading the phase-field solver's counters, say): any
/// `'static` type has it.
pub trait AsAny {
    fn as_any(&self) -> &dyn Any;
    fn as_any_mut(&mut self) -> &mut dyn Any;
}

impl<T: Any> AsAny for T {
    fn as_any(&self) -> &dyn Any {
        self
    }
    fn as_any_mut(&mut self) -> &mut dyn Any {
        self
    }
}

/// The model of type `T` among `models`, if there is one.
pub fn find<T: Any, const D: usize, const V: usize>(
    models: &[Box<dyn FractureModel<D, V>>],
) -> Option<&T> {
    models.iter().find_map(|m| (**m).as_any().downcast_ref())
}

/// The model of type `T` among `models`, mutable.
pub fn find_mut<T: Any, const D: usize, const V: usize>(
    models: &mut [Box<dyn FractureModel<D, V>>],
) -> Option<&mut T> {
    models
        .iter_mut()
        .find_map(|m| (**m).as_any_mut().downcast_mut())
}

/// A fracture model in the explicit step.
pub trait FractureModel<const D: usize = 2, const V: usize = 3>: Send + AsAny {
    /// The model's name as the scene and the docs know it.
    fn name(&self) -> &'static str;

    /// The plan stages this model runs (each at its place in the plan).
    fn stages(&self) -> &'static [Stage];

    /// Runs one of [`Self::stages`]. An error stops the run with its
    /// message.
    fn run(&mut self, stage: Stage, ctx: StepContext<'_, D, V>) -> Result<(), String>;

    /// Declares (see [`SeriesOut::declaring`]) or fills this model's
    /// series columns.
    fn series(&mut self, at: &RowContext<'_, D, V>, out: &mut SeriesOut);

    /// Adds this model's per-particle fields to a snapshot.
    fn snapshot(&mut self, _at: &RowContext<'_, D, V>, _fields: &mut Vec<Field>) {}

    /// Adds the polylines this model draws to a snapshot (explicit cracks:
    /// each crack's plane and surfaces), which the writers put beside the
    /// particles. Most models draw none, and a snapshot without lines
    /// writes no line files, so the default adds nothing.
    fn snapshot_lines(&self, _out: &mut Vec<Polyline>) {}

    /// This model's part of the run summary (its counters and times), as
    /// JSON.
    fn summary(&self) -> serde_json::Value;

    /// The state a checkpoint keeps beyond the particle arrays (postcard
    /// bytes of the model's own type, whose layout the checkpoint's layout
    /// test traces).
    fn save(&self) -> Vec<u8>;

    /// Takes up the state [`Self::save`] wrote, for the freshly built
    /// model of the same scene; an error names what does not fit.
    fn restore(&mut self, state: &[u8], at: RestoreContext<'_, D, V>) -> Result<(), String>;

    /// The scene's top-level tables of this model that a resume from a
    /// checkpoint may change (its solver's settings, say: how something
    /// is solved for, not what is simulated).
    fn may_change_on_resume(&self) -> &'static [&'static str] {
        &[]
    }

    /// The model's split of the velocity fields, if it splits them.
    fn field_split(&mut self) -> Option<&mut dyn FieldSplit<D, V>> {
        None
    }
}

/// A model that splits the velocity fields at the nodes it cuts: there a
/// contact group has several fields (two sides of a crack, which the
/// contact law keeps from interpenetrating), and each particle–node pair
/// maps to one of them. DFG partitioning does this (Homel & Herbold
/// 2017), and explicit cracks (Nairn & Aimene's CRAMP: up to four fields
/// for two cracks). With a split the plan has contact, and the split's
/// stages run before the scatter, because they decide the field slots
/// the rest of the step uses. The slots borrow the model (shared) for the
/// rest of the step, so its own [`FractureModel::run`] stages cannot run
/// in that step; what it must do meanwhile reads it shared
/// ([`FieldSplit::contact`]), and what changes it runs after the slots
/// are released ([`FieldSplit::after_slots`]: moving crack surfaces).
/// `tests/engine/plan.rs` fails on a plan stage that did not run.
pub trait FieldSplit<const D: usize = 2, const V: usize = 3> {
    /// Coulomb friction between a group's two sides where they touch.
    fn self_friction(&self) -> f64;

    /// Runs a stage that comes before the scatter (`damage_field`,
    /// `field_partition`). The partition sets `multi`'s field masks, lays
    /// out its slots and returns how many there are (nodes + extra); None
    /// for a stage that is not the split's (the step then runs its own).
    fn before_scatter(
        &mut self,
        stage: Stage,
        at: ScatterContext<'_, D, V>,
        multi: &mut MultiField,
    ) -> Option<usize>;

    /// This step's field slots (after the partition).
    fn slots<'a>(&'a self, at: SlotContext<'a>) -> SplitSlots<'a, D>;

    /// Whether the scatter sums the mass gradients Σ m_p ∇N per field (the
    /// group law's contact normals); a split with its own normals says no.
    fn mass_gradients(&self) -> bool {
        true
    }

    /// Contact between the split's fields by the split's own law (explicit
    /// cracks: each crack's normal and friction), in the `contact` stage
    /// (`at.momenta` false) or the `contact_momenta` stage (true: on the
    /// scattered velocities v⁰, the correction carried into v̄ as well);
    /// returns the nodes where it acted. None: the step's law between
    /// fields ([`crate::contact::apply`], with [`Self::self_friction`]),
    /// and no `contact_momenta` pass.
    fn contact(&self, _at: ContactContext<'_, D>) -> Option<usize> {
        None
    }

    /// Adds the split's own forces to the nodal fields in a stage between
    /// the scatter and the grid update (`crack_traction`: pressure on
    /// crack faces); returns their work over the step, J, or None for a
    /// stage that is not the split's.
    fn forces(&self, _stage: Stage, _at: ForceContext<'_, D>) -> Option<f64> {
        None
    }

    /// Runs a stage that comes after the step's slots are released
    /// ([`Stage::after_slots`]: moving crack surfaces), on the nodal
    /// fields the step left; false for a stage that is not the split's.
    fn after_slots(&mut self, _stage: Stage, _at: AfterContext<'_, D, V>) -> bool {
        false
    }
}

/// What a split's contact law works on: the step's nodal fields after the
/// grid update (velocities to correct), the field layout, and the mass
/// below which a field takes no part, kg.
pub struct ContactContext<'a, const D: usize = 2> {
    pub grid: &'a mut GridFields<D>,
    pub multi: &'a MultiField,
    pub floor: f64,
    /// The first pass, on the scattered momenta (`contact_momenta`).
    pub momenta: bool,
}

/// What a split's forces are added to: the grid, the step's nodal fields
/// after the scatter and their layout, the kernel, the step's mid-time
/// (s) and Δt.
pub struct ForceContext<'a, const D: usize = 2> {
    pub geom: &'a GridGeom<D>,
    pub grid: &'a mut GridFields<D>,
    pub multi: &'a MultiField,
    pub kernel: ShapeFunctionKind,
    pub time: f64,
    pub dt: f64,
}

/// What a split's stages after the slots read: the grid and the nodal
/// fields the step left (mass, first and final velocities per field slot),
/// the particles after the gather, the kernel and Δt.
pub struct AfterContext<'a, const D: usize = 2, const V: usize = 3> {
    pub geom: &'a GridGeom<D>,
    pub parts: &'a Particles<D, V>,
    pub mats: &'a [Elastic],
    pub grid: &'a GridFields<D>,
    pub multi: &'a MultiField,
    pub kernel: ShapeFunctionKind,
    /// The step's end, s.
    pub time: f64,
    pub dt: f64,
}

/// The field slots of every model that splits the velocity fields, one
/// variant each: the step's scatter and gathers call a slot per
/// particle–node pair, so they are compiled for each concrete rule
/// ([`SplitSlots::visit`]) rather than called through a pointer (which
/// cost DFG's P2G and G2P about a tenth of their time). Adding a
/// splitting model: its variant here and its arm in `visit`.
pub enum SplitSlots<'a, const D: usize = 2> {
    /// Damage-field-gradient partitioning (Homel & Herbold 2017).
    Dfg(crate::fracture::dfg::DfgFields<'a, D>),
    /// Explicit cracks' velocity fields (Nairn & Aimene).
    Cramp(crate::fracture::cracks::CrampFields<'a, D>),
}

/// What runs with a step's field slots, for any concrete slot rule.
pub trait SlotsVisitor {
    type Output;
    fn visit<S: FieldSlots>(self, slots: &S) -> Self::Output;
}

impl<const D: usize> SplitSlots<'_, D> {
    /// Runs `v` with the concrete slots.
    pub fn visit<V: SlotsVisitor>(&self, v: V) -> V::Output {
        match self {
            SplitSlots::Dfg(s) => v.visit(s),
            SplitSlots::Cramp(s) => v.visit(s),
        }
    }
}

/// What the stages before the scatter read.
pub struct ScatterContext<'a, const D: usize = 2, const V: usize = 3> {
    pub geom: &'a GridGeom<D>,
    pub parts: &'a Particles<D, V>,
    pub bins: &'a Bins,
    pub kernel: ShapeFunctionKind,
    /// The step's Δt, s.
    pub dt: f64,
    /// The step ends on a series row.
    pub row_due: bool,
}

/// What the field slots map through: the grid's node count, the field
/// masks and slot layout the partition made, and each particle's dense
/// contact group.
pub struct SlotContext<'a> {
    pub nodes: usize,
    pub multi: &'a MultiField,
    pub group: &'a [u8],
}

/// What a model restores against: the resumed particles and the grid.
pub struct RestoreContext<'a, const D: usize = 2, const V: usize = 3> {
    pub geom: &'a GridGeom<D>,
    pub parts: &'a Particles<D, V>,
}

/// A model's state in postcard bytes ([`FractureModel::save`]).
pub fn encode<T: serde::Serialize>(state: &T) -> Vec<u8> {
    // plain structs of numbers and vectors: postcard cannot fail on them
    postcard::to_stdvec(state).expect("a model state encodes")
}

/// The state [`encode`] wrote.
pub fn decode<'de, T: serde::Deserialize<'de>>(bytes: &'de [u8]) -> Result<T, String> {
    postcard::from_bytes(bytes).map_err(|e| format!("its state does not decode: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// One function declares and fills: the names and values line up.
    #[test]
    fn declaring_and_filling_line_up() {
        let tip = CrackTip {
            x: [1.0, 2.0],
            length: 3.0,
            speed: 4.0,
        };
        let run = |out: &mut SeriesOut| {
            out.push("a", 7.0);
            out.push_tip(&body_suffix(2, 3), &tip);
        };
        let mut names = SeriesOut::declare();
        run(&mut names);
        let mut values = SeriesOut::fill();
        run(&mut values);
        values.set_fracture_energy(0.5);
        assert_eq!(
            names.names(),
            [
                "a",
                "crack_tip_x_b2",
                "crack_tip_y_b2",
                "crack_length_b2",
                "crack_speed_b2"
            ]
        );
        assert_eq!(values.values(), (vec![7.0, 1.0, 2.0, 3.0, 4.0], Some(0.5)));
        assert_eq!(body_suffix(0, 1), "");
    }
}
