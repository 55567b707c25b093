//! `tileraster view`: a page on a local web server that shows the frames the engine renders as
//! the user moves, each with the `tileraster render` command line that draws it and its CRC-32.
//!
//! The page keeps the camera and the toggles and asks for one frame at a time (`POST /frame`,
//! a small JSON object); the server draws it from the mesh prepared once ([`PreparedModel`])
//! and answers with the frame's description (JSON) and its RGBA bytes, which the page puts on
//! a canvas as they are. The server is the one author of the command line: it writes it from
//! the options it drew with.
//!
//! Safe to leave running: it listens on 127.0.0.1 unless told otherwise, serves its page and
//! frames and nothing from the disk, takes requests of at most [`MAX_REQUEST_BYTES`] and frames
//! of at most [`MAX_SIDE`] pixels a side, holds at most [`MAX_CONNECTIONS`] connections (each
//! closed after [`HEADER_TIMEOUT`] without a request's headers and ended gracefully after
//! [`CONNECTION_LIFETIME`]), and answers a bad request with an error, never stopping.

use super::progress::note;
use super::render::{FrameArgs, command_line};
use axum::Router;
use axum::body::Bytes;
use axum::extract::{DefaultBodyLimit, State};
use axum::http::{StatusCode, header};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::{get, post};
use clap::Args;
use serde::{Deserialize, Serialize};
use std::net::{IpAddr, SocketAddr};
use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use tileraster::Backend;
use tileraster::render::{CameraChoice, Frame, FrameError, Lens, MAX_JITTER, MeshSource, Model, ModelOptions, PreparedModel, ViewOptions};

/// The largest request body the server reads.
pub const MAX_REQUEST_BYTES: usize = 4096;
/// The widest and tallest frame a request may ask for.
pub const MAX_SIDE: u32 = 4096;
/// Samples a frame may hold at most (pixels × MSAA samples): 4K at 8 samples.
pub const MAX_SAMPLES: u64 = 3840 * 2160 * 8;
/// Open connections at most; one more is closed at once.
pub const MAX_CONNECTIONS: usize = 32;
/// How long a connection may take to send a request's headers.
pub const HEADER_TIMEOUT: Duration = Duration::from_secs(10);
/// How long a connection is kept before it is ended gracefully (a browser opens another).
pub const CONNECTION_LIFETIME: Duration = Duration::from_secs(120);

#[derive(Args)]
pub struct ViewArgs {
    /// The mesh, as `tileraster render` takes it.
    input: PathBuf,
    /// The port to listen on (0: any free port). The page's address is printed.
    #[arg(long, default_value_t = 8765)]
    port: u16,
    /// The address to listen on: this machine only (127.0.0.1) unless another is given.
    #[arg(long, value_name = "ADDR", default_value = "127.0.0.1")]
    listen: IpAddr,
    #[command(flatten)]
    frame: FrameArgs,
}

/// The server's one viewer: the mesh prepared once, and the options the command line gave.
struct Viewer {
    input: PathBuf,
    instances: Option<PathBuf>,
    model_options: ModelOptions,
    base: ViewOptions,
    backend: Backend,
    /// The mesh prepared once, and the last frame, whose layers the next reuses.
    prepared: Mutex<(PreparedModel, Frame)>,
}

/// A look-at camera as the page keeps it.
#[derive(Debug, Clone, Copy, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
struct LookAt {
    eye: [f64; 3],
    target: [f64; 3],
    up: [f64; 3],
}

/// What the page asks for; each field left out keeps the command line's option.
#[derive(Debug, Default, Deserialize)]
#[serde(deny_unknown_fields)]
struct FrameRequest {
    size: Option<[u32; 2]>,
    camera: Option<LookAt>,
    /// One of `--projection`'s values.
    projection: Option<String>,
    /// The orthographic width seen across the frame (`None`: as wide as frames the mesh).
    ortho_width: Option<f64>,
    /// `"flat"`, `"smooth"`, `"phong"`, or another of `--shading`'s values.
    shading: Option<String>,
    wireframe: Option<bool>,
    points: Option<bool>,
    msaa: Option<u32>,
    /// Samples at sub-pixel offsets averaged into the frame (`--jitter`).
    jitter: Option<u32>,
    /// The tile heat map instead of the frame.
    heat: Option<bool>,
    /// `"cpu"` or `"gpu"`.
    backend: Option<String>,
}

/// What the page is told of a frame, before its pixels.
#[derive(Debug, Serialize)]
struct FrameReply {
    /// The image that follows: the frame's, or its heat map's.
    width: u32,
    height: u32,
    frame_size: [u32; 2],
    crc: String,
    command: String,
    ms: f64,
    backend: &'static str,
    camera: Option<LookAt>,
    fov: f64,
    projection: &'static str,
    shading: String,
    wireframe: bool,
    points: bool,
    msaa: u32,
    jitter: u32,
    heat: bool,
}

/// A request the server refuses, with why.
struct Refusal(StatusCode, String);

impl IntoResponse for Refusal {
    fn into_response(self) -> Response {
        (self.0, [(header::CONTENT_TYPE, "text/plain; charset=utf-8")], self.1).into_response()
    }
}

fn bad(message: impl Into<String>) -> Refusal {
    Refusal(StatusCode::BAD_REQUEST, message.into())
}

impl Viewer {
    /// The options of the frame `request` asks for.
    fn view_of(&self, request: &FrameRequest) -> Result<(ViewOptions, Backend), Refusal> {
        let mut view = self.base.clone();
        if let Some([w, h]) = request.size {
            if !(1..=MAX_SIDE).contains(&w) || !(1..=MAX_SIDE).contains(&h) {
                return Err(bad(format!("size {w} × {h}: give a width and a height from 1 to {MAX_SIDE} pixels")));
            }
            view.size = Some([w, h]);
        }
        if let Some(c) = request.camera {
            view.camera = CameraChoice::LookAt { eye: c.eye, target: c.target, up: c.up };
        }
        let fov = perspective_fov(view.lens);
        if let Some(name) = request.projection.as_deref() {
            let ortho = (name == "orthographic").then_some(request.ortho_width);
            view.lens = Lens::of(Some(name).filter(|&n| n != "orthographic"), (name == "perspective").then_some(fov), ortho).map_err(|e| bad(e.to_string()))?;
        }
        if let Some(samples) = request.jitter {
            if !(1..=MAX_JITTER).contains(&samples) {
                return Err(bad(format!("jitter {samples}: give from 1 to {MAX_JITTER} samples")));
            }
            view.jitter = samples;
        }
        if let Some(name) = &request.shading {
            view.shading = Some(super::render::shading_named(name).ok_or_else(|| bad(format!("shading {name:?}: give one of --shading's values")))?);
        }
        if let Some(on) = request.wireframe {
            view.wireframe = on.then_some(self.base.wireframe.unwrap_or(tileraster::render::LineRule::DiamondExit));
        }
        if let Some(on) = request.points {
            view.points = on.then_some(self.base.points.unwrap_or(3.0));
        }
        if let Some(samples) = request.msaa {
            if ![1, 4, 8].contains(&samples) {
                return Err(bad(format!("msaa {samples}: give 1, 4 or 8 samples")));
            }
            view.msaa = samples;
        }
        let [w, h] = view.size.unwrap_or([1280, 720]);
        if w as u64 * h as u64 * view.msaa as u64 > MAX_SAMPLES {
            return Err(bad(format!("{w} × {h} pixels at {} samples: at most {MAX_SAMPLES} samples a frame", view.msaa)));
        }
        let heat = request.heat.unwrap_or(false);
        if heat && !Model::is_plain(&view) {
            return Err(bad("the tile heat map shows one frame of the pipeline: turn jitter and panoramas off"));
        }
        (view.count_fragments, view.count_tiles, view.return_depth) = (heat, heat, false);
        let backend = match request.backend.as_deref() {
            None => self.backend,
            Some("cpu") => Backend::Cpu,
            Some("gpu") => Backend::Gpu,
            Some(other) => return Err(bad(format!("backend {other:?}: give \"cpu\" or \"gpu\""))),
        };
        Ok((view, backend))
    }

    /// The frame `request` asks for: its description as JSON (its length first, 4 bytes
    /// little-endian), then its image's RGBA bytes.
    fn frame(&self, request: &FrameRequest) -> Result<Vec<u8>, Refusal> {
        let (view, backend) = self.view_of(request)?;
        let mut guard = self.prepared.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
        let (prepared, frame) = &mut *guard;
        let start = Instant::now();
        let params = prepared.render_view(&view, backend, frame).map_err(|e| match e {
            FrameError::Render(e) => Refusal(StatusCode::UNPROCESSABLE_ENTITY, e.to_string()),
            options => bad(options.to_string()),
        })?;
        let ms = start.elapsed().as_secs_f64() * 1e3;
        let camera = prepared.look_at(&view, params.width, params.height).map(|c| LookAt { eye: c.eye, target: c.target, up: c.up });
        let heat = request.heat.unwrap_or(false);
        // The colour's bytes as `--stats` checksums them (each pixel's word little-endian).
        let colour: Vec<u8> = frame.colour.iter().flat_map(|c| c.to_le_bytes()).collect();
        let crc = crc32fast::hash(&colour);
        let (width, height, rgba) = match heat {
            true => frame.heat_map().map_err(|e| Refusal(StatusCode::INTERNAL_SERVER_ERROR, e.to_string()))?,
            false => (frame.width, frame.height, colour),
        };
        let frame_size = [frame.width, frame.height];
        drop(guard);
        let mut args = command_line(&self.input, "frame.png", self.instances.as_deref(), &self.model_options, &view, backend);
        if heat {
            args.extend(["--heat-map".into(), "heat.png".into()]);
        }
        let reply = FrameReply {
            width,
            height,
            frame_size,
            crc: format!("{crc:08x}"),
            command: shell_words::join(&args),
            ms,
            backend: backend.name(),
            camera,
            fov: perspective_fov(view.lens),
            projection: view.lens.projection().0,
            jitter: view.jitter,
            shading: super::render::shading_name(params.shading),
            wireframe: view.wireframe.is_some(),
            points: view.points.is_some(),
            msaa: view.msaa,
            heat,
        };
        let json = serde_json::to_vec(&reply).expect("a reply is plain data");
        let mut body = Vec::with_capacity(4 + json.len() + rgba.len());
        body.extend((json.len() as u32).to_le_bytes());
        body.extend(json);
        put_spans(&mut body, &rgba, width as usize);
        Ok(body)
    }
}

/// The image's rows as spans, without the pixels equal to its top-left pixel (the background,
/// mostly) at either end of each row: that pixel's word (4 bytes), then each row's first kept
/// column and count (2 bytes each, little-endian), then the kept pixels, row by row. The page
/// fills the rest with the top-left pixel: the same bytes, fewer sent where the model does not
/// fill the frame.
fn put_spans(body: &mut Vec<u8>, rgba: &[u8], width: usize) {
    let fill: [u8; 4] = rgba.get(..4).map_or([0; 4], |p| p.try_into().expect("four bytes"));
    body.extend(fill);
    let rows: Vec<(usize, usize)> = rgba
        .chunks_exact(4 * width.max(1))
        .map(|row| {
            let pixels = row.as_chunks::<4>().0;
            match pixels.iter().position(|p| *p != fill) {
                None => (0, 0),
                Some(first) => (first, pixels.iter().rposition(|p| *p != fill).expect("a kept pixel") + 1 - first),
            }
        })
        .collect();
    for &(first, count) in &rows {
        body.extend((first as u16).to_le_bytes());
        body.extend((count as u16).to_le_bytes());
    }
    for (row, &(first, count)) in rgba.chunks_exact(4 * width.max(1)).zip(&rows) {
        body.extend(&row[4 * first..4 * (first + count)]);
    }
}

/// The field of view the page's perspective takes: the lens's, or the default.
fn perspective_fov(lens: Lens) -> f64 {
    match lens {
        Lens::Perspective { fov_deg } => fov_deg,
        _ => 45.0,
    }
}

async fn page() -> Html<&'static str> {
    Html(include_str!("view.html"))
}

async fn serve_frame(State(viewer): State<Arc<Viewer>>, body: Bytes) -> Response {
    let request: FrameRequest = match serde_json::from_slice(&body) {
        Ok(request) => request,
        Err(e) => return bad(format!("the request is not a frame's JSON: {e}")).into_response(),
    };
    // Drawn off the server's threads; a panic there is answered, and the server goes on.
    match tokio::task::spawn_blocking(move || viewer.frame(&request)).await {
        Ok(Ok(body)) => ([(header::CONTENT_TYPE, "application/octet-stream"), (header::CACHE_CONTROL, "no-store")], body).into_response(),
        Ok(Err(refusal)) => refusal.into_response(),
        Err(e) => Refusal(StatusCode::INTERNAL_SERVER_ERROR, format!("the frame failed: {e} (please report it)")).into_response(),
    }
}

async fn wrong_method() -> Refusal {
    Refusal(StatusCode::METHOD_NOT_ALLOWED, "POST a frame's JSON to /frame".into())
}

async fn not_found() -> Refusal {
    Refusal(StatusCode::NOT_FOUND, "not found: this server has its page (/) and its frames (POST /frame)".into())
}

pub fn view_command(args: ViewArgs) -> Result<ExitCode, String> {
    let ViewArgs { input, port, listen, frame } = args;
    let instances = frame.instances_path();
    let (mut model_options, base, backend_arg) = frame.options()?;
    // The vertices view (V) may be asked for any frame.
    model_options.points = true;
    let (backend, _) = crate::choose_backend(backend_arg, 1280 * 720);
    let model = Model::load(MeshSource::File(input.clone()), &model_options).map_err(|e| e.to_string())?;
    let prepared = Mutex::new((model.prepare().map_err(|e| e.to_string())?, Frame::default()));
    let viewer = Arc::new(Viewer { input, instances, model_options, base, backend, prepared });
    let app = Router::new()
        .route("/", get(page))
        .route("/frame", post(serve_frame).fallback(wrong_method))
        .fallback(not_found)
        .layer(DefaultBodyLimit::max(MAX_REQUEST_BYTES))
        .with_state(viewer);
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build().map_err(|e| e.to_string())?;
    runtime.block_on(serve(SocketAddr::new(listen, port), app))
}

/// Accept connections and serve each with `app`, within the bounds above.
async fn serve(address: SocketAddr, app: Router) -> Result<ExitCode, String> {
    let listener = tokio::net::TcpListener::bind(address).await.map_err(|e| format!("--listen {} --port {}: {e}", address.ip(), address.port()))?;
    let bound = listener.local_addr().map_err(|e| e.to_string())?;
    note(format!("tileraster view: http://{bound}/ (Ctrl-C stops it)"));
    let permits = Arc::new(tokio::sync::Semaphore::new(MAX_CONNECTIONS));
    loop {
        let stream = match listener.accept().await {
            Ok((stream, _)) => stream,
            // Out of descriptors, or a connection reset before it was accepted: go on.
            Err(_) => {
                tokio::time::sleep(Duration::from_millis(50)).await;
                continue;
            }
        };
        let Ok(permit) = permits.clone().try_acquire_owned() else {
            continue;
        };
        let service = hyper_util::service::TowerToHyperService::new(app.clone());
        tokio::spawn(async move {
            let _permit = permit;
            let connection = hyper::server::conn::http1::Builder::new()
                .timer(hyper_util::rt::TokioTimer::new())
                .header_read_timeout(HEADER_TIMEOUT)
                .serve_connection(hyper_util::rt::TokioIo::new(stream), service);
            let mut connection = std::pin::pin!(connection);
            tokio::select! {
                _ = connection.as_mut() => {}
                _ = tokio::time::sleep(CONNECTION_LIFETIME) => {
                    connection.as_mut().graceful_shutdown();
                    let _ = connection.await;
                }
            }
        });
    }
}
