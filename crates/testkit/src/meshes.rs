//! 3D meshes for the render pipeline's tests, deterministic for a seed.

pub use crate::scenes::Rng;
use tileraster_core::render::Mesh;

/// A closed UV sphere, faces counter-clockwise seen from outside, with outward normals and a
/// colour per vertex.
pub fn sphere(centre: [f64; 3], radius: f64, stacks: u32, slices: u32) -> Mesh {
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut colours = Vec::new();
    // Poles once each, rings between.
    positions.push([centre[0], centre[1], centre[2] + radius]);
    normals.push([0.0, 0.0, 1.0]);
    colours.push([1.0, 0.9, 0.3, 1.0]);
    for s in 1..stacks {
        let theta = std::f64::consts::PI * s as f64 / stacks as f64;
        for k in 0..slices {
            let phi = 2.0 * std::f64::consts::PI * k as f64 / slices as f64;
            let n = [theta.sin() * phi.cos(), theta.sin() * phi.sin(), theta.cos()];
            positions.push([centre[0] + radius * n[0], centre[1] + radius * n[1], centre[2] + radius * n[2]]);
            normals.push(n.map(|c| c as f32));
            colours.push([0.5 + 0.5 * n[0] as f32, 0.5 + 0.5 * n[1] as f32, 0.5 + 0.5 * n[2] as f32, 1.0]);
        }
    }
    positions.push([centre[0], centre[1], centre[2] - radius]);
    normals.push([0.0, 0.0, -1.0]);
    colours.push([0.2, 0.3, 1.0, 1.0]);
    let ring = |s: u32, k: u32| 1 + (s - 1) * slices + k % slices;
    let south = positions.len() as u32 - 1;
    let mut triangles = Vec::new();
    for k in 0..slices {
        triangles.push([0, ring(1, k), ring(1, k + 1)]);
    }
    for s in 1..stacks - 1 {
        for k in 0..slices {
            let (a, b, c, d) = (ring(s, k), ring(s, k + 1), ring(s + 1, k), ring(s + 1, k + 1));
            triangles.push([a, c, d]);
            triangles.push([a, d, b]);
        }
    }
    for k in 0..slices {
        triangles.push([south, ring(stacks - 1, k + 1), ring(stacks - 1, k)]);
    }
    Mesh { positions, triangles, normals: Some(normals), colours: Some(colours), uvs: None, ..Default::default() }
}

/// `n` random triangles of up to `size` inside the box `lo..hi`, random colours, no normals:
/// interpenetrating, in both windings.
pub fn soup(n: usize, lo: [f64; 3], hi: [f64; 3], size: f64, seed: u64) -> Mesh {
    let mut rng = Rng::new(seed);
    let mut positions = Vec::with_capacity(3 * n);
    let mut colours = Vec::with_capacity(3 * n);
    let mut triangles = Vec::with_capacity(n);
    for t in 0..n {
        let c = [0, 1, 2].map(|a| rng.range(lo[a], hi[a]));
        for _ in 0..3 {
            positions.push([0, 1, 2].map(|a| c[a] + rng.range(-size, size)));
            colours.push([rng.range(0.0, 1.0) as f32, rng.range(0.0, 1.0) as f32, rng.range(0.0, 1.0) as f32, 1.0]);
        }
        let v = 3 * t as u32;
        triangles.push([v, v + 1, v + 2]);
    }
    Mesh { positions, triangles, normals: None, colours: Some(colours), uvs: None, ..Default::default() }
}

/// A height-field grid of `n × n` cells over `0..extent` in x and y, heights a smooth bump
/// field: a terrain seen in perspective.
pub fn terrain(n: u32, extent: f64, height: f64) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (extent * i as f64 / n as f64, extent * j as f64 / n as f64);
            let (u, v) = (x / extent * 6.0, y / extent * 6.0);
            positions.push([x, y, height * (0.5 * u.sin() * v.cos() + 0.25 * (2.1 * u + 0.7).cos() * (1.7 * v).sin())]);
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    let mut triangles = Vec::new();
    for j in 0..n {
        for i in 0..n {
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    Mesh { positions, triangles, ..Default::default() }
}

/// Fill rate: `layers` full-frame squares of two triangles each in clip space (use the
/// identity matrix), the nearest last, so that every layer passes a `Less` depth test drawn
/// in order: overdraw `layers`.
pub fn fill_layers(layers: u32) -> Mesh {
    let mut mesh = Mesh::default();
    for layer in 0..layers {
        let z = 0.9 - 0.8 * layer as f64 / layers as f64;
        let v = mesh.positions.len() as u32;
        mesh.positions.extend([[-1.0, -1.0, z], [1.0, -1.0, z], [1.0, 1.0, z], [-1.0, 1.0, z]]);
        mesh.triangles.extend([[v, v + 1, v + 2], [v, v + 2, v + 3]]);
    }
    mesh
}

/// The textures benchmark's ground plane: `2·n²` triangles over `0..100` in x and y, white,
/// its texture coordinates repeating 16 times across, with one `size²` sRGB texture (a
/// gradient in red and green over a checker of 16-texel squares in blue). Seen from
/// [`TEXTURED_PLANE_EYE`] towards the horizon it is magnified near and minified far.
pub fn textured_plane(n: u32, size: u32) -> Mesh {
    use tileraster_core::render::Texture;
    let rgba: Vec<u8> = (0..size * size)
        .flat_map(|k| {
            let (x, y) = (k % size, k / size);
            let checker = if (x / 16 + y / 16) % 2 == 0 { 230 } else { 40 };
            [(x * 255 / (size - 1)) as u8, (y * 255 / (size - 1)) as u8, checker, 255]
        })
        .collect();
    let mut mesh = terrain(n, 100.0, 0.0);
    mesh.uvs = Some(mesh.positions.iter().map(|p| [(p[0] / 100.0 * 16.0) as f32, (p[1] / 100.0 * 16.0) as f32]).collect());
    mesh.colours = Some(vec![[1.0; 4]; mesh.positions.len()]);
    mesh.textures = vec![Texture::srgb(size, size, rgba)];
    mesh
}

/// Where [`textured_plane`] is seen from: eye, target, up.
pub const TEXTURED_PLANE_EYE: [[f64; 3]; 3] = [[50.0, -8.0, 6.0], [50.0, 40.0, 0.0], [0.0, 0.0, 1.0]];
