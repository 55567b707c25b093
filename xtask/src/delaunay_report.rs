//! `cargo xtask delaunay-report [POINTS]`: the candidate Delaunay crates on the same point
//! sets, timed and checked, to choose the one `tileraster-tin` uses. Prints markdown.
//!
//! Each result is checked two ways: its triangle count against Euler's formula for a
//! triangulation of the points' convex hull (`2n − 2 − h`), and tileraster's own overlap
//! proof over a grid covering the points (no pixel centre inside two triangles).

use std::fmt::Write as _;
use std::time::Instant;
use tileraster::{Grid, Params, Scene, prepare};
use tileraster_testkit::scenes::Rng;

fn uniform(n: usize) -> Vec<[f64; 3]> {
    let mut rng = Rng::new(2026);
    (0..n).map(|_| [500_000.0 + rng.range(0.0, 10_000.0), 5_000_000.0 + rng.range(0.0, 10_000.0), rng.range(0.0, 1000.0)]).collect()
}

/// A square lattice: every cell's four corners are cocircular, many points collinear.
fn lattice(n: usize) -> Vec<[f64; 3]> {
    let side = (n as f64).sqrt() as usize;
    (0..side * side).map(|k| [500_000.0 + (k % side) as f64, 5_000_000.0 + (k / side) as f64, (k % 7) as f64]).collect()
}

/// A triangulation: its vertices (x, y, z) and triangles.
type Mesh = (Vec<[f64; 3]>, Vec<[u32; 3]>);

struct Outcome {
    seconds: f64,
    triangles: usize,
    expected: Option<usize>,
    overlap_free: Option<bool>,
}

/// Plain `bulk_load` reorders the vertices: its triangles index spade's own vertex order, which
/// it returns with them.
fn spade_raw(points: &[[f64; 3]]) -> Result<Mesh, String> {
    use spade::{DelaunayTriangulation, Point2, Triangulation};
    let sites: Vec<Point2<f64>> = points.iter().map(|p| Point2::new(p[0], p[1])).collect();
    let dt = DelaunayTriangulation::<Point2<f64>>::bulk_load(sites).map_err(|e| format!("{e:?}"))?;
    let vertices = dt.vertices().map(|v| [v.position().x, v.position().y, 0.0]).collect();
    Ok((vertices, dt.inner_faces().map(|f| f.vertices().map(|v| v.fix().index() as u32)).collect()))
}

fn delaunator(points: &[[f64; 3]]) -> Result<Mesh, String> {
    let sites: Vec<delaunator::Point> = points.iter().map(|p| delaunator::Point { x: p[0], y: p[1] }).collect();
    let t = delaunator::triangulate(&sites);
    Ok((points.to_vec(), t.triangles.chunks(3).map(|c| [c[0] as u32, c[1] as u32, c[2] as u32]).collect()))
}

/// Convex hull size (Andrew's monotone chain; collinear hull points left out), for Euler's count.
fn hull_size(points: &[[f64; 3]]) -> usize {
    let mut p: Vec<(f64, f64)> = points.iter().map(|q| (q[0], q[1])).collect();
    p.sort_by(|a, b| a.partial_cmp(b).expect("finite"));
    p.dedup();
    let cross = |o: (f64, f64), a: (f64, f64), b: (f64, f64)| (a.0 - o.0) * (b.1 - o.1) - (a.1 - o.1) * (b.0 - o.0);
    let mut hull: Vec<(f64, f64)> = Vec::new();
    for pass in 0..2 {
        let start = hull.len();
        let iter: Box<dyn Iterator<Item = &(f64, f64)>> = if pass == 0 { Box::new(p.iter()) } else { Box::new(p.iter().rev()) };
        for &q in iter {
            while hull.len() >= start + 2 && cross(hull[hull.len() - 2], hull[hull.len() - 1], q) <= 0.0 {
                hull.pop();
            }
            hull.push(q);
        }
        hull.pop();
    }
    hull.len()
}

fn check(points: &[[f64; 3]], vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>, seconds: f64, all_hull_points: bool) -> Outcome {
    let n = points.len();
    // With collinear points on the hull, Euler's count takes every hull point: skip it there.
    let expected = (!all_hull_points).then(|| 2 * n - 2 - hull_size(points));
    let count = triangles.len();
    let (xmin, xmax) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[0]), b.max(p[0])));
    let (ymin, ymax) = points.iter().fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[1]), b.max(p[1])));
    let grid = Grid::new(xmin, xmax, ymin, ymax, 4096, 4096);
    let scene = Scene::new(vertices, triangles);
    let overlap_free = prepare(&scene, &Params::new(grid), None).ok().map(|p| p.overlap_free_rows.is_some());
    Outcome { seconds, triangles: count, expected, overlap_free }
}

pub fn run(n: usize) -> Result<String, String> {
    let mut s = String::from(
        "| points | crate | time | triangles | Euler's count | overlap-free (tileraster's proof, 4096² grid) |\n| --- | --- | ---: | ---: | ---: | :---: |\n",
    );
    for (name, points, collinear_hull) in [
        (format!("{n} uniform, UTM coordinates"), uniform(n), false),
        (format!("{} lattice (cocircular cells), UTM coordinates", lattice(n).len()), lattice(n), true),
    ] {
        type Candidate<'a> = (&'a str, &'a dyn Fn(&[[f64; 3]]) -> Result<Mesh, String>);
        let candidates: [Candidate; 3] = [
            ("tileraster-tin (spade 2 with its vertex numbers, repeated points removed)", &|p| {
                tileraster_tin::triangulate(p).map(|t| (t.scene.vertices, t.scene.triangles)).map_err(|e| e.to_string())
            }),
            ("spade 2, bulk_load", &spade_raw),
            ("delaunator 1", &delaunator),
        ];
        for (crate_name, f) in candidates {
            eprintln!("delaunay: {name}, {crate_name} ...");
            let start = Instant::now();
            let result = f(&points);
            let seconds = start.elapsed().as_secs_f64();
            match result {
                Ok((vertices, triangles)) => {
                    let o = check(&points, vertices, triangles, seconds, collinear_hull);
                    let _ = writeln!(
                        s,
                        "| {name} | {crate_name} | {:.0} ms | {} | {} | {} |",
                        o.seconds * 1e3,
                        o.triangles,
                        o.expected.map_or("–".into(), |e| e.to_string()),
                        match o.overlap_free {
                            Some(true) => "yes",
                            Some(false) => "**no**",
                            None => "not preparable",
                        }
                    );
                }
                Err(e) => {
                    let _ = writeln!(s, "| {name} | {crate_name} | failed: {e} | | | |");
                }
            }
        }
    }
    Ok(s)
}
