//! The render pipeline's coverage against an external reference: the same random triangles
//! drawn by wgpu's render pipeline on the same Vulkan adapter (lavapipe here, which implements
//! Vulkan's rasterisation rules with 8 sub-pixel bits), piglit's triangle-rasterization test
//! being the model. Vertices lie on the 1/256-pixel lattice, so snapping is exact in both and
//! only the coverage rules can differ; a quarter of the coordinates lie on pixel-centre lines,
//! so edges and vertices through pixel centres test the fill rule. Both draw in order with no
//! depth test (the last triangle over a pixel keeps it), and the triangle ids are compared
//! pixel by pixel.

mod common;

use tileraster::Backend;
use tileraster::render::{Cull, DepthFunc, Eye, Mesh, RenderParams, Shading, render};
use tileraster_peers::{MeshPipeline, NO_ID};
use tileraster_testkit::meshes::Rng;

const SIZE: u32 = 256;
const FRAMES: usize = 250;
const PER_FRAME: usize = 400;

/// What one comparison found.
struct Comparison {
    adapter: String,
    triangles: usize,
    covered: u64,
    differing: u64,
    /// Differing pixels that lie within `NEAR_EDGE_PX` of an edge of a triangle that crosses
    /// the frame's boundary (see the second test).
    near_clipped_edges: u64,
    first: Vec<String>,
}

/// Distance from an edge, in pixels, within which lavapipe's own clipping may move coverage.
const NEAR_EDGE_PX: f64 = 1.0 / 64.0;

/// Draw `FRAMES × PER_FRAME` random triangles whose vertices lie in `lo..hi` (pixels) with
/// both rasterisers and compare the ids.
fn compare(lo: f64, hi: f64, seed: u64) -> Comparison {
    let mut peer = MeshPipeline::new().expect("the render pipeline peer");
    let mut rng = Rng::new(seed);
    let identity = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    let mut out = Comparison { adapter: peer.adapter_name(), triangles: 0, covered: 0, differing: 0, near_clipped_edges: 0, first: Vec::new() };
    // A coordinate near `around` within `spread` px, on the 1/256 px lattice, a quarter of the
    // time on a pixel-centre line.
    let coordinate = |rng: &mut Rng, around: f64, spread: f64| {
        let v = (around + rng.range(-spread, spread)).clamp(lo, hi);
        if rng.next_u64().is_multiple_of(4) { (v - 0.5).round().clamp(lo.ceil(), hi.floor() - 1.0) + 0.5 } else { (v * 256.0).round() / 256.0 }
    };
    for frame in 0..FRAMES {
        let mut pixels = Vec::with_capacity(3 * PER_FRAME);
        let mut depths = Vec::with_capacity(3 * PER_FRAME);
        for _ in 0..PER_FRAME {
            // Sizes from a fraction of a pixel to a few hundred pixels, log-uniform.
            let spread = 2f64.powf(rng.range(-2.0, 8.0));
            let (cx, cy) = (rng.range(0.0, SIZE as f64), rng.range(0.0, SIZE as f64));
            let z = rng.range(0.05, 0.95);
            for _ in 0..3 {
                pixels.push([coordinate(&mut rng, cx, spread), coordinate(&mut rng, cy, spread)]);
                depths.push(z);
            }
        }
        // Pixels to NDC: exact in f32 and f64 for a 256-pixel frame.
        let positions: Vec<[f64; 3]> = pixels.iter().zip(&depths).map(|(p, &z)| [2.0 * p[0] / SIZE as f64 - 1.0, 2.0 * p[1] / SIZE as f64 - 1.0, z]).collect();
        let faces: Vec<[u32; 3]> = (0..PER_FRAME as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
        out.triangles += faces.len();
        let mesh = Mesh { positions: positions.clone(), triangles: faces.clone(), ..Default::default() };
        let params = RenderParams {
            cull: Cull::None,
            shading: Shading::Ids,
            depth_func: DepthFunc::Always,
            eye: Some(Eye::Point([0.0, 0.0, -1.0])),
            ..RenderParams::new(SIZE, SIZE, identity)
        };
        let ours = render(&mesh, &params, Backend::Cpu).expect("tileraster");
        let positions32: Vec<[f32; 3]> = positions.iter().map(|p| p.map(|c| c as f32)).collect();
        let theirs = peer.draw_ids(&positions32, &faces, &identity.map(|r| r.map(|c| c as f32)), SIZE, SIZE, false).expect("render pipeline");
        // Whether pixel centre (px, py) lies within NEAR_EDGE_PX of an edge of triangle `t`,
        // and `t` crosses the frame's boundary (so lavapipe clipped it).
        let near_clipped_edge = |t: u32, px: f64, py: f64| {
            if t == NO_ID {
                return false;
            }
            let v = [0, 1, 2].map(|c| pixels[3 * t as usize + c]);
            let crosses = v.iter().any(|p| p[0] < 0.0 || p[0] > SIZE as f64 || p[1] < 0.0 || p[1] > SIZE as f64);
            crosses
                && (0..3).any(|c| {
                    let (a, b) = (v[c], v[(c + 1) % 3]);
                    let length = ((b[0] - a[0]).powi(2) + (b[1] - a[1]).powi(2)).sqrt();
                    ((b[0] - a[0]) * (py - a[1]) - (b[1] - a[1]) * (px - a[0])).abs() <= NEAR_EDGE_PX * length
                })
        };
        for (k, (&a, &b)) in ours.ids.iter().zip(&theirs).enumerate() {
            out.covered += u64::from(b != NO_ID);
            if a != b {
                out.differing += 1;
                let (i, j) = (k as u32 % SIZE, k as u32 / SIZE);
                let (px, py) = (i as f64 + 0.5, j as f64 + 0.5);
                out.near_clipped_edges += u64::from(near_clipped_edge(a, px, py) || near_clipped_edge(b, px, py));
                if out.first.len() < 10 {
                    out.first.push(format!("frame {frame}, pixel ({i}, {j}): tileraster {a}, render pipeline {b}"));
                }
            }
        }
    }
    out
}

/// Triangles inside the frame: no clipping anywhere, so the two must agree on every pixel.
#[test]
fn coverage_matches_the_render_pipeline_on_random_triangles_inside_the_frame() {
    if !common::gpu_or_skip("coverage_matches_the_render_pipeline_on_random_triangles_inside_the_frame") {
        return;
    }
    let c = compare(0.0, SIZE as f64 - 1.0 / 256.0, 20261124);
    println!("inside the frame, against {}: {} triangles, {} covered pixels, {} differ", c.adapter, c.triangles, c.covered, c.differing);
    assert!(c.triangles >= 100_000 && c.covered > 10_000_000);
    assert_eq!(c.differing, 0, "pixels that differ from the render pipeline; first ones:\n{}", c.first.join("\n"));
}

/// Triangles reaching up to a quarter frame beyond it. Mesa's llvmpipe clips such triangles
/// against the viewport in `f32` (its draw module runs with clipping on and no guard band), so
/// its clipped edges are not exactly the original ones; tileraster's guard band keeps them
/// whole. Every pixel that differs must lie within 1/64 px of an edge of a triangle that
/// crosses the frame's boundary.
#[test]
fn coverage_differs_from_the_render_pipeline_only_at_edges_it_clips() {
    if !common::gpu_or_skip("coverage_differs_from_the_render_pipeline_only_at_edges_it_clips") {
        return;
    }
    let c = compare(-0.25 * SIZE as f64, 1.25 * SIZE as f64, 20261125);
    println!(
        "crossing the frame, against {}: {} triangles, {} covered pixels, {} differ, {} of them within {NEAR_EDGE_PX} px of a clipped edge",
        c.adapter, c.triangles, c.covered, c.differing, c.near_clipped_edges
    );
    assert!(c.triangles >= 100_000 && c.covered > 10_000_000);
    assert_eq!(c.near_clipped_edges, c.differing, "differences not explained by clipping; first differing pixels:\n{}", c.first.join("\n"));
}
