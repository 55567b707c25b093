//! Integer edge functions and the top-left fill rule. An edge function is exact in `i64` over
//! its triangle's pixel rectangle (the host bounds every snapped triangle, see
//! `stages::setup`), so every coverage decision is the same on every device.

use crate::abi::EdgeEq;

impl EdgeEq {
    /// The edge function at the pixel `(di, dj)` pixels from the rectangle's corner pixel.
    #[inline(always)]
    pub fn at(&self, di: i64, dj: i64) -> i64 {
        self.e0 + self.step_i * di + self.step_j * dj
    }

    /// [`Self::at`] in 32-bit wrapping arithmetic, plus `extra_i`, `extra_j` sixteenths of a
    /// step (a sample's offset): exact modulo 2^32, so exact wherever the value fits 32 bits
    /// (`stages::setup::edges_fit_i32`).
    #[inline(always)]
    pub fn at_i32(&self, di: i32, dj: i32, extra_i: i32, extra_j: i32) -> i32 {
        let (step_i, step_j) = (self.step_i as i32, self.step_j as i32);
        (self.e0 as i32)
            .wrapping_add(step_i.wrapping_mul(di))
            .wrapping_add(step_j.wrapping_mul(dj))
            .wrapping_add((step_i >> 4).wrapping_mul(extra_i))
            .wrapping_add((step_j >> 4).wrapping_mul(extra_j))
    }
}

/// Top-left rule for a positively oriented triangle in raster space (x right, y down): an
/// edge going right along the top (`dy == 0, dx > 0`) or going up on the left (`dy < 0`)
/// owns the pixel centres exactly on it.
pub fn is_top_left(dx: i64, dy: i64) -> bool {
    (dy == 0 && dx > 0) || dy < 0
}

/// Where a pixel centre lies relative to a triangle. (`u32`: SPIR-V has no 8-bit integers
/// without an extra capability.)
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug))]
pub enum Side {
    Outside,
    /// On an edge the fill rule gives to the neighbour across it (if there is one).
    OnExcludedEdge,
    Inside,
}

/// Where a pixel centre lies, from the three edge functions there and the triangle's
/// excluded edges (bit `k`: edge `k` is not top-left).
#[inline(always)]
pub fn side_of(w0: i64, w1: i64, w2: i64, excluded_edges: u32) -> Side {
    side_from((w0 | w1 | w2) < 0, (w0 == 0) as u32 | ((w1 == 0) as u32) << 1 | ((w2 == 0) as u32) << 2, excluded_edges)
}

/// [`side_of`] for edge functions that fit 32 bits (`stages::setup::edges_fit_i32`): the same
/// decision in 32-bit operations.
#[inline(always)]
pub fn side_of_i32(w0: i32, w1: i32, w2: i32, excluded_edges: u32) -> Side {
    side_from((w0 | w1 | w2) < 0, (w0 == 0) as u32 | ((w1 == 0) as u32) << 1 | ((w2 == 0) as u32) << 2, excluded_edges)
}

/// The side, from whether an edge function is negative and which are zero (bit `k`: edge `k`).
#[inline(always)]
fn side_from(negative: bool, on_edges: u32, excluded_edges: u32) -> Side {
    if negative {
        Side::Outside
    } else if on_edges & excluded_edges != 0 {
        Side::OnExcludedEdge
    } else {
        Side::Inside
    }
}
