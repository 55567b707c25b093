//! The point-file target's check, shared with `tests/fuzz_parsers.rs` and `las_check.rs`: any bytes, read as a
//! point file (delimited text) with columns chosen by the first byte, must give a typed error
//! naming the file, or finite points; those, triangulated, a typed error or a TIN whose
//! triangles index its vertices, with every input point kept or counted as a repeat.

#![allow(dead_code)]

use std::path::Path;
use tileraster_io::{Column, PointColumns, parse_points};

/// What the check saw, for the corpus test's tally.
pub enum Outcome {
    Refused,
    Points(usize),
    Triangulated(usize),
}

pub fn check(data: &[u8]) -> Result<Outcome, String> {
    let (choice, text) = data.split_first().map_or((0, &[][..]), |(c, rest)| (*c, rest));
    let text = String::from_utf8_lossy(text);
    let columns = match choice % 3 {
        0 => PointColumns::default(),
        1 => PointColumns { x: Some(Column::Position(2)), y: Some(Column::Position(1)), z: Some(Column::Position(3)) },
        _ => PointColumns { x: Some(Column::Name("x".into())), y: Some(Column::Name("Y".into())), z: Some(Column::Name("h".into())) },
    };
    let points = match parse_points(&text, Path::new("fuzz.csv"), &columns) {
        Err(e) => {
            let message = e.to_string();
            return if message.starts_with("fuzz.csv") { Ok(Outcome::Refused) } else { Err(format!("error without the file name: {message}")) };
        }
        Ok(points) => points,
    };
    triangulated(&points)
}

/// Points a reader accepted: all finite; triangulated, a typed error or a TIN whose triangles
/// index its vertices, with every input point kept or counted as a repeat.
pub fn triangulated(points: &[[f64; 3]]) -> Result<Outcome, String> {
    if let Some(p) = points.iter().find(|p| p.iter().any(|v| !v.is_finite())) {
        return Err(format!("accepted a non-finite point {p:?}"));
    }
    match tileraster_tin::triangulate(points) {
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
