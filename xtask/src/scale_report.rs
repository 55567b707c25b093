//! `cargo xtask scale-report TILES [--copc DIR] [--class N] [--tr R] [--memory MIB] [--chunks N]
//! [--python PY]`: a DEM from a directory of point tiles as users have them (made by
//! `benches/synthetic_lidar.py`; `benches/to_copc.py` writes them as COPC), measured as whole
//! processes: the command line (release build) to a COG at `--tr` under `--memory` (wall time,
//! peak resident memory, points a second, the blocks it made), the same tiles as COPC, and
//! `tileraster.dask` on a `distributed.LocalCluster` of two single-threaded worker processes
//! (`--python` names an interpreter with tileraster, dask, distributed, rioxarray and
//! rasterio), whose wall time and each worker's peak memory and CPU time are reported and whose
//! cells are compared with the command line's, bit for bit. Prints markdown.

use crate::stream_report::peak_of;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// What the report runs on.
pub struct Options {
    pub tiles: PathBuf,
    pub copc: Option<PathBuf>,
    pub class: Option<u8>,
    pub tr: f64,
    pub memory_mib: u64,
    pub chunks: u32,
    pub python: Option<PathBuf>,
}

/// The Dask run, as a script for `--python`: argv = tiles, tr, classes, chunk side, output,
/// the command line's COG. Prints one JSON object.
const DASK_SCRIPT: &str = r#"
import json, resource, sys, time
import numpy as np, rasterio, rioxarray
from distributed import Client, LocalCluster, Lock
import tileraster, tileraster.dask
tiles, tr, classes, chunk, out, cli = sys.argv[1], float(sys.argv[2]), [int(c) for c in sys.argv[3].split(",") if c], int(sys.argv[4]), sys.argv[5], sys.argv[6]
with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster, Client(cluster) as client:
    start = time.monotonic()
    dem = tileraster.dask.points_to_dem([tiles], tileraster.Grid(tr=(tr, tr)), chunks=(chunk, chunk), classes=classes)
    dem.rio.to_raster(out, tiled=True, lock=Lock("scale-report"))
    wall = time.monotonic() - start
    workers = client.run(lambda: (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, time.process_time()))
with rasterio.open(out) as a, rasterio.open(cli) as b:
    x, y = a.read(1), b.read(1)
differ = int(np.count_nonzero(x.view(np.uint32) != y.view(np.uint32))) if x.shape == y.shape else -1
print(json.dumps({"wall": wall, "chunks": int(np.prod(dem.data.numblocks)), "workers": [list(v) for v in workers.values()], "cells": int(x.size), "differ": differ}))
"#;

/// One command-line run: its time, peak and notes.
struct CliRun {
    seconds: f64,
    /// Bytes.
    peak: u64,
    notes: String,
}

fn run_cli(bin: &Path, input: &Path, out: &Path, options: &Options) -> Result<CliRun, String> {
    let mut command = Command::new("/usr/bin/time");
    command.args(["-f", "peak resident KiB: %M"]).arg(bin).arg("rasterise").arg(input).arg("-o").arg(out);
    command.args(["--of", "COG", "--backend", "cpu", "--tr", &options.tr.to_string(), &options.tr.to_string(), "--memory", &options.memory_mib.to_string()]);
    if let Some(class) = options.class {
        command.args(["--class", &class.to_string()]);
    }
    let start = Instant::now();
    let output = command.output().map_err(|e| format!("{command:?}: {e}"))?;
    let seconds = start.elapsed().as_secs_f64();
    let notes = String::from_utf8_lossy(&output.stderr).to_string();
    if !output.status.success() {
        return Err(format!("{command:?} failed: {notes}"));
    }
    Ok(CliRun { seconds, peak: peak_of(&notes)?, notes })
}

/// The files of a directory and what their LAS headers count.
fn inventory(dir: &Path) -> Result<(usize, u64, u64), String> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| format!("{}: {e}", dir.display()))? {
        let path = entry.map_err(|e| e.to_string())?.path();
        if path.extension().is_some_and(|e| e == "laz" || e == "las") {
            files.push(path);
        }
    }
    let bytes = files.iter().map(|f| std::fs::metadata(f).map(|m| m.len()).unwrap_or(0)).sum();
    let records = files.iter().map(|f| tileraster_io::las_point_count(f).map_err(|e| e.to_string())).sum::<Result<u64, String>>()?;
    Ok((files.len(), records, bytes))
}

/// A number from the notes: the first `at`-th whitespace word after `after`.
fn note_number(notes: &str, after: &str, at: usize) -> Option<f64> {
    notes.split(after).nth(1)?.split_whitespace().nth(at)?.trim_end_matches([',', ')']).parse().ok()
}

pub fn run(options: &Options) -> Result<String, String> {
    let bin = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../target/release/tileraster");
    if !bin.exists() {
        return Err(format!("{} is missing (`cargo build --release --bin tileraster` builds it)", bin.display()));
    }
    let dir = std::env::temp_dir().join(format!("tileraster-scale-{}", std::process::id()));
    std::fs::create_dir_all(&dir).map_err(|e| e.to_string())?;
    let result = report(&bin, &dir, options);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn report(bin: &Path, dir: &Path, options: &Options) -> Result<String, String> {
    let class = options.class.map_or(String::new(), |c| format!(" --class {c}"));
    let mut s = format!(
        "`tileraster rasterise TILES -o dem.tif --of COG --tr {0} {0} --memory {1}{class} --backend cpu`, whole processes, one run each \
         (peak resident memory by GNU time).\n\n\
         | input | files | point records | bytes | wall | peak resident | points a second | first pass | blocks | points a block |\n\
         | --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |\n",
        options.tr, options.memory_mib
    );
    let mut cli_cog = None;
    for (what, input) in [("LAZ tiles", Some(&options.tiles)), ("the same as COPC", options.copc.as_ref())] {
        let Some(input) = input else { continue };
        eprintln!("scale-report: {what} ({}) ...", input.display());
        let (files, records, bytes) = inventory(input)?;
        let out = dir.join(format!("{}.tif", cli_cog.is_some() as u8));
        let run = run_cli(bin, input, &out, options)?;
        let points = note_number(&run.notes, "tileraster: ", 0).unwrap_or(records as f64);
        let first = note_number(&run.notes, "read in ", 0).map_or("–".into(), |ms| format!("{:.1} s", ms / 1e3));
        let blocks = run.notes.split_once(" blocks in bands").and_then(|(before, _)| before.rsplit(' ').next()).unwrap_or("–").to_string();
        let range = run.notes.split("triangulated ").last().and_then(|t| t.split(" of the").next()).filter(|t| t.contains(" to ")).unwrap_or("–").to_string();
        let _ = writeln!(
            s,
            "| {what} | {files} | {records} | {:.0} MB | {:.1} s | {} MiB | {:.3} million | {first} | {blocks} | {range} |",
            bytes as f64 / 1e6,
            run.seconds,
            run.peak >> 20,
            points / run.seconds / 1e6
        );
        cli_cog.get_or_insert(out);
    }
    let Some(python) = &options.python else {
        s += "\nDask: not run (give `--python` an interpreter with tileraster, dask, distributed, rioxarray and rasterio).\n";
        return Ok(s);
    };
    eprintln!("scale-report: tileraster.dask on a LocalCluster of two worker processes ...");
    let classes = options.class.map_or(String::new(), |c| c.to_string());
    let out = dir.join("dask.tif");
    let cli = cli_cog.expect("the LAZ run");
    let output = Command::new(python)
        .arg("-c")
        .arg(DASK_SCRIPT)
        .arg(&options.tiles)
        .arg(options.tr.to_string())
        .arg(&classes)
        .arg(options.chunks.to_string())
        .arg(&out)
        .arg(&cli)
        .output()
        .map_err(|e| format!("{}: {e}", python.display()))?;
    let stdout = String::from_utf8_lossy(&output.stdout);
    if !output.status.success() {
        return Err(format!("the Dask run failed: {}", String::from_utf8_lossy(&output.stderr)));
    }
    let field = |name: &str| stdout.split(&format!("\"{name}\": ")).nth(1).and_then(|t| t.split([',', '}']).next()).and_then(|t| t.trim().parse::<f64>().ok());
    let workers: Vec<(f64, f64)> = stdout
        .split("\"workers\": [[")
        .nth(1)
        .and_then(|t| t.split("]]").next())
        .map(|t| t.split("], [").filter_map(|w| w.split_once(", ").and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))).collect())
        .unwrap_or_default();
    let (wall, chunks, cells, differ) = (field("wall"), field("chunks"), field("cells"), field("differ"));
    let _ = writeln!(
        s,
        "\n`tileraster.dask.points_to_dem` on a `distributed.LocalCluster` of 2 worker processes of 1 thread, chunks of {0}² cells, \
         written with `rio.to_raster` under a `distributed.Lock`: {1} chunks in **{2:.1} s**; per worker: {3}. Cells against the \
         command line's COG: {4} of {5} differ.",
        options.chunks,
        chunks.unwrap_or(0.0),
        wall.unwrap_or(f64::NAN),
        workers.iter().map(|(kib, cpu)| format!("peak {:.0} MiB, {:.1} s CPU", kib / 1024.0, cpu)).collect::<Vec<_>>().join("; "),
        differ.map_or("?".into(), |d| format!("{d:.0}")),
        cells.map_or("?".into(), |c| format!("{c:.0}"))
    );
    Ok(s)
}
