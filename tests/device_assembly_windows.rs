//! A frame assembled on the device's rows (`AssemblyOn::Device`) and rasterised in many
//! windows (the GPU's window limit lowered): every window bins by the lists the rows wrote and
//! sets up nothing again, and the frame is the CPU backend's. Its own process: the limit and
//! the choice hold for the whole test binary.

mod common;

use tileraster::Backend;
use tileraster::render::{Camera, Eye, Projection, RenderParams, Shading, render};
use tileraster_testkit::meshes;

#[test]
fn a_frame_assembled_on_the_device_in_many_windows_is_the_cpus() {
    use tileraster_kernels::abi::{TriangleInput, TriangleShading};
    tileraster::set_gpu_assembly_on(tileraster::GpuAssemblyOn::Device);
    if !common::gpu_or_skip("a_frame_assembled_on_the_device_in_many_windows_is_the_cpus") {
        return;
    }
    let mesh = meshes::terrain(200, 400.0, 8.0);
    let eye = [201.3, 197.9, 4.4];
    let camera = Camera { eye, target: [180.0, 270.0, -3.0], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.3, far: 80.0 };
    let (w, h) = (150, 100);
    let base = RenderParams { eye: Some(Eye::Point(eye)), ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap()) };
    // 32 × 32 pixels a window: 5 × 4 windows.
    tileraster::set_gpu_window_limit(32 * 32);
    for (what, params) in [
        ("Phong", base.clone()),
        ("face ids", RenderParams { shading: Shading::Ids, ..base.clone() }),
        ("four samples", RenderParams { samples: 4, ..base.clone() }),
    ] {
        let cpu = render(&mesh, &params, Backend::Cpu).unwrap();
        let gpu = render(&mesh, &params, Backend::Gpu).unwrap();
        assert!(cpu.colour == gpu.colour && cpu.ids == gpu.ids && cpu.fragments == gpu.fragments, "{what}: the frames differ");
        assert!(cpu.depth.iter().zip(&gpu.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "{what}: depths differ");
        assert_eq!(cpu.stats, gpu.stats, "{what}: statistics");
        assert!(cpu.stats.geometry.clipped > 50, "{what}: {:?}", cpu.stats.geometry);
    }
    // Held, the call writes neither the records nor the lists, in any window: exactly those
    // bytes less than the same call over the frame assembled apart.
    let mut device = tileraster_gpu::GeometryDevice::default();
    let (prepared, _) = tileraster_core::render::prepare_render(&mesh, &base, &mut device).unwrap();
    let plan = prepared.plan(prepared.window, false).unwrap();
    let (held, profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, Some(&device)).unwrap();
    let (apart, apart_profile) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, None).unwrap();
    let records = prepared.triangles.len() * (std::mem::size_of::<TriangleInput>() + std::mem::size_of::<TriangleShading>());
    let lists = 4 * (plan.listed.len() + plan.small.len());
    assert_eq!(apart_profile.bytes_up - profile.bytes_up, (records + lists) as u64, "{profile:?} against {apart_profile:?}");
    assert!(profile.dispatches > 20, "{profile:?}: many windows");
    assert!(held.colours == apart.colours && held.faces == apart.faces, "the same frame either way");
    tileraster::set_gpu_window_limit(4096 * 4096);
}
