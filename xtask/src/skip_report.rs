//! The skips section of `docs/benchmarks.md`: each skip's gain, measured on and off in the same
//! run (the two runs interleaved, so that the machine's noise falls on both alike), prepare
//! once against preparing per window, and a sparse scene over growing grids.

use crate::median;
use std::fmt::Write as _;
use std::time::Instant;
use tileraster::{Backend, Grid, Params, PreparedScene, Raster, Scene, Skip, Skips, Stats, Window, rasterise, rasterise_window};
use tileraster_testkit::scenes;

const NODATA: f32 = -9999.0;

/// Medians of `runs` interleaved calls of `a` and `b` after one warm-up of each, and their last
/// results.
fn interleaved<T>(runs: usize, mut a: impl FnMut() -> Result<T, String>, mut b: impl FnMut() -> Result<T, String>) -> Result<(f64, f64, T, T), String> {
    let (mut last_a, mut last_b) = (a()?, b()?);
    let (mut ta, mut tb) = (Vec::new(), Vec::new());
    for _ in 0..runs {
        let start = Instant::now();
        last_a = a()?;
        ta.push(start.elapsed().as_secs_f64());
        let start = Instant::now();
        last_b = b()?;
        tb.push(start.elapsed().as_secs_f64());
    }
    Ok((median(ta), median(tb), last_a, last_b))
}

fn ms(s: f64) -> String {
    format!("{:.2} ms", s * 1e3)
}

fn same_bits(a: &[Raster], b: &[Raster]) -> &'static str {
    match a.iter().zip(b).all(|(x, y)| x.compare_bits(y, 0).0 == 0) {
        true => "yes",
        false => "**no**",
    }
}

/// The backends measured: the CPU, and the GPU when there is an adapter.
fn backends() -> Vec<Backend> {
    match tileraster::gpu_adapter() {
        Ok(_) => vec![Backend::Cpu, Backend::Gpu],
        Err(_) => vec![Backend::Cpu],
    }
}

struct Scenes {
    tin: Scene,
    tin_grid: Grid,
    sparse: Scene,
    sparse_grid: Grid,
    plane_grid: Grid,
}

/// The sparse scene: a 64 × 64-cell TIN of 512 triangles, in the middle of an `n × n` grid of
/// 1-unit cells.
fn sparse(n: u32) -> (Scene, Grid) {
    let c = (n / 2) as f64;
    (scenes::terrain(c - 32.0, c - 32.0, 64.0, 64.0, 16, 16, 21), Grid::new(0.0, n as f64, 0.0, n as f64, n, n))
}

pub fn run(quick: bool) -> Result<String, String> {
    let size = if quick { 1024 } else { 4096 };
    let cols = if quick { 60 } else { 315 };
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let (sparse_scene, sparse_grid) = sparse(size);
    let s = Scenes {
        tin: scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, cols, cols, 2026),
        tin_grid: Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, size, size),
        sparse: sparse_scene,
        sparse_grid,
        plane_grid: Grid::new(0.0, 1.0, 0.0, 1.0, size, size),
    };
    let runs = if quick { 2 } else { 5 };
    let mut out = String::from("## Skips\n\n");
    out += "What each skip saves, measured with the skip on and off in the same run, the two calls interleaved \
            (medians; `Skips::all_but(name)` turns one off, `tileraster rasterise --no-skip NAME` does the same). \
            Every call is a whole `rasterise` (preparation, the scene analysis, upload and read-back included) \
            unless it says otherwise. *Same bits* compares the two results bit for bit; every skip is exact.\n\n";
    out += &each_skip(&s, runs)?;
    out += &preparation(&s, runs)?;
    out += &prepare_once(&s, runs)?;
    out += &sparse_series(quick, runs)?;
    Ok(out)
}

/// One row per skip and backend: the scene that needs the skip, timed with it and without.
fn each_skip(s: &Scenes, runs: usize) -> Result<String, String> {
    let n = s.tin_grid.width;
    let mut t = String::from(
        "| skip | scene | backend | with | without | gain | same bits | statistics with the skip |\n| --- | --- | --- | ---: | ---: | ---: | :---: | --- |\n",
    );
    let tin_name = format!("TIN, {} points, {n}²", s.tin.vertices.len());
    let sparse_name = format!("64² px TIN in a {n}² grid");
    // A window a quarter of the TIN's grid across, from a prepared scene (only the window differs).
    let window = Window { x0: n / 2 - n / 8, y0: n / 2 - n / 8, width: n / 4, height: n / 4 };
    let plane = scenes::sloping_plane();
    // (skip, scene name, scene, grid, window of a prepared scene, the skips without it)
    type SkipCase<'a> = (&'static str, String, &'a Scene, Grid, Option<Window>, Skips);
    let cases: Vec<SkipCase> = vec![
        (
            Skip::CullWindow.name(),
            format!("{}² window of the {tin_name} (prepared once)", n / 4),
            &s.tin,
            s.tin_grid,
            Some(window),
            Skips::all_but(Skip::CullWindow),
        ),
        (Skip::EmptyTiles.name(), sparse_name.clone(), &s.sparse, s.sparse_grid, None, Skips::all_but(Skip::EmptyTiles)),
        (Skip::FullTiles.name(), format!("plane, 2 triangles, {n}²"), &plane, s.plane_grid, None, Skips::all_but(Skip::FullTiles)),
        (Skip::OverlapFree.name(), tin_name.clone(), &s.tin, s.tin_grid, None, Skips::all_but(Skip::OverlapFree)),
        ("all four", tin_name, &s.tin, s.tin_grid, None, Skips::NONE),
        ("all four", sparse_name, &s.sparse, s.sparse_grid, None, Skips::NONE),
    ];
    for (skip, scene_name, scene, grid, window, without) in cases {
        for backend in backends() {
            eprintln!("skips: {skip}, {scene_name}, {} ...", backend.name());
            let params = |skips| Params::new(grid).with_nodata(NODATA).with_skips(skips);
            let (with_s, without_s, a, b) = match window {
                // Prepared once, as a caller rasterising many windows would: times one window.
                Some(w) => {
                    let mut on = PreparedScene::new(scene, &params(Skips::ALL), backend).map_err(|e| e.to_string())?;
                    let mut off = PreparedScene::new(scene, &params(without), backend).map_err(|e| e.to_string())?;
                    interleaved(runs, || on.rasterise_window(w).map_err(|e| e.to_string()), || off.rasterise_window(w).map_err(|e| e.to_string()))?
                }
                None => interleaved(
                    runs,
                    || rasterise(scene, &params(Skips::ALL), backend).map_err(|e| e.to_string()),
                    || rasterise(scene, &params(without), backend).map_err(|e| e.to_string()),
                )?,
            };
            let _ = writeln!(
                t,
                "| {skip} | {scene_name} | {} | {} | {} | {:.2}× | {} | {} |",
                backend.name(),
                ms(with_s),
                ms(without_s),
                without_s / with_s,
                same_bits(std::slice::from_ref(&a), &[b]),
                brief(&a.stats)
            );
        }
    }
    Ok(t + "\n")
}

/// What the scene analysis costs: preparation (validation, culling, snapping, planes) with the
/// overlap analysis and without it.
fn preparation(s: &Scenes, runs: usize) -> Result<String, String> {
    let mut t = String::from(
        "### What the scene analysis costs\n\n`tileraster::prepare` alone (host, once per scene and grid), with the overlap \
         analysis (`overlap_free` on) and without it.\n\n| scene | with the analysis | without | analysis share | proven overlap-free |\n| --- | ---: | ---: | ---: | :---: |\n",
    );
    let plane = scenes::sloping_plane();
    let soup_grid = Grid::new(0.0, 1000.0, 0.0, 1000.0, 1024, 1024);
    let soup = scenes::triangle_soup(&soup_grid, 100_000, 20.0, 5);
    let cases = [
        (format!("TIN, {} points, {}²", s.tin.vertices.len(), s.tin_grid.width), &s.tin, s.tin_grid),
        (format!("plane, 2 triangles, {}²", s.plane_grid.width), &plane, s.plane_grid),
        ("soup of 100000 overlapping triangles, 1024²".to_string(), &soup, soup_grid),
    ];
    for (name, scene, grid) in cases {
        eprintln!("skips: preparation, {name} ...");
        let prep = |skips| tileraster::prepare(scene, &Params::new(grid).with_skips(skips), None).map_err(|e| e.to_string());
        let (with_s, without_s, a, _) = interleaved(runs, || prep(Skips::ALL), || prep(Skips::all_but(Skip::OverlapFree)))?;
        let _ = writeln!(
            t,
            "| {name} | {} | {} | {:.0} % | {} |",
            ms(with_s),
            ms(without_s),
            100.0 * (with_s - without_s).max(0.0) / with_s,
            if a.overlap_free_rows.is_some() { "yes" } else { "no" }
        );
    }
    Ok(t + "\n")
}

/// The statistics a reader needs to see a skip happen.
fn brief(s: &Stats) -> String {
    format!(
        "{} tiles: {} empty, {} full, {} tested; {} triangles culled, {} binned; overlap-free: {}",
        s.tiles_total, s.tiles_empty_skipped, s.tiles_full, s.tiles_partial, s.triangles_culled, s.triangles_binned, s.overlap_free
    )
}

/// Rasterising a grid as 16 windows: one prepared scene, against a whole call per window.
fn prepare_once(s: &Scenes, runs: usize) -> Result<String, String> {
    let n = s.tin_grid.width;
    let q = n / 4;
    let windows: Vec<Window> = (0..16).map(|k| Window { x0: (k % 4) * q, y0: (k / 4) * q, width: q, height: q }).collect();
    let params = Params::new(s.tin_grid).with_nodata(NODATA);
    let mut t = format!(
        "### Prepare once, rasterise many\n\nThe {}-point TIN's {n}² grid as 16 windows of {q}²: one `PreparedScene` (prepared, \
         uploaded and set up once, each window then lists its triangles), against 16 `rasterise_window` calls that each \
         prepare, upload and set up the whole scene.\n\n\
         | backend | prepared once | per window | gain | same bits | bytes uploaded, once / per window |\n| --- | ---: | ---: | ---: | :---: | ---: |\n",
        s.tin.vertices.len()
    );
    for backend in backends() {
        eprintln!("skips: prepare once, {} ...", backend.name());
        let once = || -> Result<(Vec<Raster>, u64), String> {
            let mut prepared = PreparedScene::new(&s.tin, &params, backend).map_err(|e| e.to_string())?;
            let rasters: Vec<Raster> = windows.iter().map(|&w| prepared.rasterise_window(w)).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
            let bytes = rasters.iter().map(|r| r.stats.bytes_uploaded).sum();
            Ok((rasters, bytes))
        };
        let each = || -> Result<(Vec<Raster>, u64), String> {
            let rasters: Vec<Raster> =
                windows.iter().map(|&w| rasterise_window(&s.tin, &params, Some(w), backend)).collect::<Result<_, _>>().map_err(|e| e.to_string())?;
            let bytes = rasters.iter().map(|r| r.stats.bytes_uploaded).sum();
            Ok((rasters, bytes))
        };
        let (once_s, each_s, (a, a_bytes), (b, b_bytes)) = interleaved(runs.min(3), once, each)?;
        let _ = writeln!(
            t,
            "| {} | {} | {} | {:.2}× | {} | {:.1} MB / {:.1} MB |",
            backend.name(),
            ms(once_s),
            ms(each_s),
            each_s / once_s,
            same_bits(&a, &b),
            a_bytes as f64 / 1e6,
            b_bytes as f64 / 1e6
        );
    }
    Ok(t + "\n")
}

/// The same small mesh in ever larger grids: with the skips, the time beyond filling the raster
/// with nodata stays flat; without them it grows with the grid.
fn sparse_series(quick: bool, runs: usize) -> Result<String, String> {
    let sizes: &[u32] = if quick { &[256, 512, 1024] } else { &[512, 1024, 2048, 4096, 8192] };
    let mut t = String::from(
        "### A sparse scene\n\nA 64 × 64-cell TIN (512 triangles) in the middle of grids from small to large. *Nodata fill* \
         is allocating the raster and filling it with nodata on the host, as the call must; *beyond the fill* is the \
         call's time minus that. With the skips, the part beyond the fill follows the covered area and stays flat; \
         without them it follows the grid.\n\n\
         | grid | backend | tiles rasterised | nodata fill | call, skips on | beyond the fill | call, skips off | beyond the fill | same bits |\n\
         | --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | :---: |\n",
    );
    for &n in sizes {
        let (scene, grid) = sparse(n);
        let cells = grid.pixel_count() as usize;
        let fill_once = || -> Result<(), String> {
            let mut v = tileraster_core::zeroed_cells::<f32>(cells)?;
            v.fill(NODATA);
            std::hint::black_box(&v);
            Ok(())
        };
        for backend in backends() {
            eprintln!("skips: sparse {n}², {} ...", backend.name());
            let params = |skips| Params::new(grid).with_nodata(NODATA).with_skips(skips);
            let runs = if n >= 4096 { runs.min(3) } else { runs };
            // The fill and the two calls in turn, so that the same noise falls on all three.
            let on = || rasterise(&scene, &params(Skips::ALL), backend).map_err(|e| e.to_string());
            let off = || rasterise(&scene, &params(Skips::NONE), backend).map_err(|e| e.to_string());
            let (mut a, mut b) = (on()?, off()?);
            let (mut fills, mut ons, mut offs) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..runs {
                let start = Instant::now();
                fill_once()?;
                fills.push(start.elapsed().as_secs_f64());
                let start = Instant::now();
                a = on()?;
                ons.push(start.elapsed().as_secs_f64());
                let start = Instant::now();
                b = off()?;
                offs.push(start.elapsed().as_secs_f64());
            }
            let (fill, on_s, off_s) = (median(fills), median(ons), median(offs));
            let _ = writeln!(
                t,
                "| {n}² | {} | {} of {} | {} | {} | {} | {} | {} | {} |",
                backend.name(),
                a.stats.tiles_full + a.stats.tiles_partial,
                a.stats.tiles_total,
                ms(fill),
                ms(on_s),
                ms(on_s - fill),
                ms(off_s),
                ms(off_s - fill),
                same_bits(std::slice::from_ref(&a), &[b])
            );
        }
    }
    Ok(t)
}
