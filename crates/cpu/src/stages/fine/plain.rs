//! The plain twin: each tile exactly as the GPU runs its workgroup, for any pixel program.

use super::SmallSeeds;
use super::band::{Band, BandCounters, StatCounters, for_each_band};
use tileraster_core::Raster;
use tileraster_kernels::abi::{Counter, FrameParams, SetupPart, TriangleSetup};
use tileraster_kernels::memory::{LaneValue, Lanes};
use tileraster_kernels::stages::bin::{entry_keys, entry_spans};
use tileraster_kernels::stages::fine::{self, FineShared, PixelProgram, PixelState};
use tileraster_kernels::{BATCH, FULL_TILE_BIT, TILE_PIXELS};

/// The plain twin, for any pixel program whose values are 32-bit words (the raster's values
/// layer holds their bits); with `walk`, the entry point's walk (`fine::fine_walk`) where it
/// takes it.
#[allow(clippy::too_many_arguments)]
pub(crate) fn fine_raster_plain<P: PixelProgram<Setup = TriangleSetup, Value = u32> + Sync>(
    program: &P,
    walk: bool,
    frame: &FrameParams,
    setups: &[P::Setup],
    offsets: &[u32],
    bins: &[u32],
    seeds: &SmallSeeds,
    raster: &mut Raster,
) -> StatCounters
where
    P::Setup: Sync + bytemuck::Pod,
    P::Staged: Default + SetupPart,
    P::Key: LaneValue + Sync,
{
    // What the GPU's binning writes for a walk: the entries' span masks after the entries, and
    // the keys where it rejects hidden triangles.
    let with_spans;
    let bins = if walk {
        with_spans = window_spans(frame, setups, offsets, bins);
        &with_spans[..]
    } else {
        bins
    };
    let keys = if walk && fine::rejects_hidden::<P>(frame) { window_keys(program, frame, setups, offsets, bins) } else { Vec::new() };
    for_each_band(frame, raster, |band, stats| {
        let mut counts = BandCounters::default();
        for tx in 0..frame.tiles_x {
            fine_raster_tile_plain(program, walk, tx, frame, setups, offsets, bins, &keys, seeds, band, &mut counts);
        }
        counts.add_to(stats);
    })
}

/// The window's bins as `bin_fill` leaves them for a walk: the entries, then each entry's span
/// mask (`stages::bin::entry_spans`).
fn window_spans(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32]) -> Vec<u32> {
    let entries = offsets[frame.tile_count() as usize] as usize;
    let mut out = bins[..entries].to_vec();
    out.resize(2 * entries, 0);
    for ty in 0..frame.tiles_y {
        for tx in 0..frame.tiles_x {
            let (start, len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
            let tile = fine::tile_rect(tx, ty, frame);
            for e in start as usize..(start + len) as usize {
                out[entries + e] = entry_spans(&setups[(bins[e] & !FULL_TILE_BIT) as usize].coverage.rect, &tile);
            }
        }
    }
    out
}

/// The keys `bin_fill` writes for every entry of the window's bins where the walk rejects
/// hidden triangles (`stages::bin::entry_keys`): the occluder keys, then the lowest keys.
fn window_keys<P: PixelProgram<Setup = TriangleSetup>>(program: &P, frame: &FrameParams, setups: &[P::Setup], offsets: &[u32], bins: &[u32]) -> Vec<P::Key> {
    let entries = offsets[frame.tile_count() as usize] as usize;
    let mut keys = vec![P::NO_KEY; 2 * entries];
    for ty in 0..frame.tiles_y {
        for tx in 0..frame.tiles_x {
            let (start, len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
            let tile = fine::tile_rect(tx, ty, frame);
            for e in start as usize..(start + len) as usize {
                let setup = &setups[(bins[e] & !FULL_TILE_BIT) as usize];
                (keys[e], keys[entries + e]) = entry_keys(program, setup, bins[e], &tile);
            }
        }
    }
    keys
}

/// One fine-raster workgroup exactly as the entry point runs it: the same branches, every
/// invocation's `fine_load` and `fine_test` batch by batch, then `fine_resolve` per pixel.
#[allow(clippy::too_many_arguments)]
pub(super) fn fine_raster_tile_plain<P: PixelProgram<Setup = TriangleSetup, Value = u32>>(
    program: &P,
    walk: bool,
    tx: u32,
    frame: &FrameParams,
    setups: &[P::Setup],
    offsets: &[u32],
    bins: &[u32],
    bin_keys: &[P::Key],
    seeds: &SmallSeeds,
    band: &mut Band,
    stats: &mut BandCounters,
) where
    P::Setup: bytemuck::Pod,
    P::Staged: Default + SetupPart,
    P::Key: LaneValue,
{
    let ty = band.ty;
    let (bin_start, bin_len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
    if fine::left_to_shade(bin_len, frame) {
        fine::count_tile(0, Counter::TilesEmpty, stats);
        band.record_tile(tx, bin_len, 0, frame);
        return;
    }
    let pixel = |lid: u32| fine::tile_pixel(tx, ty, lid, frame);
    let mut states: [PixelState<P::Key>; TILE_PIXELS as usize] = core::array::from_fn(|lid| {
        let (i, j, inside) = pixel(lid as u32);
        fine::starting_state(program, i, j, inside, frame, &seeds.keys, &seeds.counts)
    });
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
        let overlap_free = fine::overlap_free::<P>(frame);
        let count_hidden = fine::counts_hidden(frame);
        let rejects_hidden = fine::rejects_hidden::<P>(frame);
        // The entry point's two ways through the bin, as it takes them.
        if walk {
            for (lid, state) in states.iter_mut().enumerate() {
                let (i, j, _) = pixel(lid as u32);
                let words = bytemuck::cast_slice(setups);
                let walk_hidden = fine::fine_walk(
                    program,
                    &Lanes::new(),
                    bins,
                    bin_start,
                    bin_len,
                    bin_keys,
                    offsets[frame.tile_count() as usize],
                    words,
                    rejects_hidden,
                    count_hidden,
                    fine::span_bit(lid as u32),
                    i,
                    j,
                    overlap_free,
                    state,
                );
                if lid == 0 {
                    hidden = walk_hidden;
                }
            }
        } else {
            let mut occluding = P::NO_KEY;
            if rejects_hidden {
                for lid in 0..TILE_PIXELS {
                    fine::fine_occluders(program, lid, bins, bin_start, bin_len, setups, &tile, &mut shared);
                }
                occluding = fine::occluding_key::<P>(&shared);
            }
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
        }
        fine::count_hidden_triangles(0, hidden, stats);
    }
    band.record_tile(tx, bin_len, hidden, frame);
    for (lid, state) in states.iter().enumerate() {
        let (i, j, inside) = pixel(lid as u32);
        if !inside {
            continue;
        }
        // An empty tile's pixels hold what the small triangles left, or nothing.
        let out = fine::fine_resolve(program, i, j, state, setups);
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
