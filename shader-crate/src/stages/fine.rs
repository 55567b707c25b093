//! Fine raster: one workgroup per tile, one invocation per pixel. The tile's bin is walked in
//! batches: every invocation stages one triangle's coverage data in workgroup memory
//! (`fine_load`), barrier, every invocation tests its pixel centre against the whole batch
//! (`fine_test`), barrier. Finally each invocation resolves its pixel (`fine_resolve`).
//!
//! Ownership is the minimum triangle index over all covering triangles, which does not
//! depend on the order of the bin; the coverage count is a plain count. Both are therefore
//! deterministic whatever the scheduling of the binning atomics.

use crate::fixed::fixed_to_f32_bits;
use crate::types::{Coverage, FrameParams, Plane, PixelRect, TriangleSetup};
use crate::{BATCH, NO_OWNER, TILE};

/// Workgroup memory of fine raster.
#[repr(C)]
#[derive(Copy, Clone)]
pub struct FineShared {
    pub batch: [Coverage; BATCH as usize],
}

/// What one invocation carries across the batches of its tile.
#[derive(Copy, Clone)]
pub struct PixelState {
    /// Lowest covering triangle index so far (`NO_OWNER` if none).
    pub owner: u32,
    /// Setup slot of that triangle.
    pub slot: u32,
    /// Number of covering triangles.
    pub count: u32,
}

impl PixelState {
    pub const EMPTY: PixelState = PixelState { owner: NO_OWNER, slot: 0, count: 0 };
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
pub fn tile_pixel(tx: u32, ty: u32, lid: u32, frame: &FrameParams) -> (i32, i32, bool) {
    let lx = lid % TILE;
    let ly = lid / TILE;
    let wx = tx * TILE + lx;
    let wy = ty * TILE + ly;
    let inside = wx < frame.win_w && wy < frame.win_h;
    ((frame.win_x0 + wx) as i32, (frame.win_y0 + wy) as i32, inside)
}

/// Index of grid pixel `(i, j)` in the window's row-major output buffers.
pub fn window_index(i: i32, j: i32, frame: &FrameParams) -> usize {
    ((j as u32 - frame.win_y0) * frame.win_w + (i as u32 - frame.win_x0)) as usize
}

/// Phase 1: invocation `lid` stages entry `batch_start + lid` of the tile's bin.
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
        let slot = bin[(bin_start + k) as usize];
        shared.batch[lid as usize] = setups[slot as usize].coverage;
    }
}

/// Whether pixel centre `(i, j)` is inside the triangle (fill rule included).
pub fn covers(c: &Coverage, i: i32, j: i32) -> bool {
    if !c.rect.contains(i, j) {
        return false;
    }
    let di = (i - c.rect.i0) as i64;
    let dj = (j - c.rect.j0) as i64;
    let e = &c.edges;
    let w0 = e[0].e0 + e[0].step_i * di + e[0].step_j * dj;
    let w1 = e[1].e0 + e[1].step_i * di + e[1].step_j * dj;
    let w2 = e[2].e0 + e[2].step_i * di + e[2].step_j * dj;
    (w0 | w1 | w2) >= 0
}

/// Phase 2: test pixel `(i, j)` against the `batch_len` staged triangles.
pub fn fine_test(i: i32, j: i32, batch_len: u32, shared: &FineShared, state: &mut PixelState) {
    let mut k = 0;
    while k < batch_len {
        let c = &shared.batch[k as usize];
        if covers(c, i, j) {
            state.count += 1;
            if c.index < state.owner {
                state.owner = c.index;
                state.slot = c.slot;
            }
        }
        k += 1;
    }
}

/// The owner's plane at pixel `(i, j)`, correctly rounded to `f32`.
pub fn plane_value_bits(plane: &Plane, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    fixed_to_f32_bits(plane.z + plane.gi * di + plane.gj * dj, plane.frac_bits)
}

/// Phase 3: the pixel's outputs.
pub fn fine_resolve(i: i32, j: i32, state: &PixelState, setups: &[TriangleSetup], frame: &FrameParams) -> PixelOut {
    let value_bits = if state.owner == NO_OWNER {
        frame.nodata_bits
    } else {
        let s = &setups[state.slot as usize];
        plane_value_bits(&s.plane, &s.coverage.rect, i, j)
    };
    PixelOut { value_bits, owner: state.owner, count: state.count }
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
