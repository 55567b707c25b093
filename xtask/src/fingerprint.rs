//! `cargo xtask fingerprint`: one line per scene × mode with two hashes: of what `prepare`
//! made (every prepared triangle's bytes, the snapping, the counts, the overlap proof), and of
//! the CPU backend's raster. Work that must change no output bit is checked by running it
//! before and after and comparing the second column (and the first, where the preparation
//! itself must not change). Then one line per rendered frame (every shading, interpolation,
//! texture filter and address mode, blending, multisampling, lines and points): the hash of
//! the CPU frame's colour, depth and id layers. The CPU backend runs the kernels' own source,
//! so a change to the shade stage that keeps these changes no bit on any device.

use std::time::Instant;
use tileraster::render::{Address, Camera, Cull, Filter, Interpolation, LineRule, Mesh, Projection, RenderParams, Shading, Texture, Up, Wireframe, render};
use tileraster::{Backend, Grid, Mode, Params, Scene, prepare, rasterise};
use tileraster_testkit::{meshes, scenes};

/// FNV-1a, 64 bits: stable across builds and toolchains, unlike `std`'s hasher.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn bytes(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ b as u64).wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
}

fn cases() -> Vec<(String, Scene, Grid)> {
    let (x0, y0) = (500_000.0, 5_000_000.0);
    let mut cases = Vec::new();
    for px in [0.25, 1.0, 4.0] {
        let (scene, grid) = scenes::micro_triangles(512, px, 7);
        cases.push((format!("micro-triangles {px} px, 512²"), scene, grid));
    }
    let tin = scenes::delaunay_terrain(x0, y0, 10_000.0, 10_000.0, 315, 315, 2026);
    cases.push(("TIN 99856 points, 4096²".into(), tin.clone(), Grid::new(x0, x0 + 10_000.0, y0, y0 + 10_000.0, 4096, 4096)));
    cases.push(("TIN 99856 points, offset 1000×700".into(), tin, Grid::new(x0 + 13.3, x0 + 9_000.0, y0 - 20.0, y0 + 7_000.0, 1000, 700)));
    let grid = Grid::new(0.0, 100.0, 0.0, 100.0, 333, 257);
    cases.push(("soup of 5000".into(), scenes::triangle_soup(&grid, 5000, 30.0, 9), grid));
    cases.push(("sliver wedge".into(), scenes::sliver_wedge(&grid, 800, 0.02, 4), grid));
    cases.push(("fan".into(), scenes::fan(&grid, 60, 60, 90, 40.0, 3), grid));
    cases
}

pub fn run() -> Result<String, String> {
    let mut out = String::new();
    for (name, scene, grid) in cases() {
        for mode in Mode::ALL {
            let params = Params::new(grid).with_mode(mode);
            let start = Instant::now();
            let prepared = prepare(&scene, &params, None).map_err(|e| e.to_string())?;
            let seconds = start.elapsed().as_secs_f64();
            let mut h = Fnv::new();
            for t in &prepared.triangles {
                h.bytes(bytemuck::bytes_of(t));
            }
            let rows = prepared.overlap_free_rows.clone().map_or((u32::MAX, u32::MAX), |r| (r.start, r.end));
            for v in [prepared.snap_bits as u64, prepared.culled as u64, prepared.degenerate as u64, rows.0 as u64, rows.1 as u64] {
                h.bytes(&v.to_le_bytes());
            }
            let raster = rasterise(&scene, &params, Backend::Cpu).map_err(|e| e.to_string())?;
            let mut r = Fnv::new();
            r.bytes(bytemuck::cast_slice(&raster.values));
            out.push_str(&format!("{:016x} {:016x}  {name} [{}]\n", h.0, r.0, mode.name()));
            eprintln!("{name} [{}]: prepare {:.1} ms", mode.name(), seconds * 1e3);
        }
    }
    for (name, mesh, params) in frames()? {
        let frame = render(&mesh, &params, Backend::Cpu).map_err(|e| format!("{name}: {e}"))?;
        let mut h = Fnv::new();
        h.bytes(bytemuck::cast_slice(&frame.colour));
        h.bytes(bytemuck::cast_slice(&frame.depth));
        h.bytes(bytemuck::cast_slice(&frame.ids));
        out.push_str(&format!("{:016x}  frame: {name}\n", h.0));
    }
    Ok(out)
}

/// The frames whose bits the shade stage decides: a lit sphere and a textured ground plane
/// seen towards the horizon (magnified near the camera, minified far off), 320×180.
fn frames() -> Result<Vec<(String, Mesh, RenderParams)>, String> {
    let (w, h) = (320, 180);
    let mut sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 24, 32);
    sphere.colours = Some((0..sphere.positions.len()).map(|k| [(k % 7) as f32 / 6.0, (k % 5) as f32 / 4.0, 0.6, if k % 3 == 0 { 0.5 } else { 1.0 }]).collect());
    let camera = Camera::framing(&sphere, w as f64 / h as f64, Projection::Perspective { fov_deg: 45.0 }, Up::Y);
    let view = camera.view_projection(w, h).map_err(|e| e.to_string())?;
    let lit = RenderParams { eye: Some(camera.viewer()), ..RenderParams::new(w, h, view) };
    let mut frames = Vec::new();
    for shading in Shading::ALL {
        for interpolation in [Interpolation::Perspective, Interpolation::Screen, Interpolation::Flat] {
            frames.push((format!("sphere, {shading:?}, {interpolation:?}"), sphere.clone(), RenderParams { shading, interpolation, ..lit.clone() }));
        }
    }
    let phong = RenderParams { shading: Shading::Phong, ..lit.clone() };
    frames.push(("sphere, Phong, blended".into(), sphere.clone(), RenderParams { blend: true, cull: Cull::None, ..phong.clone() }));
    for samples in [4, 8] {
        frames.push((format!("sphere, Phong, {samples} samples"), sphere.clone(), RenderParams { samples, ..phong.clone() }));
    }
    let wire = Wireframe { rule: LineRule::DiamondExit, colour: None };
    frames.push(("sphere, wireframe and points".into(), sphere.clone(), RenderParams { wireframe: Some(wire), points: Some(3.0), ..phong.clone() }));

    let size = 256u32;
    let rgba: Vec<u8> = (0..size * size)
        .flat_map(|k| {
            let (x, y) = (k % size, k / size);
            let checker = if (x / 8 + y / 8) % 2 == 0 { 230 } else { 40 };
            [(x * 255 / (size - 1)) as u8, (y * 255 / (size - 1)) as u8, checker, if x % 32 < 24 { 255 } else { 128 }]
        })
        .collect();
    let mut plane = meshes::terrain(16, 100.0, 0.0);
    // Coordinates past [0, 1] on both sides, for every address mode.
    plane.uvs = Some(plane.positions.iter().map(|p| [(p[0] / 100.0 * 6.0 - 3.0) as f32, (p[1] / 100.0 * 6.0 - 1.5) as f32]).collect());
    plane.colours = Some(vec![[1.0, 0.9, 0.8, 1.0]; plane.positions.len()]);
    plane.textures = vec![Texture::srgb(size, size, rgba)];
    let camera = Camera {
        eye: [50.0, -8.0, 6.0],
        target: [50.0, 40.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 60.0 },
        near: 0.5,
        far: 200.0,
    };
    let view = camera.view_projection(w, h).map_err(|e| e.to_string())?;
    let ground = RenderParams { cull: Cull::None, eye: Some(camera.viewer()), ..RenderParams::new(w, h, view) };
    for filter in Filter::ALL {
        for address in Address::ALL {
            for shading in [Shading::Unlit, Shading::Phong] {
                let params = RenderParams { shading, texture_filter: Some(filter), texture_address: Some(address), ..ground.clone() };
                frames.push((format!("textured plane, {filter:?}, {address:?}, {shading:?}"), plane.clone(), params));
            }
        }
    }
    let trilinear = RenderParams { shading: Shading::Phong, texture_filter: Some(Filter::Trilinear), ..ground };
    frames.push(("textured plane, Trilinear, blended".into(), plane.clone(), RenderParams { blend: true, ..trilinear.clone() }));
    frames.push(("textured plane, Trilinear, 4 samples".into(), plane.clone(), RenderParams { samples: 4, ..trilinear.clone() }));
    frames.push(("textured plane, Trilinear, Screen".into(), plane, RenderParams { interpolation: Interpolation::Screen, ..trilinear }));
    Ok(frames)
}
