//! glTF 2.0 (`.gltf` with its buffers, or `.glb`) through the `gltf` crate: the default scene's
//! nodes (or, without scenes, every root node), each node's mesh placed by its world transform
//! (the product of its ancestors' matrices), every triangle primitive's positions, normals
//! (transformed by the inverse transpose and normalised), `COLOR_0` times the material's base
//! colour factor, and `TEXCOORD_0` (moved by the textures' `KHR_texture_transform`), with each
//! primitive's material (its factors and textures, `doubleSided`, `alphaMode`,
//! `KHR_materials_unlit`, `KHR_materials_emissive_strength`). Faces count the triangles in that
//! order: nodes depth first in document order, primitives in order, triangles in index order
//! (strips and fans unrolled), then those of blended materials move after the rest.
//!
//! The nodes stand in a pose (`gltf_pose`): at rest, or at a time of the file's first
//! animation. Morph targets add their weighted offsets to positions and normals; a skinned
//! node's vertices go to world coordinates by the weighted sum of up to four joint matrices
//! (`JOINTS_0`, `WEIGHTS_0`). Points, lines, more joints per vertex and required extensions
//! this reader does not implement are refused with an error that names them.

use crate::IoError;
use crate::gltf_pose::{IDENTITY, Matrix, Pose};
use crate::gltf_rig::{Binding, Offsets, PosableGltf, Rig, SkinWeights};
use gltf::accessor::{DataType, Dimensions};
use std::path::Path;
use tileraster_core::render::{Address, AlphaMode, Filter, Instance, Material, Mesh, NO_TEXTURE, Texture, World, normal_matrix, transform_normal};

/// Read a glTF 2.0 file (`.gltf` or `.glb`) as one mesh in world coordinates, posed `time`
/// seconds into its first animation (at rest without a time).
pub fn read_gltf(path: &Path, time: Option<f64>) -> Result<Mesh, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let (gltf, buffers) = open(path)?;
    let pose = posed(&gltf.document, &buffers, time).map_err(format)?;
    let sources = Sources { base: path.parent(), buffers: &buffers };
    let mut out = Parts::default();
    pose.walk(&gltf.document, &mut |node, world| match node.mesh() {
        Some(mesh) => {
            let deform = Deform::of(&pose, node, &mesh, &buffers)?;
            // A skinned mesh's joints take it to world coordinates.
            let world = if deform.joints.is_some() { &IDENTITY } else { world };
            mesh.primitives().try_for_each(|primitive| add_primitive(&mesh, &primitive, world, &deform, &sources, &mut out, None))
        }
        None => Ok(()),
    })
    .map_err(format)?;
    out.into_mesh().ok_or_else(|| format("the file has no triangles in its scene".into()))
}

/// Read a glTF 2.0 file whose meshes have skins or morph targets as one mesh at rest, with the
/// vertex texture and constants that pose it in the kernels' vertex stage
/// (`VertexStage::DEFORM`) as [`read_gltf`] poses it on the host at `time` (at rest without a
/// time): the same vertices and faces in the same order. `None` for a file without skins or
/// morph targets, which [`read_gltf_world`] reads.
pub fn read_gltf_posable(path: &Path, time: Option<f64>) -> Result<Option<PosableGltf>, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let (gltf, buffers) = open(path)?;
    let morphs = |m: gltf::Mesh| m.primitives().any(|p| p.morph_targets().next().is_some());
    if !gltf.document.nodes().any(|n| n.mesh().is_some_and(|m| n.skin().is_some() || morphs(m))) {
        return Ok(None);
    }
    let pose = posed(&gltf.document, &buffers, time).map_err(format)?;
    let sources = Sources { base: path.parent(), buffers: &buffers };
    let (mut out, mut rig) = (Parts::default(), Rig::default());
    pose.walk(&gltf.document, &mut |node, world| match node.mesh() {
        Some(mesh) => {
            let deform = Deform::of(&pose, node, &mesh, &buffers)?;
            let binding = rig.bind(world, deform.joints.as_deref(), &deform.weights);
            let world = if deform.joints.is_some() { &IDENTITY } else { world };
            mesh.primitives().try_for_each(|primitive| add_primitive(&mesh, &primitive, world, &deform, &sources, &mut out, Some((&mut rig, binding))))
        }
        None => Ok(()),
    })
    .map_err(format)?;
    let mesh = out.into_mesh().ok_or_else(|| format("the file has no triangles in its scene".into()))?;
    let (texture, constants) = rig.texture(&mesh).map_err(format)?;
    Ok(Some(PosableGltf { mesh, texture, constants }))
}

/// Read a glTF 2.0 file as a [`World`], posed as [`read_gltf`] poses it: each mesh once, in its
/// own coordinates, and one instance per node that places a mesh, with the node's world
/// transform. Nodes that share a mesh share it here too (instances), where the pose deforms it
/// alike (no skin, the same morph weights); a skinned node's mesh is in world coordinates.
/// Rendered, it gives the faces in [`read_gltf`]'s order.
pub fn read_gltf_world(path: &Path, time: Option<f64>) -> Result<World, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let (gltf, buffers) = open(path)?;
    let pose = posed(&gltf.document, &buffers, time).map_err(format)?;
    let sources = Sources { base: path.parent(), buffers: &buffers };
    let mut world = World::default();
    // (glTF mesh, skinned node, morph weights' bits) → the world's mesh index (a mesh without
    // triangles is left out).
    let mut built: std::collections::HashMap<(usize, Option<usize>, Vec<u64>), Option<u32>> = std::collections::HashMap::new();
    pose.walk(&gltf.document, &mut |node, transform| {
        let Some(mesh) = node.mesh() else { return Ok(()) };
        let deform = Deform::of(&pose, node, &mesh, &buffers)?;
        let skinned = deform.joints.is_some().then_some(node.index());
        let weights = match deform.weights.iter().all(|&w| w == 0.0) {
            true => Vec::new(),
            false => deform.weights.iter().map(|w| w.to_bits()).collect(),
        };
        let key = (mesh.index(), skinned, weights);
        let index = match built.get(&key) {
            Some(&index) => index,
            None => {
                let mut parts = Parts::default();
                mesh.primitives().try_for_each(|primitive| add_primitive(&mesh, &primitive, &IDENTITY, &deform, &sources, &mut parts, None))?;
                let index = parts.into_mesh().map(|m| {
                    world.meshes.push(m);
                    world.meshes.len() as u32 - 1
                });
                built.insert(key, index);
                index
            }
        };
        if let Some(mesh) = index {
            let transform = if skinned.is_some() { IDENTITY } else { *transform };
            world.instances.push(Instance { mesh, transform });
        }
        Ok(())
    })
    .map_err(format)?;
    if world.instances.is_empty() {
        return Err(format("the file has no triangles in its scene".into()));
    }
    Ok(blended_last(world))
}

/// `world` with every blended face drawn after every other one, as `read_gltf` orders them: a
/// mesh with both is cut in two (its blended faces, which `Parts::into_mesh` put last, a mesh
/// of their own), and the instances of blended meshes follow the rest, each in file order.
fn blended_last(world: World) -> World {
    let mut out = World::default();
    // Each mesh's opaque and blended parts in `out`.
    let mut parts: Vec<[Option<u32>; 2]> = Vec::with_capacity(world.meshes.len());
    let push = |mesh: Mesh, out: &mut World| {
        out.meshes.push(mesh);
        Some(out.meshes.len() as u32 - 1)
    };
    for mut mesh in world.meshes {
        let blended = |f: usize| mesh.materials.get(mesh.face_materials.as_ref().map_or(0, |m| m[f] as usize)).is_some_and(|m| m.alpha == AlphaMode::Blend);
        let first = (0..mesh.triangles.len()).find(|&f| blended(f)).unwrap_or(mesh.triangles.len());
        parts.push(match first {
            0 => [None, push(mesh, &mut out)],
            k if k == mesh.triangles.len() => [push(mesh, &mut out), None],
            k => {
                let tail = |v: &Option<Vec<u32>>| v.as_ref().map(|v| v[k..].to_vec());
                let glass = Mesh {
                    triangles: mesh.triangles[k..].to_vec(),
                    face_textures: tail(&mesh.face_textures),
                    face_materials: tail(&mesh.face_materials),
                    ..mesh.clone()
                };
                mesh.triangles.truncate(k);
                mesh.face_textures.iter_mut().for_each(|v| v.truncate(k));
                mesh.face_materials.iter_mut().for_each(|v| v.truncate(k));
                [push(mesh, &mut out), push(glass, &mut out)]
            }
        });
    }
    let parts = &parts;
    let placed = |part: usize| world.instances.iter().filter_map(move |i| parts[i.mesh as usize][part].map(|mesh| Instance { mesh, transform: i.transform }));
    out.instances = placed(0).chain(placed(1)).collect();
    out
}

/// The file's pose at `time`, or at rest.
fn posed(document: &gltf::Document, buffers: &[gltf::buffer::Data], time: Option<f64>) -> Result<Pose, String> {
    match time {
        Some(time) => Pose::at(document, buffers, time),
        None => Pose::rest(document),
    }
}

/// What a pose does to a node's primitives: its morph weights and its skin's joint matrices.
struct Deform {
    weights: Vec<f64>,
    joints: Option<Vec<Matrix>>,
}

impl Deform {
    fn of(pose: &Pose, node: &gltf::Node, mesh: &gltf::Mesh, buffers: &[gltf::buffer::Data]) -> Result<Deform, String> {
        let targets = mesh.primitives().next().map_or(0, |p| p.morph_targets().count());
        let joints = match node.skin() {
            Some(skin) => Some(pose.joint_matrices(&skin, buffers)?),
            None => None,
        };
        Ok(Deform { weights: pose.weights(node, mesh, targets)?, joints })
    }
}

/// A camera that a glTF file's scene places on a node.
#[derive(Debug, Clone, PartialEq)]
pub struct GltfCamera {
    /// The node's index and name.
    pub node: usize,
    pub node_name: Option<String>,
    /// The camera's own name.
    pub name: Option<String>,
    /// The node's world transform, row-major: the camera sits at its origin and looks down its
    /// `−Z`, `+Y` up (glTF's convention).
    pub to_world: [[f64; 4]; 4],
    pub projection: GltfProjection,
}

/// A glTF camera's projection, as the file gives it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GltfProjection {
    /// Vertical field of view in radians; `zfar` absent: an infinite projection.
    Perspective { yfov: f64, aspect_ratio: Option<f64>, znear: f64, zfar: Option<f64> },
    /// Half the view's width and height.
    Orthographic { xmag: f64, ymag: f64, znear: f64, zfar: f64 },
}

/// The cameras of a glTF file's scene, nodes depth first in document order (as
/// [`read_gltf_world`] walks them), placed as the file's pose at `time` places them (at rest
/// without a time).
pub fn read_gltf_cameras(path: &Path, time: Option<f64>) -> Result<Vec<GltfCamera>, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let gltf = gltf::Gltf::open(path).map_err(|e| format(format!("not a readable glTF 2.0 file: {e}")))?;
    let pose = match time {
        // Only an animation's keyframes need the buffers.
        Some(time) => {
            let buffers = gltf::import_buffers(&gltf.document, path.parent(), gltf.blob.clone()).map_err(|e| format(format!("reading its buffers: {e}")))?;
            Pose::at(&gltf.document, &buffers, time)
        }
        None => Pose::rest(&gltf.document),
    }
    .map_err(format)?;
    let mut cameras = Vec::new();
    pose.walk(&gltf.document, &mut |node, transform| {
        if let Some(camera) = node.camera() {
            let projection = match camera.projection() {
                gltf::camera::Projection::Perspective(p) => GltfProjection::Perspective {
                    yfov: p.yfov() as f64,
                    aspect_ratio: p.aspect_ratio().map(f64::from),
                    znear: p.znear() as f64,
                    zfar: p.zfar().map(f64::from),
                },
                gltf::camera::Projection::Orthographic(o) => {
                    GltfProjection::Orthographic { xmag: o.xmag() as f64, ymag: o.ymag() as f64, znear: o.znear() as f64, zfar: o.zfar() as f64 }
                }
            };
            cameras.push(GltfCamera {
                node: node.index(),
                node_name: node.name().map(str::to_owned),
                name: camera.name().map(str::to_owned),
                to_world: *transform,
                projection,
            });
        }
        Ok(())
    })
    .map_err(format)?;
    Ok(cameras)
}

/// The extensions a file may require: the reader implements them.
const IMPLEMENTED_EXTENSIONS: [&str; 3] = ["KHR_texture_transform", "KHR_materials_unlit", "KHR_materials_emissive_strength"];

/// The document and its buffers, with required extensions it does not implement refused.
fn open(path: &Path) -> Result<(gltf::Gltf, Vec<gltf::buffer::Data>), IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let gltf = gltf::Gltf::open(path).map_err(|e| format(format!("not a readable glTF 2.0 file: {e}")))?;
    if let Some(ext) = gltf.document.extensions_required().find(|ext| !IMPLEMENTED_EXTENSIONS.contains(ext)) {
        return Err(format(format!("unsupported glTF feature: the file requires the extension {ext}, which this reader does not implement")));
    }
    let buffers = gltf::import_buffers(&gltf.document, path.parent(), gltf.blob.clone()).map_err(|e| format(format!("reading its buffers: {e}")))?;
    Ok((gltf, buffers))
}

/// What the primitives read so far add up to.
#[derive(Default)]
struct Parts {
    positions: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
    normals: Vec<[f32; 3]>,
    colours: Vec<[f32; 4]>,
    uvs: Vec<[f32; 2]>,
    primitives: usize,
    with_normals: usize,
    with_colours: usize,
    with_uvs: usize,
    coloured_materials: usize,
    /// Textures, by glTF texture index and whether they hold sRGB colours (base colour,
    /// emission) or linear values, and each face's base-colour texture (`NO_TEXTURE`: none).
    textures: Vec<Texture>,
    texture_of: std::collections::HashMap<(usize, bool), u32>,
    face_textures: Vec<u32>,
    /// Materials, by glTF material index (`None`: the default material), and each face's.
    materials: Vec<Material>,
    material_of: std::collections::HashMap<Option<usize>, u32>,
    face_materials: Vec<u32>,
}

/// Where a file's images come from: its folder and its buffers.
struct Sources<'a> {
    base: Option<&'a Path>,
    buffers: &'a [gltf::buffer::Data],
}

impl Sources<'_> {
    /// Texture `texture`, of sRGB colours or linear values, with its sampler.
    fn texture(&self, texture: &gltf::Texture, srgb: bool) -> Result<Texture, String> {
        use gltf::image::Format;
        use gltf::texture::{MagFilter, MinFilter, WrappingMode};
        let image = texture.source();
        let data = gltf::image::Data::from_source(image.source(), self.base, self.buffers)
            .map_err(|e| format!("image {} of texture {}: {e}", image.index(), texture.index()))?;
        let n = data.width as usize * data.height as usize;
        let p = &data.pixels;
        let rgba: Vec<u8> = match data.format {
            Format::R8G8B8A8 => p.clone(),
            Format::R8G8B8 => p.as_chunks::<3>().0.iter().flat_map(|c| [c[0], c[1], c[2], 255]).collect(),
            Format::R8G8 => p.as_chunks::<2>().0.iter().flat_map(|c| [c[0], c[0], c[0], c[1]]).collect(),
            Format::R8 => p.iter().flat_map(|&c| [c, c, c, 255]).collect(),
            // 16-bit channels, little-endian: their high bytes.
            Format::R16G16B16A16 => p.as_chunks::<8>().0.iter().flat_map(|c| [c[1], c[3], c[5], c[7]]).collect(),
            Format::R16G16B16 => p.as_chunks::<6>().0.iter().flat_map(|c| [c[1], c[3], c[5], 255]).collect(),
            Format::R16G16 => p.as_chunks::<4>().0.iter().flat_map(|c| [c[1], c[1], c[1], c[3]]).collect(),
            Format::R16 => p.as_chunks::<2>().0.iter().flat_map(|c| [c[1], c[1], c[1], 255]).collect(),
            other => return Err(format!("unsupported glTF feature: image {} is {other:?}", image.index())),
        };
        debug_assert_eq!(rgba.len(), n * 4);
        let sampler = texture.sampler();
        let address = |mode| match mode {
            WrappingMode::ClampToEdge => Address::ClampToEdge,
            WrappingMode::MirroredRepeat => Address::MirroredRepeat,
            WrappingMode::Repeat => Address::Repeat,
        };
        // The mipmapped minifications are trilinear; a plain one is the level-0 filter.
        let filter = match (sampler.min_filter(), sampler.mag_filter()) {
            (Some(MinFilter::Nearest), _) => Filter::Nearest,
            (Some(MinFilter::Linear), _) => Filter::Bilinear,
            (None, Some(MagFilter::Nearest)) => Filter::Nearest,
            _ => Filter::Trilinear,
        };
        Ok(Texture { width: data.width, height: data.height, rgba, srgb, filter, address_u: address(sampler.wrap_s()), address_v: address(sampler.wrap_t()) })
    }
}

impl Parts {
    /// The index of `texture` (of sRGB colours or linear values) in the mesh's textures, read
    /// the first time.
    fn texture(&mut self, sources: &Sources, texture: &gltf::Texture, srgb: bool) -> Result<u32, String> {
        let key = (texture.index(), srgb);
        if let Some(&k) = self.texture_of.get(&key) {
            return Ok(k);
        }
        self.textures.push(sources.texture(texture, srgb)?);
        let k = self.textures.len() as u32 - 1;
        self.texture_of.insert(key, k);
        Ok(k)
    }

    /// The mesh the primitives add up to; `None` without triangles. The faces of blended
    /// materials come after the others (each in the file's order), so that a frame that draws
    /// in order blends them over the opaque surfaces.
    fn into_mesh(mut self) -> Option<Mesh> {
        if self.triangles.is_empty() {
            return None;
        }
        let blended = |f: &usize| self.materials[self.face_materials[*f] as usize].alpha == AlphaMode::Blend;
        let order: Vec<usize> = (0..self.triangles.len()).filter(|f| !blended(f)).chain((0..self.triangles.len()).filter(blended)).collect();
        if order.iter().enumerate().any(|(k, &f)| k != f) {
            let permuted = |v: &[u32]| order.iter().map(|&f| v[f]).collect::<Vec<u32>>();
            (self.face_textures, self.face_materials) = (permuted(&self.face_textures), permuted(&self.face_materials));
            self.triangles = order.iter().map(|&f| self.triangles[f]).collect();
        }
        let vertex_count = self.positions.len();
        // Named whenever there are textures: some may not be base colours (a face without a
        // base-colour texture would otherwise take texture 0).
        Some(Mesh {
            face_textures: (!self.textures.is_empty()).then_some(self.face_textures),
            textures: self.textures,
            face_materials: (self.materials.len() > 1).then_some(self.face_materials),
            materials: self.materials,
            positions: self.positions,
            triangles: self.triangles,
            normals: (self.with_normals == self.primitives).then_some(self.normals),
            colours: (self.with_colours > 0 || self.coloured_materials > 0).then_some(self.colours),
            uvs: (self.with_uvs > 0).then(|| {
                let mut uvs = self.uvs;
                uvs.resize(vertex_count, [0.0; 2]);
                uvs
            }),
        })
    }
}

/// Adds `primitive`'s triangles and vertices to `out`: its positions morphed by `deform`'s
/// weights, then skinned by its joints or else placed by `world`; or, given a `rig`, at rest,
/// with its joints, weights and morph offsets added to the rig (its node's `Binding`).
fn add_primitive(
    mesh: &gltf::Mesh,
    primitive: &gltf::Primitive,
    world: &Matrix,
    deform: &Deform,
    sources: &Sources,
    out: &mut Parts,
    rig: Option<(&mut Rig, Binding)>,
) -> Result<(), String> {
    let buffers = sources.buffers;
    use gltf::mesh::Mode;
    let name = || format!("mesh {}{} primitive {}", mesh.index(), mesh.name().map(|n| format!(" ('{n}')")).unwrap_or_default(), primitive.index());
    check_primitive(primitive).map_err(|e| format!("{}: {e}", name()))?;
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let mut positions: Vec<[f64; 3]> =
        reader.read_positions().ok_or_else(|| format!("{} has no POSITION attribute", name()))?.map(|p| p.map(f64::from)).collect();
    let n = positions.len();
    let mut normals: Option<Vec<[f64; 3]>> = reader.read_normals().map(|normals| normals.map(|v| v.map(f64::from)).collect());
    if normals.as_ref().is_some_and(|v| v.len() != n) {
        return Err(format!("{} has {} normals for {n} positions", name(), normals.map_or(0, |v| v.len())));
    }
    let offsets = morph_offsets(primitive, &reader, &deform.weights, n).map_err(|e| format!("{}: {e}", name()))?;
    let skin = match &deform.joints {
        Some(joints) => Some(skin_weights(primitive, &reader, joints.len(), n).map_err(|e| format!("{}: {e}", name()))?),
        None => None,
    };
    let skinned: Option<Vec<Matrix>> = deform.joints.as_ref().zip(skin.as_ref()).map(|(joints, skin)| skin.iter().map(|s| blended(joints, s)).collect());
    // At rest for a rig, whose program poses the vertices; else posed here.
    let rest = rig.is_some();
    match rig {
        Some((rig, binding)) => rig.add(binding, skin.as_deref(), n, offsets),
        None => morph(&offsets, &deform.weights, &mut positions, &mut normals),
    }
    let base = out.positions.len();
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None => (0..n as u32).collect(),
    };
    if let Some(&bad) = indices.iter().find(|&&i| i as usize >= n) {
        return Err(format!("{} refers to vertex {bad}, but has only {n}", name()));
    }
    let corner = |i: u32| base as u32 + i;
    let triangles: Vec<[u32; 3]> = match primitive.mode() {
        Mode::Triangles => indices.as_chunks::<3>().0.iter().map(|t| t.map(corner)).collect(),
        // The specification's order: every other triangle of a strip takes its last two
        // vertices the other way round, which keeps the winding.
        Mode::TriangleStrip => (0..indices.len().saturating_sub(2))
            .map(|t| if t % 2 == 0 { [indices[t], indices[t + 1], indices[t + 2]] } else { [indices[t], indices[t + 2], indices[t + 1]] })
            .map(|t| t.map(corner))
            .collect(),
        Mode::TriangleFan => (2..indices.len()).map(|k| [indices[0], indices[k - 1], indices[k]].map(corner)).collect(),
        other => return Err(format!("unsupported glTF feature: {} draws {other:?}, not triangles", name())),
    };
    let m = world;
    // A mirroring transform (negative determinant) turns counter-clockwise faces clockwise:
    // glTF then defines the winding the other way round, so swap two corners back.
    let linear_det = determinant(m);
    // A skinned vertex's matrix is its own: a face whose first corner's mirrors turns the same way.
    let mirrored = |[a, _, _]: &[u32; 3]| match &skinned {
        Some(skin) => determinant(&skin[(a - base as u32) as usize]) < 0.0,
        None => linear_det < 0.0,
    };
    let triangles: Vec<[u32; 3]> = triangles.into_iter().map(|t| if mirrored(&t) { [t[0], t[2], t[1]] } else { t }).collect();
    let place = |m: &Matrix, p: &[f64; 3]| -> [f64; 3] { std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]) };
    match &skinned {
        _ if rest => out.positions.extend(positions),
        Some(skin) => out.positions.extend(positions.iter().zip(skin).map(|(p, s)| place(s, p))),
        None => out.positions.extend(positions.iter().map(|p| place(m, p))),
    }
    let material = primitive.material();
    let maps = material_textures(&material).map_err(|e| format!("unsupported glTF feature: {}'s {e}", name()))?;
    let transform = maps.transform;
    let texture = match maps.base_colour {
        Some(t) => out.texture(sources, &t, true)?,
        None => NO_TEXTURE,
    };
    out.face_textures.extend(std::iter::repeat_n(texture, triangles.len()));
    let material_index = match out.material_of.get(&material.index()) {
        Some(&k) => k,
        None => {
            let mut surface = surface(&material).map_err(|e| format!("{}: {e}", name()))?;
            surface.metallic_roughness_texture = maps.metallic_roughness.map(|t| out.texture(sources, &t, false)).transpose()?;
            surface.occlusion_texture = maps.occlusion.map(|t| out.texture(sources, &t, false)).transpose()?;
            surface.emissive_texture = maps.emissive.map(|t| out.texture(sources, &t, true)).transpose()?;
            out.materials.push(surface);
            let k = out.materials.len() as u32 - 1;
            out.material_of.insert(material.index(), k);
            k
        }
    };
    out.face_materials.extend(std::iter::repeat_n(material_index, triangles.len()));
    out.triangles.extend(triangles);
    out.primitives += 1;
    match (normals, &skinned) {
        (Some(normals), _) if rest => {
            out.with_normals += 1;
            out.normals.extend(normals.iter().map(|v| v.map(|c| c as f32)));
        }
        (Some(normals), Some(skin)) => {
            out.with_normals += 1;
            out.normals.extend(normals.iter().zip(skin).map(|(v, s)| transform_normal(&normal_matrix(s), v.map(|c| c as f32))));
        }
        (Some(normals), None) => {
            out.with_normals += 1;
            let normal_matrix = normal_matrix(m);
            out.normals.extend(normals.iter().map(|v| transform_normal(&normal_matrix, v.map(|c| c as f32))));
        }
        (None, _) => out.normals.extend(std::iter::repeat_n([0.0; 3], n)),
    }
    let factor = primitive.material().pbr_metallic_roughness().base_color_factor();
    out.coloured_materials += usize::from(factor != [1.0; 4]);
    match reader.read_colors(0) {
        Some(colours) => {
            out.with_colours += 1;
            out.colours.extend(colours.into_rgba_f32().map(|c| std::array::from_fn(|k| c[k] * factor[k])));
        }
        None => out.colours.extend(std::iter::repeat_n(factor, n)),
    }
    if let Some(uvs) = reader.read_tex_coords(0) {
        // Vertices of earlier primitives without coordinates get zeros.
        out.uvs.resize(base, [0.0; 2]);
        out.with_uvs += 1;
        match &transform {
            Some(t) => out.uvs.extend(uvs.into_f32().map(|uv| transformed(t, uv))),
            None => out.uvs.extend(uvs.into_f32()),
        }
    }
    Ok(())
}

/// A material's textures, and the `KHR_texture_transform` they share.
struct MaterialTextures<'a> {
    base_colour: Option<gltf::Texture<'a>>,
    metallic_roughness: Option<gltf::Texture<'a>>,
    occlusion: Option<gltf::Texture<'a>>,
    emissive: Option<gltf::Texture<'a>>,
    transform: Option<gltf::texture::TextureTransform<'a>>,
}

/// `material`'s textures (an error says which does not): each must read `TEXCOORD_0`, and the base-colour, metallic-roughness
/// and emissive textures must take the same texture transform (which moves the primitive's
/// coordinates, and so the occlusion texture's too) or none.
fn material_textures<'a>(material: &gltf::Material<'a>) -> Result<MaterialTextures<'a>, String> {
    let pbr = material.pbr_metallic_roughness();
    let infos =
        [("base colour", pbr.base_color_texture()), ("metallic-roughness", pbr.metallic_roughness_texture()), ("emissive", material.emissive_texture())];
    let transform = infos.iter().find_map(|(_, info)| info.as_ref().and_then(|i| i.texture_transform()));
    let moves = |t: &Option<gltf::texture::TextureTransform>| t.as_ref().map(|t| (t.offset(), t.rotation(), t.scale()));
    let shared = moves(&transform);
    let occlusion = material.occlusion_texture();
    let uses = infos
        .iter()
        .filter_map(|(what, info)| {
            info.as_ref().map(|i| (*what, i.texture_transform().and_then(|t| t.tex_coord()).unwrap_or(i.tex_coord()), moves(&i.texture_transform())))
        })
        .chain(occlusion.as_ref().map(|o| ("occlusion", o.tex_coord(), shared)));
    for (what, tex_coord, moved) in uses {
        if tex_coord != 0 {
            return Err(format!("{what} texture reads TEXCOORD_{tex_coord}"));
        }
        if moved != shared {
            return Err(format!("{what} texture takes another texture transform than its other textures"));
        }
    }
    let [base_colour, metallic_roughness, emissive] = infos.map(|(_, info)| info.map(|i| i.texture()));
    Ok(MaterialTextures { base_colour, metallic_roughness, occlusion: occlusion.map(|o| o.texture()), emissive, transform })
}

/// A glTF material as the renderer draws it: its metallic and roughness factors, whether it is
/// double-sided and unlit, its alpha mode (with `MASK`'s cutoff) and its emission
/// (`emissiveFactor` times `KHR_materials_emissive_strength`).
fn surface(material: &gltf::Material) -> Result<Material, String> {
    let which = || material.index().map_or("the default material".to_owned(), |k| format!("material {k}"));
    let pbr = material.pbr_metallic_roughness();
    let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
    for (what, value) in [("metallicFactor", metallic), ("roughnessFactor", roughness)] {
        if !(0.0..=1.0).contains(&value) {
            return Err(format!("{}'s {what} is {value}, outside [0, 1]", which()));
        }
    }
    let alpha = match material.alpha_mode() {
        gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
        gltf::material::AlphaMode::Mask => AlphaMode::Mask { cutoff: material.alpha_cutoff().unwrap_or(0.5) },
        gltf::material::AlphaMode::Blend => AlphaMode::Blend,
    };
    let strength = material.emissive_strength().unwrap_or(1.0);
    let emissive = material.emissive_factor().map(|e| e * strength);
    let cutoff = material.alpha_cutoff().unwrap_or(0.5);
    let not_negative = [("alphaCutoff", cutoff), ("emissiveFactor", emissive[0]), ("emissiveFactor", emissive[1]), ("emissiveFactor", emissive[2])];
    if let Some((what, value)) = not_negative.into_iter().find(|(_, v)| !(v.is_finite() && *v >= 0.0)) {
        return Err(format!("{}'s {what} is {value}, not a finite number of at least 0", which()));
    }
    let occlusion_strength = material.occlusion_texture().map_or(1.0, |o| o.strength());
    if !(0.0..=1.0).contains(&occlusion_strength) {
        return Err(format!("{}'s occlusion strength is {occlusion_strength}, outside [0, 1]", which()));
    }
    Ok(Material { metallic, roughness, double_sided: material.double_sided(), alpha, unlit: material.unlit(), emissive, occlusion_strength, ..Material::PLAIN })
}

/// `uv` moved by a `KHR_texture_transform`: scaled, rotated (counter-clockwise in the image as
/// the specification's matrix turns it), then offset, in `f64` with `libm`'s sine and cosine.
fn transformed(t: &gltf::texture::TextureTransform, [u, v]: [f32; 2]) -> [f32; 2] {
    let ([ox, oy], r, [sx, sy]) = (t.offset().map(f64::from), f64::from(t.rotation()), t.scale().map(f64::from));
    let (s, c) = (libm::sin(r), libm::cos(r));
    let (u, v) = (sx * f64::from(u), sy * f64::from(v));
    [(c * u + s * v + ox) as f32, (-s * u + c * v + oy) as f32]
}

/// The determinant of `m`'s linear part.
fn determinant(m: &Matrix) -> f64 {
    m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0])
}

/// Refuses an accessor the `gltf` crate's readers cannot take (they panic on a component type
/// or a shape they do not expect): `what` it holds, the types and shapes allowed.
pub(crate) fn check_accessor(accessor: &gltf::Accessor, what: &str, types: &[DataType], shapes: &[Dimensions]) -> Result<(), String> {
    if types.contains(&accessor.data_type()) && shapes.contains(&accessor.dimensions()) && accessor.count() > 0 {
        return Ok(());
    }
    Err(format!(
        "accessor {} ({what}) holds {} {:?} {:?} elements; {what} takes {:?} of {:?}",
        accessor.index(),
        accessor.count(),
        accessor.data_type(),
        accessor.dimensions(),
        shapes,
        types
    ))
}

/// Every accessor of `primitive` this reader reads, checked ([`check_accessor`]); attributes it
/// does not read are left alone.
fn check_primitive(primitive: &gltf::Primitive) -> Result<(), String> {
    use gltf::Semantic;
    let floats: &[DataType] = &[DataType::F32];
    let normalised: &[DataType] = &[DataType::U8, DataType::U16, DataType::F32];
    for (semantic, accessor) in primitive.attributes() {
        let (types, shapes): (&[DataType], &[Dimensions]) = match semantic {
            Semantic::Positions | Semantic::Normals => (floats, &[Dimensions::Vec3]),
            Semantic::Colors(_) => (normalised, &[Dimensions::Vec3, Dimensions::Vec4]),
            Semantic::TexCoords(_) => (normalised, &[Dimensions::Vec2]),
            Semantic::Joints(_) => (&[DataType::U8, DataType::U16], &[Dimensions::Vec4]),
            Semantic::Weights(_) => (normalised, &[Dimensions::Vec4]),
            _ => continue,
        };
        check_accessor(&accessor, &format!("{semantic:?}"), types, shapes)?;
    }
    if let Some(indices) = primitive.indices() {
        check_accessor(&indices, "indices", &[DataType::U8, DataType::U16, DataType::U32], &[Dimensions::Scalar])?;
    }
    for target in primitive.morph_targets() {
        for (accessor, what) in [(target.positions(), "morph target positions"), (target.normals(), "morph target normals")] {
            if let Some(accessor) = accessor {
                check_accessor(&accessor, what, floats, &[Dimensions::Vec3])?;
            }
        }
    }
    Ok(())
}

/// The morph targets' position and normal offsets for `primitive`'s `n` vertices, checked
/// against its mesh's `weights` (one per target).
fn morph_offsets<'a, 's, F>(primitive: &gltf::Primitive, reader: &gltf::mesh::Reader<'a, 's, F>, weights: &[f64], n: usize) -> Result<Vec<Offsets>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    let targets: Vec<_> = reader.read_morph_targets().collect();
    if targets.len() != weights.len() {
        return Err(format!("{} morph targets where its mesh's first primitive has {}", targets.len(), weights.len()));
    }
    let read = |k: usize, offsets: Option<gltf::accessor::Iter<'s, [f32; 3]>>, what: &str| match offsets {
        Some(offsets) if offsets.len() != n => Err(format!("morph target {k} has {} {what} offsets for {n} vertices", offsets.len())),
        offsets => Ok(offsets.map(|o| o.collect::<Vec<_>>())),
    };
    primitive
        .morph_targets()
        .zip(targets)
        .enumerate()
        .map(|(k, (target, (positions, normals, _)))| {
            if target.positions().is_some() != positions.is_some() || target.normals().is_some() != normals.is_some() {
                return Err(format!("morph target {k}'s data lies outside its buffers"));
            }
            Ok((read(k, positions, "position")?, read(k, normals, "normal")?))
        })
        .collect()
}

/// Adds the morph targets' `offsets`, each times its weight, to `positions` and `normals`.
fn morph(offsets: &[Offsets], weights: &[f64], positions: &mut [[f64; 3]], normals: &mut Option<Vec<[f64; 3]>>) {
    for ((target_positions, target_normals), &weight) in offsets.iter().zip(weights).filter(|(_, w)| **w != 0.0) {
        let add = |offsets: &Option<Vec<[f32; 3]>>, to: &mut [[f64; 3]]| {
            for (v, d) in to.iter_mut().zip(offsets.iter().flatten()) {
                *v = std::array::from_fn(|c| v[c] + weight * d[c] as f64);
            }
        };
        add(target_positions, positions);
        if let Some(normals) = normals {
            add(target_normals, normals);
        }
    }
}

/// Each vertex's (up to four) joints, indices into a skin of `joints` joints, and their weights
/// normalised to sum to 1 (as players do; glTF asks files for it). A vertex whose weights are
/// all zero follows its first joint.
fn skin_weights<'a, 's, F>(primitive: &gltf::Primitive, reader: &gltf::mesh::Reader<'a, 's, F>, joints: usize, n: usize) -> Result<Vec<SkinWeights>, String>
where
    F: Clone + Fn(gltf::Buffer<'a>) -> Option<&'s [u8]>,
{
    if primitive.get(&gltf::Semantic::Joints(1)).is_some() || primitive.get(&gltf::Semantic::Weights(1)).is_some() {
        return Err("unsupported glTF feature: more than four joints per vertex (JOINTS_1, WEIGHTS_1); up to four are supported".into());
    }
    let (Some(indices), Some(weights)) = (reader.read_joints(0), reader.read_weights(0)) else {
        return Err("its node has a skin but it has no JOINTS_0 and WEIGHTS_0 attributes".into());
    };
    let (indices, weights): (Vec<[u16; 4]>, Vec<[f32; 4]>) = (indices.into_u16().collect(), weights.into_f32().collect());
    if indices.len() != n || weights.len() != n {
        return Err(format!("{} joints and {} weights for {n} vertices", indices.len(), weights.len()));
    }
    indices
        .iter()
        .zip(&weights)
        .enumerate()
        .map(|(v, (indices, weights))| {
            let weights = weights.map(f64::from);
            if let Some(bad) = weights.iter().find(|w| !(w.is_finite() && **w >= 0.0)) {
                return Err(format!("vertex {v} has the joint weight {bad}; weights are finite and not negative"));
            }
            if let Some((joint, _)) = indices.iter().zip(&weights).find(|&(&j, &w)| w != 0.0 && j as usize >= joints) {
                return Err(format!("vertex {v} names joint {joint} of a skin with {joints}"));
            }
            let sum: f64 = weights.iter().sum();
            Ok(match sum > 0.0 {
                true => (*indices, weights.map(|w| w / sum)),
                false => (*indices, [1.0, 0.0, 0.0, 0.0]),
            })
        })
        .collect()
}

/// A vertex's skin matrix: the sum of its joints' matrices, each times its weight.
fn blended(joints: &[Matrix], (indices, weights): &SkinWeights) -> Matrix {
    let mut sum = [[0.0; 4]; 4];
    for (&joint, &weight) in indices.iter().zip(weights).filter(|(_, w)| **w != 0.0) {
        for (row, m) in sum.iter_mut().zip(&joints[joint as usize]) {
            *row = std::array::from_fn(|c| row[c] + weight * m[c]);
        }
    }
    sum
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A quad (two triangles, normals +z, colours) and its buffer, little-endian.
    fn quad_buffer() -> Vec<u8> {
        let positions: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let normals: [[f32; 3]; 4] = [[0.0, 0.0, 1.0]; 4];
        let colours: [[f32; 4]; 4] = [[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]];
        let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
        let mut b = Vec::new();
        b.extend_from_slice(bytemuck::cast_slice(&positions));
        b.extend_from_slice(bytemuck::cast_slice(&normals));
        b.extend_from_slice(bytemuck::cast_slice(&colours));
        b.extend_from_slice(bytemuck::cast_slice(&indices));
        b
    }

    /// The document: a root node translated by (10, 0, 0) and scaled by 2 with the quad, and a
    /// child rotated 90° about z with the quad again (its material halves red); `mode` is the
    /// second primitive's mode (4: triangles).
    fn document(uri: Option<&str>, mode: u32, required: &str) -> String {
        let uri = uri.map(|u| format!(r#""uri": "{u}","#)).unwrap_or_default();
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  {required}
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [
    {{"mesh": 0, "translation": [10, 0, 0], "scale": [2, 2, 2], "children": [1]}},
    {{"mesh": 1, "rotation": [0, 0, 0.7071067811865476, 0.7071067811865476]}}
  ],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorFactor": [0.5, 1, 1, 1]}}}}],
  "meshes": [
    {{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "COLOR_0": 2}}, "indices": 3}}]}},
    {{"primitives": [{{"attributes": {{"POSITION": 0, "NORMAL": 1, "COLOR_0": 2}}, "indices": 3, "material": 0, "mode": {mode}}}]}}
  ],
  "buffers": [{{{uri} "byteLength": 172}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 48, "byteLength": 48}},
    {{"buffer": 0, "byteOffset": 96, "byteLength": 64}},
    {{"buffer": 0, "byteOffset": 160, "byteLength": 12}}
  ],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"}},
    {{"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC4"}},
    {{"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}}
  ]
}}"#
        )
    }

    pub(crate) fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("tileraster-gltf-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A `.glb`: the JSON chunk and the binary chunk, each padded to four bytes.
    pub(crate) fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
        let mut json = json.as_bytes().to_vec();
        json.resize(json.len().next_multiple_of(4), b' ');
        let mut bin = bin.to_vec();
        bin.resize(bin.len().next_multiple_of(4), 0);
        let total = 12 + 8 + json.len() + 8 + bin.len();
        let mut out = Vec::new();
        out.extend_from_slice(b"glTF");
        out.extend_from_slice(&2u32.to_le_bytes());
        out.extend_from_slice(&(total as u32).to_le_bytes());
        out.extend_from_slice(&(json.len() as u32).to_le_bytes());
        out.extend_from_slice(b"JSON");
        out.extend_from_slice(&json);
        out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
        out.extend_from_slice(b"BIN\0");
        out.extend_from_slice(&bin);
        out
    }

    fn close(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6)
    }

    fn check(mesh: &Mesh) {
        assert_eq!(mesh.triangles, vec![[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]]);
        // The root: scaled by 2, moved by 10 in x.
        assert!(close(mesh.positions[2], [12.0, 2.0, 0.0]), "{:?}", mesh.positions[2]);
        // The child: rotated 90° about z (x → y), then the root's transform.
        assert!(close(mesh.positions[5], [10.0, 2.0, 0.0]), "{:?}", mesh.positions[5]);
        assert!(close(mesh.positions[6], [8.0, 2.0, 0.0]), "{:?}", mesh.positions[6]);
        let normals = mesh.normals.as_ref().expect("normals");
        assert!(normals.iter().all(|n| close(n.map(f64::from), [0.0, 0.0, 1.0])));
        let colours = mesh.colours.as_ref().expect("colours");
        assert_eq!(colours[0], [1.0, 0.0, 0.0, 1.0]);
        assert_eq!(colours[4], [0.5, 0.0, 0.0, 1.0], "COLOR_0 times the base colour factor");
        assert!(mesh.uvs.is_none());
    }

    #[test]
    fn gltf_with_an_external_buffer_and_glb_give_the_same_mesh() {
        let dir = scratch("both");
        std::fs::write(dir.join("quad.bin"), quad_buffer()).unwrap();
        std::fs::write(dir.join("quad.gltf"), document(Some("quad.bin"), 4, "")).unwrap();
        let from_gltf = read_gltf(&dir.join("quad.gltf"), None).unwrap();
        check(&from_gltf);
        std::fs::write(dir.join("quad.glb"), glb(&document(None, 4, ""), &quad_buffer())).unwrap();
        assert_eq!(read_gltf(&dir.join("quad.glb"), None).unwrap(), from_gltf);
    }

    /// Each primitive's material as the renderer draws it (its factors, `doubleSided`,
    /// `alphaMode` and `alphaCutoff`, `KHR_materials_unlit`, the emission times
    /// `KHR_materials_emissive_strength`), the faces of blended materials after the rest, and
    /// factors outside [0, 1] refused.
    #[test]
    fn materials_are_read_and_blended_faces_come_last() {
        let dir = scratch("materials");
        let one = r#""materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1]}}]"#;
        let two = r#""materials": [
    {"pbrMetallicRoughness": {"baseColorFactor": [0.5, 1, 1, 1]}, "alphaMode": "MASK", "alphaCutoff": 0.25, "emissiveFactor": [1, 0.5, 0],
     "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}}},
    {"pbrMetallicRoughness": {"metallicFactor": 0.25, "roughnessFactor": 0.75}, "alphaMode": "BLEND", "doubleSided": true,
     "extensions": {"KHR_materials_unlit": {}}}
  ]"#;
        let doc = document(None, 4, r#""extensionsUsed": ["KHR_materials_unlit", "KHR_materials_emissive_strength"],"#).replace(one, two).replacen(
            r#""indices": 3}]"#,
            r#""indices": 3, "material": 1}]"#,
            1,
        );
        std::fs::write(dir.join("materials.glb"), glb(&doc, &quad_buffer())).unwrap();
        let mesh = read_gltf(&dir.join("materials.glb"), None).unwrap();
        let blended = Material { metallic: 0.25, roughness: 0.75, double_sided: true, alpha: AlphaMode::Blend, unlit: true, ..Material::PLAIN };
        let masked = Material { alpha: AlphaMode::Mask { cutoff: 0.25 }, emissive: [2.0, 1.0, 0.0], ..Material::default() };
        assert_eq!(mesh.materials, vec![blended, masked], "in the order the primitives name them");
        // The root's primitive (blended) is drawn after its child's.
        assert_eq!(mesh.triangles, vec![[4, 5, 6], [4, 6, 7], [0, 1, 2], [0, 2, 3]]);
        assert_eq!(mesh.face_materials, Some(vec![1, 1, 0, 0]));
        // As a world too: the blended mesh's instance after the other's.
        let world = read_gltf_world(&dir.join("materials.glb"), None).unwrap();
        let blends = |i: &Instance| world.meshes[i.mesh as usize].materials.iter().all(|m| m.alpha == AlphaMode::Blend);
        assert_eq!(world.instances.iter().map(blends).collect::<Vec<_>>(), vec![false, true]);
        let bad = doc.replace(r#""metallicFactor": 0.25"#, r#""metallicFactor": 1.5"#);
        std::fs::write(dir.join("bad.glb"), glb(&bad, &quad_buffer())).unwrap();
        let message = read_gltf(&dir.join("bad.glb"), None).unwrap_err().to_string();
        assert!(message.contains("material 1's metallicFactor is 1.5, outside [0, 1]"), "{message}");
    }

    /// A world's mesh with blended faces (last, as `Parts::into_mesh` leaves them) is cut in two,
    /// and every instance of a blended part follows every other instance.
    #[test]
    fn a_worlds_blended_faces_are_drawn_last() {
        let glass = Material { alpha: AlphaMode::Blend, ..Material::PLAIN };
        let mesh = Mesh {
            positions: vec![[0.0; 3]; 3],
            triangles: vec![[0, 1, 2]; 4],
            materials: vec![Material::default(), glass],
            face_materials: Some(vec![0, 0, 1, 1]),
            face_textures: Some(vec![NO_TEXTURE, 0, 1, 2]),
            ..Default::default()
        };
        let moved = |x: f64| [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
        let world = blended_last(World::instanced(mesh, &[moved(1.0), moved(2.0)]));
        assert_eq!(world.meshes.len(), 2);
        assert_eq!((world.meshes[0].face_materials.clone(), world.meshes[0].face_textures.clone()), (Some(vec![0, 0]), Some(vec![NO_TEXTURE, 0])));
        assert_eq!((world.meshes[1].face_materials.clone(), world.meshes[1].face_textures.clone()), (Some(vec![1, 1]), Some(vec![1, 2])));
        let order: Vec<(u32, f64)> = world.instances.iter().map(|i| (i.mesh, i.transform[0][3])).collect();
        assert_eq!(order, vec![(0, 1.0), (0, 2.0), (1, 1.0), (1, 2.0)]);
    }

    /// As a world, each mesh is read once in its own coordinates and each node places one:
    /// flattened, the world is the mesh `read_gltf` reads (the same faces, the same positions
    /// to rounding). Nodes sharing a mesh become instances of one mesh.
    #[test]
    fn nodes_become_instances_of_their_meshes() {
        let dir = scratch("world");
        std::fs::write(dir.join("quad.glb"), glb(&document(None, 4, ""), &quad_buffer())).unwrap();
        let world = read_gltf_world(&dir.join("quad.glb"), None).unwrap();
        assert_eq!((world.meshes.len(), world.instances.len()), (2, 2));
        assert_eq!(world.instances.iter().map(|i| i.mesh).collect::<Vec<_>>(), vec![0, 1]);
        let (flat, mesh) = (world.flattened().unwrap(), read_gltf(&dir.join("quad.glb"), None).unwrap());
        assert_eq!(flat.triangles, mesh.triangles);
        assert!(flat.positions.iter().zip(&mesh.positions).all(|(a, b)| close(*a, *b)));
        let shared = document(None, 4, "").replace(r#"{"mesh": 1, "rotation""#, r#"{"mesh": 0, "rotation""#);
        std::fs::write(dir.join("shared.glb"), glb(&shared, &quad_buffer())).unwrap();
        let world = read_gltf_world(&dir.join("shared.glb"), None).unwrap();
        assert_eq!((world.meshes.len(), world.instances.len()), (1, 2));
        assert_eq!(world.meshes[0].positions[2], [1.0, 1.0, 0.0], "the mesh in its own coordinates");
        assert!(close(world.flattened().unwrap().positions[6], [8.0, 2.0, 0.0]), "the second node's placement");
    }

    /// A base-colour texture: its image decoded (PNG from a file, the same image embedded in
    /// the binary chunk), its sampler's filter and wrapping, every face of the primitive taking
    /// it, and the texture coordinates read.
    #[test]
    fn base_colour_textures_are_read_with_their_samplers() {
        let dir = scratch("texture");
        let texels: Vec<u8> = (0..3 * 2 * 4).map(|k| (k * 11) as u8).collect();
        let mut png = Vec::new();
        image::write_buffer_with_format(&mut std::io::Cursor::new(&mut png), &texels, 3, 2, image::ExtendedColorType::Rgba8, image::ImageFormat::Png).unwrap();
        let positions: [[f32; 3]; 4] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]];
        let uvs: [[f32; 2]; 4] = [[0.0, 1.0], [1.0, 1.0], [1.0, 0.0], [0.0, 0.0]];
        let indices: [u16; 6] = [0, 1, 2, 0, 2, 3];
        let mut bin = Vec::new();
        bin.extend_from_slice(bytemuck::cast_slice(&positions));
        bin.extend_from_slice(bytemuck::cast_slice(&uvs));
        bin.extend_from_slice(bytemuck::cast_slice(&indices));
        bin.resize(92, 0);
        let image_at = bin.len();
        bin.extend_from_slice(&png);
        let document_with = |image: &str, base_colour: &str, extensions: &str| {
            format!(
                r#"{{"asset": {{"version": "2.0"}}, {extensions} "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {base_colour}}}}}],
  "textures": [{{"source": 0, "sampler": 0}}],
  "samplers": [{{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33648}}],
  "images": [{image}],
  "buffers": [{{"byteLength": {}}}],
  "bufferViews": [
    {{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 32}},
    {{"buffer": 0, "byteOffset": 80, "byteLength": 12}}, {{"buffer": 0, "byteOffset": {image_at}, "byteLength": {}}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]}},
    {{"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC2"}},
    {{"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}}]}}"#,
                bin.len(),
                png.len()
            )
        };
        let document = |image: &str| document_with(image, r#"{"index": 0}"#, "");
        std::fs::write(dir.join("tex.png"), &png).unwrap();
        std::fs::write(dir.join("file.glb"), glb(&document(r#"{"uri": "tex.png"}"#), &bin)).unwrap();
        std::fs::write(dir.join("embedded.glb"), glb(&document(r#"{"bufferView": 3, "mimeType": "image/png"}"#), &bin)).unwrap();
        for name in ["file.glb", "embedded.glb"] {
            let mesh = read_gltf(&dir.join(name), None).unwrap();
            let t = &mesh.textures[0];
            assert_eq!((mesh.textures.len(), t.width, t.height, &t.rgba), (1, 3, 2, &texels), "{name}");
            assert_eq!((t.srgb, t.filter, t.address_u, t.address_v), (true, Filter::Nearest, Address::ClampToEdge, Address::MirroredRepeat), "{name}");
            assert_eq!(mesh.face_textures, Some(vec![0, 0]), "{name}");
            assert_eq!(mesh.uvs.as_ref().unwrap()[1], [1.0, 1.0], "{name}");
        }
        // KHR_texture_transform, required: the coordinates scaled, rotated a quarter turn, offset.
        let transform = r#"{"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.25], "rotation": 1.5707963267948966, "scale": [2, 3]}}}"#;
        let required = r#""extensionsUsed": ["KHR_texture_transform"], "extensionsRequired": ["KHR_texture_transform"],"#;
        std::fs::write(dir.join("moved.glb"), glb(&document_with(r#"{"uri": "tex.png"}"#, transform, required), &bin)).unwrap();
        let moved = read_gltf(&dir.join("moved.glb"), None).unwrap();
        for (got, [u, v]) in moved.uvs.unwrap().iter().zip(uvs) {
            // u' = s·(3v) + 0.5 and v' = −(2u) + 0.25 at a quarter turn (cos 0 to within 1e-16).
            let want = [3.0 * v as f64 + 0.5, -2.0 * u as f64 + 0.25];
            assert!((got[0] as f64 - want[0]).abs() < 1e-6 && (got[1] as f64 - want[1]).abs() < 1e-6, "{got:?} against {want:?}");
        }
        // A metallic-roughness material's other textures: the same image read once as sRGB
        // colours (base colour, emission) and once as linear values (metallic-roughness,
        // occlusion).
        let maps =
            r#"{"index": 0}, "metallicRoughnessTexture": {"index": 0}}, "occlusionTexture": {"index": 0, "strength": 0.5}, "emissiveTexture": {"index": 0"#;
        std::fs::write(dir.join("maps.glb"), glb(&document_with(r#"{"uri": "tex.png"}"#, maps, ""), &bin)).unwrap();
        let mesh = read_gltf(&dir.join("maps.glb"), None).unwrap();
        assert_eq!(mesh.textures.iter().map(|t| t.srgb).collect::<Vec<_>>(), vec![true, false]);
        let m = &mesh.materials[0];
        assert_eq!((m.metallic_roughness_texture, m.occlusion_texture, m.occlusion_strength, m.emissive_texture), (Some(1), Some(1), 0.5, Some(0)));
        // One of them under another transform than the others is refused.
        let scaled = r#""metallicRoughnessTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"scale": [2, 2]}}}"#;
        let apart = maps.replace(r#""metallicRoughnessTexture": {"index": 0}"#, scaled);
        std::fs::write(dir.join("apart.glb"), glb(&document_with(r#"{"uri": "tex.png"}"#, &apart, required), &bin)).unwrap();
        let e = read_gltf(&dir.join("apart.glb"), None).unwrap_err().to_string();
        assert!(e.contains("unsupported glTF feature") && e.contains("texture takes another texture transform than its other textures"), "{e}");
        std::fs::remove_file(dir.join("tex.png")).unwrap();
        let e = read_gltf(&dir.join("file.glb"), None).unwrap_err().to_string();
        assert!(e.contains("image 0 of texture 0") && e.contains("file.glb"), "{e}");
    }

    #[test]
    fn strips_are_unrolled_and_unsupported_features_are_named() {
        let dir = scratch("features");
        // A strip of indices 0 1 2 0 2 3: four triangles, every other one's last two swapped.
        std::fs::write(dir.join("strip.glb"), glb(&document(None, 5, ""), &quad_buffer())).unwrap();
        let strip = read_gltf(&dir.join("strip.glb"), None).unwrap();
        assert_eq!(&strip.triangles[2..], &[[4, 5, 6], [5, 4, 6], [6, 4, 6], [4, 7, 6]]);
        std::fs::write(dir.join("points.glb"), glb(&document(None, 0, ""), &quad_buffer())).unwrap();
        let e = read_gltf(&dir.join("points.glb"), None).unwrap_err().to_string();
        assert!(e.contains("unsupported glTF feature") && e.contains("Points") && e.contains("mesh 1"), "{e}");
        let draco = r#""extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#;
        std::fs::write(dir.join("draco.glb"), glb(&document(None, 4, draco), &quad_buffer())).unwrap();
        let e = read_gltf(&dir.join("draco.glb"), None).unwrap_err().to_string();
        assert!(e.contains("KHR_draco_mesh_compression") && e.contains("draco.glb"), "{e}");
        std::fs::write(dir.join("broken.glb"), b"glTF\x02\0\0\0garbage").unwrap();
        assert!(read_gltf(&dir.join("broken.glb"), None).unwrap_err().to_string().contains("not a readable glTF"));
        let missing = read_gltf(&dir.join("none.gltf"), None).unwrap_err().to_string();
        assert!(missing.contains("none.gltf"), "{missing}");
    }

    /// A camera's world transform is its node's, parents included; cameras outside the scene
    /// are not listed; the projections are the file's.
    #[test]
    fn cameras_are_placed_by_their_nodes() {
        let dir = scratch("cameras");
        let json = r#"{
  "asset": {"version": "2.0"},
  "scene": 0,
  "scenes": [{"nodes": [0]}],
  "nodes": [
    {"name": "rig", "translation": [1, 2, 3], "rotation": [0, 0.7071067811865476, 0, 0.7071067811865476], "children": [1]},
    {"name": "eye", "camera": 0, "translation": [0, 0, 4]},
    {"name": "unplaced", "camera": 1}
  ],
  "cameras": [
    {"name": "wide", "type": "perspective", "perspective": {"yfov": 1.2, "znear": 0.5}},
    {"type": "orthographic", "orthographic": {"xmag": 3, "ymag": 2, "znear": 0, "zfar": 9}}
  ]
}"#;
        std::fs::write(dir.join("cameras.gltf"), json).unwrap();
        let cameras = read_gltf_cameras(&dir.join("cameras.gltf"), None).unwrap();
        assert_eq!(cameras.len(), 1, "the scene's cameras only");
        let c = &cameras[0];
        assert_eq!((c.node, c.node_name.as_deref(), c.name.as_deref()), (1, Some("eye"), Some("wide")));
        assert_eq!(c.projection, GltfProjection::Perspective { yfov: 1.2f32 as f64, aspect_ratio: None, znear: 0.5, zfar: None });
        // 4 along +z, turned 90° about y (z → x), then moved by (1, 2, 3): at (5, 2, 3),
        // looking down −x.
        let column = |k: usize| [c.to_world[0][k], c.to_world[1][k], c.to_world[2][k]];
        assert!(close(column(3), [5.0, 2.0, 3.0]), "{:?}", column(3));
        assert!(close(column(2), [1.0, 0.0, 0.0]), "the camera's +z (it looks down −z): {:?}", column(2));
        assert!(close(column(1), [0.0, 1.0, 0.0]), "up: {:?}", column(1));
    }
}
