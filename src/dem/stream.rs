//! A window, rasterised in bands of rows and streamed to its files: prepared once, each
//! band written while the next is rasterised, so memory holds two bands whatever the grid's
//! size. Every band's cells are the whole grid's there, so the files do not depend
//! on how the window was cut.

use super::block::{BlockRead, FileSummary, HeldPoints, block_scene_held};
use super::{DemError, Fallback, Progress, ReadOptions};
use crate::{Backend, Grid, Params, PreparedScene, Raster, Scene, Stats, Window};
use std::path::Path;
use tileraster_io::{GeoTiffOptions, GeoTiffWriter, Sample, TILE};

/// Where a run's results go. Each file is written beside its destination and renamed into
/// place once complete and durable: a failed run leaves no partial file.
pub struct Destinations<'a> {
    /// The heights (Float32, nodata tagged).
    pub heights: &'a Path,
    /// The owner-triangle raster (UInt32), if asked for.
    pub owner: Option<&'a Path>,
    /// A hillshaded PNG preview, if asked for (sampled down to `PREVIEW_SIDE`).
    pub preview: Option<&'a Path>,
    pub tiff: GeoTiffOptions,
}

/// What a run did.
#[derive(Debug)]
pub struct Run {
    /// Each band's statistics, top to bottom.
    pub bands: Vec<Stats>,
    pub snap_bits: u32,
    /// Cells outside every triangle that the fallback filled.
    pub filled: u64,
}

/// The longest side of a preview; larger windows are sampled every few cells.
pub const PREVIEW_SIDE: u32 = 4096;

/// Bytes a band holds per cell: each layer's 4, twice on the GPU (the device copy is read
/// back into the host's).
pub fn bytes_per_cell(owner: bool, backend: Backend) -> u64 {
    let layers = 1 + owner as u64;
    4 * layers * if backend == Backend::Gpu { 2 } else { 1 }
}

/// Rows per band: the whole window when it fits in `budget` bytes; else as many whole tile
/// rows as the budget holds (at least one tile row).
pub fn band_rows(window: &Window, bytes_per_cell: u64, budget: u64) -> u32 {
    let row = (window.width as u64 * bytes_per_cell).max(1);
    if row * window.height as u64 <= budget {
        return window.height;
    }
    let rows = (budget / row) / TILE as u64 * TILE as u64;
    rows.max(TILE as u64).min(window.height as u64) as u32
}

/// Rows per band for [`write_dem`], which writes one band while it draws the next: the whole
/// window when it fits in `budget` bytes, else bands of half the budget each.
pub fn streamed_band_rows(window: &Window, bytes_per_cell: u64, budget: u64) -> u32 {
    match band_rows(window, bytes_per_cell, budget) {
        whole if whole == window.height => whole,
        _ => band_rows(window, bytes_per_cell, budget / 2),
    }
}

/// Rasterise `window` of `params.grid` on `backend` in bands of `band_rows` rows (see
/// [`streamed_band_rows`]), each written to `outputs` while the next is drawn, with the cells outside
/// every triangle filled by `fallback` when given. An owner file or a fallback turns the
/// owner layer on (count it in [`bytes_per_cell`]).
#[allow(clippy::too_many_arguments)]
pub fn write_dem(
    scene: &Scene,
    params: &Params,
    window: Window,
    backend: Backend,
    band_rows: u32,
    outputs: &Destinations,
    fallback: Option<&Fallback>,
    progress: &dyn Progress,
) -> Result<Run, DemError> {
    let mut params = *params;
    params.outputs.owner |= outputs.owner.is_some() || fallback.is_some();
    let prepared = crate::prepare(scene, &params, Some(window))?;
    let mut scene = PreparedScene::from_prepared(prepared, backend);
    stream_bands(&params, window, band_rows, outputs, fallback, progress, |band| Ok(scene.rasterise_window(band)?))
}

/// The DEM of the points of the summarised `files` on `window`, written as [`write_dem`]
/// writes it, in bands of `band_rows` rows cut into blocks about as wide, each block's TIN made
/// from the points around it only ([`block_scene_held`]) and its blocks run on all cores: the
/// whole TIN's cells, holding a band's points and those near the hull's edges. Returns how
/// each block's TIN was made too.
#[allow(clippy::too_many_arguments)]
pub fn write_dem_of_files(
    files: &[FileSummary],
    options: &ReadOptions,
    params: &Params,
    window: Window,
    backend: Backend,
    band_rows: u32,
    outputs: &Destinations,
    progress: &dyn Progress,
) -> Result<(Run, Vec<BlockRead>), DemError> {
    use rayon::prelude::*;
    let near_hull = HeldPoints::near_hull(files, options)?;
    let mut blocks = Vec::new();
    let run = stream_bands(params, window, band_rows, outputs, None, progress, |band| {
        let held = HeldPoints::around(files, options, &params.grid, band)?;
        let columns: Vec<Window> = (0..band.width)
            .step_by(band.height.max(TILE) as usize)
            .map(|x| Window { x0: band.x0 + x, width: band.height.max(TILE).min(band.width - x), ..band })
            .collect();
        let drawn = columns
            .par_iter()
            .map(|&block| {
                let input = block_scene_held(files, &near_hull, &held, &params.grid, block, options)?;
                let prepared = crate::prepare(&input.scene, params, Some(block))?;
                Ok((PreparedScene::from_prepared(prepared, backend).rasterise_window(block)?, input.block))
            })
            .collect::<Result<Vec<_>, DemError>>()?;
        blocks.extend(drawn.iter().filter_map(|(_, block)| *block));
        Ok(side_by_side(band, drawn.into_iter().map(|(raster, _)| raster).collect()))
    })?;
    Ok((run, blocks))
}

/// The rasters of windows side by side, left to right, as one raster of `band`: their
/// values row by row, their statistics added up.
fn side_by_side(band: Window, parts: Vec<Raster>) -> Raster {
    let mut values = Vec::with_capacity(band.pixel_count() as usize);
    for row in 0..band.height as usize {
        for part in &parts {
            let width = part.window.width as usize;
            values.extend_from_slice(&part.values[row * width..(row + 1) * width]);
        }
    }
    let mut stats = parts[0].stats.clone();
    parts[1..].iter().for_each(|part| stats.absorb(&part.stats));
    let first = parts.into_iter().next().expect("a band has a block");
    Raster { window: band, values, stats, ..first }
}

/// Draw `window` in bands of `band_rows` rows with `draw`, each written to `outputs` while
/// the next is drawn.
fn stream_bands(
    params: &Params,
    window: Window,
    band_rows: u32,
    outputs: &Destinations,
    fallback: Option<&Fallback>,
    progress: &dyn Progress,
    mut draw: impl FnMut(Window) -> Result<Raster, DemError>,
) -> Result<Run, DemError> {
    let grid = &params.grid;
    let mut heights = GeoTiffWriter::create(outputs.heights, grid, window, Sample::Float32 { nodata: params.nodata }, &outputs.tiff)?;
    let mut owner = outputs.owner.map(|path| GeoTiffWriter::create(path, grid, window, Sample::UInt32, &outputs.tiff)).transpose()?;
    let mut preview = outputs.preview.map(|_| Sampled::new(grid, window, params.nodata));
    // Band `k + 1` is rasterised while band `k` is filled, sampled and written: the writer
    // takes each band through a rendezvous, so at most two bands are in memory (one being
    // written, one being drawn), as `bytes_per_cell` counts.
    let mut run = Run { bands: Vec::new(), snap_bits: 0, filled: 0 };
    let (drawn, written) = std::thread::scope(|threads| {
        let (hand, take) = std::sync::mpsc::sync_channel::<Raster>(0);
        let (run, heights, owner, preview) = (&mut run, &mut heights, &mut owner, &mut preview);
        let writer = threads.spawn(move || -> Result<(), DemError> {
            for mut raster in take {
                if let Some(fallback) = fallback {
                    run.filled += fallback.fill(&mut raster);
                }
                heights.write_rows(&raster.values)?;
                if let (Some(file), Some(layer)) = (owner.as_mut(), raster.owner.as_deref()) {
                    file.write_rows(layer)?;
                }
                if let Some(sampled) = preview.as_mut() {
                    sampled.add(&raster);
                }
                run.snap_bits = raster.snap_bits;
                run.bands.push(raster.stats);
            }
            Ok(())
        });
        let drawn = (|| -> Result<(), DemError> {
            for y in (0..window.height).step_by(band_rows as usize) {
                let band = Window { x0: window.x0, y0: window.y0 + y, width: window.width, height: band_rows.min(window.height - y) };
                let raster = draw(band)?;
                if hand.send(raster).is_err() {
                    // The writer stopped on an error: it is the run's.
                    return Ok(());
                }
                progress.advance(band.height as u64);
            }
            Ok(())
        })();
        drop(hand);
        let written = writer.join().unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (drawn, written)
    });
    // A band that failed to draw or to write leaves the files unfinished: dropped, they are
    // removed, and no file is left behind.
    drawn?;
    written?;
    progress.stage("writing");
    heights.finish()?;
    if let Some(file) = owner {
        file.finish()?;
    }
    if let (Some(path), Some(sampled)) = (outputs.preview, preview) {
        tileraster_io::write_preview_png(&sampled.into_raster(run.snap_bits), path)?;
    }
    Ok(run)
}

/// Every `step`-th cell of every `step`-th row of a window, gathered band by band: a preview
/// of at most `PREVIEW_SIDE` cells a side.
struct Sampled {
    step: u32,
    window: Window,
    grid: Grid,
    nodata: f32,
    width: u32,
    values: Vec<f32>,
}

impl Sampled {
    fn new(grid: &Grid, window: Window, nodata: f32) -> Sampled {
        let step = window.width.max(window.height).div_ceil(PREVIEW_SIDE).max(1);
        let width = window.width.div_ceil(step);
        let cells = width as usize * window.height.div_ceil(step) as usize;
        Sampled { step, window, grid: *grid, nodata, width, values: Vec::with_capacity(cells) }
    }

    fn add(&mut self, band: &Raster) {
        for j in 0..band.height() {
            if (band.window.y0 + j - self.window.y0).is_multiple_of(self.step) {
                self.values.extend((0..band.width()).step_by(self.step as usize).map(|i| band.value(i, j)));
            }
        }
    }

    /// The samples as a raster of their own coarse grid over the window.
    fn into_raster(self, snap_bits: u32) -> Raster {
        let height = (self.values.len() / self.width as usize) as u32;
        let (dx, dy) = (self.grid.dx() * self.step as f64, self.grid.dy() * self.step as f64);
        let xmin = self.grid.xmin + self.window.x0 as f64 * self.grid.dx();
        let ymax = self.grid.ymax - self.window.y0 as f64 * self.grid.dy();
        let grid = Grid::new(xmin, xmin + dx * self.width as f64, ymax - dy * height as f64, ymax, self.width, height);
        Raster {
            grid,
            window: Window::whole(&grid),
            nodata: self.nodata,
            values: self.values,
            owner: None,
            coverage: None,
            colours: None,
            faces: None,
            tiles: None,
            snap_bits,
            stats: Stats::default(),
        }
    }
}

/// The default memory budget (the command line's `--memory`): half of the least of what the system has available
/// (`MemAvailable`), what this process's cgroup may still take (a container's or a batch
/// job's limit: Kubernetes, Slurm) and what its address-space limit (`ulimit -v`) leaves;
/// 2 GiB where none of them says. Returns the budget and which limit set it.
pub fn default_memory_budget() -> (u64, &'static str) {
    let read = |path: &str| std::fs::read_to_string(path).ok();
    let mut limits = Vec::new();
    if let Some(available) = read("/proc/meminfo").and_then(|text| kib_field(&text, "MemAvailable:")) {
        limits.push((available, "the memory available"));
    }
    if let Some(room) = read("/proc/self/cgroup").and_then(|groups| cgroup_room(&groups, |path| read(path))) {
        limits.push((room, "the room left under the cgroup's memory limit"));
    }
    if let Some(room) = address_space_room(read("/proc/self/status").as_deref()) {
        limits.push((room, "the room left under the address-space limit"));
    }
    match limits.into_iter().min_by_key(|l| l.0) {
        Some((bytes, what)) => (bytes / 2, what),
        None => (2 << 30, "a default, as the system reports no memory figures"),
    }
}

/// A `/proc` field given in KiB, in bytes.
fn kib_field(text: &str, name: &str) -> Option<u64> {
    let line = text.lines().find(|l| l.starts_with(name))?;
    Some(line.split_whitespace().nth(1)?.parse::<u64>().ok()? * 1024)
}

/// Memory this process's cgroup may still take: cgroup v2 (`0::PATH`, memory.max and
/// memory.current) or v1 (`N:memory:PATH`, memory.limit_in_bytes and memory.usage_in_bytes).
/// Inside a cgroup namespace the group is mounted at the root, so that is tried too.
fn cgroup_room(groups: &str, read: impl Fn(&str) -> Option<String>) -> Option<u64> {
    let number = |text: Option<String>| text.and_then(|t| t.trim().parse::<u64>().ok());
    for line in groups.lines() {
        let mut fields = line.splitn(3, ':');
        let (_, controllers, path) = (fields.next()?, fields.next()?, fields.next()?);
        let (root, limit, usage) = match controllers {
            "" => ("/sys/fs/cgroup", "memory.max", "memory.current"),
            c if c.split(',').any(|c| c == "memory") => ("/sys/fs/cgroup/memory", "memory.limit_in_bytes", "memory.usage_in_bytes"),
            _ => continue,
        };
        for dir in [format!("{root}{}", path.trim_end_matches('/')), root.to_string()] {
            // "max", or v1's "unlimited" of about 2^63, parse to none or to no limit.
            if let Some(limit) = number(read(&format!("{dir}/{limit}"))).filter(|&l| l < 1 << 60) {
                return Some(limit.saturating_sub(number(read(&format!("{dir}/{usage}"))).unwrap_or(0)));
            }
        }
    }
    None
}

/// Address space `ulimit -v` leaves this process, from its limit and its `VmSize`.
#[allow(clippy::unnecessary_cast)] // rlim_t is not u64 on every target
fn address_space_room(status: Option<&str>) -> Option<u64> {
    let mut limit = libc::rlimit { rlim_cur: 0, rlim_max: 0 };
    // SAFETY: getrlimit writes one `rlimit` through a valid pointer.
    if unsafe { libc::getrlimit(libc::RLIMIT_AS, &mut limit) } != 0 || limit.rlim_cur == libc::RLIM_INFINITY {
        return None;
    }
    Some((limit.rlim_cur as u64).saturating_sub(status.and_then(|s| kib_field(s, "VmSize:")).unwrap_or(0)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bands_are_whole_tile_rows_within_the_budget() {
        let window = Window { x0: 0, y0: 0, width: 1000, height: 3000 };
        assert_eq!(band_rows(&window, 4, 12_000_000), 3000, "fits whole");
        assert_eq!(band_rows(&window, 4, 4_000 * 700), 512);
        assert_eq!(band_rows(&window, 8, 4_000 * 700), 256);
        assert_eq!(band_rows(&window, 4, 1), 256, "at least one tile row");
        // Streamed: two bands in memory, one written while the next is drawn.
        assert_eq!(streamed_band_rows(&window, 4, 12_000_000), 3000, "fits whole");
        assert_eq!(streamed_band_rows(&window, 4, 11_999_999), 1280);
        assert_eq!(streamed_band_rows(&window, 4, 2 * 4_000 * 700), 512);
        assert_eq!(streamed_band_rows(&window, 4, 4_000 * 700), 256);
        let short = Window { x0: 0, y0: 0, width: 100_000, height: 100 };
        assert_eq!(band_rows(&short, 4, 1), 100, "never more than the window");
    }

    #[test]
    fn cgroup_limits_are_found_for_v1_and_v2_and_in_namespaces() {
        let files = |entries: &'static [(&'static str, &'static str)]| move |path: &str| entries.iter().find(|e| e.0 == path).map(|e| e.1.to_string());
        let v2 = files(&[("/sys/fs/cgroup/job/memory.max", "1073741824\n"), ("/sys/fs/cgroup/job/memory.current", "73741824\n")]);
        assert_eq!(cgroup_room("0::/job\n", v2), Some(1_000_000_000));
        let v2_unlimited = files(&[("/sys/fs/cgroup/memory.max", "max\n")]);
        assert_eq!(cgroup_room("0::/\n", v2_unlimited), None);
        let v1 = files(&[
            ("/sys/fs/cgroup/memory/slurm/job_7/memory.limit_in_bytes", "2000\n"),
            ("/sys/fs/cgroup/memory/slurm/job_7/memory.usage_in_bytes", "500\n"),
        ]);
        assert_eq!(cgroup_room("5:cpu,cpuacct:/\n4:memory:/slurm/job_7\n0::/\n", v1), Some(1500));
        let v1_namespaced = files(&[("/sys/fs/cgroup/memory/memory.limit_in_bytes", "4096\n"), ("/sys/fs/cgroup/memory/memory.usage_in_bytes", "96\n")]);
        assert_eq!(cgroup_room("4:memory:/kubepods/pod1\n", v1_namespaced), Some(4000));
        let v1_unlimited = files(&[("/sys/fs/cgroup/memory/memory.limit_in_bytes", "9223372036854771712\n")]);
        assert_eq!(cgroup_room("4:memory:/\n", v1_unlimited), None);
        assert_eq!(kib_field("MemTotal: 10 kB\nMemAvailable:    2048 kB\n", "MemAvailable:"), Some(2 << 20));
    }

    /// A preview of a window wider than `PREVIEW_SIDE` samples every third cell of every
    /// third row, across bands, and keeps the window's georeferencing.
    #[test]
    fn previews_sample_large_windows_across_bands() {
        let grid = Grid::new(0.0, 20_000.0, 0.0, 100.0, 10_000, 50);
        let window = Window { x0: 0, y0: 10, width: 10_000, height: 7 };
        let mut sampled = Sampled::new(&grid, window, -1.0);
        assert_eq!((sampled.step, sampled.width), (3, 3334));
        for (y0, height) in [(10, 4), (14, 3)] {
            let band = Window { x0: 0, y0, width: 10_000, height };
            let values = (0..band.pixel_count()).map(|k| (y0 as u64 * 100_000 + k) as f32).collect();
            let raster = Raster {
                grid,
                window: band,
                nodata: -1.0,
                values,
                owner: None,
                coverage: None,
                colours: None,
                faces: None,
                tiles: None,
                snap_bits: 0,
                stats: Stats::default(),
            };
            sampled.add(&raster);
        }
        let preview = sampled.into_raster(0);
        assert_eq!((preview.width(), preview.height()), (3334, 3), "rows 10, 13 and 16 of the grid");
        assert_eq!(preview.value(1, 1), (10 * 100_000 + 3 * 10_000 + 3) as f32, "row 13 is the first band's fourth");
        assert_eq!(preview.value(0, 2), (14 * 100_000 + 2 * 10_000) as f32, "row 16 is the second band's third");
        assert_eq!((preview.grid.xmin, preview.grid.ymax, preview.grid.dx()), (0.0, 80.0, 6.0));
    }
}
