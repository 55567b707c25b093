//! Cameras: a look-at view with a perspective or an orthographic projection, in Vulkan's
//! conventions (depth 0 at the near plane and 1 at the far plane, NDC `y` down the image, so
//! world "up" is up on the screen).

use super::{Eye, Mesh};
use crate::Error;

/// How a camera projects the world onto the frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Projection {
    /// From the eye, with this vertical field of view in degrees.
    Perspective { fov_deg: f64 },
    /// Along the viewing direction (a parallel projection, the centre of projection at
    /// infinity), seeing this width in world units; the height follows from the frame's aspect.
    Orthographic { width: f64 },
}

/// Which world axis points up in a mesh, by its format's convention: `+Y` for glTF (whose
/// front faces `+Z`) and the usual OBJ, PLY and STL exports; `+Z` for terrain and point clouds
/// (whose front faces `−Y`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Up {
    Y,
    Z,
}

impl Up {
    pub fn vector(self) -> [f64; 3] {
        match self {
            Up::Y => [0.0, 1.0, 0.0],
            Up::Z => [0.0, 0.0, 1.0],
        }
    }

    /// Whence the default camera looks: from the front, a little to the right and above.
    fn view_from(self) -> [f64; 3] {
        match self {
            Up::Y => [0.5, 0.45, 0.74],
            Up::Z => [0.55, -0.65, 0.52],
        }
    }
}

/// A look-at camera.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Camera {
    pub eye: [f64; 3],
    pub target: [f64; 3],
    pub up: [f64; 3],
    pub projection: Projection,
    /// Near and far planes' distances from the eye along the viewing direction: `0 < near <
    /// far` in perspective; `near < far` orthographically, where the near plane may lie behind
    /// the eye.
    pub near: f64,
    pub far: f64,
}

impl Camera {
    /// A camera at `eye` looking at `target`, near and far planes fitted to `mesh`'s bounding
    /// sphere.
    pub fn look_at(eye: [f64; 3], target: [f64; 3], up: [f64; 3], projection: Projection, mesh: &Mesh) -> Camera {
        let (centre, radius) = bounding_sphere(mesh);
        let distance = norm(sub(centre, eye));
        let (near, far) = match projection {
            Projection::Perspective { .. } => {
                let far = (distance + radius) * 1.01;
                ((distance - radius).max(far * 1e-4), far)
            }
            // About the centre's depth along the view, which lies off the line to the target
            // wherever the eye does not look at the centre.
            Projection::Orthographic { .. } => {
                let f = sub(target, eye);
                let f = scale(f, 1.0 / norm(f));
                let offset = sub(centre, eye);
                slab(offset[0] * f[0] + offset[1] * f[1] + offset[2] * f[2], radius)
            }
        };
        Camera { eye, target, up, projection, near, far }
    }

    /// A camera that frames the whole mesh for a frame of aspect `aspect` (width / height),
    /// `up` up: looking at its bounding sphere's centre from the front, a little to the right
    /// and above. In perspective its distance is fitted; orthographically its width (the
    /// projection's own width is replaced).
    pub fn framing(mesh: &Mesh, aspect: f64, projection: Projection, up: Up) -> Camera {
        let (centre, radius) = bounding_sphere(mesh);
        let radius = if radius > 0.0 { radius } else { 1.0 };
        let direction = up.view_from();
        let d = scale(direction, 1.0 / norm(direction));
        let camera_at = |distance: f64, projection: Projection| {
            let eye = [centre[0] + d[0] * distance, centre[1] + d[1] * distance, centre[2] + d[2] * distance];
            let (near, far) = match projection {
                Projection::Perspective { .. } => ((distance - radius).max(distance * 1e-3), distance + radius * 1.01),
                Projection::Orthographic { .. } => slab(distance, radius),
            };
            Camera { eye, target: centre, up: up.vector(), projection, near, far }
        };
        let fov_deg = match projection {
            Projection::Perspective { fov_deg } => fov_deg,
            Projection::Orthographic { .. } => return camera_at(2.0 * radius, projection).fit_orthographic(mesh, aspect),
        };
        let tan_half = (fov_deg.to_radians() / 2.0).tan();
        // Far enough that the bounding sphere fits the narrower field of view...
        let mut distance = radius / tan_half.min(tan_half * aspect).atan().sin() * 1.05;
        // ... then closer, until the bounding box's corners fill 90 % of the frame (the
        // corners' spread on the screen grows about as the inverse of the distance).
        let (w, h) = if aspect >= 1.0 { ((1000.0 * aspect) as u32, 1000) } else { (1000, (1000.0 / aspect) as u32) };
        for _ in 0..4 {
            let Ok(m) = camera_at(distance, projection).view_projection(w.max(1), h.max(1)) else { break };
            let spread = corners(mesh)
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
        camera_at(distance, projection)
    }

    /// This camera made orthographic, as wide as makes `mesh`'s bounding box fill 90 % of a
    /// frame of aspect `aspect` (width / height), its eye and planes unchanged but for the
    /// planes' enclosing the mesh. Unchanged where the view is singular.
    pub fn fit_orthographic(self, mesh: &Mesh, aspect: f64) -> Camera {
        let Ok(view) = self.view() else { return self };
        let (mut half_x, mut half_y) = (0.0f64, 0.0f64);
        let (mut nearest, mut farthest) = (f64::INFINITY, f64::NEG_INFINITY);
        for p in corners(mesh) {
            let v = [0, 1, 2].map(|r| view[r][0] * p[0] + view[r][1] * p[1] + view[r][2] * p[2] + view[r][3]);
            (half_x, half_y) = (half_x.max(v[0].abs()), half_y.max(v[1].abs()));
            (nearest, farthest) = (nearest.min(v[2]), farthest.max(v[2]));
        }
        let width = 2.0 * half_x.max(half_y * aspect) / 0.9;
        if !(width.is_finite() && width > 0.0 && nearest <= farthest) {
            return self;
        }
        // A little room before and behind, so that no face lies on a plane.
        let pad = 0.01 * (farthest - nearest).max(1e-6 * width);
        Camera { projection: Projection::Orthographic { width }, near: nearest - pad, far: farthest + pad, ..self }
    }

    /// A glTF file's camera for a frame of aspect `aspect` (width / height): at its node's
    /// origin, looking down the node's `−Z` with its `+Y` up. The vertical field of view (or
    /// orthographic height) is the file's, the width follows from `aspect`, as glTF asks where
    /// the camera names no aspect ratio (so a frame of another shape sees more or less at the
    /// sides, never a stretched picture). A perspective camera without a far plane (glTF's
    /// infinite projection) gets one just beyond `mesh`'s farthest bounding-box corner. A scale
    /// in the node's transform turns the view but does not scale the planes or the height
    /// (glTF asks for camera nodes without one).
    pub fn of_gltf(camera: &tileraster_io::GltfCamera, mesh: &Mesh, aspect: f64) -> Camera {
        let m = &camera.to_world;
        let column = |c: usize| [m[0][c], m[1][c], m[2][c]];
        let eye = column(3);
        let forward = scale(column(2), -1.0);
        let forward = scale(forward, 1.0 / norm(forward));
        let target = [eye[0] + forward[0], eye[1] + forward[1], eye[2] + forward[2]];
        let (projection, near, far) = match camera.projection {
            tileraster_io::GltfProjection::Perspective { yfov, znear, zfar, .. } => {
                let far = zfar.unwrap_or_else(|| {
                    let farthest = corners(mesh).iter().map(|p| norm(sub(*p, eye))).fold(0.0f64, f64::max);
                    (farthest * 1.01).max(znear * 2.0)
                });
                (Projection::Perspective { fov_deg: yfov.to_degrees() }, znear, far)
            }
            tileraster_io::GltfProjection::Orthographic { ymag, znear, zfar, .. } => {
                (Projection::Orthographic { width: 2.0 * ymag.abs() * aspect }, znear, zfar)
            }
        };
        Camera { eye, target, up: column(1), projection, near, far }
    }

    /// Where the lighting takes the viewer to be: the eye in perspective; orthographically
    /// the direction from the target towards the eye.
    pub fn viewer(&self) -> Eye {
        match self.projection {
            Projection::Perspective { .. } => Eye::Point(self.eye),
            Projection::Orthographic { .. } => {
                let d = sub(self.eye, self.target);
                Eye::Direction(scale(d, 1.0 / norm(d)))
            }
        }
    }

    /// World to view space (x right, y down as Vulkan's NDC, z forward), row-major; checked
    /// from what the caller chose to what follows from it, so that each error names its own
    /// cause.
    fn view(&self) -> Result<[[f64; 4]; 4], Error> {
        let [r, u, f] = self.axes()?;
        let t = |a: [f64; 3]| -(a[0] * self.eye[0] + a[1] * self.eye[1] + a[2] * self.eye[2]);
        Ok([[r[0], r[1], r[2], t(r)], [-u[0], -u[1], -u[2], -t(u)], [f[0], f[1], f[2], t(f)], [0.0, 0.0, 0.0, 1.0]])
    }

    /// The camera's own unit axes: right, up and forward (the image's x, its y upwards, the
    /// viewing direction); checked from what the caller chose to what follows from it, so that
    /// each error names its own cause.
    pub(super) fn axes(&self) -> Result<[[f64; 3]; 3], Error> {
        let singular = |reason: &str| Err(Error::SingularCamera { reason: reason.into() });
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
        let r = scale(side, 1.0 / norm(side));
        Ok([r, cross(r, f), f])
    }

    /// World to clip space for a `width` × `height` frame, row-major.
    pub fn view_projection(&self, width: u32, height: u32) -> Result<[[f64; 4]; 4], Error> {
        if width == 0 || height == 0 {
            return Err(Error::ZeroSizedRaster { width: width as u64, height: height as u64 });
        }
        let singular = |reason: &str| Err(Error::SingularCamera { reason: reason.into() });
        // The projection is checked first: a field of view of 0 frames a mesh from infinitely
        // far, which would otherwise read as a degenerate up vector.
        match self.projection {
            Projection::Perspective { fov_deg } if !(fov_deg > 0.0 && fov_deg < 180.0) => {
                return singular("the field of view must lie strictly between 0 and 180 degrees");
            }
            Projection::Orthographic { width } if !(width > 0.0 && width.is_finite()) => {
                return singular("the orthographic width must be positive and finite");
            }
            _ => {}
        }
        let view = self.view()?;
        let (n, fa) = (self.near, self.far);
        let proj = match self.projection {
            Projection::Perspective { fov_deg } => {
                if !(self.near > 0.0 && self.far > self.near) || !self.far.is_finite() {
                    return singular("the near and far planes must satisfy 0 < near < far");
                }
                let sy = 1.0 / (fov_deg.to_radians() / 2.0).tan();
                let sx = sy * height as f64 / width as f64;
                // z_clip = far/(far − near) · (z − near), w = z: depth 0 at near, 1 at far.
                let a = fa / (fa - n);
                [[sx, 0.0, 0.0, 0.0], [0.0, sy, 0.0, 0.0], [0.0, 0.0, a, -a * n], [0.0, 0.0, 1.0, 0.0]]
            }
            Projection::Orthographic { width: seen } => {
                if !(self.near.is_finite() && self.far.is_finite() && self.far > self.near) {
                    return singular("the near and far planes must satisfy near < far, both finite");
                }
                let sx = 2.0 / seen;
                let sy = sx * width as f64 / height as f64;
                // z_clip = (z − near) / (far − near), w = 1: depth 0 at near, 1 at far.
                let a = 1.0 / (fa - n);
                [[sx, 0.0, 0.0, 0.0], [0.0, sy, 0.0, 0.0], [0.0, 0.0, a, -a * n], [0.0, 0.0, 0.0, 1.0]]
            }
        };
        let mut m = [[0.0; 4]; 4];
        for i in 0..4 {
            for j in 0..4 {
                m[i][j] = (0..4).map(|k| proj[i][k] * view[k][j]).sum();
            }
        }
        Ok(m)
    }
}

/// An orthographic camera's near and far planes at `distance` from a sphere of `radius`: the
/// sphere and a little more between them.
fn slab(distance: f64, radius: f64) -> (f64, f64) {
    let reach = radius * 1.01 + 1e-6 * distance.abs().max(radius).max(f64::MIN_POSITIVE);
    (distance - reach, distance + reach)
}

/// The corners of `mesh`'s bounding box.
fn corners(mesh: &Mesh) -> [[f64; 3]; 8] {
    let (lo, hi) = bounds(mesh);
    std::array::from_fn(|k| [if k & 1 == 0 { lo[0] } else { hi[0] }, if k & 2 == 0 { lo[1] } else { hi[1] }, if k & 4 == 0 { lo[2] } else { hi[2] }])
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

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn add(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
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
