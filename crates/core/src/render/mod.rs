//! The render pipeline's geometry stages, once per frame and the same for both backends: vertex
//! transform, clipping, culling, viewport transform and snapping. The kernels' `vertex` stage
//! (`stages::vertex`, run by the frame's backend through [`GeometryKernels`]) gives every
//! vertex inside the clipping planes its snapped position, depth and `1/w`, and its frustum
//! bits, from which the kernels' assembly (`assemble`) decides the faces of a frame that draws
//! faces alone; the host clips in `f64` the faces it leaves, and runs the rest of the stages
//! in `f64` for frames with the wireframe or vertices view.
//! What they leave is a [`Prepared`] scene for the kernels (setup, binning, the depth test of
//! `programs::depth` and the shade stage of `programs::shade`). The pipeline is written here
//! (`prepare_instances_in`); each stage is a file of its own:
//!
//! - `vertex`: positions to clip space by the view-projection matrix (Vulkan conventions:
//!   `0 ≤ z ≤ w` is visible, NDC `y` points down the image); per-vertex colour, normal, world
//!   position and texture coordinates carried along (Gouraud shading lights them per vertex,
//!   flat shading per face, with the kernels' functions: `lighting`).
//! - `clip`: in homogeneous space against the near (`z = 0`) and far (`z = w`) planes, a plane
//!   `w = W_MIN` that keeps `w ≤ 0` from the rasteriser, and a guard band [`GUARD_PX`] pixels
//!   beyond the viewport on each side, so that every snapped edge function fits the kernels'
//!   integers. An edge is always cut from its inside end towards its outside end, so two faces
//!   sharing an edge cut it at the same point: clipping opens no crack. The clipped polygon is
//!   cut into a fan; every piece keeps its face's id.
//! - `cull`: whole triangles outside one frustum plane (in `clip`); back or front faces
//!   (orientation from the snapped vertices, Vulkan's sign rule); zero-area pieces.
//! - `assemble`: for a frame drawing faces alone (one mesh or a world of instances), the kernels'
//!   assembly stages (`assemble_count`, `assemble_scan`, `assemble_fill`, run by the backend)
//!   decide every face from the vertex stage's bits and write the kept faces' records from `f32`
//!   attributes (kept with a prepared mesh), lit where the shading lights them; only the faces they leave to
//!   the host go through `clip` and `cull`, patched in at their places, and no other vertex is
//!   computed in `f64`.
//! - `viewport`: pixel centres at `+0.5`, vertices rounded to 8 sub-pixel bits (16.8 fixed
//!   point, as Direct3D 11 and Vulkan's 2022 roadmap require), the clipping planes.
//! - `lines` and `points`: the wireframe and vertices views; `lighting`: the viewer, the
//!   lights and the shade stage's parameters, flat and Gouraud lighting for the host's path; `instances`: placements and object
//!   culling; `texture`: textures laid out for the kernels; `emit`: where triangles go.
//! - `params` (what a frame is made of and asked for), `validate` (bad input as typed errors)
//!   and `vector` sit below them all.
//!
//! The kernels' vertex and viewport arithmetic, in double-`f32`, is `stages::vertex` and
//! `stages::viewport` (`docs/numeric-contract.md`, "Geometry in the kernels").

mod assemble;
mod clip;
mod cull;
mod emit;
mod instances;
mod lighting;
mod lines;
mod params;
mod points;
pub(crate) mod program;
mod texture;
mod validate;
mod vector;
mod vertex;
mod viewport;

use assemble::{AssembledFrame, MeshFaces, VertexAttributes};
pub use assemble::{AssembledRecords, AssemblyCount, AssemblyMesh, AssemblyPatches, KeptHanded, KeptInputs};
use clip::geometry;
use emit::{Emit, FaceTag};
pub use instances::{Instance, World};
use instances::{Placement, validate_world};
use lighting::Lighting;
pub use lines::edges;
pub(crate) use params::GREY;
pub use params::{
    AlphaMode, Cull, Eye, FrontFace, GUARD_PX, GeometryCounts, IDENTITY, Light, LineRule, MAX_POINT_SIZE, MAX_RENDER_DIM, MIN_POINT_SIZE, Material, Mesh,
    RENDER_SNAP_BITS, RenderParams, Shading, ToneMap, Wireframe, centre_of_projection, face_normals,
};
use points::{point, surface_bias};
pub use program::{FragmentConstants, FragmentStage, ProgramStage, ShaderModules, VertexConstants, VertexStage, VertexTexture};
pub use texture::{LaidOutTextures, MAX_TEXTURE_DIM, Texture};
pub use tileraster_kernels::abi::{Address, Filter, NO_TEXTURE};
pub use tileraster_kernels::programs::deform::DeformLayout;
pub use validate::validate_mesh;
use validate::validate_params;
pub use vector::{multiply, normal_matrix, transform_normal};
use vertex::depth_range;
use vertex::{ClipVertex, Corner, Shaded, VertexStageMemory, flattened};
pub use vertex::{GeometryKernels, MeshPositions, Posing, Positions, light_bytes, pose_origin};
use viewport::{Target, Viewport};

use crate::{Error, Grid, Mode, Outputs, Params, Prepared, RenderInputs, Skips, Window};
use rayon::prelude::*;
use tileraster_kernels::abi::{DepthTest, FaceMaterial, Interpolation, MaterialRecord, TriangleInput, TriangleShading};
use tileraster_kernels::stages::setup::edges_fit_i32;

/// Faces per task of the geometry stages; tasks keep face order.
const CHUNK: usize = 1 << 12;

/// Runs the geometry stages over `mesh`: the prepared scene the kernels rasterise, and what
/// the stages did.
/// `kernels` runs the kernels' geometry stages (the frame's backend).
pub fn prepare_render(mesh: &Mesh, params: &RenderParams, kernels: &mut dyn GeometryKernels) -> Result<(Prepared, GeometryCounts), Error> {
    validate_mesh(mesh)?;
    prepare_checked_mesh(mesh, params, kernels)
}

/// [`prepare_render`] for a mesh [`validate_mesh`] has accepted.
pub fn prepare_checked_mesh(mesh: &Mesh, params: &RenderParams, kernels: &mut dyn GeometryKernels) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_checked_mesh_in(mesh, params, &mut GeometryMemory::default(), kernels)
}

/// The geometry stages' memory, kept between frames: the vertices through the vertex stage and
/// the arrays of the frame's triangles ([`GeometryMemory::recycle`] takes them back from the
/// frame). A frame that reuses it writes into pages already mapped instead of faulting fresh
/// ones in; its bits are the same.
#[derive(Default)]
pub struct GeometryMemory {
    world: Vec<[f64; 3]>,
    vertices: Vec<ClipVertex>,
    corners: Vec<Corner>,
    triangles: Vec<TriangleInput>,
    shading: Vec<TriangleShading>,
    faces: Vec<u32>,
    /// The light stage's colours, where the host keeps them.
    lit: Vec<[f32; 4]>,
    vertex_stage: VertexStageMemory,
    /// The kernels' assembly's attributes of a frame that keeps none (`assemble`).
    attributes: Option<VertexAttributes>,
}

impl GeometryMemory {
    /// Take back the triangle arrays of a frame prepared in this memory.
    pub fn recycle(&mut self, prepared: Prepared) {
        self.triangles = prepared.triangles;
        if let Some(render) = prepared.render {
            self.shading = render.triangles;
            self.faces = render.faces;
        }
    }
}

/// [`prepare_checked_mesh`] in `memory`.
pub fn prepare_checked_mesh_in(
    mesh: &Mesh,
    params: &RenderParams,
    memory: &mut GeometryMemory,
    kernels: &mut dyn GeometryKernels,
) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_instances_in(std::slice::from_ref(mesh), &[Instance::of(0)], params, memory, None, kernels, &mut |_| {})
}

/// What a mesh's frames keep between them for the next: its textures as laid out for the
/// kernels, its positions as the vertex stage takes them (which a backend that keeps them, the
/// GPU, is handed once), and its vertex attributes (and face normals) as the kernels' assembly
/// reads them.
#[derive(Default)]
pub struct KeptMesh {
    textures: Option<LaidOutTextures>,
    positions: Option<MeshPositions>,
    attributes: Option<VertexAttributes>,
    /// The mesh as a vertex shader posed it last, and its pose.
    posed: Option<(vertex::PoseKey, vertex::PosedMesh)>,
}

/// [`prepare_checked_mesh_in`] for a frame of a mesh whose earlier frames left what they keep
/// in `kept`: its textures taken as they are where this frame's filter and address overrides
/// are theirs (else laid out again and kept), its positions as they are, its attributes where
/// made for the same placement. `kept` must hold only this mesh's (a `PreparedMesh` keeps them
/// together).
pub fn prepare_mesh_frame(
    mesh: &Mesh,
    params: &RenderParams,
    memory: &mut GeometryMemory,
    kept: &mut KeptMesh,
    kernels: &mut dyn GeometryKernels,
) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_instances_in(std::slice::from_ref(mesh), &[Instance::of(0)], params, memory, Some(kept), kernels, &mut |_| {})
}

/// `mesh`'s own normals as the vertex shader of `params` poses them for a frame: where the
/// built-in deform program (`VertexStage::DEFORM`) poses a mesh with normals. `None` where the
/// frame computes the normals of its posed faces instead (another shader, or a mesh without
/// normals) or has no vertex shader (the mesh's normals are then its own).
pub fn posed_normals(mesh: &Mesh, params: &RenderParams) -> Option<Vec<[f32; 3]>> {
    vertex::Posing::of(params).and_then(|posing| vertex::posed_normals(mesh, &posing))
}

/// `mesh`'s positions as the vertex shader of `params` poses them for a frame, in `f64` as the
/// host's stages take them (clipping, normals, the culling of instances), or its own where the
/// frame has no vertex shader: the bounds a camera that frames the posed mesh needs.
pub fn posed_positions(mesh: &Mesh, params: &RenderParams) -> Result<Vec<[f64; 3]>, Error> {
    match vertex::Posing::of(params) {
        Some(posing) => vertex::posed_positions(mesh, &posing, None),
        None => Ok(mesh.positions.clone()),
    }
}

/// Runs the geometry stages over every instance of `world`.
pub fn prepare_world(world: &World, params: &RenderParams, kernels: &mut dyn GeometryKernels) -> Result<(Prepared, GeometryCounts), Error> {
    prepare_world_in(world, params, &mut GeometryMemory::default(), kernels)
}

/// [`prepare_world`] in `memory`.
pub fn prepare_world_in(
    world: &World,
    params: &RenderParams,
    memory: &mut GeometryMemory,
    kernels: &mut dyn GeometryKernels,
) -> Result<(Prepared, GeometryCounts), Error> {
    validate_world(&world.meshes, &world.instances)?;
    prepare_instances_in(&world.meshes, &world.instances, params, memory, None, kernels, &mut |_| {})
}

/// The geometry stages' passes, in the order they run, as [`prepare_render_observed`] reports
/// them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum GeometryPass {
    /// The frame's parameters checked, the instances culled and placed, the textures laid out,
    /// the wireframe's edges found.
    Frame,
    /// `vertex`: every placed vertex through the kernels' vertex stage, and its attributes;
    /// where the host assembles the frame, every vertex to clip space in `f64` too (lit there
    /// under Gouraud shading).
    Vertex,
    /// `clip`, `cull` and `viewport` over every face (and line and point), counting what each
    /// chunk puts out: a face that needs no clipping is counted from its corners' 24 bytes each
    /// (`vertex::Corner`), its vertices left unread. Or the kernels' `assemble_count` (which
    /// reads the vertex stage's 20) and the host's clipping of the faces it leaves.
    AssembleCount,
    /// `light`: under Gouraud shading, the kernels' light stage over the frame's vertices
    /// (nothing in other shadings, nor where the host assembles the frame: it lit them above).
    Light,
    /// The same, writing the triangles into their places (the kernels' `assemble_scan` and
    /// `assemble_fill`).
    AssembleFill,
    /// The frame's shade parameters and the kernels' 32-bit check.
    Finish,
}

impl GeometryPass {
    pub const ALL: [GeometryPass; 6] =
        [GeometryPass::Frame, GeometryPass::Vertex, GeometryPass::AssembleCount, GeometryPass::Light, GeometryPass::AssembleFill, GeometryPass::Finish];

    pub fn name(self) -> &'static str {
        match self {
            GeometryPass::Frame => "frame",
            GeometryPass::Vertex => "vertex",
            GeometryPass::AssembleCount => "assemble (count)",
            GeometryPass::Light => "light",
            GeometryPass::AssembleFill => "assemble (fill)",
            GeometryPass::Finish => "finish",
        }
    }
}

/// [`prepare_render`], calling `observe` as each of its passes ends (a caller that times them
/// reads its clock there), in the order of [`GeometryPass::ALL`].
pub fn prepare_render_observed(
    mesh: &Mesh,
    params: &RenderParams,
    kernels: &mut dyn GeometryKernels,
    observe: &mut dyn FnMut(GeometryPass),
) -> Result<(Prepared, GeometryCounts), Error> {
    validate_mesh(mesh)?;
    prepare_instances_in(std::slice::from_ref(mesh), &[Instance::of(0)], params, &mut GeometryMemory::default(), None, kernels, observe)
}

/// The geometry stages over instances of checked meshes (`validate_world`); what an earlier
/// frame of the same mesh kept where `kept` is given.
pub(crate) fn prepare_instances_in(
    meshes: &[Mesh],
    instances: &[Instance],
    params: &RenderParams,
    memory: &mut GeometryMemory,
    mut kept: Option<&mut KeptMesh>,
    kernels: &mut dyn GeometryKernels,
    observe: &mut dyn FnMut(GeometryPass),
) -> Result<(Prepared, GeometryCounts), Error> {
    validate_params(params)?;
    let (w, h) = (params.width, params.height);
    let m = &params.view_projection;
    let lighting = Lighting::of(params)?;
    let viewport = Viewport::new(w, h);
    let mut placed = vec![false; meshes.len()];
    instances.iter().for_each(|i| placed[i.mesh as usize] = true);

    // A vertex shader poses each placed mesh in its own coordinates (`vertex::posed_meshes`;
    // the kernels' vertex stage poses a mesh drawn once with the same function).
    let posing = vertex::Posing::of(params);
    // A one-shot frame of one posed mesh computes the mesh's pairs once, for the host's pose
    // and the vertex stage (a prepared mesh keeps its own).
    let mut one_shot: Option<MeshPositions> = None;
    let single = instances.len() == 1;
    let one_shot_pairs = (kept.is_none() && single && posing.is_some()).then_some(&mut one_shot);
    let posed = vertex::posed_meshes(meshes, &placed, posing.as_ref(), kept.as_deref_mut().filter(|_| single), one_shot_pairs)?;
    let drawn_positions = |k: usize| posed.get(k).and_then(|p| p.as_deref()).map_or(&meshes[k].positions[..], |p| &p.positions[..]);

    // Object culling: instances whose bounding box lies outside the view frustum get no vertex
    // work (`instances`: it changes no bit).
    let mut counts = GeometryCounts::default();
    let bounds: Vec<Option<[[f64; 3]; 2]>> = if params.skips.cull_instances && instances.len() > 1 {
        (0..meshes.len()).into_par_iter().map(|k| placed[k].then(|| instances::bounds(drawn_positions(k)))).collect()
    } else {
        Vec::new()
    };
    // The frame's textures: every placed mesh's, once.
    let mut first_textures = vec![0u32; meshes.len()];
    let mut textures: Vec<&Texture> = Vec::new();
    for (k, mesh) in meshes.iter().enumerate().filter(|(k, _)| placed[*k]) {
        first_textures[k] = textures.len() as u32;
        textures.extend(mesh.textures.iter());
    }
    let laid_out = LaidOutTextures::of(&textures, params.texture_filter, params.texture_address, kept.as_deref().and_then(|k| k.textures.as_ref()))?;
    if let Some(kept) = kept.as_deref_mut() {
        kept.textures = Some(laid_out.clone());
    }
    let LaidOutTextures { infos: texture_infos, texels, .. } = laid_out;
    // The frame's materials: its own surface (for meshes without materials), then every placed
    // mesh's, once.
    let mut first_materials = vec![0u32; meshes.len()];
    let mut materials = vec![plain_record(params)];
    for (k, mesh) in meshes.iter().enumerate().filter(|(k, _)| placed[*k] && !meshes[*k].materials.is_empty()) {
        first_materials[k] = materials.len() as u32;
        materials.extend(mesh.materials.iter().map(|m| m.record(first_textures[k])));
    }
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
            let (first_texture, first_material) = (first_textures[instance.mesh as usize], first_materials[instance.mesh as usize]);
            placements.push(Placement {
                mesh,
                mesh_index: instance.mesh as usize,
                positions: drawn_positions(instance.mesh as usize),
                normals: match posing {
                    None => mesh.normals.as_deref(),
                    Some(_) => posed.get(instance.mesh as usize).and_then(|p| p.as_deref()).and_then(|p| p.normals.as_deref()),
                },
                to_world,
                mirrored: instances::mirrors(&instance.transform),
                first_vertex,
                first_face,
                first_texture,
                first_material,
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

    // A fragment shader takes the vertex attributes as they are (no lighting on the host).
    let shading = if params.fragment.is_some() { Shading::Unlit } else { params.shading };
    observe(GeometryPass::Frame);
    // The kernels assemble the faces of a frame that lets them (`assemble`), unless its matrix
    // lies beyond the vertex stage's range; the host's path takes the rest.
    let kernel_stage = match assemble::assembles(params) {
        true => vertex::project_for_assembly(
            &placements,
            instances.len() == 1,
            first_vertex,
            m,
            &viewport,
            &mut memory.world,
            &mut memory.vertex_stage,
            kept.as_deref_mut().map(|k| &mut k.positions).or(one_shot.is_some().then_some(&mut one_shot)),
            posing.as_ref(),
            kernels,
        )?,
        false => None,
    };
    let mut mesh_faces = Vec::new();
    match kernel_stage {
        Some(bytes) => {
            counts.bytes_uploaded = bytes;
            // A prepared mesh's faces are the same in each of its frames: kept by its positions'.
            let faces_key = kept.as_deref().and_then(|k| k.positions.as_ref()).filter(|_| placements.len() == 1).map(MeshPositions::key);
            let (slot, keeps) = match kept {
                // (A posed mesh's attributes are kept for as long as its pose is the same.)
                Some(k) if placements.len() == 1 => (&mut k.attributes, true),
                _ => (&mut memory.attributes, false),
            };
            let attributes = VertexAttributes::of(&placements, first_vertex, shading, &lighting, posing.as_ref(), slot, keeps);
            let projected = memory.vertex_stage.projected();
            let kept_inputs = KeptInputs { faces: faces_key, attributes: Some(attributes.key) };
            let mut first_face_normal = 0;
            mesh_faces = placements
                .iter()
                .map(|p| {
                    let normals = attributes.normals_of(p.first_vertex, p.mesh.positions.len());
                    let first = first_face_normal;
                    if !attributes.face_normals.is_empty() {
                        first_face_normal += p.mesh.triangles.len() as u32;
                    }
                    let material = mesh_material(p.mesh);
                    MeshFaces {
                        placement: p,
                        material,
                        face_materials: match material {
                            Some(_) => Vec::new(),
                            None => (0..p.mesh.triangles.len()).map(|k| mesh_face_material(p.mesh, k)).collect(),
                        },
                        projected,
                        attributes: &attributes.values,
                        face_normals: &attributes.face_normals,
                        first_face_normal: first,
                        kept: kept_inputs,
                        flat: params.interpolation == Interpolation::Flat,
                        shaded: Shaded { mesh: p.mesh, normals, shading, lighting: &lighting },
                        view_projection: m,
                    }
                })
                .collect();
        }
        None => {
            counts.bytes_uploaded = vertex::transform_vertices(
                &placements,
                first_vertex,
                &params.view_projection,
                shading,
                &lighting,
                &viewport,
                &mut memory.world,
                &mut memory.vertices,
                &mut memory.vertex_stage,
                instances.len() == 1,
                kept.map(|k| &mut k.positions).or(one_shot.is_some().then_some(&mut one_shot)),
                posing.as_ref(),
                kernels,
            )?;
            memory.vertices.par_iter().map(Corner::of).collect_into_vec(&mut memory.corners);
        }
    }
    // (The kernels' assembly reads no vertex in `f64`: the arrays the host's path keeps hold
    // an earlier frame's.)
    let (world, vertices, corners) = match kernel_stage {
        Some(_) => (&[][..], &[][..], &[][..]),
        None => (&memory.world[..], &memory.vertices[..], &memory.corners[..]),
    };
    observe(GeometryPass::Vertex);

    let grid = Grid::new(0.0, w as f64, 0.0, h as f64, w, h);
    let target = Target::new(&grid, params);
    // The faces in chunks of at most `CHUNK` of one instance each, in drawing order, then the
    // lines and the points likewise.
    let face_chunks = placements
        .iter()
        .filter(|_| params.faces && kernel_stage.is_none())
        .flat_map(|p| (0..p.mesh.triangles.len()).step_by(CHUNK).map(move |start| (p, start, Work::Faces)));
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
        if let Work::Points = work {
            let size = params.points.expect("point chunks only with points");
            for v in start..(start + CHUNK).min(p.mesh.positions.len()) {
                let bias = point_bias.get(p.first_vertex + v).copied().unwrap_or(0.0);
                point(
                    &vertices[p.first_vertex + v],
                    size,
                    bias,
                    FaceTag { id: p.first_point + v as u32, material: FaceMaterial::plain(NO_TEXTURE, 0) },
                    &target,
                    emit,
                    counts,
                );
            }
            return;
        }
        let mesh = p.mesh;
        let end = (start + CHUNK).min(mesh.triangles.len());
        let faces = &mesh.triangles[start..end];
        for (k, tri) in faces.iter().enumerate() {
            let face = p.first_face + (start + k) as u32;
            let tri = if p.mirrored { [tri[0], tri[2], tri[1]] } else { *tri };
            let tri = tri.map(|v| p.first_vertex + v as usize);
            let mut vertex = tri.map(|v| &vertices[v]);
            // Flat modes give every corner (and so every clipped piece) one set of values
            // (attributes only: counting needs none of it). Flat shading lights the face with
            // its normal at its first vertex, in that vertex's colour.
            let counting = emit.counting();
            let light = (!counting && shading == Shading::Flat).then(|| {
                let base = mesh.colours.as_ref().map_or(GREY, |c| c[tri[0] - p.first_vertex]).map(f64::from);
                lighting.light_face(base, tri.map(|v| world[v]))
            });
            let flat_corners;
            if let Some(corners) = flattened(vertex, !counting && params.interpolation == Interpolation::Flat, light.as_ref()) {
                flat_corners = corners;
                vertex = flat_corners.each_ref();
            }
            let material = face_material(mesh, start + k, p.first_texture, p.first_material);
            geometry(tri.map(|v| &corners[v]), vertex, FaceTag { id: face, material }, &viewport, &target, emit, counts);
        }
    };
    let (triangles, shading, faces, small_edges, records_held) = match kernel_stage {
        Some(_) => {
            // The plan lists small triangles apart in a single-sample depth-tested frame that
            // does not blend and counts no tile's triangles (`Prepared::splits_small_triangles`).
            let split_small = params.skips.small_triangles && params.samples == 1 && !params.blend && !params.count_tiles;
            let spare = AssembledFrame {
                triangles: std::mem::take(&mut memory.triangles),
                shading: std::mem::take(&mut memory.shading),
                faces: std::mem::take(&mut memory.faces),
                lit: std::mem::take(&mut memory.lit),
                held: None,
            };
            let mut frame = assemble::assemble_frame(&mesh_faces, split_small, &viewport, &target, kernels, spare, &mut counts, observe)?;
            memory.lit = std::mem::take(&mut frame.lit);
            let small_edges = frame.triangles.par_iter().all(|t| edges_fit_i32(t, RENDER_SNAP_BITS));
            counts.rasterised = frame.triangles.len() as u64;
            (frame.triangles, frame.shading, frame.faces, small_edges, frame.held)
        }
        None => {
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
            observe(GeometryPass::AssembleCount);
            observe(GeometryPass::Light);
            counts = counted.iter().fold(counts, |sum, p| sum.add(p.1));
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
            let mut faces = crate::raster::reuse_cells(Some(std::mem::take(&mut memory.faces)), total).map_err(out_of_memory)?;
            let mut parts = Vec::with_capacity(counted.len());
            let (mut rest_t, mut rest_s, mut rest_f, mut first_slot) = (&mut triangles[..], &mut shading[..], &mut faces[..], 0);
            for &(n, _) in &counted {
                let (t, tail_t) = rest_t.split_at_mut(n);
                let (s, tail_s) = rest_s.split_at_mut(n);
                let (f, tail_f) = rest_f.split_at_mut(n);
                parts.push(Emit::Fill { triangles: t, shading: s, faces: f, next: 0, first_slot, small_edges: true });
                (rest_t, rest_s, rest_f, first_slot) = (tail_t, tail_s, tail_f, first_slot + n);
            }
            // (Folded with `reduce`, which fills every chunk, where `all` would stop at the first false.)
            let small_edges = chunks
                .par_iter()
                .enumerate()
                .zip(parts)
                .map(|((c, piece), mut emit)| {
                    chunk(piece, &mut emit, &mut GeometryCounts::default());
                    debug_assert_eq!(emit.count(), counted[c].0, "the filling pass puts what the counting pass counted");
                    emit.small_edges()
                })
                .reduce(|| true, |a, b| a && b);
            counts.rasterised = total as u64;
            (triangles, shading, faces, small_edges, None)
        }
    };
    observe(GeometryPass::AssembleFill);
    let depths = match kernel_stage {
        Some(_) => vertex::projected_depth_range(memory.vertex_stage.projected()),
        None => depth_range(vertices),
    };
    let mut shade = lighting.shade_params(depths);
    shade.textured = u32::from(!texture_infos.is_empty());
    // Whether the stages may take every edge function in 32-bit arithmetic.
    shade.small_edges = u32::from(small_edges);
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
            faces,
            params: shade,
            depth_test: DepthTest::new(params.depth_func, params.depth_write),
            textures: texture_infos,
            texels,
            texels_resident: false,
            materials,
            records_held,
            fragment: params.fragment,
            returns_colour: params.return_colour,
            returns_depth: params.return_depth,
        }),
    };
    observe(GeometryPass::Finish);
    Ok((prepared, counts))
}

/// Face `k`'s surface, its texture and material indices into the mesh's (a mesh without
/// materials takes the frame's own, 0, single-sided, its alpha kept and lit).
fn mesh_face_material(mesh: &Mesh, k: usize) -> FaceMaterial {
    let texture = match &mesh.face_textures {
        Some(t) => t[k],
        None if mesh.textures.is_empty() => NO_TEXTURE,
        None => 0,
    };
    match mesh.materials.is_empty() {
        true => FaceMaterial::plain(texture, 0),
        false => {
            let material = mesh.face_materials.as_ref().map_or(0, |m| m[k]);
            FaceMaterial { material, ..mesh.materials[material as usize].face_material(texture) }
        }
    }
}

/// Face `k`'s surface, its texture and material the frame's (its mesh's start at
/// `first_texture` and `first_material`).
fn face_material(mesh: &Mesh, k: usize, first_texture: u32, first_material: u32) -> FaceMaterial {
    mesh_face_material(mesh, k).placed(first_texture, first_material)
}

/// The surface of every face of `mesh` where they are alike (`None` where each face needs its
/// own: the mesh names its faces' textures or materials), its indices into the mesh's.
fn mesh_material(mesh: &Mesh) -> Option<FaceMaterial> {
    let alike = mesh.face_textures.is_none() && (mesh.face_materials.is_none() || mesh.materials.len() <= 1);
    alike.then(|| match mesh.triangles.is_empty() {
        true => FaceMaterial::plain(NO_TEXTURE, 0),
        false => mesh_face_material(mesh, 0),
    })
}

/// The frame's own material, which meshes without materials take: its metallic and roughness.
fn plain_record(params: &RenderParams) -> MaterialRecord {
    MaterialRecord { metallic: params.metallic as f32, roughness: params.roughness as f32, ..Default::default() }
}

/// What a chunk of the geometry stages takes.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Work {
    Faces,
    Lines,
    Points,
}
