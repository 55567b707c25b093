//! The GPU backend's two ways of meeting a tile's bin in `fine_raster`, each forced on every
//! device: staged batches, and every pixel walking the bin (the way a CPU implementation of
//! Vulkan takes for short bins). Both give the CPU backend's bits and statistics. One test in
//! a binary of its own: the way is process-wide.

mod common;

use common::assert_parity;
use tileraster::{FineWalk, Grid, Mode, Outputs, Params, set_gpu_fine_walk};
use tileraster_testkit::scenes;

#[test]
fn both_ways_through_the_bins_give_the_cpu_bits() {
    let grid = Grid::new(0.0, 200.0, 0.0, 160.0, 301, 233);
    let (micro, micro_grid) = scenes::micro_triangles(128, 1.0, 5);
    let cases = [
        ("terrain TIN", scenes::delaunay_terrain(-5.0, -3.0, 210.0, 170.0, 40, 32, 4), grid),
        ("overlapping soup", scenes::triangle_soup(&grid, 1500, 25.0, 3), grid),
        ("sliver wedge", scenes::sliver_wedge(&grid, 300, 0.05, 6), grid),
        ("fan of 90", scenes::fan(&grid, 150, 110, 90, 30.0, 2), grid),
        ("micro-triangles, long bins", micro, micro_grid),
    ];
    for walk in [FineWalk::Always, FineWalk::Never] {
        set_gpu_fine_walk(walk);
        for (name, scene, grid) in &cases {
            for mode in Mode::ALL {
                let params = Params::new(*grid).with_mode(mode).with_nodata(-9999.0).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
                assert_parity(&format!("{name}, {}, {walk:?}", mode.name()), scene, &params);
            }
        }
    }
    set_gpu_fine_walk(FineWalk::Auto);
}
