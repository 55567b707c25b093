use thiserror::Error;

/// Everything that can go wrong in a call, each with what, where, and how to fix it.
#[derive(Debug, Error, Clone, PartialEq)]
pub enum Error {
    #[error(
        "no GPU adapter: {details}. Install a Vulkan driver (on Debian/Ubuntu the CPU driver is \
         `apt-get install mesa-vulkan-drivers libvulkan1`) or use the CPU backend"
    )]
    NoAdapter { details: String },

    #[error("GPU failure: {0}")]
    Gpu(String),

    #[error("the scene has no {what}: give at least one triangle over three vertices")]
    EmptyScene { what: &'static str },

    #[error("vertex {vertex} has a non-finite {axis} coordinate ({value}); every x, y and z must be a finite number")]
    NonFiniteCoordinate { vertex: usize, axis: char, value: f64 },

    #[error("vertex {vertex} has height {value:e}, beyond the range of the Float32 raster (±3.4e38)")]
    HeightOutOfRange { vertex: usize, value: f64 },

    #[error(
        "triangle {triangle} refers to vertex {index} at corner {corner}, but the scene has only \
         {vertex_count} vertices (valid indices are 0..{vertex_count})"
    )]
    IndexOutOfRange { triangle: usize, corner: usize, index: u64, vertex_count: usize },

    #[error("raster size {width}×{height} is empty: width and height must both be at least 1")]
    ZeroSizedRaster { width: u64, height: u64 },

    #[error("invalid grid extent: {reason}")]
    InvalidExtent { reason: String },

    #[error("raster {width}×{height} is too large: {reason}; rasterise it in windows or use a coarser grid")]
    RasterTooLarge { width: u64, height: u64, reason: String },

    #[error(
        "invalid window {x0},{y0} {width}×{height}: it must be non-empty and lie inside the \
         {grid_width}×{grid_height} grid"
    )]
    InvalidWindow { x0: u64, y0: u64, width: u64, height: u64, grid_width: u64, grid_height: u64 },

    #[error(
        "triangle {triangle} spans {extent_px} pixels, more than the {limit_px} pixels exact \
         coverage supports; split it into smaller triangles or use a coarser grid"
    )]
    TriangleTooLarge { triangle: usize, extent_px: f64, limit_px: u64 },

    #[error(
        "triangle {triangle}: the {mode} mode computes values in f32, and over the triangle's \
         pixels they reach {reach:e}, beyond what its f32 arithmetic keeps finite (< 2^127 ≈ 1.7e38); \
         use the exact mode, or scale the heights"
    )]
    OutsideModeRange { triangle: usize, mode: &'static str, reach: f64 },

    #[error(
        "triangle {triangle} covers pixel centres across {extent_px} columns or rows of the grid, \
         more than the {limit_px} over which the {mode} mode's f32 pixel offsets are exact; use \
         the exact mode, or split the triangle"
    )]
    TooWideForMode { triangle: usize, mode: &'static str, extent_px: u64, limit_px: u64 },

    #[error(
        "the {mode} mode computes values in f32, and the GPU adapter {adapter} does not give the \
         CPU backend's bits for that arithmetic ({reason}); use the exact mode, or the CPU backend"
    )]
    ModeInexactOnAdapter { mode: &'static str, adapter: String, reason: String },

    #[error("not enough memory for {what}: {reason}; rasterise fewer triangles at once (split the scene) or free memory")]
    OutOfMemory { what: &'static str, reason: String },

    #[error("no {what} named '{name}'; choose one of {choices}")]
    UnknownName { what: &'static str, name: String, choices: String },

    #[error("the {name} matrix has a non-finite entry at row {row}, column {column} ({value}); every entry must be a finite number")]
    NonFiniteMatrix { name: &'static str, row: usize, column: usize, value: f64 },

    #[error("the mesh has {len} {attribute} for {vertex_count} vertices; give one per vertex, or none")]
    AttributeLength { attribute: &'static str, len: usize, vertex_count: usize },

    #[error("the mesh has {len} {what} for {faces} faces; give one per face, or none")]
    FaceListLength { what: &'static str, len: usize, faces: usize },

    #[error("vertex {vertex} has a non-finite {attribute} ({value}); every attribute must be a finite number")]
    NonFiniteAttribute { attribute: &'static str, vertex: usize, value: f64 },

    #[error("the camera is singular: {reason}")]
    SingularCamera { reason: String },

    #[error(
        "the model matrix's last row is {last_row:?}; a model transform is affine: make its last row 0, 0, 0, 1 and put any projection in the view-projection matrix"
    )]
    NonAffineModel { last_row: [f64; 4] },

    #[error("the heat map needs the frame's {layer}: render with RenderParams::{flag} on (the command line's --heat-map does)")]
    HeatMapNeeds { layer: &'static str, flag: &'static str },

    #[error("texture {texture} ({width}×{height}) is too large: {reason}; scale it down")]
    TextureTooLarge { texture: usize, width: u32, height: u32, reason: String },

    #[error("the frame's textures take {bytes} bytes, more than the {limit} bytes the GPU binds at once; use smaller textures or the CPU backend")]
    TexturesTooLarge { bytes: u64, limit: u64 },

    #[error("texture {texture}: {reason}")]
    InvalidTexture { texture: usize, reason: String },

    #[error("a point size of {size} pixels: give a finite size from {} to {} pixels", crate::render::MIN_POINT_SIZE, crate::render::MAX_POINT_SIZE)]
    InvalidPointSize { size: f32 },

    #[error("the frame draws neither faces, lines nor points: draw the faces, the wireframe, or give a point size")]
    NothingToDraw,

    #[error("{samples} samples per pixel: {reason}")]
    InvalidSamples { samples: u32, reason: &'static str },

    #[error("{what}'s colour {colour:?} is not linear RGBA within [0, 1]")]
    InvalidColour { what: &'static str, colour: [f32; 4] },

    #[error("the surface's {what} is {value}: give a number from 0 to 1")]
    InvalidMaterial { what: &'static str, value: f64 },

    #[error("material {material}'s {what} is {value}: give a number {range}")]
    InvalidMeshMaterial { material: usize, what: &'static str, value: f64, range: &'static str },

    #[error("face {face} takes material {material}, but the mesh has {materials}: give each face an index into the mesh's materials")]
    InvalidFaceMaterial { face: usize, material: usize, materials: usize },

    #[error("instance {instance}: {reason}")]
    InvalidInstance { instance: usize, reason: String },

    #[error("the instances hold {faces} faces in all, more than the 2^32 − 2 a frame numbers; draw fewer instances per frame")]
    TooManyFaces { faces: u64 },

    #[error("the fragment shader {name}'s module cannot run on the GPU backend:\n{}\nbuild its crate with tileraster-build (fragment_shader! in the crate, tileraster::fragment_stage! in the host) against this version of tileraster-kernels", .problems.join("\n"))]
    FragmentShader { name: String, problems: Vec<String> },

    #[error("the vertex shader {name}'s module cannot run on the GPU backend:\n{}\nbuild its crate with tileraster-build (vertex_shader! in the crate, tileraster::vertex_stage! in the host) against this version of tileraster-kernels", .problems.join("\n"))]
    VertexShader { name: String, problems: Vec<String> },

    #[error(
        "the vertex shader {name} put vertex {vertex} at {position:?}, which is not a finite position: make it return finite coordinates for every vertex and constant the frame hands it"
    )]
    VertexPosedBeyond { name: String, vertex: usize, position: [f64; 3] },

    #[error("the vertex texture is {width} × {height} texels but holds {texels}: give width × height texels, row by row, fewer than 2^32")]
    InvalidVertexTexture { width: u32, height: u32, texels: usize },

    #[error(
        "the deform program's vertex texture holds {texels} texels, but the joints, weights and {vertices} vertices its constants lay out need {needs}: make the texture and constants for this mesh (tileraster_io::read_gltf_posable)"
    )]
    DeformTexture { vertices: usize, texels: usize, needs: u64 },
}
