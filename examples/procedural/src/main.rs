//! Renders the marble scene with the procedural fragment shader on both backends, checks that
//! their frames are the same bits, and writes the frame as a PNG.
//!
//! `cargo run --release -p procedural -- [OUT.png] [--msaa 1|4|8] [--size WxH]`

use std::process::ExitCode;
use std::time::Instant;
use tileraster::Backend;
use tileraster::render::render;

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("procedural: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<ExitCode, String> {
    let mut out = String::from("marble.png");
    let (mut width, mut height, mut samples) = (960u32, 640u32, 4u32);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--msaa" => samples = args.next().and_then(|s| s.parse().ok()).ok_or("--msaa takes 1, 4 or 8")?,
            "--size" => {
                let size = args.next().ok_or("--size takes WxH")?;
                let (w, h) = size.split_once('x').ok_or("--size takes WxH")?;
                (width, height) = (w.parse().map_err(|_| "--size: bad width")?, h.parse().map_err(|_| "--size: bad height")?);
            }
            path => out = path.to_string(),
        }
    }
    let mesh = procedural::scene();
    let mut params = procedural::params(&mesh, width, height).map_err(|e| e.to_string())?;
    params.samples = samples;
    let mut frames = Vec::new();
    for backend in [Backend::Cpu, Backend::Gpu] {
        let start = Instant::now();
        let frame = render(&mesh, &params, backend).map_err(|e| format!("{}: {e}", backend.name()))?;
        println!("{}: {:.1} ms, colour CRC-32 {:08x}", backend.name(), start.elapsed().as_secs_f64() * 1e3, frame.checksums().colour);
        frames.push(frame);
    }
    let same = frames[0] == frames[1];
    println!("CPU and GPU frames {}", if same { "are the same bits" } else { "DIFFER" });
    image::save_buffer(&out, &frames[0].rgba8(), width, height, image::ColorType::Rgba8).map_err(|e| format!("{out}: {e}"))?;
    println!("wrote {out}");
    Ok(if same { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}
