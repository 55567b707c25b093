//! The vertex stage: positions to clip space, normals to the world, and what each vertex
//! carries to the stages after it.

use super::KeptMesh;
use super::assemble::{AssembledRecords, AssemblyCount, AssemblyMesh, AssemblyPatches};
use super::instances::{self, Placement};
use super::lighting::{FaceLight, Lighting};
use super::params::{GREY, IDENTITY, Mesh, Shading, surface_normals};
use super::params::{GUARD_PX, RENDER_SNAP_BITS, RenderParams};
use super::program::{VertexStage, VertexTexture};
use super::vector::{multiply, normal_matrix, transform_normal};
use super::viewport::{Viewport, distance};
use crate::Error;
use rayon::prelude::*;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, Ordering};
use tileraster_kernels::abi::{
    ATTR_COLOUR, ATTR_NORMAL, ATTR_POSITION, ATTR_UV, ATTRIBUTES, LightParams, ProjectedVertex, RelativePosition, ShadeParams, VertexParams, VertexUniforms,
};
use tileraster_kernels::math::double::Double;
use tileraster_kernels::programs::deform::{self, DeformLayout, JOINTS_PER_VERTEX};
use tileraster_kernels::programs::vertex::BUILTIN_DEFORM;
use tileraster_kernels::stages::vertex::{self as vertex_stage, FRUSTUM, MATRIX_LIMIT, POSITION_LIMIT};

/// The kernels' geometry stages as a backend runs them while the host prepares a frame: the
/// CPU backend's twins, or the device's dispatches, to the same bits.
pub trait GeometryKernels {
    /// The `vertex` stage (`tileraster_kernels::stages::vertex`) over `positions`, into
    /// `projected` (one per position; its memory reused), with the frame's vertex shader and
    /// vertex texture (`posing`) where `params.posed` says the stage poses them (else the
    /// built-in program). Returns the bytes handed to the stage: its parameters, the positions
    /// unless it holds them already (a mesh's kept positions, [`Positions::kept`], that it was
    /// handed before), and of the vertex texture what `tileraster_cpu::texture_update` says
    /// (nothing where it holds that one already, the texels that changed where it holds
    /// another of the same size).
    fn vertex(
        &mut self,
        params: &VertexParams,
        positions: Positions<'_>,
        posing: Option<&Posing<'_>>,
        projected: &mut Vec<ProjectedVertex>,
    ) -> Result<u64, Error>;

    /// The `assemble_count` stage (`tileraster_kernels::stages::assemble`) over a placed mesh's
    /// faces (whose vertices went through `vertex` last): what it leaves, its faces left to the
    /// host in face order.
    fn assemble_count(&mut self, mesh: &AssemblyMesh<'_>) -> Result<AssemblyCount, Error>;

    /// The `assemble_scan` and `assemble_fill` stages over the same faces, given what
    /// `assemble_count` left and the host's `patches` for the faces it left (the mesh's
    /// `params.patches` of them): the mesh's records into `out`. Returns the bytes the mesh's
    /// assembly handed the stages (its count's and its fill's).
    fn assemble_fill(&mut self, mesh: &AssemblyMesh<'_>, count: &AssemblyCount, patches: &AssemblyPatches, out: AssembledRecords<'_>) -> Result<u64, Error>;

    /// The `light` stage (`stages::light`, Gouraud shading) over the frame's vertex `attributes`
    /// (the assembly's, kept as `KeptInputs::attributes` says by `kept`), with the frame's
    /// lights in `shade`: each vertex's colour into `lit` (one per vertex, its memory reused).
    /// Called once a frame's counts are in (after [`Self::hold_records`]), before its fills; a
    /// backend whose fills run on its device keeps the colours there and leaves `lit` empty.
    /// Returns the bytes handed to the stage: its parameters and the lights (the attributes
    /// are counted with the assembly's inputs).
    fn light(&mut self, shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]], kept: Option<u64>, lit: &mut Vec<[f32; 4]>) -> Result<u64, Error>;

    /// Called once a frame's counts are in, before its fills: the backend makes room for the
    /// frame's records where its raster stages read them (`records` of them, `listed` and
    /// `small` in its lists; on the CPU, the fills' `out` is that room) and returns the key
    /// the prepared frame carries (`RenderInputs::records_held`). A backend that assembles a
    /// frame apart from its raster stages' buffers (the GPU on a CPU device, or past its binding
    /// limits, where the host's twins assemble) returns
    /// a key too: such a frame is counted as if held (`Stats::bytes_uploaded`). `None`: the
    /// records are handed over as a heightfield's are.
    fn hold_records(&mut self, records: u64, listed: u64, small: u64) -> Result<Option<u64>, Error> {
        let _ = (records, listed, small);
        Ok(None)
    }
}

/// The bytes handed to the light stage: its parameters and the frame's lights.
pub fn light_bytes() -> u64 {
    (std::mem::size_of::<LightParams>() + std::mem::size_of::<ShadeParams>()) as u64
}

/// The positions a vertex stage runs over.
#[derive(Clone, Copy)]
pub struct Positions<'a> {
    pub pairs: &'a [RelativePosition],
    /// `Some`: a mesh's kept positions ([`MeshPositions`]), the same pairs in every call that
    /// names this key, which a backend may keep between calls (the GPU keeps them on the
    /// device, so that a prepared mesh's later frames upload none).
    pub kept: Option<u64>,
}

impl Positions<'_> {
    /// The bytes of the stage's input: its parameters and, where `handed`, the positions.
    pub fn bytes(&self, handed: bool) -> u64 {
        (std::mem::size_of::<VertexParams>() + if handed { std::mem::size_of_val(self.pairs) } else { 0 }) as u64
    }
}

/// A mesh's positions as the vertex stage takes them, relative to the centre of the mesh's
/// box in the mesh's own coordinates: the same for every frame and placement of the mesh, so
/// computed once for a prepared mesh and kept (on the GPU, on the device).
pub struct MeshPositions {
    origin: [f64; 3],
    pairs: Vec<RelativePosition>,
    key: u64,
}

impl MeshPositions {
    /// The key the positions are kept by ([`Positions::kept`]).
    pub(super) fn key(&self) -> u64 {
        self.key
    }

    pub(super) fn of(positions: &[[f64; 3]]) -> Self {
        static KEYS: AtomicU64 = AtomicU64::new(0);
        let origin = box_centre(positions);
        let mut pairs = Vec::new();
        relative_pairs(positions, origin, &mut pairs);
        MeshPositions { origin, pairs, key: KEYS.fetch_add(1, Ordering::Relaxed) }
    }
}

/// A vertex through the vertex stage: clip-space position and attributes.
#[derive(Clone, Copy, Default)]
pub(super) struct ClipVertex {
    pub(super) clip: [f64; 4],
    pub(super) attributes: [f64; ATTRIBUTES],
    /// Bit `k`: outside clipping plane `k` (`Viewport::planes`).
    pub(super) outside: u8,
    /// What the kernels take of it, when inside every clipping plane (computed once for every
    /// face that shares it: a face that clipping cuts takes its kept corners' as they are, so
    /// that no crack opens beside them).
    pub(super) projected: Projected,
    /// A point clipping made: not yet projected (`project` gives it its values).
    pub(super) cut: bool,
}

impl ClipVertex {
    /// Projected later, by the vertex stage ([`project_vertices`]).
    pub(super) fn new(clip: [f64; 4], attributes: [f64; ATTRIBUTES], viewport: &Viewport) -> Self {
        let planes = viewport.planes();
        let outside = (0..planes.len()).fold(0u8, |m, k| m | u8::from(distance(&planes, k, &clip) < 0.0) << k);
        ClipVertex { clip, attributes, outside, projected: Projected::default(), cut: false }
    }

    /// Its snapped screen position, depth, `1/w` and attributes in `f32`, in `f64` on the host:
    /// for the points clipping makes, and for the vertices outside the vertex stage's domain.
    pub(super) fn project(&self, viewport: &Viewport) -> Projected {
        let c = &viewport.onto_planes(&self.clip);
        Projected {
            screen: viewport.snap(c),
            depth: (c[2] / c[3]).clamp(0.0, 1.0) as f32,
            inv_w: (1.0 / c[3]) as f32,
            attributes: self.attributes.map(|a| a as f32),
        }
    }
}

/// Bit `k`: `c` outside plane `k` of the view frustum (left, right, top, bottom, near, far). A
/// face is wholly outside one plane where its corners' codes share a bit.
fn frustum_outcode(c: &[f64; 4]) -> u8 {
    let outside = [c[0] < -c[3], c[0] > c[3], c[1] < -c[3], c[1] > c[3], c[2] < 0.0, c[2] > c[3]];
    outside.iter().enumerate().fold(0, |code, (k, &out)| code | u8::from(out) << k)
}

/// What the assembly's decisions read of a vertex (whether a face is outside the frustum, needs
/// clipping, is culled), kept apart from the rest of [`ClipVertex`] (about 200 bytes) so that
/// counting a frame's triangles reads 24 bytes a corner instead of several cache lines.
#[derive(Clone, Copy, Default)]
pub(super) struct Corner {
    /// [`Projected::screen`], where `outside` is zero.
    pub(super) screen: (i64, i64),
    pub(super) outside: u8,
    /// Bit `k`: outside plane `k` of the view frustum ([`frustum_outcode`]).
    pub(super) frustum: u8,
}

impl Corner {
    pub(super) fn of(v: &ClipVertex) -> Self {
        Corner { screen: v.projected.screen, outside: v.outside, frustum: frustum_outcode(&v.clip) }
    }
}

/// A vertex inside every clipping plane as the kernels take it.
#[derive(Clone, Copy, Default)]
pub(super) struct Projected {
    /// Snapped, in `2^-RENDER_SNAP_BITS` px, `y` down.
    pub(super) screen: (i64, i64),
    /// `z/w`, in [0, 1].
    pub(super) depth: f32,
    pub(super) inv_w: f32,
    pub(super) attributes: [f32; ATTRIBUTES],
}

/// A frame's vertex shader and what it hands the shader: the uniforms and the vertex texture.
#[derive(Clone, Copy)]
pub struct Posing<'a> {
    pub stage: &'a VertexStage,
    pub uniforms: VertexUniforms,
    pub texture: Option<&'a Arc<VertexTexture>>,
}

impl<'a> Posing<'a> {
    /// The frame's, where it has a vertex shader.
    pub(super) fn of(params: &'a RenderParams) -> Option<Self> {
        let texture = params.vertex_texture.as_ref();
        let texture_size = texture.map_or([0, 0], |t| [t.width, t.height]);
        params.vertex.as_ref().map(|stage| {
            let uniforms = VertexUniforms { constants: params.vertex_constants, time: params.time, texture_size, builtin: stage.builtin() };
            Posing { stage, uniforms, texture }
        })
    }

    /// The vertex texture's texels (none where the frame has none).
    pub fn texels(&self) -> &'a [f32] {
        self.texture.map_or(&[], |t| &t.texels)
    }
}

/// What a pose depends on: the vertex shader, its uniforms and its vertex texture. Two frames
/// with equal keys pose a mesh alike, so a prepared mesh keeps its posed attributes between
/// them (a DEM's frames from a moving camera, lifted by the same heights), and its posed
/// positions.
#[derive(Clone)]
pub(super) struct PoseKey {
    stage: VertexStage,
    uniforms: VertexUniforms,
    texture: Option<Arc<VertexTexture>>,
}

impl PoseKey {
    pub(super) fn of(posing: &Posing<'_>) -> Self {
        PoseKey { stage: *posing.stage, uniforms: posing.uniforms, texture: posing.texture.cloned() }
    }
}

impl PartialEq for PoseKey {
    fn eq(&self, other: &Self) -> bool {
        let same_texture = match (&self.texture, &other.texture) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (a, b) => a.is_none() && b.is_none(),
        };
        self.stage == other.stage && bytemuck::bytes_of(&self.uniforms) == bytemuck::bytes_of(&other.uniforms) && same_texture
    }
}

/// A mesh as the frame's vertex shader poses it, shared with the prepared mesh that keeps it:
/// its positions ([`posed_positions`]) and, where the built-in deform program poses them, its
/// own normals ([`posed_normals`]; else the frame computes the posed faces' normals).
pub(super) struct Posed {
    pub(super) positions: Vec<[f64; 3]>,
    pub(super) normals: Option<Vec<[f32; 3]>>,
}

pub(super) type PosedMesh = Arc<Posed>;

impl Posed {
    fn of(mesh: &Mesh, posing: &Posing<'_>, kept: Option<&mut Option<MeshPositions>>) -> Result<PosedMesh, Error> {
        Ok(Arc::new(Posed { positions: posed_positions(mesh, posing, kept)?, normals: posed_normals(mesh, posing) }))
    }
}

/// Each placed mesh as the frame's vertex shader (`posing`) poses it ([`Posed`]; `None` for the
/// meshes no instance places, and none at all without a shader). A prepared mesh (`kept`)
/// keeps its posed mesh while its pose is the same; a one-shot frame of one mesh leaves the
/// pairs it posed in `pairs`, for the vertex stage to take rather than compute again.
pub(super) fn posed_meshes(
    meshes: &[Mesh],
    placed: &[bool],
    posing: Option<&Posing<'_>>,
    kept: Option<&mut KeptMesh>,
    pairs: Option<&mut Option<MeshPositions>>,
) -> Result<Vec<Option<PosedMesh>>, Error> {
    let Some(posing) = posing else {
        return Ok(Vec::new());
    };
    if let (None, Some(pairs), [mesh]) = (&kept, pairs, meshes) {
        return Ok(vec![Some(Posed::of(mesh, posing, Some(pairs))?)]);
    }
    if let Some(k) = kept {
        let key = PoseKey::of(posing);
        let posed = match k.posed.take() {
            Some((held, posed)) if held == key => posed,
            _ => Posed::of(&meshes[0], posing, Some(&mut k.positions))?,
        };
        k.posed = Some((key, posed.clone()));
        return Ok(vec![Some(posed)]);
    }
    let pose = |(mesh, &placed): (&Mesh, &bool)| placed.then(|| Posed::of(mesh, posing, None)).transpose();
    meshes.iter().zip(placed).map(pose).collect()
}

/// `mesh`'s positions as the frame's vertex shader poses them, in `f64` for the host's stages
/// (clipping, normals, culling of instances): the shader called natively on the pairs the
/// kernels' vertex stage poses (`MeshPositions`; `kept`'s, where the mesh keeps them), each
/// posed pair added to their origin. A coordinate the shader leaves as it is keeps the mesh's
/// own value, and so does a vertex beyond the stage's range (which the stage does not project).
pub(super) fn posed_positions(mesh: &Mesh, posing: &Posing<'_>, kept: Option<&mut Option<MeshPositions>>) -> Result<Vec<[f64; 3]>, Error> {
    let fresh;
    let stage = match kept {
        Some(kept) => &*kept.get_or_insert_with(|| MeshPositions::of(&mesh.positions)),
        None => {
            fresh = MeshPositions::of(&mesh.positions);
            &fresh
        }
    };
    if posing.stage.builtin() == BUILTIN_DEFORM {
        let needs = DeformLayout::of(&posing.uniforms).texels(mesh.positions.len() as u64);
        if (posing.texels().len() as u64) < needs {
            return Err(Error::DeformTexture { vertices: mesh.positions.len(), texels: posing.texels().len(), needs });
        }
    }
    let program = posing.stage.program();
    let pose = |(v, (pair, own)): (usize, (&RelativePosition, &[f64; 3]))| {
        let r = vertex_stage::pairs(pair);
        let posed = vertex_stage::posed(program, &posing.uniforms, posing.texels(), v as u32, pair);
        let unmoved = |k: usize| posed[k].hi.to_bits() == r[k].hi.to_bits() && posed[k].lo.to_bits() == r[k].lo.to_bits();
        std::array::from_fn(|k| if unmoved(k) { own[k] } else { stage.origin[k] + posed[k].to_f64() })
    };
    let posed: Vec<[f64; 3]> = stage.pairs.par_iter().zip(mesh.positions.par_iter()).enumerate().map(pose).collect();
    match posed.iter().position(|p| !p.iter().all(|c| c.is_finite())) {
        Some(vertex) => Err(Error::VertexPosedBeyond { name: posing.stage.name().into(), vertex, position: posed[vertex] }),
        None => Ok(posed),
    }
}

/// `mesh`'s own normals as the built-in deform program (`VertexStage::DEFORM`) poses its
/// positions: each moved by its morph targets' normal offsets (`programs::deform::morphed`) and
/// turned by the inverse transpose of its joints' weighted matrices ([`normal_matrix`]), in
/// `f64` from the texture's `f32` values. `None` for another program (the frame then computes
/// the posed faces' normals) or a mesh without normals.
pub(super) fn posed_normals(mesh: &Mesh, posing: &Posing<'_>) -> Option<Vec<[f32; 3]>> {
    let normals = mesh.normals.as_ref().filter(|_| posing.stage.builtin() == BUILTIN_DEFORM)?;
    let (layout, texture) = (DeformLayout::of(&posing.uniforms), posing.texels());
    let texel = |i: u32| f64::from(deform::fetch(texture, i));
    let pose = |(v, &n): (usize, &[f32; 3])| {
        let v = v as u32;
        let mut blended = [[0.0; 4]; 4];
        for i in 0..JOINTS_PER_VERTEX {
            let (joint, weight) = layout.joint_of(texture, v, i);
            for (r, row) in blended.iter_mut().take(3).enumerate() {
                for (c, entry) in row.iter_mut().take(3).enumerate() {
                    *entry += f64::from(weight) * texel(joint + 4 * r as u32 + c as u32);
                }
            }
        }
        transform_normal(&normal_matrix(&blended), deform::morphed(&layout, texture, v, n, true))
    };
    Some(normals.par_iter().enumerate().map(pose).collect())
}

/// The mesh's normals in the world: its own, or (where it has none) [`face_normals`], turned by
/// the model matrix's inverse transpose (its cofactors, with the determinant's sign) and
/// normalised.
pub(super) fn vertex_normals(n: &[[f32; 3]], model: &[[f64; 4]; 4]) -> Vec<[f32; 3]> {
    if *model == IDENTITY {
        return n.to_vec();
    }
    let normal_matrix = normal_matrix(model);
    n.par_iter().map(|&v| transform_normal(&normal_matrix, v)).collect()
}

/// The normals of the placed meshes that have none of their own ([`face_normals`]), once per
/// mesh, by mesh index (`None` for the others).
pub(super) fn computed_normals(placements: &[Placement]) -> Vec<Option<Vec<[f32; 3]>>> {
    let mut computed: Vec<Option<Vec<[f32; 3]>>> = vec![None; placements.iter().map(|p| p.mesh_index + 1).max().unwrap_or(0)];
    for p in placements {
        if p.normals.is_none() && computed[p.mesh_index].is_none() {
            computed[p.mesh_index] = Some(surface_normals(p.positions, &p.mesh.triangles));
        }
    }
    computed
}

/// A placement's normals in the world: its mesh's own or `computed` ([`computed_normals`]),
/// turned by its transform ([`vertex_normals`]).
pub(super) fn placed_normals(p: &Placement, computed: &[Option<Vec<[f32; 3]>>]) -> Vec<[f32; 3]> {
    let own = p.normals.or(computed[p.mesh_index].as_deref()).expect("normals of every placed mesh");
    vertex_normals(own, &p.to_world)
}

/// A face's corners with flat interpolation's values (`flat`: the first corner's attributes at
/// every corner) and flat shading's face light over them, where either applies: every clipped
/// piece then carries them.
pub(super) fn flattened(corners: [&ClipVertex; 3], flat: bool, light: Option<&FaceLight>) -> Option<[ClipVertex; 3]> {
    if !flat && light.is_none() {
        return None;
    }
    let first = corners[0].attributes;
    Some(corners.map(|c| {
        let mut values = if flat { first } else { c.attributes };
        if let Some(light) = light {
            light.apply(&mut values);
        }
        ClipVertex { attributes: values, projected: Projected { attributes: values.map(|v| v as f32), ..c.projected }, ..*c }
    }))
}

/// What a vertex's attributes are made of: its mesh, the mesh's normals in the world
/// ([`vertex_normals`]; empty where no attribute is read), and the frame's shading.
pub(super) struct Shaded<'a> {
    pub(super) mesh: &'a Mesh,
    pub(super) normals: &'a [[f32; 3]],
    pub(super) shading: Shading,
    pub(super) lighting: &'a Lighting,
}

impl Shaded<'_> {
    /// Vertex `v` of the mesh, at `world` in the world, through `m` to clip space with its
    /// attributes in `f64` (colour, normal, world position, texture coordinates), lit for
    /// Gouraud shading ([`Lighting::lit_vertex`], as the kernels' assembly lights it).
    pub(super) fn clip_vertex(&self, v: usize, world: [f64; 3], m: &[[f64; 4]; 4], viewport: &Viewport) -> ClipVertex {
        let p = world;
        let clip = [0, 1, 2, 3].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
        let mut attributes = self.attributes(v, p);
        if self.shading == Shading::Smooth {
            let lit = self.lighting.lit_vertex(&attributes);
            attributes[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&lit);
        }
        ClipVertex::new(clip, attributes, viewport)
    }

    /// The attributes of vertex `v` at `p` in the world, unlit (zeros where none is read).
    pub(super) fn attributes(&self, v: usize, p: [f64; 3]) -> [f64; ATTRIBUTES] {
        let mesh = self.mesh;
        let mut attributes = [0.0; ATTRIBUTES];
        if !self.shading.reads_attributes() {
            return attributes;
        }
        let n = self.normals[v].map(f64::from);
        let colour = mesh.colours.as_ref().map_or(GREY, |c| c[v]).map(f64::from);
        let uv = mesh.uvs.as_ref().map_or([0.0; 2], |t| t[v]).map(f64::from);
        attributes[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&colour);
        attributes[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&n);
        attributes[ATTR_POSITION..ATTR_POSITION + 3].copy_from_slice(&p);
        attributes[ATTR_UV..ATTR_UV + 2].copy_from_slice(&uv);
        attributes
    }
}

/// The vertex stage over the visible instances (`placements`, `count` vertices in all): each
/// instance's transform, then the view-projection, into the arrays `world` (positions) and
/// `vertices` (clip-space vertices with their attributes (colour, normal, world position, texture
/// coordinates; lit per vertex for Gouraud shading)), kept between frames, on all cores, then
/// the kernels' vertex stage ([`project_vertices`]; its bytes returned). `one_instance`:
/// whether the world has one instance (then placed in `placements`); `kept`: a prepared mesh's
/// positions for the stage, kept between its frames.
#[allow(clippy::too_many_arguments)]
pub(super) fn transform_vertices(
    placements: &[Placement],
    count: usize,
    m: &[[f64; 4]; 4],
    shading: Shading,
    lighting: &Lighting,
    viewport: &Viewport,
    world: &mut Vec<[f64; 3]>,
    vertices: &mut Vec<ClipVertex>,
    stage: &mut VertexStageMemory,
    one_instance: bool,
    kept: Option<&mut Option<MeshPositions>>,
    posing: Option<&Posing<'_>>,
    kernels: &mut dyn GeometryKernels,
) -> Result<u64, Error> {
    // Every entry is overwritten below: the last frame's are kept as they are, and only the
    // entries beyond them filled first (a prepared mesh's frames fill none: about 12 MB of stores
    // a frame for the 100k-triangle terrain).
    world.truncate(count);
    vertices.truncate(count);
    // Many instances of a large mesh can ask for more than the machine has: a typed error.
    let bytes = count as u128 * (std::mem::size_of::<[f64; 3]>() + std::mem::size_of::<ClipVertex>()) as u128;
    let reserved = world.try_reserve_exact(count - world.len()).and_then(|()| vertices.try_reserve_exact(count - vertices.len()));
    reserved.map_err(|e| Error::OutOfMemory { what: "the visible instances' vertices", reason: format!("{count} vertices, {bytes} bytes ({e})") })?;
    // Filled on all cores (`resize` writes them on one).
    world.par_extend(rayon::iter::repeat_n([0.0; 3], count - world.len()));
    vertices.par_extend(rayon::iter::repeat_n(ClipVertex::default(), count - vertices.len()));
    // The depth and id views read no attribute: they carry zeros, and no normal is computed.
    let attributes_used = shading.reads_attributes();
    let computed = if attributes_used { computed_normals(placements) } else { Vec::new() };
    let mut pieces = Vec::with_capacity(placements.len());
    let (mut rest_w, mut rest_v) = (&mut world[..], &mut vertices[..]);
    for p in placements {
        let n = p.positions.len();
        let (w, tail_w) = rest_w.split_at_mut(n);
        let (v, tail_v) = rest_v.split_at_mut(n);
        pieces.push((p, w, v));
        (rest_w, rest_v) = (tail_w, tail_v);
    }
    pieces.into_par_iter().for_each(|(p, world, vertices)| {
        let (mesh, model) = (p.mesh, &p.to_world);
        p.positions.par_iter().zip(world.par_iter_mut()).for_each(|(v, out)| *out = instances::transform_point(model, v));
        let world = &*world;
        let normals = if attributes_used { placed_normals(p, &computed) } else { Vec::new() };
        vertices.par_iter_mut().enumerate().for_each(|(v, out)| {
            let shaded = Shaded { mesh, normals: &normals, shading, lighting };
            *out = shaded.clip_vertex(v, world[v], m, viewport);
        });
    });
    let VertexStageMemory { positions, projected } = stage;
    let (handed, origin, matrix, posed) = stage_input(placements, one_instance, m, world, kept, posing, positions);
    project_vertices(handed, origin, &matrix, posed, vertices, viewport, projected, kernels)
}

/// What the vertex stage takes for a frame: its positions, their origin, and the matrix from
/// them to clip space. A world of one instance (a mesh) hands the mesh's own positions,
/// relative to its box's centre, with the placement's transform composed into the matrix, so
/// that a prepared mesh (`kept`) hands them to the stage once. Several instances hand the
/// world's positions (`world`), relative to their box's centre, however many the culling keeps
/// (which changes no bit). `pairs` holds the positions a prepared mesh does not keep.
///
/// With a vertex shader (`posing`), a mesh's own positions are handed unposed and the stage
/// poses them (the last value returned: whether it does, with the uniforms `posing` holds);
/// the world's positions of several instances are handed as the host posed them
/// ([`posed_positions`], the same function on the same pairs).
fn stage_input<'a, 'p>(
    placements: &[Placement],
    one_instance: bool,
    m: &[[f64; 4]; 4],
    world: &[[f64; 3]],
    kept: Option<&'a mut Option<MeshPositions>>,
    posing: Option<&'p Posing<'p>>,
    pairs: &'a mut Vec<RelativePosition>,
) -> (Positions<'a>, [f64; 3], [[f64; 4]; 4], Option<&'p Posing<'p>>) {
    let (points, matrix, posing) = match placements {
        [only] if one_instance => {
            let matrix = if only.to_world == IDENTITY { *m } else { multiply(m, &only.to_world) };
            if let Some(kept) = kept {
                let mesh = kept.get_or_insert_with(|| MeshPositions::of(&only.mesh.positions));
                return (Positions { pairs: &mesh.pairs, kept: Some(mesh.key) }, mesh.origin, matrix, posing);
            }
            (&only.mesh.positions[..], matrix, posing)
        }
        _ => (world, *m, None),
    };
    let origin = box_centre(points);
    relative_pairs(points, origin, pairs);
    (Positions { pairs, kept: None }, origin, matrix, posing)
}

/// The centre of the points' box (the origin their pairs are taken from).
/// The origin the vertex stage takes a mesh's positions relative to (the centre of their box),
/// in the mesh's own coordinates: what a vertex program's pose is relative to, and what
/// `VertexStage::DEFORM`'s joint matrices fold in.
pub fn pose_origin(positions: &[[f64; 3]]) -> [f64; 3] {
    box_centre(positions)
}

fn box_centre(points: &[[f64; 3]]) -> [f64; 3] {
    let [lo, hi] = instances::bounds(points);
    if points.is_empty() { [0.0; 3] } else { [0, 1, 2].map(|k| lo[k] / 2.0 + hi[k] / 2.0) }
}

/// `points − origin` in double-`f32` pairs, into `pairs`; a point beyond the stage's range (or
/// not finite) goes as one that it does not project.
fn relative_pairs(points: &[[f64; 3]], origin: [f64; 3], pairs: &mut Vec<RelativePosition>) {
    let beyond = RelativePosition { hi: [POSITION_LIMIT; 3], lo: [0.0; 3] };
    points
        .par_iter()
        .map(|p| {
            // `+ 0.0`: a −0 coordinate goes as +0, as it does through a transform.
            let r = [0, 1, 2].map(|k| p[k] - origin[k] + 0.0);
            if !r.iter().all(|v| v.abs() < POSITION_LIMIT as f64) {
                return beyond;
            }
            let r = r.map(Double::from_f64);
            RelativePosition { hi: r.map(|d| d.hi), lo: r.map(|d| d.lo) }
        })
        .collect_into_vec(pairs);
}

/// The vertex stage's memory, kept between frames.
#[derive(Default)]
pub(super) struct VertexStageMemory {
    positions: Vec<RelativePosition>,
    projected: Vec<ProjectedVertex>,
}

impl VertexStageMemory {
    /// The frame's vertices as the stage projected them.
    pub(super) fn projected(&self) -> &[ProjectedVertex] {
        &self.projected
    }
}

/// The kernels' vertex stage alone, for a frame the kernels assemble (`assemble`): no vertex in
/// `f64` but, for a world of several instances, their positions in the world (into `world`),
/// which the stage takes as the host's path hands them (`stage_input`). The projected vertices
/// are left in `stage`; returns the bytes handed to the stage, or `None` where the frame's
/// matrix lies beyond the stage's range (the frame then takes the host's path).
#[allow(clippy::too_many_arguments)]
pub(super) fn project_for_assembly(
    placements: &[Placement],
    one_instance: bool,
    count: usize,
    m: &[[f64; 4]; 4],
    viewport: &Viewport,
    world: &mut Vec<[f64; 3]>,
    stage: &mut VertexStageMemory,
    kept: Option<&mut Option<MeshPositions>>,
    posing: Option<&Posing<'_>>,
    kernels: &mut dyn GeometryKernels,
) -> Result<Option<u64>, Error> {
    let vertices = u32::try_from(count).map_err(|_| Error::TooManyFaces { faces: count as u64 })?;
    if !(one_instance && placements.len() == 1) {
        world.clear();
        let reserved = world.try_reserve_exact(count);
        reserved.map_err(|e| Error::OutOfMemory { what: "the visible instances' vertices", reason: format!("{count} vertices ({e})") })?;
        world.par_extend(placements.par_iter().flat_map(|p| p.positions.par_iter().map(|v| instances::transform_point(&p.to_world, v))));
    }
    let VertexStageMemory { positions, projected } = stage;
    let (handed, origin, matrix, posed) = stage_input(placements, one_instance, m, world, kept, posing, positions);
    let Some(params) = vertex_params(&matrix, origin, posed, viewport) else {
        return Ok(None);
    };
    let bytes = kernels.vertex(&VertexParams { vertices, ..params }, handed, posed, projected)?;
    if projected.len() != count {
        return Err(Error::Gpu(format!("the vertex stage returned {} vertices of {count}", projected.len())));
    }
    Ok(Some(bytes))
}

/// The vertex stage proper, on the frame's backend (`kernels`): every vertex inside the clipping
/// planes gets its snapped position, depth and `1/w` from `stages::vertex`. The kernels take
/// positions relative to an origin in double-`f32` pairs (`positions`, one per vertex), and
/// `matrix` (from the positions' space to clip space) with the origin composed in, posed by
/// `posed`'s shader where given. Returns the bytes handed to the stage.
#[allow(clippy::too_many_arguments)]
fn project_vertices(
    positions: Positions<'_>,
    origin: [f64; 3],
    matrix: &[[f64; 4]; 4],
    posed: Option<&Posing<'_>>,
    vertices: &mut [ClipVertex],
    viewport: &Viewport,
    projected: &mut Vec<ProjectedVertex>,
    kernels: &mut dyn GeometryKernels,
) -> Result<u64, Error> {
    let count = u32::try_from(vertices.len()).map_err(|_| Error::TooManyFaces { faces: vertices.len() as u64 })?;
    let Some(params) = vertex_params(matrix, origin, posed, viewport) else {
        // A matrix beyond the stage's range (a camera of absurd scale): every vertex on the host.
        vertices.par_iter_mut().filter(|v| v.outside == 0).for_each(|v| v.projected = v.project(viewport));
        return Ok(0);
    };
    let params = VertexParams { vertices: count, ..params };
    let bytes = kernels.vertex(&params, positions, posed, projected)?;
    if projected.len() != vertices.len() {
        return Err(Error::Gpu(format!("the vertex stage returned {} vertices of {}", projected.len(), vertices.len())));
    }
    // The guard band in snapped units: where every vertex inside the planes snaps in `f64`. The
    // stage's snapped vertex is taken there (an ill-conditioned `w` may put it beyond, where
    // the edge functions' range is not proven; the host projects such a vertex).
    let (low, high) = guard_band_units(viewport);
    let within = |s: [i32; 2]| s[0] >= low && s[1] >= low && s[0] <= high[0] && s[1] <= high[1];
    vertices.par_iter_mut().zip(&*projected).filter(|(v, _)| v.outside == 0).for_each(|(v, p)| {
        v.projected = if p.is_projected() && within(p.screen) {
            Projected { screen: (p.screen[0] as i64, p.screen[1] as i64), depth: p.depth, inv_w: p.inverse_w, attributes: v.attributes.map(|a| a as f32) }
        } else {
            v.project(viewport)
        };
    });
    Ok(bytes)
}

/// The vertex stage's parameters: `m · T(origin)` in pairs, the viewport in snapped units, and
/// where the stage poses the positions (`posed`) the shader's uniforms; `None` where an entry
/// lies beyond the stage's range.
fn vertex_params(m: &[[f64; 4]; 4], origin: [f64; 3], posed: Option<&Posing<'_>>, viewport: &Viewport) -> Option<VertexParams> {
    let mut composed = *m;
    for row in &mut composed {
        row[3] += row[0] * origin[0] + row[1] * origin[1] + row[2] * origin[2];
    }
    if !composed.iter().flatten().all(|v| v.abs() < MATRIX_LIMIT as f64) {
        return None;
    }
    let pairs = composed.map(|row| row.map(Double::from_f64));
    let (low, high) = guard_band_units(viewport);
    let unit = (1u64 << RENDER_SNAP_BITS) as f64;
    Some(VertexParams {
        matrix_hi: pairs.map(|row| row.map(|d| d.hi)),
        matrix_lo: pairs.map(|row| row.map(|d| d.lo)),
        half_units: viewport.half.map(|h| (h * unit) as f32),
        reach: viewport.guard.map(|g| (2.0 * g) as f32),
        band_low: low,
        band_high: high,
        posed: u32::from(posed.is_some()),
        uniforms: posed.map_or_else(VertexUniforms::default, |p| p.uniforms),
        ..VertexParams::default()
    })
}

/// The guard band in snapped units, lowest and highest per axis: where every vertex inside the
/// clipping planes snaps in `f64`.
fn guard_band_units(viewport: &Viewport) -> (i32, [i32; 2]) {
    let unit = (1u64 << RENDER_SNAP_BITS) as f64;
    ((-GUARD_PX * unit) as i32, viewport.half.map(|h| ((2.0 * h + GUARD_PX) * unit) as i32))
}

/// The depths of the vertices the vertex stage found inside the frustum, lowest and highest
/// (the depth view's range, where the kernels assemble the frame): the stage's `f32` depths.
pub(super) fn projected_depth_range(projected: &[ProjectedVertex]) -> (f64, f64) {
    let inside = |p: &&ProjectedVertex| p.is_projected() && p.planes & FRUSTUM == 0;
    // (`+ 0.0`: a depth of −0 counts as +0, whichever way the reduction splits.)
    let visible = projected.par_iter().filter(inside).map(|p| p.depth as f64 + 0.0);
    let (lo, hi) = visible.fold(|| (1.0f64, 0.0f64), |(lo, hi), d| (lo.min(d), hi.max(d))).reduce(|| (1.0, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    if lo < hi { (lo, hi) } else { (0.0, 1.0) }
}

/// The depths of the visible vertices, lowest and highest (the depth view's range).
pub(super) fn depth_range(vertices: &[ClipVertex]) -> (f64, f64) {
    let inside = |c: &[f64; 4]| c[3] > 0.0 && c[2] >= 0.0 && c[2] <= c[3] && c[0].abs() <= c[3] && c[1].abs() <= c[3];
    let visible = vertices.par_iter().filter(|v| inside(&v.clip)).map(|v| v.clip[2] / v.clip[3]);
    let (lo, hi) = visible.fold(|| (1.0f64, 0.0f64), |(lo, hi), d| (lo.min(d), hi.max(d))).reduce(|| (1.0, 0.0), |a, b| (a.0.min(b.0), a.1.max(b.1)));
    if lo < hi { (lo, hi) } else { (0.0, 1.0) }
}
