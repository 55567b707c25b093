//! One twin per kernel stage, with the stage's name, in files named as the kernel crate's
//! `stages/` (`vertex`, `assemble`, `setup`, `bin`, `scan`, `small`, `fine`, `shade`), and `multisample` for the stage its
//! program of that name makes (`fine_samples`).

mod assemble;
mod bin;
mod fine;
mod light;
mod multisample;
#[cfg(test)]
mod occlusion;
mod scan;
mod setup;
mod shade;
mod small;
mod vertex;

pub use assemble::{assemble_count, assemble_fill, assemble_scan};
pub use bin::{bin_count, bin_fill};
pub use fine::{FinePath, fine_depth, fine_raster};
pub use light::light;
pub use multisample::fine_samples;
pub use scan::bin_scan;
pub use setup::{setup, setup_into};
pub use shade::shade;
pub use small::{SmallBins, SmallSeeds, SmallTriangles, fine_small, fine_small_for};
pub use vertex::vertex;

use std::sync::atomic::{AtomicU32, Ordering};
use tileraster_kernels::memory::{Counters, Slots};

/// Host atomics standing in for a storage buffer the kernels update atomically.
#[derive(Clone, Copy)]
pub(crate) struct AtomicSlice<'a>(&'a [AtomicU32]);

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

pub(crate) fn atomic_zeroed(len: usize) -> Vec<AtomicU32> {
    (0..len).map(|_| AtomicU32::new(0)).collect()
}
