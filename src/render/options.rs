//! A frame as its front ends describe it (the command line's `tileraster render`, Python's
//! `tileraster.render` and `Renderer`): where the mesh comes from and the options, turned into the
//! world and the [`RenderParams`] the pipeline takes. Written once here, so that the same options
//! draw the same bits whichever front end gives them.
//!
//! ```no_run
//! use tileraster::render::{Model, ModelOptions, MeshSource, ViewOptions, render_world};
//! use tileraster::Backend;
//! let model = Model::load(MeshSource::File("terrain.tif".into()), &ModelOptions::default())?;
//! let params = model.params(&ViewOptions { size: Some([800, 600]), ..Default::default() })?;
//! let frame = render_world(model.world(), &params, Backend::Cpu)?;
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

use super::{
    Address, AlphaMode, Camera, Cull, Filter, Frame, IDENTITY, Interpolation, LineRule, MAX_RENDER_DIM, Mesh, Panorama, PreparedMesh, Projection, RenderParams,
    Shading, ToneMap, Up, VertexStage, Wireframe, World, accumulate, format_up, is_geotiff, panorama_frame, posed_positions, read_dem_grid, read_mesh_at,
    read_posable_at, read_world_at,
};
use crate::dem::{DemError, InputKind};
use crate::{Backend, Error, Skip};
use std::path::{Path, PathBuf};
use std::sync::Arc;

/// Where a frame's mesh comes from.
#[derive(Debug, Clone)]
pub enum MeshSource {
    /// A file [`read_world_at`] reads (glTF, OBJ, PLY, STL, points, a GeoTIFF DEM).
    File(PathBuf),
    /// A mesh in memory (+Y up for the default camera, as OBJ, PLY and STL files are).
    Mesh(Mesh),
}

/// What is decided once a mesh: its pose and placements.
#[derive(Debug, Clone, PartialEq)]
pub struct ModelOptions {
    /// Seconds into a glTF file's first animation; `None`: its rest pose.
    pub time: Option<f64>,
    /// Heights (z) multiplied about the lowest point (of the box holding every placement).
    pub z_scale: f64,
    /// Placements of the mesh, each a 4×4 affine matrix row-major; `None`: the file's own.
    pub instances: Option<Vec<[[f64; 4]; 4]>>,
    /// Whether frames may draw the vertices as points. A DEM is then meshed on the host: the
    /// kernels' heightfield program would draw the cells without a height as vertices too.
    pub points: bool,
}

impl Default for ModelOptions {
    fn default() -> Self {
        ModelOptions { time: None, z_scale: 1.0, instances: None, points: false }
    }
}

/// The camera of a frame.
#[derive(Debug, Clone, Default, PartialEq)]
pub enum CameraChoice {
    /// Frames the whole mesh from its front (from +Z with +Y up, from −Y with +Z up), a little
    /// from the right and above.
    #[default]
    Framing,
    /// A look-at camera in the mesh's coordinates.
    LookAt { eye: [f64; 3], target: [f64; 3], up: [f64; 3] },
    /// A glTF file's camera: a node's index, or its name, or its camera's name.
    Node(String),
    /// A 4×4 matrix, row-major, from the mesh's coordinates to clip space (Vulkan's: depth 0..1,
    /// NDC y down the image), perspective or orthographic.
    Matrix([[f64; 4]; 4]),
}

/// How [`CameraChoice::Framing`] and [`CameraChoice::LookAt`] project.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Lens {
    /// A vertical field of view in degrees.
    Perspective { fov_deg: f64 },
    /// Parallel projection seeing `width` in the mesh's units across the frame; `None`: as
    /// wide as frames the whole mesh.
    Orthographic { width: Option<f64> },
    /// Around the camera's eye, resampled from the faces of a cube map ([`Panorama`]).
    Panorama(Panorama),
}

impl Lens {
    /// The projections' names, as the front ends take them.
    pub const PROJECTIONS: [&str; 5] = ["perspective", "orthographic", "cylindrical", "equirectangular", "fisheye"];

    /// The lens a projection's name, a field of view and an orthographic width (`Some(None)`:
    /// as wide as frames the mesh) give: perspective (45° unless told) unless the width or
    /// another name is given; a cylinder 90° high and a fisheye 180° wide unless told.
    pub fn of(projection: Option<&str>, fov_deg: Option<f64>, ortho: Option<Option<f64>>) -> Result<Lens, FrameError> {
        let fov = |default: f64| fov_deg.unwrap_or(default);
        Ok(match (projection, ortho) {
            (Some(p), Some(_)) if p != "orthographic" => return Err(option_error("projection", format!("{p}, and an orthographic width: give one of them"))),
            (_, Some(width)) => Lens::Orthographic { width },
            (None | Some("perspective"), None) => Lens::Perspective { fov_deg: fov(45.0) },
            (Some("orthographic"), None) => Lens::Orthographic { width: None },
            (Some("cylindrical"), None) => Lens::Panorama(Panorama::Cylindrical { fov_deg: fov(90.0) }),
            (Some("equirectangular"), None) if fov_deg.is_some() => {
                return Err(option_error("fov", "an equirectangular frame sees every direction; leave the field of view out"));
            }
            (Some("equirectangular"), None) => Lens::Panorama(Panorama::Equirectangular),
            (Some("fisheye"), None) => Lens::Panorama(Panorama::Fisheye { fov_deg: fov(180.0) }),
            (Some(other), None) => return Err(option_error("projection", format!("{other:?}: give one of {}", Lens::PROJECTIONS.join(", ")))),
        })
    }

    /// The lens's projection's name, and its field of view with the one [`Lens::of`] takes
    /// where none is given (`None` for a lens without one).
    pub fn projection(self) -> (&'static str, Option<(f64, f64)>) {
        match self {
            Lens::Perspective { fov_deg } => ("perspective", Some((fov_deg, 45.0))),
            Lens::Orthographic { .. } => ("orthographic", None),
            Lens::Panorama(Panorama::Cylindrical { fov_deg }) => ("cylindrical", Some((fov_deg, 90.0))),
            Lens::Panorama(Panorama::Equirectangular) => ("equirectangular", None),
            Lens::Panorama(Panorama::Fisheye { fov_deg }) => ("fisheye", Some((fov_deg, 180.0))),
        }
    }
}

/// What each frame of a model may choose. The defaults are `tileraster render`'s.
#[derive(Debug, Clone, PartialEq)]
pub struct ViewOptions {
    /// Width and height in pixels; `None`: 1280 × 720, or with a glTF camera 1280 wide and as
    /// high as its aspect ratio makes it.
    pub size: Option<[u32; 2]>,
    pub camera: CameraChoice,
    pub lens: Lens,
    /// The up axis of [`CameraChoice::Framing`]; `None`: the format's convention ([`format_up`]).
    pub up: Option<Up>,
    /// RGBA of pixels no triangle covers, whole numbers 0..=255.
    pub background: [f64; 4],
    /// Which faces are dropped by facing; `None`: back faces, but not those of a double-sided
    /// material (glTF's `doubleSided`). Given, every face is culled as it says.
    pub cull: Option<Cull>,
    /// `None`: `Shading::Pbr` where the meshes have materials (a glTF file, an OBJ with an MTL
    /// file), else `Shading::Smooth` ([`Model::shading`]).
    pub shading: Option<Shading>,
    /// The surface of `Shading::Pbr` where the meshes have no materials: how metallic (`None`:
    /// 0), and its perceptual roughness (`None`: 0.5), each 0..=1. Refused for meshes with
    /// materials, which give their own.
    pub metallic: Option<f64>,
    pub roughness: Option<f64>,
    /// The tone map of lit colours, and whether they are stored sRGB-encoded.
    pub tone_map: ToneMap,
    pub srgb: bool,
    pub interpolation: Interpolation,
    /// Each vertex also drawn as a square this many pixels wide.
    pub points: Option<f32>,
    pub faces: bool,
    /// Each edge also drawn as a line by this rule.
    pub wireframe: Option<LineRule>,
    /// The wireframe's RGBA, whole numbers 0..=255; `None`: black over faces, the vertices'
    /// colours without faces.
    pub wire_colour: Option<[f64; 4]>,
    pub msaa: u32,
    pub filter: Option<Filter>,
    pub address: Option<Address>,
    pub blend: bool,
    /// The pipeline's skips turned off (the frame does not change).
    pub no_skip: Vec<Skip>,
    /// Samples at sub-pixel offsets averaged into the frame ([`accumulate`]); 1: one frame.
    pub jitter: u32,
    pub return_depth: bool,
    pub count_fragments: bool,
    pub count_tiles: bool,
}

impl Default for ViewOptions {
    fn default() -> Self {
        ViewOptions {
            size: None,
            camera: CameraChoice::Framing,
            lens: Lens::Perspective { fov_deg: 45.0 },
            up: None,
            background: [0.0; 4],
            cull: None,
            shading: None,
            metallic: None,
            roughness: None,
            tone_map: ToneMap::None,
            srgb: false,
            interpolation: Interpolation::Perspective,
            points: None,
            faces: true,
            wireframe: None,
            wire_colour: None,
            msaa: 1,
            filter: None,
            address: None,
            blend: false,
            no_skip: Vec::new(),
            jitter: 1,
            return_depth: true,
            count_fragments: false,
            count_tiles: false,
        }
    }
}

/// Why a frame could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum FrameError {
    /// An option's value: `option` is its command-line name without dashes (`camera-node`).
    #[error("--{option}: {message}")]
    Option { option: &'static str, message: String },
    /// The mesh could not be read.
    #[error(transparent)]
    Read(#[from] DemError),
    /// The pipeline refused the mesh or the frame.
    #[error(transparent)]
    Render(#[from] Error),
}

fn option_error(option: &'static str, message: impl Into<String>) -> FrameError {
    FrameError::Option { option, message: message.into() }
}

/// A mesh as its frames draw it: read (and posed) once, then any number of frames set up by
/// [`Model::params`].
pub struct Model {
    world: World,
    /// The file's path, for its cameras.
    path: Option<PathBuf>,
    time: Option<f64>,
    /// The vertices the default camera frames where they are not the world's one mesh: the
    /// posed vertices a vertex program moves, or the corners of the box holding the instances.
    framing: Option<Mesh>,
    /// The model matrix: heights scaled about the lowest corner of the instances' box.
    model: [[f64; 4]; 4],
    /// The kernels' built-in vertex program that poses the mesh, its texture and constants.
    pose: Option<(VertexStage, Arc<super::VertexTexture>, [f32; 8])>,
    /// The format's up axis.
    up: Up,
    /// Whether the frames may draw points (see [`ModelOptions::points`]).
    points: bool,
    /// Whether the meshes have materials, and whether one of them is blended or masked (glTF's
    /// `BLEND`, `MASK`: a frame of one sample per pixel blends, and so discards masked
    /// fragments).
    materials: bool,
    blended: bool,
}

impl Model {
    /// Read `source` as `options` say: a GeoTIFF DEM lifted by the kernels' heightfield program
    /// and a glTF file's skins and morph targets posed by their deform program where nothing
    /// (instances, a height scale, points) needs the mesh on the host.
    pub fn load(source: MeshSource, options: &ModelOptions) -> Result<Model, FrameError> {
        let ModelOptions { time, z_scale, ref instances, points } = *options;
        if !(z_scale.is_finite() && z_scale != 0.0) {
            return Err(option_error("z-scale", format!("{z_scale}: give a finite, non-zero factor")));
        }
        let (world, pose, path, up) = match source {
            MeshSource::File(path) => {
                let (world, pose) = read_posed(&path, time, z_scale, instances.as_deref(), points)?;
                let up = format_up(&path)?;
                (world, pose, Some(path), up)
            }
            MeshSource::Mesh(mesh) => {
                if let Some(time) = time {
                    return Err(option_error("time", format!("{time} s: a time poses a glTF file's animation, and a mesh in memory holds none")));
                }
                let world = match instances {
                    Some(transforms) => World::instanced(mesh, transforms),
                    None => World::single(mesh),
                };
                (world, None, None, Up::Y)
            }
        };
        let materials = world.meshes.iter().any(|m| !m.materials.is_empty());
        let blended = world.meshes.iter().flat_map(|m| &m.materials).any(|m| matches!(m.alpha, AlphaMode::Blend | AlphaMode::Mask { .. }));
        let mut model = Model { world, path, time, framing: None, model: IDENTITY, pose, up, points, materials, blended };
        model.place(z_scale)?;
        Ok(model)
    }

    /// Scale the heights (a single mesh's vertices; instances by the model matrix) and find
    /// what the default camera frames.
    fn place(&mut self, z_scale: f64) -> Result<(), FrameError> {
        if self.is_single() {
            let world = &mut self.world;
            let mesh = &mut world.meshes[0];
            if z_scale != 1.0 {
                let lowest = mesh.positions.iter().map(|p| p[2]).fold(f64::INFINITY, f64::min);
                for p in &mut mesh.positions {
                    p[2] = lowest + z_scale * (p[2] - lowest);
                }
            }
            // Framed as posed, by the vertices its faces use (not a DEM's cells without a height).
            if let Some((stage, texture, constants)) = &self.pose {
                let mut posing = RenderParams::new(1, 1, IDENTITY);
                (posing.vertex, posing.vertex_texture, posing.vertex_constants) = (Some(*stage), Some(texture.clone()), *constants);
                let mut used = vec![false; mesh.positions.len()];
                mesh.triangles.iter().flatten().for_each(|&v| used[v as usize] = true);
                let posed = posed_positions(mesh, &posing)?;
                let positions = posed.into_iter().zip(used).filter_map(|(p, used)| used.then_some(p)).collect();
                self.framing = Some(Mesh { positions, ..Default::default() });
            }
            return Ok(());
        }
        let [lo, hi] = self.world.bounds()?;
        self.model[2] = [0.0, 0.0, z_scale, lo[2] * (1.0 - z_scale)];
        let scaled = |z: f64| lo[2] + z_scale * (z - lo[2]);
        let corners =
            (0..8).map(|k| [if k & 1 == 0 { lo[0] } else { hi[0] }, if k & 2 == 0 { lo[1] } else { hi[1] }, scaled(if k & 4 == 0 { lo[2] } else { hi[2] })]);
        self.framing = Some(Mesh { positions: corners.collect(), triangles: vec![[0, 1, 2]], ..Default::default() });
        Ok(())
    }

    /// The meshes and their placements.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// Whether the world is one mesh where it is (no instances).
    pub fn is_single(&self) -> bool {
        self.world.instances.len() == 1 && self.world.instances[0].transform == IDENTITY
    }

    /// The kernels' built-in vertex program that poses the mesh, if one does.
    pub fn vertex_stage(&self) -> Option<VertexStage> {
        self.pose.as_ref().map(|(stage, ..)| *stage)
    }

    /// The model ready for many frames: its world as one [`PreparedMesh`] (a single mesh as it
    /// is, instances as [`World::flattened`] places them: the same pixels, though the frames'
    /// statistics count one instance).
    pub fn prepare(mut self) -> Result<PreparedModel, FrameError> {
        let mesh = match self.is_single() {
            true => {
                let mesh = std::mem::take(&mut self.world.meshes[0]);
                self.framing.get_or_insert_with(|| Mesh { positions: mesh.positions.clone(), ..Default::default() });
                mesh
            }
            false => self.world.flattened()?,
        };
        // The prepared mesh holds the faces now; the default camera frames `framing`.
        self.world = World::default();
        Ok(PreparedModel { prepared: PreparedMesh::new(mesh)?, model: self })
    }

    /// The mesh the default camera frames.
    fn framed(&self) -> &Mesh {
        self.framing.as_ref().unwrap_or_else(|| &self.world.meshes[0])
    }

    /// The shading of a frame of `view`: its own, or `Shading::Pbr` for meshes with materials
    /// and `Shading::Smooth` for the rest.
    pub fn shading(&self, view: &ViewOptions) -> Shading {
        view.shading.unwrap_or(if self.materials { Shading::Pbr } else { Shading::Smooth })
    }

    /// One frame's parameters: its size, camera, shading and outputs.
    pub fn params(&self, view: &ViewOptions) -> Result<RenderParams, FrameError> {
        if view.points.is_some() && !self.points && self.vertex_stage() == Some(VertexStage::HEIGHTS) {
            return Err(option_error("points", "the DEM was read to be lifted by the kernels, without its vertices: read it with points allowed"));
        }
        let node_camera = match &view.camera {
            CameraChoice::Node(wanted) => Some(self.gltf_camera(wanted)?),
            _ => None,
        };
        let [width, height] = match (view.size, &node_camera) {
            (Some(size), _) => size,
            (None, Some(c)) => {
                let aspect = match c.projection {
                    tileraster_io::GltfProjection::Perspective { aspect_ratio, .. } => aspect_ratio.unwrap_or(16.0 / 9.0),
                    tileraster_io::GltfProjection::Orthographic { xmag, ymag, .. } => (xmag / ymag).abs(),
                };
                match aspect.is_finite() && aspect > 0.0 {
                    true => [1280, ((1280.0 / aspect).round() as u32).clamp(1, MAX_RENDER_DIM)],
                    false => [1280, 720],
                }
            }
            (None, None) => [1280, 720],
        };
        if width == 0 || height == 0 {
            return Err(option_error("size", format!("{width} × {height} is empty: give a width and a height of at least 1 pixel")));
        }
        if width.max(height) > MAX_RENDER_DIM {
            return Err(option_error("size", format!("{width} × {height}: a frame is at most {MAX_RENDER_DIM} pixels a side")));
        }
        if !(1..=super::MAX_JITTER).contains(&view.jitter) {
            return Err(option_error("jitter", format!("{}: give from 1 to {} samples", view.jitter, super::MAX_JITTER)));
        }
        if let Lens::Panorama(panorama) = view.lens {
            panorama.check().map_err(|e| option_error("fov", e))?;
            if view.jitter > 1 {
                return Err(option_error("jitter", "a panorama is resampled from its cube's faces: jitter perspective and orthographic frames"));
            }
            if !matches!(view.camera, CameraChoice::Framing | CameraChoice::LookAt { .. }) {
                return Err(option_error("projection", "a panorama is seen from a look-at camera's eye: give --camera, or no camera"));
            }
        }
        let (view_projection, viewer) = self.camera(view, node_camera.as_ref(), width, height)?;
        for (option, colour) in [("background", Some(view.background)), ("wire-colour", view.wire_colour)] {
            if let Some(c) = colour.iter().flatten().find(|c| !(0.0..=255.0).contains(*c) || c.fract() != 0.0) {
                return Err(option_error(option, format!("{c} is not a whole number from 0 to 255")));
            }
        }
        for (option, value) in [("metallic", view.metallic), ("roughness", view.roughness)] {
            match value {
                Some(value) if !(0.0..=1.0).contains(&value) => return Err(option_error(option, format!("{value} is not a number from 0 to 1"))),
                Some(_) if self.materials => {
                    return Err(option_error(
                        option,
                        "the file's materials give each surface its own factors; this sets the surface of a mesh without materials",
                    ));
                }
                _ => {}
            }
        }
        let mut params = RenderParams::new(width, height, view_projection);
        params.model = self.model;
        (params.metallic, params.roughness) = (view.metallic.unwrap_or(params.metallic), view.roughness.unwrap_or(params.roughness));
        (params.tone_map, params.srgb) = (view.tone_map, view.srgb);
        params.eye = viewer;
        params.background = view.background.map(|c| c as u8);
        (params.cull, params.double_sided) = (view.cull.unwrap_or(Cull::Back), view.cull.is_none());
        (params.shading, params.interpolation) = (self.shading(view), view.interpolation);
        // Blended materials blend where a frame can (one sample per pixel).
        params.blend = view.blend || (view.msaa <= 1 && self.blended);
        (params.count_fragments, params.count_tiles, params.return_depth) = (view.count_fragments, view.count_tiles, view.return_depth);
        (params.points, params.faces, params.samples) = (view.points, view.faces, view.msaa);
        params.wireframe = view.wireframe.map(|rule| Wireframe {
            rule,
            colour: match (view.wire_colour, view.faces) {
                (Some(c), _) => Some(c.map(|c| (c / 255.0) as f32)),
                (None, true) => Some([0.0, 0.0, 0.0, 1.0]),
                (None, false) => None,
            },
        });
        (params.texture_filter, params.texture_address) = (view.filter, view.address);
        for &skip in &view.no_skip {
            params.skips = params.skips.without(skip);
        }
        if let Some((stage, texture, constants)) = &self.pose {
            (params.vertex, params.vertex_texture, params.vertex_constants) = (Some(*stage), Some(texture.clone()), *constants);
        }
        Ok(params)
    }

    /// The frame `view` describes, each of its exact frames drawn by `draw`: one frame, the
    /// average of [`ViewOptions::jitter`] frames at sub-pixel offsets, or a panorama resampled
    /// from the cube faces it needs.
    pub fn draw(&self, view: &ViewOptions, draw: &mut dyn FnMut(&RenderParams) -> Result<Frame, Error>) -> Result<Frame, FrameError> {
        self.draw_with(&self.params(view)?, view, draw)
    }

    /// [`Model::draw`] with `params`, which [`Model::params`] gave for `view`.
    fn draw_with(&self, params: &RenderParams, view: &ViewOptions, draw: &mut dyn FnMut(&RenderParams) -> Result<Frame, Error>) -> Result<Frame, FrameError> {
        match view.lens {
            Lens::Panorama(panorama) => {
                let camera = self.look_at(view, params.width, params.height).ok_or_else(|| option_error("projection", "a panorama needs a look-at camera"))?;
                Ok(panorama_frame(panorama, &camera, self.framed(), params, draw)?)
            }
            _ => Ok(accumulate(params, view.jitter, draw)?),
        }
    }

    /// Whether a frame of `view` is one frame of the pipeline (no jitter, no panorama).
    pub fn is_plain(view: &ViewOptions) -> bool {
        view.jitter <= 1 && !matches!(view.lens, Lens::Panorama(_))
    }

    /// The look-at camera `view` draws with: its framing or its look-at, as wide as frames the
    /// mesh where the orthographic width is not given; `None` for a matrix or a glTF camera.
    pub fn look_at(&self, view: &ViewOptions, width: u32, height: u32) -> Option<Camera> {
        let mesh = self.framed();
        let aspect = width as f64 / height.max(1) as f64;
        let projection = match view.lens {
            Lens::Orthographic { width } => Projection::Orthographic { width: width.unwrap_or(1.0) },
            Lens::Perspective { fov_deg } => Projection::Perspective { fov_deg },
            // A panorama's eye and axes; its faces are 90° perspective frames.
            Lens::Panorama(_) => Projection::Perspective { fov_deg: 90.0 },
        };
        match view.camera {
            CameraChoice::LookAt { eye, target, up } => {
                let look = Camera::look_at(eye, target, up, projection, mesh);
                Some(if view.lens == (Lens::Orthographic { width: None }) { look.fit_orthographic(mesh, aspect) } else { look })
            }
            CameraChoice::Framing => {
                let mut framed = Camera::framing(mesh, aspect, projection, view.up.unwrap_or(self.up));
                if let Lens::Orthographic { width: Some(seen) } = view.lens {
                    framed.projection = Projection::Orthographic { width: seen };
                }
                Some(framed)
            }
            CameraChoice::Node(_) | CameraChoice::Matrix(_) => None,
        }
    }

    /// The view-projection matrix, and the viewer the lighting takes where a camera names it
    /// (the default perspective camera's is its matrix's centre of projection, and a matrix's
    /// too).
    fn camera(
        &self,
        view: &ViewOptions,
        node: Option<&tileraster_io::GltfCamera>,
        width: u32,
        height: u32,
    ) -> Result<([[f64; 4]; 4], Option<super::Eye>), FrameError> {
        let orthographic = matches!(view.lens, Lens::Orthographic { .. });
        let (camera, option) = match (&view.camera, node) {
            (CameraChoice::Matrix(m), _) => return Ok((*m, None)),
            (_, Some(c)) => (Camera::of_gltf(c, self.framed(), width as f64 / height.max(1) as f64), "camera-node"),
            (CameraChoice::LookAt { .. }, None) => (self.look_at(view, width, height).ok_or_else(|| option_error("camera", "no camera"))?, "camera"),
            _ => (self.look_at(view, width, height).ok_or_else(|| option_error("camera-node", "no such camera"))?, if orthographic { "ortho" } else { "fov" }),
        };
        let matrix = camera.view_projection(width, height).map_err(|e| option_error(option, e.to_string()))?;
        let framing = view.camera == CameraChoice::Framing;
        Ok((matrix, (!framing || orthographic).then(|| camera.viewer())))
    }

    /// The camera of the glTF file that `wanted` names (posed at the model's time): a node
    /// index, a node's name or a camera's name.
    fn gltf_camera(&self, wanted: &str) -> Result<tileraster_io::GltfCamera, FrameError> {
        let fail = |message: String| option_error("camera-node", message);
        let path = match &self.path {
            Some(path) if matches!(InputKind::of(path), Ok(InputKind::Gltf)) => path,
            Some(path) => return Err(fail(format!("{} is not a glTF file (.gltf, .glb); only glTF files hold cameras", path.display()))),
            None => return Err(fail("a mesh in memory holds no cameras; only glTF files do".into())),
        };
        let cameras = tileraster_io::read_gltf_cameras(path, self.time).map_err(|e| fail(e.to_string()))?;
        // A node's index first, then a node's name, then a camera's (so a node named "2" is found).
        let found = wanted
            .parse::<usize>()
            .ok()
            .and_then(|node| cameras.iter().find(|c| c.node == node))
            .or_else(|| cameras.iter().find(|c| c.node_name.as_deref() == Some(wanted)))
            .or_else(|| cameras.iter().find(|c| c.name.as_deref() == Some(wanted)));
        found.cloned().ok_or_else(|| {
            let listed: Vec<String> = cameras
                .iter()
                .map(|c| {
                    let named = |what: &str, name: &Option<String>| name.as_ref().map(|n| format!(" {what}{n:?}")).unwrap_or_default();
                    format!("node {}{}{}", c.node, named("", &c.node_name), named("camera ", &c.name))
                })
                .collect();
            match listed.is_empty() {
                true => fail(format!("{wanted}: {} places no camera in its scene", path.display())),
                false => fail(format!("{wanted}: no such camera node; the scene's cameras: {}", listed.join(", "))),
            }
        })
    }
}

/// A [`Model`] kept for many frames ([`Model::prepare`]): each frame costs only the per-frame
/// stages, in the last frame's memory.
pub struct PreparedModel {
    model: Model,
    prepared: PreparedMesh,
}

impl PreparedModel {
    /// One frame's parameters ([`Model::params`]).
    pub fn params(&self, view: &ViewOptions) -> Result<RenderParams, FrameError> {
        self.model.params(view)
    }

    /// The frame `params` describe, on `backend`.
    pub fn render(&mut self, params: &RenderParams, backend: Backend) -> Result<Frame, Error> {
        self.prepared.render(params, backend)
    }

    /// [`PreparedModel::render`] into `frame`, whose layers (of any earlier frame) are reused.
    pub fn render_into(&mut self, params: &RenderParams, backend: Backend, frame: &mut Frame) -> Result<(), Error> {
        self.prepared.render_into(params, backend, frame)
    }

    /// The frame `view` describes ([`Model::draw`]) on `backend`, into `frame` (a plain frame
    /// reuses its layers); the parameters it was drawn with.
    pub fn render_view(&mut self, view: &ViewOptions, backend: Backend, frame: &mut Frame) -> Result<RenderParams, FrameError> {
        let params = self.model.params(view)?;
        if Model::is_plain(view) {
            self.prepared.render_into(&params, backend, frame)?;
        } else {
            let prepared = &mut self.prepared;
            *frame = self.model.draw_with(&params, view, &mut |params| prepared.render(params, backend))?;
        }
        Ok(params)
    }

    /// The look-at camera a `width` × `height` frame of `view` draws with ([`Model::look_at`]).
    pub fn look_at(&self, view: &ViewOptions, width: u32, height: u32) -> Option<Camera> {
        self.model.look_at(view, width, height)
    }

    /// The kernels' built-in vertex program that poses the mesh, if one does.
    pub fn vertex_stage(&self) -> Option<VertexStage> {
        self.model.vertex_stage()
    }

    /// The lowest and highest corners of the box holding what the frames draw (posed, scaled
    /// and placed), to aim cameras at.
    pub fn bounds(&self) -> [[f64; 3]; 2] {
        self.model.framed().positions.iter().fold([[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]], |[lo, hi], p| {
            [std::array::from_fn(|k| lo[k].min(p[k])), std::array::from_fn(|k| hi[k].max(p[k]))]
        })
    }
}

/// The world in `path` and the kernels' program that poses it. A DEM is drawn by the kernels'
/// built-in heightfield program: its flat grid, lifted in the vertex stage by its heights as a
/// vertex texture (the same frame as its mesh's); its points would include the cells without a
/// height, and a height scale scales about the lowest height: both take the mesh. A glTF file's
/// skins and morph targets are posed by the kernels' built-in deform program, the file at rest
/// and its pose at `time` a vertex texture, unless the mesh is placed or scaled on the host.
#[allow(clippy::type_complexity)]
fn read_posed(
    path: &Path,
    time: Option<f64>,
    z_scale: f64,
    instances: Option<&[[[f64; 4]; 4]]>,
    points: bool,
) -> Result<(World, Option<(VertexStage, Arc<super::VertexTexture>, [f32; 8])>), FrameError> {
    let host = instances.is_some() || z_scale != 1.0;
    if is_geotiff(path)
        && !host
        && !points
        && let Some((grid, texture)) = read_dem_grid(path)?
    {
        return Ok((World::single(grid), Some((VertexStage::HEIGHTS, Arc::new(texture), [1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0]))));
    }
    if !host && let Some(posable) = read_posable_at(path, time)? {
        return Ok((World::single(posable.mesh), Some((VertexStage::DEFORM, Arc::new(posable.texture), posable.constants))));
    }
    Ok(match instances {
        Some(transforms) => (World::instanced(read_mesh_at(path, time)?, transforms), None),
        None => (read_world_at(path, time)?, None),
    })
}
