//! Twin of the `light` entry point: one invocation per vertex of the frame.

use rayon::prelude::*;
use tileraster_kernels::abi::{ATTRIBUTES, ShadeParams};
use tileraster_kernels::stages::light::light as light_vertex;

/// Each of the frame's vertices (`attributes`) lit with the frame's lights (`shade`), into
/// `lit` (its memory reused).
pub fn light(shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]], lit: &mut Vec<[f32; 4]>) {
    (0..attributes.len() as u32).into_par_iter().with_min_len(1 << 10).map(|v| light_vertex(shade, attributes, v)).collect_into_vec(lit);
}
