//! glTF 2.0 (`.gltf` with its buffers, or `.glb`) through the `gltf` crate: the default scene's
//! nodes (or, without scenes, every root node), each node's mesh placed by its world transform
//! (the product of its ancestors' matrices), every triangle primitive's positions, normals
//! (transformed by the inverse transpose and normalised), `COLOR_0` times the material's base
//! colour factor, and `TEXCOORD_0`. Faces count the triangles in that order: nodes depth first
//! in document order, primitives in order, triangles in index order (strips and fans unrolled).
//! Points, lines, required extensions this reader does not implement, and skins or morph
//! targets are refused with an error that names them.

use crate::IoError;
use std::path::Path;
use tileraster_core::render::{Address, Filter, Instance, Mesh, NO_TEXTURE, Texture, World, normal_matrix, transform_normal};

/// Read a glTF 2.0 file (`.gltf` or `.glb`) as one mesh in world coordinates.
pub fn read_gltf(path: &Path) -> Result<Mesh, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let (gltf, buffers) = open(path)?;
    let mut out = Parts::default();
    walk(&gltf.document, &mut |node, world| match node.mesh() {
        Some(mesh) => {
            mesh.primitives().try_for_each(|primitive| add_primitive(&mesh, &primitive, world, &Sources { base: path.parent(), buffers: &buffers }, &mut out))
        }
        None => Ok(()),
    })
    .map_err(format)?;
    out.into_mesh().ok_or_else(|| format("the file has no triangles in its scene".into()))
}

/// Read a glTF 2.0 file as a [`World`]: each mesh once, in its own coordinates, and one
/// instance per node that places a mesh, with the node's world transform. Nodes that share a
/// mesh share it here too (instances). Rendered, it gives the faces in [`read_gltf`]'s order.
pub fn read_gltf_world(path: &Path) -> Result<World, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let (gltf, buffers) = open(path)?;
    let mut world = World::default();
    // glTF mesh index → the world's mesh index (a mesh without triangles is left out).
    let mut built: std::collections::HashMap<usize, Option<u32>> = std::collections::HashMap::new();
    walk(&gltf.document, &mut |node, transform| {
        let Some(mesh) = node.mesh() else { return Ok(()) };
        let index = match built.get(&mesh.index()) {
            Some(&index) => index,
            None => {
                let mut parts = Parts::default();
                mesh.primitives()
                    .try_for_each(|primitive| add_primitive(&mesh, &primitive, &IDENTITY, &Sources { base: path.parent(), buffers: &buffers }, &mut parts))?;
                let index = parts.into_mesh().map(|m| {
                    world.meshes.push(m);
                    world.meshes.len() as u32 - 1
                });
                built.insert(mesh.index(), index);
                index
            }
        };
        if let Some(mesh) = index {
            world.instances.push(Instance { mesh, transform: *transform });
        }
        Ok(())
    })
    .map_err(format)?;
    if world.instances.is_empty() {
        return Err(format("the file has no triangles in its scene".into()));
    }
    Ok(world)
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
/// [`read_gltf_world`] walks them).
pub fn read_gltf_cameras(path: &Path) -> Result<Vec<GltfCamera>, IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let gltf = gltf::Gltf::open(path).map_err(|e| format(format!("not a readable glTF 2.0 file: {e}")))?;
    let mut cameras = Vec::new();
    walk(&gltf.document, &mut |node, transform| {
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

/// The document and its buffers, with required extensions refused.
fn open(path: &Path) -> Result<(gltf::Gltf, Vec<gltf::buffer::Data>), IoError> {
    let format = |message: String| IoError::Format { path: path.to_owned(), message };
    let gltf = gltf::Gltf::open(path).map_err(|e| format(format!("not a readable glTF 2.0 file: {e}")))?;
    if let Some(ext) = gltf.document.extensions_required().next() {
        return Err(format(format!("unsupported glTF feature: the file requires the extension {ext}, which this reader does not implement")));
    }
    let buffers = gltf::import_buffers(&gltf.document, path.parent(), gltf.blob.clone()).map_err(|e| format(format!("reading its buffers: {e}")))?;
    Ok((gltf, buffers))
}

/// Calls `f` with every node of the default scene (or, without scenes, of every root node)
/// and its world transform, depth first in document order.
fn walk(document: &gltf::Document, f: &mut dyn FnMut(&gltf::Node, &Matrix) -> Result<(), String>) -> Result<(), String> {
    let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
        Some(scene) => scene.nodes().collect(),
        None => {
            // No scene: every node that is nobody's child.
            let children: std::collections::HashSet<usize> = document.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
            document.nodes().filter(|n| !children.contains(&n.index())).collect()
        }
    };
    roots.iter().try_for_each(|node| visit(node, IDENTITY, f, 0))
}

type Matrix = [[f64; 4]; 4];
const IDENTITY: Matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

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
    /// Base-colour textures, by glTF texture index, and each face's (`NO_TEXTURE`: none).
    textures: Vec<Texture>,
    texture_of: std::collections::HashMap<usize, u32>,
    face_textures: Vec<u32>,
}

/// Where a file's images come from: its folder and its buffers.
struct Sources<'a> {
    base: Option<&'a Path>,
    buffers: &'a [gltf::buffer::Data],
}

impl Sources<'_> {
    /// Texture `texture` as a base-colour texture (sRGB), with its sampler.
    fn texture(&self, texture: &gltf::Texture) -> Result<Texture, String> {
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
        Ok(Texture {
            width: data.width,
            height: data.height,
            rgba,
            srgb: true,
            filter,
            address_u: address(sampler.wrap_s()),
            address_v: address(sampler.wrap_t()),
        })
    }
}

impl Parts {
    /// The mesh the primitives add up to; `None` without triangles.
    fn into_mesh(self) -> Option<Mesh> {
        if self.triangles.is_empty() {
            return None;
        }
        let vertex_count = self.positions.len();
        let textured = self.face_textures.iter().any(|&t| t != NO_TEXTURE);
        Some(Mesh {
            face_textures: textured.then_some(self.face_textures),
            textures: self.textures,
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

/// glTF's column-major matrix as rows.
fn rows(m: [[f32; 4]; 4]) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| m[c][r] as f64))
}

fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

/// Node hierarchies deeper than this are refused (a cycle, or a hostile file).
const MAX_DEPTH: usize = 256;

fn visit(node: &gltf::Node, parent: Matrix, f: &mut dyn FnMut(&gltf::Node, &Matrix) -> Result<(), String>, depth: usize) -> Result<(), String> {
    if depth > MAX_DEPTH {
        return Err(format!("node {} is nested more than {MAX_DEPTH} deep (a cycle?)", node.index()));
    }
    let world = multiply(&parent, &rows(node.transform().matrix()));
    if node.skin().is_some() {
        return Err(format!("unsupported glTF feature: node {} is skinned", node.index()));
    }
    f(node, &world)?;
    for child in node.children() {
        visit(&child, world, f, depth + 1)?;
    }
    Ok(())
}

fn add_primitive(mesh: &gltf::Mesh, primitive: &gltf::Primitive, world: &Matrix, sources: &Sources, out: &mut Parts) -> Result<(), String> {
    let buffers = sources.buffers;
    use gltf::mesh::Mode;
    let name = || format!("mesh {}{} primitive {}", mesh.index(), mesh.name().map(|n| format!(" ('{n}')")).unwrap_or_default(), primitive.index());
    if primitive.morph_targets().next().is_some() {
        return Err(format!("unsupported glTF feature: {} has morph targets", name()));
    }
    let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
    let positions: Vec<[f32; 3]> = reader.read_positions().ok_or_else(|| format!("{} has no POSITION attribute", name()))?.collect();
    let n = positions.len();
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
    let linear_det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    let triangles: Vec<[u32; 3]> = if linear_det < 0.0 { triangles.into_iter().map(|[a, b, c]| [a, c, b]).collect() } else { triangles };
    out.positions.extend(positions.iter().map(|p| {
        let p = p.map(f64::from);
        std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
    }));
    let material = primitive.material();
    let texture = match material.pbr_metallic_roughness().base_color_texture() {
        Some(info) if info.tex_coord() != 0 => {
            return Err(format!("unsupported glTF feature: {}'s base colour texture reads TEXCOORD_{}", name(), info.tex_coord()));
        }
        Some(info) => {
            let t = info.texture();
            match out.texture_of.get(&t.index()) {
                Some(&k) => k,
                None => {
                    out.textures.push(sources.texture(&t)?);
                    let k = out.textures.len() as u32 - 1;
                    out.texture_of.insert(t.index(), k);
                    k
                }
            }
        }
        None => NO_TEXTURE,
    };
    out.face_textures.extend(std::iter::repeat_n(texture, triangles.len()));
    out.triangles.extend(triangles);
    out.primitives += 1;
    let normal_matrix = normal_matrix(m);
    match reader.read_normals() {
        Some(normals) => {
            out.with_normals += 1;
            out.normals.extend(normals.map(|v| transform_normal(&normal_matrix, v)));
        }
        None => out.normals.extend(std::iter::repeat_n([0.0; 3], n)),
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
        out.uvs.extend(uvs.into_f32());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
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

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("tileraster-gltf-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    /// A `.glb`: the JSON chunk and the binary chunk, each padded to four bytes.
    fn glb(json: &str, bin: &[u8]) -> Vec<u8> {
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
        let from_gltf = read_gltf(&dir.join("quad.gltf")).unwrap();
        check(&from_gltf);
        std::fs::write(dir.join("quad.glb"), glb(&document(None, 4, ""), &quad_buffer())).unwrap();
        assert_eq!(read_gltf(&dir.join("quad.glb")).unwrap(), from_gltf);
    }

    /// As a world, each mesh is read once in its own coordinates and each node places one:
    /// flattened, the world is the mesh `read_gltf` reads (the same faces, the same positions
    /// to rounding). Nodes sharing a mesh become instances of one mesh.
    #[test]
    fn nodes_become_instances_of_their_meshes() {
        let dir = scratch("world");
        std::fs::write(dir.join("quad.glb"), glb(&document(None, 4, ""), &quad_buffer())).unwrap();
        let world = read_gltf_world(&dir.join("quad.glb")).unwrap();
        assert_eq!((world.meshes.len(), world.instances.len()), (2, 2));
        assert_eq!(world.instances.iter().map(|i| i.mesh).collect::<Vec<_>>(), vec![0, 1]);
        let (flat, mesh) = (world.flattened().unwrap(), read_gltf(&dir.join("quad.glb")).unwrap());
        assert_eq!(flat.triangles, mesh.triangles);
        assert!(flat.positions.iter().zip(&mesh.positions).all(|(a, b)| close(*a, *b)));
        let shared = document(None, 4, "").replace(r#"{"mesh": 1, "rotation""#, r#"{"mesh": 0, "rotation""#);
        std::fs::write(dir.join("shared.glb"), glb(&shared, &quad_buffer())).unwrap();
        let world = read_gltf_world(&dir.join("shared.glb")).unwrap();
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
        let document = |image: &str| {
            format!(
                r#"{{"asset": {{"version": "2.0"}}, "scene": 0, "scenes": [{{"nodes": [0]}}], "nodes": [{{"mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0, "TEXCOORD_0": 1}}, "indices": 2, "material": 0}}]}}],
  "materials": [{{"pbrMetallicRoughness": {{"baseColorTexture": {{"index": 0}}}}}}],
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
        std::fs::write(dir.join("tex.png"), &png).unwrap();
        std::fs::write(dir.join("file.glb"), glb(&document(r#"{"uri": "tex.png"}"#), &bin)).unwrap();
        std::fs::write(dir.join("embedded.glb"), glb(&document(r#"{"bufferView": 3, "mimeType": "image/png"}"#), &bin)).unwrap();
        for name in ["file.glb", "embedded.glb"] {
            let mesh = read_gltf(&dir.join(name)).unwrap();
            let t = &mesh.textures[0];
            assert_eq!((mesh.textures.len(), t.width, t.height, &t.rgba), (1, 3, 2, &texels), "{name}");
            assert_eq!((t.srgb, t.filter, t.address_u, t.address_v), (true, Filter::Nearest, Address::ClampToEdge, Address::MirroredRepeat), "{name}");
            assert_eq!(mesh.face_textures, Some(vec![0, 0]), "{name}");
            assert_eq!(mesh.uvs.as_ref().unwrap()[1], [1.0, 1.0], "{name}");
        }
        std::fs::remove_file(dir.join("tex.png")).unwrap();
        let e = read_gltf(&dir.join("file.glb")).unwrap_err().to_string();
        assert!(e.contains("image 0 of texture 0") && e.contains("file.glb"), "{e}");
    }

    #[test]
    fn strips_are_unrolled_and_unsupported_features_are_named() {
        let dir = scratch("features");
        // A strip of indices 0 1 2 0 2 3: four triangles, every other one's last two swapped.
        std::fs::write(dir.join("strip.glb"), glb(&document(None, 5, ""), &quad_buffer())).unwrap();
        let strip = read_gltf(&dir.join("strip.glb")).unwrap();
        assert_eq!(&strip.triangles[2..], &[[4, 5, 6], [5, 4, 6], [6, 4, 6], [4, 7, 6]]);
        std::fs::write(dir.join("points.glb"), glb(&document(None, 0, ""), &quad_buffer())).unwrap();
        let e = read_gltf(&dir.join("points.glb")).unwrap_err().to_string();
        assert!(e.contains("unsupported glTF feature") && e.contains("Points") && e.contains("mesh 1"), "{e}");
        let draco = r#""extensionsUsed": ["KHR_draco_mesh_compression"], "extensionsRequired": ["KHR_draco_mesh_compression"],"#;
        std::fs::write(dir.join("draco.glb"), glb(&document(None, 4, draco), &quad_buffer())).unwrap();
        let e = read_gltf(&dir.join("draco.glb")).unwrap_err().to_string();
        assert!(e.contains("KHR_draco_mesh_compression") && e.contains("draco.glb"), "{e}");
        std::fs::write(dir.join("broken.glb"), b"glTF\x02\0\0\0garbage").unwrap();
        assert!(read_gltf(&dir.join("broken.glb")).unwrap_err().to_string().contains("not a readable glTF"));
        let missing = read_gltf(&dir.join("none.gltf")).unwrap_err().to_string();
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
        let cameras = read_gltf_cameras(&dir.join("cameras.gltf")).unwrap();
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
