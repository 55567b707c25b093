//! The GPU backend keeps its buffers between calls, so a call's bins, layers and setups are
//! written over what a larger call left there. Small frames after large ones, alternating
//! with render frames, many times over: every one gives the CPU backend's bits, in every
//! mode (the walk through the bins reads eight bin entries at a time, past the end of a short
//! bin into what an earlier call left).

mod common;

use common::gpu_or_skip;
use tileraster::render::{Camera, Projection, RenderParams, Up};
use tileraster::{Backend, Grid, Mode, Params, Scene, rasterise};
use tileraster_testkit::{meshes, scenes};

#[test]
fn small_frames_after_large_ones_give_the_cpu_bits_every_time() {
    if !gpu_or_skip("small_frames_after_large_ones_give_the_cpu_bits_every_time") {
        return;
    }
    // Two triangles, each alone in its tile and covering part of it (the frame that probes an
    // adapter's float arithmetic), and a small TIN.
    let probe_grid = Grid::new(0.0, 32.0, 0.0, 16.0, 32, 16);
    let probe = Scene::new(
        vec![[0.0, 0.0, 1.0], [16.0, 0.0, 2.0], [0.0, 16.0, 3.0], [16.0, 0.0, 1_000.123_456_7], [32.0, 0.0, 1_234.987_654_3], [16.0, 16.0, -777.777_777_7]],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    let tin_grid = Grid::new(0.0, 100.0, 0.0, 100.0, 97, 89);
    let tin = scenes::delaunay_terrain(0.0, 0.0, 100.0, 100.0, 12, 12, 3);
    let large_grid = Grid::new(0.0, 1000.0, 0.0, 1000.0, 2048, 2048);
    let large = scenes::delaunay_terrain(0.0, 0.0, 1000.0, 1000.0, 200, 200, 9);
    let mesh = meshes::terrain(120, 1000.0, 60.0);
    let camera = Camera::framing(&mesh, 1.5, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
    let render_params = RenderParams { eye: Some(camera.viewer()), ..RenderParams::new(480, 320, camera.view_projection(480, 320).unwrap()) };
    for round in 0..12 {
        if round % 4 == 0 {
            let p = Params::new(large_grid).with_nodata(-9999.0);
            let (c, g) = (rasterise(&large, &p, Backend::Cpu).unwrap(), rasterise(&large, &p, Backend::Gpu).unwrap());
            common::assert_same_bits(&format!("round {round}: the large TIN"), &c, &g);
        }
        if round % 3 == 0 {
            common::assert_frame_parity(&format!("round {round}: a render frame"), &mesh, &render_params);
        }
        for mode in Mode::ALL {
            for (name, scene, grid) in [("two triangles", &probe, probe_grid), ("small TIN", &tin, tin_grid)] {
                let p = Params::new(grid).with_mode(mode);
                let (c, g) = (rasterise(scene, &p, Backend::Cpu).unwrap(), rasterise(scene, &p, Backend::Gpu).unwrap());
                common::assert_same_bits(&format!("round {round}: {name}, {}", mode.name()), &c, &g);
            }
        }
    }
}
