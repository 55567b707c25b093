//! Binning: every triangle is listed in each tile its pixel rectangle touches. Counted first
//! (`bin_count`), offsets by prefix sum (`scan`), then written (`bin_fill`): no bin has a fixed
//! capacity, so no triangle is ever dropped from a crowded tile. The order inside a bin
//! depends on scheduling; fine raster is written so that it does not matter.

use crate::TILE;
use crate::memory::{Counters, Slots};
use crate::types::{FrameParams, PixelRect, TriangleSetup};

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
    TileSpan {
        tx0: (x0 - wx0) as u32 / TILE,
        ty0: (y0 - wy0) as u32 / TILE,
        tx1: (x1 - wx0) as u32 / TILE,
        ty1: (y1 - wy0) as u32 / TILE,
        empty: false,
    }
}

/// Calls `visit` with the index of every window tile the triangle's rectangle touches.
fn for_each_tile(setup: &TriangleSetup, frame: &FrameParams, mut visit: impl FnMut(usize)) {
    let span = tile_span(&setup.coverage.rect, frame);
    if span.empty {
        return;
    }
    let mut ty = span.ty0;
    while ty <= span.ty1 {
        let mut tx = span.tx0;
        while tx <= span.tx1 {
            visit((ty * frame.tiles_x + tx) as usize);
            tx += 1;
        }
        ty += 1;
    }
}

/// Count pass: one increment per touched tile.
pub fn bin_count<C: Counters + ?Sized>(setup: &TriangleSetup, frame: &FrameParams, counts: &mut C) {
    for_each_tile(setup, frame, |tile| {
        counts.fetch_add(tile, 1);
    });
}

/// Fill pass: claim a slot in each touched tile's bin and write the triangle's setup slot.
pub fn bin_fill<C: Counters + ?Sized, S: Slots + ?Sized>(
    setup: &TriangleSetup,
    frame: &FrameParams,
    offsets: &[u32],
    cursors: &mut C,
    bins: &mut S,
) {
    for_each_tile(setup, frame, |tile| {
        let k = cursors.fetch_add(tile, 1);
        bins.store((offsets[tile] + k) as usize, setup.coverage.slot);
    });
}
