//! tileraster's programmable fragment stage by example: the procedural marble of
//! `procedural-shader`, compiled to SPIR-V by `build.rs` and linked natively, as one
//! [`FragmentStage`] that both backends run with the same bits.

use tileraster::Error;
use tileraster::render::{Camera, FragmentStage, Light, Mesh, Projection, RenderParams, Shading};

/// The marble shader on both backends.
pub static MARBLE: FragmentStage = tileraster::fragment_stage!(procedural_shader);

/// A sphere of radius 1 resting on a square floor 6 units wide (`+z` up), white, with normals.
pub fn scene() -> Mesh {
    let mut mesh = tileraster_testkit::meshes::sphere([0.0, 0.0, 1.0], 1.0, 48, 96);
    mesh.colours = Some(vec![[1.0; 4]; mesh.positions.len()]);
    // The floor: an n × n grid of quads at z = 0, facing up, a little darker.
    let n = 16u32;
    let first = mesh.positions.len() as u32;
    for j in 0..=n {
        for i in 0..=n {
            mesh.positions.push([-3.0 + 6.0 * i as f64 / n as f64, -3.0 + 6.0 * j as f64 / n as f64, 0.0]);
        }
    }
    let floor = (n + 1) * (n + 1);
    mesh.normals.as_mut().expect("the sphere has normals").extend(std::iter::repeat_n([0.0, 0.0, 1.0], floor as usize));
    mesh.colours.as_mut().expect("set above").extend(std::iter::repeat_n([0.75, 0.75, 0.78, 1.0], floor as usize));
    let at = |i: u32, j: u32| first + j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            mesh.triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            mesh.triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    mesh
}

/// A `width` × `height` frame of [`scene`] with the marble shader, from the front-right and
/// above, lit by a key light and a fill light.
pub fn params(mesh: &Mesh, width: u32, height: u32) -> Result<RenderParams, Error> {
    let camera = Camera::look_at([3.4, -4.2, 2.8], [0.0, 0.0, 0.7], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 40.0 }, mesh);
    let mut params = RenderParams::new(width, height, camera.view_projection(width, height)?);
    params.eye = Some(camera.viewer());
    params.shading = Shading::Phong;
    params.background = [24, 26, 32, 255];
    params.lights = vec![Light { direction: [0.5, -0.4, 0.8], colour: [0.8, 0.78, 0.72] }, Light { direction: [-0.6, -0.2, 0.3], colour: [0.2, 0.22, 0.28] }];
    params.ambient = [0.12, 0.12, 0.14];
    params.specular = [0.35, 0.35, 0.35];
    params.shininess = 48;
    params.fragment = Some(MARBLE);
    Ok(params)
}
