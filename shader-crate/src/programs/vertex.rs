//! The programmable vertex stage: where a frame puts each vertex of its mesh before the camera
//! sees it.
//!
//! The vertex stage (`stages::vertex`) is generic over a [`VertexProgram`], which poses a
//! vertex in its mesh's own coordinates; the frame's matrix then takes the posed position to
//! clip space in double-`f32`. The built-in program ([`Builtin`]) leaves every vertex where the
//! mesh has it. A user's `no_std` function is another: it implements [`VertexShader`], from a
//! [`Vertex`] and the frame's [`VertexUniforms`] to a position, in its own crate, and
//! [`vertex_shader!`](crate::vertex_shader) compiles the vertex stage around it.
//! `tileraster-build` turns that crate into a SPIR-V module for the GPU backend, and the CPU
//! backend and the host call the same function natively, so all give the same bits.
//!
//! Why a pose in the mesh's coordinates and not a clip-space position: a mesh of UTM terrain
//! lies 5,000,000 m from its origin, where `f32` steps by half a metre. The stage hands the
//! program its position relative to the centre of the mesh's box (small, so `f32` keeps it to
//! a fraction of a millimetre there) and keeps the rest of the position's bits in the pair's
//! low part: a program that leaves a coordinate alone changes none of its bits, one that moves
//! it moves it by an `f32` difference added exactly. The matrix stays the host's, in
//! double-`f32` (`docs/numeric-contract.md`, "Geometry in the kernels").
//!
//! A program keeps the numeric contract as a fragment shader does (`programs::fragment`):
//! float additions, subtractions, multiplications and comparisons, integer arithmetic, and
//! `math::float`'s correctly rounded division and square root; `tileraster-build` refuses the
//! rest.

use super::deform;
use crate::abi::VertexUniforms;
use crate::math::double::Double;

/// How the vertex stage poses vertex `index` of its mesh at `position` (relative to the
/// mesh's origin, as a double-`f32` pair per coordinate), given the frame's vertex `texture`.
pub trait VertexProgram {
    fn pose(&self, uniforms: &VertexUniforms, texture: &[f32], index: u32, position: [Double; 3]) -> [Double; 3];
}

/// The built-in programs, chosen by `VertexUniforms::builtin`: [`BUILTIN_NONE`] leaves every
/// vertex where its mesh has it; [`BUILTIN_HEIGHTS`] lifts a grid by a raster's heights;
/// [`BUILTIN_DEFORM`] poses glTF's morph targets and skins.
#[derive(Copy, Clone, Default)]
pub struct Builtin;

/// Every vertex where its mesh has it.
pub const BUILTIN_NONE: u32 = 0;
/// A heightfield: vertex `index` of a grid of `texture_size` vertices, row by row (a DEM's
/// cells), lifted by its texel times `constants[0]` (1 for the heights as they are, more to
/// exaggerate them).
pub const BUILTIN_HEIGHTS: u32 = 1;
/// glTF's morph targets and skinning (`programs::deform`), from the vertex texture's joints,
/// weights and offsets.
pub const BUILTIN_DEFORM: u32 = 2;

impl VertexProgram for Builtin {
    #[inline]
    fn pose(&self, uniforms: &VertexUniforms, texture: &[f32], index: u32, position: [Double; 3]) -> [Double; 3] {
        let width = uniforms.texture_size[0];
        if uniforms.builtin == BUILTIN_DEFORM {
            let at = [position[0].hi, position[1].hi, position[2].hi];
            return moved(position, at, deform::deformed(uniforms, texture, index, at));
        }
        if uniforms.builtin != BUILTIN_HEIGHTS || width == 0 {
            return position;
        }
        let height = texel(texture, uniforms, (index % width) as i32, (index / width) as i32);
        [position[0], position[1], position[2] + Double::from_f32(height * uniforms.constants[0])]
    }
}

/// `position` moved by the `f32` difference from `at` (its high parts) to `to`, added to each
/// whole pair: a coordinate `to` leaves as it was keeps every bit.
#[inline]
fn moved(position: [Double; 3], at: [f32; 3], to: [f32; 3]) -> [Double; 3] {
    [position[0] + Double::from_f32(to[0] - at[0]), position[1] + Double::from_f32(to[1] - at[1]), position[2] + Double::from_f32(to[2] - at[2])]
}

/// What a vertex shader sees of one vertex.
#[derive(Copy, Clone, Default)]
pub struct Vertex {
    /// Its index in its mesh.
    pub index: u32,
    /// Its position relative to the centre of its mesh's box, rounded to `f32`.
    pub position: [f32; 3],
}

/// A user's vertex shader: a vertex (and the frame's constants, time and vertex texture, read
/// with [`texel`]) to its posed position, relative to the same origin as [`Vertex::position`].
pub trait VertexShader {
    fn position(&self, vertex: &Vertex, uniforms: &VertexUniforms, texture: &[f32]) -> [f32; 3];
}

/// The texel of the frame's vertex `texture` at `column` and `row` (`uniforms.texture_size`
/// gives its size; texels row by row from the first), the nearest edge's beyond it, 0 where the
/// frame has no texture.
#[inline]
pub fn texel(texture: &[f32], uniforms: &VertexUniforms, column: i32, row: i32) -> f32 {
    let [width, height] = uniforms.texture_size;
    if width == 0 || height == 0 || (width as usize) * (height as usize) > texture.len() {
        return 0.0;
    }
    let clamp = |v: i32, n: u32| {
        if v < 0 {
            0
        } else if v as u32 >= n {
            n - 1
        } else {
            v as u32
        }
    };
    texture[(clamp(row, height) * width + clamp(column, width)) as usize]
}

/// A [`VertexShader`] as the vertex stage's program: each coordinate moved by the shader's
/// `f32` difference, added to the whole pair exactly, so a coordinate the shader returns as it
/// got it keeps every bit.
#[derive(Copy, Clone, Default)]
pub struct Programmed<S>(pub S);

impl<S: VertexShader> VertexProgram for Programmed<S> {
    #[inline]
    fn pose(&self, uniforms: &VertexUniforms, texture: &[f32], index: u32, position: [Double; 3]) -> [Double; 3] {
        let at = [position[0].hi, position[1].hi, position[2].hi];
        moved(position, at, self.0.position(&Vertex { index, position: at }, uniforms, texture))
    }
}

/// The vertex stage's compute entry point around the vertex program `$program` (an
/// expression whose type implements [`VertexProgram`]), in a module `vertex_entry_points`,
/// binding exactly what the stage table's row says. The kernels make theirs with [`Builtin`]; a
/// user's shader crate makes its own with `vertex_shader!(MyShader)`. Natively it expands to
/// nothing: there the CPU backend calls the program itself.
#[macro_export]
macro_rules! vertex_entry_points {
    ($program:expr) => {
        #[cfg(target_arch = "spirv")]
        pub mod vertex_entry_points {
            #[allow(unused_imports)]
            use super::*;
            use $crate::abi::{ProjectedVertex, RelativePosition, VertexParams};
            use $crate::entry::{UVec3, spirv};

            /// The vertex stage (`stages::vertex`): one invocation per vertex.
            #[spirv(compute(threads(64), entry_point_name = "entry::vertex"))]
            pub fn vertex(
                #[spirv(global_invocation_id)] gid: UVec3,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &VertexParams,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] positions: &[RelativePosition],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] projected: &mut [ProjectedVertex],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] texture: &[f32],
            ) {
                let v = gid.y * params.dispatch_width + gid.x;
                if v < params.vertices {
                    let index = params.first_vertex + v;
                    projected[v as usize] = $crate::stages::vertex::vertex(&$program, params, texture, index, &positions[v as usize]);
                }
            }
        }
    };
}

/// What a shader crate invokes, once, with its vertex shader `$shader` (an expression whose
/// type implements [`VertexShader`]): on the GPU the vertex stage's entry point around it;
/// natively `VERTEX_PROGRAM`, the same shader for the CPU backend and the host, which
/// `tileraster::vertex_stage!` takes. One expression for both, so the backends cannot run
/// different shaders.
///
/// ```text
/// tileraster_kernels::vertex_shader!(Waves);
/// ```
#[macro_export]
macro_rules! vertex_shader {
    ($shader:expr) => {
        $crate::vertex_entry_points!($crate::programs::vertex::Programmed($shader));
        /// This crate's vertex shader, for the CPU backend and the host (`tileraster::vertex_stage!`).
        #[cfg(not(target_arch = "spirv"))]
        pub const VERTEX_PROGRAM: &(dyn $crate::programs::vertex::VertexProgram + Sync) = &$crate::programs::vertex::Programmed($shader);
    };
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    struct Unmoved;
    impl VertexShader for Unmoved {
        fn position(&self, vertex: &Vertex, _uniforms: &VertexUniforms, _texture: &[f32]) -> [f32; 3] {
            vertex.position
        }
    }

    struct Lifted;
    impl VertexShader for Lifted {
        fn position(&self, vertex: &Vertex, uniforms: &VertexUniforms, _texture: &[f32]) -> [f32; 3] {
            let p = vertex.position;
            [p[0], p[1], p[2] + uniforms.constants[0]]
        }
    }

    /// Pairs as the host makes them (`Double::from_f64` of differences of `f64`s), of every
    /// magnitude the stage takes.
    fn pairs() -> impl Iterator<Item = Double> {
        let mut x = 0x9e37_79b9_7f4a_7c15u64;
        std::iter::repeat_with(move || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            let unit = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            let scale = 2f64.powi((x % 90) as i32 - 40);
            Double::from_f64(unit * scale)
        })
        .take(100_000)
    }

    #[test]
    fn a_shader_that_moves_nothing_keeps_every_bit_of_the_pairs() {
        let uniforms = VertexUniforms::default();
        for p in pairs() {
            let posed = Programmed(Unmoved).pose(&uniforms, &[], 0, [p, -p, p]);
            for (q, want) in posed.iter().zip([p, -p, p]) {
                assert_eq!((q.hi.to_bits(), q.lo.to_bits()), (want.hi.to_bits(), want.lo.to_bits()), "{want:?}");
            }
        }
    }

    #[test]
    fn a_shader_moves_the_whole_pair_by_its_f32_difference() {
        let uniforms = VertexUniforms { constants: [0.375, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], ..VertexUniforms::default() };
        for p in pairs().filter(|p| p.hi.abs() < 1e6 && p.hi.abs() > 1e-3) {
            let posed = Programmed(Lifted).pose(&uniforms, &[], 7, [p, p, p]);
            assert_eq!(posed[0], p);
            let moved = (p.hi + 0.375) - p.hi;
            // The pair's value plus the difference, to the pair's precision.
            let want = p.to_f64() + moved as f64;
            assert!((posed[2].to_f64() - want).abs() <= want.abs() * 2f64.powi(-46), "{p:?}: {:?} against {want}", posed[2]);
        }
    }

    #[test]
    fn texels_are_read_row_by_row_and_clamped_to_the_edges() {
        let texture = [1.0, 2.0, 3.0, 4.0, 5.0, 6.0];
        let uniforms = VertexUniforms { texture_size: [3, 2], ..VertexUniforms::default() };
        assert_eq!(texel(&texture, &uniforms, 1, 1), 5.0);
        assert_eq!(texel(&texture, &uniforms, -4, 0), 1.0);
        assert_eq!(texel(&texture, &uniforms, 9, 9), 6.0);
        let none = VertexUniforms::default();
        assert_eq!(texel(&texture, &none, 0, 0), 0.0);
        let too_large = VertexUniforms { texture_size: [4, 2], ..VertexUniforms::default() };
        assert_eq!(texel(&texture, &too_large, 0, 0), 0.0);
    }
}
