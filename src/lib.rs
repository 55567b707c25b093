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

mod auto;
pub mod dem;
pub mod render;

pub use auto::{BackendChoice, GPU_MIN_PIXELS, choose_backend};

/// A fragment shader compiled for both backends (`render::FragmentStage`), from a shader crate
/// that `tileraster-build` compiled in the build script: see `examples/procedural`.
pub use tileraster_core::fragment_stage;
pub use tileraster_core::kernels::pipeline::Stage;
/// A vertex shader compiled for both backends (`render::VertexStage`), from a shader crate
/// that `tileraster-build` compiled in the build script: see `examples/waves`.
pub use tileraster_core::vertex_stage;
pub use tileraster_core::{Error, Grid, MAX_GRID_DIM, Mode, Outputs, Params, Pass, Prepared, Raster, Scene, Skip, Skips, Stats, Window};

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

/// Rasterise `scene` onto `params.grid`. What the call did and skipped is in `raster.stats`.
pub fn rasterise(scene: &Scene, params: &Params, backend: Backend) -> Result<Raster, Error> {
    rasterise_window(scene, params, None, backend)
}

/// Rasterise one window of `params.grid` (the whole grid for `None`). A window's cells are
/// bit for bit the cells the whole grid has there.
pub fn rasterise_window(scene: &Scene, params: &Params, window: Option<Window>, backend: Backend) -> Result<Raster, Error> {
    let prepared = tileraster_core::prepare(scene, params, window)?;
    rasterise_prepared(&prepared, backend)
}

/// Snap, cull, fit planes and analyse overlaps once; rasterise the result with
/// [`rasterise_prepared`], or keep it on a backend with [`PreparedScene`].
pub use tileraster_core::prepare;

/// Rasterise an already prepared scene once, over the window it was prepared for.
pub fn rasterise_prepared(prepared: &Prepared, backend: Backend) -> Result<Raster, Error> {
    match backend {
        Backend::Cpu => tileraster_cpu::rasterise(prepared),
        Backend::Gpu => tileraster_gpu::rasterise(prepared),
    }
}

/// A scene prepared for one grid and kept on one backend: prepare once, rasterise many
/// windows. The first call that has something to draw uploads the triangles and sets them up
/// (the `upload` and `setup` passes); later calls reuse both, and only list the triangles
/// their window needs.
///
/// ```no_run
/// use tileraster::{Backend, Grid, Params, PreparedScene, Scene, Stage, Window};
/// # let scene = Scene::new(vec![[0.0, 0.0, 1.0], [100.0, 0.0, 2.0], [0.0, 100.0, 3.0]], vec![[0, 1, 2]]);
/// let params = Params::new(Grid::new(0.0, 100.0, 0.0, 100.0, 8192, 8192));
/// let mut dem = PreparedScene::new(&scene, &params, Backend::Gpu)?;
/// for y0 in (0..8192).step_by(1024) {
///     let part = dem.rasterise_window(Window { x0: 0, y0, width: 8192, height: 1024 })?;
///     assert!(!part.stats.passes.contains(&Stage::Setup.into()) || y0 == 0);
/// }
/// # Ok::<(), tileraster::Error>(())
/// ```
pub struct PreparedScene {
    prepared: Prepared,
    backend: Backend,
    resident: Resident,
}

/// What a backend keeps of a prepared scene between calls.
enum Resident {
    Cpu(Option<tileraster_cpu::Resident>),
    Gpu(Option<tileraster_gpu::Resident>),
}

impl PreparedScene {
    /// Prepare `scene` for `params.grid`, to run on `backend`.
    pub fn new(scene: &Scene, params: &Params, backend: Backend) -> Result<Self, Error> {
        Ok(PreparedScene::from_prepared(prepare(scene, params, None)?, backend))
    }

    pub fn from_prepared(prepared: Prepared, backend: Backend) -> Self {
        let resident = match backend {
            Backend::Cpu => Resident::Cpu(None),
            Backend::Gpu => Resident::Gpu(None),
        };
        PreparedScene { prepared, backend, resident }
    }

    pub fn prepared(&self) -> &Prepared {
        &self.prepared
    }

    pub fn backend(&self) -> Backend {
        self.backend
    }

    /// The whole grid (or the window the scene was prepared for).
    pub fn rasterise(&mut self) -> Result<Raster, Error> {
        self.rasterise_window(self.prepared.window)
    }

    /// Any window of the grid, bit for bit the cells the whole grid has there.
    pub fn rasterise_window(&mut self, window: Window) -> Result<Raster, Error> {
        let p = &self.prepared;
        match &mut self.resident {
            Resident::Cpu(r) => tileraster_cpu::rasterise_planned(p, &p.plan(window, r.is_some())?, r),
            Resident::Gpu(r) => tileraster_gpu::rasterise_planned(p, &p.plan(window, r.is_some())?, r),
        }
    }
}

pub use tileraster_gpu::{
    Adapter, AssemblyOn as GpuAssemblyOn, FineWalk, set_assembly_on as set_gpu_assembly_on, set_binding_limit as set_gpu_binding_limit,
    set_fine_walk as set_gpu_fine_walk, set_window_limit as set_gpu_window_limit,
};

/// The Vulkan adapter [`Backend::Gpu`] uses, or why there is none.
pub fn gpu_adapter() -> Result<Adapter, Error> {
    tileraster_gpu::adapter()
}
