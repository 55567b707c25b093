//! The LAS/LAZ target's check, shared with `tests/fuzz_parsers.rs`: any bytes, read as a LAS or
//! LAZ file, must give a typed error naming the file, or finite points; those, triangulated, a
//! typed error or a TIN whose triangles index its vertices, with every input point kept or
//! counted as a repeat (the checks of `points_check.rs`).

#![allow(dead_code)]

#[path = "points_check.rs"]
pub mod points_check;

pub use points_check::Outcome;
use std::path::Path;

pub fn check(data: &[u8]) -> Result<Outcome, String> {
    match tileraster_io::parse_las(data, Path::new("fuzz.las")) {
        Err(e) => {
            let message = e.to_string();
            if message.starts_with("fuzz.las: ") { Ok(Outcome::Refused) } else { Err(format!("error without the file name: {message}")) }
        }
        Ok(points) if points.is_empty() => Err("accepted a file without points".into()),
        Ok(points) => points_check::triangulated(&points),
    }
}
