//! Watertightness: in meshes that tile a region, every pixel centre inside is covered by
//! exactly one triangle (coverage count 1), on both backends, including centres exactly on
//! shared edges and vertices; centres on the mesh's outer boundary are covered too.

mod common;

use tileraster::{Backend, Grid, Outputs, Params, Raster, Scene, rasterise};
use tileraster_testkit::scenes;

fn coverage(scene: &Scene, grid: Grid, backend: Backend) -> Raster {
    let params = Params::new(grid).with_outputs(Outputs { owner: true, coverage: true, tiles: false });
    rasterise(scene, &params, backend).unwrap_or_else(|e| panic!("{}: {e}", backend.name()))
}

fn backends(test: &str) -> Vec<Backend> {
    if common::gpu_or_skip(test) { vec![Backend::Cpu, Backend::Gpu] } else { vec![Backend::Cpu] }
}

/// Every cell for which `inside(i, j)` holds has coverage 1 and an owner; no cell anywhere
/// has coverage above 1.
fn assert_tiles(name: &str, raster: &Raster, inside: impl Fn(u32, u32) -> bool) {
    let counts = raster.coverage.as_ref().expect("coverage asked for");
    let owners = raster.owner.as_ref().expect("owner asked for");
    let mut checked = 0;
    for j in 0..raster.height() {
        for i in 0..raster.width() {
            let k = (j * raster.width() + i) as usize;
            assert!(counts[k] <= 1, "{name}: pixel ({i}, {j}) is covered {} times", counts[k]);
            if inside(i, j) {
                checked += 1;
                assert_eq!(counts[k], 1, "{name}: pixel ({i}, {j}) inside the mesh is a hole");
                assert_ne!(owners[k], u32::MAX, "{name}: pixel ({i}, {j}) has no owner");
                assert!(!raster.is_nodata(i, j), "{name}: pixel ({i}, {j}) is nodata");
            } else {
                assert_eq!(counts[k] == 0, owners[k] == u32::MAX, "{name}: owner and coverage disagree at ({i}, {j})");
            }
        }
    }
    assert!(checked > 0, "{name}: no interior pixel was checked");
}

#[test]
fn terrain_tin_covering_the_grid_has_no_holes_and_no_overlaps() {
    for backend in backends("terrain watertightness") {
        for seed in 0..4u64 {
            let scene = scenes::terrain(0.0, 0.0, 640.0, 480.0, 37 + seed as u32, 29, seed);
            let raster = coverage(&scene, Grid::new(0.0, 640.0, 0.0, 480.0, 320, 240), backend);
            assert_tiles(&format!("terrain {seed} [{}]", backend.name()), &raster, |_, _| true);
        }
    }
}

#[test]
fn lattice_through_pixel_centres_including_its_boundary() {
    let grid = Grid::new(0.0, 97.0, 0.0, 61.0, 97, 61);
    for backend in backends("centre lattice watertightness") {
        for step in [1u32, 2, 5] {
            let scene = scenes::centre_lattice(&grid, step, 7);
            let (ci, cj) = ((grid.width - 1) / step * step, (grid.height - 1) / step * step);
            let raster = coverage(&scene, grid, backend);
            // The hull runs through pixel centres: those on it are covered, as gdal_grid does.
            assert_tiles(&format!("lattice step {step} [{}]", backend.name()), &raster, |i, j| i <= ci && j <= cj);
        }
    }
}

#[test]
fn fan_centre_is_owned_exactly_once() {
    let grid = Grid::new(0.0, 41.0, 0.0, 41.0, 41, 41);
    for backend in backends("fan watertightness") {
        for n in [3u32, 4, 5, 8, 16, 64, 255] {
            let scene = scenes::fan(&grid, 20, 20, n, 12.0, n as u64);
            let raster = coverage(&scene, grid, backend);
            // Pixels within 2 px of the centre are inside every fan with radius ≥ 9.6 px.
            let near = |i: u32, j: u32| (i as i32 - 20).abs() <= 2 && (j as i32 - 20).abs() <= 2;
            assert_tiles(&format!("fan {n} [{}]", backend.name()), &raster, near);
        }
    }
}

#[test]
fn utm_scale_tin_is_watertight() {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 1500.0, 1500.0, 80, 80, 3);
    for backend in backends("utm watertightness") {
        let raster = coverage(&scene, Grid::new(x0, x0 + 1500.0, y0, y0 + 1500.0, 700, 700), backend);
        assert_tiles(&format!("utm terrain [{}]", backend.name()), &raster, |_, _| true);
    }
}

#[test]
fn sliver_wedge_is_watertight() {
    let grid = Grid::new(0.0, 200.0, 0.0, 60.0, 200, 60);
    for backend in backends("sliver watertightness") {
        let scene = scenes::sliver_wedge(&grid, 500, 0.05, 1);
        let raster = coverage(&scene, grid, backend);
        // Cells on the wedge's axis between apex and far side are well inside it.
        let axis = grid.height / 2;
        assert_tiles(&format!("sliver wedge [{}]", backend.name()), &raster, |i, j| j == axis && (10..190).contains(&i));
    }
}

/// Micro-triangles, most of which touch no pixel centre and are dropped at preparation: the
/// ones that remain still cover every centre exactly once, on both backends.
#[test]
fn micro_triangles_cover_every_centre_once() {
    for backend in backends("micro-triangle watertightness") {
        for (px, seed) in [(0.25, 3u64), (0.5, 4), (1.0, 5)] {
            let (scene, grid) = scenes::micro_triangles(96, px, seed);
            let raster = coverage(&scene, grid, backend);
            let culled = raster.stats.triangles_culled as f64 / scene.triangles.len() as f64;
            if px == 0.25 {
                assert!(culled > 0.4, "{px} px: {:.0} % dropped; most of these touch no centre", culled * 100.0);
            }
            assert_tiles(&format!("micro {px} px [{}]", backend.name()), &raster, |_, _| true);
        }
    }
}
