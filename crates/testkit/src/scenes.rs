//! Procedurally generated scenes: the demo's terrain and the test and benchmark meshes.
//! Deterministic for a given seed, no data files needed.

use crate::{Grid, Scene};

/// Twelve points on the circle of radius 5 about the origin, all with integer coordinates
/// (Pythagorean triples): exactly cocircular, the hardest tie a Delaunay triangulation meets.
pub const TWELVE_ON_A_CIRCLE: [(f64, f64); 12] =
    [(3.0, 4.0), (4.0, 3.0), (-3.0, 4.0), (-4.0, 3.0), (3.0, -4.0), (4.0, -3.0), (-3.0, -4.0), (-4.0, -3.0), (0.0, 5.0), (5.0, 0.0), (0.0, -5.0), (-5.0, 0.0)];

/// SplitMix64: tiny, fast and good enough for test geometry.
#[derive(Debug, Clone)]
pub struct Rng(u64);

impl Rng {
    pub fn new(seed: u64) -> Self {
        Rng(seed)
    }

    pub fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// Uniform in `[0, 1)`.
    pub fn unit(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `[lo, hi)`.
    pub fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }
}

/// Smooth rolling terrain heights around `base`: octaves of plane waves in random
/// directions, each octave half the wavelength and a little under half the amplitude.
pub struct Heights {
    /// `[amplitude, kx, ky, phase]` per wave.
    waves: Vec<[f64; 4]>,
    base: f64,
}

impl Heights {
    pub fn new(seed: u64, base: f64, relief: f64, wavelength: f64) -> Self {
        let mut rng = Rng::new(seed ^ 0x4845_4947_4854);
        let mut waves = Vec::new();
        for octave in 0..5 {
            let k = std::f64::consts::TAU / wavelength * 2f64.powi(octave);
            let a = relief * 0.35f64.powi(octave) / 2.0;
            for _ in 0..3 {
                let dir = rng.range(0.0, std::f64::consts::TAU);
                let k = k * rng.range(0.8, 1.25);
                waves.push([a * rng.range(0.6, 1.0), k * dir.cos(), k * dir.sin(), rng.range(0.0, std::f64::consts::TAU)]);
            }
        }
        Heights { waves, base }
    }

    pub fn at(&self, x: f64, y: f64) -> f64 {
        self.base + self.waves.iter().map(|w| w[0] * (w[1] * x + w[2] * y + w[3]).sin()).sum::<f64>()
    }
}

/// A terrain TIN covering `[x0, x0 + width] × [y0, y0 + height]` exactly: a lattice of
/// `cols × rows` cells with interior vertices jittered (by at most a fifth of a cell, which
/// keeps every cell convex), each cell split along a random diagonal.
pub fn terrain(x0: f64, y0: f64, width: f64, height: f64, cols: u32, rows: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let heights = Heights::new(seed, 500.0, 120.0, width.max(height) / 1.5);
    let (cw, ch) = (width / cols as f64, height / rows as f64);
    let mut vertices = Vec::with_capacity(((cols + 1) * (rows + 1)) as usize);
    for r in 0..=rows {
        for c in 0..=cols {
            let jx = if c == 0 || c == cols { 0.0 } else { rng.range(-0.2, 0.2) * cw };
            let jy = if r == 0 || r == rows { 0.0 } else { rng.range(-0.2, 0.2) * ch };
            let (x, y) = (x0 + c as f64 * cw + jx, y0 + r as f64 * ch + jy);
            vertices.push([x, y, heights.at(x - x0, y - y0)]);
        }
    }
    let triangles = lattice_triangles(cols, rows, |_, _| rng.next_u64() & 1 == 0);
    Scene::new(vertices, triangles)
}

/// [`terrain`]'s points triangulated as Delaunay would: every cell split along the diagonal
/// that keeps the fourth corner out of the other triangle's circumcircle. With jitter this
/// small the lattice edges are Delaunay edges too, so a Delaunay triangulator given the same
/// points (gdal_grid's, for one) builds this very mesh, ties aside.
pub fn delaunay_terrain(x0: f64, y0: f64, width: f64, height: f64, cols: u32, rows: u32, seed: u64) -> Scene {
    let mut scene = terrain(x0, y0, width, height, cols, rows, seed);
    let v = &scene.vertices;
    let at = |c: u32, r: u32| v[(r * (cols + 1) + c) as usize];
    scene.triangles = lattice_triangles(cols, rows, |c, r| {
        // Diagonal a–e is Delaunay when d lies outside the circumcircle of (a, b, e).
        let (a, b, d, e) = (at(c, r), at(c + 1, r), at(c, r + 1), at(c + 1, r + 1));
        !in_circle(a, b, e, d)
    });
    scene
}

/// Whether `p` lies strictly inside the circumcircle of the counter-clockwise or clockwise
/// triangle `(a, b, c)` (relative coordinates keep the f64 determinant accurate).
fn in_circle(a: [f64; 3], b: [f64; 3], c: [f64; 3], p: [f64; 3]) -> bool {
    let d = |q: [f64; 3]| (q[0] - p[0], q[1] - p[1]);
    let ((ax, ay), (bx, by), (cx, cy)) = (d(a), d(b), d(c));
    let det = (ax * ax + ay * ay) * (bx * cy - cx * by) - (bx * bx + by * by) * (ax * cy - cx * ay) + (cx * cx + cy * cy) * (ax * by - bx * ay);
    let orientation = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
    det * orientation.signum() > 0.0
}

/// Triangles of a `(cols + 1) × (rows + 1)` vertex lattice (row-major), each cell split along
/// its main diagonal when `main_diagonal(c, r)` says so, else along the other one.
pub fn lattice_triangles(cols: u32, rows: u32, mut main_diagonal: impl FnMut(u32, u32) -> bool) -> Vec<[u32; 3]> {
    let mut triangles = Vec::with_capacity((2 * cols * rows) as usize);
    let at = |c: u32, r: u32| r * (cols + 1) + c;
    for r in 0..rows {
        for c in 0..cols {
            let (a, b, d, e) = (at(c, r), at(c + 1, r), at(c, r + 1), at(c + 1, r + 1));
            if main_diagonal(c, r) {
                triangles.push([a, b, e]);
                triangles.push([a, e, d]);
            } else {
                triangles.push([a, b, d]);
                triangles.push([b, e, d]);
            }
        }
    }
    triangles
}

/// A TIN whose vertices sit exactly on pixel centres of `grid`, every `step` pixels, with
/// random heights: edges and vertices run through pixel centres everywhere.
pub fn centre_lattice(grid: &Grid, step: u32, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let cols = (grid.width - 1) / step;
    let rows = (grid.height - 1) / step;
    let mut vertices = Vec::new();
    for r in 0..=rows {
        for c in 0..=cols {
            let (x, y) = grid.cell_centre(c * step, r * step);
            vertices.push([x, y, rng.range(100.0, 200.0)]);
        }
    }
    Scene::new(vertices, lattice_triangles(cols, rows, |c, r| (c + r) % 2 == 0))
}

/// `n` thin triangles fanned all the way around the centre of pixel `(i, j)` of `grid`,
/// closing on themselves: the centre pixel must be owned by exactly one of them.
pub fn fan(grid: &Grid, i: u32, j: u32, n: u32, radius_px: f64, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let (cx, cy) = grid.cell_centre(i, j);
    let mut vertices = vec![[cx, cy, 250.0]];
    let phase = rng.range(0.0, 1.0);
    for k in 0..n {
        let a = std::f64::consts::TAU * (k as f64 + phase) / n as f64;
        let r = radius_px * rng.range(0.8, 1.2);
        vertices.push([cx + r * a.cos() * grid.dx(), cy + r * a.sin() * grid.dy(), rng.range(200.0, 300.0)]);
    }
    let triangles = (0..n).map(|k| [0, 1 + k, 1 + (k + 1) % n]).collect();
    Scene::new(vertices, triangles)
}

/// Slivers: a wedge from one apex to `n` points packed `spacing_px` apart along a far
/// vertical line, so every triangle is long and thin, and they tile the wedge.
pub fn sliver_wedge(grid: &Grid, n: u32, spacing_px: f64, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let (ax, ay) = grid.cell_centre(1, grid.height / 2);
    let far_x = grid.xmin + (grid.width as f64 - 1.3) * grid.dx();
    let top = ay + 0.5 * n as f64 * spacing_px * grid.dy();
    let mut vertices = vec![[ax, ay + 0.37 * grid.dy(), 300.0]];
    for k in 0..=n {
        vertices.push([far_x, top - k as f64 * spacing_px * grid.dy(), rng.range(250.0, 350.0)]);
    }
    let triangles = (0..n).map(|k| [0, 1 + k, 2 + k]).collect();
    Scene::new(vertices, triangles)
}

/// `n` random triangles anywhere over (and a little beyond) `grid`, overlapping freely.
pub fn triangle_soup(grid: &Grid, n: u32, max_size_px: f64, seed: u64) -> Scene {
    let mut rng = Rng::new(seed);
    let mut vertices = Vec::new();
    let mut triangles = Vec::new();
    for t in 0..n {
        let cx = rng.range(grid.xmin - 2.0 * grid.dx(), grid.xmax + 2.0 * grid.dx());
        let cy = rng.range(grid.ymin - 2.0 * grid.dy(), grid.ymax + 2.0 * grid.dy());
        for _ in 0..3 {
            let x = cx + rng.range(-0.5, 0.5) * max_size_px * grid.dx();
            let y = cy + rng.range(-0.5, 0.5) * max_size_px * grid.dy();
            vertices.push([x, y, rng.range(-50.0, 50.0)]);
        }
        triangles.push([3 * t, 3 * t + 1, 3 * t + 2]);
    }
    Scene::new(vertices, triangles)
}

/// The seed design's benchmark: two triangles forming a sloping plane over the unit square
/// (grid it with `Grid::new(0.0, 1.0, 0.0, 1.0, n, n)`).
pub fn sloping_plane() -> Scene {
    Scene::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 10.0], [1.0, 1.0, 30.0], [0.0, 1.0, 20.0]], vec![[0, 1, 2], [0, 2, 3]])
}

/// A terrain TIN over `[0, size]²` whose triangles cover `triangle_px` pixels each on a
/// `size`² grid of unit cells (two per lattice cell), with that grid.
pub fn micro_triangles(size: u32, triangle_px: f64, seed: u64) -> (Scene, Grid) {
    let cols = (size as f64 / (2.0 * triangle_px).sqrt()).round() as u32;
    let extent = size as f64;
    (terrain(0.0, 0.0, extent, extent, cols, cols, seed), Grid::new(0.0, extent, 0.0, extent, size, size))
}
