//! The depth test's fast paths (`fine_depth`): each triangle of a tile's bin against its rows
//! of the tile, centre by centre or 16 lanes at a time, then the pixels resolved from their
//! smallest keys.

use super::super::SmallBins;
use super::band::{Band, BandCounters, StatCounters, fine_resolve_empty_tile, for_each_band, tile_rows};
use super::rows::{Lanes, TriangleRows};
use super::wide::fine_depth_band_wide;
use std::simd::cmp::{SimdPartialEq, SimdPartialOrd};
use std::simd::num::{SimdFloat, SimdInt, SimdUint};
use std::simd::{Mask, Select, Simd};
use tileraster_core::Raster;
use tileraster_kernels::abi::{Counter, DepthFunc, FrameParams, PixelRect, TriangleSetup};
use tileraster_kernels::programs::depth::{DepthOrder, DepthProgram};
use tileraster_kernels::stages::fine::{self, PixelProgram};
use tileraster_kernels::{FULL_TILE_BIT, NO_OWNER, TILE, TILE_PIXELS};

/// How the depth test takes a tile's pixels.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub(super) enum Way {
    /// Centre by centre.
    Centres,
    /// 16 lanes at a time, built for the CPU's baseline (its 64-bit conversions and
    /// comparisons emulated: slower than centre by centre, kept to test the lanes alone).
    Lanes,
    /// 16 lanes at a time, the band built for AVX-512 (only where the CPU has it).
    WideLanes,
}

impl Way {
    /// The fastest way: lanes where the CPU has AVX-512 (`wide`), else centres.
    pub(super) fn fastest(wide: bool) -> Way {
        if wide { Way::WideLanes } else { Way::Centres }
    }
}

/// The depth test's fast path, every band in parallel.
#[allow(clippy::too_many_arguments)]
pub(super) fn fine_depth_using(
    way: Way,
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    small: &SmallBins,
    raster: &mut Raster,
) -> StatCounters {
    for_each_band(frame, raster, |band, stats| match way {
        // SAFETY: `Way::WideLanes` comes only from `Way::fastest` when `wide_vectors` found the features.
        Way::WideLanes => unsafe { fine_depth_band_wide(program, frame, setups, offsets, bins, small, band, stats) },
        Way::Lanes => fine_depth_band_rows(program, frame, setups, offsets, bins, small, band, stats),
        Way::Centres => {
            let mut counts = BandCounters::default();
            for tx in 0..frame.tiles_x {
                fine_depth_tile(program, tx, frame, setups, offsets, bins, small, band, &mut counts);
            }
            counts.add_to(stats);
        }
    })
}

/// Every `fine_depth` workgroup of one row of tiles, rows of lanes at a time.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub(super) fn fine_depth_band_rows(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    small: &SmallBins,
    band: &mut Band,
    stats: &StatCounters,
) {
    let mut counts = BandCounters::default();
    for tx in 0..frame.tiles_x {
        fine_depth_tile_rows(program, tx, frame, setups, offsets, bins, small, band, &mut counts);
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
    small: &SmallBins,
    band: &mut Band,
    stats: &mut BandCounters,
) {
    let Some((bin_start, bin_len, side, tile)) = depth_tile_bin(tx, frame, offsets, small, band, stats) else { return };
    const N: usize = TILE_PIXELS as usize;
    let (mut key, mut owner, mut slot, mut count) = ([DepthProgram::NO_KEY; N], [NO_OWNER; N], [0u32; N], [0u32; N]);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    let occluding = occluding_key(program, frame, setups, bin, &tile);
    let count_hidden = fine::counts_hidden(frame);
    let mut hidden_here = 0;
    // The bin, then the tile's small triangles (never hidden: the GPU's bound takes only the bin).
    for (k, &entry) in bin.iter().chain(side).enumerate() {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let hidden = k < bin.len() && program.hidden(s, &tile, occluding);
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

/// The start of a `fine_depth` workgroup: a tile with an empty bin and no small triangle is
/// resolved to the background (`None`); any other is counted (empty or partial, by its bin as
/// the GPU counts it). Returns the bin's range, the tile's small triangles and its pixels.
#[inline(always)]
fn depth_tile_bin<'a>(
    tx: u32,
    frame: &FrameParams,
    offsets: &[u32],
    small: &'a SmallBins,
    band: &mut Band,
    stats: &mut BandCounters,
) -> Option<(u32, u32, &'a [u32], PixelRect)> {
    let t = band.ty * frame.tiles_x + tx;
    let (bin_start, bin_len) = fine::bin_range(offsets, t);
    let side = small.of_tile(t);
    if fine::empty_tile(bin_len, frame) {
        fine::count_tile(0, Counter::TilesEmpty, stats);
        if side.is_empty() {
            band.record_tile(tx, bin_len, 0, frame);
            fine_resolve_empty_tile(tx, frame, band);
            return None;
        }
    } else {
        fine::count_tile(0, Counter::TilesPartial, stats);
    }
    Some((bin_start, bin_len, side, fine::tile_rect(tx, band.ty, frame)))
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
    small: &SmallBins,
    band: &mut Band,
    stats: &mut BandCounters,
) {
    let Some((bin_start, bin_len, side, tile)) = depth_tile_bin(tx, frame, offsets, small, band, stats) else { return };
    // The tile's pixel states, one row of lanes past its end: a row of a triangle starting
    // `shift` pixels into the tile's last row reads and writes (masked) 16 lanes from there.
    const N: usize = (TILE_PIXELS + TILE) as usize;
    const L: usize = TILE as usize;
    let (mut key, mut owner, mut slot, mut count) = ([DepthProgram::NO_KEY; N], [NO_OWNER; N], [0u32; N], [0u32; N]);
    let bin = &bins[bin_start as usize..][..bin_len as usize];
    let occluding = occluding_key(program, frame, setups, bin, &tile);
    let count_hidden = fine::counts_hidden(frame);
    let mut hidden_here = 0;
    // The bin, then the tile's small triangles (never hidden: the GPU's bound takes only the bin).
    for (k, &entry) in bin.iter().chain(side).enumerate() {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        let hidden = k < bin.len() && program.hidden(s, &tile, occluding);
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
