//! Twin of the `setup` entry point: one invocation per prepared triangle.

use rayon::prelude::*;
use tileraster_core::Prepared;
use tileraster_kernels::abi::{FrameParams, TriangleSetup};
use tileraster_kernels::stages::setup::setup_triangle;

pub fn setup(prepared: &Prepared, frame: &FrameParams) -> Vec<TriangleSetup> {
    let mut setups = Vec::new();
    setup_into(prepared, frame, &mut setups);
    setups
}

/// [`setup`] into `setups`, reusing its memory.
pub fn setup_into(prepared: &Prepared, frame: &FrameParams, setups: &mut Vec<TriangleSetup>) {
    prepared.triangles.par_iter().enumerate().map(|(slot, input)| setup_triangle(input, slot as u32, frame.snap_bits)).collect_into_vec(setups);
}
