//! `cargo xtask bench-report`: run time against error, for every backend × mode × scene, side by
//! side with the peers a user would otherwise pick, all in one run. Writes
//! `docs/benchmarks.md` (tables) and `docs/time-vs-error.svg` (the plot).
//!
//! Errors are against `tileraster_testkit::reference`, an f64 evaluation on the unsnapped input that
//! shares no code with the rasteriser. Times are medians of several runs after a warm-up;
//! each call is a whole `rasterise` (preparation, upload and read-back included).

use crate::{Timing, svg};
use std::fmt::Write as _;
use std::time::Instant;
use tileraster::{Backend, Grid, Mode, Params, Raster, Scene, rasterise};
use tileraster_peers::{GpuFill, RenderPipeline, fill_cpu, gdal_grid_linear, gdal_grid_version};
use tileraster_testkit::reference::{Accuracy, Reference, accuracy};
use tileraster_testkit::scenes;

const NODATA: f32 = -9999.0;

pub struct Options {
    /// Fewer and smaller scenes, fewer runs: a check that the report works, not a measurement.
    pub quick: bool,
    /// Only the library's tables and the skips section: leaves out the sections that run the
    /// command line's release build (gdal_grid end to end, streaming), for a machine that has
    /// the report's binary and nothing else.
    pub tables_only: bool,
    pub out_dir: std::path::PathBuf,
}

struct Case {
    name: String,
    scene: Scene,
    grid: Grid,
    /// Run gdal_grid on the scene's vertices (its Delaunay triangulation is the scene's mesh).
    gdal: bool,
}

impl Case {
    fn new(name: impl Into<String>, scene: Scene, grid: Grid, gdal: bool) -> Self {
        Case { name: name.into(), scene, grid, gdal }
    }

    fn cells(&self) -> u64 {
        self.grid.pixel_count()
    }
}

/// One measured line of the report.
pub struct Row {
    pub case: String,
    /// `tileraster cpu`, `tileraster gpu`, `render pipeline`, `gdal_grid`.
    pub engine: String,
    pub mode: String,
    pub cells: u64,
    pub triangles: usize,
    pub time: Timing,
    /// Median time of filling the same raster with a constant on the same device.
    pub roofline_s: Option<f64>,
    pub accuracy: Option<Accuracy>,
    /// CPU and GPU rasters bit-identical (tileraster rows only).
    pub identical: Option<bool>,
}

fn micro_grid(size: u32, triangle_px: f64) -> Case {
    let (scene, grid) = scenes::micro_triangles(size, triangle_px, 7);
    Case::new(format!("micro-triangles {triangle_px} px, {size}²"), scene, grid, false)
}

fn cases(quick: bool) -> Vec<Case> {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let unit = Grid::new(0.0, 1.0, 0.0, 1.0, 1, 1);
    let plane_sizes: &[u32] = if quick { &[512, 1024] } else { &[512, 1024, 2048, 4096, 8192] };
    let mut cases: Vec<Case> = plane_sizes
        .iter()
        .map(|&n| Case::new(format!("plane, 2 triangles, {n}²"), scenes::sloping_plane(), Grid { width: n, height: n, ..unit }, false))
        .collect();
    // ~100k points: a 315 × 315-cell lattice has 316² = 99,856 vertices.
    let (cols, tin_sizes): (u32, &[u32]) = if quick { (60, &[256, 1024]) } else { (315, &[1024, 4096]) };
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, cols, cols, 2026);
    for &n in tin_sizes {
        let grid = Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, n, n);
        let points = tin.vertices.len();
        cases.push(Case::new(format!("terrain TIN, {points} points, {n}²"), tin.clone(), grid, true));
    }
    let micro_size = if quick { 128 } else { 512 };
    for px in [0.25, 1.0, 4.0] {
        cases.push(micro_grid(micro_size, px));
    }
    let sliver_grid = Grid::new(0.0, 1024.0, 0.0, 256.0, 1024, 256);
    cases.push(Case::new("slivers, 2000 × 0.1 px wedge", scenes::sliver_wedge(&sliver_grid, 2000, 0.1, 4), sliver_grid, false));
    let mut rough = scenes::delaunay_terrain(x0, y0, 2000.0, 2000.0, 200, 200, 13);
    let mut rng = scenes::Rng::new(13);
    for v in &mut rough.vertices {
        v[2] = rng.range(0.0, 1000.0);
    }
    let utm_size = if quick { 256 } else { 2048 };
    let utm_grid = Grid::new(x0, x0 + 2000.0, y0, y0 + 2000.0, utm_size, utm_size);
    cases.push(Case::new(format!("rough TIN at UTM coordinates, {utm_size}²"), rough, utm_grid, true));
    cases
}

/// The times of `runs` calls after one warm-up, and the last call's result. Each call's result
/// is dropped before the next call, as a caller's loop over tiles or files does: a call made
/// while the previous one's raster is still held measured up to twice as long here (fresh
/// memory to fault in), for every engine alike.
pub(crate) fn timed<T>(runs: usize, mut f: impl FnMut() -> Result<T, String>) -> Result<(Timing, T), String> {
    let mut last = Some(f()?);
    let mut times = Vec::with_capacity(runs);
    for _ in 0..runs {
        drop(last.take());
        let start = Instant::now();
        last = Some(f()?);
        times.push(start.elapsed().as_secs_f64());
    }
    Ok((Timing::of(times), last.expect("at least the warm-up ran")))
}

fn runs_for(cells: u64, quick: bool) -> usize {
    match (quick, cells) {
        (true, _) => 2,
        (false, c) if c >= 4096 * 4096 => 3,
        _ => 5,
    }
}

/// A peer's values as a raster shaped like `like`, for the same accuracy measure.
fn as_raster(values: Vec<f32>, like: &Raster) -> Raster {
    Raster {
        grid: like.grid,
        window: like.window,
        nodata: like.nodata,
        values,
        owner: None,
        coverage: None,
        colours: None,
        faces: None,
        tiles: None,
        snap_bits: like.snap_bits,
        stats: Default::default(),
    }
}

/// Everything measured, plus what the header needs.
pub struct Report {
    pub rows: Vec<Row>,
    pub adapter: Option<String>,
    /// What the adapter reports of IEEE-754 float controls.
    pub float_controls: Option<String>,
    pub gdal: Option<String>,
    pub notes: Vec<String>,
    /// The skips section (`skip_report`).
    pub skips: String,
    /// The render pipeline against wgpu's render pipeline (`render_report`).
    pub render: String,
    /// Points in, GeoTIFF out, against gdal_grid (`gdal_report`).
    pub end_to_end: crate::gdal_report::EndToEnd,
    /// The cluster recipe run locally, and a grid larger than its memory (`stream_report`).
    pub streaming: String,
}

pub fn run(options: &Options) -> Result<Report, String> {
    let adapter = tileraster::gpu_adapter();
    let float_controls = adapter.as_ref().ok().map(|a| a.float_controls.to_string());
    let adapter = adapter.map(|a| a.to_string());
    let mut notes = Vec::new();
    if let Err(e) = &adapter {
        notes.push(format!("GPU rows left out: {e}"));
    }
    let adapter = adapter.ok();
    let mut render = match RenderPipeline::new() {
        Ok(r) => Some(r),
        Err(e) => {
            notes.push(format!("render-pipeline rows left out: {e}"));
            None
        }
    };
    let mut gpu_fill = GpuFill::new().map_err(|e| notes.push(format!("GPU roofline left out: {e}"))).ok();
    let gdal = gdal_grid_version();
    if gdal.is_none() {
        notes.push("gdal_grid is not installed here: its rows are left out (Debian: apt install gdal-bin).".into());
    }
    let workdir = std::env::temp_dir().join(format!("tileraster-bench-{}", std::process::id()));

    let empty = Scene::new(Vec::new(), Vec::new());
    let mut rows = Vec::new();
    for case in cases(options.quick) {
        eprintln!("{} ...", case.name);
        let runs = runs_for(case.cells(), options.quick);
        let cells = case.cells() as usize;
        let triangles = case.scene.triangles.len();
        let reference = Reference::new(&case.scene, &case.grid);
        // A limit is best estimated by the fastest of many runs: a slow one measures the
        // machine's noise. Filling is cheap, so it gets three times the runs.
        let roof_runs = 3 * runs;
        let cpu_roof = timed(roof_runs, || Ok(fill_cpu(cells, NODATA)))?.0.min;
        // The GPU roofline is the faster of two ways to hand the host a constant raster: a
        // compute-shader fill, and a render pass that only clears (the render pipeline peer
        // with no triangles). Either alone can be slower than a whole call of some engine.
        let mut fastest = |how: &str, timing: Option<Result<Timing, String>>| match timing? {
            Ok(t) => Some(t.min),
            Err(e) => {
                notes.push(format!("{}: GPU roofline ({how}) failed: {e}", case.name));
                None
            }
        };
        let compute_fill = fastest("compute fill", gpu_fill.as_mut().map(|fill| timed(roof_runs, || fill.fill(cells, NODATA)).map(|(t, _)| t)));
        let render_clear =
            fastest("render-pass clear", render.as_mut().map(|render| timed(roof_runs, || render.rasterise(&empty, &case.grid, NODATA)).map(|(t, _)| t)));
        let gpu_roof = match (compute_fill, render_clear) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        let row = |engine: &str, mode: &str, time: Timing, roofline_s: Option<f64>, acc: Option<Accuracy>, identical: Option<bool>| Row {
            case: case.name.clone(),
            engine: engine.into(),
            mode: mode.into(),
            cells: case.cells(),
            triangles,
            time,
            roofline_s,
            accuracy: acc,
            identical,
        };

        let mut template: Option<Raster> = None;
        for mode in Mode::ALL {
            let params = Params::new(case.grid).with_nodata(NODATA).with_mode(mode);
            let go = |backend| timed(runs, || rasterise(&case.scene, &params, backend).map_err(|e| e.to_string()));
            let (cpu_s, cpu) = go(Backend::Cpu)?;
            let gpu = if adapter.is_some() {
                match go(Backend::Gpu) {
                    Ok(r) => Some(r),
                    Err(e) => {
                        notes.push(format!("{} [{}]: GPU failed: {e}", case.name, mode.name()));
                        None
                    }
                }
            } else {
                None
            };
            let identical = gpu.as_ref().map(|(_, g)| cpu.compare_bits(g, 0).0 == 0);
            rows.push(row("tileraster cpu", mode.name(), cpu_s, Some(cpu_roof), Some(accuracy(&cpu, &reference)), identical));
            if let Some((gpu_s, g)) = gpu {
                rows.push(row("tileraster gpu", mode.name(), gpu_s, gpu_roof, Some(accuracy(&g, &reference)), identical));
            }
            template.get_or_insert(cpu);
        }
        let template = template.expect("at least one mode ran");

        if let Some(render) = render.as_mut() {
            match timed(runs, || render.rasterise(&case.scene, &case.grid, NODATA)) {
                Ok((t, values)) => {
                    let acc = accuracy(&as_raster(values, &template), &reference);
                    rows.push(row("render pipeline", "f32 hardware", t, gpu_roof, Some(acc), None));
                }
                Err(e) => notes.push(format!("{}: render pipeline failed: {e}", case.name)),
            }
        }
        if case.gdal && gdal.is_some() {
            // One warm-up and fewer runs: gdal_grid is slow at these sizes.
            let gdal_runs = if options.quick { 1 } else { 3 };
            let mut times = Vec::new();
            let mut last = None;
            for _ in 0..gdal_runs {
                let (values, seconds) = gdal_grid_linear(&case.scene.vertices, &case.grid, NODATA, &workdir)?;
                times.push(seconds);
                last = Some(values);
            }
            let acc = accuracy(&as_raster(last.expect("ran"), &template), &reference);
            rows.push(row("gdal_grid", "linear", Timing::of(times), Some(cpu_roof), Some(acc), None));
        }
    }
    let _ = std::fs::remove_dir_all(&workdir);
    let skips = crate::skip_report::run(options.quick)?;
    let render = crate::render_report::run(options.quick)?;
    let left_out = || "Not in this run (`--tables-only`).\n".to_string();
    let end_to_end = match (options.tables_only, options.quick) {
        (true, _) => crate::gdal_report::EndToEnd { markdown: left_out(), goals: "- Points → DEM end to end: not in this run (`--tables-only`).\n".into() },
        (false, true) => crate::gdal_report::run(10_000, 1024)?,
        (false, false) => crate::gdal_report::run(100_000, 4096)?,
    };
    let streaming = match (options.tables_only, options.quick) {
        (true, _) => left_out(),
        (false, true) => crate::stream_report::run(10_000, 2048, 256)?,
        (false, false) => crate::stream_report::run(100_000, 32_768, 1536)?,
    };
    Ok(Report { rows, adapter, float_controls, gdal, notes, skips, render, end_to_end, streaming })
}

/// Writes the tables and the plot.
pub fn write(report: &Report, options: &Options) -> Result<(), String> {
    std::fs::create_dir_all(&options.out_dir).map_err(|e| format!("creating {}: {e}", options.out_dir.display()))?;
    let md = markdown(report);
    let svg = svg::time_vs_error(&report.rows);
    for (name, text) in [("benchmarks.md", md), ("time-vs-error.svg", svg)] {
        let path = options.out_dir.join(name);
        let tmp = options.out_dir.join(format!(".{name}.tmp"));
        std::fs::write(&tmp, text).map_err(|e| format!("writing {}: {e}", tmp.display()))?;
        std::fs::rename(&tmp, &path).map_err(|e| format!("renaming to {}: {e}", path.display()))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|s| s.lines().find(|l| l.starts_with("model name")).map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string()))
        .unwrap_or_else(|| "unknown CPU".into())
}

fn fmt_ulps(v: f64) -> String {
    if v >= 1e4 { format!("{v:.2e}") } else { format!("{v:.3}") }
}

fn markdown(report: &Report) -> String {
    let mut s = String::new();
    let date = crate::today();
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(1);
    let _ = writeln!(s, "# Benchmarks: run time against error\n");
    let _ = writeln!(s, "Written by `cargo xtask bench-report` on {date}. Do not edit by hand: run it again.\n");
    let _ = writeln!(s, "- Machine: {} ({cores} cores)", cpu_model());
    let _ = writeln!(s, "- GPU adapter: {}", report.adapter.as_deref().unwrap_or("none"));
    if let Some(controls) = &report.float_controls {
        let _ = writeln!(s, "- GPU float controls: {controls}");
    }
    let _ = writeln!(s, "- gdal_grid: {}", report.gdal.as_deref().unwrap_or("not installed"));
    for n in &report.notes {
        let _ = writeln!(s, "- Note: {n}");
    }
    let _ = writeln!(
        s,
        "\nEach time is the median of several whole calls after a warm-up (preparation, upload and read-back \
         included, each call's result dropped before the next; gdal_grid: the process from start to exit). *Roofline* is the share of the time that filling \
         the same raster with a constant takes on the same device (allocation and read-back included; the fastest \
         of three times as many runs; on the GPU the faster of a compute-shader fill and a render pass that only clears), so 100 % means \
         the store bandwidth limit. Errors are against an f64 evaluation of the plane through the unsnapped \
         vertices at each cell centre (`tileraster_testkit::reference`), in units of the f32 spacing there; *exact* is \
         the share of cells equal to that value rounded to f32. *Coverage* counts cells covered by exactly one of \
         raster and reference. *CPU = GPU* says whether the two backends gave the same bits. *Spread* is the \
         slowest timed run against the fastest: two rows whose medians differ by less than their spreads are \
         not known to differ.\n"
    );
    let _ = writeln!(s, "![time against error](time-vs-error.svg)\n");
    let _ = writeln!(s, "{}", goals(report));
    let _ = writeln!(
        s,
        "## Points in, GeoTIFF out, against gdal_grid\n\n`cargo xtask gdal-report` (the release build of the command line, `cargo build --release --bin tileraster`).\n\n{}",
        report.end_to_end.markdown
    );
    let _ = writeln!(
        s,
        "## Any raster size, and the cluster recipe\n\n`cargo xtask stream-report` (the same release build; recipes in [cluster.md](cluster.md)).\n\n{}",
        report.streaming
    );
    let _ = writeln!(s, "{}", report.skips);
    let _ = writeln!(s, "## 3D rendering, against the render pipeline\n\n`cargo xtask render-report`.\n\n{}", report.render);
    let _ = writeln!(s, "## Run time against error\n");
    let mut case = String::new();
    for r in &report.rows {
        if r.case != case {
            case = r.case.clone();
            let _ = writeln!(s, "\n### {case}\n\n{} cells, {} triangles\n", r.cells, r.triangles);
            let _ = writeln!(s, "| engine | mode | median | spread | Mpixel/s | Mtriangle/s | roofline | max ulp | RMS ulp | exact | coverage | CPU = GPU |");
            let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | :---: |");
        }
        let roof = r.roofline_s.map(|t| format!("{:.0} %", 100.0 * t / r.time.median)).unwrap_or_else(|| "–".into());
        let (max, rms, exact, cov) = match &r.accuracy {
            Some(a) => (fmt_ulps(a.max_ulps), fmt_ulps(a.rms_ulps), format!("{:.4} %", 100.0 * a.share_exact()), a.coverage_mismatches.to_string()),
            None => ("–".into(), "–".into(), "–".into(), "–".into()),
        };
        let identical = match r.identical {
            Some(true) => "yes",
            Some(false) => "**no**",
            None => "–",
        };
        let _ = writeln!(
            s,
            "| {} | {} | {:.2} ms | {:.0} % | {:.0} | {:.2} | {roof} | {max} | {rms} | {exact} | {cov} | {identical} |",
            r.engine,
            r.mode,
            r.time.median * 1e3,
            100.0 * r.time.spread(),
            r.cells as f64 / r.time.median / 1e6,
            r.triangles as f64 / r.time.median / 1e6,
        );
    }
    s
}

fn find<'a>(report: &'a Report, case_prefix: &str, case_suffix: &str, engine: &str, mode: &str) -> Option<&'a Row> {
    report.rows.iter().find(|r| r.case.starts_with(case_prefix) && r.case.ends_with(case_suffix) && r.engine == engine && r.mode == mode)
}

/// The goals the project reports against, with what this run measured.
fn goals(report: &Report) -> String {
    let mut s = String::from("## Goals\n\n");
    match find(report, "plane", "4096²", "tileraster cpu", "exact") {
        Some(r) => {
            let gpx = r.cells as f64 / r.time.median / 1e9;
            let roof = r.roofline_s.map(|t| t / r.time.median).unwrap_or(0.0);
            let _ = writeln!(
                s,
                "- CPU, exact mode, 4096² plane: **{gpx:.2} Gpixel/s** (runs {:.2} to {:.2}; goal ≥ 1: {}), **{:.0} %** of the roofline (goal ≥ 50 %: {}).",
                r.cells as f64 / r.time.max / 1e9,
                r.cells as f64 / r.time.min / 1e9,
                if gpx >= 1.0 { "met" } else { "not met" },
                100.0 * roof,
                if roof >= 0.5 { "met" } else { "not met" }
            );
        }
        None => s.push_str("- 4096² plane not in this run.\n"),
    }
    let mut ratios = Vec::new();
    for cpu in report.rows.iter().filter(|r| r.engine == "tileraster cpu") {
        if let Some(gpu) = report.rows.iter().find(|g| g.engine == "tileraster gpu" && g.case == cpu.case && g.mode == cpu.mode) {
            ratios.push(gpu.time.median / cpu.time.median);
        }
    }
    if let (Some(min), Some(max)) = (ratios.iter().cloned().reduce(f64::min), ratios.iter().cloned().reduce(f64::max)) {
        let adapter = report.adapter.as_deref().unwrap_or("the GPU adapter");
        let _ = write!(s, "- The same kernels on {adapter} take {min:.2}× to {max:.2}× the CPU backend's time over all {} scene × mode pairs", ratios.len());
        // On a software adapter the CPU backend is expected to win: it runs the kernels natively.
        if adapter.contains("llvmpipe") {
            let _ = write!(s, " (goal: the CPU backend faster than lavapipe: {})", if min > 1.0 { "met" } else { "not met" });
        }
        s.push_str(".\n");
    }
    // Small triangles and the TIN against the render pipeline on the same adapter, same run.
    let met = |ok: bool| if ok { "met" } else { "not met" };
    match (find(report, "terrain TIN", "4096²", "tileraster cpu", "exact"), find(report, "terrain TIN", "4096²", "render pipeline", "f32 hardware")) {
        (Some(cpu), Some(render)) => {
            let (ms, ratio) = (cpu.time.median * 1e3, render.time.median / cpu.time.median);
            let _ = writeln!(
                s,
                "- Terrain TIN → 4096², CPU, exact mode: **{ms:.1} ms** ({:.0} Mpixel/s; goal ≤ 40 ms: {}), **{ratio:.2}×** the render pipeline's speed ({:.1} ms; goal ≥ 3×: {}).",
                cpu.cells as f64 / cpu.time.median / 1e6,
                met(ms <= 40.0),
                render.time.median * 1e3,
                met(ratio >= 3.0)
            );
        }
        _ => s.push_str("- The 4096² terrain TIN against the render pipeline is not in this run.\n"),
    }
    for case in
        report.rows.iter().filter(|r| r.engine == "tileraster cpu" && r.mode == "exact" && (r.case.starts_with("micro") || r.case.starts_with("slivers")))
    {
        let Some(render) = report.rows.iter().find(|r| r.engine == "render pipeline" && r.case == case.case) else { continue };
        let mtri = |r: &Row| r.triangles as f64 / r.time.median / 1e6;
        let _ = writeln!(
            s,
            "- {}, CPU, exact mode: **{:.1} Mtri/s** against the render pipeline's {:.1} ({:.2} ms against {:.2} ms): **{:.2}×** (goal: ahead: {}).",
            case.case,
            mtri(case),
            mtri(render),
            case.time.median * 1e3,
            render.time.median * 1e3,
            render.time.median / case.time.median,
            met(case.time.median < render.time.median)
        );
    }
    // Marginal cost per extra cell: the TIN at two grid sizes.
    let tin: Vec<&Row> = report.rows.iter().filter(|r| r.case.starts_with("terrain TIN")).collect();
    let marginal = |engine: &str, mode: &str| -> Option<f64> {
        let mut rs: Vec<&&Row> = tin.iter().filter(|r| r.engine == engine && r.mode == mode).collect();
        rs.sort_by_key(|r| r.cells);
        let (a, b) = (rs.first()?, rs.last()?);
        (b.cells > a.cells).then(|| (b.time.median - a.time.median) / (b.cells - a.cells) as f64)
    };
    match (marginal("tileraster cpu", "exact"), marginal("gdal_grid", "linear")) {
        (Some(ours), Some(gdal)) => {
            let _ = writeln!(
                s,
                "- Cost per extra cell on the terrain TIN: tileraster CPU {:.2} ns, gdal_grid {:.2} ns: **{:.1}× cheaper** (goal ≥ 10×: {}).",
                ours * 1e9,
                gdal * 1e9,
                gdal / ours,
                if gdal / ours >= 10.0 { "met" } else { "not met" }
            );
        }
        _ => s.push_str("- gdal_grid comparison not in this run.\n"),
    }
    s.push_str(&report.end_to_end.goals);
    s
}
