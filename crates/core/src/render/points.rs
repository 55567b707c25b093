//! The vertices view: a square per vertex, offset towards the camera by the slope of the
//! faces around it.

use super::emit::{Emit, FaceTag};
use super::instances::Placement;
use super::params::{GeometryCounts, RENDER_SNAP_BITS};
use super::vertex::ClipVertex;
use super::viewport::Target;
use super::viewport::W_MIN;
use tileraster_kernels::abi::{FloatCoeffs, TriangleInput, TriangleShading};

/// The depth offset of each vertex's point (or line end) drawn over the faces: the steepest
/// depth slope (per pixel, in either screen direction) of the faces around the vertex, times
/// half the point's width (a line's: one) and one pixel more, so that the square or line stays
/// in front of the surface it sits on (graphics APIs' polygon offset, computed per vertex in
/// f64 on the host).
pub(super) fn surface_bias(placements: &[Placement], vertices: &[ClipVertex], size: f32) -> Vec<f64> {
    let mut slope = vec![0.0f64; vertices.len()];
    for p in placements {
        for tri in &p.mesh.triangles {
            let v = tri.map(|k| p.first_vertex + k as usize);
            if v.iter().any(|&k| vertices[k].outside != 0) {
                continue;
            }
            let q = v.map(|k| &vertices[k].projected);
            let px =
                |k: usize| (q[k].screen.0 as f64 / (1 << RENDER_SNAP_BITS) as f64, q[k].screen.1 as f64 / (1 << RENDER_SNAP_BITS) as f64, q[k].depth as f64);
            let (a, b, c) = (px(0), px(1), px(2));
            let area = (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0);
            if area == 0.0 {
                continue;
            }
            let ddx = ((b.2 - a.2) * (c.1 - a.1) - (c.2 - a.2) * (b.1 - a.1)) / area;
            let ddy = ((c.2 - a.2) * (b.0 - a.0) - (b.2 - a.2) * (c.0 - a.0)) / area;
            let s = ddx.abs() + ddy.abs();
            for k in v {
                slope[k] = slope[k].max(s);
            }
        }
    }
    let reach = size as f64 / 2.0 + 1.0;
    slope.into_iter().map(|s| s * reach).collect()
}

/// A vertex's point: a square `size` pixels wide centred on its snapped position, as two
/// triangles (the top-left rule then covers exactly `size²` pixel centres of a square of whole
/// pixels wherever it lies), at the vertex's depth less `bias`, in its attributes; dropped
/// where the vertex lies outside the view volume.
pub(super) fn point(v: &ClipVertex, size: f32, bias: f64, tag: FaceTag, target: &Target, out: &mut Emit<'_>, counts: &mut GeometryCounts) {
    let c = &v.clip;
    if !(c[3] > W_MIN && c[0].abs() <= c[3] && c[1].abs() <= c[3] && c[2] >= 0.0 && c[2] <= c[3]) {
        counts.points_culled += 1;
        return;
    }
    counts.points_drawn += 1;
    let q = &v.projected;
    let half = (size as f64 * (1 << (RENDER_SNAP_BITS - 1)) as f64).round() as i64;
    let (x0, y0, x1, y1) = (q.screen.0 - half, q.screen.1 - half, q.screen.0 + half, q.screen.1 + half);
    let depth = ((q.depth as f64 - bias).max(0.0)) as f32;
    let area = (2 * half) as f64 * (2 * half) as f64;
    for (x, y) in [([x0, x1, x1], [y0, y0, y1]), ([x0, x1, x0], [y0, y1, y1])] {
        let rect = target.rect(&x, &y);
        if rect.is_empty() {
            counts.culled_no_centre += 1;
            continue;
        }
        out.put(|| {
            let coeffs = FloatCoeffs { c: [depth, depth, depth, (1.0 / area) as f32] };
            (
                TriangleInput { x, y, rect, coeffs, ..Default::default() },
                TriangleShading { attributes: [q.attributes; 3], inv_w: [q.inv_w; 3], face: tag.id, material: tag.material },
            )
        });
    }
}
