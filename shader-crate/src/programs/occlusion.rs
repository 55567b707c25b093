//! Hierarchical depth rejection for the render pipeline's depth test: before a tile's pixels
//! test its bin, the bin gives the tile a depth bound, and a triangle whose keys all lie above
//! it cannot own any pixel of the tile. Fine raster then skips its keys (and, where no
//! coverage count is asked for, its edge tests). It changes no bit: only triangles that lose
//! every pixel are rejected, and the rejections are counted (`Counter::TrianglesHidden`).
//!
//! A triangle that covers the tile whole (`FULL_TILE_BIT`) and passes the depth test all over
//! it gives every pixel a key no larger than its own largest key in the tile: the tile's
//! bound is the smallest such key. It does not depend on the order of the bin.
//!
//! The bounds are exact, not estimated: the depth ([`barycentric_bits`]) is
//! `Σ fl(fl(f32(e_k) · c3) · c_k)`, summed left to right, with `c3 > 0` and depths `c_k ≥ 0`,
//! and each step (the conversion, the products, the sums) is monotone, so evaluating it with
//! each edge function at its smallest (largest) value over the tile's centres, found at the
//! tile's corners as the edge functions are affine, gives a lower (upper) bound of every
//! centre's depth. A zero bound is taken as −0 below and +0 above, the ends of the zeros in
//! the keys' order. The bounds ignore that the weights sum to one, so they are tight only for
//! triangles much larger than a tile: the occluders that matter.
//!
//! Everything here is integers, conversions and correctly rounded products and sums, so both
//! backends reject the same triangles.
//!
//! [`barycentric_bits`]: crate::programs::height::barycentric_bits

use crate::abi::{PixelRect, TriangleSetup};
use crate::math::fixed::i64_to_f32;
use crate::programs::depth::DepthProgram;
use crate::stages::fine::PixelProgram;

/// Whether `x` is neither infinite nor NaN.
#[inline]
fn finite(x: f32) -> bool {
    x.to_bits() & 0x7f80_0000 != 0x7f80_0000
}

/// Bounds of the depths of triangle `s` over the centres of `tile`: `(low, high, valid)`, not
/// valid where the argument above does not hold (a coefficient negative or not finite).
#[inline]
pub fn depth_bounds(s: &TriangleSetup, tile: &PixelRect) -> (f32, f32, bool) {
    let c = &s.coeffs.c;
    if !(c[3] > 0.0 && finite(c[3]) && c[0] >= 0.0 && finite(c[0]) && c[1] >= 0.0 && finite(c[1]) && c[2] >= 0.0 && finite(c[2])) {
        return (0.0, 0.0, false);
    }
    let rect = &s.coverage.rect;
    let (di0, di1) = ((tile.i0 - rect.i0) as i64, (tile.i1 - rect.i0) as i64);
    let (dj0, dj1) = ((tile.j0 - rect.j0) as i64, (tile.j1 - rect.j0) as i64);
    // Each edge's weight at its smallest and largest over the tile's corners (three calls with
    // a constant index, not a loop over arrays: see `stages::bin::tile_cover`).
    let weights = |k: usize| {
        let edge = &s.coverage.edges[k];
        let (a, b, c_, d) = (edge.at(di0, dj0), edge.at(di1, dj0), edge.at(di0, dj1), edge.at(di1, dj1));
        let (min, max) = (min_i64(min_i64(a, b), min_i64(c_, d)), max_i64(max_i64(a, b), max_i64(c_, d)));
        (i64_to_f32(min) * c[3], i64_to_f32(max) * c[3])
    };
    let ((lo0, hi0), (lo1, hi1), (lo2, hi2)) = (weights(0), weights(1), weights(2));
    let (lo, hi) = ([lo0, lo1, lo2], [hi0, hi1, hi2]);
    let low = lo[0] * c[0] + lo[1] * c[1] + lo[2] * c[2];
    let high = hi[0] * c[0] + hi[1] * c[1] + hi[2] * c[2];
    if !(finite(low) && finite(high)) {
        return (0.0, 0.0, false);
    }
    // The zeros' ends in the keys' order: −0 below +0.
    (if low == 0.0 { -0.0 } else { low }, if high == 0.0 { 0.0 } else { high }, true)
}

#[inline]
fn min_i64(a: i64, b: i64) -> i64 {
    if a < b { a } else { b }
}

#[inline]
fn max_i64(a: i64, b: i64) -> i64 {
    if a > b { a } else { b }
}

impl DepthProgram {
    /// The smallest and largest key triangle `s` can have where its depth lies in
    /// `[low, high]` (the key is monotone in the depth, one way or the other).
    #[inline]
    fn key_bounds(&self, s: &TriangleSetup, low: f32, high: f32) -> (u64, u64) {
        let (a, b) = (self.key_of(low.to_bits(), s.coverage.index), self.key_of(high.to_bits(), s.coverage.index));
        if a < b { (a, b) } else { (b, a) }
    }

    /// The key below which triangle `s`, covering `tile` whole, leaves every pixel of it: its
    /// largest key there, where it passes the depth test all over the tile (each test is one
    /// interval of depths, so passing at both bounds is passing everywhere between), else
    /// `NO_KEY`.
    #[inline]
    pub fn occluder_key_of(&self, s: &TriangleSetup, tile: &PixelRect) -> u64 {
        let (low, high, valid) = depth_bounds(s, tile);
        if valid && self.passes(low) && self.passes(high) { self.key_bounds(s, low, high).1 } else { Self::NO_KEY }
    }

    /// The smallest key triangle `s` can have over `tile`, where the depth bounds hold, else 0
    /// (no bound lies below it): the triangle owns no pixel of the tile exactly where this lies
    /// above the tile's bound (`NO_KEY`, no bound, lies above nothing).
    #[inline]
    pub fn lowest_key_of(&self, s: &TriangleSetup, tile: &PixelRect) -> u64 {
        let (low, high, valid) = depth_bounds(s, tile);
        if valid { self.key_bounds(s, low, high).0 } else { 0 }
    }
}
