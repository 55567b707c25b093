//! Twin of the `fine_samples` entry point (`programs::multisample`): each tile as the GPU runs
//! its workgroup, with the entry point's branches, every invocation's `fine_load` and
//! `test_samples` batch by batch, then `resolve_samples` per pixel with the frame's fragment
//! program; tiles in parallel.

use super::AtomicSlice;
use super::fine::StatCounters;
use rayon::prelude::*;
use std::sync::atomic::AtomicU32;
use tileraster_core::{Raster, RenderInputs};
use tileraster_kernels::abi::{Counter, FrameParams, OutputSet, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::programs::fragment::{Builtin, FragmentProgram};
use tileraster_kernels::programs::multisample::{MAX_SAMPLES, Resolved, SampleState, resolve_samples, test_samples};
use tileraster_kernels::stages::fine::{self, FineShared};
use tileraster_kernels::{BATCH, TILE, TILE_PIXELS};

/// One tile's results: its bin's length, and each of its pixels in the window with its
/// resolved outputs and coverage count.
struct TileOut {
    tile: u32,
    bin_len: u32,
    pixels: Vec<(i32, i32, Resolved, u32)>,
}

pub fn fine_samples(frame: &FrameParams, inputs: &RenderInputs, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) -> StatCounters {
    // The program is chosen once per frame: the built-in shadings are called directly.
    match &inputs.fragment {
        None => fine_samples_with(&Builtin, frame, inputs, setups, offsets, bins, raster),
        Some(stage) => fine_samples_with(stage.program(), frame, inputs, setups, offsets, bins, raster),
    }
}

/// [`fine_samples`] with the fragment program `fragment`.
fn fine_samples_with<F: FragmentProgram + Sync + ?Sized>(
    fragment: &F,
    frame: &FrameParams,
    inputs: &RenderInputs,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    raster: &mut Raster,
) -> StatCounters {
    let program = DepthProgram::of(frame);
    let (params, records) = (&inputs.params, inputs.records());
    let stats: StatCounters = std::array::from_fn(|_| AtomicU32::new(0));
    let tiles: Vec<TileOut> = (0..frame.tile_count())
        .into_par_iter()
        .map(|tile| {
            let mut counters = AtomicSlice(&stats[..]);
            let (tx, ty) = (tile % frame.tiles_x, tile / frame.tiles_x);
            let (bin_start, bin_len) = fine::bin_range(offsets, tile);
            let mut states = [[SampleState::EMPTY; MAX_SAMPLES]; TILE_PIXELS as usize];
            let mut counts = [0u32; TILE_PIXELS as usize];
            if fine::empty_tile(bin_len, frame) {
                fine::count_tile(0, Counter::TilesEmpty, &mut counters);
            } else {
                fine::count_tile(0, Counter::TilesPartial, &mut counters);
                let tile_rect = fine::tile_rect(tx, ty, frame);
                let mut shared = FineShared::new(TriangleSetup::default(), u64::MAX);
                let mut batch_start = 0;
                while batch_start < bin_len {
                    let batch_len = fine::batch_len(bin_len, batch_start);
                    for lid in 0..TILE_PIXELS {
                        fine::fine_load(&program, lid, bins, bin_start, bin_len, batch_start, setups, &tile_rect, u64::MAX, &mut shared);
                    }
                    for lid in 0..TILE_PIXELS {
                        let (i, j, _) = fine::tile_pixel(tx, ty, lid, frame);
                        test_samples(&program, i, j, batch_len, &shared, params.samples, &mut states[lid as usize], &mut counts[lid as usize]);
                    }
                    batch_start += BATCH;
                }
            }
            let pixels = (0..TILE_PIXELS)
                .filter_map(|lid| {
                    let (i, j, inside) = fine::tile_pixel(tx, ty, lid, frame);
                    inside.then(|| {
                        let out = resolve_samples(
                            fragment,
                            params,
                            &program,
                            setups,
                            &records,
                            &inputs.textures,
                            &inputs.texels,
                            &inputs.materials,
                            &states[lid as usize],
                            params.samples,
                            i,
                            j,
                        );
                        (i, j, out, counts[lid as usize])
                    })
                })
                .collect();
            TileOut { tile, bin_len, pixels }
        })
        .collect();
    // Into the raster's layers (the frame may be part of its window).
    let stride = raster.window.width as usize;
    let (x0, y0) = (raster.window.x0 as i32, raster.window.y0 as i32);
    let raster_tiles_x = raster.window.width.div_ceil(TILE);
    let (tile_x0, tile_y0) = ((frame.win_x0 - raster.window.x0) / TILE, (frame.win_y0 - raster.window.y0) / TILE);
    for t in tiles {
        if let Some(layer) = raster.tiles.as_deref_mut().filter(|_| frame.outputs.contains(OutputSet::TILES)) {
            let (tx, ty) = (t.tile % frame.tiles_x, t.tile / frame.tiles_x);
            let k = 2 * ((tile_y0 + ty) * raster_tiles_x + tile_x0 + tx) as usize;
            (layer[k], layer[k + 1]) = (t.bin_len, 0);
        }
        for (i, j, out, count) in t.pixels {
            let k = (j - y0) as usize * stride + (i - x0) as usize;
            raster.values[k] = f32::from_bits(out.depth);
            if let Some(owner) = raster.owner.as_deref_mut().filter(|_| frame.outputs.contains(OutputSet::OWNER)) {
                owner[k] = out.slot;
            }
            if let Some(coverage) = raster.coverage.as_deref_mut().filter(|_| frame.outputs.contains(OutputSet::COVERAGE)) {
                coverage[k] = count;
            }
            if let (Some(colours), Some(faces)) = (raster.colours.as_deref_mut(), raster.faces.as_deref_mut()) {
                (colours[k], faces[k]) = (out.colour, out.face);
            }
        }
    }
    stats
}
