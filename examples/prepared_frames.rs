//! Times a prepared mesh's frames: `render-report`'s 100k-triangle terrain (its camera, face ids
//! or another shading, no fragment counts; `N` = 708 gives its 1M-triangle terrain) drawn again
//! and again by one `PreparedMesh`, as a viewer draws it; or, with `one-shot`, by `render`
//! calls, each a whole frame from the mesh. A loop of frames and nothing else, for a profiler
//! (`perf record`) and for before/after runs of two builds. It prints the frames' times and the
//! bytes the last one handed over (`Stats::bytes_uploaded`).
//!
//! ```text
//! cargo run --release --example prepared_frames -- [FRAMES] [cpu|gpu] [ids|phong|smooth|flat|unlit|...] [prepared|one-shot] [N] [auto|device|host] [mesh|lifted]
//! ```
//!
//! `auto|device|host` says where a GPU frame's assembly runs (`set_gpu_assembly_on`); `lifted`
//! draws the terrain as a DEM does: its grid at height 0, lifted in the vertex stage by its
//! heights (rounded to `f32`) as a vertex texture (`VertexStage::HEIGHTS`).

use std::time::Instant;
use tileraster::Backend;
use tileraster::render::{Camera, Frame, PreparedMesh, Projection, RenderParams, Shading, Up, VertexStage, VertexTexture, render};
use tileraster_testkit::meshes;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let frames: usize = args.next().map_or(Ok(100), |a| a.parse())?;
    let backend = match args.next().as_deref() {
        None | Some("cpu") => Backend::Cpu,
        Some("gpu") => Backend::Gpu,
        Some(other) => return Err(format!("backend {other:?}: cpu or gpu").into()),
    };
    let shading = match args.next().as_deref() {
        None => Shading::Ids,
        Some(name) => match Shading::ALL.into_iter().find(|s| s.name() == name) {
            Some(shading) => shading,
            None => return Err(format!("shading {name:?}: one of {}", Shading::ALL.map(Shading::name).join(", ")).into()),
        },
    };
    let one_shot = match args.next().as_deref() {
        None | Some("prepared") => false,
        Some("one-shot") => true,
        Some(other) => return Err(format!("calls {other:?}: prepared or one-shot").into()),
    };
    let n: u32 = args.next().map_or(Ok(224), |a| a.parse())?;
    let assembly = match args.next().as_deref() {
        None | Some("auto") => tileraster::GpuAssemblyOn::Auto,
        Some("device") => tileraster::GpuAssemblyOn::Device,
        Some("host") => tileraster::GpuAssemblyOn::Host,
        Some(other) => return Err(format!("assembly {other:?}: auto, device or host").into()),
    };
    tileraster::set_gpu_assembly_on(assembly);
    let lifted = match args.next().as_deref() {
        None | Some("mesh") => false,
        Some("lifted") => true,
        Some(other) => return Err(format!("terrain {other:?}: mesh or lifted").into()),
    };
    let (w, h) = (1920, 1080);
    let mut mesh = meshes::terrain(n, 1000.0, 60.0);
    let camera = Camera::framing(&mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
    let mut params = RenderParams {
        eye: Some(camera.viewer()),
        count_fragments: false,
        shading,
        return_colour: shading != Shading::Ids,
        return_depth: shading != Shading::Ids,
        ..RenderParams::new(w, h, camera.view_projection(w, h)?)
    };
    if lifted {
        let texels = mesh.positions.iter_mut().map(|p| std::mem::take(&mut p[2]) as f32).collect();
        params.vertex_texture = Some(std::sync::Arc::new(VertexTexture { width: n + 1, height: n + 1, texels }));
        (params.vertex, params.vertex_constants[0]) = (Some(VertexStage::HEIGHTS), 1.0);
    }
    let triangles = mesh.triangles.len();
    let uploaded = std::rc::Rc::new(std::cell::Cell::new(0));
    let last = uploaded.clone();
    let mut frame_ms: Box<dyn FnMut() -> Result<f64, tileraster::Error>> = if one_shot {
        Box::new(move || {
            let start = Instant::now();
            render(&mesh, &params, backend).map(|frame| {
                let ms = start.elapsed().as_secs_f64() * 1e3;
                last.set(frame.stats.raster.bytes_uploaded);
                drop(frame);
                ms
            })
        })
    } else {
        let mut prepared = PreparedMesh::new(mesh)?;
        let mut frame = Frame::default();
        Box::new(move || {
            let start = Instant::now();
            prepared.render_into(&params, backend, &mut frame).map(|()| {
                last.set(frame.stats.raster.bytes_uploaded);
                start.elapsed().as_secs_f64() * 1e3
            })
        })
    };
    frame_ms()?;
    let mut ms: Vec<f64> = (0..frames.max(1)).map(|_| frame_ms()).collect::<Result<_, _>>()?;
    ms.sort_by(f64::total_cmp);
    let n = ms.len();
    println!(
        "{triangles} triangles{}, {w}×{h}, {}, {backend:?} (assembly {assembly:?}), {}: median {:.1} ms, fastest {:.1}, slowest {:.1} of {n} frames; the last handed over {} bytes",
        if lifted { " lifted by the vertex stage" } else { "" },
        shading.name(),
        if one_shot { "one-shot" } else { "prepared" },
        ms[n / 2],
        ms[0],
        ms[n - 1],
        uploaded.get()
    );
    Ok(())
}
