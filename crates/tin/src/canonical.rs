//! The one Delaunay triangulation of a point set, whatever the order and the company of its
//! points.
//!
//! Where four or more points lie on one empty circle (a lattice's squares, a survey's rings),
//! a Delaunay triangulation may take any diagonals inside it. spade's takes them by the order
//! it inserts the points in, which depends on all of them (their distance from the points'
//! mean): a window of a lattice triangulated alone can take other diagonals than the whole
//! lattice does there. This pass makes the choice the points' own. Each point's lift onto the
//! paraboloid `z = x² + y²` is raised by an infinitesimal that shrinks with the point's rank
//! in `(x, y)` order (a symbolic perturbation): no four perturbed points are cocircular, and
//! their Delaunay triangulation is unique. Lawson's flips reach it from spade's, over the edges
//! whose quadrilateral is exactly cocircular; no other edge moves.
//!
//! Under the perturbation, where `a, b, c` (counter-clockwise) and `d` are exactly cocircular,
//! the sign of the in-circle determinant is its cofactor's for the lift of the point of the
//! four that comes first in `(x, y)` order: `orient(b, c, d)` for `a`, `−orient(a, c, d)` for
//! `b`, `orient(a, b, d)` for `c`, `−orient(a, b, c)` (never inside) for `d`. Three distinct
//! points of a circle are never collinear, so that sign is never zero.

use robust::{Coord, incircle, orient2d};

/// No face across an edge (the hull).
pub(crate) const NO_FACE: u32 = u32::MAX;

/// Flip `triangles` (counter-clockwise, indices into `sites`, distinct positions), whose
/// `neighbours[t][k]` is the face across edge `k` (from corner `k` to the next) of face `t`,
/// from a Delaunay triangulation to the one Delaunay triangulation under the perturbation;
/// returns the flips made. Each flip keeps the two faces' slots, so the faces' order is
/// spade's wherever no quadrilateral is cocircular.
pub(crate) fn canonical(sites: &[[f64; 2]], triangles: &mut [[u32; 3]], neighbours: &mut [[u32; 3]]) -> usize {
    let at = |v: u32| Coord { x: sites[v as usize][0], y: sites[v as usize][1] };
    // Each inner edge once, in the faces' order, as (face, its corner where the edge starts,
    // the edge's end): the result does not depend on the order; the slots the flipped faces
    // take do. An entry whose face no longer holds its edge is stale (a flip took the edge
    // away, or gave it to the other face, and pushed it again with that face).
    let mut stack: Vec<(u32, u32, u32)> = Vec::new();
    for (t, (tri, across)) in triangles.iter().zip(neighbours.iter()).enumerate() {
        for k in 0..3 {
            if across[k] != NO_FACE && (t as u32) < across[k] {
                stack.push((t as u32, tri[k], tri[(k + 1) % 3]));
            }
        }
    }
    stack.reverse();
    let slot_of = |tri: &[u32; 3], a: u32, b: u32| (0..3).find(|&k| tri[k] == a && tri[(k + 1) % 3] == b);
    let mut flips = 0;
    while let Some((t1, a, b)) = stack.pop() {
        let Some(k1) = slot_of(&triangles[t1 as usize], a, b) else { continue };
        let t2 = neighbours[t1 as usize][k1];
        if t2 == NO_FACE {
            continue;
        }
        let k2 = slot_of(&triangles[t2 as usize], b, a).expect("neighbours share their edge");
        let (c, d) = (triangles[t1 as usize][(k1 + 2) % 3], triangles[t2 as usize][(k2 + 2) % 3]);
        let inside = match incircle(at(a), at(b), at(c), at(d)) {
            s if s > 0.0 => true,
            s if s < 0.0 => false,
            _ => perturbed_inside(sites, [a, b, c, d]),
        };
        if !inside {
            continue;
        }
        // The faces across the quadrilateral's sides: b–c and c–a of t1, a–d and d–b of t2.
        let (bc, ca) = (neighbours[t1 as usize][(k1 + 1) % 3], neighbours[t1 as usize][(k1 + 2) % 3]);
        let (ad, db) = (neighbours[t2 as usize][(k2 + 1) % 3], neighbours[t2 as usize][(k2 + 2) % 3]);
        // The quadrilateral is a, d, b, c counter-clockwise: its other diagonal is d–c.
        triangles[t1 as usize] = [a, d, c];
        neighbours[t1 as usize] = [ad, t2, ca];
        triangles[t2 as usize] = [d, b, c];
        neighbours[t2 as usize] = [db, bc, t1];
        // a–d moved from t2 to t1, b–c from t1 to t2: their other faces point anew.
        for (face, from, to) in [(ad, t2, t1), (bc, t1, t2)] {
            if face != NO_FACE {
                let back = neighbours[face as usize].iter_mut().find(|n| **n == from).expect("a neighbour points back");
                *back = to;
            }
        }
        stack.extend([(t1, a, d), (t2, d, b), (t2, b, c), (t1, c, a)]);
        flips += 1;
    }
    flips
}

/// Whether `d` lies inside the circle through `a, b, c` (counter-clockwise), all four exactly
/// cocircular, under the perturbation (the module's rule).
fn perturbed_inside(sites: &[[f64; 2]], [a, b, c, d]: [u32; 4]) -> bool {
    let at = |v: u32| Coord { x: sites[v as usize][0], y: sites[v as usize][1] };
    let rank = |v: u32| (sites[v as usize][0], sites[v as usize][1]);
    let first = [a, b, c, d].into_iter().min_by(|&p, &q| rank(p).partial_cmp(&rank(q)).expect("finite coordinates")).expect("four points");
    match first {
        p if p == a => orient2d(at(b), at(c), at(d)) > 0.0,
        p if p == b => orient2d(at(a), at(c), at(d)) < 0.0,
        p if p == c => orient2d(at(a), at(b), at(d)) > 0.0,
        _ => false,
    }
}
