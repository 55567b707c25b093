//! The vertex stage's built-in programs.
//!
//! The heightfield program (`VertexStage::HEIGHTS`): a DEM's flat grid lifted by its heights as
//! a vertex texture is, vertex for vertex and pixel for pixel, the terrain the host meshes from
//! the same DEM, on both backends; a prepared grid hands its heights over once, takes a
//! vertical exaggeration as a constant of the frame, and keeps its posed attributes while the
//! pose stays the same.
//!
//! The deform program (`VertexStage::DEFORM`): a glTF file's skin and morph targets posed in
//! the kernels give the same bits on both backends, and the frames of the host's `f64` pose; a
//! prepared mesh hands over a new pose and nothing of the mesh. (A user's vertex shader is
//! `examples/waves`.)

mod common;

use std::sync::Arc;
use tileraster::Backend;
use tileraster::render::{
    Camera, Cull, Frame, PosableGltf, PreparedMesh, Projection, RenderParams, Shading, VertexStage, dem_grid, dem_mesh, posed_positions, read_posable_at,
    read_world_at, render,
};
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

/// The parameters of a frame of `common::skinned_gltf` in perspective, posed by `posable`.
fn posed_view(posable: &PosableGltf, shading: Shading) -> RenderParams {
    let camera = common::skinned_camera();
    RenderParams {
        shading,
        cull: Cull::None,
        eye: Some(camera.viewer()),
        vertex: Some(VertexStage::DEFORM),
        vertex_constants: posable.constants,
        vertex_texture: Some(Arc::new(posable.texture.clone())),
        ..RenderParams::new(96, 72, camera.view_projection(96, 72).unwrap())
    }
}

fn backends(test: &str) -> Vec<Backend> {
    [Backend::Cpu, Backend::Gpu].into_iter().filter(|&b| b == Backend::Cpu || common::gpu_or_skip(test)).collect()
}

#[test]
fn a_gltf_file_posed_by_the_deform_program_is_the_host_pose_on_both_backends() {
    let dir = std::env::temp_dir().join(format!("tileraster-deform-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = common::skinned_gltf(&dir);
    let mut seen = std::collections::HashSet::new();
    for time in [None, Some(0.25), Some(0.5), Some(0.9)] {
        let posable = read_posable_at(&path, time).unwrap().expect("a skin and a morph target");
        let host = read_world_at(&path, time).unwrap().flattened().unwrap();
        for shading in [Shading::Flat, Shading::Smooth, Shading::Phong] {
            let params = posed_view(&posable, shading);
            let plain = RenderParams { vertex: None, vertex_texture: None, ..params.clone() };
            let mut frames = Vec::new();
            for backend in backends("the deform program") {
                let kernels = render(&posable.mesh, &params, backend).unwrap();
                let reference = render(&host, &plain, backend).unwrap();
                assert!(kernels.stats.pixels_covered > 500, "{time:?} s: {} pixels", kernels.stats.pixels_covered);
                // The pose in `f32` moves a corner by a few units of `2^-24` at most: a pixel
                // centre on an edge could change hands, none here does.
                assert!(same(&kernels, &reference), "{backend:?} at {time:?} s, {}: the kernels' pose differs from the host's", shading.name());
                frames.push(kernels);
            }
            if let [cpu, gpu] = &frames[..] {
                assert!(same(cpu, gpu), "at {time:?} s, {}: the backends differ", shading.name());
            }
            seen.insert(frames[0].colour.clone());
        }
    }
    assert_eq!(seen.len(), 12, "every time and shading gives its own frame");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_prepared_posable_mesh_hands_over_its_pose_and_nothing_of_the_mesh() {
    let dir = std::env::temp_dir().join(format!("tileraster-deform-prepared-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = common::skinned_gltf(&dir);
    let poses: Vec<PosableGltf> = [0.2, 0.6].into_iter().map(|t| read_posable_at(&path, Some(t)).unwrap().unwrap()).collect();
    assert_eq!(poses[0].mesh, poses[1].mesh, "the mesh at rest is the same at every time");
    let texture_bytes = (poses[0].texture.texels.len() * 4) as u64;
    let mut by_backend = Vec::new();
    for backend in backends("a prepared posable mesh") {
        let mut prepared = PreparedMesh::new(poses[0].mesh.clone()).unwrap();
        let (first, second) = (posed_view(&poses[0], Shading::Smooth), posed_view(&poses[1], Shading::Smooth));
        let frames: Vec<Frame> = [&first, &second, &second].iter().map(|p| prepared.render(p, backend).unwrap()).collect();
        for (frame, p) in frames.iter().zip([&first, &second, &second]) {
            assert!(same(frame, &render(&poses[0].mesh, p, backend).unwrap()), "{backend:?}: a prepared frame differs from its one-shot frame");
        }
        let bytes: Vec<u64> = frames.iter().map(|f| f.stats.raster.bytes_uploaded).collect();
        // A new pose hands over the texels of the texture that changed (its joints and weights,
        // at its start) and the posed attributes, nothing of the mesh; the same pose again only
        // the frame's parameters.
        let layout = tileraster::render::DeformLayout { joints: poses[0].constants[0] as u32, weights: poses[0].constants[1] as u32, targets: 0 };
        let (pose_bytes, attributes) = (4 * layout.weight(layout.weights) as u64, 6 * 48);
        assert!(
            bytes[1] < bytes[0] && bytes[1] > bytes[2] + attributes && bytes[1] <= bytes[2] + attributes + pose_bytes && bytes[2] < 1024,
            "{backend:?}: bytes uploaded {bytes:?} (the texture: {texture_bytes}, its pose: {pose_bytes})"
        );
        assert!(!same(&frames[0], &frames[1]) && same(&frames[1], &frames[2]), "{backend:?}: the pose changes the frame");
        by_backend.push(frames);
    }
    if let [cpu, gpu] = &by_backend[..] {
        assert!(cpu.iter().zip(gpu).all(|(a, b)| same(a, b)), "the backends differ");
    }
    // A texture too short for the mesh is a typed error.
    let mut short = posed_view(&poses[0], Shading::Smooth);
    let mut texture = poses[0].texture.clone();
    texture.texels.truncate(texture.texels.len() - 9);
    texture.width -= 9;
    short.vertex_texture = Some(Arc::new(texture));
    match render(&poses[0].mesh, &short, Backend::Cpu) {
        Err(tileraster::Error::DeformTexture { vertices: 6, .. }) => {}
        other => panic!("{:?}", other.map(|f| f.stats)),
    }
    std::fs::remove_dir_all(&dir).ok();
}
