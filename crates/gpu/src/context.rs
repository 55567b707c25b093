#[path = "assemble.rs"]
mod assemble;
use assemble::HeldRecords;
pub use assemble::{AssembledOnDevice, GeometryDevice, assemble_rows, light_rows};

use crate::device::{Gpu, Grown};
use crate::float_controls::{self, FloatControls};
use crate::pipeline_cache::DiskPipelineCache;
use crate::profile::{CallProfile, Recorder};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU8, AtomicU64, Ordering};
use std::sync::{Arc, Mutex, OnceLock};
use std::time::{Duration, Instant};
use tileraster_build::Role;
use tileraster_core::render::{Positions, ShaderModules};
use tileraster_core::{Error, Layers, Mode, Plan, Prepared, Raster, Window};
use tileraster_kernels::abi::{
    Counter, FrameFlags, FrameParams, MaterialRecord, ProjectedVertex, RelativePosition, ShadeParams, ShadeVariant, TextureInfo, TriangleInput, TriangleSetup,
    TriangleShading, VertexParams,
};
use tileraster_kernels::memory::LANE_GROUP;
use tileraster_kernels::pipeline::{Access, Buffer, Cells, Dispatch, LAYERS, Layer, LayerInfo, Pipeline, STAGES, Scope, Stage, StageBuffers, StageInfo};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::stages::scan::QUEUE_HEAD;
use tileraster_kernels::stages::{bin, fine};
use tileraster_kernels::{BIN_PART_TILES, NO_OWNER, TILE, TRIANGLE_GROUP};

/// Workgroups a dispatch may have along each dimension: Vulkan's least
/// `maxComputeWorkGroupCount`, wgpu's default limit.
const MAX_GROUPS: u32 = 65_535;

/// Largest window the backend rasterises at once, in pixels, whatever the device allows:
/// big enough to keep a GPU busy, small enough to bound the per-window buffers.
static WINDOW_LIMIT: AtomicU64 = AtomicU64::new(4096 * 4096);

/// Cap the pixels the GPU rasterises per window (at least one tile). Windows never change a
/// result; this trades memory for dispatch overhead, and lets tests exercise many windows.
pub fn set_window_limit(pixels: u64) {
    WINDOW_LIMIT.store(pixels.max((TILE * TILE) as u64), Ordering::Relaxed);
}

/// Largest buffer the backend binds, in bytes, below what the device allows: `u64::MAX`
/// unless a test lowers it (see [`set_binding_limit`]).
static BINDING_LIMIT: AtomicU64 = AtomicU64::new(u64::MAX);

/// Bind at most `bytes` per buffer (at least one tile's layer), below the device's own limit.
/// Like windows, this never changes a result: it lets tests reach, on small scenes, the
/// windows and the scene parts that large scenes need on devices with small bindings.
pub fn set_binding_limit(bytes: u64) {
    BINDING_LIMIT.store(bytes.max((TILE * TILE * 4) as u64), Ordering::Relaxed);
}

/// Which way the fine-raster stages' pixels meet their tile's bin (`fine::WALK`). Both give
/// the same bits and counts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FineWalk {
    /// Walk where it pays: on a CPU implementation of Vulkan (`walks_bins`).
    Auto,
    /// Every pixel walks its bin, on every device whose subgroups hold groups of eight lanes
    /// (the walk's reads, `memory::Lanes`; the others keep the batches).
    Always,
    /// Staged batches, on every device.
    Never,
}

static FINE_WALK: AtomicU8 = AtomicU8::new(FineWalk::Auto as u8);

/// Choose how `fine_raster` meets its bins from now on (the tests run both ways on every
/// device; a benchmark compares them).
pub fn set_fine_walk(walk: FineWalk) {
    FINE_WALK.store(walk as u8, Ordering::Relaxed);
}

/// Where a GPU frame's assembly runs (`assemble_count`, `assemble_scan`, `assemble_fill`).
/// Both give the same bits, counts and `Stats::bytes_uploaded`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssemblyOn {
    /// Where it pays (`assembles_on_device`): the device's rows on a GPU, the host's twins on a
    /// CPU implementation of Vulkan.
    Auto,
    /// The device's rows, their records set up where they wrote them.
    Device,
    /// The host's twins, their records uploaded for setup.
    Host,
}

static ASSEMBLY_ON: AtomicU8 = AtomicU8::new(AssemblyOn::Auto as u8);

/// Choose where GPU frames' assembly runs from now on (a test runs the device's rows on every
/// device; a benchmark compares the two).
pub fn set_assembly_on(on: AssemblyOn) {
    ASSEMBLY_ON.store(on as u8, Ordering::Relaxed);
}

/// Whether a frame's assembly runs on `device`'s rows rather than the host's twins, unless
/// told (`set_assembly_on`): on a GPU. On a CPU implementation of Vulkan the twins on all
/// cores, their records uploaded, beat the rows and the read-back of their records: on
/// lavapipe, a prepared frame of the 100k-triangle terrain at 1080p (face ids) took 98.5 and
/// 101.4 ms with the twins, 217.6 and 156.4 ms with the rows (`examples/prepared_frames`, two
/// rounds, 2026-11-28). A GPU
/// runs the rows until a device measures them against the twins.
pub(crate) fn assembles_on_device(device: wgpu::DeviceType) -> bool {
    match ASSEMBLY_ON.load(Ordering::Relaxed) {
        on if on == AssemblyOn::Device as u8 => true,
        on if on == AssemblyOn::Host as u8 => false,
        _ => device != wgpu::DeviceType::Cpu,
    }
}

static CONTEXT: OnceLock<Result<Mutex<GpuContext>, Error>> = OnceLock::new();

fn context() -> Result<&'static Mutex<GpuContext>, Error> {
    CONTEXT.get_or_init(|| GpuContext::new().map(Mutex::new)).as_ref().map_err(Clone::clone)
}

/// The adapter the GPU backend uses.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Adapter {
    pub name: String,
    pub device_type: String,
    pub driver: String,
    /// A CPU implementation of Vulkan (such as lavapipe) rather than a GPU.
    pub software: bool,
    /// What it reports of IEEE-754 float controls.
    pub float_controls: FloatControls,
    /// Whether the kernels declare round-to-nearest-even and subnormal preservation on it.
    pub float_controls_declared: bool,
}

impl std::fmt::Display for Adapter {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} ({}, {})", self.name, self.device_type, self.driver)
    }
}

/// The adapter the GPU backend uses (opening it on first use).
pub fn adapter() -> Result<Adapter, Error> {
    let ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    let info = &ctx.gpu.info;
    Ok(Adapter {
        name: info.name.clone(),
        device_type: format!("{:?}", info.device_type),
        driver: format!("{} {}", info.driver, info.driver_info).trim().to_string(),
        software: info.device_type == wgpu::DeviceType::Cpu,
        float_controls: ctx.float_controls,
        float_controls_declared: ctx.float_controls_declared,
    })
}

/// A prepared scene's triangles on the device, set up: kept for later calls, so that
/// rasterising more windows of the grid uploads and sets up nothing again. Dropping it frees
/// the device memory.
pub struct Resident {
    setups: wgpu::Buffer,
    /// The render pipeline's per-triangle attributes.
    shading: Option<wgpu::Buffer>,
}

/// A prepared mesh's texels on the device, kept for its later frames: a frame that lays its
/// textures out alike (the same shared texels) uploads none of them again. Dropping it frees
/// the device memory.
pub struct ResidentTexels {
    /// What the buffer holds (shared with the frames that lay them out so: held here, the
    /// allocation cannot be reused by other texels while this names it).
    texels: Arc<Vec<u64>>,
    buffer: wgpu::Buffer,
}

impl ResidentTexels {
    /// Whether these are `texels` (the same shared allocation).
    pub fn holds(&self, texels: &Arc<Vec<u64>>) -> bool {
        Arc::ptr_eq(&self.texels, texels)
    }
}

/// Rasterise a prepared scene on the GPU, over the preparation's window.
pub fn rasterise(prepared: &Prepared) -> Result<Raster, Error> {
    rasterise_planned(prepared, &prepared.plan(prepared.window, false)?, &mut None)
}

/// [`rasterise`] into the layers of `spare` (an earlier call's raster) where they hold enough
/// memory: a caller that renders frame after frame faults no fresh pages in for the read-back.
pub fn rasterise_into(prepared: &Prepared, spare: Layers) -> Result<Raster, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    ctx.rasterise(prepared, &prepared.plan(prepared.window, false)?, &mut None, spare)
}

/// [`rasterise_into`] for a frame whose geometry stages ran on `geometry`: its records set up
/// where the assembly wrote them on the device (where it did: `RenderInputs::records_held`).
/// With `texels` (a prepared mesh's frame), its texels from there where it holds them (the
/// frame's `texels_resident` says so), else uploaded into a buffer of their own and kept there
/// for the next frame.
pub fn rasterise_frame(prepared: &Prepared, spare: Layers, geometry: &GeometryDevice, texels: Option<&mut Option<ResidentTexels>>) -> Result<Raster, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    let plan = prepared.plan(prepared.window, false)?;
    ctx.held_records = geometry.records_of(prepared);
    let raster = match texels {
        Some(texels) => {
            ctx.kept_texels = Some(texels.take());
            let raster = ctx.rasterise(prepared, &plan, &mut None, spare);
            let kept = ctx.kept_texels.take().flatten();
            // A failed call may have left its new buffer unwritten: the next frame uploads afresh.
            *texels = if raster.is_ok() { kept } else { None };
            raster
        }
        None => ctx.rasterise(prepared, &plan, &mut None, spare),
    };
    ctx.held_records = None;
    raster
}

/// Run `plan`, uploading and setting the scene up first unless `resident` already holds it.
pub fn rasterise_planned(prepared: &Prepared, plan: &Plan, resident: &mut Option<Resident>) -> Result<Raster, Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    ctx.rasterise(prepared, plan, resident, Layers::default())
}

/// [`rasterise_planned`], and what the call did on the device: its dispatches, submissions,
/// waits and bytes moved each way, and with `time_stages` (where the adapter writes
/// timestamps) the device time of each stage. With `geometry` (whose stages prepared the
/// frame), its records are set up where its assembly wrote them, as [`rasterise_frame`] does.
pub fn rasterise_profiled(
    prepared: &Prepared,
    plan: &Plan,
    resident: &mut Option<Resident>,
    time_stages: bool,
    geometry: Option<&GeometryDevice>,
) -> Result<(Raster, CallProfile), Error> {
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    let timing = time_stages && ctx.timestamps;
    ctx.recorder.start(timing);
    ctx.held_records = geometry.and_then(|g| g.records_of(prepared));
    let raster = ctx.rasterise(prepared, plan, resident, Layers::default());
    if ctx.held_records.take().is_some() {
        // Its setups are of records in the geometry's buffers, which its next frame reuses.
        *resident = None;
    }
    let profile = ctx.recorder.finish(&ctx.gpu.device, ctx.gpu.queue.get_timestamp_period()).map_err(Error::Gpu)?;
    Ok((raster?, profile))
}

/// A storage buffer of at least `bytes` (and 16) bytes, that kernels read and write and the
/// host fills and copies from.
fn storage_buffer(device: &wgpu::Device, label: &str, bytes: u64) -> wgpu::Buffer {
    device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16).next_multiple_of(16),
        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// A mesh's kept positions on the device, in parts of `per_part` positions (each fits one
/// binding), and their key (`Positions::kept`).
#[derive(Debug)]
struct KeptPositions {
    key: u64,
    per_part: usize,
    buffers: Vec<wgpu::Buffer>,
}

/// The buffers the stages before fine raster leave for the preparation's window (see
/// `StageBuffers`), read back after rasterising it: the stage-by-stage comparison of the
/// backends. `None` when no triangle reaches the window; an error for a window the backend
/// would cut into several (only the last one's buffers would be left).
pub fn stage_buffers(prepared: &Prepared) -> Result<Option<StageBuffers>, Error> {
    let plan = prepared.plan(prepared.window, false)?;
    let Some(active) = plan.active else {
        return Ok(None);
    };
    let mut ctx = context()?.lock().map_err(|_| Error::Gpu("GPU context poisoned by an earlier panic".into()))?;
    let frame = plan.frame(prepared, active);
    let rows = ctx.stage_pipelines_of(prepared)?;
    if windows(&active, ctx.max_window_pixels(prepared)).len() != 1 || plan.bin_capacity(prepared, &frame) * ctx.bytes_per_bin_entry(&rows) > ctx.max_binding()
    {
        return Err(Error::Gpu(format!("the {}×{} window is rasterised in parts: read its stage buffers window by window", active.width, active.height)));
    }
    let mut resident = None;
    ctx.rasterise(prepared, &plan, &mut resident, Layers::default())?;
    let Some(Resident { setups, .. }) = resident else {
        return Err(Error::Gpu("the scene is set up in parts: read its stage buffers window by window".into()));
    };
    ctx.read_stage_buffers(prepared.triangles.len() as u64, frame.tile_count() as u64, &setups).map(Some)
}

/// A stage's pipeline and the layout of its one bind group, both built from its row of the
/// stage table.
struct StagePipeline {
    pipeline: wgpu::ComputePipeline,
    layout: wgpu::BindGroupLayout,
}

struct Buffers {
    frame: Grown,
    listed: Grown,
    small_listed: Grown,
    pixel_keys: Grown,
    tile_queue: Grown,
    counts: Grown,
    offsets: Grown,
    cursors: Grown,
    bins: Grown,
    bin_keys: Grown,
    stats: Grown,
    /// The output layers, in the layer table's order (`LAYERS`).
    layers: [Grown; LAYERS.len()],
    shade_params: Grown,
    textures: Grown,
    materials: Grown,
    texels: Grown,
    readback: Grown,
    vertex_params: Grown,
    positions: Grown,
    projected: Grown,
}

struct GpuContext {
    gpu: Gpu,
    float_controls: FloatControls,
    float_controls_declared: bool,
    /// Whether the `f32` modes give the CPU backend's bits here: checked on first use.
    float_modes: Option<Result<(), String>>,
    /// The kernels' module, as the device gets it (with float controls where declared).
    kernels: &'static [u8],
    /// The user's shaders (fragment and vertex) seen so far, their modules checked.
    programs: Vec<ShaderModules>,
    /// Every pipeline built so far, with what it was built from: each row of the stage table
    /// is built when a frame first runs it (a driver compiles each: a heightfield never pays
    /// for the render pipeline's), once per module and specialisation (`Build`).
    pipelines: Vec<(Build, StagePipeline)>,
    /// The driver's pipeline cache, kept on disk, where the device has one.
    pipeline_cache: Option<DiskPipelineCache>,
    buffers: Buffers,
    /// The dispatches, transfers and (in profiled calls) stage times of the call in progress.
    recorder: Recorder,
    /// During a prepared mesh's frame, the texels it keeps on the device (`Some`: it keeps
    /// them; inside, what it held before the call and holds after it).
    kept_texels: Option<Option<ResidentTexels>>,
    /// During a frame whose records the assembly wrote on the device, those records.
    held_records: Option<HeldRecords>,
    /// Whether the device writes timestamps (`TIMESTAMP_QUERY`).
    timestamps: bool,
}

/// What a stage's pipeline is built from: its row of the stage table, the module (the
/// kernels', or the user's shader `program`'s: a fragment shader's for the rows that colour
/// fragments, a vertex shader's for the vertex stage), and the
/// specialisation constant (`SpecId`, value) written into it, so that the driver compiles only
/// the branches a frame takes: the frame's `ShadeVariant` for the rows that colour fragments,
/// the way through the bins for the fine-raster rows (`fine::WALK_SPEC_ID`), with the
/// heightfield's value mode for `fine_raster`.
#[derive(Copy, Clone, PartialEq, Eq)]
struct Build {
    row: usize,
    /// An index into `GpuContext::programs`.
    program: Option<usize>,
    /// Specialisation constants set in its module: `(SpecId, value)`.
    spec: [Option<(u32, u32)>; 2],
}

/// Whether the fine-raster stages' pixels walk their tile's bin (`fine::WALK`) rather than
/// staging it in batches: on a CPU implementation of Vulkan, where each barrier switches every
/// invocation of the workgroup out and back in, and each load of storage or workgroup memory
/// is made one lane at a time (the walk reads a record once per eight lanes). Measured on
/// lavapipe (`docs/results.md`), walk against batches, ms of the stage: the TIN 650 against
/// 3450, micro-triangles 31–72 against 132–236, slivers 92 against 571, the terrain mesh 250
/// against 349, the fill-rate frame 271 against 536. A GPU keeps the batches, the way measured
/// on hardware, until a device measures the walk (`xtask stage-times --walk`).
fn walks_bins(device: wgpu::DeviceType) -> bool {
    device == wgpu::DeviceType::Cpu
}

/// Whether the device's subgroups hold whole groups of `LANE_GROUP` lanes, which the walk
/// reads its records with (`memory::Lanes`; every subgroup size is a power of two).
fn lane_groups(info: &wgpu::AdapterInfo) -> bool {
    info.subgroup_min_size >= LANE_GROUP
}

/// Prefer a real GPU, then an integrated one, then a CPU implementation such as lavapipe.
/// `TILERASTER_ADAPTER=<substring>` picks an adapter by name instead.
fn choose_adapter(adapters: Vec<wgpu::Adapter>) -> Result<wgpu::Adapter, String> {
    let wanted = std::env::var("TILERASTER_ADAPTER").ok();
    let seen: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
    let needed = crate::survey::needed_features();
    let usable = adapters.into_iter().filter(|a| a.features().contains(needed));
    let rank = |a: &wgpu::Adapter| match a.get_info().device_type {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    };
    let mut usable: Vec<_> = match &wanted {
        Some(name) => usable.filter(|a| a.get_info().name.contains(name.as_str())).collect(),
        None => usable.collect(),
    };
    usable.sort_by_key(rank);
    usable.into_iter().next().ok_or_else(|| match (&wanted, seen.is_empty()) {
        (_, true) => "no Vulkan adapter was found".into(),
        (Some(name), false) => {
            format!("no adapter named like {name:?} with 64-bit integers, 64-bit atomic minima and subgroup operations in shaders and SPIR-V passthrough among {seen:?}")
        }
        (None, false) => format!("none of the Vulkan adapters {seen:?} supports 64-bit integers, 64-bit atomic minima and subgroup operations in shaders and SPIR-V passthrough"),
    })
}

impl GpuContext {
    fn new() -> Result<Self, Error> {
        // Timestamps where the adapter has them: profiled calls time each stage's passes.
        let (gpu, adapter) =
            Gpu::open("tileraster", crate::survey::needed_features(), wgpu::Features::TIMESTAMP_QUERY | wgpu::Features::PIPELINE_CACHE, choose_adapter)
                .map_err(|details| Error::NoAdapter { details })?;
        // Every stage binds its storage buffers at once: an adapter that binds fewer per stage
        // cannot run the table (Vulkan guarantees only 4; desktop GPUs and lavapipe bind far more).
        let needed = STAGES.iter().map(|s| s.bindings.iter().filter(|b| b.access != Access::Uniform).count() as u32).max().unwrap_or(0);
        let bound = gpu.limits.max_storage_buffers_per_shader_stage;
        if bound < needed {
            return Err(Error::NoAdapter {
                details: format!("{} binds at most {bound} storage buffers per shader stage; tileraster's stages bind up to {needed}", gpu.info.name),
            });
        }
        let float_controls = FloatControls::of(&adapter);
        let declared = float_controls.declared(&adapter.get_info());
        // Its pipelines are built when a frame first runs them (`stage_pipelines_of`).
        let kernels = if declared { crate::KERNELS_FLOAT_CONTROLS_SPV } else { crate::KERNELS_SPV };
        let buffers = Buffers {
            frame: Grown::uniform("frame"),
            listed: Grown::storage("listed triangles"),
            small_listed: Grown::storage("small triangles"),
            pixel_keys: Grown::storage("pixel keys"),
            tile_queue: Grown::new("tile queue", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::INDIRECT),
            counts: Grown::storage("bin counts"),
            offsets: Grown::storage("bin offsets"),
            cursors: Grown::storage("bin cursors"),
            bins: Grown::storage("bins"),
            bin_keys: Grown::storage("bin keys"),
            stats: Grown::storage("statistics"),
            layers: LAYERS.map(|info| Grown::storage(info.name)),
            shade_params: Grown::storage("shade parameters"),
            textures: Grown::storage("textures"),
            materials: Grown::storage("materials"),
            texels: Grown::storage("texels"),
            readback: Grown::readback("readback"),
            vertex_params: Grown::storage("vertex parameters"),
            positions: Grown::storage("relative positions"),
            projected: Grown::storage("projected vertices"),
        };
        let timestamps = gpu.device.features().contains(wgpu::Features::TIMESTAMP_QUERY);
        let pipeline_cache = DiskPipelineCache::open(&gpu.device, &gpu.info);
        Ok(GpuContext {
            gpu,
            float_controls,
            float_controls_declared: declared,
            float_modes: None,
            kernels,
            programs: Vec::new(),
            pipelines: Vec::new(),
            pipeline_cache,
            buffers,
            recorder: Recorder::default(),
            kept_texels: None,
            held_records: None,
            timestamps,
        })
    }

    /// The first `bytes` of `source`, copied out through a buffer the host maps.
    fn read_buffer(&self, source: &wgpu::Buffer, bytes: u64) -> Result<Vec<u8>, Error> {
        let size = bytes.max(4).next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT);
        let readback = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("stage read-back"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = self.gpu.device.create_command_encoder(&Default::default());
        encoder.copy_buffer_to_buffer(source, 0, &readback, 0, size);
        let mut out = Vec::new();
        let scope = self.gpu.error_scope();
        self.recorder.submit();
        self.recorder.wait(size);
        let read = self.gpu.submit_and_read(encoder, &readback, size, |b| out.extend_from_slice(&b[..bytes as usize]));
        match (scope.finish(), read) {
            (Some(e), _) | (None, Err(e)) => Err(Error::Gpu(format!("reading a stage buffer back: {e}"))),
            (None, Ok(())) => Ok(out),
        }
    }

    /// The setups of `triangles` triangles and the last window's counts, offsets and bins for
    /// `tiles` tiles, as the stages left them.
    fn read_stage_buffers(&mut self, triangles: u64, tiles: u64, setups: &wgpu::Buffer) -> Result<StageBuffers, Error> {
        let device = &self.gpu.device;
        let (counts, offsets, bins) =
            (self.buffers.counts.get(device, tiles * 4), self.buffers.offsets.get(device, (tiles + 1) * 4), self.buffers.bins.get(device, 0));
        let words = |bytes: Vec<u8>| -> Vec<u32> { bytemuck::pod_collect_to_vec(&bytes) };
        let offsets = words(self.read_buffer(&offsets, (tiles + 1) * 4)?);
        let entries = offsets[tiles as usize] as u64;
        Ok(StageBuffers {
            setups: bytemuck::pod_collect_to_vec(&self.read_buffer(setups, triangles * std::mem::size_of::<TriangleSetup>() as u64)?),
            counts: words(self.read_buffer(&counts, tiles * 4)?),
            bins: words(self.read_buffer(&bins, entries * 4)?),
            offsets,
        })
    }

    /// Most pixels one window may have: every output layer must fit one binding.
    fn max_window_pixels(&self, prepared: &Prepared) -> u64 {
        let words: u64 = LAYERS.iter().filter(|i| i.cells == Cells::Pixel && prepared.writes(i.layer)).map(|i| i.words as u64).sum();
        (self.max_binding() / 4 / words).min(WINDOW_LIMIT.load(Ordering::Relaxed))
    }

    /// Largest buffer a kernel may bind.
    fn max_binding(&self) -> u64 {
        self.gpu.max_storage_binding().min(BINDING_LIMIT.load(Ordering::Relaxed))
    }

    /// Whether `triangles` triangles' setups (and the render pipeline's shading) fit one
    /// binding each, so that the whole scene can be set up once and stay resident.
    fn scene_fits(&self, prepared: &Prepared, triangles: u64) -> bool {
        triangles * scene_bytes_per_triangle(prepared) <= self.max_binding()
    }

    fn rasterise(&mut self, prepared: &Prepared, plan: &Plan, resident: &mut Option<Resident>, spare: Layers) -> Result<Raster, Error> {
        let mode = prepared.params.mode;
        if mode != Mode::Exact {
            self.check_float_modes(mode)?;
        }
        self.rasterise_unchecked(prepared, plan, resident, spare)
    }

    /// Whether the `f32` modes give the CPU backend's bits here (checked on first use), as an
    /// error naming `mode` where they do not.
    fn check_float_modes(&mut self, mode: Mode) -> Result<(), Error> {
        if self.float_modes.is_none() {
            let checked = float_controls::check(|probe| self.rasterise_unchecked(probe, &probe.plan(probe.window, false)?, &mut None, Layers::default()));
            self.float_modes = Some(checked);
        }
        match &self.float_modes {
            Some(Err(reason)) => Err(Error::ModeInexactOnAdapter { mode: mode.name(), adapter: self.gpu.info.name.clone(), reason: reason.clone() }),
            _ => Ok(()),
        }
    }

    /// The vertex stage over `positions` into `projected`, without the check of its arithmetic.
    /// Its pipeline is built on first use; its buffers are kept between calls, and a mesh's
    /// kept positions (`Positions::kept`) stay on the device in `kept`. Where the stage runs in
    /// one part, its output stays on the device too, in `on_device` (grown as needed; `None`
    /// after a stage in parts).
    #[allow(clippy::too_many_arguments)]
    fn vertex_unchecked(
        &mut self,
        params: &VertexParams,
        positions: Positions<'_>,
        program: Option<usize>,
        texture: &wgpu::Buffer,
        kept: &mut Option<KeptPositions>,
        on_device: &mut Option<wgpu::Buffer>,
        projected: &mut Vec<ProjectedVertex>,
    ) -> Result<u64, Error> {
        projected.clear();
        if positions.pairs.is_empty() {
            return Ok(positions.bytes(true));
        }
        // Parts that each fit one binding (and one 2D dispatch).
        let per_part = (self.max_binding() / std::mem::size_of::<RelativePosition>() as u64).min(MAX_GROUPS as u64 * MAX_GROUPS as u64) as usize;
        let per_part = per_part.max(TRIANGLE_GROUP as usize);
        let parts: Vec<&[RelativePosition]> = positions.pairs.chunks(per_part).collect();
        let out_bytes = (positions.pairs.len() * std::mem::size_of::<ProjectedVertex>()) as u64;
        let mut out = match parts.len() {
            1 => {
                // (Grown as `Grown` grows its buffers: the old one dropped first.)
                if on_device.as_ref().is_none_or(|b| b.size() < out_bytes) {
                    *on_device = None;
                    *on_device = Some(storage_buffer(&self.gpu.device, "projected vertices", out_bytes));
                }
                on_device.clone()
            }
            _ => {
                *on_device = None;
                None
            }
        };
        if let (Some(key), Some(held)) = (positions.kept, kept.as_ref())
            && held.key == key
            && held.per_part == per_part
        {
            let buffers = held.buffers.clone();
            let mut first = 0;
            for (part, buffer) in parts.iter().zip(&buffers) {
                self.vertex_part(params, program, texture, first, part.len() as u64, buffer, out.take(), projected)?;
                first += part.len() as u32;
            }
            return Ok(positions.bytes(false));
        }
        // Handed over: into buffers of their own where they are kept (the old ones dropped
        // first), else into the stage's buffer, part by part. Kept only once the stage has run
        // on them with no error raised (a failed call hands them over again).
        *kept = None;
        let scope = self.gpu.error_scope();
        let mut own = Vec::new();
        let mut run = || -> Result<(), Error> {
            let mut first = 0;
            for part in &parts {
                let bytes = std::mem::size_of_val(*part) as u64;
                let buffer = match positions.kept {
                    Some(_) => self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
                        label: Some("kept positions"),
                        size: bytes.next_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT),
                        usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                        mapped_at_creation: false,
                    }),
                    None => self.buffers.positions.get(&self.gpu.device, bytes),
                };
                self.recorder.upload(&self.gpu.queue, &buffer, bytemuck::cast_slice(part));
                self.vertex_part(params, program, texture, first, part.len() as u64, &buffer, out.take(), projected)?;
                first += part.len() as u32;
                own.push(buffer);
            }
            Ok(())
        };
        let ran = run();
        if let Some(e) = scope.finish() {
            return Err(Error::Gpu(format!("the vertex stage's positions: {e}")));
        }
        ran?;
        if let Some(key) = positions.kept {
            *kept = Some(KeptPositions { key, per_part, buffers: own });
        }
        Ok(positions.bytes(true))
    }

    /// The vertex stage (its module the user's shader `program`'s, else the kernels') over the
    /// first `n` positions of `positions` (which fit one binding), its results written to `out`
    /// (else to a buffer of the context's) and appended to `projected`.
    #[allow(clippy::too_many_arguments)]
    fn vertex_part(
        &mut self,
        params: &VertexParams,
        program: Option<usize>,
        texture: &wgpu::Buffer,
        first_vertex: u32,
        n: u64,
        positions: &wgpu::Buffer,
        out: Option<wgpu::Buffer>,
        projected: &mut Vec<ProjectedVertex>,
    ) -> Result<(), Error> {
        let out_bytes = n * std::mem::size_of::<ProjectedVertex>() as u64;
        let scope = self.gpu.error_scope();
        let mut rows = vec![None; STAGES.len()];
        rows[Stage::Vertex as usize] = Some(self.frame_row_of(Stage::Vertex, program));
        let groups = (n as u32).div_ceil(TRIANGLE_GROUP).max(1);
        let (x, y) = (groups.min(MAX_GROUPS), groups.div_ceil(MAX_GROUPS));
        let params = VertexParams { vertices: n as u32, dispatch_width: x * TRIANGLE_GROUP, first_vertex, ..*params };
        let device = &self.gpu.device;
        let params_buf = self.buffers.vertex_params.get(device, std::mem::size_of::<VertexParams>() as u64);
        let projected_buf = out.unwrap_or_else(|| self.buffers.projected.get(device, out_bytes));
        self.recorder.upload(&self.gpu.queue, &params_buf, bytemuck::bytes_of(&params));
        let mut encoder = device.create_command_encoder(&Default::default());
        let buffers = |buffer| match buffer {
            Buffer::VertexParams => Some(params_buf.clone()),
            Buffer::Positions => Some(positions.clone()),
            Buffer::Projected => Some(projected_buf.clone()),
            Buffer::VertexTexture => Some(texture.clone()),
            _ => None,
        };
        let frame = FrameParams::default();
        // The dispatch and the read-back in one submission.
        let read = self.encode_stages(&mut encoder, Pipeline::Render, &rows, Scope::Frame, &frame, (x, y), &buffers).and_then(|()| {
            let readback = self.buffers.readback.get(device, out_bytes);
            encoder.copy_buffer_to_buffer(&projected_buf, 0, &readback, 0, out_bytes);
            self.recorder.submit();
            self.recorder.wait(out_bytes);
            let collect = |b: &[u8]| projected.extend(bytemuck::pod_collect_to_vec::<u8, ProjectedVertex>(b));
            self.gpu.submit_and_read(encoder, &readback, out_bytes, collect).map_err(|e| Error::Gpu(format!("the vertex stage: {e}")))
        });
        if let Some(e) = scope.finish() {
            return Err(Error::Gpu(format!("the vertex stage: {e}")));
        }
        read
    }

    /// [`Self::rasterise`] without the check of the `f32` modes.
    fn rasterise_unchecked(&mut self, prepared: &Prepared, plan: &Plan, resident: &mut Option<Resident>, spare: Layers) -> Result<Raster, Error> {
        // The owner layer the stages keep without returning it stays on the device.
        let mut raster = plan.allocate_raster_reusing(prepared, spare, false)?;
        let mut counters = [0u64; Counter::COUNT];
        if let Some(active) = plan.active {
            let scope = self.gpu.error_scope();
            let result = self.rasterise_windows(prepared, plan, active, resident, &mut raster, &mut counters);
            let raised = scope.finish();
            result?;
            if let Some(e) = raised {
                return Err(Error::Gpu(e));
            }
        }
        raster.stats = plan.stats(&counters);
        Ok(raster)
    }

    /// Rasterise `active` window by window. A scene whose setups fit one binding is set up
    /// once and kept (`resident`); a larger one is set up in parts, each window with only the
    /// triangles that reach it (see [`Self::upload_and_setup`]).
    fn rasterise_windows(
        &mut self,
        prepared: &Prepared,
        plan: &Plan,
        active: Window,
        resident: &mut Option<Resident>,
        raster: &mut Raster,
        counters: &mut [u64; Counter::COUNT],
    ) -> Result<(), Error> {
        let rows = self.stage_pipelines_of(prepared)?;
        let max_pixels = self.max_window_pixels(prepared);
        let whole = self.scene_fits(prepared, prepared.triangles.len() as u64);
        // Records the assembly wrote on the device are set up there, with its lists where they
        // are the plan's (a plan of the frame's window: every record the assembly keeps
        // reaches it, in order; a plan of a part of it lists its own).
        let held = self
            .held_records
            .clone()
            .filter(|h| whole && plan.window == prepared.window && h.listed == plan.listed.len() as u64 && h.small == plan.small.len() as u64);
        if whole && resident.is_none() {
            *resident = Some(self.upload_and_setup(prepared, &rows, None, held.as_ref())?);
        }
        let shade_params = prepared.render.as_ref().map(|s| {
            let buf = self.buffers.shade_params.get(&self.gpu.device, std::mem::size_of::<ShadeParams>() as u64);
            self.recorder.upload(&self.gpu.queue, &buf, bytemuck::bytes_of(&s.params));
            buf
        });
        // The frame's textures and materials, once for all its windows (bindings hold at least
        // one element).
        let surfaces = match prepared.render.as_ref() {
            Some(s) => {
                let texel_bytes = (s.texels.len() as u64 * 8).max(8);
                if texel_bytes > self.max_binding() {
                    return Err(Error::TexturesTooLarge { bytes: texel_bytes, limit: self.max_binding() });
                }
                let infos = self
                    .buffers
                    .textures
                    .get(&self.gpu.device, (std::mem::size_of_val(s.textures.as_slice()) as u64).max(std::mem::size_of::<TextureInfo>() as u64));
                self.recorder.upload(&self.gpu.queue, &infos, bytemuck::cast_slice(&s.textures));
                let held = self.kept_texels.as_ref().and_then(Option::as_ref).filter(|r| r.holds(&s.texels)).map(|r| r.buffer.clone());
                if held.is_some() != s.texels_resident {
                    // The plan counted what the call uploads by the caller's word.
                    return Err(Error::Gpu(format!(
                        "the frame says its texels are resident ({}), the device holds them: {}",
                        s.texels_resident,
                        held.is_some()
                    )));
                }
                let texels = match held {
                    Some(buffer) => buffer,
                    // A prepared mesh's frame: a buffer of their own, kept for the next frame.
                    None if self.kept_texels.is_some() => {
                        let buffer = self.gpu.device.create_buffer(&wgpu::BufferDescriptor {
                            label: Some("resident texels"),
                            size: texel_bytes,
                            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST,
                            mapped_at_creation: false,
                        });
                        self.recorder.upload(&self.gpu.queue, &buffer, bytemuck::cast_slice(&s.texels));
                        self.kept_texels = Some(Some(ResidentTexels { texels: s.texels.clone(), buffer: buffer.clone() }));
                        buffer
                    }
                    None => {
                        let texels = self.buffers.texels.get(&self.gpu.device, texel_bytes);
                        self.recorder.upload(&self.gpu.queue, &texels, bytemuck::cast_slice(&s.texels));
                        texels
                    }
                };
                let materials = self
                    .buffers
                    .materials
                    .get(&self.gpu.device, (std::mem::size_of_val(s.materials.as_slice()) as u64).max(std::mem::size_of::<MaterialRecord>() as u64));
                self.recorder.upload(&self.gpu.queue, &materials, bytemuck::cast_slice(&s.materials));
                Some((infos, texels, materials))
            }
            None => None,
        };
        // The window's list of triangles, once for all its dispatches (a resident scene's).
        let (listed_buf, small_buf) = match &held {
            Some(h) => (Some(h.listed_slots.clone()), Some(h.small_slots.clone())),
            None => (whole.then(|| self.upload_list(ListBuffer::Listed, &plan.listed)), whole.then(|| self.upload_list(ListBuffer::Small, &plan.small))),
        };
        let mut pending = windows(&active, max_pixels);
        pending.reverse();
        while let Some(window) = pending.pop() {
            // A scene in parts: the triangles reaching this window, set up on their own.
            let part = if whole {
                None
            } else {
                let part = ScenePart::of(plan.listed_reaching(prepared, window), plan.small_reaching(prepared, window));
                if !self.scene_fits(prepared, part.slots.len() as u64) {
                    let bytes = part.slots.len() as u64 * scene_bytes_per_triangle(prepared);
                    split(&mut pending, window, || {
                        format!(
                            "{} triangles reach it, {bytes} bytes of setup, more than the GPU binds at once ({} bytes)",
                            part.slots.len(),
                            self.max_binding()
                        )
                    })?;
                    continue;
                }
                Some(part)
            };
            let (listed, small) = match &part {
                Some(p) => (p.listed.as_slice(), p.small.as_slice()),
                None => (plan.listed.as_slice(), plan.small.as_slice()),
            };
            let frame = plan.frame_listing(prepared, window, listed, small);
            let entries = Plan::bin_capacity_listing(prepared, &frame, listed);
            if entries * self.bytes_per_bin_entry(&rows) > self.max_binding() || entries > u32::MAX as u64 {
                split(&mut pending, window, || format!("{entries} triangle–tile pairs, more than the GPU binds"))?;
                continue;
            }
            let window_counters = match &part {
                None => {
                    let r = resident.as_ref().expect("a whole scene is set up before its windows");
                    let scene = SceneBuffers::of(prepared, &rows, r, shade_params.as_ref(), surfaces.as_ref());
                    let lists = (listed_buf.as_ref().expect("listed with the whole scene"), small_buf.as_ref().expect("listed with the whole scene"));
                    self.rasterise_window(&frame, entries, &scene, lists, None, raster)?
                }
                Some(part) => {
                    let r = self.upload_and_setup(prepared, &rows, Some(&part.slots), None)?;
                    let scene = SceneBuffers::of(prepared, &rows, &r, shade_params.as_ref(), surfaces.as_ref());
                    // The part's setups are its own slots 0, 1, ...: the stages take them by those.
                    let listed_buf = self.upload_list(ListBuffer::Listed, &part.local_listed);
                    let small_buf = self.upload_list(ListBuffer::Small, &part.local_small);
                    let owners = prepared.pipeline().renders().then_some(part.slots.as_slice());
                    self.rasterise_window(&frame, entries, &scene, (&listed_buf, &small_buf), owners, raster)?
                }
            };
            for (total, c) in counters.iter_mut().zip(window_counters) {
                *total += c as u64;
            }
        }
        Ok(())
    }

    /// `slots` in the buffer of list `which` (a binding holds at least one element).
    fn upload_list(&mut self, which: ListBuffer, slots: &[u32]) -> wgpu::Buffer {
        let grown = match which {
            ListBuffer::Listed => &mut self.buffers.listed,
            ListBuffer::Small => &mut self.buffers.small_listed,
        };
        let buf = grown.get(&self.gpu.device, (std::mem::size_of_val(slots) as u64).max(4));
        self.recorder.upload(&self.gpu.queue, &buf, bytemuck::cast_slice(slots));
        buf
    }

    /// Workgroups for `items` invocations of a per-triangle stage, in 2D past
    /// [`MAX_GROUPS`].
    fn dispatch_triangles(frame: &mut FrameParams, items: u32) -> (u32, u32) {
        let groups = items.div_ceil(TRIANGLE_GROUP).max(1);
        let x = groups.min(MAX_GROUPS);
        let y = groups.div_ceil(x);
        frame.dispatch_width = x * TRIANGLE_GROUP;
        (x, y)
    }

    /// For each row of the stage table, the index in `self.pipelines` of the pipeline that
    /// runs it for `prepared` (`None` for the rows its pipeline does not run), built on first
    /// use.
    fn stage_pipelines_of(&mut self, prepared: &Prepared) -> Result<Vec<Option<usize>>, Error> {
        let fragment = match prepared.render.as_ref().and_then(|r| r.fragment.as_ref()) {
            Some(stage) => stage.modules().map(|m| self.program_index(m, Role::Fragment)).transpose()?,
            None => None,
        };
        let shade_variant = prepared.render.as_ref().map(|r| if ShadeVariant::holds(&r.params) { ShadeVariant::of(&r.params) } else { ShadeVariant::GENERIC });
        let scope = self.gpu.error_scope();
        let mut rows = vec![None; STAGES.len()];
        let built = self.pipelines.len();
        let cache = self.pipeline_cache.as_ref().map(|c| &c.cache);
        let walks = match FINE_WALK.load(Ordering::Relaxed) {
            _ if !lane_groups(&self.gpu.info) => false,
            w if w == FineWalk::Always as u8 => true,
            w if w == FineWalk::Never as u8 => false,
            _ => walks_bins(self.gpu.info.device_type),
        };
        // The frame's depth test, fixed in the stages that test depth (`DepthProgram::spec_bits`),
        // and whether every triangle's edge functions fit 32 bits (`ShadeParams::small_edges`,
        // found by preparation), so that those stages take them in 32-bit arithmetic.
        let depth = prepared
            .render
            .as_ref()
            .map_or(0, |r| DepthProgram::spec_bits(r.depth_test) | if r.params.small_edges != 0 { DepthProgram::SMALL_EDGES } else { 0 });
        let walk = if walks { fine::WALK } else { 0 };
        let no_tiles_left = if prepared.may_leave_tiles_to_shade() { 0 } else { fine::NO_TILES_LEFT };
        for (row, info) in STAGES.iter().enumerate().filter(|(_, info)| info.scope != Scope::Frame && info.runs_in(prepared.pipeline())) {
            let build = match info.stage {
                _ if info.stage.colours_fragments() => {
                    // Both test depth (the shade stage resolves the tiles fine raster leaves
                    // to it); the multisampled stage walks its bins where the others do.
                    let way = if info.stage == Stage::FineSamples { walk | depth } else { depth | no_tiles_left };
                    Build { row, program: fragment, spec: [shade_variant.map(|v| (ShadeVariant::SPEC_ID, v.0)), Some((fine::WALK_SPEC_ID, way))] }
                }
                // Binning writes its entries' span masks where the fine stage walks
                // (`stages::bin::entry_spans`), and their keys where `fine_depth`'s walk
                // rejects hidden triangles (`stages::bin::entry_keys`).
                Stage::BinFill => {
                    let keys = walks && prepared.pipeline() == Pipeline::Render && prepared.params.skips.hidden_triangles;
                    let spans = if walks { bin::WRITE_SPANS } else { 0 };
                    // (Binning's keys take no edge function at a pixel: the small-edge bit
                    // stays out of its constant, and out of its pipeline variants.)
                    let keys = if keys { bin::WRITE_KEYS | depth & !DepthProgram::SMALL_EDGES } else { 0 };
                    Build { row, program: None, spec: [Some((bin::KEYS_SPEC_ID, spans | keys)), None] }
                }
                // The small triangles' depth test is `fine_depth`'s.
                Stage::FineSmall => Build { row, program: None, spec: [Some((fine::WALK_SPEC_ID, depth)), None] },
                Stage::FineRaster | Stage::FineDepth => {
                    // `fine_raster`'s value mode shares the constant, as `fine_depth`'s depth test.
                    let mode = if info.stage == Stage::FineRaster { prepared.params.mode as u32 + 1 } else { depth };
                    Build { row, program: None, spec: [Some((fine::WALK_SPEC_ID, mode | walk)), None] }
                }
                _ => Build { row, program: None, spec: [None; 2] },
            };
            rows[row] = Some(match self.pipelines.iter().position(|(b, _)| *b == build) {
                Some(k) => k,
                None => {
                    let (module, label) = self.module_of(&build);
                    let module = passthrough_module(&self.gpu.device, &label, module, &build.spec, |other| other.stage == info.stage);
                    self.pipelines.push((build, stage_pipeline(&self.gpu.device, &module, info, cache)));
                    self.pipelines.len() - 1
                }
            });
        }
        match scope.finish() {
            Some(e) => Err(Error::Gpu(format!("the kernels were rejected by the device: {e}"))),
            None => {
                if self.pipelines.len() > built
                    && let Some(cache) = &self.pipeline_cache
                {
                    cache.save();
                }
                Ok(rows)
            }
        }
    }

    /// The index in `self.programs` of the user's shader `modules` (a `role` one), its module
    /// checked on first use by `tileraster-build`'s checks again (the bytes are handed to the
    /// driver unvalidated).
    pub(super) fn program_index(&mut self, modules: ShaderModules, role: Role) -> Result<usize, Error> {
        if let Some(k) = self.programs.iter().position(|m| *m == modules) {
            return Ok(k);
        }
        let module = modules.module(self.float_controls_declared);
        let name = modules.name().into();
        tileraster_build::check::program_module(module, role).map_err(|problems| match role {
            Role::Vertex => Error::VertexShader { name, problems },
            _ => Error::FragmentShader { name, problems },
        })?;
        self.programs.push(modules);
        Ok(self.programs.len() - 1)
    }

    /// The module a pipeline is built from, and its label.
    pub(super) fn module_of(&self, build: &Build) -> (&'static [u8], String) {
        let info = &STAGES[build.row];
        match build.program {
            Some(k) => (self.programs[k].module(self.float_controls_declared), format!("shader {}, {}", self.programs[k].name(), info.name)),
            None => (self.kernels, format!("tileraster kernels, {}", info.name)),
        }
    }

    /// Record the stages of `scope`, in the stage table's order, each with its bindings looked
    /// up by role in `buffers` and its workgroups by its dispatch shape, each run by its pipeline
    /// in `rows` (`stage_pipelines_of`).
    #[allow(clippy::too_many_arguments)]
    fn encode_stages(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        pipeline: Pipeline,
        rows: &[Option<usize>],
        scope: Scope,
        frame: &FrameParams,
        triangle_groups: (u32, u32),
        buffers: &dyn Fn(Buffer) -> Option<wgpu::Buffer>,
    ) -> Result<(), Error> {
        // The frame's rows run one at a time, as the host's preparation reaches them: a call
        // records those it has built a pipeline for.
        let ours = |k: usize, info: &StageInfo| info.scope != Scope::Frame || rows[k].is_some();
        let run: Vec<(usize, &StageInfo)> = STAGES
            .iter()
            .enumerate()
            .filter(|&(k, info)| info.scope == scope && info.runs_in(pipeline) && info.runs_for(frame.flags) && ours(k, info))
            .collect();
        let record = |encoder: &mut wgpu::CommandEncoder, queries: Option<&wgpu::QuerySet>| -> Result<(), Error> {
            for (n, &(k, info)) in run.iter().enumerate() {
                let stage = &self.pipelines[rows[k].ok_or_else(|| Error::Gpu(format!("stage {} has no pipeline for this frame", info.name)))?].1;
                let bound: Vec<wgpu::Buffer> = info
                    .bindings
                    .iter()
                    .map(|b| buffers(b.buffer).ok_or_else(|| Error::Gpu(format!("stage {} binds {:?}, which its scope has not", info.name, b.buffer))))
                    .collect::<Result<_, _>>()?;
                let entries: Vec<wgpu::BindGroupEntry> =
                    bound.iter().enumerate().map(|(k, b)| wgpu::BindGroupEntry { binding: k as u32, resource: b.as_entire_binding() }).collect();
                let bind = self.gpu.device.create_bind_group(&wgpu::BindGroupDescriptor { label: Some(info.name), layout: &stage.layout, entries: &entries });
                let (x, y) = match info.dispatch {
                    Dispatch::PerTriangle | Dispatch::PerTrianglePart | Dispatch::PerVertex | Dispatch::PerFace => triangle_groups,
                    Dispatch::Single => (1, 1),
                    Dispatch::PerTile => (frame.tiles_x, frame.tiles_y),
                    Dispatch::PerSmallTriangle => {
                        let groups = frame.small_triangles.div_ceil(TRIANGLE_GROUP).max(1);
                        (groups.min(MAX_GROUPS), groups.div_ceil(MAX_GROUPS))
                    }
                    // The counts are on the device: `bin_scan` wrote them, at most the
                    // window's tile rows (`windows` bounds those).
                    Dispatch::Queued => (0, 0),
                };
                let timestamp_writes = queries.map(|query_set| wgpu::ComputePassTimestampWrites {
                    query_set,
                    beginning_of_pass_write_index: Some(2 * n as u32),
                    end_of_pass_write_index: Some(2 * n as u32 + 1),
                });
                let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor { label: Some(info.name), timestamp_writes });
                pass.set_pipeline(&stage.pipeline);
                pass.set_bind_group(0, &bind, &[]);
                if info.dispatch == Dispatch::Queued {
                    let queue = info.bindings.iter().position(|b| b.buffer == Buffer::TileQueue).map(|k| &bound[k]);
                    let queue = queue.ok_or_else(|| Error::Gpu(format!("stage {} is dispatched by the tile queue but does not bind it", info.name)))?;
                    pass.dispatch_workgroups_indirect(queue, 0);
                } else {
                    pass.dispatch_workgroups(x, y, 1);
                }
                self.recorder.dispatch();
            }
            Ok(())
        };
        if self.recorder.timing() && !run.is_empty() {
            let mut recorded = Ok(());
            let stages = run.iter().map(|(_, info)| info.stage).collect();
            self.recorder.time_passes(&self.gpu.device, encoder, stages, |encoder, queries| recorded = record(encoder, Some(queries)));
            recorded
        } else {
            record(encoder, None)
        }
    }

    /// Upload the prepared triangles (all of them, or the setup slots `part` lists, which then
    /// take the slots 0, 1, ... in that order; none where `held` has them all on the device)
    /// and run the scene stages over them: the setups stay on the device.
    ///
    /// In a part, the render pipeline's triangles carry their new slot as their index (its
    /// shade stage reads the setups by the owner layer, see `programs::depth`): the order of
    /// the slots is the scene's, so depth ties and blending go the same way, and the owner
    /// layer is mapped back to the scene's slots as it is read.
    fn upload_and_setup(&mut self, prepared: &Prepared, rows: &[Option<usize>], part: Option<&[u32]>, held: Option<&HeldRecords>) -> Result<Resident, Error> {
        let n = part.map_or(prepared.triangles.len(), <[u32]>::len) as u64;
        let renumber = prepared.pipeline().renders();
        let inputs_part: Option<Vec<TriangleInput>> = part.map(|slots| {
            slots
                .par_iter()
                .enumerate()
                .map(|(k, &s)| {
                    let t = prepared.triangles[s as usize];
                    TriangleInput { index: if renumber { k as u32 } else { t.index }, ..t }
                })
                .collect()
        });
        let shading_part: Option<Vec<TriangleShading>> =
            part.zip(prepared.render.as_ref()).map(|(slots, r)| slots.par_iter().map(|&s| r.triangles[s as usize]).collect());
        let mut frame = FrameParams { triangles: n as u32, snap_bits: prepared.snap_bits, ..Default::default() };
        let groups = Self::dispatch_triangles(&mut frame, n as u32);
        let device = &self.gpu.device;
        let frame_buf = self.buffers.frame.get(device, std::mem::size_of::<FrameParams>() as u64);
        self.recorder.upload(&self.gpu.queue, &frame_buf, bytemuck::bytes_of(&frame));
        // Bindings must hold at least one element. The inputs are dropped once set up.
        let slots = n.max(1);
        let storage = |label, bytes| {
            device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: bytes,
                // Copied from only by `stage_buffers`, which reads the setups back.
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            })
        };
        let setups = storage("triangle setups", slots * std::mem::size_of::<TriangleSetup>() as u64);
        let (inputs, shading) = match held.filter(|_| part.is_none()) {
            Some(h) => (h.inputs.clone(), Some(h.shading.clone())),
            None => {
                let inputs = storage("triangle inputs", slots * std::mem::size_of::<TriangleInput>() as u64);
                self.recorder.upload(&self.gpu.queue, &inputs, bytemuck::cast_slice(inputs_part.as_deref().unwrap_or(&prepared.triangles)));
                let shading = prepared.render.as_ref().map(|s| {
                    let buf = storage("triangle shading", slots * std::mem::size_of::<TriangleShading>() as u64);
                    self.recorder.upload(&self.gpu.queue, &buf, bytemuck::cast_slice(shading_part.as_deref().unwrap_or(&s.triangles)));
                    buf
                });
                (inputs, shading)
            }
        };
        let mut encoder = device.create_command_encoder(&Default::default());
        let buffers = |buffer| match buffer {
            Buffer::Frame => Some(frame_buf.clone()),
            Buffer::Inputs => Some(inputs.clone()),
            Buffer::Setups | Buffer::SetupWords => Some(setups.clone()),
            _ => None,
        };
        self.encode_stages(&mut encoder, prepared.pipeline(), rows, Scope::Scene, &frame, groups, &buffers)?;
        self.recorder.submit();
        self.gpu.queue.submit([encoder.finish()]);
        Ok(Resident { setups, shading })
    }

    /// Whether the binning pipeline among `rows` writes its entries' keys (`bin::KEYS_SPEC_ID`).
    fn writes_bin_keys(&self, rows: &[Option<usize>]) -> bool {
        let bin_fill = STAGES.iter().position(|s| s.stage == Stage::BinFill);
        bin_fill
            .and_then(|row| rows[row])
            .is_some_and(|k| matches!(self.pipelines[k].0.spec[0], Some((bin::KEYS_SPEC_ID, value)) if value & bin::WRITE_KEYS != 0))
    }

    /// Whether the binning pipeline among `rows` writes its entries' span masks after them in
    /// the bins (`bin::WRITE_SPANS`), for a fine stage that walks.
    fn writes_bin_spans(&self, rows: &[Option<usize>]) -> bool {
        let bin_fill = STAGES.iter().position(|s| s.stage == Stage::BinFill);
        bin_fill
            .and_then(|row| rows[row])
            .is_some_and(|k| matches!(self.pipelines[k].0.spec[0], Some((bin::KEYS_SPEC_ID, value)) if value & bin::WRITE_SPANS != 0))
    }

    /// The largest binding a bin entry takes room in: its slot (4 bytes), with its span mask,
    /// or its two keys.
    fn bytes_per_bin_entry(&self, rows: &[Option<usize>]) -> u64 {
        if self.writes_bin_keys(rows) {
            2 * 8
        } else if self.writes_bin_spans(rows) {
            2 * 4
        } else {
            4
        }
    }

    /// One window's dispatches and readback; returns its statistics counters.
    fn rasterise_window(
        &mut self,
        frame: &FrameParams,
        entries: u64,
        scene: &SceneBuffers,
        (listed, small_listed): (&wgpu::Buffer, &wgpu::Buffer),
        owner_slots: Option<&[u32]>,
        raster: &mut Raster,
    ) -> Result<[u32; Counter::COUNT], Error> {
        let mut frame = *frame;
        // Binning runs one invocation per triangle and band of its tile rows.
        let items = frame.triangles as u64 * frame.bin_parts as u64;
        let items = u32::try_from(items).map_err(|_| Error::RasterTooLarge {
            width: frame.win_w as u64,
            height: frame.win_h as u64,
            reason: format!("binning needs {items} invocations, more than one dispatch holds"),
        })?;
        let groups = Self::dispatch_triangles(&mut frame, items);
        let tiles = frame.tile_count() as u64;
        let pixels = frame.win_w as u64 * frame.win_h as u64;
        let keys = self.writes_bin_keys(scene.rows);
        let spans = self.writes_bin_spans(scene.rows);
        let device = &self.gpu.device;
        let b = &mut self.buffers;
        let frame_buf = b.frame.get(device, std::mem::size_of::<FrameParams>() as u64);
        self.recorder.upload(&self.gpu.queue, &frame_buf, bytemuck::bytes_of(&frame));
        let counts = b.counts.get(device, tiles * 4);
        let cursors = b.cursors.get(device, tiles * 4);
        let offsets = b.offsets.get(device, (tiles + 1) * 4);
        let tile_queue = b.tile_queue.get(device, (QUEUE_HEAD as u64 + tiles) * 4);
        let bins = b.bins.get(device, entries * 4 * if spans { 2 } else { 1 });
        let bin_keys = b.bin_keys.get(device, if keys { 2 * entries * 8 } else { 0 });
        let small = frame.flags.contains(FrameFlags::SMALL_TRIANGLES);
        let pixel_keys = b.pixel_keys.get(device, if small { pixels * 8 } else { 8 });
        let stats_bytes = (Counter::COUNT * 4) as u64;
        let stats = b.stats.get(device, stats_bytes);
        // The output layers the frame's stages write (the layer table), each read back where
        // the call returns it (the render pipeline's owners and depth stay here otherwise).
        let layers: Vec<LayerBuffer> = LAYERS
            .iter()
            .map(|info| {
                let cells = match info.cells {
                    Cells::Pixel => pixels,
                    Cells::Tile => tiles,
                };
                let bytes = if info.written_by(scene.pipeline, frame.outputs) { cells * info.words as u64 * 4 } else { 0 };
                let read = if raster.layer(info.layer).is_some() { bytes } else { 0 };
                LayerBuffer { info, buffer: b.layers[info.layer as usize].get(device, bytes), bytes, read }
            })
            .collect();
        let layer_buffer = |layer: Layer| layers[layer as usize].buffer.clone();
        let reads: u64 = layers.iter().map(|l| l.read).sum();
        let readback = b.readback.get(device, stats_bytes + reads);

        let mut counters = [0u32; Counter::COUNT];
        let mut owner_out_of_range = false;
        let mut encoder = device.create_command_encoder(&Default::default());
        encoder.clear_buffer(&counts, 0, Some(tiles * 4));
        encoder.clear_buffer(&cursors, 0, Some(tiles * 4));
        encoder.clear_buffer(&stats, 0, Some(stats_bytes));
        // The small triangles' atomics start from zero: keys stored complemented, counts.
        if small {
            encoder.clear_buffer(&pixel_keys, 0, Some(pixels * 8));
            let coverage = &layers[Layer::Coverage as usize];
            encoder.clear_buffer(&coverage.buffer, 0, Some(coverage.bytes));
        }
        let buffers = |buffer| {
            Some(match buffer {
                Buffer::Frame => frame_buf.clone(),
                Buffer::Inputs
                | Buffer::VertexParams
                | Buffer::Positions
                | Buffer::VertexTexture
                | Buffer::Projected
                | Buffer::AssembleParams
                | Buffer::FaceIndices
                | Buffer::VertexAttributes
                | Buffer::FaceNormals
                | Buffer::LightParams
                | Buffer::LitColours
                | Buffer::FaceMaterials
                | Buffer::GroupCounts
                | Buffer::AssemblyCounters
                | Buffer::ClippedFaces
                | Buffer::Patches
                | Buffer::Pieces
                | Buffer::PieceShading
                | Buffer::GroupOffsets => return None,
                Buffer::Setups | Buffer::SetupWords => scene.setups.clone(),
                Buffer::Listed => listed.clone(),
                Buffer::SmallListed => small_listed.clone(),
                Buffer::PixelKeys => pixel_keys.clone(),
                Buffer::Counts => counts.clone(),
                Buffer::Offsets => offsets.clone(),
                Buffer::TileQueue => tile_queue.clone(),
                Buffer::Cursors => cursors.clone(),
                Buffer::Bins => bins.clone(),
                Buffer::BinKeys => bin_keys.clone(),
                Buffer::Values => layer_buffer(Layer::Values),
                Buffer::Owners => layer_buffer(Layer::Owners),
                Buffer::Coverage => layer_buffer(Layer::Coverage),
                Buffer::Stats => stats.clone(),
                Buffer::TileStats => layer_buffer(Layer::Tiles),
                Buffer::ShadeParams => scene.shade_params?.clone(),
                Buffer::Shading => scene.shading?.clone(),
                Buffer::Textures => scene.surfaces?.0.clone(),
                Buffer::Texels => scene.surfaces?.1.clone(),
                Buffer::Materials => scene.surfaces?.2.clone(),
                Buffer::Colours => layer_buffer(Layer::Colours),
                Buffer::Faces => layer_buffer(Layer::Faces),
            })
        };
        self.encode_stages(&mut encoder, scene.pipeline, scene.rows, Scope::Window, &frame, groups, &buffers)?;
        encoder.copy_buffer_to_buffer(&stats, 0, &readback, 0, stats_bytes);
        let mut at = stats_bytes;
        for layer in &layers {
            encoder.copy_buffer_to_buffer(&layer.buffer, 0, &readback, at, layer.read);
            at += layer.read;
        }
        let total = at;
        self.recorder.window();
        self.recorder.submit();
        self.recorder.wait(total);
        let submitted = Instant::now();
        let mut copying = Duration::ZERO;
        self.gpu
            .submit_and_read(encoder, &readback, total, |bytes| {
                let mapped = Instant::now();
                let words: &[u32] = bytemuck::cast_slice(bytes);
                let (stat_words, mut words) = words.split_at(Counter::COUNT);
                counters.copy_from_slice(stat_words);
                let (width, x0, y0) = (raster.window.width, raster.window.x0, raster.window.y0);
                let window = raster.window;
                for layer in &layers {
                    let (read, rest) = words.split_at((layer.read / 4) as usize);
                    words = rest;
                    let Some(out) = raster.layer_mut(layer.info.layer).filter(|_| layer.read > 0) else { continue };
                    match (layer.info.cells, layer.info.layer, owner_slots) {
                        (Cells::Tile, ..) => copy_tile_rows(read, &frame, &window, out),
                        // A scene set up in parts: the window's owners are its part's slots.
                        (Cells::Pixel, Layer::Owners, Some(slots)) => {
                            let scene_slots: Option<Vec<u32>> =
                                read.par_iter().map(|&o| if o == NO_OWNER { Some(o) } else { slots.get(o as usize).copied() }).collect();
                            match scene_slots {
                                Some(scene_slots) => copy_rows(&scene_slots, &frame, width, x0, y0, out),
                                None => owner_out_of_range = true,
                            }
                        }
                        (Cells::Pixel, ..) => copy_rows(read, &frame, width, x0, y0, out),
                    }
                }
                copying = mapped.elapsed();
            })
            .map_err(|e| Error::Gpu(format!("reading the raster back: {e}")))?;
        self.recorder.read_back(submitted.elapsed(), copying);
        if owner_out_of_range {
            return Err(Error::Gpu(format!("the window at ({}, {}) names a triangle beyond its {} setups", frame.win_x0, frame.win_y0, frame.triangles)));
        }
        Ok(counters)
    }
}

/// An output layer's buffer for one window: its row of the layer table, the bytes the stages
/// write and the bytes read back.
struct LayerBuffer {
    info: &'static LayerInfo,
    buffer: wgpu::Buffer,
    bytes: u64,
    read: u64,
}

/// The triangles of a scene set up in parts that reach one window: their setup slots in the
/// scene's order (the part's slots 0, 1, ...), the binned ones and the small ones among them,
/// by scene slot and by part slot.
struct ScenePart {
    slots: Vec<u32>,
    listed: Vec<u32>,
    small: Vec<u32>,
    local_listed: Vec<u32>,
    local_small: Vec<u32>,
}

impl ScenePart {
    /// The part of the (ascending) scene slots `listed` and `small`.
    fn of(listed: Vec<u32>, small: Vec<u32>) -> ScenePart {
        let mut slots = Vec::with_capacity(listed.len() + small.len());
        let (mut local_listed, mut local_small) = (Vec::with_capacity(listed.len()), Vec::with_capacity(small.len()));
        let (mut a, mut b) = (listed.iter().peekable(), small.iter().peekable());
        loop {
            let next_listed = match (a.peek(), b.peek()) {
                (Some(x), Some(y)) => x < y,
                (Some(_), None) => true,
                (None, Some(_)) => false,
                (None, None) => break,
            };
            let local = slots.len() as u32;
            if next_listed {
                slots.push(*a.next().expect("peeked"));
                local_listed.push(local);
            } else {
                slots.push(*b.next().expect("peeked"));
                local_small.push(local);
            }
        }
        ScenePart { slots, listed, small, local_listed, local_small }
    }
}

/// Which list of setup slots a buffer holds.
#[derive(Copy, Clone)]
enum ListBuffer {
    /// The triangles the binning stages take (`Buffer::Listed`).
    Listed,
    /// The small ones, which `fine_small` takes (`Buffer::SmallListed`).
    Small,
}

/// A scene's buffers on the device, as one window's dispatches bind them.
struct SceneBuffers<'a> {
    pipeline: Pipeline,
    /// The pipeline of each row (`GpuContext::stage_pipelines_of`).
    rows: &'a [Option<usize>],
    setups: &'a wgpu::Buffer,
    /// The render pipeline's: per-triangle attributes, and the frame's shade parameters.
    shading: Option<&'a wgpu::Buffer>,
    shade_params: Option<&'a wgpu::Buffer>,
    /// The render pipeline's textures, texels and materials.
    surfaces: Option<&'a (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer)>,
}

impl<'a> SceneBuffers<'a> {
    /// The buffers of `prepared`'s scene, set up in `resident`.
    fn of(
        prepared: &Prepared,
        rows: &'a [Option<usize>],
        resident: &'a Resident,
        shade_params: Option<&'a wgpu::Buffer>,
        surfaces: Option<&'a (wgpu::Buffer, wgpu::Buffer, wgpu::Buffer)>,
    ) -> Self {
        SceneBuffers { pipeline: prepared.pipeline(), rows, setups: &resident.setups, shading: resident.shading.as_ref(), shade_params, surfaces }
    }
}

/// Copy a window's rows into the raster that holds it, rows in parallel: reading a large
/// raster back is bound by this copy (and the first touch of the raster's pages), not by the
/// device.
fn copy_rows(src: &[u32], frame: &FrameParams, width: u32, x0: u32, y0: u32, dst: &mut [u32]) {
    let w = frame.win_w as usize;
    let x = (frame.win_x0 - x0) as usize;
    let first_row = (frame.win_y0 - y0) as usize;
    dst.par_chunks_mut(width as usize).skip(first_row).zip(src.par_chunks(w)).for_each(|(row, window_row)| row[x..x + w].copy_from_slice(window_row));
}

/// Copy a window's tile statistics (two words a tile) into the raster's, whose tiles the
/// window's are aligned to.
fn copy_tile_rows(src: &[u32], frame: &FrameParams, window: &tileraster_core::Window, dst: &mut [u32]) {
    let row = 2 * window.width.div_ceil(TILE) as usize;
    let x = 2 * ((frame.win_x0 - window.x0) / TILE) as usize;
    let first_row = ((frame.win_y0 - window.y0) / TILE) as usize;
    let w = 2 * frame.tiles_x as usize;
    for (k, window_row) in src.chunks(w).enumerate() {
        dst[(first_row + k) * row + x..][..w].copy_from_slice(window_row);
    }
}

/// `module` as the driver gets it (the kernels, or a fragment shader's), with the entry points
/// of the rows `rows` picks: a passthrough module, so the driver receives rust-gpu's SPIR-V with
/// its `NoContraction` decorations and float controls intact. With `spec` (a `SpecId` and a
/// value), the module's specialisation constants of that id are set first
/// (`crate::specialise`): the driver then compiles only the branches that value takes.
fn passthrough_module(device: &wgpu::Device, label: &str, module: &[u8], spec: &[Option<(u32, u32)>], rows: impl Fn(&StageInfo) -> bool) -> wgpu::ShaderModule {
    let mut words = wgpu::util::make_spirv_raw(module);
    for &(id, value) in spec.iter().flatten() {
        // A module without the constant (or not SPIR-V) is left as it is: the device's own
        // validation reports what is wrong with it.
        if let Ok((specialised, _)) = crate::specialise::specialise(&words, id, value) {
            words = specialised.into();
        }
    }
    let entry_points: Vec<wgpu::PassthroughShaderEntryPoint> = STAGES
        .iter()
        .filter(|s| rows(s))
        .map(|s| wgpu::PassthroughShaderEntryPoint { name: s.entry_point.into(), workgroup_size: (s.workgroup[0], s.workgroup[1], s.workgroup[2]) })
        .collect();
    // SAFETY: the module is rust-gpu's output, validated by spirv-val when it was built, and
    // `tests/spirv.rs` checks that every entry point binds exactly what its row of the stage
    // table (and so the layout below) says, with the table's workgroup size; a fragment
    // shader's entry points are the same source (`shading_entry_points!`), validated when its
    // crate was built, and `fragment_index` checks its bindings against the table again.
    // Specialising changes the values of the variant's constants and nothing else.
    unsafe {
        device.create_shader_module_passthrough(wgpu::ShaderModuleDescriptorPassthrough {
            label: Some(label),
            entry_points: entry_points.into(),
            spirv: Some(words),
            ..Default::default()
        })
    }
}

/// A stage's pipeline over `module` (through the driver's `cache` where there is one), with an
/// explicit bind group layout from its row of the table (each buffer uniform, read-only or read-write, as the table says).
fn stage_pipeline(device: &wgpu::Device, module: &wgpu::ShaderModule, info: &StageInfo, cache: Option<&wgpu::PipelineCache>) -> StagePipeline {
    let entries: Vec<wgpu::BindGroupLayoutEntry> = info
        .bindings
        .iter()
        .enumerate()
        .map(|(k, b)| wgpu::BindGroupLayoutEntry {
            binding: k as u32,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: match b.access {
                    Access::Uniform => wgpu::BufferBindingType::Uniform,
                    access => wgpu::BufferBindingType::Storage { read_only: access == Access::Read },
                },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        })
        .collect();
    let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor { label: Some(info.name), entries: &entries });
    let pipeline_layout =
        device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor { label: Some(info.name), bind_group_layouts: &[Some(&layout)], immediate_size: 0 });
    let pipeline = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(info.name),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some(info.entry_point),
        compilation_options: Default::default(),
        cache,
    });
    StagePipeline { pipeline, layout }
}

/// Bytes one triangle of `prepared` takes in the biggest of its scene bindings: its input,
/// its setup, or the render pipeline's shading.
fn scene_bytes_per_triangle(prepared: &Prepared) -> u64 {
    let shading = if prepared.render.is_some() { std::mem::size_of::<TriangleShading>() } else { 0 };
    std::mem::size_of::<TriangleInput>().max(std::mem::size_of::<TriangleSetup>()).max(shading) as u64
}

/// Put `window`'s two halves on `pending` (the top or left one next): into bands of tile rows,
/// or, once it is one tile row high, into blocks of tile columns. A single tile that is still
/// too much is an error, with `why` it is.
fn split(pending: &mut Vec<Window>, window: Window, why: impl FnOnce() -> String) -> Result<(), Error> {
    if window.height > TILE {
        let top = (window.height / 2).next_multiple_of(TILE);
        pending.push(Window { y0: window.y0 + top, height: window.height - top, ..window });
        pending.push(Window { height: top, ..window });
    } else if window.width > TILE {
        let left = (window.width / 2).next_multiple_of(TILE);
        pending.push(Window { x0: window.x0 + left, width: window.width - left, ..window });
        pending.push(Window { width: left, ..window });
    } else {
        return Err(Error::RasterTooLarge {
            width: window.width as u64,
            height: window.height as u64,
            reason: format!("the tile at ({}, {}) is too much for this GPU: {}; use the CPU backend", window.x0, window.y0, why()),
        });
    }
    Ok(())
}

/// Cut `area` into tile-aligned bands of full width (or tile-aligned blocks when one row of
/// the area is already too wide), each at most `max_pixels`, and at most [`MAX_GROUPS`]
/// tiles high (the per-tile stages dispatch a workgroup per tile).
fn windows(area: &Window, max_pixels: u64) -> Vec<Window> {
    let max_pixels = max_pixels.max((TILE * TILE) as u64);
    // At most `BIN_PART_TILES` tiles a row, so that one band of tile rows is short enough.
    let widest = (max_pixels / TILE as u64 / TILE as u64 * TILE as u64).clamp(TILE as u64, (BIN_PART_TILES * TILE) as u64);
    let width = (area.width as u64).min(widest) as u32;
    let height = ((max_pixels / width as u64) / TILE as u64 * TILE as u64).clamp(TILE as u64, (MAX_GROUPS * TILE) as u64).min(area.height as u64) as u32;
    let mut out = Vec::new();
    let mut y = 0;
    while y < area.height {
        let h = height.min(area.height - y);
        let mut x = 0;
        while x < area.width {
            let w = width.min(area.width - x);
            out.push(Window { x0: area.x0 + x, y0: area.y0 + y, width: w, height: h });
            x += w;
        }
        y += h;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_cpu_device_walks() {
        assert!(walks_bins(wgpu::DeviceType::Cpu));
        assert!(!walks_bins(wgpu::DeviceType::DiscreteGpu));
        assert!(!walks_bins(wgpu::DeviceType::IntegratedGpu));
    }
}
