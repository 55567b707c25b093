//! Where the geometry stages put what reaches the rasteriser: counted first, then written
//! into place (as binning does).

use super::params::RENDER_SNAP_BITS;
use tileraster_kernels::abi::{FaceMaterial, TriangleInput, TriangleShading};
use tileraster_kernels::stages::setup::edges_fit_i32;

/// What the kernels keep of a face besides its vertices: its id and its surface (its texture
/// in the frame's).
#[derive(Clone, Copy)]
pub(super) struct FaceTag {
    pub(super) id: u32,
    pub(super) material: FaceMaterial,
}

/// Where the geometry stages put the triangles that reach the rasteriser: the first pass
/// counts a chunk's, the second writes them into the chunk's place in the frame's arrays
/// (and finds, while each is at hand, whether all of them take 32-bit edge functions:
/// `small_edges`, [`edges_fit_i32`]).
pub(super) enum Emit<'a> {
    Count(usize),
    Fill { triangles: &'a mut [TriangleInput], shading: &'a mut [TriangleShading], faces: &'a mut [u32], next: usize, first_slot: usize, small_edges: bool },
}

impl Emit<'_> {
    pub(super) fn counting(&self) -> bool {
        matches!(self, Emit::Count(_))
    }

    /// Triangles put so far.
    pub(super) fn count(&self) -> usize {
        match self {
            Emit::Count(n) | Emit::Fill { next: n, .. } => *n,
        }
    }

    /// Whether every triangle put so far takes 32-bit edge functions (counting: none is put).
    pub(super) fn small_edges(&self) -> bool {
        match self {
            Emit::Count(_) => true,
            Emit::Fill { small_edges, .. } => *small_edges,
        }
    }

    /// Put the next triangle; `make` builds it only where it is written.
    pub(super) fn put(&mut self, make: impl FnOnce() -> (TriangleInput, TriangleShading)) {
        match self {
            Emit::Count(n) => *n += 1,
            Emit::Fill { triangles, shading, faces, next, first_slot, small_edges } => {
                let (t, s) = make();
                *small_edges &= edges_fit_i32(&t, RENDER_SNAP_BITS);
                // The setup slot is the index: the depth key's tie-break and the owner layer's value.
                triangles[*next] = TriangleInput { index: (*first_slot + *next) as u32, ..t };
                faces[*next] = s.face;
                shading[*next] = s;
                *next += 1;
            }
        }
    }
}
