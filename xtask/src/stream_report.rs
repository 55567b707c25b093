//! `cargo xtask stream-report [POINTS] [SIZE] [LIMIT_MIB]`: the command line at scale, as
//! users run it (release build, CPU backend, whole processes).
//!
//! - Cluster recipe, locally: the grid cut into `--part K/N` windows, each part its own
//!   process, all started at once; `tileraster mosaic` builds the VRT; the mosaic's cells,
//!   read through GDAL when it is installed, are compared bit for bit with the single run.
//! - A grid larger than the memory it may use: `SIZE`² cells in a process whose address space
//!   is limited to `LIMIT_MIB` (`ulimit -v`), with no `--memory`: it streams bands to a tiled
//!   (Big)TIFF by itself; the peak resident memory of the process, and windows of the file
//!   compared bit for bit with `--window` runs of the same cells.
//!
//! Prints markdown.

use crate::gdal_report::{read_values, write_points_csv};
use crate::{measure, median};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;
use tiff::decoder::{Decoder, DecodingResult};

fn mib(bytes: u64) -> String {
    format!("{:.0} MiB", bytes as f64 / (1 << 20) as f64)
}

fn same_bits(a: &[f32], b: &[f32]) -> u64 {
    a.iter().zip(b).filter(|(x, y)| x.to_bits() != y.to_bits()).count() as u64 + a.len().abs_diff(b.len()) as u64
}

/// The cells of `window` (tile-aligned) of a tiled file, read tile by tile.
fn read_tiled_window(path: &Path, x0: u32, y0: u32, size: u32) -> Result<Vec<f32>, String> {
    let text = |e: tiff::TiffError| format!("{}: {e}", path.display());
    let mut d = Decoder::new(std::io::BufReader::new(std::fs::File::open(path).map_err(|e| e.to_string())?)).map_err(text)?;
    let (width, _) = d.dimensions().map_err(text)?;
    let (tw, th) = d.chunk_dimensions();
    if ![x0, size].iter().all(|v| v.is_multiple_of(tw)) || ![y0, size].iter().all(|v| v.is_multiple_of(th)) {
        return Err(format!("window ({x0}, {y0}) {size}² is not aligned to {tw}×{th} tiles"));
    }
    let across = width.div_ceil(tw);
    let mut cells = vec![0f32; (size * size) as usize];
    for ty in 0..size / th {
        for tx in 0..size / tw {
            let index = (y0 / th + ty) * across + x0 / tw + tx;
            let DecodingResult::F32(tile) = d.read_chunk(index).map_err(text)? else { return Err("not Float32".into()) };
            for row in 0..th {
                let to = ((ty * th + row) * size + tx * tw) as usize;
                cells[to..to + tw as usize].copy_from_slice(&tile[(row * tw) as usize..][..tw as usize]);
            }
        }
    }
    Ok(cells)
}

/// `command` run with its address space limited to `limit` bytes (the shell's `ulimit -v`),
/// under GNU time, which reports its peak resident memory ([`peak_of`]). Not `wait4`'s figure
/// for a child of this process: a child starts as this process's copy, or shares its memory
/// until `exec`, and its peak counts this process's pages. GNU time's own child is forked from
/// a small process.
fn limited_address_space(command: &Command, limit: u64) -> Command {
    let mut shell = Command::new("sh");
    shell
        .arg("-c")
        .arg(format!("ulimit -v {} && exec /usr/bin/time -f 'peak resident KiB: %M' \"$0\" \"$@\"", limit >> 10))
        .arg(command.get_program())
        .args(command.get_args());
    shell
}

/// The peak resident memory GNU time reported on `stderr`.
pub(crate) fn peak_of(stderr: &str) -> Result<u64, String> {
    stderr
        .lines()
        .find_map(|l| l.strip_prefix("peak resident KiB: "))
        .and_then(|v| v.trim().parse::<u64>().ok())
        .map(|kib| kib << 10)
        .ok_or_else(|| "no peak from /usr/bin/time (Debian: apt install time)".to_string())
}

pub fn run(points: usize, size: u32, limit_mib: u64) -> Result<String, String> {
    let bin = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/release/tileraster");
    if !bin.exists() {
        return Ok(format!("Not measured: {} is missing (`cargo build --release --bin tileraster` builds it).\n", bin.display()));
    }
    let dir = std::env::temp_dir().join(format!("tileraster-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let result = report(&bin, &dir, points, size, limit_mib);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn report(bin: &Path, dir: &Path, points: usize, size: u32, limit_mib: u64) -> Result<String, String> {
    let (csv, extent) = write_points_csv(dir, points)?;
    let grid_args = |n: u32| -> Vec<String> {
        let [x0, x1, y0, y1] = extent.map(|v| v.to_string());
        let n = n.to_string();
        ["--txe", &x0, &x1, "--tye", &y0, &y1, "--outsize", &n, &n, "--nodata", "-9999", "--backend", "cpu", "-q"].map(String::from).to_vec()
    };
    let rasterise = |out: &Path, n: u32, extra: &[&str]| {
        let mut c = Command::new(bin);
        c.arg("rasterise").arg(&csv).arg("-o").arg(out).args(grid_args(n)).args(extra);
        c
    };
    let mut s = String::new();

    // The cluster recipe, locally.
    const CLUSTER: u32 = 4096;
    const PARTS: u32 = 8;
    let single = dir.join("single.tif");
    let (mut t_single, mut t_parts) = (Vec::new(), Vec::new());
    let parts: Vec<PathBuf> = (0..PARTS).map(|k| dir.join(format!("part-{k}.tif"))).collect();
    for _ in 0..3 {
        eprintln!("stream-report: single run, {PARTS} parts ...");
        t_single.push(measure(&mut rasterise(&single, CLUSTER, &[]))?.seconds);
        let start = Instant::now();
        let jobs: Vec<_> = (0..PARTS)
            .map(|k| rasterise(&parts[k as usize], CLUSTER, &["--part", &format!("{k}/{PARTS}")]).spawn().map_err(|e| e.to_string()))
            .collect::<Result<_, _>>()?;
        for mut job in jobs {
            if !job.wait().map_err(|e| e.to_string())?.success() {
                return Err("a part failed".into());
            }
        }
        t_parts.push(start.elapsed().as_secs_f64());
    }
    let vrt = dir.join("mosaic.vrt");
    let out = Command::new(bin).args(["mosaic", "-o"]).arg(&vrt).args(&parts).output().map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(format!("mosaic failed: {}", String::from_utf8_lossy(&out.stderr)));
    }
    let whole = read_values(&single)?;
    let through = match tileraster_peers::gdal_grid_version() {
        Some(_) => {
            let tif = dir.join("mosaic.tif");
            let out = Command::new("gdal_translate").args(["-q"]).arg(&vrt).arg(&tif).output().map_err(|e| e.to_string())?;
            if !out.status.success() {
                return Err(format!("gdal_translate failed: {}", String::from_utf8_lossy(&out.stderr)));
            }
            let differ = same_bits(&read_values(&tif)?, &whole);
            format!("read through GDAL's `gdal_translate`: {differ} of {} cells differ from the single run", whole.len())
        }
        None => "GDAL is not installed here, so the VRT was not read back through GDAL".into(),
    };
    let _ = writeln!(
        s,
        "**Cluster recipe, locally.** {points} CSV points onto {CLUSTER}² cells, cut into {PARTS} `--part K/{PARTS}` windows, each its own process, \
         all started at once; `tileraster mosaic` wrote the VRT, {through}. Medians of 3: the single run {:.0} ms, the {PARTS} parts together {:.0} ms \
         (each part reads all the points and triangulates those around its band).\n",
        median(t_single) * 1e3,
        median(t_parts) * 1e3
    );

    // Larger than the memory it may use: an address-space limit (`ulimit -v`) far below the
    // raster's size, and no --memory: the run finds the limit and streams by itself.
    let big = dir.join("big.tif");
    let limit = limit_mib << 20;
    eprintln!("stream-report: {size}² under ulimit -v {limit_mib} MiB ...");
    // Tiled even when it fits in one band, so its windows can be read tile by tile.
    let mut command = limited_address_space(&rasterise(&big, size, &["--co", "TILED=YES"]), limit);
    let m = measure(command.arg("--stats"))?;
    let bands = m.stderr.lines().filter(|l| l.starts_with('{')).count();
    let file = std::fs::metadata(&big).map_err(|e| e.to_string())?.len();
    let bigtiff = {
        let mut magic = [0u8; 4];
        std::fs::File::open(&big).and_then(|mut f| std::io::Read::read_exact(&mut f, &mut magic)).is_ok() && magic[2] == 43
    };
    let raster_bytes = size as u64 * size as u64 * 4;
    let mut checked = Vec::new();
    for (x0, y0) in [(0, 0), (size / 2 / 256 * 256, size / 3 / 256 * 256), (size - 1024, size - 1024)] {
        let window = dir.join("window.tif");
        let w = [x0.to_string(), y0.to_string(), "1024".into(), "1024".into()];
        measure(&mut rasterise(&window, size, &["--window", &w[0], &w[1], &w[2], &w[3]]))?;
        let differ = same_bits(&read_tiled_window(&big, x0, y0, 1024)?, &read_values(&window)?);
        checked.push(format!("({x0}, {y0}): {differ} differ"));
    }
    let _ = writeln!(
        s,
        "**Larger than the memory it may use.** The same points onto {size}² cells ({} of Float32), the process's address space \
         limited to {limit_mib} MiB (`ulimit -v`) and no `--memory`: it found the limit itself and streamed {bands} bands in {:.1} s, \
         peak resident memory {} for the whole process (points, TIN and all), a {} tiled {}. \
         Three 1024² windows of the file, read tile by tile, against `--window` runs of the same cells: {}.\n",
        mib(raster_bytes),
        m.seconds,
        mib(peak_of(&m.stderr)?),
        mib(file),
        if bigtiff { "BigTIFF" } else { "classic TIFF" },
        checked.join("; ")
    );

    // The same run as a cloud-optimised GeoTIFF: each level's tiles spill to an unnamed
    // temporary file until the directories, which come first, can be written.
    let cog = dir.join("big-cog.tif");
    eprintln!("stream-report: {size}² as a COG under ulimit -v {limit_mib} MiB ...");
    let mut command = limited_address_space(&rasterise(&cog, size, &["--of", "COG", "--co", "COMPRESS=DEFLATE", "--co", "PREDICTOR=YES"]), limit);
    let m = measure(&mut command)?;
    let validator =
        match Command::new("/usr/bin/python3").args(["-m", "osgeo_utils.samples.validate_cloud_optimized_geotiff", "--full-check=yes"]).arg(&cog).output() {
            Ok(out) if out.status.success() => String::from_utf8_lossy(&out.stdout).trim().replace('\n', " "),
            Ok(out) => format!("**refused**: {}", String::from_utf8_lossy(&out.stdout).trim().replace('\n', " ")),
            Err(e) => format!("not run ({e})"),
        };
    let mut checked = Vec::new();
    for (x0, y0) in [(0, 0), (size / 2 / 256 * 256, size / 3 / 256 * 256), (size - 1024, size - 1024)] {
        let differ = same_bits(&read_tiled_window(&cog, x0, y0, 1024)?, &read_tiled_window(&big, x0, y0, 1024)?);
        checked.push(format!("({x0}, {y0}): {differ} differ"));
    }
    let _ = writeln!(
        s,
        "**A COG larger than memory.** The same run with `--of COG --co COMPRESS=DEFLATE --co PREDICTOR=YES`, under the same limit: {:.1} s, \
         peak resident memory {}, a {} file; GDAL's validator (`--full-check=yes`): {validator}. Three 1024² windows against the tiled file's: {}.\n",
        m.seconds,
        mib(peak_of(&m.stderr)?),
        mib(std::fs::metadata(&cog).map_err(|e| e.to_string())?.len()),
        checked.join("; ")
    );

    // Interrupted: SIGINT, then SIGTERM, 1.5 s into the streamed run: the time to exit, how
    // it ended, what is left.
    for (signal, name) in [(libc::SIGINT, "SIGINT"), (libc::SIGTERM, "SIGTERM")] {
        let out = dir.join("interrupted.tif");
        let mut child = rasterise(&out, size, &["--memory", "64"]).stderr(std::process::Stdio::piped()).spawn().map_err(|e| e.to_string())?;
        std::thread::sleep(std::time::Duration::from_millis(1500));
        let partial = std::fs::metadata(dir.join("interrupted.tif.tileraster-partial")).map(|m| m.len()).unwrap_or(0);
        // SAFETY: kill(2) of our own child.
        unsafe { libc::kill(child.id() as libc::pid_t, signal) };
        let sent = Instant::now();
        let status = child.wait().map_err(|e| e.to_string())?;
        let exited = sent.elapsed();
        let left: Vec<String> = std::fs::read_dir(dir)
            .map_err(|e| e.to_string())?
            .filter_map(|e| e.ok()?.file_name().into_string().ok())
            .filter(|name| name.starts_with("interrupted"))
            .collect();
        let _ = writeln!(
            s,
            "**Interrupted by {name}** 1.5 s into a run of the same points onto {size}² cells with `--memory 64` ({} written to the partial file by then): \
             ended {:.0} ms after the signal, {}, leaving {}.\n",
            mib(partial),
            exited.as_secs_f64() * 1e3,
            match (status.code(), std::os::unix::process::ExitStatusExt::signal(&status)) {
                (_, Some(n)) => format!("by the signal itself (a shell reports {})", 128 + n),
                (Some(c), None) => format!("with status {c}"),
                (None, None) => "somehow".into(),
            },
            if left.is_empty() { "no file".to_string() } else { left.join(", ") }
        );
    }
    Ok(s)
}
