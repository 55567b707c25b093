//! Stability under generated input (proptest). For random jittered TINs that tile a rectangle
//! — with vertices on pixel centres and tile borders, rows and columns of exactly collinear
//! vertices, edges split at their midpoints, duplicate vertices and zero-area triangles — and
//! for random triangle soups full of degenerate triangles (collinear, zero-area, 10^-12 px
//! high, repeated vertices), in every value mode:
//!
//! 1. the CPU and GPU backends give bit-identical values, owners and coverage counts;
//! 2. a mesh that tiles a rectangle covers every pixel centre inside it exactly once, and no
//!    pixel centre anywhere more than once;
//! 3. no value lies outside its owning triangle's vertex heights by more than the rounding to
//!    `f32` and the snapping of the coverage test allow;
//! 4. moving a mesh by whole pixels, by up to 10^9 px, moves its raster and changes no bit;
//! 5. degenerate input never panics or hangs, and gives no NaN other than a NaN nodata;
//! 6. at the documented range limits rasterising works, and just beyond them it fails with
//!    the documented typed error, naming the culprit. The `f32` modes refuse a triangle
//!    whose arithmetic could overflow (partial sums of `2^127` or more); every such refusal
//!    is checked against the triangle's own heights and slope.
//!
//! Case counts keep the file under a minute on two cores; `PROPTEST_CASES=n`
//! runs `n` cases in every property instead. A failure prints proptest's minimal input.

mod common;

use std::sync::mpsc;
use std::time::Duration;

use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::Index;
use proptest::test_runner::{Config, TestCaseError, TestRunner};
use tileraster::{Backend, Error, Grid, Mode, Outputs, Params, Raster, Scene, Window, rasterise, rasterise_window};
use tileraster_core::MAX_GRID_DIM;
use tileraster_testkit::scenes;

const BOTH: Outputs = Outputs { owner: true, coverage: true, tiles: false };

/// Lattice of the exactly placed coordinates, in pixels: coarser than the finest snapping
/// lattice (2^-16 px), so such vertices snap exactly and stay exactly collinear.
const LATTICE: f64 = 4096.0;

// ---------------------------------------------------------------------------------------------
// Running properties

fn config(cases: u32) -> Config {
    let cases = std::env::var("PROPTEST_CASES").ok().and_then(|v| v.parse().ok()).unwrap_or(cases);
    Config { cases, failure_persistence: None, max_shrink_iters: 4096, max_shrink_time: 60_000, ..Config::default() }
}

/// Run `test` on `cases` generated inputs; on failure panic with proptest's minimal input.
fn check<S>(name: &str, cases: u32, strategy: S, test: impl Fn(S::Value) -> Result<(), TestCaseError>)
where
    S: Strategy,
    S::Value: std::fmt::Debug,
{
    let mut runner = TestRunner::new(config(cases));
    if let Err(e) = runner.run(&strategy, test) {
        panic!("{name}: {e}");
    }
}

/// `rasterise_window` on the CPU in a thread of its own, failing if it does not return
/// within a minute (and passing its panic on, if it panics).
fn cpu_with_deadline(scene: &Scene, params: &Params, window: Option<Window>) -> Result<Raster, Error> {
    let (tx, rx) = mpsc::channel();
    let (scene, params) = (scene.clone(), *params);
    let worker = std::thread::spawn(move || {
        let _ = tx.send(rasterise_window(&scene, &params, window, Backend::Cpu));
    });
    match rx.recv_timeout(Duration::from_secs(60)) {
        Ok(result) => result,
        Err(mpsc::RecvTimeoutError::Timeout) => panic!("rasterise did not return within 60 s"),
        Err(mpsc::RecvTimeoutError::Disconnected) => match worker.join() {
            Err(panic) => std::panic::resume_unwind(panic),
            Ok(()) => unreachable!("the worker sends before it returns"),
        },
    }
}

fn cpu(scene: &Scene, params: &Params) -> Result<Raster, TestCaseError> {
    cpu_with_deadline(scene, params, None).map_err(|e| TestCaseError::fail(format!("CPU backend failed: {e}")))
}

/// `2^127`: the `f32` modes refuse a triangle whose arithmetic could reach it.
const FLOAT_REACH_LIMIT: f64 = 1.7014118346046923e38;

/// Whether `params.mode` refuses `scene` because its `f32` arithmetic could overflow
/// (`OutsideModeRange`), after checking that refusal independently: the exact mode never
/// refuses, and the named triangle's heights (barycentric), or its heights plus its plane's
/// slope across its bounding box (plane-f32), must reach `2^127`.
fn refused_as_beyond_f32(scene: &Scene, params: &Params, window: Option<Window>) -> Result<bool, TestCaseError> {
    let (triangle, reach) = match tileraster::prepare(scene, params, window) {
        Ok(_) => return Ok(false),
        Err(Error::OutsideModeRange { triangle, mode, reach }) if params.mode != Mode::Exact && mode == params.mode.name() => (triangle, reach),
        Err(e) => return Err(TestCaseError::fail(format!("[{}] prepare failed: {e}", params.mode.name()))),
    };
    prop_assert!(reach >= FLOAT_REACH_LIMIT, "refused with reach {:e}", reach);
    let exact = tileraster::prepare(scene, &params.with_mode(Mode::Exact), window)
        .map_err(|e| TestCaseError::fail(format!("exact mode refused what {} refused: {e}", params.mode.name())))?;
    let tri = scene.triangles[triangle];
    let zmax = tri.map(|k| (scene.vertices[k as usize][2] as f32).abs() as f64).into_iter().fold(0.0, f64::max);
    let bound = match params.mode {
        Mode::Barycentric => zmax,
        _ => {
            let uv = tri.map(|k| params.grid.to_raster(scene.vertices[k as usize][0], scene.vertices[k as usize][1]));
            let span = |f: fn(&(f64, f64)) -> f64| uv.iter().map(f).fold(f64::NEG_INFINITY, f64::max) - uv.iter().map(f).fold(f64::INFINITY, f64::min);
            // The plane's value at the bounding box's corner pixel, plus its steps across it.
            zmax + 2.0 * gradient(scene, &params.grid, tri, exact.snap_bits) * (span(|p| p.0) + span(|p| p.1) + 2.0)
        }
    };
    prop_assert!(
        bound >= FLOAT_REACH_LIMIT * (1.0 - 2f64.powi(-20)),
        "[{}] refused triangle {} {:?}, whose f32 arithmetic stays below {:e}",
        params.mode.name(),
        triangle,
        tri.map(|k| scene.vertices[k as usize]),
        bound
    );
    Ok(true)
}

/// [`cpu`], or `None` where the mode justly refuses the scene (see [`refused_as_beyond_f32`]).
fn cpu_in_range(scene: &Scene, params: &Params) -> Result<Option<Raster>, TestCaseError> {
    if refused_as_beyond_f32(scene, params, None)? {
        return Ok(None);
    }
    cpu(scene, params).map(Some)
}

// ---------------------------------------------------------------------------------------------
// Generated input

/// A mesh in raster space: `(u, v, z)` per vertex, in pixels from the grid's top-left corner
/// (x right, y down), placed onto a grid by `on_grid`.
#[derive(Debug, Clone, Default)]
struct Mesh {
    vertices: Vec<[f64; 3]>,
    triangles: Vec<[u32; 3]>,
}

impl Mesh {
    /// The scene in `grid`'s world coordinates, moved by `shift` pixels.
    fn on_grid(&self, grid: &Grid, shift: (f64, f64)) -> Scene {
        let (dx, dy) = (grid.dx(), grid.dy());
        let vertices = self.vertices.iter().map(|&[u, v, z]| [grid.xmin + (u + shift.0) * dx, grid.ymax - (v + shift.1) * dy, z]).collect();
        Scene::new(vertices, self.triangles.clone())
    }

    fn push(&mut self, u: f64, v: f64, z: f64) -> u32 {
        self.vertices.push([u, v, z]);
        (self.vertices.len() - 1) as u32
    }

    /// Bounding box `[umin, umax, vmin, vmax]` of the vertices.
    fn bounds(&self) -> [f64; 4] {
        let mut b = [f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY];
        for &[u, v, _] in &self.vertices {
            b = [b[0].min(u), b[1].max(u), b[2].min(v), b[3].max(v)];
        }
        b
    }
}

/// A grid: `exact` ones have power-of-two cells and an origin on a multiple of 16 cells, so
/// that raster coordinates on the 2^-13 px lattice map to world coordinates and back exactly;
/// the others have any cell size and UTM-scale origins.
#[derive(Debug, Clone, Copy)]
struct GridSpec {
    width: u32,
    height: u32,
    exact: bool,
    origin: (f64, f64),
    cell: (f64, f64),
}

impl GridSpec {
    fn grid(&self) -> Grid {
        let (x0, y0) = self.origin;
        let (w, h) = (self.width as f64, self.height as f64);
        Grid::new(x0, x0 + w * self.cell.0, y0, y0 + h * self.cell.1, self.width, self.height)
    }
}

fn grid_spec() -> impl Strategy<Value = GridSpec> {
    let exact = (48u32..=160, 48u32..=160, -3i32..=3, -1000i32..=1000, -1000i32..=1000).prop_map(|(width, height, e, kx, ky)| {
        let c = 2f64.powi(e);
        GridSpec { width, height, exact: true, origin: (kx as f64 * 16.0 * c, ky as f64 * 16.0 * c), cell: (c, c) }
    });
    let any = (48u32..=160, 48u32..=160, 0.05f64..20.0, 0.5f64..2.0, -1e6f64..1e6, 4e6f64..6e6).prop_map(|(width, height, c, aspect, x0, y0)| GridSpec {
        width,
        height,
        exact: false,
        origin: (x0, y0),
        cell: (c, c * aspect),
    });
    prop_oneof![3 => exact, 1 => any]
}

/// Where a jittered lattice vertex goes.
#[derive(Debug, Clone, Copy)]
enum Place {
    /// Where the jitter put it.
    Jitter,
    /// Onto the nearest pixel centre (per free axis).
    PixelCentre,
    /// Onto the nearest tile border (multiple of 16 px) if that is near, else onto the
    /// nearest pixel corner.
    TileBorder,
}

fn place() -> impl Strategy<Value = Place> {
    prop_oneof![2 => Just(Place::Jitter), 1 => Just(Place::PixelCentre), 1 => Just(Place::TileBorder)]
}

/// A jittered lattice TIN tiling the rectangle `origin + [0, cols·cell.0] × [0, rows·cell.1]`
/// (pixels): cells of at least 8 px, interior vertices jittered by at most 0.12 of a cell and
/// then moved by at most half a pixel or 0.1 of a cell, which keeps every triangle positively
/// oriented (each vertex stays within 0.22 cell per axis of its lattice point, less than half
/// the smallest altitude, 0.71 cell, of the lattice's triangles).
#[derive(Debug, Clone)]
struct TinSpec {
    origin: (f64, f64),
    cell: (f64, f64),
    cols: u32,
    rows: u32,
    /// Per lattice vertex, row-major: jitter (fractions of a cell), placement, height.
    vertices: Vec<((f64, f64), Place, f64)>,
    /// Rows and columns whose vertices stay exactly on one straight line.
    straight_rows: Vec<bool>,
    straight_cols: Vec<bool>,
    /// Per cell: split along the main diagonal?
    diagonals: Vec<bool>,
    /// Edges split at their midpoints (with the neighbour across them): (triangle, edge).
    splits: Vec<(Index, u8)>,
    /// Zero-area triangles inserted: (position, source triangle, kind).
    degenerate: Vec<(Index, Index, u8)>,
    /// Triangle corners given a vertex of their own, at the same place: (triangle, corner).
    duplicates: Vec<(Index, u8)>,
    /// Coordinates quantised to 2^-12 px, so that snapping is exact and the inserted collinear
    /// triangles stay exactly flat (on exact grids).
    on_lattice: bool,
}

/// A start coordinate of the tiled rectangle: anywhere, a pixel centre or a tile border, such
/// that the rectangle (cells of 8 px or more, grids of 48 px or more) reaches over pixel
/// centres of the grid with a pixel to spare.
fn start() -> impl Strategy<Value = f64> {
    prop_oneof![-6.0f64..40.0, (-6i32..40).prop_map(|i| i as f64 + 0.5), (0i32..=2).prop_map(|k| 16.0 * k as f64)]
}

fn cell_size() -> impl Strategy<Value = f64> {
    prop_oneof![8.0f64..40.0, (8u32..=40).prop_map(f64::from)]
}

/// `(base, scale)` of the heights `base + scale·t`, `t ∈ [-1, 1]`; with `extreme`, also
/// heights up to `±f32::MAX`.
fn height_range(extreme: bool) -> impl Strategy<Value = (f64, f64)> {
    prop_oneof![
        4 => Just((0.0, 1000.0)),
        2 => Just((5000.0, 10.0)),
        1 => Just((0.0, 1.0)),
        1 => Just((1e6, 1.0)),
        1 => Just((0.0, 1e30)),
        if extreme { 3 } else { 0 } => Just((0.0, f32::MAX as f64)),
        if extreme { 1 } else { 0 } => Just((f32::MAX as f64, 0.0)),
        if extreme { 1 } else { 0 } => Just((-(f32::MAX as f64), 0.0)),
    ]
}

fn tin_spec(extreme: bool) -> impl Strategy<Value = TinSpec> {
    ((1u32..=10, 1u32..=10), (start(), start()), (cell_size(), cell_size()), height_range(extreme), any::<bool>())
        .prop_flat_map(|((cols, rows), origin, cell, (base, scale), on_lattice)| {
            let n = ((cols + 1) * (rows + 1)) as usize;
            let vertex = ((-0.12f64..=0.12, -0.12f64..=0.12), place(), -1.0f64..=1.0).prop_map(move |(j, p, t)| (j, p, base + scale * t));
            (
                (Just((cols, rows)), Just(origin), Just(cell), Just(on_lattice)),
                vec(vertex, n),
                vec(prop::bool::weighted(0.25), rows as usize + 1),
                vec(prop::bool::weighted(0.25), cols as usize + 1),
                vec(any::<bool>(), (cols * rows) as usize),
                vec((any::<Index>(), 0u8..3), 0..6),
                vec((any::<Index>(), any::<Index>(), 0u8..4), 0..5),
                vec((any::<Index>(), 0u8..3), 0..4),
            )
        })
        .prop_map(|(((cols, rows), origin, cell, on_lattice), vertices, straight_rows, straight_cols, diagonals, splits, degenerate, duplicates)| TinSpec {
            origin,
            cell,
            cols,
            rows,
            vertices,
            straight_rows,
            straight_cols,
            diagonals,
            splits,
            degenerate,
            duplicates,
            on_lattice,
        })
}

impl TinSpec {
    /// The mesh and the rectangle `[u0, u1, v0, v1]` it tiles, in pixels. `exact_grid`: the
    /// mesh goes onto an exact grid, where lattice coordinates stay exact.
    fn build(&self, exact_grid: bool) -> (Mesh, [f64; 4]) {
        let q = |x: f64| if self.on_lattice { (x * LATTICE).round() / LATTICE } else { x };
        let (cols, rows) = (self.cols, self.rows);
        let (cu, cv) = self.cell;
        let put = |x: f64, cell: f64, place: Place| match place {
            Place::Jitter => x,
            Place::PixelCentre => x.floor() + 0.5,
            Place::TileBorder => {
                let border = 16.0 * (x / 16.0).round();
                if (border - x).abs() <= 0.1 * cell { border } else { x.round() }
            }
        };
        let mut mesh = Mesh::default();
        for r in 0..=rows {
            for c in 0..=cols {
                let ((ju, jv), place, z) = self.vertices[(r * (cols + 1) + c) as usize];
                let mut u = self.origin.0 + c as f64 * cu;
                let mut v = self.origin.1 + r as f64 * cv;
                // Boundary vertices slide along the boundary only; straight rows and columns stay put.
                if c != 0 && c != cols && !self.straight_cols[c as usize] {
                    u = put(u + ju * cu, cu, place);
                }
                if r != 0 && r != rows && !self.straight_rows[r as usize] {
                    v = put(v + jv * cv, cv, place);
                }
                mesh.push(q(u), q(v), z);
            }
        }
        mesh.triangles = scenes::lattice_triangles(cols, rows, |c, r| self.diagonals[(r * cols + c) as usize]);

        for &(t, e) in &self.splits {
            let t = t.index(mesh.triangles.len());
            let tri = mesh.triangles[t];
            let e = e as usize;
            let (p, q_, r) = (tri[e], tri[(e + 1) % 3], tri[(e + 2) % 3]);
            let m = midpoint(&mut mesh, p, q_);
            mesh.triangles[t] = [p, m, r];
            mesh.triangles.push([m, q_, r]);
            // The neighbour across the edge, which runs q → p in it.
            let across =
                mesh.triangles.iter().enumerate().find_map(|(n, t2)| (0..3).find(|&k| t2[k] == q_ && t2[(k + 1) % 3] == p).map(|k| (n, t2[(k + 2) % 3])));
            if let Some((n, s)) = across {
                mesh.triangles[n] = [q_, m, s];
                mesh.triangles.push([m, p, s]);
            }
        }

        let exact = self.on_lattice && exact_grid;
        for &(at, from, kind) in &self.degenerate {
            let tri = mesh.triangles[from.index(mesh.triangles.len())];
            let (p, q_) = (tri[0], tri[1]);
            let flat = match kind {
                // A repeated vertex.
                0 => [p, p, q_],
                // A vertex of its own at the same place as another.
                1 => {
                    let [u, v, z] = mesh.vertices[p as usize];
                    let copy = mesh.push(u, v, z);
                    [p, q_, copy]
                }
                // Three consecutive vertices of a straight row (any coordinates: same v).
                2 if cols >= 2 && self.straight_rows.iter().any(|&s| s) => {
                    let r = self.straight_rows.iter().position(|&s| s).unwrap() as u32;
                    let c = 1 + from.index((cols - 1) as usize) as u32;
                    let at_ = |c: u32| r * (cols + 1) + c;
                    [at_(c - 1), at_(c), at_(c + 1)]
                }
                // An exact midpoint: only exactly collinear on the lattice of an exact grid.
                3 if exact => {
                    let m = midpoint(&mut mesh, p, q_);
                    [p, m, q_]
                }
                _ => [q_, p, q_],
            };
            let at = at.index(mesh.triangles.len() + 1);
            mesh.triangles.insert(at, flat);
        }

        for &(t, corner) in &self.duplicates {
            let t = t.index(mesh.triangles.len());
            let [u, v, z] = mesh.vertices[mesh.triangles[t][corner as usize] as usize];
            // Same place, another height: a cliff.
            mesh.triangles[t][corner as usize] = mesh.push(u, v, -z);
        }

        let rect = [q(self.origin.0), q(self.origin.0 + cols as f64 * cu), q(self.origin.1), q(self.origin.1 + rows as f64 * cv)];
        (mesh, rect)
    }
}

/// A new vertex halfway between `p` and `q` (exactly, when their coordinates are on the lattice).
fn midpoint(mesh: &mut Mesh, p: u32, q: u32) -> u32 {
    let (a, b) = (mesh.vertices[p as usize], mesh.vertices[q as usize]);
    mesh.push((a[0] + b[0]) / 2.0, (a[1] + b[1]) / 2.0, a[2] / 2.0 + b[2] / 2.0)
}

/// Heights for soups: ordinary ones, zero, tiny ones, huge ones and, with `extreme`, the
/// extremes of the `f32` range.
fn height(extreme: bool) -> impl Strategy<Value = f64> {
    let max = f32::MAX as f64;
    prop_oneof![
        8 => -1000.0f64..1000.0,
        1 => Just(0.0),
        1 => -1e-38f64..1e-38,
        1 => -1e30f64..1e30,
        if extreme { 4 } else { 0 } => prop_oneof![Just(max), Just(-max), 1e37f64..max, -max..-1e37f64],
    ]
}

/// One triangle of a soup; `kind` picks its shape (see `SoupSpec::build`).
#[derive(Debug, Clone)]
struct SoupTri {
    kind: u8,
    /// First vertex, as a fraction of the grid's size (a little beyond it too).
    a: (f64, f64),
    /// Offsets to the other vertices, in pixels.
    d1: (f64, f64),
    d2: (f64, f64),
    /// Multiples of the step along a line, for collinear triangles.
    steps: [i8; 3],
    /// Height of near-flat triangles: 2^-17 px, 2^-16 px, or 10^-tiny px.
    tiny: u8,
    reuse: [Index; 3],
    z: [f64; 3],
    /// All three vertices at the first height?
    flat: bool,
}

#[derive(Debug, Clone)]
struct SoupSpec {
    triangles: Vec<SoupTri>,
    on_lattice: bool,
}

fn soup_tri(extreme: bool) -> impl Strategy<Value = SoupTri> {
    let d = || (-40.0f64..40.0, -40.0f64..40.0);
    (
        0u8..10,
        (-0.1f64..1.1, -0.1f64..1.1),
        d(),
        d(),
        [-4i8..=4, -4i8..=4, -4i8..=4],
        0u8..=12,
        [any::<Index>(), any::<Index>(), any::<Index>()],
        [height(extreme), height(extreme), height(extreme)],
        prop::bool::weighted(0.2),
    )
        .prop_map(|(kind, a, d1, d2, steps, tiny, reuse, z, flat)| SoupTri { kind, a, d1, d2, steps, tiny, reuse, z, flat })
}

fn soup_spec(extreme: bool) -> impl Strategy<Value = SoupSpec> {
    (vec(soup_tri(extreme), 1..40), any::<bool>()).prop_map(|(triangles, on_lattice)| SoupSpec { triangles, on_lattice })
}

impl SoupSpec {
    /// The soup over a `w` × `h` px area.
    fn build(&self, w: f64, h: f64) -> Mesh {
        let q = |x: f64| if self.on_lattice { (x * LATTICE).round() / LATTICE } else { x };
        let mut mesh = Mesh::default();
        for t in &self.triangles {
            let a = (q(t.a.0 * w), q(t.a.1 * h));
            let b = (q(a.0 + t.d1.0), q(a.1 + t.d1.1));
            let c = (q(a.0 + t.d2.0), q(a.1 + t.d2.1));
            let len = t.d1.0.hypot(t.d1.1);
            let normal = if len > 0.0 { (-t.d1.1 / len, t.d1.0 / len) } else { (0.0, 1.0) };
            let z = if t.flat { [t.z[0]; 3] } else { t.z };
            let points: [(f64, f64); 3] = match t.kind {
                0..=2 => [a, b, c],
                // Exactly collinear (on the lattice): multiples of a step on the 2^-6 px lattice.
                3 => {
                    let step = ((t.d1.0 * 64.0).round() / 64.0, (t.d1.1 * 64.0).round() / 64.0);
                    t.steps.map(|k| (a.0 + k as f64 * step.0, a.1 + k as f64 * step.1))
                }
                // Two vertices at the same place.
                4 => [a, a, b],
                // One place.
                5 => [a, a, a],
                // Nearly flat: the third vertex a hair off the middle of the first edge.
                6 => {
                    let hair = match t.tiny {
                        0 => 2f64.powi(-17),
                        1 => 2f64.powi(-16),
                        k => 10f64.powi(-(k as i32)),
                    };
                    [a, b, ((a.0 + b.0) / 2.0 + normal.0 * hair, (a.1 + b.1) / 2.0 + normal.1 * hair)]
                }
                // A long needle, 0.01 px wide.
                7 => {
                    let far = (a.0 + 6.0 * t.d1.0, a.1 + 6.0 * t.d1.1);
                    [a, far, (far.0 + normal.0 * 0.01, far.1 + normal.1 * 0.01)]
                }
                // A repeated vertex index.
                8 => {
                    let i = mesh.push(a.0, a.1, z[0]);
                    let j = mesh.push(b.0, b.1, z[1]);
                    mesh.triangles.push(if t.steps[0] >= 0 { [i, i, j] } else { [i, j, i] });
                    continue;
                }
                // Vertices of earlier triangles (repeats possible).
                _ => {
                    if mesh.vertices.is_empty() {
                        [a, b, c]
                    } else {
                        let n = mesh.vertices.len();
                        mesh.triangles.push(t.reuse.map(|k| k.index(n) as u32));
                        continue;
                    }
                }
            };
            // On the lattice, everything is (the hair of nearly flat triangles shrinks to the
            // lattice's 2^-12 px or vanishes).
            let tri = [0, 1, 2].map(|k| mesh.push(q(points[k].0), q(points[k].1), z[k]));
            mesh.triangles.push(tri);
        }
        mesh
    }
}

fn nodata() -> impl Strategy<Value = f32> {
    prop_oneof![Just(f32::NAN), Just(f32::from_bits(0xffc0_0001)), Just(-9999.0f32), Just(0.0f32), Just(f32::MAX),]
}

// ---------------------------------------------------------------------------------------------
// Checks

/// Owner and coverage agree (coverage 0 ⇔ no owner), uncovered cells hold the nodata bits,
/// and covered cells hold a finite value (so no NaN but a NaN nodata).
fn check_consistent(name: &str, raster: &Raster) -> Result<(), TestCaseError> {
    let owner = raster.owner.as_ref().expect("owner asked for");
    let coverage = raster.coverage.as_ref().expect("coverage asked for");
    let width = raster.width() as usize;
    for (k, value) in raster.values.iter().enumerate() {
        let (i, j) = (k % width, k / width);
        prop_assert_eq!(coverage[k] == 0, owner[k] == u32::MAX, "{}: owner {} but coverage {} at ({}, {})", name, owner[k], coverage[k], i, j);
        if coverage[k] == 0 {
            prop_assert_eq!(value.to_bits(), raster.nodata.to_bits(), "{}: uncovered ({}, {}) holds {:e}, not nodata", name, i, j, value);
        } else {
            prop_assert!(value.is_finite(), "{}: ({}, {}), owned by triangle {}, holds {}", name, i, j, owner[k], value);
        }
    }
    Ok(())
}

/// Every pixel centre at least 1 px inside `rect` (raster space) is covered exactly once and
/// owned; none anywhere is covered more than once.
fn check_tiles(name: &str, raster: &Raster, rect: [f64; 4]) -> Result<(), TestCaseError> {
    let owner = raster.owner.as_ref().unwrap();
    let coverage = raster.coverage.as_ref().unwrap();
    let w = raster.window;
    let mut inside = 0;
    for j in 0..w.height {
        for i in 0..w.width {
            let k = (j * w.width + i) as usize;
            let (u, v) = ((w.x0 + i) as f64 + 0.5, (w.y0 + j) as f64 + 0.5);
            prop_assert!(coverage[k] <= 1, "{}: pixel ({}, {}) is covered {} times", name, i, j, coverage[k]);
            if u >= rect[0] + 1.0 && u <= rect[1] - 1.0 && v >= rect[2] + 1.0 && v <= rect[3] - 1.0 {
                prop_assert!(coverage[k] == 1 && owner[k] != u32::MAX, "{}: pixel ({}, {}) inside the tiled rectangle is a hole", name, i, j);
                inside += 1;
            }
        }
    }
    prop_assert!(inside > 0, "{}: no pixel centre lies inside the tiled rectangle", name);
    Ok(())
}

/// Magnitude of the per-pixel gradient of the plane the rasteriser fits to triangle `tri`:
/// through its unsnapped vertices unless those are flat or flipped against the snapped ones.
fn gradient(scene: &Scene, grid: &Grid, tri: [u32; 3], snap_bits: u32) -> f64 {
    let unit = 2f64.powi(snap_bits as i32);
    let p = tri.map(|k| {
        let [x, y, z] = scene.vertices[k as usize];
        let (u, v) = grid.to_raster(x, y);
        (u, v, z)
    });
    let snapped = p.map(|(u, v, z)| ((u * unit).round() / unit, (v * unit).round() / unit, z));
    let fit = |p: [(f64, f64, f64); 3]| {
        let (au, av, az) = (p[1].0 - p[0].0, p[1].1 - p[0].1, p[1].2 - p[0].2);
        let (bu, bv, bz) = (p[2].0 - p[0].0, p[2].1 - p[0].1, p[2].2 - p[0].2);
        let det = au * bv - av * bu;
        ((az * bv - av * bz) / det, (au * bz - az * bu) / det, det)
    };
    let (gi, gj, det) = fit(p);
    let (si, sj, sdet) = fit(snapped);
    if det != 0.0 && det.signum() == sdet.signum() && gi.is_finite() && gj.is_finite() { gi.hypot(gj) } else { si.hypot(sj) }
}

/// Every covered cell lies within its owner's vertex heights, widened by `2^-21·max|z|` (a few
/// `f32` roundings), `|∇z|·2^-(snap_bits-1)` (snapping may let a centre up to
/// `2^-snap_bits·√2/2` px outside the unsnapped triangle own it), `2^-147` (the rounding of
/// subnormal results) and `(2 + w + h)·2^-150` (plane-f32's subnormal coefficients, rounded
/// absolutely, times pixel offsets: docs/numeric-contract.md §6).
fn check_no_overshoot(name: &str, scene: &Scene, grid: &Grid, raster: &Raster) -> Result<(), TestCaseError> {
    let owner = raster.owner.as_ref().unwrap();
    let width = raster.width() as usize;
    for (k, value) in raster.values.iter().enumerate() {
        if owner[k] == u32::MAX {
            continue;
        }
        let tri = scene.triangles[owner[k] as usize];
        let z = tri.map(|i| scene.vertices[i as usize][2]);
        let (lo, hi) = (z[0].min(z[1]).min(z[2]), z[0].max(z[1]).max(z[2]));
        let zmax = z[0].abs().max(z[1].abs()).max(z[2].abs());
        let g = gradient(scene, grid, tri, raster.snap_bits);
        // In the subnormal range each f32 rounding is absolute, up to 2^-150, and plane-f32's
        // coefficients are scaled by pixel offsets below the grid's width and height.
        let subnormal = (2.0 + grid.width as f64 + grid.height as f64) * 2f64.powi(-150);
        let slack = zmax * 2f64.powi(-21) + g * 2f64.powi(1 - raster.snap_bits as i32) + 2f64.powi(-147) + subnormal;
        let value = *value as f64;
        prop_assert!(
            value >= lo - slack && value <= hi + slack,
            "{}: pixel ({}, {}) = {:e} outside [{:e}, {:e}] ± {:e} of its owner, triangle {} {:?}",
            name,
            k % width,
            k / width,
            value,
            lo,
            hi,
            slack,
            owner[k],
            tri.map(|i| scene.vertices[i as usize])
        );
    }
    Ok(())
}

fn params(grid: Grid, mode: Mode) -> Params {
    Params::new(grid).with_nodata(-9999.0).with_outputs(BOTH).with_mode(mode)
}

// ---------------------------------------------------------------------------------------------
// 1. CPU/GPU bit identity

#[test]
fn gpu_matches_cpu_on_tiling_tins() {
    if !common::gpu_or_skip("gpu_matches_cpu_on_tiling_tins") {
        return;
    }
    check("CPU/GPU parity, TINs", 512, (grid_spec(), tin_spec(true)), |(gs, spec)| {
        let grid = gs.grid();
        let scene = spec.build(gs.exact).0.on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            if refused_as_beyond_f32(&scene, &params(grid, mode), None)? {
                continue;
            }
            common::assert_parity(&format!("TIN [{}]", mode.name()), &scene, &params(grid, mode));
        }
        Ok(())
    });
}

#[test]
fn gpu_matches_cpu_on_degenerate_soups() {
    if !common::gpu_or_skip("gpu_matches_cpu_on_degenerate_soups") {
        return;
    }
    check("CPU/GPU parity, soups", 512, (grid_spec(), soup_spec(true), nodata()), |(gs, spec, nodata)| {
        let grid = gs.grid();
        let scene = spec.build(gs.width as f64, gs.height as f64).on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            if refused_as_beyond_f32(&scene, &params(grid, mode), None)? {
                continue;
            }
            common::assert_parity(&format!("soup [{}]", mode.name()), &scene, &params(grid, mode).with_nodata(nodata));
        }
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------------
// 2. Watertightness, 3. no overshoot

#[test]
fn tiling_tins_are_watertight_and_do_not_overshoot() {
    check("TIN watertightness and overshoot", 2048, (grid_spec(), tin_spec(false)), |(gs, spec)| {
        let grid = gs.grid();
        let (mesh, rect) = spec.build(gs.exact);
        let scene = mesh.on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            let Some(raster) = cpu_in_range(&scene, &params(grid, mode))? else { continue };
            let name = format!("TIN [{}]", mode.name());
            check_consistent(&name, &raster)?;
            check_tiles(&name, &raster, rect)?;
            check_no_overshoot(&name, &scene, &grid, &raster)?;
        }
        Ok(())
    });
}

#[test]
fn soups_do_not_overshoot() {
    check("soup overshoot", 2048, (grid_spec(), soup_spec(false)), |(gs, spec)| {
        let grid = gs.grid();
        let scene = spec.build(gs.width as f64, gs.height as f64).on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            let Some(raster) = cpu_in_range(&scene, &params(grid, mode))? else { continue };
            check_no_overshoot(&format!("soup [{}]", mode.name()), &scene, &grid, &raster)?;
        }
        Ok(())
    });
}

/// Heights up to `±f32::MAX` (the documented limit) stay finite and within their triangles'
/// heights, in TINs and in degenerate soups.
#[test]
fn extreme_heights_stay_finite_and_do_not_overshoot() {
    let mesh = prop_oneof![tin_spec(true).prop_map(Ok), soup_spec(true).prop_map(Err)];
    check("extreme heights", 1024, (grid_spec(), mesh), |(gs, spec)| {
        let grid = gs.grid();
        let mesh = match &spec {
            Ok(tin) => tin.build(gs.exact).0,
            Err(soup) => soup.build(gs.width as f64, gs.height as f64),
        };
        let scene = mesh.on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            let Some(raster) = cpu_in_range(&scene, &params(grid, mode))? else { continue };
            let name = format!("extreme heights [{}]", mode.name());
            check_consistent(&name, &raster)?;
            check_no_overshoot(&name, &scene, &grid, &raster)?;
        }
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------------
// 4. Translation invariance

/// A small mesh (TIN or soup, coordinates on the 2^-12 px lattice) in a grid of 2^22 or 2^30
/// cells a side, placed at `from` and moved to `to` (pixels).
///
/// Translation by whole pixels is exact only while every translated coordinate is exactly
/// representable: here cells are powers of two, the origin is a multiple of 2^20 cells and
/// vertices lie on the 2^-13 px lattice (midpoints included), so `x = xmin + u·dx` needs at
/// most 44 significant bits and both `x` and `(x − xmin)/dx` are exact in `f64`.
#[derive(Debug, Clone)]
struct FarSpec {
    mesh: Result<TinSpec, SoupSpec>,
    side_log2: u32,
    cell_log2: i32,
    origin: (i32, i32),
    from: (f64, f64),
    to: (f64, f64),
}

fn far_spec() -> impl Strategy<Value = FarSpec> {
    let tin = tin_spec(true).prop_map(|mut t| {
        t.on_lattice = true;
        Ok(t)
    });
    let soup = soup_spec(true).prop_map(|mut s| {
        s.on_lattice = true;
        Err(s)
    });
    let mesh = prop_oneof![tin, soup];
    // Positions as fractions of the usable span, plus small moves.
    let at = || (0.0f64..1.0, 0.0f64..1.0);
    (
        mesh,
        prop_oneof![Just(22u32), Just(30u32)],
        -1i32..=1,
        (-4i32..=4, -4i32..=4),
        at(),
        prop_oneof![at().prop_map(Ok), (-99i32..99, -99i32..99).prop_map(Err)],
    )
        .prop_map(|(mesh, side_log2, cell_log2, origin, from, to)| {
            // Meshes are under 700 px across: keep them 1024 px inside the grid.
            let span = (1u64 << side_log2) as f64 - 2048.0;
            let from = ((from.0 * span).floor() + 1024.0, (from.1 * span).floor() + 1024.0);
            let to = match to {
                Ok(to) => ((to.0 * span).floor() + 1024.0, (to.1 * span).floor() + 1024.0),
                Err((k, l)) => (from.0 + k as f64, from.1 + l as f64),
            };
            FarSpec { mesh, side_log2, cell_log2, origin, from, to }
        })
}

impl FarSpec {
    fn grid(&self) -> Grid {
        let n = 1u32 << self.side_log2;
        let c = 2f64.powi(self.cell_log2);
        let (x0, y0) = (self.origin.0 as f64 * 2f64.powi(20) * c, self.origin.1 as f64 * 2f64.powi(20) * c);
        Grid::new(x0, x0 + n as f64 * c, y0, y0 + n as f64 * c, n, n)
    }

    /// The mesh with its bounding box's top-left pixel at the origin of raster space, and
    /// the window around it there, `(width, height)`.
    fn mesh(&self) -> (Mesh, (u32, u32)) {
        let mut mesh = match &self.mesh {
            Ok(tin) => tin.build(true).0,
            Err(soup) => soup.build(64.0, 64.0),
        };
        let b = mesh.bounds();
        let (u0, v0) = (b[0].floor(), b[2].floor());
        for p in &mut mesh.vertices {
            p[0] -= u0;
            p[1] -= v0;
        }
        (mesh, ((b[1] - u0).ceil() as u32 + 16, (b[3] - v0).ceil() as u32 + 16))
    }

    /// The scene at `at` and the window around it.
    fn placed(&self, at: (f64, f64)) -> (Scene, Window) {
        let (mesh, (width, height)) = self.mesh();
        let scene = mesh.on_grid(&self.grid(), at);
        (scene, Window { x0: at.0 as u32 - 8, y0: at.1 as u32 - 8, width, height })
    }
}

#[test]
fn moving_a_mesh_by_whole_pixels_changes_no_bit() {
    check("translation invariance", 1024, far_spec(), |spec| {
        let grid = spec.grid();
        let (here, window) = spec.placed(spec.from);
        let (there, moved) = spec.placed(spec.to);
        for mode in Mode::ALL {
            let p = params(grid, mode);
            if refused_as_beyond_f32(&here, &p, Some(window))? {
                // The same triangle, moved: refused there too.
                prop_assert!(refused_as_beyond_f32(&there, &p, Some(moved))?, "[{}] refused at {:?} only", mode.name(), spec.from);
                continue;
            }
            let a = cpu_with_deadline(&here, &p, Some(window)).map_err(|e| TestCaseError::fail(format!("at {:?}: {e}", spec.from)))?;
            let b = cpu_with_deadline(&there, &p, Some(moved)).map_err(|e| TestCaseError::fail(format!("at {:?}: {e}", spec.to)))?;
            let (count, first) = a.compare_bits(&b, 8);
            let list: Vec<String> = first.iter().map(|d| d.to_string()).collect();
            prop_assert_eq!(count, 0, "[{}] windows {:?} and {:?} differ in {} cells: {:?}", mode.name(), window, moved, count, list);
            prop_assert_eq!(a.snap_bits, b.snap_bits);
        }
        Ok(())
    });
}

#[test]
fn gpu_matches_cpu_far_out_in_huge_grids() {
    if !common::gpu_or_skip("gpu_matches_cpu_far_out_in_huge_grids") {
        return;
    }
    check("CPU/GPU parity far out", 128, far_spec(), |spec| {
        let grid = spec.grid();
        let (scene, window) = spec.placed(spec.to);
        for mode in Mode::ALL {
            let p = params(grid, mode);
            if refused_as_beyond_f32(&scene, &p, Some(window))? {
                continue;
            }
            let a = rasterise_window(&scene, &p, Some(window), Backend::Cpu).map_err(|e| TestCaseError::fail(format!("cpu: {e}")))?;
            let b = rasterise_window(&scene, &p, Some(window), Backend::Gpu).map_err(|e| TestCaseError::fail(format!("gpu: {e}")))?;
            let (count, first) = a.compare_bits(&b, 8);
            let list: Vec<String> = first.iter().map(|d| d.to_string()).collect();
            prop_assert_eq!(count, 0, "[{}] window {:?}: CPU and GPU differ in {} cells: {:?}", mode.name(), window, count, list);
        }
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------------
// 5. Degenerate soups: no panic, no hang, no NaN

#[test]
fn degenerate_soups_return_clean_rasters() {
    check("degenerate soups", 2048, (grid_spec(), soup_spec(false), nodata()), |(gs, spec, nodata)| {
        let grid = gs.grid();
        let scene = spec.build(gs.width as f64, gs.height as f64).on_grid(&grid, (0.0, 0.0));
        for mode in Mode::ALL {
            let Some(raster) = cpu_in_range(&scene, &params(grid, mode).with_nodata(nodata))? else { continue };
            check_consistent(&format!("soup [{}] nodata {:#x}", mode.name(), nodata.to_bits()), &raster)?;
        }
        Ok(())
    });
}

// ---------------------------------------------------------------------------------------------
// 6. Range limits

fn expect_err(name: &str, result: Result<Raster, Error>) -> Error {
    match result {
        Ok(_) => panic!("{name}: expected an error, got a raster"),
        Err(e) => e,
    }
}

#[test]
fn grid_sides_up_to_max_grid_dim_work_and_one_more_is_too_large() {
    assert_eq!(MAX_GRID_DIM, 1 << 30);
    let n = MAX_GRID_DIM as u32;
    let grid = Grid::new(0.0, n as f64, 0.0, n as f64, n, n);
    // A triangle in the far corner, rasterised through a window there.
    let (u, v) = (n as f64 - 40.0, n as f64 - 40.0);
    let corner = |du: f64, dv: f64, z: f64| [u + du, grid.ymax - (v + dv), z];
    let scene = Scene::new(vec![corner(0.0, 0.0, 1.0), corner(30.0, 2.0, 2.0), corner(5.0, 31.0, 3.0)], vec![[0, 1, 2]]);
    let window = Window { x0: n - 48, y0: n - 48, width: 48, height: 48 };
    let mut backends = vec![Backend::Cpu];
    if common::gpu_or_skip("grid sides at MAX_GRID_DIM") {
        backends.push(Backend::Gpu);
    }
    let mut rasters = Vec::new();
    for backend in backends {
        for mode in Mode::ALL {
            let raster = rasterise_window(&scene, &params(grid, mode), Some(window), backend)
                .unwrap_or_else(|e| panic!("{} [{}]: a {n}×{n} grid must be accepted: {e}", backend.name(), mode.name()));
            check_consistent("max grid", &raster).unwrap();
            assert!(raster.coverage.as_ref().unwrap().contains(&1), "the triangle covers nothing");
            rasters.push(raster);
        }
    }
    if rasters.len() == 6 {
        for m in 0..3 {
            assert_eq!(rasters[m].compare_bits(&rasters[m + 3], 4).0, 0, "{}: CPU and GPU differ", Mode::ALL[m].name());
        }
    }
    for (w, h) in [(n + 1, 16), (16, n + 1), (u32::MAX, u32::MAX)] {
        let grid = Grid::new(0.0, 16.0, 0.0, 16.0, w, h);
        let e = expect_err("too large", rasterise_window(&scene, &Params::new(grid), Some(Window { x0: 0, y0: 0, width: 16, height: 16 }), Backend::Cpu));
        assert!(matches!(e, Error::RasterTooLarge { width, height, .. } if width == w as u64 && height == h as u64), "{e:?}");
        let text = e.to_string();
        assert!(text.contains(&format!("{w}×{h}")) && text.contains(&MAX_GRID_DIM.to_string()), "{text}");
    }
}

/// A 64×64 grid of 1-px cells under a small triangle 0 and a right triangle 1 whose legs are
/// `extent` px, with the plane `z = 100 + (u + 10)·2^-20 − (v + 10)·2^-21` (exact in `f64`).
fn big_triangle(extent: f64) -> (Scene, Grid) {
    let grid = Grid::new(0.0, 64.0, 0.0, 64.0, 64, 64);
    let z = |u: f64, v: f64| 100.0 + (u + 10.0) * 2f64.powi(-20) - (v + 10.0) * 2f64.powi(-21);
    let at = |u: f64, v: f64| [u, 64.0 - v, z(u, v)];
    let scene = Scene::new(
        vec![at(2.0, 2.0), at(9.0, 2.5), at(3.0, 8.0), at(-10.0, -10.0), at(-10.0 + extent, -10.0), at(-10.0, -10.0 + extent)],
        vec![[0, 1, 2], [3, 4, 5]],
    );
    (scene, grid)
}

#[test]
fn triangles_just_inside_the_extent_limit_work() {
    let extent = ((1u64 << 28) - 3) as f64;
    let (scene, grid) = big_triangle(extent);
    let z = |i: u32, j: u32| 100.0 + (i as f64 + 10.5) * 2f64.powi(-20) - (j as f64 + 10.5) * 2f64.powi(-21);
    for mode in Mode::ALL {
        let raster = rasterise(&scene, &params(grid, mode), Backend::Cpu).unwrap_or_else(|e| panic!("[{}] extent {extent}: {e}", mode.name()));
        assert_eq!(raster.snap_bits, 1, "extent {extent}");
        check_consistent("big triangle", &raster).unwrap();
        let coverage = raster.coverage.as_ref().unwrap();
        assert!(coverage.iter().all(|&c| c >= 1), "[{}] the big triangle covers the whole grid", mode.name());
        if mode == Mode::Exact {
            // Cells only triangle 1 covers are its plane, correctly rounded.
            for (j, i) in [(40, 40), (63, 0), (0, 63), (63, 63), (20, 50)] {
                assert_eq!(raster.value(i, j), z(i, j) as f32, "pixel ({i}, {j})");
            }
        }
    }
    if let Some((cpu, _)) = common::assert_parity("triangle at the extent limit", &scene, &params(grid, Mode::Exact)) {
        assert_eq!(cpu.snap_bits, 1);
    }
}

#[test]
fn triangles_beyond_the_extent_limit_are_too_large() {
    let extent = ((1u64 << 28) - 2) as f64;
    let (scene, grid) = big_triangle(extent);
    for backend in [Backend::Cpu, Backend::Gpu] {
        let e = expect_err("beyond the extent limit", rasterise(&scene, &Params::new(grid), backend));
        assert!(matches!(e, Error::TriangleTooLarge { triangle: 1, .. }), "{e:?}");
        assert!(e.to_string().contains("triangle 1 "), "{e}");
    }
}

/// The documented limit is "≤ 2^28 − 3 px", and the error says the triangle spans more than
/// its `limit_px`: exactly the triangles beyond the limit are refused, each with an extent
/// beyond the limit it names.
#[test]
fn the_extent_error_reports_an_extent_beyond_its_limit() {
    let limit = ((1u64 << 28) - 3) as f64;
    let mut failures = vec![];
    for extent in [limit - 0.5, limit, limit + 0.25, limit + 1.0, 3e8] {
        let (scene, grid) = big_triangle(extent);
        match rasterise(&scene, &Params::new(grid), Backend::Cpu) {
            Ok(_) if extent <= limit => {}
            Ok(raster) => failures.push(format!("extent {extent} px was accepted (snap bits {})", raster.snap_bits)),
            Err(Error::TriangleTooLarge { extent_px, limit_px, .. }) if extent_px <= limit_px as f64 || extent <= limit => {
                failures.push(format!("extent {extent} px: refused, saying {extent_px} px is more than {limit_px} px"))
            }
            Err(Error::TriangleTooLarge { limit_px, .. }) if limit_px as f64 != limit => {
                failures.push(format!("extent {extent} px: refused with limit {limit_px} px, not the documented {limit}"))
            }
            Err(Error::TriangleTooLarge { .. }) => {}
            Err(e) => failures.push(format!("extent {extent} px: {e}")),
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn heights_up_to_f32_max_work_and_beyond_are_out_of_range() {
    let max = f32::MAX as f64;
    let grid = Grid::new(0.0, 64.0, 0.0, 64.0, 64, 64);
    let tri = |z: [f64; 3]| Scene::new(vec![[1.0, 1.0, z[0]], [60.0, 3.0, z[1]], [4.0, 62.0, z[2]]], vec![[0, 1, 2]]);
    // Raster-space vertices on a grid of 1-px cells, `side` px a side.
    let raster = |side: u32, uvz: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>| {
        let grid = Grid::new(0.0, side as f64, 0.0, side as f64, side, side);
        (grid, Scene::new(uvz.into_iter().map(|[u, v, z]| [u, side as f64 - v, z]).collect(), triangles))
    };
    let mut cases = vec![];
    for (name, z) in [("flat at f32::MAX", [max; 3]), ("flat at -f32::MAX", [-max; 3]), ("±f32::MAX", [max, -max, max]), ("∓f32::MAX", [-max, max, 0.0])] {
        cases.push((name, grid, tri(z), z[0] == z[1] && z[1] == z[2]));
    }
    // A rectangle of two triangles, flat at f32::MAX (the barycentric weights of pixel (1, 0)
    // of triangle 0 sum to more than 1).
    let (g, scene) = raster(48, vec![[0.0, 0.0, max], [8.0, 0.0, max], [0.0, 36.4034085004024, max], [8.0, 36.4034085004024, max]], vec![[0, 1, 2], [1, 3, 2]]);
    cases.push(("two triangles flat at f32::MAX", g, scene, true));
    // A vertex 3e-6 px right of the centre of pixel (0, 10), at f32::MAX, on a slope of
    // -3.4e37 per px: it snaps onto the centre, which is then covered, though it lies outside
    // the unsnapped triangle, where the plane is 1e32 above f32::MAX.
    let (g, scene) = raster(32, vec![[0.5 + 3e-6, 10.5, max], [20.5, 0.5, -max], [20.5, 20.5, -max]], vec![[0, 1, 2]]);
    cases.push(("vertex at f32::MAX snapped onto a pixel centre", g, scene, false));

    // Inside the f32 modes' range: a flat plane just below 2^127, and a gentle slope at 2^126
    // (plane-f32 also counts the slope across the triangle's rectangle).
    let below = FLOAT_REACH_LIMIT * (1.0 - 2f64.powi(-23));
    cases.push(("flat just below 2^127", grid, tri([below; 3]), true));
    let half = FLOAT_REACH_LIMIT / 2.0;
    cases.push(("sloping below 2^127", grid, tri([half, half * 0.99, half * 0.98]), false));

    let mut failures = vec![];
    for (name, grid, scene, flat) in &cases {
        for mode in Mode::ALL {
            let label = format!("{name} [{}]", mode.name());
            match refused_as_beyond_f32(scene, &params(*grid, mode), None) {
                Ok(false) => {}
                // Heights of 2^127 and more are beyond the f32 modes: they must refuse them.
                Ok(true) if !name.contains("below") => continue,
                Ok(true) => {
                    failures.push(format!("{label}: refused heights below 2^127"));
                    continue;
                }
                Err(e) => {
                    failures.push(format!("{label}: {e}"));
                    continue;
                }
            }
            if mode != Mode::Exact && !name.contains("below") {
                failures.push(format!("{label}: heights of 2^127 and more were not refused"));
            }
            let raster = match rasterise(scene, &params(*grid, mode), Backend::Cpu) {
                Ok(raster) => raster,
                Err(e) => {
                    failures.push(format!("{label}: {e}"));
                    continue;
                }
            };
            for check in [check_consistent(&label, &raster), check_no_overshoot(&label, scene, grid, &raster)] {
                if let Err(e) = check {
                    failures.push(e.to_string());
                }
            }
            // A flat plane is exact in the plane modes; barycentric weights need not sum to 1
            // exactly, so that mode is held to the overshoot bound only.
            if *flat && mode != Mode::Barycentric {
                let z = scene.vertices[0][2] as f32;
                let covered: Vec<f32> = raster.values.iter().copied().filter(|v| v.to_bits() != (-9999.0f32).to_bits()).collect();
                if covered.is_empty() || covered.iter().any(|&v| v != z) {
                    failures.push(format!("{label}: a flat plane at {z:e} is not exact"));
                }
            }
            common::assert_parity(&label, scene, &params(*grid, mode));
        }
    }
    assert!(failures.is_empty(), "{} failures:\n{}", failures.len(), failures.join("\n"));

    for (vertex, value) in [(1usize, 1.0000001 * max), (2, -1.0000001 * max), (0, max * (1.0 + 2f64.powi(-40)))] {
        let mut scene = tri([1.0, 2.0, 3.0]);
        scene.vertices[vertex][2] = value;
        let e = expect_err("height beyond f32", rasterise(&scene, &Params::new(grid), Backend::Cpu));
        assert!(matches!(e, Error::HeightOutOfRange { vertex: v, value: x } if v == vertex && x == value), "{e:?}");
        assert!(e.to_string().contains(&format!("vertex {vertex} ")), "{e}");
    }
}

/// `plane-f32` converts pixel offsets to `f32`, exactly up to `2^24`: a triangle whose pixel
/// centres span `2^24 + 1` columns works on both backends, within the mode's bound at its far
/// end; one column more is refused in that mode (and only in that mode).
#[test]
fn plane_f32_takes_triangles_up_to_2_pow_24_plus_1_columns() {
    let limit = (1u32 << 24) + 1;
    let n = limit + 8;
    let grid = Grid::new(0.0, n as f64, 0.0, 8.0, n, 8);
    // Top edge along row 0, right edge vertical: centres in columns 0 ..= columns - 1.
    let triangle = |columns: u32| {
        let right = columns as f64 - 0.25;
        Scene::new(vec![[0.25, 8.0, 1.0], [right, 8.0, 2.0], [right, 0.0, 3.0]], vec![[0, 1, 2]])
    };
    let window = |columns: u32| Some(Window { x0: columns - 32, y0: 0, width: 32, height: 8 });

    let scene = triangle(limit);
    let exact = rasterise_window(&scene, &params(grid, Mode::Exact), window(limit), Backend::Cpu).expect("exact mode");
    let mut backends = vec![Backend::Cpu];
    if common::gpu_or_skip("plane-f32 at 2^24 + 1 columns") {
        backends.push(Backend::Gpu);
    }
    let mut rasters = vec![];
    for backend in backends {
        let raster = rasterise_window(&scene, &params(grid, Mode::PlaneF32), window(limit), backend)
            .unwrap_or_else(|e| panic!("{}: {limit} columns must be accepted: {e}", backend.name()));
        check_consistent("plane-f32 at the offset limit", &raster).unwrap();
        let coverage = raster.coverage.as_ref().unwrap();
        assert!(coverage.contains(&1), "the window shows none of the triangle");
        // S ≤ 3 + 1 + 2: the heights and the plane's rise across the rectangle.
        for (k, (&v, &e)) in raster.values.iter().zip(&exact.values).enumerate() {
            if coverage[k] > 0 {
                assert!((v as f64 - e as f64).abs() <= 6.0 * 2f64.powi(-21), "{}: cell {k}: {v} against exact {e}", backend.name());
            }
        }
        rasters.push(raster);
    }
    if let [cpu, gpu] = &rasters[..] {
        assert_eq!(cpu.compare_bits(gpu, 4).0, 0, "plane-f32 at {limit} columns: CPU and GPU differ");
    }

    let wider = triangle(limit + 1);
    let e = expect_err("plane-f32 beyond the offset limit", rasterise_window(&wider, &params(grid, Mode::PlaneF32), window(limit + 1), Backend::Cpu));
    assert!(matches!(e, Error::TooWideForMode { triangle: 0, extent_px, limit_px, .. } if extent_px == limit as u64 + 1 && limit_px == limit as u64), "{e:?}");
    assert!(e.to_string().contains("use the exact mode"), "{e}");
    for mode in [Mode::Exact, Mode::Barycentric] {
        rasterise_window(&wider, &params(grid, mode), window(limit + 1), Backend::Cpu).unwrap_or_else(|e| panic!("[{}] has no offset limit: {e}", mode.name()));
    }
}

#[test]
fn non_finite_coordinates_are_named() {
    let grid = Grid::new(0.0, 16.0, 0.0, 16.0, 16, 16);
    let base = Scene::new((0..8).map(|k| [k as f64, (k * k % 16) as f64, k as f64]).collect(), vec![[0, 1, 2], [2, 3, 4], [4, 5, 6], [5, 6, 7]]);
    for vertex in [0usize, 3, 7] {
        for (axis, name) in ['x', 'y', 'z'].into_iter().enumerate() {
            for value in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
                let mut scene = base.clone();
                scene.vertices[vertex][axis] = value;
                let e = expect_err("non-finite", rasterise(&scene, &Params::new(grid), Backend::Cpu));
                assert!(matches!(e, Error::NonFiniteCoordinate { vertex: v, axis: a, .. } if v == vertex && a == name), "{e:?}");
                let text = e.to_string();
                assert!(text.contains(&format!("vertex {vertex} ")) && text.contains(&format!("{name} coordinate")), "{text}");
            }
        }
    }
}

/// A case the property tests found: a plane-f32 triangle with subnormal heights whose f32
/// coefficients, rounded absolutely, overshoot by tens of subnormal steps at a far pixel
/// (docs/numeric-contract.md §6).
#[test]
fn subnormal_plane_f32_stays_within_its_absolute_bound() {
    let grid = Grid::new(0.0, 63.0 * 0.05, 4_000_000.0, 4_000_000.0 + 152.0 * 0.025, 63, 152);
    let scene = Scene::new(
        vec![
            [1.684500967003627, 4000003.8, 1.3991397889882268e-39],
            [0.7772162573954957, 3999999.791050389, 0.0],
            [3.8002733566193587, 4000002.9320051474, 0.0],
        ],
        vec![[0, 1, 2]],
    );
    let params = Params::new(grid).with_mode(Mode::PlaneF32).with_outputs(Outputs { owner: true, coverage: true, tiles: false });
    let raster = rasterise(&scene, &params, Backend::Cpu).unwrap();
    let value = raster.value(40, 108);
    assert!(raster.owner.as_ref().unwrap()[108 * 63 + 40] == 0, "the triangle covers pixel (40, 108)");
    eprintln!("pixel (40, 108) = {value:e}");
    check_no_overshoot("subnormal plane-f32", &scene, &grid, &raster).unwrap();
}
