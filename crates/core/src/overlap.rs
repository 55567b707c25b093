//! Scene analysis: does any pixel centre lie inside two triangles?
//!
//! Fine raster resolves ownership (lowest index wins) because triangles may overlap. Most
//! scenes — every TIN, every heightfield — never do, and then a pixel can stop at the first
//! triangle it is inside. This module proves that, exactly, on the snapped lattice the
//! kernels decide coverage on; when it cannot prove it, ownership is resolved as usual.
//!
//! The argument. The fill rule puts pixel centre `p` inside a triangle exactly when the
//! perturbed point `p* = p + (ε, ε²)` (ε infinitesimal) is strictly inside it: an edge through
//! `p` then decides by the sign of `−dy`, or of `dx` when it is horizontal, which is the
//! top-left rule of `stages::setup`. Every prepared triangle is positively oriented, so the
//! number of triangles `p*` is inside equals the winding number around `p*` of all their
//! directed edges together; edges that cancel (`a→b` against `b→a`, shared inside a mesh)
//! drop out. What is left is a short chain (a TIN's hull), and its winding number along the
//! row of `p` is a running sum over the chain's crossings of that row to the right of `p*`.
//! The scene is overlap-free when that sum never exceeds one on any pixel row of the grid.

use rayon::prelude::*;
use std::ops::Range;
use tileraster_kernels::abi::TriangleInput;

/// Crossings the analysis may sort per triangle and per pixel row before it gives up (and
/// ownership is resolved): bounds its time and memory on scenes of many large triangles whose
/// edges do not cancel, which are rarely overlap-free anyway.
const CROSSINGS_PER_ITEM: usize = 8;

/// Whether no pixel centre of pixel rows `rows` is inside two of `triangles` (snapped,
/// positive, `1 px = 2^snap_bits` units; `corners[t]` the scene vertex indices of triangle `t`
/// in the same order). `false` means "not proven".
pub fn overlap_free(triangles: &[TriangleInput], corners: &[[u32; 3]], snap_bits: u32, rows: Range<u32>) -> bool {
    let budget = CROSSINGS_PER_ITEM * (triangles.len() + rows.len());
    prove(triangles, corners, snap_bits, rows, budget)
}

/// [`overlap_free`], giving up past `budget` crossings.
fn prove(triangles: &[TriangleInput], corners: &[[u32; 3]], snap_bits: u32, rows: Range<u32>, budget: usize) -> bool {
    if more_area_than_room(triangles) {
        return false;
    }
    let Some(crossings) = residual_crossings(triangles, corners, snap_bits, rows, budget) else {
        return false;
    };
    max_winding(crossings) <= 1
}

/// Twice the triangles' total area exceeds twice the area of their bounding box: they must
/// overlap (exact, in `i128`). Rejects dense soups before any sorting.
fn more_area_than_room(triangles: &[TriangleInput]) -> bool {
    let (mut x0, mut y0, mut x1, mut y1) = (i64::MAX, i64::MAX, i64::MIN, i64::MIN);
    let mut area2: i128 = 0;
    for t in triangles {
        let (x, y) = (&t.x, &t.y);
        area2 += (x[1] - x[0]) as i128 * (y[2] - y[0]) as i128 - (y[1] - y[0]) as i128 * (x[2] - x[0]) as i128;
        x0 = x0.min(x[0]).min(x[1]).min(x[2]);
        x1 = x1.max(x[0]).max(x[1]).max(x[2]);
        y0 = y0.min(y[0]).min(y[1]).min(y[2]);
        y1 = y1.max(y[0]).max(y[1]).max(y[2]);
    }
    !triangles.is_empty() && area2 > 2 * (x1 - x0) as i128 * (y1 - y0) as i128
}

/// Where a directed edge crosses the centre line of pixel row `row`: at `x = num / den`
/// (`den > 0`), adding `winding` to every point to its left.
struct Crossing {
    row: u32,
    num: i128,
    den: i128,
    winding: i32,
}

/// An edge of the scene by its two vertex indices: the smaller, the larger, and the triangle and
/// corner it starts at with whether it runs from the smaller index (`(t·3 + k) << 1 | up`).
/// Horizontal edges cross no row line (the perturbation lifts p* off them) and are left out.
type EdgeKey = (u32, u32, u32);

/// The crossings of pixel-centre rows by the directed edges that do not cancel, or `None` past
/// the budget. Edges are split by their smaller vertex index into one range per thread; each
/// range's edges cancel among themselves only, so the ranges are worked in parallel, and the
/// crossings (a set: `max_winding` sorts them) do not depend on how many there are.
fn residual_crossings(triangles: &[TriangleInput], corners: &[[u32; 3]], snap_bits: u32, rows: Range<u32>, budget: usize) -> Option<Vec<Crossing>> {
    let vertices = corners.as_flattened().par_iter().max().map_or(0, |&v| v as usize + 1);
    // Every triangle's three edges, in parallel; a horizontal edge is `None`.
    let mut edges: Vec<[Option<EdgeKey>; 3]> = Vec::new();
    triangles
        .par_iter()
        .zip(corners)
        .enumerate()
        .map(|(t, (tri, ids))| {
            [0, 1, 2].map(|k| {
                let (p, q) = (ids[k], ids[(k + 1) % 3]);
                (tri.y[k] != tri.y[(k + 1) % 3]).then(|| (p.min(q), p.max(q), (t as u32 * 3 + k as u32) << 1 | (p < q) as u32))
            })
        })
        .collect_into_vec(&mut edges);
    let parts = rayon::current_num_threads().max(1);
    let per_part = vertices.div_ceil(parts).max(1);
    let pieces: Vec<Option<Vec<Crossing>>> = (0..parts)
        .into_par_iter()
        .map(|part| {
            let low = (part * per_part).min(vertices)..((part + 1) * per_part).min(vertices);
            crossings_of_range(triangles, &edges, low, snap_bits, rows.clone(), budget)
        })
        .collect();
    let mut crossings = Vec::new();
    for piece in pieces {
        crossings.extend(piece?);
        if crossings.len() > budget {
            return None;
        }
    }
    Some(crossings)
}

/// [`residual_crossings`] of the edges whose smaller vertex index lies in `lows`.
fn crossings_of_range(
    triangles: &[TriangleInput],
    all_edges: &[[Option<EdgeKey>; 3]],
    lows: Range<usize>,
    snap_bits: u32,
    rows: Range<u32>,
    budget: usize,
) -> Option<Vec<Crossing>> {
    // Each edge by its two vertex indices, bucketed by the smaller one (a counting sort: a
    // vertex has a handful of edges); sorting each small bucket by the larger index brings an
    // edge's uses together. (Edges that meet only in coordinates, through duplicate vertices,
    // stay; their crossings coincide and cancel in the sweep.)
    let base = lows.start;
    let vertices = lows.len();
    let mut starts = vec![0u32; vertices + 1];
    // One scan of all the edges for this range's (the counting sort then walks only those).
    let mine: Vec<EdgeKey> =
        all_edges.as_flattened().iter().flatten().filter(|e| lows.contains(&(e.0 as usize))).map(|&(l, h, code)| (l - base as u32, h, code)).collect();
    for &(low, _, _) in &mine {
        starts[low as usize + 1] += 1;
    }
    for v in 0..vertices {
        starts[v + 1] += starts[v];
    }
    let mut fill = starts.clone();
    let mut edges = vec![(0u32, 0u32); starts[vertices] as usize];
    for &(low, high, code) in &mine {
        edges[fill[low as usize] as usize] = (high, code);
        fill[low as usize] += 1;
    }
    for v in 0..vertices {
        edges[starts[v] as usize..starts[v + 1] as usize].sort_unstable();
    }

    let unit = 1i64 << snap_bits;
    let half = unit >> 1;
    let mut crossings = Vec::new();
    let mut k = 0;
    let mut low = 0;
    while k < edges.len() {
        while starts[low + 1] as usize <= k {
            low += 1;
        }
        let key = (low, edges[k].0);
        let mut multiplicity = 0i32;
        let sample = edges[k].1;
        while k < edges.len() && (k as u32) < starts[low + 1] && edges[k].0 == key.1 {
            multiplicity += if edges[k].1 & 1 == (sample & 1) { 1 } else { -1 };
            k += 1;
        }
        if multiplicity == 0 {
            continue;
        }
        // The sample's directed edge a → b, `multiplicity` times (negative: b → a).
        let (t, c) = ((sample >> 1) as usize / 3, (sample >> 1) as usize % 3);
        let tri = &triangles[t];
        let (a, b) = ((tri.x[c], tri.y[c]), (tri.x[(c + 1) % 3], tri.y[(c + 1) % 3]));
        let (a, b, m) = if multiplicity > 0 { (a, b, multiplicity) } else { (b, a, -multiplicity) };
        // Row j's centre line is y = j·unit + half; p* lies below it by ε², so the edge
        // crosses p*'s line when ymin <= j·unit + half < ymax.
        let (ymin, ymax) = (a.1.min(b.1), a.1.max(b.1));
        let first = (ymin - half).div_euclid(unit) + i64::from((ymin - half).rem_euclid(unit) != 0);
        let first = first.max(rows.start as i64);
        let last = (ymax - half - 1).div_euclid(unit).min(rows.end as i64 - 1);
        if first > last {
            continue;
        }
        if crossings.len() + (last - first + 1) as usize > budget {
            return None;
        }
        // Edges going down the raster (y grows) wind positively around points on their left.
        let winding = if b.1 > a.1 { m } else { -m };
        let (dx, dy) = ((b.0 - a.0) as i128, (b.1 - a.1) as i128);
        for row in first..=last {
            let yc = (row * unit + half) as i128;
            // x = a.x + dx·(yc − a.y)/dy, as a fraction with a positive denominator.
            let (num, den) = (a.0 as i128 * dy + dx * (yc - a.1 as i128), dy);
            let (num, den) = if den < 0 { (-num, -den) } else { (num, den) };
            crossings.push(Crossing { row: row as u32, num, den, winding });
        }
    }
    Some(crossings)
}

/// The largest winding number over the points of every row: the crossings strictly to the
/// right of a point count (a crossing at the point's own x passes left of `p* = p + ε`).
fn max_winding(mut crossings: Vec<Crossing>) -> i32 {
    // Exact order by (row, x): both fractions have positive denominators below 2^30 and
    // numerators below 2^60, so the cross products fit in i128.
    crossings.par_sort_unstable_by(|a, b| a.row.cmp(&b.row).then_with(|| (a.num * b.den).cmp(&(b.num * a.den))));
    let mut max = 0;
    let mut end = crossings.len();
    while end > 0 {
        // One row, walked from the right; crossings at the same x are added together, so a
        // vertex where the chain turns back adds its net change only.
        let row = crossings[end - 1].row;
        let mut running = 0;
        while end > 0 && crossings[end - 1].row == row {
            let c = &crossings[end - 1];
            let mut sum = 0;
            while end > 0 && crossings[end - 1].row == row && crossings[end - 1].num * c.den == c.num * crossings[end - 1].den {
                sum += crossings[end - 1].winding;
                end -= 1;
            }
            running += sum;
            max = max.max(running);
        }
    }
    max
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::ops::Range;
    use tileraster_kernels::abi::TriangleInput;

    const S: u32 = 4; // 16 units a pixel; centres at 8 + 16·k

    /// [`super::overlap_free`] with vertex indices given by position (equal points, one vertex).
    fn overlap_free(triangles: &[TriangleInput], snap_bits: u32, rows: Range<u32>) -> bool {
        let mut ids = std::collections::HashMap::new();
        let corners: Vec<[u32; 3]> = triangles
            .iter()
            .map(|t| {
                [0, 1, 2].map(|k| {
                    let n = ids.len() as u32;
                    *ids.entry((t.x[k], t.y[k])).or_insert(n)
                })
            })
            .collect();
        super::overlap_free(triangles, &corners, snap_bits, rows)
    }

    /// A positively oriented triangle from lattice points (given in any order).
    fn tri(p: [(i64, i64); 3]) -> TriangleInput {
        let area = (p[1].0 - p[0].0) * (p[2].1 - p[0].1) - (p[1].1 - p[0].1) * (p[2].0 - p[0].0);
        assert_ne!(area, 0);
        let p = if area > 0 { p } else { [p[0], p[2], p[1]] };
        TriangleInput { x: p.map(|v| v.0), y: p.map(|v| v.1), ..Default::default() }
    }

    /// Two triangles per cell of an `n × n` lattice with `step` units between points.
    fn mesh(n: i64, step: i64, origin: (i64, i64)) -> Vec<TriangleInput> {
        let mut out = Vec::new();
        for r in 0..n {
            for c in 0..n {
                let p = |dc: i64, dr: i64| (origin.0 + (c + dc) * step, origin.1 + (r + dr) * step);
                out.push(tri([p(0, 0), p(1, 0), p(1, 1)]));
                out.push(tri([p(0, 0), p(1, 1), p(0, 1)]));
            }
        }
        out
    }

    #[test]
    fn a_mesh_is_overlap_free_even_with_vertices_and_edges_on_centres() {
        assert!(overlap_free(&mesh(6, 37, (3, 5)), S, 0..40));
        // Vertices exactly on pixel centres, edges along centre rows and columns.
        assert!(overlap_free(&mesh(5, 16, (8, 8)), S, 0..10));
        assert!(overlap_free(&[tri([(0, 0), (100, 0), (0, 100)])], S, 0..10));
    }

    #[test]
    fn overlaps_are_found() {
        let one = tri([(0, 0), (160, 0), (0, 160)]);
        let nudged = tri([(10, 10), (170, 10), (10, 170)]);
        assert!(!overlap_free(&[one, nudged], S, 0..20));
        // The same triangle twice, with either orientation given.
        assert!(!overlap_free(&[one, tri([(0, 0), (0, 160), (160, 0)])], S, 0..20));
        // A small island lying wholly inside a mesh: no edge crosses another.
        let mut scene = mesh(4, 64, (0, 0));
        scene.push(tri([(100, 100), (140, 100), (100, 140)]));
        assert!(!overlap_free(&scene, S, 0..20));
        // A mesh folded back over itself along a shared edge.
        let folded = [tri([(0, 0), (160, 0), (80, 160)]), tri([(0, 0), (160, 0), (80, 100)])];
        assert!(!overlap_free(&folded, S, 0..20));
    }

    #[test]
    fn separate_and_touching_pieces_are_overlap_free() {
        let mut scene = mesh(2, 48, (0, 0));
        scene.extend(mesh(2, 48, (96, 0))); // shares a vertical boundary, other vertices
        scene.extend(mesh(3, 20, (300, 300)));
        // Two triangles touching at a single vertex that is a pixel centre.
        scene.push(tri([(600, 600), (664, 568), (664, 632)]));
        scene.push(tri([(600, 600), (536, 568), (536, 632)]));
        assert!(overlap_free(&scene, S, 0..60));
    }

    /// The analysis against a brute-force count with the kernels' own coverage test: a proof
    /// must hold at every pixel centre, and meshes must be proven.
    #[test]
    fn agrees_with_counting_every_pixel_centre() {
        use crate::prepare::{Analysis, prepare_with};
        use crate::{Grid, Params, scenes};
        use tileraster_kernels::math::edge::Side;
        use tileraster_kernels::stages::fine::side;
        use tileraster_kernels::stages::setup::setup_triangle;
        let grid = Grid::new(0.0, 64.0, 0.0, 48.0, 64, 48);
        let cases = [
            (scenes::terrain(0.0, 0.0, 64.0, 48.0, 9, 7, 1), true),
            (scenes::terrain(-10.0, -10.0, 90.0, 70.0, 23, 17, 2), true), // cut by the grid
            (scenes::centre_lattice(&grid, 1, 3), true),
            (scenes::centre_lattice(&grid, 8, 4), true),
            (scenes::fan(&grid, 20, 20, 64, 15.0, 5), true),
            (scenes::sliver_wedge(&grid, 50, 0.01, 6), true),
            (scenes::triangle_soup(&grid, 40, 10.0, 7), false),
        ];
        for (k, (scene, mesh)) in cases.iter().enumerate() {
            let prepared = prepare_with(scene, &Params::new(grid), None, Analysis::Always).unwrap();
            let setups: Vec<_> = prepared.triangles.iter().map(|t| setup_triangle(t, 0, prepared.snap_bits)).collect();
            let most = (0..grid.height as i32)
                .flat_map(|j| (0..grid.width as i32).map(move |i| (i, j)))
                .map(|(i, j)| setups.iter().filter(|s| side(&s.coverage, i, j) == Side::Inside).count())
                .max()
                .unwrap();
            let proven = prepared.overlap_free_rows.is_some();
            if *mesh {
                // Without the index keys' help too: every edge distinct, all cancelling in the sweep.
                let distinct: Vec<[u32; 3]> = (0..prepared.triangles.len() as u32).map(|t| [3 * t, 3 * t + 1, 3 * t + 2]).collect();
                let rows = 0..grid.height;
                assert!(prove(&prepared.triangles, &distinct, prepared.snap_bits, rows, usize::MAX), "case {k}, distinct vertices");
            }
            assert_eq!(proven, most <= 1, "case {k}: proof {proven} but a centre is inside {most}");
            assert_eq!(proven, *mesh, "case {k}");
        }
    }

    #[test]
    fn overlap_outside_the_rows_asked_about_does_not_count() {
        let low = [tri([(0, 400), (160, 400), (0, 560)]), tri([(10, 410), (170, 410), (10, 570)])];
        assert!(overlap_free(&low, S, 0..20)); // rows 0..20 end at y = 320
        assert!(!overlap_free(&low, S, 0..40));
        assert!(!overlap_free(&low, S, 30..31));
        assert!(overlap_free(&low, S, 40..100));
    }
}
