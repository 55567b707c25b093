//! The procedural marble through the programmable fragment stage: the same bits on both
//! backends (one sample, 4× and 8× multisampling, blending, the GPU's windows), the shader's
//! colours where the built-in shading's would be, and the frame's constants reaching it.

#[path = "../../../tests/common/mod.rs"]
mod common;

use common::{assert_frame_parity, render_frame};
use procedural::{params, scene};
use tileraster::render::{Frame, Shading, NO_FACE};
use tileraster::Backend;

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

#[test]
fn the_marble_is_the_same_bits_through_the_gpus_windows() {
    let mesh = scene();
    let p = params(&mesh, 300, 200).unwrap();
    let whole = render_frame(&mesh, &p, Backend::Cpu);
    if common::gpu_or_skip("marble through windows") {
        tileraster_gpu::set_window_limit(64 * 64);
        let windowed = render_frame(&mesh, &p, Backend::Gpu);
        tileraster_gpu::set_window_limit(4096 * 4096);
        assert!(whole.colour == windowed.colour && whole.ids == windowed.ids, "the windowed frame differs");
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
