//! Exact seams: a block of the grid (a `--part`'s band, a window) triangulated from the points
//! around it only (`dem::block_scene`) gives the whole run's cells bit for bit, whatever the
//! blocking; on synthetic terrain (cocircular lattices and rings, a hole, repeated positions,
//! UTM coordinates) and on a real airborne LiDAR tile.

use std::path::{Path, PathBuf};
use tileraster::dem::{self, DemError, ReadOptions};
use tileraster::{Backend, Grid, Params, Raster, Window, rasterise, rasterise_window};
use tileraster_testkit::scenes::{Rng, TWELVE_ON_A_CIRCLE};

/// Points at UTM-like coordinates: random ground, a lattice patch (four cocircular points to
/// each square), rings of twelve cocircular points, a round hole with no points, and
/// repeated positions with other heights.
fn terrain(n: usize, seed: u64) -> Vec<[f64; 3]> {
    let (e, north) = (500_000.0, 5_000_000.0);
    let mut rng = Rng::new(seed);
    let mut points: Vec<[f64; 3]> = (0..n)
        .map(|_| {
            let (x, y) = (rng.range(0.0, 600.0), rng.range(0.0, 400.0));
            [e + (x * 1000.0).round() / 1000.0, north + (y * 1000.0).round() / 1000.0, 100.0 + (x / 40.0).sin() * 8.0 + y * 0.02]
        })
        .filter(|p| (p[0] - e - 420.0).hypot(p[1] - north - 250.0) > 45.0)
        .collect();
    points.extend((0..40 * 25).map(|k| [e + 100.0 + (k % 40) as f64 * 2.0, north + 60.0 + (k / 40) as f64 * 2.0, (k % 13) as f64]));
    for (cx, cy) in [(250.0, 300.0), (300.5, 120.25)] {
        points.extend(TWELVE_ON_A_CIRCLE.iter().map(|&(x, y)| [e + cx + x, north + cy + y, 120.0 + x]));
    }
    let repeats: Vec<[f64; 3]> = points.iter().step_by(53).map(|p| [p[0], p[1], p[2] + 3.0]).collect();
    points.extend(repeats);
    points
}

/// The blockings tried: bands as `--part K/N` makes them, a grid of blocks, and odd windows.
fn blockings(grid: &Grid) -> Vec<(String, Window)> {
    let mut windows = Vec::new();
    for n in [2, 5] {
        for k in 0..n {
            windows.push((format!("part {k}/{n}"), dem::part_window(grid, k, n).unwrap()));
        }
    }
    let (w, h) = (grid.width, grid.height);
    for j in 0..3 {
        for i in 0..3 {
            let (x0, y0) = (i * w / 3, j * h / 3);
            windows.push((format!("block {i}, {j} of 3 × 3"), Window { x0, y0, width: (i + 1) * w / 3 - x0, height: (j + 1) * h / 3 - y0 }));
        }
    }
    windows.push(("a one-cell window".into(), Window { x0: w / 2, y0: h / 3, width: 1, height: 1 }));
    windows.push(("a thin column".into(), Window { x0: w / 7, y0: 0, width: 3, height: h }));
    windows
}

/// Every blocking's cells equal the whole run's window of them, bit for bit.
fn assert_blocks_are_the_whole_run(points: &[[f64; 3]], grid: Grid, options: &ReadOptions, what: &str) {
    let block = |window| dem::block_scene(points, &grid, window, options, &());
    assert_blocks_of_are_the_whole_run(points, grid, options, what, block);
}

/// As [`assert_blocks_are_the_whole_run`], with the blocks that `block` makes.
fn assert_blocks_of_are_the_whole_run(
    points: &[[f64; 3]],
    grid: Grid,
    options: &ReadOptions,
    what: &str,
    block: impl Fn(Window) -> Result<dem::Input, DemError>,
) {
    let mut whole_tin = tileraster_tin::triangulate(points).unwrap().scene;
    if let Some(max_edge) = options.max_edge {
        dem::drop_long_triangles(&mut whole_tin, max_edge);
    }
    let params = Params::new(grid).with_nodata(-9999.0);
    let whole = rasterise(&whole_tin, &params, Backend::Cpu).unwrap();
    let covered = whole.values.iter().filter(|v| **v != -9999.0).count();
    assert!(covered > grid.pixel_count() as usize / 2, "{what}: the TIN covers most of the grid ({covered} cells)");
    let mut smaller = 0;
    for (name, window) in blockings(&grid) {
        let block = block(window).unwrap_or_else(|e| panic!("{what}, {name}: {e}"));
        let made = block.block.expect("a block says how it was made");
        smaller += usize::from(made.points < points.len());
        let raster = rasterise_window(&block.scene, &params, Some(window), Backend::Cpu).unwrap();
        assert_window_equal(&whole, &raster, &format!("{what}, {name} ({} of {} points, {} tries)", made.points, points.len(), made.attempts));
    }
    assert!(smaller > 0, "{what}: some block triangulates fewer points than all");
}

fn assert_window_equal(whole: &Raster, block: &Raster, what: &str) {
    let w = block.window;
    let mut differ = 0;
    for j in 0..w.height as usize {
        for i in 0..w.width as usize {
            let a = whole.values[(w.y0 as usize + j) * whole.window.width as usize + w.x0 as usize + i];
            let b = block.values[j * w.width as usize + i];
            differ += usize::from(a.to_bits() != b.to_bits());
        }
    }
    assert_eq!(differ, 0, "{what}: {differ} cells differ from the whole run's");
}

#[test]
fn synthetic_blocks_are_the_whole_run_bit_for_bit() {
    let points = terrain(40_000, 7);
    let grid = Grid::new(500_000.0 - 3.0, 500_605.0, 4_999_998.0, 5_000_404.0, 608, 406);
    assert_blocks_are_the_whole_run(&points, grid, &ReadOptions::default(), "synthetic");
    let options = ReadOptions { max_edge: Some(6.0), ..Default::default() };
    assert_blocks_are_the_whole_run(&points, grid, &options, "synthetic, --max-edge 6");
}

/// Points in tiles of files, read for a block only where its region reaches: the same cells
/// as the whole run of all the files' points, in the files' order as given.
#[test]
fn blocks_of_many_files_read_what_they_need_and_are_the_whole_run() {
    let points = terrain(40_000, 11);
    let directory = std::env::temp_dir().join(format!("tileraster-seams-files-{}", std::process::id()));
    std::fs::create_dir_all(&directory).unwrap();
    // 4 × 3 tiles of 150 m × 134 m, listed in a scrambled order.
    let tile =
        |p: &[f64; 3]| ((p[0] - 500_000.0) / 150.0).floor().clamp(0.0, 3.0) as usize + 4 * ((p[1] - 5_000_000.0) / 134.0).floor().clamp(0.0, 2.0) as usize;
    let order = [5, 0, 11, 3, 8, 1, 10, 6, 2, 9, 4, 7];
    let mut paths = Vec::new();
    for &t in &order {
        let text: String = points.iter().filter(|p| tile(p) == t).map(|p| format!("{},{},{}\n", p[0], p[1], p[2])).collect();
        let path = directory.join(format!("tile{t}.csv"));
        std::fs::write(&path, format!("x,y,z\n{text}")).unwrap();
        paths.push(path);
    }
    let options = ReadOptions::default();
    let all = dem::read_points(&paths, &options).unwrap();
    assert_eq!(all.len(), points.len());
    let files = dem::summarise_files(&paths, &options).unwrap();
    assert_eq!(files.iter().map(|f| f.points).sum::<usize>(), points.len());
    let grid = Grid::new(500_000.0 - 3.0, 500_605.0, 4_999_998.0, 5_000_404.0, 608, 406);
    let fewer = std::cell::Cell::new(0);
    assert_blocks_of_are_the_whole_run(&all, grid, &options, "12 files", |window| {
        let block = dem::block_scene_of_files(&files, &grid, window, &options, &())?;
        fewer.set(fewer.get() + usize::from(block.block.unwrap().files_read < files.len()));
        Ok(block)
    });
    assert!(fewer.get() > 0, "some block reads fewer files than all");
    // A file that changed after its summary is refused, not read as if it had not.
    std::fs::write(&paths[0], "x,y,z\n500100,5000100,1\n").unwrap();
    let window = Window { x0: 0, y0: 0, width: grid.width, height: grid.height };
    let err = dem::block_scene_of_files(&files, &grid, window, &options, &()).err().expect("a changed file errs");
    assert!(matches!(err, DemError::InputChanged { summarised, read: 1, .. } if summarised == files[0].points), "{err}");
    std::fs::remove_dir_all(&directory).unwrap();
}

fn autzen() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/autzen_trim.laz")
}

#[test]
fn a_real_lidar_tiles_blocks_are_the_whole_run_bit_for_bit() {
    let points = dem::read_points(&[autzen()], &ReadOptions::default()).unwrap();
    assert_eq!(points.len(), 110_000);
    let hull = tileraster_tin::Rect::around(&points).unwrap();
    // 2 m cells over the tile's extent.
    let (width, height) = (((hull.x1 - hull.x0) / 2.0).ceil() as u32, ((hull.y1 - hull.y0) / 2.0).ceil() as u32);
    let grid = Grid::new(hull.x0, hull.x0 + 2.0 * width as f64, hull.y0, hull.y0 + 2.0 * height as f64, width, height);
    assert_blocks_are_the_whole_run(&points, grid, &ReadOptions::default(), "autzen_trim");
}

/// A COPC file (the same tile as an octree of nodes): its summary reads only the nodes that
/// may hold corners of its hull and finds the exact hull; its blocks decode only the nodes their
/// regions meet and are the whole run of the file's points, with and without `--class`.
#[test]
fn a_copc_files_blocks_decode_their_nodes_and_are_the_whole_run() {
    let copc = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/autzen_trim.copc.laz");
    assert!(dem::is_copc(&copc).unwrap() && !dem::is_copc(&autzen()).unwrap());
    for classes in [vec![], vec![2]] {
        let options = ReadOptions { classes: classes.clone(), ..Default::default() };
        let points = dem::read_points(std::slice::from_ref(&copc), &options).unwrap();
        let mut sorted = dem::read_points(&[autzen()], &options).unwrap();
        let mut ours = points.clone();
        let key = |p: &[f64; 3]| p.map(f64::to_bits);
        sorted.sort_by_key(key);
        ours.sort_by_key(key);
        assert_eq!(ours, sorted, "the COPC file holds the LAZ file's points, in its own order");
        let files = dem::summarise_files(std::slice::from_ref(&copc), &options).unwrap();
        assert_eq!(files[0].records, Some(110_000));
        assert_eq!(files[0].hull, tileraster_tin::Hull::of(&points), "the summary's hull is exact (classes {classes:?})");
        if classes.is_empty() {
            assert_eq!(files[0].points, 110_000);
        }
        let hull = tileraster_tin::Rect::around(&points).unwrap();
        let (width, height) = (((hull.x1 - hull.x0) / 2.0).ceil() as u32, ((hull.y1 - hull.y0) / 2.0).ceil() as u32);
        let grid = Grid::new(hull.x0, hull.x0 + 2.0 * width as f64, hull.y0, hull.y0 + 2.0 * height as f64, width, height);
        let fewer = std::cell::Cell::new(0);
        let what = format!("autzen_trim as COPC, classes {classes:?}");
        assert_blocks_of_are_the_whole_run(&points, grid, &options, &what, |window| {
            let block = dem::block_scene_of_files(&files, &grid, window, &options, &())?;
            let made = block.block.unwrap();
            fewer.set(fewer.get() + usize::from(made.attempts == 1 && made.points_decoded < 110_000));
            Ok(block)
        });
        assert!(fewer.get() > 0, "{what}: some block decodes fewer points than the file holds");
    }
    let none = ReadOptions { classes: vec![99], ..Default::default() };
    let err = dem::summarise_files(std::slice::from_ref(&copc), &none).unwrap_err().to_string();
    assert!(err.contains("no point is of class 99") && err.contains("class 2:"), "{err}");
}

/// A triangle wider than the finest snapping lattice allows coarsens the whole run's lattice;
/// the block that holds it says so instead of giving other bits, and a block beside it (that
/// cannot know) is still whole-run bits whenever no block errs.
#[test]
fn a_block_over_a_triangle_too_wide_for_the_finest_lattice_is_an_error() {
    let mut rng = Rng::new(3);
    let mut points: Vec<[f64; 3]> = (0..2000).map(|_| [rng.range(0.0, 100.0), rng.range(0.0, 100.0), rng.range(0.0, 10.0)]).collect();
    // Far points: a fan of triangles 9,000 cells across at 1 cell a unit.
    points.extend([[9_000.0, 50.0, 0.0], [9_000.0, 90.0, 0.0]]);
    let grid = Grid::new(0.0, 9_001.0, 0.0, 100.0, 9_001, 100);
    let whole = rasterise(&tileraster_tin::triangulate(&points).unwrap().scene, &Params::new(grid), Backend::Cpu).unwrap();
    assert!(whole.snap_bits < tileraster_kernels::MAX_SNAP_BITS, "the whole run coarsens its lattice");
    let window = Window { x0: 4_000, y0: 0, width: 100, height: 100 };
    let err = dem::block_scene(&points, &grid, window, &ReadOptions::default(), &()).err().expect("a block over the wide triangles errs");
    assert!(matches!(err, DemError::BlockLattice { .. }), "{err}");
    assert!(err.to_string().contains("--max-edge"), "{err}");
}
