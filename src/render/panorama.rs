//! Non-linear projections (cylindrical, equirectangular, fisheye): the faces of a cube map around
//! the eye rendered as exact perspective frames (90° square, the faces the output needs and no
//! other), then resampled by a fixed rule. Each output pixel takes the face pixel its centre's
//! direction falls in (nearest, no filtering), so its colour, depth and face id are a face
//! pixel's: the labels stay exact, and the frame is the same bits on every backend. The
//! directions are computed on the host in `f64` with the `libm` crate's functions, the same on
//! every machine.

use super::camera::{add, cross, dot};
use super::{Camera, Frame, GeometryCounts, Mesh, NO_FACE, Projection, RenderParams, RenderStats};
use crate::Error;

/// A non-linear projection of the whole sphere of directions around the eye.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Panorama {
    /// 360° across the frame, heights as on a cylinder: `fov_deg` seen from the bottom of the
    /// frame to its top.
    Cylindrical { fov_deg: f64 },
    /// Longitude across the frame (360°), latitude up it (180°).
    Equirectangular,
    /// Equidistant fisheye: the angle from the viewing direction grows with the distance from
    /// the frame's centre, `fov_deg` across the frame's width (up to 360°); the corners see
    /// further, and what lies more than 180° from the axis is background.
    Fisheye { fov_deg: f64 },
}

/// Cube faces, in the order a direction's face is chosen among equal components.
const FACES: usize = 6;

/// Face `f`'s viewing direction and up vector in the camera's axes (x right, y up, z forward):
/// front, back, right, left, top, bottom.
fn face_axes(f: usize) -> ([f64; 3], [f64; 3]) {
    match f {
        0 => ([0.0, 0.0, 1.0], [0.0, 1.0, 0.0]),
        1 => ([0.0, 0.0, -1.0], [0.0, 1.0, 0.0]),
        2 => ([1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        3 => ([-1.0, 0.0, 0.0], [0.0, 1.0, 0.0]),
        4 => ([0.0, 1.0, 0.0], [0.0, 0.0, -1.0]),
        _ => ([0.0, -1.0, 0.0], [0.0, 0.0, 1.0]),
    }
}

impl Panorama {
    /// The direction (x right, y up, z forward, not normalised) through the centre of pixel
    /// (`x`, `y`) of a `width` × `height` frame; `None` outside a fisheye's field.
    fn direction(self, x: u32, y: u32, width: u32, height: u32) -> Option<[f64; 3]> {
        use std::f64::consts::PI;
        let (u, v) = ((x as f64 + 0.5) / width as f64, (y as f64 + 0.5) / height as f64);
        match self {
            Panorama::Equirectangular => {
                let (longitude, latitude) = ((u - 0.5) * 2.0 * PI, (0.5 - v) * PI);
                let c = libm::cos(latitude);
                Some([c * libm::sin(longitude), libm::sin(latitude), c * libm::cos(longitude)])
            }
            Panorama::Cylindrical { fov_deg } => {
                let longitude = (u - 0.5) * 2.0 * PI;
                let height = (0.5 - v) * 2.0 * libm::tan(fov_deg.to_radians() / 2.0);
                Some([libm::sin(longitude), height, libm::cos(longitude)])
            }
            Panorama::Fisheye { fov_deg } => {
                let per_pixel = fov_deg.to_radians() / width as f64;
                let (px, py) = (x as f64 + 0.5 - width as f64 / 2.0, height as f64 / 2.0 - (y as f64 + 0.5));
                let angle = libm::hypot(px, py) * per_pixel;
                if angle > PI {
                    return None;
                }
                let around = libm::atan2(py, px);
                let s = libm::sin(angle);
                Some([s * libm::cos(around), s * libm::sin(around), libm::cos(angle)])
            }
        }
    }

    /// The angle an output pixel spans, radians: what sets the faces' size.
    fn pixel_angle(self, width: u32, height: u32) -> f64 {
        use std::f64::consts::PI;
        match self {
            Panorama::Equirectangular => (2.0 * PI / width as f64).min(PI / height as f64),
            Panorama::Cylindrical { .. } => 2.0 * PI / width as f64,
            Panorama::Fisheye { fov_deg } => fov_deg.to_radians() / width as f64,
        }
    }

    /// The faces' side: a face's central pixel spans about an output pixel (2 / F radians).
    pub fn face_size(self, width: u32, height: u32) -> u32 {
        ((2.0 / self.pixel_angle(width, height)).ceil() as u32).clamp(1, 4096)
    }

    /// Whether the projection's parameters make a frame.
    pub fn check(self) -> Result<(), String> {
        match self {
            Panorama::Cylindrical { fov_deg } if !(fov_deg > 0.0 && fov_deg < 180.0) => {
                Err(format!("{fov_deg}: a cylindrical projection sees less than 180° from the bottom to the top"))
            }
            Panorama::Fisheye { fov_deg } if !(fov_deg > 0.0 && fov_deg <= 360.0) => Err(format!("{fov_deg}: a fisheye sees more than 0° and at most 360°")),
            _ => Ok(()),
        }
    }
}

/// The face a direction falls in, and the pixel of a `size`-sided face: the largest component
/// (the first of equal ones, in face order), then the face's perspective pixel.
fn face_pixel(d: [f64; 3], size: u32) -> (usize, u32, u32) {
    let candidates = [d[2], -d[2], d[0], -d[0], d[1], -d[1]];
    let mut face = 0;
    for (f, &c) in candidates.iter().enumerate() {
        if c > candidates[face] {
            face = f;
        }
    }
    let (forward, up) = face_axes(face);
    // The face camera's right, forward × up in the world: in these left-handed axes (x right,
    // y up, z forward) the components' cross product is reversed.
    let right = cross(up, forward);
    let depth = dot(d, forward);
    // As the face's camera projects (y down the image), in [−1, 1] on the face.
    let (x, y) = (dot(d, right) / depth, -dot(d, up) / depth);
    let pixel = |t: f64| (((t + 1.0) / 2.0 * size as f64).floor().max(0.0) as u32).min(size - 1);
    (face, pixel(x), pixel(y))
}

/// The camera of face `f` around `camera`'s eye: 90° square perspective, the planes `near` and
/// `far` as every face's.
pub fn face_camera(camera: &Camera, f: usize, mesh: &Mesh) -> Result<Camera, Error> {
    let axes = camera.axes()?;
    let world = |v: [f64; 3]| [0, 1, 2].map(|k| axes[0][k] * v[0] + axes[1][k] * v[1] + axes[2][k] * v[2]);
    let (forward, up) = face_axes(f);
    Ok(Camera::look_at(camera.eye, add(camera.eye, world(forward)), world(up), Projection::Perspective { fov_deg: 90.0 }, mesh))
}

/// The frame of `panorama` around `camera` (its eye and axes), `width` × `height`: the faces it
/// needs drawn by `draw` from `face_params` (the face's view-projection for a `size`-sided
/// frame), then resampled. Its statistics are the faces' summed and the frame's own pixels.
pub fn panorama_frame(
    panorama: Panorama,
    camera: &Camera,
    mesh: &Mesh,
    params: &RenderParams,
    draw: &mut dyn FnMut(&RenderParams) -> Result<Frame, Error>,
) -> Result<Frame, Error> {
    let (width, height) = (params.width, params.height);
    let size = panorama.face_size(width, height);
    let sources: Vec<Option<(usize, u32, u32)>> =
        (0..height).flat_map(|y| (0..width).map(move |x| (x, y))).map(|(x, y)| panorama.direction(x, y, width, height).map(|d| face_pixel(d, size))).collect();
    let mut needed = [false; FACES];
    sources.iter().flatten().for_each(|&(f, ..)| needed[f] = true);
    let mut faces: Vec<Option<Frame>> = vec![None; FACES];
    // The faces' statistics summed (the passes the first face's).
    let (mut geometry, mut raster) = (GeometryCounts::default(), None::<crate::Stats>);
    for f in (0..FACES).filter(|&f| needed[f]) {
        let face = face_camera(camera, f, mesh)?;
        let mut face_params = params.clone();
        (face_params.width, face_params.height) = (size, size);
        face_params.view_projection = face.view_projection(size, size)?;
        face_params.eye = Some(face.viewer());
        let frame = draw(&face_params)?;
        geometry.absorb(&frame.stats.geometry);
        match raster.as_mut() {
            Some(r) => r.absorb(&frame.stats.raster),
            None => raster = Some(frame.stats.raster.clone()),
        }
        faces[f] = Some(frame);
    }
    let background = u32::from_le_bytes(params.background);
    let mut out = Frame { width, height, ..Default::default() };
    // The layers the faces returned.
    let drawn = faces.iter().flatten().next();
    let colour = drawn.is_some_and(|f| !f.colour.is_empty());
    let depth = drawn.is_some_and(|f| !f.depth.is_empty());
    let fragments = drawn.is_some_and(|f| !f.fragments.is_empty());
    for source in &sources {
        let at = source.and_then(|(f, x, y)| faces[f].as_ref().map(|face| (face, (y * size + x) as usize)));
        match at {
            Some((face, k)) => {
                out.ids.push(face.ids[k]);
                if colour {
                    out.colour.push(face.colour[k]);
                }
                if depth {
                    out.depth.push(face.depth[k]);
                }
                if fragments {
                    out.fragments.push(face.fragments[k]);
                }
            }
            None => {
                out.ids.push(NO_FACE);
                if colour {
                    out.colour.push(background);
                }
                if depth {
                    out.depth.push(params.clear_depth);
                }
                if fragments {
                    out.fragments.push(0);
                }
            }
        }
    }
    let covered = out.ids.iter().filter(|&&id| id != NO_FACE).count() as u64;
    out.stats = RenderStats { geometry, raster: raster.unwrap_or_default(), pixels_covered: covered, ..Default::default() };
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn directions_fall_in_the_faces_they_face() {
        // The centre of an equirectangular frame looks forward; a quarter turn right, right.
        let (w, h) = (400, 200);
        let size = Panorama::Equirectangular.face_size(w, h);
        let at = |x, y| face_pixel(Panorama::Equirectangular.direction(x, y, w, h).unwrap(), size);
        assert_eq!(at(200, 100).0, 0);
        assert_eq!(at(300, 100).0, 2);
        assert_eq!(at(100, 100).0, 3);
        assert_eq!(at(0, 100).0, 1);
        assert_eq!(at(200, 0).0, 4);
        assert_eq!(at(200, 199).0, 5);
        // The front face's centre, as its perspective camera draws it (y down).
        let (_, x, y) = at(200, 100);
        assert!(x.abs_diff(size / 2) <= 1 && y.abs_diff(size / 2) <= 1, "{x} {y} of {size}");
        let (_, _, y_up) = at(200, 80);
        assert!(y_up < y, "up the frame is up the face");
        // A fisheye sees nothing beyond 180° from its axis.
        let fisheye = Panorama::Fisheye { fov_deg: 180.0 };
        assert!(fisheye.direction(0, 0, 100, 100).is_some() && Panorama::Fisheye { fov_deg: 360.0 }.direction(0, 0, 100, 100).is_none());
        let d = fisheye.direction(99, 50, 100, 100).unwrap();
        assert!(d[2].abs() < 0.02 && d[0] > 0.99, "the right edge of a 180° fisheye looks right: {d:?}");
    }
}
