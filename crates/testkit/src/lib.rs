//! What the tests, benchmarks and reports measure tileraster with, kept out of the library's
//! API: procedurally generated scenes ([`scenes`]) and 3D meshes ([`meshes`]), deterministic for a seed, and an
//! independent f64 reference ([`reference`]) that shares no code with the preparation or the
//! kernels.
//!
//! (`tileraster-core`'s own unit tests compile `scenes.rs` into themselves: a dev-dependency
//! on this crate would give them a second, incompatible copy of the core's types.)

use tileraster_core::{Grid, Raster, Scene};

pub mod meshes;
pub mod reference;
pub mod scenes;
