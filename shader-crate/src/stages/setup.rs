//! Triangle setup: integer edge functions stepped from the corner pixel of the triangle's
//! rectangle, and which edges the fill rule excludes.
//!
//! Range: the host guarantees `(extent_px + 1) << snap_bits < 2^29` for every triangle
//! (`EXTENT_LIMIT_BITS`), so coordinate differences stay below 2^29 and every product here,
//! and every edge value inside the rectangle, stays below 2^60.

use crate::abi::{Coverage, EdgeEq, TriangleInput, TriangleSetup};
use crate::math::edge::is_top_left;

pub fn setup_triangle(input: &TriangleInput, slot: u32, snap_bits: u32) -> TriangleSetup {
    let unit = 1i64 << snap_bits;
    // Centre of the rectangle's corner pixel, in snapped units.
    let px = input.rect.i0 as i64 * unit + (unit >> 1);
    let py = input.rect.j0 as i64 * unit + (unit >> 1);
    // Edge `k` runs from vertex `k` to the next (three calls with a constant index, not a loop:
    // a CPU implementation of Vulkan reaches an array indexed by a loop counter one lane at a
    // time).
    let edge = |k: usize, b: usize| {
        let dx = input.x[b] - input.x[k];
        let dy = input.y[b] - input.y[k];
        // Positive inside: e(p) = dx·(p.y − a.y) − dy·(p.x − a.x).
        let e0 = dx * (py - input.y[k]) - dy * (px - input.x[k]);
        let excluded = if is_top_left(dx, dy) { 0 } else { 1 << k };
        (EdgeEq { e0, step_i: -dy * unit, step_j: dx * unit }, excluded)
    };
    let ((e0, x0), (e1, x1), (e2, x2)) = (edge(0, 1), edge(1, 2), edge(2, 0));
    let (edges, excluded_edges) = ([e0, e1, e2], x0 | x1 | x2);
    TriangleSetup {
        coverage: Coverage { edges, rect: input.rect, index: input.index, slot, excluded_edges, _pad: 0 },
        plane: input.plane,
        coeffs: input.coeffs,
    }
}
