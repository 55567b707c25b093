//! Preparation, once per scene and grid, on the host in f64:
//!
//! 1. validate the scene and the grid;
//! 2. cull triangles that cannot reach a pixel centre of the grid;
//! 3. choose the snapping lattice (`2^-snap_bits` px) from the largest triangle, so that
//!    every edge function of the kernels fits in `i64`;
//! 4. snap vertices, orient triangles positively, drop the ones snapping made flat, and the
//!    small ones that touch no pixel centre (the kernels' own test, on at most 16 centres);
//! 5. fit each triangle's height plane through its *unsnapped* vertices and store it in
//!    fixed point, exact over the triangle's pixel rectangle;
//! 6. where it can pay, prove that no pixel centre is inside two triangles (`overlap`).
//!
//! Coverage is then decided on the snapped lattice with integers (watertight and identical on
//! every device); values come from the unsnapped planes, so snapping only matters for which
//! triangle owns a pixel centre lying within `2^-(snap_bits+1)` px of an edge.

use crate::{Error, Grid, Mode, Params, Scene};
use rayon::prelude::*;
use tileraster_kernels::abi::{
    DepthTest, FloatCoeffs, MaterialRecord, OutputSet, PixelRect, Plane, RecordsAndFaces, ShadeParams, TextureInfo, TriangleInput, TriangleShading,
};
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::pipeline::{Layer, Pipeline};
use tileraster_kernels::stages::fine::side;
use tileraster_kernels::stages::setup::setup_triangle;
use tileraster_kernels::{EXTENT_LIMIT_BITS, MAX_SNAP_BITS};

/// A rectangle of grid pixels: columns `x0..x0+width`, rows `y0..y0+height`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    pub x0: u32,
    pub y0: u32,
    pub width: u32,
    pub height: u32,
}

impl Window {
    pub fn whole(grid: &Grid) -> Self {
        Window { x0: 0, y0: 0, width: grid.width, height: grid.height }
    }

    pub fn pixel_count(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    /// Whether the window is non-empty and lies inside `grid`.
    pub fn validate(&self, grid: &Grid) -> Result<(), Error> {
        let fits = self.width > 0
            && self.height > 0
            && self.x0 as u64 + self.width as u64 <= grid.width as u64
            && self.y0 as u64 + self.height as u64 <= grid.height as u64;
        if fits {
            Ok(())
        } else {
            Err(Error::InvalidWindow {
                x0: self.x0 as u64,
                y0: self.y0 as u64,
                width: self.width as u64,
                height: self.height as u64,
                grid_width: grid.width as u64,
                grid_height: grid.height as u64,
            })
        }
    }
}

/// A scene made ready for the kernels on one grid: snapped, culled, oriented, with planes, and
/// analysed for overlaps. It serves any window of the grid ([`Prepared::plan`]); `window` is
/// the one it was prepared for, the default.
///
/// The backends trust what preparation proved about it (the rows free of overlaps, the
/// render pipeline's `ShadeParams::small_edges`): its fields are open for reading and for the
/// outputs it asks for (`params.outputs`), and a preparation edited otherwise is outside the
/// numeric contract.
#[derive(Debug, Clone)]
pub struct Prepared {
    pub params: Params,
    pub window: Window,
    pub snap_bits: u32,
    /// The triangles that can cover a pixel centre of the grid, in scene order.
    pub triangles: Vec<TriangleInput>,
    /// Triangles dropped because they cannot reach a pixel centre of the grid.
    pub culled: usize,
    /// Triangles dropped because they have no area once snapped.
    pub degenerate: usize,
    /// The grid rows (those of `window`) on which the scene analysis proved that no pixel
    /// centre is inside two of `triangles` (see `overlap`); `None` when not proven, or not
    /// looked for (`Skips::overlap_free` off).
    pub overlap_free_rows: Option<std::ops::Range<u32>>,
    /// The render pipeline's per-triangle attributes and frame parameters; `None` for the
    /// heightfield pipeline.
    pub render: Option<RenderInputs>,
}

/// What the render pipeline adds to a prepared scene (see `crate::render`).
#[derive(Debug, Clone, PartialEq)]
pub struct RenderInputs {
    /// One per prepared triangle, in the same order (setup slots).
    pub triangles: Vec<TriangleShading>,
    /// Each one's `face` again (`faces[k] == triangles[k].face`), compact: the CPU's shade stages
    /// read a pixel's face here (`abi::RecordsAndFaces`), the GPU's from the record, so whoever
    /// changes a record's face changes it here too.
    pub faces: Vec<u32>,
    pub params: ShadeParams,
    pub depth_test: DepthTest,
    /// The frame's textures and their texels (`programs::texture`), the texels shared with
    /// the other frames of a prepared mesh that lay its textures out alike.
    pub textures: Vec<TextureInfo>,
    pub texels: std::sync::Arc<Vec<u64>>,
    /// Whether the backend holds these texels from an earlier frame (a prepared mesh's): the
    /// call hands it none of them (`Stats::bytes_uploaded`).
    pub texels_resident: bool,
    /// The frame's materials (`Materials`): its own surface, then its meshes' materials.
    pub materials: Vec<MaterialRecord>,
    /// Where the kernels' assembly wrote the frame's records and lists where its backend's
    /// raster stages read them (the host's arrays on the CPU, the device's buffers on the GPU),
    /// the key the backend gave them (`GeometryKernels::hold_records`): the GPU's raster call
    /// sets up the records it holds under this key rather than take `triangles` and the
    /// shading again, and `Stats::bytes_uploaded` counts neither. `triangles` hold the same
    /// records.
    pub records_held: Option<u64>,
    /// The frame's fragment shader; `None`: the built-in shadings.
    pub fragment: Option<crate::render::FragmentStage>,
    /// Whether the call returns the colour layer, and the depth layer (the values): the stages
    /// write both in any case.
    pub returns_colour: bool,
    pub returns_depth: bool,
}

impl RenderInputs {
    /// The shading records as the CPU's shade stages read them: with the faces apart.
    pub fn records(&self) -> RecordsAndFaces<'_> {
        debug_assert_eq!(self.faces.len(), self.triangles.len(), "a face per record");
        RecordsAndFaces { records: &self.triangles, faces: &self.faces }
    }
}

impl Prepared {
    /// Whether the stages keep an owner layer: where the call returns it, and in the
    /// single-sample render pipeline, whose shade stage reads each pixel's setup by it (its
    /// frame returns face ids instead).
    pub fn keeps_owner(&self) -> bool {
        self.params.outputs.owner || self.pipeline() == Pipeline::Render
    }

    /// Whether the call returns the values layer: always for a heightfield, as asked for a
    /// frame's depth.
    pub fn returns_values(&self) -> bool {
        self.render.as_ref().is_none_or(|r| r.returns_depth)
    }

    /// Whether the call returns a colour layer (a frame, where asked for).
    pub fn returns_colours(&self) -> bool {
        self.render.as_ref().is_some_and(|r| r.returns_colour)
    }

    /// Whether the call returns `layer`.
    pub fn returns(&self, layer: Layer) -> bool {
        let outputs = &self.params.outputs;
        match layer {
            Layer::Values => self.returns_values(),
            Layer::Owners => outputs.owner,
            Layer::Coverage => outputs.coverage,
            Layer::Colours => self.returns_colours(),
            Layer::Faces => self.render.is_some(),
            Layer::Tiles => outputs.tiles,
        }
    }

    /// Whether the raster stages write `layer` (the layer table's `Written`), returned or not.
    pub fn writes(&self, layer: Layer) -> bool {
        layer.info().written_by(self.pipeline(), self.output_set())
    }

    /// The layers the kernels write (`FrameParams::outputs`): those the call returns, and the
    /// owner layer where the stages keep it.
    pub fn output_set(&self) -> OutputSet {
        self.params.output_set().with(OutputSet::OWNER, self.keeps_owner())
    }

    /// The pipeline this preparation runs.
    pub fn pipeline(&self) -> Pipeline {
        match &self.render {
            Some(r) if r.params.samples > 1 => Pipeline::RenderMultisampled,
            Some(_) => Pipeline::Render,
            None => Pipeline::Height,
        }
    }
}

/// Margin of the conservative f64 cull, in pixels: far more than snapping can move a vertex.
const CULL_MARGIN_PX: f64 = 1.0;

pub fn prepare(scene: &Scene, params: &Params, window: Option<Window>) -> Result<Prepared, Error> {
    prepare_with(scene, params, window, Analysis::WherePays)
}

/// When preparation runs the overlap analysis (with `Skips::overlap_free` on).
#[derive(Clone, Copy, PartialEq, Eq)]
pub(crate) enum Analysis {
    /// Where it can pay: the triangles' pixel rectangles hold at least
    /// [`ANALYSIS_MIN_MEAN_PIXELS`] pixels on average.
    WherePays,
    /// Always (the analysis's own tests).
    #[cfg_attr(not(test), allow(dead_code))]
    Always,
}

/// The overlap analysis costs about the same per triangle whatever its size (three edges to
/// match with their neighbours'); what it saves, fine raster's tests of a pixel against the
/// triangles after the one it is inside, grows with the pixels each triangle is tested
/// against. Measured on the CPU backend (2 cores, 2026-11-23), whole calls with the analysis
/// and without: the 100k-point TIN at 4096² (rectangles of 181 px on average) 97 against
/// 126 ms; at 2048² (45 px) 83 against 63 ms; 1 px micro-triangles 71 against 45 ms. The
/// break-even lies between; lavapipe's GPU backend, whose fine raster pays more per pixel,
/// gains from it on smaller triangles too, but a hardware GPU's calls are bound by this very
/// preparation.
const ANALYSIS_MIN_MEAN_PIXELS: u64 = 96;

pub(crate) fn prepare_with(scene: &Scene, params: &Params, window: Option<Window>, analysis: Analysis) -> Result<Prepared, Error> {
    let grid = params.grid;
    grid.validate()?;
    let window = window.unwrap_or_else(|| Window::whole(&grid));
    window.validate(&grid)?;
    validate_scene(scene)?;

    // Every step below is per vertex or per triangle, in tasks of `CHUNK` triangles over all
    // cores; each keeps scene order, so the result does not depend on the number of threads.
    // The triangles are walked three times rather than collected into intermediate vectors:
    // for small triangles, moving and faulting in memory would cost more than the arithmetic.
    let raster: Vec<[f64; 2]> = scene
        .vertices
        .par_iter()
        .map(|v| {
            let (u, v) = grid.to_raster(v[0], v[1]);
            [u, v]
        })
        .collect();
    let reaching_extent = |tri: &[u32; 3]| reaching_extent(tri.map(|k| raster[k as usize]), &grid);
    let snap_bits = snap_bits_of(&scene.triangles, reaching_extent)?;
    let unit = (1i64 << snap_bits) as f64;

    // 4. Snap, orient, rectangle: what becomes of triangle `t`.
    // `search`: look for a centre the triangle touches (the first walk; the second knows).
    let snap = |t: usize, search: bool| -> Snap {
        let tri = &scene.triangles[t];
        if reaching_extent(tri).is_none() {
            return Snap::Outside;
        }
        let mut corners = tri.map(|k| k as usize);
        let (mut x, mut y) = ([0i64; 3], [0i64; 3]);
        for c in 0..3 {
            let [u, v] = raster[corners[c]];
            (x[c], y[c]) = (round_to_i64(u * unit), round_to_i64(v * unit));
        }
        let area = (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
        if area == 0 {
            return Snap::Flat;
        }
        if area < 0 {
            x.swap(1, 2);
            y.swap(1, 2);
            corners.swap(1, 2);
        }
        let rect = pixel_rect(&x, &y, snap_bits, &grid);
        if rect.is_empty() {
            return Snap::NoCentre;
        }
        let snapped = Snapped { index: t, corners, x, y, rect };
        if search && touches_no_centre(&snapped, snap_bits) { Snap::Hidden } else { Snap::Kept(snapped) }
    };
    // First walk: what becomes of each triangle (so the second snaps only the kept ones again),
    // how many each task keeps and hides (for the overlap analysis only), and the pixels of
    // the kept ones' rectangles.
    let chunks = scene.triangles.len().div_ceil(CHUNK);
    let chunk = |c: usize| c * CHUNK..scene.triangles.len().min((c + 1) * CHUNK);
    let mut fate = vec![Fate::Dropped; scene.triangles.len()];
    let counts: Vec<ChunkCounts> = fate
        .par_chunks_mut(CHUNK)
        .enumerate()
        .map(|(c, fates)| {
            let mut n = ChunkCounts::default();
            for (fate, t) in fates.iter_mut().zip(chunk(c)) {
                *fate = match snap(t, true) {
                    Snap::Kept(s) => {
                        n.pixels += (s.rect.i1 - s.rect.i0 + 1) as u64 * (s.rect.j1 - s.rect.j0 + 1) as u64;
                        Fate::Kept
                    }
                    Snap::Hidden => Fate::Hidden,
                    Snap::Flat => Fate::Flat,
                    Snap::Outside | Snap::NoCentre => Fate::Dropped,
                };
                n.kept += usize::from(*fate == Fate::Kept);
                n.hidden += usize::from(*fate == Fate::Hidden);
            }
            n
        })
        .collect();
    let degenerate = fate.par_iter().filter(|&&f| f == Fate::Flat).count();
    let kept: usize = counts.iter().map(|n| n.kept).sum();
    let pixels: u64 = counts.iter().map(|n| n.pixels).sum();
    let culled = scene.triangles.len() - kept - degenerate;
    let analyse = params.skips.overlap_free && (analysis == Analysis::Always || pixels >= ANALYSIS_MIN_MEAN_PIXELS * kept as u64);
    // Hidden triangles are dropped unless the analysis needs them.
    let hidden_of = |n: &ChunkCounts| if analyse { n.hidden } else { 0 };
    let hidden: usize = counts.iter().map(hidden_of).sum();

    // 5. Planes, and the cheaper modes' coefficients, written straight into place (huge pages,
    // no copies). The first failing triangle in scene order names the error.
    let input = |s: &Snapped| -> Result<TriangleInput, Error> {
        let (plane, f64_plane) = fit_plane(scene, &raster, s, snap_bits);
        let coeffs = float_coeffs(params.mode, scene, s, f64_plane);
        let reach = float_reach(params.mode, &coeffs, &s.rect);
        if reach.is_nan() || reach >= FLOAT_REACH_LIMIT {
            return Err(Error::OutsideModeRange { triangle: s.index, mode: params.mode.name(), reach });
        }
        let extent_px = (s.rect.i1 - s.rect.i0).max(s.rect.j1 - s.rect.j0) as u64 + 1;
        if params.mode == Mode::PlaneF32 && extent_px > FLOAT_OFFSET_LIMIT + 1 {
            return Err(Error::TooWideForMode { triangle: s.index, mode: params.mode.name(), extent_px, limit_px: FLOAT_OFFSET_LIMIT + 1 });
        }
        Ok(TriangleInput { x: s.x, y: s.y, rect: s.rect, plane, index: s.index as u32, _pad: 0, coeffs })
    };
    let out_of_memory = |what| move |reason| Error::OutOfMemory { what, reason };
    // The kept triangles in scene order, then the hidden ones (the analysis takes them as a
    // set; they are cut off after it).
    let mut triangles: Vec<TriangleInput> = crate::zeroed_cells(kept + hidden).map_err(out_of_memory("the prepared triangles"))?;
    // Scene vertex indices of each, in the same orientation, for the overlap analysis.
    let mut corners: Vec<[u32; 3]> = if analyse { crate::zeroed_cells(kept + hidden).map_err(out_of_memory("the overlap analysis"))? } else { Vec::new() };
    let mut parts = Vec::with_capacity(chunks);
    let (kept_t, hidden_t) = triangles.split_at_mut(kept);
    let (kept_c, hidden_c) = corners.split_at_mut(if analyse { kept } else { 0 });
    let (mut rest_t, mut rest_c, mut rest_ht, mut rest_hc) = (kept_t, kept_c, hidden_t, hidden_c);
    for (c, chunk_counts) in counts.iter().enumerate() {
        let (n, h) = (chunk_counts.kept, hidden_of(chunk_counts));
        let (part_t, tail_t) = rest_t.split_at_mut(n);
        let (part_c, tail_c) = if analyse { rest_c.split_at_mut(n) } else { (&mut [][..], rest_c) };
        let (part_ht, tail_ht) = rest_ht.split_at_mut(h);
        let (part_hc, tail_hc) = rest_hc.split_at_mut(h);
        parts.push((c, part_t, part_c, part_ht, part_hc));
        (rest_t, rest_c, rest_ht, rest_hc) = (tail_t, tail_c, tail_ht, tail_hc);
    }
    let failures: Vec<Error> = parts
        .into_par_iter()
        .filter_map(|(c, part_t, part_c, part_ht, part_hc)| {
            let (mut k, mut h) = (0, 0);
            for t in chunk(c) {
                let wanted = fate[t] == Fate::Kept || (analyse && fate[t] == Fate::Hidden);
                if !wanted {
                    continue;
                }
                match (fate[t], snap(t, false)) {
                    (Fate::Kept, Snap::Kept(s)) => {
                        match input(&s) {
                            Ok(t) => part_t[k] = t,
                            Err(e) => return Some(e),
                        }
                        if analyse {
                            part_c[k] = s.corners.map(|c| c as u32);
                        }
                        k += 1;
                    }
                    // Only the analysis reads it: its snapped corners.
                    (Fate::Hidden, Snap::Kept(s)) if analyse => {
                        part_ht[h] = TriangleInput { x: s.x, y: s.y, rect: s.rect, index: s.index as u32, ..Default::default() };
                        part_hc[h] = s.corners.map(|c| c as u32);
                        h += 1;
                    }
                    (Fate::Kept | Fate::Hidden, _) => unreachable!("the first walk kept triangle {t}"),
                    _ => {}
                }
            }
            None
        })
        .collect();
    if let Some(first) = failures.into_iter().next() {
        return Err(first);
    }

    let rows = window.y0..window.y0 + window.height;
    let overlap_free = analyse && crate::overlap::overlap_free(&triangles, &corners, snap_bits, rows.clone());
    let overlap_free_rows = overlap_free.then_some(rows);
    triangles.truncate(kept);
    Ok(Prepared { params: *params, window, snap_bits, triangles, culled, degenerate, overlap_free_rows, render: None })
}

fn validate_scene(scene: &Scene) -> Result<(), Error> {
    if scene.vertices.is_empty() {
        return Err(Error::EmptyScene { what: "vertices" });
    }
    if scene.triangles.is_empty() {
        return Err(Error::EmptyScene { what: "triangles" });
    }
    for (vertex, v) in scene.vertices.iter().enumerate() {
        for (axis, value) in ['x', 'y', 'z'].into_iter().zip(*v) {
            if !value.is_finite() {
                return Err(Error::NonFiniteCoordinate { vertex, axis, value });
            }
        }
        if v[2].abs() > f32::MAX as f64 {
            return Err(Error::HeightOutOfRange { vertex, value: v[2] });
        }
    }
    let n = scene.vertices.len();
    for (triangle, tri) in scene.triangles.iter().enumerate() {
        for (corner, &index) in tri.iter().enumerate() {
            if index as usize >= n {
                return Err(Error::IndexOutOfRange { triangle, corner, index: index as u64, vertex_count: n });
            }
        }
    }
    Ok(())
}

/// Largest `s <= MAX_SNAP_BITS` with `(ceil(extent) + 2) << s < 2^EXTENT_LIMIT_BITS`
/// (one pixel of slack for snapping), or `None` if even `s = 1` does not fit.
/// The raster-space extent of the triangle with raster-space corners `p`, if it may reach a
/// pixel centre of `grid` (with [`CULL_MARGIN_PX`]).
///
/// A triangle whose bounding box reaches the grid may still pass beside it; one that large
/// ([`SEPARATION_MIN_PX`]) is tested against the grid's rectangle edge by edge, so that the
/// snapping lattice depends only on triangles that pass over the grid. (A block of a TIN,
/// `tileraster_tin::block`, holds every triangle that passes over its window, not every one
/// whose box does.)
fn reaching_extent(p: [[f64; 2]; 3], grid: &Grid) -> Option<f64> {
    let (w, h) = (grid.width as f64, grid.height as f64);
    let (umin, umax) = (p[0][0].min(p[1][0]).min(p[2][0]), p[0][0].max(p[1][0]).max(p[2][0]));
    let (vmin, vmax) = (p[0][1].min(p[1][1]).min(p[2][1]), p[0][1].max(p[1][1]).max(p[2][1]));
    let (lo, hi) = ([0.5 - CULL_MARGIN_PX; 2], [w - 0.5 + CULL_MARGIN_PX, h - 0.5 + CULL_MARGIN_PX]);
    let reaches_box = umax >= lo[0] && umin <= hi[0] && vmax >= lo[1] && vmin <= hi[1];
    let extent = (umax - umin).max(vmax - vmin);
    if !reaches_box {
        return None;
    }
    if extent < SEPARATION_MIN_PX {
        return Some(extent);
    }
    // Separated when all four corners of the rectangle lie strictly outside one edge.
    let cross = |a: [f64; 2], b: [f64; 2], c: [f64; 2]| (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    let turn = cross(p[0], p[1], p[2]).signum();
    let corners = [[lo[0], lo[1]], [hi[0], lo[1]], [hi[0], hi[1]], [lo[0], hi[1]]];
    let separated = (0..3).any(|k| corners.iter().all(|&c| turn * cross(p[k], p[(k + 1) % 3], c) < 0.0));
    (!separated).then_some(extent)
}

/// Triangles at least this wide (px) are tested edge by edge against the grid: far below the
/// extents that coarsen the lattice, far above the sizes whose test would cost.
const SEPARATION_MIN_PX: f64 = 1024.0;

/// The snapping lattice's bits for triangles whose [`reaching_extent`] is given: the finest on
/// which the widest one's edge functions fit (the first of that extent in scene order names
/// the error).
fn snap_bits_of(triangles: &[[u32; 3]], reaching_extent: impl Fn(&[u32; 3]) -> Option<f64> + Sync) -> Result<u32, Error> {
    // The largest extent, and the first triangle of that extent (triangle 0 if every extent
    // is zero) as a sequential scan finds it, whatever order the reduction pairs them in.
    let (max_extent, widest) = triangles
        .par_iter()
        .enumerate()
        .filter_map(|(t, tri)| reaching_extent(tri).map(|extent| (extent, t)))
        .reduce(|| (0.0, 0), |a, b| if b.0 > a.0 || (b.0 == a.0 && b.1 < a.1) { b } else { a });
    snap_bits_for(max_extent).ok_or(Error::TriangleTooLarge {
        triangle: widest,
        extent_px: max_extent,
        // ceil(extent) + 2 < 2^28 at one snap bit: extents up to 2^28 − 3 px.
        limit_px: (1u64 << (EXTENT_LIMIT_BITS - 1)) - 3,
    })
}

/// The snapping lattice's bits (`Raster::snap_bits`) that preparing `scene` on `grid` chooses,
/// without preparing it: blocks of one TIN (`tileraster --part`) check with it that their
/// lattice is the finest one, which every block then shares with the whole TIN.
pub fn snap_bits(scene: &Scene, grid: &Grid) -> Result<u32, Error> {
    grid.validate()?;
    validate_scene(scene)?;
    let raster: Vec<[f64; 2]> = scene.vertices.par_iter().map(|v| grid.to_raster(v[0], v[1]).into()).collect();
    snap_bits_of(&scene.triangles, |tri: &[u32; 3]| reaching_extent(tri.map(|k| raster[k as usize]), grid))
}

pub fn snap_bits_for(max_extent_px: f64) -> Option<u32> {
    let ext = max_extent_px.ceil() + 2.0;
    let limit = (1u64 << EXTENT_LIMIT_BITS) as f64;
    (1..=MAX_SNAP_BITS).rev().find(|&s| ext * ((1u64 << s) as f64) < limit)
}

/// Triangles one task of the per-triangle passes takes, in scene order.
const CHUNK: usize = 1 << 13;

/// What the first walk over the triangles found of each, for the second.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Fate {
    Kept,
    /// No area once snapped.
    Flat,
    /// Touches no pixel centre: only the overlap analysis sees it (its edges cancel its
    /// neighbours').
    Hidden,
    /// Culled, or no pixel centre in its snapped bounding box.
    Dropped,
}

/// What the first walk counts in one task's chunk of triangles.
#[derive(Default)]
struct ChunkCounts {
    kept: usize,
    /// Touching no centre: kept for the overlap analysis only, if it runs.
    hidden: usize,
    /// Pixels of the kept triangles' rectangles.
    pixels: u64,
}

/// What snapping makes of a scene triangle.
enum Snap {
    /// Culled: it cannot reach a pixel centre of the grid.
    Outside,
    /// No area once snapped.
    Flat,
    /// Its snapped bounding box holds no pixel centre of the grid.
    NoCentre,
    /// No pixel centre lies inside it or on its edges: it changes no pixel (see
    /// [`touches_no_centre`]).
    Hidden,
    Kept(Snapped),
}

/// Rectangles of at most this many pixels are searched for a centre the triangle touches.
const SMALL_RECT_PIXELS: i64 = 16;

/// Whether a small snapped triangle touches no pixel centre: the kernels' own coverage test
/// (`stages::fine::side`, on `stages::setup`'s edge functions) finds every centre of its
/// rectangle outside it, neither inside nor on an edge. Fine raster then never lets it change
/// a pixel, so no pass needs it. Many micro-triangles are such: of the quarter-pixel ones on a
/// 512² grid, 333,869 of the 596,013 whose rectangle holds a centre. Larger rectangles are not
/// searched (`false`: kept).
fn touches_no_centre(s: &Snapped, snap_bits: u32) -> bool {
    let r = &s.rect;
    if (r.i1 - r.i0 + 1) as i64 * (r.j1 - r.j0 + 1) as i64 > SMALL_RECT_PIXELS {
        return false;
    }
    let coverage = setup_triangle(&TriangleInput { x: s.x, y: s.y, rect: s.rect, ..Default::default() }, 0, snap_bits).coverage;
    (r.j0..=r.j1).all(|j| (r.i0..=r.i1).all(|i| side(&coverage, i, j) == Side::Outside))
}

/// `v.round() as i64` (half away from zero) without a call: `f64::round` is a libm call on
/// x86-64's baseline, and snapping rounds six coordinates per triangle. Below 2^52 the
/// truncation and `v − trunc(v)` are exact, so the two agree; beyond, `round` decides.
#[inline]
pub(crate) fn round_to_i64(v: f64) -> i64 {
    if v.abs() < (1u64 << 52) as f64 {
        let t = v as i64;
        let f = v - t as f64;
        t + i64::from(f >= 0.5) - i64::from(f <= -0.5)
    } else {
        v.round() as i64
    }
}

/// `2^k`, exactly (as `2f64.powi(k)`, without its call where `2^k` is a normal number).
#[inline]
fn pow2(k: i32) -> f64 {
    if (-1022..=1023).contains(&k) { f64::from_bits(((k + 1023) as u64) << 52) } else { 2f64.powi(k) }
}

struct Snapped {
    index: usize,
    /// Scene vertex indices, in the (possibly swapped) positive orientation.
    corners: [usize; 3],
    x: [i64; 3],
    y: [i64; 3],
    rect: PixelRect,
}

/// Grid pixels whose centres lie in the snapped bounding box (empty if none does).
pub(crate) fn pixel_rect(x: &[i64; 3], y: &[i64; 3], snap_bits: u32, grid: &Grid) -> PixelRect {
    tileraster_kernels::stages::assemble::pixel_rect(x, y, snap_bits, grid.width, grid.height)
}

/// The plane through the unsnapped vertices (or, where those are flat or flipped, through the
/// snapped ones), relative to the rectangle's corner pixel: in fixed point, and as
/// `(value, gi, gj)` in `f64`.
fn fit_plane(scene: &Scene, raster: &[[f64; 2]], s: &Snapped, snap_bits: u32) -> (Plane, [f64; 3]) {
    let z = s.corners.map(|c| scene.vertices[c][2]);
    let unsnapped = s.corners.map(|c| raster[c]);
    let unit = (1i64 << snap_bits) as f64;
    let snapped = [0, 1, 2].map(|k| [s.x[k] as f64 / unit, s.y[k] as f64 / unit]);
    let (ci, cj) = (s.rect.i0 as f64 + 0.5, s.rect.j0 as f64 + 0.5);
    let (zr, gi, gj) =
        plane_through(&unsnapped, &z, ci, cj).unwrap_or_else(|| plane_through(&snapped, &z, ci, cj).expect("snapped triangles have positive area"));
    (quantise_plane(zr, gi, gj, &s.rect), [zr, gi, gj])
}

/// The `f32` coefficients `mode` interpolates with (see `FloatCoeffs`).
fn float_coeffs(mode: Mode, scene: &Scene, s: &Snapped, plane: [f64; 3]) -> FloatCoeffs {
    let c = match mode {
        Mode::Exact => [0.0; 4],
        Mode::PlaneF32 => [plane[0] as f32, plane[1] as f32, plane[2] as f32, 0.0],
        Mode::Barycentric => {
            // Edge k runs from vertex k to k+1; its weight belongs to the vertex opposite.
            let z = |k: usize| scene.vertices[s.corners[k]][2] as f32;
            let (x, y) = (&s.x, &s.y);
            // Σw is twice the snapped area in lattice units² at every pixel.
            let area2 = (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
            [z(2), z(0), z(1), (1.0 / area2 as f64) as f32]
        }
    };
    FloatCoeffs { c }
}

/// The `f32` modes' partial sums must stay below `2^127`: then no rounding step can carry a
/// value past `f32::MAX` (`≈ 2^128`), so every covered cell is finite.
const FLOAT_REACH_LIMIT: f64 = 1.7014118346046923e38; // 2^127

/// `plane-f32` converts pixel offsets from the triangle's corner pixel to `f32`; up to `2^24`
/// that is exact on every device (Vulkan leaves the rounding of larger ones open).
const FLOAT_OFFSET_LIMIT: u64 = 1 << 24;

/// The largest magnitude `mode`'s `f32` arithmetic meets over `rect` before rounding: `S`
/// for `plane-f32` (`|z| + |gi|·Δi + |gj|·Δj`, with the rounded coefficients), the largest
/// `|h|` for `barycentric` (its weights lie in `[0, 1]` on covered pixels); zero in exact mode.
fn float_reach(mode: Mode, coeffs: &FloatCoeffs, rect: &PixelRect) -> f64 {
    let c = coeffs.c.map(f64::from);
    match mode {
        Mode::Exact => 0.0,
        // A coefficient beyond f32 (infinite) is out of range even where it multiplies zero.
        _ if c.iter().any(|v| !v.is_finite()) => f64::INFINITY,
        Mode::PlaneF32 => {
            let (w, h) = ((rect.i1 - rect.i0).max(0) as f64, (rect.j1 - rect.j0).max(0) as f64);
            c[0].abs() + c[1].abs() * w + c[2].abs() * h
        }
        Mode::Barycentric => c[0].abs().max(c[1].abs()).max(c[2].abs()),
    }
}

/// Value at `(ci, cj)` and per-pixel gradients of the plane through three raster-space points,
/// if they are positively oriented (as the snapped triangle is) and the result is finite.
fn plane_through(p: &[[f64; 2]; 3], z: &[f64; 3], ci: f64, cj: f64) -> Option<(f64, f64, f64)> {
    let (au, av, az) = (p[1][0] - p[0][0], p[1][1] - p[0][1], z[1] - z[0]);
    let (bu, bv, bz) = (p[2][0] - p[0][0], p[2][1] - p[0][1], z[2] - z[0]);
    let det = au * bv - av * bu;
    if det.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
        return None;
    }
    let gi = (az * bv - av * bz) / det;
    let gj = (au * bz - az * bu) / det;
    let zr = z[0] + gi * (ci - p[0][0]) + gj * (cj - p[0][1]);
    [zr, gi, gj].iter().all(|v| v.is_finite()).then_some((zr, gi, gj))
}

/// Fixed point with the most fraction bits for which `|z| + |gi|·w + |gj|·h < 2^61`, so the
/// kernels' `z + gi·di + gj·dj` cannot overflow anywhere in the rectangle.
fn quantise_plane(zr: f64, gi: f64, gj: f64, rect: &PixelRect) -> Plane {
    let bound = zr.abs() + gi.abs() * (rect.i1 - rect.i0) as f64 + gj.abs() * (rect.j1 - rect.j0) as f64;
    let frac_bits = if bound == 0.0 {
        0
    } else {
        // bound < 2^(e+1) with e = floor(log2(bound)), read from the bits (exact).
        let e = ((bound.to_bits() >> 52) & 0x7ff) as i32 - 1023;
        (60 - e).min(200)
    };
    let scale = |v: f64| {
        // v · 2^frac_bits in two exact steps (2^frac_bits alone may overflow f64).
        let half = frac_bits / 2;
        round_to_i64(v * pow2(half) * pow2(frac_bits - half))
    };
    Plane { z: scale(zr), gi: scale(gi), gj: scale(gj), frac_bits, _pad: 0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_kernels::math::fixed::fixed_to_f32_bits;

    /// `prepare` on a pool of `threads` threads.
    fn prepare_on(threads: usize, scene: &Scene, params: &Params) -> Result<Prepared, Error> {
        rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap().install(|| prepare(scene, params, None))
    }

    /// Preparation runs its per-triangle passes in parallel, in chunks, and splits the overlap
    /// analysis by vertex ranges, one per thread: none of it may show in the result, nor in
    /// which triangle an error names.
    #[test]
    fn preparation_does_not_depend_on_the_number_of_threads() {
        let grid = Grid::new(0.0, 64.0, 0.0, 64.0, 64, 64);
        let (micro, micro_grid) = crate::scenes::micro_triangles(64, 0.25, 7);
        assert!(micro.triangles.len() > 2 * CHUNK, "several chunks");
        let cases =
            [(micro, micro_grid), (crate::scenes::terrain(0.0, 0.0, 64.0, 64.0, 40, 40, 5), grid), (crate::scenes::triangle_soup(&grid, 3000, 6.0, 9), grid)];
        for (scene, grid) in &cases {
            for mode in Mode::ALL {
                let params = Params::new(*grid).with_mode(mode);
                let one = prepare_on(1, scene, &params).unwrap();
                for threads in [2, 3, 8] {
                    let many = prepare_on(threads, scene, &params).unwrap();
                    assert_eq!(one.triangles, many.triangles, "{threads} threads, {mode:?}");
                    let facts = |p: &Prepared| (p.snap_bits, p.culled, p.degenerate, p.overlap_free_rows.clone());
                    assert_eq!(facts(&one), facts(&many), "{threads} threads, {mode:?}");
                }
            }
        }
        // Several triangles out of plane-f32's range, in different chunks: the first is named.
        let (mut scene, grid) = crate::scenes::micro_triangles(64, 0.25, 7);
        for t in [2 * CHUNK + 5, CHUNK + 400, 2 * CHUNK - 3] {
            let v = scene.triangles[t][0] as usize;
            scene.vertices[v][2] = 3e38;
        }
        // The first kept triangle (the exact mode takes any height) on a raised vertex.
        let kept = prepare(&scene, &Params::new(grid), None).unwrap().triangles;
        let first = kept.iter().map(|t| t.index as usize).find(|&t| scene.triangles[t].iter().any(|&v| scene.vertices[v as usize][2] == 3e38)).unwrap();
        assert!(first > CHUNK, "the failures lie beyond the first chunk");
        let params = Params::new(grid).with_mode(Mode::PlaneF32);
        for threads in [1, 2, 8] {
            match prepare_on(threads, &scene, &params) {
                Err(Error::OutsideModeRange { triangle, .. }) => assert_eq!(triangle, first, "{threads} threads"),
                other => panic!("{threads} threads: {other:?}"),
            }
        }
    }

    /// The call-free rounding and powers of two are `f64::round` and `powi`, bit for bit.
    #[test]
    fn round_to_i64_and_pow2_are_round_and_powi() {
        let mut v = 0.5f64;
        let mut specials = vec![0.0, -0.0, 0.5, -0.5, 1.5, -1.5, 2.5, -2.5, 0.49999999999999994, -0.49999999999999994, f64::NAN, 1e300, -1e300];
        specials.extend([(1u64 << 52) as f64 - 0.5, (1u64 << 52) as f64 + 1.0, -((1u64 << 52) as f64) + 0.5, 4503599627370495.5]);
        for _ in 0..2000 {
            v = v * 1.75 + 0.123_456_789;
            if v > 1e17 {
                v /= 3.0e16;
            }
            specials.extend([v, -v, v.floor() + 0.5, -(v.floor() + 0.5)]);
        }
        for x in specials {
            assert_eq!(round_to_i64(x), x.round() as i64, "{x:e}");
        }
        for k in -1100..=1100 {
            assert_eq!(pow2(k).to_bits(), 2f64.powi(k).to_bits(), "2^{k}");
        }
    }

    #[test]
    fn snapping_is_finest_unless_a_triangle_is_huge() {
        assert_eq!(snap_bits_for(0.0), Some(16));
        assert_eq!(snap_bits_for(8189.0), Some(16));
        assert_eq!(snap_bits_for(8190.0), Some(15));
        assert_eq!(snap_bits_for(65_000.0), Some(13));
        assert_eq!(snap_bits_for(((1u64 << 28) - 3) as f64), Some(1));
        assert_eq!(snap_bits_for(((1u64 << 28) - 2) as f64), None);
    }

    #[test]
    fn pixel_rect_takes_centres_inside_the_box_and_clips_to_the_grid() {
        let grid = Grid::new(0.0, 10.0, 0.0, 10.0, 10, 10);
        let s = 4; // 16 units per pixel, centres at 8 + 16·i
        let r = pixel_rect(&[8, 40, 8], &[8, 8, 41], s, &grid);
        assert_eq!(r, PixelRect { i0: 0, j0: 0, i1: 2, j1: 2 });
        let r = pixel_rect(&[9, 39, 9], &[9, 9, 39], s, &grid);
        assert_eq!(r, PixelRect { i0: 1, j0: 1, i1: 1, j1: 1 });
        let r = pixel_rect(&[-1000, 1000, 0], &[-5, -5, 5000], s, &grid);
        assert_eq!(r, PixelRect { i0: 0, j0: 0, i1: 9, j1: 9 });
        assert!(pixel_rect(&[200, 300, 250], &[0, 0, 50], s, &grid).is_empty());
    }

    #[test]
    fn plane_is_exact_at_its_reference_and_bounded_everywhere() {
        let rect = PixelRect { i0: 3, j0: 4, i1: 1000, j1: 700 };
        let (zr, gi, gj) = (1_234.567_891_234, -0.731_234_567, 2.5e-3);
        let plane = quantise_plane(zr, gi, gj, &rect);
        assert!(plane.frac_bits > 40);
        let at = |di: i64, dj: i64| plane.z + plane.gi * di + plane.gj * dj;
        assert_eq!(f32::from_bits(fixed_to_f32_bits(at(0, 0), plane.frac_bits)), zr as f32);
        let far = at(997, 696) as f64 * 2f64.powi(-plane.frac_bits);
        assert!((far - (zr + gi * 997.0 + gj * 696.0)).abs() < 1e-9);
        assert!(at(997, 696).unsigned_abs() < 1 << 61);
    }

    #[test]
    fn culls_outside_drops_flat_and_orients_positively() {
        let grid = Grid::new(0.0, 4.0, 0.0, 4.0, 4, 4);
        let scene = Scene::new(
            vec![[1.0, 1.0, 0.0], [3.0, 1.0, 0.0], [1.0, 3.0, 0.0], [2.0, 2.0, 0.0], [50.0, 50.0, 0.0], [51.0, 50.0, 0.0], [50.0, 51.0, 0.0]],
            vec![[0, 1, 2], [0, 2, 1], [0, 3, 0], [4, 5, 6], [0, 3, 1]],
        );
        let p = prepare(&scene, &Params::new(grid), None).unwrap();
        assert_eq!(p.triangles.iter().map(|t| t.index).collect::<Vec<_>>(), vec![0, 1, 4]);
        assert_eq!((p.culled, p.degenerate), (1, 1));
        for t in &p.triangles {
            let area = (t.x[1] - t.x[0]) as i128 * (t.y[2] - t.y[0]) as i128 - (t.y[1] - t.y[0]) as i128 * (t.x[2] - t.x[0]) as i128;
            assert!(area > 0);
        }
    }

    #[test]
    fn float_modes_refuse_planes_their_f32_arithmetic_would_overflow() {
        let grid = Grid::new(0.0, 8.0, 0.0, 8.0, 8, 8);
        let near_max = f32::MAX as f64 * 0.75; // within the raster's range, beyond 2^127
        let scene = |z: f64| Scene::new(vec![[0.0, 0.0, 1.0], [8.0, 0.0, z], [0.0, 8.0, 1.0]], vec![[0, 1, 2]]);
        for mode in Mode::ALL {
            let params = Params::new(grid).with_mode(mode);
            assert!(prepare(&scene(1e38), &params, None).is_ok(), "{mode:?}");
            match prepare(&scene(near_max), &params, None) {
                Ok(_) => assert_eq!(mode, Mode::Exact),
                Err(Error::OutsideModeRange { triangle: 0, mode: name, reach }) => {
                    assert_eq!(name, mode.name());
                    assert!(reach >= FLOAT_REACH_LIMIT, "{reach:e}");
                }
                Err(e) => panic!("{mode:?}: {e}"),
            }
        }
        // A plane that stays in range at the vertices but not at the rectangle's corner pixel,
        // where plane-f32 starts: a steep sliver.
        let sliver = Scene::new(vec![[0.0, 0.0, 0.0], [8.0, 8.0, 0.0], [0.0, 0.01, 1e36]], vec![[0, 1, 2]]);
        assert!(prepare(&sliver, &Params::new(grid), None).is_ok());
        let err = prepare(&sliver, &Params::new(grid).with_mode(Mode::PlaneF32), None).unwrap_err();
        assert!(matches!(err, Error::OutsideModeRange { .. }), "{err}");
        assert!(err.to_string().contains("use the exact mode"), "{err}");
    }
}
