//! Renders the sea with the waves vertex shader on both backends, checks that their frames are
//! the same bits, and writes the frame as a PNG.
//!
//! `cargo run --release -p waves -- [OUT.png] [--time SECONDS] [--size WxH] [--grid N]`

use std::process::ExitCode;
use std::time::Instant;
use tileraster::Backend;
use tileraster::render::render;

fn main() -> ExitCode {
    match run() {
        Ok(code) => code,
        Err(e) => {
            eprintln!("waves: {e}");
            ExitCode::FAILURE
        }
    }
}

fn run() -> Result<ExitCode, String> {
    let mut out = String::from("waves.png");
    let (mut width, mut height, mut time, mut grid) = (960u32, 540u32, 0.0f32, 384u32);
    let mut args = std::env::args().skip(1);
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--time" => time = args.next().and_then(|s| s.parse().ok()).ok_or("--time takes seconds")?,
            "--grid" => grid = args.next().and_then(|s| s.parse().ok()).filter(|&n| n > 0).ok_or("--grid takes quads per side")?,
            "--size" => {
                let size = args.next().ok_or("--size takes WxH")?;
                let (w, h) = size.split_once('x').ok_or("--size takes WxH")?;
                (width, height) = (w.parse().map_err(|_| "--size: bad width")?, h.parse().map_err(|_| "--size: bad height")?);
            }
            path => out = path.to_string(),
        }
    }
    let mesh = waves::sea(grid);
    let params = waves::params(&mesh, width, height, time).map_err(|e| e.to_string())?;
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
