//! The peers tileraster's benchmark report compares against, each run on the same input:
//!
//! - [`RenderPipeline`]: the triangles drawn by the GPU's fixed-function rasteriser through a
//!   wgpu render pipeline, as a user of a hardware rasteriser would do it (f32 vertices, linear
//!   interpolation of an f32 height attribute).
//! - [`fill_cpu`] and [`GpuFill`]: store-bandwidth rooflines, the least work any raster call
//!   must do (write every cell once and hand the raster to the host).
//! - [`gdal_grid_linear`]: `gdal_grid -a linear` as an external process, when installed.

mod device;
mod fill;
mod gdal;
mod render;

pub use fill::{GpuFill, fill_cpu};
pub use gdal::{gdal_grid_linear, gdal_grid_version};
pub use render::RenderPipeline;
