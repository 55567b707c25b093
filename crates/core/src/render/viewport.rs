//! Clip space to pixels: the clipping planes with their guard band, snapping to 8 sub-pixel
//! bits, and the pixels a snapped triangle may cover.

use super::params::{Cull, FrontFace, GUARD_PX, RENDER_SNAP_BITS, RenderParams};
use crate::Grid;
use crate::prepare::round_to_i64;
use tileraster_kernels::abi::PixelRect;
use tileraster_kernels::stages::assemble::{Assembly, CULL_BACK, CULL_FRONT, CULL_NONE, reach_rect};

/// Clip space to pixels.
pub(super) struct Viewport {
    pub(super) half: [f64; 2],
    /// Guard-band factor per axis: `|x| ≤ g·w` keeps a vertex within `GUARD_PX` of the viewport.
    pub(super) guard: [f64; 2],
}

impl Viewport {
    pub(super) fn new(w: u32, h: u32) -> Self {
        Viewport::with_guard(w, h, GUARD_PX)
    }

    /// With a guard band `guard_px` pixels wide.
    pub(super) fn with_guard(w: u32, h: u32, guard_px: f64) -> Self {
        let (w, h) = (w as f64, h as f64);
        Viewport { half: [w / 2.0, h / 2.0], guard: [1.0 + 2.0 * guard_px / w, 1.0 + 2.0 * guard_px / h] }
    }

    /// The clipping planes, as coefficients of `(x, y, z, w)`: inside where the dot product is
    /// at least zero (the `w` plane: at least `W_MIN`).
    pub(super) fn planes(&self) -> [[f64; 4]; 7] {
        let [gx, gy] = self.guard;
        [
            [0.0, 0.0, 1.0, 0.0],  // near: z ≥ 0
            [0.0, 0.0, -1.0, 1.0], // far: z ≤ w
            [0.0, 0.0, 0.0, 1.0],  // w ≥ W_MIN
            [1.0, 0.0, 0.0, gx],   // guard band
            [-1.0, 0.0, 0.0, gx],
            [0.0, 1.0, 0.0, gy],
            [0.0, -1.0, 0.0, gy],
        ]
    }

    /// `c` taken onto the clipping planes it lies beyond. A point clipping made is tested only
    /// against the planes after the one it was cut on, and near the centre of projection
    /// (`x = y = w = 0`) it comes from differences of nearly equal numbers: a rounding error
    /// outside an earlier plane, divided by its tiny `w`, would put its snapped position far
    /// beyond the guard band (where the kernels' 64-bit edge functions overflow) and its `1/w`
    /// beyond `f32`. On the planes, neither can happen. A point the `f64` tests found inside
    /// every plane does not move (the bounds are the tests' own comparisons).
    pub(super) fn onto_planes(&self, c: &[f64; 4]) -> [f64; 4] {
        let w = c[3].max(W_MIN);
        let [gx, gy] = self.guard;
        [c[0].clamp(-gx * w, gx * w), c[1].clamp(-gy * w, gy * w), c[2].clamp(0.0, w), w]
    }

    /// A clip-space position in snapped pixel units (`2^-RENDER_SNAP_BITS` px), `y` down.
    pub(super) fn snap(&self, c: &[f64; 4]) -> (i64, i64) {
        let unit = (1u64 << RENDER_SNAP_BITS) as f64;
        let px = (c[0] / c[3] + 1.0) * self.half[0];
        let py = (c[1] / c[3] + 1.0) * self.half[1];
        (round_to_i64(px * unit), round_to_i64(py * unit))
    }
}

/// The frame the geometry stages emit triangles for: its pixels, and what the kernels'
/// assembly decides with (culling, front face, samples per pixel).
#[derive(Clone, Copy)]
pub(super) struct Target {
    pub(super) assembly: Assembly,
}

impl Target {
    pub(super) fn new(grid: &Grid, params: &RenderParams) -> Self {
        let cull = match params.cull {
            Cull::None => CULL_NONE,
            Cull::Back => CULL_BACK,
            Cull::Front => CULL_FRONT,
        };
        // With several samples a pixel is covered where its samples are: the standard positions
        // lie within 7/16 px of the centre.
        let reach = if params.samples > 1 { 7 << (RENDER_SNAP_BITS - 4) } else { 0 };
        let assembly = Assembly {
            cull,
            front_counter_clockwise: u32::from(params.front_face == FrontFace::CounterClockwise),
            width: grid.width,
            height: grid.height,
            snap_bits: RENDER_SNAP_BITS,
            reach,
            double_sided: u32::from(params.double_sided),
        };
        Target { assembly }
    }

    /// The pixels a triangle with snapped vertices `x`, `y` may cover: those whose centre (or,
    /// with several samples, one of whose samples) may lie in its box.
    pub(super) fn rect(&self, x: &[i64; 3], y: &[i64; 3]) -> PixelRect {
        reach_rect(x, y, &self.assembly)
    }
}

/// The smallest `w` that reaches the rasteriser.
pub(super) const W_MIN: f64 = 1e-30;

/// Signed distance of `c` inside plane `k` of [`Viewport::planes`].
pub(super) fn distance(planes: &[[f64; 4]; 7], k: usize, c: &[f64; 4]) -> f64 {
    let p = &planes[k];
    let d = p[0] * c[0] + p[1] * c[1] + p[2] * c[2] + p[3] * c[3];
    if k == 2 { d - W_MIN } else { d }
}
