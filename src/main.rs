//! The `tileraster` command line.

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};
mod cli;

use cli::progress::{Progress, note, set_quiet};
use tileraster::dem::{self, Destinations, GridSize, GridSpec};
use tileraster::{Backend, Grid, Mode, Params, Raster, Skip, Skips, Window, rasterise};
use tileraster_io::{GeoTiffOptions, PointColumns, Sample};
use tileraster_testkit::scenes;

#[derive(Parser)]
#[command(name = "tileraster", version, about = "Deterministic triangle rasteriser: bit-identical heightfields on CPU and GPU")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, Debug, PartialEq, ValueEnum)]
pub(crate) enum BackendArg {
    /// A hardware GPU if there is one, otherwise the CPU backend.
    Auto,
    Cpu,
    Gpu,
}

#[derive(Subcommand)]
enum Command {
    /// Rasterise a mesh, or the Delaunay TIN of a point set, to a Float32 GeoTIFF, with
    /// gdal_grid's grid semantics.
    Rasterise(Box<RasteriseArgs>),
    /// Write a VRT mosaic of GeoTIFF parts of one grid (from --part or --window runs), each
    /// placed by its own georeferencing: GDAL then reads them as one raster.
    Mosaic {
        /// The VRT to write.
        #[arg(short, long)]
        output: PathBuf,
        /// The parts, in any order.
        #[arg(required = true)]
        parts: Vec<PathBuf>,
    },
    /// Render a mesh in perspective, depth-tested and shaded, to a PNG (and optionally its
    /// depth and triangle-id rasters): the same bits on both backends.
    Render(Box<cli::render::RenderArgs>),
    /// Show a mesh on a page in the browser (a local web server): drag to rotate, wheel to
    /// zoom, right-drag to pan, W/A/S/D to move; keys for shading, wireframe, vertices, MSAA,
    /// projection, heat map, backend and a reference CRC. The page shows each frame's
    /// `tileraster render` command line and CRC-32.
    View(Box<cli::view::ViewArgs>),
    /// Rasterise a built-in procedural terrain TIN on both backends, time them, compare them
    /// bit for bit, and write a GeoTIFF and a PNG preview.
    Demo {
        /// Folder for demo.tif and demo.png.
        #[arg(short, long, default_value = "tileraster-demo")]
        output: PathBuf,
        /// Raster width and height in cells.
        #[arg(long, default_value_t = 2048)]
        size: u32,
        /// Terrain lattice cells per side (the TIN has 2·cells² triangles).
        #[arg(long, default_value_t = 200)]
        cells: u32,
    },
}

/// `tileraster rasterise`: gdal_grid's flags, with two dashes, and tileraster's own.
#[derive(Args)]
struct RasteriseArgs {
    /// Input: a mesh (`.obj`, `.ply`, `.stl`; heights in z) or points (`.las`, `.laz`, COPC,
    /// delimited text: `.csv`, `.xyz`, `.txt`, `.pts`, or a NumPy array of shape (n, 3) saved
    /// as `.npy`), triangulated by Delaunay. Several point
    /// inputs (files, directories of them, quoted glob patterns such as "tiles/*.laz") are
    /// triangulated together, as if their points were one file's in the order given
    /// (a directory's and a pattern's files by name).
    #[arg(required = true, num_args = 1..)]
    input: Vec<PathBuf>,
    /// Point files: the x, y and z columns, each a header name or a 1-based position
    /// (default: columns named x/easting/lon, y/northing/lat, z/elevation/height, or the
    /// first three when there is no header).
    #[arg(long, value_name = "X,Y,Z", value_parser = point_columns)]
    columns: Option<PointColumns>,
    /// Output GeoTIFF.
    #[arg(short, long)]
    output: PathBuf,
    /// Grid x extent, as gdal_grid's -txe (default: the input's).
    #[arg(long, num_args = 2, value_names = ["XMIN", "XMAX"], allow_negative_numbers = true)]
    txe: Option<Vec<f64>>,
    /// Grid y extent, as gdal_grid's -tye (row 0 is at YMAX; default: the input's).
    #[arg(long, num_args = 2, value_names = ["YMIN", "YMAX"], allow_negative_numbers = true)]
    tye: Option<Vec<f64>>,
    /// Raster size in cells, as gdal_grid's -outsize (or give --tr).
    #[arg(long, num_args = 2, value_names = ["WIDTH", "HEIGHT"], required_unless_present = "tr", conflicts_with = "tr")]
    outsize: Option<Vec<u32>>,
    /// Cell size in world units, as gdal_grid's -tr: with --txe and --tye, the size is each
    /// extent over its cell size, rounded to the nearest whole cell, and the extent is kept;
    /// with the input's extent, cells are exactly this size from its west and north edges
    /// (as gdalwarp's -tr).
    #[arg(long, num_args = 2, value_names = ["XRES", "YRES"])]
    tr: Option<Vec<f64>>,
    /// Align the extent to whole multiples of the cell size (GDAL's -tap; needs --tr): the
    /// least edges are rounded down and the greatest up, so the grid covers the extent.
    #[arg(long, requires = "tr")]
    tap: bool,
    /// LAS/LAZ: keep only points of these classifications (repeatable, or a comma list):
    /// `--class 2` keeps ground points for a bare-earth DEM.
    #[arg(long = "class", value_name = "CLASS", value_delimiter = ',')]
    classes: Vec<u8>,
    /// Leave out triangles with an edge longer than this (map units, measured in x and y),
    /// so water bodies and gaps in the data stay nodata instead of being bridged (unless -a
    /// linear's radius reaches across them). --owner and --tin then count the triangles kept.
    #[arg(long, value_name = "LENGTH", allow_negative_numbers = true)]
    max_edge: Option<f64>,
    /// Rasterise only this window of the grid (pixel offsets and size); its cells are bit
    /// for bit the whole run's, and the GeoTIFF is georeferenced to the window.
    #[arg(long, num_args = 4, value_names = ["XOFF", "YOFF", "XSIZE", "YSIZE"], conflicts_with = "part")]
    window: Option<Vec<u32>>,
    /// Rasterise only part K (counted from 0) of N bands of rows of the grid: the window a
    /// cluster job's index picks (see docs/cluster.md). Mosaic the parts with
    /// `tileraster mosaic`.
    #[arg(long, value_name = "K/N", value_parser = part)]
    part: Option<(u32, u32)>,
    /// Also write the owner-triangle raster: a UInt32 GeoTIFF of the index of the triangle
    /// each cell's value comes from (0-based, in the mesh's face order, or the order of the
    /// Delaunay TIN's triangles for points), 4294967295 where none covers the cell.
    #[arg(long, value_name = "FILE.tif")]
    owner: Option<PathBuf>,
    /// Also write the mesh that was rasterised as OBJ (for points, their Delaunay TIN):
    /// its faces, in order, are what --owner's indices count.
    #[arg(long, value_name = "FILE.obj")]
    tin: Option<PathBuf>,
    /// The most memory, in MiB, the raster may take at once (default: half of the least of
    /// the memory available, the room under this process's cgroup limit and under its
    /// `ulimit -v`). Larger grids are rasterised in bands of rows and streamed to the file.
    #[arg(long, value_name = "MIB")]
    memory: Option<u64>,
    /// No messages on stderr but errors (and --stats when asked for).
    #[arg(short, long)]
    quiet: bool,
    #[arg(long, value_enum, default_value = "auto")]
    backend: BackendArg,
    /// Value of cells no triangle covers (written as the GDAL_NODATA tag; default -9999).
    #[arg(long, allow_negative_numbers = true)]
    nodata: Option<f32>,
    /// gdal_grid's -a: linear[:radius=R][:nodata=V]. Cells outside every triangle take the z
    /// of the nearest input point within R, as gdal_grid 3.6 picks it (R < 0, bare `linear`'s
    /// default: at any distance; R = 0: nodata, as without this flag), gaps opened by
    /// --max-edge included (give a radius shorter than the gaps to keep them). nodata=V is
    /// --nodata; without either, -9999 (gdal_grid's linear writes 0 and no nodata tag).
    #[arg(long = "algorithm", short = 'a', value_name = "linear[:radius=R][:nodata=V]", allow_hyphen_values = true)]
    algorithm: Option<dem::Linear>,
    /// The CRS, as an EPSG code (gdal_grid's -a_srs), written as GeoKeys.
    #[arg(long = "a_srs", value_name = "EPSG:CODE", value_parser = tileraster_io::parse_epsg)]
    a_srs: Option<u16>,
    /// A GeoTIFF creation option, as gdal_grid's -co (repeatable): TILED=YES (256 × 256
    /// tiles), COMPRESS=DEFLATE|ZSTD, PREDICTOR=2|3|YES (with compression; YES: 3 for heights,
    /// 2 for owners), BIGTIFF=YES|NO|IF_NEEDED (default IF_NEEDED), COG=YES. Output streamed
    /// in bands is tiled unless TILED=NO is given.
    #[arg(long = "co", value_name = "NAME=VALUE")]
    creation_options: Vec<String>,
    /// The output format, as gdal_translate's -of: GTiff (the default) or COG, a
    /// cloud-optimised GeoTIFF (as --co COG=YES): tiled, with averaged overviews, its
    /// directories ahead of the data as GDAL's COG driver lays them out.
    #[arg(long = "of", value_name = "GTiff|COG")]
    format: Option<String>,
    /// Also write a hillshaded PNG preview.
    #[arg(long)]
    preview: Option<PathBuf>,
    /// How values are computed: exact (correctly rounded, the default), plane-f32 or
    /// barycentric (cheaper f32 arithmetic; bounds in docs/numeric-contract.md).
    #[arg(long, default_value = "exact")]
    mode: Mode,
    /// Print what the call did and skipped as one JSON object on stderr, one per band when
    /// streamed (tiles_total, tiles_empty_skipped, tiles_full, triangles_culled, passes,
    /// bytes_uploaded, ...).
    #[arg(long)]
    stats: bool,
    /// Turn one of the pipeline's skips off (repeatable), to measure its gain; results do
    /// not change. Names: cull_window, empty_tiles, full_tiles, overlap_free, hidden_triangles.
    #[arg(long = "no-skip", value_name = "SKIP", value_parser = skip_name)]
    no_skip: Vec<Skip>,
}

fn main() -> ExitCode {
    give_vulkan_a_runtime_dir();
    stop_cleanly_when_interrupted();
    match run(Cli::parse()) {
        Ok(code) => code,
        Err(message) => {
            eprintln!("tileraster: error: {message}");
            ExitCode::FAILURE
        }
    }
}

fn run(cli: Cli) -> Result<ExitCode, String> {
    match cli.command {
        Command::Rasterise(args) => rasterise_command(args),
        Command::Render(args) => cli::render::render_command(*args),
        Command::View(args) => cli::view::view_command(*args),
        Command::Mosaic { output, parts } => {
            let parts = parts.iter().map(|p| tileraster_io::read_part(p)).collect::<Result<Vec<_>, _>>().map_err(|e| e.to_string())?;
            let mosaic = tileraster_io::write_mosaic_vrt(&output, &parts).map_err(|e| e.to_string())?;
            note(format!(
                "tileraster: {} parts → {}×{} cells{} → {}",
                parts.len(),
                mosaic.width,
                mosaic.height,
                match mosaic.uncovered {
                    0 => String::new(),
                    n => format!(" ({n} cells in no part: nodata)"),
                },
                output.display()
            ));
            Ok(ExitCode::SUCCESS)
        }
        Command::Demo { output, size, cells } => demo(&output, size, cells),
    }
}

/// `tileraster rasterise`: read, triangulate if points, rasterise in bands, write.
fn rasterise_command(args: Box<RasteriseArgs>) -> Result<ExitCode, String> {
    let RasteriseArgs {
        input,
        columns,
        output,
        txe,
        tye,
        outsize,
        tr,
        tap,
        classes,
        max_edge,
        window,
        part,
        owner,
        tin,
        memory,
        quiet,
        backend,
        nodata,
        algorithm,
        a_srs,
        creation_options,
        format,
        preview,
        mode,
        stats,
        no_skip,
    } = *args;
    set_quiet(quiet);
    let linear = algorithm.unwrap_or_default();
    let nodata = match (nodata, linear.nodata) {
        (Some(a), Some(b)) if a.to_bits() != b.to_bits() => {
            return Err(format!("--nodata {a} and --algorithm's nodata={b} differ; give one"));
        }
        (a, b) => a.or(b).unwrap_or(-9999.0),
    };
    let mut tiff = GeoTiffOptions { epsg: a_srs, ..Default::default() };
    // The format first, so that a creation option that contradicts it is refused.
    if let Some(format) = &format {
        tiff.apply_format(format)?;
    }
    for option in &creation_options {
        tiff.apply(option)?;
    }
    // Each file its own path: two writers of one file would corrupt it.
    let files = [("-o", Some(&output)), ("--owner", owner.as_ref()), ("--preview", preview.as_ref()), ("--tin", tin.as_ref())];
    for (k, (flag, path)) in files.iter().enumerate() {
        if let Some((other, _)) = files[..k].iter().find(|(_, p)| p.is_some() && p == path) {
            return Err(format!("{flag} {} is also {other}'s file; give each output its own path", path.expect("found equal to a given path").display()));
        }
    }
    // Options a file's sample type refuses, refused before anything is read.
    tiff.check(Sample::Float32 { nodata }).map_err(|e| format!("{}: {e}", output.display()))?;
    if let Some(owner) = &owner {
        tiff.check(Sample::UInt32).map_err(|e| format!("{}: {e}", owner.display()))?;
    }
    let size = match (outsize, tr) {
        (Some(size), _) => GridSize::Cells { width: size[0], height: size[1] },
        (None, Some(tr)) => GridSize::Resolution { x: tr[0], y: tr[1] },
        (None, None) => return Err("give the raster size with --outsize WIDTH HEIGHT or the cell size with --tr XRES YRES".into()),
    };
    let spec = GridSpec { txe: txe.map(|v| [v[0], v[1]]), tye: tye.map(|v| [v[0], v[1]]), size, tap };
    let grid_error = |e: dem::DemError| match size {
        GridSize::Resolution { .. } => format!("--tr: {e}"),
        GridSize::Cells { .. } => e.to_string(),
    };
    let window_of = |grid: &Grid| -> Result<Window, String> {
        let window = match (&window, part) {
            (Some(w), _) => Window { x0: w[0], y0: w[1], width: w[2], height: w[3] },
            (None, Some((k, n))) => dem::part_window(grid, k, n).map_err(|e| format!("--part {k}/{n}: {e}"))?,
            (None, None) => Window::whole(grid),
        };
        window.validate(grid).map_err(|e| format!("--window: {e}"))?;
        Ok(window)
    };
    // A grid given whole, and its window, are checked before the input is read; one that takes
    // the input's extent, after.
    let given = spec.check().map_err(grid_error)?;
    if let Some(grid) = &given {
        window_of(grid)?;
    }
    let inputs = dem::input_files(&input).map_err(|e| e.to_string())?;
    let input = dem::describe(&inputs);
    let progress = Progress::start();
    progress.stage(format!("reading {}", input.display()));
    let options = dem::ReadOptions { columns: columns.unwrap_or_default(), classes, max_edge, keep_points: linear.radius != 0.0 };
    // A part triangulates only the points around its band, which prove its triangles the whole
    // TIN's; what needs the whole TIN's numbering or all its points (--owner, --tin, the
    // nearest-point fallback) triangulates them all.
    let points_only = inputs.iter().all(|p| dem::InputKind::of(p).is_ok_and(dem::InputKind::is_points));
    let eligible = points_only && owner.is_none() && tin.is_none() && linear.radius == 0.0;
    let blocked = eligible && part.is_some();
    let (budget, set_by) = memory.map_or_else(dem::default_memory_budget, |mib| (mib << 20, "--memory"));
    // Points whose whole TIN would not fit in the budget: rasterised in bands, each band's TIN
    // made from the points around it, the files read again for each band that needs them.
    let in_blocks = eligible && part.is_none() && window.is_none() && {
        let estimate = dem::estimated_points(&inputs).map_err(|e| e.to_string())?;
        estimate.saturating_mul(dem::BYTES_PER_POINT) > budget
    };
    let (read, grid, files) = if in_blocks {
        let start = Instant::now();
        progress.stage(format!("summarising {}", input.display()));
        let files = dem::summarise_files(&inputs, &options).map_err(|e| e.to_string())?;
        let total: usize = files.iter().map(|f| f.points).sum();
        let grid = match given {
            Some(grid) => grid,
            None => spec
                .grid_for(&files.iter().filter_map(|f| f.bounds).flat_map(|b| [[b.x0, b.y0, 0.0], [b.x1, b.y1, 0.0]]).collect::<Vec<_>>())
                .map_err(grid_error)?,
        };
        note(format!(
            "tileraster: {total} points in {} read in {} for their bounds and hulls: more than {} MiB ({set_by}) holds as one TIN, so each band of the grid triangulates the points around it",
            input.display(),
            ms(start.elapsed()),
            budget >> 20
        ));
        let empty = dem::Input { scene: tileraster::Scene::new(Vec::new(), Vec::new()), points: None, long_triangles: 0, points_read: None, block: None };
        (empty, grid, Some((files, total)))
    } else if blocked {
        let start = Instant::now();
        // Several files, or a COPC file: a pass over them for their counts, bounds and hulls,
        // holding one file at a time, then only the files (and COPC nodes) the band needs.
        // One other file: its points, read once.
        let summarise = inputs.len() > 1 || dem::is_copc(&inputs[0]).map_err(|e| e.to_string())?;
        let (files, points) = match summarise {
            false => (Vec::new(), dem::read_points(&inputs, &options).map_err(|e| e.to_string())?),
            true => (dem::summarise_files(&inputs, &options).map_err(|e| e.to_string())?, Vec::new()),
        };
        let read_time = start.elapsed();
        let total = points.len() + files.iter().map(|f| f.points).sum::<usize>();
        let grid = match given {
            Some(grid) => grid,
            None if files.is_empty() => spec.grid_for(&points).map_err(grid_error)?,
            None => spec
                .grid_for(&files.iter().filter_map(|f| f.bounds).flat_map(|b| [[b.x0, b.y0, 0.0], [b.x1, b.y1, 0.0]]).collect::<Vec<_>>())
                .map_err(grid_error)?,
        };
        let read = match files.is_empty() {
            true => dem::block_scene(&points, &grid, window_of(&grid)?, &options, &progress),
            false => dem::block_scene_of_files(&files, &grid, window_of(&grid)?, &options, &progress),
        }
        .map_err(|e| e.to_string())?;
        let (block, summary) = (read.block.expect("a block's scene says how it was made"), read.points.expect("a block is of points"));
        let (k, n) = part.expect("blocked runs are parts");
        let records: u64 = files.iter().filter_map(|f| f.records).sum();
        let files_read = match files.len() {
            0 | 1 => String::new(),
            n => format!(", from {} of the {n} files", block.files_read),
        } + &match records {
            0 => String::new(),
            r => format!(", decoding {} points from COPC octree nodes (which hold {r}) over its tries", block.points_decoded),
        };
        let around = match (block.points == total, block.attempts) {
            (true, _) => "every point (the band's triangles need points that far)".to_string(),
            (false, 1) => format!("the {} around its band (a buffer of {:.1} map units)", block.points, block.buffer),
            (false, a) => format!(
                "the {} around its band (a buffer of {:.1} map units, widened {} times until it proved them the whole TIN's)",
                block.points,
                block.buffer,
                a - 1
            ),
        };
        note(format!(
            "tileraster: {} points from {} in {}; part {k}/{n} triangulated {around}{files_read} → {} triangles over it in {}",
            total,
            input.display(),
            ms(read_time),
            read.scene.triangles.len() + read.long_triangles,
            ms(summary.triangulated)
        ));
        (read, grid, None)
    } else {
        let read = dem::read_scenes(&inputs, &options, &progress).map_err(|e| e.to_string())?;
        if let Some(points) = &read.points {
            note(format!(
                "tileraster: {} points from {} in {}{} → Delaunay TIN of {} triangles in {}",
                points.count,
                input.display(),
                ms(points.read),
                match points.duplicates {
                    0 => String::new(),
                    n => format!(" ({n} repeating an earlier point's x, y: the first of each is kept)"),
                },
                read.scene.triangles.len() + read.long_triangles,
                ms(points.triangulated)
            ));
        }
        let grid = match given {
            Some(grid) => grid,
            None => spec.grid_for(&read.scene.vertices).map_err(grid_error)?,
        };
        (read, grid, None)
    };
    if let (Some(max_edge), false) = (max_edge, in_blocks) {
        note(format!("tileraster: --max-edge {max_edge}: {} triangles with a longer edge left out, {} kept", read.long_triangles, read.scene.triangles.len()));
    }
    if given.is_none() || tap {
        note(format!(
            "tileraster: extent x {} to {}, y {} to {}: {}×{} cells of {} × {}",
            grid.xmin,
            grid.xmax,
            grid.ymin,
            grid.ymax,
            grid.width,
            grid.height,
            grid.dx(),
            grid.dy()
        ));
    }
    let window = window_of(&grid)?;
    let scene = read.scene;
    let fallback = dem::Fallback::new(read.points_read.as_deref().unwrap_or(&scene.vertices), linear.radius);
    let (backend, chosen) = choose_backend(backend, window.width as u64 * window.height as u64);
    let mut skips = Skips::ALL;
    for &skip in &no_skip {
        skips = skips.without(skip);
    }
    let layers = tileraster::Outputs { owner: owner.is_some(), coverage: false, tiles: false };
    let params = Params::new(grid).with_nodata(nodata).with_mode(mode).with_skips(skips).with_outputs(layers);
    let band_rows = dem::streamed_band_rows(&window, dem::bytes_per_cell(owner.is_some() || fallback.is_some(), backend), budget);
    let band_rows = files.as_ref().map_or(band_rows, |(_, total)| band_rows.min(dem::block_band_rows(&window, &grid, *total, budget)));
    if band_rows < window.height && !in_blocks {
        if !creation_options.iter().any(|o| o.to_ascii_uppercase().starts_with("TILED=")) {
            tiff.tiled = true;
        }
        note(format!(
            "tileraster: {}×{} cells do not fit in {} MiB ({set_by}): rasterising bands of {band_rows} rows, streamed to a {} GeoTIFF",
            window.width,
            window.height,
            budget >> 20,
            if tiff.tiled { "tiled" } else { "striped" }
        ));
    }
    let outputs = Destinations { heights: &output, owner: owner.as_deref(), preview: preview.as_deref(), tiff };
    let start = Instant::now();
    let (run, blocks) = match &files {
        Some((files, _)) => dem::write_dem_of_files(files, &options, &params, window, backend, band_rows, &outputs, &progress),
        None => dem::write_dem(&scene, &params, window, backend, band_rows, &outputs, fallback.as_ref(), &progress).map(|run| (run, Vec::new())),
    }
    .map_err(|e| e.to_string())?;
    if let (Some(first), Some((_, total))) = (blocks.first(), &files) {
        let (least, most) = blocks.iter().fold((first.points, first.points), |(l, m), b| (l.min(b.points), m.max(b.points)));
        let buffer = blocks.iter().fold(0.0f64, |m, b| m.max(b.buffer));
        note(format!(
            "tileraster: {} blocks in bands of {band_rows} rows triangulated {least} to {most} of the {total} points each (buffers up to {buffer:.1} map units)",
            blocks.len(),
        ));
    }
    if let Some(path) = &tin {
        tileraster_io::write_obj(&scene, path).map_err(|e| e.to_string())?;
    }
    drop(progress);
    let whole = window == Window::whole(&grid);
    note(format!(
        "tileraster: {} onto {}×{} cells{} with the {} backend, {} mode, rasterised and written in {} (snapping step 2^-{} px){} → {}",
        if blocks.is_empty() { format!("{} triangles", scene.triangles.len()) } else { "the TIN".to_string() },
        grid.width,
        grid.height,
        if whole { String::new() } else { format!(" (window {}×{} at {}, {})", window.width, window.height, window.x0, window.y0) },
        backend.name(),
        mode.name(),
        ms(start.elapsed()),
        run.snap_bits,
        match run.bands.len() {
            1 => String::new(),
            n => format!(", {n} bands"),
        },
        output.display()
    ));
    if fallback.is_some() {
        note(format!("tileraster: --algorithm linear:radius={}: {} cells outside every triangle took the nearest point's z", linear.radius, run.filled));
    }
    if stats {
        if let Some(choice) = &chosen {
            eprintln!("{}", choice.to_json());
        }
        for band in &run.bands {
            eprintln!("{}", band.to_json());
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn part(s: &str) -> Result<(u32, u32), String> {
    let parsed = s.split_once('/').and_then(|(k, n)| Some((k.trim().parse::<u32>().ok()?, n.trim().parse::<u32>().ok()?)));
    match parsed {
        Some((k, n)) if k < n => Ok((k, n)),
        Some((k, n)) => Err(format!("part {k} of {n}: parts are counted from 0, so K must be less than N")),
        None => Err(format!("'{s}' is not K/N (part K, counted from 0, of N)")),
    }
}

fn point_columns(s: &str) -> Result<PointColumns, String> {
    let parts: Vec<&str> = s.split(',').collect();
    let [x, y, z] = parts.as_slice() else {
        return Err(format!("'{s}': give three columns, X,Y,Z (names or 1-based positions)"));
    };
    Ok(PointColumns { x: Some(x.parse()?), y: Some(y.parse()?), z: Some(z.parse()?) })
}

fn skip_name(name: &str) -> Result<Skip, String> {
    name.parse().map_err(|e: tileraster::Error| e.to_string())
}

/// Mesa's Vulkan drivers print `error: XDG_RUNTIME_DIR is invalid or not set` when the
/// session has none (a container, a batch job, ssh without a login session), though nothing
/// fails. A successful run prints no line that says error: give the process a private runtime
/// directory of its own, as a login session would, before any thread starts.
fn give_vulkan_a_runtime_dir() {
    use std::os::unix::fs::{DirBuilderExt, MetadataExt};
    let valid = |dir: &Path| std::fs::metadata(dir).is_ok_and(|m| m.is_dir() && m.uid() == unsafe { libc::getuid() });
    if std::env::var_os("XDG_RUNTIME_DIR").is_some_and(|d| valid(Path::new(&d))) {
        return;
    }
    let dir = std::env::temp_dir().join(format!("tileraster-runtime-{}", unsafe { libc::getuid() }));
    let _ = std::fs::DirBuilder::new().mode(0o700).create(&dir);
    if valid(&dir) {
        // SAFETY: called first thing in `main`, before any other thread exists.
        unsafe { std::env::set_var("XDG_RUNTIME_DIR", &dir) };
    }
}

/// Ctrl-C (SIGINT), SIGTERM or a closed terminal (SIGHUP): stop at once, remove every
/// partial file, leave each destination as it was (a file already renamed into place is
/// complete), say so in one line, and end by the signal itself, as a process without a handler
/// would: a shell then reports 130, 143 or 129 and stops a script's loop. A thread of its own
/// waits for the signal, so a run is stopped mid-band, not at the next band.
fn stop_cleanly_when_interrupted() {
    use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
    let mut signals = match signal_hook::iterator::Signals::new([SIGINT, SIGTERM, SIGHUP]) {
        Ok(signals) => signals,
        Err(e) => {
            return eprintln!("tileraster: warning: cannot handle interrupts ({e}); an interrupted run may leave *{} files", tileraster_io::PARTIAL_SUFFIX);
        }
    };
    std::thread::spawn(move || {
        let Some(signal) = signals.forever().next() else {
            return;
        };
        // Held until the process ends: no file is created or renamed into place after this.
        let abandoned = tileraster_io::abandon_partial_files();
        let name = match signal {
            SIGINT => "SIGINT",
            SIGTERM => "SIGTERM",
            _ => "SIGHUP",
        };
        let mut said = match abandoned.removed.as_slice() {
            [] => "no partial file to remove".to_string(),
            files => format!("removed {}", files.iter().map(|f| f.display().to_string()).collect::<Vec<_>>().join(", ")),
        };
        for (file, e) in &abandoned.not_removed {
            said += &format!("; could not remove {} ({e})", file.display());
        }
        // Start a fresh line: a progress bar or the terminal's ^C may be on this one.
        use std::io::IsTerminal;
        let fresh = if std::io::stderr().is_terminal() { "\r\x1b[2K" } else { "" };
        eprintln!("{fresh}tileraster: interrupted by {name}: stopped, {said}");
        // The default action ends the process at once: no exit handlers run beside threads
        // still drawing. Should that fail, exit without them all the same.
        let _ = signal_hook::low_level::emulate_default_handler(signal);
        // SAFETY: _exit ends the process; nothing after it runs.
        unsafe { libc::_exit(128 + signal) };
    });
}

/// The backend a call of `pixels` cells runs on, and what `auto` chose and why (`None` where
/// the user named the backend).
pub(crate) fn choose_backend(arg: BackendArg, pixels: u64) -> (Backend, Option<tileraster::BackendChoice>) {
    match arg {
        BackendArg::Cpu => (Backend::Cpu, None),
        BackendArg::Gpu => (Backend::Gpu, None),
        BackendArg::Auto => {
            let choice = tileraster::choose_backend(pixels);
            note(format!("tileraster: backend auto: {}: {}", choice.backend.name(), choice.reason));
            (choice.backend, Some(choice))
        }
    }
}

fn ms(d: Duration) -> String {
    format!("{:.1} ms", d.as_secs_f64() * 1e3)
}

/// Median wall time of `runs` calls, and the last result.
fn timed(runs: usize, mut f: impl FnMut() -> Result<Raster, String>) -> Result<(Duration, Raster), String> {
    let mut times = Vec::with_capacity(runs);
    let mut last = None;
    for _ in 0..runs {
        let start = Instant::now();
        last = Some(f()?);
        times.push(start.elapsed());
    }
    times.sort();
    Ok((times[times.len() / 2], last.expect("at least one run")))
}

fn demo(dir: &Path, size: u32, cells: u32) -> Result<ExitCode, String> {
    const RUNS: usize = 5;
    let (x0, y0, extent) = (500_000.0, 5_000_000.0, 10_000.0);
    let scene = scenes::terrain(x0, y0, extent, extent, cells, cells, 2026);
    let grid = Grid::new(x0, x0 + extent, y0, y0 + extent, size, size);
    let params = Params::new(grid).with_nodata(-9999.0);
    println!(
        "tileraster demo: procedural terrain TIN, {} triangles at UTM-scale coordinates, onto {size}×{size} cells ({:.2} m)",
        scene.triangles.len(),
        grid.dx()
    );
    let (cpu_time, cpu) = timed(RUNS, || rasterise(&scene, &params, Backend::Cpu).map_err(|e| e.to_string()))?;
    println!("  cpu: {} (median of {RUNS}, {} threads)", ms(cpu_time), std::thread::available_parallelism().map_or(1, |n| n.get()));
    let gpu = match tileraster::gpu_adapter() {
        Ok(adapter) => {
            let (gpu_time, gpu) = timed(RUNS, || rasterise(&scene, &params, Backend::Gpu).map_err(|e| e.to_string()))?;
            println!("  gpu: {} (median of {RUNS}, {adapter})", ms(gpu_time));
            Some(gpu)
        }
        Err(e) => {
            println!("  gpu: unavailable: {e}");
            None
        }
    };
    std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
    let (tif, png) = (dir.join("demo.tif"), dir.join("demo.png"));
    tileraster_io::write_geotiff(&cpu, &tif).map_err(|e| e.to_string())?;
    tileraster_io::write_preview_png(&cpu, &png).map_err(|e| e.to_string())?;
    println!("  wrote {} and {}", tif.display(), png.display());
    let Some(gpu) = gpu else {
        println!("  bit-identical: not checked (no GPU backend)");
        return Ok(ExitCode::FAILURE);
    };
    let (count, first) = cpu.compare_bits(&gpu, 5);
    let mut same = true;
    if cpu.stats != gpu.stats {
        println!("  statistics: NOT equal:\n    cpu {}\n    gpu {}", cpu.stats.to_json(), gpu.stats.to_json());
        same = false;
    } else {
        println!("  statistics, equal on both: {}", cpu.stats.to_json());
    }
    if count == 0 {
        println!("  bit-identical: yes ({} cells, values compared bit for bit)", cpu.values.len());
    } else {
        println!("  bit-identical: NO, {count} cells differ; first:");
        for d in first {
            println!("    {d} (cpu vs gpu)");
        }
        same = false;
    }
    same &= demo_render(&scene, dir)?;
    Ok(if same { ExitCode::SUCCESS } else { ExitCode::FAILURE })
}

/// The demo's terrain in perspective: Phong-shaded, heights exaggerated four times and coloured
/// by a ramp, on both backends, compared bit for bit (colour, depth and ids).
fn demo_render(scene: &tileraster::Scene, dir: &Path) -> Result<bool, String> {
    use tileraster::render::{Camera, Mesh, Projection, RenderParams, Shading, Up, render};
    const RUNS: usize = 5;
    let (w, h) = (1280, 720);
    let (lo, hi) = scene.vertices.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| (lo.min(v[2]), hi.max(v[2])));
    let exaggerate = |z: f64| lo + 4.0 * (z - lo);
    let ramp = |t: f64| -> [f32; 4] {
        let stops = [(0.0, [0.18, 0.43, 0.24]), (0.35, [0.47, 0.65, 0.33]), (0.6, [0.84, 0.78, 0.51]), (0.82, [0.63, 0.45, 0.31]), (1.0, [0.96, 0.96, 0.96])];
        let k = stops.iter().rposition(|s| s.0 <= t).unwrap_or(0).min(stops.len() - 2);
        let (a, b) = (stops[k], stops[k + 1]);
        let f = ((t - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
        let channel = |c: usize| (a.1[c] + f * (b.1[c] - a.1[c])) as f32;
        [channel(0), channel(1), channel(2), 1.0]
    };
    let mesh = Mesh {
        positions: scene.vertices.iter().map(|v| [v[0], v[1], exaggerate(v[2])]).collect(),
        triangles: scene.triangles.clone(),
        colours: Some(scene.vertices.iter().map(|v| ramp((v[2] - lo) / (hi - lo).max(1e-9))).collect()),
        ..Default::default()
    };
    let camera = Camera::framing(&mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 40.0 }, Up::Z);
    let params = RenderParams {
        shading: Shading::Phong,
        background: [30, 34, 42, 255],
        ..RenderParams::new(w, h, camera.view_projection(w, h).map_err(|e| e.to_string())?)
    };
    println!("tileraster demo: the same terrain in perspective, {} triangles, Phong-shaded, {w}×{h}", mesh.triangles.len());
    let timed_render = |backend| -> Result<(Duration, tileraster::render::Frame), String> {
        let mut times = Vec::with_capacity(RUNS);
        let mut last = None;
        for _ in 0..RUNS {
            let start = Instant::now();
            last = Some(render(&mesh, &params, backend).map_err(|e| e.to_string())?);
            times.push(start.elapsed());
        }
        times.sort();
        Ok((times[RUNS / 2], last.expect("at least one run")))
    };
    let (cpu_time, cpu) = timed_render(Backend::Cpu)?;
    println!("  cpu: {} (median of {RUNS})", ms(cpu_time));
    let png = dir.join("demo-3d.png");
    let obj = dir.join("terrain.obj");
    tileraster_io::write_obj(scene, &obj).map_err(|e| e.to_string())?;
    println!("  wrote {} (the TIN, +Z up: `tileraster render {0} --up z`)", obj.display());
    // The TIN again with the DEM's preview draped over it as a texture (north at the top row).
    let ([x0, y0], [x1, y1]) = scene
        .vertices
        .iter()
        .fold(([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]), |(lo, hi), v| ([lo[0].min(v[0]), lo[1].min(v[1])], [hi[0].max(v[0]), hi[1].max(v[1])]));
    let uvs: Vec<[f32; 2]> = scene.vertices.iter().map(|v| [((v[0] - x0) / (x1 - x0)) as f32, ((y1 - v[1]) / (y1 - y0)) as f32]).collect();
    let textured = dir.join("terrain-textured.obj");
    tileraster_io::write_obj_textured(scene, &uvs, "demo.png", &textured).map_err(|e| e.to_string())?;
    println!("  wrote {} (with terrain-textured.mtl: demo.png draped over it)", textured.display());
    tileraster_io::write_rgba_png(&png, w, h, &cpu.rgba8()).map_err(|e| e.to_string())?;
    println!("  wrote {}", png.display());
    let Ok(adapter) = tileraster::gpu_adapter() else {
        println!("  frames bit-identical: not checked (no GPU backend)");
        return Ok(false);
    };
    let (gpu_time, gpu) = timed_render(Backend::Gpu)?;
    println!("  gpu: {} (median of {RUNS}, {adapter})", ms(gpu_time));
    let differing = (0..cpu.colour.len())
        .filter(|&k| cpu.colour[k] != gpu.colour[k] || cpu.depth[k].to_bits() != gpu.depth[k].to_bits() || cpu.ids[k] != gpu.ids[k])
        .count();
    println!("  frame statistics: {}", cpu.stats.to_json());
    if differing == 0 && cpu.stats == gpu.stats {
        println!("  frames bit-identical: yes ({} pixels: colour, depth and triangle ids compared bit for bit)", cpu.colour.len());
        Ok(true)
    } else {
        println!("  frames bit-identical: NO, {differing} pixels differ{}", if cpu.stats == gpu.stats { "" } else { "; statistics differ" });
        Ok(false)
    }
}
