//! Accuracy of the default mode against an f64 evaluation of the plane through the original,
//! unsnapped vertices at each cell centre: at least 99.9 % of covered cells within 1 ulp
//! (f32), none beyond 64 ulp; coverage equal to the reference's point location except for
//! centres within the snapping step of the mesh's outer boundary.

mod common;

use tileraster::{Backend, Grid, Params, Raster, Scene, rasterise};
use tileraster_testkit::reference::{Reference, accuracy};
use tileraster_testkit::scenes;

/// The accuracy bounds, with every skip variant (each raster is checked on its own).
fn check(name: &str, scene: &Scene, grid: Grid, backend: Backend) {
    let reference = Reference::new(scene, &grid);
    for (variant, skips) in common::skip_variants() {
        let params = Params::new(grid).with_nodata(-9999.0).with_skips(skips);
        let raster = rasterise(scene, &params, backend).unwrap_or_else(|e| panic!("{name}, {variant}: {e}"));
        check_raster(&format!("{name}, {variant}"), &raster, &reference, backend);
    }
}

fn check_raster(name: &str, raster: &Raster, reference: &Reference, backend: Backend) {
    let a = accuracy(raster, reference);
    eprintln!(
        "{name} [{}]: {} cells, {:.5}% within 0.5 ulp, {:.5}% within 1 ulp, max {:.3} ulp, rms {:.4} ulp, {} coverage mismatches",
        backend.name(),
        a.compared,
        100.0 * a.within_half_ulp as f64 / a.compared as f64,
        100.0 * a.share_within_one_ulp(),
        a.max_ulps,
        a.rms_ulps,
        a.coverage_mismatches
    );
    assert!(a.compared > 0, "{name}: nothing was compared");
    assert!(a.share_within_one_ulp() >= 0.999, "{name}: only {:.4}% of cells within 1 ulp", 100.0 * a.share_within_one_ulp());
    assert!(a.max_ulps <= 64.0, "{name}: a cell is {:.1} ulp off", a.max_ulps);
    // Snapping may move a boundary centre in or out by at most 2^-17 px: rare, never many.
    assert!(a.coverage_mismatches * 10_000 <= a.compared, "{name}: {} coverage mismatches", a.coverage_mismatches);
}

#[test]
fn terrain_tin() {
    let scene = scenes::terrain(0.0, 0.0, 1000.0, 800.0, 70, 56, 5);
    check("terrain", &scene, Grid::new(-20.0, 1010.0, -15.0, 790.0, 601, 467), Backend::Cpu);
}

#[test]
fn terrain_tin_at_utm_scale() {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 3000.0, 3000.0, 150, 150, 21);
    check("utm terrain, 2.5 m cells", &scene, Grid::new(x0, x0 + 3000.0, y0, y0 + 3000.0, 1200, 1200), Backend::Cpu);
    check("utm terrain, 0.37 m cells", &scene, Grid::new(x0 + 1000.0, x0 + 1370.0, y0 + 500.0, y0 + 870.0, 1000, 1000), Backend::Cpu);
}

#[test]
fn terrain_tin_at_utm_scale_on_gpu() {
    if !common::gpu_or_skip("terrain_tin_at_utm_scale_on_gpu") {
        return;
    }
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let scene = scenes::terrain(x0, y0, 3000.0, 3000.0, 150, 150, 21);
    check("utm terrain, 2.5 m cells", &scene, Grid::new(x0, x0 + 3000.0, y0, y0 + 3000.0, 1200, 1200), Backend::Gpu);
}

#[test]
fn lattice_with_vertices_on_pixel_centres() {
    let grid = Grid::new(0.0, 300.0, 0.0, 200.0, 300, 200);
    let scene = scenes::centre_lattice(&grid, 7, 3);
    check("centre lattice", &scene, grid, Backend::Cpu);
}

#[test]
fn steep_slivers() {
    let grid = Grid::new(0.0, 400.0, 0.0, 100.0, 400, 100);
    let scene = scenes::sliver_wedge(&grid, 300, 0.02, 4);
    check("sliver wedge", &scene, grid, Backend::Cpu);
}

#[test]
fn rough_tin_with_cliffs_at_utm_scale() {
    // Random heights per vertex: neighbouring planes differ by up to ~100 m per m, so a centre
    // given to the wrong side of an edge would show at once.
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let mut scene = scenes::terrain(x0, y0, 800.0, 800.0, 100, 100, 13);
    let mut rng = scenes::Rng::new(13);
    for v in &mut scene.vertices {
        v[2] = rng.range(0.0, 1000.0);
    }
    check("rough utm tin", &scene, Grid::new(x0, x0 + 800.0, y0, y0 + 800.0, 1600, 1600), Backend::Cpu);
}
