//! Twins of the `bin_count` and `bin_fill` entry points: one invocation per (listed triangle,
//! band of its tile rows), grouped by triangle; the bins' atomics are host atomics.

use super::{AtomicSlice, atomic_zeroed};
use rayon::prelude::*;
use std::sync::atomic::AtomicU32;
use tileraster_kernels::abi::{FrameParams, TriangleSetup};
use tileraster_kernels::stages::bin;

pub fn bin_count(frame: &FrameParams, setups: &[TriangleSetup], listed: &[u32]) -> Vec<u32> {
    let counts = atomic_zeroed(frame.tile_count() as usize);
    let sink = AtomicSlice(&counts);
    // The GPU's invocations, (listed triangle, band of tile rows) pairs, grouped by triangle.
    listed.par_iter().for_each(|&t| (0..frame.bin_parts).for_each(|part| bin::bin_count(&setups[t as usize], frame, part, &mut { sink })));
    counts.into_iter().map(AtomicU32::into_inner).collect()
}

/// The entry point without its keys and spans (`bin::KEYS_SPEC_ID` 0): the CPU backend's fine
/// stages do not walk their bins (the plain twin's walk works them out itself,
/// `plain::window_keys`, `plain::window_spans`).
pub fn bin_fill(frame: &FrameParams, setups: &[TriangleSetup], listed: &[u32], offsets: &[u32]) -> Vec<u32> {
    let cursors = atomic_zeroed(frame.tile_count() as usize);
    let bins = atomic_zeroed(offsets[frame.tile_count() as usize] as usize);
    let (cursors_sink, bins_sink) = (AtomicSlice(&cursors), AtomicSlice(&bins));
    listed.par_iter().for_each(|&t| {
        let s = &setups[t as usize];
        let no_keys: &mut [u64] = &mut [];
        (0..frame.bin_parts).for_each(|part| bin::bin_fill(false, false, 0, s, frame, part, offsets, &mut { cursors_sink }, &mut { bins_sink }, no_keys))
    });
    bins.into_iter().map(AtomicU32::into_inner).collect()
}
