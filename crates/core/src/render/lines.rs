//! Lines: the wireframe view. Every edge of a mesh's faces is drawn once, one pixel wide, after
//! the faces, depth-tested and counted like them, as two triangles that both backends
//! rasterise as any other, so the same bits come out.
//!
//! Under the diamond-exit and Bresenham rules a line lights one pixel per column of its major
//! axis (`x` where `|Δx| ≥ |Δy|`, else `y`): the pixel whose centre lies in the half-open band
//! one pixel tall (or wide) centred on the segment, which the top-left rule of the band's two
//! triangles makes exact. The rule says which columns: those whose diamond the segment passes
//! through and leaves (diamond-exit), or every column between its endpoints' pixels
//! (Bresenham). The band reaches beyond those columns along the segment's exact direction, so
//! that its end edges decide nothing, and its triangles' pixel rectangles keep the rule's
//! columns. The rectangle rule is Vulkan's strict line: the rectangle one pixel wide around
//! the segment.

use super::clip::cut;
use super::emit::Emit;
use super::params::{GUARD_PX, GeometryCounts, RENDER_SNAP_BITS};
use super::params::{LineRule, Wireframe};
use super::vertex::{ClipVertex, Projected};
use super::viewport::distance;
use super::viewport::{Target, Viewport};
use rayon::prelude::*;
use std::sync::atomic::{AtomicU32, Ordering};
use tileraster_kernels::EXTENT_LIMIT_BITS;
use tileraster_kernels::abi::{ATTR_COLOUR, ATTRIBUTES, FaceMaterial, FloatCoeffs, NO_TEXTURE, SHADING_UNLIT, TriangleInput, TriangleShading};
use tileraster_kernels::math::float::recip_u64;

impl LineRule {
    pub fn name(self) -> &'static str {
        match self {
            LineRule::DiamondExit => "diamond-exit",
            LineRule::Bresenham => "bresenham",
            LineRule::Rectangle => "rectangle",
        }
    }
}

/// How far beyond the viewport, in pixels, a line may reach before it is clipped: a quarter of
/// the triangles' guard band, so that a line's band triangles, up to three times its length,
/// stay within the kernels' extent.
pub(super) const LINE_GUARD_PX: f64 = GUARD_PX / 4.0;

/// Half a pixel, in snapped units.
const HALF: i64 = 1 << (RENDER_SNAP_BITS - 1);

/// The edges of `triangles`, each once (either direction), in the order the faces first name
/// them; an edge from a vertex to itself is no line.
///
/// The faces' sides are grouped by their lower vertex (counted and placed with atomics), each
/// group sorted by upper vertex and face order, and each edge's first side kept, all on all
/// cores. (For a grid of 200k triangles on a 2-core host: 12–14 ms, where a
/// hash set walked face by face took 32–40 and a serial counting sort 17–22.)
///
/// Panics where the faces have more than `u32::MAX` sides (`render` refuses such a wireframe
/// first, with [`Error::TooManyFaces`](crate::Error::TooManyFaces)).
pub fn edges(triangles: &[[u32; 3]]) -> Vec<[u32; 2]> {
    assert!(triangles.len() <= u32::MAX as usize / 3, "{} faces have more sides than a u32 counts", triangles.len());
    let side = |s: usize| {
        let t = &triangles[s / 3];
        let k = s % 3;
        [t[k], t[(k + 1) % 3]]
    };
    let lower = |s: usize| {
        let [a, b] = side(s);
        (a != b).then_some(a.min(b) as usize)
    };
    let upper = |s: u32| {
        let [a, b] = side(s as usize);
        a.max(b)
    };
    let sides = triangles.len() * 3;
    let vertices = triangles.par_iter().map(|t| t[0].max(t[1]).max(t[2]) as usize + 1).max().unwrap_or(0);
    let sizes: Vec<AtomicU32> = (0..vertices).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    (0..sides).into_par_iter().filter_map(lower).for_each(|v| {
        sizes[v].fetch_add(1, Ordering::Relaxed);
    });
    let mut group_start: Vec<u32> = Vec::with_capacity(vertices + 1);
    group_start.push(0);
    let mut total = 0u32;
    group_start.extend(sizes.iter().map(|n| {
        total += n.load(Ordering::Relaxed);
        total
    }));
    // Each side into its group, at a place the group's counter hands out.
    let cursors = sizes;
    cursors.par_iter().zip(&group_start[..vertices]).for_each(|(c, &start)| c.store(start, Ordering::Relaxed));
    let grouped: Vec<AtomicU32> = (0..total).into_par_iter().map(|_| AtomicU32::new(0)).collect();
    (0..sides).into_par_iter().for_each(|s| {
        if let Some(v) = lower(s) {
            grouped[cursors[v].fetch_add(1, Ordering::Relaxed) as usize].store(s as u32, Ordering::Relaxed);
        }
    });
    let mut grouped: Vec<u32> = grouped.into_iter().map(AtomicU32::into_inner).collect();
    // A side is its edge's first where no earlier side of its group reaches the same vertex.
    let mut groups = Vec::with_capacity(vertices);
    let mut rest = &mut grouped[..];
    for w in group_start.windows(2) {
        let (group, tail) = rest.split_at_mut((w[1] - w[0]) as usize);
        groups.push(group);
        rest = tail;
    }
    let mut firsts: Vec<u32> = groups
        .into_par_iter()
        .flat_map_iter(|group| {
            // By (upper vertex, face order): each run is one edge, its head the first side.
            group.sort_unstable_by_key(|&s| (upper(s), s));
            let group = &*group;
            group.iter().enumerate().filter(move |&(k, &s)| k == 0 || upper(group[k - 1]) != upper(s)).map(|(_, &s)| s)
        })
        .collect();
    // Back into face order.
    firsts.par_sort_unstable();
    firsts.par_iter().map(|&s| side(s as usize)).collect()
}

/// A segment's ends and what the kernels take of them, in snapped units.
struct End<'a> {
    at: (i64, i64),
    depth: f64,
    attributes: &'a [f32; ATTRIBUTES],
}

/// Clip, snap and push one line: the segment between `a` and `b`, drawn with `rule`, its
/// ends' depths less `bias` (drawn over faces), in `colour` or its vertices' colours.
#[allow(clippy::too_many_arguments)]
pub(super) fn line(
    ends: [&ClipVertex; 2],
    bias: [f64; 2],
    wireframe: &Wireframe,
    flat: bool,
    id: u32,
    viewport: &Viewport,
    target: &Target,
    out: &mut Emit<'_>,
    counts: &mut GeometryCounts,
) {
    let Some([a, b]) = clip_segment(ends[0], ends[1], &viewport.planes()) else {
        counts.lines_culled += 1;
        return;
    };
    // A vertex's own end as the vertex stage snapped it (where the faces meet it), a point
    // clipping made on the host.
    let snap = |v: &ClipVertex| if !v.cut && v.outside == 0 { v.projected } else { v.project(viewport) };
    let (pa, pb) = (snap(&a), snap(&b));
    let mut attributes = [pa.attributes, if flat { pa.attributes } else { pb.attributes }];
    if let Some(c) = wireframe.colour {
        for v in &mut attributes {
            v[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&c);
        }
    }
    let end = |p: &Projected, bias: f64, attributes| End { at: p.screen, depth: (p.depth as f64 - bias).max(0.0), attributes };
    let (p0, p1) = (end(&pa, bias[0], &attributes[0]), end(&pb, bias[1], &attributes[1]));
    let put = band(&p0, &p1, wireframe.rule, id, target, out);
    if put == 0 {
        counts.lines_culled += 1;
    } else {
        counts.lines_drawn += 1;
    }
}

/// The segment within every clipping plane, each cut made from its inside end (as faces are
/// cut), or `None` where nothing of it is left.
fn clip_segment(a: &ClipVertex, b: &ClipVertex, planes: &[[f64; 4]; 7]) -> Option<[ClipVertex; 2]> {
    let (mut a, mut b) = (*a, *b);
    for k in 0..planes.len() {
        let (da, db) = (distance(planes, k, &a.clip), distance(planes, k, &b.clip));
        match (da >= 0.0, db >= 0.0) {
            (true, true) => {}
            (false, false) => return None,
            (true, false) => b = cut(&a, &b, da, db, k),
            (false, true) => a = cut(&b, &a, db, da, k),
        }
    }
    Some([a, b])
}

/// The index of the pixel whose interval holds `v` (snapped units), and its centre.
fn pixel(v: i64) -> (i64, i64) {
    let i = v >> RENDER_SNAP_BITS;
    (i, (i << RENDER_SNAP_BITS) + HALF)
}

/// The first pixel index whose centre is at least `v`, and the last whose centre is at most `v`.
fn centres_from(v: i64) -> i64 {
    -((HALF - v) >> RENDER_SNAP_BITS)
}
fn centres_to(v: i64) -> i64 {
    (v - HALF) >> RENDER_SNAP_BITS
}

/// Whether `(u, v)` lies inside the open diamond of the pixel that holds it.
fn in_diamond((u, v): (i64, i64)) -> bool {
    let (cu, cv) = (pixel(u).1, pixel(v).1);
    (u - cu).abs() + (v - cv).abs() < HALF
}

/// What [`columns`] finds: the lowest and highest major-axis pixel index, the segment's two
/// ends in `(major, minor)` coordinates, and whether `y` is the major axis.
type Columns = (i64, i64, (i64, i64), (i64, i64), bool);

/// The major-axis pixels a diamond-exit or Bresenham line lights, lowest and highest index (empty where `lo > hi`), and
/// the segment whose band they take (Bresenham moves the ends to pixel centres), in
/// `(major, minor)` coordinates, and whether `y` is the major axis.
pub(super) fn columns(p0: (i64, i64), p1: (i64, i64), rule: LineRule) -> Option<Columns> {
    let (q0, q1) = match rule {
        LineRule::DiamondExit | LineRule::Rectangle => (p0, p1),
        LineRule::Bresenham => ((pixel(p0.0).1, pixel(p0.1).1), (pixel(p1.0).1, pixel(p1.1).1)),
    };
    let (dx, dy) = (q1.0 - q0.0, q1.1 - q0.1);
    let y_major = dy.abs() > dx.abs();
    let swap = |p: (i64, i64)| if y_major { (p.1, p.0) } else { p };
    let (u0, u1) = (swap(q0), swap(q1));
    let (lo, hi) = match rule {
        LineRule::Bresenham => {
            let (a, b) = (pixel(u0.0).0, pixel(u1.0).0);
            (a.min(b), a.max(b))
        }
        LineRule::DiamondExit | LineRule::Rectangle => {
            if u0 == u1 {
                return None;
            }
            // A line with |slope| ≤ 1 meets a diamond exactly where it crosses the diamond's
            // vertical diagonal inside it (its L1 distance from the centre is least there), and
            // the band's pixel is that diamond's: so the segment passes through the diamonds
            // of the columns whose centre it reaches, and, before its start, at most the one
            // it starts inside (moving away, its distance from any other grows). Those
            // columns, with the first pixel's where it starts inside its diamond and without
            // the last's where it ends inside one.
            let start = in_diamond(u0).then(|| pixel(u0.0).0);
            let end = in_diamond(u1).then(|| pixel(u1.0).0);
            if u1.0 > u0.0 {
                (start.unwrap_or_else(|| centres_from(u0.0)), end.map_or_else(|| centres_to(u1.0), |e| e - 1))
            } else {
                (end.map_or_else(|| centres_from(u1.0), |e| e + 1), start.unwrap_or_else(|| centres_to(u0.0)))
            }
        }
    };
    (lo <= hi).then_some((lo, hi, u0, u1, y_major))
}

/// A line's quadrilateral: its corners (`a` end low side, `b` end low side, `b` high, `a` high),
/// how far its ends reach beyond the segment's (a fraction of its length, for depth and
/// attributes), and the major-axis pixels it may light, where its rule limits them.
struct Quad {
    corners: [(i64, i64); 4],
    reach: f64,
    columns: Option<(i64, i64, bool)>,
}

/// The band of a diamond-exit or Bresenham line, over the columns its rule lights.
fn band_quad(p0: (i64, i64), p1: (i64, i64), rule: LineRule) -> Option<Quad> {
    let (lo, hi, u0, u1, y_major) = columns(p0, p1, rule)?;
    // The band reaches at least half a pixel and a unit past both ends along the segment's
    // exact direction (a whole multiple of its smallest integer step), so that no end edge
    // crosses a column the rule lights.
    let (du, dv) = (u1.0 - u0.0, u1.1 - u0.1);
    let (du, dv) = if (du, dv) == (0, 0) { (1, 0) } else { (du, dv) };
    let g = gcd(du.unsigned_abs(), dv.unsigned_abs()) as i64;
    let step = (du / g, dv / g);
    let k = (HALF + 1 + step.0.abs() - 1) / step.0.abs();
    let e = (k * step.0, k * step.1);
    let (a, b) = ((u0.0 - e.0, u0.1 - e.1), (u1.0 + e.0, u1.1 + e.1));
    let reach = if (u1.0 - u0.0, u1.1 - u0.1) == (0, 0) { 0.0 } else { k as f64 / g as f64 };
    let corner = |p: (i64, i64), side: i64| if y_major { (p.1 + side * HALF, p.0) } else { (p.0, p.1 + side * HALF) };
    Some(Quad { corners: [corner(a, -1), corner(b, -1), corner(b, 1), corner(a, 1)], reach, columns: Some((lo, hi, y_major)) })
}

/// The rectangle one pixel wide around the segment, its corners rounded to the snapping
/// lattice (in `f64`, on the host: the same corners for both backends).
fn rectangle_quad(p0: (i64, i64), p1: (i64, i64)) -> Option<Quad> {
    let (dx, dy) = ((p1.0 - p0.0) as f64, (p1.1 - p0.1) as f64);
    let length = dx.hypot(dy);
    if length == 0.0 {
        return None;
    }
    let n = ((-dy * HALF as f64 / length).round() as i64, (dx * HALF as f64 / length).round() as i64);
    let corner = |p: (i64, i64), side: i64| (p.0 + side * n.0, p.1 + side * n.1);
    Some(Quad { corners: [corner(p0, -1), corner(p1, -1), corner(p1, 1), corner(p0, 1)], reach: 0.0, columns: None })
}

/// Push the two triangles of a line's quadrilateral; how many were put (none where the line
/// lights no pixel of the frame).
fn band(p0: &End<'_>, p1: &End<'_>, rule: LineRule, id: u32, target: &Target, out: &mut Emit<'_>) -> u64 {
    let quad = match rule {
        LineRule::Rectangle => rectangle_quad(p0.at, p1.at),
        LineRule::DiamondExit | LineRule::Bresenham => band_quad(p0.at, p1.at, rule),
    };
    let Some(Quad { corners: [a_lo, b_lo, b_hi, a_hi], reach: t, columns }) = quad else {
        return 0;
    };
    // Depth and attributes are affine along the line in screen space (`1/w` is left at one):
    // extended as far as its quadrilateral goes.
    let extend = |v0: f64, v1: f64| [v0 - t * (v1 - v0), v1 + t * (v1 - v0)];
    let [za, zb] = extend(p0.depth, p1.depth);
    let mut attr_a = [0.0f32; ATTRIBUTES];
    let mut attr_b = [0.0f32; ATTRIBUTES];
    for n in 0..ATTRIBUTES {
        let [x, y] = extend(p0.attributes[n] as f64, p1.attributes[n] as f64);
        (attr_a[n], attr_b[n]) = (x as f32, y as f32);
    }
    let mut put = 0;
    for tri in [[(a_lo, false), (b_lo, true), (b_hi, true)], [(a_lo, false), (b_hi, true), (a_hi, false)]] {
        let mut v = tri;
        let (x, y) = (v.map(|c| c.0.0), v.map(|c| c.0.1));
        let area = (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
        if area == 0 {
            continue;
        }
        if area < 0 {
            v.swap(1, 2);
        }
        let (x, y) = (v.map(|c| c.0.0), v.map(|c| c.0.1));
        let mut rect = target.rect(&x, &y);
        if let Some((lo, hi, y_major)) = columns {
            let (lo, hi) = (lo.clamp(i32::MIN as i64, i32::MAX as i64) as i32, hi.clamp(i32::MIN as i64, i32::MAX as i64) as i32);
            if y_major {
                (rect.j0, rect.j1) = (rect.j0.max(lo), rect.j1.min(hi));
            } else {
                (rect.i0, rect.i1) = (rect.i0.max(lo), rect.i1.min(hi));
            }
        }
        if rect.is_empty() {
            continue;
        }
        let extent = (x.iter().max().unwrap() - x.iter().min().unwrap()).max(y.iter().max().unwrap() - y.iter().min().unwrap());
        debug_assert!(((extent >> RENDER_SNAP_BITS) + 2) << RENDER_SNAP_BITS < 1 << EXTENT_LIMIT_BITS, "the line guard band bounds every band");
        put += 1;
        out.put(|| {
            // Entry k of the kernels' per-vertex data belongs to the vertex opposite edge k.
            let opposite = [v[2].1, v[0].1, v[1].1];
            let depth = |at_b: bool| (if at_b { zb } else { za }) as f32;
            let attributes = |at_b: bool| if at_b { attr_b } else { attr_a };
            let coeffs = FloatCoeffs { c: [depth(opposite[0]), depth(opposite[1]), depth(opposite[2]), recip_u64(area.unsigned_abs() as u64)] };
            (
                TriangleInput { x, y, rect, coeffs, ..Default::default() },
                TriangleShading {
                    attributes: opposite.map(attributes),
                    inv_w: [1.0, 1.0, 1.0],
                    face: id,
                    material: FaceMaterial::plain(NO_TEXTURE, SHADING_UNLIT),
                },
            )
        });
    }
    put
}

fn gcd(mut a: u64, mut b: u64) -> u64 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_are_listed_once_in_first_use_order() {
        let e = edges(&[[0, 1, 2], [2, 1, 3], [3, 3, 4]]);
        assert_eq!(e, vec![[0, 1], [1, 2], [2, 0], [1, 3], [3, 2], [3, 4]]);
    }

    /// The sorted form against a hash set walked face by face, on meshes with shared,
    /// repeated and degenerate sides.
    #[test]
    fn edges_match_a_set_walked_in_order() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = |n: u32| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 33) as u32 % n
        };
        for vertices in [1, 3, 40, 1000] {
            let triangles: Vec<[u32; 3]> = (0..3000).map(|_| [next(vertices), next(vertices), next(vertices)]).collect();
            let mut seen = std::collections::HashSet::new();
            let mut expected = Vec::new();
            for t in &triangles {
                for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                    if a != b && seen.insert((a.min(b), a.max(b))) {
                        expected.push([a, b]);
                    }
                }
            }
            assert_eq!(edges(&triangles), expected, "{vertices} vertices");
        }
        // A fan: every side but the rim's in the group of vertex 0.
        let fan: Vec<[u32; 3]> = (1..2000).map(|i| [0, i, i + 1]).collect();
        let expected: Vec<[u32; 2]> = [[0, 1]].into_iter().chain((1..2000).flat_map(|i| [[i, i + 1], [i + 1, 0]])).collect();
        assert_eq!(edges(&fan), expected);
    }

    #[test]
    fn centres_are_found_on_both_sides() {
        // Centres at 128 + 256·i.
        assert_eq!((centres_from(128), centres_to(128)), (0, 0));
        assert_eq!((centres_from(129), centres_to(383)), (1, 0));
        assert_eq!((centres_from(-200), centres_to(-200)), (-1, -2));
        assert!(in_diamond((128 + 60, 256 + 128 - 67)));
        assert!(!in_diamond((128 + 60, 256 + 128 - 68)));
    }
}
