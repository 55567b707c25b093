//! Fine raster: one workgroup per tile, one invocation per pixel. The tile's bin is walked in
//! batches: every invocation stages one triangle's coverage data in workgroup memory
//! (`fine_load`), barrier, every invocation tests its pixel centre against the whole batch
//! (`fine_test`), barrier. Finally each invocation resolves its pixel (`fine_resolve`).
//!
//! Fill rule: a pixel centre strictly inside a triangle, or on one of its top-left edges, is
//! *inside* it; in a mesh that tiles a region every centre of the region's interior is inside
//! exactly one triangle. A centre that is inside no triangle but lies exactly on the edge of
//! one (an edge no triangle continues beyond: the mesh's outer boundary) is still covered, by
//! the lowest-index triangle it touches, as gdal_grid covers hull points.
//!
//! Specialisations, each allowed by a bit of `FrameParams::flags`; none changes a bit of the
//! output:
//! - a tile with an empty bin writes nodata straight away (`empty_tile`);
//! - a tile whose bin holds a single triangle that covers all of it (binning marks such
//!   entries with `FULL_TILE_BIT`) skips the batches: every pixel is inside that triangle
//!   (`full_tile`);
//! - where the host proved that no pixel centre is inside two triangles (`overlap_free`), a
//!   pixel stops testing at the first triangle it is inside: that one owns it, the count is 1.
//!
//! Ownership is the minimum triangle index over the triangles a centre is inside, which does
//! not depend on the order of the bin; the coverage count is a plain count. Both are
//! therefore deterministic whatever the scheduling of the binning atomics.

use crate::math::fixed::fixed_to_f32_bits;
use crate::abi::{Counter, Coverage, FloatCoeffs, FrameFlags, FrameParams, Plane, PixelRect, TriangleSetup, ValueMode};
use crate::math::edge::{side_of, Side};
use crate::memory::Counters;
use crate::{BATCH, FULL_TILE_BIT, NO_OWNER, TILE};

/// Workgroup memory of fine raster.
#[repr(C)]
#[derive(Copy, Clone)]
pub struct FineShared {
    pub batch: [Coverage; BATCH as usize],
}

/// What one invocation carries across the batches of its tile.
#[derive(Copy, Clone)]
pub struct PixelState {
    /// Lowest index of a triangle the centre is inside (`NO_OWNER` if none).
    pub owner: u32,
    /// Setup slot of that triangle.
    pub slot: u32,
    /// Number of triangles the centre is inside.
    pub count: u32,
    /// Lowest index of a triangle whose excluded edge the centre lies on.
    pub edge_owner: u32,
    /// Setup slot of that triangle.
    pub edge_slot: u32,
}

impl PixelState {
    pub const EMPTY: PixelState = PixelState { owner: NO_OWNER, slot: 0, count: 0, edge_owner: NO_OWNER, edge_slot: 0 };
}

/// The resolved pixel: its value bits, owner and coverage count.
#[derive(Copy, Clone)]
pub struct PixelOut {
    pub value_bits: u32,
    pub owner: u32,
    pub count: u32,
}

/// Grid pixel `(i, j)` of invocation `lid` in window tile `(tx, ty)`, and whether it lies in
/// the window (edge tiles overhang it).
#[inline]
pub fn tile_pixel(tx: u32, ty: u32, lid: u32, frame: &FrameParams) -> (i32, i32, bool) {
    let lx = lid % TILE;
    let ly = lid / TILE;
    let wx = tx * TILE + lx;
    let wy = ty * TILE + ly;
    let inside = wx < frame.win_w && wy < frame.win_h;
    ((frame.win_x0 + wx) as i32, (frame.win_y0 + wy) as i32, inside)
}

/// Index of grid pixel `(i, j)` in the window's row-major output buffers.
#[inline]
pub fn window_index(i: i32, j: i32, frame: &FrameParams) -> usize {
    ((j as u32 - frame.win_y0) * frame.win_w + (i as u32 - frame.win_x0)) as usize
}

/// Phase 1: invocation `lid` stages entry `batch_start + lid` of the tile's bin.
#[inline]
pub fn fine_load(
    lid: u32,
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    batch_start: u32,
    setups: &[TriangleSetup],
    shared: &mut FineShared,
) {
    let k = batch_start + lid;
    if lid < BATCH && k < bin_len {
        let slot = bin[(bin_start + k) as usize] & !FULL_TILE_BIT;
        shared.batch[lid as usize] = setups[slot as usize].coverage;
    }
}

/// Where pixel centre `(i, j)` lies relative to the triangle.
#[inline]
pub fn side(c: &Coverage, i: i32, j: i32) -> Side {
    if !c.rect.contains(i, j) {
        return Side::Outside;
    }
    let di = (i - c.rect.i0) as i64;
    let dj = (j - c.rect.j0) as i64;
    let e = &c.edges;
    side_of(e[0].at(di, dj), e[1].at(di, dj), e[2].at(di, dj), c.excluded_edges)
}

/// What a pixel state keeps of one triangle test: a count, and the lowest index (with its
/// setup slot) among the triangles it is inside, or on an excluded edge of. Minimum and sum
/// do not depend on the order of the tests.
#[inline(always)]
pub fn accumulate(side: Side, c: &Coverage, state: &mut PixelState) {
    match side {
        Side::Inside => {
            state.count += 1;
            if c.index < state.owner {
                state.owner = c.index;
                state.slot = c.slot;
            }
        }
        Side::OnExcludedEdge => {
            if c.index < state.edge_owner {
                state.edge_owner = c.index;
                state.edge_slot = c.slot;
            }
        }
        Side::Outside => {}
    }
}

/// Whether the frame lets a pixel stop at the first triangle it is inside.
#[inline]
pub fn overlap_free(frame: &FrameParams) -> bool {
    frame.flags.contains(FrameFlags::OVERLAP_FREE)
}

/// Phase 2: test pixel `(i, j)` against the `batch_len` staged triangles (with `overlap_free`,
/// only until it is inside one: no other can contain it).
#[inline]
pub fn fine_test(i: i32, j: i32, batch_len: u32, shared: &FineShared, overlap_free: bool, state: &mut PixelState) {
    let mut k = 0;
    while k < batch_len {
        if overlap_free && state.owner != NO_OWNER {
            return;
        }
        let c = &shared.batch[k as usize];
        accumulate(side(c, i, j), c, state);
        k += 1;
    }
}

/// Whether the tile takes the empty path: nothing in its bin, so every pixel is nodata.
#[inline]
pub fn empty_tile(bin_len: u32, frame: &FrameParams) -> bool {
    bin_len == 0 && frame.flags.contains(FrameFlags::EMPTY_TILES)
}

/// Whether the tile takes the full path: its bin is a single triangle covering the whole tile.
/// If so, `state` becomes every pixel's state, with no edge test.
#[inline]
pub fn full_tile(bin: &[u32], bin_start: u32, bin_len: u32, setups: &[TriangleSetup], frame: &FrameParams, state: &mut PixelState) -> bool {
    if !frame.flags.contains(FrameFlags::FULL_TILES) || bin_len != 1 || bin[bin_start as usize] & FULL_TILE_BIT == 0 {
        return false;
    }
    let slot = bin[bin_start as usize] & !FULL_TILE_BIT;
    *state = PixelState { owner: setups[slot as usize].coverage.index, slot, count: 1, edge_owner: NO_OWNER, edge_slot: 0 };
    true
}

/// The owner's plane at pixel `(i, j)`, correctly rounded to `f32`, or `±f32::MAX` where it
/// lies beyond the `f32` range. Inside a triangle the plane lies between the vertex heights;
/// only a centre that snapping lets it cover from just outside can be beyond them.
#[inline]
pub fn plane_value_bits(plane: &Plane, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    saturate_infinity(fixed_to_f32_bits(plane.z + plane.gi * di + plane.gj * dj, plane.frac_bits))
}

/// `±∞` becomes `±f32::MAX` (the bits just below); every other value stays.
#[inline]
pub fn saturate_infinity(bits: u32) -> u32 {
    if bits & 0x7fff_ffff == 0x7f80_0000 { bits - 1 } else { bits }
}

/// `ValueMode::PlaneF32`: `(z + gi·Δi) + gj·Δj` in `f32`. `Δi`, `Δj` convert exactly (they are below
/// 2^24); each product and sum rounds once, unless a device contracts `a·b + c`.
#[inline]
pub fn plane_f32_bits(coeffs: &FloatCoeffs, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let c = &coeffs.c;
    let di = (i - rect.i0) as f32;
    let dj = (j - rect.j0) as f32;
    (c[0] + c[1] * di + c[2] * dj).to_bits()
}

/// `ValueMode::Barycentric`: the barycentric weights `wk / Σw` of the snapped triangle in `f32`, as a
/// hardware rasteriser computes them, times the vertex heights. The edge functions are
/// converted with the exact integer conversion so that only the products and sums round.
#[inline]
pub fn barycentric_bits(s: &TriangleSetup, i: i32, j: i32) -> u32 {
    let c = &s.coeffs.c;
    let rect = &s.coverage.rect;
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    let e = &s.coverage.edges;
    let weight = |k: usize| f32::from_bits(fixed_to_f32_bits(e[k].at(di, dj), 0)) * c[3];
    (weight(0) * c[0] + weight(1) * c[1] + weight(2) * c[2]).to_bits()
}

/// The value bits of pixel `(i, j)` on the triangle in setup slot `slot`, in the frame's mode.
#[inline]
pub fn pixel_value_bits(s: &TriangleSetup, i: i32, j: i32, mode: ValueMode) -> u32 {
    match mode {
        ValueMode::PlaneF32 => plane_f32_bits(&s.coeffs, &s.coverage.rect, i, j),
        ValueMode::Barycentric => barycentric_bits(s, i, j),
        ValueMode::Exact => plane_value_bits(&s.plane, &s.coverage.rect, i, j),
    }
}

/// Phase 3: the pixel's outputs. A centre inside no triangle falls back to a triangle whose
/// excluded edge it lies on: nobody continues across that edge.
#[inline]
pub fn fine_resolve(i: i32, j: i32, state: &PixelState, setups: &[TriangleSetup], frame: &FrameParams) -> PixelOut {
    let (owner, slot, count) = if state.owner != NO_OWNER {
        (state.owner, state.slot, state.count)
    } else if state.edge_owner != NO_OWNER {
        (state.edge_owner, state.edge_slot, 1)
    } else {
        return nodata_pixel(frame);
    };
    let s = &setups[slot as usize];
    PixelOut { value_bits: pixel_value_bits(s, i, j, frame.value_mode()), owner, count }
}

/// Invocation 0 adds the tile to statistics counter `counter`.
#[inline]
pub fn count_tile<C: Counters + ?Sized>(lid: u32, counter: Counter, stats: &mut C) {
    if lid == 0 {
        stats.fetch_add(counter as usize, 1);
    }
}

/// The outputs of a pixel no triangle covers.
pub fn nodata_pixel(frame: &FrameParams) -> PixelOut {
    PixelOut { value_bits: frame.nodata_bits, owner: NO_OWNER, count: 0 }
}

/// Number of bin entries in the batch starting at `batch_start`.
pub fn batch_len(bin_len: u32, batch_start: u32) -> u32 {
    let left = bin_len - batch_start;
    if left < BATCH { left } else { BATCH }
}

/// Bin entries of window tile `tile`: `(start, len)`.
pub fn bin_range(offsets: &[u32], tile: u32) -> (u32, u32) {
    let start = offsets[tile as usize];
    (start, offsets[tile as usize + 1] - start)
}
