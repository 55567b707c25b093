//! The light stage (Gouraud shading): each of the frame's vertices lit once, with the frame's
//! lights and viewer, before the assembly's fill copies its colour to the corners of its faces.
//! Lighting the vertex rather than each corner keeps the work per vertex (a vertex of a closed
//! mesh is a corner of about six faces); the colour is the same either way
//! (`programs::shade::lit_vertex` is a function of the vertex's attributes alone).

use crate::abi::{ATTRIBUTES, ShadeParams};
use crate::programs::shade::lit_vertex;

/// Vertex `v`'s lit colour, RGBA.
#[inline]
pub fn light(shade: &ShadeParams, attributes: &[[f32; ATTRIBUTES]], v: u32) -> [f32; 4] {
    lit_vertex(shade, &attributes[v as usize])
}
