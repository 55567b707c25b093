//! Ocean waves: a flat sea lifted by three travelling waves, a vertex shader for tileraster's
//! programmable vertex stage, written once in `no_std` Rust: `tileraster-build` compiles this
//! crate to SPIR-V for the GPU backend, and the host links it natively for the CPU backend and
//! for its own stages; all give the same bits.
//!
//! Everything here keeps tileraster's numeric contract: float additions, subtractions,
//! multiplications and comparisons, and conversions. No `sin`: each wave is a periodic
//! parabola ([`swell`]), whose bits are the same on every device.
//!
//! The frame's constants tune it: `constants[0]` the height of the highest wave's crest above
//! the still sea, in the mesh's units (0: a flat sea); the frame's time moves the waves. A
//! vertex texture, where the frame hands one, is a calm map: a texel per vertex of the sea's
//! grid, row by row, scaling the crest there (0 behind a breakwater, 1 in the open sea).
#![cfg_attr(target_arch = "spirv", no_std)]

use tileraster_kernels::abi::VertexUniforms;
use tileraster_kernels::math::float::floor;
use tileraster_kernels::programs::vertex::{Vertex, VertexShader, texel};

/// The shader: a stateless sea.
#[derive(Clone, Copy, Default)]
pub struct Waves;

/// Each wave: direction (a unit vector in the plane), wavenumber (cycles per mesh unit), speed
/// (cycles per second) and height relative to the highest.
const WAVES: [([f32; 2], f32, f32, f32); 3] =
    [([0.8, 0.6], 1.0 / 420.0, 0.11, 1.0), ([-0.28, 0.96], 1.0 / 230.0, 0.17, 0.45), ([0.96, -0.28], 1.0 / 97.0, 0.29, 0.18)];

impl VertexShader for Waves {
    fn position(&self, vertex: &Vertex, uniforms: &VertexUniforms, texture: &[f32]) -> [f32; 3] {
        let [x, y, z] = vertex.position;
        let width = uniforms.texture_size[0];
        let calm = if width > 0 { texel(texture, uniforms, (vertex.index % width) as i32, (vertex.index / width) as i32) } else { 1.0 };
        let crest = uniforms.constants[0] * calm;
        let mut lift = 0.0;
        let mut k = 0;
        while k < WAVES.len() {
            let (d, number, speed, height) = WAVES[k];
            let phase = (d[0] * x + d[1] * y) * number - speed * uniforms.time;
            lift += height * swell(phase);
            k += 1;
        }
        [x, y, z + crest * lift]
    }
}

// The GPU's vertex stage around the shader.
tileraster_kernels::vertex_shader!(Waves);

/// A wave of period 1 shaped like a sine (within 6 % of `sin 2πx` in height), smooth to its
/// first derivative: the parabolas `±4u(1 − |u|)` over each half-period, 1 at the crests
/// (`x = ¼`) and −1 in the troughs (`x = ¾`).
#[inline]
pub fn swell(x: f32) -> f32 {
    let u = floor(x).1 * 2.0 - 1.0;
    let magnitude = if u < 0.0 { -u } else { u };
    -4.0 * u * (1.0 - magnitude)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn the_swell_is_periodic_bounded_and_close_to_a_sine() {
        for k in -4000..4000 {
            let x = k as f32 * 0.00125;
            let s = swell(x);
            assert!((-1.0..=1.0).contains(&s), "swell({x}) = {s}");
            let sine = (std::f64::consts::TAU * x as f64).sin();
            assert!((s as f64 - sine).abs() < 0.06, "swell({x}) = {s}, sin = {sine}");
        }
        assert_eq!(swell(0.25), 1.0);
        assert_eq!(swell(0.75), -1.0);
        assert_eq!(swell(0.0), 0.0);
    }

    #[test]
    fn a_still_sea_leaves_every_vertex_where_it_is() {
        let still = VertexUniforms { time: 12.5, ..VertexUniforms::default() };
        for p in [[0.0f32, 0.0, 0.0], [-1000.0, 999.5, 3.25], [1.0e-3, -7.0, -0.0]] {
            let posed = Waves.position(&Vertex { index: 3, position: p }, &still, &[]);
            // Equal values (a height of −0 may come back as +0 or −0: the stage's pairs move
            // by the difference, 0 either way).
            assert_eq!(posed, p);
        }
    }
}
