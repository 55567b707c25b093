//! Multisampling: coverage and depth per sample at the standard positions, shading once per
//! pixel per triangle, a box resolve; the same bits on both backends; watertight per sample.

mod common;

use common::{assert_frame_parity, render_frame};
use tileraster::render::{render, Camera, Cull, LineRule, Mesh, RenderParams, Shading, Wireframe, IDENTITY, NO_FACE};
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
        let params = RenderParams { cull: Cull::None, shading: Shading::Unlit, samples, eye: Some([0.0, 0.0, -1.0]), ..RenderParams::new(97, 61, IDENTITY) };
        let f = assert_frame_parity(&format!("{samples} samples"), &mesh, &params);
        let grey: Vec<(usize, u32)> = f.colour.iter().copied().enumerate().filter(|&(_, c)| c != 0xffff_ffff).collect();
        let at: Vec<(usize, usize, u32)> = grey.iter().map(|&(k, c)| (k % 97, k / 97, c >> 24)).collect();
        assert!(grey.is_empty(), "{samples} samples: {} pixels not white, first {:?}", grey.len(), &at[..at.len().min(60)]);
        assert!(f.ids.iter().all(|&id| id != NO_FACE), "{samples} samples: a pixel without a face");
    }
}
