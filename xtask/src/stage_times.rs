//! `cargo xtask stage-times`: where a call's time goes, pass by pass, on the scenes the
//! small-triangle goals name and on the render pipeline's benchmark meshes.
//!
//! - CPU backend: preparation (the render pipeline's geometry stages), the plan, then each
//!   stage of the pipeline's rows of the table as the CPU executor runs it
//!   (`tileraster_cpu::rasterise_observed`; the raster's allocation counts with the first
//!   stage).
//! - GPU backend: the device time of each stage from timestamp queries written around its
//!   compute passes (summed over the call's windows), the whole call's wall time (upload,
//!   dispatches, waits and read-back included), and what the call moved: dispatches,
//!   submissions, waits for the device, bytes up and down (`tileraster_gpu::rasterise_profiled`).
//!   Each call is a fresh one: the scene is uploaded and set up in it.
//!
//! Medians of several calls, each call's result dropped before the next.

use std::fmt::Write;
use std::time::Instant;
use tileraster::render::{Camera, Cull, Eye, GeometryPass, IDENTITY, Mesh, Projection, RenderParams, Shading, Up, prepare_render_observed};
use tileraster::{Backend, Grid, Params, Prepared, Scene};
use tileraster_core::kernels::pipeline::{Pipeline, raster_stages};
use tileraster_testkit::{meshes, scenes};

/// A scene to time: a heightfield onto a grid, or a mesh in perspective.
enum Case {
    Height(Scene, Grid),
    Render(Mesh, Box<RenderParams>),
}

impl Case {
    /// The prepared scene, a mesh's geometry stages run on `backend`, and the time of each pass
    /// of [`Self::preparation`] (ms).
    /// The case prepared on `backend` (a render's geometry stages on the backend's kernels,
    /// returned: the GPU's hold the frame's records for its call), with each pass's time (ms).
    fn prepare_timed(&self, backend: Backend) -> Result<(Prepared, Option<tileraster_gpu::GeometryDevice>, Vec<f64>), String> {
        let text = |e: tileraster::Error| e.to_string();
        let mut clock = Instant::now();
        let mut laps = Vec::new();
        let mut lap = || {
            laps.push(clock.elapsed().as_secs_f64() * 1e3);
            clock = Instant::now();
        };
        let mut device = None;
        let prepared = match (self, backend) {
            (Case::Height(scene, grid), _) => tileraster::prepare(scene, &Params::new(*grid), None).map_err(text)?,
            (Case::Render(mesh, params), Backend::Cpu) => prepare_render_observed(mesh, params, backend, &mut |_| lap()).map(|(p, _)| p).map_err(text)?,
            (Case::Render(mesh, params), Backend::Gpu) => {
                let kernels = device.insert(tileraster_gpu::GeometryDevice::default());
                tileraster_core::render::prepare_render_observed(mesh, params, kernels, &mut |_| lap()).map(|(p, _)| p).map_err(text)?
            }
        };
        if let Case::Height(..) = self {
            lap();
        }
        if laps.len() != self.preparation().len() {
            return Err(format!("the preparation reported {} passes of {}", laps.len(), self.preparation().len()));
        }
        Ok((prepared, device, laps))
    }

    /// The columns of the host's preparation: the geometry stages' passes for a mesh, one for a
    /// heightfield.
    fn preparation(&self) -> Vec<&'static str> {
        match self {
            Case::Height(..) => vec!["prepare"],
            Case::Render(..) => GeometryPass::ALL.iter().map(|p| p.name()).collect(),
        }
    }

    fn pipeline(&self) -> Pipeline {
        match self {
            Case::Height(..) => Pipeline::Height,
            Case::Render(_, params) if params.samples > 1 => Pipeline::RenderMultisampled,
            Case::Render(..) => Pipeline::Render,
        }
    }
}

fn cases() -> Result<Vec<(String, Case)>, String> {
    let mut cases = Vec::new();
    for px in [0.25, 1.0, 4.0] {
        let (scene, grid) = scenes::micro_triangles(512, px, 7);
        cases.push((format!("micro-triangles {px} px, 512²"), Case::Height(scene, grid)));
    }
    let sliver_grid = Grid::new(0.0, 1024.0, 0.0, 256.0, 1024, 256);
    cases.push(("slivers, 2000 × 0.1 px wedge".into(), Case::Height(scenes::sliver_wedge(&sliver_grid, 2000, 0.1, 4), sliver_grid)));
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, 315, 315, 2026);
    cases.push(("terrain TIN, 99856 points, 4096²".into(), Case::Height(tin, Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, 4096, 4096))));
    let mesh = meshes::terrain(224, 1000.0, 60.0);
    let camera = Camera::framing(&mesh, 1920.0 / 1080.0, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
    let base = RenderParams { eye: Some(camera.viewer()), ..RenderParams::new(1920, 1080, camera.view_projection(1920, 1080).map_err(|e| e.to_string())?) };
    for shading in [Shading::Ids, Shading::Smooth, Shading::Phong] {
        cases.push((
            format!("render: terrain mesh, 100352 triangles, 1920×1080, {}", shading.name()),
            Case::Render(mesh.clone(), Box::new(RenderParams { shading, ..base.clone() })),
        ));
    }
    cases.push((
        "render: terrain mesh, ids, fragments not counted".into(),
        Case::Render(mesh.clone(), Box::new(RenderParams { shading: Shading::Ids, count_fragments: false, ..base.clone() })),
    ));
    let fill = RenderParams { cull: Cull::None, eye: Some(Eye::Point([0.0, 0.0, -1.0])), shading: Shading::Ids, ..RenderParams::new(1920, 1080, IDENTITY) };
    cases.push(("render: fill rate, 8 full-frame layers, 1920×1080, ids".into(), Case::Render(meshes::fill_layers(8), Box::new(fill.clone()))));
    // What the render pipeline computes: no fragment counts, so the hidden layers get no tests.
    let uncounted = RenderParams { count_fragments: false, ..fill };
    cases.push(("render: fill rate, 8 layers, ids, fragments not counted".into(), Case::Render(meshes::fill_layers(8), Box::new(uncounted.clone()))));
    // As the render pipeline it is measured against reads it back: the ids alone.
    let ids_alone = RenderParams { return_colour: false, return_depth: false, ..uncounted.clone() };
    cases.push(("render: fill rate, 8 layers, the ids alone".into(), Case::Render(meshes::fill_layers(8), Box::new(ids_alone))));
    // The same frame's visible work alone: what the seven hidden layers cost beside it.
    cases.push(("render: fill rate, 1 layer, ids, fragments not counted".into(), Case::Render(meshes::fill_layers(1), Box::new(uncounted))));
    cases.extend(report_cases(&mesh, &base)?);
    Ok(cases)
}

/// The render report's other scenes, one mode each: textures, lines, points, the fragment
/// stage and multisampling.
fn report_cases(terrain: &Mesh, base: &RenderParams) -> Result<Vec<(String, Case)>, String> {
    use tileraster::render::{Address, Filter, LineRule, Wireframe, edges};
    let mut cases = Vec::new();
    let plane = meshes::textured_plane(64, 1024);
    let [eye, target, up] = meshes::TEXTURED_PLANE_EYE;
    let camera = Camera { eye, target, up, projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.5, far: 200.0 };
    let textured = RenderParams {
        shading: Shading::Unlit,
        cull: Cull::None,
        eye: Some(Eye::Point(eye)),
        count_fragments: false,
        texture_filter: Some(Filter::Trilinear),
        texture_address: Some(Address::Repeat),
        ..RenderParams::new(1920, 1080, camera.view_projection(1920, 1080).map_err(|e| e.to_string())?)
    };
    cases.push((format!("render: textured plane, {} triangles, trilinear", plane.triangles.len()), Case::Render(plane, Box::new(textured))));
    let lines = RenderParams {
        shading: Shading::Ids,
        faces: false,
        wireframe: Some(Wireframe { rule: LineRule::Rectangle, colour: None }),
        count_fragments: false,
        ..base.clone()
    };
    let name = format!("render: wireframe, {} edges, rectangle rule", edges(&terrain.triangles).len());
    cases.push((name, Case::Render(terrain.clone(), Box::new(lines))));
    let points = RenderParams { shading: Shading::Ids, faces: false, points: Some(1.0), count_fragments: false, ..base.clone() };
    cases.push((format!("render: points 1 px, {} vertices", terrain.positions.len()), Case::Render(terrain.clone(), Box::new(points))));
    let marble_mesh = procedural::scene();
    let marble = procedural::params(&marble_mesh, 1920, 1080).map_err(|e| e.to_string())?;
    cases.push((format!("render: marble fragment shader, {} triangles", marble_mesh.triangles.len()), Case::Render(marble_mesh, Box::new(marble))));
    // The waves posed by the vertex shader, beside the same sea posed beforehand and drawn
    // without one: what posing costs each stage.
    let sea = waves::sea(384);
    let posing = waves::params(&sea, 1920, 1080, 4.0).map_err(|e| e.to_string())?;
    let posed = Mesh { positions: tileraster::render::posed_positions(&sea, &posing).map_err(|e| e.to_string())?, ..sea.clone() };
    let triangles = sea.triangles.len();
    cases.push((format!("render: waves vertex shader, {triangles} triangles"), Case::Render(sea, Box::new(posing.clone()))));
    cases.push((format!("render: waves posed beforehand, {triangles} triangles"), Case::Render(posed, Box::new(RenderParams { vertex: None, ..posing }))));
    for shading in [Shading::Ids, Shading::Phong] {
        let msaa = RenderParams { shading, samples: 4, ..base.clone() };
        cases.push((format!("render: terrain mesh, 4 samples, {}", shading.name()), Case::Render(terrain.clone(), Box::new(msaa))));
    }
    Ok(cases)
}

/// Milliseconds of one call: preparation (a mesh's by the geometry stages' passes), plan, each
/// stage of the pipeline in order (0 for a stage the frame does not run, such as `fine_small`
/// without small triangles), total.
fn one_call(case: &Case) -> Result<Vec<f64>, String> {
    let text = |e: tileraster::Error| e.to_string();
    let rows: Vec<_> = raster_stages(case.pipeline()).map(|info| info.stage).collect();
    let (prepared, _, mut laps) = case.prepare_timed(Backend::Cpu)?;
    let mut clock = Instant::now();
    let mut lap = || {
        let ms = clock.elapsed().as_secs_f64() * 1e3;
        clock = Instant::now();
        ms
    };
    let plan = prepared.plan(prepared.window, false).map_err(text)?;
    laps.push(lap());
    let mut stage_ms = vec![0.0; rows.len()];
    let mut unknown = None;
    let raster = tileraster_cpu::rasterise_observed(&prepared, &plan, &mut |stage| match rows.iter().position(|&s| s == stage) {
        Some(k) => stage_ms[k] += lap(),
        None => unknown = Some(stage),
    })
    .map_err(text)?;
    drop(raster);
    if let Some(stage) = unknown {
        return Err(format!("stage {} ran outside its pipeline", stage.name()));
    }
    laps.extend(stage_ms);
    laps.push(laps.iter().sum());
    Ok(laps)
}

/// One GPU call: its profile, the host's preparation pass by pass ([`Case::preparation`]) and
/// the call's wall time (ms).
fn one_gpu_call(case: &Case) -> Result<(tileraster_gpu::CallProfile, Vec<f64>, f64), String> {
    let (prepared, device, laps) = case.prepare_timed(Backend::Gpu)?;
    let plan = prepared.plan(prepared.window, false).map_err(|e| e.to_string())?;
    let start = Instant::now();
    let (raster, profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, true, device.as_ref()).map_err(|e| e.to_string())?;
    let ms = start.elapsed().as_secs_f64() * 1e3;
    drop(raster);
    Ok((profile, laps, ms))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Which backends a report times.
#[derive(Clone, Copy, PartialEq, Eq)]
pub enum Backends {
    Cpu,
    Gpu,
    Both,
}

/// The tables, over the cases whose name contains `only` (all of them without it), each row
/// the medians of `runs` calls (`None`: the backend's default, 15 on the CPU and 5 on the GPU).
pub fn run(only: Option<&str>, backends: Backends, runs: Option<usize>) -> Result<String, String> {
    let cases: Vec<(String, Case)> = cases()?.into_iter().filter(|(name, _)| only.is_none_or(|o| name.contains(o))).collect();
    let mut s = String::new();
    if backends != Backends::Gpu {
        s += &cpu_table(&cases, runs.unwrap_or(15))?;
    }
    if backends != Backends::Cpu {
        s += &gpu_table(&cases, runs.unwrap_or(5))?;
    }
    Ok(s)
}

/// A new table's header where the columns differ from the table's before.
fn table_header<'a>(s: &mut String, header: &mut Option<Vec<&'a str>>, names: &[&'a str]) {
    if header.as_deref() != Some(names) {
        let _ = writeln!(s, "\n| scene | {} |", names.join(" | "));
        let _ = writeln!(s, "| --- |{}", " ---: |".repeat(names.len()));
        *header = Some(names.to_vec());
    }
}

fn cpu_table(cases: &[(String, Case)], runs: usize) -> Result<String, String> {
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get());
    let mut s = format!("CPU backend ({threads} threads; heightfields in exact mode); median ms per pass of {runs} calls after a warm-up.\n");
    let mut header = None;
    for (name, case) in cases {
        let names: Vec<&str> =
            case.preparation().into_iter().chain(["plan"]).chain(raster_stages(case.pipeline()).map(|info| info.name)).chain(["total"]).collect();
        table_header(&mut s, &mut header, &names);
        one_call(case)?;
        let calls = (0..runs).map(|_| one_call(case)).collect::<Result<Vec<_>, _>>()?;
        let medians: Vec<String> = (0..names.len()).map(|k| format!("{:.1}", median(calls.iter().map(|c| c[k]).collect()))).collect();
        let _ = writeln!(s, "| {name} | {} |", medians.join(" | "));
        eprintln!("cpu: {name} done");
    }
    Ok(s)
}

fn gpu_table(cases: &[(String, Case)], runs: usize) -> Result<String, String> {
    let adapter = tileraster::gpu_adapter().map_err(|e| e.to_string())?;
    let mut s = format!(
        "\nGPU backend on {adapter}; median of {runs} calls after a warm-up. The host's preparation before the call, ms: *prepare* for a heightfield (its snapping and analysis), the geometry stages' passes for a mesh as in the CPU's table (*vertex* runs the kernels' vertex stage on the device, its upload and read-back included); the plan between it and the call is in neither. Stage columns: device time from timestamp queries, ms; *device* is their sum, *call* the whole call's wall time. The host's share of the call: *upload* hands the scene to the queue (copies into staging memory), *wait* runs from each read-back's submission until its buffer is mapped, and its unmapping (the submission itself, the device's work, the copies over the bus, the driver), *copy* takes the mapped read-back into the raster's layers, *rest* is the remainder (the context's lock, allocating the raster, recording passes, binding, the statistics, reading the timestamps back).\n"
    );
    let mut header = None;
    for (name, case) in cases {
        let rows: Vec<_> = raster_stages(case.pipeline()).collect();
        let preparation = case.preparation();
        let names: Vec<&str> = preparation
            .iter()
            .copied()
            .chain(rows.iter().map(|info| info.name))
            .chain(["device", "call", "upload", "wait", "copy", "rest", "dispatches", "submissions", "waits", "MB up", "MB down"])
            .collect();
        table_header(&mut s, &mut header, &names);
        one_gpu_call(case)?;
        let calls = (0..runs).map(|_| one_gpu_call(case)).collect::<Result<Vec<_>, _>>()?;
        let Some(_) = calls[0].0.stage_ms else {
            return Err(format!("{adapter} writes no timestamps: the GPU's stage times cannot be measured on it"));
        };
        let stage = |k: usize| median(calls.iter().map(|(p, _, _)| p.stage(rows[k].stage).unwrap_or(f64::NAN)).collect());
        let mut cells: Vec<String> = (0..preparation.len()).map(|k| format!("{:.1}", median(calls.iter().map(|(_, laps, _)| laps[k]).collect()))).collect();
        cells.extend((0..rows.len()).map(|k| format!("{:.1}", stage(k))));
        cells.push(format!("{:.1}", median(calls.iter().map(|(p, _, _)| rows.iter().map(|info| p.stage(info.stage).unwrap_or(0.0)).sum()).collect())));
        cells.push(format!("{:.1}", median(calls.iter().map(|(_, _, ms)| *ms).collect())));
        let host: [fn(&tileraster_gpu::CallProfile) -> f64; 3] = [|p| p.upload_ms, |p| p.wait_ms, |p| p.read_back_ms];
        cells.extend(host.iter().map(|f| format!("{:.1}", median(calls.iter().map(|(p, _, _)| f(p)).collect()))));
        cells.push(format!("{:.1}", median(calls.iter().map(|(p, _, ms)| ms - p.upload_ms - p.wait_ms - p.read_back_ms).collect())));
        let (p, _, _) = &calls[0];
        cells.extend([p.dispatches.to_string(), p.submissions.to_string(), p.waits.to_string()]);
        cells.extend([p.bytes_up, p.bytes_down].map(|b| format!("{:.2}", b as f64 / 1e6)));
        let _ = writeln!(s, "| {name} | {} |", cells.join(" | "));
        eprintln!("gpu: {name} done");
    }
    Ok(s)
}
