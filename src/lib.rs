//! cleave: dynamic fracture with the material point method.
//!
//! Start with [`scene::Scene::from_path`] (parse and validate a scene),
//! then [`methods::build`] (the scene's simulation method, a
//! [`run::Method`]) and [`run::Method::run`] with an
//! [`diagnostics::Observer`] such as [`output::OutputWriter`].
//! `docs/architecture.md` maps the modules, the step and the data flow.

pub mod checkpoint;
pub mod contact;
pub mod cpu;
pub mod diagnostics;
pub mod dpm;
pub mod fracture;
pub mod geometry;
pub mod grid;
pub mod jobs;
pub mod material;
pub mod methods;
pub mod mpm;
pub mod neighbours;
pub mod output;
pub mod particles;
pub mod run;
pub mod scene;
pub mod service;
pub mod study;
pub mod tensor;

/// The crate version, as reported by the binaries.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");
