//! The engine's integration tests, as one test binary: each file is a
//! module of it. One binary and not one per file because every file used
//! to compile the engine's generic step (`Simulation<D, V>` and the
//! models under it) again for itself in release, about four minutes of a
//! CI core each; here it is compiled once. A test that needs a process
//! of its own (an address-space limit, an environment without fonts)
//! runs itself again in a child (`common::run_in_child`).
//!
//! Run one file's tests with its module as the filter:
//! `cargo test --release --test engine dpm::`.

mod common;

mod checkpoint;
mod crack_snapshots;
mod cracks;
mod damage3d;
mod dfg;
mod dfg3d;
mod dpm;
mod eigen;
mod fuzz;
mod layers;
mod lme;
mod output_files;
mod phase_field;
mod phase_field3d;
mod plan;
mod scene3d;
mod stability;
mod verification;
mod verification3d;
