//! The simulation methods, and which one a scene runs: the one place
//! that names them. Adding a method: its module (implementing
//! [`Method`] and declaring its [`MethodEntry`]), and one entry in
//! [`METHODS`].

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::run::{Method, MethodEntry, Resumed};
use crate::scene::Scene;

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

/// Sets up the run of a validated scene with its method.
pub fn build(scene: &Scene) -> Box<dyn Method> {
    (entry(scene).build)(scene)
}

/// The run of `scene` at `cp`, by the method that wrote it (which must be
/// the one the scene runs).
pub fn resume(scene: &Scene, cp: Checkpoint<'_>) -> Resumed {
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
