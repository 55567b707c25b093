//! Clipping in homogeneous space: faces wholly outside one frustum plane are dropped, faces
//! across a clipping plane cut (Sutherland–Hodgman) into a convex polygon, the rest pass whole.

use super::cull::{kept, triangles};
use super::emit::{Emit, FaceTag};
use super::params::GeometryCounts;
use super::vertex::{ClipVertex, Corner, Projected};
use super::viewport::{Target, Viewport, distance};
use tileraster_kernels::abi::ATTRIBUTES;

/// Clip, cull, snap one face and push what reaches the rasteriser. The decisions read the
/// face's [`Corner`]s, and counting reads nothing else of a face that needs no clipping;
/// `vertices` are its corners' [`ClipVertex`]s (in flat modes, copies with the face's values).
pub(super) fn geometry(
    corners: [&Corner; 3],
    vertices: [&ClipVertex; 3],
    face: FaceTag,
    viewport: &Viewport,
    target: &Target,
    out: &mut Emit<'_>,
    counts: &mut GeometryCounts,
) {
    // Wholly outside one plane of the view frustum: nothing to clip.
    if corners[0].frustum & corners[1].frustum & corners[2].frustum != 0 {
        counts.culled_frustum += 1;
        return;
    }
    if corners.iter().all(|c| c.outside == 0) {
        if out.counting() {
            let (x, y) = (corners.map(|c| c.screen.0), corners.map(|c| c.screen.1));
            if kept(x, y, &face.material, target, counts).is_some() {
                out.put(|| unreachable!("counting builds no triangle"));
            }
            return;
        }
        return triangles(&vertices.map(|v| v.projected), face, target, out, counts);
    }
    let corners = vertices;
    let polygon = clip_polygon(&corners.map(|v| *v), &viewport.planes());
    if polygon.len() < 3 {
        counts.culled_frustum += 1;
        return;
    }
    counts.clipped += 1;
    // The face's own corners as the vertex stage projected them, for every face that shares
    // them; the points clipping made, on the host.
    let projected: Vec<Projected> = polygon.iter().map(|v| if v.cut { v.project(viewport) } else { v.projected }).collect();
    triangles(&projected, face, target, out, counts);
}

/// Sutherland–Hodgman in homogeneous space against every plane. An edge crossing a plane is cut
/// at the point interpolated from its inside end, so a face's neighbour cuts the shared edge
/// at the same point.
pub(super) fn clip_polygon(corners: &[ClipVertex; 3], planes: &[[f64; 4]; 7]) -> Vec<ClipVertex> {
    let mut polygon = corners.to_vec();
    for k in 0..planes.len() {
        if polygon.is_empty() {
            break;
        }
        let d: Vec<f64> = polygon.iter().map(|v| distance(planes, k, &v.clip)).collect();
        if d.iter().all(|&d| d >= 0.0) {
            continue;
        }
        let mut next = Vec::with_capacity(polygon.len() + 1);
        for i in 0..polygon.len() {
            let j = (i + 1) % polygon.len();
            if d[i] >= 0.0 {
                next.push(polygon[i]);
            }
            if (d[i] >= 0.0) != (d[j] >= 0.0) {
                let (a, b, da, db) = if d[i] >= 0.0 { (&polygon[i], &polygon[j], d[i], d[j]) } else { (&polygon[j], &polygon[i], d[j], d[i]) };
                next.push(cut(a, b, da, db, k));
            }
        }
        polygon = next;
    }
    polygon
}

/// The point where the edge from `a` (inside plane `k`, at distance `da`) to `b` (outside, at
/// `db`) crosses the plane, interpolated from the inside end.
pub(super) fn cut(a: &ClipVertex, b: &ClipVertex, da: f64, db: f64, k: usize) -> ClipVertex {
    let t = da / (da - db);
    let mut v = ClipVertex { clip: [0.0; 4], attributes: [0.0; ATTRIBUTES], outside: 0, projected: Projected::default(), cut: true };
    for n in 0..4 {
        v.clip[n] = a.clip[n] + t * (b.clip[n] - a.clip[n]);
    }
    for n in 0..ATTRIBUTES {
        v.attributes[n] = a.attributes[n] + t * (b.attributes[n] - a.attributes[n]);
    }
    // On the near and far planes exactly, so that depths stay within [0, 1].
    match k {
        0 => v.clip[2] = 0.0,
        1 => v.clip[2] = v.clip[3],
        _ => {}
    }
    v
}
