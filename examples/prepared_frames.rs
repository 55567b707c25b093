//! Times a prepared mesh's frames: `render-report`'s 100k-triangle terrain (its camera, face ids
//! or Phong shading, no fragment counts) drawn again and again by one `PreparedMesh`, as a viewer
//! draws it.
//! A loop of frames and nothing else, for a profiler (`perf record`) and for before/after runs
//! of two builds.
//!
//! ```text
//! cargo run --release --example prepared_frames -- [FRAMES] [cpu|gpu] [ids|phong]
//! ```

use std::time::Instant;
use tileraster::Backend;
use tileraster::render::{Camera, Frame, PreparedMesh, Projection, RenderParams, Shading, Up};
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
        None | Some("ids") => Shading::Ids,
        Some("phong") => Shading::Phong,
        Some(other) => return Err(format!("shading {other:?}: ids or phong").into()),
    };
    let (w, h) = (1920, 1080);
    let mesh = meshes::terrain(224, 1000.0, 60.0);
    let camera = Camera::framing(&mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 45.0 }, Up::Z);
    let params = RenderParams {
        eye: Some(camera.viewer()),
        count_fragments: false,
        shading,
        return_colour: shading != Shading::Ids,
        return_depth: shading != Shading::Ids,
        ..RenderParams::new(w, h, camera.view_projection(w, h)?)
    };
    let triangles = mesh.triangles.len();
    let mut prepared = PreparedMesh::new(mesh)?;
    let mut frame = Frame::default();
    prepared.render_into(&params, backend, &mut frame)?;
    let mut ms: Vec<f64> = (0..frames.max(1))
        .map(|_| {
            let start = Instant::now();
            prepared.render_into(&params, backend, &mut frame).map(|()| start.elapsed().as_secs_f64() * 1e3)
        })
        .collect::<Result<_, _>>()?;
    ms.sort_by(f64::total_cmp);
    let n = ms.len();
    println!(
        "{triangles} triangles, {w}×{h}, {}, {backend:?}: median {:.1} ms, fastest {:.1}, slowest {:.1} of {n} frames",
        shading.name(),
        ms[n / 2],
        ms[0],
        ms[n - 1]
    );
    Ok(())
}
