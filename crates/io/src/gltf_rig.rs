//! A glTF file's meshes at rest with what poses them, for the kernels' built-in deform program
//! (`VertexStage::DEFORM`, `programs::deform`): the vertex texture of joint matrices, morph
//! weights and per-vertex joints, weights and morph offsets, laid out as
//! `DeformLayout` says.
//!
//! Every node that places a mesh adds joints to the texture's table: its skin's joint matrices
//! in the pose, or (without a skin) its own world transform, which its vertices follow with
//! weight 1. Its morph weights in the pose are a row of the weight table. The pose is the
//! reader's (`gltf_pose`), in `f64`; each matrix has the mesh's origin folded in before it is
//! rounded to `f32`.

use crate::gltf_pose::Matrix;
use tileraster_core::render::{DeformLayout, Mesh, VertexConstants, VertexTexture, pose_origin};

/// A glTF file's meshes as one mesh at rest, with the vertex texture and constants that pose it
/// in the kernels' vertex stage (`VertexStage::DEFORM`) as [`read_gltf`](crate::read_gltf)
/// poses it on the host.
pub struct PosableGltf {
    /// Each vertex where its glTF mesh has it, before morph targets, skin and node transform,
    /// its normal likewise; faces turned as the pose read turns them (a mirroring joint or node
    /// swaps two corners, as `read_gltf` does).
    pub mesh: Mesh,
    /// The pose: joints, morph weights and each vertex's joints, weights and offsets.
    pub texture: VertexTexture,
    /// Where the program finds them in the texture (`DeformLayout::constants`), for
    /// `RenderParams::vertex_constants`.
    pub constants: VertexConstants,
}

/// The joints and morph targets of a file's meshes as they are read.
#[derive(Default)]
pub(crate) struct Rig {
    /// The joint table: each node's skin's joint matrices, or its world transform.
    joints: Vec<Matrix>,
    /// Each node's morph weights, a row per node.
    weight_rows: Vec<Vec<f64>>,
    /// Per vertex: its joints (in the table), their weights and its node's weight row.
    vertices: Vec<RigVertex>,
    /// Each primitive's morph offsets: its first vertex, and per target its position and
    /// normal offsets (absent: zeros).
    targets: Vec<(usize, Vec<Offsets>)>,
}

/// A vertex's four joints (indices into its node's skin) and their weights.
pub(crate) type SkinWeights = ([u16; 4], [f64; 4]);

/// A morph target's position and normal offsets for a primitive's vertices.
pub(crate) type Offsets = (Option<Vec<[f32; 3]>>, Option<Vec<[f32; 3]>>);

#[derive(Clone, Copy)]
struct RigVertex {
    joints: [u32; 4],
    weights: [f64; 4],
    row: u32,
}

/// Where a node's vertices find their joints and weights in a [`Rig`].
#[derive(Clone, Copy)]
pub(crate) struct Binding {
    first_joint: u32,
    row: u32,
}

impl Rig {
    /// Adds a node's joints (`skin`: its skin's joint matrices; else its world transform alone)
    /// and its morph `weights`.
    pub(crate) fn bind(&mut self, world: &Matrix, skin: Option<&[Matrix]>, weights: &[f64]) -> Binding {
        let binding = Binding { first_joint: self.joints.len() as u32, row: self.weight_rows.len() as u32 };
        match skin {
            Some(joints) => self.joints.extend_from_slice(joints),
            None => self.joints.push(*world),
        }
        self.weight_rows.push(weights.to_vec());
        binding
    }

    /// Adds a primitive's vertices: each with its skin's joints and weights (`skin`, indices
    /// into the node's skin; normalised), or the node's transform alone; and its morph
    /// targets' offsets.
    pub(crate) fn add(&mut self, binding: Binding, skin: Option<&[SkinWeights]>, vertices: usize, targets: Vec<Offsets>) {
        self.targets.push((self.vertices.len(), targets));
        let row = binding.row;
        match skin {
            Some(skin) => self.vertices.extend(skin.iter().map(|(j, w)| RigVertex { joints: j.map(|j| binding.first_joint + u32::from(j)), weights: *w, row })),
            None => self.vertices.extend(std::iter::repeat_n(RigVertex { joints: [binding.first_joint; 4], weights: [1.0, 0.0, 0.0, 0.0], row }, vertices)),
        }
    }

    /// The vertex texture and constants that pose `mesh` (whose vertices are this rig's, in
    /// order), each joint's matrix with the mesh's origin folded in: `M p − o = A (p − o) + b`,
    /// `b = A o + t − o`.
    pub(crate) fn texture(&self, mesh: &Mesh) -> Result<(VertexTexture, VertexConstants), String> {
        debug_assert_eq!(mesh.positions.len(), self.vertices.len());
        let targets = self.weight_rows.iter().map(Vec::len).max().unwrap_or(0);
        // Integers the program reads from `f32` texels and constants: exact below 2^24.
        let exact = 1usize << 24;
        let rows = self.weight_rows.len() * targets;
        if self.joints.len() * 12 + rows >= exact || targets >= exact {
            return Err(format!("{} joints and {rows} morph weights are more than the deform program takes (2^24 texels of them)", self.joints.len()));
        }
        let layout = DeformLayout { joints: self.joints.len() as u32, weights: rows as u32, targets: targets as u32 };
        let size = layout.texels(self.vertices.len() as u64);
        if size >= u32::MAX as u64 {
            return Err(format!("the pose of {} vertices with {targets} morph targets takes {size} texels, more than 2^32", self.vertices.len()));
        }
        let mut texels = vec![0.0f32; size as usize];
        let o = pose_origin(&mesh.positions);
        for (j, m) in self.joints.iter().enumerate() {
            let at = layout.joint(j as u32) as usize;
            for r in 0..3 {
                let b = m[r][0] * o[0] + m[r][1] * o[1] + m[r][2] * o[2] + m[r][3] - o[r];
                texels[at + 4 * r..at + 4 * r + 4].copy_from_slice(&[m[r][0] as f32, m[r][1] as f32, m[r][2] as f32, b as f32]);
            }
        }
        for (row, weights) in self.weight_rows.iter().enumerate() {
            let at = layout.weight((row * targets) as u32) as usize;
            texels[at..at + weights.len()].iter_mut().zip(weights).for_each(|(t, &w)| *t = w as f32);
        }
        for (v, rig) in self.vertices.iter().enumerate() {
            let at = layout.vertex(v as u32) as usize;
            texels[at..at + 4].copy_from_slice(&rig.joints.map(|j| j as f32));
            texels[at + 4..at + 8].copy_from_slice(&rig.weights.map(|w| w as f32));
            texels[at + 8] = (rig.row as usize * targets) as f32;
        }
        for (first, offsets) in &self.targets {
            for (k, (positions, normals)) in offsets.iter().enumerate() {
                for (normal, offsets) in [(false, positions), (true, normals)] {
                    for (v, d) in offsets.iter().flatten().enumerate() {
                        let at = layout.offset((first + v) as u32, k as u32, normal) as usize;
                        texels[at..at + 3].copy_from_slice(d);
                    }
                }
            }
        }
        Ok((VertexTexture { width: size as u32, height: 1, texels }, layout.constants()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::gltf_pose::IDENTITY;
    use tileraster_core::render::{RenderParams, VertexStage, posed_positions};

    /// One vertex pair followed by two joints, one morphed: the texture poses them where the
    /// matrices in `f64` put them, at a large origin.
    #[test]
    fn a_rig_poses_its_vertices_as_their_matrices_do_far_from_the_origin() {
        let far = 1.0e5;
        let positions = vec![[far, 0.0, 0.0], [far + 2.0, 1.0, 0.0]];
        let mesh = Mesh { positions: positions.clone(), triangles: vec![[0, 1, 1]], ..Mesh::default() };
        let turn = [[0.0, -1.0, 0.0, 3.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
        let mut rig = Rig::default();
        let binding = rig.bind(&IDENTITY, Some(&[IDENTITY, turn]), &[0.25]);
        let skin = [([0u16, 0, 0, 0], [1.0, 0.0, 0.0, 0.0]), ([0, 1, 0, 0], [0.5, 0.5, 0.0, 0.0])];
        rig.add(binding, Some(&skin), 2, vec![(Some(vec![[0.0; 3], [4.0, 0.0, 0.0]]), None)]);
        let (texture, constants) = rig.texture(&mesh).unwrap();
        let mut params = RenderParams::new(8, 8, IDENTITY);
        params.vertex = Some(VertexStage::DEFORM);
        params.vertex_constants = constants;
        params.vertex_texture = Some(std::sync::Arc::new(texture));
        let posed = posed_positions(&mesh, &params).unwrap();
        assert_eq!(posed[0], positions[0], "joint 0 is the identity");
        // Morphed to (far + 3, 1, 0), then half as it is and half turned.
        let morphed = [far + 3.0, 1.0, 0.0];
        let turned = [3.0 - morphed[1], morphed[0], 0.0];
        let want: [f64; 3] = std::array::from_fn(|k| 0.5 * morphed[k] + 0.5 * turned[k]);
        for k in 0..3 {
            assert!((posed[1][k] - want[k]).abs() <= 1e-2, "{:?} against {want:?}", posed[1]);
        }
    }
}
