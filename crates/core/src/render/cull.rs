//! Culling and setup of a clipped face's fan: zero-area, back- or front-facing and
//! pixel-less triangles dropped, the rest oriented and emitted.

use super::emit::{Emit, FaceTag};
use super::params::{GeometryCounts, RENDER_SNAP_BITS};
use super::vertex::Projected;
use super::viewport::Target;
use tileraster_kernels::EXTENT_LIMIT_BITS;
use tileraster_kernels::abi::FaceMaterial;
use tileraster_kernels::stages::assemble::{
    DROPPED_BACK, DROPPED_FRONT, DROPPED_NO_CENTRE, DROPPED_ZERO_AREA, KEPT, Snapped, assembly_for, snap_triangle, triangle_records,
};

/// Cull, orient and set up the fan of a convex polygon of vertices inside every clipping plane,
/// and push what reaches the rasteriser.
pub(super) fn triangles(polygon: &[Projected], face: FaceTag, target: &Target, out: &mut Emit<'_>, counts: &mut GeometryCounts) {
    for k in 1..polygon.len() - 1 {
        let corners = [&polygon[0], &polygon[k], &polygon[k + 1]];
        let Some(t) = kept(corners.map(|p| p.screen.0), corners.map(|p| p.screen.1), &face.material, target, counts) else {
            continue;
        };
        out.put(|| {
            let (depth, inv_w, attributes) = (corners.map(|p| p.depth), corners.map(|p| p.inv_w), corners.map(|p| p.attributes));
            triangle_records(&t, &depth, &inv_w, &attributes, face.id, face.material)
        });
    }
}

/// The triangle of snapped corners `x`, `y` of a face of surface `material` oriented for the
/// kernels where it reaches the rasteriser (`stages::assemble`); where it does not (zero area,
/// back or front face, no pixel centre), `None`, and counted in `counts`.
pub(super) fn kept(x: [i64; 3], y: [i64; 3], material: &FaceMaterial, target: &Target, counts: &mut GeometryCounts) -> Option<Snapped> {
    let t = snap_triangle(x, y, &assembly_for(target.assembly, material));
    match t.dropped {
        KEPT => {
            let side = |v: &[i64; 3]| v.iter().max().unwrap() - v.iter().min().unwrap();
            let extent = side(&t.x).max(side(&t.y));
            debug_assert!(((extent >> RENDER_SNAP_BITS) + 2) << RENDER_SNAP_BITS < 1 << EXTENT_LIMIT_BITS, "the guard band bounds every triangle");
            return Some(t);
        }
        dropped => count_dropped(dropped, counts),
    }
    None
}

/// A triangle [`snap_triangle`] dropped, counted by why.
pub(super) fn count_dropped(dropped: u32, counts: &mut GeometryCounts) {
    match dropped {
        DROPPED_ZERO_AREA => counts.culled_zero_area += 1,
        DROPPED_BACK => counts.culled_back += 1,
        DROPPED_FRONT => counts.culled_front += 1,
        DROPPED_NO_CENTRE => counts.culled_no_centre += 1,
        other => unreachable!("snap_triangle drops for no reason {other}"),
    }
}
