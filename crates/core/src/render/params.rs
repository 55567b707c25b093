//! What a frame is made of and asked for: the mesh, the render parameters, and what the
//! geometry stages report.

use super::program::{FragmentConstants, FragmentStage, VertexConstants, VertexStage, VertexTexture};
use super::texture::Texture;
use super::vector::{cross, dot, sub, unit};
use crate::Skips;
use tileraster_kernels::abi::{
    Address, DepthFunc, FaceMaterial, Filter, Interpolation, MaterialRecord, NO_TEXTURE, SHADING_DOUBLE_SIDED, SHADING_MASK, SHADING_NOT_LIT, SHADING_OPAQUE,
};

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
    /// How the faces' surfaces are drawn and lit besides their colour. None: the frame's
    /// (`RenderParams::metallic`, `roughness`, culling, alpha as the colours give it).
    pub materials: Vec<Material>,
    /// Each face's material, an index into `materials`; `None`: every face takes material 0
    /// where there is one.
    pub face_materials: Option<Vec<u32>>,
}

/// How a surface is drawn and lit besides its colour (the vertex colours times the base-colour
/// texture): glTF 2.0's metallic-roughness material, as far as the renderer reads it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Material {
    /// How metallic, and how rough (perceptual roughness), in `[0, 1]` (`Shading::Pbr`).
    pub metallic: f32,
    pub roughness: f32,
    /// Kept whichever way it faces, whatever the frame culls; its back is lit with the normal
    /// turned round (`Shading::Phong` and `Shading::Pbr`, and a fragment program's normal).
    pub double_sided: bool,
    pub alpha: AlphaMode,
    /// Drawn in its base colour, not lit (glTF's `KHR_materials_unlit`), in the shadings that
    /// light per pixel.
    pub unlit: bool,
    /// The light it emits, linear RGB (glTF's `emissiveFactor` times
    /// `KHR_materials_emissive_strength`), added to the lit colour in the shadings that light
    /// per pixel.
    pub emissive: [f32; 3],
    /// Its textures besides the base colour's, indices into the mesh's `textures` (which they
    /// sample as they sample theirs, at the same coordinates): metallic-roughness (the factors
    /// times its blue and green), occlusion (the share of the ambient light that reaches the
    /// surface, `1 + occlusion_strength · (red − 1)`) and emission (the emission times it); read
    /// in the shadings that light per pixel.
    pub metallic_roughness_texture: Option<u32>,
    pub occlusion_texture: Option<u32>,
    pub occlusion_strength: f32,
    pub emissive_texture: Option<u32>,
}

/// What a material's alpha means (glTF's `alphaMode`).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub enum AlphaMode {
    /// Opaque: the alpha is taken as 1.
    #[default]
    Opaque,
    /// The alpha is 1 where it reaches `cutoff`, else 0; a frame that blends
    /// (`RenderParams::blend`) discards such fragments (no colour, no depth), one that does not
    /// keeps them, transparent.
    Mask { cutoff: f32 },
    /// The alpha is kept, so that a frame that blends blends the surface over what lies behind
    /// it.
    Blend,
}

impl Default for Material {
    /// glTF's default material: fully metallic and rough, single-sided, opaque and lit.
    fn default() -> Material {
        Material { metallic: 1.0, roughness: 1.0, alpha: AlphaMode::Opaque, ..Material::PLAIN }
    }
}

impl Material {
    /// The surface of a mesh without materials in a frame of default `RenderParams`: a
    /// dielectric of medium roughness, single-sided, its alpha kept.
    pub const PLAIN: Material = Material {
        metallic: 0.0,
        roughness: 0.5,
        double_sided: false,
        alpha: AlphaMode::Blend,
        unlit: false,
        emissive: [0.0; 3],
        metallic_roughness_texture: None,
        occlusion_texture: None,
        occlusion_strength: 1.0,
        emissive_texture: None,
    };

    /// The kernels' surface of a face of this material with `texture` (its material index 0).
    pub(crate) fn face_material(&self, texture: u32) -> FaceMaterial {
        let flag = |on: bool, flag: u32| if on { flag } else { 0 };
        let alpha = match self.alpha {
            AlphaMode::Opaque => SHADING_OPAQUE,
            AlphaMode::Mask { .. } => SHADING_MASK,
            AlphaMode::Blend => 0,
        };
        FaceMaterial::plain(texture, flag(self.double_sided, SHADING_DOUBLE_SIDED) | alpha | flag(self.unlit, SHADING_NOT_LIT))
    }

    /// The shade stage's record of this material, its mesh's textures from `first_texture` in
    /// the frame's.
    pub(crate) fn record(&self, first_texture: u32) -> MaterialRecord {
        let alpha_cutoff = match self.alpha {
            AlphaMode::Mask { cutoff } => cutoff,
            _ => 0.0,
        };
        let [r, g, b] = self.emissive;
        let texture = |t: Option<u32>| t.map_or(NO_TEXTURE, |t| first_texture + t);
        MaterialRecord {
            metallic: self.metallic,
            roughness: self.roughness,
            alpha_cutoff,
            occlusion_strength: self.occlusion_strength,
            emissive: [r, g, b, 0.0],
            metallic_roughness_texture: texture(self.metallic_roughness_texture),
            occlusion_texture: texture(self.occlusion_texture),
            emissive_texture: texture(self.emissive_texture),
            _pad: 0,
        }
    }

    /// Its textures besides the base colour's, with what each is.
    pub(crate) fn textures(&self) -> [(&'static str, Option<u32>); 3] {
        [("metallic-roughness", self.metallic_roughness_texture), ("occlusion", self.occlusion_texture), ("emissive", self.emissive_texture)]
    }
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
    /// Lit per pixel with glTF's metallic-roughness BRDF (Lambert + GGX) from interpolated
    /// normals, the surface's `metallic` and `roughness`.
    Pbr,
    /// Depth as grey.
    Depth,
    /// Unit normals as RGB.
    Normals,
    /// A colour per face id.
    Ids,
}

impl Shading {
    pub const ALL: [Shading; 8] =
        [Shading::Unlit, Shading::Flat, Shading::Smooth, Shading::Phong, Shading::Pbr, Shading::Depth, Shading::Normals, Shading::Ids];

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
            Shading::Pbr => "pbr",
            Shading::Depth => "depth",
            Shading::Normals => "normals",
            Shading::Ids => "ids",
        }
    }
}

/// How a lit colour, linear and unbounded, is brought into `[0, 1]` before the 8-bit frame.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum ToneMap {
    /// Channels clamped to `[0, 1]`.
    #[default]
    None,
    /// Khronos PBR Neutral: colours below 0.76 kept, brighter ones compressed towards white.
    Neutral,
    /// ACES (Hill's fit of its reference transforms, as glTF's sample viewer has it).
    Aces,
}

impl ToneMap {
    pub const ALL: [ToneMap; 3] = [ToneMap::None, ToneMap::Neutral, ToneMap::Aces];

    pub fn name(self) -> &'static str {
        match self {
            ToneMap::None => "none",
            ToneMap::Neutral => "neutral",
            ToneMap::Aces => "aces",
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
    /// Which faces are dropped by facing: those whose material is double-sided only where
    /// `double_sided` is false.
    pub cull: Cull,
    /// Whether a double-sided material's faces are kept whichever way they face (true, as glTF
    /// says), or culled as `cull` says like every other face.
    pub double_sided: bool,
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
    /// How metallic the surface is, `[0, 1]`, for `Shading::Pbr` (0 by default: a dielectric).
    pub metallic: f64,
    /// The surface's perceptual roughness, `[0, 1]`, for `Shading::Pbr` (0.5 by default).
    pub roughness: f64,
    /// The tone map of lit and coloured surfaces (lines and the data views keep their values).
    pub tone_map: ToneMap,
    /// Encode those colours with sRGB's transfer function, as image files and screens expect
    /// them; off by default: the linear values stored as they are.
    pub srgb: bool,
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
    /// A vertex shader that poses every vertex of the frame's meshes in their own coordinates
    /// before the camera sees them ([`vertex_stage!`](crate::vertex_stage)); `None`: the mesh as
    /// it is. The frame's normals are then computed from its posed faces (a mesh's own normals
    /// are the unposed surface's).
    pub vertex: Option<VertexStage>,
    /// Values the vertex shader reads (`VertexUniforms::constants`); zeros by default.
    pub vertex_constants: VertexConstants,
    /// Seconds, for the vertex shader (`VertexUniforms::time`); 0 by default.
    pub time: f32,
    /// Texels the vertex shader reads (`VertexUniforms::texture_size`); none by default.
    pub vertex_texture: Option<std::sync::Arc<VertexTexture>>,
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
            double_sided: true,
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
            metallic: 0.0,
            roughness: 0.5,
            tone_map: ToneMap::None,
            srgb: false,
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
            vertex: None,
            vertex_constants: [0.0; tileraster_kernels::abi::VERTEX_CONSTANTS],
            time: 0.0,
            vertex_texture: None,
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
    /// Bytes the geometry stages handed the backend's kernels: the vertex stage's positions
    /// and parameters.
    pub bytes_uploaded: u64,
}

impl GeometryCounts {
    /// Add another frame's counts to these (frames drawn for one picture: a panorama's faces).
    pub fn absorb(&mut self, other: &GeometryCounts) {
        self.clipped += other.clipped;
        self.culled_frustum += other.culled_frustum;
        self.culled_back += other.culled_back;
        self.culled_front += other.culled_front;
        self.culled_zero_area += other.culled_zero_area;
        self.culled_no_centre += other.culled_no_centre;
        self.rasterised += other.rasterised;
        self.instances_culled += other.instances_culled;
        self.instances_drawn += other.instances_drawn;
        self.points_drawn += other.points_drawn;
        self.points_culled += other.points_culled;
        self.lines_drawn += other.lines_drawn;
        self.lines_culled += other.lines_culled;
        self.bytes_uploaded += other.bytes_uploaded;
    }
}

impl GeometryCounts {
    pub(super) fn add(mut self, o: GeometryCounts) -> Self {
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
        self.bytes_uploaded += o.bytes_uploaded;
        self
    }
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
    pub(super) fn homogeneous(self) -> [f64; 4] {
        match self {
            Eye::Point(p) => [p[0], p[1], p[2], 1.0],
            Eye::Direction(d) => {
                let d = unit(d);
                [d[0], d[1], d[2], 0.0]
            }
        }
    }
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

/// Which pixels a line lights.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum LineRule {
    /// Direct3D's rule, which Vulkan's Bresenham lines follow: a pixel is lit where the segment
    /// passes through its diamond (`|x − cx| + |y − cy| < ½`) and leaves it, so a line ending
    /// inside a diamond does not light it and two lines joined end to end light their shared
    /// pixel once.
    #[default]
    DiamondExit,
    /// The classic algorithm: both endpoints move to their pixels' centres, and every column
    /// from the first to the last, both included, lights the pixel nearest the line between
    /// them.
    Bresenham,
    /// Vulkan's strict lines (what most Vulkan devices draw by default, lavapipe among them):
    /// the rectangle one pixel wide centred on the segment, filled as a polygon. A diagonal
    /// line is up to √2 pixels thick in its columns.
    Rectangle,
}

/// The wireframe view: every face's edges as lines.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Wireframe {
    pub rule: LineRule,
    /// The lines' linear RGBA in `[0, 1]`; `None`: their vertices' colours, interpolated along
    /// them. Lines are neither lit nor textured.
    pub colour: Option<[f32; 4]>,
}

/// Area-weighted face normals summed per vertex, in the mesh's coordinates and in face order
/// (so the same on every run), normalised: the normals of a mesh that has none.
pub fn face_normals(mesh: &Mesh) -> Vec<[f32; 3]> {
    surface_normals(&mesh.positions, &mesh.triangles)
}

/// [`face_normals`] of the faces `triangles` over `positions` (a mesh's, or as a vertex shader
/// posed them).
pub(super) fn surface_normals(positions: &[[f64; 3]], triangles: &[[u32; 3]]) -> Vec<[f32; 3]> {
    let mut sum = vec![[0.0f64; 3]; positions.len()];
    for tri in triangles {
        let p = tri.map(|v| positions[v as usize]);
        let n = cross(sub(p[1], p[0]), sub(p[2], p[0]));
        for &v in tri {
            for c in 0..3 {
                sum[v as usize][c] += n[c];
            }
        }
    }
    sum.into_iter().map(|n| unit(n).map(|c| c as f32)).collect()
}
