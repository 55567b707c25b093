//! The kernels' assembly of a frame's faces (`stages::assemble`), for a frame that draws faces
//! alone: what happens to a face (culled wholly outside the frustum, for zero area, by facing,
//! for having no pixel centre; kept; clipped) is decided by the vertex stage's bits alone, and
//! a kept face's records come from its corners as the stage projected them and its vertices'
//! attributes in `f32`, lit per vertex by the `light` stage for Gouraud shading and per face by
//! the fill for flat shading (`programs::shade`, as the host's path lights them). The backend runs the stages
//! ([`GeometryKernels`]: `assemble_count`, then `assemble_scan` and `assemble_fill`) placed mesh
//! by placed mesh; between them the host clips the faces the count leaves it
//! (`CLIPPED_ON_HOST`), the only vertices it computes in `f64`, each taking the stage's word for
//! every corner the stage projected, so that a vertex shared by a kept face and a clipped one
//! lies where both say, and the fill patches their pieces in at their places.

use super::GeometryPass;
use super::clip::geometry;
use super::emit::{Emit, FaceTag};
use super::instances::{Placement, transform_point};
use super::lighting::{FaceLight, Lighting, face_normal};
use super::params::{GREY, GeometryCounts, IDENTITY, RenderParams, Shading};
use super::vertex::{ClipVertex, Corner, Projected, Shaded, computed_normals, flattened, placed_normals};
use super::vertex::{GeometryKernels, PoseKey, Posing};
use super::viewport::{Target, Viewport};
use crate::Error;
use rayon::prelude::*;
use tileraster_kernels::abi::{
    ATTRIBUTES, AssembleParams, AssemblyPatch, FaceMaterial, FaceNormal, ProjectedVertex, ShadeParams, TriangleInput, TriangleShading,
};
use tileraster_kernels::abi::{LIGHT_FACES, LIGHT_NONE, LIGHT_VERTICES};
use tileraster_kernels::stages::assemble::{
    ASSEMBLY_COUNTERS, DROPPED_BACK, DROPPED_FRONT, DROPPED_FRUSTUM, DROPPED_NO_CENTRE, DROPPED_ZERO_AREA, FACE_GROUP, face_material, goes_small,
};
use tileraster_kernels::stages::vertex::UNASSEMBLED;

/// One placed mesh's faces as the kernels' assembly stages take them (`stages::assemble`):
/// their parameters, the mesh's faces (three vertex indices each), the frame's vertices through
/// the vertex stage (the mesh's from `params.first_vertex` on), and what the records carry
/// (each read where `params` says so): per vertex of the frame its attributes in `f32`, per
/// vertex of the frame its colour as the light stage lit it (Gouraud shading; empty where the
/// backend keeps the colours on its device), per face of the frame its normal under flat
/// shading and the frame's lights (`shade`, read where `params.lighting` lights faces), and per
/// face its surface (where the faces name theirs: `params.face_materials`).
pub struct AssemblyMesh<'a> {
    pub params: AssembleParams,
    pub faces: &'a [u32],
    pub projected: &'a [ProjectedVertex],
    pub attributes: &'a [[f32; ATTRIBUTES]],
    pub lit: &'a [[f32; 4]],
    pub face_normals: &'a [FaceNormal],
    pub shade: &'a ShadeParams,
    pub materials: &'a [FaceMaterial],
    /// Which of these a backend may keep between calls (as it keeps a mesh's positions).
    pub kept: KeptInputs,
}

/// Keys of an assembly's inputs that stay the same between calls: `Some(key)`, the same
/// arrays in every call that names the key.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct KeptInputs {
    /// The faces and their surfaces (a prepared mesh's: its positions' key with the frame's
    /// surface).
    pub faces: Option<u64>,
    /// The frame's vertex attributes and face normals (the same for each of its placements, and
    /// for the frames of a prepared mesh at one placement).
    pub attributes: Option<u64>,
}

impl AssemblyMesh<'_> {
    /// The bytes handed to the assembly's stages for this mesh: their parameters (the count's
    /// and the fill's, and the frame's lights where the fill lights faces), the host's
    /// `patches`, and its faces and face textures and the frame's vertex attributes and face
    /// normals where `handed` says so (a backend holds no earlier call's). The vertices come
    /// from the vertex stage, where they are.
    pub fn bytes(&self, patches: &AssemblyPatches, handed: KeptHanded) -> u64 {
        use std::mem::size_of_val as size;
        let mut bytes = 2 * std::mem::size_of::<AssembleParams>();
        if self.params.lighting == LIGHT_FACES {
            bytes += std::mem::size_of::<ShadeParams>();
        }
        bytes += size(patches.patches.as_slice()) + size(patches.inputs.as_slice()) + size(patches.shading.as_slice());
        if handed.faces {
            bytes += size(self.faces) + size(self.materials);
        }
        if handed.attributes {
            bytes += size(self.attributes) + size(self.face_normals);
        }
        bytes as u64
    }
}

/// Whether a call hands over the inputs of [`KeptInputs`] (the backend holds none of an
/// earlier call's under their keys).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeptHanded {
    pub faces: bool,
    pub attributes: bool,
}

impl KeptHanded {
    /// What a backend that held `held` (and now holds `kept`'s) is handed.
    pub fn of(kept: &KeptInputs, held: &mut KeptInputs) -> KeptHanded {
        let hand = |key: Option<u64>, held: &mut Option<u64>| key.is_none_or(|k| held.replace(k) != Some(k));
        KeptHanded { faces: hand(kept.faces, &mut held.faces), attributes: hand(kept.attributes, &mut held.attributes) }
    }
}

/// What `assemble_count` leaves: two words per group of faces (its kept faces' listed and small
/// records), the counters (faces dropped for each cause and left to the host, at their codes),
/// and the faces left to the host in face order.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct AssemblyCount {
    pub group_counts: Vec<u32>,
    pub counters: [u32; ASSEMBLY_COUNTERS],
    pub clipped: Vec<u32>,
}

impl AssemblyCount {
    /// The records the kept faces put out.
    pub fn kept(&self) -> u64 {
        self.group_counts.iter().map(|&c| c as u64).sum()
    }
}

/// The faces the host clipped, for `assemble_scan` and `assemble_fill` to patch in at their
/// places: one entry per face, in face order, and its pieces' records in that order.
#[derive(Debug, Clone, Default)]
pub struct AssemblyPatches {
    pub patches: Vec<AssemblyPatch>,
    pub inputs: Vec<TriangleInput>,
    pub shading: Vec<TriangleShading>,
}

/// Where `assemble_fill` writes a placed mesh's records: exactly its records' room (from its
/// first slot on), and its entries of the listed and small lists where asked for.
pub struct AssembledRecords<'a> {
    pub inputs: &'a mut [TriangleInput],
    pub shading: &'a mut [TriangleShading],
    pub lists: Option<(&'a mut [u32], &'a mut [u32])>,
}

/// Face `k` of a placed mesh, its vertices in drawing order (a mirroring placement turns it).
fn drawn(p: &Placement, k: usize) -> [usize; 3] {
    let tri = p.mesh.triangles[k];
    if p.mirrored { [tri[0], tri[2], tri[1]] } else { tri }.map(|v| v as usize)
}

/// Whether the kernels assemble a frame's faces: faces alone (the wireframe and vertices views
/// take their vertices in `f64`).
pub(super) fn assembles(params: &RenderParams) -> bool {
    params.faces && params.wireframe.is_none() && params.points.is_none()
}

/// The visible instances' vertex attributes in `f32`, one after the other in the placements'
/// order, as the kernels' assembly reads them (unlit: the fill lights them), their normals in
/// the world (for the corners the host clips), and under flat shading their faces' normals:
/// the same for every frame of one mesh at one placement, so a prepared mesh keeps them.
pub(super) struct VertexAttributes {
    /// The placement they were made for (a prepared mesh's one), whether any is read (none:
    /// all empty), and whether the faces' normals were made.
    to_world: [[f64; 4]; 4],
    used: bool,
    faces_lit: bool,
    /// The pose they were made in (`None`: the mesh as it is).
    pose: Option<PoseKey>,
    /// The key they are kept by (`KeptInputs::attributes`): a fresh one each time they are
    /// made, so that a frame's placements share them and a prepared mesh's frames keep them.
    pub(super) key: u64,
    pub(super) normals: Vec<[f32; 3]>,
    pub(super) values: Vec<[f32; ATTRIBUTES]>,
    /// Under flat shading, each face's unit normal in the world ([`face_normal`], its corners
    /// in drawing order), the placements' faces one after the other; else empty.
    pub(super) face_normals: Vec<FaceNormal>,
}

impl VertexAttributes {
    /// The attributes of the instances `placements` (`count` vertices) for `shading`, in `slot`:
    /// where it `keeps` a prepared mesh's (one placement), as they are if made for the same
    /// placement; else made afresh in the slot's arrays (whose pages a frame that reuses its
    /// memory has mapped already).
    #[allow(clippy::too_many_arguments)]
    pub(super) fn of<'a>(
        placements: &[Placement],
        count: usize,
        shading: Shading,
        lighting: &Lighting,
        posing: Option<&Posing<'_>>,
        slot: &'a mut Option<VertexAttributes>,
        keeps: bool,
    ) -> &'a VertexAttributes {
        let (used, faces_lit) = (shading.reads_attributes(), shading == Shading::Flat);
        let to_world = match placements {
            [only] => only.to_world,
            _ => IDENTITY,
        };
        let pose = posing.map(PoseKey::of);
        let same =
            |k: &VertexAttributes| keeps && placements.len() == 1 && k.to_world == to_world && k.used == used && k.faces_lit == faces_lit && k.pose == pose;
        if !slot.as_ref().is_some_and(same) {
            let (mut normals, mut values, mut face_normals) = slot.take().map_or_else(Default::default, |k| (k.normals, k.values, k.face_normals));
            normals.clear();
            values.clear();
            face_normals.clear();
            if used {
                let computed = computed_normals(placements);
                normals.reserve_exact(count);
                values.reserve_exact(count);
                for p in placements {
                    let turned = placed_normals(p, &computed);
                    let shaded = Shaded { mesh: p.mesh, normals: &turned, shading, lighting };
                    let positions = p.positions.par_iter().enumerate();
                    values.par_extend(positions.map(|(v, q)| shaded.attributes(v, transform_point(&p.to_world, q)).map(|a| a as f32)));
                    normals.extend_from_slice(&turned);
                }
            }
            if faces_lit {
                for p in placements {
                    let world = |v: usize| transform_point(&p.to_world, &p.positions[v]);
                    face_normals.par_extend((0..p.mesh.triangles.len()).into_par_iter().map(|k| face_normal(drawn(p, k).map(world))));
                }
            }
            static KEYS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
            let key = KEYS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
            *slot = Some(VertexAttributes { to_world, used, faces_lit, pose, key, normals, values, face_normals });
        }
        slot.as_ref().expect("made above")
    }

    /// The normals of the placement whose vertices start at `first` (of `n`); empty where no
    /// attribute is read.
    pub(super) fn normals_of(&self, first: usize, n: usize) -> &[[f32; 3]] {
        if self.used { &self.normals[first..first + n] } else { &[] }
    }
}

/// The frame's records as the kernels' assembly leaves them: for setup, for shading, and each
/// one's face.
pub(super) struct AssembledFrame {
    pub(super) triangles: Vec<TriangleInput>,
    pub(super) shading: Vec<TriangleShading>,
    pub(super) faces: Vec<u32>,
    /// The light stage's colours, where the host keeps them (Gouraud shading).
    pub(super) lit: Vec<[f32; 4]>,
    /// The key the backend holds the records by (`GeometryKernels::hold_records`).
    pub(super) held: Option<u64>,
}

/// The frame's faces through the kernels' assembly, placed mesh by placed mesh: counted
/// (`assemble_count`), the faces it leaves to the host clipped there, then ranked and written
/// (`assemble_scan`, `assemble_fill`) with the clipped faces' pieces in their places, so that
/// the records are in face order. `split_small`: the plan lists small triangles apart (the
/// stages' lists follow it). `memory`: an earlier frame's arrays, whose pages are mapped.
#[allow(clippy::too_many_arguments)]
pub(super) fn assemble_frame(
    meshes: &[MeshFaces<'_>],
    split_small: bool,
    viewport: &Viewport,
    target: &Target,
    kernels: &mut dyn GeometryKernels,
    memory: AssembledFrame,
    counts: &mut GeometryCounts,
    observe: &mut dyn FnMut(GeometryPass),
) -> Result<AssembledFrame, Error> {
    let mut counted = Vec::with_capacity(meshes.len());
    let (mut listed, mut small) = (0u64, 0u64);
    for faces in meshes {
        let mut mesh = faces.assembly(target, split_small, (0, 0));
        let count = kernels.assemble_count(&mesh)?;
        let (patches, clipped) = faces.patches(&count.clipped, &mesh, viewport, target);
        *counts = counts.add(clipped);
        let c = &count.counters;
        counts.culled_zero_area += c[DROPPED_ZERO_AREA as usize] as u64;
        counts.culled_back += c[DROPPED_BACK as usize] as u64;
        counts.culled_front += c[DROPPED_FRONT as usize] as u64;
        counts.culled_no_centre += c[DROPPED_NO_CENTRE as usize] as u64;
        counts.culled_frustum += c[DROPPED_FRUSTUM as usize] as u64;
        mesh.params.first_listed = listed.min(u32::MAX as u64) as u32;
        mesh.params.first_small = small.min(u32::MAX as u64) as u32;
        mesh.params.patches = patches.patches.len() as u32;
        listed += count.group_counts.iter().step_by(2).map(|&n| n as u64).sum::<u64>() + patches.patches.iter().map(|p| p.listed as u64).sum::<u64>();
        small += count.group_counts.iter().skip(1).step_by(2).map(|&n| n as u64).sum::<u64>() + patches.patches.iter().map(|p| p.small as u64).sum::<u64>();
        counted.push((mesh.params, count, patches));
    }
    observe(GeometryPass::AssembleCount);
    let total = listed + small;
    if total >= u32::MAX as u64 {
        return Err(Error::RasterTooLarge {
            width: target.assembly.width as u64,
            height: target.assembly.height as u64,
            reason: format!("clipping left {total} triangles, more than the 2^32 − 1 a frame indexes"),
        });
    }
    let held = kernels.hold_records(total, listed, small)?;
    // Gouraud shading: the frame's vertices lit once, before the fills copy their colours.
    let mut lit = memory.lit;
    lit.clear();
    if let Some(first) = meshes.first().filter(|m| m.shaded.shading == Shading::Smooth) {
        counts.bytes_uploaded += kernels.light(first.shaded.lighting.params(), first.attributes, first.kept.attributes, &mut lit)?;
    }
    observe(GeometryPass::Light);
    let total = total as usize;
    let out_of_memory = |reason| Error::OutOfMemory { what: "the frame's triangles", reason };
    let mut triangles = crate::raster::reuse_cells(Some(memory.triangles), total).map_err(out_of_memory)?;
    let mut shading = crate::raster::reuse_cells(Some(memory.shading), total).map_err(out_of_memory)?;
    let mut faces = crate::raster::reuse_cells(Some(memory.faces), total).map_err(out_of_memory)?;
    let (mut rest_t, mut rest_s) = (&mut triangles[..], &mut shading[..]);
    for ((params, count, patches), mesh_faces) in counted.iter().zip(meshes) {
        let first = (params.first_listed, params.first_small);
        let mesh = AssemblyMesh { params: *params, lit: &lit, ..mesh_faces.assembly(target, split_small, first) };
        let n = count.kept() as usize + patches.inputs.len();
        let (t, tail_t) = rest_t.split_at_mut(n);
        let (s, tail_s) = rest_s.split_at_mut(n);
        (rest_t, rest_s) = (tail_t, tail_s);
        counts.bytes_uploaded += kernels.assemble_fill(&mesh, count, patches, AssembledRecords { inputs: t, shading: s, lists: None })?;
    }
    faces.par_iter_mut().zip(&shading).for_each(|(f, s)| *f = s.face);
    Ok(AssembledFrame { triangles, shading, faces, lit, held })
}

/// A mesh's faces as the kernels assemble them.
pub(super) struct MeshFaces<'a> {
    pub(super) placement: &'a Placement<'a>,
    /// The surface of every face where they are alike, else each face's (`face_materials`),
    /// their textures the mesh's.
    pub(super) material: Option<FaceMaterial>,
    pub(super) face_materials: Vec<FaceMaterial>,
    /// The frame's vertices through the vertex stage (the placement's from its `first_vertex`).
    pub(super) projected: &'a [ProjectedVertex],
    /// Their attributes in `f32` (empty where none is read).
    pub(super) attributes: &'a [[f32; ATTRIBUTES]],
    /// The frame's face normals under flat shading (else empty), the placement's from
    /// `first_face_normal`.
    pub(super) face_normals: &'a [FaceNormal],
    pub(super) first_face_normal: u32,
    /// Which inputs a backend may keep between frames.
    pub(super) kept: KeptInputs,
    /// Flat interpolation: every corner takes the face's first vertex's attributes.
    pub(super) flat: bool,
    /// What the host's clipping computes a corner from: the attributes' recipe and the frame's
    /// matrix.
    pub(super) shaded: Shaded<'a>,
    pub(super) view_projection: &'a [[f64; 4]; 4],
}

impl<'a> MeshFaces<'a> {
    /// The mesh's faces as the assembly stages take them, their records' slots after
    /// `first_listed` and `first_small` of the frame's earlier placements'.
    fn assembly(&self, target: &Target, split_small: bool, first: (u32, u32)) -> AssemblyMesh<'_> {
        let (p, a) = (self.placement, &target.assembly);
        let faces = p.mesh.triangles.len() as u32;
        let params = AssembleParams {
            faces,
            first_face: p.first_face,
            cull: a.cull,
            front_counter_clockwise: a.front_counter_clockwise,
            width: a.width,
            height: a.height,
            snap_bits: a.snap_bits,
            reach: a.reach as u32,
            mirrored: u32::from(p.mirrored),
            attributes: u32::from(!self.attributes.is_empty()),
            flat: u32::from(self.flat),
            lighting: match self.shaded.shading {
                Shading::Smooth => LIGHT_VERTICES,
                Shading::Flat => LIGHT_FACES,
                _ => LIGHT_NONE,
            },
            face_materials: u32::from(self.material.is_none()),
            first_texture: p.first_texture,
            first_material: p.first_material,
            material: self.material.map_or(FaceMaterial::default(), |m| m.placed(p.first_texture, p.first_material)),
            split_small: u32::from(split_small),
            patches: 0,
            groups: faces.div_ceil(FACE_GROUP),
            dispatch_width: 0,
            first_listed: first.0,
            first_small: first.1,
            first_vertex: p.first_vertex as u32,
            first_face_normal: self.first_face_normal,
            double_sided: a.double_sided,
        };
        let faces = bytemuck::cast_slice(&p.mesh.triangles);
        let (projected, attributes, face_normals, shade) = (self.projected, self.attributes, self.face_normals, self.shaded.lighting.params());
        AssemblyMesh { params, faces, projected, attributes, lit: &[], face_normals, shade, materials: &self.face_materials, kept: self.kept }
    }

    /// Face `k`'s vertices in drawing order.
    fn drawn(&self, k: usize) -> [usize; 3] {
        drawn(self.placement, k)
    }

    /// The faces `assemble_count` left to the host, clipped: their patches and their pieces'
    /// records, and what the clipping counted.
    fn patches(&self, clipped: &[u32], mesh: &AssemblyMesh<'_>, viewport: &Viewport, target: &Target) -> (AssemblyPatches, GeometryCounts) {
        let p = self.placement;
        let pieces: Vec<(Vec<TriangleInput>, Vec<TriangleShading>, GeometryCounts)> = clipped
            .par_iter()
            .map(|&f| {
                let tri = self.drawn(f as usize);
                let tag = FaceTag { id: p.first_face + f, material: face_material(&mesh.params, mesh.materials, f) };
                let mut counts = GeometryCounts::default();
                let mut emit = Emit::Count(0);
                self.clip_on_host(tri, tag, viewport, target, &mut emit, &mut counts);
                let n = emit.count();
                let (mut inputs, mut shading, mut faces) = (vec![TriangleInput::default(); n], vec![TriangleShading::default(); n], vec![0; n]);
                let mut emit = Emit::Fill { triangles: &mut inputs, shading: &mut shading, faces: &mut faces, next: 0, first_slot: 0, small_edges: true };
                self.clip_on_host(tri, tag, viewport, target, &mut emit, &mut GeometryCounts::default());
                (inputs, shading, counts)
            })
            .collect();
        let mut patches = AssemblyPatches::default();
        let mut counts = GeometryCounts::default();
        for (&face, (inputs, shading, c)) in clipped.iter().zip(pieces) {
            let small = inputs.iter().filter(|t| goes_small(&mesh.params, &t.rect)).count() as u32;
            let first = patches.inputs.len() as u32;
            patches.patches.push(AssemblyPatch { face, first, listed: inputs.len() as u32 - small, small });
            patches.inputs.extend(inputs);
            patches.shading.extend(shading);
            counts = counts.add(c);
        }
        (patches, counts)
    }

    /// A face with a corner the vertex stage left to the host, through the host's clipping.
    fn clip_on_host(&self, tri: [usize; 3], tag: FaceTag, viewport: &Viewport, target: &Target, emit: &mut Emit<'_>, counts: &mut GeometryCounts) {
        let vertices = tri.map(|v| self.corner(v, viewport));
        // (Counting reads no attribute.)
        let light = if emit.counting() { None } else { self.face_light(tri) };
        let vertices = flattened(vertices.each_ref(), self.flat && !emit.counting(), light.as_ref()).unwrap_or(vertices);
        let corners = vertices.each_ref().map(Corner::of);
        geometry(corners.each_ref(), vertices.each_ref(), tag, viewport, target, emit, counts);
    }

    /// Under flat shading, the face's lit colour and normal (`Lighting::light_face`, from its
    /// corners in the world in `f64`).
    fn face_light(&self, tri: [usize; 3]) -> Option<FaceLight> {
        if self.shaded.shading != Shading::Flat {
            return None;
        }
        let p = self.placement;
        let q = tri.map(|v| transform_point(&p.to_world, &p.positions[v]));
        let base = p.mesh.colours.as_ref().map_or(GREY, |c| c[tri[0]]).map(f64::from);
        Some(self.shaded.lighting.light_face(base, q))
    }

    /// Vertex `v` in `f64` for the host's clipping, taken as the vertex stage took it: where the
    /// stage projected it for the assembly, onto the clipping planes it may lie a rounding
    /// beyond (so the clipping keeps it whole) with the stage's values; where not, projected
    /// on the host if it lies inside the planes.
    fn corner(&self, v: usize, viewport: &Viewport) -> ClipVertex {
        let p = self.placement;
        let world = transform_point(&p.to_world, &p.positions[v]);
        let mut c = self.shaded.clip_vertex(v, world, self.view_projection, viewport);
        let k = &self.projected[p.first_vertex + v];
        if k.planes & UNASSEMBLED == 0 {
            c = ClipVertex::new(viewport.onto_planes(&c.clip), c.attributes, viewport);
            debug_assert_eq!(c.outside, 0, "on the planes");
            let screen = (k.screen[0] as i64, k.screen[1] as i64);
            c.projected = Projected { screen, depth: k.depth, inv_w: k.inverse_w, attributes: c.attributes.map(|a| a as f32) };
        } else if c.outside == 0 {
            c.projected = c.project(viewport);
        }
        c
    }
}
