//! glTF's morph targets and skinning as a built-in vertex program
//! ([`BUILTIN_DEFORM`](super::vertex::BUILTIN_DEFORM)): a vertex moved by its morph targets'
//! weighted offsets, then placed by the weighted sum of its joints' matrices (up to four), as
//! the glTF specification poses it. A vertex of a node without a skin has one joint, its node's
//! transform, of weight 1, so one program places a whole file's meshes.
//!
//! Everything the pose changes lives in the frame's vertex texture ([`DeformLayout`]), so a
//! later time of an animation hands the kernels new joint matrices and weights and nothing of
//! the mesh.
//!
//! Precision: the program works in `f32` on the position relative to the mesh's origin `o`
//! (the centre of its box), and the host folds the origin into each joint's matrix in `f64`:
//! with `M p = A p + t`, `M p − o = A (p − o) + (A o + t − o)`, so no large coordinate meets
//! `f32`. The host normalises each vertex's weights to sum to 1 (as players do; glTF asks files
//! for it), which that identity needs.

use crate::abi::VertexUniforms;

/// Texels a joint's matrix takes: the rows of its `3 × 4` affine part, each `A` row then the
/// row's `b` (`A o + t − o`).
pub const JOINT_TEXELS: u32 = 12;
/// Joints a vertex names (glTF's `JOINTS_0`, `WEIGHTS_0`).
pub const JOINTS_PER_VERTEX: u32 = 4;

/// Where the deform program finds its data in the vertex texture, from the frame's constants:
/// `constants[0]` joints, `constants[1]` morph weights, `constants[2]` morph targets per vertex
/// (each an integer, exact in `f32` below `2^24`).
///
/// The texture holds, in order:
/// - each joint's matrix ([`JOINT_TEXELS`] texels);
/// - the morph weights of every deformed node, each node's targets in a row;
/// - per vertex, `9 + 6 · targets` texels: its four joints' indices and their four weights,
///   the index of its node's first morph weight, its position offset per target (`x, y, z`),
///   then its normal offset per target (which the host reads; the kernels pose positions).
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct DeformLayout {
    pub joints: u32,
    pub weights: u32,
    pub targets: u32,
}

impl DeformLayout {
    #[inline]
    pub fn of(uniforms: &VertexUniforms) -> Self {
        let c = &uniforms.constants;
        DeformLayout { joints: c[0] as u32, weights: c[1] as u32, targets: c[2] as u32 }
    }

    /// The constants a frame hands the program for this layout.
    pub fn constants(&self) -> [f32; crate::abi::VERTEX_CONSTANTS] {
        [self.joints as f32, self.weights as f32, self.targets as f32, 0.0, 0.0, 0.0, 0.0, 0.0]
    }

    /// The first texel of joint `j`'s matrix.
    #[inline]
    pub fn joint(&self, j: u32) -> u32 {
        j * JOINT_TEXELS
    }

    /// The texel of morph weight `k`.
    #[inline]
    pub fn weight(&self, k: u32) -> u32 {
        self.joints * JOINT_TEXELS + k
    }

    /// Texels per vertex.
    #[inline]
    pub fn stride(&self) -> u32 {
        2 * JOINTS_PER_VERTEX + 1 + 6 * self.targets
    }

    /// The first texel of vertex `v`'s record.
    #[inline]
    pub fn vertex(&self, v: u32) -> u32 {
        self.joints * JOINT_TEXELS + self.weights + v * self.stride()
    }

    /// The texel of vertex `v`'s position offset (`normal`: its normal offset) for target `k`.
    #[inline]
    pub fn offset(&self, v: u32, k: u32, normal: bool) -> u32 {
        let first = self.vertex(v) + 2 * JOINTS_PER_VERTEX + 1 + 3 * k;
        if normal { first + 3 * self.targets } else { first }
    }

    /// Vertex `v`'s joint `i` (of [`JOINTS_PER_VERTEX`]): the first texel of its matrix, and
    /// its weight.
    #[inline]
    pub fn joint_of(&self, texture: &[f32], v: u32, i: u32) -> (u32, f32) {
        let record = self.vertex(v);
        (self.joint(fetch(texture, record + i) as u32), fetch(texture, record + JOINTS_PER_VERTEX + i))
    }

    /// The texels a texture of this layout holds for `vertices` vertices.
    pub fn texels(&self, vertices: u64) -> u64 {
        (self.joints * JOINT_TEXELS + self.weights) as u64 + vertices * self.stride() as u64
    }
}

/// Texel `i`, 0 beyond the texture.
#[inline]
pub fn fetch(texture: &[f32], i: u32) -> f32 {
    if (i as usize) < texture.len() { texture[i as usize] } else { 0.0 }
}

/// Vertex `v`'s morph weights and offsets applied to `r`, `normal` saying which offsets (its
/// position's, or its normal's).
#[inline]
pub fn morphed(layout: &DeformLayout, texture: &[f32], v: u32, r: [f32; 3], normal: bool) -> [f32; 3] {
    let mut m = r;
    let first_weight = fetch(texture, layout.vertex(v) + 2 * JOINTS_PER_VERTEX) as u32;
    let mut k = 0;
    while k < layout.targets {
        let w = fetch(texture, layout.weight(first_weight + k));
        if w != 0.0 {
            let at = layout.offset(v, k, normal);
            m = [m[0] + w * fetch(texture, at), m[1] + w * fetch(texture, at + 1), m[2] + w * fetch(texture, at + 2)];
        }
        k += 1;
    }
    m
}

/// Vertex `v` (at `r`, relative to the mesh's origin) posed: morphed, then placed by its
/// joints' matrices each times its weight. Relative to the same origin.
#[inline]
pub fn deformed(uniforms: &VertexUniforms, texture: &[f32], v: u32, r: [f32; 3]) -> [f32; 3] {
    let layout = DeformLayout::of(uniforms);
    let m = morphed(&layout, texture, v, r, false);
    let mut out = [0.0f32; 3];
    let mut i = 0;
    while i < JOINTS_PER_VERTEX {
        let (a, w) = layout.joint_of(texture, v, i);
        if w != 0.0 {
            let mut row = 0;
            while row < 3 {
                let at = a + 4 * row;
                let placed = fetch(texture, at) * m[0] + fetch(texture, at + 1) * m[1] + fetch(texture, at + 2) * m[2] + fetch(texture, at + 3);
                out[row as usize] += w * placed;
                row += 1;
            }
        }
        i += 1;
    }
    out
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// Two joints (a translation, and a quarter turn about `z` with the origin folded in), one
    /// target, two vertices.
    #[test]
    fn a_vertex_is_morphed_then_placed_by_its_weighted_joints() {
        let layout = DeformLayout { joints: 2, weights: 1, targets: 1 };
        let mut texture = vec![0.0f32; layout.texels(2) as usize];
        let joint0 = [1.0, 0.0, 0.0, 2.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        let joint1 = [0.0, -1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0];
        texture[..12].copy_from_slice(&joint0);
        texture[12..24].copy_from_slice(&joint1);
        texture[layout.weight(0) as usize] = 0.5;
        for (v, record) in [[0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0, 0.5, 0.5, 0.0, 0.0, 0.0]].iter().enumerate() {
            let at = layout.vertex(v as u32) as usize;
            texture[at..at + 9].copy_from_slice(record);
        }
        let offset = layout.offset(1, 0, false) as usize;
        texture[offset..offset + 3].copy_from_slice(&[2.0, 0.0, 0.0]);
        let uniforms = VertexUniforms { constants: layout.constants(), ..VertexUniforms::default() };
        // Vertex 0: joint 0 alone, no offset.
        assert_eq!(deformed(&uniforms, &texture, 0, [1.0, 1.0, 1.0]), [3.0, 1.0, 1.0]);
        // Vertex 1: morphed to (2, 0, 0) by half its offset, then half translated (4, 0, 0),
        // half turned (0, 2, 0).
        assert_eq!(deformed(&uniforms, &texture, 1, [1.0, 0.0, 0.0]), [2.0, 1.0, 0.0]);
        // Its normal offset is not its position's.
        assert_eq!(morphed(&layout, &texture, 1, [1.0, 0.0, 0.0], true), [1.0, 0.0, 0.0]);
    }
}
