//! Lines (the wireframe view): every edge of the faces drawn one pixel wide, depth-tested and
//! counted like triangles, the same bits on both backends; the pixels each rule lights,
//! against references written here (the diamond-exit rule from the diamonds themselves and
//! Bresenham from its nearest-row definition, in integers; the rectangle in `f64`); bad
//! colours are typed errors.

mod common;

use common::{assert_frame_parity as assert_parity, render_frame as frame};
use std::collections::HashSet;
use tileraster::render::{Camera, Cull, Eye, IDENTITY, Interpolation, LineRule, Mesh, NO_FACE, Projection, RenderParams, Shading, Up, Wireframe, render};
use tileraster::{Backend, Error};
use tileraster_testkit::meshes;
use tileraster_testkit::scenes::Rng;

/// The undirected edges of a mesh's faces, each once.
fn edge_count(mesh: &Mesh) -> u64 {
    let edges: HashSet<(u32, u32)> =
        mesh.triangles.iter().flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])]).filter(|(a, b)| a != b).map(|(a, b)| (a.min(b), a.max(b))).collect();
    edges.len() as u64
}

/// A sphere close enough that the near plane and the frame's edges cut its edges, under both
/// rules, over the faces and alone, in a wire colour and in the vertices' colours, in every
/// shading that shows them: CPU = GPU; every edge is drawn or culled; the lines show.
#[test]
fn lines_are_the_same_bits_on_both_backends() {
    let sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 10, 16);
    let edges = edge_count(&sphere);
    let camera =
        Camera { eye: [0.3, -1.6, 0.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 70.0 }, near: 0.8, far: 5.0 };
    let (w, h) = (120, 90);
    let first_line = (sphere.triangles.len() + sphere.positions.len()) as u32;
    for rule in [LineRule::DiamondExit, LineRule::Bresenham, LineRule::Rectangle] {
        for faces in [false, true] {
            for (shading, colour, interpolation) in [
                (Shading::Smooth, None, Interpolation::Perspective),
                (Shading::Phong, Some([0.0, 0.0, 0.0, 1.0]), Interpolation::Perspective),
                (Shading::Unlit, None, Interpolation::Flat),
                (Shading::Depth, None, Interpolation::Perspective),
                (Shading::Ids, None, Interpolation::Perspective),
            ] {
                let params = RenderParams {
                    cull: Cull::Back,
                    shading,
                    interpolation,
                    faces,
                    wireframe: Some(Wireframe { rule, colour }),
                    eye: Some(camera.viewer()),
                    ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap())
                };
                let what = format!("{rule:?}, faces {faces}, {shading:?}, colour {colour:?}, {interpolation:?}");
                let f = assert_parity(&what, &sphere, &params);
                let g = f.stats.geometry;
                assert_eq!(g.lines_drawn + g.lines_culled, edges, "{what}");
                assert!(g.lines_drawn > 100 && g.lines_culled > 0, "{what}: {g:?}");
                let line_pixels = f.ids.iter().filter(|&&id| id != NO_FACE && id >= first_line).count();
                assert!(line_pixels > 300, "{what}: {line_pixels} pixels show a line");
                if faces {
                    assert!(f.ids.iter().any(|&id| id < first_line), "{what}: no face shows");
                }
                if colour.is_some() {
                    let black = f.colour.iter().zip(&f.ids).filter(|(_, id)| **id != NO_FACE && **id >= first_line).all(|(&c, _)| c == 0xff00_0000);
                    assert!(black, "{what}: a line pixel is not the wire colour");
                }
            }
        }
    }
}

/// Snapped units (1/256 px) in a 64 × 64 frame under the identity matrix: NDC `u/8192 − 1`,
/// exact.
const W: u32 = 64;
const UNIT: i64 = 256;

fn ndc(u: i64) -> f64 {
    u as f64 / (128.0 * W as f64) - 1.0
}

/// What the diamond-exit rule lights of the segment `p0 → p1` (snapped units) in the frame,
/// from the diamonds themselves: pixel `(i, j)` is lit when the segment passes through its
/// open diamond `|x − cx| + |y − cy| < ½ px` and `p1` is not inside it. The distance along the
/// segment is convex and piecewise linear, smallest at an end or where `x = cx` or `y = cy`;
/// each is compared exactly, in integers. `None`: the segment passes a diamond's corner
/// exactly, where the rule leaves the choice to the implementation.
fn diamond_exit_reference(p0: (i64, i64), p1: (i64, i64)) -> Option<HashSet<(i64, i64)>> {
    let (dx, dy) = (p1.0 - p0.0, p1.1 - p0.1);
    let l1 = |p: (i64, i64), c: (i64, i64)| (p.0 - c.0).abs() + (p.1 - c.1).abs();
    let mut lit = HashSet::new();
    for j in 0..W as i64 {
        for i in 0..W as i64 {
            let c = (i * UNIT + UNIT / 2, j * UNIT + UNIT / 2);
            // Each candidate as (distance · scale, scale): inside when distance < ½ px.
            let mut candidates = vec![(l1(p0, c) as i128, 1i128), (l1(p1, c) as i128, 1)];
            if dx != 0 && (c.0 - p0.0) * dx.signum() >= 0 && (c.0 - p0.0).abs() <= dx.abs() {
                candidates.push((((p0.1 - c.1) as i128 * dx as i128 + (c.0 - p0.0) as i128 * dy as i128).abs(), dx.abs() as i128));
            }
            if dy != 0 && (c.1 - p0.1) * dy.signum() >= 0 && (c.1 - p0.1).abs() <= dy.abs() {
                candidates.push((((p0.0 - c.0) as i128 * dy as i128 + (c.1 - p0.1) as i128 * dx as i128).abs(), dy.abs() as i128));
            }
            let half = (UNIT / 2) as i128;
            let hit = candidates.iter().any(|&(d, s)| d < half * s);
            if !hit && candidates.iter().any(|&(d, s)| d == half * s) {
                return None;
            }
            if hit && l1(p1, c) >= UNIT / 2 {
                lit.insert((i, j));
            }
        }
    }
    Some(lit)
}

/// What Bresenham's algorithm lights: both ends moved to their pixels, and in every column of
/// the major axis between them (both included) the pixel whose centre is nearest the line
/// between the two pixels' centres. `None`: a column's line lies halfway between two pixels.
fn bresenham_reference(p0: (i64, i64), p1: (i64, i64)) -> Option<HashSet<(i64, i64)>> {
    let (a, b) = ((p0.0.div_euclid(UNIT), p0.1.div_euclid(UNIT)), (p1.0.div_euclid(UNIT), p1.1.div_euclid(UNIT)));
    let y_major = (b.1 - a.1).abs() > (b.0 - a.0).abs();
    let swap = |p: (i64, i64)| if y_major { (p.1, p.0) } else { p };
    let (a, b) = (swap(a), swap(b));
    let (du, dv) = (b.0 - a.0, b.1 - a.1);
    let mut lit = HashSet::new();
    for u in a.0.min(b.0)..=a.0.max(b.0) {
        let v = if du == 0 {
            a.1
        } else {
            // The line at column u: a.1 + (u − a.0)·dv/du = num/du.
            let num = a.1 * du + (u - a.0) * dv;
            let near: Vec<i64> = (num.div_euclid(du) - 1..=num.div_euclid(du) + 2).filter(|r| 2 * (r * du - num).abs() <= du.abs()).collect();
            if near.len() != 1 {
                return None;
            }
            near[0]
        };
        let (i, j) = if y_major { (v, u) } else { (u, v) };
        if (0..W as i64).contains(&i) && (0..W as i64).contains(&j) {
            lit.insert((i, j));
        }
    }
    Some(lit)
}

/// A set of pixels, by column and row.
type Pixels = HashSet<(i64, i64)>;

/// What the rectangle rule lights: pixel centres inside the rectangle one pixel wide around
/// the segment (`f64`), with the pixels whose centre lies within 1/64 px of its edges apart
/// (where rounding its corners to the 1/256-pixel lattice decides): `(lit, undecided)`.
fn rectangle_reference(p0: (i64, i64), p1: (i64, i64)) -> (Pixels, Pixels) {
    let (p0, p1) = ([p0.0 as f64 / UNIT as f64, p0.1 as f64 / UNIT as f64], [p1.0 as f64 / UNIT as f64, p1.1 as f64 / UNIT as f64]);
    let d = [p1[0] - p0[0], p1[1] - p0[1]];
    let length = d[0].hypot(d[1]);
    let (mut lit, mut undecided) = (HashSet::new(), HashSet::new());
    for j in 0..W as i64 {
        for i in 0..W as i64 {
            let v = [i as f64 + 0.5 - p0[0], j as f64 + 0.5 - p0[1]];
            let along = (v[0] * d[0] + v[1] * d[1]) / length;
            let across = (d[0] * v[1] - d[1] * v[0]) / length;
            let margin = along.abs().min((along - length).abs()).min((across.abs() - 0.5).abs());
            if margin < 1.0 / 64.0 {
                undecided.insert((i, j));
            } else if (0.0..length).contains(&along) && across.abs() < 0.5 {
                lit.insert((i, j));
            }
        }
    }
    (lit, undecided)
}

/// One segment, alone in the frame.
fn segment_mesh(p0: (i64, i64), p1: (i64, i64)) -> Mesh {
    // A face from the first vertex to the second and back: its one edge is the segment.
    Mesh { positions: vec![[ndc(p0.0), ndc(p0.1), 0.5], [ndc(p1.0), ndc(p1.1), 0.5]], triangles: vec![[0, 1, 0]], ..Default::default() }
}

fn line_params(rule: LineRule) -> RenderParams {
    RenderParams {
        cull: Cull::None,
        shading: Shading::Ids,
        faces: false,
        wireframe: Some(Wireframe { rule, colour: None }),
        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
        ..RenderParams::new(W, W, IDENTITY)
    }
}

/// Random segments, long and short, in every direction, some reaching beyond the frame: the
/// pixels each rule lights are exactly the reference's, each once.
#[test]
fn each_rule_lights_exactly_its_reference_pixels() {
    let mut rng = Rng::new(15);
    let mut compared = [0; 3];
    for n in 0..300 {
        let span = if n % 3 == 0 { 3.0 } else { 90.0 };
        let start = (rng.range(-10.0, 74.0), rng.range(-10.0, 74.0));
        let p0 = ((start.0 * UNIT as f64) as i64, (start.1 * UNIT as f64) as i64);
        let p1 = (p0.0 + (rng.range(-span, span) * UNIT as f64) as i64, p0.1 + (rng.range(-span, span) * UNIT as f64) as i64);
        if p0 == p1 {
            continue;
        }
        let mesh = segment_mesh(p0, p1);
        for (k, rule) in [LineRule::DiamondExit, LineRule::Bresenham, LineRule::Rectangle].into_iter().enumerate() {
            let (expected, undecided) = match rule {
                LineRule::DiamondExit => (diamond_exit_reference(p0, p1), HashSet::new()),
                LineRule::Bresenham => (bresenham_reference(p0, p1), HashSet::new()),
                LineRule::Rectangle => {
                    let (lit, undecided) = rectangle_reference(p0, p1);
                    (Some(lit), undecided)
                }
            };
            let Some(expected) = expected else { continue };
            let f = frame(&mesh, &line_params(rule), Backend::Cpu);
            // Ids: the face 0, the vertices 1 and 2, the line 3.
            let lit: HashSet<(i64, i64)> =
                f.ids.iter().enumerate().filter(|(_, id)| **id == 3).map(|(p, _)| ((p % W as usize) as i64, (p / W as usize) as i64)).collect();
            let lit: HashSet<(i64, i64)> = lit.difference(&undecided).copied().collect();
            let (extra, missing): (Vec<_>, Vec<_>) = (lit.difference(&expected).collect(), expected.difference(&lit).collect());
            assert!(extra.is_empty() && missing.is_empty(), "{rule:?} {p0:?} → {p1:?}: lit but not expected {extra:?}, expected but not lit {missing:?}");
            assert!(f.fragments.iter().all(|&c| c <= 1), "{rule:?} {p0:?} → {p1:?}: a pixel lit twice");
            compared[k] += 1;
        }
    }
    // Exact ties are rare at random positions for the diamonds (a segment through a corner);
    // between whole pixels a line halfway between two rows is common.
    assert!(compared[0] > 250 && compared[1] > 150 && compared[2] > 280, "segments compared: {compared:?}");
}

/// All those segments at once, both rules: CPU = GPU.
#[test]
fn many_segments_are_the_same_bits_on_both_backends() {
    let mut rng = Rng::new(16);
    let mut mesh = Mesh::default();
    for k in 0..200u32 {
        let p = [0, 1].map(|_| [ndc((rng.range(-10.0, 74.0) * UNIT as f64) as i64), ndc((rng.range(-10.0, 74.0) * UNIT as f64) as i64), rng.range(0.1, 0.9)]);
        mesh.positions.extend(p);
        mesh.triangles.push([2 * k, 2 * k + 1, 2 * k]);
    }
    for rule in [LineRule::DiamondExit, LineRule::Bresenham, LineRule::Rectangle] {
        let f = assert_parity(&format!("{rule:?}"), &mesh, &RenderParams { shading: Shading::Depth, ..line_params(rule) });
        assert!(f.stats.fragments > f.stats.pixels_covered, "{rule:?}: the lines should cross");
    }
}

#[test]
fn bad_wire_colours_are_typed_errors() {
    let mesh = meshes::sphere([0.0; 3], 1.0, 4, 6);
    let base = RenderParams::new(16, 16, Camera::framing(&mesh, 1.0, Projection::Perspective { fov_deg: 45.0 }, Up::Y).view_projection(16, 16).unwrap());
    for colour in [[1.5, 0.0, 0.0, 1.0], [f32::NAN, 0.0, 0.0, 1.0], [0.0, 0.0, -0.1, 1.0]] {
        let params = RenderParams { wireframe: Some(Wireframe { rule: LineRule::DiamondExit, colour: Some(colour) }), ..base.clone() };
        let e = render(&mesh, &params, Backend::Cpu).map(|_| ()).unwrap_err();
        assert!(matches!(e, Error::InvalidColour { .. }), "{colour:?}: {e}");
    }
    let params = RenderParams { faces: false, wireframe: Some(Wireframe::default()), ..base.clone() };
    assert!(render(&mesh, &params, Backend::Cpu).is_ok(), "the wireframe alone is something to draw");
}
