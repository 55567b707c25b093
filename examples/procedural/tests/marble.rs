//! The procedural marble through the programmable fragment stage: the same bits on both
//! backends (one sample, 4× and 8× multisampling, blending, the GPU's windows, switching
//! between the shader and the built-in shadings), the shader's colours where the built-in
//! shading's would be, the frame's constants reaching it, and modules that are not what
//! `tileraster-build` writes refused.

#[path = "../../../tests/common/mod.rs"]
mod common;

use common::{assert_frame_parity, render_frame};
use procedural::{params, scene};
use tileraster::Backend;
use tileraster::render::{Frame, NO_FACE, Shading};

fn covered(f: &Frame) -> usize {
    f.ids.iter().filter(|&&id| id != NO_FACE).count()
}

#[test]
fn the_marble_is_the_same_bits_on_both_backends() {
    let mesh = scene();
    let p = params(&mesh, 320, 240).unwrap();
    let marble = assert_frame_parity("marble", &mesh, &p);
    let covered_pixels = covered(&marble);
    assert!(covered_pixels > 320 * 240 / 3, "the scene fills the frame: {covered_pixels} pixels");
    // The shader ran: the built-in Phong shading of the same frame differs almost everywhere
    // the scene covers, and the veins make many colours.
    let builtin = render_frame(&mesh, &tileraster::render::RenderParams { fragment: None, shading: Shading::Phong, ..p.clone() }, Backend::Cpu);
    assert_eq!(builtin.ids, marble.ids, "the shader changes no coverage");
    let differ = marble.colour.iter().zip(&builtin.colour).zip(&marble.ids).filter(|((a, b), id)| **id != NO_FACE && a != b).count();
    assert!(differ * 10 > covered_pixels * 9, "{differ} of {covered_pixels} covered pixels differ from the built-in shading");
    let mut colours = marble.colour.clone();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 2000, "{} colours", colours.len());
}

#[test]
fn multisampled_and_blended_marble_is_the_same_bits_on_both_backends() {
    let mesh = scene();
    for samples in [4, 8] {
        let mut p = params(&mesh, 200, 150).unwrap();
        p.samples = samples;
        let f = assert_frame_parity(&format!("marble, {samples} samples"), &mesh, &p);
        assert!(covered(&f) > 0);
    }
    let mut p = params(&mesh, 200, 150).unwrap();
    p.blend = true;
    assert_frame_parity("marble, blended", &mesh, &p);
}

/// Restores the GPU backend's window limit when dropped, whatever the test did.
struct WindowLimit;

impl Drop for WindowLimit {
    fn drop(&mut self) {
        tileraster_gpu::set_window_limit(4096 * 4096);
    }
}

#[test]
fn the_marble_is_the_same_bits_through_the_gpus_windows() {
    let mesh = scene();
    let p = params(&mesh, 300, 200).unwrap();
    let whole = render_frame(&mesh, &p, Backend::Cpu);
    if common::gpu_or_skip("marble through windows") {
        let _restore = WindowLimit;
        // 64×64-pixel windows: the 300×200 frame takes at least 20.
        tileraster_gpu::set_window_limit(64 * 64);
        let windowed = render_frame(&mesh, &p, Backend::Gpu);
        assert!(whole.colour == windowed.colour && whole.ids == windowed.ids && whole.fragments == windowed.fragments, "the windowed frame differs");
        assert!(whole.depth.iter().zip(&windowed.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "the windowed depths differ");
        assert_eq!(whole.stats, windowed.stats);
    }
}

/// One GPU context switches between the kernels' shading stages and the shader's: the marble,
/// the built-in Phong shading, the marble again, each the CPU backend's bits.
#[test]
fn the_gpu_switches_between_the_shader_and_the_built_in_shadings() {
    let mesh = scene();
    let marble = params(&mesh, 128, 96).unwrap();
    let phong = tileraster::render::RenderParams { fragment: None, ..marble.clone() };
    for (what, p) in [("marble", &marble), ("built-in phong", &phong), ("marble again", &marble)] {
        assert_frame_parity(what, &mesh, p);
    }
}

/// A module that is not what `tileraster-build` writes is refused with a typed error before it
/// reaches the driver; the example's own modules pass the same checks.
#[test]
fn the_gpu_backend_checks_a_shaders_module_before_running_it() {
    for float_controls in [false, true] {
        if let Err(problems) = tileraster_build::check::fragment_module(procedural::MARBLE.module(float_controls)) {
            panic!("the marble's module (float controls {float_controls}):\n{}", problems.join("\n"));
        }
    }
    // The kernels' module has every stage's entry point, not just the shading stages'.
    let kernels = tileraster::render::FragmentStage::from_parts(
        "kernels",
        procedural::MARBLE.program(),
        tileraster_gpu::KERNELS_SPV,
        tileraster_gpu::KERNELS_FLOAT_CONTROLS_SPV,
    );
    let garbage = tileraster::render::FragmentStage::from_parts("garbage", procedural::MARBLE.program(), &[1, 2, 3, 4, 5, 6, 7, 8], &[1, 2, 3, 4, 5, 6, 7, 8]);
    let mesh = scene();
    if common::gpu_or_skip("a bad fragment module") {
        for stage in [kernels, garbage] {
            let p = tileraster::render::RenderParams { fragment: Some(stage), ..params(&mesh, 64, 48).unwrap() };
            match tileraster::render::render(&mesh, &p, Backend::Gpu) {
                Err(tileraster::Error::FragmentShader { name, problems }) => assert!(name == stage.name() && !problems.is_empty()),
                other => panic!("{}: {other:?}", stage.name()),
            }
        }
    }
}

#[test]
fn the_frames_constants_reach_the_shader() {
    let mesh = scene();
    let mut p = params(&mesh, 160, 120).unwrap();
    let default = assert_frame_parity("marble, default constants", &mesh, &p);
    // Veins three per unit by default: asking for three gives the same frame, six another.
    p.fragment_constants[0] = 3.0;
    assert_eq!(render_frame(&mesh, &p, Backend::Cpu).colour, default.colour);
    p.fragment_constants[0] = 6.0;
    let finer = assert_frame_parity("marble, 6 veins per unit", &mesh, &p);
    assert_ne!(finer.colour, default.colour);
}
