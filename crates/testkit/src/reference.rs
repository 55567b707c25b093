//! An independent f64 reference for measuring accuracy: for every cell centre, the
//! lowest-index triangle of the *unsnapped* mesh containing it (edges inclusive), and the
//! height of that triangle's plane there, evaluated in world coordinates. It shares no code
//! with the preparation or the kernels.

use crate::{Grid, Raster, Scene};

pub struct Reference {
    /// Per cell: `(triangle, height)` or `None` outside the mesh.
    pub cells: Vec<Option<(u32, f64)>>,
}

/// Height at `(x, y)` of the plane through triangle `t`'s vertices (world coordinates).
pub fn plane_at(scene: &Scene, t: [u32; 3], x: f64, y: f64) -> f64 {
    let [p0, p1, p2] = t.map(|k| scene.vertices[k as usize]);
    let (ax, ay, az) = (p1[0] - p0[0], p1[1] - p0[1], p1[2] - p0[2]);
    let (bx, by, bz) = (p2[0] - p0[0], p2[1] - p0[1], p2[2] - p0[2]);
    let det = ax * by - ay * bx;
    let gx = (az * by - ay * bz) / det;
    let gy = (ax * bz - az * bx) / det;
    p0[2] + gx * (x - p0[0]) + gy * (y - p0[1])
}

/// Whether `(x, y)` lies in the triangle, edges included (orientation-independent).
fn contains(scene: &Scene, t: [u32; 3], x: f64, y: f64) -> bool {
    let p = t.map(|k| scene.vertices[k as usize]);
    let side = |a: [f64; 3], b: [f64; 3]| (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]);
    let (s0, s1, s2) = (side(p[0], p[1]), side(p[1], p[2]), side(p[2], p[0]));
    (s0 >= 0.0 && s1 >= 0.0 && s2 >= 0.0) || (s0 <= 0.0 && s1 <= 0.0 && s2 <= 0.0)
}

/// Whether triangle `t` has no area in f64.
pub fn degenerate(scene: &Scene, t: [u32; 3]) -> bool {
    let p = t.map(|k| scene.vertices[k as usize]);
    (p[1][0] - p[0][0]) * (p[2][1] - p[0][1]) - (p[1][1] - p[0][1]) * (p[2][0] - p[0][0]) == 0.0
}

impl Reference {
    pub fn new(scene: &Scene, grid: &Grid) -> Self {
        let (w, h) = (grid.width as usize, grid.height as usize);
        let mut cells: Vec<Option<(u32, f64)>> = vec![None; w * h];
        for (index, &t) in scene.triangles.iter().enumerate() {
            if degenerate(scene, t) {
                continue;
            }
            let r = t.map(|k| grid.to_raster(scene.vertices[k as usize][0], scene.vertices[k as usize][1]));
            let lo = |a: f64, b: f64, c: f64| (a.min(b).min(c) - 1.0).floor().max(0.0) as usize;
            let hi = |a: f64, b: f64, c: f64, n: usize| ((a.max(b).max(c) + 1.0).ceil().max(0.0) as usize).min(n);
            for j in lo(r[0].1, r[1].1, r[2].1)..hi(r[0].1, r[1].1, r[2].1, h) {
                for i in lo(r[0].0, r[1].0, r[2].0)..hi(r[0].0, r[1].0, r[2].0, w) {
                    let cell = &mut cells[j * w + i];
                    if cell.is_some() {
                        continue; // a lower index already owns it
                    }
                    let (x, y) = grid.cell_centre(i as u32, j as u32);
                    if contains(scene, t, x, y) {
                        *cell = Some((index as u32, plane_at(scene, t, x, y)));
                    }
                }
            }
        }
        Reference { cells }
    }
}

/// `|value − reference|` in units of the f32 spacing at the reference value.
pub fn ulps(value: f32, reference: f64) -> f64 {
    let r = reference.abs().max(f32::MIN_POSITIVE as f64);
    let exponent = r.log2().floor() as i32;
    let spacing = 2f64.powi(exponent - 23).max(2f64.powi(-149));
    (value as f64 - reference).abs() / spacing
}

/// Error statistics of a raster against the reference over the cells both cover.
#[derive(Debug, Default)]
pub struct Accuracy {
    pub compared: u64,
    pub within_half_ulp: u64,
    pub within_one_ulp: u64,
    /// Cells equal to the reference rounded to the nearest `f32`.
    pub exact: u64,
    pub max_ulps: f64,
    pub rms_ulps: f64,
    /// Cells covered by exactly one of raster and reference.
    pub coverage_mismatches: u64,
}

impl Accuracy {
    pub fn share_within_one_ulp(&self) -> f64 {
        self.within_one_ulp as f64 / self.compared.max(1) as f64
    }

    pub fn share_exact(&self) -> f64 {
        self.exact as f64 / self.compared.max(1) as f64
    }
}

pub fn accuracy(raster: &Raster, reference: &Reference) -> Accuracy {
    let mut a = Accuracy::default();
    let mut sum_sq = 0.0;
    for (k, cell) in reference.cells.iter().enumerate() {
        let v = raster.values[k];
        let covered = v.to_bits() != raster.nodata.to_bits();
        match (cell, covered) {
            (Some((_, z)), true) => {
                let e = ulps(v, *z);
                a.compared += 1;
                a.within_half_ulp += (e <= 0.5) as u64;
                a.within_one_ulp += (e <= 1.0) as u64;
                a.exact += (v == *z as f32) as u64;
                a.max_ulps = a.max_ulps.max(e);
                sum_sq += e * e;
            }
            (None, false) => {}
            _ => a.coverage_mismatches += 1,
        }
    }
    a.rms_ulps = (sum_sq / a.compared.max(1) as f64).sqrt();
    a
}
