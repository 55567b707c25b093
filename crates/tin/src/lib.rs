//! Point sets to TINs: the Delaunay triangulation of the points' x, y, with z as the height.
//!
//! The triangulation is spade's, whose geometric predicates are exact, so that collinear and
//! cocircular points (lattices, survey lines) give a valid triangulation rather than
//! crossing or missing triangles. (`cargo xtask delaunay-report` measures it against
//! delaunator on a million points.)
//!
//! Points with equal x and y (and -0.0 equals 0.0) are handled deterministically: the first
//! of them in input order is kept with its z, the others are dropped and counted. The
//! triangulation has no randomness, so the same input gives the same TIN.

pub mod nearest;

pub use nearest::NearestPoints;
use spade::{DelaunayTriangulation, HasPosition, Point2, Triangulation};
use tileraster_core::Scene;

/// Why a point set could not be triangulated.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TinError {
    #[error("point {index} has a non-finite coordinate ({x}, {y}, {z}); remove it or fix the input")]
    NonFinite { index: usize, x: f64, y: f64, z: f64 },
    #[error("point {index} ({x}, {y}) is too far out for the triangulation (|x|, |y| must stay below {limit:e}); shift the coordinates")]
    OutOfRange { index: usize, x: f64, y: f64, limit: f64 },
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
    let triangles: Vec<[u32; 3]> = dt.inner_faces().map(|f| f.vertices().map(|v| v.data().vertex)).collect();
    if triangles.is_empty() {
        return Err(TinError::Collinear { distinct: keep.len() });
    }
    let vertices = keep.iter().map(|&i| points[i]).collect();
    Ok(Tin { scene: Scene::new(vertices, triangles), source: keep, duplicates })
}

/// Input indices of the first point at each distinct (x, y), in input order.
fn first_of_each_position(points: &[[f64; 3]]) -> Vec<usize> {
    // `+ 0.0` turns -0.0 into 0.0, so that the two compare equal bit for bit.
    let key = |i: usize| ((points[i][0] + 0.0).to_bits(), (points[i][1] + 0.0).to_bits());
    let mut order: Vec<usize> = (0..points.len()).collect();
    order.sort_by_key(|&i| (key(i), i));
    let mut keep: Vec<usize> = order.chunk_by(|&a, &b| key(a) == key(b)).map(|run| run[0]).collect();
    keep.sort_unstable();
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
