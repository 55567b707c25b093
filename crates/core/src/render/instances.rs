//! Instances: placements of meshes in the world, each culled against the view frustum by its
//! bounding box before any vertex work.
//!
//! An instance is culled only where every vertex it has would be culled anyway: its mesh's
//! bounding box, carried to clip space corner by corner, lies wholly outside one plane of the
//! view frustum (the planes the geometry stages cull whole faces by), by a margin far above the
//! rounding of the vertex stage. The box holds every vertex, and the plane tests are affine,
//! so every face of the instance would be culled by that plane, one by one. The culling changes
//! no bit of a frame; it only saves the vertex work, and `GeometryCounts::instances_culled`
//! counts it.

use super::params::{IDENTITY, Material, Mesh};
use super::vector::multiply;
use crate::Error;
use rayon::prelude::*;
use tileraster_kernels::abi::NO_TEXTURE;

/// One placement of a mesh. A mirroring placement (a transform of negative determinant) keeps
/// the mesh's front faces in front: its faces are taken with their last two corners swapped,
/// as glTF specifies for mirrored nodes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Instance {
    /// Index of the mesh in [`World::meshes`].
    pub mesh: u32,
    /// The mesh's coordinates to the world, row-major (affine); `RenderParams::model` applies
    /// after it.
    pub transform: [[f64; 4]; 4],
}

impl Instance {
    /// Mesh `mesh` where it is.
    pub fn of(mesh: u32) -> Instance {
        Instance { mesh, transform: IDENTITY }
    }
}

/// Meshes and their placements, drawn instance by instance in order (each instance's faces in
/// the mesh's order). A frame's face ids number the faces of every instance in that order, as
/// if the instances were one mesh: instance `k`'s faces start after those of instances `0..k`.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct World {
    pub meshes: Vec<Mesh>,
    pub instances: Vec<Instance>,
}

impl World {
    /// `mesh`, once where it is.
    pub fn single(mesh: Mesh) -> World {
        World { meshes: vec![mesh], instances: vec![Instance::of(0)] }
    }

    /// `mesh` placed by each of `transforms`.
    pub fn instanced(mesh: Mesh, transforms: &[[[f64; 4]; 4]]) -> World {
        World { meshes: vec![mesh], instances: transforms.iter().map(|&transform| Instance { mesh: 0, transform }).collect() }
    }

    /// Which instances the object culling keeps for a frame of `params`: those whose bounding
    /// box does not lie wholly outside the view frustum.
    pub fn in_view(&self, params: &super::params::RenderParams) -> Result<Vec<bool>, Error> {
        validate_world(&self.meshes, &self.instances)?;
        let boxes: Vec<[[f64; 3]; 2]> = self.meshes.iter().map(bounding_box).collect();
        Ok(self.instances.iter().map(|i| !outside_frustum(&boxes[i.mesh as usize], &instance_to_world(&params.model, i), &params.view_projection)).collect())
    }

    /// A box holding every instance in the world: each mesh's bounding box carried by its
    /// instances' transforms, corner by corner (exact for a mesh where it is).
    pub fn bounds(&self) -> Result<[[f64; 3]; 2], Error> {
        validate_world(&self.meshes, &self.instances)?;
        let boxes: Vec<[[f64; 3]; 2]> = self.meshes.iter().map(bounding_box).collect();
        let mut out = [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
        for instance in &self.instances {
            let b = &boxes[instance.mesh as usize];
            for k in 0..8 {
                let corner: [f64; 3] = std::array::from_fn(|a| b[k >> a & 1][a]);
                let p = if instance.transform == IDENTITY { corner } else { transform_point(&instance.transform, &corner) };
                for a in 0..3 {
                    out[0][a] = out[0][a].min(p[a]);
                    out[1][a] = out[1][a].max(p[a]);
                }
            }
        }
        Ok(out)
    }

    /// Every instance's faces as one mesh in world coordinates, as the frame numbers them (for
    /// tests and for readers that want the world flattened): positions and normals are the
    /// instances' transforms applied as the vertex stage applies them (normals computed in the
    /// mesh's coordinates where it has none); the placed meshes' textures once each, in mesh
    /// order, as a frame lists them.
    pub fn flattened(&self) -> Result<Mesh, Error> {
        validate_world(&self.meshes, &self.instances)?;
        let mut out = Mesh::default();
        let mut placed = vec![false; self.meshes.len()];
        self.instances.iter().for_each(|i| placed[i.mesh as usize] = true);
        let mut first_texture = vec![0u32; self.meshes.len()];
        for (k, mesh) in self.meshes.iter().enumerate().filter(|(k, _)| placed[*k]) {
            first_texture[k] = out.textures.len() as u32;
            out.textures.extend(mesh.textures.iter().cloned());
        }
        let mut face_textures = Vec::new();
        // The placed meshes' materials once each, as their textures; a mesh without takes the
        // default frame's surface where another has materials.
        let with_materials = self.instances.iter().any(|i| !self.meshes[i.mesh as usize].materials.is_empty());
        let mut first_material = vec![0u32; self.meshes.len()];
        for (k, mesh) in self.meshes.iter().enumerate().filter(|(k, _)| placed[*k] && with_materials) {
            first_material[k] = out.materials.len() as u32;
            let moved = |t: Option<u32>| t.map(|t| first_texture[k] + t);
            out.materials.extend(if mesh.materials.is_empty() { &[Material::PLAIN][..] } else { &mesh.materials[..] }.iter().map(|m| Material {
                metallic_roughness_texture: moved(m.metallic_roughness_texture),
                occlusion_texture: moved(m.occlusion_texture),
                emissive_texture: moved(m.emissive_texture),
                ..*m
            }));
        }
        let mut face_materials = Vec::new();
        let any = |f: fn(&Mesh) -> bool| self.instances.iter().any(|i| f(&self.meshes[i.mesh as usize]));
        let (colours, uvs) = (any(|m| m.colours.is_some()), any(|m| m.uvs.is_some()));
        let (mut n, mut c, mut t) = (Vec::new(), Vec::new(), Vec::new());
        for instance in &self.instances {
            let mesh = &self.meshes[instance.mesh as usize];
            let base = out.positions.len() as u32;
            out.positions.extend(mesh.positions.iter().map(|p| transform_point(&instance.transform, p)));
            let mirrored = mirrors(&instance.transform);
            out.triangles.extend(mesh.triangles.iter().map(|&[a, b, c]| if mirrored { [a, c, b] } else { [a, b, c] }.map(|v| v + base)));
            let count = mesh.positions.len();
            let base_texture = first_texture[instance.mesh as usize];
            match &mesh.face_textures {
                Some(f) => face_textures.extend(f.iter().map(|&t| if t == NO_TEXTURE { t } else { base_texture + t })),
                None => face_textures.extend(std::iter::repeat_n(if mesh.textures.is_empty() { NO_TEXTURE } else { base_texture }, mesh.triangles.len())),
            }
            let base_material = first_material[instance.mesh as usize];
            match &mesh.face_materials {
                Some(f) => face_materials.extend(f.iter().map(|&m| base_material + m)),
                None => face_materials.extend(std::iter::repeat_n(base_material, mesh.triangles.len())),
            }
            // As the vertex stage turns them: the mesh's normals, or its face normals, by the
            // instance's normal matrix (unchanged where the instance is where its mesh is).
            let computed;
            let normals = match &mesh.normals {
                Some(v) => v,
                None => {
                    computed = super::params::face_normals(mesh);
                    &computed
                }
            };
            if instance.transform == IDENTITY {
                n.extend_from_slice(normals);
            } else {
                let m = super::vector::normal_matrix(&instance.transform);
                n.extend(normals.iter().map(|&x| super::vector::transform_normal(&m, x)));
            }
            if colours {
                c.extend(mesh.colours.clone().unwrap_or_else(|| vec![super::params::GREY; count]));
            }
            if uvs {
                t.extend(mesh.uvs.clone().unwrap_or_else(|| vec![[0.0; 2]; count]));
            }
        }
        out.normals = Some(n);
        out.colours = colours.then_some(c);
        out.uvs = uvs.then_some(t);
        out.face_textures = (!out.textures.is_empty()).then_some(face_textures);
        out.face_materials = with_materials.then_some(face_materials);
        Ok(out)
    }
}

/// Whether affine `m` mirrors: its linear part's determinant is negative.
pub(super) fn mirrors(m: &[[f64; 4]; 4]) -> bool {
    let det = m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
        + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    det < 0.0
}

/// `m · (p, 1)`, as the vertex stage computes it.
#[inline]
pub(super) fn transform_point(m: &[[f64; 4]; 4], p: &[f64; 3]) -> [f64; 3] {
    std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3])
}

/// An instance's transform to the world: `model` after the instance's own (exactly either one
/// where the other is the identity).
pub(super) fn instance_to_world(model: &[[f64; 4]; 4], instance: &Instance) -> [[f64; 4]; 4] {
    match (instance.transform == IDENTITY, *model == IDENTITY) {
        (true, _) => *model,
        (false, true) => instance.transform,
        (false, false) => multiply(model, &instance.transform),
    }
}

/// The smallest box holding a mesh's positions: `[min, max]`.
pub(super) fn bounding_box(mesh: &Mesh) -> [[f64; 3]; 2] {
    bounds(&mesh.positions)
}

/// The smallest box holding `points`, `[min, max]` (infinite and empty for none), on all cores
/// (minima and maxima are exact: any order gives the same box).
pub(super) fn bounds(points: &[[f64; 3]]) -> [[f64; 3]; 2] {
    let join = |[lo, hi]: [[f64; 3]; 2], [l, h]: [[f64; 3]; 2]| [std::array::from_fn(|k| lo[k].min(l[k])), std::array::from_fn(|k| hi[k].max(h[k]))];
    let empty = || [[f64::INFINITY; 3], [f64::NEG_INFINITY; 3]];
    points.par_iter().fold(empty, |b, p| join(b, [*p, *p])).reduce(empty, join)
}

/// Whether a mesh of bounding box `bounds`, placed by `to_world` and seen through
/// `view_projection`, lies wholly outside one plane of the view frustum.
pub(super) fn outside_frustum(bounds: &[[f64; 3]; 2], to_world: &[[f64; 4]; 4], view_projection: &[[f64; 4]; 4]) -> bool {
    let norm = |m: &[[f64; 4]; 4]| m.iter().flatten().fold(0.0f64, |a, v| a.max(v.abs()));
    let mut clip = [[0.0f64; 4]; 8];
    let mut size = 0.0f64;
    for (k, c) in clip.iter_mut().enumerate() {
        let corner = std::array::from_fn(|a| bounds[k >> a & 1][a]);
        let world = transform_point(to_world, &corner);
        *c = std::array::from_fn(|r| {
            view_projection[r][0] * world[0] + view_projection[r][1] * world[1] + view_projection[r][2] * world[2] + view_projection[r][3]
        });
        size = size.max(corner.iter().fold(1.0f64, |a, v| a.max(v.abs())));
    }
    // Every vertex's clip coordinates are within a few units in the last place of this size of
    // their exact values; the margin is far above that.
    let margin = 1e-9 * 16.0 * norm(view_projection) * (4.0 * norm(to_world) * size);
    let planes: [fn(&[f64; 4]) -> f64; 6] = [|c| -(c[0] + c[3]), |c| c[0] - c[3], |c| -(c[1] + c[3]), |c| c[1] - c[3], |c| -c[2], |c| c[2] - c[3]];
    planes.iter().any(|beyond| clip.iter().all(|c| beyond(c) > margin))
}

/// Checks a world: meshes valid, instances naming one, transforms finite, face ids within `u32`.
pub(super) fn validate_world(meshes: &[Mesh], instances: &[Instance]) -> Result<(), Error> {
    if instances.is_empty() {
        return Err(Error::EmptyScene { what: "instances" });
    }
    for mesh in meshes {
        super::validate::validate_mesh(mesh)?;
    }
    let mut faces = 0u64;
    for (k, instance) in instances.iter().enumerate() {
        let invalid = |reason: String| Err(Error::InvalidInstance { instance: k, reason });
        let Some(mesh) = meshes.get(instance.mesh as usize) else {
            return invalid(format!("it places mesh {}, but the world has {} meshes (0..{})", instance.mesh, meshes.len(), meshes.len()));
        };
        let t = &instance.transform;
        if let Some((r, c)) = (0..16).map(|k| (k / 4, k % 4)).find(|&(r, c)| !t[r][c].is_finite()) {
            return invalid(format!("its transform has a non-finite entry at row {r}, column {c} ({}); every entry must be a finite number", t[r][c]));
        }
        if t[3] != [0.0, 0.0, 0.0, 1.0] {
            return invalid(format!("its transform's last row is {:?}; a placement is affine: make its last row 0, 0, 0, 1", t[3]));
        }
        faces += mesh.triangles.len() as u64;
    }
    if faces >= u32::MAX as u64 {
        return Err(Error::TooManyFaces { faces });
    }
    Ok(())
}

/// A visible instance as the geometry stages take it.
pub(super) struct Placement<'a> {
    /// Its mesh, and where the world lists it.
    pub(super) mesh: &'a Mesh,
    pub(super) mesh_index: usize,
    /// The mesh's positions as the frame draws them: its own, or as the frame's vertex shader
    /// posed them (`vertex::posed_positions`).
    pub(super) positions: &'a [[f64; 3]],
    /// The mesh's own normals where they are the drawn surface's: as they are, or as the
    /// built-in deform program posed them (`vertex::Posed`). None where it has none or another
    /// vertex shader posed it: the frame computes them from the drawn faces.
    pub(super) normals: Option<&'a [[f32; 3]]>,
    pub(super) to_world: [[f64; 4]; 4],
    /// Whether the instance's own transform mirrors (its faces are taken the other way round).
    pub(super) mirrored: bool,
    /// Its first vertex in the frame's vertex arrays.
    pub(super) first_vertex: usize,
    /// The id of its first face.
    pub(super) first_face: u32,
    /// Its mesh's first texture in the frame's textures, and first material in its materials
    /// (0, the frame's own, for a mesh without).
    pub(super) first_texture: u32,
    pub(super) first_material: u32,
    /// The id of its first vertex's point: after every instance's faces, vertices numbered
    /// over every instance in order.
    pub(super) first_point: u32,
    /// The id of its first edge's line: after every instance's points, edges numbered over
    /// every instance in order.
    pub(super) first_line: u32,
}
