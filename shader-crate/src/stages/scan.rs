//! Exclusive prefix sum of the per-tile bin counts, by one workgroup of `SCAN_GROUP`
//! invocations in three phases separated by barriers: each invocation sums a contiguous
//! chunk, the chunk sums are scanned, each invocation writes its chunk's offsets.
//! `offsets` has `n + 1` entries; the last is the total.
//!
//! The same pass writes the tile queue of `fine_depth`, an indirect dispatch: the tiles it
//! takes (every tile but those it leaves to the shade stage, `fine::left_to_shade`), in
//! order, after [`QUEUE_HEAD`] words that hold the dispatch's workgroup counts and the queue's
//! length ([`queued_tile`] maps a workgroup to its tile). A frame of small triangles alone
//! starts no `fine_depth` workgroup on the tiles they alone reach, where a CPU implementation
//! of Vulkan pays a fixed cost for each one it starts.

use crate::SCAN_GROUP;
use crate::abi::FrameParams;
use crate::stages::fine::left_to_shade;

/// Workgroup memory of the scan: per invocation, its chunk's sum of counts, then (from
/// `SCAN_GROUP` on) how many of its tiles the queue takes.
pub type ScanShared = [u32; 2 * SCAN_GROUP as usize];

/// Words of the tile queue before its tiles: the indirect dispatch's workgroup counts
/// `(x, y, z)`, then the queue's length.
pub const QUEUE_HEAD: u32 = 4;

/// Invocation `lid`'s chunk of `n` items: `[start, end)`, clamped to `n`. (`assemble_scan`'s
/// chunks of groups too.)
pub fn chunk(lid: u32, n: u32) -> (u32, u32) {
    let size = n.div_ceil(SCAN_GROUP);
    let start = lid * size;
    let end = start + size;
    (if start < n { start } else { n }, if end < n { end } else { n })
}

/// Whether the tile queue takes a tile of `count` bin entries.
#[inline]
fn queued(count: u32, frame: &FrameParams) -> bool {
    !left_to_shade(count, frame)
}

/// Phase 1: `shared[lid]` = sum of this invocation's chunk, `shared[SCAN_GROUP + lid]` its
/// queued tiles.
pub fn scan_reduce(lid: u32, counts: &[u32], n: u32, frame: &FrameParams, shared: &mut ScanShared) {
    let (start, end) = chunk(lid, n);
    let (mut sum, mut tiles) = (0, 0);
    let mut i = start;
    while i < end {
        let count = counts[i as usize];
        sum += count;
        tiles += queued(count, frame) as u32;
        i += 1;
    }
    shared[lid as usize] = sum;
    shared[(SCAN_GROUP + lid) as usize] = tiles;
}

/// Phase 2: invocation 0 turns the chunk sums, and the chunks' queued tiles, into exclusive
/// prefixes (and `assemble_scan`'s chunks' listed and small records).
pub fn scan_partials(lid: u32, shared: &mut ScanShared) {
    if lid != 0 {
        return;
    }
    let (mut running, mut tiles) = (0, 0);
    let mut k = 0;
    while k < SCAN_GROUP as usize {
        let (sum, queued) = (shared[k], shared[SCAN_GROUP as usize + k]);
        shared[k] = running;
        shared[SCAN_GROUP as usize + k] = tiles;
        running += sum;
        tiles += queued;
        k += 1;
    }
}

/// Phase 3: write the offsets and the queued tiles of this invocation's chunk; the last
/// invocation writes the total and the queue's head.
#[allow(clippy::too_many_arguments)]
pub fn scan_write(lid: u32, counts: &[u32], n: u32, frame: &FrameParams, shared: &ScanShared, offsets: &mut [u32], queue: &mut [u32]) {
    let (start, end) = chunk(lid, n);
    let mut running = shared[lid as usize];
    let mut tiles = shared[(SCAN_GROUP + lid) as usize];
    let mut i = start;
    while i < end {
        let count = counts[i as usize];
        offsets[i as usize] = running;
        if queued(count, frame) {
            queue[(QUEUE_HEAD + tiles) as usize] = i;
            tiles += 1;
        }
        running += count;
        i += 1;
    }
    if lid == SCAN_GROUP - 1 {
        offsets[n as usize] = running;
        // A row of workgroups per `tiles_x` queued tiles, and at least one: it counts the
        // tiles left out (`fine::count_left_tiles`).
        queue[0] = frame.tiles_x;
        queue[1] = tiles.div_ceil(frame.tiles_x).max(1);
        queue[2] = 1;
        queue[3] = tiles;
    }
}

/// The window tile `(tx, ty)` that workgroup `(x, y)` of the queue's dispatch takes: queue
/// entry `y · tiles_x + x`; `false` past the queue's end.
#[inline]
pub fn queued_tile(x: u32, y: u32, frame: &FrameParams, queue: &[u32]) -> (u32, u32, bool) {
    let entry = y * frame.tiles_x + x;
    if entry >= queue[3] {
        return (0, 0, false);
    }
    let tile = queue[(QUEUE_HEAD + entry) as usize];
    (tile % frame.tiles_x, tile / frame.tiles_x, true)
}
