//! GPU frames whose assembly runs on the device's rows (`AssemblyOn::Device`), whatever the
//! adapter's default (on a CPU implementation of Vulkan the host's twins assemble): the CPU
//! backend's bits and statistics, and the records and lists set up where the rows wrote them,
//! the call handing none over. Every test of this file (its own process) makes that choice.

mod common;

use common::{assert_frame_parity, gpu_or_skip};
use tileraster::Backend;
use tileraster::render::{
    Camera, Cull, Eye, Frame, Instance, Interpolation, Mesh, PreparedMesh, Projection, RenderParams, Shading, Up, World, render, render_world,
};
use tileraster_testkit::meshes;

/// Whether the GPU backend runs here (else skipped, as `gpu_or_skip` says), its assembly on the
/// device's rows from now on.
fn device_assembly(test: &str) -> bool {
    tileraster::set_gpu_assembly_on(tileraster::GpuAssemblyOn::Device);
    gpu_or_skip(test)
}

/// A terrain grid seen from just above it, so that the near plane, the far plane and the
/// guard band cut hundreds of faces (clipped on the host and patched in by the rows).
fn low_view(w: u32, h: u32) -> (Mesh, RenderParams) {
    let mesh = meshes::terrain(300, 400.0, 8.0);
    let eye = [201.3, 197.9, 4.4];
    let camera = Camera { eye, target: [180.0, 270.0, -3.0], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.3, far: 80.0 };
    let params = RenderParams { eye: Some(Eye::Point(eye)), ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap()) };
    (mesh, params)
}

fn assert_same(what: &str, a: &Frame, b: &Frame) {
    assert!(a.colour == b.colour && a.ids == b.ids && a.fragments == b.fragments, "{what}: the frames differ");
    assert!(a.depth.iter().zip(&b.depth).all(|(x, y)| x.to_bits() == y.to_bits()) && a.depth.len() == b.depth.len(), "{what}: depths differ");
    assert_eq!(a.stats, b.stats, "{what}: statistics");
}

/// Every shading and interpolation, culling, blending, four samples, the tile counts and a
/// textured plane: the same frames on both backends.
#[test]
fn frames_assembled_on_the_device_are_the_cpus_bits() {
    if !device_assembly("frames_assembled_on_the_device_are_the_cpus_bits") {
        return;
    }
    let (terrain, base) = low_view(200, 130);
    let cases = [
        ("flat shading, flat interpolation", RenderParams { cull: Cull::None, shading: Shading::Flat, interpolation: Interpolation::Flat, ..base.clone() }),
        ("Gouraud, back faces culled", RenderParams { cull: Cull::Back, shading: Shading::Smooth, ..base.clone() }),
        ("Phong, four samples", RenderParams { samples: 4, ..base.clone() }),
        ("ids, tiles counted", RenderParams { shading: Shading::Ids, count_tiles: true, ..base.clone() }),
        ("unlit, blended", RenderParams { shading: Shading::Unlit, blend: true, ..base.clone() }),
    ];
    for (what, params) in &cases {
        let frame = assert_frame_parity(what, &terrain, params);
        assert!(frame.stats.geometry.clipped > 100 && frame.stats.geometry.rasterised > 1000, "{what}: {:?}", frame.stats.geometry);
    }
    let plane = meshes::textured_plane(40, 64);
    let [eye, target, up] = meshes::TEXTURED_PLANE_EYE;
    let camera = Camera { eye, target, up, projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.5, far: 200.0 };
    let textured = RenderParams { shading: Shading::Unlit, ..RenderParams::new(160, 100, camera.view_projection(160, 100).unwrap()) };
    assert_frame_parity("a textured plane", &plane, &textured);
}

/// A world of two meshes placed four times (moved, turned, mirrored): each placement's records
/// after the last's, the same frame on both backends.
#[test]
fn a_world_assembled_on_the_device_is_the_cpus() {
    if !device_assembly("a_world_assembled_on_the_device_is_the_cpus") {
        return;
    }
    let sphere = meshes::sphere([0.0; 3], 1.0, 12, 18);
    let soup = meshes::soup(200, [-1.0; 3], [1.0; 3], 0.5, 3);
    let moved = |x: f64, y: f64, mirror: f64| [[mirror, 0.0, 0.0, x], [0.0, 1.0, 0.0, y], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let world = World {
        meshes: vec![sphere, soup],
        instances: vec![
            Instance::of(0),
            Instance { mesh: 1, transform: moved(2.5, 0.0, 1.0) },
            Instance { mesh: 0, transform: moved(-2.5, 0.5, -1.0) },
            Instance { mesh: 1, transform: moved(0.0, 2.5, -1.0) },
        ],
    };
    let camera =
        Camera { eye: [2.0, -7.0, 4.0], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.5, far: 40.0 };
    for shading in [Shading::Phong, Shading::Flat, Shading::Smooth, Shading::Ids] {
        let params = RenderParams { shading, eye: Some(camera.viewer()), ..RenderParams::new(150, 110, camera.view_projection(150, 110).unwrap()) };
        let cpu = render_world(&world, &params, Backend::Cpu).unwrap();
        let gpu = render_world(&world, &params, Backend::Gpu).unwrap();
        assert_same(&format!("the world, {}", shading.name()), &cpu, &gpu);
        assert_eq!(cpu.stats.geometry.instances_drawn, 4);
    }
}

/// A prepared mesh's frames (other cameras, shadings and sizes) on the device are the one-shot
/// CPU frames, and a later frame at the same placement hands over the stages' parameters
/// alone (no lighting per vertex, no clipped face).
#[test]
fn a_prepared_meshs_frames_on_the_device_are_the_cpus() {
    use tileraster_kernels::abi::{AssembleParams, VertexParams};
    if !device_assembly("a_prepared_meshs_frames_on_the_device_are_the_cpus") {
        return;
    }
    let mesh = meshes::terrain(60, 100.0, 12.0);
    let mut prepared = PreparedMesh::new(mesh.clone()).unwrap();
    let mut frame = Frame::default();
    let view = |w: u32, h: u32, yaw: f64| {
        let camera = Camera::framing(&mesh, w as f64 / h as f64, Projection::Perspective { fov_deg: 50.0 }, Up::Z);
        let (c, s) = (yaw.cos(), yaw.sin());
        let d = [camera.eye[0] - camera.target[0], camera.eye[1] - camera.target[1], camera.eye[2]];
        let eye = [camera.target[0] + c * d[0] - s * d[1], camera.target[1] + s * d[0] + c * d[1], d[2]];
        let camera = Camera { eye, ..camera };
        RenderParams { eye: Some(camera.viewer()), ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap()) }
    };
    let frames = [
        (120, 90, 0.0, Shading::Phong),
        (120, 90, 0.3, Shading::Phong),
        (90, 60, 1.1, Shading::Ids),
        (150, 100, 2.0, Shading::Flat),
        (150, 100, 2.5, Shading::Smooth),
    ];
    for (k, (w, h, yaw, shading)) in frames.into_iter().enumerate() {
        let params = RenderParams { shading, ..view(w, h, yaw) };
        prepared.render_into(&params, Backend::Gpu, &mut frame).unwrap();
        let once = render(&mesh, &params, Backend::Cpu).unwrap();
        assert!(frame.colour == once.colour && frame.ids == once.ids, "frame {k}: the prepared GPU frame differs from the one-shot CPU frame");
        assert!(frame.depth.iter().zip(&once.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "frame {k}: depths");
        if k == 1 {
            let parameters = (std::mem::size_of::<VertexParams>() + 2 * std::mem::size_of::<AssembleParams>()) as u64;
            assert_eq!(frame.stats.geometry.bytes_uploaded, parameters, "frame {k}: a later Phong frame hands over its parameters alone");
        }
    }
}

/// The raster call sets up the records where the rows wrote them and bins by their lists: it
/// writes the shade parameters and one `FrameParams` uniform per dispatch (setup's and the
/// window's), measured where it writes them; a frame assembled apart hands its records and
/// lists over whole.
#[test]
fn the_device_keeps_the_records() {
    use tileraster_kernels::abi::{FrameParams, ShadeParams, TriangleInput, TriangleShading};
    if !device_assembly("the_device_keeps_the_records") {
        return;
    }
    let (mesh, params) = low_view(96, 64);
    let mut device = tileraster_gpu::GeometryDevice::default();
    let (prepared, _) = tileraster_core::render::prepare_render(&mesh, &params, &mut device).unwrap();
    let plan = prepared.plan(prepared.window, false).unwrap();
    let render = prepared.render.as_ref().unwrap();
    let textures = (std::mem::size_of_val(render.textures.as_slice()) + std::mem::size_of_val(render.materials.as_slice())) as u64;
    let raster = std::mem::size_of::<ShadeParams>() as u64 + textures + 2 * std::mem::size_of::<FrameParams>() as u64;
    let (held, profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, Some(&device)).unwrap();
    assert_eq!(profile.bytes_up, raster, "{profile:?}");
    let records = prepared.triangles.len() as u64;
    assert!(records > 1000, "{records} records");
    let lists = 4 * (plan.listed.len() + plan.small.len()) as u64;
    let (apart, profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, None).unwrap();
    let whole = records * (std::mem::size_of::<TriangleInput>() + std::mem::size_of::<TriangleShading>()) as u64;
    assert_eq!(profile.bytes_up, raster + whole + lists, "{profile:?}");
    assert!(held.colours == apart.colours && held.faces == apart.faces, "the same frame either way");

    // A world of three placements: each one's records after the last's, all held.
    let world = World {
        meshes: vec![mesh.clone()],
        instances: vec![
            Instance::of(0),
            Instance { mesh: 0, transform: [[1.0, 0.0, 0.0, 2.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]] },
            Instance { mesh: 0, transform: [[-1.0, 0.0, 0.0, 400.0], [0.0, 1.0, 0.0, -3.0], [0.0, 0.0, 1.0, 0.5], [0.0, 0.0, 0.0, 1.0]] },
        ],
    };
    let mut device = tileraster_gpu::GeometryDevice::default();
    let (prepared, counts) = tileraster_core::render::prepare_world(&world, &params, &mut device).unwrap();
    assert_eq!(counts.instances_drawn, 3);
    let plan = prepared.plan(prepared.window, false).unwrap();
    let (held, profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, Some(&device)).unwrap();
    assert_eq!(profile.bytes_up, raster, "the world: {profile:?}");
    let cpu = tileraster::render::render_world(&world, &params, Backend::Cpu).unwrap();
    assert!(held.colours.as_ref() == Some(&cpu.colour) && held.faces.as_ref() == Some(&cpu.ids), "the world's frame is the CPU's");
}
