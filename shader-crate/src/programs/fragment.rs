//! The programmable fragment stage: what colours a fragment once the depth test has chosen it.
//!
//! The shade stage (`shade`, `fine_samples` and the blended walk) is generic over a
//! [`FragmentProgram`]. The built-in shadings are one ([`Builtin`], `ShadeParams::shading`
//! chooses among them); a user's `no_std` function is another: it implements
//! [`FragmentShader`], from the interpolated [`Fragment`] to a colour, in its own crate, and
//! [`fragment_shader!`](crate::fragment_shader) compiles the shading stages around it.
//! `tileraster-build` turns that crate into a SPIR-V module for the GPU backend, and the CPU
//! backend calls the same function natively, so both give the same bits.
//!
//! The contract the kernels keep holds for a program too: additions, subtractions,
//! multiplications and comparisons of floats (correctly rounded everywhere, and never
//! contracted: the build marks them `NoContraction`), integer arithmetic, and
//! `math::float`'s correctly rounded division and square root. `tileraster-build` refuses a
//! module that divides floats with the device's division, or calls a transcendental function,
//! whose bits differ between devices.

use crate::abi::{ATTR_NORMAL, ATTR_POSITION, ATTR_UV, MaterialRecord, ShadeParams, TextureInfo, TriangleSetup, TriangleShading};
use crate::programs::shade::{colour_at, facing_normal, fragment_colour, interpolate, interpolate3, normalise, rgba8, surface_at, weights};

/// How the shade stage colours a fragment: triangle `(s, t)` at pixel `(i, j)`, of depth
/// `depth_bits`, as RGBA8 (red in the low byte). `face` is `t.face` as the backend keeps it
/// (`ShadingRecords::face`): a program that needs nothing else of `t` reads no record.
pub trait FragmentProgram {
    #[allow(clippy::too_many_arguments)]
    fn colour(
        &self,
        params: &ShadeParams,
        s: &TriangleSetup,
        t: &TriangleShading,
        face: u32,
        textures: &[TextureInfo],
        texels: &[u64],
        materials: &[MaterialRecord],
        depth_bits: u32,
        i: i32,
        j: i32,
    ) -> u32;
}

/// The built-in shadings: the frame's `ShadeParams::shading`.
#[derive(Copy, Clone, Default)]
pub struct Builtin;

impl FragmentProgram for Builtin {
    #[inline]
    fn colour(
        &self,
        params: &ShadeParams,
        s: &TriangleSetup,
        t: &TriangleShading,
        face: u32,
        textures: &[TextureInfo],
        texels: &[u64],
        materials: &[MaterialRecord],
        depth_bits: u32,
        i: i32,
        j: i32,
    ) -> u32 {
        fragment_colour(params, s, t, face, textures, texels, materials, depth_bits, i, j)
    }
}

/// What a fragment shader sees of one fragment: its pixel and depth, and its triangle's
/// vertex attributes interpolated at the pixel centre as the frame's interpolation says.
#[derive(Copy, Clone, Default)]
pub struct Fragment {
    /// Column and row of the pixel in the frame; its centre is at `+0.5`.
    pub pixel: [i32; 2],
    /// The depth of the triangle's plane at the pixel centre (in `[0, 1]` where the centre is
    /// inside the triangle; a multisampled pixel's centre may lie outside it).
    pub depth: f32,
    /// The input face it belongs to.
    pub face: u32,
    /// Its surface's `SHADING_*` flags: `SHADING_UNLIT` where the triangle is part of a line
    /// drawn in its own colour (the wireframe's), which the built-in shadings neither light nor
    /// texture; `SHADING_BACK` on the back of a double-sided surface; the material's
    /// `SHADING_DOUBLE_SIDED`, `SHADING_OPAQUE`, `SHADING_MASK` and `SHADING_NOT_LIT`.
    pub flags: u32,
    /// Its surface's material: metallic and roughness factors, alpha cutoff, emission.
    pub material: MaterialRecord,
    /// The point in the world.
    pub position: [f32; 3],
    /// The interpolated normal, of unit length (zero where it has no direction), turned round
    /// on the back of a double-sided surface.
    pub normal: [f32; 3],
    /// The vertex colour, RGBA in `[0, 1]`.
    pub colour: [f32; 4],
    /// The texture coordinates.
    pub uv: [f32; 2],
    /// The built-in base colour: `colour` times the triangle's texture sampled at `uv` (the
    /// frame's filter and addressing, the level of detail from the pixel's 2×2 quad), or
    /// `colour` where the triangle has no texture.
    pub base: [f32; 4],
}

impl Fragment {
    /// Triangle `(s, t)`'s fragment at pixel `(i, j)`, of depth `depth_bits`; `face` is `t.face`.
    #[inline]
    #[allow(clippy::too_many_arguments)]
    pub fn at(
        params: &ShadeParams,
        s: &TriangleSetup,
        t: &TriangleShading,
        face: u32,
        textures: &[TextureInfo],
        texels: &[u64],
        materials: &[MaterialRecord],
        depth_bits: u32,
        i: i32,
        j: i32,
    ) -> Fragment {
        let b = weights(s, t, params, i, j);
        let material = materials[t.material.material as usize];
        Fragment {
            pixel: [i, j],
            depth: f32::from_bits(depth_bits),
            face,
            flags: t.material.flags,
            material,
            position: interpolate3(t, &b, ATTR_POSITION),
            normal: facing_normal(t.material.flags, normalise(interpolate3(t, &b, ATTR_NORMAL))),
            colour: colour_at(t, &b),
            uv: [interpolate(t, &b, ATTR_UV), interpolate(t, &b, ATTR_UV + 1)],
            base: surface_at(params, s, t, &material, textures, texels, &b, false, i, j).base,
        }
    }
}

/// A user's fragment shader: a fragment (and the frame's parameters: its lights, eye and
/// `constants`) to RGBA in `[0, 1]`, which the stage rounds to 8 bits per channel.
pub trait FragmentShader {
    fn shade(&self, fragment: &Fragment, params: &ShadeParams) -> [f32; 4];
}

/// A [`FragmentShader`] as the shade stage's program.
#[derive(Copy, Clone, Default)]
pub struct Programmed<S>(pub S);

impl<S: FragmentShader> FragmentProgram for Programmed<S> {
    #[inline]
    fn colour(
        &self,
        params: &ShadeParams,
        s: &TriangleSetup,
        t: &TriangleShading,
        face: u32,
        textures: &[TextureInfo],
        texels: &[u64],
        materials: &[MaterialRecord],
        depth_bits: u32,
        i: i32,
        j: i32,
    ) -> u32 {
        rgba8(self.0.shade(&Fragment::at(params, s, t, face, textures, texels, materials, depth_bits, i, j), params))
    }
}

/// The compute entry points of the stages that colour fragments, `shade` and `fine_samples`,
/// around the fragment program `$program` (an expression whose type implements
/// [`FragmentProgram`]), in a module `shading_entry_points`. The kernels make theirs with the
/// built-in shadings; a user's shader crate makes its own with `fragment_shader!(MyShader)`. Both bind exactly what the stage table's
/// rows of those stages say, so the GPU backend runs either module with the same bind groups.
/// Both take the frame's [`ShadeVariant`](crate::abi::ShadeVariant) as specialisation constant
/// 0 (`ShadeVariant::SPEC_ID`); left at its default, they read every choice from the shade
/// parameters. Natively it expands to nothing: there the CPU backend calls the program itself.
#[macro_export]
macro_rules! shading_entry_points {
    ($program:expr) => {
        #[cfg(target_arch = "spirv")]
        pub mod shading_entry_points {
            #[allow(unused_imports)]
            use super::*;
            use $crate::abi::{FrameParams, MaterialRecord, ShadeParams, ShadeVariant, TextureInfo, TriangleSetup};
            use $crate::entry::{UVec3, spirv};
            use $crate::stages::fine::FineShared;

            // Named as the stage table names them, wherever the macro is invoked.

            /// The render pipeline's shade stage: `SHADE_PASSES` window pixels per invocation,
            /// from the owner fine raster left there (`programs::shade`).
            #[spirv(compute(threads(16, 2), entry_point_name = "entry::shade"))]
            #[allow(clippy::too_many_arguments)]
            pub fn shade(
                #[spirv(workgroup_id)] wg: UVec3,
                #[spirv(local_invocation_index)] lid: u32,
                #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] params: &ShadeParams,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] setups: &[TriangleSetup],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] shading: &[$crate::entry::UVec4],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] textures: &[TextureInfo],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] texels: &[u64],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] offsets: &[u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] bins: &[u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] values: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] owners: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] colours: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] faces: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] pixel_keys: &[u64],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] coverage: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] materials: &[MaterialRecord],
                #[spirv(spec_constant(id = 0, default = 0))] variant: u32,
                #[spirv(spec_constant(id = 1, default = 0))] way: u32,
            ) {
                let params = &ShadeVariant(variant).apply(params);
                $crate::entry::shade_pixels(
                    &$program,
                    &$crate::programs::depth::DepthProgram::specialised(frame, way),
                    way & $crate::stages::fine::NO_TILES_LEFT == 0,
                    wg,
                    lid,
                    frame,
                    params,
                    setups,
                    shading,
                    textures,
                    texels,
                    materials,
                    offsets,
                    bins,
                    pixel_keys,
                    values,
                    owners,
                    coverage,
                    colours,
                    faces,
                );
            }

            /// Fine raster of the multisampled render pipeline (`programs::multisample`).
            #[spirv(compute(threads(16, 16), entry_point_name = "entry::fine_samples"))]
            #[allow(clippy::too_many_arguments)]
            pub fn fine_samples(
                #[spirv(workgroup_id)] wg: UVec3,
                #[spirv(local_invocation_index)] lid: u32,
                #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bins: &[u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] values: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owners: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] coverage: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] stats: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] tile_stats: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] params: &ShadeParams,
                #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] shading: &[$crate::entry::UVec4],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] textures: &[TextureInfo],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] texels: &[u64],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] colours: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] faces: &mut [u32],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] setup_words: &[u64],
                #[spirv(storage_buffer, descriptor_set = 0, binding = 16)] materials: &[MaterialRecord],
                #[spirv(subgroup_local_invocation_id)] subgroup_lane: u32,
                #[spirv(workgroup)] shared: &mut FineShared<TriangleSetup, u64>,
                #[spirv(spec_constant(id = 0, default = 0))] variant: u32,
                #[spirv(spec_constant(id = 1, default = 0))] way: u32,
            ) {
                let params = &ShadeVariant(variant).apply(params);
                $crate::entry::fine_samples_workgroup(
                    &$program,
                    &$crate::programs::depth::DepthProgram::specialised(frame, way),
                    way & $crate::stages::fine::WALK != 0,
                    &$crate::memory::Lanes::new(subgroup_lane),
                    setup_words,
                    wg,
                    lid,
                    frame,
                    setups,
                    offsets,
                    bins,
                    values,
                    owners,
                    coverage,
                    stats,
                    tile_stats,
                    params,
                    shading,
                    textures,
                    texels,
                    materials,
                    colours,
                    faces,
                    shared,
                );
            }
        }
    };
}

/// What a shader crate invokes, once, with its fragment shader `$shader` (an expression whose
/// type implements [`FragmentShader`]): on the GPU the shading stages' entry points around
/// it; natively `FRAGMENT_PROGRAM`, the same shader as the CPU backend's program, which the
/// host's `tileraster::fragment_stage!` takes. One expression for both, so the two backends
/// cannot run different shaders.
///
/// ```text
/// tileraster_kernels::fragment_shader!(Marble);
/// ```
#[macro_export]
macro_rules! fragment_shader {
    ($shader:expr) => {
        $crate::shading_entry_points!($crate::programs::fragment::Programmed($shader));
        /// This crate's fragment shader, for the CPU backend (`tileraster::fragment_stage!`).
        #[cfg(not(target_arch = "spirv"))]
        pub const FRAGMENT_PROGRAM: &(dyn $crate::programs::fragment::FragmentProgram + Sync) = &$crate::programs::fragment::Programmed($shader);
    };
}
