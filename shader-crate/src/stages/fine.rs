//! Fine raster: one workgroup per tile, one invocation per pixel. The tile's bin is walked in
//! batches: every invocation stages one triangle in workgroup memory (`fine_load`), barrier,
//! each span of 8 pixels lists the triangles whose rectangles reach it (`span_lists`: not those
//! the tile's depth bound hides), barrier, every invocation tests its pixel centre against its
//! span's (`fine_test`), barrier.
//! Finally each invocation resolves its pixel (`fine_resolve`). Or, where the host asks for it
//! (short bins on a CPU implementation of Vulkan, where barriers are dear), each invocation
//! walks the bin on its own (`fine_walk`).
//!
//! The stage is generic over what a pixel computes: a [`PixelProgram`] says what a batch
//! stages of a triangle, which of the triangles covering a centre owns it (the smallest
//! *key*), and what the owner's value is there. The heightfield's program
//! (`crate::programs::height`) keys by triangle index and computes a height plane; a 3D
//! pipeline keys by depth and interpolates attributes, through the same stage.
//!
//! Fill rule: a pixel centre strictly inside a triangle, or on one of its top-left edges, is
//! *inside* it; in a mesh that tiles a region every centre of the region's interior is inside
//! exactly one triangle. Where a program asks for it ([`PixelProgram::HULL_EDGES`]), a centre
//! that is inside no triangle but lies exactly on the edge of one (an edge no triangle
//! continues beyond: the mesh's outer boundary) is still covered, by the lowest-index triangle
//! it touches, as gdal_grid covers hull points.
//!
//! Specialisations, each allowed by a bit of `FrameParams::flags`; none changes a bit of the
//! output:
//! - a tile with an empty bin writes the background straight away (`empty_tile`);
//! - a tile whose bin holds a single triangle that covers all of it (binning marks such
//!   entries with `FULL_TILE_BIT`) skips the batches: every pixel is inside that triangle
//!   (`full_tile`);
//! - where the host proved that no pixel centre is inside two triangles (`overlap_free`), a
//!   pixel stops testing at the first triangle it is inside: that one owns it, the count is 1;
//! - where the program bounds its keys over a tile ([`PixelProgram::OCCLUSION`]: the depth
//!   test), the bin's triangles that cover the tile whole give it a bound first
//!   (`fine_occluders`), and each triangle whose keys all lie above it is staged as hidden:
//!   the pixels only count it (where the coverage layer is asked for) and compute no key.
//!
//! Ownership is the minimum key over the triangles a centre is inside, which does not depend
//! on the order of the bin; the coverage count is a plain count. Both are therefore
//! deterministic whatever the scheduling of the binning atomics.

use crate::abi::{Counter, Coverage, FrameFlags, FrameParams, OutputSet, PixelRect, SetupPart, TriangleSetup};
use crate::math::edge::{Side, side_of};
use crate::memory::{Counters, LANE_GROUP, LaneValue, Lanes};
use crate::{BATCH, FULL_TILE_BIT, NO_OWNER, TILE, TILE_PIXELS};

/// What a fine-raster pixel computes from the triangles that cover it.
///
/// Keys must be unique per triangle where ties would matter (the heightfield's key is the
/// triangle index; a depth key carries the index in its low bits), so that the owner does not
/// depend on the order in which the pixel meets the triangles.
pub trait PixelProgram {
    /// One triangle as the setup stage leaves it (an element of the setup buffer).
    type Setup;
    /// What a batch stages of a triangle in workgroup memory: its coverage, and what its key
    /// needs. A setup record starts with it, so the CPU reads it in place.
    type Staged: Copy;
    /// Orders the triangles covering a centre: the smallest owns it.
    type Key: Copy + PartialOrd;
    /// One pixel's element of the values layer.
    type Value: Copy;
    /// Greater than every key a triangle has.
    const NO_KEY: Self::Key;
    /// Whether a centre inside no triangle but on an excluded edge of one is covered by the
    /// lowest-index such triangle (the heightfield's hull), rather than left uncovered.
    const HULL_EDGES: bool;

    /// The part of a setup record a batch stages.
    fn staged(setup: &Self::Setup) -> &Self::Staged;
    /// The coverage data of a staged triangle.
    fn coverage(staged: &Self::Staged) -> &Coverage;
    /// The triangle's key at pixel `(i, j)` (called only where the centre is inside it):
    /// `NO_KEY` where the triangle may not own the pixel at all (a failed depth test).
    fn key(&self, staged: &Self::Staged, i: i32, j: i32) -> Self::Key;
    /// [`Self::key`] given the triangle's three edge functions at the centre, which the
    /// coverage test has just computed (a program whose key depends on them reuses them).
    #[inline(always)]
    fn key_at(&self, staged: &Self::Staged, i: i32, j: i32, _edges: &[i64; 3]) -> Self::Key {
        self.key(staged, i, j)
    }
    /// The owner's value at pixel `(i, j)`.
    fn value(&self, setup: &Self::Setup, i: i32, j: i32) -> Self::Value;
    /// The owner's value, where its key holds it (the depth test's key holds the depth), so
    /// that resolving a pixel reads no setup record; `None` where [`Self::value`] must work it
    /// out.
    #[inline(always)]
    fn value_in_key(&self, _key: Self::Key) -> Option<Self::Value> {
        None
    }
    /// Whether every triangle's edge functions fit 32 bits (`stages::setup::edges_fit_i32`), so
    /// that coverage takes them in 32-bit arithmetic ([`side_and_edges_small`]) and a key that
    /// reuses them may too: the same values, fewer instructions.
    #[inline(always)]
    fn small_edges(&self) -> bool {
        false
    }
    /// Whether a pixel may stop at the first triangle it is inside where the frame proves that
    /// none overlap (`overlap_free`): not for a program whose frames never ask for it (the
    /// depth test, where every fragment's key counts), so that its stage holds no such check.
    const OVERLAP_FREE_PATH: bool = true;
    /// Whether a tile whose bin is one triangle covering it whole may skip the tests
    /// (`full_tile`): not for a program whose value comes from the key, which that path does
    /// not work out.
    const FULL_TILE_PATH: bool = true;
    /// The value of a pixel no triangle covers.
    fn background(&self) -> Self::Value;

    /// The state a pixel starts the tile stage from where the frame's small triangles were
    /// rasterised apart (`stages::small`, `FrameFlags::SMALL_TRIANGLES`): the word their
    /// atomics left in its key (`small::stored_key`), and their fragments there. Only a program
    /// whose keys name their owner can take it; the default is for the others, whose frames
    /// never ask for it.
    #[inline(always)]
    fn seeded(&self, _stored: u64, _count: u32) -> PixelState<Self::Key> {
        PixelState::empty(Self::NO_KEY)
    }

    /// Whether the program can bound its keys over a tile ([`Self::occluder_key`],
    /// [`Self::lowest_key`]), so that a tile rejects the triangles that cannot own any of its
    /// pixels.
    const OCCLUSION: bool = false;
    /// For a triangle that covers `tile` whole: a key no pixel of the tile ends above, where
    /// the triangle gives every pixel of the tile a key; `NO_KEY` otherwise.
    fn occluder_key(&self, _staged: &Self::Staged, _tile: &PixelRect) -> Self::Key {
        Self::NO_KEY
    }
    /// A key no key of the triangle over `tile` lies below (or one no bound lies below). A
    /// program with [`Self::OCCLUSION`] must give it: the default, `NO_KEY`, is for programs
    /// without, where nothing is hidden.
    fn lowest_key(&self, _staged: &Self::Staged, _tile: &PixelRect) -> Self::Key {
        Self::NO_KEY
    }
    /// Whether the triangle's keys over `tile` all lie above `occluding` (the smallest
    /// `occluder_key` of the tile's bin), so that it owns none of its pixels. Without a bound
    /// (`NO_KEY`) nothing is hidden, and the lowest key is not worked out.
    #[inline(always)]
    fn hidden(&self, staged: &Self::Staged, tile: &PixelRect, occluding: Self::Key) -> bool {
        Self::OCCLUSION && occluding != Self::NO_KEY && self.lowest_key(staged, tile) > occluding
    }
}

/// Workgroup memory of fine raster: one batch of staged triangles, which of them are hidden,
/// the ones the pixels test, and the occluder keys of the tile's bin, a partial minimum per
/// loading invocation.
#[repr(C)]
#[derive(Copy, Clone)]
pub struct FineShared<S: Copy, K: Copy> {
    pub batch: [S; BATCH as usize],
    /// 1 where the staged triangle is hidden in the tile.
    pub hidden: [u32; BATCH as usize],
    /// Per span, the positions in `batch` of the triangles its pixels test, in batch order,
    /// four bytes to a word (`span_lists`)...
    pub lists: [u32; (SPANS * BATCH / 4) as usize],
    /// ... and how many there are.
    pub listed: [u32; SPANS as usize],
    pub occluders: [K; OCCLUDER_LANES as usize],
}

impl<S: Copy, K: Copy> FineShared<S, K> {
    /// Workgroup memory as it is before the first phase (the CPU's twins start from it).
    pub fn new(staged: S, no_key: K) -> Self {
        FineShared {
            batch: [staged; BATCH as usize],
            hidden: [0; BATCH as usize],
            lists: [0; (SPANS * BATCH / 4) as usize],
            listed: [0; SPANS as usize],
            occluders: [no_key; OCCLUDER_LANES as usize],
        }
    }
}

/// What one invocation carries across the batches of its tile.
#[derive(Copy, Clone)]
pub struct PixelState<K: Copy> {
    /// Smallest key of a triangle the centre is inside (`NO_KEY` if none)...
    pub key: K,
    /// ... that triangle's index (`NO_OWNER` if none)...
    pub owner: u32,
    /// ... and its setup slot.
    pub slot: u32,
    /// Number of triangles the centre is inside.
    pub count: u32,
    /// Lowest index of a triangle whose excluded edge the centre lies on.
    pub edge_owner: u32,
    /// Setup slot of that triangle.
    pub edge_slot: u32,
}

impl<K: Copy> PixelState<K> {
    /// The state before any triangle: `no_key` is the program's `NO_KEY`.
    #[inline]
    pub fn empty(no_key: K) -> Self {
        PixelState { key: no_key, owner: NO_OWNER, slot: 0, count: 0, edge_owner: NO_OWNER, edge_slot: 0 }
    }
}

/// The resolved pixel: its value, owner and coverage count.
#[derive(Copy, Clone)]
pub struct PixelOut<V: Copy> {
    pub value: V,
    pub owner: u32,
    pub count: u32,
}

/// Grid pixel `(i, j)` of invocation `lid` in window tile `(tx, ty)`, and whether it lies in
/// the window (edge tiles overhang it).
#[inline]
pub fn tile_pixel(tx: u32, ty: u32, lid: u32, frame: &FrameParams) -> (i32, i32, bool) {
    let lx = lid % TILE;
    let ly = lid / TILE;
    let wx = tx * TILE + lx;
    let wy = ty * TILE + ly;
    let inside = wx < frame.win_w && wy < frame.win_h;
    ((frame.win_x0 + wx) as i32, (frame.win_y0 + wy) as i32, inside)
}

/// Index of grid pixel `(i, j)` in the window's row-major output buffers.
#[inline]
pub fn window_index(i: i32, j: i32, frame: &FrameParams) -> usize {
    ((j as u32 - frame.win_y0) * frame.win_w + (i as u32 - frame.win_x0)) as usize
}

/// The grid pixels of window tile `(tx, ty)` that lie in the window.
#[inline]
pub fn tile_rect(tx: u32, ty: u32, frame: &FrameParams) -> PixelRect {
    let (i0, j0, _) = tile_pixel(tx, ty, 0, frame);
    let i1 = i0 + (TILE - 1).min(frame.win_w - 1 - tx * TILE) as i32;
    let j1 = j0 + (TILE - 1).min(frame.win_h - 1 - ty * TILE) as i32;
    PixelRect { i0, j0, i1, j1 }
}

/// Whether the frame lets a tile reject the triangles its depth bound hides.
#[inline]
pub fn rejects_hidden<P: PixelProgram>(frame: &FrameParams) -> bool {
    P::OCCLUSION && frame.flags.contains(FrameFlags::HIDDEN_TRIANGLES)
}

/// Invocations that take the tile's occluders: few, since every invocation then reads their
/// partial minima (`occluding_key`), and every SIMD group pays for the loop it does not run.
pub const OCCLUDER_LANES: u32 = 8;

/// Occlusion, phase 1 (before the batches): invocation `lid < OCCLUDER_LANES` keeps the
/// smallest occluder key among the bin's entries `lid`, `lid + OCCLUDER_LANES`, … that cover the
/// tile whole.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn fine_occluders<P: PixelProgram>(
    program: &P,
    lid: u32,
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    setups: &[P::Setup],
    tile: &PixelRect,
    shared: &mut FineShared<P::Staged, P::Key>,
) {
    if lid >= OCCLUDER_LANES {
        return;
    }
    let mut best = P::NO_KEY;
    let mut k = lid;
    while k < bin_len {
        let entry = bin[(bin_start + k) as usize];
        if entry & FULL_TILE_BIT != 0 {
            let key = program.occluder_key(P::staged(&setups[(entry & !FULL_TILE_BIT) as usize]), tile);
            if key < best {
                best = key;
            }
        }
        k += OCCLUDER_LANES;
    }
    shared.occluders[lid as usize] = best;
}

/// Occlusion, phase 2: the tile's bound, the smallest of the partial minima.
#[inline]
pub fn occluding_key<P: PixelProgram>(shared: &FineShared<P::Staged, P::Key>) -> P::Key {
    let mut best = P::NO_KEY;
    let mut k = 0;
    while k < OCCLUDER_LANES {
        if shared.occluders[k as usize] < best {
            best = shared.occluders[k as usize];
        }
        k += 1;
    }
    best
}

/// Phase 1: invocation `lid` stages entry `batch_start + lid` of the tile's bin, and whether
/// the tile's bound `occluding` hides it.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn fine_load<P: PixelProgram>(
    program: &P,
    lid: u32,
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    batch_start: u32,
    setups: &[P::Setup],
    tile: &PixelRect,
    occluding: P::Key,
    shared: &mut FineShared<P::Staged, P::Key>,
) {
    let k = batch_start + lid;
    if lid < BATCH && k < bin_len {
        let slot = bin[(bin_start + k) as usize] & !FULL_TILE_BIT;
        let staged = P::staged(&setups[slot as usize]);
        shared.batch[lid as usize] = *staged;
        shared.hidden[lid as usize] = (P::OCCLUSION && program.hidden(staged, tile, occluding)) as u32;
    }
}

/// How many triangles of the batch just staged are hidden (invocation 0 adds them up for the
/// statistics).
#[inline]
pub fn batch_hidden<S: Copy, K: Copy>(batch_len: u32, shared: &FineShared<S, K>) -> u32 {
    let mut n = 0;
    let mut k = 0;
    while k < batch_len {
        n += shared.hidden[k as usize];
        k += 1;
    }
    n
}

/// Pixels of a span: a run of one tile row, the unit of the triangle lists (`span_lists`). A
/// span is at most one SIMD group of invocations wherever a device groups 8 or more consecutive
/// ones (a CPU implementation of Vulkan runs 8 at a time).
pub const SPAN: u32 = 8;
/// Spans of a tile.
pub const SPANS: u32 = TILE_PIXELS / SPAN;

// A span lies in one tile row, and a batch position fits a byte.
const _: () = assert!(TILE.is_multiple_of(SPAN) && BATCH <= 256 && BATCH.is_multiple_of(4));

/// The bit of invocation `lid`'s span in a bin entry's span mask (`stages::bin::entry_spans`):
/// `half · 16 + row`, for the tile's two 8-pixel halves of its 16 rows.
#[inline]
pub fn span_bit(lid: u32) -> u32 {
    (lid % TILE / SPAN) * TILE + lid / TILE
}

// The spans of a tile are the 32 bits of a mask (a walk's lane group is one span where the
// device numbers subgroup lanes as invocations).
const _: () = assert!(SPANS == 32 && TILE / SPAN == 2 && SPAN == crate::memory::LANE_GROUP);

/// Phase 1b, invocations `lid < SPANS` (after the batch is staged): span `lid`'s list of the
/// batch's triangles whose rectangle reaches it, in batch order. A triangle owns, covers and
/// touches nothing outside its rectangle, and a hidden one owns nothing: it is listed only
/// where the coverage layer counts it (`count_hidden`). The pixels then loop over their span's
/// triangles alone: a SIMD lane pays for an iteration it skips as for one it takes (a CPU
/// implementation of Vulkan runs every branch), so the only saving is a shorter loop.
#[inline]
pub fn span_lists<P: PixelProgram>(
    lid: u32,
    tx: u32,
    ty: u32,
    frame: &FrameParams,
    batch_len: u32,
    count_hidden: bool,
    shared: &mut FineShared<P::Staged, P::Key>,
) {
    if lid >= SPANS {
        return;
    }
    let (i0, j, _) = tile_pixel(tx, ty, lid * SPAN, frame);
    let i1 = i0 + SPAN as i32 - 1;
    let base = lid * BATCH;
    let mut n = 0;
    let mut k = 0;
    while k < batch_len {
        let r = &P::coverage(&shared.batch[k as usize]).rect;
        if (count_hidden || shared.hidden[k as usize] == 0) && r.j0 <= j && j <= r.j1 && r.i0 <= i1 && i0 <= r.i1 {
            let at = base + n;
            let word = (at / 4) as usize;
            let shift = 8 * (at % 4);
            shared.lists[word] = (shared.lists[word] & !(0xff << shift)) | (k << shift);
            n += 1;
        }
        k += 1;
    }
    shared.listed[lid as usize] = n;
}

/// Where pixel centre `(i, j)` lies relative to the triangle.
#[inline]
pub fn side(c: &Coverage, i: i32, j: i32) -> Side {
    side_and_edges(c, i, j).0
}

/// Where pixel centre `(i, j)` lies relative to the triangle, and the three edge functions
/// there where it is in the triangle's rectangle (a SIMD lane computes them either way; outside
/// the rectangle they are those of its nearest pixel, whose values the setup bounds, and mean
/// nothing).
#[inline(always)]
pub fn side_and_edges(c: &Coverage, i: i32, j: i32) -> (Side, [i64; 3]) {
    let r = &c.rect;
    let di = (i.clamp(r.i0, r.i1) - r.i0) as i64;
    let dj = (j.clamp(r.j0, r.j1) - r.j0) as i64;
    let e = &c.edges;
    let edges = [e[0].at(di, dj), e[1].at(di, dj), e[2].at(di, dj)];
    let side = if c.rect.contains(i, j) { side_of(edges[0], edges[1], edges[2], c.excluded_edges) } else { Side::Outside };
    (side, edges)
}

/// [`side_and_edges`] for a triangle whose edge functions fit 32 bits over its rectangle
/// (`stages::setup::edges_fit_i32`): each edge in 32-bit wrapping arithmetic
/// (`EdgeEq::at_i32`), exact modulo 2^32 and so exact where the value fits. (A GPU runs
/// 32-bit integer arithmetic natively; 64-bit products are several instructions each.)
#[inline(always)]
pub fn side_and_edges_small(c: &Coverage, i: i32, j: i32) -> (Side, [i64; 3]) {
    let r = &c.rect;
    let di = i.clamp(r.i0, r.i1) - r.i0;
    let dj = j.clamp(r.j0, r.j1) - r.j0;
    let e = &c.edges;
    let edges = [e[0].at_i32(di, dj, 0, 0) as i64, e[1].at_i32(di, dj, 0, 0) as i64, e[2].at_i32(di, dj, 0, 0) as i64];
    let side = if c.rect.contains(i, j) { side_of(edges[0], edges[1], edges[2], c.excluded_edges) } else { Side::Outside };
    (side, edges)
}

/// [`side_and_edges`], or its 32-bit twin where the program's triangles allow it.
#[inline(always)]
pub fn program_side_and_edges<P: PixelProgram>(program: &P, c: &Coverage, i: i32, j: i32) -> (Side, [i64; 3]) {
    if program.small_edges() { side_and_edges_small(c, i, j) } else { side_and_edges(c, i, j) }
}

/// What a pixel state keeps of one triangle test at pixel `(i, j)`: a count, the smallest key
/// (with its triangle's index and setup slot) among the triangles it is inside, and the
/// lowest index among those it lies on an excluded edge of. Minimum and sum do not depend on
/// the order of the tests.
#[inline(always)]
pub fn accumulate<P: PixelProgram>(program: &P, side: Side, staged: &P::Staged, i: i32, j: i32, state: &mut PixelState<P::Key>) {
    accumulate_with::<P>(side, staged, state, || program.key(staged, i, j))
}

/// [`accumulate`] given the edge functions at the centre, which the key may reuse.
#[allow(clippy::too_many_arguments)]
#[inline(always)]
pub fn accumulate_at<P: PixelProgram>(program: &P, side: Side, edges: &[i64; 3], staged: &P::Staged, i: i32, j: i32, state: &mut PixelState<P::Key>) {
    accumulate_with::<P>(side, staged, state, || program.key_at(staged, i, j, edges))
}

#[inline(always)]
fn accumulate_with<P: PixelProgram>(side: Side, staged: &P::Staged, state: &mut PixelState<P::Key>, key: impl FnOnce() -> P::Key) {
    let c = P::coverage(staged);
    match side {
        Side::Inside => {
            state.count += 1;
            let key = key();
            if key < state.key {
                state.key = key;
                state.owner = c.index;
                state.slot = c.slot;
            }
        }
        Side::OnExcludedEdge => {
            if P::HULL_EDGES && c.index < state.edge_owner {
                state.edge_owner = c.index;
                state.edge_slot = c.slot;
            }
        }
        Side::Outside => {}
    }
}

/// Pixel `(i, j)`'s state before the tile's bin: what the frame's small triangles left there
/// (`PixelProgram::seeded`, from `keys` and the coverage layer's counts) where the frame
/// rasterised them apart, else empty.
#[inline]
pub fn starting_state<P: PixelProgram>(program: &P, i: i32, j: i32, inside: bool, frame: &FrameParams, keys: &[u64], coverage: &[u32]) -> PixelState<P::Key> {
    if !(inside && frame.flags.contains(FrameFlags::SMALL_TRIANGLES)) {
        return PixelState::empty(P::NO_KEY);
    }
    let k = window_index(i, j, frame);
    let count = if counts_hidden(frame) { coverage[k] } else { 0 };
    program.seeded(keys[k], count)
}

/// Whether the frame lets a pixel stop at the first triangle it is inside.
#[inline]
pub fn overlap_free<P: PixelProgram>(frame: &FrameParams) -> bool {
    P::OVERLAP_FREE_PATH && frame.flags.contains(FrameFlags::OVERLAP_FREE)
}

/// Whether the frame writes the coverage layer, so that a hidden triangle is still counted
/// where its pixels are inside it.
#[inline]
pub fn counts_hidden(frame: &FrameParams) -> bool {
    frame.outputs.contains(OutputSet::COVERAGE)
}

/// Phase 2: test pixel `(i, j)` of invocation `lid` against the staged triangles its span's
/// list holds (with `overlap_free`, only until it is inside one: no other can contain it). A
/// hidden triangle owns nothing: it is only counted, and only where `count_hidden`.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn fine_test<P: PixelProgram>(
    program: &P,
    lid: u32,
    i: i32,
    j: i32,
    shared: &FineShared<P::Staged, P::Key>,
    overlap_free: bool,
    count_hidden: bool,
    state: &mut PixelState<P::Key>,
) {
    let span = lid / SPAN;
    let base = span * BATCH;
    let mut n = 0;
    while n < shared.listed[span as usize] {
        if overlap_free && state.owner != NO_OWNER {
            return;
        }
        let at = base + n;
        let k = shared.lists[(at / 4) as usize] >> (8 * (at % 4)) & 0xff;
        let staged = &shared.batch[k as usize];
        // One coverage test serves both cases (and the key where it needs the edges).
        let (side, edges) = program_side_and_edges(program, P::coverage(staged), i, j);
        if !P::OCCLUSION || shared.hidden[k as usize] == 0 {
            accumulate_at(program, side, &edges, staged, i, j, state);
        } else if count_hidden && side == Side::Inside {
            state.count += 1;
        }
        n += 1;
    }
}

/// The `SpecId` of the fine-raster entry points' way through their bins...
pub const WALK_SPEC_ID: u32 = 1;
/// ... and its bit that makes them walk (`fine_walk`), so that the driver never sees the
/// batches' barriers. (`fine_raster`'s constant also holds its value mode, below this bit.)
pub const WALK: u32 = 1 << 8;
/// A bit of the shade stage's constant at the same `SpecId`: no tile of the scene is left to
/// it ([`left_to_shade`]), so that the driver leaves the resolve out of it.
pub const NO_TILES_LEFT: u32 = 1 << 9;

/// The walk, instead of the batches: pixel `(i, j)` tests every triangle of the tile's bin
/// whose rectangle holds it (with `overlap_free`, only until it is inside one). No workgroup
/// memory and no barrier: on a CPU implementation of Vulkan a barrier switches every
/// invocation of the workgroup out and back in.
///
/// The bin is taken eight entries at a time by a group of eight lanes, one span of the tile
/// where the device numbers its subgroup lanes as its invocations (`span` is each pixel's bit,
/// [`span_bit`]; the group ORs its pixels' bits once, so any order is right). Each lane judges
/// one entry (does its rectangle reach the group's spans: one load of the span mask binning
/// wrote after the window's `entries` entries of `bin`, `stages::bin::entry_spans`), the group
/// votes, and then reads together (`Lanes`: a word loaded per lane, passed round) the records
/// of the triangles it must test, so every lane runs every iteration; a pixel that may stop
/// (`overlap_free`, an owner found) only stops testing, and the subgroup stops before its next
/// eight entries once all its pixels have (asking it is a loop over its lanes on a CPU
/// implementation of Vulkan: once a round, not once a triangle). The host's twin, one pixel at a
/// time, judges all eight entries itself by its own span: neither skips a triangle that holds a
/// pixel. The records are read as words (`setup_words`), so the walk is for programs whose
/// setup is a [`TriangleSetup`].
///
/// Where the frame rejects hidden triangles (`rejects_hidden`), binning wrote each entry's
/// keys (`bin_keys`, `stages::bin::entry_keys`): a first pass takes the tile's bound, the smallest occluder key of the bin (as
/// `fine_occluders` and `occluding_key` take it for the batches), and a triangle whose lowest
/// key lies above it is hidden, as the batches judge it. Returns how many of the bin's
/// triangles it hides (the same in every lane).
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn fine_walk<P: PixelProgram<Setup = TriangleSetup>>(
    program: &P,
    lanes: &Lanes,
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    bin_keys: &[P::Key],
    entries: u32,
    setup_words: &[u64],
    rejects_hidden: bool,
    count_hidden: bool,
    span: u32,
    i: i32,
    j: i32,
    overlap_free: bool,
    state: &mut PixelState<P::Key>,
) -> u32
where
    P::Staged: SetupPart,
    P::Key: LaneValue,
{
    let mut occluding = P::NO_KEY;
    if rejects_hidden {
        let mut k = 0;
        while k < bin_len {
            let run = if bin_len - k < LANE_GROUP { bin_len - k } else { LANE_GROUP };
            let key = lanes.read8(bin_keys, bin_start + k).min_of(run, P::NO_KEY, |key| key);
            if key < occluding {
                occluding = key;
            }
            k += LANE_GROUP;
        }
    }
    let group_spans = lanes.group_or(1 << span);
    let mut hidden = 0;
    let mut k = 0;
    while k < bin_len {
        // A subgroup whose pixels have all found their owner stops (the hidden count needs every
        // entry).
        if overlap_free && !rejects_hidden && lanes.all(state.owner != NO_OWNER) {
            return 0;
        }
        let slots = lanes.read8(bin, bin_start + k);
        let run = if bin_len - k < LANE_GROUP { bin_len - k } else { LANE_GROUP };
        // Without a bound (`NO_KEY`) nothing is hidden, as `PixelProgram::hidden` has it.
        let hides =
            if rejects_hidden && occluding != P::NO_KEY { lanes.read8(bin_keys, entries + bin_start + k).select(run, |lowest| lowest > occluding) } else { 0 };
        hidden += hides.count_ones();
        // A hidden triangle is only counted, and only where the coverage layer is asked for.
        let reach = lanes.read8(bin, entries + bin_start + k).select(run, move |spans| spans & group_spans != 0);
        let mut left = reach & if count_hidden { !0 } else { !hides };
        while left != 0 {
            let m = left.trailing_zeros();
            left &= left - 1;
            let done = overlap_free && state.owner != NO_OWNER;
            let staged = P::Staged::read_setup(lanes, setup_words, slots.get(m) & !FULL_TILE_BIT);
            let c = P::coverage(&staged);
            if !done && c.rect.contains(i, j) {
                let (side, edges) = program_side_and_edges(program, c, i, j);
                if hides >> m & 1 == 0 {
                    accumulate_at(program, side, &edges, &staged, i, j, state);
                } else if side == Side::Inside {
                    state.count += 1;
                }
            }
        }
        k += LANE_GROUP;
    }
    hidden
}

/// Whether the tile takes the empty path: nothing in its bin, so every pixel is background.
#[inline]
pub fn empty_tile(bin_len: u32, frame: &FrameParams) -> bool {
    bin_len == 0 && frame.flags.contains(FrameFlags::EMPTY_TILES)
}

/// Whether fine raster leaves the tile to the shade stage: an empty tile of a frame whose small
/// triangles were rasterised apart (`fine_small`), so that only they reach it and each pixel's
/// owner is its key's. The shade stage reads every pixel anyway; it resolves these
/// ([`resolve_left`]) and writes their depth and owner, which saves a pass over the tile. Their
/// coverage counts are in the coverage layer already (`fine_small` counts there), but for the
/// pixels nothing owns (every fragment failed against the clear depth), which count none, as
/// `fine_resolve` has it: the shade stage zeroes those.
#[inline]
pub fn left_to_shade(bin_len: u32, frame: &FrameParams) -> bool {
    empty_tile(bin_len, frame) && frame.flags.contains(FrameFlags::SMALL_TRIANGLES)
}

/// The first workgroup of the tile queue's dispatch (`stages::scan`) counts the tiles left out
/// of it (left to the shade stage) as empty tiles, as the workgroups that never start would.
#[inline]
pub fn count_left_tiles<C: Counters + ?Sized>(x: u32, y: u32, lid: u32, frame: &FrameParams, queue: &[u32], stats: &mut C) {
    let left = frame.tile_count() - queue[3];
    if x == 0 && y == 0 && lid == 0 && left != 0 {
        stats.fetch_add(Counter::TilesEmpty as usize, left);
    }
}

/// Pixel `(i, j)` of a tile left to the shade stage ([`left_to_shade`]), resolved from the key
/// the small triangles left there (`PixelProgram::seeded`) as fine raster resolves it: the
/// same value and owner (its count is not asked for).
#[inline]
pub fn resolve_left<P: PixelProgram>(program: &P, i: i32, j: i32, stored_key: u64, setups: &[P::Setup]) -> PixelOut<P::Value> {
    fine_resolve(program, i, j, &program.seeded(stored_key, 0), setups)
}

/// Whether the tile takes the full path: its bin is a single triangle covering the whole tile.
/// If so, `state` becomes every pixel's state, with no edge test (and no key: there is no
/// other triangle to compare it with).
#[inline]
pub fn full_tile<P: PixelProgram>(bin: &[u32], bin_start: u32, bin_len: u32, setups: &[P::Setup], frame: &FrameParams, state: &mut PixelState<P::Key>) -> bool {
    if !P::FULL_TILE_PATH || !frame.flags.contains(FrameFlags::FULL_TILES) || bin_len != 1 || bin[bin_start as usize] & FULL_TILE_BIT == 0 {
        return false;
    }
    let slot = bin[bin_start as usize] & !FULL_TILE_BIT;
    let index = P::coverage(P::staged(&setups[slot as usize])).index;
    *state = PixelState { key: P::NO_KEY, owner: index, slot, count: 1, edge_owner: NO_OWNER, edge_slot: 0 };
    true
}

/// Phase 3: the pixel's outputs: the owner's value from its key where the key holds it, else
/// from its setup record. A centre inside no triangle falls back to a triangle whose excluded
/// edge it lies on (with `HULL_EDGES`): nobody continues across that edge.
#[inline]
pub fn fine_resolve<P: PixelProgram>(program: &P, i: i32, j: i32, state: &PixelState<P::Key>, setups: &[P::Setup]) -> PixelOut<P::Value> {
    let (owner, slot, count) = if state.owner != NO_OWNER {
        if let Some(value) = program.value_in_key(state.key) {
            return PixelOut { value, owner: state.owner, count: state.count };
        }
        (state.owner, state.slot, state.count)
    } else if P::HULL_EDGES && state.edge_owner != NO_OWNER {
        (state.edge_owner, state.edge_slot, 1)
    } else {
        return background_pixel(program);
    };
    PixelOut { value: program.value(&setups[slot as usize], i, j), owner, count }
}

/// The outputs of a pixel no triangle covers.
#[inline]
pub fn background_pixel<P: PixelProgram>(program: &P) -> PixelOut<P::Value> {
    PixelOut { value: program.background(), owner: NO_OWNER, count: 0 }
}

/// Invocation 0 adds the tile to statistics counter `counter`.
#[inline]
pub fn count_tile<C: Counters + ?Sized>(lid: u32, counter: Counter, stats: &mut C) {
    if lid == 0 {
        stats.fetch_add(counter as usize, 1);
    }
}

/// Invocation 0 adds the `hidden` triangles it counted in the tile's batches to the statistics.
#[inline]
pub fn count_hidden_triangles<C: Counters + ?Sized>(lid: u32, hidden: u32, stats: &mut C) {
    if lid == 0 && hidden != 0 {
        stats.fetch_add(Counter::TrianglesHidden as usize, hidden);
    }
}

/// Invocation 0 writes the tile's statistics where the frame asks for them: its bin's entries
/// and how many of them were hidden.
#[inline]
pub fn write_tile_stats(lid: u32, tile: u32, bin_len: u32, hidden: u32, frame: &FrameParams, tile_stats: &mut [u32]) {
    if lid == 0 && frame.outputs.contains(OutputSet::TILES) {
        tile_stats[2 * tile as usize] = bin_len;
        tile_stats[2 * tile as usize + 1] = hidden;
    }
}

/// Number of bin entries in the batch starting at `batch_start`.
pub fn batch_len(bin_len: u32, batch_start: u32) -> u32 {
    let left = bin_len - batch_start;
    if left < BATCH { left } else { BATCH }
}

/// Bin entries of window tile `tile`: `(start, len)`.
pub fn bin_range(offsets: &[u32], tile: u32) -> (u32, u32) {
    let start = offsets[tile as usize];
    (start, offsets[tile as usize + 1] - start)
}
