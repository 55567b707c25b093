//! The mesh-file target's check, shared with `tests/fuzz_parsers.rs`: any bytes, read as OBJ,
//! PLY or STL (the first byte chooses), must give a typed error naming the file, or a mesh of
//! finite vertices whose triangles index them.

#![allow(dead_code)]

use std::path::Path;

pub enum Outcome {
    Refused,
    Mesh(usize),
}

pub fn check(data: &[u8]) -> Result<Outcome, String> {
    let (choice, body) = data.split_first().map_or((0, &[][..]), |(c, rest)| (*c, rest));
    let (name, result) = match choice % 3 {
        0 => ("fuzz.obj", tileraster_io::parse_obj(&String::from_utf8_lossy(body), Path::new("fuzz.obj"))),
        1 => ("fuzz.ply", tileraster_io::parse_ply(body, Path::new("fuzz.ply"))),
        _ => ("fuzz.stl", tileraster_io::parse_stl(body, Path::new("fuzz.stl"))),
    };
    match result {
        Err(e) => {
            let message = e.to_string();
            if message.starts_with(name) { Ok(Outcome::Refused) } else { Err(format!("error without the file name: {message}")) }
        }
        Ok(scene) => {
            let n = scene.vertices.len();
            if let Some(v) = scene.vertices.iter().find(|v| v.iter().any(|c| !c.is_finite())) {
                return Err(format!("{name}: accepted a non-finite vertex {v:?}"));
            }
            if let Some(t) = scene.triangles.iter().find(|t| t.iter().any(|&k| k as usize >= n)) {
                return Err(format!("{name}: triangle {t:?} indexes beyond {n} vertices"));
            }
            if n == 0 || scene.triangles.is_empty() {
                return Err(format!("{name}: accepted an empty mesh"));
            }
            Ok(Outcome::Mesh(scene.triangles.len()))
        }
    }
}
