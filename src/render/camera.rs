//! Cameras: a look-at view with a perspective projection, in Vulkan's conventions (depth 0 at
//! the near plane and 1 at the far plane, NDC `y` down the image, so world "up" is up on the
//! screen).

use super::Mesh;
use crate::Error;

/// A perspective camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    /// Vertical field of view, degrees.
    pub fov_deg: f64,
    /// Near and far planes' distances from the eye (`0 < near < far`).
    pub near: f64,
    pub far: f64,
}

impl Camera {
    /// A camera at `eye` looking at `target`, near and far planes fitted to `mesh`'s bounding
    /// sphere.
    pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3], fov_deg: f64, mesh: &Mesh) -> Camera {
        let (centre, radius) = bounding_sphere(mesh);
        let distance = norm(sub(centre, eye));
        let far = (distance + radius) * 1.01;
        let near = (distance - radius).max(far * 1e-4);
        Camera { eye, target, up, fov_deg, near, far }
    }

    /// A camera that frames the whole mesh for a frame of aspect `aspect` (width / height):
    /// looking at its bounding sphere's centre from the front-right and above (`+z` up for
    /// terrain-like meshes, whose largest extent is horizontal; `+y` up otherwise).
    pub fn framing(mesh: &Mesh, aspect: f64, fov_deg: f64) -> Camera {
        let (centre, radius) = bounding_sphere(mesh);
        let radius = if radius > 0.0 { radius } else { 1.0 };
        let (lo, hi) = bounds(mesh);
        let extent = sub(hi, lo);
        let z_up = extent[2] < 0.5 * extent[0].max(extent[1]);
        let (up, direction) = if z_up { ([0.0, 0.0, 1.0], [0.55, -0.65, 0.52]) } else { ([0.0, 1.0, 0.0], [0.5, 0.45, 0.74]) };
        let d = scale(direction, 1.0 / norm(direction));
        let tan_half = (fov_deg.to_radians() / 2.0).tan();
        // Far enough that the bounding sphere fits the narrower field of view...
        let mut distance = radius / tan_half.min(tan_half * aspect).atan().sin() * 1.05;
        let camera_at = |distance: f64| {
            let eye = [centre[0] + d[0] * distance, centre[1] + d[1] * distance, centre[2] + d[2] * distance];
            Camera { eye, target: centre, up, fov_deg, near: (distance - radius).max(distance * 1e-3), far: distance + radius * 1.01 }
        };
        // ... then closer, until the bounding box's corners fill 90 % of the frame (the
        // corners' spread on the screen grows about as the inverse of the distance).
        let corners: Vec<[f64; 3]> =
            (0..8).map(|k| [if k & 1 == 0 { lo[0] } else { hi[0] }, if k & 2 == 0 { lo[1] } else { hi[1] }, if k & 4 == 0 { lo[2] } else { hi[2] }]).collect();
        let (w, h) = if aspect >= 1.0 { ((1000.0 * aspect) as u32, 1000) } else { (1000, (1000.0 / aspect) as u32) };
        for _ in 0..4 {
            let Ok(m) = camera_at(distance).view_projection(w.max(1), h.max(1)) else { break };
            let spread = corners
                .iter()
                .map(|p| {
                    let c = [0, 1, 3].map(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
                    (c[0] / c[2]).abs().max((c[1] / c[2]).abs())
                })
                .fold(0.0f64, f64::max);
            if !(spread.is_finite() && spread > 0.0) {
                break;
            }
            distance *= (spread / 0.9).clamp(0.5, 1.0);
        }
        camera_at(distance)
    }

    /// World to clip space for a `width` × `height` frame, row-major.
    pub fn view_projection(&self, width: u32, height: u32) -> Result<[[f64; 4]; 4], Error> {
        if width == 0 || height == 0 {
            return Err(Error::ZeroSizedRaster { width: width as u64, height: height as u64 });
        }
        let singular = |reason: &str| Err(Error::SingularCamera { reason: reason.into() });
        // The checks run from what the caller chose (the field of view) to what follows from
        // it, so that each names its own cause: a field of view of 0 frames a mesh from
        // infinitely far, which would otherwise read as a degenerate up vector.
        if !(self.fov_deg > 0.0 && self.fov_deg < 180.0) {
            return singular("the field of view must lie strictly between 0 and 180 degrees");
        }
        if !self.eye.iter().chain(&self.target).chain(&self.up).all(|c| c.is_finite()) {
            return Err(Error::SingularCamera {
                reason: format!(
                    "the eye {:?}, target {:?} or up {:?} is not finite (framing a mesh whose extent f64 cannot hold gives that: scale the mesh down)",
                    self.eye, self.target, self.up
                ),
            });
        }
        let forward = sub(self.target, self.eye);
        if norm(forward).is_nan() || norm(forward) <= 0.0 {
            return singular("the eye and the target are the same point; move the eye");
        }
        let f = scale(forward, 1.0 / norm(forward));
        let side = cross(f, self.up);
        if norm(side).is_nan() || norm(side) <= 1e-12 * norm(self.up) {
            return singular("the up vector is parallel to the viewing direction (or zero); choose another up");
        }
        if !(self.near > 0.0 && self.far > self.near) || !self.far.is_finite() {
            return singular("the near and far planes must satisfy 0 < near < far");
        }
        let r = scale(side, 1.0 / norm(side));
        let u = cross(r, f);
        // View: x right, y down (Vulkan's NDC), z forward.
        let t = |a: [f64; 3]| -(a[0] * self.eye[0] + a[1] * self.eye[1] + a[2] * self.eye[2]);
        let view = [[r[0], r[1], r[2], t(r)], [-u[0], -u[1], -u[2], -t(u)], [f[0], f[1], f[2], t(f)], [0.0, 0.0, 0.0, 1.0]];
        let sy = 1.0 / (self.fov_deg.to_radians() / 2.0).tan();
        let sx = sy * height as f64 / width as f64;
        let (n, fa) = (self.near, self.far);
        // z_clip = far/(far − near) · (z − near), w = z: depth 0 at near, 1 at far.
        let a = fa / (fa - n);
        let proj = [[sx, 0.0, 0.0, 0.0], [0.0, sy, 0.0, 0.0], [0.0, 0.0, a, -a * n], [0.0, 0.0, 1.0, 0.0]];
        let mut m = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                m[i][j] = (0..4).map(|k| proj[i][k] * view[k][j]).sum();
            }
        }
        Ok(m)
    }
}

fn bounds(mesh: &Mesh) -> ([f64; 3], [f64; 3]) {
    let mut lo = [f64::INFINITY; 3];
    let mut hi = [f64::NEG_INFINITY; 3];
    for p in &mesh.positions {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    (lo, hi)
}

/// The bounding box's centre and the farthest vertex's distance from it.
fn bounding_sphere(mesh: &Mesh) -> ([f64; 3], f64) {
    if mesh.positions.is_empty() {
        return ([0.0; 3], 1.0);
    }
    let (lo, hi) = bounds(mesh);
    let centre = [0.5 * (lo[0] + hi[0]), 0.5 * (lo[1] + hi[1]), 0.5 * (lo[2] + hi[2])];
    let radius = mesh.positions.iter().map(|p| norm(sub(*p, centre))).fold(0.0, f64::max);
    (centre, radius)
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

/// The Euclidean length; scaled by the largest component where the plain sum of squares
/// overflows or underflows (a mesh with coordinates near 1e200), the plain result elsewhere.
fn norm(a: [f64; 3]) -> f64 {
    let plain = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    let largest = a[0].abs().max(a[1].abs()).max(a[2].abs());
    if plain.is_finite() && (plain > 0.0 || largest == 0.0) || !largest.is_finite() {
        return plain;
    }
    let s = [a[0] / largest, a[1] / largest, a[2] / largest];
    largest * (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt()
}
