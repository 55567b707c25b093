//! The render pipeline as a library: a mesh, a camera and a few choices in; colour, depth and
//! triangle ids out, the same bits on both backends.
//!
//! ```no_run
//! use tileraster::render::{render, Camera, Mesh, Projection, RenderParams, Up};
//! use tileraster::Backend;
//! let mesh = Mesh {
//!     positions: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
//!     triangles: vec![[0, 1, 2]],
//!     ..Default::default()
//! };
//! let camera = Camera::framing(&mesh, 1.0, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
//! let params = RenderParams::new(640, 480, camera.view_projection(640, 480)?);
//! let frame = render(&mesh, &params, Backend::Cpu)?;
//! assert_eq!(frame.colour.len(), 640 * 480);
//! # Ok::<(), tileraster::Error>(())
//! ```
//!
//! The geometry stages (`tileraster_core::render`) run on the host, but for the snapping of the
//! vertices, which the kernels' `vertex` stage does on the frame's backend; the depth test and
//! the shading run in the kernels (`fine_depth`, `shade`).

mod camera;
mod diagnostics;
mod jitter;
mod options;
mod panorama;
mod terrain;

pub use camera::{Camera, Projection, Up};
pub use diagnostics::{Checksums, TileCounts};
pub use jitter::{MAX_JITTER, accumulate, jitter_offset, jittered};
pub use options::{CameraChoice, FrameError, Lens, MeshSource, Model, ModelOptions, PreparedModel, ViewOptions};
pub use panorama::{Panorama, face_camera, panorama_frame};
pub use terrain::{dem_grid, dem_mesh};
pub use tileraster_core::kernels::abi::{DepthFunc, Interpolation};
pub use tileraster_core::render::{
    Address, AlphaMode, Cull, DeformLayout, Eye, Filter, FragmentConstants, FragmentStage, FrontFace, GeometryCounts, GeometryKernels, GeometryMemory,
    GeometryPass, IDENTITY, Instance, KeptMesh, LaidOutTextures, Light, LineRule, MAX_POINT_SIZE, MAX_RENDER_DIM, MAX_TEXTURE_DIM, MIN_POINT_SIZE, Material,
    Mesh, NO_TEXTURE, RenderParams, Shading, Texture, ToneMap, VertexConstants, VertexStage, VertexTexture, Wireframe, World, edges, face_normals,
    posed_normals, posed_positions, validate_mesh,
};

use crate::dem::{DemError, InputKind};
use crate::{Backend, Error, Stats};
use rayon::prelude::*;
use std::path::Path;
use tileraster_core::kernels::pipeline::Layer;
use tileraster_core::{Layers, Raster};
pub use tileraster_io::PosableGltf;

/// The mesh in `path`: glTF 2.0 (`.gltf`, `.glb`) with its normals, colours and texture
/// coordinates in world coordinates; PLY with its vertex normals and colours; OBJ with its normals,
/// texture coordinates and materials' diffuse colours; a GeoTIFF DEM (`.tif`, `.tiff`) as its
/// terrain ([`dem_mesh`]); any other input `tileraster rasterise` takes (STL, or points as
/// their Delaunay TIN) as positions and faces.
pub fn read_mesh(path: &Path) -> Result<Mesh, DemError> {
    read_mesh_at(path, None)
}

/// [`read_mesh`], a glTF file posed `time` seconds into its first animation (its nodes, skins
/// and morph weights; at rest without a time). A time for a file of another format, which
/// holds no animation, is an error.
pub fn read_mesh_at(path: &Path, time: Option<f64>) -> Result<Mesh, DemError> {
    refuse_time_without_animation(path, time)?;
    if is_geotiff(path) {
        let dem = tileraster_io::read_dem(path)?;
        let fail = |message: String| DemError::Io(tileraster_io::IoError::Format { path: path.to_owned(), message });
        let mesh = dem_mesh(&dem).map_err(|e| fail(e.to_string()))?;
        if mesh.triangles.is_empty() {
            return Err(fail(format!("the {} × {} DEM has no 2 × 2 block of cells that all have a height: nothing to draw", dem.width, dem.height)));
        }
        return Ok(mesh);
    }
    match InputKind::of(path)? {
        InputKind::Gltf => return Ok(tileraster_io::read_gltf(path, time)?),
        InputKind::Ply => return Ok(tileraster_io::read_ply_mesh(path)?),
        InputKind::Obj => return Ok(tileraster_io::read_obj_mesh(path)?),
        _ => {}
    }
    let input = crate::dem::read_scene(path, &Default::default(), &())?;
    Ok(Mesh { positions: input.scene.vertices, triangles: input.scene.triangles, ..Default::default() })
}

/// The up axis of the mesh in `path` by its format's convention: `+Z` for points and DEMs
/// (terrain and point clouds), `+Y` for glTF (its specification's) and for OBJ, PLY and STL (the usual
/// exports').
pub fn format_up(path: &Path) -> Result<Up, DemError> {
    Ok(if is_geotiff(path) || InputKind::of(path)?.is_points() { Up::Z } else { Up::Y })
}

/// The DEM in `path` (a GeoTIFF) as the kernels' built-in heightfield program draws it
/// ([`dem_grid`]): `None` where its heights are not `f32` values ([`read_mesh`] meshes it then).
pub fn read_dem_grid(path: &Path) -> Result<Option<(Mesh, VertexTexture)>, DemError> {
    let dem = tileraster_io::read_dem(path)?;
    Ok(dem_grid(&dem).filter(|(grid, _)| !grid.triangles.is_empty()))
}

/// Whether `path` names a GeoTIFF (`.tif`, `.tiff`): a DEM that [`read_mesh`] reads as terrain.
pub fn is_geotiff(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("tif") || e.eq_ignore_ascii_case("tiff"))
}

/// The meshes in `path` and their placements: a glTF file's meshes with one instance per node
/// that places one (nodes sharing a mesh share it); any other input [`read_mesh`] reads, once.
pub fn read_world(path: &Path) -> Result<World, DemError> {
    read_world_at(path, None)
}

/// [`read_world`], a glTF file posed as [`read_mesh_at`] poses it.
pub fn read_world_at(path: &Path, time: Option<f64>) -> Result<World, DemError> {
    match is_geotiff(path) || InputKind::of(path)? != InputKind::Gltf {
        true => Ok(World::single(read_mesh_at(path, time)?)),
        false => Ok(tileraster_io::read_gltf_world(path, time)?),
    }
}

/// The glTF file in `path` at rest with what poses it at `time` in the kernels' vertex stage
/// (`VertexStage::DEFORM`: its skins and morph targets; [`tileraster_io::read_gltf_posable`]),
/// as [`read_mesh_at`] poses it on the host. `None` for a file without skins or morph targets,
/// or of another format.
pub fn read_posable_at(path: &Path, time: Option<f64>) -> Result<Option<PosableGltf>, DemError> {
    if is_geotiff(path) || InputKind::of(path)? != InputKind::Gltf {
        return Ok(None);
    }
    Ok(tileraster_io::read_gltf_posable(path, time)?)
}

/// A time is for a glTF file's animation: any other format's mesh has no pose to take.
fn refuse_time_without_animation(path: &Path, time: Option<f64>) -> Result<(), DemError> {
    match time {
        Some(time) if is_geotiff(path) || InputKind::of(path)? != InputKind::Gltf => Err(DemError::Io(tileraster_io::IoError::Format {
            path: path.to_owned(),
            message: format!("a time ({time} s) poses a glTF file's animation, and this format holds none: leave the time out"),
        })),
        _ => Ok(()),
    }
}

/// A rendered frame: row 0 at the top.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    pub width: u32,
    pub height: u32,
    /// RGBA8 per pixel (red in the low byte: `to_le_bytes` gives R, G, B, A). Empty where
    /// `RenderParams::return_colour` is off.
    pub colour: Vec<u32>,
    /// Depth per pixel (the clear value where no triangle is). Empty where
    /// `RenderParams::return_depth` is off.
    pub depth: Vec<f32>,
    /// The input face per pixel, counting the mesh's triangles from 0 (`NO_FACE` where none).
    pub ids: Vec<u32>,
    /// Fragments per pixel: how many rasterised triangles cover its centre (before the depth
    /// test). Empty unless `RenderParams::count_fragments`.
    pub fragments: Vec<u32>,
    /// Per-tile counts, where `RenderParams::count_tiles` asks for them.
    pub tiles: Option<TileCounts>,
    pub stats: RenderStats,
}

/// The face value of a pixel no triangle covers.
pub const NO_FACE: u32 = u32::MAX;

/// What a frame did, equal on both backends.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct RenderStats {
    /// The geometry stages: clipped faces, culled and rasterised triangles.
    pub geometry: GeometryCounts,
    /// Fragments: pixel centres inside a rasterised triangle (counted before the depth test;
    /// 0 unless `RenderParams::count_fragments`).
    pub fragments: u64,
    /// Pixels some triangle owns after the depth test.
    pub pixels_covered: u64,
    /// Fragments that lost the depth test (`fragments − pixels_covered`; 0 unless
    /// `RenderParams::count_fragments`).
    pub depth_rejected: u64,
    /// The kernels' statistics (tiles, passes).
    pub raster: Stats,
}

impl RenderStats {
    /// Fragments per covered pixel.
    pub fn overdraw(&self) -> f64 {
        if self.pixels_covered == 0 { 0.0 } else { self.fragments as f64 / self.pixels_covered as f64 }
    }

    /// One JSON object.
    pub fn to_json(&self) -> String {
        let g = &self.geometry;
        format!(
            "{{\"instances_drawn\":{},\"instances_culled\":{},\"points_drawn\":{},\"points_culled\":{},\"lines_drawn\":{},\"lines_culled\":{},\"clipped\":{},\"culled_frustum\":{},\"culled_back\":{},\"culled_front\":{},\"culled_zero_area\":{},\"culled_no_centre\":{},\
             \"triangles_rasterised\":{},\"fragments\":{},\"pixels_covered\":{},\"depth_rejected\":{},\"overdraw\":{:.3},\"raster\":{}}}",
            g.instances_drawn,
            g.instances_culled,
            g.points_drawn,
            g.points_culled,
            g.lines_drawn,
            g.lines_culled,
            g.clipped,
            g.culled_frustum,
            g.culled_back,
            g.culled_front,
            g.culled_zero_area,
            g.culled_no_centre,
            g.rasterised,
            self.fragments,
            self.pixels_covered,
            self.depth_rejected,
            self.overdraw(),
            self.raster.to_json()
        )
    }
}

impl Frame {
    /// The colour as RGBA bytes, row by row.
    pub fn rgba8(&self) -> Vec<u8> {
        self.colour.iter().flat_map(|c| c.to_le_bytes()).collect()
    }
}

/// The geometry stages' kernels as `backend` runs them.
fn geometry_kernels(backend: Backend) -> Box<dyn GeometryKernels> {
    match backend {
        Backend::Cpu => Box::new(tileraster_cpu::GeometryTwins::default()),
        Backend::Gpu => Box::new(tileraster_gpu::GeometryDevice::default()),
    }
}

/// One frame's geometry kernels, kept for its raster call: the GPU's hold the frame's records
/// where its assembly wrote them.
enum FrameKernels {
    Cpu(tileraster_cpu::GeometryTwins),
    Gpu(Box<tileraster_gpu::GeometryDevice>),
}

impl FrameKernels {
    fn stages(&mut self) -> &mut dyn GeometryKernels {
        match self {
            FrameKernels::Cpu(k) => k,
            FrameKernels::Gpu(k) => k.as_mut(),
        }
    }
}

/// The geometry stages over `mesh`: the prepared scene the kernels rasterise, and what the
/// stages did. The kernels' geometry stages run as their CPU twins, which give every
/// backend's bits.
pub fn prepare_render(mesh: &Mesh, params: &RenderParams) -> Result<(tileraster_core::Prepared, GeometryCounts), Error> {
    prepare_render_on(mesh, params, Backend::Cpu)
}

/// [`prepare_render`], the kernels' geometry stages run on `backend`.
pub fn prepare_render_on(mesh: &Mesh, params: &RenderParams, backend: Backend) -> Result<(tileraster_core::Prepared, GeometryCounts), Error> {
    tileraster_core::render::prepare_render(mesh, params, geometry_kernels(backend).as_mut())
}

/// [`prepare_render`], calling `observe` as each of its passes ends.
pub fn prepare_render_observed(
    mesh: &Mesh,
    params: &RenderParams,
    backend: Backend,
    observe: &mut dyn FnMut(GeometryPass),
) -> Result<(tileraster_core::Prepared, GeometryCounts), Error> {
    tileraster_core::render::prepare_render_observed(mesh, params, geometry_kernels(backend).as_mut(), observe)
}

/// The geometry stages over every instance of `world` (see [`prepare_render`]).
pub fn prepare_world(world: &World, params: &RenderParams) -> Result<(tileraster_core::Prepared, GeometryCounts), Error> {
    tileraster_core::render::prepare_world(world, params, &mut tileraster_cpu::GeometryTwins::default())
}

/// Render `mesh` as `params` say on `backend`. The call works in the memory the last call on
/// any thread left, as a [`PreparedMesh`] does, and keeps its own for the next: as much as the
/// largest frame since needed, until [`release_memory`] frees it. The returned layers are the
/// caller's.
pub fn render(mesh: &Mesh, params: &RenderParams, backend: Backend) -> Result<Frame, Error> {
    validate_mesh(mesh)?;
    with_call_memory(|memory| memory.render(mesh, params, backend))
}

/// Render every instance of `world` (many placements of its meshes, each culled against the
/// view frustum by its bounding box before any vertex work) as `params` say on `backend`. The
/// face ids number the instances' faces in order, as if they were one mesh
/// ([`World::flattened`] gives that mesh, and the same frame). Like [`render`], the call works
/// in the memory the last call left and keeps its own ([`release_memory`]).
pub fn render_world(world: &World, params: &RenderParams, backend: Backend) -> Result<Frame, Error> {
    with_call_memory(|memory| memory.frame(params, backend, |geometry, kernels| tileraster_core::render::prepare_world_in(world, params, geometry, kernels)))
}

/// The memory [`render`] and [`render_world`] work in, kept for the next call: the geometry
/// stages' arrays, the CPU's triangle setups and the layers its stages wrote that a frame did
/// not return (a frame's returned layers are the caller's), and the GPU's geometry stages with
/// their buffers on the device (the projected vertices, the records). A frame drawn in pages
/// already mapped skips faulting tens of megabytes in (the 100k-triangle terrain at 1080p); its
/// bits are the same.
#[derive(Default)]
struct CallMemory {
    geometry: GeometryMemory,
    cpu: tileraster_cpu::Workspace,
    gpu_geometry: Option<Box<tileraster_gpu::GeometryDevice>>,
}

/// The kept [`CallMemory`], `None` until a call leaves it, while a call works in it, and after
/// [`release_memory`]. The lock is held only to take it out and put it back, never while a frame
/// is drawn, so no caller (a rayon task that runs meanwhile, a fragment program) can wait on a
/// call that waits on it.
static CALL_MEMORY: std::sync::Mutex<Option<CallMemory>> = std::sync::Mutex::new(None);

/// Run `f` in the kept memory, or in fresh memory where another call has it; then keep `f`'s
/// (a panicking call leaves none).
fn with_call_memory<T>(f: impl FnOnce(&mut CallMemory) -> T) -> T {
    let slot = || CALL_MEMORY.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let mut memory = slot().take().unwrap_or_default();
    let result = f(&mut memory);
    // Where calls overlapped, the last to end keeps its memory.
    *slot() = Some(memory);
    result
}

/// Free the memory that [`render`] and [`render_world`] keep between calls (as much as the
/// largest frame since needed: a few hundred megabytes after a frame of a million triangles,
/// and on the GPU the device buffers of its geometry stages).
/// The next call maps fresh memory again. A call in progress keeps working in its own memory,
/// and keeps it when it ends.
pub fn release_memory() {
    *CALL_MEMORY.lock().unwrap_or_else(std::sync::PoisonError::into_inner) = None;
}

impl CallMemory {
    /// [`render`] of a checked mesh in this memory.
    fn render(&mut self, mesh: &Mesh, params: &RenderParams, backend: Backend) -> Result<Frame, Error> {
        self.frame(params, backend, |geometry, kernels| tileraster_core::render::prepare_checked_mesh_in(mesh, params, geometry, kernels))
    }

    /// A frame on `backend` that `prepare` prepares in this memory's arrays with the frame's
    /// geometry kernels (the GPU's those the last call kept, and kept again after a frame that
    /// was drawn: a failed call may leave a buffer the device could not make).
    fn frame(
        &mut self,
        params: &RenderParams,
        backend: Backend,
        prepare: impl FnOnce(&mut GeometryMemory, &mut dyn GeometryKernels) -> Result<(tileraster_core::Prepared, GeometryCounts), Error>,
    ) -> Result<Frame, Error> {
        let mut kernels = match backend {
            Backend::Cpu => FrameKernels::Cpu(Default::default()),
            Backend::Gpu => FrameKernels::Gpu(self.gpu_geometry.take().unwrap_or_default()),
        };
        let frame = prepare(&mut self.geometry, kernels.stages()).and_then(|(prepared, geometry)| self.rasterise(prepared, geometry, params, &kernels));
        if let (Ok(_), FrameKernels::Gpu(device)) = (&frame, kernels) {
            self.gpu_geometry = Some(device);
        }
        frame
    }

    /// Rasterise and shade `prepared` on the backend whose `kernels` prepared it, and take its
    /// arrays back.
    fn rasterise(
        &mut self,
        prepared: tileraster_core::Prepared,
        geometry: GeometryCounts,
        params: &RenderParams,
        kernels: &FrameKernels,
    ) -> Result<Frame, Error> {
        let raster = match kernels {
            FrameKernels::Cpu(_) => tileraster_cpu::rasterise_in(&prepared, &mut self.cpu),
            FrameKernels::Gpu(device) => tileraster_gpu::rasterise_frame(&prepared, Layers::default(), device, None),
        };
        self.geometry.recycle(prepared);
        Ok(frame_of(raster?, geometry, params))
    }
}

/// A mesh checked once, with its normals computed once where it has none, and the memory its
/// frames work in: each frame of it (any camera, model matrix, shading or size) costs only the
/// per-frame stages, reuses the last frame's memory instead of faulting fresh pages in, and is
/// bit for bit what [`render`] gives. Its textures are laid out (decoded, their mip chains
/// built) once for as long as the frames' `texture_filter` and `texture_address` stay the same,
/// and the GPU keeps their texels on the device between its frames. [`PreparedMesh::render_into`] reuses the output layers
/// of a frame too.
///
/// ```no_run
/// # use tileraster::render::{Camera, Frame, Mesh, PreparedMesh, Projection, RenderParams};
/// # use tileraster::Backend;
/// # let mesh = Mesh::default();
/// let mut prepared = PreparedMesh::new(mesh)?;
/// let mut frame = Frame::default();
/// for k in 0..36 {
///     let angle = (k as f64 * 10.0).to_radians();
///     let eye = [5.0 * angle.cos(), 5.0 * angle.sin(), 2.0];
///     let camera = Camera::look_at(eye, [0.0; 3], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 45.0 }, prepared.mesh());
///     prepared.render_into(&RenderParams::new(640, 480, camera.view_projection(640, 480)?), Backend::Cpu, &mut frame)?;
/// }
/// # Ok::<(), tileraster::Error>(())
/// ```
pub struct PreparedMesh {
    mesh: Mesh,
    memory: FrameMemory,
}

/// What a frame's stages work in, kept between the frames of a [`PreparedMesh`].
#[derive(Default)]
struct FrameMemory {
    geometry: GeometryMemory,
    /// The mesh's textures as the last frame laid them out and its positions as the vertex
    /// stage takes them; the geometry stages of each backend, which keep what they were handed
    /// (the GPU's on the device); the texels each backend was handed last (the GPU keeps them
    /// on the device).
    kept: KeptMesh,
    cpu_geometry: tileraster_cpu::GeometryTwins,
    gpu_geometry: tileraster_gpu::GeometryDevice,
    cpu_texels: Option<std::sync::Arc<Vec<u64>>>,
    gpu_texels: Option<tileraster_gpu::ResidentTexels>,
    /// The CPU's setups and the layers its stages wrote that the frame does not return (the
    /// owner layer, and the colour or depth where not asked for).
    cpu: tileraster_cpu::Workspace,
}

impl PreparedMesh {
    pub fn new(mut mesh: Mesh) -> Result<Self, Error> {
        validate_mesh(&mesh)?;
        if mesh.normals.is_none() {
            mesh.normals = Some(face_normals(&mesh));
        }
        Ok(PreparedMesh { mesh, memory: FrameMemory::default() })
    }

    /// The mesh, normals included.
    pub fn mesh(&self) -> &Mesh {
        &self.mesh
    }

    /// A frame in new output layers; the stages' intermediates reuse the last frame's memory.
    pub fn render(&mut self, params: &RenderParams, backend: Backend) -> Result<Frame, Error> {
        let mut frame = Frame::default();
        self.render_into(params, backend, &mut frame)?;
        Ok(frame)
    }

    /// A frame into `frame`, whose layers (of any earlier frame, any size) are reused. On an
    /// error `frame` is left empty.
    pub fn render_into(&mut self, params: &RenderParams, backend: Backend, frame: &mut Frame) -> Result<(), Error> {
        let memory = &mut self.memory;
        let spare = std::mem::take(frame);
        let kernels: &mut dyn GeometryKernels = match backend {
            Backend::Cpu => &mut memory.cpu_geometry,
            Backend::Gpu => &mut memory.gpu_geometry,
        };
        let (mut prepared, geometry) = tileraster_core::render::prepare_mesh_frame(&self.mesh, params, &mut memory.geometry, &mut memory.kept, kernels)?;
        // Texels the backend was handed by the last frame are not handed over again.
        if let Some(render) = prepared.render.as_mut() {
            render.texels_resident = match backend {
                Backend::Cpu => memory.cpu_texels.as_ref().is_some_and(|t| std::sync::Arc::ptr_eq(t, &render.texels)),
                Backend::Gpu => memory.gpu_texels.as_ref().is_some_and(|t| t.holds(&render.texels)),
            };
            if backend == Backend::Cpu {
                memory.cpu_texels = Some(render.texels.clone());
            }
        }
        // An empty layer (one the last frame did not return) leaves the workspace its own.
        let layers = Layers::default()
            .with_values(reusable(spare.depth))
            .with(Layer::Coverage, reusable(spare.fragments))
            .with(Layer::Colours, reusable(spare.colour))
            .with(Layer::Faces, reusable(spare.ids));
        let raster = match backend {
            Backend::Cpu => {
                memory.cpu.recycle(layers);
                tileraster_cpu::rasterise_in(&prepared, &mut memory.cpu)
            }
            Backend::Gpu => tileraster_gpu::rasterise_frame(&prepared, layers, &memory.gpu_geometry, Some(&mut memory.gpu_texels)),
        };
        memory.geometry.recycle(prepared);
        *frame = frame_of(raster?, geometry, params);
        Ok(())
    }
}

/// A returned layer's memory for the next frame, unless it holds none.
fn reusable<T>(layer: Vec<T>) -> Option<Vec<T>> {
    (layer.capacity() > 0).then_some(layer)
}

/// The frame a rasterised and shaded raster holds, with its statistics.
fn frame_of(mut raster: Raster, geometry: GeometryCounts, params: &RenderParams) -> Frame {
    // The frame's whole upload: the geometry stages' and the rasteriser's.
    raster.stats.bytes_uploaded += geometry.bytes_uploaded;
    let ids = raster.faces.expect("the render pipeline writes faces");
    let per_pixel = raster.coverage.unwrap_or_default();
    let covered = ids.par_iter().filter(|&&f| f != NO_FACE).count() as u64;
    let fragments = per_pixel.par_iter().map(|&c| c as u64).sum::<u64>();
    Frame {
        width: params.width,
        height: params.height,
        colour: raster.colours.unwrap_or_default(),
        depth: raster.values,
        ids,
        fragments: per_pixel,
        tiles: raster.tiles.as_deref().map(|layer| TileCounts::from_layer(params.width, params.height, layer)),
        stats: RenderStats { geometry, fragments, pixels_covered: covered, depth_rejected: fragments.saturating_sub(covered), raster: raster.stats },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_testkit::meshes;

    /// One-shot calls in kept memory give the frame that fresh memory gives, whatever the calls
    /// before them drew (other sizes, shadings, returned layers, meshes), on the CPU and the GPU
    /// (skipped only with `TILERASTER_SKIP_GPU=1`, and then said).
    #[test]
    fn calls_in_kept_memory_keep_nothing_of_the_last_frame() {
        let sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 12, 20);
        let soup = meshes::soup(300, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.6, 9);
        let camera = |w: u32, h: u32, eye: [f64; 3]| {
            Camera { eye, target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near: 0.5, far: 30.0 }
                .view_projection(w, h)
                .unwrap()
        };
        let frames = [
            (&sphere, 131, 97, [3.0, -2.0, 1.0], Shading::Phong, true, true, 1),
            (&soup, 64, 48, [-2.0, 3.0, 2.0], Shading::Ids, false, false, 1),
            (&sphere, 90, 70, [2.5, -2.0, 1.0], Shading::Smooth, true, false, 4),
            (&soup, 200, 120, [2.0, 2.5, -1.5], Shading::Unlit, false, true, 1),
            (&sphere, 32, 32, [12.0, 9.0, 6.0], Shading::Flat, true, true, 1),
            // A large frame keeps its depth, colour and owner layers; smaller ones then take
            // them over, returning the depth or not.
            (&soup, 220, 160, [2.5, 2.0, 1.5], Shading::Phong, false, false, 1),
            (&sphere, 100, 80, [3.0, -2.0, 1.0], Shading::Smooth, true, true, 1),
            (&soup, 220, 160, [2.5, 2.0, 1.5], Shading::Ids, false, false, 1),
            (&sphere, 90, 60, [-2.0, 3.0, 2.0], Shading::Phong, false, true, 1),
        ];
        let mut backends = vec![Backend::Cpu];
        match crate::gpu_adapter() {
            Ok(_) => backends.push(Backend::Gpu),
            Err(e) if std::env::var("TILERASTER_SKIP_GPU").as_deref() == Ok("1") => {
                use std::io::Write;
                let _ = writeln!(std::io::stderr(), "SKIPPED (TILERASTER_SKIP_GPU=1): kept memory on the GPU: {e}");
            }
            Err(e) => panic!("kept memory: the GPU backend is unavailable: {e}\nTo skip GPU tests deliberately, set TILERASTER_SKIP_GPU=1."),
        }
        for backend in backends {
            let mut kept = CallMemory::default();
            for (k, &(mesh, w, h, eye, shading, return_colour, return_depth, samples)) in frames.iter().chain(&frames).enumerate() {
                let params = RenderParams { shading, return_colour, return_depth, samples, cull: Cull::None, ..RenderParams::new(w, h, camera(w, h, eye)) };
                let got = kept.render(mesh, &params, backend).unwrap_or_else(|e| panic!("{backend:?}, frame {k}: {e}"));
                let want = CallMemory::default().render(mesh, &params, backend).unwrap();
                assert!(got.ids.iter().any(|&f| f != NO_FACE), "{backend:?}, frame {k} draws the mesh");
                assert_eq!(got.colour, want.colour, "{backend:?}, frame {k}: colour");
                assert_eq!(
                    got.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                    want.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>(),
                    "{backend:?}, frame {k}: depth"
                );
                assert_eq!(got.ids, want.ids, "{backend:?}, frame {k}: ids");
                assert_eq!(got.fragments, want.fragments, "{backend:?}, frame {k}: fragments");
                assert_eq!(got.stats.geometry, want.stats.geometry, "{backend:?}, frame {k}: geometry counts");
            }
        }
    }
}
