//! The simulation methods, and which one a scene runs: the one place
//! that names them. Adding a method: its module (implementing
//! [`Method`]), and one entry in [`METHODS`].

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::run::Method;
use crate::scene::Scene;

/// A method's run resumed from a checkpoint it wrote.
pub type Resumed = Result<Box<dyn Method>, CheckpointError>;

/// A simulation method as the registry knows it.
pub struct MethodEntry {
    /// Its name, as checkpoints record it ([`Method::name`]).
    pub name: &'static str,
    /// Whether a validated scene runs this method.
    pub runs: fn(&Scene) -> bool,
    /// Sets up the scene's run.
    pub build: fn(&Scene) -> Box<dyn Method>,
    /// The run at a checkpoint this method wrote.
    pub resume: fn(&Scene, Checkpoint<'_>) -> Resumed,
}

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
