//! `cargo xtask stage-times`: where a CPU call's time goes, pass by pass, on the scenes the
//! small-triangle goals name: preparation, the plan, then each stage of the table as the CPU
//! executor runs it (`tileraster_cpu::rasterise_observed`; the raster's allocation counts with
//! the first stage). Medians of several calls, each call's result dropped before the next.

use std::fmt::Write;
use std::time::Instant;
use tileraster::{Grid, Params, Scene};
use tileraster_core::kernels::pipeline::STAGES;
use tileraster_testkit::scenes;

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

/// Milliseconds of one call: preparation, plan, each stage of the table in order, total.
fn one_call(scene: &Scene, params: &Params) -> Result<Vec<f64>, String> {
    let text = |e: tileraster::Error| e.to_string();
    let mut laps = Vec::with_capacity(STAGES.len() + 3);
    let mut clock = Instant::now();
    let mut lap = |laps: &mut Vec<f64>| {
        laps.push(clock.elapsed().as_secs_f64() * 1e3);
        clock = Instant::now();
    };
    let prepared = tileraster::prepare(scene, params, None).map_err(text)?;
    lap(&mut laps);
    let plan = prepared.plan(prepared.window, false).map_err(text)?;
    lap(&mut laps);
    let raster = tileraster_cpu::rasterise_observed(&prepared, &plan, &mut |_| lap(&mut laps)).map_err(text)?;
    drop(raster);
    if laps.len() != STAGES.len() + 2 {
        return Err(format!("{} stages ran of the table's {}", laps.len() - 2, STAGES.len()));
    }
    laps.push(laps.iter().sum());
    Ok(laps)
}

pub fn run() -> Result<String, String> {
    const RUNS: usize = 15;
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut s = format!("CPU backend, exact mode, {threads} threads; median ms per pass of {RUNS} calls after a warm-up.\n\n");
    let names: Vec<&str> = ["prepare", "plan"].into_iter().chain(STAGES.iter().map(|info| info.name)).chain(["total"]).collect();
    let _ = writeln!(s, "| scene | {} |", names.join(" | "));
    let _ = writeln!(s, "| --- |{}", " ---: |".repeat(names.len()));
    for (name, scene, grid) in cases() {
        let params = Params::new(grid);
        one_call(&scene, &params)?;
        let calls = (0..RUNS).map(|_| one_call(&scene, &params)).collect::<Result<Vec<_>, _>>()?;
        let medians: Vec<String> = (0..names.len())
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
