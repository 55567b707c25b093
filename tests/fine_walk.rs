//! The GPU backend's two ways of meeting a tile's bin in `fine_raster`, `fine_depth` and
//! `fine_samples`, each forced on every device: staged batches, and every pixel walking the
//! bin (the way a CPU implementation of Vulkan takes). Both give the CPU
//! backend's bits and statistics, the hidden triangles' count included. One test in a binary
//! of its own: the way is process-wide.

mod common;

use common::{assert_frame_parity, assert_parity};
use tileraster::render::{Camera, Cull, DepthFunc, Eye, Projection, RenderParams, Shading};
use tileraster::{FineWalk, Grid, Mode, Outputs, Params, Skips, set_gpu_fine_walk};
use tileraster_testkit::{meshes, scenes};

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
    let back_to_front = meshes::fill_layers(8);
    let mut front_to_back = back_to_front.clone();
    front_to_back.triangles.reverse();
    let meshes = [("8 layers back to front", back_to_front), ("8 layers front to back", front_to_back), ("terrain mesh", meshes::terrain(60, 2.0, 0.4))];
    for walk in [FineWalk::Always, FineWalk::Never] {
        set_gpu_fine_walk(walk);
        for (name, scene, grid) in &cases {
            for mode in Mode::ALL {
                let params = Params::new(*grid).with_mode(mode).with_nodata(-9999.0).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
                assert_parity(&format!("{name}, {}, {walk:?}", mode.name()), scene, &params);
            }
        }
        for (name, mesh) in &meshes {
            for depth_func in [DepthFunc::Less, DepthFunc::GreaterEqual] {
                for (count_fragments, hidden_triangles) in [(true, true), (false, true), (true, false)] {
                    let clear_depth = if depth_func == DepthFunc::GreaterEqual { 0.0 } else { 1.0 };
                    let mvp = if name.starts_with("terrain") {
                        Camera {
                            eye: [1.0, -1.5, 2.0],
                            target: [1.0, 1.0, 0.0],
                            up: [0.0, 0.0, 1.0],
                            projection: Projection::Perspective { fov_deg: 50.0 },
                            near: 0.1,
                            far: 10.0,
                        }
                        .view_projection(181, 133)
                        .unwrap()
                    } else {
                        tileraster::render::IDENTITY
                    };
                    let params = RenderParams {
                        cull: Cull::None,
                        depth_func,
                        clear_depth,
                        count_fragments,
                        count_tiles: true,
                        skips: Skips { hidden_triangles, ..Skips::ALL },
                        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                        ..RenderParams::new(181, 133, mvp)
                    };
                    let what = format!("{name}, {}, fragments {count_fragments}, hidden rejected {hidden_triangles}, {walk:?}", depth_func.name());
                    let frame = assert_frame_parity(&what, mesh, &params);
                    assert!(!hidden_triangles || !name.starts_with("8 layers") || frame.stats.raster.triangles_hidden > 0, "{what}: nothing hidden");
                    // The multisampled stage walks or stages its bins as the others do.
                    if !hidden_triangles {
                        for samples in [4, 8] {
                            let params = RenderParams { samples, shading: Shading::Phong, ..params.clone() };
                            let frame = assert_frame_parity(&format!("{what}, {samples} samples"), mesh, &params);
                            assert!(frame.stats.pixels_covered > 1000, "{what}, {samples} samples: {} pixels covered", frame.stats.pixels_covered);
                        }
                    }
                }
            }
        }
    }
    set_gpu_fine_walk(FineWalk::Auto);
}
