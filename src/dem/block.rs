//! Blocks of a grid from points: a window's TIN made from the points around it only, proven to
//! be the whole point set's there (`tileraster_tin::block`), so that blocks rasterised apart
//! (parts of a cluster run, chunks of a Dask array) give the single run's cells bit for bit.
//!
//! The points come from memory ([`block_scene`]) or from files ([`block_scene_of_files`]):
//! a first pass over the files ([`summarise_files`]) learns each one's point count, bounds and
//! convex hull, and a block then reads only the files its region meets, more as it grows.

use super::input::{InputKind, PointsRead, ReadOptions, describe, drop_long_triangles, read_points};
use super::{DemError, Input, Progress};
use crate::{Grid, Window};
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};
use tileraster_io::{Copc, CopcNode};
use tileraster_tin::{BlockSource, BlockTin, Hull, Rect, Region, TinError};

/// How a block's TIN was made ([`block_scene`]).
#[derive(Debug, Clone, Copy)]
pub struct BlockRead {
    /// The points triangulated: those of the window and its buffer, repeats included.
    pub points: usize,
    /// The widest side of the buffer that proved the block's triangles, in map units beyond
    /// the window's cells.
    pub buffer: f64,
    /// Regions triangulated, the last included (1: the first buffer sufficed).
    pub attempts: u32,
    /// The width of the bands along the hull's edges whose points were triangulated too (0
    /// for none).
    pub band: f64,
    /// Input files read (0 for points in memory).
    pub files_read: usize,
    /// Discs read around circles too wide for the rectangle (across a lake, say).
    pub discs: usize,
    /// Points decoded from the files, over every region tried: all of a file read whole (of
    /// `--class`), and the records of the nodes of a COPC file read (0 for points in memory).
    pub points_decoded: usize,
}

/// Cells beyond a block's window whose triangles the block keeps: more than the rasteriser's
/// own one-cell margin ([`tileraster_core::prepare`]'s cull), so that a triangle that reaches
/// the grid passes over some block's window with room to spare.
const BLOCK_MARGIN_CELLS: f64 = 2.0;

/// The scene of `window` of `grid` as a block: the TIN of `points` (all of the input's, as
/// [`read_points`](super::read_points) gives them) made from the points of the window and a
/// buffer around it only, proven to hold the whole TIN's triangles over the window, then
/// without the triangles `options.max_edge` leaves out. Its cells are the whole TIN's bit for
/// bit, on the snapping lattice every block shares: a block that meets a triangle too wide for
/// the finest lattice ([`tileraster_core::snap_bits`]) is [`DemError::BlockLattice`].
pub fn block_scene(points: &[[f64; 3]], grid: &Grid, window: Window, options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    let triangulation = |source| DemError::Triangulation { path: PathBuf::from("the input's points"), source };
    let hull = Hull::of(points);
    block_of(grid, window, options, progress, |cells| tileraster_tin::triangulate_block(points, &hull, cells).map_err(triangulation))
}

/// What a first pass over one point file learns: enough to read only the files a block needs.
#[derive(Debug, Clone, PartialEq)]
pub struct FileSummary {
    pub path: PathBuf,
    /// Its points (those of `--class`, for LAS/LAZ), repeats included.
    pub points: usize,
    /// The least rectangle holding its points' x and y; `None` when it has none.
    pub bounds: Option<Rect>,
    /// The convex hull of its points' x and y.
    pub hull: Hull,
    /// Its points counted in each cell of a `DENSITY_SIDE`² grid over `bounds`, row by row
    /// from the south (empty without points): what reading a region of it costs.
    pub density: Vec<u32>,
    /// For a COPC file, the point records its header counts: its points are read by octree
    /// node and numbered by record, and with `--class`, `points` and `density` are estimates
    /// from the nodes the summary read. `None` for a file read whole.
    pub records: Option<u64>,
}

/// Cells along each side of a file's density grid ([`FileSummary::density`]).
pub const DENSITY_SIDE: usize = 32;

impl FileSummary {
    /// The numbers its points take in the whole set's order: its points, or a COPC file's
    /// records.
    fn span(&self) -> usize {
        self.records.map_or(self.points, |r| r as usize)
    }

    /// About how many of its points `region` holds: those of the density cells it meets.
    fn estimate(&self, region: &Region) -> usize {
        let Some(b) = self.bounds.filter(|b| region.meets(b)) else { return 0 };
        let (w, h) = ((b.x1 - b.x0) / DENSITY_SIDE as f64, (b.y1 - b.y0) / DENSITY_SIDE as f64);
        let cell = |k: usize| {
            let (i, j) = ((k % DENSITY_SIDE) as f64, (k / DENSITY_SIDE) as f64);
            Rect { x0: b.x0 + i * w, x1: b.x0 + (i + 1.0) * w, y0: b.y0 + j * h, y1: b.y0 + (j + 1.0) * h }
        };
        self.density.iter().enumerate().filter(|&(k, &n)| n > 0 && region.meets(&cell(k))).map(|(_, &n)| n as usize).sum()
    }
}

/// The density grid of `points` over `bounds` ([`FileSummary::density`]).
fn density(points: &[[f64; 3]], bounds: Option<Rect>) -> Vec<u32> {
    let Some(b) = bounds else { return Vec::new() };
    let mut counts = vec![0u32; DENSITY_SIDE * DENSITY_SIDE];
    let at = |v: f64, lo: f64, hi: f64| (((v - lo) / (hi - lo) * DENSITY_SIDE as f64) as usize).min(DENSITY_SIDE - 1);
    for p in points {
        // A file of one column or row puts its points in the first cells.
        let (i, j) = (if b.x1 > b.x0 { at(p[0], b.x0, b.x1) } else { 0 }, if b.y1 > b.y0 { at(p[1], b.y0, b.y1) } else { 0 });
        counts[j * DENSITY_SIDE + i] += 1;
    }
    counts
}

/// Read each file of `paths` (on all cores, one file a core) and summarise it.
pub fn summarise_files(paths: &[PathBuf], options: &ReadOptions) -> Result<Vec<FileSummary>, DemError> {
    paths.par_iter().map(|path| summarise_file(path, options)).collect()
}

/// Read `path` and summarise it; a non-finite coordinate is refused as the whole run refuses it.
/// A COPC file is summarised from its index and the nodes that may hold corners of its hull.
pub fn summarise_file(path: &Path, options: &ReadOptions) -> Result<FileSummary, DemError> {
    if let Some(copc) = open_copc(path)? {
        return summarise_copc(&copc, path, options);
    }
    let points = read_file(path, options)?;
    if let Some((index, &[x, y, z])) = points.iter().enumerate().find(|(_, p)| !p.iter().all(|c| c.is_finite())) {
        return Err(DemError::Triangulation { path: path.to_path_buf(), source: TinError::NonFinite { index, x, y, z } });
    }
    let bounds = Rect::around(&points);
    Ok(FileSummary { path: path.to_path_buf(), points: points.len(), bounds, hull: Hull::of(&points), density: density(&points, bounds), records: None })
}

/// Whether `path` is a COPC file, whose blocks read only the octree nodes their regions meet.
pub fn is_copc(path: &Path) -> Result<bool, DemError> {
    Ok(open_copc(path)?.is_some())
}

/// The COPC index of `path` when it is a LAS/LAZ file that is one.
fn open_copc(path: &Path) -> Result<Option<Copc>, DemError> {
    Ok(match InputKind::of(path)? {
        InputKind::Las => Copc::open(path)?,
        _ => None,
    })
}

/// A node's cube as a rectangle.
fn cube(node: &CopcNode) -> Rect {
    let [x0, y0, x1, y1] = node.bounds;
    Rect { x0, y0, x1, y1 }
}

/// A COPC file's summary. Its hull is exact: nodes are read until every node not read lies
/// strictly inside the hull of the points read (first those whose cubes reach the extremes,
/// then those the hull does not surround), so no point left unread can be a corner of it.
/// With `--class`, its points and density scale the index's counts by the share of the
/// points read that are of those classes.
fn summarise_copc(copc: &Copc, path: &Path, options: &ReadOptions) -> Result<FileSummary, DemError> {
    let cubes: Vec<Rect> = copc.nodes.iter().map(cube).collect();
    let Some(outer) = cubes.iter().copied().reduce(|a, b| Rect { x0: a.x0.min(b.x0), y0: a.y0.min(b.y0), x1: a.x1.max(b.x1), y1: a.y1.max(b.y1) }) else {
        return Err(DemError::Io(tileraster_io::IoError::Format { path: path.to_owned(), message: "the file holds no points".into() }));
    };
    let mut wanted: Vec<usize> = (0..cubes.len())
        .filter(|&k| [cubes[k].x0 == outer.x0, cubes[k].x1 == outer.x1, cubes[k].y0 == outer.y0, cubes[k].y1 == outer.y1].contains(&true))
        .collect();
    let (mut read, mut corners, mut kept, mut decoded) = (vec![false; cubes.len()], Vec::new(), 0u64, 0u64);
    let mut hull = Hull::of(&corners);
    while !wanted.is_empty() {
        let nodes = copc.read(&wanted, &options.classes)?;
        wanted.iter().for_each(|&k| read[k] = true);
        kept += nodes.points.len() as u64;
        decoded += nodes.decoded;
        corners.extend(nodes.points.iter().map(|&(_, p)| [p[0], p[1]]));
        hull = Hull::of(&corners);
        corners = hull.corners().to_vec();
        wanted = (0..cubes.len()).filter(|&k| !read[k] && !hull.surrounds(&cubes[k])).collect();
    }
    if hull.corners().is_empty() {
        // Every node was read (an empty hull surrounds none) and none holds a point of the
        // classes asked for: the whole file's own error names the classes it holds.
        read_file(path, options)?;
        return Err(DemError::Io(tileraster_io::IoError::Format { path: path.to_owned(), message: "the file holds no points".into() }));
    }
    let share = if decoded > 0 { kept as f64 / decoded as f64 } else { 1.0 };
    let bounds = hull.bounds();
    let density = bounds.map_or_else(Vec::new, |b| node_density(&copc.nodes, &b, share));
    Ok(FileSummary { path: path.to_owned(), points: (copc.records as f64 * share).round() as usize, bounds, hull, density, records: Some(copc.records) })
}

/// The density grid over `bounds` from a COPC index: each node's count, times `share`, spread
/// over the cells by the part of its cube in each.
fn node_density(nodes: &[CopcNode], bounds: &Rect, share: f64) -> Vec<u32> {
    let mut counts = vec![0f64; DENSITY_SIDE * DENSITY_SIDE];
    let n = DENSITY_SIDE as f64;
    let (w, h) = ((bounds.x1 - bounds.x0) / n, (bounds.y1 - bounds.y0) / n);
    for node in nodes {
        let c = cube(node);
        let (cw, ch) = (c.x1 - c.x0, c.y1 - c.y0);
        let span = |lo: f64, hi: f64, origin: f64, step: f64| {
            if step > 0.0 { ((((lo - origin) / step).floor().max(0.0)) as usize, (((hi - origin) / step).ceil().clamp(0.0, n)) as usize) } else { (0, 1) }
        };
        let (i0, i1) = span(c.x0, c.x1, bounds.x0, w);
        let (j0, j1) = span(c.y0, c.y1, bounds.y0, h);
        for j in j0..j1.max(j0 + 1).min(DENSITY_SIDE) {
            for i in i0..i1.max(i0 + 1).min(DENSITY_SIDE) {
                let part = |lo: f64, hi: f64, a: f64, b: f64, whole: f64| if whole > 0.0 { ((hi.min(b) - lo.max(a)) / whole).clamp(0.0, 1.0) } else { 1.0 };
                let (x0, y0) = (bounds.x0 + i as f64 * w, bounds.y0 + j as f64 * h);
                counts[j * DENSITY_SIDE + i] += node.count() as f64 * share * part(c.x0, c.x1, x0, x0 + w, cw) * part(c.y0, c.y1, y0, y0 + h, ch);
            }
        }
    }
    counts.iter().map(|&c| c.ceil() as u32).collect()
}

fn read_file(path: &Path, options: &ReadOptions) -> Result<Vec<[f64; 3]>, DemError> {
    read_points(std::slice::from_ref(&path.to_path_buf()), options)
}

/// The scene of `window` of `grid` as a block ([`block_scene`]) of the points of `files` (in
/// that order, as one file's), reading only the files whose bounds meet the block's region.
/// A file whose points differ in number from its summary is [`DemError::InputChanged`].
pub fn block_scene_of_files(files: &[FileSummary], grid: &Grid, window: Window, options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    if files.is_empty() {
        return Err(DemError::NoInputs);
    }
    let hull = Hull::of_hulls(&files.iter().map(|f| f.hull.clone()).collect::<Vec<_>>());
    let mut source = FileSource::new(files, options);
    let paths: Vec<PathBuf> = files.iter().map(|f| f.path.clone()).collect();
    let mut input = block_of(grid, window, options, progress, |cells| {
        tileraster_tin::triangulate_block_from(&mut source, &hull, cells).map_err(|e| match e {
            SourceError::Tin(source) => DemError::Triangulation { path: describe(&paths), source },
            SourceError::Read(e) => e,
        })
    })?;
    if let Some(block) = &mut input.block {
        block.files_read = source.read.iter().filter(|&&r| r).count();
        block.points_decoded = source.decoded;
    }
    Ok(input)
}

/// Bytes a whole run holds a point (its coordinates, the TIN, the prepared triangles, the
/// file read): 326 measured on 3,151,294 LAZ points (a peak of 1.03 GB, 2026-11-29).
pub const BYTES_PER_POINT: u64 = 350;

/// An upper estimate of the points of `paths`, without reading them: the LAS/LAZ headers'
/// counts (before `--class`), and a text file's size over 16 bytes a point.
pub fn estimated_points(paths: &[PathBuf]) -> Result<u64, DemError> {
    let estimate = |path: &PathBuf| -> Result<u64, DemError> {
        Ok(match InputKind::of(path)? {
            InputKind::Las => tileraster_io::las_point_count(path)?,
            _ => std::fs::metadata(path).map_err(|source| tileraster_io::IoError::Io { path: path.clone(), source })?.len() / 16,
        })
    };
    paths.iter().map(estimate).sum()
}

/// Rows of the bands of a run in blocks ([`write_dem_of_files`](super::write_dem_of_files)):
/// whole tile rows of about `budget / 2` bytes of points each at the grid's mean density, and
/// at most a fifth of the points, so that a band need not take them all.
pub fn block_band_rows(window: &Window, grid: &Grid, points: usize, budget: u64) -> u32 {
    let per_row = (points as f64 / grid.height.max(1) as f64).max(1.0);
    let band_points = ((budget / 2 / BYTES_PER_POINT) as f64).min(points as f64 / 5.0);
    let tile = tileraster_io::TILE as u64;
    ((band_points / per_row) as u64 / tile * tile).clamp(tile, window.height.max(1) as u64) as u32
}

/// Point files read as a block's region reaches them. Each file read keeps only the points
/// the region holds, so a block holds its own points and one file a core at a time, whatever
/// the files' sizes; a region that grows reads its files again.
struct FileSource<'a> {
    files: &'a [FileSummary],
    options: &'a ReadOptions,
    /// Where each file's points start in the whole set.
    offsets: Vec<usize>,
    /// Which files were read.
    read: Vec<bool>,
    /// The COPC files' indices, once opened.
    copc: Vec<Option<Copc>>,
    /// Points decoded so far ([`BlockRead::points_decoded`]).
    decoded: usize,
}

/// Points, each with its number in the whole set's order.
type Indexed = Vec<(usize, [f64; 3])>;

enum SourceError {
    Tin(TinError),
    Read(DemError),
}

impl From<DemError> for SourceError {
    fn from(e: DemError) -> Self {
        SourceError::Read(e)
    }
}

impl From<TinError> for SourceError {
    fn from(e: TinError) -> Self {
        SourceError::Tin(e)
    }
}

impl<'a> FileSource<'a> {
    fn new(files: &'a [FileSummary], options: &'a ReadOptions) -> Self {
        let offsets = files.iter().scan(0, |start, f| Some(std::mem::replace(start, *start + f.span()))).collect();
        FileSource { files, options, offsets, read: vec![false; files.len()], copc: vec![None; files.len()], decoded: 0 }
    }
}

impl BlockSource for FileSource<'_> {
    type Error = SourceError;

    fn total(&self) -> usize {
        self.files.iter().map(|f| f.points).sum()
    }

    fn within(&mut self, region: Option<&Region>) -> Result<Vec<(usize, [f64; 3])>, SourceError> {
        let wanted: Vec<usize> = (0..self.files.len()).filter(|&k| self.files[k].bounds.is_some_and(|b| region.is_none_or(|r| r.meets(&b)))).collect();
        for &k in &wanted {
            let file = &self.files[k];
            if let (Some(records), None) = (file.records, &self.copc[k]) {
                let copc = open_copc(&file.path)?.filter(|c| c.records == records);
                let read = copc.as_ref().map_or(0, |c| c.records as usize);
                self.copc[k] = Some(copc.ok_or(DemError::InputChanged { path: file.path.clone(), summarised: records as usize, read })?);
            }
        }
        // Each file's points the region holds, and the points decoded for them.
        let read = |&k: &usize| -> Result<(Indexed, usize), DemError> {
            let file = &self.files[k];
            let inside = |p: &[f64; 3]| region.is_none_or(|r| r.holds(p[0], p[1]));
            if let Some(copc) = &self.copc[k] {
                // The nodes whose cubes the region meets, in file order, numbered by record.
                let nodes: Vec<usize> = (0..copc.nodes.len()).filter(|&n| region.is_none_or(|r| r.meets(&cube(&copc.nodes[n])))).collect();
                let read = copc.read(&nodes, &self.options.classes)?;
                let held = read.points.into_iter().filter(|(_, p)| inside(p)).map(|(record, p)| (self.offsets[k] + record as usize, p)).collect();
                return Ok((held, read.decoded as usize));
            }
            let points = read_file(&file.path, self.options)?;
            if points.len() != file.points {
                return Err(DemError::InputChanged { path: file.path.clone(), summarised: file.points, read: points.len() });
            }
            Ok((points.iter().enumerate().filter(|(_, p)| inside(p)).map(|(i, &p)| (self.offsets[k] + i, p)).collect(), points.len()))
        };
        let parts = wanted.par_iter().map(read).collect::<Result<Vec<_>, _>>().map_err(SourceError::Read)?;
        wanted.iter().for_each(|&k| self.read[k] = true);
        self.decoded += parts.iter().map(|(_, n)| n).sum::<usize>();
        // In the files' order, each file's points in its own: the whole set's order.
        Ok(parts.into_iter().flat_map(|(points, _)| points).collect())
    }

    fn estimate(&self, region: &Region) -> usize {
        self.files.iter().map(|f| f.estimate(region)).sum()
    }
}

/// `window` of `grid` in map units, with the margin of cells whose triangles a block keeps.
fn block_cells(grid: &Grid, window: Window) -> Rect {
    let (dx, dy) = (grid.dx(), grid.dy());
    Rect {
        x0: grid.xmin + (window.x0 as f64 - BLOCK_MARGIN_CELLS) * dx,
        x1: grid.xmin + ((window.x0 + window.width) as f64 + BLOCK_MARGIN_CELLS) * dx,
        y0: grid.ymax - ((window.y0 + window.height) as f64 + BLOCK_MARGIN_CELLS) * dy,
        y1: grid.ymax - (window.y0 as f64 - BLOCK_MARGIN_CELLS) * dy,
    }
}

/// Points of summarised files held in memory for many blocks: every point of `rect`, or
/// within `width` of the hull's edges (a band's blocks share the first, a run's the second).
pub struct HeldPoints {
    rect: Rect,
    width: f64,
    points: Vec<(usize, [f64; 3])>,
}

impl HeldPoints {
    /// The points of `files` within the hull's bands of a width the blocks' bands may reach
    /// (eight times the first: three doublings), read once (one file a core).
    pub fn near_hull(files: &[FileSummary], options: &ReadOptions) -> Result<HeldPoints, DemError> {
        let (hull, total) = hull_of(files);
        let width = tileraster_tin::first_buffer(&hull, total);
        let points = read_region(files, options, &hull.strip(width))?;
        Ok(HeldPoints { rect: Rect::EMPTY, width, points })
    }

    /// The points of `files` in the cells of `window` of `grid` and a margin of four first
    /// buffers around them, which a block of the window holds unless its buffer doubles thrice.
    pub fn around(files: &[FileSummary], options: &ReadOptions, grid: &Grid, window: Window) -> Result<HeldPoints, DemError> {
        let (hull, total) = hull_of(files);
        let rect = block_cells(grid, window).grown(4.0 * tileraster_tin::first_buffer(&hull, total));
        Ok(HeldPoints { rect, width: 0.0, points: read_region(files, options, &Region::rect(rect))? })
    }
}

fn hull_of(files: &[FileSummary]) -> (Hull, usize) {
    (Hull::of_hulls(&files.iter().map(|f| f.hull.clone()).collect::<Vec<_>>()), files.iter().map(|f| f.points).sum())
}

fn read_region(files: &[FileSummary], options: &ReadOptions, region: &Region) -> Result<Vec<(usize, [f64; 3])>, DemError> {
    FileSource::new(files, options).within(Some(region)).map_err(|e| match e {
        SourceError::Read(e) => e,
        SourceError::Tin(source) => DemError::Triangulation { path: describe(&files.iter().map(|f| f.path.clone()).collect::<Vec<_>>()), source },
    })
}

/// The scene of `window` of `grid` as a block ([`block_scene_of_files`]), its points taken
/// from `band` and `near_hull` where they hold all of its region, else read from the files.
pub fn block_scene_held(
    files: &[FileSummary],
    near_hull: &HeldPoints,
    band: &HeldPoints,
    grid: &Grid,
    window: Window,
    options: &ReadOptions,
) -> Result<Input, DemError> {
    let (hull, _) = hull_of(files);
    let mut source = HeldSource { held: [band, near_hull], files: FileSource::new(files, options) };
    let paths: Vec<PathBuf> = files.iter().map(|f| f.path.clone()).collect();
    let mut input = block_of(grid, window, options, &(), |cells| {
        tileraster_tin::triangulate_block_from(&mut source, &hull, cells).map_err(|e| match e {
            SourceError::Tin(source) => DemError::Triangulation { path: describe(&paths), source },
            SourceError::Read(e) => e,
        })
    })?;
    if let Some(block) = &mut input.block {
        block.files_read = source.files.read.iter().filter(|&&r| r).count();
        block.points_decoded = source.files.decoded;
    }
    Ok(input)
}

/// Points held in memory where they hold a region, else the files.
struct HeldSource<'a> {
    held: [&'a HeldPoints; 2],
    files: FileSource<'a>,
}

impl BlockSource for HeldSource<'_> {
    type Error = SourceError;

    fn total(&self) -> usize {
        self.files.total()
    }

    fn within(&mut self, region: Option<&Region>) -> Result<Vec<(usize, [f64; 3])>, SourceError> {
        // Every point of the region's rectangle in the first, of its bands in the second.
        let [rect, bands] = self.held;
        match region {
            Some(r) if rect.rect.covers(&r.rect) && r.band_width() <= bands.width => {
                let mut chosen: Vec<(usize, [f64; 3])> = rect.points.iter().chain(&bands.points).filter(|(_, p)| r.holds(p[0], p[1])).copied().collect();
                // Discs (around circles too wide for the rectangle) from the files they meet.
                if r.has_discs() {
                    chosen.extend(self.files.within(Some(&r.discs_only()))?);
                }
                chosen.sort_unstable_by_key(|&(index, _)| index);
                chosen.dedup_by_key(|&mut (index, _)| index);
                Ok(chosen)
            }
            _ => self.files.within(region),
        }
    }

    fn estimate(&self, region: &Region) -> usize {
        self.files.estimate(region)
    }
}

/// A block's scene from `triangulate`, given the block's window in map units with its margin.
fn block_of(
    grid: &Grid,
    window: Window,
    options: &ReadOptions,
    progress: &dyn Progress,
    triangulate: impl FnOnce(Rect) -> Result<BlockTin, DemError>,
) -> Result<Input, DemError> {
    if let Some(max_edge) = options.max_edge.filter(|l| !(l.is_finite() && *l > 0.0)) {
        return Err(DemError::MaxEdge(max_edge));
    }
    window.validate(grid)?;
    let start = Instant::now();
    let cells = block_cells(grid, window);
    progress.stage(&format!("triangulating the points around {}×{} cells", window.width, window.height));
    let block = triangulate(cells)?;
    let mut scene = block.tin.scene;
    let long_triangles = options.max_edge.map_or(0, |max_edge| drop_long_triangles(&mut scene, max_edge));
    let bits = tileraster_core::snap_bits(&scene, grid)?;
    if bits < tileraster_core::kernels::MAX_SNAP_BITS {
        return Err(DemError::BlockLattice { bits, finest: tileraster_core::kernels::MAX_SNAP_BITS });
    }
    let summary = PointsRead { count: block.points, duplicates: block.tin.duplicates, read: Duration::ZERO, triangulated: start.elapsed() };
    let region = block.region;
    let buffer = (cells.x0 - region.x0).max(cells.y0 - region.y0).max(region.x1 - cells.x1).max(region.y1 - cells.y1).max(0.0);
    Ok(Input {
        scene,
        points: Some(summary),
        long_triangles,
        points_read: None,
        block: Some(BlockRead {
            points: block.points,
            buffer,
            attempts: block.attempts,
            band: block.band,
            discs: block.discs,
            files_read: 0,
            points_decoded: 0,
        }),
    })
}
