//! A glTF file's pose: every node's local and world transform and morph weights, at rest (the
//! nodes as the file gives them) or at a time of the file's first animation, its channels
//! sampled as the specification's interpolations say (`STEP`, `LINEAR` with spherical
//! interpolation of rotations, `CUBICSPLINE`), in `f64`; and each skin's joint matrices in that
//! pose. Before its first keyframe a channel holds its first value, after its last its last.
//!
//! What the pose does to vertices (morph targets, then skinning) is `gltf_mesh::add_primitive`'s:
//! the host's reference for the kernels' vertex programs.

use crate::gltf_mesh::check_accessor;
use gltf::accessor::{DataType, Dimensions};
use gltf::animation::util::ReadOutputs;
use gltf::animation::{Interpolation, Property};

/// A row-major 4×4 matrix.
pub(crate) type Matrix = [[f64; 4]; 4];
pub(crate) const IDENTITY: Matrix = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];

/// Node hierarchies deeper than this are refused (a cycle, or a hostile file).
const MAX_DEPTH: usize = 256;

/// The nodes' transforms and weights in one pose.
pub(crate) struct Pose {
    /// The local transforms the animation sets, by node index (`None`: the file's own).
    animated: Vec<Option<Matrix>>,
    /// The morph weights the animation sets, by node index.
    weights: Vec<Option<Vec<f64>>>,
    /// Every scene node's world transform, by node index (`None`: not in the scene).
    world: Vec<Option<Matrix>>,
}

impl Pose {
    /// The file's nodes as it gives them: the rest pose (a skin's bind pose where its joints
    /// rest there), each mesh's default morph weights.
    pub(crate) fn rest(document: &gltf::Document) -> Result<Pose, String> {
        let n = document.nodes().len();
        Pose { animated: vec![None; n], weights: vec![None; n], world: vec![None; n] }.with_worlds(document)
    }

    /// The pose `time` seconds into the file's first animation (the rest pose for the nodes
    /// and weights it does not animate).
    pub(crate) fn at(document: &gltf::Document, buffers: &[gltf::buffer::Data], time: f64) -> Result<Pose, String> {
        if !time.is_finite() {
            return Err(format!("the time {time} s is not a finite number of seconds"));
        }
        let Some(animation) = document.animations().next() else {
            return Err(format!("the file has no animation to pose at {time} s"));
        };
        let n = document.nodes().len();
        // The animated nodes' translation, rotation and scale, from the file's where a channel
        // leaves one alone.
        let mut trs: Vec<Option<Trs>> = vec![None; n];
        let mut weights: Vec<Option<Vec<f64>>> = vec![None; n];
        for channel in animation.channels() {
            let at = || format!("animation 0 channel {}", channel.index());
            let node = channel.target().node();
            let property = channel.target().property();
            let (sampler, floats) = (channel.sampler(), &[DataType::F32][..]);
            let normalised = &[DataType::F32, DataType::I8, DataType::U8, DataType::I16, DataType::U16][..];
            check_accessor(&sampler.input(), "keyframe times", floats, &[Dimensions::Scalar]).map_err(|e| format!("{}: {e}", at()))?;
            let (types, shape) = match property {
                Property::Translation | Property::Scale => (floats, Dimensions::Vec3),
                Property::Rotation => (normalised, Dimensions::Vec4),
                Property::MorphTargetWeights => (normalised, Dimensions::Scalar),
            };
            check_accessor(&sampler.output(), "keyframe values", types, &[shape]).map_err(|e| format!("{}: {e}", at()))?;
            let reader = channel.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let inputs: Vec<f64> = reader.read_inputs().ok_or_else(|| format!("{}: its sampler has no input times", at()))?.map(f64::from).collect();
            let (width, outputs): (usize, Vec<f64>) = match reader.read_outputs().ok_or_else(|| format!("{}: its sampler has no outputs", at()))? {
                ReadOutputs::Translations(t) => (3, t.flatten().map(f64::from).collect()),
                ReadOutputs::Rotations(r) => (4, r.into_f32().flatten().map(f64::from).collect()),
                ReadOutputs::Scales(s) => (3, s.flatten().map(f64::from).collect()),
                ReadOutputs::MorphTargetWeights(w) => {
                    let w: Vec<f64> = w.into_f32().map(f64::from).collect();
                    let per_key = if channel.sampler().interpolation() == Interpolation::CubicSpline { 3 } else { 1 };
                    (w.len() / (inputs.len() * per_key).max(1), w)
                }
            };
            let track = Track { inputs: &inputs, outputs: &outputs, width, interpolation: channel.sampler().interpolation() };
            track.check().map_err(|e| format!("{}: {e}", at()))?;
            let value = track.sample(time, property == Property::Rotation);
            // A node whose weights alone are animated keeps the file's own transform.
            if property == Property::MorphTargetWeights {
                weights[node.index()] = Some(value);
                continue;
            }
            let node_trs = trs[node.index()].get_or_insert_with(|| Trs::of(&node));
            match property {
                Property::Translation => node_trs.translation = [value[0], value[1], value[2]],
                Property::Rotation => node_trs.rotation = [value[0], value[1], value[2], value[3]],
                _ => node_trs.scale = [value[0], value[1], value[2]],
            }
        }
        let animated = trs.iter().map(|t| t.map(|t| t.matrix())).collect();
        Pose { animated, weights, world: vec![None; n] }.with_worlds(document)
    }

    /// The pose with every scene node's world transform filled in.
    fn with_worlds(mut self, document: &gltf::Document) -> Result<Pose, String> {
        let mut world = std::mem::take(&mut self.world);
        self.walk(document, &mut |node, m| {
            world[node.index()].get_or_insert(*m);
            Ok(())
        })?;
        self.world = world;
        Ok(self)
    }

    /// Calls `f` with every node of the default scene (or, without scenes, of every root
    /// node) and its world transform in this pose, depth first in document order.
    pub(crate) fn walk(&self, document: &gltf::Document, f: &mut dyn FnMut(&gltf::Node, &Matrix) -> Result<(), String>) -> Result<(), String> {
        let roots: Vec<gltf::Node> = match document.default_scene().or_else(|| document.scenes().next()) {
            Some(scene) => scene.nodes().collect(),
            None => {
                // No scene: every node that is nobody's child.
                let children: std::collections::HashSet<usize> = document.nodes().flat_map(|n| n.children().map(|c| c.index())).collect();
                document.nodes().filter(|n| !children.contains(&n.index())).collect()
            }
        };
        roots.iter().try_for_each(|node| self.visit(node, IDENTITY, f, 0))
    }

    fn visit(&self, node: &gltf::Node, parent: Matrix, f: &mut dyn FnMut(&gltf::Node, &Matrix) -> Result<(), String>, depth: usize) -> Result<(), String> {
        if depth > MAX_DEPTH {
            return Err(format!("node {} is nested more than {MAX_DEPTH} deep (a cycle?)", node.index()));
        }
        let local = self.animated[node.index()].unwrap_or_else(|| rows(node.transform().matrix()));
        let world = multiply(&parent, &local);
        f(node, &world)?;
        for child in node.children() {
            self.visit(&child, world, f, depth + 1)?;
        }
        Ok(())
    }

    /// The morph weights of `node`'s mesh in this pose: the animation's, else the node's,
    /// else the mesh's defaults, else zeros; `targets` of them.
    pub(crate) fn weights(&self, node: &gltf::Node, mesh: &gltf::Mesh, targets: usize) -> Result<Vec<f64>, String> {
        if targets == 0 {
            // Weights without targets move nothing.
            return Ok(Vec::new());
        }
        let weights = match (&self.weights[node.index()], node.weights(), mesh.weights()) {
            (Some(w), _, _) => w.clone(),
            (None, Some(w), _) | (None, None, Some(w)) => w.iter().map(|&w| f64::from(w)).collect(),
            (None, None, None) => vec![0.0; targets],
        };
        if weights.len() != targets {
            return Err(format!("node {} gives {} morph weights for the {targets} morph targets of mesh {}", node.index(), weights.len(), mesh.index()));
        }
        if let Some(bad) = weights.iter().find(|w| !w.is_finite()) {
            return Err(format!("node {} has the morph weight {bad}, not a finite number", node.index()));
        }
        Ok(weights)
    }

    /// `skin`'s joint matrices in this pose: each joint's world transform times its inverse
    /// bind matrix. They take a vertex of the skinned mesh to world coordinates (the skinned
    /// node's own transform plays no part, as the specification says).
    pub(crate) fn joint_matrices(&self, skin: &gltf::Skin, buffers: &[gltf::buffer::Data]) -> Result<Vec<Matrix>, String> {
        let joints: Vec<gltf::Node> = skin.joints().collect();
        let inverse_binds: Vec<Matrix> = match skin.inverse_bind_matrices() {
            Some(accessor) => {
                let at = || format!("skin {}'s inverse bind matrices", skin.index());
                check_accessor(&accessor, "inverse bind matrices", &[DataType::F32], &[Dimensions::Mat4]).map_err(|e| format!("{}: {e}", at()))?;
                let read = skin.reader(|b| buffers.get(b.index()).map(|d| &d.0[..])).read_inverse_bind_matrices();
                read.ok_or_else(|| format!("{} lie outside their buffers", at()))?.map(rows).collect()
            }
            None => vec![IDENTITY; joints.len()],
        };
        if inverse_binds.len() < joints.len() {
            return Err(format!("skin {} has {} joints but {} inverse bind matrices", skin.index(), joints.len(), inverse_binds.len()));
        }
        joints
            .iter()
            .zip(&inverse_binds)
            .map(|(joint, inverse_bind)| match &self.world[joint.index()] {
                Some(world) => Ok(multiply(world, inverse_bind)),
                None => Err(format!("joint node {} of skin {} is not in the scene", joint.index(), skin.index())),
            })
            .collect()
    }
}

/// A node's translation, rotation (a quaternion, `x, y, z, w`) and scale.
#[derive(Clone, Copy)]
struct Trs {
    translation: [f64; 3],
    rotation: [f64; 4],
    scale: [f64; 3],
}

impl Trs {
    /// The node's own, as the file gives them (a matrix decomposed: the specification gives an
    /// animated node translation, rotation and scale, but a matrix that is one reads alike).
    fn of(node: &gltf::Node) -> Trs {
        let (t, r, s) = node.transform().decomposed();
        Trs { translation: t.map(f64::from), rotation: r.map(f64::from), scale: s.map(f64::from) }
    }

    /// `T · R · S`, the rotation normalised.
    fn matrix(&self) -> Matrix {
        let [x, y, z, w] = normalised(self.rotation);
        let r = [
            [1.0 - 2.0 * (y * y + z * z), 2.0 * (x * y - z * w), 2.0 * (x * z + y * w)],
            [2.0 * (x * y + z * w), 1.0 - 2.0 * (x * x + z * z), 2.0 * (y * z - x * w)],
            [2.0 * (x * z - y * w), 2.0 * (y * z + x * w), 1.0 - 2.0 * (x * x + y * y)],
        ];
        let mut m = IDENTITY;
        for (row, r) in m.iter_mut().zip(r) {
            *row = [r[0] * self.scale[0], r[1] * self.scale[1], r[2] * self.scale[2], 0.0];
        }
        for (k, t) in self.translation.iter().enumerate() {
            m[k][3] = *t;
        }
        m
    }
}

/// One channel's keyframes: `inputs` in seconds, `width` numbers per value (times three for
/// `CUBICSPLINE`: in-tangent, value, out-tangent).
struct Track<'a> {
    inputs: &'a [f64],
    outputs: &'a [f64],
    width: usize,
    interpolation: Interpolation,
}

impl Track<'_> {
    fn per_key(&self) -> usize {
        if self.interpolation == Interpolation::CubicSpline { 3 } else { 1 }
    }

    fn check(&self) -> Result<(), String> {
        let n = self.inputs.len();
        if n == 0 {
            return Err("its sampler has no keyframes".into());
        }
        if let Some(k) = (0..n).find(|&k| !self.inputs[k].is_finite() || (k > 0 && self.inputs[k] <= self.inputs[k - 1])) {
            return Err(format!("keyframe time {k} ({} s) is not finite or not after the one before it", self.inputs[k]));
        }
        if self.width == 0 || self.outputs.len() != n * self.per_key() * self.width {
            return Err(format!("its sampler has {} output numbers for {n} keyframes", self.outputs.len()));
        }
        if self.outputs.iter().any(|v| !v.is_finite()) {
            return Err("its sampler's outputs are not all finite".into());
        }
        Ok(())
    }

    /// Element `e` of keyframe `k`'s `part` (0 in-tangent, 1 value, 2 out-tangent of a cubic
    /// spline; 0 otherwise).
    fn at(&self, k: usize, part: usize, e: usize) -> f64 {
        self.outputs[(k * self.per_key() + part) * self.width + e]
    }

    fn value(&self, k: usize) -> Vec<f64> {
        let part = self.per_key() / 2;
        (0..self.width).map(|e| self.at(k, part, e)).collect()
    }

    /// The value at `time`; a rotation is interpolated on the sphere and normalised.
    fn sample(&self, time: f64, rotation: bool) -> Vec<f64> {
        let last = self.inputs.len() - 1;
        if time <= self.inputs[0] {
            return self.value(0);
        }
        if time >= self.inputs[last] {
            return self.value(last);
        }
        // The keyframe at or before `time`: `inputs[k] ≤ time < inputs[k + 1]`.
        let k = self.inputs.partition_point(|&t| t <= time) - 1;
        let span = self.inputs[k + 1] - self.inputs[k];
        let u = (time - self.inputs[k]) / span;
        match self.interpolation {
            Interpolation::Step => self.value(k),
            Interpolation::Linear if rotation => {
                let (a, b) = (self.value(k), self.value(k + 1));
                slerp([a[0], a[1], a[2], a[3]], [b[0], b[1], b[2], b[3]], u).to_vec()
            }
            Interpolation::Linear => {
                let (a, b) = (self.value(k), self.value(k + 1));
                a.iter().zip(&b).map(|(a, b)| a + (b - a) * u).collect()
            }
            Interpolation::CubicSpline => {
                // Hermite: the values at the ends, the tangents scaled by the span.
                let (u2, u3) = (u * u, u * u * u);
                let (h00, h10, h01, h11) = (2.0 * u3 - 3.0 * u2 + 1.0, u3 - 2.0 * u2 + u, -2.0 * u3 + 3.0 * u2, u3 - u2);
                let v: Vec<f64> = (0..self.width)
                    .map(|e| h00 * self.at(k, 1, e) + h10 * span * self.at(k, 2, e) + h01 * self.at(k + 1, 1, e) + h11 * span * self.at(k + 1, 0, e))
                    .collect();
                if rotation { normalised([v[0], v[1], v[2], v[3]]).to_vec() } else { v }
            }
        }
    }
}

/// Spherical interpolation from `a` to `b` the short way round, normalised.
fn slerp(a: [f64; 4], b: [f64; 4], u: f64) -> [f64; 4] {
    let d: f64 = (0..4).map(|k| a[k] * b[k]).sum();
    let (b, d) = if d < 0.0 { (b.map(|v| -v), -d) } else { (b, d) };
    let (wa, wb) = if d > 1.0 - 1e-9 {
        // Nearly equal: the chord is the arc.
        (1.0 - u, u)
    } else {
        let angle = d.acos();
        let s = angle.sin();
        (((1.0 - u) * angle).sin() / s, (u * angle).sin() / s)
    };
    normalised(std::array::from_fn(|k| wa * a[k] + wb * b[k]))
}

fn normalised(q: [f64; 4]) -> [f64; 4] {
    let len = q.iter().map(|v| v * v).sum::<f64>().sqrt();
    if len > 0.0 { q.map(|v| v / len) } else { [0.0, 0.0, 0.0, 1.0] }
}

/// glTF's column-major matrix as rows.
pub(crate) fn rows(m: [[f32; 4]; 4]) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| m[c][r] as f64))
}

pub(crate) fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

#[cfg(test)]
mod tests {
    use crate::gltf_mesh::tests::{glb, scratch};
    use crate::{read_gltf, read_gltf_cameras, read_gltf_world};

    /// A test file's binary chunk and the buffer views and accessors into it.
    #[derive(Default)]
    struct Bin {
        bytes: Vec<u8>,
        views: Vec<String>,
        accessors: Vec<String>,
    }

    impl Bin {
        /// An accessor over `data`: `count` elements of `kind` (`VEC3`, …) of `component`
        /// (5126 `f32`, 5123 `u16`); `bounds` adds the min and max the specification asks of
        /// positions and keyframe times.
        fn add(&mut self, data: &[u8], component: u32, count: usize, kind: &str, bounds: Option<(Vec<f32>, Vec<f32>)>) -> usize {
            self.bytes.resize(self.bytes.len().next_multiple_of(4), 0);
            self.views.push(format!(r#"{{"buffer": 0, "byteOffset": {}, "byteLength": {}}}"#, self.bytes.len(), data.len()));
            self.bytes.extend_from_slice(data);
            let bounds = bounds.map(|(min, max)| format!(r#", "min": {min:?}, "max": {max:?}"#)).unwrap_or_default();
            self.accessors
                .push(format!(r#"{{"bufferView": {}, "componentType": {component}, "count": {count}, "type": "{kind}"{bounds}}}"#, self.views.len() - 1));
            self.accessors.len() - 1
        }

        fn floats<const N: usize>(&mut self, values: &[[f32; N]], kind: &str, bounded: bool) -> usize {
            let bounds = bounded.then(|| {
                let column = |k: usize| values.iter().map(move |v| v[k]);
                ((0..N).map(|k| column(k).fold(f32::INFINITY, f32::min)).collect(), (0..N).map(|k| column(k).fold(f32::NEG_INFINITY, f32::max)).collect())
            });
            let bytes: Vec<u8> = values.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
            self.add(&bytes, 5126, values.len(), kind, bounds)
        }

        /// The file: `body` (scenes, nodes, meshes, …) with this chunk's buffer, views and
        /// accessors.
        fn file(&self, body: &str) -> Vec<u8> {
            let json = format!(
                r#"{{"asset": {{"version": "2.0"}}, {body}, "buffers": [{{"byteLength": {}}}], "bufferViews": [{}], "accessors": [{}]}}"#,
                self.bytes.len().next_multiple_of(4),
                self.views.join(", "),
                self.accessors.join(", ")
            );
            glb(&json, &self.bytes)
        }
    }

    /// A strip two units tall of five rows of two vertices (x = ±½, y = 0, ½, … 2), normals
    /// +x, skinned to two joints: node 1 at the origin, and its child node 2 one unit up, which
    /// the animation turns about z from no turn at 0 s to 90° at 1 s. The rows at y ≤ ½ follow
    /// joint 0, the row at y = 1 both by half, the rows above joint 1. The skinned node is moved
    /// by 100 in x, which skinning ignores.
    fn skinned_strip(interpolation: &str) -> Vec<u8> {
        let (bin, body) = skinned_strip_parts(interpolation);
        bin.file(&body)
    }

    /// [`skinned_strip`]'s chunk and the JSON it takes.
    fn skinned_strip_parts(interpolation: &str) -> (Bin, String) {
        let mut bin = Bin::default();
        let positions: Vec<[f32; 3]> = (0..10).map(|v| [if v % 2 == 0 { -0.5 } else { 0.5 }, (v / 2) as f32 * 0.5, 0.0]).collect();
        let position = bin.floats(&positions, "VEC3", true);
        let normal = bin.floats(&[[1.0f32, 0.0, 0.0]; 10], "VEC3", false);
        let joints: Vec<[u16; 4]> = (0..10)
            .map(|v| {
                if v / 2 < 2 {
                    [0, 0, 0, 0]
                } else if v / 2 == 2 {
                    [0, 1, 0, 0]
                } else {
                    [1, 0, 0, 0]
                }
            })
            .collect();
        let joint = bin.add(bytemuck::cast_slice(&joints), 5123, 10, "VEC4", None);
        let weights: Vec<[f32; 4]> = (0..10).map(|v| if v / 2 == 2 { [0.5, 0.5, 0.0, 0.0] } else { [1.0, 0.0, 0.0, 0.0] }).collect();
        let weight = bin.floats(&weights, "VEC4", false);
        let indices: Vec<u16> = (0..4u16).flat_map(|r| [2 * r, 2 * r + 1, 2 * r + 3, 2 * r, 2 * r + 3, 2 * r + 2]).collect();
        let index = bin.add(bytemuck::cast_slice(&indices), 5123, indices.len(), "SCALAR", None);
        // Column-major: the identity, and a move down by one unit.
        let binds: [[f32; 16]; 2] = [
            [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0],
            [1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 1.0],
        ];
        let bind = bin.floats(&binds, "MAT4", false);
        let times = bin.floats(&[[0.0f32], [1.0]], "SCALAR", true);
        let half = std::f32::consts::FRAC_1_SQRT_2;
        let turns = bin.floats(&[[0.0f32, 0.0, 0.0, 1.0], [0.0, 0.0, half, half]], "VEC4", false);
        let body = format!(
            r#""scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0, "skin": 0, "translation": [100, 0, 0]}}, {{"children": [2]}}, {{"translation": [0, 1, 0]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}, "NORMAL": {normal}, "JOINTS_0": {joint}, "WEIGHTS_0": {weight}}}, "indices": {index}}}]}}],
  "skins": [{{"inverseBindMatrices": {bind}, "joints": [1, 2]}}],
  "animations": [{{"channels": [{{"sampler": 0, "target": {{"node": 2, "path": "rotation"}}}}],
                   "samplers": [{{"input": {times}, "output": {turns}, "interpolation": "{interpolation}"}}]}}]"#
        );
        (bin, body)
    }

    fn near(a: [f64; 3], b: [f64; 3]) -> bool {
        (0..3).all(|k| (a[k] - b[k]).abs() < 1e-6)
    }

    /// The strip at rest, halfway and at the end of its animation, against the turn about
    /// (0, 1) worked out here: the rows on joint 1 turn by the angle, the row on both joints
    /// moves halfway to its turned place, the rows on joint 0 stay, the node's own move plays
    /// no part; before the first and after the last keyframe the channel holds its ends.
    #[test]
    fn a_skin_bends_its_vertices_by_the_animated_joints() {
        let dir = scratch("skin");
        let path = dir.join("strip.glb");
        std::fs::write(&path, skinned_strip("LINEAR")).unwrap();
        let bent = |angle: f64| -> Vec<[f64; 3]> {
            let (s, c) = angle.sin_cos();
            let turned = |[x, y]: [f64; 2]| [x * c - (y - 1.0) * s, 1.0 + x * s + (y - 1.0) * c];
            (0..10)
                .map(|v| {
                    let p = [if v % 2 == 0 { -0.5 } else { 0.5 }, (v / 2) as f64 * 0.5];
                    let q = match v / 2 {
                        0 | 1 => p,
                        2 => {
                            let t = turned(p);
                            [0.5 * p[0] + 0.5 * t[0], 0.5 * p[1] + 0.5 * t[1]]
                        }
                        _ => turned(p),
                    };
                    [q[0], q[1], 0.0]
                })
                .collect()
        };
        let quarter = std::f64::consts::FRAC_PI_2;
        for (time, angle) in [(None, 0.0), (Some(0.0), 0.0), (Some(0.5), quarter / 2.0), (Some(1.0), quarter), (Some(-3.0), 0.0), (Some(7.0), quarter)] {
            let mesh = read_gltf(&path, time).unwrap();
            let want = bent(angle);
            for (v, (got, want)) in mesh.positions.iter().zip(&want).enumerate() {
                assert!(near(*got, *want), "at {time:?} s, vertex {v}: {got:?}, want {want:?}");
            }
            // Normals turn with their joints (+x turned by 90° is +y).
            let normal = mesh.normals.as_ref().unwrap()[9].map(f64::from);
            assert!(near(normal, [angle.cos(), angle.sin(), 0.0]), "at {time:?} s: {normal:?}");
            // The world holds the skinned mesh in world coordinates, unmoved by its node.
            let world = read_gltf_world(&path, time).unwrap();
            assert_eq!(world.flattened().unwrap().positions, mesh.positions);
        }
        // A skeleton mirrored in x (its root scaled by −1) mirrors every skin matrix: each face
        // takes two corners the other way round, so that it still faces the viewer it faced.
        let plain = read_gltf(&path, None).unwrap();
        let (bin, body) = skinned_strip_parts("LINEAR");
        std::fs::write(&path, bin.file(&body.replace(r#"{"children": [2]}"#, r#"{"children": [2], "scale": [-1, 1, 1]}"#))).unwrap();
        let mirrored = read_gltf(&path, None).unwrap();
        assert_eq!(mirrored.triangles, plain.triangles.iter().map(|t| [t[0], t[2], t[1]]).collect::<Vec<_>>());
        assert!(near(mirrored.positions[1], [-0.5, 0.0, 0.0]));

        // A step holds the first keyframe's value until the second's time.
        std::fs::write(&path, skinned_strip("STEP")).unwrap();
        assert_eq!(read_gltf(&path, Some(0.999)).unwrap().positions, read_gltf(&path, None).unwrap().positions);
        assert!(near(read_gltf(&path, Some(1.0)).unwrap().positions[9], bent(quarter)[9]));
    }

    /// A triangle with two morph targets (one moves vertex 2 left by one, the other vertex 1
    /// up by one) and default weights ½, ½; node 1 shares its mesh with weights of its own,
    /// and the animation drives node 0's weights by a cubic spline from (0, 0) at 0 s to
    /// (1, 0) at 2 s with an out-tangent (1, 0) at 0 s.
    fn morphing_triangle() -> Vec<u8> {
        let mut bin = Bin::default();
        let position = bin.floats(&[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.5, 0.5, 0.0]], "VEC3", true);
        let left = bin.floats(&[[0.0f32, 0.0, 0.0], [0.0, 0.0, 0.0], [-1.0, 0.0, 0.0]], "VEC3", true);
        let up = bin.floats(&[[0.0f32, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 0.0]], "VEC3", true);
        let times = bin.floats(&[[0.0f32], [2.0]], "SCALAR", true);
        // Per keyframe: in-tangent, value, out-tangent, two weights each.
        let weights = bin.floats(&[[0.0f32], [0.0], [0.0], [0.0], [1.0], [0.0], [0.0], [0.0], [1.0], [0.0], [0.0], [0.0]], "SCALAR", false);
        bin.file(&format!(
            r#""scene": 0, "scenes": [{{"nodes": [0, 1]}}],
  "nodes": [{{"mesh": 0}}, {{"mesh": 0, "weights": [1, 1], "translation": [5, 0, 0]}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}}}, "targets": [{{"POSITION": {left}}}, {{"POSITION": {up}}}]}}], "weights": [0.5, 0.5]}}],
  "animations": [{{"channels": [{{"sampler": 0, "target": {{"node": 0, "path": "weights"}}}}],
                   "samplers": [{{"input": {times}, "output": {weights}, "interpolation": "CUBICSPLINE"}}]}}]"#
        ))
    }

    /// Morph targets at rest take the mesh's (or the node's) weights; at 1 s the spline's value
    /// is h01(½) · 1 + h10(½) · 2 s · 1 = ½ + ¼ (Hermite basis, the tangent scaled by the span),
    /// and the second weight stays 0. Nodes sharing a mesh with other weights get a mesh each.
    #[test]
    fn morph_targets_blend_by_the_animated_weights() {
        let dir = scratch("morph");
        let path = dir.join("morph.glb");
        std::fs::write(&path, morphing_triangle()).unwrap();
        let rest = read_gltf(&path, None).unwrap();
        assert_eq!(&rest.positions[..3], &[[0.0, 0.0, 0.0], [1.0, 0.5, 0.0], [0.0, 0.5, 0.0]]);
        assert_eq!(&rest.positions[3..], &[[5.0, 0.0, 0.0], [6.0, 1.0, 0.0], [4.5, 0.5, 0.0]], "node 1's own weights");
        let posed = read_gltf(&path, Some(1.0)).unwrap();
        assert!(near(posed.positions[2], [0.5 - 0.75, 0.5, 0.0]), "{:?}", posed.positions[2]);
        assert_eq!(posed.positions[1], [1.0, 0.0, 0.0]);
        assert_eq!(&posed.positions[3..], &rest.positions[3..], "node 1 is not animated");
        let world = read_gltf_world(&path, Some(1.0)).unwrap();
        assert_eq!(world.meshes.len(), 2);
        assert_eq!(world.flattened().unwrap().positions, posed.positions);
    }

    /// The kernels' deform program poses a file read at rest ([`read_gltf_posable`]) as the
    /// host's `f64` pose does ([`read_gltf`]): the same faces, positions within `2^-20` of the
    /// file's extent, normals within `2^-20`. A file that neither skins nor morphs is not
    /// posable.
    #[test]
    fn the_deform_program_poses_as_the_host_does() {
        use crate::read_gltf_posable;
        use tileraster_core::render::{RenderParams, VertexStage, posed_normals, posed_positions};
        let dir = scratch("posable");
        let (strip, triangle) = (dir.join("strip.glb"), dir.join("triangle.glb"));
        std::fs::write(&strip, skinned_strip("LINEAR")).unwrap();
        std::fs::write(&triangle, morphing_triangle()).unwrap();
        let (bin, body) = skinned_strip_parts("LINEAR");
        let mirrored = dir.join("mirrored.glb");
        std::fs::write(&mirrored, bin.file(&body.replace(r#"{"children": [2]}"#, r#"{"children": [2], "scale": [-1, 1, 1]}"#))).unwrap();
        for path in [&strip, &triangle, &mirrored] {
            for time in [None, Some(0.0), Some(0.3), Some(1.0), Some(1.7)] {
                let host = read_gltf(path, time).unwrap();
                let posable = read_gltf_posable(path, time).unwrap().unwrap();
                assert_eq!(posable.mesh.triangles, host.triangles, "{path:?} at {time:?} s");
                let mut params = RenderParams::new(8, 8, super::IDENTITY);
                params.vertex = Some(VertexStage::DEFORM);
                params.vertex_constants = posable.constants;
                params.vertex_texture = Some(std::sync::Arc::new(posable.texture));
                let positions = posed_positions(&posable.mesh, &params).unwrap();
                let bound = 2f64.powi(-20) * 3.0;
                for (v, (got, want)) in positions.iter().zip(&host.positions).enumerate() {
                    assert!((0..3).all(|k| (got[k] - want[k]).abs() <= bound), "{path:?} at {time:?} s, vertex {v}: {got:?}, want {want:?}");
                }
                match (posed_normals(&posable.mesh, &params), &host.normals) {
                    (Some(got), Some(want)) => {
                        for (v, (got, want)) in got.iter().zip(want).enumerate() {
                            assert!((0..3).all(|k| (got[k] - want[k]).abs() <= 2f32.powi(-20)), "{path:?} at {time:?} s, normal {v}: {got:?}, want {want:?}");
                        }
                    }
                    (None, None) => {}
                    (got, want) => panic!("{path:?}: posed normals {got:?}, the host's {want:?}"),
                }
            }
        }
        let dir = scratch("posable-still");
        let still = dir.join("still.glb");
        std::fs::write(&still, still_triangle()).unwrap();
        assert!(read_gltf_posable(&still, None).unwrap().is_none());
    }

    /// A triangle with no animation, skin or morph target.
    fn still_triangle() -> Vec<u8> {
        let mut bin = Bin::default();
        let position = bin.floats(&[[0.0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]], "VEC3", true);
        bin.file(&format!(r#""nodes": [{{"mesh": 0}}], "meshes": [{{"primitives": [{{"attributes": {{"POSITION": {position}}}}}]}}]"#))
    }

    /// A time for a file without animation, a non-finite time, more than four joints per
    /// vertex and a joint outside the skin are refused, each naming its cause; a camera
    /// node follows its animation.
    #[test]
    fn poses_refuse_what_they_cannot_pose_and_move_cameras() {
        let dir = scratch("refused");
        let still = dir.join("still.glb");
        std::fs::write(&still, still_triangle()).unwrap();
        let e = read_gltf(&still, Some(1.0)).unwrap_err().to_string();
        assert!(e.contains("no animation") && e.contains("still.glb"), "{e}");
        let strip = dir.join("strip.glb");
        std::fs::write(&strip, skinned_strip("LINEAR")).unwrap();
        let e = read_gltf(&strip, Some(f64::NAN)).unwrap_err().to_string();
        assert!(e.contains("not a finite number"), "{e}");

        // Joint 1 of a skin with one; a second set of joints.
        let (bin, body) = skinned_strip_parts("LINEAR");
        let patched = |from: &str, to: &str| {
            assert!(body.contains(from));
            bin.file(&body.replace(from, to))
        };
        std::fs::write(&strip, patched(r#""joints": [1, 2]"#, r#""joints": [1]"#)).unwrap();
        let e = read_gltf(&strip, None).unwrap_err().to_string();
        assert!(e.contains("names joint 1 of a skin with 1"), "{e}");
        std::fs::write(&strip, patched(r#""WEIGHTS_0""#, r#""WEIGHTS_1""#)).unwrap();
        let e = read_gltf(&strip, None).unwrap_err().to_string();
        assert!(e.contains("more than four joints per vertex"), "{e}");

        // Accessors the readers cannot take are refused, not read: rotations as 32-bit
        // integers, joints as floats, inverse bind matrices beyond their buffer.
        for (accessor, from, to, expected) in
            [(7, "5126", "5125", "keyframe values"), (2, "5123", "5126", "Joints(0)"), (5, r#""count": 2"#, r#""count": 3"#, "inverse bind matrices")]
        {
            let (mut bin, body) = skinned_strip_parts("LINEAR");
            bin.accessors[accessor] = bin.accessors[accessor].replace(from, to);
            std::fs::write(&strip, bin.file(&body)).unwrap();
            let e = read_gltf(&strip, Some(0.5)).unwrap_err().to_string();
            assert!(e.contains(expected), "{e}");
        }

        // A camera one unit right of node 2 (joint 1) turns with it about (0, 1).
        let camera = body
            .replace(r#"{"translation": [0, 1, 0]}"#, r#"{"translation": [0, 1, 0], "children": [3]}, {"camera": 0, "translation": [1, 0, 0]}"#)
            .replace(r#""skins""#, r#""cameras": [{"type": "perspective", "perspective": {"yfov": 1, "znear": 0.1}}], "skins""#);
        std::fs::write(&strip, bin.file(&camera)).unwrap();
        let at = |time| {
            let m = read_gltf_cameras(&strip, time).unwrap()[0].to_world;
            [m[0][3], m[1][3], m[2][3]]
        };
        assert!(near(at(None), [1.0, 1.0, 0.0]), "{:?}", at(None));
        assert!(near(at(Some(1.0)), [0.0, 2.0, 0.0]), "{:?}", at(Some(1.0)));
    }
}
