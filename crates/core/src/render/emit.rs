//! Where the geometry stages put what reaches the rasteriser: counted first, then written
//! into place (as binning does).

use tileraster_kernels::abi::{TriangleInput, TriangleShading};

/// What the kernels keep of a face besides its vertices: its id and its texture.
#[derive(Clone, Copy)]
pub(super) struct FaceTag {
    pub(super) id: u32,
    pub(super) texture: u32,
}

/// Where the geometry stages put the triangles that reach the rasteriser: the first pass
/// counts a chunk's, the second writes them into the chunk's place in the frame's arrays.
pub(super) enum Emit<'a> {
    Count(usize),
    Fill { triangles: &'a mut [TriangleInput], shading: &'a mut [TriangleShading], faces: &'a mut [u32], next: usize, first_slot: usize },
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

    /// Put the next triangle; `make` builds it only where it is written.
    pub(super) fn put(&mut self, make: impl FnOnce() -> (TriangleInput, TriangleShading)) {
        match self {
            Emit::Count(n) => *n += 1,
            Emit::Fill { triangles, shading, faces, next, first_slot } => {
                let (t, s) = make();
                // The setup slot is the index: the depth key's tie-break and the owner layer's value.
                triangles[*next] = TriangleInput { index: (*first_slot + *next) as u32, ..t };
                faces[*next] = s.face;
                shading[*next] = s;
                *next += 1;
            }
        }
    }
}
