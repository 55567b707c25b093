//! The waves through the programmable vertex stage: the same bits on both backends (one-shot
//! frames in each shading, a prepared sea's frames, a world of instances, a calm map read as a
//! vertex texture), a still sea the bits of the mesh drawn without a shader, the posed vertices
//! where an `f64` reference of the waves puts them, and modules that are not a vertex shader's
//! refused.

#[path = "../../../tests/common/mod.rs"]
mod common;

use common::{assert_frame_parity, render_frame};
use tileraster::Backend;
use tileraster::render::{Frame, Instance, NO_FACE, PreparedMesh, RenderParams, Shading, VertexStage, VertexTexture, World, posed_positions};
use waves::{CREST, WAVES, params, sea};

fn covered(f: &Frame) -> usize {
    f.ids.iter().filter(|&&id| id != NO_FACE).count()
}

#[test]
fn the_waves_are_the_same_bits_on_both_backends() {
    let mesh = sea(96);
    for (time, shading) in [(0.0, Shading::Phong), (3.7, Shading::Phong), (3.7, Shading::Smooth), (11.0, Shading::Flat)] {
        let p = RenderParams { shading, ..params(&mesh, 240, 160, time).unwrap() };
        let frame = assert_frame_parity(&format!("waves at {time} s, {shading:?}"), &mesh, &p);
        assert!(covered(&frame) > 240 * 160 / 3, "the sea fills the frame: {} pixels", covered(&frame));
    }
}

/// The shader moved the sea: the frame differs from the still sea's, and from one a moment
/// later; a still sea (no crest) is the mesh drawn without a shader, bit for bit, on both
/// backends, its normals computed from the same faces.
#[test]
fn a_still_sea_is_the_mesh_drawn_without_a_shader() {
    let mesh = sea(64);
    let waves = params(&mesh, 200, 120, 2.0).unwrap();
    let mut still = waves.clone();
    still.vertex_constants[0] = 0.0;
    let unposed = RenderParams { vertex: None, ..waves.clone() };
    for backend in [Backend::Cpu, Backend::Gpu] {
        if backend == Backend::Gpu && !common::gpu_or_skip("a still sea on the GPU") {
            continue;
        }
        let (a, b) = (render_frame(&mesh, &still, backend), render_frame(&mesh, &unposed, backend));
        assert!(a.colour == b.colour && a.ids == b.ids, "{backend:?}: the still sea differs from the unposed mesh");
        assert!(a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits()), "{backend:?}: depths");
        let moving = render_frame(&mesh, &waves, backend);
        let differ = moving.colour.iter().zip(&a.colour).filter(|(x, y)| x != y).count();
        assert!(differ > covered(&moving) / 2, "{backend:?}: {differ} pixels differ from the still sea");
        let later = render_frame(&mesh, &RenderParams { time: 2.5, ..waves.clone() }, backend);
        assert_ne!(later.colour, moving.colour, "{backend:?}: the time moves the waves");
    }
}

/// A prepared sea keeps its unposed positions (handed to the GPU once) and poses them each
/// frame: its frames are the one-shot frames' bits on both backends, and a later frame hands
/// over parameters, lights and the posed sea's attributes but not its positions.
#[test]
fn a_prepared_sea_poses_its_kept_positions_each_frame() {
    let mesh = sea(48);
    let mut prepared = PreparedMesh::new(mesh.clone()).unwrap();
    let backends: Vec<Backend> = [Backend::Cpu, Backend::Gpu].into_iter().filter(|&b| b == Backend::Cpu || common::gpu_or_skip("a prepared sea")).collect();
    for backend in backends {
        let mut uploads = Vec::new();
        for time in [0.0, 1.5, 0.0, 4.0] {
            let p = params(&mesh, 160, 100, time).unwrap();
            let frame = prepared.render(&p, backend).unwrap();
            let once = render_frame(&mesh, &p, backend);
            assert!(frame.colour == once.colour && frame.ids == once.ids, "{backend:?} at {time} s: the prepared frame differs");
            uploads.push(frame.stats.raster.bytes_uploaded);
        }
        let positions = (mesh.positions.len() * 24) as u64;
        assert!(uploads[1..].iter().all(|&b| b + positions <= uploads[0]), "{backend:?}: bytes uploaded per frame {uploads:?}");
    }
}

/// Several instances of the sea: the host poses the mesh once and the stage projects the
/// world's positions as they are, the same bits on both backends.
#[test]
fn a_world_of_seas_is_the_same_bits_on_both_backends() {
    let mesh = sea(32);
    let shifted = |dx: f64| [[1.0, 0.0, 0.0, dx], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let world =
        World { meshes: vec![mesh.clone()], instances: vec![Instance { mesh: 0, transform: shifted(0.0) }, Instance { mesh: 0, transform: shifted(-2000.0) }] };
    let p = params(&mesh, 200, 120, 6.0).unwrap();
    let cpu = tileraster::render::render_world(&world, &p, Backend::Cpu).unwrap();
    assert!(covered(&cpu) > 200 * 120 / 3);
    if common::gpu_or_skip("a world of seas") {
        let gpu = tileraster::render::render_world(&world, &p, Backend::Gpu).unwrap();
        assert!(cpu.colour == gpu.colour && cpu.ids == gpu.ids, "the worlds differ");
    }
}

/// A calm map handed as a vertex texture reaches the shader on both backends: all ones is the
/// open sea's frame bit for bit; zeros west of the middle leave that half where the mesh has it,
/// and the rest moves as in the open sea.
#[test]
fn a_calm_map_read_as_a_vertex_texture_stills_the_sea_where_it_says() {
    let n = 48u32;
    let mesh = sea(n);
    let open = params(&mesh, 200, 120, 3.0).unwrap();
    let map = |f: &dyn Fn(u32) -> f32| {
        let texels = (0..(n + 1) * (n + 1)).map(|k| f(k % (n + 1))).collect();
        Some(std::sync::Arc::new(VertexTexture { width: n + 1, height: n + 1, texels }))
    };
    let everywhere = RenderParams { vertex_texture: map(&|_| 1.0), ..open.clone() };
    let harbour = RenderParams { vertex_texture: map(&|column| if column < n / 2 { 0.0 } else { 1.0 }), ..open.clone() };
    let a = assert_frame_parity("a calm map of ones", &mesh, &everywhere);
    let b = render_frame(&mesh, &open, Backend::Cpu);
    assert!(a.colour == b.colour && a.ids == b.ids, "a calm map of ones is the open sea");
    assert_frame_parity("a harbour", &mesh, &harbour);
    let (calm, rough) = (posed_positions(&mesh, &harbour).unwrap(), posed_positions(&mesh, &open).unwrap());
    for (k, ((p, q), r)) in mesh.positions.iter().zip(&calm).zip(&rough).enumerate() {
        let column = k as u32 % (n + 1);
        assert_eq!(*q, if column < n / 2 { *p } else { *r }, "vertex {k}");
    }
}

/// A module that is not a vertex shader's (the kernels', with every stage; bytes that are not
/// SPIR-V) is refused with a typed error before it reaches the driver; the example's own
/// modules pass the same checks.
#[test]
fn the_gpu_backend_checks_a_vertex_shaders_module_before_running_it() {
    for float_controls in [false, true] {
        if let Err(problems) = tileraster_build::check::program_module(WAVES.module(float_controls), tileraster_build::Role::Vertex) {
            panic!("the waves' module (float controls {float_controls}):\n{}", problems.join("\n"));
        }
    }
    let kernels = VertexStage::from_parts("kernels", WAVES.program(), tileraster_gpu::KERNELS_SPV, tileraster_gpu::KERNELS_FLOAT_CONTROLS_SPV);
    let garbage = VertexStage::from_parts("garbage", WAVES.program(), &[1, 2, 3, 4, 5, 6, 7, 8], &[1, 2, 3, 4, 5, 6, 7, 8]);
    let mesh = sea(8);
    if common::gpu_or_skip("a bad vertex module") {
        for stage in [kernels, garbage] {
            let p = RenderParams { vertex: Some(stage), ..params(&mesh, 64, 48, 1.0).unwrap() };
            match tileraster::render::render(&mesh, &p, Backend::Gpu) {
                Err(tileraster::Error::VertexShader { name, problems }) => assert!(name == stage.name() && !problems.is_empty()),
                other => panic!("{}: {:?}", stage.name(), other.map(|f| f.stats)),
            }
        }
    }
}

/// A shader's non-finite pose is a typed error naming the shader and the vertex.
#[test]
fn a_pose_beyond_the_numbers_is_a_typed_error() {
    let mesh = sea(8);
    let mut p = params(&mesh, 64, 48, 1.0).unwrap();
    p.vertex_constants[0] = f32::INFINITY;
    match tileraster::render::render(&mesh, &p, Backend::Cpu) {
        Err(tileraster::Error::VertexPosedBeyond { name, vertex, position }) => {
            assert_eq!(name, WAVES.name());
            assert!(!position[2].is_finite(), "vertex {vertex} at {position:?}");
        }
        other => panic!("{:?}", other.map(|f| f.stats)),
    }
}

/// The posed sea where an `f64` reference of the waves puts it: each vertex's height within the
/// bound of the shader's `f32` arithmetic (a few units of `2^-24` of the crest, plus the
/// position's rounding to `f32` relative to the sea's centre).
#[test]
fn the_posed_heights_follow_an_f64_reference_of_the_waves() {
    let mesh = sea(64);
    let time = 7.25f32;
    let posed = posed_positions(&mesh, &params(&mesh, 64, 48, time).unwrap()).unwrap();
    let centre = [waves::CORNER[0] + waves::SIDE / 2.0, waves::CORNER[1] + waves::SIDE / 2.0];
    let swell = |x: f64| {
        let u = (x - x.floor()) * 2.0 - 1.0;
        -4.0 * u * (1.0 - u.abs())
    };
    let waves: [([f64; 2], f64, f64, f64); 3] =
        [([0.8, 0.6], 1.0 / 420.0, 0.11, 1.0), ([-0.28, 0.96], 1.0 / 230.0, 0.17, 0.45), ([0.96, -0.28], 1.0 / 97.0, 0.29, 0.18)];
    let (mut worst, mut largest_phase) = (0.0f64, 0.0f64);
    for (p, q) in mesh.positions.iter().zip(&posed) {
        assert_eq!((p[0], p[1]), (q[0], q[1]), "the waves move vertices only up and down");
        let (x, y) = (p[0] - centre[0], p[1] - centre[1]);
        let phases = waves.map(|(d, k, speed, _)| (d[0] * x + d[1] * y) * k - speed * time as f64);
        largest_phase = phases.iter().fold(largest_phase, |m, f| m.max(f.abs()));
        let lift: f64 = waves.iter().zip(phases).map(|(w, phase)| w.3 * swell(phase)).sum();
        worst = worst.max((q[2] - CREST as f64 * lift).abs());
    }
    // The shader's `f32` phase lies within a few (here 8) units of `2^-24` of the largest phase
    // of the exact one (its constants and the position rounded to `f32`, three products and two
    // sums); the swell's slope (at most 8 per cycle), the waves' heights (1.63 in all) and the
    // crest scale that into a height.
    let bound = CREST as f64 * 1.63 * 8.0 * 8.0 * largest_phase * 2f64.powi(-24);
    println!("largest height error {worst:.3e} m (bound {bound:.3e} m)");
    assert!(worst <= bound, "largest height error {worst} m, bound {bound} m");
}
