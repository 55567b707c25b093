//! Turns arbitrary bytes into a small scene, a grid and a value mode, rasterises them on the
//! CPU and checks the outcome: a typed error, or a raster whose cells are all nodata or
//! finite, with owner and coverage agreeing (coverage 0 ⇔ no owner), and bit for bit the
//! raster the pipeline gives with none of its skips.
//!
//! Shared by the cargo-fuzz target (`rasterise.rs`) and by `tests/fuzz_corpus.rs`, so it
//! depends on nothing but `tileraster-core` and `tileraster-cpu` (no GPU build to fuzz).
//!
//! Layout: a header (grid, mode, nodata, counts), then the vertices, then the triangles. Each
//! number starts with a selector byte: its high, rare values take raw `f64` bits (NaN, ±∞,
//! huge, subnormal), special values or points far away, the others values a scene would have
//! (on the grid, on pixel centres, on a fine lattice, repeating an earlier vertex); index
//! byte 255 is out of range. Past the end of the input every byte reads as zero.

#![allow(dead_code)]

use tileraster_core::{Error, Grid, Mode, Outputs, Params, Raster, Scene, Skips};

/// The CPU backend, as `tileraster::rasterise(.., Backend::Cpu)` runs it.
fn rasterise(scene: &Scene, params: &Params) -> Result<Raster, Error> {
    tileraster_cpu::rasterise(&tileraster_core::prepare(scene, params, None)?)
}

pub const MAX_VERTICES: usize = 64;
pub const MAX_TRIANGLES: usize = 64;
pub const MAX_SIDE: u32 = 128;

/// What one input decodes to.
#[derive(Debug, Clone)]
pub struct Case {
    pub scene: Scene,
    pub params: Params,
}

struct Bytes<'a>(&'a [u8]);

impl Bytes<'_> {
    fn u8(&mut self) -> u8 {
        match self.0.split_first() {
            Some((&b, rest)) => {
                self.0 = rest;
                b
            }
            None => 0,
        }
    }

    fn u16(&mut self) -> u16 {
        u16::from_le_bytes([self.u8(), self.u8()])
    }

    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.u8(), self.u8(), self.u8(), self.u8()])
    }

    fn u64(&mut self) -> u64 {
        (self.u32() as u64) | (self.u32() as u64) << 32
    }

    fn raw(&mut self) -> f64 {
        f64::from_bits(self.u64())
    }

    /// `[0, 1]`.
    fn unit(&mut self) -> f64 {
        self.u16() as f64 / u16::MAX as f64
    }
}

const F32_MAX: f64 = f32::MAX as f64;

/// Values that tend to break things.
const SPECIAL: [f64; 20] = [
    f64::NAN,
    f64::INFINITY,
    f64::NEG_INFINITY,
    0.0,
    -0.0,
    f64::MAX,
    f64::MIN,
    f64::MIN_POSITIVE,
    5e-324,
    1e-300,
    1e300,
    -1e300,
    F32_MAX,
    -F32_MAX,
    F32_MAX * 1.0000001,
    1e-45,
    9_007_199_254_740_993.0,
    1e9,
    -1e9,
    0.5,
];

fn grid(b: &mut Bytes) -> Grid {
    let width = b.u8() as u32 % (MAX_SIDE + 1);
    let height = b.u8() as u32 % (MAX_SIDE + 1);
    if b.u8() >= 248 {
        return Grid::new(b.raw(), b.raw(), b.raw(), b.raw(), width, height);
    }
    let scale = |b: &mut Bytes| 2f64.powi(b.u8() as i32 % 48 - 20) * (1.0 + b.u8() as f64 / 256.0);
    let x0 = b.u16() as i16 as f64 * scale(b);
    let y0 = b.u16() as i16 as f64 * scale(b);
    let (dx, dy) = (scale(b), scale(b));
    Grid::new(x0, x0 + width as f64 * dx, y0, y0 + height as f64 * dy, width, height)
}

/// One coordinate along an axis of the grid: `lo` is the side where pixel 0 starts, `step`
/// the signed cell size towards the other side, `n` the number of cells; `earlier` holds the
/// same coordinate of the vertices decoded so far.
fn coordinate(b: &mut Bytes, lo: f64, step: f64, n: u32, earlier: &[f64]) -> f64 {
    let span = step * n.max(1) as f64;
    match b.u8() {
        255 => b.raw(),
        254 => SPECIAL[b.u8() as usize % SPECIAL.len()],
        // Far from the grid, in whole cells.
        252..=253 => lo + (b.u16() as i16 as f64) * step * 2f64.powi(b.u8() as i32 % 40),
        // A pixel centre.
        200..=251 => lo + (b.u8() as f64 % (n.max(1) as f64 + 2.0) - 1.0 + 0.5) * step,
        // A lattice point: 1/64 px.
        150..=199 => lo + (b.u16() as f64 / 64.0 - 8.0) * step,
        // An earlier vertex's.
        100..=149 if !earlier.is_empty() => earlier[b.u8() as usize % earlier.len()],
        // On and around the grid.
        _ => lo + (b.unit() * 1.4 - 0.2) * span,
    }
}

fn height(b: &mut Bytes) -> f64 {
    match b.u8() {
        255 => b.raw(),
        254 => SPECIAL[b.u8() as usize % SPECIAL.len()],
        250..=253 => [F32_MAX, -F32_MAX, F32_MAX * (1.0 - 1e-7), -F32_MAX * 0.5][b.u8() as usize % 4],
        245..=249 => b.u16() as i16 as f64 * 1e-42,
        240..=244 => b.u16() as i16 as f64 * 1e30,
        _ => b.u16() as i16 as f64 / 16.0,
    }
}

pub fn decode(data: &[u8]) -> Case {
    let mut b = Bytes(data);
    let grid = grid(&mut b);
    let mode = Mode::ALL[b.u8() as usize % Mode::ALL.len()];
    let nodata = match b.u8() % 4 {
        0 => f32::NAN,
        1 => -9999.0,
        2 => f32::from_bits(b.u32()),
        _ => 0.0,
    };
    let vertex_count = b.u8() as usize % (MAX_VERTICES + 1);
    let triangle_count = b.u8() as usize % (MAX_TRIANGLES + 1);

    let (dx, dy) = ((grid.xmax - grid.xmin) / grid.width.max(1) as f64, (grid.ymax - grid.ymin) / grid.height.max(1) as f64);
    let (mut xs, mut ys) = (Vec::new(), Vec::new());
    let mut vertices = Vec::with_capacity(vertex_count);
    for _ in 0..vertex_count {
        let x = coordinate(&mut b, grid.xmin, dx, grid.width, &xs);
        let y = coordinate(&mut b, grid.ymax, -dy, grid.height, &ys);
        xs.push(x);
        ys.push(y);
        vertices.push([x, y, height(&mut b)]);
    }
    let n = vertex_count as u32;
    let triangles = (0..triangle_count)
        .map(|_| {
            [(); 3].map(|_| match b.u8() {
                // Out of range, just or far.
                255 => {
                    if b.u8() % 2 == 0 {
                        n
                    } else {
                        b.u32()
                    }
                }
                k if n > 0 => k as u32 % n,
                k => k as u32,
            })
        })
        .collect();
    Case {
        scene: Scene::new(vertices, triangles),
        params: Params::new(grid).with_mode(mode).with_nodata(nodata).with_outputs(Outputs { owner: true, coverage: true, tiles: true }),
    }
}

/// How a case that passed its checks came out.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// A typed error: its variant's name.
    Refused(String),
    /// A raster with this many covered cells.
    Rasterised(usize),
}

/// Rasterise `case` on the CPU; what is wrong with the outcome, if anything. (A panic inside
/// `rasterise` passes through.)
pub fn check(case: &Case) -> Result<Outcome, String> {
    let scene = &case.scene;
    match rasterise(scene, &case.params) {
        Err(e @ (Error::NoAdapter { .. } | Error::Gpu(_))) => Err(format!("the CPU backend gave a GPU error: {e}")),
        Err(e) => {
            if e.to_string().is_empty() {
                return Err(format!("{e:?} has no message"));
            }
            let debug = format!("{e:?}");
            Ok(Outcome::Refused(debug.split([' ', '(', '{']).next().unwrap_or_default().to_string()))
        }
        Ok(raster) => {
            let n = scene.vertices.len();
            if let Some(v) = scene.vertices.iter().position(|v| v.iter().any(|c| !c.is_finite())) {
                return Err(format!("accepted vertex {v} with a non-finite coordinate: {:?}", scene.vertices[v]));
            }
            if let Some(v) = scene.vertices.iter().position(|v| v[2].abs() > F32_MAX) {
                return Err(format!("accepted vertex {v} with height {:e}, beyond f32", scene.vertices[v][2]));
            }
            if let Some(t) = scene.triangles.iter().position(|t| t.iter().any(|&k| k as usize >= n)) {
                return Err(format!("accepted triangle {t} {:?} with only {n} vertices", scene.triangles[t]));
            }
            let cells = case.params.grid.width as usize * case.params.grid.height as usize;
            let (owner, coverage) = match (&raster.owner, &raster.coverage) {
                (Some(o), Some(c)) if o.len() == cells && c.len() == cells && raster.values.len() == cells => (o, c),
                _ => return Err(format!("the raster's layers do not have {cells} cells each")),
            };
            let width = case.params.grid.width as usize;
            for (k, value) in raster.values.iter().enumerate() {
                let (i, j) = (k % width, k / width);
                if (coverage[k] == 0) != (owner[k] == u32::MAX) {
                    return Err(format!("pixel ({i}, {j}): coverage {} but owner {}", coverage[k], owner[k]));
                }
                if coverage[k] == 0 {
                    if value.to_bits() != case.params.nodata.to_bits() {
                        return Err(format!("uncovered pixel ({i}, {j}) holds {value:e}, not nodata"));
                    }
                } else {
                    if owner[k] as usize >= scene.triangles.len() || coverage[k] as usize > scene.triangles.len() {
                        return Err(format!("pixel ({i}, {j}): owner {} and coverage {} with {} triangles", owner[k], coverage[k], scene.triangles.len()));
                    }
                    if !value.is_finite() {
                        let tri = scene.triangles[owner[k] as usize];
                        return Err(format!(
                            "[{}] pixel ({i}, {j}) holds {value}, owned by triangle {} {:?}",
                            case.params.mode.name(),
                            owner[k],
                            tri.map(|v| scene.vertices[v as usize])
                        ));
                    }
                }
            }
            // Every skip is exact: without any, the same bits (an unsound overlap proof would
            // show here as another owner or count).
            match rasterise(scene, &case.params.with_skips(Skips::NONE)) {
                Ok(plain) => {
                    let (differing, first) = raster.compare_bits(&plain, 1);
                    if differing > 0 {
                        return Err(format!("{differing} cells change when nothing is skipped; first: {}", first[0]));
                    }
                }
                Err(e) => return Err(format!("rasterised with the skips, but without them: {e}")),
            }
            Ok(Outcome::Rasterised(coverage.iter().filter(|&&c| c > 0).count()))
        }
    }
}
