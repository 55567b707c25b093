//! Twin of the `bin_scan` entry point: one workgroup of `SCAN_GROUP` invocations, phase by
//! phase.

use tileraster_kernels::SCAN_GROUP;
use tileraster_kernels::abi::FrameParams;
use tileraster_kernels::stages::scan;

pub fn bin_scan(frame: &FrameParams, counts: &[u32]) -> Vec<u32> {
    let n = frame.tile_count();
    let mut offsets = vec![0u32; n as usize + 1];
    let mut shared: scan::ScanShared = [0; SCAN_GROUP as usize];
    for lid in 0..SCAN_GROUP {
        scan::scan_reduce(lid, counts, n, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_partials(lid, &mut shared);
    }
    for lid in 0..SCAN_GROUP {
        scan::scan_write(lid, counts, n, &shared, &mut offsets);
    }
    offsets
}
