//! Twins of the `bin_count` and `bin_fill` entry points: one invocation per (listed triangle,
//! band of its tile rows), as the GPU numbers them; the bins' atomics are host atomics.

use super::{AtomicSlice, atomic_zeroed};
use rayon::prelude::*;
use std::sync::atomic::AtomicU32;
use tileraster_kernels::abi::{FrameParams, TriangleSetup};
use tileraster_kernels::stages::bin;

pub fn bin_count(frame: &FrameParams, setups: &[TriangleSetup], listed: &[u32]) -> Vec<u32> {
    let counts = atomic_zeroed(frame.tile_count() as usize);
    let sink = AtomicSlice(&counts);
    invocations(frame, listed).for_each(|(t, part)| bin::bin_count(&setups[t as usize], frame, part, &mut { sink }));
    counts.into_iter().map(AtomicU32::into_inner).collect()
}

/// The entry point without its keys and spans (`bin::KEYS_SPEC_ID` 0): the CPU backend's fine
/// stages do not walk their bins (the plain twin's walk works them out itself,
/// `plain::window_keys`, `plain::window_spans`).
pub fn bin_fill(frame: &FrameParams, setups: &[TriangleSetup], listed: &[u32], offsets: &[u32]) -> Vec<u32> {
    let cursors = atomic_zeroed(frame.tile_count() as usize);
    let bins = atomic_zeroed(offsets[frame.tile_count() as usize] as usize);
    let (cursors_sink, bins_sink) = (AtomicSlice(&cursors), AtomicSlice(&bins));
    invocations(frame, listed).for_each(|(t, part)| {
        let no_keys: &mut [u64] = &mut [];
        bin::bin_fill(false, false, 0, &setups[t as usize], frame, part, offsets, &mut { cursors_sink }, &mut { bins_sink }, no_keys)
    });
    bins.into_iter().map(AtomicU32::into_inner).collect()
}

/// The GPU's binning invocations: (setup slot, band of its tile rows) for every listed triangle
/// and band, on all cores (a frame of a few large triangles has many bands each).
fn invocations<'a>(frame: &'a FrameParams, listed: &'a [u32]) -> impl ParallelIterator<Item = (u32, u32)> + 'a {
    let parts = frame.bin_parts as usize;
    (0..listed.len() * parts).into_par_iter().map(move |id| (listed[id / parts], (id % parts) as u32))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stages::{bin_scan, setup};
    use tileraster_core::render::{Cull, Eye, IDENTITY, RenderParams, prepare_render};
    use tileraster_testkit::meshes;

    /// A frame of a few full-frame triangles is binned in bands of one tile row, and every
    /// tile's bin holds what binning each triangle in one band gives, in some order.
    #[test]
    fn bands_change_no_bin() {
        let params = RenderParams { cull: Cull::None, eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(1920, 1080, IDENTITY) };
        let (prepared, _) = prepare_render(&meshes::fill_layers(8), &params, &mut crate::GeometryTwins::default()).unwrap();
        let plan = prepared.plan(prepared.window, false).unwrap();
        let banded = plan.frame(&prepared, plan.active.unwrap());
        assert_eq!((banded.bin_part_rows, banded.bin_parts), (1, banded.tiles_y), "16 triangles take one tile row a band");
        let whole = FrameParams { bin_part_rows: banded.tiles_y, bin_parts: 1, ..banded };
        let setups = setup(&prepared, &banded);
        let bins = |frame: &FrameParams| {
            let counts = bin_count(frame, &setups, &plan.listed);
            let offsets = bin_scan(frame, &counts);
            let entries = bin_fill(frame, &setups, &plan.listed, &offsets);
            let tiles = (0..frame.tile_count() as usize).map(|t| {
                let mut bin = entries[offsets[t] as usize..offsets[t + 1] as usize].to_vec();
                bin.sort_unstable();
                bin
            });
            (counts.clone(), tiles.collect::<Vec<_>>())
        };
        let (banded_bins, whole_bins) = (bins(&banded), bins(&whole));
        assert!(whole_bins.0.iter().all(|&n| (8..=16).contains(&n)), "each of the 8 layers reaches every tile's bin");
        assert_eq!(banded_bins, whole_bins);
    }
}
