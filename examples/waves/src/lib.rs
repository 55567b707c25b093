//! tileraster's programmable vertex stage by example: the ocean waves of `waves-shader`,
//! compiled to SPIR-V by `build.rs` and linked natively, as one [`VertexStage`] that both
//! backends (and the host's own stages) run with the same bits.
//!
//! The sea lies where a GIS user's data lies: in UTM coordinates, 500 km east and 5,000 km north
//! of the zone's origin. The shader sees each vertex relative to the centre of the sea, so its
//! `f32` arithmetic keeps a fraction of a millimetre there.

use tileraster::Error;
use tileraster::render::{Camera, Light, Mesh, Projection, RenderParams, Shading, VertexStage};

/// The waves shader on both backends.
pub static WAVES: VertexStage = tileraster::vertex_stage!(waves_shader);

/// Where the sea's south-west corner lies (UTM easting and northing, metres).
pub const CORNER: [f64; 2] = [500_000.0, 5_000_000.0];
/// The sea's side, metres.
pub const SIDE: f64 = 2_000.0;
/// The default height of the highest crest above the still sea, metres.
pub const CREST: f32 = 14.0;

/// A still sea: an `n` × `n` grid of quads at height 0 (`+z` up), sea blue, without normals (the
/// frame computes them from the posed faces).
pub fn sea(n: u32) -> Mesh {
    let mut positions = Vec::with_capacity(((n + 1) * (n + 1)) as usize);
    for j in 0..=n {
        for i in 0..=n {
            positions.push([CORNER[0] + SIDE * i as f64 / n as f64, CORNER[1] + SIDE * j as f64 / n as f64, 0.0]);
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::with_capacity((2 * n * n) as usize);
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let colours = Some(vec![[0.10, 0.32, 0.52, 1.0]; positions.len()]);
    Mesh { positions, triangles, normals: None, colours, uvs: None, textures: Vec::new(), face_textures: None, ..Default::default() }
}

/// A `width` × `height` frame of `mesh` (a [`sea`]) at `time` seconds, posed by the waves
/// shader, seen from a cliff to the south-west, lit by a low sun.
pub fn params(mesh: &Mesh, width: u32, height: u32, time: f32) -> Result<RenderParams, Error> {
    let centre = [CORNER[0] + SIDE / 2.0, CORNER[1] + SIDE / 2.0];
    let eye = [centre[0] - 0.4 * SIDE, centre[1] - 0.55 * SIDE, 190.0];
    let camera = Camera::look_at(eye, [centre[0] + 0.05 * SIDE, centre[1] + 0.1 * SIDE, 0.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 50.0 }, mesh);
    let mut params = RenderParams::new(width, height, camera.view_projection(width, height)?);
    params.eye = Some(camera.viewer());
    params.shading = Shading::Phong;
    params.background = [196, 214, 232, 255];
    params.lights = vec![Light { direction: [0.3, 0.9, 0.35], colour: [0.95, 0.88, 0.75] }];
    params.ambient = [0.18, 0.2, 0.24];
    params.specular = [0.6, 0.6, 0.6];
    params.shininess = 64;
    params.vertex = Some(WAVES);
    params.vertex_constants[0] = CREST;
    params.time = time;
    Ok(params)
}
