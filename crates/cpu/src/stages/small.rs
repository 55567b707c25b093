//! Twin of the `fine_small` entry point: one invocation per small triangle of the window
//! (`stages::small`), the pixels' keys and counts host atomics.

use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};
use tileraster_kernels::abi::{FrameFlags, FrameParams, OutputSet, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::stages::small::{self, PixelKeys};

use super::{AtomicSlice, atomic_zeroed};

/// What the small triangles leave for the tile stage (`Buffer::PixelKeys`, and the coverage
/// layer's counts): per window pixel, the complement of its smallest key and its fragments.
/// Empty where the frame lists no small triangle.
#[derive(Default)]
pub struct SmallSeeds {
    pub keys: Vec<u64>,
    pub counts: Vec<u32>,
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
    let keys: Vec<AtomicU64> = (0..pixels).map(|_| AtomicU64::new(0)).collect();
    let counts = atomic_zeroed(if frame.outputs.contains(OutputSet::COVERAGE) { pixels } else { 0 });
    let program = DepthProgram::of(frame);
    let (keys_sink, counts_sink) = (AtomicKeys(&keys), AtomicSlice(&counts));
    small_listed.par_iter().for_each(|&t| small::fine_small(&program, &setups[t as usize], frame, &mut { keys_sink }, &mut { counts_sink }));
    SmallSeeds { keys: keys.into_iter().map(AtomicU64::into_inner).collect(), counts: counts.into_iter().map(AtomicU32::into_inner).collect() }
}
