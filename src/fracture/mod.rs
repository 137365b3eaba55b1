//! Fracture models. Each lives in its own module and plugs into the
//! explicit step through the plan; a scene that asks for none runs none.

pub mod cracks;
pub mod damage;
pub mod dfg;
pub mod eigen;
pub mod model;
pub mod phase_field;
pub(crate) mod tracks;

/// Every fracture model the engine knows, in the order of their series
/// columns (and of the summary, snapshots and checkpoint state). A scene
/// gets each model whose [`model::Build`] returns one. Adding a model: its
/// folder, and one line here.
pub(crate) const MODELS: &[model::Build] = &[
    phase_field::model::build::<2, 3>,
    dfg::model::build,
    damage::model::build,
    cracks::model::build,
    eigen::model::build,
];

/// The fracture models that run in 3D (issue 32), in the order of
/// [`MODELS`]: the phase field, DFG partitioning and continuum damage
/// (what of them is still 2D, [`crate::methods::runnable`] refuses in a
/// 3D scene).
pub(crate) const MODELS_3D: &[model::Build<3, 6>] = &[
    phase_field::model::build::<3, 6>,
    dfg::model::build::<3, 6>,
    damage::model::build::<3, 6>,
    eigen::model::build::<3, 6>,
];
