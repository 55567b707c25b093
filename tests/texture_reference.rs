//! Texture sampling against an external reference: the same textured scenes drawn by wgpu's
//! render pipeline on the same Vulkan adapter (its texture units: lavapipe's here), compared
//! pixel by pixel. tileraster's sampling is exact in integers with 8 sub-texel bits; a
//! hardware sampler has its own precision (and its own interpolation of the coordinates, and
//! its own level of detail), so the comparison bounds the share of differing pixels and the
//! size of the differences (`docs/textures.md` explains them).

mod common;

use tileraster::Backend;
use tileraster::render::{Address, Camera, Cull, Eye, Filter, IDENTITY, Mesh, Projection, RenderParams, Shading, Texture, render};
use tileraster_peers::TexturedPipeline;

/// A texture with gradients, a fine checker and varying alpha.
fn pattern(w: u32, h: u32, srgb: bool) -> Texture {
    let rgba = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| {
            let checker = if (x / 2 + y / 2) % 2 == 0 { 220 } else { 30 };
            [(x * 255 / (w - 1)) as u8, (y * 255 / (h - 1)) as u8, checker, (128 + (x * 7 + y * 13) % 128) as u8]
        })
        .collect();
    Texture { srgb, ..Texture::srgb(w, h, rgba) }
}

fn quad(positions: [[f64; 3]; 4], uv0: [f32; 2], uv1: [f32; 2], srgb: bool) -> Mesh {
    Mesh {
        positions: positions.to_vec(),
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        colours: Some(vec![[1.0; 4]; 4]),
        uvs: Some(vec![uv0, [uv1[0], uv0[1]], uv1, [uv0[0], uv1[1]]]),
        textures: vec![pattern(64, 64, srgb)],
        ..Default::default()
    }
}

/// What one comparison found.
struct Found {
    covered: usize,
    differing: usize,
    beyond_one: usize,
    largest: u8,
}

fn compare(mesh: &Mesh, matrix: [[f64; 4]; 4], eye: [f64; 3], filter: Filter, address: Address, peer: &mut TexturedPipeline) -> Found {
    let (w, h) = (128, 96);
    let params = RenderParams {
        cull: Cull::None,
        shading: Shading::Unlit,
        eye: Some(Eye::Point(eye)),
        texture_filter: Some(filter),
        texture_address: Some(address),
        ..RenderParams::new(w, h, matrix)
    };
    let ours = render(mesh, &params, Backend::Cpu).unwrap();
    let theirs = peer.draw(mesh, &matrix, w, h, filter, address).unwrap();
    let mut found = Found { covered: 0, differing: 0, beyond_one: 0, largest: 0 };
    for (k, (&a, &b)) in ours.colour.iter().zip(&theirs).enumerate() {
        if ours.ids[k] == tileraster::render::NO_FACE {
            continue;
        }
        found.covered += 1;
        let d = (0..4).map(|c| a.to_le_bytes()[c].abs_diff(b.to_le_bytes()[c])).max().unwrap();
        found.differing += usize::from(d > 0);
        found.beyond_one += usize::from(d > 1);
        found.largest = found.largest.max(d);
    }
    found
}

/// The bounds lavapipe keeps (`docs/textures.md` explains each difference): for each scene,
/// filter and colour space, the largest share of covered pixels that may differ by more than
/// one, and the largest difference.
fn lavapipe_bound(perspective: bool, filter: Filter, srgb: bool) -> (f64, u8) {
    match (perspective, filter) {
        // Magnified on the screen's axes: the same texels; sRGB decoding and bilinear weights
        // round differently by at most one.
        (false, Filter::Nearest) if !srgb => (0.0, 0),
        (false, _) => (0.0, 1),
        // In perspective the coordinates are interpolated differently: a texel boundary may
        // fall on the other side of a pixel centre (nearest: a whole texel's difference).
        (true, Filter::Nearest) => (1.0, 255),
        (true, Filter::Bilinear) => (8.0, 16),
        // The level of detail (per-pixel against per-quad derivatives) and the mip chains.
        (true, Filter::Trilinear) => (35.0, 8),
    }
}

#[test]
fn textured_frames_match_the_render_pipeline() {
    if !common::gpu_or_skip("textured_frames_match_the_render_pipeline") {
        return;
    }
    let mut peer = TexturedPipeline::new().expect("the textured peer");
    let adapter = peer.adapter_name();
    let lavapipe = adapter.starts_with("llvmpipe");
    if !lavapipe {
        // The bounds are lavapipe's; another adapter's sampler has its own precision.
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "NOTE: the render pipeline runs on {adapter}, not lavapipe: its differences are printed, not bounded");
    }
    let camera = Camera {
        eye: [0.0, -1.2, 0.6],
        target: [0.0, 3.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 60.0 },
        near: 0.1,
        far: 40.0,
    };
    for srgb in [true, false] {
        let flat = quad([[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [1.0, 1.0, 0.5], [-1.0, 1.0, 0.5]], [0.0, 0.0], [1.0, 1.0], srgb);
        let ground = quad([[-3.0, -1.0, 0.0], [3.0, -1.0, 0.0], [3.0, 30.0, 0.0], [-3.0, 30.0, 0.0]], [-1.3, -2.2], [6.7, 12.8], srgb);
        let scenes = [
            ("magnified, screen-aligned", false, &flat, IDENTITY, [0.0, 0.0, -1.0]),
            ("ground plane in perspective", true, &ground, camera.view_projection(128, 96).unwrap(), camera.eye),
        ];
        for (name, perspective, mesh, matrix, eye) in scenes {
            for filter in Filter::ALL {
                for address in Address::ALL {
                    let f = compare(mesh, matrix, eye, filter, address, &mut peer);
                    let beyond = 100.0 * f.beyond_one as f64 / f.covered as f64;
                    let what = format!("{name}, srgb {srgb}, {filter:?}, {address:?} on {adapter}");
                    eprintln!(
                        "{what}: {} covered pixels, {:.2} % differ, {beyond:.2} % by more than 1, largest difference {}",
                        f.covered,
                        100.0 * f.differing as f64 / f.covered as f64,
                        f.largest
                    );
                    assert!(f.covered > 5000, "{what}: {} pixels covered", f.covered);
                    if lavapipe {
                        let (share, largest) = lavapipe_bound(perspective, filter, srgb);
                        assert!(
                            beyond <= share && f.largest <= largest,
                            "{what}: {beyond:.2} % differ by more than 1 (bound {share} %), largest {} (bound {largest})",
                            f.largest
                        );
                    }
                }
            }
        }
    }
}
