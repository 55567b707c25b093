//! Exclusive prefix sum of the per-tile bin counts, by one workgroup of `SCAN_GROUP`
//! invocations in three phases separated by barriers: each invocation sums a contiguous
//! chunk, the chunk sums are scanned, each invocation writes its chunk's offsets.
//! `offsets` has `n + 1` entries; the last is the total.

use crate::SCAN_GROUP;

/// Workgroup memory of the scan: one partial sum per invocation.
pub type ScanShared = [u32; SCAN_GROUP as usize];

fn chunk(lid: u32, n: u32) -> (u32, u32) {
    let size = n.div_ceil(SCAN_GROUP);
    let start = lid * size;
    let end = start + size;
    (if start < n { start } else { n }, if end < n { end } else { n })
}

/// Phase 1: `shared[lid]` = sum of this invocation's chunk.
pub fn scan_reduce(lid: u32, counts: &[u32], n: u32, shared: &mut ScanShared) {
    let (start, end) = chunk(lid, n);
    let mut sum = 0;
    let mut i = start;
    while i < end {
        sum += counts[i as usize];
        i += 1;
    }
    shared[lid as usize] = sum;
}

/// Phase 2: invocation 0 turns the chunk sums into exclusive prefixes.
pub fn scan_partials(lid: u32, shared: &mut ScanShared) {
    if lid != 0 {
        return;
    }
    let mut running = 0;
    let mut k = 0;
    while k < SCAN_GROUP as usize {
        let sum = shared[k];
        shared[k] = running;
        running += sum;
        k += 1;
    }
}

/// Phase 3: write the offsets of this invocation's chunk; the last invocation writes the total.
pub fn scan_write(lid: u32, counts: &[u32], n: u32, shared: &ScanShared, offsets: &mut [u32]) {
    let (start, end) = chunk(lid, n);
    let mut running = shared[lid as usize];
    let mut i = start;
    while i < end {
        offsets[i as usize] = running;
        running += counts[i as usize];
        i += 1;
    }
    if lid == SCAN_GROUP - 1 {
        offsets[n as usize] = running;
    }
}
