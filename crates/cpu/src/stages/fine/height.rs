//! The heightfield's fast paths (`fine_raster`): tiles with an empty bin or one triangle
//! covering them whole written row by row, and partial tiles taken triangle by triangle,
//! a row of 16 pixels at a time, where the frame is proven overlap-free or not.

use super::FinePath;
use super::SmallSeeds;
use super::band::{Band, BandCounters, StatCounters, fill_other_layers, fine_resolve_empty_tile, for_each_band, tile_rows, write_masked};
use super::plain::fine_raster_tile_plain;
use super::rows::{Lanes, TriangleRows, lane_steps};
use super::wide::fine_raster_band_wide;
use std::simd::cmp::{SimdPartialEq, SimdPartialOrd};
use std::simd::num::{SimdFloat, SimdInt};
use std::simd::{Mask, Select, Simd};
use tileraster_core::Raster;
use tileraster_kernels::abi::{Counter, Coverage, FrameParams, TriangleSetup, ValueMode};
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::math::fixed::converts_natively;
use tileraster_kernels::programs::height::{self, HeightProgram};
use tileraster_kernels::stages::fine::{self, PixelProgram, PixelState};
use tileraster_kernels::{FULL_TILE_BIT, NO_OWNER, TILE, TILE_PIXELS};

/// What a heightfield tile's bin makes of it: which fast path takes it.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(super) enum TileKind {
    /// Nothing in its bin (`fine::empty_tile`).
    Empty,
    /// One triangle covering it whole (`fine::full_tile`).
    Full,
    /// Partial, in a frame proven overlap-free (`fine::overlap_free`).
    OverlapFree,
    /// Partial, where triangles may overlap.
    Overlapping,
}

/// `path`'s fast paths over every band in parallel, the band built for AVX-512 where `wide`
/// (only where the CPU has it).
pub(super) fn fine_raster_using(
    path: FinePath,
    wide: bool,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    raster: &mut Raster,
) -> StatCounters {
    for_each_band(frame, raster, |band, stats| {
        if wide {
            // SAFETY: callers pass `wide` only when `wide_vectors` found the features.
            unsafe { fine_raster_band_wide(path, frame, setups, offsets, bins, band, stats) }
        } else {
            fine_raster_band(path, frame, setups, offsets, bins, band, stats)
        }
    })
}

/// Every fine-raster workgroup of one row of tiles. The band counts its tiles in plain
/// integers and adds them to the shared counters once: a tile each would make the threads
/// queue on one cache line.
#[inline(always)]
pub(super) fn fine_raster_band(
    path: FinePath,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    let mut counts = BandCounters::default();
    for tx in 0..frame.tiles_x {
        fine_raster_tile(path, tx, frame, setups, offsets, bins, band, &mut counts);
    }
    counts.add_to(stats);
}

/// One fine-raster workgroup: its kind's fast path where `path` takes it, else the plain twin.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fine_raster_tile(
    path: FinePath,
    tx: u32,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &mut BandCounters,
) {
    let (bin_start, bin_len) = fine::bin_range(offsets, band.ty * frame.tiles_x + tx);
    let mut full = PixelState::empty(NO_OWNER);
    let kind = if fine::empty_tile(bin_len, frame) {
        TileKind::Empty
    } else if fine::full_tile::<HeightProgram>(bins, bin_start, bin_len, setups, frame, &mut full) {
        TileKind::Full
    } else if fine::overlap_free::<HeightProgram>(frame) {
        TileKind::OverlapFree
    } else {
        TileKind::Overlapping
    };
    if !path.takes(kind) {
        return fine_raster_tile_plain(&HeightProgram::of(frame), false, tx, frame, setups, offsets, bins, &[], &SmallSeeds::default(), band, stats);
    }
    band.record_tile(tx, bin_len, 0, frame);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    match kind {
        TileKind::Empty => {
            fine::count_tile(0, Counter::TilesEmpty, stats);
            fine_resolve_empty_tile(tx, frame, band)
        }
        TileKind::Full => {
            fine::count_tile(0, Counter::TilesFull, stats);
            fine_resolve_full_tile(tx, frame, &setups[full.slot as usize], &full, band)
        }
        TileKind::OverlapFree => {
            fine::count_tile(0, Counter::TilesPartial, stats);
            fine_raster_tile_overlap_free(tx, frame, setups, bin, band)
        }
        TileKind::Overlapping => {
            fine::count_tile(0, Counter::TilesPartial, stats);
            fine_raster_tile_overlapping(tx, frame, setups, bin, band)
        }
    }
}

/// The heightfield's program where only its keys matter (they are the triangle indices).
const HEIGHT_KEYS: HeightProgram = HeightProgram { mode: ValueMode::Exact, nodata_bits: 0 };

/// Notes the row's centres on an excluded edge of triangle `c` (`on_edge`, lanes from grid
/// pixel `(i0, j)`, tile pixel `first` onwards) in the band's edge states, as
/// `fine::accumulate` does: the lowest index is kept.
#[inline(always)]
fn note_excluded_edges(band: &mut Band, edge_seen: &mut [u64; TILE_PIXELS as usize / 64], c: &Coverage, first: usize, on_edge: u64, i0: i32, j: i32) {
    let mut left = on_edge;
    while left != 0 {
        let n = left.trailing_zeros() as usize;
        left &= left - 1;
        let (p, state) = (first + n, &mut band.edge_states[first + n]);
        if edge_seen[p / 64] >> (p % 64) & 1 == 0 {
            edge_seen[p / 64] |= 1 << (p % 64);
            *state = PixelState::empty(NO_OWNER);
        }
        fine::accumulate(&HEIGHT_KEYS, Side::OnExcludedEdge, c, i0 + n as i32, j, state);
    }
}

/// The state the band's edge states give tile pixel `p`: its excluded-edge owner if a row
/// noted one, else none.
#[inline(always)]
fn edge_state(band: &Band, edge_seen: &[u64; TILE_PIXELS as usize / 64], p: usize) -> PixelState<u32> {
    if edge_seen[p / 64] >> (p % 64) & 1 == 1 { band.edge_states[p] } else { PixelState::empty(NO_OWNER) }
}

/// A partial tile where triangles may overlap: each triangle of the bin against the pixels of
/// its rectangle in the tile, a row of 16 lanes at a time, where the GPU's pixels take the
/// triangles in turn. The pixels' states are kept as 16 vectors per field, and come out as
/// `fine::accumulate` leaves them in any order: the count of triangles a centre is inside,
/// the smallest key with its setup slot (the height program's key is the triangle's index,
/// so the owner is the key), and, in the band's edge states, the lowest excluded edge.
#[inline(always)]
fn fine_raster_tile_overlapping(tx: u32, frame: &FrameParams, setups: &[TriangleSetup], bin: &[u32], band: &mut Band) {
    type Words = Simd<u32, { TILE as usize }>;
    let mut key = [Words::splat(NO_OWNER); TILE as usize];
    let mut slot = [Words::splat(0); TILE as usize];
    let mut count = [Words::splat(0); TILE as usize];
    let mut edge_seen = [0u64; TILE_PIXELS as usize / 64];
    let tile = fine::tile_rect(tx, band.ty, frame);
    for &entry in bin {
        let Some(mut rows) = TriangleRows::new(&setups[(entry & !FULL_TILE_BIT) as usize], &tile) else {
            continue;
        };
        let c = &rows.setup.coverage;
        let (index, triangle_slot) = (Words::splat(c.index), Words::splat(c.slot));
        for j in rows.j0..=rows.j1 {
            let (inside, on_edge) = rows.masks();
            let r = (j - tile.j0) as usize;
            if on_edge != 0 {
                note_excluded_edges(band, &mut edge_seen, c, r * TILE as usize + rows.shift as usize, on_edge, rows.i0, j);
            }
            if inside != 0 {
                let inside = Mask::<i32, { TILE as usize }>::from_bitmask(inside << rows.shift);
                count[r] += inside.select(Words::splat(1), Words::splat(0));
                let lower = inside & index.simd_lt(key[r]);
                key[r] = lower.select(index, key[r]);
                slot[r] = lower.select(triangle_slot, slot[r]);
            }
            rows.next_row();
        }
    }
    // Each owner writes its pixels' values, a row at a time, as the overlap-free path does.
    let program = HeightProgram::of(frame);
    let mode = frame.value_mode();
    for &entry in bin {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let Some(rows) = TriangleRows::new(s, &tile) else {
            continue;
        };
        let (index, p) = (Words::splat(s.coverage.index), &s.plane);
        let mut height = p.z + p.gi * (rows.i0 - s.coverage.rect.i0) as i64 + p.gj * (rows.j0 - s.coverage.rect.j0) as i64;
        let native = mode == ValueMode::Exact && converts_natively(p.frac_bits);
        for j in rows.j0..=rows.j1 {
            let owned = key[(j - tile.j0) as usize].simd_eq(index).to_bitmask() >> rows.shift & rows.lanes;
            if owned != 0 {
                let out = band.index(rows.i0, j);
                let values = &mut band.values[out..][..rows.lanes.count_ones() as usize];
                if native {
                    exact_heights(Lanes::splat(height) + lane_steps(p.gi), p.frac_bits).store_select(values, Mask::from_bitmask(owned));
                } else {
                    for (n, value) in values.iter_mut().enumerate() {
                        if owned >> n & 1 == 1 {
                            *value = f32::from_bits(program.value(s, rows.i0 + n as i32, j));
                        }
                    }
                }
            }
            // Past the last row the plane may leave `i64`: it is not read there.
            height = height.wrapping_add(p.gj);
        }
    }
    // The owners and counts as they are; the pixels inside no triangle resolve to nodata or
    // to the lowest triangle whose excluded edge they lie on.
    for r in tile_rows(tx, frame, band) {
        let ly = r.ly as usize;
        if let Some(layer) = band.owner.as_deref_mut() {
            layer[r.start..][..r.width].copy_from_slice(&key[ly].as_array()[..r.width]);
        }
        if let Some(layer) = band.coverage.as_deref_mut() {
            layer[r.start..][..r.width].copy_from_slice(&count[ly].as_array()[..r.width]);
        }
        let mut left = key[ly].simd_eq(Words::splat(NO_OWNER)).to_bitmask() & ((1 << r.width) - 1);
        while left != 0 {
            let lx = left.trailing_zeros() as usize;
            left &= left - 1;
            let state = edge_state(band, &edge_seen, ly * TILE as usize + lx);
            let out = fine::fine_resolve(&program, r.i0 + lx as i32, r.j, &state, setups);
            band.values[r.start + lx] = f32::from_bits(out.value);
            if let Some(layer) = band.owner.as_deref_mut() {
                layer[r.start + lx] = out.owner;
            }
            if let Some(layer) = band.coverage.as_deref_mut() {
                layer[r.start + lx] = out.count;
            }
        }
    }
}

/// A partial tile of a scene proven overlap-free: a pixel centre is inside at most one
/// triangle, so that triangle writes the pixel's value (owner, count of one) as soon as it
/// finds it, a row of 16 lanes at a time (`TriangleRows`), and marks it done. The rows also
/// note the centres that lie on an excluded edge, as `fine::accumulate` does; the centres
/// inside no triangle resolve to those after the bin: nodata, or the lowest triangle whose
/// excluded edge they lie on. The exact plane steps from row to row as the edge functions
/// do: exact over the rectangle, it is summed wrapping (a ring: in range, the true value)
/// and read only on the rectangle's pixels.
#[inline(always)]
fn fine_raster_tile_overlap_free(tx: u32, frame: &FrameParams, setups: &[TriangleSetup], bin: &[u32], band: &mut Band) {
    // Bit `p`: tile pixel `p` is inside a triangle and written.
    let mut done = [0u64; TILE_PIXELS as usize / 64];
    // What the pixels inside no triangle resolve to (`band.edge_states`, valid where the bit is set).
    let mut edge_seen = [0u64; TILE_PIXELS as usize / 64];
    let program = HeightProgram::of(frame);
    let mode = frame.value_mode();
    let tile = fine::tile_rect(tx, band.ty, frame);
    for &entry in bin {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let Some(mut rows) = TriangleRows::new(s, &tile) else {
            continue;
        };
        let (c, p) = (&s.coverage, &s.plane);
        let len = rows.lanes.count_ones() as usize;
        let mut height = p.z + p.gi * (rows.i0 - c.rect.i0) as i64 + p.gj * (rows.j0 - c.rect.j0) as i64;
        let height_along = lane_steps(p.gi);
        let native = converts_natively(p.frac_bits);
        for j in rows.j0..=rows.j1 {
            let (inside, on_edge) = rows.masks();
            let first = (j - tile.j0) as usize * TILE as usize + rows.shift as usize;
            if on_edge != 0 {
                note_excluded_edges(band, &mut edge_seen, c, first, on_edge, rows.i0, j);
            }
            if inside != 0 {
                let out = band.index(rows.i0, j);
                let values = &mut band.values[out..][..len];
                // The mode and the conversion's range answered outside the lanes' loop (as in
                // `fine_resolve_full_tile`).
                match (mode, native) {
                    (ValueMode::Exact, true) => {
                        // All 16 lanes converted at once, then one masked store.
                        exact_heights(Lanes::splat(height) + height_along, p.frac_bits).store_select(values, Mask::from_bitmask(inside));
                    }
                    _ => {
                        for (n, value) in values.iter_mut().enumerate() {
                            if inside >> n & 1 == 1 {
                                *value = f32::from_bits(program.value(s, rows.i0 + n as i32, j));
                            }
                        }
                    }
                }
                // A tile row is 16 pixels: its bits never straddle two words.
                done[first / 64] |= inside << (first % 64);
                if let Some(layer) = band.owner.as_deref_mut() {
                    write_masked(&mut layer[out..][..len], inside, c.index);
                }
                if let Some(layer) = band.coverage.as_deref_mut() {
                    write_masked(&mut layer[out..][..len], inside, 1);
                }
            }
            rows.next_row();
            // Past the last row the plane may leave `i64`: it is not read there.
            height = height.wrapping_add(p.gj);
        }
    }
    for r in tile_rows(tx, frame, band) {
        let row_done = done[(r.ly * TILE) as usize / 64] >> ((r.ly * TILE) as usize % 64);
        // The row's pixels not written, lowest first.
        let mut left = !row_done & ((1 << r.width) - 1);
        while left != 0 {
            let lx = left.trailing_zeros() as usize;
            left &= left - 1;
            let (i, j) = (r.i0 + lx as i32, r.j);
            let state = edge_state(band, &edge_seen, (r.ly * TILE) as usize + lx);
            let out = fine::fine_resolve(&program, i, j, &state, setups);
            band.values[r.start + lx] = f32::from_bits(out.value);
            if let Some(layer) = band.owner.as_deref_mut() {
                layer[r.start + lx] = out.owner;
            }
            if let Some(layer) = band.coverage.as_deref_mut() {
                layer[r.start + lx] = out.count;
            }
        }
    }
}

/// The heights of 16 exact fixed-point plane values with `2^−frac_bits` a normal `f32`:
/// `fixed_to_f32_bits`'s native path (one correctly rounded conversion, an exact power-of-two
/// scale) and `height::saturate_infinity`, lane by lane.
#[inline(always)]
fn exact_heights(fixed: Lanes, frac_bits: i32) -> Simd<f32, { TILE as usize }> {
    let scale = f32::from_bits(((127 - frac_bits) as u32) << 23);
    let bits = (fixed.cast::<f32>() * Simd::splat(scale)).to_bits();
    let infinite = (bits & Simd::splat(0x7fff_ffff)).simd_eq(Simd::splat(0x7f80_0000));
    Simd::<f32, { TILE as usize }>::from_bits(infinite.select(bits - Simd::splat(1), bits))
}

/// The last phase for a tile one triangle covers whole: `fine_resolve` of the full state is
/// that triangle's value, owner and a count of one at every pixel, so rows are written in
/// straight loops the compiler can vectorise.
#[inline(always)]
fn fine_resolve_full_tile(tx: u32, frame: &FrameParams, setup: &TriangleSetup, full: &PixelState<u32>, band: &mut Band) {
    let mode = frame.value_mode();
    for r in tile_rows(tx, frame, band) {
        let values = &mut band.values[r.start..][..r.width];
        let (i0, j) = (r.i0, r.j);
        let write_row = |values: &mut [f32]| {
            for (lx, value) in values.iter_mut().enumerate() {
                *value = f32::from_bits(height::pixel_value_bits(setup, i0 + lx as i32, j, mode));
            }
        };
        // The same loop in every arm: with the mode and the conversion's range test answered
        // outside, the compiler drops both from the loop and vectorises the rest.
        match (mode, converts_natively(setup.plane.frac_bits)) {
            (ValueMode::Exact, true) => write_row(values),
            (ValueMode::PlaneF32, _) => write_row(values),
            (ValueMode::Barycentric, _) => write_row(values),
            _ => write_row(values),
        }
        fill_other_layers(band, &r, full.owner, full.count);
    }
}
