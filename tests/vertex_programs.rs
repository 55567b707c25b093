//! The vertex stage's built-in heightfield program (`VertexStage::HEIGHTS`): a DEM's flat grid
//! lifted by its heights as a vertex texture is, vertex for vertex and pixel for pixel, the
//! terrain the host meshes from the same DEM, on both backends; a prepared grid hands its
//! heights over once, takes a vertical exaggeration as a constant of the frame, and keeps its
//! posed attributes while the pose stays the same. (A user's
//! vertex shader is `examples/waves`.)

mod common;

use std::sync::Arc;
use tileraster::Backend;
use tileraster::render::{Camera, Frame, PreparedMesh, Projection, RenderParams, Shading, VertexStage, dem_grid, dem_mesh, posed_positions, render};
use tileraster_io::Dem;

/// 60 × 40 cells of 25 m at 500 km E, 5,000 km N: hills of `f32` heights, with a hole of
/// nodata cells and a NaN.
fn dem() -> Dem {
    let (w, h) = (60u32, 40u32);
    let mut heights: Vec<f64> = (0..w * h)
        .map(|k| {
            let (c, r) = ((k % w) as f64, (k / w) as f64);
            (300.0 + 40.0 * (c * 0.21).sin() + 25.0 * (r * 0.17).cos() + 0.001 * c * r) as f32 as f64
        })
        .collect();
    for (c, r) in [(10, 10), (11, 10), (10, 11), (40, 30)] {
        heights[r * w as usize + c] = -9999.0;
    }
    heights[5] = f64::NAN;
    Dem { width: w, height: h, x0: 500_000.0, y0: 5_001_000.0, dx: 25.0, dy: 25.0, nodata: Some(-9999.0), heights }
}

fn same(a: &Frame, b: &Frame) -> bool {
    a.colour == b.colour && a.ids == b.ids && a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn a_dem_lifted_by_the_heights_program_is_the_terrain_the_host_meshes() {
    let dem = dem();
    let meshed = dem_mesh(&dem).unwrap();
    let (grid, texture) = dem_grid(&dem).expect("f32 heights");
    let camera =
        Camera::look_at([500_000.0, 4_999_800.0, 700.0], [500_750.0, 5_000_500.0, 300.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 50.0 }, &meshed);
    let plain = RenderParams { eye: Some(camera.viewer()), shading: Shading::Phong, ..RenderParams::new(320, 200, camera.view_projection(320, 200).unwrap()) };
    let mut lifted = RenderParams { vertex: Some(VertexStage::HEIGHTS), vertex_texture: Some(Arc::new(texture)), ..plain.clone() };
    lifted.vertex_constants[0] = 1.0;

    // Posed, the grid's vertices with a height are the meshed DEM's, bit for bit.
    let posed = posed_positions(&grid, &lifted).unwrap();
    let valid: Vec<[f64; 3]> = (0..posed.len()).filter(|&k| dem.has_value(k as u32 % dem.width, k as u32 / dem.width)).map(|k| posed[k]).collect();
    assert_eq!(valid, meshed.positions);
    assert_eq!(grid.triangles.len(), meshed.triangles.len());

    let backends: Vec<Backend> =
        [Backend::Cpu, Backend::Gpu].into_iter().filter(|&b| b == Backend::Cpu || common::gpu_or_skip("the heights program")).collect();
    let mut frames = Vec::new();
    for &backend in &backends {
        let host = render(&meshed, &plain, backend).unwrap();
        let kernels = render(&grid, &lifted, backend).unwrap();
        let covered = host.ids.iter().filter(|&&id| id != tileraster::render::NO_FACE).count();
        assert!(covered > 320 * 200 / 3, "{backend:?}: the terrain covers {covered} pixels");
        assert!(same(&host, &kernels), "{backend:?}: the lifted grid's frame differs from the meshed DEM's");
        frames.push(kernels);
    }
    if let [cpu, gpu] = &frames[..] {
        assert!(same(cpu, gpu), "the backends differ");
    }
}

#[test]
fn a_prepared_grid_hands_its_heights_over_once_and_exaggerates_them_per_frame() {
    let dem = dem();
    let (grid, texture) = dem_grid(&dem).unwrap();
    let texture_bytes = (texture.texels.len() * 4) as u64;
    let camera =
        Camera::look_at([499_600.0, 5_000_100.0, 1400.0], [500_750.0, 5_000_500.0, 300.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 50.0 }, &grid);
    let mut p = RenderParams {
        vertex: Some(VertexStage::HEIGHTS),
        vertex_texture: Some(Arc::new(texture)),
        ..RenderParams::new(200, 120, camera.view_projection(200, 120).unwrap())
    };
    let backends: Vec<Backend> = [Backend::Cpu, Backend::Gpu].into_iter().filter(|&b| b == Backend::Cpu || common::gpu_or_skip("a prepared grid")).collect();
    let mut by_backend = Vec::new();
    for backend in backends {
        let mut prepared = PreparedMesh::new(grid.clone()).unwrap();
        let mut frames = Vec::new();
        for exaggeration in [1.0, 3.0, 1.0, 1.0] {
            p.vertex_constants[0] = exaggeration;
            let frame = prepared.render(&p, backend).unwrap();
            assert!(same(&frame, &render(&grid, &p, backend).unwrap()), "{backend:?}, ×{exaggeration}: the prepared frame differs");
            frames.push(frame);
        }
        let bytes: Vec<u64> = frames.iter().map(|f| f.stats.raster.bytes_uploaded).collect();
        // A new exaggeration poses the grid anew (its attributes handed over again, not its
        // heights); the same one again, as a camera that moves, hands over only the frame's
        // parameters.
        assert!(
            bytes[1..].iter().all(|&b| b + texture_bytes <= bytes[0]) && bytes[3] < 1024,
            "{backend:?}: bytes uploaded {bytes:?} (the heights: {texture_bytes})"
        );
        assert!(
            !same(&frames[0], &frames[1]) && same(&frames[0], &frames[2]) && same(&frames[0], &frames[3]),
            "{backend:?}: the exaggeration changes the frame, and only it"
        );
        by_backend.push(frames);
    }
    if let [cpu, gpu] = &by_backend[..] {
        assert!(cpu.iter().zip(gpu).all(|(a, b)| same(a, b)), "the backends differ");
    }
}

#[test]
fn a_vertex_texture_of_the_wrong_size_is_a_typed_error() {
    let (grid, mut texture) = dem_grid(&dem()).unwrap();
    texture.texels.pop();
    let camera =
        Camera::look_at([499_600.0, 5_000_100.0, 900.0], [500_750.0, 5_000_500.0, 300.0], [0.0, 0.0, 1.0], Projection::Perspective { fov_deg: 50.0 }, &grid);
    let p = RenderParams {
        vertex: Some(VertexStage::HEIGHTS),
        vertex_texture: Some(Arc::new(texture)),
        ..RenderParams::new(64, 48, camera.view_projection(64, 48).unwrap())
    };
    match render(&grid, &p, Backend::Cpu) {
        Err(tileraster::Error::InvalidVertexTexture { width: 60, height: 40, texels: 2399 }) => {}
        other => panic!("{:?}", other.map(|f| f.stats)),
    }
}
