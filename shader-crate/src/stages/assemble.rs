//! Assembly of a snapped triangle in the render pipeline: whether it reaches the rasteriser
//! (area, facing, pixel centres), its orientation for the edge functions, and its records for
//! setup and shading. Integers and the `f32` values it is given, nothing else, so that every
//! device assembles the same bits. The host's assembly (`tileraster_core::render`, its `cull`
//! stage) takes every face's triangles through these functions.
//!
//! Range: snapped coordinates within the guard band (below `2^28` in magnitude), so that
//! differences stay below `2^29` and the doubled area below `2^59`.

use crate::abi::{ATTRIBUTES, FloatCoeffs, PixelRect, ProjectedVertex, TriangleInput, TriangleShading};
use crate::math::fixed::{ceil_shr, floor_shr};
use crate::math::float::recip_u64;
use crate::stages::vertex::{FRUSTUM, UNASSEMBLED};

/// Culling by facing: none.
pub const CULL_NONE: u32 = 0;
/// Culling by facing: back faces.
pub const CULL_BACK: u32 = 1;
/// Culling by facing: front faces.
pub const CULL_FRONT: u32 = 2;

/// What a frame's assembly decides with.
#[derive(Copy, Clone)]
pub struct Assembly {
    /// [`CULL_NONE`], [`CULL_BACK`] or [`CULL_FRONT`].
    pub cull: u32,
    /// 1 where triangles counter-clockwise on the screen face the viewer, 0 where clockwise ones do.
    pub front_counter_clockwise: u32,
    /// The target's pixels.
    pub width: u32,
    pub height: u32,
    /// Sub-pixel bits of the snapped coordinates.
    pub snap_bits: u32,
    /// How far beyond its snapped box a triangle's samples reach, in snapped units (0 with one
    /// sample per pixel).
    pub reach: i64,
}

/// The triangle reaches the rasteriser.
pub const KEPT: u32 = 0;
/// Dropped: its snapped corners lie on one line.
pub const DROPPED_ZERO_AREA: u32 = 1;
/// Dropped: a back face, culled.
pub const DROPPED_BACK: u32 = 2;
/// Dropped: a front face, culled.
pub const DROPPED_FRONT: u32 = 3;
/// Dropped: no pixel centre (or sample) lies in its box.
pub const DROPPED_NO_CENTRE: u32 = 4;
/// Dropped: its corners lie beyond one plane of the view frustum ([`assemble_face`]).
pub const DROPPED_FRUSTUM: u32 = 5;
/// Left to the host's clipping: a corner the vertex stage marked `UNASSEMBLED` ([`assemble_face`]).
pub const CLIPPED_ON_HOST: u32 = 6;

/// A snapped triangle as assembly leaves it.
#[derive(Copy, Clone, Default)]
pub struct Snapped {
    /// [`KEPT`], or why it was dropped (the rest is then unspecified).
    pub dropped: u32,
    /// Its corners (indices into what it was given) in the kernels' orientation.
    pub order: [usize; 3],
    pub x: [i64; 3],
    pub y: [i64; 3],
    /// Twice its area, in squared snapped units.
    pub area: u64,
    /// The pixels it may cover.
    pub rect: PixelRect,
}

/// The triangle of snapped corners `x`, `y`: dropped (zero area, culled by facing, no pixel
/// centre), or oriented so that its edge functions are positive inside.
pub fn snap_triangle(x: [i64; 3], y: [i64; 3], a: &Assembly) -> Snapped {
    let mut t = Snapped { dropped: KEPT, order: [0, 1, 2], x, y, ..Snapped::default() };
    let signed = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if signed == 0 {
        t.dropped = DROPPED_ZERO_AREA;
        return t;
    }
    // Vulkan's rule: with y down, a triangle counter-clockwise on the screen has a negative
    // cross product here.
    let front = (signed < 0) == (a.front_counter_clockwise == 1);
    if a.cull == CULL_BACK && !front {
        t.dropped = DROPPED_BACK;
        return t;
    }
    if a.cull == CULL_FRONT && front {
        t.dropped = DROPPED_FRONT;
        return t;
    }
    if signed < 0 {
        t.order = [0, 2, 1];
        t.x = [x[0], x[2], x[1]];
        t.y = [y[0], y[2], y[1]];
    }
    t.area = signed.unsigned_abs();
    t.rect = reach_rect(&t.x, &t.y, a);
    if t.rect.is_empty() {
        t.dropped = DROPPED_NO_CENTRE;
    }
    t
}

/// A face of three vertices through the vertex stage: dropped wholly outside one frustum plane
/// (by the stage's bits), left to the host where a corner is `UNASSEMBLED` (beyond the near or
/// far plane or the guard band, or outside the stage's domain), else [`snap_triangle`]. What
/// the assembly decides is the stage's bits alone, so every device decides alike, and a vertex
/// shared by faces is taken the same way by each of them.
#[inline]
pub fn assemble_face(corners: [ProjectedVertex; 3], a: &Assembly) -> Snapped {
    let (p0, p1, p2) = (corners[0].planes, corners[1].planes, corners[2].planes);
    if p0 & p1 & p2 & FRUSTUM != 0 {
        return Snapped { dropped: DROPPED_FRUSTUM, ..Snapped::default() };
    }
    if (p0 | p1 | p2) & UNASSEMBLED != 0 {
        return Snapped { dropped: CLIPPED_ON_HOST, ..Snapped::default() };
    }
    let x = [corners[0].screen[0] as i64, corners[1].screen[0] as i64, corners[2].screen[0] as i64];
    let y = [corners[0].screen[1] as i64, corners[1].screen[1] as i64, corners[2].screen[1] as i64];
    snap_triangle(x, y, a)
}

/// The records of a kept triangle: for setup (its corners, pixels and depth coefficients) and
/// for shading (its corners' attributes and `1/w`, its face and texture). `depth`, `inv_w` and
/// `attributes` are its corners' in the order it was given (before [`snap_triangle`] oriented it).
pub fn triangle_records(
    t: &Snapped,
    depth: &[f32; 3],
    inv_w: &[f32; 3],
    attributes: &[[f32; ATTRIBUTES]; 3],
    face: u32,
    texture: u32,
) -> (TriangleInput, TriangleShading) {
    // Entry k of the kernels' per-vertex data belongs to the vertex opposite edge k.
    let opposite = [t.order[2], t.order[0], t.order[1]];
    let coeffs = FloatCoeffs { c: [depth[opposite[0]], depth[opposite[1]], depth[opposite[2]], recip_u64(t.area)] };
    (
        TriangleInput { x: t.x, y: t.y, rect: t.rect, coeffs, ..Default::default() },
        TriangleShading {
            attributes: [attributes[opposite[0]], attributes[opposite[1]], attributes[opposite[2]]],
            inv_w: [inv_w[opposite[0]], inv_w[opposite[1]], inv_w[opposite[2]], 0.0],
            face,
            texture,
            flags: 0,
            _pad: 0,
        },
    )
}

/// The pixels a triangle of snapped vertices `x`, `y` may cover: those whose centre lies in its
/// box or, with several samples, whose samples may (`Assembly::reach`).
pub fn reach_rect(x: &[i64; 3], y: &[i64; 3], a: &Assembly) -> PixelRect {
    let (x0, x1) = (min3(x) - a.reach, max3(x) + a.reach);
    let (y0, y1) = (min3(y) - a.reach, max3(y) + a.reach);
    pixel_rect(&[x0, x1, x1], &[y0, y1, y1], a.snap_bits, a.width, a.height)
}

/// The pixels whose centres lie in the box of the snapped vertices `x`, `y`, clamped to a
/// `width` × `height` grid (an empty rectangle stays empty).
pub fn pixel_rect(x: &[i64; 3], y: &[i64; 3], snap_bits: u32, width: u32, height: u32) -> PixelRect {
    let half = 1i64 << (snap_bits - 1);
    let first = |v: i64, n: u32| clamp(ceil_shr(v - half, snap_bits), 0, n as i64) as i32;
    let last = |v: i64, n: u32| clamp(floor_shr(v - half, snap_bits), -1, n as i64 - 1) as i32;
    PixelRect { i0: first(min3(x), width), j0: first(min3(y), height), i1: last(max3(x), width), j1: last(max3(y), height) }
}

fn min3(v: &[i64; 3]) -> i64 {
    v[0].min(v[1]).min(v[2])
}

fn max3(v: &[i64; 3]) -> i64 {
    v[0].max(v[1]).max(v[2])
}

fn clamp(v: i64, lo: i64, hi: i64) -> i64 {
    v.max(lo).min(hi)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    const UNIT: i64 = 256;

    fn frame(cull: u32, reach: i64) -> Assembly {
        Assembly { cull, front_counter_clockwise: 1, width: 16, height: 16, snap_bits: 8, reach }
    }

    /// Edge `k` (from corner `k` to the next) at the point `(px, py)`, positive inside.
    fn edge(t: &Snapped, k: usize, px: i64, py: i64) -> i64 {
        let b = (k + 1) % 3;
        (t.x[b] - t.x[k]) * (py - t.y[k]) - (t.y[b] - t.y[k]) * (px - t.x[k])
    }

    #[test]
    fn facing_decides_culling_and_orientation() {
        // Top left, bottom left, top right: counter-clockwise on a screen whose y points down.
        let (x, y) = ([UNIT, UNIT, 5 * UNIT], [UNIT, 5 * UNIT, UNIT]);
        assert_eq!(snap_triangle(x, y, &frame(CULL_FRONT, 0)).dropped, DROPPED_FRONT);
        let clockwise = ([x[0], x[2], x[1]], [y[0], y[2], y[1]]);
        assert_eq!(snap_triangle(clockwise.0, clockwise.1, &frame(CULL_BACK, 0)).dropped, DROPPED_BACK);
        for (x, y) in [(x, y), clockwise] {
            let t = snap_triangle(x, y, &frame(CULL_NONE, 0));
            assert_eq!(t.dropped, KEPT);
            assert_eq!(t.area, 16 * UNIT as u64 * UNIT as u64);
            // Oriented: every edge function positive at a centre inside, whichever way it came.
            assert!((0..3).all(|k| edge(&t, k, 2 * UNIT + UNIT / 2, 2 * UNIT + UNIT / 2) > 0));
            assert_eq!(t.order.map(|i| (x[i], y[i])), [0, 1, 2].map(|k| (t.x[k], t.y[k])));
            // Centres 1.5 … 4.5 lie in the box [1, 5].
            assert_eq!((t.rect.i0, t.rect.i1, t.rect.j0, t.rect.j1), (1, 4, 1, 4));
        }
    }

    #[test]
    fn lines_and_boxes_without_a_centre_are_dropped() {
        let line = snap_triangle([0, UNIT, 2 * UNIT], [0, UNIT, 2 * UNIT], &frame(CULL_NONE, 0));
        assert_eq!(line.dropped, DROPPED_ZERO_AREA);
        // Between the centres 0.5 and 1.5 on both axes: none inside, but samples within 7/16
        // px of a centre reach it.
        let (x, y) = ([UNIT - 40, UNIT - 40, UNIT + 40], [UNIT - 40, UNIT + 40, UNIT - 40]);
        assert_eq!(snap_triangle(x, y, &frame(CULL_NONE, 0)).dropped, DROPPED_NO_CENTRE);
        let reached = snap_triangle(x, y, &frame(CULL_NONE, 7 << 4));
        assert_eq!(reached.dropped, KEPT);
        assert_eq!((reached.rect.i0, reached.rect.i1), (0, 1));
    }

    #[test]
    fn a_face_is_decided_by_its_corners_planes() {
        use crate::stages::vertex::{BEYOND_FAR, BEYOND_LEFT, BEYOND_NEAR, UNASSEMBLED};
        let corner = |x: i64, y: i64, planes: u32| ProjectedVertex { screen: [x as i32, y as i32], depth: 0.5, inverse_w: 1.0, planes };
        let (a, b, c) = (corner(UNIT, UNIT, 0), corner(UNIT, 5 * UNIT, 0), corner(5 * UNIT, UNIT, 0));
        let kept = assemble_face([a, b, c], &frame(CULL_NONE, 0));
        assert_eq!((kept.dropped, kept.area), (KEPT, 16 * UNIT as u64 * UNIT as u64));
        // Beyond one plane together: dropped, even where a corner is not projected.
        let left = |v: &ProjectedVertex, more: u32| ProjectedVertex { planes: BEYOND_LEFT | more, ..*v };
        let outside = [left(&a, 0), left(&b, BEYOND_NEAR | UNASSEMBLED), left(&c, BEYOND_FAR)];
        assert_eq!(assemble_face(outside, &frame(CULL_NONE, 0)).dropped, DROPPED_FRUSTUM);
        // Beyond different planes, or one corner left to the host: clipped there.
        let across = [left(&a, 0), ProjectedVertex { planes: BEYOND_NEAR | UNASSEMBLED, ..b }, c];
        assert_eq!(assemble_face(across, &frame(CULL_NONE, 0)).dropped, CLIPPED_ON_HOST);
        let none = ProjectedVertex::NONE;
        assert_eq!(assemble_face([a, none, c], &frame(CULL_BACK, 0)).dropped, CLIPPED_ON_HOST);
        // Beyond a side plane but projected: the assembly takes it (the guard band holds it).
        let wide = [left(&a, 0), b, c];
        assert_eq!(assemble_face(wide, &frame(CULL_NONE, 0)).dropped, KEPT);
    }

    #[test]
    fn records_follow_the_orientation() {
        let (x, y) = ([UNIT, UNIT, 5 * UNIT], [UNIT, 5 * UNIT, UNIT]);
        let t = snap_triangle(x, y, &frame(CULL_NONE, 0));
        assert_eq!(t.order, [0, 2, 1], "counter-clockwise as given: turned");
        let mut attributes = [[0.0; ATTRIBUTES]; 3];
        (0..3).for_each(|k| attributes[k][0] = k as f32);
        let (input, shading) = triangle_records(&t, &[0.0, 0.5, 1.0], &[1.0, 2.0, 3.0], &attributes, 7, 9);
        // Entry k belongs to the corner opposite edge k: oriented corners 2, 0, 1, given ones
        // 1, 0, 2.
        assert_eq!(input.coeffs.c[..3], [0.5, 0.0, 1.0]);
        assert_eq!(input.coeffs.c[3], (1.0 / t.area as f64) as f32);
        assert_eq!(shading.inv_w, [2.0, 1.0, 3.0, 0.0]);
        assert_eq!(shading.attributes.map(|a| a[0]), [1.0, 0.0, 2.0]);
        assert_eq!((shading.face, shading.texture, input.x, input.y), (7, 9, t.x, t.y));
    }
}
