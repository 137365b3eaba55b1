//! The simulation methods, and which one a scene runs: the one place
//! that names them. Adding a method: its module (implementing
//! [`Method`] and declaring its [`MethodEntry`]), and one entry in
//! [`METHODS`].

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::run::{Method, MethodEntry, Resumed};
use crate::scene::{MaterialRef, Scene, SceneError};

/// Every method, the first whose `runs` accepts a scene runs it.
pub const METHODS: &[MethodEntry] = &[crate::mpm::METHOD, crate::dpm::method::METHOD];

/// The method `scene` runs.
fn entry(scene: &Scene) -> &'static MethodEntry {
    METHODS
        .iter()
        .find(|m| (m.runs)(scene))
        // the grid MPM takes every scene the others do not
        .unwrap_or(&METHODS[0])
}

/// Whether some method runs `scene`, or why none does. A 3D scene runs the
/// grid MPM's explicit core (issue 32: the grid, the transfers, the
/// materials, contact and the walls are generic over the dimension),
/// continuum damage (`materials.NAME.damage`: Rankine, time to failure,
/// Weibull strengths, fragments), DFG partitioning (`[dfg]`; with its
/// self-contact a block slides on a plane of its own contact group, 6 %
/// slower than two groups over 60 ms: docs/dfg.md "In 3D") and the phase
/// field (2nd order, and 4th order with
/// the 6 × 6 γ; solved on the 3D stencil, every solver method), with
/// initial cracks (flat polygons) and crack origins; what is still 2D is
/// refused here, naming the key: a phase field's material `angle` (an
/// in-plane turn of the 2D tensor; in 3D γ is given in the scene's axes;
/// the damage particle method's 2D cracks are refused by its validation).
/// Asked before a run is set up, so
/// that the CLI's `run` and a server's submit refuse the scene before
/// writing or queueing anything.
pub fn runnable(scene: &Scene) -> Result<(), SceneError> {
    if scene.dimension() == 2 {
        return Ok(());
    }
    let file = &scene.file;
    let not_yet = |path: String, what: &str| {
        Err(SceneError::single(
            &path,
            format!("{what} in 3D is not run yet (a 3D scene runs the explicit core: elasticity, contact, walls, tractions; continuum damage, DFG partitioning and the phase field)"),
        ))
    };
    // a fracture model, named at its body's material
    for (b, body) in file.bodies.iter().enumerate() {
        let m = &scene.materials[scene.body_material[b]];
        let key = match &body.material {
            MaterialRef::Name(n) => format!("materials.{n}"),
            MaterialRef::Inline(_) => format!("bodies[{b}].material"),
        };
        if let Some(pf) = m.phase_field() {
            if pf.angle != 0.0 {
                return not_yet(
                    format!("{key}.phase_field.angle"),
                    "a material angle (an in-plane turn of the 2D anisotropy tensor; give gamma in the scene's axes)",
                );
            }
        }
    }
    Ok(())
}

/// Sets up the run of a validated scene with its method; refuses a scene
/// no method runs ([`runnable`]).
pub fn build(scene: &Scene) -> Result<Box<dyn Method>, SceneError> {
    runnable(scene)?;
    (entry(scene).build)(scene)
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
