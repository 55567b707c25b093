//! Culling and setup of a clipped face's fan: zero-area, back- or front-facing and
//! pixel-less triangles dropped, the rest oriented and emitted.

use super::emit::{Emit, FaceTag};
use super::params::{Cull, FrontFace, GeometryCounts, RENDER_SNAP_BITS, RenderParams};
use super::vertex::Projected;
use super::viewport::Target;
use tileraster_kernels::EXTENT_LIMIT_BITS;
use tileraster_kernels::abi::{FloatCoeffs, PixelRect, TriangleInput, TriangleShading};

/// Cull, orient and set up the fan of a convex polygon of vertices inside every clipping plane,
/// and push what reaches the rasteriser.
pub(super) fn triangles(polygon: &[Projected], face: FaceTag, params: &RenderParams, target: &Target<'_>, out: &mut Emit<'_>, counts: &mut GeometryCounts) {
    for k in 1..polygon.len() - 1 {
        let v = [0, k, k + 1];
        let Some(Kept { v, x, y, area, rect }) = kept(v, v.map(|i| polygon[i].screen.0), v.map(|i| polygon[i].screen.1), params, target, counts) else {
            continue;
        };
        out.put(|| {
            // Entry k of the kernels' per-vertex data belongs to the vertex opposite edge k.
            let opposite = [v[2], v[0], v[1]];
            let area = area.unsigned_abs() as f64;
            let depth = |i: usize| polygon[i].depth;
            let coeffs = FloatCoeffs { c: [depth(opposite[0]), depth(opposite[1]), depth(opposite[2]), (1.0 / area) as f32] };
            let inv_w = |i: usize| polygon[i].inv_w;
            let attributes = opposite.map(|i| polygon[i].attributes);
            (
                TriangleInput { x, y, rect, coeffs, ..Default::default() },
                TriangleShading {
                    attributes,
                    inv_w: [inv_w(opposite[0]), inv_w(opposite[1]), inv_w(opposite[2]), 0.0],
                    face: face.id,
                    texture: face.texture,
                    flags: 0,
                    _pad: 0,
                },
            )
        });
    }
}

/// A triangle that reaches the rasteriser: its corners (indices `v` into its polygon) and their
/// snapped positions in the kernels' orientation, its doubled signed area, its pixels.
pub(super) struct Kept {
    v: [usize; 3],
    x: [i64; 3],
    y: [i64; 3],
    area: i128,
    rect: PixelRect,
}

/// Whether the triangle of snapped corners `x`, `y` (its polygon's vertices `v`) reaches the
/// rasteriser, oriented for the kernels: zero-area, back- or front-facing and pixel-less ones
/// are dropped, and counted in `counts`.
pub(super) fn kept(
    mut v: [usize; 3],
    mut x: [i64; 3],
    mut y: [i64; 3],
    params: &RenderParams,
    target: &Target<'_>,
    counts: &mut GeometryCounts,
) -> Option<Kept> {
    let area = (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
    if area == 0 {
        counts.culled_zero_area += 1;
        return None;
    }
    // Vulkan's rule: with y down, a triangle counter-clockwise on the screen has a negative
    // cross product here.
    let front = (area < 0) == (params.front_face == FrontFace::CounterClockwise);
    match (params.cull, front) {
        (Cull::Back, false) => {
            counts.culled_back += 1;
            return None;
        }
        (Cull::Front, true) => {
            counts.culled_front += 1;
            return None;
        }
        _ => {}
    }
    if area < 0 {
        v.swap(1, 2);
        x.swap(1, 2);
        y.swap(1, 2);
    }
    let rect = target.rect(&x, &y);
    if rect.is_empty() {
        counts.culled_no_centre += 1;
        return None;
    }
    let extent = (x.iter().max().unwrap() - x.iter().min().unwrap()).max(y.iter().max().unwrap() - y.iter().min().unwrap());
    debug_assert!(((extent >> RENDER_SNAP_BITS) + 2) << RENDER_SNAP_BITS < 1 << EXTENT_LIMIT_BITS, "the guard band bounds every triangle");
    Some(Kept { v, x, y, area, rect })
}
