//! Point sets to TINs: the Delaunay triangulation of the points' x, y, with z as the height.
//!
//! The triangulation is spade's, whose geometric predicates are exact, so that collinear and
//! cocircular points (lattices, survey lines) give a valid triangulation rather than
//! crossing or missing triangles. (`cargo xtask delaunay-report` measures it against
//! delaunator on a million points.)
//!
//! Points with equal x and y (and -0.0 equals 0.0) are handled deterministically: the first
//! of them in input order is kept with its z, the others are dropped and counted. The
//! triangulation has no randomness, so the same input gives the same TIN; and where four or
//! more points are cocircular it is the one a symbolic perturbation defines (`canonical`),
//! so that its triangles are the same whatever other points are triangulated with them and in
//! whatever order.
//!
//! The faces' order and each face's first corner are the points' own too: a face starts at its
//! corner that comes first in input order, and faces are sorted by their corners' input order.
//! A subset of the points (a block's, [`block`]) keeps their order, so the faces it shares with
//! the whole set come in the same order and start at the same corner: the rasteriser, whose
//! ties go to the lower face and whose plane fit starts at the first corner, then gives those
//! faces' cells the same bits.

pub mod block;
mod canonical;
pub mod nearest;

pub use block::{BlockSource, BlockTin, Disc, Hull, Rect, Region, first_buffer, triangulate_block, triangulate_block_from};
pub use nearest::NearestPoints;
use rayon::prelude::*;
use spade::handles::FixedUndirectedEdgeHandle;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};
use tileraster_core::Scene;

/// Why a point set could not be triangulated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TinError {
    #[error("point {index} has a non-finite coordinate ({x}, {y}, {z}); remove it or fix the input")]
    NonFinite { index: usize, x: f64, y: f64, z: f64 },
    #[error("point {index} ({x}, {y}) is too far out for the triangulation (|x|, |y| must stay below {limit:e}); shift the coordinates")]
    OutOfRange { index: usize, x: f64, y: f64, limit: f64 },
    #[error("point {index} ({x}, {y}) lies outside the hull given for the points; make the hull from every point (or every file's hull)")]
    OutsideHull { index: usize, x: f64, y: f64 },
    #[error("{distinct} distinct point positions: a TIN needs at least 3 that are not all on one line")]
    TooFew { distinct: usize },
    #[error("all {distinct} distinct points lie on one line: they span no triangle")]
    Collinear { distinct: usize },
    /// Not expected after the checks above; reported rather than hidden.
    #[error("the triangulation refused the points: {0}")]
    Triangulation(String),
}

/// A TIN built from points: the scene (vertices are the kept points, in input order) and what
/// was dropped.
#[derive(Debug, Clone)]
pub struct Tin {
    pub scene: Scene,
    /// For each scene vertex, the index of its point in the input.
    pub source: Vec<usize>,
    /// Points dropped because an earlier point has the same x and y.
    pub duplicates: usize,
}

/// Largest coordinate magnitude spade accepts, with margin: its exact predicates need the
/// squared coordinates to stay finite.
const COORDINATE_LIMIT: f64 = 1e150;

struct Site {
    position: Point2<f64>,
    vertex: u32,
}

impl HasPosition for Site {
    type Scalar = f64;

    fn position(&self) -> Point2<f64> {
        self.position
    }
}

/// Triangulate `points` (x, y, z). Errors name the offending point by its input index.
pub fn triangulate(points: &[[f64; 3]]) -> Result<Tin, TinError> {
    Ok(triangulate_with_hull(points)?.0)
}

/// [`triangulate`], and the convex hull's edges as pairs of scene vertices with the TIN on
/// their left.
pub(crate) fn triangulate_with_hull(points: &[[f64; 3]]) -> Result<(Tin, Vec<[u32; 2]>), TinError> {
    for (index, &[x, y, z]) in points.iter().enumerate() {
        if !(x.is_finite() && y.is_finite() && z.is_finite()) {
            return Err(TinError::NonFinite { index, x, y, z });
        }
        if x.abs() > COORDINATE_LIMIT || y.abs() > COORDINATE_LIMIT {
            return Err(TinError::OutOfRange { index, x, y, limit: COORDINATE_LIMIT });
        }
    }
    let keep = first_of_each_position(points);
    let duplicates = points.len() - keep.len();
    if keep.len() < 3 {
        return Err(TinError::TooFew { distinct: keep.len() });
    }
    let sites: Vec<Site> =
        keep.iter().enumerate().map(|(vertex, &i)| Site { position: Point2::new(points[i][0] + 0.0, points[i][1] + 0.0), vertex: vertex as u32 }).collect();
    // Bulk loading reorders the sites but carries each one's vertex number with it; it has no
    // randomness, so the same points give the same triangles.
    let dt = DelaunayTriangulation::<Site>::bulk_load(sites).map_err(|e| TinError::Triangulation(format!("{e:?}")))?;
    let mut triangles: Vec<[u32; 3]> = dt.inner_faces().map(|f| f.vertices().map(|v| v.data().vertex)).collect();
    if triangles.is_empty() {
        return Err(TinError::Collinear { distinct: keep.len() });
    }
    // The hull's edges, each turned so that its inner face lies on its left. (The flips below
    // move inner edges only.)
    let hull = dt
        .convex_hull()
        .map(|e| {
            let inner = if e.face().is_outer() { e.rev() } else { e };
            [inner.from().data().vertex, inner.to().data().vertex]
        })
        .collect();
    // Cocircular points: the one triangulation of them, not spade's choice (`canonical`).
    if has_cocircular_edge(&dt) {
        let sites: Vec<[f64; 2]> = keep.iter().map(|&i| [points[i][0] + 0.0, points[i][1] + 0.0]).collect();
        let mut slot = vec![canonical::NO_FACE; dt.num_all_faces()];
        dt.inner_faces().enumerate().for_each(|(t, f)| slot[f.fix().index()] = t as u32);
        let across = |f: spade::handles::FaceHandle<'_, spade::handles::InnerTag, Site, (), (), ()>| {
            f.adjacent_edges().map(|e| e.rev().face().as_inner().map_or(canonical::NO_FACE, |g| slot[g.fix().index()]))
        };
        let mut neighbours: Vec<[u32; 3]> = dt.inner_faces().map(across).collect();
        canonical::canonical(&sites, &mut triangles, &mut neighbours);
    }
    in_input_order(&mut triangles, keep.len());
    let vertices = keep.iter().map(|&i| points[i]).collect();
    Ok((Tin { scene: Scene::new(vertices, triangles), source: keep, duplicates }, hull))
}

/// Each face from its first corner in input order (turned, so still counter-clockwise), the
/// faces sorted by their corners: an order that any order-keeping subset of the points gives
/// its faces too. (Counted into place by first corner, of which `vertices` there are, then
/// each corner's few faces sorted.)
fn in_input_order(triangles: &mut [[u32; 3]], vertices: usize) {
    triangles.par_iter_mut().for_each(|t| {
        let first = (0..3).min_by_key(|&k| t[k]).expect("three corners");
        t.rotate_left(first);
    });
    let mut start = vec![0usize; vertices + 1];
    triangles.iter().for_each(|t| start[t[0] as usize + 1] += 1);
    (0..vertices).for_each(|v| start[v + 1] += start[v]);
    let mut sorted = vec![[0u32; 3]; triangles.len()];
    let mut next = start.clone();
    for &t in triangles.iter() {
        sorted[next[t[0] as usize]] = t;
        next[t[0] as usize] += 1;
    }
    (0..vertices).for_each(|v| sorted[start[v]..start[v + 1]].sort_unstable());
    triangles.copy_from_slice(&sorted);
}

/// Whether an inner edge of `dt` has the four points of its two faces on one circle, exactly
/// (the edges looked at on all cores).
fn has_cocircular_edge(dt: &DelaunayTriangulation<Site>) -> bool {
    let at = |p: Point2<f64>| robust::Coord { x: p.x, y: p.y };
    let edges: Vec<FixedUndirectedEdgeHandle> = dt.fixed_undirected_edges().collect();
    edges.into_par_iter().any(|edge| {
        let e = dt.undirected_edge(edge).as_directed();
        match (e.opposite_vertex(), e.rev().opposite_vertex()) {
            (Some(c), Some(d)) => robust::incircle(at(e.from().position()), at(e.to().position()), at(c.position()), at(d.position())) == 0.0,
            _ => false,
        }
    })
}

/// Input indices of the first point at each distinct (x, y), in input order.
fn first_of_each_position(points: &[[f64; 3]]) -> Vec<usize> {
    // `+ 0.0` turns -0.0 into 0.0, so that the two compare equal bit for bit.
    let mut keys: Vec<(u64, u64, usize)> = points.par_iter().enumerate().map(|(i, p)| ((p[0] + 0.0).to_bits(), (p[1] + 0.0).to_bits(), i)).collect();
    keys.par_sort_unstable();
    let mut keep: Vec<usize> = keys.chunk_by(|a, b| (a.0, a.1) == (b.0, b.1)).map(|run| run[0].2).collect();
    keep.par_sort_unstable();
    keep
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_square_gives_two_triangles_and_duplicates_keep_the_first() {
        let points = [[0.0, 0.0, 1.0], [1.0, 0.0, 2.0], [1.0, 1.0, 3.0], [0.0, 1.0, 4.0], [1.0, 1.0, 99.0], [-0.0, 0.0, 98.0]];
        let tin = triangulate(&points).unwrap();
        assert_eq!(tin.scene.triangles.len(), 2);
        assert_eq!(tin.duplicates, 2);
        assert_eq!(tin.source, vec![0, 1, 2, 3]);
        assert_eq!(tin.scene.vertices[2], [1.0, 1.0, 3.0]);
    }

    #[test]
    fn a_cocircular_lattice_is_triangulated_whole() {
        let n = 60;
        let points: Vec<[f64; 3]> = (0..n * n).map(|k| [(k % n) as f64, (k / n) as f64, k as f64]).collect();
        let tin = triangulate(&points).unwrap();
        assert_eq!(tin.scene.triangles.len(), 2 * (n - 1) * (n - 1));
        // Repeatable: the same input, the same triangles.
        assert_eq!(triangulate(&points).unwrap().scene.triangles, tin.scene.triangles);
    }

    /// The triangles of `points`' TIN with every corner inside `[lo, hi]²`, by their corners'
    /// positions: comparable between TINs of other point sets and orders.
    fn triangles_within(points: &[[f64; 3]], lo: f64, hi: f64) -> Vec<[[u64; 2]; 3]> {
        let tin = triangulate(points).unwrap();
        let mut found: Vec<[[u64; 2]; 3]> = tin
            .scene
            .triangles
            .iter()
            .map(|t| t.map(|v| tin.scene.vertices[v as usize]))
            .filter(|corners| corners.iter().all(|p| (lo..=hi).contains(&p[0]) && (lo..=hi).contains(&p[1])))
            .map(|corners| {
                let mut key = corners.map(|p| [p[0].to_bits(), p[1].to_bits()]);
                key.sort();
                key
            })
            .collect();
        found.sort();
        found
    }

    /// A lattice's squares (four cocircular points each) take the same diagonals whether the
    /// lattice is triangulated alone or as a window of larger lattices around it, and whatever
    /// the points' order; so do rings of twelve cocircular points, each alone and in company.
    /// (spade's own choice differed in all ten larger lattices.)
    #[test]
    fn cocircular_points_are_triangulated_alike_in_any_company_and_order() {
        let lattice = |n: usize, x0: f64, y0: f64| -> Vec<[f64; 3]> { (0..n * n).map(|k| [(k % n) as f64 - x0, (k / n) as f64 - y0, k as f64]).collect() };
        let alone = triangles_within(&lattice(12, 0.0, 0.0), 1.0, 10.0);
        assert_eq!(alone.len(), 2 * 9 * 9);
        for k in 0..10 {
            let larger = lattice(20 + k, k as f64, 3.0);
            assert_eq!(triangles_within(&larger, 1.0, 10.0), alone, "a lattice of {} around it", 20 + k);
        }
        let mut shuffled = lattice(12, 0.0, 0.0);
        let mut x = 0x2545_f491_4f6c_dd1du64;
        for i in (1..shuffled.len()).rev() {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            shuffled.swap(i, (x % (i as u64 + 1)) as usize);
        }
        assert_eq!(triangles_within(&shuffled, 1.0, 10.0), alone, "the same points in another order");

        let ring = |cx: f64, cy: f64| -> Vec<[f64; 3]> { tileraster_testkit::scenes::TWELVE_ON_A_CIRCLE.iter().map(|&(x, y)| [cx + x, cy + y, 0.0]).collect() };
        let alone = triangles_within(&ring(0.0, 0.0), -5.0, 5.0);
        assert_eq!(alone.len(), 10, "a convex 12-gon has 10 triangles");
        for k in 0..6 {
            let mut company = ring(0.0, 0.0);
            company.extend(ring(20.0 + 3.0 * k as f64, -7.0 + k as f64));
            company.extend([[-40.0 - k as f64, 30.0, 0.0], [9.0, 70.0 + 2.5 * k as f64, 0.0]]);
            assert_eq!(triangles_within(&company, -5.0, 5.0), alone, "company {k}");
        }
    }

    /// The TIN of cocircular points is still Delaunay: no point lies inside any triangle's
    /// circumcircle (exact predicate, over every triangle and every point of a small lattice
    /// with rings in it), and it covers the lattice's square whole.
    #[test]
    fn the_chosen_triangulation_is_delaunay() {
        let n = 9;
        let mut points: Vec<[f64; 3]> = (0..n * n).map(|k| [(k % n) as f64 * 2.0, (k / n) as f64 * 2.0, 0.0]).collect();
        points.extend([[8.0, 8.5, 0.0], [3.0, 13.0, 0.0]]);
        let tin = triangulate(&points).unwrap();
        let at = |p: [f64; 3]| robust::Coord { x: p[0], y: p[1] };
        let mut area = 0.0;
        for t in &tin.scene.triangles {
            let [a, b, c] = t.map(|v| tin.scene.vertices[v as usize]);
            assert!(robust::orient2d(at(a), at(b), at(c)) > 0.0, "counter-clockwise");
            area += robust::orient2d(at(a), at(b), at(c)) / 2.0;
            for &d in &tin.scene.vertices {
                assert!(robust::incircle(at(a), at(b), at(c), at(d)) <= 0.0, "{d:?} inside the circle of {a:?} {b:?} {c:?}");
            }
        }
        assert_eq!(area, 16.0 * 16.0);
    }

    #[test]
    fn bad_point_sets_are_refused_with_the_reason() {
        assert_eq!(triangulate(&[[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]).unwrap_err(), TinError::TooFew { distinct: 2 });
        assert_eq!(triangulate(&[[0.0, 0.0, 0.0], [0.0, 0.0, 5.0], [1.0, 1.0, 0.0]]).unwrap_err(), TinError::TooFew { distinct: 2 });
        let line: Vec<[f64; 3]> = (0..10).map(|k| [k as f64, 2.0 * k as f64, 0.0]).collect();
        assert_eq!(triangulate(&line).unwrap_err(), TinError::Collinear { distinct: 10 });
        let err = triangulate(&[[0.0, 0.0, 0.0], [f64::NAN, 1.0, 0.0], [1.0, 0.0, 0.0]]).unwrap_err();
        assert!(matches!(err, TinError::NonFinite { index: 1, .. }), "{err}");
        let err = triangulate(&[[0.0, 0.0, 0.0], [1e200, 1.0, 0.0], [1.0, 0.0, 0.0]]).unwrap_err();
        assert!(matches!(err, TinError::OutOfRange { index: 1, .. }), "{err}");
    }
}
