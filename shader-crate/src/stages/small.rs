//! Fine raster of small triangles: one invocation per triangle, not per pixel. A triangle
//! whose rectangle is at most [`SMALL_SIDE`] pixels on each side skips binning (the plan lists
//! it apart, `Plan::small`): its invocation tests every pixel centre of its rectangle in the
//! window and, where the centre is inside it and the fragment passes the depth test, keeps the
//! smaller of its key and the pixel's with an atomic minimum on the pixel's 64-bit key
//! (`PixelKeys`), and counts the fragment where the coverage layer is asked for.
//!
//! The smallest key over any set of fragments does not depend on the order they arrive in, so
//! the result is the same whatever the scheduling; the tile stage (`fine_depth`) then starts
//! each pixel from that key and count (`PixelProgram::seeded`) and walks only the large
//! triangles' bins. A pixel covered by a hundred thin triangles costs a hundred atomics where
//! they reach it, not a hundred record reads for every pixel of its span: this is how
//! cudaraster and Nanite split small triangles from large ones.
//!
//! The keys are stored complemented (`!key`, an atomic maximum), so that the buffer's zeroes
//! are `NO_KEY`: a clear, not a fill, prepares it.

use crate::abi::{FrameParams, OutputSet, PixelRect, TriangleSetup};
use crate::math::edge::{Side, side_of_i32};
use crate::memory::Counters;
use crate::stages::fine::{self, PixelProgram};

/// Most pixels a small triangle's rectangle spans on each side.
pub const SMALL_SIDE: i32 = 8;

/// Whether a triangle with rectangle `rect` is small: one invocation tests all its centres.
#[inline]
pub fn is_small(rect: &PixelRect) -> bool {
    rect.i1 - rect.i0 < SMALL_SIDE && rect.j1 - rect.j0 < SMALL_SIDE
}

/// Per-pixel keys that invocations lower at once (a storage buffer's atomics, the host's).
pub trait PixelKeys {
    /// Lower pixel `index`'s key to `key` where `key` is smaller. The pixel holds `!key`, so
    /// that zero is `NO_KEY`.
    fn keep_smallest(&mut self, index: usize, key: u64);
}

#[cfg(target_arch = "spirv")]
impl PixelKeys for [u64] {
    #[inline(always)]
    fn keep_smallest(&mut self, index: usize, key: u64) {
        use spirv_std::memory::{Scope, Semantics};
        // The atomics are unordered: only the final minimum is read, by a later dispatch.
        unsafe {
            spirv_std::arch::atomic_u_max::<u64, { Scope::QueueFamily as u32 }, { Semantics::NONE.bits() }>(&mut self[index], !key);
        }
    }
}

/// The key a pixel holds, from its stored word (`!key`).
#[inline(always)]
pub fn stored_key(word: u64) -> u64 {
    !word
}

/// Small triangle `setup` (of the frame's small list): each centre of its rectangle in the
/// window inside it keeps the smallest key, and is counted where the frame writes coverage.
#[inline]
pub fn fine_small<P, K, C>(program: &P, setup: &TriangleSetup, frame: &FrameParams, keys: &mut K, counts: &mut C)
where
    P: PixelProgram<Setup = TriangleSetup, Staged = TriangleSetup, Key = u64>,
    K: PixelKeys + ?Sized,
    C: Counters + ?Sized,
{
    // One copy of the record: read in the loops, a storage buffer's words would be loaded
    // again at every centre (the atomics below may alias them, as far as a compiler knows).
    let setup = *setup;
    let setup = &setup;
    let c = &setup.coverage;
    let (wx0, wy0) = (frame.win_x0 as i32, frame.win_y0 as i32);
    let (wx1, wy1) = (wx0 + frame.win_w as i32 - 1, wy0 + frame.win_h as i32 - 1);
    let (i0, i1) = (if c.rect.i0 > wx0 { c.rect.i0 } else { wx0 }, if c.rect.i1 < wx1 { c.rect.i1 } else { wx1 });
    let (j0, j1) = (if c.rect.j0 > wy0 { c.rect.j0 } else { wy0 }, if c.rect.j1 < wy1 { c.rect.j1 } else { wy1 });
    let counted = frame.outputs.contains(OutputSet::COVERAGE);
    let e = &c.edges;
    let mut j = j0;
    while j <= j1 {
        if program.small_edges() {
            // 32-bit edge functions, stepped along the row: the same values
            // (`EdgeEq::at_i32`), an add a centre.
            let (di, dj) = (i0 - c.rect.i0, j - c.rect.j0);
            let (mut w0, mut w1, mut w2) = (e[0].at_i32(di, dj, 0, 0), e[1].at_i32(di, dj, 0, 0), e[2].at_i32(di, dj, 0, 0));
            let (s0, s1, s2) = (e[0].step_i as i32, e[1].step_i as i32, e[2].step_i as i32);
            let mut i = i0;
            while i <= i1 {
                if side_of_i32(w0, w1, w2, c.excluded_edges) == Side::Inside {
                    keep_fragment(program, setup, frame, counted, keys, counts, i, j, [w0 as i64, w1 as i64, w2 as i64]);
                }
                (w0, w1, w2) = (w0.wrapping_add(s0), w1.wrapping_add(s1), w2.wrapping_add(s2));
                i += 1;
            }
        } else {
            let mut i = i0;
            while i <= i1 {
                let (side, edges) = fine::side_and_edges(c, i, j);
                if side == Side::Inside {
                    keep_fragment(program, setup, frame, counted, keys, counts, i, j, edges);
                }
                i += 1;
            }
        }
        j += 1;
    }
}

/// A centre `(i, j)` inside the triangle, its edge functions `edges`: counted where `counted`,
/// and its key kept where it passes.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
fn keep_fragment<P, K, C>(program: &P, setup: &TriangleSetup, frame: &FrameParams, counted: bool, keys: &mut K, counts: &mut C, i: i32, j: i32, edges: [i64; 3])
where
    P: PixelProgram<Setup = TriangleSetup, Staged = TriangleSetup, Key = u64>,
    K: PixelKeys + ?Sized,
    C: Counters + ?Sized,
{
    let k = fine::window_index(i, j, frame);
    if counted {
        counts.fetch_add(k, 1);
    }
    let key = program.key_at(setup, i, j, &edges);
    if key != P::NO_KEY {
        keys.keep_smallest(k, key);
    }
}
