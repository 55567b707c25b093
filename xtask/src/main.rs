//! Project tasks.
//!
//! - `cargo xtask kernels`: what the rust-gpu build of `shader-crate` produced — size,
//!   capabilities, entry points with their workgroup sizes — as a quick check that the module
//!   is what the GPU backend expects; then the adapter, its float controls and which module
//!   it gets.
//! - `cargo xtask bench-report [--quick] [--tables-only] [--out DIR]`: run time against error
//!   for every backend × mode × scene beside the peers; writes `DIR/benchmarks.md` and
//!   `DIR/time-vs-error.svg` (`DIR` defaults to `docs`), with the skips section.
//!   `--tables-only` leaves out the sections that run the command line (gdal_grid, streaming).
//! - `cargo xtask delaunay-report [POINTS]`: the candidate Delaunay crates timed and checked on
//!   the same point sets (default one million points), printed as markdown.
//! - `cargo xtask gdal-report [POINTS] [SIZE]`: points in, GeoTIFF out, against gdal_grid:
//!   time and cell-by-cell agreement (default 100,000 points onto 4096²).
//! - `cargo xtask stream-report [POINTS] [SIZE] [LIMIT_MIB]`: the cluster recipe run locally
//!   (parts as separate processes, a VRT mosaic, compared with the single run) and a grid
//!   larger than its address-space limit streamed to disk (default 100,000 points, 32768², 1536 MiB).
//! - `cargo xtask scale-report TILES [--copc DIR] [--class N] [--tr R] [--memory MIB] [--chunks N]
//!   [--python PY]`: a DEM at scale from a directory of point tiles: the command line as one
//!   process (time, peak memory, points a second), the tiles as COPC, and `tileraster.dask` on a
//!   two-process `LocalCluster` (time and each worker's memory), cells compared.
//! - `cargo xtask fingerprint`: a hash per scene × mode of what `prepare` made and of the CPU
//!   raster, to show that a change (speed work, say) changed no bit: run it before and after.
//! - `cargo xtask render-report [--quick | --fragment | --textures]`: the render pipeline
//!   against wgpu's render pipeline on the same adapter (a 100k-triangle mesh at 1920×1080, a 1M-triangle mesh at 4096², a
//!   fill-rate scene of overdraw 8), printed as markdown; also a section of `bench-report`.
//!   `--fragment`: only its programmable fragment stage section; `--textures`: only its
//!   textures section.
//! - `cargo xtask skip-report [--quick]`: only the skips section (each skip on and off, prepare
//!   once, a sparse scene), printed as markdown.
//! - `cargo xtask stage-times [--walk always|never|auto] [--runs N] [--cpu | --gpu] [NAME_PART]`: a
//!   call's time pass by pass on each backend (the CPU's host times, the GPU's device times
//!   from timestamp queries, with its dispatches, waits and bytes moved) on the
//!   micro-triangles, the slivers, the 4096² TIN and the render pipeline's meshes, printed as
//!   markdown. `--walk` sets how the GPU's heightfield tiles meet their bins (`FineWalk`);
//!   `--runs` how many calls each median takes (a profiler wants a long run).

mod bench_report;
mod delaunay_report;
mod fingerprint;
mod gdal_report;
mod render_report;
mod scale_report;
mod skip_report;
mod stage_times;
mod stream_report;
mod svg;

use std::process::ExitCode;

const OP_CAPABILITY: u32 = 17;
const OP_ENTRY_POINT: u32 = 15;
const OP_EXECUTION_MODE: u32 = 16;
const EXECUTION_MODE_LOCAL_SIZE: u32 = 17;
const SPIRV_MAGIC: u32 = 0x0723_0203;

fn usage() -> ExitCode {
    eprintln!(
        "usage: cargo xtask kernels\n       cargo xtask bench-report [--quick] [--tables-only] [--out DIR]\n       cargo xtask skip-report [--quick]\n       cargo xtask render-report [--quick | --fragment | --textures]\n       cargo xtask fingerprint\n       cargo xtask stage-times [--walk always|never|auto] [--runs N] [--cpu | --gpu] [NAME_PART]\n       cargo xtask delaunay-report [POINTS]\n       cargo xtask gdal-report [POINTS] [SIZE]\n       cargo xtask stream-report [POINTS] [SIZE] [LIMIT_MIB]\n       cargo xtask scale-report TILES [--copc DIR] [--class N] [--tr R] [--memory MIB] [--chunks N] [--python PY]"
    );
    ExitCode::from(2)
}

/// A literal string operand: UTF-8, NUL-terminated, packed into words.
fn literal_string(words: &[u32]) -> String {
    let bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).take_while(|&b| b != 0).collect();
    String::from_utf8_lossy(&bytes).into_owned()
}

fn kernels() -> Result<(), String> {
    let bytes = tileraster_gpu::KERNELS_SPV;
    if !bytes.len().is_multiple_of(4) {
        return Err(format!("SPIR-V module is {} bytes, not a whole number of words", bytes.len()));
    }
    let words: Vec<u32> = bytes.as_chunks::<4>().0.iter().map(|&c| u32::from_le_bytes(c)).collect();
    if words.first() != Some(&SPIRV_MAGIC) {
        return Err("not a SPIR-V module (bad magic number)".into());
    }
    let version = words[1];
    println!("SPIR-V {}.{}, {} bytes, bound {}", (version >> 16) & 0xff, (version >> 8) & 0xff, bytes.len(), words[3]);
    let mut capabilities = Vec::new();
    let mut entries = Vec::new(); // (function id, name)
    let mut sizes = std::collections::HashMap::new();
    let mut at = 5;
    while at < words.len() {
        let (count, opcode) = ((words[at] >> 16) as usize, words[at] & 0xffff);
        if count == 0 || at + count > words.len() {
            return Err(format!("malformed instruction at word {at}"));
        }
        let operands = &words[at + 1..at + count];
        match opcode {
            OP_CAPABILITY => capabilities.push(operands[0]),
            OP_ENTRY_POINT => entries.push((operands[1], literal_string(&operands[2..]))),
            OP_EXECUTION_MODE if operands[1] == EXECUTION_MODE_LOCAL_SIZE => {
                sizes.insert(operands[0], (operands[2], operands[3], operands[4]));
            }
            _ => {}
        }
        at += count;
    }
    println!("capabilities (SPIR-V enumerants): {capabilities:?}");
    for (id, name) in &entries {
        let (x, y, z) = sizes.get(id).copied().unwrap_or_default();
        println!("entry point {name:<24} workgroup {x}×{y}×{z}");
    }
    match tileraster::gpu_adapter() {
        Ok(a) => {
            let module = if a.float_controls_declared { "with float controls" } else { "plain" };
            println!("adapter {a}\n  {}\n  module: {module}", a.float_controls);
        }
        Err(e) => println!("adapter: none ({e})"),
    }
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.iter().map(String::as_str).collect::<Vec<_>>().as_slice() {
        ["kernels"] => match kernels() {
            Ok(()) => ExitCode::SUCCESS,
            Err(e) => {
                eprintln!("xtask: {e}");
                ExitCode::FAILURE
            }
        },
        ["bench-report", rest @ ..] => {
            let mut options = bench_report::Options { quick: false, tables_only: false, out_dir: "docs".into() };
            let mut rest = rest.iter();
            while let Some(arg) = rest.next() {
                match *arg {
                    "--quick" => options.quick = true,
                    "--tables-only" => options.tables_only = true,
                    "--out" => match rest.next() {
                        Some(dir) => options.out_dir = dir.into(),
                        None => return usage(),
                    },
                    _ => return usage(),
                }
            }
            match bench_report::run(&options).and_then(|report| bench_report::write(&report, &options)) {
                Ok(()) => ExitCode::SUCCESS,
                Err(e) => {
                    eprintln!("xtask bench-report: {e}");
                    ExitCode::FAILURE
                }
            }
        }
        ["delaunay-report", rest @ ..] => match numbers(rest, &[1_000_000]) {
            Some(n) => print_markdown("delaunay-report", delaunay_report::run(n[0] as usize)),
            None => usage(),
        },
        ["gdal-report", rest @ ..] => match numbers(rest, &[100_000, 4096]) {
            Some(n) => print_markdown("gdal-report", gdal_report::run(n[0] as usize, n[1] as u32).map(|e| format!("{}\n{}", e.markdown, e.goals))),
            None => usage(),
        },
        ["stream-report", rest @ ..] => match numbers(rest, &[100_000, 32_768, 1536]) {
            Some(n) => print_markdown("stream-report", stream_report::run(n[0] as usize, n[1] as u32, n[2])),
            None => usage(),
        },
        ["scale-report", tiles, rest @ ..] => {
            let mut options = scale_report::Options { tiles: tiles.into(), copc: None, class: None, tr: 1.0, memory_mib: 1536, chunks: 2000, python: None };
            let mut rest = rest.iter();
            while let Some(flag) = rest.next() {
                let Some(value) = rest.next() else { return usage() };
                let parsed = match *flag {
                    "--copc" => {
                        options.copc = Some(value.into());
                        true
                    }
                    "--python" => {
                        options.python = Some(value.into());
                        true
                    }
                    "--class" => value.parse().map(|c| options.class = Some(c)).is_ok(),
                    "--tr" => value.parse().map(|r| options.tr = r).is_ok(),
                    "--memory" => value.parse().map(|m| options.memory_mib = m).is_ok(),
                    "--chunks" => value.parse().map(|c| options.chunks = c).is_ok(),
                    _ => false,
                };
                if !parsed {
                    return usage();
                }
            }
            print_markdown("scale-report", scale_report::run(&options))
        }
        ["fingerprint"] => print_markdown("fingerprint", fingerprint::run()),
        ["stage-times", rest @ ..] => {
            // `--walk always | never`: how the GPU's heightfield tiles meet their bins
            // (`FineWalk`), to compare the two ways on an adapter.
            let rest = match rest {
                ["--walk", way, rest @ ..] => {
                    tileraster::set_gpu_fine_walk(match *way {
                        "always" => tileraster::FineWalk::Always,
                        "never" => tileraster::FineWalk::Never,
                        "auto" => tileraster::FineWalk::Auto,
                        _ => return usage(),
                    });
                    rest
                }
                rest => rest,
            };
            let (runs, rest) = match rest {
                ["--runs", n, rest @ ..] => match n.parse::<usize>() {
                    Ok(n) if n > 0 => (Some(n), rest),
                    _ => return usage(),
                },
                rest => (None, rest),
            };
            let (backends, only) = match rest {
                ["--cpu", only @ ..] => (stage_times::Backends::Cpu, only),
                ["--gpu", only @ ..] => (stage_times::Backends::Gpu, only),
                only => (stage_times::Backends::Both, only),
            };
            match only {
                [] => print_markdown("stage-times", stage_times::run(None, backends, runs)),
                [only] => print_markdown("stage-times", stage_times::run(Some(only), backends, runs)),
                _ => usage(),
            }
        }
        ["render-report", rest @ ..] => match rest {
            [] => print_markdown("render-report", render_report::run(false)),
            ["--quick"] => print_markdown("render-report", render_report::run(true)),
            ["--fragment"] => print_markdown("render-report", render_report::fragment_only()),
            ["--textures"] => print_markdown("render-report", render_report::textures_only()),
            _ => usage(),
        },
        ["skip-report", rest @ ..] => match rest {
            [] => print_markdown("skip-report", skip_report::run(false)),
            ["--quick"] => print_markdown("skip-report", skip_report::run(true)),
            _ => usage(),
        },
        _ => usage(),
    }
}

/// Positional numbers, each one not given taken from `defaults`; none if one is not a number
/// or there are too many.
fn numbers(args: &[&str], defaults: &[u64]) -> Option<Vec<u64>> {
    if args.len() > defaults.len() {
        return None;
    }
    let given: Option<Vec<u64>> = args.iter().map(|a| a.parse().ok()).collect();
    Some(given?.into_iter().chain(defaults[args.len()..].iter().copied()).collect())
}

/// A report's markdown on stdout, or its error on stderr.
fn print_markdown(task: &str, report: Result<String, String>) -> ExitCode {
    match report {
        Ok(markdown) => {
            println!("{markdown}");
            ExitCode::SUCCESS
        }
        Err(e) => {
            eprintln!("xtask {task}: {e}");
            ExitCode::FAILURE
        }
    }
}

/// A finished child process: wall seconds and what it wrote on stderr. (Not its peak memory:
/// a child's peak as `wait4` reports it counts this process's pages; `stream-report` runs
/// the command under GNU time instead.)
pub(crate) struct Measured {
    pub seconds: f64,
    pub stderr: String,
}

/// Run `command` to its end.
pub(crate) fn measure(command: &mut std::process::Command) -> Result<Measured, String> {
    let start = std::time::Instant::now();
    let child = command.stderr(std::process::Stdio::piped()).spawn().map_err(|e| format!("{command:?}: {e}"))?;
    let pid = child.id() as libc::pid_t;
    let mut stderr = child.stderr.ok_or("no stderr")?;
    let mut text = String::new();
    std::io::Read::read_to_string(&mut stderr, &mut text).map_err(|e| e.to_string())?;
    let mut status = 0;
    // SAFETY: `pid` is our child, not yet waited for; the out-pointer is valid.
    if unsafe { libc::waitpid(pid, &mut status, 0) } != pid {
        return Err(format!("{command:?}: waitpid failed"));
    }
    let seconds = start.elapsed().as_secs_f64();
    if !(libc::WIFEXITED(status) && libc::WEXITSTATUS(status) == 0) {
        return Err(format!("{command:?} failed: {text}"));
    }
    Ok(Measured { seconds, stderr: text })
}

/// The median of measured times (seconds).
fn median(times: Vec<f64>) -> f64 {
    Timing::of(times).median
}

/// Repeated measurements of one thing (seconds): the median, and the fastest and slowest run,
/// so a report shows whether a difference is larger than the machine's noise.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Timing {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Timing {
    fn of(mut times: Vec<f64>) -> Self {
        times.sort_by(f64::total_cmp);
        Timing { median: times[times.len() / 2], min: times[0], max: times[times.len() - 1] }
    }

    /// The slowest run against the fastest, less one: 0.05 means they were within 5 %.
    pub fn spread(&self) -> f64 {
        self.max / self.min - 1.0
    }
}

/// Today's date (UTC) as `YYYY-MM-DD`, from the system clock.
fn today() -> String {
    let days = std::time::SystemTime::now().duration_since(std::time::UNIX_EPOCH).map(|d| d.as_secs() / 86_400).unwrap_or(0) as i64;
    // Civil date from days since 1970-01-01 (Howard Hinnant's algorithm).
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}
