//! `cargo xtask render-report [--quick]`: the render pipeline's speed, side by side with wgpu's
//! render pipeline on the same adapter (`tileraster_peers::MeshPipeline`: a depth buffer, the
//! `Less` test, triangle ids written), all in one run. Also a section of `bench-report`.
//!
//! Each call is whole: tileraster's `render` (geometry stages, upload, kernels, read-back of
//! colour, depth, ids and fragment counts) against the peer's draw (vertex upload, one draw
//! call, read-back of the ids). tileraster runs with `Shading::Ids`, the peer's fragment work;
//! its Phong-shaded time is given too. The peer keeps its render target and buffers between
//! draws; so does tileraster's prepared form (`PreparedMesh::render_into`, its frames' memory
//! and output layers kept), timed beside the one-shot `render`.

use crate::Timing;
use crate::bench_report::timed;
use std::fmt::Write as _;
use tileraster::Backend;
use tileraster::render::{Camera, Cull, Eye, Frame, IDENTITY, Mesh, NO_FACE, PreparedMesh, Projection, RenderParams, Shading, Up, World, render, render_world};
use tileraster_peers::{MeshPipeline, NO_ID};
use tileraster_testkit::meshes;

struct Scene {
    name: String,
    mesh: Mesh,
    params: RenderParams,
}

fn scenes(quick: bool) -> Result<Vec<Scene>, String> {
    let mut out = Vec::new();
    let perspective = |mesh: &Mesh, w: u32, h: u32| -> Result<RenderParams, String> {
        let camera = Camera::framing(mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
        let mut params = RenderParams::new(w, h, camera.view_projection(w, h).map_err(|e| e.to_string())?);
        params.eye = Some(camera.viewer());
        // The peer's outputs: colour (or ids) and depth, no per-pixel fragment counts.
        params.count_fragments = false;
        Ok(params)
    };
    // 2·n² triangles: n = 224 gives 100,352, n = 708 gives 1,002,528.
    let sizes: &[(u32, u32, u32)] = if quick { &[(40, 320, 180)] } else { &[(224, 1920, 1080), (708, 4096, 4096)] };
    for &(n, w, h) in sizes {
        let mesh = meshes::terrain(n, 1000.0, 60.0);
        let params = perspective(&mesh, w, h)?;
        out.push(Scene { name: format!("terrain mesh, {} triangles, {w}×{h}", mesh.triangles.len()), mesh, params });
    }
    // Fill rate: eight full-frame layers of two triangles, drawn back to front (every layer
    // passes the depth test in the hardware pipeline): overdraw 8.
    let (w, h) = if quick { (320, 180) } else { (1920, 1080) };
    let mesh = meshes::fill_layers(8);
    let params = RenderParams { cull: Cull::None, eye: Some(Eye::Point([0.0, 0.0, -1.0])), count_fragments: false, ..RenderParams::new(w, h, IDENTITY) };
    out.push(Scene { name: format!("fill rate: 8 full-frame layers (16 triangles), back to front, {w}×{h}"), mesh, params });
    Ok(out)
}

/// The GPU backend's median for `params` beside the CPU's frame `cpu`, and whether its frame
/// has the same bits (the ids, and the colour and depth where `params` returns them; the tests
/// compare every layer); or no adapter.
fn gpu_cell(gpu: bool, runs: usize, mesh: &Mesh, params: &RenderParams, cpu: &Frame) -> Result<(String, &'static str), String> {
    if !gpu {
        return Ok(("no adapter".into(), "–"));
    }
    let (t, g) = timed(runs, || render(mesh, params, Backend::Gpu).map_err(|e| e.to_string()))?;
    let same = g.colour == cpu.colour && g.ids == cpu.ids && g.depth.iter().zip(&cpu.depth).all(|(a, b)| a.to_bits() == b.to_bits());
    Ok((ms(&t), if same { "yes" } else { "**NO**" }))
}

/// A framed mesh: the mesh, its camera, the view-projection and the frame's width and height.
type Framed = (Mesh, Camera, [[f64; 4]; 4], u32, u32);

/// The terrain mesh of the line and multisampling sections, framed.
fn framed_terrain(quick: bool) -> Result<Framed, String> {
    let (n, w, h) = if quick { (40, 320, 180) } else { (224, 1920, 1080) };
    let mesh = meshes::terrain(n, 1000.0, 60.0);
    let camera = Camera::framing(&mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
    let matrix = camera.view_projection(w, h).map_err(|e| e.to_string())?;
    Ok((mesh, camera, matrix, w, h))
}

fn ms(t: &Timing) -> String {
    format!("{:.1} ms (±{:.0} %)", t.median * 1e3, 50.0 * t.spread())
}

/// The section, in markdown.
pub fn run(quick: bool) -> Result<String, String> {
    let runs = if quick { 2 } else { 5 };
    let mut peer = MeshPipeline::new()?;
    let adapter = peer.adapter_name();
    let gpu = tileraster::gpu_adapter().ok();
    let mut s = String::new();
    let _ = writeln!(
        s,
        "Medians of {runs} whole calls after a warm-up. tileraster draws triangle ids (`--shading ids`, the same fragment work as the \
         peer; no per-pixel fragment counts, which the peer does not make either) and, in its own columns, Phong shading; \"prepared\" is `PreparedMesh::render_into`, which keeps the frames' memory and \
         output layers between calls as the peer keeps its render target and buffers (on either backend); the render pipeline is wgpu's on {adapter} with a Depth32Float buffer and the `Less` \
         test, writing R32Uint triangle ids. Both read the ids back to the host, and nothing else (tileraster's ids frames turn `return_colour` and `return_depth` off; its Phong frames return all three layers). \"ids agree\" is the share of pixels where \
         tileraster's CPU frame and the render pipeline name the same triangle. \"bytes handed over\" is `Stats::bytes_uploaded` (the \
         same figure on both backends) of a one-shot ids frame, of a prepared mesh's later ids frame and of its later Phong frame.\n"
    );
    let _ = writeln!(
        s,
        "| scene | tileraster cpu | cpu, prepared | cpu, phong | cpu, phong, prepared | tileraster gpu | gpu, prepared | render pipeline | cpu vs render pipeline (prepared) | gpu vs render pipeline (prepared) | cpu = gpu | ids agree | bytes handed over: once, prepared, prepared phong |"
    );
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: | ---: |");
    let mut notes = Vec::new();
    for scene in scenes(quick)? {
        // The ids alone come back, as the peer's: the colour and depth stay with the stages.
        let ids = RenderParams { shading: Shading::Ids, return_colour: false, return_depth: false, ..scene.params.clone() };
        let phong = RenderParams { shading: Shading::Phong, ..scene.params.clone() };
        let (cpu_time, cpu) = timed(runs, || render(&scene.mesh, &ids, Backend::Cpu).map_err(|e| e.to_string()))?;
        let (phong_time, _) = timed(runs, || render(&scene.mesh, &phong, Backend::Cpu).map_err(|e| e.to_string()))?;
        // The prepared form: one frame's memory and layers reused by every call; the memory the
        // CPU's one-shot calls kept is freed first, so that its frames do not run beside it.
        tileraster::render::release_memory();
        let mut prepared = PreparedMesh::new(scene.mesh.clone()).map_err(|e| e.to_string())?;
        let mut frame = Frame::default();
        let mut into = |params: &RenderParams, frame: &mut Frame| timed(runs, || prepared.render_into(params, Backend::Cpu, frame).map_err(|e| e.to_string()));
        let (prepared_time, ()) = into(&ids, &mut frame)?;
        if frame.ids != cpu.ids || frame.colour != cpu.colour {
            return Err(format!("{}: the prepared frame differs from render's", scene.name));
        }
        // What a later frame hands over (the same figure on both backends), and a one-shot frame.
        let uploads = [cpu.stats.raster.bytes_uploaded, frame.stats.raster.bytes_uploaded];
        let (prepared_phong_time, ()) = into(&phong, &mut frame)?;
        let uploads = [uploads[0], uploads[1], frame.stats.raster.bytes_uploaded];
        // A frame the GPU backend refuses (its limits) is reported, not fatal.
        let gpu_result = gpu.as_ref().map(|_| timed(runs, || render(&scene.mesh, &ids, Backend::Gpu).map_err(|e| e.to_string())));
        let mut gpu_frame = Frame::default();
        let gpu_prepared = match &gpu_result {
            Some(Ok(_)) => match timed(runs, || prepared.render_into(&ids, Backend::Gpu, &mut gpu_frame).map_err(|e| e.to_string())) {
                Ok((t, ())) => Some(t),
                Err(e) => {
                    notes.push(format!("{}: the GPU backend refused the prepared frame: {e}", scene.name));
                    None
                }
            },
            _ => None,
        };
        let positions: Vec<[f32; 3]> = scene.mesh.positions.iter().map(|p| p.map(|c| c as f32)).collect();
        let matrix = scene.params.view_projection.map(|r| r.map(|c| c as f32));
        let (w, h) = (scene.params.width, scene.params.height);
        let (peer_time, peer_ids) = timed(runs, || peer.draw_ids(&positions, &scene.mesh.triangles, &matrix, w, h, true))?;
        let agree = cpu.ids.iter().zip(&peer_ids).filter(|(a, b)| (**a == NO_FACE && **b == NO_ID) || a == b).count() as f64 / peer_ids.len() as f64;
        let same_bits = |g: &Frame| g.colour == cpu.colour && g.ids == cpu.ids && g.depth.iter().zip(&cpu.depth).all(|(a, b)| a.to_bits() == b.to_bits());
        let (gpu_cell, same) = match &gpu_result {
            Some(Ok((t, g))) => (ms(t), if same_bits(g) && (gpu_prepared.is_none() || same_bits(&gpu_frame)) { "yes" } else { "**NO**" }),
            Some(Err(e)) => {
                notes.push(format!("{}: the GPU backend refused the frame: {e}", scene.name));
                ("refused (see below)".into(), "–")
            }
            None => ("no adapter".into(), "–"),
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.2}× ({:.2}×) | {} | {} | {:.4} % | {}, {}, {} |",
            scene.name,
            ms(&cpu_time),
            ms(&prepared_time),
            ms(&phong_time),
            ms(&prepared_phong_time),
            gpu_cell,
            gpu_prepared.as_ref().map_or("–".into(), ms),
            ms(&peer_time),
            peer_time.median / cpu_time.median,
            peer_time.median / prepared_time.median,
            match (&gpu_result, &gpu_prepared) {
                (Some(Ok((t, _))), Some(p)) => format!("{:.2}× ({:.2}×)", peer_time.median / t.median, peer_time.median / p.median),
                _ => "–".into(),
            },
            same,
            100.0 * agree,
            uploads[0],
            uploads[1],
            uploads[2]
        );
        eprintln!("render-report: {} done", scene.name);
    }
    for n in notes {
        let _ = writeln!(s, "\n- {n}");
    }
    let _ = writeln!(
        s,
        "\nA ratio above 1 means tileraster's backend is ahead. The goals: the CPU backend at least 1 on the same cores as llvmpipe's graphics pipeline; the GPU backend at least 0.25 (within 4×) on lavapipe, and at least 0.5 (within 2×) against a hardware GPU's own pipeline."
    );
    s.push_str(&hidden_section(quick, runs, gpu.is_some())?);
    s.push_str(&instance_section(quick, runs, gpu.is_some())?);
    s.push_str(&texture_section(quick, runs, gpu.is_some())?);
    s.push_str(&line_section(quick, runs, gpu.is_some())?);
    s.push_str(&msaa_section(quick, runs, gpu.is_some())?);
    s.push_str(&fragment_section(quick, runs, gpu.is_some())?);
    Ok(s)
}

/// Only the programmable fragment stage's section, at full size.
pub fn fragment_only() -> Result<String, String> {
    fragment_section(false, 5, tileraster::gpu_adapter().is_ok())
}

/// `render-report --textures`: the textures section alone.
pub fn textures_only() -> Result<String, String> {
    texture_section(false, 5, tileraster::gpu_adapter().is_ok())
}

/// The programmable fragment stage: the procedural marble of `examples/procedural` against the
/// built-in Phong shading of the same frame, and against the same shader written in WGSL for
/// the render pipeline (`MarblePipeline`), timed side by side, with the colours compared.
fn fragment_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    let (w, h) = if quick { (320, 180) } else { (1920, 1080) };
    let mesh = procedural::scene();
    // Colour and ids back, no depth: the peer reads its colour back alone.
    let marble = RenderParams { return_depth: false, ..procedural::params(&mesh, w, h).map_err(|e| e.to_string())? };
    let phong = RenderParams { fragment: None, ..marble.clone() };
    let mut peer = tileraster_peers::MarblePipeline::new()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Programmable fragment stage\n\n\
         The marble of `examples/procedural` (three octaves of value noise and Blinn-Phong lighting, a user's `no_std` function: \
         [fragment-stage.md](fragment-stage.md)) on a sphere and a floor of {} triangles, {w}×{h}, against the built-in Phong shading of \
         the same frame, medians of {runs} whole calls. The render pipeline is wgpu's on {} running the same shader written in WGSL \
         (a depth buffer, the `Less` test, RGBA8 read back; tileraster returns colour and ids, not depth). \"differ\" is the share of covered pixels whose colour differs from \
         tileraster's CPU frame by more than one unit in a channel, and the largest difference.\n",
        mesh.triangles.len(),
        peer.adapter_name()
    );
    let _ = writeln!(s, "| shading | tileraster cpu | tileraster gpu | render pipeline | cpu vs render pipeline | cpu = gpu | differ (largest) |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | --- | ---: |");
    let (phong_time, phong_frame) = timed(runs, || render(&mesh, &phong, Backend::Cpu).map_err(|e| e.to_string()))?;
    let (gpu_cell_phong, same_phong) = gpu_cell(gpu, runs, &mesh, &phong, &phong_frame)?;
    let _ = writeln!(s, "| built-in Phong | {} | {gpu_cell_phong} | – | – | {same_phong} | – |", ms(&phong_time));
    let (cpu_time, cpu) = timed(runs, || render(&mesh, &marble, Backend::Cpu).map_err(|e| e.to_string()))?;
    let (gpu_cell, same) = gpu_cell(gpu, runs, &mesh, &marble, &cpu)?;
    let (peer_time, theirs) = timed(runs, || peer.draw(&mesh, &marble))?;
    let (differ, largest) = colour_difference(&cpu, &theirs);
    let _ = writeln!(
        s,
        "| marble (fragment shader) | {} | {gpu_cell} | {} | {:.2}× | {same} | {:.2} % ({largest}) |",
        ms(&cpu_time),
        ms(&peer_time),
        peer_time.median / cpu_time.median,
        100.0 * differ
    );
    eprintln!("render-report: fragment stage done");
    Ok(s)
}

/// Multisampling: the terrain mesh at 1, 4 and 8 samples per pixel, against the render
/// pipeline drawing it 4× multisampled (`MultisampledPipeline`, every sample read back).
fn msaa_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    use tileraster_peers::{MultisampledPipeline, PEER_SAMPLES};
    let (mesh, camera, matrix, w, h) = framed_terrain(quick)?;
    let mut peer = MultisampledPipeline::new()?;
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.map(|c| c as f32)).collect();
    let (peer_time, _) = timed(runs, || peer.draw_sample_ids(&positions, &mesh.triangles, &matrix.map(|r| r.map(|c| c as f32)), w, h))?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Multisampling\n\n\
         The terrain mesh of {} triangles, {w}×{h}, Phong-shaded, at 1, 4 and 8 samples per pixel (coverage and depth per sample, \
         each triangle shaded once per pixel, a box resolve), medians of {runs} whole calls. The render pipeline is wgpu's on {} \
         drawing the triangles' ids {PEER_SAMPLES}× multisampled with a depth buffer, every sample read back by a compute pass \
         ({PEER_SAMPLES} words a pixel, as tileraster hands back four layers); its samples are compared one by one in `tests/msaa.rs` \
         (0 of 1,310,720 differ).\n",
        mesh.triangles.len(),
        peer.adapter_name()
    );
    let _ = writeln!(s, "| samples | tileraster cpu | tileraster gpu | cpu vs 1 sample | render pipeline, {PEER_SAMPLES}× | cpu = gpu |");
    let _ = writeln!(s, "| ---: | ---: | ---: | ---: | ---: | --- |");
    let mut single = None;
    for samples in [1, 4, 8] {
        let params = RenderParams { shading: Shading::Phong, samples, eye: Some(camera.viewer()), ..RenderParams::new(w, h, matrix) };
        let (cpu_time, cpu) = timed(runs, || render(&mesh, &params, Backend::Cpu).map_err(|e| e.to_string()))?;
        let (gpu_cell, same) = gpu_cell(gpu, runs, &mesh, &params, &cpu)?;
        let base = *single.get_or_insert(cpu_time.median);
        let peer_cell = if samples == PEER_SAMPLES { ms(&peer_time) } else { "–".into() };
        let _ = writeln!(s, "| {samples} | {} | {gpu_cell} | {:.2}× | {peer_cell} | {same} |", ms(&cpu_time), cpu_time.median / base);
        eprintln!("render-report: msaa, {samples} samples done");
    }
    Ok(s)
}

/// The wireframe view against the render pipeline drawing the same edges as a line list
/// (`MeshPipeline::draw_line_ids`), timed side by side, with the share of lit pixels that only
/// one of the two lights.
fn line_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    use tileraster::render::{LineRule, Wireframe, edges};
    let (mesh, camera, matrix, w, h) = framed_terrain(quick)?;
    let lines = edges(&mesh.triangles);
    let positions: Vec<[f32; 3]> = mesh.positions.iter().map(|p| p.map(|c| c as f32)).collect();
    let matrix_f32 = matrix.map(|r| r.map(|c| c as f32));
    let mut peer = MeshPipeline::new()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Lines and points\n\n\
         The wireframe of a terrain mesh of {} triangles alone: {} edges one pixel wide, {w}×{h}, the ids view (the ids alone returned), medians of {runs} whole \
         calls. The render pipeline is wgpu's on {} drawing the same edges as a line list (no depth test, the vertices transformed in \
         `f32`); it draws Vulkan's strict lines, which tileraster's rectangle rule follows. Then the mesh's vertices as points one \
         pixel wide against its point list. \"differ\" is the share of pixels lit by either that only one lights \
         ([docs/lines.md](lines.md)).\n",
        mesh.triangles.len(),
        lines.len(),
        peer.adapter_name()
    );
    let _ = writeln!(s, "| rule | tileraster cpu | tileraster gpu | render pipeline | cpu vs render pipeline | cpu = gpu | differ |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | --- | ---: |");
    let (peer_time, theirs) = timed(runs, || peer.draw_line_ids(&positions, &lines, &matrix_f32, w, h))?;
    for rule in [LineRule::Rectangle, LineRule::DiamondExit, LineRule::Bresenham] {
        let params = RenderParams {
            shading: Shading::Ids,
            faces: false,
            wireframe: Some(Wireframe { rule, colour: None }),
            eye: Some(camera.viewer()),
            count_fragments: false,
            return_colour: false,
            return_depth: false,
            ..RenderParams::new(w, h, matrix)
        };
        let (cpu_time, cpu) = timed(runs, || render(&mesh, &params, Backend::Cpu).map_err(|e| e.to_string()))?;
        let (gpu_cell, same) = gpu_cell(gpu, runs, &mesh, &params, &cpu)?;
        let _ = writeln!(
            s,
            "| {} | {} | {gpu_cell} | {} | {:.2}× | {same} | {:.2} % |",
            rule.name(),
            ms(&cpu_time),
            ms(&peer_time),
            peer_time.median / cpu_time.median,
            100.0 * differing_share(&cpu.ids, &theirs)
        );
        eprintln!("render-report: lines, {} done", rule.name());
    }
    // The vertices as points one pixel wide, against the device's point list.
    let params = RenderParams {
        shading: Shading::Ids,
        faces: false,
        points: Some(1.0),
        eye: Some(camera.viewer()),
        count_fragments: false,
        return_colour: false,
        return_depth: false,
        ..RenderParams::new(w, h, matrix)
    };
    let (cpu_time, cpu) = timed(runs, || render(&mesh, &params, Backend::Cpu).map_err(|e| e.to_string()))?;
    let (gpu_cell, same) = gpu_cell(gpu, runs, &mesh, &params, &cpu)?;
    let (peer_time, theirs) = timed(runs, || peer.draw_point_ids(&positions, &matrix_f32, w, h))?;
    let _ = writeln!(
        s,
        "| points, 1 px ({} vertices) | {} | {gpu_cell} | {} | {:.2}× | {same} | {:.2} % |",
        mesh.positions.len(),
        ms(&cpu_time),
        ms(&peer_time),
        peer_time.median / cpu_time.median,
        100.0 * differing_share(&cpu.ids, &theirs)
    );
    Ok(s)
}

/// The share of pixels lit by either of two id layers that only one lights.
/// The share of the pixels `ours` covers whose RGBA8 colour in `theirs` differs by more than
/// one unit in some channel, and the largest difference in a channel over those pixels.
fn colour_difference(ours: &Frame, theirs: &[u32]) -> (f64, u8) {
    let channel_diff = |k: usize| (0..4).map(|c| ours.colour[k].to_le_bytes()[c].abs_diff(theirs[k].to_le_bytes()[c])).max().unwrap_or(0);
    let covered: Vec<usize> = (0..ours.ids.len()).filter(|&k| ours.ids[k] != NO_FACE).collect();
    let differ = covered.iter().filter(|&&k| channel_diff(k) > 1).count();
    let largest = covered.iter().map(|&k| channel_diff(k)).max().unwrap_or(0);
    (differ as f64 / covered.len().max(1) as f64, largest)
}

fn differing_share(ours: &[u32], theirs: &[u32]) -> f64 {
    let (mut either, mut one) = (0u64, 0u64);
    for (ours, theirs) in ours.iter().zip(theirs) {
        let (a, b) = (*ours != NO_FACE, *theirs != NO_ID);
        either += u64::from(a || b);
        one += u64::from(a != b);
    }
    one as f64 / either.max(1) as f64
}

/// Textured frames against the render pipeline drawing the same mesh with the same texture
/// and sampler (`TexturedPipeline`): a ground plane whose texture repeats towards the horizon,
/// at each filter, timed side by side, with the share of pixels that differ.
fn texture_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    use tileraster::render::{Address, Filter};
    let (w, h) = if quick { (320, 180) } else { (1920, 1080) };
    let size = 1024u32;
    let mesh = meshes::textured_plane(64, size);
    let [eye, target, up] = meshes::TEXTURED_PLANE_EYE;
    let camera = Camera { eye, target, up, projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.5, far: 200.0 };
    let matrix = camera.view_projection(w, h).map_err(|e| e.to_string())?;
    let mut peer = tileraster_peers::TexturedPipeline::new()?;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Textures\n\n\
         A ground plane of {} triangles seen towards the horizon, its {size}² sRGB texture repeating 16 times across it (magnified near the \
         camera, minified far away), unlit, {w}×{h}, medians of {runs} whole calls. The render pipeline is wgpu's on {} with the same \
         texture (`Rgba8UnormSrgb`, a mip chain of linear 2×2 means for trilinear, built once and uploaded with the texture on every call) \
         and sampler; tileraster decodes the texture and builds its chain on every call, and returns colour and ids, not depth; its \
         \"prepared\" columns are `PreparedMesh::render_into`, which lays the texture out once and (on the GPU) keeps its texels on the \
         device between frames. \"differ\" is the share of covered pixels \
         whose colour differs from the CPU frame's by more than one unit in a channel ([docs/textures.md](textures.md) explains why).\n",
        mesh.triangles.len(),
        peer.adapter_name()
    );
    let _ = writeln!(
        s,
        "| filter | tileraster cpu | cpu, prepared | tileraster gpu | gpu, prepared | render pipeline | cpu vs render pipeline (prepared) | cpu = gpu | differ |"
    );
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | ---: | --- | ---: |");
    for filter in Filter::ALL {
        let params = RenderParams {
            shading: Shading::Unlit,
            cull: Cull::None,
            eye: Some(camera.viewer()),
            count_fragments: false,
            return_depth: false,
            texture_filter: Some(filter),
            texture_address: Some(Address::Repeat),
            ..RenderParams::new(w, h, matrix)
        };
        let (cpu_time, cpu) = timed(runs, || render(&mesh, &params, Backend::Cpu).map_err(|e| e.to_string()))?;
        let (gpu_cell, same) = gpu_cell(gpu, runs, &mesh, &params, &cpu)?;
        // The prepared form, one mesh per backend: its texture laid out by the warm-up frame.
        let prepared_cell = |backend: Backend| -> Result<(String, Timing), String> {
            tileraster::render::release_memory();
            let mut prepared = PreparedMesh::new(mesh.clone()).map_err(|e| e.to_string())?;
            let mut frame = Frame::default();
            let (time, ()) = timed(runs, || prepared.render_into(&params, backend, &mut frame).map_err(|e| e.to_string()))?;
            if frame.colour != cpu.colour {
                return Err(format!("textures, {filter:?}: the prepared {backend:?} frame differs from render's"));
            }
            Ok((ms(&time), time))
        };
        let (cpu_prepared, cpu_prepared_time) = prepared_cell(Backend::Cpu)?;
        let gpu_prepared = if gpu { prepared_cell(Backend::Gpu)?.0 } else { "no adapter".into() };
        let (peer_time, theirs) = timed(runs, || peer.draw(&mesh, &matrix, w, h, filter, Address::Repeat))?;
        let (differ, _) = colour_difference(&cpu, &theirs);
        let _ = writeln!(
            s,
            "| {filter:?} | {} | {cpu_prepared} | {gpu_cell} | {gpu_prepared} | {} | {:.2}× ({:.2}×) | {same} | {:.2} % |",
            ms(&cpu_time),
            ms(&peer_time),
            peer_time.median / cpu_time.median,
            peer_time.median / cpu_prepared_time.median,
            100.0 * differ
        );
        eprintln!("render-report: textures, {filter:?} done");
    }
    Ok(s)
}

/// What object culling (`Skip::CullInstances`) saves: a field of instances of which about a
/// tenth lies in the view, rendered with the culling on and off, and the visible instances
/// alone, side by side.
fn instance_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    let (side, (w, h)) = if quick { (30u32, (320, 180)) } else { (100u32, (1280, 720)) };
    let sphere = meshes::sphere([0.0, 0.0, 0.0], 0.4, 8, 12);
    let place = |x: f64, y: f64| [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let transforms: Vec<[[f64; 4]; 4]> = (0..side * side).map(|k| place((k % side) as f64, (k / side) as f64)).collect();
    let world = World::instanced(sphere.clone(), &transforms);
    // Looking along the field's diagonal from one corner, with the far plane a third of the
    // way across: about a tenth of the instances lie in the view.
    let d = side as f64;
    let camera = Camera {
        eye: [-2.0, -2.0, 3.0],
        target: [d / 2.0, d / 2.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 50.0 },
        near: 0.5,
        far: 0.42 * d,
    };
    let on = RenderParams {
        shading: Shading::Phong,
        eye: Some(camera.viewer()),
        count_fragments: false,
        ..RenderParams::new(w, h, camera.view_projection(w, h).map_err(|e| e.to_string())?)
    };
    let off = RenderParams { skips: tileraster::Skips { cull_instances: false, ..on.skips }, ..on.clone() };
    let probe = render_world(&world, &on, Backend::Cpu).map_err(|e| e.to_string())?;
    let drawn = probe.stats.geometry.instances_drawn;
    // The visible instances alone: those the culling keeps.
    let visible: Vec<[[f64; 4]; 4]> = transforms.iter().zip(world.in_view(&on).map_err(|e| e.to_string())?).filter(|p| p.1).map(|p| *p.0).collect();
    let alone = World::instanced(sphere.clone(), &visible);
    let mut s = String::new();
    let triangles = sphere.triangles.len() as u32 * side * side;
    let _ = writeln!(
        s,
        "\n### Instances and object culling\n\n\
         {} instances of a sphere of {} triangles ({triangles} in all) in a {side} × {side} field, seen from one corner with the far \
         plane a third of the way across: {drawn} instances ({:.1} %) pass the culling. Phong shading, {w}×{h}, medians of {runs} whole \
         calls; \"visible alone\" renders only the instances the culling keeps.\n",
        side * side,
        sphere.triangles.len(),
        100.0 * drawn as f64 / (side * side) as f64
    );
    let _ = writeln!(s, "| backend | culling on | culling off | visible alone | on / off | on / visible alone | same bits |");
    let _ = writeln!(s, "| --- | ---: | ---: | ---: | ---: | ---: | --- |");
    let backends: &[Backend] = if gpu { &[Backend::Cpu, Backend::Gpu] } else { &[Backend::Cpu] };
    for &backend in backends {
        let (on_time, a) = timed(runs, || render_world(&world, &on, backend).map_err(|e| e.to_string()))?;
        let (off_time, b) = timed(runs, || render_world(&world, &off, backend).map_err(|e| e.to_string()))?;
        let (alone_time, _) = timed(runs, || render_world(&alone, &on, backend).map_err(|e| e.to_string()))?;
        let same = a.colour == b.colour && a.ids == b.ids && a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits());
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {:.3} | {:.2} | {} |",
            backend.name(),
            ms(&on_time),
            ms(&off_time),
            ms(&alone_time),
            on_time.median / off_time.median,
            on_time.median / alone_time.median,
            if same { "yes" } else { "**NO**" }
        );
        eprintln!("render-report: instances, {} done", backend.name());
    }
    Ok(s)
}

/// What hierarchical depth rejection (`Skip::HiddenTriangles`) saves on scenes of heavy
/// overdraw: each frame with the rejection on and off, on each backend, in one run.
fn hidden_section(quick: bool, runs: usize, gpu: bool) -> Result<String, String> {
    let (w, h) = if quick { (320, 180) } else { (1920, 1080) };
    let mut s = String::new();
    let _ = writeln!(
        s,
        "\n### Hierarchical depth rejection\n\n\
         Each tile takes a depth bound from the triangles of its bin that cover it whole, and skips the depth tests of the \
         triangles that lie behind it everywhere (`--no-skip hidden_triangles` turns it off). The bound does not depend on the order \
         of the bin, so it rejects as much drawn back to front as front to back. Medians of {runs} whole calls ({w}×{h}, triangle ids, \
         fragments not counted: hidden triangles get no edge tests either), with the rejection on and off side by side; \
         \"hidden\" is `Stats::triangles_hidden`, the bin entries rejected.\n"
    );
    let _ = writeln!(s, "| scene | backend | rejection on | off | on / off | hidden | hidden per tile | same bits |");
    let _ = writeln!(s, "| --- | --- | ---: | ---: | ---: | ---: | ---: | --- |");
    let layers = if quick { [8, 32] } else { [8, 64] };
    for n in layers {
        for (order, reverse) in [("back to front", false), ("front to back", true)] {
            let mut mesh = meshes::fill_layers(n);
            if reverse {
                mesh.triangles.reverse();
            }
            let name = format!("{n} full-frame layers, {order}");
            let on = RenderParams {
                cull: Cull::None,
                shading: Shading::Ids,
                count_fragments: false,
                eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                ..RenderParams::new(w, h, IDENTITY)
            };
            let off = RenderParams { skips: tileraster::Skips { hidden_triangles: false, ..on.skips }, ..on.clone() };
            let backends: &[Backend] = if gpu { &[Backend::Cpu, Backend::Gpu] } else { &[Backend::Cpu] };
            for &backend in backends {
                let (on_time, a) = timed(runs, || render(&mesh, &on, backend).map_err(|e| e.to_string()))?;
                let (off_time, b) = timed(runs, || render(&mesh, &off, backend).map_err(|e| e.to_string()))?;
                let same = a.colour == b.colour && a.ids == b.ids && a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits());
                let hidden = a.stats.raster.triangles_hidden;
                let _ = writeln!(
                    s,
                    "| {name} | {} | {} | {} | {:.2} | {hidden} | {:.1} (of at most {}) | {} |",
                    backend.name(),
                    ms(&on_time),
                    ms(&off_time),
                    on_time.median / off_time.median,
                    hidden as f64 / a.stats.raster.tiles_total as f64,
                    n - 1,
                    if same { "yes" } else { "**NO**" }
                );
                eprintln!("render-report: {name}, {} done", backend.name());
            }
        }
    }
    Ok(s)
}
