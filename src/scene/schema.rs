//! The scene file as written by a user (TOML or JSON), before validation.
//!
//! Every struct denies unknown keys so that a typo is an error naming the
//! key, not a silently ignored setting. Units are SI throughout: m, kg, s,
//! Pa, N/m (tractions are stresses, Pa), m/s².

use serde::de::{self, MapAccess, Visitor};
use serde::{Deserialize, Deserializer, Serialize};
use std::collections::BTreeMap;
use std::fmt;

// Types the base layer defines and the scene file names: the scene builds
// base types, the base imports nothing from the scene (tests/engine/layers.rs).
pub use crate::geometry::{Matrix, ShapeSpec, Vector};
pub use crate::grid::shape::ShapeFunctionKind;
pub use crate::material::{MaterialModel, PlaneKind};
// Each fracture model owns its scene section (its types and their checks
// live in the model's folder); the scene file names them.
pub use crate::dpm::section::{DpmDamageSpec, DpmSpec, InitiationSpec, MethodKind};
pub use crate::fracture::cracks::section::{CrampSpec, ExplicitCrackSpec, SurfaceUpdate};
pub use crate::fracture::damage::section::{DamageModel, DamageSpec, WeibullSpec};
pub use crate::fracture::dfg::section::DfgSpec;
pub use crate::fracture::eigen::section::{EigenModel, EigenSpec};
pub use crate::fracture::phase_field::section::{
    PhaseFieldSpec, PhaseFieldVolumes, PlaneStressSplit,
};

/// The whole scene file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// Free-form metadata (name, description); not used by the solver.
    #[serde(default)]
    pub meta: Meta,
    /// The method that runs the scene: the grid MPM (default) or the
    /// damage particle method (`damage_particle`, with its options in
    /// `[damage_particle]`).
    #[serde(default, skip_serializing_if = "MethodKind::is_grid_mpm")]
    pub method: MethodKind,
    /// The damage particle method's options (Wei & Chen).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub damage_particle: Option<DpmSpec>,
    pub grid: GridSpec,
    /// Plane strain or plane stress, and the out-of-plane thickness.
    #[serde(default)]
    pub analysis: AnalysisSpec,
    pub time: TimeSpec,
    /// Particle-to-grid-to-particle velocity transfer.
    #[serde(default)]
    pub transfer: TransferSpec,
    /// Named materials that bodies may refer to by name.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialSpec>,
    pub bodies: Vec<BodySpec>,
    /// Body force per unit mass (gravity), m/s²: 2 or 3 components as the
    /// grid has; left out, zero (validation writes the zero of the grid's
    /// dimension, so that a validated scene serialises as it always has).
    #[serde(default, skip_serializing_if = "Vector::is_unset")]
    pub body_force: Vector,
    #[serde(default)]
    pub contact: ContactSpec,
    #[serde(default)]
    pub output: OutputSpec,
    #[serde(default)]
    pub guards: GuardSpec,
    /// How the phase-field systems are solved (scenes with a phase field).
    #[serde(default)]
    pub phase_field_solver: PhaseFieldSolverSpec,
    /// Damage-field-gradient partitioning (Homel & Herbold 2017):
    /// cracks of damaged material, and self-contact, as contacting
    /// velocity fields. Absent: damage models and phase fields run in
    /// single-field mode. With a phase field, a particle's damage is
    /// 1 − c, and c < 0.1 counts as fully damaged
    /// ([`crate::fracture::phase_field::dfg_damage`]).
    #[serde(default)]
    pub dfg: Option<DfgSpec>,
    /// Options of the explicit cracks (Nairn & Aimene's CRAMP) that bodies
    /// list in `explicit_cracks`; left out, the defaults.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cramp: Option<CrampSpec>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum PhaseFieldMethod {
    /// Numeric Cholesky factorization every step.
    #[default]
    Direct,
    /// Conjugate gradients warm-started from the last solution and
    /// preconditioned by the last factorization, made in f32 (the residual
    /// is still taken to `tolerance` in f64).
    Pcg,
    /// Conjugate gradients warm-started from the last solution and
    /// preconditioned by one V-cycle of geometric multigrid (B-spline
    /// two-scale prolongation, Galerkin coarse levels, Chebyshev smoothing):
    /// no symbolic analysis when the active nodes change, and a cheap
    /// rebuild when the history has grown (`refactor_after` is its cost).
    Multigrid,
    /// Whichever of `pcg` and `multigrid` takes less wall time on this
    /// scene and this machine: each system's first solves are made by both
    /// (the factor's solutions are used) and timed, then the faster goes
    /// on alone. Until then, and when the factor is chosen, a run gives
    /// `pcg`'s results bit for bit; the choice rests on seconds, so it can
    /// differ between machines, thread counts and loads. The run's summary
    /// says what was chosen (`auto_factor`, `auto_multigrid`): to repeat a
    /// run exactly, name that method.
    Auto,
}

/// Options of the phase-field solve.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct PhaseFieldSolverSpec {
    #[serde(default)]
    pub method: PhaseFieldMethod,
    /// PCG: converged when ‖F − Kc‖ ≤ tolerance·‖F‖.
    #[serde(default = "default_pcg_tolerance")]
    pub tolerance: f64,
    /// PCG: iterations before falling back to a direct solve.
    #[serde(default = "default_pcg_max")]
    pub max_iterations: u32,
    /// PCG: what a numeric factorization costs, in PCG iterations. The
    /// factor is renewed after a solve that costs more than the average per
    /// solve since the last factorization (this cost included); a solve
    /// with the old factor that has not converged after twice this many
    /// iterations is redone with a fresh factor.
    #[serde(default = "default_pcg_refactor")]
    pub refactor_after: u32,
    /// Staggered iterations per step (Kakouris & Triantafyllou, Algorithm 1): after the
    /// history update, c is solved again while the relative phase-field
    /// residual exceeds `stagger_tolerance`, up to this many solves per step.
    /// 1 (the default, the paper's finding) does no re-solve.
    #[serde(default = "default_max_staggers")]
    pub max_staggers: u32,
    /// Relative residual ‖K(H)c − F‖/‖F‖ below which the stagger loop stops.
    #[serde(default = "default_stagger_tolerance")]
    pub stagger_tolerance: f64,
    /// The fill-reducing ordering of the Cholesky factorizations (methods
    /// direct and pcg, and the factor of auto and of multigrid's fall-back).
    #[serde(default)]
    pub ordering: FactorOrdering,
}

/// Options of [`PhaseFieldSolverSpec::ordering`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum FactorOrdering {
    /// faer's approximate minimum degree ordering of the matrix's graph;
    /// one factorization on one thread.
    #[default]
    Amd,
    /// Geometric nested dissection of the grid's nodes: the two sides of
    /// its first cut are factorized at once (two threads) and the slab
    /// between them after, as a dense matrix. Falls back to `amd` where the
    /// unknowns have no cut or the slab is over 1024 unknowns (a 3D
    /// grid's). Other round-off than `amd`'s; the same for any thread
    /// count.
    Dissection,
}

impl Default for PhaseFieldSolverSpec {
    fn default() -> Self {
        PhaseFieldSolverSpec {
            method: PhaseFieldMethod::Direct,
            tolerance: default_pcg_tolerance(),
            max_iterations: default_pcg_max(),
            refactor_after: default_pcg_refactor(),
            max_staggers: default_max_staggers(),
            stagger_tolerance: default_stagger_tolerance(),
            ordering: FactorOrdering::Amd,
        }
    }
}

fn default_max_staggers() -> u32 {
    1
}
fn default_stagger_tolerance() -> f64 {
    1e-6
}

fn default_pcg_tolerance() -> f64 {
    1e-8
}
fn default_pcg_max() -> u32 {
    100
}
fn default_pcg_refactor() -> u32 {
    10
}

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct Meta {
    #[serde(default)]
    pub name: String,
    #[serde(default)]
    pub description: String,
}

/// The uniform background grid. Its `max` decides the scene's dimension:
/// 2 components make a 2D scene, 3 a 3D one ([`SceneFile::dimension`]).
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GridSpec {
    /// Edge length of a square (cubic) cell, m.
    pub cell_size: f64,
    /// Lower-left (-back) corner of the grid, m; left out, the origin.
    #[serde(default, skip_serializing_if = "Vector::is_unset")]
    pub min: Vector,
    /// Upper-right (-front) corner of the grid, m (rounded up to whole
    /// cells).
    pub max: Vector,
    #[serde(default)]
    pub shape_function: ShapeFunctionKind,
    /// Locality γ = βh² of `shape_function = "lme"` (dimensionless, in
    /// [`crate::grid::shape::LME_GAMMA_MIN`], [`crate::grid::shape::LME_GAMMA_MAX`]);
    /// left out: [`crate::grid::shape::LME_GAMMA_DEFAULT`]. Only with LME.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lme_gamma: Option<f64>,
    /// Steps between re-sorts of the particle arrays into the tiles' order
    /// (the order setup stores them in), so that a long run whose particles
    /// have moved across tiles reads memory in order again; 0 or left
    /// out: never (the `resort` stage is then not in the plan). Scenes
    /// without fracture models only, for now.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub resort_every: u32,
    #[serde(default)]
    pub boundary: BoundarySpec,
}

/// Boundary conditions on the sides of the grid: `left`/`right` (x),
/// `bottom`/`top` (y), and in 3D `back`/`front` (z).
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BoundarySpec {
    #[serde(default, deserialize_with = "side_condition")]
    pub left: SideCondition,
    #[serde(default, deserialize_with = "side_condition")]
    pub right: SideCondition,
    #[serde(default, deserialize_with = "side_condition")]
    pub bottom: SideCondition,
    #[serde(default, deserialize_with = "side_condition")]
    pub top: SideCondition,
    /// The z = min side, 3D only (left out: free). Optional, not
    /// defaulted, so that a 2D scene that writes it is refused and a 2D
    /// scene serialises as before.
    #[serde(
        default,
        deserialize_with = "some_side_condition",
        skip_serializing_if = "Option::is_none"
    )]
    pub back: Option<SideCondition>,
    /// The z = max side, 3D only (left out: free).
    #[serde(
        default,
        deserialize_with = "some_side_condition",
        skip_serializing_if = "Option::is_none"
    )]
    pub front: Option<SideCondition>,
}

/// [`side_condition`] for a side that may be left out.
fn some_side_condition<'de, D: Deserializer<'de>>(d: D) -> Result<Option<SideCondition>, D::Error> {
    side_condition(d).map(Some)
}

/// The condition on one side of the grid. Written either as a bare string
/// (`"free"`, `"fixed"`, `"roller"`) or as a table with a `type` key.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum SideCondition {
    /// No constraint.
    #[default]
    Free,
    /// Both velocity components zero on the side's nodes.
    Fixed,
    /// Normal velocity zero (symmetry plane); tangential free.
    #[serde(alias = "symmetry")]
    Roller,
    /// Prescribed velocity components (m/s) as functions of time; a missing
    /// component is left free. `z` is for 3D scenes only.
    Velocity {
        #[serde(default)]
        x: Option<TimeFunction>,
        #[serde(default)]
        y: Option<TimeFunction>,
        #[serde(default, skip_serializing_if = "Option::is_none")]
        z: Option<TimeFunction>,
    },
    /// A traction (Pa) on the outermost particles that face this side, as
    /// functions of time. Positive `normal` pulls outward; `shear` acts
    /// along +x on the bottom and top sides, along +y on the left and right
    /// (and along +x on the back and front).
    Traction {
        #[serde(default)]
        normal: Option<TimeFunction>,
        #[serde(default)]
        shear: Option<TimeFunction>,
    },
}

/// A `traction` side's load as both methods read it: `normal` along the
/// side's outward unit normal, `shear` along +x on the bottom and top (and
/// back and front) sides, along +y on the left and right.
#[derive(Debug, Clone)]
pub struct SideTraction<const D: usize> {
    pub normal: Option<TimeFunction>,
    pub shear: Option<TimeFunction>,
    /// The side's outward unit normal.
    pub out: [f64; D],
    /// The shear's direction.
    pub tangent: [f64; D],
}

impl<const D: usize> SideTraction<D> {
    /// The traction of side `k` (0 left, 1 right, 2 bottom, 3 top, 4 back,
    /// 5 front).
    pub fn new(k: usize, normal: &Option<TimeFunction>, shear: &Option<TimeFunction>) -> Self {
        let across = k / 2;
        let mut out = [0.0; D];
        out[across] = if k % 2 == 0 { -1.0 } else { 1.0 };
        let mut tangent = [0.0; D];
        tangent[if across == 0 { 1 } else { 0 }] = 1.0;
        SideTraction {
            normal: normal.clone(),
            shear: shear.clone(),
            out,
            tangent,
        }
    }

    /// The traction vector at time `t`, Pa.
    pub fn at(&self, t: f64) -> [f64; D] {
        let sn = self.normal.as_ref().map_or(0.0, |f| f.eval(t));
        let ss = self.shear.as_ref().map_or(0.0, |f| f.eval(t));
        std::array::from_fn(|a| sn * self.out[a] + ss * self.tangent[a])
    }
}

/// Reads a [`SideCondition`] from its table form, or from a bare string
/// for the conditions without parameters.
fn side_condition<'de, D: Deserializer<'de>>(d: D) -> Result<SideCondition, D::Error> {
    struct V;
    impl<'de> Visitor<'de> for V {
        type Value = SideCondition;
        fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
            f.write_str("\"free\", \"fixed\", \"roller\", or a table with `type` = free | fixed | roller | velocity | traction")
        }
        fn visit_str<E: de::Error>(self, s: &str) -> Result<SideCondition, E> {
            match s {
                "velocity" | "traction" => Err(E::custom(format!(
                    "`{s}` needs parameters: write it as a table, e.g. {{ type = \"{s}\", ... }}"
                ))),
                _ => SideCondition::deserialize(de::value::MapDeserializer::new(std::iter::once(
                    ("type", s),
                ))),
            }
        }
        fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<SideCondition, A::Error> {
            SideCondition::deserialize(de::value::MapAccessDeserializer::new(map))
        }
    }
    d.deserialize_any(V)
}

/// A scalar function of time: a constant, or a piecewise-linear table of
/// `[time, value]` pairs (held constant outside the table).
#[derive(Debug, Clone, Serialize, PartialEq)]
#[serde(untagged)]
pub enum TimeFunction {
    Constant(f64),
    Table { table: Vec<[f64; 2]> },
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TimeTable {
    table: Vec<[f64; 2]>,
}

impl<'de> Deserialize<'de> for TimeFunction {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = TimeFunction;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("a number, or { table = [[t0, v0], [t1, v1], ...] }")
            }
            fn visit_f64<E: de::Error>(self, v: f64) -> Result<TimeFunction, E> {
                Ok(TimeFunction::Constant(v))
            }
            fn visit_i64<E: de::Error>(self, v: i64) -> Result<TimeFunction, E> {
                Ok(TimeFunction::Constant(v as f64))
            }
            fn visit_u64<E: de::Error>(self, v: u64) -> Result<TimeFunction, E> {
                Ok(TimeFunction::Constant(v as f64))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<TimeFunction, A::Error> {
                let t = TimeTable::deserialize(de::value::MapAccessDeserializer::new(map))?;
                Ok(TimeFunction::Table { table: t.table })
            }
        }
        d.deserialize_any(V)
    }
}

impl TimeFunction {
    /// Value at time `t` (linear interpolation, constant extrapolation).
    pub fn eval(&self, t: f64) -> f64 {
        match self {
            TimeFunction::Constant(v) => *v,
            TimeFunction::Table { table } => {
                let (first, last) = match (table.first(), table.last()) {
                    (Some(f), Some(l)) => (f, l),
                    _ => return 0.0,
                };
                if t <= first[0] {
                    return first[1];
                }
                if t >= last[0] {
                    return last[1];
                }
                for w in table.windows(2) {
                    let (a, b) = (w[0], w[1]);
                    if t <= b[0] {
                        let span = b[0] - a[0];
                        if span <= 0.0 {
                            return b[1];
                        }
                        return a[1] + (b[1] - a[1]) * (t - a[0]) / span;
                    }
                }
                last[1]
            }
        }
    }
}

/// The 2D idealisation: plane strain or plane stress, and the
/// out-of-plane thickness. Both keys are 2D-only: a 3D scene is fully 3D,
/// and one that writes either is refused naming it. So the spec keeps
/// which keys the scene wrote ([`AnalysisSpec::written`]); left out, they
/// are not serialised, but a validated 2D scene writes both (the defaults
/// filled in), as it always has.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(from = "AnalysisKeys", into = "AnalysisKeys")]
pub struct AnalysisSpec {
    pub plane: PlaneKind,
    /// Out-of-plane thickness, m. Plane strain defaults to 1 m (energies per
    /// metre of thickness).
    pub thickness: f64,
    /// Whether `plane` and `thickness` were written (or filled in).
    written: [bool; 2],
}

impl Default for AnalysisSpec {
    fn default() -> Self {
        AnalysisSpec {
            plane: PlaneKind::PlaneStrain,
            thickness: 1.0,
            written: [false; 2],
        }
    }
}

impl AnalysisSpec {
    /// Which of `plane` and `thickness` the scene sets: written, or
    /// changed from their defaults since.
    pub fn written(&self) -> [bool; 2] {
        [
            self.written[0] || self.plane != PlaneKind::PlaneStrain,
            self.written[1] || self.thickness != 1.0,
        ]
    }

    /// Marks both as written (a validated 2D scene's defaults).
    pub(crate) fn write_defaults(&mut self) {
        self.written = [true; 2];
    }
}

/// `[analysis]` as the file has it.
#[derive(Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct AnalysisKeys {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    plane: Option<PlaneKind>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    thickness: Option<f64>,
}

impl From<AnalysisKeys> for AnalysisSpec {
    fn from(k: AnalysisKeys) -> AnalysisSpec {
        AnalysisSpec {
            plane: k.plane.unwrap_or(PlaneKind::PlaneStrain),
            thickness: k.thickness.unwrap_or(1.0),
            written: [k.plane.is_some(), k.thickness.is_some()],
        }
    }
}

impl From<AnalysisSpec> for AnalysisKeys {
    fn from(a: AnalysisSpec) -> AnalysisKeys {
        let [plane, thickness] = a.written();
        AnalysisKeys {
            plane: plane.then_some(a.plane),
            thickness: thickness.then_some(a.thickness),
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TimeSpec {
    /// Simulated end time, s.
    pub end: f64,
    /// Courant factor α: dt = α·h / max(c_p + |v_p|). Default 0.5 when `dt`
    /// is not given.
    #[serde(default)]
    pub cfl: Option<f64>,
    /// A fixed time step, s (checked against the CFL limit every step).
    #[serde(default)]
    pub dt: Option<f64>,
    /// Safety cap on the number of steps (default 10 million).
    #[serde(default)]
    pub max_steps: Option<u64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum TransferKind {
    /// PIC/FLIP blend with `flip_blend` (1 = pure FLIP, 0 = pure PIC).
    #[default]
    Flip,
    /// Pure PIC (dissipative).
    Pic,
    /// Affine PIC (Jiang et al. 2015): conserves angular momentum.
    Apic,
    /// XPIC(1) (Hammerquist & Nairn 2017): PIC velocities with a
    /// second-order position update; what Nairn & Aimene recommend.
    Xpic1,
    /// FMPM(1) (Nairn & Hammerquist 2021): PIC velocities, positions moved
    /// by the mean of the old and new particle velocities; Nairn &
    /// Aimene's J benchmarks (C1–C4) ran with it.
    Fmpm1,
}

/// When the stress is updated within a step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StressUpdate {
    /// Update stress last, from the grid velocities of the step (one
    /// scatter, one gather; dissipates some energy in impacts).
    #[default]
    Usl,
    /// Modified USL (Sulsky et al. 1995; Bardenhagen 2002): map the updated
    /// particle momenta back to the grid and take the velocity gradient from
    /// those; conserves energy much better at the cost of a second scatter
    /// and gather.
    Musl,
    /// The explicit Newmark predictor–corrector of Molinos et al.
    /// (Algorithm 1, eqs. 1–5): the nodal predictor from the particles'
    /// v_p + (1 − γ) Δt a_p, the strain and stress from it, the force
    /// from that stress, the corrector v_I = v_I^pred + γ Δt f_I/m_I, and
    /// particles that carry their acceleration. Single velocity field
    /// only (no contact, explicit cracks, partitioning or phase field).
    Newmark,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct TransferSpec {
    #[serde(default)]
    pub scheme: TransferKind,
    /// FLIP fraction for `scheme = "flip"`, in [0, 1].
    #[serde(default = "default_flip_blend")]
    pub flip_blend: f64,
    #[serde(default)]
    pub stress_update: StressUpdate,
    /// Newmark's γ for `stress_update = "newmark"`, in [0.5, 1] (default
    /// 0.5: second order, no numerical damping; above it damps).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub newmark_gamma: Option<f64>,
}

impl TransferSpec {
    /// Newmark's γ when the stress update is the predictor–corrector.
    pub fn newmark(&self) -> Option<f64> {
        (self.stress_update == StressUpdate::Newmark)
            .then(|| self.newmark_gamma.unwrap_or(NEWMARK_GAMMA_DEFAULT))
    }
}

/// Newmark's γ unless the scene gives one: the average-acceleration
/// value, second order and without numerical damping.
pub const NEWMARK_GAMMA_DEFAULT: f64 = 0.5;

impl Default for TransferSpec {
    fn default() -> Self {
        TransferSpec {
            scheme: TransferKind::Flip,
            flip_blend: default_flip_blend(),
            stress_update: StressUpdate::Usl,
            newmark_gamma: None,
        }
    }
}

fn default_flip_blend() -> f64 {
    0.99
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct MaterialSpec {
    pub model: MaterialModel,
    /// Mass density, kg/m³.
    pub density: f64,
    /// Young's modulus E, Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio ν, in (−1, 0.5).
    pub poissons_ratio: f64,
    /// Phase-field fracture for bodies of this material (Kakouris & Triantafyllou).
    #[serde(default)]
    pub phase_field: Option<PhaseFieldSpec>,
    /// A continuum damage model (Homel & Herbold 2017, section 2.7), run in
    /// single-field mode or, with `[dfg]`, with field-gradient partitioning.
    #[serde(default)]
    pub damage: Option<DamageSpec>,
    /// Eigenerosion or eigensoftening (Molinos et al., after Pandolfi &
    /// Ortiz and Navas et al.).
    #[serde(default)]
    pub eigen: Option<EigenSpec>,
}

/// A body's material: either the name of an entry of `[materials]` or an
/// inline table.
#[derive(Debug, Clone, Serialize)]
#[serde(untagged)]
pub enum MaterialRef {
    Name(String),
    /// Boxed: a material table is ten times the size of a name.
    Inline(Box<MaterialSpec>),
}

impl SceneFile {
    /// The scene's dimension: the number of components of `grid.max`, 2 or
    /// 3 (validation checks every other vector against it).
    pub fn dimension(&self) -> usize {
        self.grid.max.len()
    }

    /// The material spec a body refers to (`None` for an unknown name).
    pub fn material_of<'a>(&'a self, m: &'a MaterialRef) -> Option<&'a MaterialSpec> {
        match m {
            MaterialRef::Inline(spec) => Some(spec),
            MaterialRef::Name(n) => self.materials.get(n),
        }
    }
}

impl<'de> Deserialize<'de> for MaterialRef {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = MaterialRef;
            fn expecting(&self, f: &mut fmt::Formatter) -> fmt::Result {
                f.write_str("the name of a [materials] entry, or an inline material table")
            }
            fn visit_str<E: de::Error>(self, s: &str) -> Result<MaterialRef, E> {
                Ok(MaterialRef::Name(s.to_string()))
            }
            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<MaterialRef, A::Error> {
                MaterialSpec::deserialize(de::value::MapAccessDeserializer::new(map))
                    .map(|m| MaterialRef::Inline(Box::new(m)))
            }
        }
        d.deserialize_any(V)
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct BodySpec {
    #[serde(default)]
    pub name: String,
    pub shape: ShapeSpec,
    /// Regions removed from the shape (holes, notches).
    #[serde(default)]
    pub holes: Vec<ShapeSpec>,
    pub material: MaterialRef,
    /// Particles per cell: a perfect square in 2D (1, 4, 9, 16, ...), a
    /// perfect cube in 3D (1, 8, 27, 64), placed on a regular sub-grid of
    /// each cell. Left out: 4 in 2D, 8 in 3D (2 per direction), which
    /// validation writes in ([`BodySpec::ppc`] reads it).
    #[serde(default)]
    pub particles_per_cell: Option<u32>,
    /// Initial velocity at `velocity_origin`, m/s.
    #[serde(default, skip_serializing_if = "Vector::is_unset")]
    pub velocity: Vector,
    /// Initial velocity gradient ∂v/∂x (row i = ∂v_i/∂x_j), 1/s: the initial
    /// velocity is v + G (x − velocity_origin). A spin ω is [[0, −ω], [ω, 0]].
    /// 2×2 in 2D, 3×3 in 3D.
    #[serde(default, skip_serializing_if = "Matrix::is_unset")]
    pub velocity_gradient: Matrix,
    /// The point about which `velocity_gradient` acts (default: the centroid
    /// of the body's particles).
    #[serde(default)]
    pub velocity_origin: Option<Vector>,
    /// Bodies in different contact groups get separate velocity fields and
    /// interact by frictional contact; bodies in one group share a field.
    #[serde(default)]
    pub contact_group: u32,
    /// Initial cracks: polylines (2D) or flat polygons (3D: three or more
    /// points in one plane, in order) along which, for a phase-field
    /// material, the history field is set so that c ≈ 0 there (Borden et
    /// al. 2012), and for a damage or eigen material the particles are
    /// fully broken (those within 0.55 particle spacings of the crack).
    #[serde(default)]
    pub cracks: Vec<CrackSpec>,
    /// Where the crack-tip diagnostic measures from (phase-field or damage
    /// bodies): the tip is the particle with c < 0.1 farthest from this
    /// point; for damage, the particle with D > 0.9 farthest from it among
    /// those connected to it through such particles (initial cracks
    /// excluded).
    /// Default: the first point of the first initial crack; without either,
    /// the body's tip is not tracked.
    #[serde(default)]
    pub crack_origin: Option<Vector>,
    /// Explicit cracks (Nairn & Aimene's CRAMP, 2D): polylines of crack
    /// points that split the velocity fields, move with the material and
    /// keep their faces from interpenetrating.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub explicit_cracks: Vec<ExplicitCrackSpec>,
    /// A velocity the body imposes, a grip's: each step, at every grid
    /// node where the body holds at least half the mass, the given
    /// components of every field's velocity are set after the grid update
    /// (as a side's velocity condition is); a component left out is free.
    /// `drive = { y = 0.1 }` on a grip pulls its edge along y and lets it
    /// slide along x, a roller that moves. The body's particles move with
    /// those nodes; give it the same initial `velocity`. Grid MPM only.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub drive: Option<DriveSpec>,
}

/// The velocity components (m/s, functions of time) a body imposes
/// ([`BodySpec::drive`]); `z` is for 3D scenes only.
#[derive(Debug, Clone, Default, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct DriveSpec {
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub x: Option<TimeFunction>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub y: Option<TimeFunction>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub z: Option<TimeFunction>,
}

impl BodySpec {
    /// Its particles per cell, the default of a scene of `dim` dimensions
    /// if left out (4 in 2D, 8 in 3D: 2 per direction).
    pub fn ppc(&self, dim: usize) -> u32 {
        self.particles_per_cell
            .unwrap_or(if dim == 3 { 8 } else { 4 })
    }
}

/// An initial crack, m: in 2D a polyline of at least two points, in 3D
/// a flat polygon of at least three (its outline, in order; validation
/// refuses points off one plane), 2 or 3 components each, as the grid has
/// ([`crate::geometry::CrackGeometry`]).
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(deny_unknown_fields)]
pub struct CrackSpec {
    pub points: Vec<Vector>,
    /// How a phase-field body's initial history is laid along the crack.
    #[serde(default)]
    pub profile: CrackProfile,
}

/// The initial history of a phase-field crack (Kakouris & Triantafyllou §5.1: "an initial
/// history field at the corresponding material points as in [18]", Borden
/// et al. 2012).
#[derive(Debug, Clone, Copy, Default, Deserialize, Serialize, PartialEq, Eq)]
#[serde(rename_all = "snake_case")]
pub enum CrackProfile {
    /// The particles within 0.55 particle spacings of the line get
    /// H = B·Ḡc/(4l₀) with B = 10⁶ (c ≈ 10⁻⁶ there): a band one or two
    /// particles wide at any resolution.
    #[default]
    Line,
    /// Borden et al. (2012): H = B·Ḡc/(4l₀)·(1 − 2d/l₀) for a distance
    /// d ≤ l₀/2 from the line, B = 10³: a band l₀ wide whose history falls
    /// linearly to zero at its edges. Needs particle spacing ≤ l₀/2, so that
    /// a row of particles lies within l₀/4 of the line.
    Borden,
}

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ContactSpec {
    /// Coulomb friction coefficient for pairs not listed in `pairs`.
    #[serde(default)]
    pub friction: f64,
    #[serde(default)]
    pub pairs: Vec<ContactPairSpec>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct ContactPairSpec {
    pub groups: [u32; 2],
    pub friction: f64,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct OutputSpec {
    /// Number of time-series rows over the run (evenly spaced in time),
    /// including t = 0 and the end.
    #[serde(default = "default_rows")]
    pub series_rows: u32,
    /// Number of snapshots over the run, including t = 0 and the end
    /// (0 writes none).
    #[serde(default = "default_snapshots")]
    pub snapshots: u32,
    /// Write grid fields with each snapshot.
    #[serde(default = "yes")]
    pub grid_fields: bool,
    /// With damage: particles with damage below this are intact material
    /// for the fragment count (connected components, Homel & Herbold 2017, section 3.4).
    #[serde(default = "default_fragment_damage")]
    pub fragment_damage: f64,
    /// Series columns `reaction_<side>_<axis>`: the force each
    /// constrained grid side exerts on the material over the row's step,
    /// N (its constraint impulse over Δt).
    #[serde(default, skip_serializing_if = "is_false")]
    pub reactions: bool,
    /// Series columns `momentum_<axis>_<body>`: each body's momentum,
    /// kg·m/s (its rate is the force on the body: an impactor's force).
    #[serde(default, skip_serializing_if = "is_false")]
    pub body_momenta: bool,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

fn is_false(b: &bool) -> bool {
    !*b
}

impl Default for OutputSpec {
    fn default() -> Self {
        OutputSpec {
            series_rows: default_rows(),
            snapshots: default_snapshots(),
            grid_fields: true,
            fragment_damage: default_fragment_damage(),
            reactions: false,
            body_momenta: false,
        }
    }
}

fn default_fragment_damage() -> f64 {
    0.5
}

fn default_rows() -> u32 {
    200
}
fn default_snapshots() -> u32 {
    10
}
fn yes() -> bool {
    true
}

/// Thresholds of the numerical guards.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct GuardSpec {
    /// The run fails when kinetic + strain energy exceeds this factor times
    /// (initial energy + |external work| so far), checked on every series row.
    #[serde(default = "default_energy_factor")]
    pub energy_growth: f64,
    /// Nodes lighter than this fraction of the lightest particle mass are
    /// treated as empty (zero velocity). Off (0) by default: B-splines and
    /// GIMP keep the force at a nearly empty node as small as its mass, and
    /// the cutoff costs exact momentum conservation (a small leak of
    /// the momentum over a thousand steps). Raise it for linear shape
    /// functions if thin free surfaces misbehave.
    #[serde(default = "default_mass_fraction")]
    pub min_node_mass_fraction: f64,
}

impl Default for GuardSpec {
    fn default() -> Self {
        GuardSpec {
            energy_growth: default_energy_factor(),
            min_node_mass_fraction: default_mass_fraction(),
        }
    }
}

fn default_energy_factor() -> f64 {
    10.0
}
fn default_mass_fraction() -> f64 {
    0.0
}
