//! Twin of the `fine_small` entry point: one invocation per small triangle of the window
//! (`stages::small`), the pixels' keys and counts host atomics; or, for the fast paths of
//! `fine_depth`, the small triangles binned on their own, so that each tile takes them with its
//! bin the CPU's way round (every triangle through the tile's rows, no atomics).

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use tileraster_kernels::abi::{FrameFlags, FrameParams, OutputSet, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::stages::small::{self, PixelKeys};

use super::{AtomicSlice, bin_count, bin_fill, bin_scan};

/// What the small triangles leave for the tile stage (`Buffer::PixelKeys`, and the coverage
/// layer's counts): per window pixel, the complement of its smallest key and its fragments.
/// Empty where the frame lists no small triangle.
#[derive(Default)]
pub struct SmallSeeds {
    pub keys: Vec<u64>,
    pub counts: Vec<u32>,
}

/// The small triangles binned apart (the binning stages' twins over the small list): each
/// tile's small triangles, which the fast paths of `fine_depth` take after its bin. Empty
/// where the frame lists no small triangle.
#[derive(Default)]
pub struct SmallBins {
    offsets: Vec<u32>,
    bins: Vec<u32>,
}

impl SmallBins {
    /// The small triangles of window tile `tile` (setup slots, with `FULL_TILE_BIT` where they
    /// cover it whole).
    pub fn of_tile(&self, tile: u32) -> &[u32] {
        match self.offsets.get(tile as usize..tile as usize + 2) {
            Some(&[start, end]) => &self.bins[start as usize..end as usize],
            _ => &[],
        }
    }
}

/// What the small triangles leave for the CPU's fine raster: `fine_small`'s keys and counts
/// for the plain twin, or their own bins for the fast paths (`FinePath::bins_small`).
pub enum SmallTriangles {
    Seeded(SmallSeeds),
    Binned(SmallBins),
}

impl Default for SmallTriangles {
    fn default() -> Self {
        SmallTriangles::Seeded(SmallSeeds::default())
    }
}

impl SmallTriangles {
    /// No small triangle, in the form the fine path takes (`binned`: the fast paths').
    pub fn empty_for(binned: bool) -> SmallTriangles {
        if binned { SmallTriangles::Binned(SmallBins::default()) } else { SmallTriangles::default() }
    }
}

/// The stage's twin for the fine-raster path `binned` says: the small triangles binned apart
/// where `binned`, else as the GPU runs them.
pub fn fine_small_for(binned: bool, frame: &FrameParams, setups: &[TriangleSetup], small_listed: &[u32]) -> SmallTriangles {
    if !binned {
        return SmallTriangles::Seeded(fine_small(frame, setups, small_listed));
    }
    if !frame.flags.contains(FrameFlags::SMALL_TRIANGLES) {
        return SmallTriangles::Binned(SmallBins::default());
    }
    // One band of every tile row: a small triangle reaches a few tiles, and the frame's bands
    // are sized for its listed triangles (one tile row each where they are few and large).
    let frame = &FrameParams { bin_part_rows: frame.tiles_y, bin_parts: 1, ..*frame };
    let counts = bin_count(frame, setups, small_listed);
    let offsets = bin_scan(frame, &counts);
    let bins = bin_fill(frame, setups, small_listed, &offsets);
    SmallTriangles::Binned(SmallBins { offsets, bins })
}

/// Host atomics standing in for `Buffer::PixelKeys`.
#[derive(Clone, Copy)]
struct AtomicKeys<'a>(&'a [AtomicU64]);

impl PixelKeys for AtomicKeys<'_> {
    fn keep_smallest(&mut self, index: usize, key: u64) {
        self.0[index].fetch_max(!key, Ordering::Relaxed);
    }
}

pub fn fine_small(frame: &FrameParams, setups: &[TriangleSetup], small_listed: &[u32]) -> SmallSeeds {
    if !frame.flags.contains(FrameFlags::SMALL_TRIANGLES) {
        return SmallSeeds::default();
    }
    let pixels = frame.win_w as usize * frame.win_h as usize;
    let counted = frame.outputs.contains(OutputSet::COVERAGE);
    // Zeros written before the invocations (the allocator's untouched pages would fault in
    // under the atomics, one thread against the other), then seen as atomics: no pass copies
    // them out.
    let mut seeds = SmallSeeds { keys: zeroed(pixels), counts: zeroed(if counted { pixels } else { 0 }) };
    let program = DepthProgram::of(frame);
    let (keys_sink, counts_sink) = (AtomicKeys(AtomicU64::from_mut_slice(&mut seeds.keys)), AtomicSlice(AtomicU32::from_mut_slice(&mut seeds.counts)));
    small_listed.par_iter().for_each(|&t| small::fine_small(&program, &setups[t as usize], frame, &mut { keys_sink }, &mut { counts_sink }));
    seeds
}

/// `n` zeros, written (not the allocator's zeroed pages).
fn zeroed<T: Copy + Default>(n: usize) -> Vec<T> {
    let mut v = Vec::with_capacity(n);
    v.resize(n, T::default());
    v
}
