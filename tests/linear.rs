//! gdal_grid's `linear:radius=R`: cells outside every triangle take the z of the point
//! gdal_grid 3.6 picks, bit for bit, compared with gdal_grid itself. GDAL must be installed
//! (CI installs gdal-bin); `TILERASTER_SKIP_GDAL=1` skips the comparison, and says so.

use tileraster::dem::Fallback;
use tileraster::{Backend, Grid, Outputs, Params, rasterise};
use tileraster_testkit::scenes;

fn gdal_or_skip() -> bool {
    if let Some(version) = tileraster_peers::gdal_grid_version() {
        // The fallback reproduces gdal_grid 3.6's search (its square box); other versions may
        // choose otherwise, and this comparison would say so.
        eprintln!("comparing with {version}; tileraster follows gdal_grid 3.6");
        return true;
    }
    if std::env::var_os("TILERASTER_SKIP_GDAL").is_some_and(|v| v == "1") {
        eprintln!("SKIPPED: gdal_grid is not installed and TILERASTER_SKIP_GDAL=1: the linear fallback was not compared with gdal_grid");
        return false;
    }
    panic!("gdal_grid is not installed: install gdal-bin (apt-get install gdal-bin), or set TILERASTER_SKIP_GDAL=1 to skip this comparison");
}

/// Random points on a millimetre grid, a lattice with ties, and repeated positions with other
/// heights, onto a grid reaching well beyond their hull; for several radii, every cell outside
/// the TIN equals gdal_grid's, bit for bit.
#[test]
fn cells_outside_the_tin_are_gdal_grids() {
    if !gdal_or_skip() {
        return;
    }
    let mut rng = scenes::Rng::new(17);
    let mut points: Vec<[f64; 3]> = (0..1500)
        .map(|_| [rng.range(100_000.0, 400_000.0).round() / 1000.0, rng.range(50_000.0, 250_000.0).round() / 1000.0, rng.range(0.0, 50_000.0).round() / 1000.0])
        .collect();
    // A lattice (equidistant neighbours: ties that only gdal_grid's search order decides) and
    // repeated positions with other heights.
    for k in 0..60 {
        points.push([450.0 + (k % 6) as f64 * 5.0, 100.0 + (k / 6) as f64 * 5.0, k as f64]);
    }
    for k in 0..40 {
        let p = points[k * 7];
        points.push([p[0], p[1], p[2] + 100.0]);
    }
    let tin = tileraster_tin::triangulate(&points).unwrap();
    let grid = Grid::new(0.0, 600.0, 0.0, 300.0, 240, 120);
    let nodata = -9999.0;
    let params = Params::new(grid).with_nodata(nodata).with_outputs(Outputs { owner: true, coverage: false, tiles: false });
    let dir = std::env::temp_dir().join(format!("tileraster-linear-{}", std::process::id()));
    for radius in [-1.0, 0.0, 3.0, 25.0] {
        let mut raster = rasterise(&tin.scene, &params, Backend::Cpu).unwrap();
        let filled = Fallback::new(&points, radius).map_or(0, |f| f.fill(&mut raster));
        let (gdal, _) = tileraster_peers::gdal_grid_linear_radius(&points, &grid, radius, nodata, &dir).unwrap();
        let owner = raster.owner.as_ref().unwrap();
        let outside: Vec<usize> = (0..owner.len()).filter(|&k| owner[k] == u32::MAX).collect();
        let differing: Vec<(usize, f32, f32)> =
            outside.iter().filter(|&&k| raster.values[k].to_bits() != gdal[k].to_bits()).map(|&k| (k, raster.values[k], gdal[k])).collect();
        assert!(
            differing.is_empty(),
            "radius {radius}: {} of {} cells outside the TIN differ from gdal_grid, first: {:?}",
            differing.len(),
            outside.len(),
            &differing[..differing.len().min(5)]
        );
        let empty = outside.iter().filter(|&&k| raster.values[k] == nodata).count() as u64;
        match radius {
            0.0 => assert_eq!(filled, 0),
            r if r < 0.0 => assert_eq!((filled, empty), (outside.len() as u64, 0), "any distance fills every cell"),
            _ => assert!(filled > 0 && empty > 0, "radius {radius}: some cells filled ({filled}), some left empty ({empty})"),
        }
        assert!(outside.len() > 15_000, "most of the grid is outside the TIN: {}", outside.len());
    }
    std::fs::remove_dir_all(&dir).ok();
}
