//! `tileraster._native`: the library for Python. numpy arrays in (copied once into the
//! scene), numpy arrays out (the library's buffers handed over, not copied), the library's
//! errors as `TilerasterError` with the same messages, and every long call interruptible
//! by Ctrl-C. `tileraster/__init__.py` normalises arguments and documents the API.

use numpy::ndarray::Array2;
use numpy::{IntoPyArray, PyArray2, PyArrayMethods, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyList, PyTuple};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, RecvTimeoutError};
use std::sync::{Arc, Mutex};
use std::time::Duration;
use tileraster::dem::{self, GridSize, GridSpec};
use tileraster::{Backend, Mode, Outputs, Params, PreparedScene, Raster as RustRaster, Scene as RustScene, Stats, Window};
use tileraster_io::{GeoTiffOptions, GeoTiffWriter, Sample};

mod render;

create_exception!(tileraster, TilerasterError, PyValueError, "What tileraster refused, with what was wrong and how to fix it.");

pub(crate) fn error(e: impl std::fmt::Display) -> PyErr {
    TilerasterError::new_err(e.to_string())
}

/// A grid as gdal_grid's flags give it (see `tileraster.Grid`).
#[pyclass(frozen, module = "tileraster._native")]
#[derive(Clone)]
struct Grid {
    spec: GridSpec,
}

#[pymethods]
impl Grid {
    #[new]
    #[pyo3(signature = (*, txe = None, tye = None, outsize = None, tr = None, tap = false))]
    fn new(txe: Option<(f64, f64)>, tye: Option<(f64, f64)>, outsize: Option<(u32, u32)>, tr: Option<(f64, f64)>, tap: bool) -> PyResult<Grid> {
        let size = match (outsize, tr) {
            (Some((width, height)), None) => GridSize::Cells { width, height },
            (None, Some((x, y))) => GridSize::Resolution { x, y },
            _ => {
                return Err(error("give the raster size as outsize=(width, height) or the cell size as tr=(xres, yres), one of them"));
            }
        };
        let spec = GridSpec { txe: txe.map(|(a, b)| [a, b]), tye: tye.map(|(a, b)| [a, b]), size, tap };
        spec.check().map_err(error)?;
        Ok(Grid { spec })
    }

    fn __repr__(&self) -> String {
        format!("tileraster.Grid({:?})", self.spec)
    }

    /// Whether the grid's extent is given (`txe` and `tye`), not taken from the points.
    #[getter]
    fn extent_given(&self) -> bool {
        self.spec.txe.is_some() && self.spec.tye.is_some()
    }

    /// The grid over points whose x and y span `bounds` (west, south, east, north), as
    /// `Raster.grid` gives it: (xmin, xmax, ymin, ymax, width, height). `bounds` may be
    /// `None` when the extent is given.
    #[pyo3(signature = (bounds = None))]
    fn resolve(&self, bounds: Option<(f64, f64, f64, f64)>) -> PyResult<GridTuple> {
        let corners = bounds.map_or(Vec::new(), |(x0, y0, x1, y1)| vec![[x0, y0, 0.0], [x1, y1, 0.0]]);
        let g = self.spec.grid_for(&corners).map_err(error)?;
        Ok((g.xmin, g.xmax, g.ymin, g.ymax, g.width, g.height))
    }
}

/// A triangle mesh: vertices (x, y, z) and triangles (three vertex indices each).
#[pyclass(frozen, module = "tileraster._native")]
struct Scene {
    scene: Arc<RustScene>,
}

#[pymethods]
impl Scene {
    #[new]
    fn new(vertices: &Bound<'_, PyAny>, triangles: &Bound<'_, PyAny>) -> PyResult<Scene> {
        Ok(Scene { scene: Arc::new(RustScene::new(vertices_of(vertices, "vertices")?, triangles_of(triangles)?)) })
    }

    /// The Delaunay TIN of points (x, y, z); of points with equal x, y the first is kept.
    #[staticmethod]
    fn from_points(py: Python<'_>, points: &Bound<'_, PyAny>) -> PyResult<Scene> {
        let points = vertices_of(points, "points")?;
        let tin = interruptible(py, move |_| tileraster_tin::triangulate(&points))?.map_err(error)?;
        Ok(Scene { scene: Arc::new(tin.scene) })
    }

    #[getter]
    fn vertices<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<f64>> {
        rows(self.scene.vertices.iter().flatten().copied().collect(), 3).into_pyarray(py)
    }

    #[getter]
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray2<u32>> {
        rows(self.scene.triangles.iter().flatten().copied().collect(), 3).into_pyarray(py)
    }

    /// This mesh without the triangles that have an edge longer than `max_edge` in x and y.
    fn without_long_edges(&self, max_edge: f64) -> PyResult<Scene> {
        if !(max_edge.is_finite() && max_edge > 0.0) {
            return Err(error(dem::DemError::MaxEdge(max_edge)));
        }
        let mut scene = (*self.scene).clone();
        dem::drop_long_triangles(&mut scene, max_edge);
        Ok(Scene { scene: Arc::new(scene) })
    }

    fn __len__(&self) -> usize {
        self.scene.triangles.len()
    }

    fn __repr__(&self) -> String {
        format!("tileraster.Scene({} vertices, {} triangles)", self.scene.vertices.len(), self.scene.triangles.len())
    }
}

fn rows<T>(flat: Vec<T>, width: usize) -> Array2<T> {
    let height = flat.len() / width.max(1);
    Array2::from_shape_vec((height, width), flat).expect("whole rows")
}

/// `value` (any array-like) as a C-ordered (N, 3) numpy array of `dtype`, checked: no copy
/// when it already is one. Integer `dtype`s take integer arrays only: a float array of indices
/// is refused rather than truncated.
fn rows_of_three<'py>(value: &Bound<'py, PyAny>, what: &str, dtype: &str) -> PyResult<Bound<'py, PyAny>> {
    let numpy = value.py().import("numpy")?;
    let array = numpy.call_method1("asarray", (value,))?;
    let shape: Vec<usize> = array.getattr("shape")?.extract()?;
    if shape.len() != 2 || shape[1] != 3 {
        return Err(error(format!("{what} has shape {}; give an (N, 3) array", array.getattr("shape")?.repr()?)));
    }
    let kind: String = array.getattr("dtype")?.getattr("kind")?.extract()?;
    let size: usize = array.getattr("size")?.extract()?;
    if dtype == "int64" && size > 0 && !matches!(kind.as_str(), "i" | "u") {
        return Err(error(format!("{what} has dtype {}; give integer vertex indices", array.getattr("dtype")?.str()?)));
    }
    if dtype == "float64" && !matches!(kind.as_str(), "f" | "i" | "u") {
        return Err(error(format!("{what} has dtype {}; give numbers", array.getattr("dtype")?.str()?)));
    }
    numpy.call_method1("ascontiguousarray", (array, dtype))
}

pub(crate) fn vertices_of(value: &Bound<'_, PyAny>, what: &str) -> PyResult<Vec<[f64; 3]>> {
    let array = rows_of_three(value, what, "float64")?;
    let array: PyReadonlyArray2<'_, f64> = array.extract()?;
    Ok(array.as_slice().map_err(error)?.as_chunks::<3>().0.to_vec())
}

pub(crate) fn triangles_of(value: &Bound<'_, PyAny>) -> PyResult<Vec<[u32; 3]>> {
    let array = rows_of_three(value, "triangles", "int64")?;
    let array: PyReadonlyArray2<'_, i64> = array.extract()?;
    let flat = array.as_slice().map_err(error)?;
    let index = |k: usize| {
        u32::try_from(flat[k]).map_err(|_| error(format!("triangle {} has vertex index {}; indices are 0-based and at most {}", k / 3, flat[k], u32::MAX)))
    };
    (0..flat.len() / 3).map(|t| Ok([index(3 * t)?, index(3 * t + 1)?, index(3 * t + 2)?])).collect()
}

/// How a call runs: its backend (`None`: `auto`, chosen once the raster's size is known) and
/// the `Params` beyond the grid.
struct Settings {
    backend: Option<Backend>,
    mode: Mode,
    nodata: f32,
    owner: bool,
}

impl Settings {
    fn new(backend: &str, mode: &str, nodata: f32, owner: bool) -> PyResult<Settings> {
        let backend = match backend {
            "cpu" => Some(Backend::Cpu),
            "gpu" => Some(Backend::Gpu),
            "auto" => None,
            other => {
                return Err(error(format!("backend '{other}': give \"cpu\", \"gpu\" or \"auto\"")));
            }
        };
        Ok(Settings { backend, mode: mode.parse().map_err(error)?, nodata, owner })
    }

    /// The backend for a raster of `grid` (its `window`): `auto` decides without opening a
    /// device (`tileraster::choose_backend`).
    fn backend_for(&self, grid: &tileraster::Grid, window: Option<Window>) -> Backend {
        let window = window.unwrap_or_else(|| Window::whole(grid));
        self.backend.unwrap_or_else(|| tileraster::choose_backend(window.width as u64 * window.height as u64).backend)
    }

    fn params(&self, grid: tileraster::Grid) -> Params {
        Params::new(grid).with_nodata(self.nodata).with_mode(self.mode).with_outputs(Outputs { owner: self.owner, coverage: false, tiles: false })
    }
}

fn window_of(window: Option<(u32, u32, u32, u32)>) -> Option<Window> {
    window.map(|(x0, y0, width, height)| Window { x0, y0, width, height })
}

/// Run `work` on a thread of its own while this one waits without the GIL and checks for
/// signals: Ctrl-C raises `KeyboardInterrupt` at once and sets the flag `work` is given,
/// which banded work checks between bands to stop.
pub(crate) fn interruptible<T: Send + 'static>(py: Python<'_>, work: impl FnOnce(&AtomicBool) -> T + Send + 'static) -> PyResult<T> {
    let cancel = Arc::new(AtomicBool::new(false));
    let flag = cancel.clone();
    let (send, mut receive) = mpsc::channel();
    std::thread::Builder::new()
        .name("tileraster".into())
        .spawn(move || {
            let _ = send.send(work(&flag));
        })
        .map_err(error)?;
    loop {
        let (received, back) = py.detach(move || (receive.recv_timeout(Duration::from_millis(50)), receive));
        receive = back;
        match received {
            Ok(result) => return Ok(result),
            Err(RecvTimeoutError::Timeout) => {
                if let Err(interrupt) = py.check_signals() {
                    cancel.store(true, Ordering::Relaxed);
                    return Err(interrupt);
                }
            }
            Err(RecvTimeoutError::Disconnected) => {
                return Err(error("the rasterising thread stopped without a result (a panic: please report it)"));
            }
        }
    }
}

/// Cells a call rasterises at once: larger windows run in bands of rows, so that Ctrl-C
/// stops them between bands. Every band's cells are the whole window's there.
const BAND_CELLS: u64 = 1 << 24;

/// Rasterise `window` of a prepared scene in bands, stopping when `cancel` is set.
fn rasterise_banded(prepared: &mut PreparedScene, window: Window, cancel: &AtomicBool) -> Result<Option<(RustRaster, Vec<Stats>)>, tileraster::Error> {
    let band_rows = dem::band_rows(&window, 1, BAND_CELLS);
    if band_rows >= window.height {
        let raster = prepared.rasterise_window(window)?;
        let stats = vec![raster.stats.clone()];
        return Ok(Some((raster, stats)));
    }
    let mut whole: Option<RustRaster> = None;
    let mut stats = Vec::new();
    for y in (0..window.height).step_by(band_rows as usize) {
        if cancel.load(Ordering::Relaxed) {
            return Ok(None);
        }
        let band = prepared.rasterise_window(Window { y0: window.y0 + y, height: band_rows.min(window.height - y), ..window })?;
        stats.push(band.stats.clone());
        match &mut whole {
            None => {
                // The whole window's layers, allocated once.
                let cells = window.pixel_count() as usize;
                let mut values = Vec::with_capacity(cells);
                values.extend_from_slice(&band.values);
                let owner = band.owner.as_ref().map(|part| {
                    let mut owner = Vec::with_capacity(cells);
                    owner.extend_from_slice(part);
                    owner
                });
                whole = Some(RustRaster { window, values, owner, ..band });
            }
            Some(raster) => {
                raster.values.extend_from_slice(&band.values);
                if let (Some(all), Some(part)) = (&mut raster.owner, &band.owner) {
                    all.extend_from_slice(part);
                }
            }
        }
    }
    Ok(whole.map(|raster| (raster, stats)))
}

/// A rasterised window: heights (and owner triangles) as numpy arrays, with its
/// georeferencing (see `tileraster.Raster`).
#[pyclass(frozen, module = "tileraster._native")]
struct Raster {
    #[pyo3(get)]
    values: Py<PyArray2<f32>>,
    #[pyo3(get)]
    owner: Option<Py<PyArray2<u32>>>,
    #[pyo3(get)]
    nodata: f32,
    /// What the call did and skipped: one dict per band it ran in.
    bands: Py<PyList>,
    grid: tileraster::Grid,
    window: Window,
    /// For a block's raster, how its TIN was made.
    block: Option<dem::BlockRead>,
}

impl Raster {
    fn new(py: Python<'_>, raster: RustRaster, stats: &[Stats]) -> PyResult<Raster> {
        let width = raster.window.width as usize;
        let bands = PyList::empty(py);
        for band in stats {
            bands.append(stats_dict(py, band)?)?;
        }
        Ok(Raster {
            values: rows(raster.values, width).into_pyarray(py).unbind(),
            owner: raster.owner.map(|owner| rows(owner, width).into_pyarray(py).unbind()),
            nodata: raster.nodata,
            bands: bands.unbind(),
            grid: raster.grid,
            window: raster.window,
            block: None,
        })
    }

    /// The window's west and north edges and its cell size.
    fn corner(&self) -> (f64, f64, f64, f64) {
        let (dx, dy) = (self.grid.dx(), self.grid.dy());
        (self.grid.xmin + self.window.x0 as f64 * dx, self.grid.ymax - self.window.y0 as f64 * dy, dx, dy)
    }
}

/// A grid as Python sees it: (xmin, xmax, ymin, ymax, width, height).
type GridTuple = (f64, f64, f64, f64, u32, u32);

fn stats_dict<'py>(py: Python<'py>, stats: &Stats) -> PyResult<Bound<'py, PyDict>> {
    let dict = PyDict::new(py);
    dict.set_item("tiles_total", stats.tiles_total)?;
    dict.set_item("tiles_empty_skipped", stats.tiles_empty_skipped)?;
    dict.set_item("tiles_full", stats.tiles_full)?;
    dict.set_item("tiles_partial", stats.tiles_partial)?;
    dict.set_item("triangles_culled", stats.triangles_culled)?;
    dict.set_item("triangles_flat", stats.triangles_flat)?;
    dict.set_item("triangles_binned", stats.triangles_binned)?;
    dict.set_item("triangles_small", stats.triangles_small)?;
    dict.set_item("triangles_hidden", stats.triangles_hidden)?;
    dict.set_item("overlap_free", stats.overlap_free)?;
    dict.set_item("passes", stats.passes.iter().map(|p| p.name()).collect::<Vec<_>>())?;
    dict.set_item("bytes_uploaded", stats.bytes_uploaded)?;
    Ok(dict)
}

#[pymethods]
impl Raster {
    /// rasterio's affine transform, as (a, b, c, d, e, f): `Affine(*raster.transform)`.
    #[getter]
    fn transform(&self) -> (f64, f64, f64, f64, f64, f64) {
        let (west, north, dx, dy) = self.corner();
        (dx, 0.0, west, 0.0, -dy, north)
    }

    /// What the call did and skipped, one dict per band it ran in (a copy).
    #[getter]
    fn bands<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyTuple>> {
        let copies: Vec<Bound<'py, PyDict>> = self.bands.bind(py).iter().map(|band| band.cast_into::<PyDict>()?.copy()).collect::<PyResult<_>>()?;
        PyTuple::new(py, copies)
    }

    /// What the call did and skipped, as the command line's `--stats` prints it; for a call
    /// run in several bands (see `bands`), their counts added up, `passes` the first band's,
    /// and `"bands"` their number.
    #[getter]
    fn stats<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let bands = self.bands.bind(py);
        let first = bands.get_item(0)?.cast_into::<PyDict>()?.copy()?;
        if bands.len() > 1 {
            for key in [
                "tiles_total",
                "tiles_empty_skipped",
                "tiles_full",
                "tiles_partial",
                "triangles_culled",
                "triangles_flat",
                "triangles_binned",
                "triangles_small",
                "triangles_hidden",
                "bytes_uploaded",
            ] {
                let mut total = 0u64;
                for band in bands.iter() {
                    total += band.get_item(key)?.extract::<u64>()?;
                }
                first.set_item(key, total)?;
            }
            let mut overlap_free = true;
            for band in bands.iter() {
                overlap_free &= band.get_item("overlap_free")?.extract::<bool>()?;
            }
            first.set_item("overlap_free", overlap_free)?;
        }
        first.set_item("bands", bands.len())?;
        Ok(first)
    }

    /// For a block of a larger DEM (`tileraster.dask`), how its TIN was made: the points
    /// triangulated, the files read, the points decoded from them (a COPC file's nodes), the
    /// regions tried, the widest buffer beyond the window
    /// and the width of the bands along the hull's edges (map units); `None` for other rasters.
    #[getter]
    fn block<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyDict>>> {
        let Some(block) = self.block else { return Ok(None) };
        let dict = PyDict::new(py);
        dict.set_item("points", block.points)?;
        dict.set_item("files_read", block.files_read)?;
        dict.set_item("points_decoded", block.points_decoded)?;
        dict.set_item("discs", block.discs)?;
        dict.set_item("attempts", block.attempts)?;
        dict.set_item("buffer", block.buffer)?;
        dict.set_item("band", block.band)?;
        Ok(Some(dict))
    }

    /// GDAL's geotransform: (west, dx, 0, north, 0, -dy).
    #[getter]
    fn geotransform(&self) -> (f64, f64, f64, f64, f64, f64) {
        let (west, north, dx, dy) = self.corner();
        (west, dx, 0.0, north, 0.0, -dy)
    }

    /// (west, south, east, north), as rasterio's bounds.
    #[getter]
    fn bounds(&self) -> (f64, f64, f64, f64) {
        let (west, north, dx, dy) = self.corner();
        (west, north - self.window.height as f64 * dy, west + self.window.width as f64 * dx, north)
    }

    /// The grid's (xmin, xmax, ymin, ymax, width, height), and the window's (x0, y0, width, height) in it.
    #[getter]
    fn grid(&self) -> (GridTuple, (u32, u32, u32, u32)) {
        let (g, w) = (&self.grid, &self.window);
        ((g.xmin, g.xmax, g.ymin, g.ymax, g.width, g.height), (w.x0, w.y0, w.width, w.height))
    }

    /// Write the heights (or the owner triangles, `owner=True`) as the command line writes
    /// them: a GeoTIFF with gdal_grid's georeferencing and nodata tag. `epsg` sets the CRS;
    /// `creation_options` are the command line's `--co` (TILED=YES, COMPRESS=DEFLATE, ...).
    #[pyo3(signature = (path, *, epsg = None, creation_options = Vec::new(), owner = false))]
    fn write(&self, py: Python<'_>, path: PathBuf, epsg: Option<u16>, creation_options: Vec<String>, owner: bool) -> PyResult<()> {
        let mut options = GeoTiffOptions { epsg, ..Default::default() };
        for option in &creation_options {
            options.apply(option).map_err(error)?;
        }
        // Compressing and syncing take a while: without the GIL.
        let (grid, window) = (self.grid, self.window);
        match (owner, &self.owner) {
            (false, _) => {
                let values = self.values.bind(py).readonly();
                let cells = values.as_slice().map_err(error)?;
                py.detach(|| write_layer(&path, grid, window, Sample::Float32 { nodata: self.nodata }, &options, cells))
            }
            (true, Some(layer)) => {
                let layer = layer.bind(py).readonly();
                let cells = layer.as_slice().map_err(error)?;
                py.detach(|| write_layer(&path, grid, window, Sample::UInt32, &options, cells))
            }
            (true, None) => Err(error("this raster has no owner layer: rasterise with owner=True")),
        }
    }

    fn __repr__(&self) -> String {
        let (west, south, east, north) = self.bounds();
        format!("tileraster.Raster({}×{} cells, x {west} to {east}, y {south} to {north})", self.window.width, self.window.height)
    }
}

fn write_layer<T: bytemuck::Pod>(
    path: &std::path::Path,
    grid: tileraster::Grid,
    window: Window,
    sample: Sample,
    options: &GeoTiffOptions,
    cells: &[T],
) -> PyResult<()> {
    let mut file = GeoTiffWriter::create(path, &grid, window, sample, options).map_err(error)?;
    file.write_rows(cells).map_err(error)?;
    file.finish().map_err(error)
}

/// A scene prepared for a grid once, to rasterise many windows of it.
#[pyclass(frozen, module = "tileraster._native")]
struct Prepared {
    inner: Arc<Mutex<PreparedScene>>,
}

#[pymethods]
impl Prepared {
    #[new]
    #[pyo3(signature = (scene, grid, *, backend = "auto", mode = "exact", nodata = -9999.0, owner = false))]
    fn new(py: Python<'_>, scene: &Scene, grid: &Grid, backend: &str, mode: &str, nodata: f32, owner: bool) -> PyResult<Prepared> {
        let settings = Settings::new(backend, mode, nodata, owner)?;
        let (scene, spec) = (scene.scene.clone(), grid.spec);
        let prepared = interruptible(py, move |_| -> PyResult<PreparedScene> {
            let grid = spec.grid_for(&scene.vertices).map_err(error)?;
            PreparedScene::new(&scene, &settings.params(grid), settings.backend_for(&grid, None)).map_err(error)
        })??;
        Ok(Prepared { inner: Arc::new(Mutex::new(prepared)) })
    }

    /// Rasterise a window (x0, y0, width, height) of the grid, or the whole grid.
    #[pyo3(signature = (window = None))]
    fn rasterise(&self, py: Python<'_>, window: Option<(u32, u32, u32, u32)>) -> PyResult<Raster> {
        let inner = self.inner.clone();
        let window = window_of(window);
        let done = interruptible(py, move |cancel| {
            let mut prepared = inner.lock().unwrap_or_else(|e| e.into_inner());
            let window = window.unwrap_or(prepared.prepared().window);
            rasterise_banded(&mut prepared, window, cancel)
        })?;
        let (raster, stats) = done.map_err(error)?.ok_or_else(|| error("interrupted"))?;
        Raster::new(py, raster, &stats)
    }

    /// The grid it was prepared for, as `Raster.grid` gives it.
    #[getter]
    fn grid(&self) -> GridTuple {
        let g = self.inner.lock().unwrap_or_else(|e| e.into_inner()).prepared().params.grid;
        (g.xmin, g.xmax, g.ymin, g.ymax, g.width, g.height)
    }
}

/// Rasterise `scene` onto `grid` (its extent from the scene where the grid has none), the
/// whole grid or one window of it; with `radius` (gdal_grid's `linear:radius`), cells outside
/// every triangle take the z of the nearest of `points` (every input point, repeats too).
#[pyfunction]
#[pyo3(signature = (scene, grid, *, backend = "auto", mode = "exact", nodata = -9999.0, owner = false, window = None, points = None, radius = 0.0))]
#[allow(clippy::too_many_arguments)]
fn rasterise(
    py: Python<'_>,
    scene: &Scene,
    grid: &Grid,
    backend: &str,
    mode: &str,
    nodata: f32,
    owner: bool,
    window: Option<(u32, u32, u32, u32)>,
    points: Option<&Bound<'_, PyAny>>,
    radius: f64,
) -> PyResult<Raster> {
    if radius.is_nan() {
        return Err(error("radius is NaN; give a number (negative: any distance, 0: none)"));
    }
    // The fallback reads the owner layer: it is computed, and dropped if not asked for.
    let settings = Settings::new(backend, mode, nodata, owner || radius != 0.0)?;
    let points = match (points, radius != 0.0) {
        (Some(points), true) => Some(vertices_of(points, "points")?),
        // A mesh's own vertices when no points are given.
        (None, true) => Some(scene.scene.vertices.clone()),
        (_, false) => None,
    };
    let (scene, spec, window) = (scene.scene.clone(), grid.spec, window_of(window));
    let done = interruptible(py, move |cancel| -> PyResult<_> {
        let grid = spec.grid_for(&scene.vertices).map_err(error)?;
        let params = settings.params(grid);
        let mut prepared = PreparedScene::from_prepared(tileraster::prepare(&scene, &params, window).map_err(error)?, settings.backend_for(&grid, window));
        let window = prepared.prepared().window;
        let Some((mut raster, stats)) = rasterise_banded(&mut prepared, window, cancel).map_err(error)? else {
            return Ok(None);
        };
        if let Some(fallback) = points.and_then(|points| dem::Fallback::new(&points, radius)) {
            fallback.fill(&mut raster);
        }
        if !owner {
            raster.owner = None;
        }
        Ok(Some((raster, stats)))
    })??;
    let (raster, stats) = done.ok_or_else(|| error("interrupted"))?;
    Raster::new(py, raster, &stats)
}

/// A point file summarised for blocks, as Python keeps it (plain values, so that Dask can
/// ship it): (path, points, bounds (west, south, east, north) or `None`, hull corners (K, 2),
/// density counts, a COPC file's records or `None`).
type SummaryTuple<'py> = (PathBuf, usize, Option<(f64, f64, f64, f64)>, Bound<'py, PyArray2<f64>>, Vec<u32>, Option<u64>);

/// The files that `inputs` (files, directories, glob patterns) name, as the command line
/// finds them.
#[pyfunction]
fn input_files(inputs: Vec<PathBuf>) -> PyResult<Vec<PathBuf>> {
    dem::input_files(&inputs).map_err(error)
}

fn read_options(classes: Vec<u8>, max_edge: Option<f64>) -> dem::ReadOptions {
    dem::ReadOptions { classes, max_edge, ..Default::default() }
}

/// Read the point file `path` and summarise it for blocks ([`block_dem`]).
#[pyfunction]
#[pyo3(signature = (path, *, classes = Vec::new()))]
fn summarise_points(py: Python<'_>, path: PathBuf, classes: Vec<u8>) -> PyResult<SummaryTuple<'_>> {
    let options = read_options(classes, None);
    let summary = interruptible(py, move |_| dem::summarise_file(&path, &options))?.map_err(error)?;
    let bounds = summary.bounds.map(|b| (b.x0, b.y0, b.x1, b.y1));
    let hull = rows(summary.hull.corners().iter().flatten().copied().collect(), 2).into_pyarray(py);
    Ok((summary.path, summary.points, bounds, hull, summary.density, summary.records))
}

fn grid_of((xmin, xmax, ymin, ymax, width, height): GridTuple) -> tileraster::Grid {
    tileraster::Grid::new(xmin, xmax, ymin, ymax, width, height)
}

/// Rasterise `window` of `grid` from the block scene `block` makes, on a thread of its own
/// ([`interruptible`]), with how the block was made.
fn rasterise_block(
    py: Python<'_>,
    grid: tileraster::Grid,
    window: Window,
    settings: Settings,
    block: impl FnOnce() -> Result<dem::Input, dem::DemError> + Send + 'static,
) -> PyResult<Raster> {
    let done = interruptible(py, move |cancel| -> PyResult<_> {
        let input = block().map_err(error)?;
        let params = settings.params(grid);
        let prepared = tileraster::prepare(&input.scene, &params, Some(window)).map_err(error)?;
        let mut prepared = PreparedScene::from_prepared(prepared, settings.backend_for(&grid, Some(window)));
        Ok(rasterise_banded(&mut prepared, window, cancel).map_err(error)?.map(|done| (done, input.block)))
    })??;
    let ((raster, stats), block) = done.ok_or_else(|| error("interrupted"))?;
    Ok(Raster { block, ..Raster::new(py, raster, &stats)? })
}

/// `window` of `grid` from the points of the summarised `files` (in their order, as one file's),
/// reading only the files the block's region meets: the whole run's cells bit for bit.
#[pyfunction]
#[pyo3(signature = (files, grid, window, *, backend = "cpu", mode = "exact", nodata = -9999.0, max_edge = None, classes = Vec::new()))]
#[allow(clippy::too_many_arguments)]
fn block_dem(
    py: Python<'_>,
    files: Vec<SummaryTuple<'_>>,
    grid: GridTuple,
    window: (u32, u32, u32, u32),
    backend: &str,
    mode: &str,
    nodata: f32,
    max_edge: Option<f64>,
    classes: Vec<u8>,
) -> PyResult<Raster> {
    let settings = Settings::new(backend, mode, nodata, false)?;
    let mut summaries = Vec::with_capacity(files.len());
    for (path, points, bounds, hull, density, records) in files {
        let hull = vertices_of_two(&hull)?;
        let bounds = bounds.map(|(x0, y0, x1, y1)| tileraster_tin::Rect { x0, y0, x1, y1 });
        summaries.push(dem::FileSummary { path, points, bounds, hull: tileraster_tin::Hull::of(&hull), density, records });
    }
    let (options, grid, window) = (read_options(classes, max_edge), grid_of(grid), window_of(Some(window)).expect("given"));
    rasterise_block(py, grid, window, settings, move || dem::block_scene_of_files(&summaries, &grid, window, &options, &()))
}

/// `window` of `grid` from `points` ((N, 3) x, y, z, all of them), triangulating only those
/// around the window: the whole run's cells bit for bit.
#[pyfunction]
#[pyo3(signature = (points, grid, window, *, backend = "cpu", mode = "exact", nodata = -9999.0, max_edge = None))]
#[allow(clippy::too_many_arguments)]
fn block_dem_points(
    py: Python<'_>,
    points: &Bound<'_, PyAny>,
    grid: GridTuple,
    window: (u32, u32, u32, u32),
    backend: &str,
    mode: &str,
    nodata: f32,
    max_edge: Option<f64>,
) -> PyResult<Raster> {
    let settings = Settings::new(backend, mode, nodata, false)?;
    let points = vertices_of(points, "points")?;
    let (options, grid, window) = (read_options(Vec::new(), max_edge), grid_of(grid), window_of(Some(window)).expect("given"));
    rasterise_block(py, grid, window, settings, move || dem::block_scene(&points, &grid, window, &options, &()))
}

fn vertices_of_two(array: &Bound<'_, PyArray2<f64>>) -> PyResult<Vec<[f64; 2]>> {
    let array = array.readonly();
    let array = array.as_array();
    if array.ncols() != 2 {
        return Err(error(format!("a hull has shape ({}, {}); give (K, 2) corners", array.nrows(), array.ncols())));
    }
    Ok(array.rows().into_iter().map(|r| [r[0], r[1]]).collect())
}

/// The backend "auto" picks here for a large raster, and the Vulkan adapter if there is one.
/// It opens no device (`tileraster::choose_backend`).
#[pyfunction]
fn backends(py: Python<'_>) -> (String, Option<String>) {
    let choice = py.detach(|| tileraster::choose_backend(tileraster::GPU_MIN_PIXELS));
    (choice.backend.name().into(), choice.adapter)
}

#[pymodule]
fn _native(module: &Bound<'_, PyModule>) -> PyResult<()> {
    module.add("TilerasterError", module.py().get_type::<TilerasterError>())?;
    module.add_class::<Grid>()?;
    module.add_class::<Scene>()?;
    module.add_class::<Raster>()?;
    module.add_class::<Prepared>()?;
    module.add_function(wrap_pyfunction!(rasterise, module)?)?;
    module.add_function(wrap_pyfunction!(backends, module)?)?;
    module.add_function(wrap_pyfunction!(input_files, module)?)?;
    module.add_function(wrap_pyfunction!(summarise_points, module)?)?;
    module.add_function(wrap_pyfunction!(block_dem, module)?)?;
    module.add_function(wrap_pyfunction!(block_dem_points, module)?)?;
    render::register(module)?;
    Ok(())
}
