//! The peers tileraster's benchmark report compares against, each run on the same input:
//!
//! - [`RenderPipeline`]: the triangles drawn by the GPU's fixed-function rasteriser through a
//!   wgpu render pipeline, as a user of a hardware rasteriser would do it (f32 vertices, linear
//!   interpolation of an f32 height attribute).
//! - [`MeshPipeline`]: a mesh drawn by the same rasteriser with a depth buffer (or in API
//!   order), writing triangle ids: the render pipeline's coverage reference and speed peer.
//! - [`MultisampledPipeline`]: a mesh drawn by the same rasteriser 4× multisampled, every
//!   sample's triangle id read back: the reference for multisampled coverage.
//! - [`TexturedPipeline`]: a textured mesh drawn by the same rasteriser and its texture units:
//!   the reference for texture sampling.
//! - [`MarblePipeline`]: the procedural marble of `examples/procedural` as a WGSL fragment
//!   shader in the same rasteriser: the peer of the programmable fragment stage.
//! - [`fill_cpu`] and [`GpuFill`]: store-bandwidth rooflines, the least work any raster call
//!   must do (write every cell once and hand the raster to the host).
//! - [`gdal_grid_linear`]: `gdal_grid -a linear` as an external process, when installed.

mod device;
mod fill;
mod gdal;
mod marble;
mod mesh;
mod multisample;
mod render;
mod textured;

pub use fill::{GpuFill, fill_cpu};
pub use gdal::{gdal_grid_linear, gdal_grid_linear_radius, gdal_grid_version};
pub use marble::MarblePipeline;
pub use mesh::{MeshPipeline, NO_ID};
pub use multisample::{MultisampledPipeline, NO_SAMPLE_ID, PEER_SAMPLES};
pub use render::RenderPipeline;
pub use textured::{TexturedPipeline, mip_levels};
