//! CPU vs GPU, byte for byte, on every scene family the rasteriser promises to handle.

mod common;

use common::assert_parity;
use tileraster::{Grid, Outputs, Params, Scene};
use tileraster_testkit::scenes;

fn params(grid: Grid) -> Params {
    Params::new(grid).with_nodata(-9999.0).with_outputs(Outputs { owner: true, coverage: true, tiles: true })
}

#[test]
fn random_terrain_tins() {
    for (seed, cells) in [(1u64, 12u32), (2, 40), (3, 97)] {
        let scene = scenes::terrain(0.0, 0.0, 1000.0, 800.0, cells, cells * 4 / 5, seed);
        let grid = Grid::new(-20.0, 1010.0, -15.0, 790.0, 301, 233);
        assert_parity(&format!("terrain seed {seed}"), &scene, &params(grid));
    }
}

#[test]
fn lattice_on_pixel_centres() {
    let grid = Grid::new(0.0, 64.0, 0.0, 48.0, 64, 48);
    for step in [1, 3, 8] {
        let scene = scenes::centre_lattice(&grid, step, step as u64);
        assert_parity(&format!("centre lattice step {step}"), &scene, &params(grid));
    }
}

#[test]
fn fans_of_thin_triangles_around_a_pixel_centre() {
    let grid = Grid::new(0.0, 40.0, 0.0, 40.0, 40, 40);
    for n in [7u32, 64, 360] {
        let scene = scenes::fan(&grid, 20, 20, n, 15.0, n as u64);
        assert_parity(&format!("fan of {n}"), &scene, &params(grid));
    }
}

#[test]
fn slivers() {
    let grid = Grid::new(0.0, 200.0, 0.0, 50.0, 400, 100);
    for (n, spacing) in [(50u32, 0.01), (400, 0.05), (20, 1e-4)] {
        let scene = scenes::sliver_wedge(&grid, n, spacing, n as u64);
        assert_parity(&format!("sliver wedge {n} × {spacing} px"), &scene, &params(grid));
    }
}

#[test]
fn overlapping_triangle_soup() {
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 137, 129);
    let scene = scenes::triangle_soup(&grid, 3000, 30.0, 9);
    assert_parity("triangle soup", &scene, &params(grid));
}

#[test]
fn utm_scale_offsets() {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 2000.0, 2000.0, 60, 60, 11);
    let grid = Grid::new(x0, x0 + 2000.0, y0, y0 + 2000.0, 517, 517);
    assert_parity("utm terrain", &scene, &params(grid));
}

#[test]
fn nan_nodata_and_huge_triangles() {
    let grid = Grid::new(0.0, 10.0, 0.0, 10.0, 333, 333);
    let scene =
        Scene::new(vec![[-1e6, -1e6, 1.0], [1e6, -1e6, 2.0], [0.0, 1e6, 3.0], [2.0, 2.0, 5.0], [8.0, 3.0, 6.0], [5.0, 9.0, 7.0]], vec![[3, 4, 5], [0, 1, 2]]);
    assert_parity("huge triangle under a small one", &scene, &Params::new(grid));
}

#[test]
fn everything_culled_or_flat_gives_nodata_everywhere() {
    let grid = Grid::new(0.0, 10.0, 0.0, 10.0, 37, 20);
    // One triangle far off the grid, one with no area.
    let scene = Scene::new(
        vec![[100.0, 100.0, 1.0], [101.0, 100.0, 1.0], [100.0, 101.0, 1.0], [1.0, 1.0, 2.0], [5.0, 5.0, 2.0], [9.0, 9.0, 2.0]],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    if let Some((cpu, _)) = assert_parity("nothing to draw", &scene, &params(grid)) {
        assert!(cpu.values.iter().all(|v| *v == -9999.0));
        assert!(cpu.coverage.unwrap().iter().all(|&c| c == 0));
    }
}

/// Two triangles covering 2048² cells each reach 8,000+ tiles: more than one binning
/// invocation may loop over on drivers that end long loops silently (llvmpipe), so the
/// binning is split into bands of tile rows. Checked coverage too: every cell is covered.
#[test]
fn triangles_spanning_thousands_of_tiles() {
    for (n, window_limit) in [(2048u32, None), (2048, Some(1024 * 1024))] {
        if let Some(limit) = window_limit {
            tileraster::set_gpu_window_limit(limit);
        }
        let grid = Grid::new(0.0, 1.0, 0.0, 1.0, n, n);
        let result = assert_parity(&format!("plane {n}², GPU windows of {window_limit:?} px"), &scenes::sloping_plane(), &params(grid));
        tileraster::set_gpu_window_limit(4096 * 4096);
        if let Some((cpu, _)) = result {
            assert!(cpu.coverage.as_ref().unwrap().iter().all(|&c| c >= 1), "the plane covers every cell");
        }
    }
}
