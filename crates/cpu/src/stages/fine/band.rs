//! What the fine-raster paths share: a band (one row of tiles' part of every output layer),
//! the bands run in parallel, per-band statistics, and the rows of a tile in the window.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use tileraster_core::Raster;
use tileraster_kernels::abi::{Counter, FrameParams};
use tileraster_kernels::memory::Counters;
use tileraster_kernels::stages::fine::{self, PixelState};
use tileraster_kernels::{NO_OWNER, TILE, TILE_PIXELS};

/// One band of `TILE` raster rows: the part of each output layer a row of the frame's tiles
/// writes. The frame may be part of the raster's window (the rest is already nodata).
pub(super) struct Band<'a> {
    pub(super) ty: u32,
    /// Grid row of the band's first row, grid column of the raster's first column.
    pub(super) row0: i32,
    pub(super) col0: i32,
    /// Raster row length.
    pub(super) stride: usize,
    pub(super) values: &'a mut [f32],
    pub(super) owner: Option<&'a mut [u32]>,
    pub(super) coverage: Option<&'a mut [u32]>,
    /// The band's row of the tile statistics layer, where asked for, and the raster tile of
    /// the frame's first.
    pub(super) tiles: Option<&'a mut [u32]>,
    pub(super) tile0: u32,
    /// Scratch of the overlap-free tiles, one state per tile pixel, valid where `edge_seen`
    /// has its bit: kept across the band's tiles so that no tile clears 256 states.
    pub(super) edge_states: [PixelState<u32>; TILE_PIXELS as usize],
}

impl Band<'_> {
    /// Index in the band's layers of grid pixel `(i, j)`.
    pub(super) fn index(&self, i: i32, j: i32) -> usize {
        (j - self.row0) as usize * self.stride + (i - self.col0) as usize
    }

    /// `fine::write_tile_stats` of the band's tile `tx`.
    pub(super) fn record_tile(&mut self, tx: u32, bin_len: u32, hidden: u32, frame: &FrameParams) {
        if let Some(tiles) = self.tiles.as_deref_mut() {
            fine::write_tile_stats(0, self.tile0 + tx, bin_len, hidden, frame, tiles);
        }
    }
}

/// Statistics counters, as the GPU's atomics in its statistics buffer.
pub type StatCounters = [AtomicU32; Counter::COUNT];

/// Runs `rasterise_band` over the bands of the frame's rows of tiles in parallel, and returns
/// the statistics counters they add to.
pub(super) fn for_each_band(frame: &FrameParams, raster: &mut Raster, rasterise_band: impl Fn(&mut Band, &StatCounters) + Sync) -> StatCounters {
    let stride = raster.window.width as usize;
    let band_len = TILE as usize * stride;
    // The frame's rows start a whole number of bands into the raster (plans align it to tiles).
    let skip = ((frame.win_y0 - raster.window.y0) / TILE) as usize;
    let take = frame.tiles_y as usize;
    let (row0, col0) = (raster.window.y0 as i32, raster.window.x0 as i32);
    let owner = optional_bands(raster.owner.as_mut(), band_len, skip, take);
    let coverage = optional_bands(raster.coverage.as_mut(), band_len, skip, take);
    let tile_row = 2 * raster.window.width.div_ceil(TILE) as usize;
    let tiles = optional_bands(raster.tiles.as_mut(), tile_row, skip, take);
    let tile0 = (frame.win_x0 - raster.window.x0) / TILE;
    let bands: Vec<Band> = raster
        .values
        .chunks_mut(band_len)
        .skip(skip)
        .take(take)
        .zip(owner)
        .zip(coverage)
        .zip(tiles)
        .enumerate()
        .map(|(ty, (((values, owner), coverage), tiles))| Band {
            ty: ty as u32,
            row0: row0 + ((skip + ty) as u32 * TILE) as i32,
            col0,
            stride,
            values,
            owner,
            coverage,
            tiles,
            tile0,
            edge_states: [PixelState::empty(NO_OWNER); TILE_PIXELS as usize],
        })
        .collect();
    let stats: StatCounters = std::array::from_fn(|_| AtomicU32::new(0));
    bands.into_par_iter().for_each(|mut band| rasterise_band(&mut band, &stats));
    stats
}

/// One band's statistics counters.
#[derive(Default)]
pub(super) struct BandCounters(pub(super) [u32; Counter::COUNT]);

impl BandCounters {
    pub(super) fn add_to(self, stats: &StatCounters) {
        for (shared, count) in stats.iter().zip(self.0) {
            shared.fetch_add(count, Ordering::Relaxed);
        }
    }
}

impl Counters for BandCounters {
    fn fetch_add(&mut self, index: usize, value: u32) -> u32 {
        let before = self.0[index];
        self.0[index] += value;
        before
    }
}

/// `take` bands of an optional output layer, after the first `skip` (all `None` when the layer
/// was not asked for).
fn optional_bands(layer: Option<&mut Vec<u32>>, band_len: usize, skip: usize, take: usize) -> Vec<Option<&mut [u32]>> {
    match layer {
        Some(v) => v.chunks_mut(band_len).skip(skip).take(take).map(Some).collect(),
        None => (0..take).map(|_| None).collect(),
    }
}

/// `value` into the elements of `layer` whose bit is set in `mask`.
#[inline(always)]
pub(super) fn write_masked(layer: &mut [u32], mask: u64, value: u32) {
    for (n, element) in layer.iter_mut().enumerate() {
        if mask >> n & 1 == 1 {
            *element = value;
        }
    }
}

/// The last phase for a tile with an empty bin: nodata, no owner, a count of zero.
#[inline(always)]
pub(super) fn fine_resolve_empty_tile(tx: u32, frame: &FrameParams, band: &mut Band) {
    for r in tile_rows(tx, frame, band) {
        band.values[r.start..][..r.width].fill(f32::from_bits(frame.nodata_bits));
        fill_other_layers(band, &r, NO_OWNER, 0);
    }
}

/// Owner and coverage of a tile row that is the same all along.
#[inline(always)]
pub(super) fn fill_other_layers(band: &mut Band, r: &TileRow, owner: u32, count: u32) {
    if let Some(layer) = band.owner.as_deref_mut() {
        layer[r.start..][..r.width].fill(owner);
    }
    if let Some(layer) = band.coverage.as_deref_mut() {
        layer[r.start..][..r.width].fill(count);
    }
}

/// A row of a tile that lies in the window: row `ly` of the tile, its first pixel `(i0, j)`,
/// where it starts in the band's layers, and how many of its pixels lie in the window.
pub(super) struct TileRow {
    pub(super) ly: u32,
    pub(super) i0: i32,
    pub(super) j: i32,
    pub(super) start: usize,
    pub(super) width: usize,
}

/// The rows of tile `tx` of `band` that lie in the window.
#[inline(always)]
pub(super) fn tile_rows(tx: u32, frame: &FrameParams, band: &Band) -> impl Iterator<Item = TileRow> + use<> {
    let width = (frame.win_w - tx * TILE).min(TILE) as usize;
    let (frame, ty, row0, col0, stride) = (*frame, band.ty, band.row0, band.col0, band.stride);
    (0..TILE).map_while(move |ly| {
        let (i0, j, inside) = fine::tile_pixel(tx, ty, ly * TILE, &frame);
        inside.then(|| TileRow { ly, i0, j, start: (j - row0) as usize * stride + (i0 - col0) as usize, width })
    })
}
