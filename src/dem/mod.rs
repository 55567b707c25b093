//! Digital elevation models from meshes and point clouds, with gdal_grid's grid semantics:
//! everything `tileraster rasterise` does, as a library.
//!
//! - [`GridSpec`] is a grid as gdal_grid's `-txe`, `-tye` and `-outsize` or `-tr` give it;
//!   [`part_window`] is band K of N of its rows, for cluster jobs.
//! - [`read_scene`] reads a mesh, or builds the Delaunay TIN of a point file, by file type;
//!   [`read_scenes`] the TIN of several point files' points together ([`input_files`]: files,
//!   directories and glob patterns); [`block_scene`] the same TIN's triangles over one window
//!   (a `--part`'s band, a Dask chunk), triangulating only the points around it.
//! - [`Linear`] and [`Fallback`]: gdal_grid's `linear:radius=R`, the nearest point's z in
//!   cells outside every triangle.
//! - [`write_dem`] rasterises a window in bands of rows that fit a memory budget
//!   ([`streamed_band_rows`], [`default_memory_budget`]) and streams them to GeoTIFFs: memory
//!   holds two bands (one drawn, one written) whatever the grid's size, and every band's cells
//!   are the whole grid's there.
//!
//! ```no_run
//! use tileraster::dem::{self, Destinations, GridSpec, GridSize};
//! use tileraster::{Backend, Params};
//! use std::path::Path;
//! let grid = GridSpec { txe: Some([0.0, 1000.0]), tye: Some([0.0, 1000.0]), size: GridSize::Resolution { x: 0.5, y: 0.5 }, tap: false }.grid()?;
//! let input = dem::read_scene(Path::new("points.laz"), &Default::default(), &())?;
//! let window = tileraster::Window::whole(&grid);
//! let (budget, _) = dem::default_memory_budget();
//! let rows = dem::streamed_band_rows(&window, dem::bytes_per_cell(false, Backend::Cpu), budget);
//! let files = Destinations { heights: Path::new("dem.tif"), owner: None, preview: None, tiff: Default::default() };
//! dem::write_dem(&input.scene, &Params::new(grid), window, Backend::Cpu, rows, &files, None, &())?;
//! # Ok::<(), tileraster::dem::DemError>(())
//! ```

mod block;
mod grid;
mod input;
mod linear;
mod stream;

pub use block::{
    BYTES_PER_POINT, BlockRead, FileSummary, HeldPoints, block_band_rows, block_scene, block_scene_held, block_scene_of_files, estimated_points, is_copc,
    summarise_file, summarise_files,
};
pub use grid::{GridSize, GridSpec, part_window};
pub use input::{Input, InputKind, PointsRead, ReadOptions, describe, drop_long_triangles, input_files, read_points, read_scene, read_scenes};
pub use linear::{Fallback, Linear};
pub use stream::{Destinations, PREVIEW_SIDE, Run, band_rows, bytes_per_cell, default_memory_budget, streamed_band_rows, write_dem, write_dem_of_files};
pub use tileraster_io::{GeoTiffOptions, PointColumns};

use std::path::PathBuf;

/// Why a DEM could not be made; each says what was wrong and how to fix it.
#[derive(Debug, thiserror::Error)]
pub enum DemError {
    /// The rasteriser refused the scene or the grid.
    #[error(transparent)]
    Raster(#[from] crate::Error),
    /// A file could not be read, parsed or written.
    #[error(transparent)]
    Io(#[from] tileraster_io::IoError),
    /// The points of `path` make no TIN.
    #[error("{}: {source}", path.display())]
    Triangulation { path: PathBuf, source: tileraster_tin::TinError },
    /// The input's file type is not one tileraster reads.
    #[error(
        "{}: unsupported input type '{extension}'; give a mesh (.obj, .ply, .stl, .gltf, .glb) or points (.las, .laz, or delimited text: .csv, .xyz, .txt, .pts)",
        path.display()
    )]
    UnsupportedInput { path: PathBuf, extension: String },
    /// A GeoTIFF given where a mesh or points are read.
    #[error("{}: a GeoTIFF is a raster already; `tileraster rasterise` takes a mesh or points (`tileraster render` draws a DEM as terrain)", path.display())]
    RasterInput { path: PathBuf },
    /// A cell size is not a positive number.
    #[error("the {axis} cell size is {res}; it must be a positive number")]
    CellSize { axis: char, res: f64 },
    /// A cell size gives too few or too many cells along its extent.
    #[error("{extent} / {res} gives {cells} cells along {axis}; it must be between 1 and {}", crate::MAX_GRID_DIM)]
    CellCount { axis: char, extent: f64, res: f64, cells: f64 },
    /// Neither the extent nor an input to take it from.
    #[error("no extent: give --txe XMIN XMAX and --tye YMIN YMAX, or an input to take the extent from")]
    NoExtent,
    /// `--tap` with a size in cells.
    #[error("--tap aligns the extent to the cell size: give the cell size with --tr XRES YRES instead of --outsize")]
    TapNeedsResolution,
    /// `--max-edge` is not a positive length.
    #[error("--max-edge is {0}; give the longest edge to keep, a positive length in map units")]
    MaxEdge(f64),
    /// `--class` on a file that has no classifications.
    #[error("{}: --class filters LAS/LAZ points by classification; this file has none", path.display())]
    ClassesOfText { path: PathBuf },
    /// An extent to take from an input that has no vertices.
    #[error("the input has no vertices to take the extent from; give --txe and --tye")]
    EmptyExtent,
    /// No input given.
    #[error("no input: give a mesh, or one or more point files, directories of them or glob patterns")]
    NoInputs,
    /// A directory or glob pattern that names no input file.
    #[error("{}: {}", input.display(), if *directory { "no point files (.las, .laz, .csv, .xyz, .txt, .pts) in this directory" } else { "no such file, and no file matches it as a pattern" })]
    NoInputFiles { input: PathBuf, directory: bool },
    /// A glob pattern that is not one.
    #[error("'{pattern}' is not a file pattern: {reason}")]
    InputPattern { pattern: String, reason: String },
    /// One file named twice among the inputs (its points would count twice).
    #[error("{}: this file is among the inputs twice; name each file once", path.display())]
    InputTwice { path: PathBuf },
    /// A mesh among several inputs: only point files are read together.
    #[error("{}: a mesh among {inputs} inputs; several inputs are point files (.las, .laz, .csv, .xyz, .txt, .pts) triangulated together, and a mesh is rasterised alone", path.display())]
    MeshAmongInputs { path: PathBuf, inputs: usize },
    /// A block's triangles need a coarser snapping lattice than the finest, which the other
    /// blocks would not share.
    #[error(
        "a triangle over this block is too wide for the finest snapping lattice (2^-{finest} cells; it needs 2^-{bits}), which every block of the grid must share: give --max-edge shorter than 8,000 cells, or rasterise the whole grid in one run"
    )]
    BlockLattice { bits: u32, finest: u32 },
    /// A file read for a block has other points than its summary counted.
    #[error("{}: {read} points now, {summarised} when it was summarised; the file changed in between: summarise the inputs again", path.display())]
    InputChanged { path: PathBuf, summarised: usize, read: usize },
    /// Part `k` of `n` lies beyond the grid's rows.
    #[error("the grid's {rows} rows make only {parts} parts of {part_rows} rows; give fewer parts")]
    NoSuchPart { k: u32, n: u32, rows: u32, parts: u32, part_rows: u32 },
}

/// What a long run reports as it goes; every method does nothing unless overridden, and `()`
/// reports nothing.
pub trait Progress {
    /// A stage with no count (reading, triangulating, writing).
    fn stage(&self, _what: &str) {}
    /// A stage counted in rows, `total` of them.
    fn rows(&self, _what: &str, _total: u64) {}
    /// `rows` more rows done.
    fn advance(&self, _rows: u64) {}
}

impl Progress for () {}
