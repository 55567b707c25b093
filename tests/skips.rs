//! What the pipeline skips, and the statistics that say so: exact figures on a scene worked out
//! by hand, each skip seen to happen (and to stop when turned off) on scenes that need it,
//! equal statistics on both backends, and a prepared scene that uploads and sets up once.
//! That no skip changes a bit is checked by every parity and accuracy test (`common`).

mod common;

use common::{assert_same_bits, gpu_or_skip, skip_variants};
use tileraster::{Backend, Grid, Outputs, Params, Pass, PreparedScene, Raster, Scene, Skip, Skips, Stage, Window, rasterise, rasterise_window};
use tileraster_testkit::scenes;

/// The backends the tests can use here.
fn backends(test: &str) -> Vec<Backend> {
    if gpu_or_skip(test) { vec![Backend::Cpu, Backend::Gpu] } else { vec![Backend::Cpu] }
}

/// Bytes of one prepared triangle, as uploaded.
const TRIANGLE_BYTES: u64 = 120;

/// A 32 × 32 px square of two triangles (split along its top-left to bottom-right diagonal) in
/// the top-left corner of a 64 × 64 grid of 16 tiles.
fn corner_square() -> (Scene, Grid) {
    let scene = Scene::new(vec![[0.0, 64.0, 1.0], [32.0, 64.0, 2.0], [32.0, 32.0, 3.0], [0.0, 32.0, 4.0]], vec![[0, 1, 2], [0, 2, 3]]);
    (scene, Grid::new(0.0, 64.0, 0.0, 64.0, 64, 64))
}

#[test]
fn statistics_of_a_scene_worked_out_by_hand() {
    let (scene, grid) = corner_square();
    for backend in backends("statistics_of_a_scene_worked_out_by_hand") {
        let raster = rasterise(&scene, &Params::new(grid), backend).unwrap();
        let s = &raster.stats;
        // 16 tiles; the square's 4 are rasterised, the other 12 are nodata from the host.
        assert_eq!((s.tiles_total, s.tiles_empty_skipped), (16, 12), "{backend:?}");
        // Off the diagonal, each triangle covers a tile whole; the diagonal tiles are tested.
        assert_eq!((s.tiles_full, s.tiles_partial), (2, 2), "{backend:?}");
        assert_eq!((s.triangles_culled, s.triangles_flat, s.triangles_binned), (0, 0, 2), "{backend:?}");
        assert!(s.overlap_free, "{backend:?}");
        let kernel = |stage: Stage| Pass::Kernel(stage);
        let window_stages = [Stage::BinCount, Stage::BinScan, Stage::BinFill, Stage::FineRaster].map(kernel);
        let passes: Vec<Pass> = [Pass::Upload, kernel(Stage::Setup), Pass::Cull, Pass::FillNodata].into_iter().chain(window_stages).collect();
        assert_eq!(s.passes, passes, "{backend:?}");
        let names: Vec<&str> = s.passes.iter().map(|p| p.name()).collect();
        assert_eq!(names, ["upload", "setup", "cull", "fill_nodata", "bin_count", "bin_scan", "bin_fill", "fine_raster"], "--stats names");
        assert_eq!(s.bytes_uploaded, 2 * TRIANGLE_BYTES + 2 * 4, "{backend:?}");

        // With nothing skipped, every tile is rasterised and tested, and overlaps are resolved.
        let none = rasterise(&scene, &Params::new(grid).with_skips(Skips::NONE), backend).unwrap();
        let s = &none.stats;
        assert_eq!((s.tiles_total, s.tiles_empty_skipped, s.tiles_full, s.tiles_partial), (16, 0, 0, 16), "{backend:?}");
        assert!(!s.overlap_free);
        let passes: Vec<Pass> = [Pass::Upload, kernel(Stage::Setup)].into_iter().chain(window_stages).chain([Pass::Ownership]).collect();
        assert_eq!(s.passes, passes);
        assert_same_bits(&format!("{backend:?}: all skips vs none"), &raster, &none);
    }
}

#[test]
fn each_skip_happens_where_the_scene_allows_it_and_not_when_turned_off() {
    let tin = scenes::terrain(0.0, 0.0, 1000.0, 800.0, 40, 32, 5);
    let grid = Grid::new(-100.0, 1100.0, -100.0, 900.0, 300, 250);
    let soup_grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
    let soup = scenes::triangle_soup(&soup_grid, 300, 30.0, 9);
    let plane_grid = Grid::new(0.0, 1.0, 0.0, 1.0, 256, 256);
    let window = Window { x0: 40, y0: 30, width: 100, height: 90 };
    let run = |scene: &Scene, grid: Grid, window: Option<Window>, skips: Skips| {
        rasterise_window(scene, &Params::new(grid).with_skips(skips), window, Backend::Cpu).unwrap().stats
    };

    // A window of a TIN: the triangles elsewhere are culled before binning.
    let on = run(&tin, grid, Some(window), Skips::ALL);
    let off = run(&tin, grid, Some(window), Skips::all_but(Skip::CullWindow));
    assert!(on.triangles_culled > 1000 && on.passes.contains(&Pass::Cull), "{on:?}");
    assert!(off.triangles_culled == 0 && !off.passes.contains(&Pass::Cull), "{off:?}");
    assert_eq!(on.triangles_binned + on.triangles_culled, off.triangles_binned);

    // The TIN leaves a margin of the grid uncovered: those tiles are skipped as empty.
    let on = run(&tin, grid, None, Skips::ALL);
    let off = run(&tin, grid, None, Skips::all_but(Skip::EmptyTiles));
    assert!(on.tiles_empty_skipped > 0 && on.passes.contains(&Pass::FillNodata), "{on:?}");
    assert!(off.tiles_empty_skipped == 0 && !off.passes.contains(&Pass::FillNodata), "{off:?}");

    // A plane covers most tiles whole.
    let on = run(&scenes::sloping_plane(), plane_grid, None, Skips::ALL);
    let off = run(&scenes::sloping_plane(), plane_grid, None, Skips::all_but(Skip::FullTiles));
    assert!(on.tiles_full > 200, "{on:?}");
    assert_eq!((off.tiles_full, off.tiles_partial), (0, on.tiles_total), "{off:?}");

    // A TIN is proven overlap-free; a soup of overlapping triangles is not. (The proof is
    // attempted where it can pay: triangles whose rectangles average 96 px or more, as this
    // coarser TIN's do, and not the finer one's.)
    let coarse = scenes::terrain(0.0, 0.0, 1000.0, 800.0, 20, 16, 5);
    let on = run(&coarse, grid, None, Skips::ALL);
    let off = run(&coarse, grid, None, Skips::all_but(Skip::OverlapFree));
    assert!(on.overlap_free && !on.passes.contains(&Pass::Ownership), "{on:?}");
    assert!(!off.overlap_free && off.passes.contains(&Pass::Ownership), "{off:?}");
    let soup = run(&soup, soup_grid, None, Skips::ALL);
    assert!(!soup.overlap_free && soup.passes.contains(&Pass::Ownership), "{soup:?}");
    let fine = run(&tin, grid, None, Skips::ALL);
    assert!(!fine.overlap_free && fine.passes.contains(&Pass::Ownership), "{fine:?}");
}

#[test]
fn nothing_in_the_window_means_no_kernel_work() {
    let (scene, grid) = corner_square();
    let far = Window { x0: 40, y0: 40, width: 24, height: 24 };
    for backend in backends("nothing_in_the_window_means_no_kernel_work") {
        let raster = rasterise_window(&scene, &Params::new(grid).with_nodata(-1.0), Some(far), backend).unwrap();
        assert!(raster.values.iter().all(|&v| v == -1.0));
        let s = &raster.stats;
        assert_eq!((s.tiles_total, s.tiles_empty_skipped, s.triangles_culled, s.bytes_uploaded), (4, 4, 2, 0));
        assert_eq!(s.passes, [Pass::Cull, Pass::FillNodata]);
    }
}

#[test]
fn outputs_nobody_asked_for_are_not_written_and_change_nothing_else() {
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 800.0, 30, 24, 8);
    let grid = Grid::new(0.0, 1000.0, 0.0, 800.0, 211, 173);
    for backend in backends("outputs_nobody_asked_for_are_not_written_and_change_nothing_else") {
        let run = |owner, coverage| rasterise(&scene, &Params::new(grid).with_outputs(Outputs { owner, coverage, tiles: false }), backend).unwrap();
        let (both, none) = (run(true, true), run(false, false));
        assert!(none.owner.is_none() && none.coverage.is_none());
        assert!(!none.stats.passes.iter().any(|p| matches!(p, Pass::WriteOwner | Pass::WriteCoverage)), "{:?}", none.stats.passes);
        for (owner, coverage) in [(true, false), (false, true), (false, false)] {
            let some = run(owner, coverage);
            assert_eq!(some.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), both.values.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
            assert_eq!(some.owner.is_some(), owner);
            assert_eq!(some.stats.passes.contains(&Pass::WriteOwner), owner);
            assert_eq!(some.stats.passes.contains(&Pass::WriteCoverage), coverage);
        }
    }
}

/// A prepared scene uploads and sets up its triangles once; every later window only lists the
/// triangles it needs. Its windows are bit for bit the one-shot calls' windows, with every
/// skip variant, and they tile the whole grid.
#[test]
fn a_prepared_scene_uploads_and_sets_up_once() {
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 800.0, 36, 30, 12);
    let grid = Grid::new(0.0, 1000.0, 0.0, 800.0, 203, 161);
    let windows =
        [Window { x0: 0, y0: 0, width: 100, height: 80 }, Window { x0: 100, y0: 0, width: 103, height: 80 }, Window { x0: 0, y0: 80, width: 203, height: 81 }];
    for backend in backends("a_prepared_scene_uploads_and_sets_up_once") {
        for (variant, skips) in skip_variants() {
            let params = Params::new(grid).with_nodata(-9999.0).with_skips(skips).with_outputs(Outputs { owner: true, coverage: true, tiles: false });
            let whole = rasterise(&scene, &params, backend).unwrap();
            let mut prepared = PreparedScene::new(&scene, &params, backend).unwrap();
            let n = prepared.prepared().triangles.len() as u64;
            for (k, &window) in windows.iter().enumerate() {
                let part = prepared.rasterise_window(window).unwrap();
                let alone = rasterise_window(&scene, &params, Some(window), backend).unwrap();
                let what = format!("{backend:?}, {variant}, window {k}");
                assert_same_bits(&what, &alone, &part);
                assert_window_of(&what, &whole, &part);
                let s = &part.stats;
                let first = k == 0;
                assert_eq!(s.passes.contains(&Pass::Upload), first, "{what}: {:?}", s.passes);
                assert_eq!(s.passes.contains(&Stage::Setup.into()), first, "{what}: {:?}", s.passes);
                let scene_bytes = if first { n * TRIANGLE_BYTES } else { 0 };
                assert_eq!(s.bytes_uploaded, scene_bytes + 4 * s.triangles_binned, "{what}");
                // The rest of the statistics are the one-shot call's.
                let (mut a, mut b) = (alone.stats.clone(), s.clone());
                a.passes.retain(|p| ![Pass::Upload, Stage::Setup.into()].contains(p));
                b.passes.retain(|p| ![Pass::Upload, Stage::Setup.into()].contains(p));
                (a.bytes_uploaded, b.bytes_uploaded) = (0, 0);
                assert_eq!(a, b, "{what}");
            }
        }
    }
}

fn assert_window_of(what: &str, whole: &Raster, part: &Raster) {
    let w = part.window;
    for j in 0..w.height {
        for i in 0..w.width {
            let (a, b) = (whole.value(w.x0 + i, w.y0 + j), part.value(i, j));
            assert_eq!(a.to_bits(), b.to_bits(), "{what}: pixel ({}, {})", w.x0 + i, w.y0 + j);
        }
    }
}

/// A small mesh in a large grid: only the tiles around it are binned and rasterised.
#[test]
fn a_sparse_scene_rasterises_only_the_tiles_it_covers() {
    let grid = Grid::new(0.0, 4096.0, 0.0, 4096.0, 4096, 4096);
    let scene = scenes::terrain(2000.0, 2000.0, 64.0, 64.0, 8, 8, 3);
    let raster = rasterise(&scene, &Params::new(grid).with_nodata(-1.0), Backend::Cpu).unwrap();
    let s = &raster.stats;
    assert_eq!(s.tiles_total, 256 * 256);
    // 64 px across, not tile-aligned: at most 5 × 5 tiles reach the kernels.
    assert!(s.tiles_full + s.tiles_partial <= 25, "{s:?}");
    assert_eq!(s.tiles_empty_skipped + s.tiles_full + s.tiles_partial, s.tiles_total);
    let covered = raster.values.iter().filter(|&&v| v != -1.0).count();
    assert!((3900..=4400).contains(&covered), "{covered} cells covered");
}

/// Small triangles skip binning in a single-sample depth-tested frame (`Skip::SmallTriangles`):
/// the statistics count them apart, every triangle is culled, binned or small, `fine_small`
/// runs only where they are, and turning the skip off bins them all with the same bits.
#[test]
fn small_triangles_skip_binning_and_are_counted_apart() {
    use tileraster::render::{Camera, Cull, DepthFunc, NO_FACE, Projection, RenderParams, render};
    // Large triangles at the equator, small ones towards the poles.
    let mesh = tileraster_testkit::meshes::sphere([0.0; 3], 1.0, 16, 32);
    let camera =
        Camera { eye: [2.5, -2.0, 1.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near: 0.5, far: 9.0 };
    let on = RenderParams { cull: Cull::None, count_fragments: true, ..RenderParams::new(640, 480, camera.view_projection(640, 480).unwrap()) };
    let off = RenderParams { skips: on.skips.without(Skip::SmallTriangles), ..on.clone() };
    for backend in backends("small_triangles_skip_binning_and_are_counted_apart") {
        let (a, b) = (render(&mesh, &on, backend).unwrap(), render(&mesh, &off, backend).unwrap());
        let (s, t) = (&a.stats.raster, &b.stats.raster);
        // Prepared: the triangles rasterised and those that reach no pixel centre (culled there).
        let prepared = a.stats.geometry.rasterised + a.stats.geometry.culled_no_centre;
        assert!(s.triangles_small > 0 && s.triangles_binned > 0, "{backend:?}: {s:?}");
        assert_eq!(s.triangles_small + s.triangles_binned + s.triangles_culled, prepared, "{backend:?}: every triangle culled, binned or small");
        assert_eq!((t.triangles_small, t.triangles_binned + t.triangles_culled), (0, prepared), "{backend:?}: the skip off bins them all");
        assert!(s.passes.contains(&Pass::Kernel(Stage::FineSmall)) && !t.passes.contains(&Pass::Kernel(Stage::FineSmall)), "{backend:?}");
        assert!(a.colour == b.colour && a.ids == b.ids && a.fragments == b.fragments, "{backend:?}: the skip changes a bit");
        assert!(a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits()), "{backend:?}: depths differ");
        // A depth buffer cleared in front of part of the sphere: the fragments behind it fail,
        // and a pixel they alone cover counts none: in tiles that large triangles reach, and in
        // those only small triangles reach, which `fine_depth` leaves to the shade stage (the
        // finer sphere's triangles are all small).
        let fine = tileraster_testkit::meshes::sphere([0.0; 3], 1.0, 64, 128);
        for (mesh, func, clear) in
            [(&mesh, DepthFunc::Less, 0.86), (&mesh, DepthFunc::Less, 0.87), (&fine, DepthFunc::Less, 0.86), (&fine, DepthFunc::Greater, 1.0)]
        {
            let a = render(mesh, &on, backend).unwrap();
            let near = RenderParams { depth_func: func, clear_depth: clear, ..on.clone() };
            let far = RenderParams { skips: near.skips.without(Skip::SmallTriangles), ..near.clone() };
            let (c, d) = (render(mesh, &near, backend).unwrap(), render(mesh, &far, backend).unwrap());
            assert!(c.colour == d.colour && c.ids == d.ids && c.fragments == d.fragments, "{backend:?}, {func:?} against {clear}: the skip changes a bit");
            assert!(c.fragments.iter().zip(&c.ids).all(|(&n, &id)| id != NO_FACE || n == 0), "{backend:?}: a pixel nothing owns counts no fragment");
            // Pixels the sphere covers whose every fragment failed.
            let failed = a.ids.iter().zip(&c.ids).filter(|&(&all, &passed)| all != NO_FACE && passed == NO_FACE).count();
            assert!(failed > 1000, "{backend:?}, {func:?} against {clear}: only {failed} pixels lost their fragments");
        }
    }
}
