//! Twin of the `bin_scan` entry point: one workgroup of `SCAN_GROUP` invocations, phase by
//! phase.

use tileraster_kernels::SCAN_GROUP;
use tileraster_kernels::abi::FrameParams;
use tileraster_kernels::stages::scan;

/// The offsets of the bins.
pub fn bin_scan(frame: &FrameParams, counts: &[u32]) -> Vec<u32> {
    bin_scan_queued(frame, counts).0
}

/// The offsets of the bins, and the tile queue of `fine_depth` (`stages::scan`), which the
/// CPU's `fine_depth` does not need: it passes the tiles left out as the GPU's workgroups
/// would have (`fine::left_to_shade`).
pub fn bin_scan_queued(frame: &FrameParams, counts: &[u32]) -> (Vec<u32>, Vec<u32>) {
    let n = frame.tile_count();
    let mut offsets = vec![0u32; n as usize + 1];
    let mut queue = vec![0u32; (scan::QUEUE_HEAD + n) as usize];
    let mut shared: scan::ScanShared = [0; 2 * SCAN_GROUP as usize];
    for lid in 0..SCAN_GROUP {
        scan::scan_reduce(lid, counts, n, frame, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_partials(lid, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_write(lid, counts, n, frame, &shared, &mut offsets, &mut queue);
    }
    (offsets, queue)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_kernels::abi::FrameFlags;

    /// The queue holds every tile but the empty ones of a frame with small triangles, in
    /// order; its head dispatches a row of workgroups per `tiles_x` of them (at least one), and
    /// each workgroup maps to its tile.
    #[test]
    fn the_tile_queue_leaves_out_the_tiles_left_to_the_shade_stage() {
        for (tiles_x, tiles_y) in [(1, 1), (7, 3), (120, 68), (300, 300)] {
            let n = tiles_x * tiles_y;
            let counts: Vec<u32> = (0..n).map(|t| if (t * 7919) % 5 < 2 { 0 } else { t % 9 }).collect();
            let both = FrameFlags::EMPTY_TILES.with(FrameFlags::SMALL_TRIANGLES, true);
            for (case, flags) in [FrameFlags::EMPTY_TILES, both, FrameFlags::SMALL_TRIANGLES].into_iter().enumerate() {
                let frame = FrameParams { tiles_x, tiles_y, flags, ..Default::default() };
                let (offsets, queue) = bin_scan_queued(&frame, &counts);
                let mut sum = 0;
                for t in 0..n as usize {
                    assert_eq!(offsets[t], sum);
                    sum += counts[t];
                }
                assert_eq!(offsets[n as usize], sum);
                let left_out = flags.contains(both);
                let want: Vec<u32> = (0..n).filter(|&t| !(left_out && counts[t as usize] == 0)).collect();
                let len = queue[3] as usize;
                assert_eq!(&queue[scan::QUEUE_HEAD as usize..][..len], &want[..], "{tiles_x} × {tiles_y}, case {case}");
                assert_eq!(queue[..3], [tiles_x, (len as u32).div_ceil(tiles_x).max(1), 1]);
                let mut taken = Vec::new();
                for y in 0..queue[1] {
                    for x in 0..queue[0] {
                        let (tx, ty, queued) = scan::queued_tile(x, y, &frame, &queue);
                        if queued {
                            taken.push(ty * tiles_x + tx);
                        }
                    }
                }
                assert_eq!(taken, want);
            }
        }
    }
}
