//! The LAS/LAZ target's check, shared with `tests/fuzz_parsers.rs`: any bytes, read as a LAS or
//! LAZ file, must give a typed error naming the file, or finite points; those, triangulated, a
//! typed error or a TIN whose triangles index its vertices, with every input point kept or
//! counted as a repeat (the checks of `points_check.rs`).

#![allow(dead_code)]

use std::path::Path;

/// What the check saw, for the corpus test's tally.
pub enum Outcome {
    Refused,
    Points(usize),
    Triangulated(usize),
}

pub fn check(data: &[u8]) -> Result<Outcome, String> {
    let points = match tileraster_io::parse_las(data, Path::new("fuzz.las")) {
        Err(e) => {
            let message = e.to_string();
            return if message.starts_with("fuzz.las: ") { Ok(Outcome::Refused) } else { Err(format!("error without the file name: {message}")) };
        }
        Ok(points) => points,
    };
    if points.is_empty() {
        return Err("accepted a file without points".into());
    }
    if let Some(p) = points.iter().find(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(format!("accepted a non-finite point {p:?}"));
    }
    match tileraster_tin::triangulate(&points) {
        Err(e) if e.to_string().is_empty() => Err(format!("{e:?} has no message")),
        Err(_) => Ok(Outcome::Points(points.len())),
        Ok(tin) => {
            let n = tin.scene.vertices.len();
            if n + tin.duplicates != points.len() || tin.source.len() != n {
                return Err(format!("{} points became {n} vertices and {} repeats", points.len(), tin.duplicates));
            }
            if let Some(t) = tin.scene.triangles.iter().find(|t| t.iter().any(|&k| k as usize >= n)) {
                return Err(format!("triangle {t:?} indexes beyond {n} vertices"));
            }
            if tin.scene.vertices.iter().zip(&tin.source).any(|(v, &s)| *v != points[s]) {
                return Err("a vertex is not the input point it came from".into());
            }
            Ok(Outcome::Triangulated(tin.scene.triangles.len()))
        }
    }
}
