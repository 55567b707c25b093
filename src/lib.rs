//! # tileraster
//!
//! A deterministic tile rasteriser. Triangles are rasterised into grids by kernels written
//! once in `no_std` Rust (`tileraster-kernels`), compiled to SPIR-V and run through wgpu
//! ([`Backend::Gpu`]), or linked natively into a rayon host dispatcher ([`Backend::Cpu`]).
//! Both backends produce bit-identical rasters.
//!
//! ```no_run
//! use tileraster::{rasterise, Backend, Grid, Params, Scene};
//! let scene = Scene::new(
//!     vec![[0.0, 0.0, 10.0], [100.0, 0.0, 20.0], [0.0, 100.0, 30.0]],
//!     vec![[0, 1, 2]],
//! );
//! let params = Params::new(Grid::new(0.0, 100.0, 0.0, 100.0, 256, 256)).with_nodata(-9999.0);
//! let raster = rasterise(&scene, &params, Backend::Cpu)?;
//! assert_eq!(raster.values.len(), 256 * 256);
//! # Ok::<(), tileraster::Error>(())
//! ```

pub use tileraster_core::{reference, scenes, Error, Grid, Mode, Outputs, Params, Prepared, Raster, Scene, Window};

/// Where the kernels run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Backend {
    /// The kernels natively, on the CPU's cores (rayon).
    Cpu,
    /// The kernels as SPIR-V, on a Vulkan adapter through wgpu.
    Gpu,
}

impl Backend {
    pub fn name(self) -> &'static str {
        match self {
            Backend::Cpu => "cpu",
            Backend::Gpu => "gpu",
        }
    }
}

/// Rasterise `scene` onto `params.grid`.
pub fn rasterise(scene: &Scene, params: &Params, backend: Backend) -> Result<Raster, Error> {
    rasterise_window(scene, params, None, backend)
}

/// Rasterise one window of `params.grid` (the whole grid for `None`). A window's cells are
/// bit for bit the cells the whole grid has there.
pub fn rasterise_window(scene: &Scene, params: &Params, window: Option<Window>, backend: Backend) -> Result<Raster, Error> {
    let prepared = tileraster_core::prepare(scene, params, window)?;
    rasterise_prepared(&prepared, backend)
}

/// Snap, cull and fit planes once; rasterise the result with [`rasterise_prepared`].
pub use tileraster_core::prepare;

/// Rasterise an already prepared scene.
pub fn rasterise_prepared(prepared: &Prepared, backend: Backend) -> Result<Raster, Error> {
    match backend {
        Backend::Cpu => tileraster_cpu::rasterise(prepared),
        Backend::Gpu => tileraster_gpu::rasterise(prepared),
    }
}

pub use tileraster_gpu::{set_window_limit as set_gpu_window_limit, Adapter};

/// The Vulkan adapter [`Backend::Gpu`] uses, or why there is none.
pub fn gpu_adapter() -> Result<Adapter, Error> {
    tileraster_gpu::adapter()
}
