//! The GPU backend: the kernels compiled to SPIR-V by rust-gpu (see `build.rs`), dispatched
//! through wgpu. One context per process keeps the device, the pipelines and the buffers
//! across calls; rasters larger than the device's buffer limits are cut into windows, and
//! scenes whose triangles do not fit one binding are set up window by window with the
//! triangles that reach each, which changes no bit of the result (every pixel depends only on
//! the triangles covering it, and keeps their order).

mod context;
pub mod device;
mod float_controls;
mod pipeline_cache;
mod profile;
mod specialise;
pub mod survey;

pub use context::{
    Adapter, AssembledOnDevice, AssemblyOn, FineWalk, GeometryDevice, Resident, ResidentTexels, adapter, assemble_rows, light_rows, rasterise, rasterise_frame,
    rasterise_into, rasterise_planned, rasterise_profiled, set_assembly_on, set_binding_limit, set_fine_walk, set_window_limit, stage_buffers,
};
pub use float_controls::{FloatControls, f32_probe};
pub use profile::CallProfile;

/// The kernels as compiled by rust-gpu, every float arithmetic result marked `NoContraction`
/// (see `build.rs`).
pub const KERNELS_SPV: &[u8] = include_bytes!(env!("TILERASTER_KERNELS_SPV"));

/// [`KERNELS_SPV`] with 32-bit round-to-nearest-even and subnormal preservation declared on
/// every entry point, for adapters that report both.
pub const KERNELS_FLOAT_CONTROLS_SPV: &[u8] = include_bytes!(env!("TILERASTER_KERNELS_FLOAT_CONTROLS_SPV"));
