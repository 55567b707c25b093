//! Twin of the `fine_raster` entry point, two ways:
//!
//! - the plain twin ([`FinePath::Plain`]) runs each tile as the GPU runs its workgroup: the
//!   entry point's branches and the stage functions, invocation by invocation;
//! - the specialised path (the default) takes a tile's phases the CPU's way round where the
//!   result cannot tell: phase 2 tests each triangle against a row of pixels (the GPU's pixels
//!   test triangles in turn; `fine::accumulate` does not depend on the order), full and
//!   overlap-free tiles write their rows straight, and the whole band is compiled for wide
//!   vectors where the CPU has them.
//!
//! Both give the same bits; the parity tests run both on every scene.

use rayon::prelude::*;
use std::simd::cmp::{SimdPartialEq, SimdPartialOrd};
use std::simd::num::{SimdFloat, SimdInt, SimdUint};
use std::simd::{Mask, Select, Simd};
use std::sync::atomic::{AtomicU32, Ordering};
use tileraster_core::Raster;
use tileraster_kernels::abi::{Counter, Coverage, DepthFunc, FrameFlags, FrameParams, PixelRect, TriangleSetup, ValueMode};
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::math::fixed::converts_natively;
use tileraster_kernels::memory::Counters;
use tileraster_kernels::programs::depth::{DepthOrder, DepthProgram};
use tileraster_kernels::programs::height::{self, HeightProgram};
use tileraster_kernels::stages::fine::{self, FineShared, PixelProgram, PixelState};
use tileraster_kernels::{BATCH, FULL_TILE_BIT, NO_OWNER, TILE, TILE_PIXELS};

/// One band of `TILE` raster rows: the part of each output layer a row of the frame's tiles
/// writes. The frame may be part of the raster's window (the rest is already nodata).
struct Band<'a> {
    ty: u32,
    /// Grid row of the band's first row, grid column of the raster's first column.
    row0: i32,
    col0: i32,
    /// Raster row length.
    stride: usize,
    values: &'a mut [f32],
    owner: Option<&'a mut [u32]>,
    coverage: Option<&'a mut [u32]>,
    /// The band's row of the tile statistics layer, where asked for, and the raster tile of
    /// the frame's first.
    tiles: Option<&'a mut [u32]>,
    tile0: u32,
    /// Scratch of the overlap-free tiles, one state per tile pixel, valid where `edge_seen`
    /// has its bit: kept across the band's tiles so that no tile clears 256 states.
    edge_states: [PixelState<u32>; TILE_PIXELS as usize],
}

impl Band<'_> {
    /// Index in the band's layers of grid pixel `(i, j)`.
    fn index(&self, i: i32, j: i32) -> usize {
        (j - self.row0) as usize * self.stride + (i - self.col0) as usize
    }

    /// `fine::write_tile_stats` of the band's tile `tx`.
    fn record_tile(&mut self, tx: u32, bin_len: u32, hidden: u32, frame: &FrameParams) {
        if let Some(tiles) = self.tiles.as_deref_mut() {
            fine::write_tile_stats(0, self.tile0 + tx, bin_len, hidden, frame, tiles);
        }
    }
}

/// Statistics counters, as the GPU's atomics in its statistics buffer.
pub type StatCounters = [AtomicU32; Counter::COUNT];

/// Which fine-raster twin runs: the CPU's specialised paths (the default), or the plain twin
/// that runs each tile as the GPU runs its workgroup. Both give the same bits; the tests run
/// both on every parity scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FinePath {
    /// Rows of pixels per triangle, full and overlap-free tiles written straight, the
    /// wide-vector build where the CPU has it.
    #[default]
    Specialised,
    /// The entry point's branches and the stage functions, invocation by invocation.
    Plain,
}

/// Twin of the `fine_raster` entry point: one workgroup per tile, the tiles of a row as one
/// rayon task.
pub fn fine_raster(path: FinePath, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) -> StatCounters {
    match path {
        FinePath::Specialised => fine_raster_using(wide_vectors(), frame, setups, offsets, bins, raster),
        FinePath::Plain => fine_raster_plain(&HeightProgram::of(frame), frame, setups, offsets, bins, raster),
    }
}

/// Twin of the `fine_depth` entry point (the render pipeline's depth test): the CPU's way
/// round (the default), or as the GPU runs its workgroups.
pub fn fine_depth(path: FinePath, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) -> StatCounters {
    let program = DepthProgram::of(frame);
    // Render frames never take the full-tile path (the depth test needs every fragment's
    // key); a frame that allowed it goes the GPU's way.
    if path == FinePath::Plain || frame.flags.contains(FrameFlags::FULL_TILES) {
        return fine_raster_plain(&program, frame, setups, offsets, bins, raster);
    }
    fine_depth_using(wide_vectors(), &program, frame, setups, offsets, bins, raster)
}

/// The specialised depth test: a row of 16 lanes at a time with the wide-vector build
/// (`wide` only where the CPU has it: without it the lanes' 64-bit conversions and
/// comparisons are emulated, slower than one centre at a time), else centre by centre.
fn fine_depth_using(
    wide: bool,
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    raster: &mut Raster,
) -> StatCounters {
    for_each_band(frame, raster, |band, stats| {
        if wide {
            // SAFETY: callers pass `wide` only when `wide_vectors` found the features.
            unsafe { fine_depth_band_wide(program, frame, setups, offsets, bins, band, stats) }
        } else {
            let mut counts = BandCounters([0; Counter::COUNT]);
            for tx in 0..frame.tiles_x {
                fine_depth_tile(program, tx, frame, setups, offsets, bins, band, &mut counts);
            }
            counts.add_to(stats);
        }
    })
}

/// Every `fine_depth` workgroup of one row of tiles, rows of lanes at a time, compiled for
/// AVX-512 (`vcvtqq2ps` converts eight 64-bit edge functions to `f32` at once, correctly
/// rounded as the scalar conversion is; the products and sums are the scalar ones, lane by
/// lane).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn fine_depth_band_wide(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_depth_band_rows(program, frame, setups, offsets, bins, band, stats)
}

#[cfg(not(target_arch = "x86_64"))]
unsafe fn fine_depth_band_wide(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_depth_band_rows(program, frame, setups, offsets, bins, band, stats)
}

/// Every `fine_depth` workgroup of one row of tiles, rows of lanes at a time.
#[inline(always)]
fn fine_depth_band_rows(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    let mut counts = BandCounters([0; Counter::COUNT]);
    for tx in 0..frame.tiles_x {
        fine_depth_tile_rows(program, tx, frame, setups, offsets, bins, band, &mut counts);
    }
    counts.add_to(stats);
}

/// One `fine_depth` workgroup the CPU's way round: each triangle of the bin against its rows of
/// the tile (`TriangleRows`' masks, the stages' `side` as integer thresholds), each centre
/// inside it counted and its key compared with the pixel's smallest, as `fine::accumulate`
/// does in any order; then `fine_resolve`'s outputs.
#[allow(clippy::too_many_arguments)]
fn fine_depth_tile(
    program: &DepthProgram,
    tx: u32,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &mut BandCounters,
) {
    let Some((bin_start, bin_len, tile)) = depth_tile_bin(tx, frame, offsets, band, stats) else { return };
    const N: usize = TILE_PIXELS as usize;
    let (mut key, mut owner, mut slot, mut count) = ([DepthProgram::NO_KEY; N], [NO_OWNER; N], [0u32; N], [0u32; N]);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    let occluding = occluding_key(program, frame, setups, bin, &tile);
    let count_hidden = fine::counts_hidden(frame);
    let mut hidden_here = 0;
    for &entry in bin {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let hidden = program.hidden(s, &tile, occluding);
        hidden_here += hidden as u32;
        if hidden && !count_hidden {
            continue;
        }
        let Some(mut rows) = TriangleRows::new(s, &tile) else { continue };
        for j in rows.j0..=rows.j1 {
            let (mut inside, _) = rows.masks();
            let first = ((j - tile.j0) as u32 * TILE + rows.shift) as usize;
            while inside != 0 {
                let n = inside.trailing_zeros();
                inside &= inside - 1;
                let p = first + n as usize;
                count[p] += 1;
                if hidden {
                    continue;
                }
                let k = program.key(s, rows.i0 + n as i32, j);
                if k < key[p] {
                    (key[p], owner[p], slot[p]) = (k, s.coverage.index, s.coverage.slot);
                }
            }
            rows.next_row();
        }
    }
    stats.0[Counter::TrianglesHidden as usize] += hidden_here;
    band.record_tile(tx, bin_len, hidden_here, frame);
    resolve_depth_tile(program, tx, frame, setups, band, &key, &owner, &slot, &count);
}

/// The start of a `fine_depth` workgroup: a tile with an empty bin is resolved to the
/// background (`None`); any other is counted partial, and its bin's range and its pixels are
/// returned.
#[inline(always)]
fn depth_tile_bin(tx: u32, frame: &FrameParams, offsets: &[u32], band: &mut Band, stats: &mut BandCounters) -> Option<(u32, u32, PixelRect)> {
    let (bin_start, bin_len) = fine::bin_range(offsets, band.ty * frame.tiles_x + tx);
    if fine::empty_tile(bin_len, frame) {
        fine::count_tile(0, Counter::TilesEmpty, stats);
        band.record_tile(tx, bin_len, 0, frame);
        fine_resolve_empty_tile(tx, frame, band);
        return None;
    }
    fine::count_tile(0, Counter::TilesPartial, stats);
    Some((bin_start, bin_len, fine::tile_rect(tx, band.ty, frame)))
}

/// The tile's depth bound (`fine::fine_occluders` and `fine::occluding_key` in one loop): the
/// smallest occluder key of the bin's entries that cover the tile whole, `NO_KEY` where the
/// frame rejects no hidden triangle.
fn occluding_key(program: &DepthProgram, frame: &FrameParams, setups: &[TriangleSetup], bin: &[u32], tile: &PixelRect) -> u64 {
    if !fine::rejects_hidden::<DepthProgram>(frame) {
        return DepthProgram::NO_KEY;
    }
    let occluders = bin.iter().filter(|&&e| e & FULL_TILE_BIT != 0);
    occluders.map(|&e| program.occluder_key(&setups[(e & !FULL_TILE_BIT) as usize], tile)).min().unwrap_or(DepthProgram::NO_KEY)
}

/// `fine_resolve` of a depth-test tile from its pixels' smallest keys, owners, setup slots and
/// counts (tile pixel order): a centre no passing fragment owns is background, with a count
/// of 0. The owner's depth is read back from its key where the key holds it.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn resolve_depth_tile(
    program: &DepthProgram,
    tx: u32,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    band: &mut Band,
    key: &[u64],
    owner: &[u32],
    slot: &[u32],
    count: &[u32],
) {
    for r in tile_rows(tx, frame, band) {
        // The row's pixel states, and its part of each layer: straight loops, no bounds checks.
        let p = (r.ly * TILE) as usize;
        let (key, owner, slot, count) = (&key[p..][..r.width], &owner[p..][..r.width], &slot[p..][..r.width], &count[p..][..r.width]);
        let values = &mut band.values[r.start..][..r.width];
        for (lx, value) in values.iter_mut().enumerate() {
            let bits = if owner[lx] != NO_OWNER {
                program.value_of_key(key[lx]).unwrap_or_else(|| program.value(&setups[slot[lx] as usize], r.i0 + lx as i32, r.j))
            } else {
                program.background()
            };
            *value = f32::from_bits(bits);
        }
        if let Some(layer) = band.owner.as_deref_mut() {
            layer[r.start..][..r.width].copy_from_slice(owner);
        }
        if let Some(layer) = band.coverage.as_deref_mut() {
            for ((c, &o), &n) in layer[r.start..][..r.width].iter_mut().zip(owner).zip(count) {
                *c = if o != NO_OWNER { n } else { 0 };
            }
        }
    }
}

/// [`fine_depth_tile`] 16 lanes at a time: each row of a triangle in the tile gives all its
/// centres' keys at once (`depth_keys`), and the pixels inside it take them where smaller,
/// with their counts, as `fine::accumulate` does in any order.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn fine_depth_tile_rows(
    program: &DepthProgram,
    tx: u32,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &mut BandCounters,
) {
    let Some((bin_start, bin_len, tile)) = depth_tile_bin(tx, frame, offsets, band, stats) else { return };
    // The tile's pixel states, one row of lanes past its end: a row of a triangle starting
    // `shift` pixels into the tile's last row reads and writes (masked) 16 lanes from there.
    const N: usize = (TILE_PIXELS + TILE) as usize;
    const L: usize = TILE as usize;
    let (mut key, mut owner, mut slot, mut count) = ([DepthProgram::NO_KEY; N], [NO_OWNER; N], [0u32; N], [0u32; N]);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    let occluding = occluding_key(program, frame, setups, bin, &tile);
    let count_hidden = fine::counts_hidden(frame);
    let mut hidden_here = 0;
    for &entry in bin {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let hidden = program.hidden(s, &tile, occluding);
        hidden_here += hidden as u32;
        if hidden && !count_hidden {
            continue;
        }
        let Some(mut rows) = TriangleRows::new(s, &tile) else { continue };
        let (index, setup_slot) = (Simd::splat(s.coverage.index), Simd::splat(s.coverage.slot));
        for j in rows.j0..=rows.j1 {
            let at = rows.at();
            let (inside, _) = rows.masks_at(&at);
            if inside != 0 {
                let first = ((j - tile.j0) as u32 * TILE + rows.shift) as usize;
                // A hidden triangle's fragments are counted; it owns none, so it needs no keys.
                if !hidden {
                    let keys = depth_keys(program, s, &at);
                    let old = Simd::<u64, L>::from_slice(&key[first..]);
                    let better = Mask::<i64, L>::from_bitmask(inside) & keys.simd_lt(old);
                    better.select(keys, old).copy_to_slice(&mut key[first..first + L]);
                    let better: Mask<i32, L> = better.cast();
                    better.select(index, Simd::from_slice(&owner[first..])).copy_to_slice(&mut owner[first..first + L]);
                    better.select(setup_slot, Simd::from_slice(&slot[first..])).copy_to_slice(&mut slot[first..first + L]);
                }
                let inside = Mask::<i32, L>::from_bitmask(inside).select(Simd::splat(1), Simd::splat(0));
                (Simd::<u32, L>::from_slice(&count[first..]) + inside).copy_to_slice(&mut count[first..first + L]);
            }
            rows.next_row();
        }
    }
    stats.0[Counter::TrianglesHidden as usize] += hidden_here;
    band.record_tile(tx, bin_len, hidden_here, frame);
    resolve_depth_tile(program, tx, frame, setups, band, &key, &owner, &slot, &count);
}

/// The plain twin, for any pixel program whose values are 32-bit words (the raster's values
/// layer holds their bits).
pub(crate) fn fine_raster_plain<P: PixelProgram<Value = u32> + Sync>(
    program: &P,
    frame: &FrameParams,
    setups: &[P::Setup],
    offsets: &[u32],
    bins: &[u32],
    raster: &mut Raster,
) -> StatCounters
where
    P::Setup: Sync,
    P::Staged: Default,
{
    for_each_band(frame, raster, |band, stats| {
        let mut counts = BandCounters([0; Counter::COUNT]);
        for tx in 0..frame.tiles_x {
            fine_raster_tile_plain(program, tx, frame, setups, offsets, bins, band, &mut counts);
        }
        counts.add_to(stats);
    })
}

/// The specialised path, with or without the wide-vector build (`wide` only where the CPU has it).
fn fine_raster_using(wide: bool, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) -> StatCounters {
    for_each_band(frame, raster, |band, stats| {
        if wide {
            // SAFETY: callers pass `wide` only when `wide_vectors` found the features.
            unsafe { fine_raster_band_wide(frame, setups, offsets, bins, band, stats) }
        } else {
            fine_raster_band(frame, setups, offsets, bins, band, stats)
        }
    })
}

/// Runs `rasterise_band` over the bands of the frame's rows of tiles in parallel, and returns
/// the statistics counters they add to.
fn for_each_band(frame: &FrameParams, raster: &mut Raster, rasterise_band: impl Fn(&mut Band, &StatCounters) + Sync) -> StatCounters {
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

/// One fine-raster workgroup exactly as the entry point runs it: the same branches, every
/// invocation's `fine_load` and `fine_test` batch by batch, then `fine_resolve` per pixel.
#[allow(clippy::too_many_arguments)]
fn fine_raster_tile_plain<P: PixelProgram<Value = u32>>(
    program: &P,
    tx: u32,
    frame: &FrameParams,
    setups: &[P::Setup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &mut BandCounters,
) where
    P::Staged: Default,
{
    let ty = band.ty;
    let (bin_start, bin_len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
    let pixel = |lid: u32| fine::tile_pixel(tx, ty, lid, frame);
    let mut states = [PixelState::empty(P::NO_KEY); TILE_PIXELS as usize];
    let mut hidden = 0;
    let empty = fine::empty_tile(bin_len, frame);
    if empty {
        fine::count_tile(0, Counter::TilesEmpty, stats);
    } else if fine::full_tile::<P>(bins, bin_start, bin_len, setups, frame, &mut states[0]) {
        fine::count_tile(0, Counter::TilesFull, stats);
        states = [states[0]; TILE_PIXELS as usize];
    } else {
        fine::count_tile(0, Counter::TilesPartial, stats);
        let tile = fine::tile_rect(tx, ty, frame);
        let mut shared = FineShared::new(P::Staged::default(), P::NO_KEY);
        let mut occluding = P::NO_KEY;
        if fine::rejects_hidden::<P>(frame) {
            for lid in 0..TILE_PIXELS {
                fine::fine_occluders(program, lid, bins, bin_start, bin_len, setups, &tile, &mut shared);
            }
            occluding = fine::occluding_key::<P>(&shared);
        }
        let overlap_free = fine::overlap_free(frame);
        let count_hidden = fine::counts_hidden(frame);
        let mut batch_start = 0;
        while batch_start < bin_len {
            let batch_len = fine::batch_len(bin_len, batch_start);
            for lid in 0..TILE_PIXELS {
                fine::fine_load(program, lid, bins, bin_start, bin_len, batch_start, setups, &tile, occluding, &mut shared);
            }
            hidden += fine::batch_hidden(batch_len, &shared);
            for lid in 0..fine::SPANS {
                fine::span_lists::<P>(lid, tx, ty, frame, batch_len, count_hidden, &mut shared);
            }
            for (lid, state) in states.iter_mut().enumerate() {
                let (i, j, _) = pixel(lid as u32);
                fine::fine_test(program, lid as u32, i, j, &shared, overlap_free, count_hidden, state);
            }
            batch_start += BATCH;
        }
        fine::count_hidden_triangles(0, hidden, stats);
    }
    band.record_tile(tx, bin_len, hidden, frame);
    for (lid, state) in states.iter().enumerate() {
        let (i, j, inside) = pixel(lid as u32);
        if !inside {
            continue;
        }
        let out = if empty { fine::background_pixel(program) } else { fine::fine_resolve(program, i, j, state, setups) };
        let k = band.index(i, j);
        band.values[k] = f32::from_bits(out.value);
        if let Some(owner) = band.owner.as_deref_mut() {
            owner[k] = out.owner;
        }
        if let Some(coverage) = band.coverage.as_deref_mut() {
            coverage[k] = out.count;
        }
    }
}

/// Whether the CPU has the vector instructions that turn a row of fixed-point values into
/// `f32` eight at a time (AVX-512 `vcvtqq2ps`, `vpmullq`).
fn wide_vectors() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq") && std::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`fine_raster_band`] compiled for AVX-512: the same code, the same bits (integer and
/// correctly rounded conversion instructions only), vectorised by the compiler.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
fn fine_raster_band_wide(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band, stats: &StatCounters) {
    fine_raster_band(frame, setups, offsets, bins, band, stats)
}

#[cfg(not(target_arch = "x86_64"))]
unsafe fn fine_raster_band_wide(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band, stats: &StatCounters) {
    fine_raster_band(frame, setups, offsets, bins, band, stats)
}

/// Every fine-raster workgroup of one row of tiles. The band counts its tiles in plain
/// integers and adds them to the shared counters once: a tile each would make the threads
/// queue on one cache line.
#[inline(always)]
fn fine_raster_band(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band, stats: &StatCounters) {
    let mut counts = BandCounters([0; Counter::COUNT]);
    for tx in 0..frame.tiles_x {
        fine_raster_tile(tx, frame, setups, offsets, bins, band, &mut counts);
    }
    counts.add_to(stats);
}

/// One band's statistics counters.
struct BandCounters([u32; Counter::COUNT]);

impl BandCounters {
    fn add_to(self, stats: &StatCounters) {
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

/// One fine-raster workgroup, phase by phase.
#[inline(always)]
fn fine_raster_tile(tx: u32, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band, stats: &mut BandCounters) {
    let ty = band.ty;
    let (bin_start, bin_len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
    band.record_tile(tx, bin_len, 0, frame);
    if fine::empty_tile(bin_len, frame) {
        fine::count_tile(0, Counter::TilesEmpty, stats);
        return fine_resolve_empty_tile(tx, frame, band);
    }
    let mut full = PixelState::empty(NO_OWNER);
    if fine::full_tile::<HeightProgram>(bins, bin_start, bin_len, setups, frame, &mut full) {
        fine::count_tile(0, Counter::TilesFull, stats);
        return fine_resolve_full_tile(tx, frame, &setups[full.slot as usize], &full, band);
    }
    fine::count_tile(0, Counter::TilesPartial, stats);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    if fine::overlap_free(frame) {
        return fine_raster_tile_overlap_free(tx, frame, setups, bin, band);
    }
    fine_raster_tile_overlapping(tx, frame, setups, bin, band)
}

/// A triangle's pixels in one tile, a row of 16 lanes at a time: the triangle's rectangle
/// clipped to the tile, with the edge functions at the current row's first pixel. A row is
/// tested with additions only: the fill rule as thresholds (inside edge `k` ⇔ `w_k ≥ t_k`,
/// `t_k` one for an excluded edge, else zero: `side_of`'s `Inside` on integers), each edge's
/// steps along the row precomputed, the edge functions stepped from row to row. Every sum the
/// masks read is exact: inside the rectangle the edge functions stay below 2^60, and 15
/// steps beyond it add less than 2^50.
struct TriangleRows<'a> {
    setup: &'a TriangleSetup,
    /// The rectangle's first pixel in the tile, and its last row.
    i0: i32,
    j0: i32,
    j1: i32,
    /// Its offset from the tile's first column, and its lanes (bits `0..len`).
    shift: u32,
    lanes: u64,
    w: [i64; 3],
    along: [Lanes; 3],
    threshold: [Lanes; 3],
}

impl<'a> TriangleRows<'a> {
    /// `None` when the triangle's rectangle misses the tile's pixels in the window.
    #[inline(always)]
    fn new(setup: &'a TriangleSetup, tile: &PixelRect) -> Option<Self> {
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
    fn masks(&self) -> (u64, u64) {
        self.masks_at(&self.at())
    }

    /// The current row's edge functions, lane by lane (exact: see the type's note).
    #[inline(always)]
    fn at(&self) -> [Lanes; 3] {
        [0, 1, 2].map(|k| Lanes::splat(self.w[k]) + self.along[k])
    }

    /// [`Self::masks`] of the edge functions `at` (the current row's).
    #[inline(always)]
    fn masks_at(&self, at: &[Lanes; 3]) -> (u64, u64) {
        let zero = Lanes::splat(0);
        let inside = ((at[0] - self.threshold[0]) | (at[1] - self.threshold[1]) | (at[2] - self.threshold[2])).simd_ge(zero).to_bitmask() & self.lanes;
        let closed = (at[0] | at[1] | at[2]).simd_ge(zero).to_bitmask();
        (inside, closed & !inside & self.lanes)
    }

    #[inline(always)]
    fn next_row(&mut self) {
        let e = &self.setup.coverage.edges;
        self.w = [self.w[0] + e[0].step_j, self.w[1] + e[1].step_j, self.w[2] + e[2].step_j];
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

/// The 16 pixels of a tile row, one `i64` each.
type Lanes = Simd<i64, { TILE as usize }>;

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

/// `step · n` for the 16 lanes `n` of a tile row, wrapping: exact wherever the sum it goes
/// into is in range (the lanes of a triangle's rectangle), and never used elsewhere.
#[inline(always)]
fn lane_steps(step: i64) -> Lanes {
    const LANE: Lanes = Lanes::from_array([0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15]);
    Lanes::splat(step) * LANE
}

/// `DepthProgram::key` of triangle `s` at the 16 centres of a row whose edge functions are
/// `at` (`TriangleRows::at`): the depth is `programs::depth::depth_bits` lane by lane (each
/// edge function converted to `f32` once, correctly rounded, as `fixed_to_f32_bits` does;
/// then the same products and sums in the same order), the test and the key as the scalar
/// key builds them.
#[inline(always)]
fn depth_keys(program: &DepthProgram, s: &TriangleSetup, at: &[Lanes; 3]) -> Simd<u64, { TILE as usize }> {
    let c = &s.coeffs.c;
    let weight = |k: usize| at[k].cast::<f32>() * Simd::splat(c[3]);
    let depth = weight(0) * Simd::splat(c[0]) + weight(1) * Simd::splat(c[1]) + weight(2) * Simd::splat(c[2]);
    let clear = Simd::splat(program.clear);
    let passes = match program.func {
        DepthFunc::Less => depth.simd_lt(clear),
        DepthFunc::LessEqual => depth.simd_le(clear),
        DepthFunc::Greater => depth.simd_gt(clear),
        DepthFunc::GreaterEqual => depth.simd_ge(clear),
        DepthFunc::Always => Mask::splat(true),
    };
    let bits = depth.to_bits();
    // `programs::depth::ordered`: negative values below positive ones.
    let ordered = || (bits >> 31).simd_eq(Simd::splat(1)).select(!bits, bits | Simd::splat(1 << 31));
    let depth = match program.depth_order() {
        DepthOrder::Ascending => ordered(),
        DepthOrder::Descending => !ordered(),
        DepthOrder::Ignored => Simd::splat(0),
    };
    let index = s.coverage.index;
    let tie = if program.later_wins() { !index } else { index };
    let keys = depth.cast::<u64>() << 32 | Simd::splat(tie as u64);
    passes.cast::<i64>().select(keys, Simd::splat(DepthProgram::NO_KEY))
}

/// `value` into the elements of `layer` whose bit is set in `mask`.
#[inline(always)]
fn write_masked(layer: &mut [u32], mask: u64, value: u32) {
    for (n, element) in layer.iter_mut().enumerate() {
        if mask >> n & 1 == 1 {
            *element = value;
        }
    }
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

/// The last phase for a tile with an empty bin: nodata, no owner, a count of zero.
#[inline(always)]
fn fine_resolve_empty_tile(tx: u32, frame: &FrameParams, band: &mut Band) {
    for r in tile_rows(tx, frame, band) {
        band.values[r.start..][..r.width].fill(f32::from_bits(frame.nodata_bits));
        fill_other_layers(band, &r, NO_OWNER, 0);
    }
}

/// Owner and coverage of a tile row that is the same all along.
#[inline(always)]
fn fill_other_layers(band: &mut Band, r: &TileRow, owner: u32, count: u32) {
    if let Some(layer) = band.owner.as_deref_mut() {
        layer[r.start..][..r.width].fill(owner);
    }
    if let Some(layer) = band.coverage.as_deref_mut() {
        layer[r.start..][..r.width].fill(count);
    }
}

/// A row of a tile that lies in the window: row `ly` of the tile, its first pixel `(i0, j)`,
/// where it starts in the band's layers, and how many of its pixels lie in the window.
struct TileRow {
    ly: u32,
    i0: i32,
    j: i32,
    start: usize,
    width: usize,
}

/// The rows of tile `tx` of `band` that lie in the window.
#[inline(always)]
fn tile_rows(tx: u32, frame: &FrameParams, band: &Band) -> impl Iterator<Item = TileRow> + use<> {
    let width = (frame.win_w - tx * TILE).min(TILE) as usize;
    let (frame, ty, row0, col0, stride) = (*frame, band.ty, band.row0, band.col0, band.stride);
    (0..TILE).map_while(move |ly| {
        let (i0, j, inside) = fine::tile_pixel(tx, ty, ly * TILE, &frame);
        inside.then(|| TileRow { ly, i0, j, start: (j - row0) as usize * stride + (i0 - col0) as usize, width })
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_core::{Grid, Mode, Outputs, Params, Skips, prepare};
    use tileraster_kernels::abi::Coverage;
    use tileraster_kernels::pipeline::StageBuffers;
    use tileraster_testkit::scenes;

    /// What the stages before fine raster leave for a scene's whole window.
    struct BeforeFine {
        prepared: tileraster_core::Prepared,
        plan: tileraster_core::Plan,
        frame: FrameParams,
        setups: Vec<TriangleSetup>,
        offsets: Vec<u32>,
        bins: Vec<u32>,
    }

    fn before_fine(scene: &tileraster_core::Scene, params: &Params) -> BeforeFine {
        let prepared = prepare(scene, params, None).unwrap();
        let plan = prepared.plan(prepared.window, false).unwrap();
        let frame = plan.frame(&prepared, plan.active.unwrap());
        let StageBuffers { setups, offsets, bins, .. } = crate::stage_buffers(&prepared).unwrap().unwrap();
        BeforeFine { prepared, plan, frame, setups, offsets, bins }
    }

    /// A pixel program other than the heightfield's, through the same stage: a depth test.
    /// The lowest surface owns a pixel (its exact height is the depth, the index breaks ties),
    /// hull edges stay uncovered, and the value is the owner's index.
    struct LowestSurface;

    impl PixelProgram for LowestSurface {
        type Setup = TriangleSetup;
        type Staged = TriangleSetup;
        type Key = u64;
        type Value = u32;
        const NO_KEY: u64 = u64::MAX;
        const HULL_EDGES: bool = false;

        fn staged(setup: &TriangleSetup) -> &TriangleSetup {
            setup
        }

        fn coverage(staged: &TriangleSetup) -> &Coverage {
            &staged.coverage
        }

        fn key(&self, s: &TriangleSetup, i: i32, j: i32) -> u64 {
            depth_key(s, i, j)
        }

        fn value(&self, setup: &TriangleSetup, _i: i32, _j: i32) -> u32 {
            setup.coverage.index
        }

        fn background(&self) -> u32 {
            u32::MAX
        }
    }

    /// The exact height's `f32` bits mapped to an unsigned order, then the index.
    fn depth_key(s: &TriangleSetup, i: i32, j: i32) -> u64 {
        let bits = height::plane_value_bits(&s.plane, &s.coverage.rect, i, j);
        (tileraster_kernels::programs::depth::ordered(bits) as u64) << 32 | s.coverage.index as u64
    }

    /// The generic stage with a depth-keyed program gives, at every pixel, what a brute-force
    /// depth test over all triangles gives: the owner, the value and the coverage count.
    #[test]
    fn a_depth_keyed_program_resolves_the_lowest_surface() {
        let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
        let scenes = [scenes::triangle_soup(&grid, 700, 30.0, 9), scenes::fan(&grid, 60, 60, 90, 40.0, 3), scenes::terrain(0.0, 0.0, 100.0, 100.0, 12, 9, 5)];
        for (k, scene) in scenes.iter().enumerate() {
            for skips in [Skips::NONE, Skips::default()] {
                let params = Params::new(grid).with_skips(skips).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
                let BeforeFine { prepared, plan, frame, setups, offsets, bins } = before_fine(scene, &params);
                let mut raster = plan.allocate_raster(&prepared).unwrap();
                fine_raster_plain(&LowestSurface, &frame, &setups, &offsets, &bins, &mut raster);
                let (owners, counts) = (raster.owner.as_ref().unwrap(), raster.coverage.as_ref().unwrap());
                for j in 0..frame.win_h {
                    for i in 0..frame.win_w {
                        let (gi, gj) = ((frame.win_x0 + i) as i32, (frame.win_y0 + j) as i32);
                        let inside: Vec<&TriangleSetup> =
                            plan.listed.iter().map(|&slot| &setups[slot as usize]).filter(|s| fine::side(&s.coverage, gi, gj) == Side::Inside).collect();
                        let lowest = inside.iter().min_by_key(|s| depth_key(s, gi, gj)).map_or(NO_OWNER, |s| s.coverage.index);
                        let n = (gj as usize - raster.window.y0 as usize) * raster.window.width as usize + (gi as usize - raster.window.x0 as usize);
                        let at = format!("scene {k}, {skips:?}, pixel ({gi}, {gj})");
                        assert_eq!(owners[n], lowest, "owner at {at}");
                        assert_eq!(raster.values[n].to_bits(), lowest, "value at {at}");
                        assert_eq!(counts[n], inside.len() as u32, "count at {at}");
                    }
                }
            }
        }
    }

    /// The 16-lane row masks of `TriangleRows` say of every pixel of a triangle's rectangle in
    /// a tile what the stages' `side` says (inside, on an excluded edge, outside), on scenes
    /// with overlaps, slivers and shared edges (checked natively, without an adapter too).
    #[test]
    fn row_masks_are_the_stages_side_of_every_pixel() {
        let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
        let scenes = [scenes::triangle_soup(&grid, 700, 30.0, 9), scenes::fan(&grid, 60, 60, 90, 40.0, 3), scenes::sliver_wedge(&grid, 80, 0.02, 4)];
        let mut seen = [0usize; 3];
        for (k, scene) in scenes.iter().enumerate() {
            let BeforeFine { frame, setups, offsets, bins, .. } = before_fine(scene, &Params::new(grid).with_skips(Skips::NONE));
            for ty in 0..frame.tiles_y {
                for tx in 0..frame.tiles_x {
                    let (start, len) = fine::bin_range(&offsets, ty * frame.tiles_x + tx);
                    let tile = fine::tile_rect(tx, ty, &frame);
                    for &entry in &bins[start as usize..][..len as usize] {
                        let Some(mut rows) = TriangleRows::new(&setups[(entry & !FULL_TILE_BIT) as usize], &tile) else { continue };
                        for j in rows.j0..=rows.j1 {
                            let (inside, on_edge) = rows.masks();
                            for n in 0..rows.lanes.count_ones() {
                                let i = rows.i0 + n as i32;
                                let side = fine::side(&rows.setup.coverage, i, j);
                                let lanes = (inside >> n & 1 == 1, on_edge >> n & 1 == 1);
                                let expected = (side == Side::Inside, side == Side::OnExcludedEdge);
                                assert_eq!(lanes, expected, "scene {k}, triangle {}, pixel ({i}, {j})", rows.setup.coverage.index);
                                seen[side as usize] += 1;
                            }
                            assert_eq!((inside | on_edge) & !rows.lanes, 0, "lanes past the rectangle");
                            rows.next_row();
                        }
                    }
                }
            }
        }
        assert!(seen.iter().all(|&n| n > 0), "every side seen: {seen:?}");
    }

    /// The depth test in rows of lanes (the wide-vector build) gives the same bits as centre
    /// by centre and as the plain twin: every depth function, with and without depth writes,
    /// on a soup of crossing triangles drawn twice (exact depth ties), on full-frame layers
    /// drawn back to front and front to back, and on full-frame layers whose depths cross
    /// (slopes in both directions, so that tiles' early depth rejection decides on bounds that
    /// vary across the tile). Both specialised paths reject hidden triangles early; the plain
    /// twin does not.
    #[test]
    fn depth_test_in_lanes_changes_no_bit() {
        use tileraster_core::render::{Cull, IDENTITY, RenderParams, prepare_render};
        use tileraster_testkit::meshes;
        if !wide_vectors() {
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED depth_test_in_lanes_changes_no_bit: this CPU lacks AVX-512 F/DQ/VL");
            return;
        }
        let mut soup = meshes::soup(300, [-1.2, -1.2, 0.1], [1.2, 1.2, 0.9], 0.5, 9);
        let n = soup.triangles.len();
        soup.triangles.extend_from_within(..n);
        let back_to_front = meshes::fill_layers(5);
        let mut front_to_back = back_to_front.clone();
        front_to_back.triangles.reverse();
        let mut crossing = tileraster_core::render::Mesh::default();
        for (k, (left, right)) in [(0.2, 0.8), (0.8, 0.2), (0.5, 0.5), (0.1, 0.6), (0.45, 0.55)].into_iter().enumerate() {
            let v = 4 * k as u32;
            crossing.positions.extend([[-1.0, -1.0, left], [1.0, -1.0, right], [1.0, 1.0, right], [-1.0, 1.0, left]]);
            crossing.triangles.extend([[v, v + 1, v + 2], [v, v + 2, v + 3]]);
        }
        let mut hidden_somewhere = false;
        for mesh in [soup, back_to_front, front_to_back, crossing] {
            for func in DepthFunc::ALL {
                for write in [true, false] {
                    // The `Greater` functions pass against a clear value of 0.
                    let clear_depth = if matches!(func, DepthFunc::Greater | DepthFunc::GreaterEqual) { 0.0 } else { 1.0 };
                    let mut reference: Option<Raster> = None;
                    for (count_fragments, hidden_triangles) in [(true, false), (true, true), (false, true), (false, false)] {
                        let skips = tileraster_core::Skips { hidden_triangles, ..tileraster_core::Skips::ALL };
                        let params = RenderParams {
                            cull: Cull::None,
                            depth_func: func,
                            depth_write: write,
                            clear_depth,
                            eye: Some([0.0, 0.0, -1.0]),
                            count_fragments,
                            skips,
                            ..RenderParams::new(203, 157, IDENTITY)
                        };
                        let (prepared, _) = prepare_render(&mesh, &params).unwrap();
                        let plan = prepared.plan(prepared.window, false).unwrap();
                        let frame = plan.frame(&prepared, plan.active.unwrap());
                        let StageBuffers { setups, offsets, bins, .. } = crate::stage_buffers(&prepared).unwrap().unwrap();
                        let program = DepthProgram::of(&frame);
                        let run = |path: Option<bool>| {
                            let mut raster = plan.allocate_raster(&prepared).unwrap();
                            let counters = match path {
                                Some(wide) => fine_depth_using(wide, &program, &frame, &setups, &offsets, &bins, &mut raster),
                                None => fine_raster_plain(&program, &frame, &setups, &offsets, &bins, &mut raster),
                            };
                            (raster, counters.map(|c| c.into_inner()))
                        };
                        let what = format!("{func:?}, write {write}, fragments counted {count_fragments}, hidden triangles rejected {hidden_triangles}");
                        let ((lanes, lane_counts), (centres, centre_counts), (plain, plain_counts)) = (run(Some(true)), run(Some(false)), run(None));
                        assert_eq!(lanes.compare_bits(&centres, 4), (0, vec![]), "{what}: lanes against centres");
                        assert_eq!(lanes.compare_bits(&plain, 4), (0, vec![]), "{what}: lanes against the plain twin");
                        assert_eq!((lane_counts, centre_counts), (plain_counts, plain_counts), "{what}: statistics");
                        let hidden = plain_counts[Counter::TrianglesHidden as usize];
                        assert!(hidden_triangles || hidden == 0, "{what}: {hidden} hidden with the rejection off");
                        hidden_somewhere |= hidden > 0;
                        if count_fragments {
                            assert!(lanes.coverage.as_ref().unwrap().iter().any(|&c| c > 1), "{what}: fragments overlap where they pass");
                        }
                        // The rejection and the fragment count change no bit of the other layers.
                        let mut bits = lanes;
                        bits.coverage = None;
                        match &reference {
                            None => reference = Some(bits),
                            Some(r) => assert_eq!(bits.compare_bits(r, 4), (0, vec![]), "{what}: against the first variant"),
                        }
                    }
                }
            }
        }
        assert!(hidden_somewhere, "the depth bounds hid no triangle in any scene");
    }

    /// A key's depth read back is the depth it was built from, for every sign and size.
    #[test]
    fn value_of_key_undoes_the_key() {
        use tileraster_kernels::programs::depth::ordered;
        for depth in [-f32::INFINITY, -3.5, -f32::MIN_POSITIVE / 2.0, -0.0, 0.0, 1e-40, 0.25, 1.0, f32::MAX] {
            let bits = depth.to_bits();
            for func in [DepthFunc::Less, DepthFunc::LessEqual, DepthFunc::Greater, DepthFunc::GreaterEqual] {
                let program = DepthProgram { func, write: true, clear: 0.5 };
                let above = if matches!(func, DepthFunc::Greater | DepthFunc::GreaterEqual) { !ordered(bits) } else { ordered(bits) };
                assert_eq!(program.value_of_key((above as u64) << 32 | 7), Some(bits), "{depth} under {func:?}");
            }
        }
        assert_eq!(DepthProgram { func: DepthFunc::Always, write: true, clear: 0.5 }.value_of_key(0), None);
        assert_eq!(DepthProgram { func: DepthFunc::Less, write: false, clear: 0.5 }.value_of_key(3), Some(0.5f32.to_bits()));
    }

    /// The wide-vector build of fine raster gives the same bits as the plain one.
    #[test]
    fn wide_vectors_change_no_bit() {
        if !wide_vectors() {
            // Say so where the harness cannot swallow it: the comparison needs the features.
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED wide_vectors_change_no_bit: this CPU lacks AVX-512 F/DQ/VL");
            return;
        }
        let scenes = [
            (scenes::terrain(0.0, 0.0, 1000.0, 800.0, 30, 20, 3), Grid::new(0.0, 1000.0, 0.0, 800.0, 331, 277)),
            (scenes::sloping_plane(), Grid::new(0.0, 1.0, 0.0, 1.0, 331, 277)),
        ];
        for (scene, grid) in &scenes {
            let grid = *grid;
            for mode in Mode::ALL {
                let params = Params::new(grid).with_mode(mode).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
                let BeforeFine { prepared, plan, frame, setups, offsets, bins } = before_fine(scene, &params);
                let run = |wide| {
                    let mut raster = plan.allocate_raster(&prepared).unwrap();
                    fine_raster_using(wide, &frame, &setups, &offsets, &bins, &mut raster);
                    raster
                };
                let (plain, wide) = (run(false), run(true));
                assert_eq!(plain.compare_bits(&wide, 4).0, 0, "{mode:?}: the wide build differs");
            }
        }
    }
}
