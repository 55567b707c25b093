//! The bits of one of the kernels' elementary functions (`tileraster_kernels::math::elementary`)
//! at each pixel's argument, as the pixel's four bytes: a frame that shows whether a device
//! computes them with the CPU's bits.
//!
//! The frame's constants choose: `constants[0]` the function ([`evaluate`]), `constants[1]` and
//! `constants[2]` the arguments' range, `constants[3]` the frame's width, `constants[4]` the
//! exponent of `pow`, `constants[5]` one over the frame's pixels.
#![cfg_attr(target_arch = "spirv", no_std)]

use tileraster_kernels::abi::ShadeParams;
use tileraster_kernels::math::elementary;
use tileraster_kernels::programs::brdf::{Cosines, Surface, reflected};
use tileraster_kernels::programs::fragment::{Fragment, FragmentShader};

/// The shader: stateless.
#[derive(Clone, Copy, Default)]
pub struct Values;

/// The functions in the order `constants[0]` numbers them; then glTF's BRDF along a path of
/// cosines ([`brdf`]), and [`chains`], no function but the arithmetic a compiler must leave as
/// written.
pub const FUNCTIONS: [&str; 11] = ["exp", "exp2", "ln", "log2", "pow", "sin", "cos", "asin", "acos", "brdf", "chains"];

impl FragmentShader for Values {
    fn shade(&self, f: &Fragment, params: &ShadeParams) -> [f32; 4] {
        let c = params.constants;
        let y = evaluate(c[0] as u32, argument(f.pixel, c), c[4]);
        bytes(y.to_bits())
    }
}

// The GPU's shading stages around the shader.
tileraster_kernels::fragment_shader!(Values);

/// Pixel `pixel`'s argument: its place in the frame, row by row, across `[c[1], c[2]]`.
#[inline]
pub fn argument(pixel: [i32; 2], c: [f32; 8]) -> f32 {
    let n = (pixel[1] as u32 * c[3] as u32 + pixel[0] as u32) as f32;
    c[1] + (c[2] - c[1]) * (n * c[5])
}

/// Function `k` of [`FUNCTIONS`] at `x` (`pow`'s exponent `y`).
#[inline]
pub fn evaluate(k: u32, x: f32, y: f32) -> f32 {
    match k {
        0 => elementary::exp(x),
        1 => elementary::exp2(x),
        2 => elementary::ln(x),
        3 => elementary::log2(x),
        4 => elementary::pow(x, y),
        5 => elementary::sin(x),
        6 => elementary::cos(x),
        7 => elementary::asin(x),
        8 => elementary::acos(x),
        9 => brdf(x),
        _ => chains(x),
    }
}

/// The red channel of glTF's BRDF (`programs::brdf::reflected`) of a half-metallic, fairly
/// smooth surface along a path of cosines: `n·h = x` from the edge of the highlight to its
/// peak, the light and the viewer turning with it.
#[inline]
pub fn brdf(x: f32) -> f32 {
    let s = Surface { base: [0.9, 0.6, 0.3], metallic: 0.5, roughness: 0.3 };
    let c = Cosines { n_l: 0.25 + 0.75 * x, n_v: 1.0 - 0.5 * x, n_h: x, v_h: 0.5 + 0.5 * x };
    reflected(&s, &c)[0]
}

/// `((c₁ − x·c₂·c₃) + c₄)`, each step rounded as written: a chain of multiplications by two
/// constants and one of additions of two, which an optimiser that folds constants would merge
/// (`x·(c₂c₃)`, `(c₁ + c₄) − …`) and round once where the CPU rounds twice.
#[inline]
pub fn chains(x: f32) -> f32 {
    (0.1 - (x * 1.1) * 1.3) + 0.3
}

/// A word's four bytes, low first, as colour channels `k / 255`: the frame stores them back
/// as the same bytes.
#[inline]
fn bytes(bits: u32) -> [f32; 4] {
    let byte = |k: u32| (bits >> k & 0xff) as f32 * (1.0 / 255.0);
    [byte(0), byte(8), byte(16), byte(24)]
}
