//! The simulation methods, and which one a scene runs: the one place
//! that names them. Adding a method: its module (implementing
//! [`Method`] and declaring its [`MethodEntry`]), and one entry in
//! [`METHODS`].

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::run::{Method, MethodEntry, Resumed};
use crate::scene::{Scene, SceneError};

/// Every method, the first whose `runs` accepts a scene runs it.
pub const METHODS: &[MethodEntry] = &[crate::mpm::METHOD];

/// The method `scene` runs.
fn entry(scene: &Scene) -> &'static MethodEntry {
    METHODS
        .iter()
        .find(|m| (m.runs)(scene))
        // the grid MPM takes every scene the others do not
        .unwrap_or(&METHODS[0])
}

/// Whether some method runs `scene`, or why none does. A 3D scene
/// validates and seeds (issue 32), but no method steps one yet: the grid
/// MPM's core is 2D until it is made generic over the dimension. Asked
/// before a run is set up, so that the CLI's `run` and a server's submit
/// refuse the scene, naming `grid.min`, before writing or queueing
/// anything.
pub fn runnable(scene: &Scene) -> Result<(), SceneError> {
    match scene.dimension() {
        2 => Ok(()),
        d => Err(SceneError::single(
            "grid.min",
            format!(
                "the grid is {d}D (grid.min and grid.max have {d} components): a 3D scene \
                 validates and seeds its bodies, but it cannot be run yet (only 2D scenes run)"
            ),
        )),
    }
}

/// Sets up the run of a validated scene with its method; refuses a scene
/// no method runs ([`runnable`]).
pub fn build(scene: &Scene) -> Result<Box<dyn Method>, SceneError> {
    runnable(scene)?;
    Ok((entry(scene).build)(scene))
}

/// The run of `scene` at `cp`, by the method that wrote it (which must be
/// the one the scene runs).
pub fn resume(scene: &Scene, cp: Checkpoint<'_>) -> Resumed {
    runnable(scene).map_err(|e| CheckpointError::Inconsistent(e.to_string()))?;
    let m = entry(scene);
    if cp.method() != m.name {
        return Err(CheckpointError::Inconsistent(format!(
            "it was written by the {} method, the scene runs {}",
            cp.method(),
            m.name
        )));
    }
    (m.resume)(scene, cp)
}
