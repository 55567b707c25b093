//! Marble: veins of a turbulent stripe pattern through the world, lit by the frame's lights.
//! A fragment shader for tileraster's programmable fragment stage, written once in `no_std`
//! Rust: `tileraster-build` compiles this crate to SPIR-V for the GPU backend, and the host
//! links it natively for the CPU backend; both give the same bits.
//!
//! Everything here keeps tileraster's numeric contract: integer hashing, float additions,
//! subtractions and multiplications, and conversions. No division, no `sin`: the
//! build refuses a module whose bits would depend on the device.
//!
//! The frame's constants tune it: `constants[0]` veins per world unit (3 when 0),
//! `constants[1]` the turbulence (1.5 when 0).
#![cfg_attr(target_arch = "spirv", no_std)]

use tileraster_kernels::abi::{SHADING_UNLIT, ShadeParams};
use tileraster_kernels::math::float::floor;
use tileraster_kernels::programs::fragment::{Fragment, FragmentShader};
use tileraster_kernels::programs::shade::phong;

/// The shader: a stateless marble.
#[derive(Clone, Copy, Default)]
pub struct Marble;

const DEFAULT_SCALE: f32 = 3.0;
const DEFAULT_TURBULENCE: f32 = 1.5;
/// The stone's colour and the veins'.
const STONE: [f32; 3] = [0.93, 0.91, 0.86];
const VEIN: [f32; 3] = [0.22, 0.25, 0.32];

impl FragmentShader for Marble {
    fn shade(&self, f: &Fragment, params: &ShadeParams) -> [f32; 4] {
        // Lines keep their own colour (a wireframe over the marble).
        if f.flags & SHADING_UNLIT != 0 {
            return f.colour;
        }
        let scale = or_default(params.constants[0], DEFAULT_SCALE);
        let turbulence = or_default(params.constants[1], DEFAULT_TURBULENCE);
        let p = [f.position[0] * scale, f.position[1] * scale, f.position[2] * scale];
        // Stripes across x and y, bent by the noise: 1 on a vein's axis, 0 between veins.
        let v = triangle_wave(p[0] + p[1] * 0.5 + turbulence * fbm(p));
        let vein = pow8(v);
        let colour = |c: usize| lerp(STONE[c], VEIN[c], vein) * f.base[c];
        phong(params, [colour(0), colour(1), colour(2), f.base[3]], f.normal, f.position)
    }
}

// The GPU's shading stages around the shader.
tileraster_kernels::fragment_shader!(Marble);

/// `x`, or `default` where `x` is not positive.
#[inline]
fn or_default(x: f32, default: f32) -> f32 {
    if x > 0.0 { x } else { default }
}

/// `x⁸`: thin veins, dark only near their axes.
#[inline]
fn pow8(x: f32) -> f32 {
    let x2 = x * x;
    let x4 = x2 * x2;
    x4 * x4
}

/// `|2·fract(x) − 1|` turned over: 1 at the integers, 0 halfway between.
#[inline]
pub fn triangle_wave(x: f32) -> f32 {
    let (_, f) = floor(x);
    let d = f * 2.0 - 1.0;
    if d < 0.0 { 1.0 + d } else { 1.0 - d }
}

/// A hash of a lattice point to `[0, 1)` in steps of `2^-24`.
#[inline]
pub fn lattice(x: i32, y: i32, z: i32) -> f32 {
    let mut h = (x as u32).wrapping_mul(0x8da6_b343) ^ (y as u32).wrapping_mul(0xd816_3841) ^ (z as u32).wrapping_mul(0xcb1a_b31f);
    h ^= h >> 15;
    h = h.wrapping_mul(0x2c1b_3c6d);
    h ^= h >> 12;
    h = h.wrapping_mul(0x297a_2d39);
    h ^= h >> 15;
    (h >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// `3t² − 2t³`: a weight whose slope vanishes at the lattice.
#[inline]
fn smooth(t: f32) -> f32 {
    t * t * (3.0 - t * 2.0)
}

#[inline]
fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Value noise in `[0, 1)`: the lattice's hashes, trilinearly blended with smooth weights.
pub fn noise(p: [f32; 3]) -> f32 {
    let (x, fx) = floor(p[0]);
    let (y, fy) = floor(p[1]);
    let (z, fz) = floor(p[2]);
    let (u, v, w) = (smooth(fx), smooth(fy), smooth(fz));
    lerp(plane(x, y, z, u, v), plane(x, y, z + 1, u, v), w)
}

/// The lattice's values in the plane `z` around cell `(x, y)`, bilinearly blended by `(u, v)`.
#[inline]
fn plane(x: i32, y: i32, z: i32, u: f32, v: f32) -> f32 {
    let bottom = lerp(lattice(x, y, z), lattice(x + 1, y, z), u);
    let top = lerp(lattice(x, y + 1, z), lattice(x + 1, y + 1, z), u);
    lerp(bottom, top, v)
}

/// Three octaves of [`noise`], each twice as fine and half as strong: in `[0, 1.75)`.
pub fn fbm(p: [f32; 3]) -> f32 {
    let mut sum = 0.0;
    let (mut q, mut amplitude) = (p, 1.0);
    let mut octave = 0;
    while octave < 3 {
        sum += amplitude * noise(q);
        q = [q[0] * 2.0, q[1] * 2.0, q[2] * 2.0];
        amplitude *= 0.5;
        octave += 1;
    }
    sum
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// Values across the range, both signs, integers and their neighbours.
    fn samples() -> impl Iterator<Item = f32> {
        let mut x = 0x1234_5678u32;
        let random = std::iter::repeat_with(move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32 - 0.5) * 2e6
        });
        let near_integers = (-40..40).flat_map(|k| [k as f32, f32::from_bits((k as f32).to_bits() + 1), k as f32 - 1e-3, k as f32 + 0.5]);
        near_integers.chain(random.take(100_000))
    }

    #[test]
    fn the_triangle_wave_matches_its_f64_definition() {
        for x in samples().filter(|x| x.abs() < 1000.0) {
            let want = 1.0 - (2.0 * (x as f64 - (x as f64).floor()) - 1.0).abs();
            assert!((triangle_wave(x) as f64 - want).abs() <= 2e-7 * (1.0 + x.abs() as f64), "triangle_wave({x}) = {}, want {want}", triangle_wave(x));
        }
    }

    #[test]
    fn the_noise_is_in_range_and_continuous_across_the_lattice() {
        for x in samples().filter(|x| x.abs() < 1000.0) {
            let p = [x, x * 0.37 + 0.5, -x * 0.71];
            let n = noise(p);
            assert!((0.0..1.0).contains(&n), "noise({p:?}) = {n}");
            assert!((0.0..1.75).contains(&fbm(p)));
        }
        // At a lattice point the noise is the lattice's value, approached from either side.
        let at = noise([3.0, -2.0, 5.0]);
        assert_eq!(at, lattice(3, -2, 5));
        for eps in [1e-4f32, -1e-4] {
            assert!((noise([3.0 + eps, -2.0, 5.0]) - at).abs() < 1e-3, "continuous at the lattice");
        }
    }
}
