//! Triangle setup: integer edge functions stepped from the corner pixel of the triangle's
//! rectangle, and which edges the fill rule excludes.
//!
//! Range: the host guarantees `(extent_px + 1) << snap_bits < 2^29` for every triangle
//! (`EXTENT_LIMIT_BITS`), so coordinate differences stay below 2^29 and every product here,
//! and every edge value inside the rectangle, stays below 2^60. A smaller triangle's edge
//! values fit 32 bits ([`edges_fit_i32`]), where the fine stages may take them in 32-bit
//! arithmetic (`stages::fine::side_and_edges_small`).

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

/// Whether every edge function of the triangle lies in `(−2^31, 2^31)` at every point within
/// two pixels of its snapped bounding box on each axis, so that 32-bit wrapping arithmetic on
/// the setup's terms gives it exactly there (every operation is exact modulo 2^32, and the one
/// value in range that agrees modulo 2^32 is the true one). That holds every point the stages
/// evaluate: the centres of the triangle's rectangle lie in the box, or with several samples
/// within 7/16 px of it (the render pipeline widens a multisampled triangle's rectangle so);
/// a sample lies within 7/16 px of its centre, and the shade stage's quad corners (the level
/// of detail's) within a pixel. The bound: with `E` the larger side of the box,
/// `|dx|, |dy| ≤ E` and `|p − a| ≤ E + 2·unit` on each axis, so
/// `|e(p)| ≤ |dx|·|p.y − a.y| + |dy|·|p.x − a.x| ≤ 2·E·(E + 2·unit) < 2^31`.
pub fn edges_fit_i32(input: &TriangleInput, snap_bits: u32) -> bool {
    let side = |v: &[i64; 3]| v[0].max(v[1]).max(v[2]) - v[0].min(v[1]).min(v[2]);
    let extent = side(&input.x).max(side(&input.y));
    2 * extent * (extent + (2 << snap_bits)) < 1 << 31
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::abi::PixelRect;
    use crate::programs::multisample::{sample_edges, sample_edges_small};
    use crate::stages::fine::{side_and_edges, side_and_edges_small};

    /// Triangles at the bound's edge, every orientation, with the rectangles of one sample and
    /// of several (widened by 7/16 px, as the render pipeline widens them): where
    /// `edges_fit_i32` holds, the 32-bit edge functions equal the 64-bit ones at the
    /// rectangle's corner pixels (where a linear function is extreme), at every sample of
    /// them and at the pixels around them (the shade stage's quad corners); just past the
    /// bound it fails.
    #[test]
    fn small_edges_are_exact_within_the_bound() {
        let snap_bits = 8;
        let unit = 1i64 << snap_bits;
        // The largest extent the bound allows at 8 bits: 2E(E + 512) < 2^31.
        let limit = (0i64..1 << 16).take_while(|&e| 2 * e * (e + 2 * unit) < 1 << 31).last().unwrap();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |n: i64| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as i64 % n
        };
        let mut checked = 0;
        for _ in 0..2000 {
            let (x0, y0) = (next(1 << 20), next(1 << 20));
            let x = [x0, x0 + next(limit + 1), x0 + next(limit + 1)];
            let y = [y0, y0 + next(limit + 1), y0 + limit * next(2)];
            let pixel = |v: i64, up: bool| if up { (v - unit / 2 + unit - 1).div_euclid(unit) } else { (v - unit / 2).div_euclid(unit) } as i32;
            let reach = if next(2) == 0 { 0 } else { 7 * unit / 16 };
            let rect = PixelRect {
                i0: pixel(*x.iter().min().unwrap() - reach, true),
                j0: pixel(*y.iter().min().unwrap() - reach, true),
                i1: pixel(*x.iter().max().unwrap() + reach, false),
                j1: pixel(*y.iter().max().unwrap() + reach, false),
            };
            if rect.i0 > rect.i1 || rect.j0 > rect.j1 {
                continue;
            }
            let input = TriangleInput { x, y, rect, ..Default::default() };
            assert!(edges_fit_i32(&input, snap_bits));
            let c = setup_triangle(&input, 0, snap_bits).coverage;
            for (i, j) in [(rect.i0, rect.j0), (rect.i1, rect.j0), (rect.i0, rect.j1), (rect.i1, rect.j1)] {
                assert_eq!(side_and_edges_small(&c, i, j).1, side_and_edges(&c, i, j).1, "{x:?} {y:?} at ({i}, {j})");
                for samples in [4, 8] {
                    for s in 0..samples {
                        assert_eq!(sample_edges_small(&c, i, j, samples, s), sample_edges(&c, i, j, samples, s));
                    }
                }
                for (oi, oj) in [(-1, -1), (-1, 1), (1, -1), (1, 1)] {
                    let (di, dj) = (i + oi - rect.i0, j + oj - rect.j0);
                    for e in &c.edges {
                        assert_eq!(e.at_i32(di, dj, 0, 0) as i64, e.at(di as i64, dj as i64), "{x:?} {y:?} at ({di}, {dj}) from the corner");
                    }
                }
                checked += 1;
            }
        }
        assert!(checked > 4000, "{checked}");
        let wide = TriangleInput { x: [0, limit + 1, 0], y: [0, 0, 1], ..Default::default() };
        assert!(!edges_fit_i32(&wide, snap_bits));
    }
}
