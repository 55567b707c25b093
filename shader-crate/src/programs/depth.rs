//! The render pipeline's pixel program: a depth test. Each fragment's depth is interpolated
//! linearly on the screen from the vertices' `z/w` (as Vulkan does), compared with the clear
//! value, and the passing fragment with the smallest key owns the pixel. The key is the depth
//! (mapped to an unsigned order) above the setup slot, so that a tie in depth goes to one
//! triangle whatever the order of the bin: the earlier one for `Less`/`Greater`, the later one
//! for the `…Equal` functions, as a graphics API drawing the triangles in order keeps.
//!
//! The render pipeline's triangles carry their setup slot as their index (`Coverage::index`),
//! so the owner layer names the slot the shade stage reads; their depth coefficients are the
//! barycentric mode's (`FloatCoeffs`: the vertices' depths and `1/Σw`), so the depth is
//! `Σ (w_k · c3) · z_k` in `f32`, each operation correctly rounded (see
//! `docs/numeric-contract.md` for its bound).

use crate::NO_OWNER;
use crate::abi::{Coverage, DepthFunc, DepthTest, FrameParams, PixelRect, TriangleSetup};
use crate::programs::height::{barycentric_bits, barycentric_bits_of, barycentric_bits_small};
use crate::stages::fine::{PixelProgram, PixelState};
use crate::stages::small::stored_key;

/// [`PixelProgram`] of the render pipeline.
#[derive(Copy, Clone)]
pub struct DepthProgram {
    pub func: DepthFunc,
    pub write: bool,
    /// The depth buffer's clear value.
    pub clear: f32,
    /// Every triangle's edge functions fit 32 bits (`stages::setup::edges_fit_i32`): coverage
    /// and depth take them in 32-bit arithmetic, with the same results.
    pub small_edges: bool,
}

impl DepthProgram {
    /// The program a frame asks for.
    #[inline]
    pub fn of(frame: &FrameParams) -> DepthProgram {
        DepthProgram { func: frame.depth_test.func(), write: frame.depth_test.write(), clear: f32::from_bits(frame.nodata_bits), small_edges: false }
    }

    /// The bit of a stage's specialisation constant (`fine::WALK_SPEC_ID`, or
    /// `bin::KEYS_SPEC_ID`) that says it fixes the frame's depth test in the bits above it...
    pub const SPECIALISED: u32 = 1 << 16;
    const FUNC_SHIFT: u32 = 17;
    const WRITE_BIT: u32 = 1 << 20;
    /// A bit of the same constant, with [`Self::SPECIALISED`]: every triangle of the frame has
    /// edge functions that fit 32 bits (`stages::setup::edges_fit_i32`), which the host checks.
    pub const SMALL_EDGES: u32 = 1 << 21;

    /// ... `test` in those bits: the host writes the frame's own, so that the driver folds
    /// the depth functions the frame does not use out of the key, the test and the resolve (a
    /// CPU implementation of Vulkan runs every arm of a `match` on a uniform).
    pub fn spec_bits(test: DepthTest) -> u32 {
        Self::SPECIALISED | (test.func() as u32) << Self::FUNC_SHIFT | if test.write() { Self::WRITE_BIT } else { 0 }
    }

    /// [`Self::of`], with the depth test the stage's constant `spec` fixes where it fixes one
    /// (the same as the frame's: [`Self::spec_bits`]).
    #[inline]
    pub fn specialised(frame: &FrameParams, spec: u32) -> DepthProgram {
        let program = Self::of(frame);
        if spec & Self::SPECIALISED == 0 {
            return program;
        }
        DepthProgram {
            func: DepthFunc::from_code(spec >> Self::FUNC_SHIFT & 0x7),
            write: spec & Self::WRITE_BIT != 0,
            small_edges: spec & Self::SMALL_EDGES != 0,
            ..program
        }
    }

    /// How this program's keys order passing fragments by depth: the nearest first (`Less…`),
    /// the farthest first (`Greater…`), or not at all (`Always`, and without depth writes,
    /// where every fragment is tested against the clear value alone).
    #[inline]
    pub fn depth_order(&self) -> DepthOrder {
        match self.func {
            _ if !self.write => DepthOrder::Ignored,
            DepthFunc::Less | DepthFunc::LessEqual => DepthOrder::Ascending,
            DepthFunc::Greater | DepthFunc::GreaterEqual => DepthOrder::Descending,
            DepthFunc::Always => DepthOrder::Ignored,
        }
    }

    /// Whether a tie in the key's depth goes to the later triangle (the key's lower half is
    /// the slot's complement): for the `…Equal` functions, `Always`, and without depth writes,
    /// as a graphics API drawing in order keeps the last fragment that passes; `Less` and
    /// `Greater` keep the first.
    #[inline]
    pub fn later_wins(&self) -> bool {
        !self.write || !matches!(self.func, DepthFunc::Less | DepthFunc::Greater)
    }

    /// The value [`PixelProgram::value`] gives the owner of a pixel whose smallest key is
    /// `key`, where the key tells it: without depth writes the clear value, with them the depth
    /// the key holds; `None` where it holds none (`Always`).
    #[inline]
    pub fn value_of_key(&self, key: u64) -> Option<u32> {
        if !self.write {
            return Some(self.clear.to_bits());
        }
        let upper = (key >> 32) as u32;
        match self.depth_order() {
            DepthOrder::Ascending => Some(unordered(upper)),
            DepthOrder::Descending => Some(unordered(!upper)),
            DepthOrder::Ignored => None,
        }
    }

    /// The key of a passing fragment of depth bits `bits` of the triangle with index `index`:
    /// its depth in the program's order above the index (or its complement, where the later
    /// triangle wins a tie).
    #[inline(always)]
    pub fn key_of(&self, bits: u32, index: u32) -> u64 {
        let depth = match self.depth_order() {
            DepthOrder::Ascending => ordered(bits),
            DepthOrder::Descending => !ordered(bits),
            DepthOrder::Ignored => 0,
        };
        let tie = if self.later_wins() { !index } else { index };
        (depth as u64) << 32 | tie as u64
    }

    /// The index of the triangle whose fragment has key `key` (its tie bits, [`Self::key_of`]).
    #[inline]
    pub fn index_of_key(&self, key: u64) -> u32 {
        let tie = key as u32;
        if self.later_wins() { !tie } else { tie }
    }

    /// The key of a fragment of depth bits `bits` of triangle `index`: `NO_KEY` where it fails
    /// the depth test.
    #[inline(always)]
    fn key_of_depth(&self, bits: u32, index: u32) -> u64 {
        if !self.passes(f32::from_bits(bits)) {
            return u64::MAX;
        }
        self.key_of(bits, index)
    }

    /// The barycentric depth bits of triangle `s` from its edge functions at a point, converted
    /// in 32-bit operations where they fit ([`Self::small_edges`]): the same bits either way.
    #[inline(always)]
    pub fn depth_of_edges(&self, s: &TriangleSetup, edges: [i64; 3]) -> u32 {
        if self.small_edges { barycentric_bits_small(s, edges) } else { barycentric_bits_of(s, edges) }
    }

    /// Whether a fragment of depth `d` passes the test against the clear value.
    #[inline]
    pub fn passes(&self, d: f32) -> bool {
        match self.func {
            DepthFunc::Less => d < self.clear,
            DepthFunc::LessEqual => d <= self.clear,
            DepthFunc::Greater => d > self.clear,
            DepthFunc::GreaterEqual => d >= self.clear,
            DepthFunc::Always => true,
        }
    }
}

/// The depth of triangle `s` at pixel `(i, j)`, as `f32` bits.
#[inline]
pub fn depth_bits(s: &TriangleSetup, i: i32, j: i32) -> u32 {
    barycentric_bits(s, i, j)
}

/// `f32` bits mapped to an unsigned order (negative values below positive ones).
#[inline]
pub fn ordered(bits: u32) -> u32 {
    if bits >> 31 == 1 { !bits } else { bits | 1 << 31 }
}

/// The `f32` bits [`ordered`] maps to `order`.
#[inline]
pub fn unordered(order: u32) -> u32 {
    if order >> 31 == 1 { order & !(1 << 31) } else { !order }
}

/// How a key's upper half orders the depths of passing fragments.
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
pub enum DepthOrder {
    /// The nearest (smallest) depth wins: [`ordered`] bits.
    Ascending,
    /// The farthest wins: the complement of the [`ordered`] bits.
    Descending,
    /// The key holds no depth (`Always`, or no depth writes).
    Ignored,
}

impl PixelProgram for DepthProgram {
    type Setup = TriangleSetup;
    type Staged = TriangleSetup;
    type Key = u64;
    type Value = u32;
    const NO_KEY: u64 = u64::MAX;
    const HULL_EDGES: bool = false;
    const OCCLUSION: bool = true;

    #[inline(always)]
    fn staged(setup: &TriangleSetup) -> &TriangleSetup {
        setup
    }

    #[inline(always)]
    fn coverage(staged: &TriangleSetup) -> &Coverage {
        &staged.coverage
    }

    /// Depth above slot; `NO_KEY` where the fragment fails the test. Without depth writes every
    /// fragment is tested against the clear value alone and the last passing one is kept.
    #[inline(always)]
    fn key(&self, s: &TriangleSetup, i: i32, j: i32) -> u64 {
        self.key_of_depth(depth_bits(s, i, j), s.coverage.index)
    }

    /// The depth from the edge functions the coverage test computed: the same bits.
    #[inline(always)]
    fn key_at(&self, s: &TriangleSetup, _i: i32, _j: i32, edges: &[i64; 3]) -> u64 {
        self.key_of_depth(self.depth_of_edges(s, *edges), s.coverage.index)
    }

    #[inline(always)]
    fn small_edges(&self) -> bool {
        self.small_edges
    }

    /// The depth the pixel keeps: the owner's, or the clear value without depth writes.
    #[inline(always)]
    fn value(&self, setup: &TriangleSetup, i: i32, j: i32) -> u32 {
        if self.write { depth_bits(setup, i, j) } else { self.clear.to_bits() }
    }

    /// Where the key holds the depth: every order but `Always` with depth writes. (Where the
    /// stage fixes the depth test, the driver drops `value`'s arithmetic altogether.)
    #[inline(always)]
    fn value_in_key(&self, key: u64) -> Option<u32> {
        self.value_of_key(key)
    }

    /// A full tile's pixels would have no key to take the depth from (render frames never ask
    /// for the path).
    const FULL_TILE_PATH: bool = false;

    /// Render frames never prove their triangles overlap-free (the host leaves it off).
    const OVERLAP_FREE_PATH: bool = false;

    #[inline(always)]
    fn background(&self) -> u32 {
        self.clear.to_bits()
    }

    /// The owner is the key's triangle, whose index is its setup slot (render triangles carry
    /// their slot as their index).
    #[inline(always)]
    fn seeded(&self, stored: u64, count: u32) -> PixelState<u64> {
        let key = stored_key(stored);
        let owner = if key != Self::NO_KEY { self.index_of_key(key) } else { NO_OWNER };
        PixelState { key, owner, slot: if owner != NO_OWNER { owner } else { 0 }, count, edge_owner: NO_OWNER, edge_slot: 0 }
    }

    #[inline(always)]
    fn occluder_key(&self, s: &TriangleSetup, tile: &PixelRect) -> u64 {
        self.occluder_key_of(s, tile)
    }

    #[inline(always)]
    fn lowest_key(&self, s: &TriangleSetup, tile: &PixelRect) -> u64 {
        self.lowest_key_of(s, tile)
    }
}
