//! Host side shared by both backends: the scene and grid types, typed errors, and the
//! preparation that snaps geometry and fits height planes once per scene, and the render
//! pipeline's geometry stages (`render`).

mod error;
mod grid;
mod overlap;
mod plan;
mod prepare;
mod raster;
pub mod render;
mod scene;
/// The test kit's scenes, compiled into the unit tests (see `tileraster-testkit`).
#[cfg(test)]
#[allow(dead_code)]
#[path = "../../testkit/src/scenes.rs"]
mod scenes;

pub use error::Error;
pub use grid::{Grid, MAX_GRID_DIM, Mode, Outputs, Params, Skip, Skips};
pub use overlap::overlap_free;
pub use plan::{Pass, Plan, Stats};
pub use prepare::{Prepared, RenderInputs, Window, prepare, snap_bits};
pub use raster::{Difference, Layers, Raster, zeroed_cells};
pub use scene::Scene;
pub use tileraster_kernels as kernels;
