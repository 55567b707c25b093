//! Multisampling: coverage and depth per sample at the standard positions, shading once per
//! pixel per triangle, a box resolve; the same bits on both backends; watertight per sample.

mod common;

use common::{assert_frame_parity, render_frame};
use tileraster::render::{Camera, Cull, Eye, IDENTITY, LineRule, Mesh, NO_FACE, Projection, RenderParams, Shading, Up, Wireframe, render};
use tileraster::{Backend, Error};
use tileraster_testkit::meshes;

/// A flat mesh of many triangles filling the frame, white and unlit: every sample of every
/// pixel is covered by exactly one triangle, so every pixel resolves to white, exactly.
#[test]
fn a_mesh_is_watertight_at_every_sample() {
    let mut mesh = meshes::terrain(23, 2.4, 0.0);
    // Centred on the origin, across the whole frame and beyond.
    for p in &mut mesh.positions {
        (p[0], p[1], p[2]) = (p[0] - 1.2, p[1] - 1.2, 0.5);
    }
    mesh.colours = Some(vec![[1.0; 4]; mesh.positions.len()]);
    for samples in [4, 8] {
        let params =
            RenderParams { cull: Cull::None, shading: Shading::Unlit, samples, eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(97, 61, IDENTITY) };
        let f = assert_frame_parity(&format!("{samples} samples"), &mesh, &params);
        let grey: Vec<(usize, u32)> = f.colour.iter().copied().enumerate().filter(|&(_, c)| c != 0xffff_ffff).collect();
        let at: Vec<(usize, usize, u32)> = grey.iter().map(|&(k, c)| (k % 97, k / 97, c >> 24)).collect();
        assert!(grey.is_empty(), "{samples} samples: {} pixels not white, first {:?}", grey.len(), &at[..at.len().min(60)]);
        assert!(f.ids.iter().all(|&id| id != NO_FACE), "{samples} samples: a pixel without a face");
    }
}

/// A pixel half covered by a white triangle over a transparent background resolves to the
/// samples' mean, rounded to nearest: 4× puts two of its samples left of the centre, 8× four.
#[test]
fn the_resolve_is_the_mean_of_the_samples() {
    // A white rectangle whose right edge runs down the middle of column 3 (x = 3.5 px).
    let (w, h) = (8u32, 4u32);
    let ndc_x = |px: f64| 2.0 * px / w as f64 - 1.0;
    let mesh = Mesh {
        positions: vec![[ndc_x(-1.0), -2.0, 0.5], [ndc_x(3.5), -2.0, 0.5], [ndc_x(3.5), 2.0, 0.5], [ndc_x(-1.0), 2.0, 0.5]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        colours: Some(vec![[1.0; 4]; 4]),
        ..Default::default()
    };
    for samples in [4, 8] {
        let params =
            RenderParams { cull: Cull::None, shading: Shading::Unlit, samples, eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(w, h, IDENTITY) };
        let f = assert_frame_parity(&format!("{samples} samples"), &mesh, &params);
        for j in 0..h as usize {
            let row = &f.colour[j * w as usize..(j + 1) * w as usize];
            // Half of 255 in every channel, alpha included: (255·n/2 + n/2) / n = 128.
            assert_eq!(row[..4], [0xffff_ffff, 0xffff_ffff, 0xffff_ffff, 0x8080_8080], "{samples} samples, row {j}");
            assert!(row[4..].iter().all(|&c| c == 0), "{samples} samples, row {j}");
        }
    }
}

/// A shaded, textured, depth-tested scene with lines and points, crossing the near plane and
/// the frame's edges, at 4× and 8×, each layer sample: CPU = GPU, also through the GPU's
/// windows.
#[test]
fn multisampled_frames_are_the_same_bits_on_both_backends() {
    let mut sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 12, 20);
    sphere.uvs = Some(sphere.positions.iter().map(|p| [(p[0] * 2.0) as f32, (p[2] * 2.0) as f32]).collect());
    let texels: Vec<u8> = (0..32 * 32).flat_map(|k| if (k % 32 / 4 + k / 32 / 4) % 2 == 0 { [230, 200, 40, 255] } else { [30, 60, 200, 255] }).collect();
    sphere.textures = vec![tileraster::render::Texture::srgb(32, 32, texels)];
    let camera =
        Camera { eye: [0.3, -1.6, 0.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 70.0 }, near: 0.8, far: 5.0 };
    let (w, h) = (150, 110);
    for samples in [4, 8] {
        let base = RenderParams { samples, cull: Cull::None, eye: Some(camera.viewer()), ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap()) };
        for (what, params) in [
            ("phong", RenderParams { shading: Shading::Phong, ..base.clone() }),
            (
                "wireframe and points",
                RenderParams {
                    shading: Shading::Smooth,
                    wireframe: Some(Wireframe { rule: LineRule::Rectangle, colour: Some([0.0, 0.0, 0.0, 1.0]) }),
                    points: Some(2.5),
                    ..base.clone()
                },
            ),
            ("depth, layer sample 3", RenderParams { shading: Shading::Depth, layer_sample: 3, ..base.clone() }),
            ("ids, layer sample 1", RenderParams { shading: Shading::Ids, layer_sample: 1, ..base.clone() }),
        ] {
            let what = format!("{samples} samples, {what}");
            let f = assert_frame_parity(&what, &sphere, &params);
            assert!(f.stats.pixels_covered > 5000, "{what}: {} pixels covered", f.stats.pixels_covered);
            tileraster::set_gpu_window_limit(40 * 40);
            let windowed = assert_frame_parity(&format!("{what}, windows"), &sphere, &params);
            tileraster::set_gpu_window_limit(4096 * 4096);
            assert!(windowed.colour == f.colour && windowed.ids == f.ids, "{what}: windows change the frame");
        }
    }
}

#[test]
fn bad_sample_counts_are_typed_errors() {
    let mesh = meshes::sphere([0.0; 3], 1.0, 4, 6);
    let base = RenderParams::new(16, 16, Camera::framing(&mesh, 1.0, Projection::Perspective { fov_deg: 45.0 }, Up::Y).view_projection(16, 16).unwrap());
    for (samples, blend, layer_sample) in [(0, false, 0), (2, false, 0), (16, false, 0), (4, true, 0), (4, false, 4), (1, false, 1)] {
        let params = RenderParams { samples, blend, layer_sample, ..base.clone() };
        let e = render(&mesh, &params, Backend::Cpu).map(|_| ()).unwrap_err();
        assert!(matches!(e, Error::InvalidSamples { .. }), "{samples} samples, blend {blend}, layer sample {layer_sample}: {e}");
    }
}

/// Random depth-tested triangles drawn 4× multisampled by wgpu's render pipeline on the same
/// adapter, every sample's owner compared with tileraster's (`layer_sample`), at the standard
/// positions: vertices on the 1/256-pixel lattice inside the frame (lavapipe clips triangles
/// that cross it in `f32`, see `tests/render_reference.rs`), a quarter of the coordinates on
/// pixel-centre lines, each triangle at its own depth (no ties).
#[test]
fn every_sample_matches_the_render_pipeline() {
    if !common::gpu_or_skip("every_sample_matches_the_render_pipeline") {
        return;
    }
    use tileraster_peers::{MultisampledPipeline, NO_SAMPLE_ID, PEER_SAMPLES};
    use tileraster_testkit::meshes::Rng;
    const SIZE: u32 = 128;
    let mut peer = MultisampledPipeline::new().expect("the multisampled peer");
    let mut rng = Rng::new(20_261_125);
    let (mut samples_compared, mut differing, mut first) = (0u64, 0u64, Vec::new());
    for frame in 0..20 {
        let mut positions = Vec::new();
        for _ in 0..300 {
            let spread = 2f64.powf(rng.range(-1.0, 6.0));
            let (cx, cy) = (rng.range(0.0, SIZE as f64), rng.range(0.0, SIZE as f64));
            let z = rng.range(0.05, 0.95);
            for _ in 0..3 {
                let mut at = |c: f64| {
                    let v = (c + rng.range(-spread, spread)).clamp(0.0, SIZE as f64 - 1.0 / 256.0);
                    if rng.next_u64().is_multiple_of(4) { ((v - 0.5).round() + 0.5).clamp(0.5, SIZE as f64 - 0.5) } else { (v * 256.0).round() / 256.0 }
                };
                let (x, y) = (at(cx), at(cy));
                positions.push([2.0 * x / SIZE as f64 - 1.0, 2.0 * y / SIZE as f64 - 1.0, z]);
            }
        }
        let faces: Vec<[u32; 3]> = (0..positions.len() as u32 / 3).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        let mesh = Mesh { positions: positions.clone(), triangles: faces.clone(), ..Default::default() };
        let positions32: Vec<[f32; 3]> = positions.iter().map(|p| p.map(|c| c as f32)).collect();
        let theirs = peer.draw_sample_ids(&positions32, &faces, &IDENTITY.map(|r| r.map(|c| c as f32)), SIZE, SIZE).expect("the multisampled peer");
        for s in 0..PEER_SAMPLES {
            let params = RenderParams {
                cull: Cull::None,
                shading: Shading::Ids,
                samples: PEER_SAMPLES,
                layer_sample: s,
                eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                ..RenderParams::new(SIZE, SIZE, IDENTITY)
            };
            let ours = render_frame(&mesh, &params, Backend::Cpu);
            for (p, &a) in ours.ids.iter().enumerate() {
                let b = theirs[p * PEER_SAMPLES as usize + s as usize];
                let b = if b == NO_SAMPLE_ID { NO_FACE } else { b };
                samples_compared += 1;
                if a != b {
                    differing += 1;
                    if first.len() < 10 {
                        first.push(format!("frame {frame}, pixel ({}, {}), sample {s}: tileraster {a}, render pipeline {b}", p as u32 % SIZE, p as u32 / SIZE));
                    }
                }
            }
        }
    }
    println!("4× samples against {}: {samples_compared} compared, {differing} differ", peer.adapter_name());
    assert_eq!(differing, 0, "samples that differ from the render pipeline; first ones:\n{}", first.join("\n"));
}
