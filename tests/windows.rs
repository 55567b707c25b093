//! Windows: a window's cells are bit for bit the cells the whole grid has there, whatever
//! the backend and however the GPU cuts its work.

mod common;

use tileraster::{Backend, Grid, Outputs, Params, Raster, Window, rasterise, rasterise_window};
use tileraster_testkit::scenes;

fn assert_window_matches(name: &str, whole: &Raster, part: &Raster) {
    let w = part.window;
    for j in 0..w.height {
        for i in 0..w.width {
            let (gi, gj) = (w.x0 + i, w.y0 + j);
            let a = whole.value(gi, gj).to_bits();
            let b = part.value(i, j).to_bits();
            assert_eq!(a, b, "{name}: window {w:?} pixel ({i}, {j}) = grid ({gi}, {gj}): {b:#x} vs whole {a:#x}");
            let k = (gj * whole.width() + gi) as usize;
            let kp = (j * w.width + i) as usize;
            assert_eq!(whole.owner.as_ref().unwrap()[k], part.owner.as_ref().unwrap()[kp], "{name}: owner at ({gi}, {gj})");
        }
    }
}

#[test]
fn windows_equal_the_whole_grid() {
    let scene = scenes::terrain(500_000.0, 5_000_000.0, 900.0, 700.0, 45, 35, 8);
    let grid = Grid::new(500_000.0, 500_900.0, 5_000_000.0, 5_000_700.0, 450, 350);
    let params = Params::new(grid).with_nodata(-1.0).with_outputs(Outputs { owner: true, coverage: false, tiles: false });
    let mut backends = vec![Backend::Cpu];
    if common::gpu_or_skip("windows_equal_the_whole_grid") {
        backends.push(Backend::Gpu);
    }
    let whole = rasterise(&scene, &params, Backend::Cpu).unwrap();
    for backend in backends {
        for window in [
            Window { x0: 0, y0: 0, width: 450, height: 350 },
            Window { x0: 17, y0: 5, width: 1, height: 1 },
            Window { x0: 100, y0: 200, width: 333, height: 150 },
            Window { x0: 449, y0: 0, width: 1, height: 350 },
            Window { x0: 3, y0: 333, width: 447, height: 17 },
        ] {
            let part = rasterise_window(&scene, &params, Some(window), backend).unwrap();
            assert_window_matches(backend.name(), &whole, &part);
        }
    }
}

/// The GPU's window limit is one setting for the process: the tests that change it take turns.
static WINDOW_LIMIT: std::sync::Mutex<()> = std::sync::Mutex::new(());

#[test]
fn gpu_results_do_not_depend_on_its_windowing() {
    if !common::gpu_or_skip("gpu_results_do_not_depend_on_its_windowing") {
        return;
    }
    let _turn = WINDOW_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 1000.0, 50, 50, 2);
    let grid = Grid::new(0.0, 1000.0, 0.0, 1000.0, 300, 290);
    let params = Params::new(grid).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
    let cpu = rasterise(&scene, &params, Backend::Cpu).unwrap();
    for limit in [256, 1000, 16 * 300, 40_000] {
        tileraster::set_gpu_window_limit(limit);
        let gpu = rasterise(&scene, &params, Backend::Gpu).unwrap();
        let (count, first) = cpu.compare_bits(&gpu, 5);
        assert_eq!(count, 0, "window limit {limit}: {first:?}");
        assert_eq!(cpu.stats, gpu.stats, "window limit {limit}: the statistics depend on the GPU's windows");
    }
    tileraster::set_gpu_window_limit(4096 * 4096);
}

/// The render pipeline through the GPU's windows (its shade stage and blending per window
/// included): the same frame as the CPU's at every window size.
#[test]
fn gpu_frames_do_not_depend_on_its_windowing() {
    use tileraster::render::{Camera, Cull, Projection, RenderParams, Shading, render};
    if !common::gpu_or_skip("gpu_frames_do_not_depend_on_its_windowing") {
        return;
    }
    let _turn = WINDOW_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    let mut mesh = tileraster_testkit::meshes::soup(200, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.7, 17);
    for (k, c) in mesh.colours.as_mut().unwrap().iter_mut().enumerate() {
        c[3] = if k % 3 == 0 { 0.5 } else { 1.0 };
    }
    let camera =
        Camera { eye: [2.5, -2.0, 1.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near: 0.5, far: 9.0 };
    // Without blending or tile counts, the small triangles skip binning (`fine_small`), in
    // each window.
    for (blend, count_tiles) in [(false, true), (true, true), (false, false)] {
        let params = RenderParams {
            cull: Cull::None,
            shading: Shading::Phong,
            blend,
            count_tiles,
            ..RenderParams::new(150, 110, camera.view_projection(150, 110).unwrap())
        };
        let cpu = render(&mesh, &params, Backend::Cpu).unwrap();
        for limit in [256, 1000, 16 * 150, 40_000] {
            tileraster::set_gpu_window_limit(limit);
            let gpu = render(&mesh, &params, Backend::Gpu).unwrap();
            assert!(
                gpu.colour == cpu.colour
                    && gpu.ids == cpu.ids
                    && gpu.fragments == cpu.fragments
                    && gpu.tiles == cpu.tiles
                    && cpu.tiles.is_some() == count_tiles,
                "blend {blend}, window limit {limit}: the frames differ"
            );
            assert!(gpu.depth.iter().zip(&cpu.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "blend {blend}, window limit {limit}: depths differ");
            assert_eq!(cpu.stats, gpu.stats, "blend {blend}, window limit {limit}: statistics");
        }
    }
    tileraster::set_gpu_window_limit(4096 * 4096);
}

/// Scenes too large for one binding are set up in parts (each window with the triangles
/// that reach it): the same bits as the CPU's. A lowered binding limit brings a small scene
/// there; every limit here is below the scene's setups, which the backend refused before it
/// could set a scene up in parts.
#[test]
fn gpu_scenes_in_parts_equal_the_cpu() {
    use tileraster::render::{Camera, Cull, Projection, RenderParams, Shading, prepare_render, render};
    use tileraster::{Prepared, rasterise_prepared};
    use tileraster_kernels::abi::{TriangleSetup, TriangleShading};
    if !common::gpu_or_skip("gpu_scenes_in_parts_equal_the_cpu") {
        return;
    }
    let _turn = WINDOW_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    let setup = std::mem::size_of::<TriangleSetup>() as u64;

    // The heightfield: 5,000 triangles, owner and coverage layers.
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 1000.0, 50, 50, 2);
    let grid = Grid::new(0.0, 1000.0, 0.0, 1000.0, 300, 290);
    let params = Params::new(grid).with_outputs(Outputs { owner: true, coverage: true, tiles: true });
    let cpu = rasterise(&scene, &params, Backend::Cpu).unwrap();
    for limit in [32 << 10, 64 << 10, 256 << 10] {
        assert!(5_000 * setup > limit);
        tileraster::set_gpu_binding_limit(limit);
        let gpu = rasterise(&scene, &params, Backend::Gpu);
        tileraster::set_gpu_binding_limit(u64::MAX);
        let gpu = gpu.unwrap_or_else(|e| panic!("binding limit {limit}: {e}"));
        let (count, first) = cpu.compare_bits(&gpu, 5);
        assert_eq!(count, 0, "binding limit {limit}: {first:?}");
        assert_eq!(cpu.stats, gpu.stats, "binding limit {limit}: statistics");
    }

    // The render pipeline: a sphere seen from outside and a soup of overlapping triangles
    // with exact depth ties (every triangle drawn twice), opaque and blended.
    let sphere = tileraster_testkit::meshes::sphere([0.0; 3], 1.0, 30, 57);
    let mut soup = tileraster_testkit::meshes::soup(60, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.5, 5);
    let n = soup.triangles.len();
    soup.triangles.extend_from_within(..n);
    for (k, c) in soup.colours.as_mut().unwrap().iter_mut().enumerate() {
        c[3] = if k % 2 == 0 { 0.5 } else { 1.0 };
    }
    let shading = std::mem::size_of::<TriangleShading>() as u64;
    let camera =
        Camera { eye: [2.5, -2.0, 1.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near: 0.5, far: 9.0 };
    for (name, mesh, limit) in [("sphere", &sphere, 64u64 << 10), ("soup", &soup, 12 << 10)] {
        assert!(mesh.triangles.len() as u64 * shading > limit, "{name}: the limit must split the scene");
        // Without blending or tile counts, the small triangles skip binning (`fine_small`),
        // each part taking its own.
        for (blend, count_tiles) in [(false, true), (true, true), (false, false)] {
            let params = RenderParams {
                cull: Cull::None,
                shading: Shading::Phong,
                blend,
                count_tiles,
                ..RenderParams::new(190, 150, camera.view_projection(190, 150).unwrap())
            };
            let cpu = render(mesh, &params, Backend::Cpu).unwrap();
            tileraster::set_gpu_binding_limit(limit);
            let gpu = render(mesh, &params, Backend::Gpu);
            tileraster::set_gpu_binding_limit(u64::MAX);
            let gpu = gpu.unwrap_or_else(|e| panic!("{name}, blend {blend}: {e}"));
            assert!(
                gpu.colour == cpu.colour
                    && gpu.ids == cpu.ids
                    && gpu.fragments == cpu.fragments
                    && gpu.tiles == cpu.tiles
                    && cpu.tiles.is_some() == count_tiles,
                "{name}, blend {blend}: the frames differ"
            );
            assert!(gpu.depth.iter().zip(&cpu.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "{name}, blend {blend}: depths differ");
            assert_eq!(cpu.stats, gpu.stats, "{name}, blend {blend}: statistics");
            // The owner layer (setup slots, which each part's readback maps back to the
            // scene's) stays with the stages unless asked for; asked for, it is the CPU's.
            let (mut prepared, _) = prepare_render(mesh, &params).unwrap();
            let layers = |prepared: &Prepared| {
                let cpu = rasterise_prepared(prepared, Backend::Cpu).unwrap();
                tileraster::set_gpu_binding_limit(limit);
                let gpu = rasterise_prepared(prepared, Backend::Gpu);
                tileraster::set_gpu_binding_limit(u64::MAX);
                (cpu, gpu.unwrap_or_else(|e| panic!("{name}, blend {blend}, raster: {e}")))
            };
            let (c, g) = layers(&prepared);
            assert!(c.owner.is_none() && g.owner.is_none(), "{name}, blend {blend}: an owner layer nobody asked for");
            prepared.params.outputs.owner = true;
            let (c, g) = layers(&prepared);
            assert!(c.owner.is_some() && g.owner.is_some(), "{name}, blend {blend}: no owner layer");
            let (count, first) = c.compare_bits(&g, 5);
            assert_eq!(count, 0, "{name}, blend {blend}: the asked-for layers differ: {first:?}");
            let small = cpu.stats.raster.triangles_small;
            let splits = !blend && !count_tiles;
            assert!(
                (small == 0 || splits) && (small > 0 || !splits || name != "sphere"),
                "{name}, blend {blend}, tile counts {count_tiles}: {small} small triangles"
            );
        }
    }
}

/// A single tile reached by more triangles than one binding holds is a typed error naming
/// the tile, not a panic or a partial frame.
#[test]
fn gpu_tile_beyond_its_binding_is_an_error() {
    use tileraster::render::{Cull, IDENTITY, Mesh, RenderParams, render};
    if !common::gpu_or_skip("gpu_tile_beyond_its_binding_is_an_error") {
        return;
    }
    let _turn = WINDOW_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    // 64 copies of one triangle over the whole frame: every tile is reached by all of them.
    let positions = vec![[-4.0, -4.0, 0.5], [4.0, -4.0, 0.5], [0.0, 6.0, 0.5]];
    let mesh = Mesh { positions, triangles: vec![[0, 1, 2]; 64], normals: None, colours: None, uvs: None, ..Default::default() };
    let params = RenderParams { cull: Cull::None, eye: Some(tileraster::render::Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(40, 40, IDENTITY) };
    tileraster::set_gpu_binding_limit(4 << 10);
    let result = render(&mesh, &params, Backend::Gpu);
    tileraster::set_gpu_binding_limit(u64::MAX);
    match result {
        Err(tileraster::Error::RasterTooLarge { reason, .. }) => assert!(reason.contains("the tile at (0, 0)") && reason.contains("64 triangles"), "{reason}"),
        other => panic!("expected RasterTooLarge, got {:?}", other.map(|f| f.stats)),
    }
}

/// A raster more than 65,535 tiles high (the most workgroups a dispatch may have along a
/// dimension, and the per-tile stages dispatch one per tile) is cut into windows the device
/// can dispatch: the CPU's bits.
#[test]
fn gpu_rasters_taller_than_a_dispatch_equal_the_cpu() {
    if !common::gpu_or_skip("gpu_rasters_taller_than_a_dispatch_equal_the_cpu") {
        return;
    }
    // At the default limits, which the other tests here lower for a while.
    let _turn = WINDOW_LIMIT.lock().unwrap_or_else(|e| e.into_inner());
    let height = 65_535 * 16 + 40;
    let scene = scenes::terrain(0.0, 0.0, 24.0, height as f64, 3, 2_000, 11);
    let grid = Grid::new(0.0, 24.0, 0.0, height as f64, 5, height);
    let params = Params::new(grid).with_outputs(Outputs { owner: true, coverage: true, tiles: false });
    let cpu = rasterise(&scene, &params, Backend::Cpu).unwrap();
    let gpu = rasterise(&scene, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{height} rows on the GPU: {e}"));
    let (count, first) = cpu.compare_bits(&gpu, 5);
    assert_eq!(count, 0, "{first:?}");
    assert_eq!(cpu.stats, gpu.stats);
}
