//! STL meshes, ASCII and binary. STL stores each triangle with its own three corners; corners
//! at exactly the same position are welded into one vertex (first seen, first numbered), so
//! that neighbouring triangles share their edges as in any other mesh.

use crate::IoError;
use std::collections::HashMap;
use std::path::Path;
use tileraster_core::Scene;

/// Read an STL mesh (ASCII or binary; a file whose size matches its binary triangle count is
/// binary).
pub fn read_stl(path: &Path) -> Result<Scene, IoError> {
    let bytes = std::fs::read(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_stl(&bytes, path)
}

/// Parse STL bytes; `path` only names the source in errors.
pub fn parse_stl(bytes: &[u8], path: &Path) -> Result<Scene, IoError> {
    let binary_count = bytes.get(80..84).map(|b| u32::from_le_bytes(b.try_into().expect("4 bytes")) as u64);
    let corners = match binary_count {
        Some(n) if bytes.len() as u64 == 84 + 50 * n => binary_corners(bytes, n as usize, path)?,
        _ if bytes.trim_ascii_start().starts_with(b"solid") => ascii_corners(bytes, path)?,
        Some(n) => {
            return Err(IoError::Format {
                path: path.to_owned(),
                message: format!(
                    "not an ASCII STL (no leading 'solid'), and {} bytes do not match the binary header's {n} triangles ({} bytes expected)",
                    bytes.len(),
                    84 + 50 * n
                ),
            });
        }
        None => return Err(IoError::Format { path: path.to_owned(), message: format!("{} bytes: too short for an STL file", bytes.len()) }),
    };
    if corners.is_empty() {
        return Err(IoError::Format { path: path.to_owned(), message: "the STL file holds no triangles".into() });
    }
    Ok(weld(&corners))
}

/// Three corners a triangle, welded by exact position.
fn weld(corners: &[[f64; 3]]) -> Scene {
    let mut index: HashMap<[u64; 3], u32> = HashMap::new();
    let mut scene = Scene::default();
    let mut ids = Vec::with_capacity(corners.len());
    for c in corners {
        // `+ 0.0`: -0.0 and 0.0 are one position.
        let key = c.map(|v| (v + 0.0).to_bits());
        let id = *index.entry(key).or_insert_with(|| {
            scene.vertices.push(*c);
            scene.vertices.len() as u32 - 1
        });
        ids.push(id);
    }
    scene.triangles = ids.chunks(3).map(|t| [t[0], t[1], t[2]]).collect();
    scene
}

fn binary_corners(bytes: &[u8], n: usize, path: &Path) -> Result<Vec<[f64; 3]>, IoError> {
    let mut corners = Vec::with_capacity(3 * n);
    for t in 0..n {
        let record = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        for k in 0..3 {
            // After the 12-byte normal, three corners of three little-endian f32.
            let at = |a: usize| f32::from_le_bytes(record[12 + 12 * k + 4 * a..][..4].try_into().expect("4 bytes")) as f64;
            let c = [at(0), at(1), at(2)];
            if c.iter().any(|v| !v.is_finite()) {
                return Err(IoError::Format {
                    path: path.to_owned(),
                    message: format!("triangle {t} (record {}): corner {k} is {c:?}; coordinates must be finite", t + 1),
                });
            }
            corners.push(c);
        }
    }
    Ok(corners)
}

fn ascii_corners(bytes: &[u8], path: &Path) -> Result<Vec<[f64; 3]>, IoError> {
    let text = std::str::from_utf8(bytes).map_err(|e| IoError::Format { path: path.to_owned(), message: format!("an ASCII STL must be text: {e}") })?;
    let fail = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    let mut corners = Vec::new();
    let mut in_loop = 0;
    let mut loop_line = 0;
    for (n, line) in text.lines().enumerate() {
        let line_no = n + 1;
        let mut words = line.split_whitespace();
        match words.next() {
            Some("outer") => {
                in_loop = 0;
                loop_line = line_no;
            }
            Some("vertex") => {
                let mut c = [0.0f64; 3];
                for (axis, v) in c.iter_mut().enumerate() {
                    let word = words.next().ok_or_else(|| fail(line_no, format!("vertex has no {} coordinate", ["x", "y", "z"][axis])))?;
                    *v = word.parse().map_err(|_| fail(line_no, format!("vertex coordinate '{word}' is not a number")))?;
                    if !v.is_finite() {
                        return Err(fail(line_no, format!("vertex coordinate '{word}' is not finite")));
                    }
                }
                corners.push(c);
                in_loop += 1;
            }
            Some("endloop") if in_loop != 3 => {
                return Err(fail(loop_line, format!("facet loop has {in_loop} vertices; STL facets are triangles")));
            }
            _ => {}
        }
    }
    if corners.len() % 3 != 0 {
        return Err(fail(loop_line, format!("the file ends inside this facet, after {in_loop} of its vertices")));
    }
    Ok(corners)
}

#[cfg(test)]
mod tests {
    use super::*;

    const SQUARE: &str = "solid square\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 1\n   vertex 1 0 2\n   vertex 1 1 3\n  endloop\n endfacet\n facet normal 0 0 1\n  outer loop\n   vertex 0 0 1\n   vertex 1 1 3\n   vertex -0 1 4\n  endloop\n endfacet\nendsolid square\n";

    fn binary(triangles: &[[[f32; 3]; 3]]) -> Vec<u8> {
        let mut b = vec![0u8; 80];
        b.extend((triangles.len() as u32).to_le_bytes());
        for t in triangles {
            b.extend([0u8; 12]);
            for c in t {
                for v in c {
                    b.extend(v.to_le_bytes());
                }
            }
            b.extend([0u8; 2]);
        }
        b
    }

    #[test]
    fn ascii_and_binary_give_the_same_welded_mesh() {
        let ascii = parse_stl(SQUARE.as_bytes(), Path::new("s.stl")).unwrap();
        assert_eq!(ascii.vertices.len(), 4);
        assert_eq!(ascii.triangles, vec![[0, 1, 2], [0, 2, 3]]);
        let bin = binary(&[[[0.0, 0.0, 1.0], [1.0, 0.0, 2.0], [1.0, 1.0, 3.0]], [[0.0, 0.0, 1.0], [1.0, 1.0, 3.0], [0.0, 1.0, 4.0]]]);
        let binary = parse_stl(&bin, Path::new("b.stl")).unwrap();
        assert_eq!((binary.vertices, binary.triangles), (ascii.vertices, ascii.triangles));
    }

    #[test]
    fn bad_stl_is_refused_with_where_and_why() {
        let err = |bytes: &[u8]| parse_stl(bytes, Path::new("m.stl")).unwrap_err().to_string();
        assert!(err(b"solid x\nfacet\nouter loop\nvertex 0 0 0\nvertex 1 0 0\nendloop\n").starts_with("m.stl:3: facet loop has 2 vertices"));
        assert!(err(b"solid x\nouter loop\nvertex 0 zero 0\n").starts_with("m.stl:3: vertex coordinate 'zero' is not a number"));
        assert!(err(b"solid x\nendsolid x\n").contains("holds no triangles"));
        assert!(err(b"solid x\nouter loop\nvertex 0 0 0\nvertex 1 0 0\n").starts_with("m.stl:2: the file ends inside this facet, after 2 of its vertices"));
        assert!(err(b"short").contains("too short"));
        let mut truncated = binary(&[[[0.0; 3], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]]);
        truncated.pop();
        assert!(err(&truncated).contains("do not match the binary header's 1 triangles"));
        assert!(err(&binary(&[[[0.0; 3], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]]])).contains("triangle 0 (record 1): corner 1"));
    }
}
