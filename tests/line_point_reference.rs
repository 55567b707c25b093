//! Lines and points against an external reference: the same random segments drawn as a line
//! list by wgpu's render pipeline on the same Vulkan adapter, one segment a frame, the lit
//! pixels compared pixel by pixel with each of tileraster's rules; points one pixel wide
//! (WebGPU's only size) as a point list. Endpoints lie on the 1/256-pixel
//! lattice, so snapping is exact in both and only the rules can differ; what differs is
//! printed, bounded here for the rule the device follows, and explained in `docs/lines.md`.

mod common;

use std::collections::HashSet;
use tileraster::Backend;
use tileraster::render::{Cull, Eye, IDENTITY, LineRule, Mesh, NO_FACE, RenderParams, Shading, Wireframe, render};
use tileraster_peers::{MeshPipeline, NO_ID};
use tileraster_testkit::scenes::Rng;

const W: u32 = 64;
const UNIT: f64 = 256.0;
const SEGMENTS: usize = 400;

/// What one rule's comparison found.
#[derive(Default, Debug)]
struct Comparison {
    segments: usize,
    identical: usize,
    /// Pixels lit by both, by tileraster only and by the reference only.
    both: u64,
    ours_only: u64,
    theirs_only: u64,
    /// Differing pixels in the first or last column of the segment's major axis (its ends).
    at_ends: u64,
    /// Differing pixels whose centre lies within `NEAR_PX` of the exact rectangle one pixel
    /// wide around the segment (Vulkan's strict line, which the device draws): where rounding
    /// its corners to the 1/256-pixel lattice decides.
    near_rectangle: u64,
}

const NEAR_PX: f64 = 1.0 / 64.0;

/// How far pixel centre `c` lies from the boundary of the rectangle one pixel wide around the
/// segment `p0 → p1` (pixels).
fn from_rectangle(p0: [f64; 2], p1: [f64; 2], c: [f64; 2]) -> f64 {
    let d = [p1[0] - p0[0], p1[1] - p0[1]];
    let length = d[0].hypot(d[1]);
    let v = [c[0] - p0[0], c[1] - p0[1]];
    let along = (v[0] * d[0] + v[1] * d[1]) / length;
    let across = (d[0] * v[1] - d[1] * v[0]) / length;
    (along.abs().min((along - length).abs())).min((across.abs() - 0.5).abs())
}

fn lit_pixels(ids: &[u32], id: u32) -> HashSet<(i64, i64)> {
    ids.iter().enumerate().filter(|(_, v)| **v == id).map(|(p, _)| ((p % W as usize) as i64, (p / W as usize) as i64)).collect()
}

fn compare(rule: LineRule, peer: &mut MeshPipeline) -> Comparison {
    let mut rng = Rng::new(17);
    let mut out = Comparison::default();
    // In NDC, exact on the 1/256 px lattice (a pixel is 2/64 wide).
    let ndc = |px: f64| px / (W as f64 / 2.0) - 1.0;
    for n in 0..SEGMENTS {
        let span = if n % 3 == 0 { 3.0 } else { 60.0 };
        let p0 = [rng.range(2.0, 62.0), rng.range(2.0, 62.0)];
        let p1 = [p0[0] + rng.range(-span, span), p0[1] + rng.range(-span, span)];
        let (p0, p1) = (p0.map(|c| (c * UNIT).round() / UNIT), p1.map(|c| (c * UNIT).round() / UNIT));
        let positions = [[ndc(p0[0]), ndc(p0[1]), 0.5], [ndc(p1[0]), ndc(p1[1]), 0.5]];
        if positions[0] == positions[1] {
            continue;
        }
        let mesh = Mesh { positions: positions.to_vec(), triangles: vec![[0, 1, 0]], ..Default::default() };
        let params = RenderParams {
            cull: Cull::None,
            shading: Shading::Ids,
            faces: false,
            wireframe: Some(Wireframe { rule, colour: None }),
            eye: Some(Eye::Point([0.0, 0.0, -1.0])),
            ..RenderParams::new(W, W, IDENTITY)
        };
        let ours = lit_pixels(&render(&mesh, &params, Backend::Cpu).expect("render").ids, 3);
        let f32_positions = positions.map(|p| p.map(|c| c as f32));
        let theirs = lit_pixels(&peer.draw_line_ids(&f32_positions, &[[0, 1]], &IDENTITY.map(|r| r.map(|c| c as f32)), W, W).expect("the line peer"), 0);
        debug_assert!(!theirs.contains(&(NO_ID as i64, 0)));
        out.segments += 1;
        out.identical += usize::from(ours == theirs);
        out.both += ours.intersection(&theirs).count() as u64;
        let differing: Vec<(i64, i64)> = ours.symmetric_difference(&theirs).copied().collect();
        out.ours_only += ours.difference(&theirs).count() as u64;
        out.theirs_only += theirs.difference(&ours).count() as u64;
        // The major axis' first and last columns, in pixels.
        let (dx, dy) = ((p1[0] - p0[0]).abs(), (p1[1] - p0[1]).abs());
        let axis = usize::from(dy > dx);
        let (a, b) = ((p0[axis]).floor() as i64, (p1[axis]).floor() as i64);
        let ends = [a.min(b) - 1, a.min(b), a.max(b), a.max(b) + 1];
        out.at_ends += differing.iter().filter(|p| ends.contains(&[p.0, p.1][axis])).count() as u64;
        out.near_rectangle += differing.iter().filter(|p| from_rectangle(p0, p1, [p.0 as f64 + 0.5, p.1 as f64 + 0.5]) < NEAR_PX).count() as u64;
    }
    out
}

/// The device draws Vulkan's strict lines: tileraster's rectangle rule lights the same pixels
/// but where a pixel centre lies within `NEAR_PX` of the rectangle's exact edges. The other
/// rules light one pixel per column and are measured against it, not bounded.
#[test]
fn rectangle_lines_match_the_render_pipeline() {
    if !common::gpu_or_skip("lines against wgpu's render pipeline") {
        return;
    }
    let mut peer = MeshPipeline::new().expect("the render pipeline peer");
    for rule in [LineRule::Rectangle, LineRule::DiamondExit, LineRule::Bresenham] {
        let c = compare(rule, &mut peer);
        let line = format!(
            "{} against {}: {} of {} segments identical; pixels lit by both {}, by tileraster only {}, by the device only {}; of the differing, {} at the ends, {} within 1/64 px of the rectangle's edges",
            rule.name(),
            peer.adapter_name(),
            c.identical,
            c.segments,
            c.both,
            c.ours_only,
            c.theirs_only,
            c.at_ends,
            c.near_rectangle
        );
        // Printed for the docs, whether or not the bounds hold.
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "{line}");
        assert!(c.segments > 390 && c.both > 5000, "{line}");
        if rule == LineRule::Rectangle {
            assert_eq!(c.near_rectangle, c.ours_only + c.theirs_only, "{line}");
            assert!(c.identical > 380, "{line}");
        }
    }
}

/// Points one pixel wide at random positions on the 1/256-pixel lattice, a quarter of them on
/// pixel edges or corners (where the fill rule decides), some beyond the frame's edges, all
/// in one frame (far enough apart that none overlaps another): the same pixels as the
/// device's point list.
#[test]
fn points_match_the_render_pipeline() {
    if !common::gpu_or_skip("points against wgpu's render pipeline") {
        return;
    }
    let mut peer = MeshPipeline::new().expect("the render pipeline peer");
    let mut rng = Rng::new(18);
    let size = 256u32;
    let ndc = |px: f64| px / (size as f64 / 2.0) - 1.0;
    // One point per 4 × 4 cell, within its middle two pixels, so no two touch.
    let mut positions = Vec::new();
    for cy in 0..size / 4 + 1 {
        for cx in 0..size / 4 + 1 {
            let mut at = |c: u32| {
                let v = c as f64 * 4.0 - 1.0 + rng.range(0.0, 2.0);
                if rng.next_u64().is_multiple_of(4) { v.round() } else { (v * UNIT).round() / UNIT }
            };
            let (x, y) = (at(cx), at(cy));
            positions.push([ndc(x), ndc(y), 0.5]);
        }
    }
    let triangles = vec![[0, 1, 2]];
    let mesh = Mesh { positions: positions.clone(), triangles, ..Default::default() };
    let params = RenderParams {
        cull: Cull::None,
        shading: Shading::Ids,
        faces: false,
        points: Some(1.0),
        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
        ..RenderParams::new(size, size, IDENTITY)
    };
    let ours = render(&mesh, &params, Backend::Cpu).expect("render").ids;
    let f32_positions: Vec<[f32; 3]> = positions.iter().map(|p| p.map(|c| c as f32)).collect();
    let theirs = peer.draw_point_ids(&f32_positions, &IDENTITY.map(|r| r.map(|c| c as f32)), size, size).expect("the point peer");
    // Ours: the face 0, then vertex v's point is 1 + v; theirs: the vertex index.
    let ours: Vec<u32> = ours.iter().map(|&id| if id == NO_FACE { NO_ID } else { id - 1 }).collect();
    let lit = ours.iter().filter(|&&id| id != NO_ID).count();
    let differing = ours.iter().zip(&theirs).filter(|(a, b)| a != b).count();
    let line = format!("points against {}: {} points, {lit} pixels lit, {differing} differ", peer.adapter_name(), positions.len());
    use std::io::Write;
    let _ = writeln!(std::io::stderr(), "{line}");
    assert!(lit > 3500, "{line}");
    assert_eq!(differing, 0, "{line}");
}
