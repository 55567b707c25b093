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
//! Ownership is the minimum triangle index over the triangles a centre is inside, which does
//! not depend on the order of the bin; the coverage count is a plain count. Both are
//! therefore deterministic whatever the scheduling of the binning atomics.

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

/// Where a pixel centre lies relative to a triangle. (`u32`: SPIR-V has no 8-bit integers
/// without an extra capability.)
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
pub enum Side {
    Outside,
    /// On an edge the fill rule gives to the neighbour across it (if there is one).
    OnExcludedEdge,
    Inside,
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

/// Where pixel centre `(i, j)` lies relative to the triangle.
pub fn side(c: &Coverage, i: i32, j: i32) -> Side {
    if !c.rect.contains(i, j) {
        return Side::Outside;
    }
    let di = (i - c.rect.i0) as i64;
    let dj = (j - c.rect.j0) as i64;
    let e = &c.edges;
    let w0 = e[0].e0 + e[0].step_i * di + e[0].step_j * dj;
    let w1 = e[1].e0 + e[1].step_i * di + e[1].step_j * dj;
    let w2 = e[2].e0 + e[2].step_i * di + e[2].step_j * dj;
    if (w0 | w1 | w2) < 0 {
        return Side::Outside;
    }
    let on_edges = (w0 == 0) as u32 | ((w1 == 0) as u32) << 1 | ((w2 == 0) as u32) << 2;
    if on_edges & c.excluded_edges != 0 { Side::OnExcludedEdge } else { Side::Inside }
}

/// Phase 2: test pixel `(i, j)` against the `batch_len` staged triangles.
pub fn fine_test(i: i32, j: i32, batch_len: u32, shared: &FineShared, state: &mut PixelState) {
    let mut k = 0;
    while k < batch_len {
        let c = &shared.batch[k as usize];
        match side(c, i, j) {
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
        k += 1;
    }
}

/// The owner's plane at pixel `(i, j)`, correctly rounded to `f32`.
pub fn plane_value_bits(plane: &Plane, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    fixed_to_f32_bits(plane.z + plane.gi * di + plane.gj * dj, plane.frac_bits)
}

/// Phase 3: the pixel's outputs. A centre inside no triangle falls back to a triangle whose
/// excluded edge it lies on: nobody continues across that edge.
pub fn fine_resolve(i: i32, j: i32, state: &PixelState, setups: &[TriangleSetup], frame: &FrameParams) -> PixelOut {
    let (owner, slot, count) = if state.owner != NO_OWNER {
        (state.owner, state.slot, state.count)
    } else if state.edge_owner != NO_OWNER {
        (state.edge_owner, state.edge_slot, 1)
    } else {
        return PixelOut { value_bits: frame.nodata_bits, owner: NO_OWNER, count: 0 };
    };
    let s = &setups[slot as usize];
    PixelOut { value_bits: plane_value_bits(&s.plane, &s.coverage.rect, i, j), owner, count }
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
