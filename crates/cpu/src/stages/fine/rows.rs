//! A triangle's rows of pixels in a tile, 16 lanes at a time: the fast paths' coverage test.

use std::simd::Simd;
use std::simd::cmp::SimdPartialOrd;
use tileraster_kernels::TILE;
use tileraster_kernels::abi::{PixelRect, TriangleSetup};

/// A triangle's pixels in one tile, a row of 16 lanes at a time: the triangle's rectangle
/// clipped to the tile, with the edge functions at the current row's first pixel. A row is
/// tested with additions only: the fill rule as thresholds (inside edge `k` ⇔ `w_k ≥ t_k`,
/// `t_k` one for an excluded edge, else zero: `side_of`'s `Inside` on integers), each edge's
/// steps along the row precomputed, the edge functions stepped from row to row. Every sum the
/// masks read is exact: inside the rectangle the edge functions stay below 2^60, and 15
/// steps beyond it add less than 2^50.
pub(super) struct TriangleRows<'a> {
    pub(super) setup: &'a TriangleSetup,
    /// The rectangle's first pixel in the tile, and its last row.
    pub(super) i0: i32,
    pub(super) j0: i32,
    pub(super) j1: i32,
    /// Its offset from the tile's first column, and its lanes (bits `0..len`).
    pub(super) shift: u32,
    pub(super) lanes: u64,
    pub(super) w: [i64; 3],
    pub(super) along: [Lanes; 3],
    pub(super) threshold: [Lanes; 3],
}

impl<'a> TriangleRows<'a> {
    /// `None` when the triangle's rectangle misses the tile's pixels in the window.
    #[inline(always)]
    pub(super) fn new(setup: &'a TriangleSetup, tile: &PixelRect) -> Option<Self> {
        let c = &setup.coverage;
        let (i0, i1) = (tile.i0.max(c.rect.i0), tile.i1.min(c.rect.i1));
        let (j0, j1) = (tile.j0.max(c.rect.j0), tile.j1.min(c.rect.j1));
        if i0 > i1 || j0 > j1 {
            return None;
        }
        let (di, dj) = ((i0 - c.rect.i0) as i64, (j0 - c.rect.j0) as i64);
        let e = &c.edges;
        Some(TriangleRows {
            setup,
            i0,
            j0,
            j1,
            shift: (i0 - tile.i0) as u32,
            lanes: (1u64 << (i1 - i0 + 1)) - 1,
            w: [0, 1, 2].map(|k| e[k].at(di, dj)),
            along: [0, 1, 2].map(|k| lane_steps(e[k].step_i)),
            threshold: [0, 1, 2].map(|k| Lanes::splat(i64::from(c.excluded_edges >> k & 1))),
        })
    }

    /// The current row's lanes whose centre is inside the triangle, and those that lie on an
    /// excluded edge (every edge function ≥ 0 but not inside: `side_of`'s `OnExcludedEdge`,
    /// rare). The comparisons go straight to bit masks (`std::simd`: a mask register where
    /// the CPU has one; written as scalar loops, they became OR-reductions).
    #[inline(always)]
    pub(super) fn masks(&self) -> (u64, u64) {
        self.masks_at(&self.at())
    }

    /// The current row's edge functions, lane by lane (exact: see the type's note).
    #[inline(always)]
    pub(super) fn at(&self) -> [Lanes; 3] {
        [0, 1, 2].map(|k| Lanes::splat(self.w[k]) + self.along[k])
    }

    /// [`Self::masks`] of the edge functions `at` (the current row's).
    #[inline(always)]
    pub(super) fn masks_at(&self, at: &[Lanes; 3]) -> (u64, u64) {
        let zero = Lanes::splat(0);
        let inside = ((at[0] - self.threshold[0]) | (at[1] - self.threshold[1]) | (at[2] - self.threshold[2])).simd_ge(zero).to_bitmask() & self.lanes;
        let closed = (at[0] | at[1] | at[2]).simd_ge(zero).to_bitmask();
        (inside, closed & !inside & self.lanes)
    }

    #[inline(always)]
    pub(super) fn next_row(&mut self) {
        let e = &self.setup.coverage.edges;
        self.w = [self.w[0] + e[0].step_j, self.w[1] + e[1].step_j, self.w[2] + e[2].step_j];
    }
}

/// The 16 pixels of a tile row, one `i64` each.
pub(super) type Lanes = Simd<i64, { TILE as usize }>;

/// `step · n` for the 16 lanes `n` of a tile row, wrapping: exact wherever the sum it goes
/// into is in range (the lanes of a triangle's rectangle), and never used elsewhere.
#[inline(always)]
pub(super) fn lane_steps(step: i64) -> Lanes {
    const LANE: Lanes = Lanes::from_array([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]);
    Lanes::splat(step) * LANE
}
