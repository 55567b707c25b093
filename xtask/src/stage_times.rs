//! `cargo xtask stage-times`: where a CPU call's time goes, pass by pass, on the scenes the
//! small-triangle goals name: preparation, the plan (listing, frame, allocation), then each
//! stage of the table run by its CPU twin. Medians of several calls; the passes run one after
//! the other as `rasterise` runs them.

use std::fmt::Write;
use std::time::Instant;
use tileraster::{Grid, Params, Scene};
use tileraster_cpu::{bin_count, bin_fill, bin_scan, fine_raster, setup, FinePath};
use tileraster_testkit::scenes;

const PASSES: [&str; 8] = ["prepare", "plan", "setup", "bin_count", "bin_scan", "bin_fill", "fine_raster", "total"];

fn cases() -> Vec<(String, Scene, Grid)> {
    let mut cases = Vec::new();
    for px in [0.25, 1.0, 4.0] {
        let (scene, grid) = scenes::micro_triangles(512, px, 7);
        cases.push((format!("micro-triangles {px} px, 512²"), scene, grid));
    }
    let sliver_grid = Grid::new(0.0, 1024.0, 0.0, 256.0, 1024, 256);
    cases.push(("slivers, 2000 × 0.1 px wedge".into(), scenes::sliver_wedge(&sliver_grid, 2000, 0.1, 4), sliver_grid));
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, 315, 315, 2026);
    cases.push(("terrain TIN, 99856 points, 4096²".into(), tin, Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, 4096, 4096)));
    cases
}

/// Milliseconds per pass of one call.
fn one_call(scene: &Scene, params: &Params) -> Result<[f64; 8], String> {
    let text = |e: tileraster::Error| e.to_string();
    let mut laps = [0.0; 8];
    let mut clock = Instant::now();
    let mut lap = |k: usize| {
        laps[k] = clock.elapsed().as_secs_f64() * 1e3;
        clock = Instant::now();
    };
    let prepared = tileraster::prepare(scene, params, None).map_err(text)?;
    lap(0);
    let plan = prepared.plan(prepared.window, false).map_err(text)?;
    let Some(active) = plan.active else { return Err("nothing to draw".into()) };
    let frame = plan.frame(&prepared, active);
    let _ = plan.bin_capacity(&prepared, &frame);
    let mut raster = plan.allocate_raster(&prepared).map_err(text)?;
    lap(1);
    let setups = setup(&prepared, &frame);
    lap(2);
    let counts = bin_count(&frame, &setups, &plan.listed);
    lap(3);
    let offsets = bin_scan(&frame, &counts);
    lap(4);
    let bins = bin_fill(&frame, &setups, &plan.listed, &offsets);
    lap(5);
    fine_raster(FinePath::Specialised, &frame, &setups, &offsets, &bins, &mut raster);
    lap(6);
    laps[7] = laps[..7].iter().sum();
    Ok(laps)
}

pub fn run() -> Result<String, String> {
    const RUNS: usize = 15;
    let mut s = format!("CPU backend, exact mode, {} threads; median ms per pass of {RUNS} calls after a warm-up.\n\n", rayon_threads());
    let _ = writeln!(s, "| scene | {} |", PASSES.join(" | "));
    let _ = writeln!(s, "| --- |{}", " ---: |".repeat(PASSES.len()));
    for (name, scene, grid) in cases() {
        let params = Params::new(grid);
        one_call(&scene, &params)?;
        let calls = (0..RUNS).map(|_| one_call(&scene, &params)).collect::<Result<Vec<_>, _>>()?;
        let medians: Vec<String> = (0..PASSES.len())
            .map(|k| {
                let mut v: Vec<f64> = calls.iter().map(|c| c[k]).collect();
                v.sort_by(f64::total_cmp);
                format!("{:.1}", v[RUNS / 2])
            })
            .collect();
        let _ = writeln!(s, "| {name} | {} |", medians.join(" | "));
        eprintln!("{name} done");
    }
    Ok(s)
}

fn rayon_threads() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}
