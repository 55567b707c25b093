//! The kernels' assembly of a frame's faces (`stages::assemble::assemble_face`), for a frame
//! that draws faces alone: what happens to a face (culled wholly outside the frustum, for zero
//! area, by facing, for having no pixel centre; kept; clipped) is decided by the vertex stage's
//! bits alone, and a kept face's records come from its corners as the stage projected them and
//! its vertices' attributes in `f32` (lit on the host in `f64` per vertex for Gouraud shading
//! and per face for flat shading, as the host's path lights them). No vertex is computed in
//! `f64` but the corners of the faces the stage leaves to the host's clipping
//! (`CLIPPED_ON_HOST`), and those take the stage's word for every corner it projected, so that
//! a vertex shared by a kept face and a clipped one lies where both say. These are the
//! decisions and records the device's assembly stages will make; here the host runs them, on
//! the stage's output.

use super::clip::geometry;
use super::cull::count_dropped;
use super::emit::{Emit, FaceTag};
use super::instances::{Placement, transform_point};
use super::lighting::{FaceLight, Lighting};
use super::params::{GREY, GeometryCounts, IDENTITY, RenderParams, Shading};
use super::vertex::{ClipVertex, Corner, Projected, Shaded, computed_normals, flattened, placed_normals};
use super::viewport::{Target, Viewport};
use rayon::prelude::*;
use tileraster_kernels::abi::{ATTRIBUTES, ProjectedVertex};
use tileraster_kernels::stages::assemble::{CLIPPED_ON_HOST, DROPPED_FRUSTUM, KEPT, assemble_face, triangle_records};
use tileraster_kernels::stages::vertex::UNASSEMBLED;

/// Whether the kernels assemble a frame's faces: faces alone (the wireframe and vertices views
/// take their vertices in `f64`).
pub(super) fn assembles(params: &RenderParams) -> bool {
    params.faces && params.wireframe.is_none() && params.points.is_none()
}

/// The visible instances' vertex attributes in `f32`, one after the other in the placements'
/// order, as the kernels' assembly reads them, and their normals in the world (for the corners
/// the host clips): the same for every frame of one mesh at one placement, so a prepared mesh
/// keeps them, unless they are lit per vertex (Gouraud shading: lit afresh every frame, for its
/// viewer and lights).
pub(super) struct VertexAttributes {
    /// The placement they were made for (a prepared mesh's one), whether any is read (none:
    /// both empty), and whether they were lit.
    to_world: [[f64; 4]; 4],
    used: bool,
    lit: bool,
    pub(super) normals: Vec<[f32; 3]>,
    pub(super) values: Vec<[f32; ATTRIBUTES]>,
}

impl VertexAttributes {
    /// The attributes of the instances `placements` (`count` vertices) for `shading`, in `slot`:
    /// where it `keeps` a prepared mesh's (one placement), as they are if made for the same
    /// placement; else made afresh in the slot's arrays (whose pages a frame that reuses its
    /// memory has mapped already).
    pub(super) fn of<'a>(
        placements: &[Placement],
        count: usize,
        shading: Shading,
        lighting: &Lighting,
        slot: &'a mut Option<VertexAttributes>,
        keeps: bool,
    ) -> &'a VertexAttributes {
        let (used, lit) = (shading.reads_attributes(), shading == Shading::Smooth);
        let to_world = match placements {
            [only] => only.to_world,
            _ => IDENTITY,
        };
        let same = |k: &VertexAttributes| keeps && placements.len() == 1 && k.to_world == to_world && k.used == used && !k.lit;
        if lit || !slot.as_ref().is_some_and(same) {
            let (mut normals, mut values) = slot.take().map_or_else(Default::default, |k| (k.normals, k.values));
            normals.clear();
            values.clear();
            if used {
                let computed = computed_normals(placements);
                normals.reserve_exact(count);
                values.reserve_exact(count);
                for p in placements {
                    let turned = placed_normals(p, &computed);
                    let shaded = Shaded { mesh: p.mesh, normals: &turned, shading, lighting };
                    let positions = p.mesh.positions.par_iter().enumerate();
                    values.par_extend(positions.map(|(v, q)| shaded.attributes(v, transform_point(&p.to_world, q)).map(|a| a as f32)));
                    normals.extend_from_slice(&turned);
                }
            }
            *slot = Some(VertexAttributes { to_world, used, lit, normals, values });
        }
        slot.as_ref().expect("made above")
    }

    /// The attributes and normals of the placement whose vertices start at `first` (of `n`);
    /// empty where none is read.
    pub(super) fn of_placement(&self, first: usize, n: usize) -> (&[[f32; ATTRIBUTES]], &[[f32; 3]]) {
        if self.used { (&self.values[first..first + n], &self.normals[first..first + n]) } else { (&[], &[]) }
    }
}

/// A mesh's faces as the kernels assemble them.
pub(super) struct MeshFaces<'a> {
    pub(super) placement: &'a Placement<'a>,
    /// The mesh's vertices through the vertex stage.
    pub(super) projected: &'a [ProjectedVertex],
    /// Their attributes in `f32` (empty where none is read).
    pub(super) attributes: &'a [[f32; ATTRIBUTES]],
    /// Flat interpolation: every corner takes the face's first vertex's attributes.
    pub(super) flat: bool,
    /// What the host's clipping computes a corner from: the attributes' recipe and the frame's
    /// matrix.
    pub(super) shaded: Shaded<'a>,
    pub(super) view_projection: &'a [[f64; 4]; 4],
}

impl MeshFaces<'_> {
    /// Face `k` of the mesh (tagged `tag`): culled and counted, kept and put, or clipped on the host.
    pub(super) fn face(&self, k: usize, tag: FaceTag, viewport: &Viewport, target: &Target, emit: &mut Emit<'_>, counts: &mut GeometryCounts) {
        let tri = self.placement.mesh.triangles[k];
        let tri = if self.placement.mirrored { [tri[0], tri[2], tri[1]] } else { tri }.map(|v| v as usize);
        let corners = tri.map(|v| self.projected[v]);
        let t = assemble_face(corners, &target.assembly);
        match t.dropped {
            KEPT => emit.put(|| {
                let attributes = |v: usize| if self.attributes.is_empty() { [0.0; ATTRIBUTES] } else { self.attributes[v] };
                let mut attributes = if self.flat { [attributes(tri[0]); 3] } else { tri.map(attributes) };
                if let Some(light) = self.face_light(tri) {
                    attributes.iter_mut().for_each(|a| light.apply_f32(a));
                }
                triangle_records(&t, &corners.map(|c| c.depth), &corners.map(|c| c.inverse_w), &attributes, tag.id, tag.texture)
            }),
            DROPPED_FRUSTUM => counts.culled_frustum += 1,
            CLIPPED_ON_HOST => self.clip_on_host(tri, tag, viewport, target, emit, counts),
            dropped => count_dropped(dropped, counts),
        }
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
        let q = tri.map(|v| transform_point(&p.to_world, &p.mesh.positions[v]));
        let base = p.mesh.colours.as_ref().map_or(GREY, |c| c[tri[0]]).map(f64::from);
        Some(self.shaded.lighting.light_face(base, q))
    }

    /// Vertex `v` in `f64` for the host's clipping, taken as the vertex stage took it: where the
    /// stage projected it for the assembly, onto the clipping planes it may lie a rounding
    /// beyond (so the clipping keeps it whole) with the stage's values; where not, projected
    /// on the host if it lies inside the planes.
    fn corner(&self, v: usize, viewport: &Viewport) -> ClipVertex {
        let p = self.placement;
        let world = transform_point(&p.to_world, &p.mesh.positions[v]);
        let mut c = self.shaded.clip_vertex(v, world, self.view_projection, viewport);
        let k = &self.projected[v];
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
