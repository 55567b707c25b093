//! The render pipeline's geometry stages, on the host in `f64`, once per frame and the same
//! for both backends: vertex transform, clipping, culling, viewport transform and snapping.
//! What they leave is a [`Prepared`] scene for the kernels (setup, binning, the depth test of
//! `programs::depth` and the shade stage of `programs::shade`).
//!
//! - **Vertex stage**: positions to clip space by the view-projection matrix (Vulkan
//!   conventions: `0 ≤ z ≤ w` is visible, NDC `y` points down the image); per-vertex colour,
//!   normal, world position and texture coordinates carried along; flat and Gouraud lighting
//!   done here, per face and per vertex.
//! - **Clipping** in homogeneous space against the near (`z = 0`) and far (`z = w`) planes, a
//!   plane `w = W_MIN` that keeps `w ≤ 0` from the rasteriser, and a guard band
//!   [`GUARD_PX`] pixels beyond the viewport on each side, so that every snapped edge function
//!   fits the kernels' integers. An edge is always cut from its inside end towards its outside
//!   end, so two faces sharing an edge cut it at the same point: clipping opens no crack.
//!   The clipped polygon is cut into a fan; every piece keeps its face's id.
//! - **Culling**: whole triangles outside one frustum plane; back or front faces (orientation
//!   from the snapped vertices, Vulkan's sign rule); zero-area pieces.
//! - **Viewport and snapping**: pixel centres at `+0.5`, vertices rounded to 8 sub-pixel bits
//!   (16.8 fixed point, as Direct3D 11 and Vulkan's 2022 roadmap require).

mod fragment;
mod instances;
mod lines;
mod texture;

pub use fragment::{FragmentConstants, FragmentStage};
use instances::validate_world;
pub use instances::{Instance, World};
pub use lines::{LineRule, Wireframe, edges};
pub use texture::{MAX_TEXTURE_DIM, Texture};
pub use tileraster_kernels::abi::{Address, Filter, NO_TEXTURE};

use crate::prepare::{pixel_rect, round_to_i64};
use crate::{Error, Grid, Mode, Outputs, Params, Prepared, RenderInputs, Skips, Window};
use rayon::prelude::*;
use tileraster_kernels::EXTENT_LIMIT_BITS;
use tileraster_kernels::abi::{
    ATTR_COLOUR, ATTR_NORMAL, ATTR_POSITION, ATTR_UV, ATTRIBUTES, DepthFunc, DepthTest, FloatCoeffs, Interpolation, MAX_LIGHTS, PixelRect, ShadeMode,
    ShadeParams, TriangleInput, TriangleShading,
};
use tileraster_kernels::stages::setup::edges_fit_i32;

/// The colour of a mesh without colours: linear light grey.
pub(crate) const GREY: [f32; 4] = [0.8, 0.8, 0.8, 1.0];

/// The identity matrix.
pub const IDENTITY: [[f64; 4]; 4] = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

/// The smallest and largest point size, in pixels.
pub const MIN_POINT_SIZE: f32 = 1.0 / 128.0;
pub const MAX_POINT_SIZE: f32 = 1024.0;

/// Sub-pixel bits of the render pipeline's snapping (16.8 fixed point).
pub const RENDER_SNAP_BITS: u32 = 8;
/// Largest width or height of a rendered frame.
pub const MAX_RENDER_DIM: u32 = 1 << 16;
/// How far beyond the viewport, in pixels, a triangle may reach before it is clipped.
pub const GUARD_PX: f64 = (1u64 << 19) as f64;
/// The smallest `w` that reaches the rasteriser.
const W_MIN: f64 = 1e-30;

/// A triangle mesh in world coordinates, with optional per-vertex attributes.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Mesh {
    pub positions: Vec<[f64; 3]>,
    /// Faces as vertex indices, counter-clockwise seen from the front (by default).
    pub triangles: Vec<[u32; 3]>,
    /// Unit normals; computed from the faces (area-weighted) where the shading needs them.
    pub normals: Option<Vec<[f32; 3]>>,
    /// Linear RGBA in `[0, 1]`; light grey where absent.
    pub colours: Option<Vec<[f32; 4]>>,
    /// Texture coordinates, `v = 0` at a texture's first row (glTF's convention).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Base-colour textures: each face's colour is its vertex colour times its texture's sample.
    pub textures: Vec<Texture>,
    /// Each face's texture, an index into `textures` or [`NO_TEXTURE`]; `None`: every face
    /// takes texture 0 where there is one.
    pub face_textures: Option<Vec<u32>>,
}

/// Which faces are dropped.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Cull {
    None,
    #[default]
    Back,
    Front,
}

/// Which winding, as seen on the screen, is the front.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum FrontFace {
    #[default]
    CounterClockwise,
    Clockwise,
}

/// How pixels are coloured.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum Shading {
    /// The vertex colours as they are, interpolated.
    Unlit,
    /// Lit once per face (its normal, its first vertex's colour).
    Flat,
    /// Lit per vertex, colours interpolated (Gouraud).
    #[default]
    Smooth,
    /// Lit per pixel (Lambert + Blinn-Phong) from interpolated normals.
    Phong,
    /// Depth as grey.
    Depth,
    /// Unit normals as RGB.
    Normals,
    /// A colour per face id.
    Ids,
}

impl Shading {
    pub const ALL: [Shading; 7] = [Shading::Unlit, Shading::Flat, Shading::Smooth, Shading::Phong, Shading::Depth, Shading::Normals, Shading::Ids];

    /// Whether the shade stage reads the interpolated attributes (colour, normal, position).
    pub fn reads_attributes(self) -> bool {
        !matches!(self, Shading::Depth | Shading::Ids)
    }

    pub fn name(self) -> &'static str {
        match self {
            Shading::Unlit => "unlit",
            Shading::Flat => "flat",
            Shading::Smooth => "smooth",
            Shading::Phong => "phong",
            Shading::Depth => "depth",
            Shading::Normals => "normals",
            Shading::Ids => "ids",
        }
    }
}

/// A directional light.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Light {
    /// Towards the light, in world coordinates (normalised when used).
    pub direction: [f64; 3],
    pub colour: [f64; 3],
}

/// Where the viewer is, for specular highlights.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Eye {
    /// A perspective camera's position, in world coordinates.
    Point([f64; 3]),
    /// Towards an orthographic camera, in world coordinates: its centre of projection lies at
    /// infinity, so every point sees the viewer in this one direction (normalised when used).
    Direction([f64; 3]),
}

impl Eye {
    /// The viewer of `view_projection`: the point it maps to `x = y = w = 0` (a perspective
    /// camera's eye), or where no such point exists (an orthographic or other parallel
    /// projection, whose rows `x`, `y` and `w` leave a direction `d` with `w = 0`) the direction
    /// `±d` towards which the depth decreases for `depth_func` (`Less` and the like: depth 0 is
    /// nearest), or increases for `Greater` and `GreaterEqual` (reversed depth). `None` where the
    /// matrix sees no single direction either (`x`, `y` and `w` of rank below 3, or a depth
    /// constant along `d`).
    pub fn of(view_projection: &[[f64; 4]; 4], depth_func: DepthFunc) -> Option<Eye> {
        if let Some(point) = centre_of_projection(view_projection) {
            return Some(Eye::Point(point));
        }
        let m = view_projection;
        let norm = |v: [f64; 3]| dot(v, v).sqrt();
        // The null direction of the 3 × 4 rows x, y, w with its w component 0: a direction
        // whose clip x, y and w do not change, so `w` must not vary along it either.
        let [x, y, w] = [m[0], m[1], m[3]].map(|r| [r[0], r[1], r[2]]);
        let d = cross(x, y);
        let scale = norm(x) * norm(y);
        // (Written so that NaN fails every test.)
        let independent = norm(d) > 1e-12 * scale;
        if !independent || dot(w, d).abs() > 1e-12 * norm(w) * norm(d) {
            return None;
        }
        let depth_slope = dot([m[2][0], m[2][1], m[2][2]], d);
        let depth_varies = depth_slope.abs() > 1e-12 * norm([m[2][0], m[2][1], m[2][2]]) * norm(d);
        if !depth_varies {
            return None;
        }
        let reversed = matches!(depth_func, DepthFunc::Greater | DepthFunc::GreaterEqual);
        let towards_viewer = if (depth_slope < 0.0) != reversed { d } else { d.map(|c| -c) };
        Some(Eye::Direction(unit(towards_viewer)))
    }

    /// As the kernels take it: `[x, y, z, 1]` for a point, `[x, y, z, 0]` for a unit direction,
    /// so that `xyz − p · w` points from `p` towards the viewer either way.
    fn homogeneous(self) -> [f64; 4] {
        match self {
            Eye::Point(p) => [p[0], p[1], p[2], 1.0],
            Eye::Direction(d) => {
                let d = unit(d);
                [d[0], d[1], d[2], 0.0]
            }
        }
    }
}

/// Everything a frame needs besides its mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderParams {
    pub width: u32,
    pub height: u32,
    /// The mesh's coordinates to the world, row-major (affine): positions by it, normals by its
    /// inverse transpose. The identity by default.
    pub model: [[f64; 4]; 4],
    /// World to clip space, row-major: `clip = M · (x, y, z, 1)`.
    pub view_projection: [[f64; 4]; 4],
    /// Where the viewer is, for specular highlights; `None`: where the view-projection says
    /// ([`Eye::of`]: its centre of projection, or for an orthographic matrix its viewing
    /// direction).
    pub eye: Option<Eye>,
    pub cull: Cull,
    pub front_face: FrontFace,
    pub shading: Shading,
    pub interpolation: Interpolation,
    pub depth_func: DepthFunc,
    pub depth_write: bool,
    pub clear_depth: f32,
    /// Blend every fragment source-over onto what is below it, in submission order, as a
    /// graphics API with blending on does (the depth test and writes as set).
    pub blend: bool,
    /// RGBA8 of pixels no triangle covers.
    pub background: [u8; 4],
    /// At most `MAX_LIGHTS`.
    pub lights: Vec<Light>,
    pub ambient: [f64; 3],
    pub specular: [f64; 3],
    pub shininess: u32,
    /// Count the fragments of every pixel (the frame's `fragments` layer and statistics):
    /// on by default. Off, a triangle a tile's depth bound hides gets no edge test there.
    pub count_fragments: bool,
    /// Count per `TILE × TILE` tile the triangles that reach it and those its depth bound hid
    /// (the frame's `tiles`, for heat maps). Off by default.
    pub count_tiles: bool,
    /// Return the colour layer (on by default). Off, the frame's `colour` is empty and the GPU
    /// backend leaves it on the device: an id or depth view reads back less.
    pub return_colour: bool,
    /// Return the depth layer (on by default). Off, the frame's `depth` is empty and the GPU
    /// backend leaves it on the device. The face ids are always returned: the frame's
    /// statistics count them.
    pub return_depth: bool,
    /// Every texture filtered so (`None`: as each texture says).
    pub texture_filter: Option<Filter>,
    /// Every texture addressed so in `u` and `v` (`None`: as each texture says).
    pub texture_address: Option<Address>,
    /// Draw the faces (on by default; off with `points`: the vertices alone, a point cloud).
    pub faces: bool,
    /// Draw every vertex as a square this many pixels wide, centred on it, after the faces
    /// (the vertices view), in its vertex's attributes; `None`: no points.
    pub points: Option<f32>,
    /// Draw every edge of the faces as a line one pixel wide, after the faces and before the
    /// points (the wireframe view); `None`: no lines.
    pub wireframe: Option<Wireframe>,
    /// Samples per pixel: 1, or 4 or 8 at Vulkan's standard positions (multisampling: coverage
    /// and depth per sample, each triangle shaded once per pixel, the samples averaged). The
    /// depth, ids and fragments layers take sample 0's depth and owner and count the triangles
    /// that cover a sample. Not with `blend`.
    pub samples: u32,
    /// The sample whose depth and owner the depth and id layers take, with several samples
    /// (0 by default; below `samples`).
    pub layer_sample: u32,
    /// `empty_tiles`, `cull_window`, `hidden_triangles` and `cull_instances` apply; the depth test needs the
    /// rest off.
    pub skips: Skips,
    /// A fragment shader that colours every fragment instead of `shading`
    /// ([`fragment_stage!`](crate::fragment_stage)); `None`: the built-in shadings.
    pub fragment: Option<FragmentStage>,
    /// Values the fragment shader reads (`ShadeParams::constants`); zeros by default.
    pub fragment_constants: FragmentConstants,
}

impl RenderParams {
    pub fn new(width: u32, height: u32, view_projection: [[f64; 4]; 4]) -> Self {
        RenderParams {
            width,
            height,
            model: IDENTITY,
            view_projection,
            eye: None,
            cull: Cull::Back,
            front_face: FrontFace::CounterClockwise,
            shading: Shading::Smooth,
            interpolation: Interpolation::Perspective,
            depth_func: DepthFunc::Less,
            depth_write: true,
            clear_depth: 1.0,
            blend: false,
            background: [0, 0, 0, 0],
            lights: vec![Light { direction: [0.4, 0.5, 0.75], colour: [0.85, 0.85, 0.85] }],
            ambient: [0.15, 0.15, 0.15],
            specular: [0.25, 0.25, 0.25],
            shininess: 32,
            count_fragments: true,
            count_tiles: false,
            return_colour: true,
            return_depth: true,
            texture_filter: None,
            texture_address: None,
            faces: true,
            points: None,
            wireframe: None,
            samples: 1,
            layer_sample: 0,
            skips: Skips::ALL,
            fragment: None,
            fragment_constants: [0.0; tileraster_kernels::abi::FRAGMENT_CONSTANTS],
        }
    }
}

/// What the geometry stages did to the faces, equal on both backends.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GeometryCounts {
    /// Faces cut by a clipping plane that kept some of their area.
    pub clipped: u64,
    /// Faces wholly outside the frustum (or clipped away entirely).
    pub culled_frustum: u64,
    /// Triangles dropped as back faces, or as front faces.
    pub culled_back: u64,
    pub culled_front: u64,
    /// Triangles with no area once snapped.
    pub culled_zero_area: u64,
    /// Triangles whose snapped box holds no pixel centre of the frame.
    pub culled_no_centre: u64,
    /// Triangles that reach the rasteriser.
    pub rasterised: u64,
    /// Instances whose bounding box lies outside the view frustum: no vertex work, their faces
    /// in none of the counts above (`Skip::CullInstances`).
    pub instances_culled: u64,
    /// Instances through the vertex stage.
    pub instances_drawn: u64,
    /// Vertices drawn as points (two triangles each, in `rasterised`), and vertices outside
    /// the view volume, whose points are dropped (as graphics APIs clip points by position).
    pub points_drawn: u64,
    pub points_culled: u64,
    /// Edges drawn as lines (two triangles each, in `rasterised`), and edges that light no
    /// pixel: outside the view volume, or under their rule (within one pixel's diamond).
    pub lines_drawn: u64,
    pub lines_culled: u64,
}

impl GeometryCounts {
    fn add(mut self, o: GeometryCounts) -> Self {
        self.clipped += o.clipped;
        self.culled_frustum += o.culled_frustum;
        self.culled_back += o.culled_back;
        self.culled_front += o.culled_front;
        self.culled_zero_area += o.culled_zero_area;
        self.culled_no_centre += o.culled_no_centre;
        self.rasterised += o.rasterised;
        self.instances_culled += o.instances_culled;
        self.instances_drawn += o.instances_drawn;
        self.points_drawn += o.points_drawn;
        self.points_culled += o.points_culled;
        self.lines_drawn += o.lines_drawn;
        self.lines_culled += o.lines_culled;
        self
    }
}

/// A vertex through the vertex stage: clip-space position and attributes.
#[derive(Clone, Copy, Default)]
struct ClipVertex {
    clip: [f64; 4],
    attributes: [f64; ATTRIBUTES],
    /// Bit `k`: outside clipping plane `k` (`Viewport::planes`).
    outside: u8,
    /// What the kernels take of it, when inside every clipping plane (computed once for every
    /// face that shares it).
    projected: Projected,
}

impl ClipVertex {
    fn new(clip: [f64; 4], attributes: [f64; ATTRIBUTES], viewport: &Viewport) -> Self {
        let planes = viewport.planes();
        let outside = (0..planes.len()).fold(0u8, |m, k| m | u8::from(distance(&planes, k, &clip) < 0.0) << k);
        let mut v = ClipVertex { clip, attributes, outside, projected: Projected::default() };
        if outside == 0 {
            v.projected = v.project(viewport);
        }
        v
    }

    /// Its snapped screen position, depth, `1/w` and attributes in `f32`.
    fn project(&self, viewport: &Viewport) -> Projected {
        let c = &self.clip;
        Projected {
            screen: viewport.snap(c),
            depth: (c[2] / c[3]).clamp(0.0, 1.0) as f32,
            inv_w: (1.0 / c[3]) as f32,
            attributes: self.attributes.map(|a| a as f32),
        }
    }
}

/// A vertex inside every clipping plane as the kernels take it.
#[derive(Clone, Copy, Default)]
struct Projected {
    /// Snapped, in `2^-RENDER_SNAP_BITS` px, `y` down.
    screen: (i64, i64),
    /// `z/w`, in [0, 1].
    depth: f32,
    inv_w: f32,
    attributes: [f32; ATTRIBUTES],
}

/// Faces per task of the geometry stages; tasks keep face order.
const CHUNK: usize = 1 << 12;

/// Runs the geometry stages over `mesh`: the prepared scene the kernels rasterise, and what
/// the stages did.
pub fn prepare_render(mesh: &Mesh, params: &RenderParams) -> Result<(Prepared, GeometryCounts), Error> {
    validate_mesh(mesh)?;
    prepare_checked_mesh(mesh, params)
}

/// [`prepare_render`] for a mesh [`validate_mesh`] has accepted.
pub fn prepare_checked_mesh(mesh: &Mesh, params: &RenderParams) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_checked_mesh_in(mesh, params, &mut GeometryMemory::default())
}

/// The geometry stages' memory, kept between frames: the vertices through the vertex stage and
/// the arrays of the frame's triangles ([`GeometryMemory::recycle`] takes them back from the
/// frame). A frame that reuses it writes into pages already mapped instead of faulting fresh
/// ones in; its bits are the same.
#[derive(Default)]
pub struct GeometryMemory {
    world: Vec<[f64; 3]>,
    vertices: Vec<ClipVertex>,
    triangles: Vec<TriangleInput>,
    shading: Vec<TriangleShading>,
}

impl GeometryMemory {
    /// Take back the triangle arrays of a frame prepared in this memory.
    pub fn recycle(&mut self, prepared: Prepared) {
        self.triangles = prepared.triangles;
        if let Some(render) = prepared.render {
            self.shading = render.triangles;
        }
    }
}

/// [`prepare_checked_mesh`] in `memory`.
pub fn prepare_checked_mesh_in(mesh: &Mesh, params: &RenderParams, memory: &mut GeometryMemory) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_instances_in(std::slice::from_ref(mesh), &[Instance::of(0)], params, memory)
}

/// Runs the geometry stages over every instance of `world`.
pub fn prepare_world(world: &World, params: &RenderParams) -> Result<(Prepared, GeometryCounts), Error> {
    validate_world(&world.meshes, &world.instances)?;
    prepare_instances_in(&world.meshes, &world.instances, params, &mut GeometryMemory::default())
}

/// A visible instance as the geometry stages take it.
struct Placement<'a> {
    /// Its mesh, and where the world lists it.
    mesh: &'a Mesh,
    mesh_index: usize,
    to_world: [[f64; 4]; 4],
    /// Whether the instance's own transform mirrors (its faces are taken the other way round).
    mirrored: bool,
    /// Its first vertex in the frame's vertex arrays.
    first_vertex: usize,
    /// The id of its first face.
    first_face: u32,
    /// Its mesh's first texture in the frame's textures.
    first_texture: u32,
    /// The id of its first vertex's point: after every instance's faces, vertices numbered
    /// over every instance in order.
    first_point: u32,
    /// The id of its first edge's line: after every instance's points, edges numbered over
    /// every instance in order.
    first_line: u32,
}

/// The geometry stages over instances of checked meshes (`validate_world`).
pub(crate) fn prepare_instances_in(
    meshes: &[Mesh],
    instances: &[Instance],
    params: &RenderParams,
    memory: &mut GeometryMemory,
) -> Result<(Prepared, GeometryCounts), Error> {
    validate_params(params)?;
    let (w, h) = (params.width, params.height);
    let m = &params.view_projection;
    let eye = match params.eye {
        Some(e) => e.homogeneous(),
        None => Eye::of(m, params.depth_func).map(Eye::homogeneous).ok_or_else(|| Error::SingularCamera {
            reason: "the view-projection matrix has neither a centre of projection (x = y = w = 0 has no single solution) nor a single viewing direction; give the eye".into(),
        })?,
    };
    let lights: Vec<Light> = params.lights.iter().take(MAX_LIGHTS).map(|l| Light { direction: unit(l.direction), colour: l.colour }).collect();
    let lit = |base: [f64; 4], n: [f64; 3], p: [f64; 3]| blinn_phong(params, &lights, eye, base, n, p);
    let viewport = Viewport::new(w, h);

    // Object culling: instances whose bounding box lies outside the view frustum get no vertex
    // work (`instances`: it changes no bit).
    let mut counts = GeometryCounts::default();
    let bounds: Vec<Option<[[f64; 3]; 2]>> = if params.skips.cull_instances && instances.len() > 1 {
        let mut used = vec![false; meshes.len()];
        instances.iter().for_each(|i| used[i.mesh as usize] = true);
        meshes.par_iter().zip(used).map(|(mesh, used)| used.then(|| instances::bounding_box(mesh))).collect()
    } else {
        Vec::new()
    };
    // The frame's textures: every placed mesh's, once.
    let mut first_textures = vec![0u32; meshes.len()];
    let mut textures: Vec<&Texture> = Vec::new();
    let mut placed = vec![false; meshes.len()];
    instances.iter().for_each(|i| placed[i.mesh as usize] = true);
    for (k, mesh) in meshes.iter().enumerate().filter(|(k, _)| placed[*k]) {
        first_textures[k] = textures.len() as u32;
        textures.extend(mesh.textures.iter());
    }
    let (texture_infos, texels) = texture::lay_out(&textures, params.texture_filter, params.texture_address)?;
    let mut placements = Vec::with_capacity(instances.len());
    let (mut first_vertex, mut first_face) = (0, 0u32);
    let all_faces: u64 = instances.iter().map(|i| meshes[i.mesh as usize].triangles.len() as u64).sum();
    let all_vertices: u64 = instances.iter().map(|i| meshes[i.mesh as usize].positions.len() as u64).sum();
    // The wireframe's edges, once per placed mesh. A mesh of more than 2^32 / 3 faces has more
    // sides than `lines::edges` counts, and more lines than a frame numbers with its faces.
    let most_faces = meshes.iter().zip(&placed).filter(|&(_, &placed)| placed).map(|(m, _)| m.triangles.len() as u64).max().unwrap_or(0);
    if params.wireframe.is_some() && most_faces > u32::MAX as u64 / 3 {
        return Err(Error::TooManyFaces { faces: all_faces + all_vertices + most_faces });
    }
    let mesh_edges: Vec<Vec<[u32; 2]>> = match params.wireframe {
        Some(_) => meshes.par_iter().zip(&placed).map(|(m, &placed)| if placed { lines::edges(&m.triangles) } else { Vec::new() }).collect(),
        None => Vec::new(),
    };
    let all_edges: u64 = instances.iter().map(|i| mesh_edges.get(i.mesh as usize).map_or(0, |e| e.len() as u64)).sum();
    let ids = all_faces + all_vertices + all_edges;
    if (params.points.is_some() || params.wireframe.is_some()) && ids >= u32::MAX as u64 {
        return Err(Error::TooManyFaces { faces: ids });
    }
    let mut first_point = all_faces as u32;
    let mut first_line = (all_faces + all_vertices) as u32;
    for instance in instances {
        let mesh = &meshes[instance.mesh as usize];
        let to_world = instances::instance_to_world(&params.model, instance);
        let culled =
            bounds.get(instance.mesh as usize).is_some_and(|b| instances::outside_frustum(b.as_ref().expect("bounds of every placed mesh"), &to_world, m));
        if culled {
            counts.instances_culled += 1;
        } else {
            let first_texture = first_textures[instance.mesh as usize];
            placements.push(Placement {
                mesh,
                mesh_index: instance.mesh as usize,
                to_world,
                mirrored: instances::mirrors(&instance.transform),
                first_vertex,
                first_face,
                first_texture,
                first_point,
                first_line,
            });
            first_vertex += mesh.positions.len();
        }
        first_face += mesh.triangles.len() as u32;
        first_point += mesh.positions.len() as u32;
        first_line += mesh_edges.get(instance.mesh as usize).map_or(0, |e| e.len() as u32);
    }
    counts.instances_drawn = placements.len() as u64;

    // Vertex stage: each instance's transform, then the view-projection, into one array of the
    // visible instances' vertices.
    let world = &mut memory.world;
    let vertices = &mut memory.vertices;
    world.clear();
    vertices.clear();
    // Many instances of a large mesh can ask for more than the machine has: a typed error.
    let bytes = first_vertex as u128 * (std::mem::size_of::<[f64; 3]>() + std::mem::size_of::<ClipVertex>()) as u128;
    let reserved = world.try_reserve_exact(first_vertex).and_then(|()| vertices.try_reserve_exact(first_vertex));
    reserved.map_err(|e| Error::OutOfMemory { what: "the visible instances' vertices", reason: format!("{first_vertex} vertices, {bytes} bytes ({e})") })?;
    // Filled on all cores (`resize` writes them on one).
    world.par_extend(rayon::iter::repeat_n([0.0; 3], first_vertex));
    vertices.par_extend(rayon::iter::repeat_n(ClipVertex::default(), first_vertex));
    // A fragment shader takes the vertex attributes as they are (no lighting on the host).
    let shading = if params.fragment.is_some() { Shading::Unlit } else { params.shading };
    // The depth and id views read no attribute: they carry zeros, and no normal is computed.
    let attributes_used = shading.reads_attributes();
    let mut base_normals: Vec<Option<Vec<[f32; 3]>>> = vec![None; meshes.len()];
    if attributes_used {
        for p in &placements {
            let k = p.mesh_index;
            if base_normals[k].is_none() {
                base_normals[k] = Some(match &p.mesh.normals {
                    Some(n) => n.clone(),
                    None => face_normals(p.mesh),
                });
            }
        }
    }
    let mut pieces = Vec::with_capacity(placements.len());
    let (mut rest_w, mut rest_v) = (&mut world[..], &mut vertices[..]);
    for p in &placements {
        let n = p.mesh.positions.len();
        let (w, tail_w) = rest_w.split_at_mut(n);
        let (v, tail_v) = rest_v.split_at_mut(n);
        pieces.push((p, w, v));
        (rest_w, rest_v) = (tail_w, tail_v);
    }
    pieces.into_par_iter().for_each(|(p, world, vertices)| {
        let (mesh, model) = (p.mesh, &p.to_world);
        mesh.positions.par_iter().zip(world.par_iter_mut()).for_each(|(v, out)| *out = instances::transform_point(model, v));
        let world = &*world;
        let normals =
            if attributes_used { vertex_normals(base_normals[p.mesh_index].as_ref().expect("normals of every placed mesh"), model) } else { Vec::new() };
        vertices.par_iter_mut().enumerate().for_each(|(v, out)| {
            let p = world[v];
            let clip = [0, 1, 2, 3].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
            if !attributes_used {
                *out = ClipVertex::new(clip, [0.0; ATTRIBUTES], &viewport);
                return;
            }
            let n = normals[v].map(f64::from);
            let mut colour = mesh.colours.as_ref().map_or(GREY, |c| c[v]).map(f64::from);
            if shading == Shading::Smooth {
                colour = lit(colour, unit(n), p);
            }
            let uv = mesh.uvs.as_ref().map_or([0.0; 2], |t| t[v]).map(f64::from);
            let mut attributes = [0.0; ATTRIBUTES];
            attributes[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&colour);
            attributes[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&n);
            attributes[ATTR_POSITION..ATTR_POSITION + 3].copy_from_slice(&p);
            attributes[ATTR_UV..ATTR_UV + 2].copy_from_slice(&uv);
            *out = ClipVertex::new(clip, attributes, &viewport);
        });
    });
    let (world, vertices) = (&*world, &*vertices);

    let grid = Grid::new(0.0, w as f64, 0.0, h as f64, w, h);
    let target = Target { grid: &grid, samples: params.samples };
    // The faces in chunks of at most `CHUNK` of one instance each, in drawing order, then the
    // lines and the points likewise.
    let face_chunks =
        placements.iter().filter(|_| params.faces).flat_map(|p| (0..p.mesh.triangles.len()).step_by(CHUNK).map(move |start| (p, start, Work::Faces)));
    let line_chunks = placements
        .iter()
        .filter(|_| params.wireframe.is_some())
        .flat_map(|p| (0..mesh_edges[p.mesh_index].len()).step_by(CHUNK).map(move |start| (p, start, Work::Lines)));
    let point_chunks = placements
        .iter()
        .filter(|_| params.points.is_some())
        .flat_map(|p| (0..p.mesh.positions.len()).step_by(CHUNK).map(move |start| (p, start, Work::Points)));
    let chunks: Vec<(&Placement, usize, Work)> = face_chunks.chain(line_chunks).chain(point_chunks).collect();
    // Each point's and line end's depth offset towards the camera, where they are drawn over
    // the faces.
    let point_bias = match params.points {
        Some(size) if params.faces => surface_bias(&placements, vertices, size),
        _ => Vec::new(),
    };
    let line_bias = match params.wireframe {
        Some(_) if params.faces => surface_bias(&placements, vertices, 1.0),
        _ => Vec::new(),
    };
    let line_viewport = Viewport::with_guard(w, h, lines::LINE_GUARD_PX);
    // One chunk of faces through clipping, culling and snapping, in face order (or of lines,
    // or of points).
    let chunk = |&(p, start, work): &(&Placement, usize, Work), emit: &mut Emit<'_>, counts: &mut GeometryCounts| {
        if let (Work::Lines, Some(wireframe)) = (work, &params.wireframe) {
            let edges = &mesh_edges[p.mesh_index];
            let flat = params.interpolation == Interpolation::Flat;
            for (k, edge) in edges.iter().enumerate().skip(start).take(CHUNK) {
                let v = edge.map(|v| p.first_vertex + v as usize);
                let bias = v.map(|v| line_bias.get(v).copied().unwrap_or(0.0));
                lines::line(v.map(|v| &vertices[v]), bias, wireframe, flat, p.first_line + k as u32, &line_viewport, &target, emit, counts);
            }
            return;
        }
        if work == Work::Points {
            let size = params.points.expect("point chunks only with points");
            for v in start..(start + CHUNK).min(p.mesh.positions.len()) {
                let bias = point_bias.get(p.first_vertex + v).copied().unwrap_or(0.0);
                point(&vertices[p.first_vertex + v], size, bias, p.first_point + v as u32, &target, emit, counts);
            }
            return;
        }
        let mesh = p.mesh;
        let faces = &mesh.triangles[start..(start + CHUNK).min(mesh.triangles.len())];
        let mut flattened = [ClipVertex::default(); 3];
        for (k, tri) in faces.iter().enumerate() {
            let face = p.first_face + (start + k) as u32;
            let tri = if p.mirrored { [tri[0], tri[2], tri[1]] } else { *tri };
            let tri = tri.map(|v| p.first_vertex + v as usize);
            let mut corners = tri.map(|v| &vertices[v]);
            // Flat modes give every corner (and so every clipped piece) one set of values
            // (attributes only: counting needs none of it).
            let mut flat: Option<[f64; ATTRIBUTES]> = None;
            if params.interpolation == Interpolation::Flat {
                // The provoking vertex: the face's first.
                flat = Some(corners[0].attributes);
            }
            let counting = emit.counting();
            if !counting && shading == Shading::Flat {
                // One colour per face: its first vertex's, lit with the face normal there.
                let q = tri.map(|v| world[v]);
                let n = unit(cross(sub(q[1], q[0]), sub(q[2], q[0])));
                let base = mesh.colours.as_ref().map_or(GREY, |c| c[tri[0] - p.first_vertex]).map(f64::from);
                let colour = lit(base, n, q[0]);
                for a in 0..3 {
                    let mut values = flat.unwrap_or(corners[a].attributes);
                    values[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&colour);
                    values[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&n);
                    flattened[a] =
                        ClipVertex { attributes: values, projected: Projected { attributes: values.map(|v| v as f32), ..corners[a].projected }, ..*corners[a] };
                }
                corners = [&flattened[0], &flattened[1], &flattened[2]];
            } else if let Some(values) = flat.filter(|_| !counting) {
                for a in 0..3 {
                    flattened[a] =
                        ClipVertex { attributes: values, projected: Projected { attributes: values.map(|v| v as f32), ..corners[a].projected }, ..*corners[a] };
                }
                corners = [&flattened[0], &flattened[1], &flattened[2]];
            }
            let texture = match &mesh.face_textures {
                Some(t) => t[start + k],
                None if mesh.textures.is_empty() => NO_TEXTURE,
                None => 0,
            };
            let texture = if texture == NO_TEXTURE { NO_TEXTURE } else { p.first_texture + texture };
            geometry(corners, FaceTag { id: face, texture }, params, &viewport, &target, emit, counts);
        }
    };
    // Count, prefix sum, fill (as binning does): the first pass counts each chunk's triangles,
    // the second writes them straight into their place, on all cores.
    let counted: Vec<(usize, GeometryCounts)> = chunks
        .par_iter()
        .map(|c| {
            let (mut emit, mut counts) = (Emit::Count(0), GeometryCounts::default());
            chunk(c, &mut emit, &mut counts);
            (emit.count(), counts)
        })
        .collect();
    let counts = counted.iter().fold(counts, |sum, p| sum.add(p.1));
    let total: usize = counted.iter().map(|p| p.0).sum();
    if total >= u32::MAX as usize {
        return Err(Error::RasterTooLarge {
            width: w as u64,
            height: h as u64,
            reason: format!("clipping left {total} triangles, more than the 2^32 − 1 a frame indexes"),
        });
    }
    let out_of_memory = |reason| Error::OutOfMemory { what: "the frame's triangles", reason };
    let mut triangles = crate::raster::reuse_cells(Some(std::mem::take(&mut memory.triangles)), total).map_err(out_of_memory)?;
    let mut shading = crate::raster::reuse_cells(Some(std::mem::take(&mut memory.shading)), total).map_err(out_of_memory)?;
    let mut parts = Vec::with_capacity(counted.len());
    let (mut rest_t, mut rest_s, mut first_slot) = (&mut triangles[..], &mut shading[..], 0);
    for &(n, _) in &counted {
        let (t, tail_t) = rest_t.split_at_mut(n);
        let (s, tail_s) = rest_s.split_at_mut(n);
        parts.push(Emit::Fill { triangles: t, shading: s, next: 0, first_slot });
        (rest_t, rest_s, first_slot) = (tail_t, tail_s, first_slot + n);
    }
    chunks.par_iter().enumerate().zip(parts).for_each(|((c, piece), mut emit)| {
        chunk(piece, &mut emit, &mut GeometryCounts::default());
        debug_assert_eq!(emit.count(), counted[c].0, "the filling pass puts what the counting pass counted");
    });
    let mut counts = counts;
    counts.rasterised = total as u64;
    let mut shade = shade_params(params, &lights, eye, depth_range(vertices));
    shade.textured = u32::from(!texture_infos.is_empty());
    // Whether the stages may take every edge function in 32-bit arithmetic.
    shade.small_edges = u32::from(triangles.par_iter().all(|t| edges_fit_i32(t, RENDER_SNAP_BITS)));
    // Multisampled tiles take neither path: both speak of pixel centres.
    let skips = Skips { full_tiles: false, overlap_free: false, hidden_triangles: params.skips.hidden_triangles && params.samples == 1, ..params.skips };
    let grid_params = Params {
        grid,
        nodata: params.clear_depth,
        // The frame returns face ids, not setup slots: the stages keep their owner layer to
        // themselves (`Prepared::keeps_owner`).
        outputs: Outputs { owner: false, coverage: params.count_fragments, tiles: params.count_tiles },
        // The depth is the barycentric mode's arithmetic: the GPU backend checks that the
        // adapter gives the CPU's bits for it before using it.
        mode: Mode::Barycentric,
        skips,
    };
    let culled = counts.culled_frustum + counts.culled_back + counts.culled_front + counts.culled_no_centre;
    let prepared = Prepared {
        params: grid_params,
        window: Window::whole(&grid),
        snap_bits: RENDER_SNAP_BITS,
        triangles,
        culled: culled as usize,
        degenerate: counts.culled_zero_area as usize,
        overlap_free_rows: None,
        render: Some(RenderInputs {
            triangles: shading,
            params: shade,
            depth_test: DepthTest::new(params.depth_func, params.depth_write),
            textures: texture_infos,
            texels,
            fragment: params.fragment,
            returns_colour: params.return_colour,
            returns_depth: params.return_depth,
        }),
    };
    Ok((prepared, counts))
}

/// The kernels' shade parameters for a frame.
fn shade_params(params: &RenderParams, lights: &[Light], eye: [f64; 4], (near, far): (f64, f64)) -> ShadeParams {
    let mode = match params.shading {
        Shading::Unlit | Shading::Flat | Shading::Smooth => ShadeMode::Colour,
        Shading::Phong => ShadeMode::Phong,
        Shading::Depth => ShadeMode::Depth,
        Shading::Normals => ShadeMode::Normals,
        Shading::Ids => ShadeMode::Ids,
    };
    let f4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
    let mut s = ShadeParams {
        shading: mode as u32,
        interpolation: params.interpolation as u32,
        background: u32::from_le_bytes(params.background),
        lights: lights.len() as u32,
        shininess: params.shininess,
        blend: u32::from(params.blend),
        depth_test: DepthTest::new(params.depth_func, params.depth_write),
        ambient: f4(params.ambient),
        specular: f4(params.specular),
        eye: eye.map(|c| c as f32),
        depth_view: [near as f32, (1.0 / (far - near).max(1e-6)) as f32, 0.0, 0.0],
        samples: params.samples,
        layer_sample: params.layer_sample,
        constants: params.fragment_constants,
        ..Default::default()
    };
    for (k, l) in lights.iter().enumerate() {
        s.light_dir[k] = f4(l.direction);
        s.light_colour[k] = f4(l.colour);
    }
    s
}

/// The depths of the visible vertices, lowest and highest (the depth view's range).
fn depth_range(vertices: &[ClipVertex]) -> (f64, f64) {
    let inside = |c: &[f64; 4]| c[3] > 0.0 && c[2] >= 0.0 && c[2] <= c[3] && c[0].abs() <= c[3] && c[1].abs() <= c[3];
    let visible = vertices.par_iter().filter(|v| inside(&v.clip)).map(|v| v.clip[2] / v.clip[3]);
    let (lo, hi) = visible.fold(|| (1.0f64, 0.0f64), |(lo, hi), d| (lo.min(d), hi.max(d))).reduce(|| (1.0, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    if lo < hi { (lo, hi) } else { (0.0, 1.0) }
}

/// Clip space to pixels.
struct Viewport {
    half: [f64; 2],
    /// Guard-band factor per axis: `|x| ≤ g·w` keeps a vertex within `GUARD_PX` of the viewport.
    guard: [f64; 2],
}

impl Viewport {
    fn new(w: u32, h: u32) -> Self {
        Viewport::with_guard(w, h, GUARD_PX)
    }

    /// With a guard band `guard_px` pixels wide.
    fn with_guard(w: u32, h: u32, guard_px: f64) -> Self {
        let (w, h) = (w as f64, h as f64);
        Viewport { half: [w / 2.0, h / 2.0], guard: [1.0 + 2.0 * guard_px / w, 1.0 + 2.0 * guard_px / h] }
    }

    /// The clipping planes, as coefficients of `(x, y, z, w)`: inside where the dot product is
    /// at least zero (the `w` plane: at least `W_MIN`).
    fn planes(&self) -> [[f64; 4]; 7] {
        let [gx, gy] = self.guard;
        [
            [0.0, 0.0, 1.0, 0.0],  // near: z ≥ 0
            [0.0, 0.0, -1.0, 1.0], // far: z ≤ w
            [0.0, 0.0, 0.0, 1.0],  // w ≥ W_MIN
            [1.0, 0.0, 0.0, gx],   // guard band
            [-1.0, 0.0, 0.0, gx],
            [0.0, 1.0, 0.0, gy],
            [0.0, -1.0, 0.0, gy],
        ]
    }

    /// A clip-space position in snapped pixel units (`2^-RENDER_SNAP_BITS` px), `y` down.
    fn snap(&self, c: &[f64; 4]) -> (i64, i64) {
        let unit = (1u64 << RENDER_SNAP_BITS) as f64;
        let px = (c[0] / c[3] + 1.0) * self.half[0];
        let py = (c[1] / c[3] + 1.0) * self.half[1];
        (round_to_i64(px * unit), round_to_i64(py * unit))
    }
}

/// Signed distance of `c` inside plane `k` of [`Viewport::planes`].
fn distance(planes: &[[f64; 4]; 7], k: usize, c: &[f64; 4]) -> f64 {
    let p = &planes[k];
    let d = p[0] * c[0] + p[1] * c[1] + p[2] * c[2] + p[3] * c[3];
    if k == 2 { d - W_MIN } else { d }
}

/// What a chunk of the geometry stages takes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Work {
    Faces,
    Lines,
    Points,
}

/// The depth offset of each vertex's point (or line end) drawn over the faces: the steepest
/// depth slope (per pixel, in either screen direction) of the faces around the vertex, times
/// half the point's width (a line's: one) and one pixel more, so that the square or line stays
/// in front of the surface it sits on (graphics APIs' polygon offset, computed per vertex in
/// f64 on the host).
fn surface_bias(placements: &[Placement], vertices: &[ClipVertex], size: f32) -> Vec<f64> {
    let mut slope = vec![0.0f64; vertices.len()];
    for p in placements {
        for tri in &p.mesh.triangles {
            let v = tri.map(|k| p.first_vertex + k as usize);
            if v.iter().any(|&k| vertices[k].outside != 0) {
                continue;
            }
            let q = v.map(|k| &vertices[k].projected);
            let px =
                |k: usize| (q[k].screen.0 as f64 / (1 << RENDER_SNAP_BITS) as f64, q[k].screen.1 as f64 / (1 << RENDER_SNAP_BITS) as f64, q[k].depth as f64);
            let (a, b, c) = (px(0), px(1), px(2));
            let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
            if area == 0.0 {
                continue;
            }
            let ddx = ((b.2 - a.2) * (c.1 - a.1) - (c.2 - a.2) * (b.1 - a.1)) / area;
            let ddy = ((c.2 - a.2) * (b.0 - a.0) - (b.2 - a.2) * (c.0 - a.0)) / area;
            let s = ddx.abs() + ddy.abs();
            for k in v {
                slope[k] = slope[k].max(s);
            }
        }
    }
    let reach = size as f64 / 2.0 + 1.0;
    slope.into_iter().map(|s| s * reach).collect()
}

/// A vertex's point: a square `size` pixels wide centred on its snapped position, as two
/// triangles (the top-left rule then covers exactly `size²` pixel centres of a square of whole
/// pixels wherever it lies), at the vertex's depth less `bias`, in its attributes; dropped
/// where the vertex lies outside the view volume.
fn point(v: &ClipVertex, size: f32, bias: f64, id: u32, target: &Target<'_>, out: &mut Emit<'_>, counts: &mut GeometryCounts) {
    let c = &v.clip;
    if !(c[3] > W_MIN && c[0].abs() <= c[3] && c[1].abs() <= c[3] && c[2] >= 0.0 && c[2] <= c[3]) {
        counts.points_culled += 1;
        return;
    }
    counts.points_drawn += 1;
    let q = &v.projected;
    let half = (size as f64 * (1 << (RENDER_SNAP_BITS - 1)) as f64).round() as i64;
    let (x0, y0, x1, y1) = (q.screen.0 - half, q.screen.1 - half, q.screen.0 + half, q.screen.1 + half);
    let depth = ((q.depth as f64 - bias).max(0.0)) as f32;
    let area = (2 * half) as f64 * (2 * half) as f64;
    for (x, y) in [([x0, x1, x1], [y0, y0, y1]), ([x0, x1, x0], [y0, y1, y1])] {
        let rect = target.rect(&x, &y);
        if rect.is_empty() {
            counts.culled_no_centre += 1;
            continue;
        }
        out.put(|| {
            let coeffs = FloatCoeffs { c: [depth, depth, depth, (1.0 / area) as f32] };
            (
                TriangleInput { x, y, rect, coeffs, ..Default::default() },
                TriangleShading { attributes: [q.attributes; 3], inv_w: [q.inv_w, q.inv_w, q.inv_w, 0.0], face: id, texture: NO_TEXTURE, flags: 0, _pad: 0 },
            )
        });
    }
}

/// The frame the geometry stages emit triangles for: its pixels and samples per pixel.
#[derive(Clone, Copy)]
struct Target<'a> {
    grid: &'a Grid,
    samples: u32,
}

impl Target<'_> {
    /// The pixels a triangle with snapped vertices `x`, `y` may cover: those whose centre lies
    /// in its box or, with several samples, whose samples may (the standard positions lie
    /// within 7/16 px of the centre).
    fn rect(&self, x: &[i64; 3], y: &[i64; 3]) -> PixelRect {
        let reach = if self.samples > 1 { 7 << (RENDER_SNAP_BITS - 4) } else { 0 };
        let (x0, x1) = (x[0].min(x[1]).min(x[2]) - reach, x[0].max(x[1]).max(x[2]) + reach);
        let (y0, y1) = (y[0].min(y[1]).min(y[2]) - reach, y[0].max(y[1]).max(y[2]) + reach);
        pixel_rect(&[x0, x1, x1], &[y0, y1, y1], RENDER_SNAP_BITS, self.grid)
    }
}

/// What the kernels keep of a face besides its vertices: its id and its texture.
#[derive(Clone, Copy)]
struct FaceTag {
    id: u32,
    texture: u32,
}

/// Clip, cull, snap one face and push what reaches the rasteriser.
fn geometry(
    corners: [&ClipVertex; 3],
    face: FaceTag,
    params: &RenderParams,
    viewport: &Viewport,
    target: &Target<'_>,
    out: &mut Emit<'_>,
    counts: &mut GeometryCounts,
) {
    // Wholly outside one plane of the view frustum: nothing to clip.
    let c = corners.map(|v| v.clip);
    let frustum: [fn(&[f64; 4]) -> bool; 6] = [|c| c[0] < -c[3], |c| c[0] > c[3], |c| c[1] < -c[3], |c| c[1] > c[3], |c| c[2] < 0.0, |c| c[2] > c[3]];
    if frustum.iter().any(|outside| c.iter().all(outside)) {
        counts.culled_frustum += 1;
        return;
    }
    if corners.iter().all(|v| v.outside == 0) {
        return triangles(&corners.map(|v| v.projected), face, params, target, out, counts);
    }
    let polygon = clip_polygon(&corners.map(|v| *v), &viewport.planes());
    if polygon.len() < 3 {
        counts.culled_frustum += 1;
        return;
    }
    counts.clipped += 1;
    let projected: Vec<Projected> = polygon.iter().map(|v| v.project(viewport)).collect();
    triangles(&projected, face, params, target, out, counts);
}

/// Cull, orient and set up the fan of a convex polygon of vertices inside every clipping plane,
/// and push what reaches the rasteriser.
fn triangles(polygon: &[Projected], face: FaceTag, params: &RenderParams, target: &Target<'_>, out: &mut Emit<'_>, counts: &mut GeometryCounts) {
    for k in 1..polygon.len() - 1 {
        let mut v = [0, k, k + 1];
        let (mut x, mut y) = (v.map(|i| polygon[i].screen.0), v.map(|i| polygon[i].screen.1));
        let area = (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
        if area == 0 {
            counts.culled_zero_area += 1;
            continue;
        }
        // Vulkan's rule: with y down, a triangle counter-clockwise on the screen has a negative
        // cross product here.
        let front = (area < 0) == (params.front_face == FrontFace::CounterClockwise);
        match (params.cull, front) {
            (Cull::Back, false) => {
                counts.culled_back += 1;
                continue;
            }
            (Cull::Front, true) => {
                counts.culled_front += 1;
                continue;
            }
            _ => {}
        }
        if area < 0 {
            v.swap(1, 2);
            x.swap(1, 2);
            y.swap(1, 2);
        }
        let rect = target.rect(&x, &y);
        if rect.is_empty() {
            counts.culled_no_centre += 1;
            continue;
        }
        let extent = (x.iter().max().unwrap() - x.iter().min().unwrap()).max(y.iter().max().unwrap() - y.iter().min().unwrap());
        debug_assert!(((extent >> RENDER_SNAP_BITS) + 2) << RENDER_SNAP_BITS < 1 << EXTENT_LIMIT_BITS, "the guard band bounds every triangle");
        out.put(|| {
            // Entry k of the kernels' per-vertex data belongs to the vertex opposite edge k.
            let opposite = [v[2], v[0], v[1]];
            let area = area.unsigned_abs() as f64;
            let depth = |i: usize| polygon[i].depth;
            let coeffs = FloatCoeffs { c: [depth(opposite[0]), depth(opposite[1]), depth(opposite[2]), (1.0 / area) as f32] };
            let inv_w = |i: usize| polygon[i].inv_w;
            let attributes = opposite.map(|i| polygon[i].attributes);
            (
                TriangleInput { x, y, rect, coeffs, ..Default::default() },
                TriangleShading {
                    attributes,
                    inv_w: [inv_w(opposite[0]), inv_w(opposite[1]), inv_w(opposite[2]), 0.0],
                    face: face.id,
                    texture: face.texture,
                    flags: 0,
                    _pad: 0,
                },
            )
        });
    }
}

/// Where the geometry stages put the triangles that reach the rasteriser: the first pass
/// counts a chunk's, the second writes them into the chunk's place in the frame's arrays.
enum Emit<'a> {
    Count(usize),
    Fill { triangles: &'a mut [TriangleInput], shading: &'a mut [TriangleShading], next: usize, first_slot: usize },
}

impl Emit<'_> {
    fn counting(&self) -> bool {
        matches!(self, Emit::Count(_))
    }

    /// Triangles put so far.
    fn count(&self) -> usize {
        match self {
            Emit::Count(n) | Emit::Fill { next: n, .. } => *n,
        }
    }

    /// Put the next triangle; `make` builds it only where it is written.
    fn put(&mut self, make: impl FnOnce() -> (TriangleInput, TriangleShading)) {
        match self {
            Emit::Count(n) => *n += 1,
            Emit::Fill { triangles, shading, next, first_slot } => {
                let (t, s) = make();
                // The setup slot is the index: the depth key's tie-break and the owner layer's value.
                triangles[*next] = TriangleInput { index: (*first_slot + *next) as u32, ..t };
                shading[*next] = s;
                *next += 1;
            }
        }
    }
}

/// Sutherland–Hodgman in homogeneous space against every plane. An edge crossing a plane is cut
/// at the point interpolated from its inside end, so a face's neighbour cuts the shared edge
/// at the same point.
fn clip_polygon(corners: &[ClipVertex; 3], planes: &[[f64; 4]; 7]) -> Vec<ClipVertex> {
    let mut polygon = corners.to_vec();
    for k in 0..planes.len() {
        if polygon.is_empty() {
            break;
        }
        let d: Vec<f64> = polygon.iter().map(|v| distance(planes, k, &v.clip)).collect();
        if d.iter().all(|&d| d >= 0.0) {
            continue;
        }
        let mut next = Vec::with_capacity(polygon.len() + 1);
        for i in 0..polygon.len() {
            let j = (i + 1) % polygon.len();
            if d[i] >= 0.0 {
                next.push(polygon[i]);
            }
            if (d[i] >= 0.0) != (d[j] >= 0.0) {
                let (a, b, da, db) = if d[i] >= 0.0 { (&polygon[i], &polygon[j], d[i], d[j]) } else { (&polygon[j], &polygon[i], d[j], d[i]) };
                next.push(cut(a, b, da, db, k));
            }
        }
        polygon = next;
    }
    polygon
}

/// The point where the edge from `a` (inside plane `k`, at distance `da`) to `b` (outside, at
/// `db`) crosses the plane, interpolated from the inside end.
fn cut(a: &ClipVertex, b: &ClipVertex, da: f64, db: f64, k: usize) -> ClipVertex {
    let t = da / (da - db);
    let mut v = ClipVertex { clip: [0.0; 4], attributes: [0.0; ATTRIBUTES], outside: 0, projected: Projected::default() };
    for n in 0..4 {
        v.clip[n] = a.clip[n] + t * (b.clip[n] - a.clip[n]);
    }
    for n in 0..ATTRIBUTES {
        v.attributes[n] = a.attributes[n] + t * (b.attributes[n] - a.attributes[n]);
    }
    // On the near and far planes exactly, so that depths stay within [0, 1].
    match k {
        0 => v.clip[2] = 0.0,
        1 => v.clip[2] = v.clip[3],
        _ => {}
    }
    v
}

/// Lambert + Blinn-Phong in `f64` (flat and Gouraud shading; the kernels' per-pixel version is
/// `programs::shade`).
fn blinn_phong(params: &RenderParams, lights: &[Light], eye: [f64; 4], base: [f64; 4], n: [f64; 3], p: [f64; 3]) -> [f64; 4] {
    let v = unit(std::array::from_fn(|c| eye[c] - p[c] * eye[3]));
    let mut diffuse = params.ambient;
    let mut specular = [0.0; 3];
    for l in lights {
        let ndl = dot(n, l.direction);
        if ndl > 0.0 {
            let h = unit([l.direction[0] + v[0], l.direction[1] + v[1], l.direction[2] + v[2]]);
            let s = dot(n, h).max(0.0).powi(params.shininess as i32);
            for c in 0..3 {
                diffuse[c] += ndl * l.colour[c];
                specular[c] += s * l.colour[c];
            }
        }
    }
    let channel = |c: usize| base[c] * diffuse[c] + params.specular[c] * specular[c];
    [channel(0), channel(1), channel(2), base[3]]
}

/// The mesh's normals in the world: its own, or (where it has none) [`face_normals`], turned by
/// the model matrix's inverse transpose (its cofactors, with the determinant's sign) and
/// normalised.
fn vertex_normals(n: &[[f32; 3]], model: &[[f64; 4]; 4]) -> Vec<[f32; 3]> {
    if *model == IDENTITY {
        return n.to_vec();
    }
    let normal_matrix = normal_matrix(model);
    n.par_iter().map(|&v| transform_normal(&normal_matrix, v)).collect()
}

/// What turns normals as `m` (affine, row-major) turns positions: the cofactors of its linear
/// part, that is its inverse transpose times the determinant, with the determinant's sign
/// taken out so that a mirroring transform does not turn normals inside out.
pub fn normal_matrix(m: &[[f64; 4]; 4]) -> [[f64; 3]; 3] {
    let cofactor: [[f64; 3]; 3] = std::array::from_fn(|r| {
        std::array::from_fn(|c| {
            let (r1, r2, c1, c2) = ((r + 1) % 3, (r + 2) % 3, (c + 1) % 3, (c + 2) % 3);
            m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
        })
    });
    let det: f64 = (0..3).map(|c| m[0][c] * cofactor[0][c]).sum();
    cofactor.map(|row| row.map(|v| if det < 0.0 { -v } else { v }))
}

/// Normal `n` turned by `normal_matrix` and normalised (zero stays zero).
pub fn transform_normal(normal_matrix: &[[f64; 3]; 3], n: [f32; 3]) -> [f32; 3] {
    let v = n.map(f64::from);
    let m = normal_matrix;
    unit(std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])).map(|c| c as f32)
}

/// Area-weighted face normals summed per vertex, in the mesh's coordinates and in face order
/// (so the same on every run), normalised: the normals of a mesh that has none.
pub fn face_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    let mut sum = vec![[0.0f64; 3]; mesh.positions.len()];
    for tri in &mesh.triangles {
        let p = tri.map(|v| mesh.positions[v as usize]);
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        for &v in tri {
            for c in 0..3 {
                sum[v as usize][c] += n[c];
            }
        }
    }
    sum.into_iter().map(|n| unit(n).map(|c| c as f32)).collect()
}

/// The point the view-projection maps to `x = y = w = 0` (a perspective camera's eye).
pub fn centre_of_projection(m: &[[f64; 4]; 4]) -> Option<[f64; 3]> {
    let rows = [m[0], m[1], m[3]];
    let a = rows.map(|r| [r[0], r[1], r[2]]);
    let b = rows.map(|r| -r[3]);
    let det = dot(a[0], cross(a[1], a[2]));
    let scale = a.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
    if det.is_nan() || det.abs() <= 1e-12 * scale.powi(3) {
        return None;
    }
    // Cramer's rule.
    let col = |k: usize| -> [[f64; 3]; 3] {
        let mut c = a;
        for r in 0..3 {
            c[r][k] = b[r];
        }
        c
    };
    Some([0, 1, 2].map(|k| {
        let c = col(k);
        dot(c[0], cross(c[1], c[2])) / det
    }))
}

/// The frame's size and matrices.
fn validate_params(params: &RenderParams) -> Result<(), Error> {
    let (w, h) = (params.width, params.height);
    if w == 0 || h == 0 {
        return Err(Error::ZeroSizedRaster { width: w as u64, height: h as u64 });
    }
    if w > MAX_RENDER_DIM || h > MAX_RENDER_DIM {
        return Err(Error::RasterTooLarge { width: w as u64, height: h as u64, reason: format!("a frame is at most {MAX_RENDER_DIM} pixels wide and high") });
    }
    match params.points {
        Some(size) if !(MIN_POINT_SIZE..=MAX_POINT_SIZE).contains(&size) => {
            return Err(Error::InvalidPointSize { size });
        }
        None if !params.faces && params.wireframe.is_none() => return Err(Error::NothingToDraw),
        _ => {}
    }
    if ![1, 4, 8].contains(&params.samples) {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "give 1, 4 or 8 samples per pixel" });
    }
    if params.layer_sample >= params.samples.max(1) {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "the layer sample must be one of the frame's samples" });
    }
    if params.samples > 1 && params.blend {
        return Err(Error::InvalidSamples { samples: params.samples, reason: "blending is drawn with one sample per pixel" });
    }
    if let Some(colour) = params.wireframe.and_then(|w| w.colour)
        && colour.iter().any(|c| !(0.0..=1.0).contains(c))
    {
        return Err(Error::InvalidColour { what: "the wireframe", colour });
    }
    for (name, m) in [("model", &params.model), ("view-projection", &params.view_projection)] {
        for (row, r) in m.iter().enumerate() {
            for (column, &value) in r.iter().enumerate() {
                if !value.is_finite() {
                    return Err(Error::NonFiniteMatrix { name, row, column, value });
                }
            }
        }
        if name == "model" && m[3] != [0.0, 0.0, 0.0, 1.0] {
            return Err(Error::NonAffineModel { last_row: m[3] });
        }
    }
    Ok(())
}

/// A mesh's positions, faces and attributes: finite, in range, one attribute per vertex.
pub fn validate_mesh(mesh: &Mesh) -> Result<(), Error> {
    if mesh.positions.is_empty() {
        return Err(Error::EmptyScene { what: "vertices" });
    }
    if mesh.triangles.is_empty() {
        return Err(Error::EmptyScene { what: "triangles" });
    }
    for (vertex, v) in mesh.positions.iter().enumerate() {
        for (axis, value) in ['x', 'y', 'z'].into_iter().zip(*v) {
            if !value.is_finite() {
                return Err(Error::NonFiniteCoordinate { vertex, axis, value });
            }
        }
    }
    let n = mesh.positions.len();
    for (triangle, tri) in mesh.triangles.iter().enumerate() {
        for (corner, &index) in tri.iter().enumerate() {
            if index as usize >= n {
                return Err(Error::IndexOutOfRange { triangle, corner, index: index as u64, vertex_count: n });
            }
        }
    }
    check_attribute("normals", mesh.normals.as_deref(), n)?;
    check_attribute("colours", mesh.colours.as_deref(), n)?;
    check_attribute("texture coordinates", mesh.uvs.as_deref(), n)?;
    for (k, texture) in mesh.textures.iter().enumerate() {
        texture.check(k)?;
    }
    if let Some(faces) = &mesh.face_textures {
        if faces.len() != mesh.triangles.len() {
            return Err(Error::AttributeLength { attribute: "face textures", len: faces.len(), vertex_count: mesh.triangles.len() });
        }
        if let Some((face, &t)) = faces.iter().enumerate().find(|&(_, &t)| t != NO_TEXTURE && t as usize >= mesh.textures.len()) {
            return Err(Error::InvalidTexture {
                texture: t as usize,
                reason: format!("face {face} takes it, but the mesh has {} textures", mesh.textures.len()),
            });
        }
    }
    Ok(())
}

fn check_attribute<const N: usize>(attribute: &'static str, values: Option<&[[f32; N]]>, vertex_count: usize) -> Result<(), Error> {
    let Some(values) = values else { return Ok(()) };
    if values.len() != vertex_count {
        return Err(Error::AttributeLength { attribute, len: values.len(), vertex_count });
    }
    for (vertex, v) in values.iter().enumerate() {
        if let Some(&value) = v.iter().find(|c| !c.is_finite()) {
            return Err(Error::NonFiniteAttribute { attribute, vertex, value: value as f64 });
        }
    }
    Ok(())
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let len = dot(v, v).sqrt();
    if len > 0.0 { v.map(|c| c / len) } else { [0.0; 3] }
}

/// The product `a · b` of two row-major 4×4 matrices.
pub fn multiply(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|r| std::array::from_fn(|c| a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c] + a[r][3] * b[3][c]))
}
