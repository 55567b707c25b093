//! The CPU backend: a host dispatcher that runs the same stage functions as the GPU entry
//! points, simulating workgroups. Per-triangle stages run as rayon parallel loops; fine
//! raster runs each tile as one task that executes the workgroup's phases in turn (phase 1
//! for all 256 invocations, then phase 2, ...), with workgroup memory as a plain struct.
//!
//! Each function here is the twin of the entry point of the same name in
//! `tileraster_kernels::entry`.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use tileraster_core::{Error, Prepared, Raster};
use tileraster_kernels::fixed::converts_natively;
use tileraster_kernels::memory::{Counters, Slots};
use tileraster_kernels::stages::fine::{self, FineShared, PixelState};
use tileraster_kernels::stages::{bin, scan, setup::setup_triangle};
use tileraster_kernels::types::{Coverage, FrameParams, TriangleSetup};
use tileraster_kernels::{BATCH, MODE_BARYCENTRIC, MODE_EXACT, MODE_PLANE_F32, SCAN_GROUP, TILE, TILE_PIXELS};

/// Host atomics standing in for a storage buffer the kernels update atomically.
#[derive(Clone, Copy)]
struct AtomicSlice<'a>(&'a [AtomicU32]);

impl Counters for AtomicSlice<'_> {
    fn fetch_add(&mut self, index: usize, value: u32) -> u32 {
        self.0[index].fetch_add(value, Ordering::Relaxed)
    }
}

impl Slots for AtomicSlice<'_> {
    fn store(&mut self, index: usize, value: u32) {
        self.0[index].store(value, Ordering::Relaxed)
    }
}

fn atomic_zeroed(len: usize) -> Vec<AtomicU32> {
    (0..len).map(|_| AtomicU32::new(0)).collect()
}

/// Rasterise a prepared scene on the CPU, over the preparation's whole window.
pub fn rasterise(prepared: &Prepared) -> Result<Raster, Error> {
    let mut raster = prepared.allocate_raster()?;
    let frame = prepared.frame(prepared.window);
    let entries = prepared.bin_capacity(&frame);
    if entries > u32::MAX as u64 {
        return Err(Error::RasterTooLarge {
            width: frame.win_w as u64,
            height: frame.win_h as u64,
            reason: format!("{entries} triangle–tile pairs exceed the 2^32 a window can bin"),
        });
    }
    let setups = setup(prepared, &frame);
    let counts = bin_count(&frame, &setups);
    let offsets = bin_scan(&frame, &counts);
    debug_assert!(offsets[frame.tile_count() as usize] as u64 <= entries);
    let bins = bin_fill(&frame, &setups, &offsets);
    fine_raster(&frame, &setups, &offsets, &bins, &mut raster);
    Ok(raster)
}

pub fn setup(prepared: &Prepared, frame: &FrameParams) -> Vec<TriangleSetup> {
    prepared
        .triangles
        .par_iter()
        .enumerate()
        .map(|(slot, input)| setup_triangle(input, slot as u32, frame.snap_bits))
        .collect()
}

pub fn bin_count(frame: &FrameParams, setups: &[TriangleSetup]) -> Vec<u32> {
    let counts = atomic_zeroed(frame.tile_count() as usize);
    let sink = AtomicSlice(&counts);
    // The GPU's invocations, (triangle, band of tile rows) pairs, grouped by triangle.
    setups.par_iter().for_each(|s| (0..frame.bin_parts).for_each(|part| bin::bin_count(s, frame, part, &mut { sink })));
    counts.into_iter().map(AtomicU32::into_inner).collect()
}

pub fn bin_scan(frame: &FrameParams, counts: &[u32]) -> Vec<u32> {
    let n = frame.tile_count();
    let mut offsets = vec![0u32; n as usize + 1];
    let mut shared: scan::ScanShared = [0; SCAN_GROUP as usize];
    for lid in 0..SCAN_GROUP {
        scan::scan_reduce(lid, counts, n, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_partials(lid, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_write(lid, counts, n, &shared, &mut offsets);
    }
    offsets
}

pub fn bin_fill(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32]) -> Vec<u32> {
    let cursors = atomic_zeroed(frame.tile_count() as usize);
    let bins = atomic_zeroed(offsets[frame.tile_count() as usize] as usize);
    let (cursors_sink, bins_sink) = (AtomicSlice(&cursors), AtomicSlice(&bins));
    setups.par_iter().for_each(|s| (0..frame.bin_parts).for_each(|part| bin::bin_fill(s, frame, part, offsets, &mut { cursors_sink }, &mut { bins_sink })));
    bins.into_iter().map(AtomicU32::into_inner).collect()
}

/// One band of `TILE` output rows: the part of each output layer a row of tiles writes.
struct Band<'a> {
    ty: u32,
    values: &'a mut [f32],
    owner: Option<&'a mut [u32]>,
    coverage: Option<&'a mut [u32]>,
}

pub fn fine_raster(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) {
    fine_raster_using(wide_vectors(), frame, setups, offsets, bins, raster)
}

/// [`fine_raster`], with or without the wide-vector build (`wide` only where the CPU has it).
fn fine_raster_using(wide: bool, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) {
    let band_len = (TILE * frame.win_w) as usize;
    let owner = optional_bands(raster.owner.as_mut(), band_len, frame.tiles_y);
    let coverage = optional_bands(raster.coverage.as_mut(), band_len, frame.tiles_y);
    let bands: Vec<Band> = raster
        .values
        .chunks_mut(band_len)
        .zip(owner)
        .zip(coverage)
        .enumerate()
        .map(|(ty, ((values, owner), coverage))| Band { ty: ty as u32, values, owner, coverage })
        .collect();
    bands.into_par_iter().for_each(|mut band| {
        if wide {
            // SAFETY: callers pass `wide` only when `wide_vectors` found the features.
            unsafe { fine_raster_band_wide(frame, setups, offsets, bins, &mut band) }
        } else {
            fine_raster_band(frame, setups, offsets, bins, &mut band)
        }
    });
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
fn fine_raster_band_wide(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band) {
    fine_raster_band(frame, setups, offsets, bins, band)
}

#[cfg(not(target_arch = "x86_64"))]
unsafe fn fine_raster_band_wide(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band) {
    fine_raster_band(frame, setups, offsets, bins, band)
}

/// Every fine-raster workgroup of one row of tiles.
#[inline(always)]
fn fine_raster_band(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band) {
    for tx in 0..frame.tiles_x {
        fine_raster_tile(tx, frame, setups, offsets, bins, band);
    }
}

/// Bands of an optional output layer (all `None` when the layer was not asked for).
fn optional_bands(layer: Option<&mut Vec<u32>>, band_len: usize, bands: u32) -> Vec<Option<&mut [u32]>> {
    match layer {
        Some(v) => v.chunks_mut(band_len).map(Some).collect(),
        None => (0..bands).map(|_| None).collect(),
    }
}

/// One fine-raster workgroup, phase by phase.
#[inline(always)]
fn fine_raster_tile(tx: u32, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], band: &mut Band) {
    let ty = band.ty;
    let (bin_start, bin_len) = fine::bin_range(offsets, ty * frame.tiles_x + tx);
    let mut full = PixelState::EMPTY;
    if fine::full_tile(bins, bin_start, bin_len, setups, &mut full) {
        return fine_resolve_full_tile(tx, frame, &setups[full.slot as usize], &full, band);
    }
    let pixels: [(i32, i32, bool); TILE_PIXELS as usize] = std::array::from_fn(|lid| fine::tile_pixel(tx, ty, lid as u32, frame));
    let mut shared = FineShared { batch: [Coverage::default(); BATCH as usize] };
    let mut states = [PixelState::EMPTY; TILE_PIXELS as usize];
    let mut batch_start = 0;
    while batch_start < bin_len {
        for lid in 0..TILE_PIXELS {
            fine::fine_load(lid, bins, bin_start, bin_len, batch_start, setups, &mut shared);
        }
        let batch_len = fine::batch_len(bin_len, batch_start);
        for (state, &(i, j, _)) in states.iter_mut().zip(&pixels) {
            fine::fine_test(i, j, batch_len, &shared, state);
        }
        batch_start += BATCH;
    }
    fine_resolve_tile(tx, frame, setups, band, |lid| states[lid as usize]);
}

/// The last phase for a tile one triangle covers whole: `fine_resolve` of the full state is
/// that triangle's value, owner and a count of one at every pixel, so rows are written in
/// straight loops the compiler can vectorise.
#[inline(always)]
fn fine_resolve_full_tile(tx: u32, frame: &FrameParams, setup: &TriangleSetup, full: &PixelState, band: &mut Band) {
    let band_start = (band.ty * TILE * frame.win_w) as usize;
    let width = (frame.win_w - tx * TILE).min(TILE) as usize;
    for ly in 0..TILE {
        let (i0, j, row_inside) = fine::tile_pixel(tx, band.ty, ly * TILE, frame);
        if !row_inside {
            break;
        }
        let row = fine::window_index(i0, j, frame) - band_start;
        let values = &mut band.values[row..row + width];
        let mode = frame.mode;
        let write_row = |values: &mut [f32]| {
            for (lx, value) in values.iter_mut().enumerate() {
                *value = f32::from_bits(fine::pixel_value_bits(setup, i0 + lx as i32, j, mode));
            }
        };
        // The same loop in every arm: with the mode and the conversion's range test answered
        // outside, the compiler drops both from the loop and vectorises the rest.
        match (mode, converts_natively(setup.plane.frac_bits)) {
            (MODE_EXACT, true) => write_row(values),
            (MODE_PLANE_F32, _) => write_row(values),
            (MODE_BARYCENTRIC, _) => write_row(values),
            _ => write_row(values),
        }
        if let Some(owner) = band.owner.as_deref_mut() {
            owner[row..row + width].fill(full.owner);
        }
        if let Some(coverage) = band.coverage.as_deref_mut() {
            coverage[row..row + width].fill(full.count);
        }
    }
}

/// The last phase of a fine-raster workgroup: every invocation resolves and writes its pixel,
/// taken row by row so that the stores run along the band's rows.
#[inline(always)]
fn fine_resolve_tile(tx: u32, frame: &FrameParams, setups: &[TriangleSetup], band: &mut Band, state: impl Fn(u32) -> PixelState) {
    let band_start = (band.ty * TILE * frame.win_w) as usize;
    for ly in 0..TILE {
        let (i0, j, row_inside) = fine::tile_pixel(tx, band.ty, ly * TILE, frame);
        if !row_inside {
            break;
        }
        let row = fine::window_index(i0, j, frame) - band_start;
        let width = (frame.win_w - tx * TILE).min(TILE) as usize;
        for lx in 0..width {
            let out = fine::fine_resolve(i0 + lx as i32, j, &state(ly * TILE + lx as u32), setups, frame);
            band.values[row + lx] = f32::from_bits(out.value_bits);
            if let Some(owner) = band.owner.as_deref_mut() {
                owner[row + lx] = out.owner;
            }
            if let Some(coverage) = band.coverage.as_deref_mut() {
                coverage[row + lx] = out.count;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_core::{prepare, scenes, Grid, Mode, Outputs, Params};

    /// The wide-vector build of fine raster gives the same bits as the plain one.
    #[test]
    fn wide_vectors_change_no_bit() {
        if !wide_vectors() {
            // Say so where the harness cannot swallow it: the comparison needs the features.
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED wide_vectors_change_no_bit: this CPU lacks AVX-512 F/DQ/VL");
            return;
        }
        let grid = Grid::new(0.0, 1000.0, 0.0, 800.0, 331, 277);
        let scenes = [scenes::terrain(0.0, 0.0, 1000.0, 800.0, 30, 20, 3), scenes::sloping_plane()];
        for scene in &scenes {
            for mode in Mode::ALL {
                let params = Params::new(grid).with_mode(mode).with_outputs(Outputs { owner: true, coverage: true });
                let prepared = prepare(scene, &params, None).unwrap();
                let frame = prepared.frame(prepared.window);
                let setups = setup(&prepared, &frame);
                let offsets = bin_scan(&frame, &bin_count(&frame, &setups));
                let bins = bin_fill(&frame, &setups, &offsets);
                let run = |wide| {
                    let mut raster = prepared.allocate_raster().unwrap();
                    fine_raster_using(wide, &frame, &setups, &offsets, &bins, &mut raster);
                    raster
                };
                let (plain, wide) = (run(false), run(true));
                assert_eq!(plain.compare_bits(&wide, 4).0, 0, "{mode:?}: the wide build differs");
            }
        }
    }
}
