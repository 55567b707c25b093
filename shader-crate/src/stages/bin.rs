//! Binning: every triangle is listed in each tile where it can cover a pixel centre. Counted
//! first (`bin_count`), offsets by prefix sum (`scan`), then written (`bin_fill`): no bin has a
//! fixed capacity, so no triangle is ever dropped from a crowded tile. The order inside a bin
//! depends on scheduling; fine raster is written so that it does not matter.
//!
//! Each (triangle, tile) pair of the triangle's rectangle is classified with the exact edge
//! functions at the corners of the tile (`tile_cover`): tiles it cannot reach are left out of
//! its bins, and tiles it covers entirely are marked with `FULL_TILE_BIT`. Both passes run the
//! same classification, so the counts and the entries agree.
//!
//! Where the fine stage walks its bins and rejects hidden triangles, `bin_fill` also writes two
//! keys per entry (`entry_keys`): what each pixel group of the walk would otherwise work out
//! from the triangle's record, lane by lane, is worked out once per triangle and tile.

use crate::abi::{Coverage, FrameParams, PixelRect, TriangleSetup};
use crate::memory::{Counters, Slots};
use crate::programs::depth::DepthProgram;
use crate::stages::fine::{self, PixelProgram, tile_rect};
use crate::{FULL_TILE_BIT, TILE};

/// Tiles `tx0..=tx1` × `ty0..=ty1` of the window (empty when `tx0 > tx1` or `ty0 > ty1`).
#[derive(Copy, Clone)]
pub struct TileSpan {
    pub tx0: u32,
    pub ty0: u32,
    pub tx1: u32,
    pub ty1: u32,
    pub empty: bool,
}

impl TileSpan {
    pub fn tile_count(&self) -> u32 {
        if self.empty { 0 } else { (self.tx1 - self.tx0 + 1) * (self.ty1 - self.ty0 + 1) }
    }
}

/// The window tiles a pixel rectangle touches.
pub fn tile_span(rect: &PixelRect, frame: &FrameParams) -> TileSpan {
    let wx0 = frame.win_x0 as i32;
    let wy0 = frame.win_y0 as i32;
    let x0 = if rect.i0 > wx0 { rect.i0 } else { wx0 };
    let y0 = if rect.j0 > wy0 { rect.j0 } else { wy0 };
    let wx1 = wx0 + frame.win_w as i32 - 1;
    let wy1 = wy0 + frame.win_h as i32 - 1;
    let x1 = if rect.i1 < wx1 { rect.i1 } else { wx1 };
    let y1 = if rect.j1 < wy1 { rect.j1 } else { wy1 };
    if x0 > x1 || y0 > y1 {
        return TileSpan { tx0: 1, ty0: 1, tx1: 0, ty1: 0, empty: true };
    }
    TileSpan { tx0: (x0 - wx0) as u32 / TILE, ty0: (y0 - wy0) as u32 / TILE, tx1: (x1 - wx0) as u32 / TILE, ty1: (y1 - wy0) as u32 / TILE, empty: false }
}

/// How a triangle meets the pixel centres of a tile that lie in the window.
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
pub enum TileCover {
    /// No centre is inside the triangle or on its edges.
    Outside,
    /// Some centres may be inside; fine raster tests each one.
    Partial,
    /// Every centre is inside (by the fill rule).
    Full,
}

/// Classify window tile `(tx, ty)` against a triangle. Edge functions are linear, so their
/// extremes over a rectangle of pixel centres are at its corners: an edge negative at all four
/// excludes every centre; edges all positive at all four (or zero on an edge that owns its
/// centres) include every centre. The corners lie inside the triangle's rectangle, where the
/// edge values fit in `i64` (see `stages::setup`).
pub fn tile_cover(c: &Coverage, tx: u32, ty: u32, frame: &FrameParams) -> TileCover {
    // The tile's centres in the window...
    let ti0 = (frame.win_x0 + tx * TILE) as i32;
    let tj0 = (frame.win_y0 + ty * TILE) as i32;
    let ti1 = min_i32(ti0 + TILE as i32 - 1, (frame.win_x0 + frame.win_w) as i32 - 1);
    let tj1 = min_i32(tj0 + TILE as i32 - 1, (frame.win_y0 + frame.win_h) as i32 - 1);
    // ...and the part of them in the triangle's rectangle.
    let r = &c.rect;
    let (i0, j0) = (max_i32(ti0, r.i0), max_i32(tj0, r.j0));
    let (i1, j1) = (min_i32(ti1, r.i1), min_i32(tj1, r.j1));
    if i0 > i1 || j0 > j1 {
        return TileCover::Outside;
    }
    // Per edge: whether it excludes every centre, and whether it includes every one. (Three
    // calls with a constant index, not a loop: a CPU implementation of Vulkan reaches an array
    // indexed by a loop counter one lane at a time.)
    let edge = |k: usize| {
        let e = &c.edges[k];
        let at_corner = e.e0 + e.step_i * (i0 - r.i0) as i64 + e.step_j * (j0 - r.j0) as i64;
        let across_i = e.step_i * (i1 - i0) as i64;
        let across_j = e.step_j * (j1 - j0) as i64;
        let lo = at_corner + min_i64(across_i, 0) + min_i64(across_j, 0);
        // A multisampled tile's border pixels have samples up to 7/16 px beyond their centres
        // (a step is a whole multiple of 16: the render pipeline snaps to 1/256 px).
        let reach = if frame.samples > 1 { 7 * ((abs_i64(e.step_i) + abs_i64(e.step_j)) >> 4) } else { 0 };
        let hi = at_corner + max_i64(across_i, 0) + max_i64(across_j, 0) + reach;
        let excluded = (c.excluded_edges >> k) & 1 != 0;
        (hi < 0, !(lo < 0 || (lo == 0 && excluded)))
    };
    let ((out0, in0), (out1, in1), (out2, in2)) = (edge(0), edge(1), edge(2));
    if out0 || out1 || out2 {
        return TileCover::Outside;
    }
    let full = i0 == ti0 && i1 == ti1 && j0 == tj0 && j1 == tj1 && in0 && in1 && in2;
    if full { TileCover::Full } else { TileCover::Partial }
}

fn min_i32(a: i32, b: i32) -> i32 {
    if a < b { a } else { b }
}

fn max_i32(a: i32, b: i32) -> i32 {
    if a > b { a } else { b }
}

fn min_i64(a: i64, b: i64) -> i64 {
    if a < b { a } else { b }
}

fn abs_i64(a: i64) -> i64 {
    if a < 0 { -a } else { a }
}

fn max_i64(a: i64, b: i64) -> i64 {
    if a > b { a } else { b }
}

/// Calls `visit(tile, tx, ty, cover)` for every window tile `(tx, ty)` the triangle's rectangle
/// touches and can cover a centre of, in band `part` of its tile rows (`frame.bin_part_rows`
/// rows a band).
fn for_each_tile(setup: &TriangleSetup, frame: &FrameParams, part: u32, mut visit: impl FnMut(usize, u32, u32, TileCover)) {
    let span = tile_span(&setup.coverage.rect, frame);
    let first = span.ty0 + part * frame.bin_part_rows;
    if span.empty || first > span.ty1 {
        return;
    }
    let last = first + frame.bin_part_rows - 1;
    let last = if last < span.ty1 { last } else { span.ty1 };
    let mut ty = first;
    while ty <= last {
        let mut tx = span.tx0;
        while tx <= span.tx1 {
            let cover = tile_cover(&setup.coverage, tx, ty, frame);
            if cover != TileCover::Outside {
                visit((ty * frame.tiles_x + tx) as usize, tx, ty, cover);
            }
            tx += 1;
        }
        ty += 1;
    }
}

/// Count pass: one increment per tile the triangle can cover a centre of, in band `part`.
pub fn bin_count<C: Counters + ?Sized>(setup: &TriangleSetup, frame: &FrameParams, part: u32, counts: &mut C) {
    for_each_tile(setup, frame, part, |tile, _, _, _| {
        counts.fetch_add(tile, 1);
    });
}

/// The `SpecId` of `bin_fill`'s constant...
pub const KEYS_SPEC_ID: u32 = 1;
/// ... and its bit that makes it write the entries' keys, because the render pipeline's fine
/// stage walks and rejects hidden triangles (under the frame's depth test, which the constant
/// may fix too: `DepthProgram::spec_bits`).
pub const WRITE_KEYS: u32 = 1;

/// ... and its bit that makes it write each entry's spans (`entry_spans`), because the fine
/// stage walks its bins.
pub const WRITE_SPANS: u32 = 2;

/// The spans of `tile` (its pixels, `stages::fine::tile_rect`) that the pixel rectangle `rect`
/// reaches: bit [`fine::span_bit`] of each 8-pixel half of a tile row it overlaps. A walk's
/// group of lanes is one span, so a group votes on an entry with one load and one bit (a
/// triangle touches no pixel outside its rectangle).
#[inline]
pub fn entry_spans(rect: &PixelRect, tile: &PixelRect) -> u32 {
    let (lo, hi) = (max_i32(rect.j0 - tile.j0, 0), min_i32(rect.j1 - tile.j0, TILE as i32 - 1));
    if lo > hi {
        return 0;
    }
    let rows = ((2u32 << hi as u32) - 1) & !((1u32 << lo as u32) - 1);
    let half = fine::SPAN as i32;
    let left = rect.i0 < tile.i0 + half && rect.i1 >= tile.i0;
    let right = rect.i0 < tile.i0 + 2 * half && rect.i1 >= tile.i0 + half;
    (if left { rows } else { 0 }) | if right { rows << TILE } else { 0 }
}

/// Fill pass: claim a slot in each of those tiles' bins and write the triangle's setup slot,
/// with `FULL_TILE_BIT` where it covers the whole tile; with `write_spans`, the entry's spans
/// (`entry_spans`) at the window's number of entries past it in `bins`; with `write_keys`,
/// the entry's keys under the frame's depth test too (`entry_keys`; fixed by `depth_spec`
/// where it holds `DepthProgram::spec_bits`): the occluder key at the entry's index of `keys`,
/// the lowest key at the window's number of entries past it.
#[allow(clippy::too_many_arguments)]
pub fn bin_fill<C: Counters + ?Sized, S: Slots + ?Sized, K: Slots<u64> + ?Sized>(
    write_keys: bool,
    write_spans: bool,
    depth_spec: u32,
    setup: &TriangleSetup,
    frame: &FrameParams,
    part: u32,
    offsets: &[u32],
    cursors: &mut C,
    bins: &mut S,
    keys: &mut K,
) {
    let entries = offsets[frame.tile_count() as usize];
    // (`move`: a closure that borrows a `bool` is a pointer to one, which SPIR-V's logical
    // addressing does not allow; and the program is made inside it, for the same reason.)
    for_each_tile(setup, frame, part, move |tile, tx, ty, cover| {
        let k = cursors.fetch_add(tile, 1);
        let entry = offsets[tile] + k;
        let word = setup.coverage.slot | if cover == TileCover::Full { FULL_TILE_BIT } else { 0 };
        bins.store(entry as usize, word);
        if write_spans {
            bins.store((entries + entry) as usize, entry_spans(&setup.coverage.rect, &tile_rect(tx, ty, frame)));
        }
        if write_keys {
            let (occluder, lowest) = entry_keys(&DepthProgram::specialised(frame, depth_spec), setup, word, &tile_rect(tx, ty, frame));
            keys.store(entry as usize, occluder);
            keys.store((entries + entry) as usize, lowest);
        }
    });
}

/// The keys of bin entry `word` (the setup `setup`'s slot, `FULL_TILE_BIT` where it covers
/// `tile` whole): its occluder key over the tile where it covers it whole (else `NO_KEY`), and
/// its lowest key there. The batches work out the same from the staged triangle
/// (`fine_occluders`, `fine_load`), so both ways reject the same triangles.
#[inline]
pub fn entry_keys<P: PixelProgram>(program: &P, setup: &P::Setup, word: u32, tile: &PixelRect) -> (P::Key, P::Key) {
    let staged = P::staged(setup);
    let occluder = if word & FULL_TILE_BIT != 0 { program.occluder_key(staged, tile) } else { P::NO_KEY };
    (occluder, program.lowest_key(staged, tile))
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// A span's bit is set exactly where some pixel of the span lies in the rectangle.
    #[test]
    fn entry_spans_mark_the_spans_a_rectangle_reaches() {
        let tile = PixelRect { i0: 32, j0: 48, i1: 47, j1: 63 };
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut next = |n: i32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as i32 % n
        };
        for _ in 0..20_000 {
            let (i0, j0) = (tile.i0 - 20 + next(40), tile.j0 - 20 + next(40));
            let rect = PixelRect { i0, j0, i1: i0 + next(30), j1: j0 + next(30) };
            let spans = entry_spans(&rect, &tile);
            for lid in 0..crate::TILE_PIXELS {
                let bit = fine::span_bit(lid);
                let (row, first) = (tile.j0 + (lid / TILE) as i32, tile.i0 + (lid % TILE / fine::SPAN * fine::SPAN) as i32);
                let reaches = (first..first + fine::SPAN as i32).any(|i| rect.contains(i, row));
                assert_eq!(spans >> bit & 1 != 0, reaches, "{rect:?}, pixel {lid}");
            }
        }
    }
}
