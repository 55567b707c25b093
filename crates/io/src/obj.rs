use crate::{write_atomically, IoError};
use std::io::Write as _;
use std::path::Path;
use tileraster_core::Scene;

/// Read a Wavefront OBJ mesh: `v x y z` vertices (world x, y and height z) and `f` faces
/// (1-based or negative indices, `v/vt/vn` forms accepted; polygons are fanned into
/// triangles). Other statements are ignored.
pub fn read_obj(path: &Path) -> Result<Scene, IoError> {
    let text = std::fs::read_to_string(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    parse_obj(&text, path)
}

/// Write a mesh as OBJ: every coordinate in the shortest text that reads back to the same
/// `f64`, faces 1-based in the scene's order (face `k + 1` is owner index `k`).
pub fn write_obj(scene: &Scene, path: &Path) -> Result<(), IoError> {
    write_atomically(path, |out| {
        let e = |e: std::io::Error| e.to_string();
        writeln!(out, "# {} vertices, {} triangles", scene.vertices.len(), scene.triangles.len()).map_err(e)?;
        for [x, y, z] in &scene.vertices {
            writeln!(out, "v {x:?} {y:?} {z:?}").map_err(e)?;
        }
        for [a, b, c] in &scene.triangles {
            writeln!(out, "f {} {} {}", a + 1, b + 1, c + 1).map_err(e)?;
        }
        Ok(())
    })
}

/// Parse OBJ text; `path` only names the source in errors.
pub fn parse_obj(text: &str, path: &Path) -> Result<Scene, IoError> {
    let err = |line: usize, message: String| IoError::Parse { path: path.to_owned(), line, message };
    let mut scene = Scene::default();
    for (n, raw) in text.lines().enumerate() {
        let line_no = n + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v") => {
                let mut xyz = [0.0f64; 3];
                for (k, axis) in ["x", "y", "z"].iter().enumerate() {
                    let word = words.next().ok_or_else(|| err(line_no, format!("vertex has no {axis} coordinate; expected `v x y z`")))?;
                    xyz[k] = word.parse().map_err(|_| err(line_no, format!("vertex {axis} coordinate {word:?} is not a number")))?;
                    if !xyz[k].is_finite() {
                        return Err(err(line_no, format!("vertex {axis} coordinate {word:?} is not finite")));
                    }
                }
                scene.vertices.push(xyz);
            }
            Some("f") => {
                let count = scene.vertices.len();
                let corners = words
                    .map(|w| {
                        let first = w.split('/').next().unwrap_or("");
                        let i: i64 = first.parse().map_err(|_| err(line_no, format!("face index {w:?} is not an integer")))?;
                        let resolved = if i > 0 { i - 1 } else { count as i64 + i };
                        if i == 0 || resolved < 0 || resolved >= count as i64 {
                            return Err(err(
                                line_no,
                                format!("face index {i} is out of range: {count} vertices are defined before this line"),
                            ));
                        }
                        Ok(resolved as u32)
                    })
                    .collect::<Result<Vec<u32>, IoError>>()?;
                if corners.len() < 3 {
                    return Err(err(line_no, format!("face has {} corners; a face needs at least 3", corners.len())));
                }
                for k in 1..corners.len() - 1 {
                    scene.triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
            }
            _ => {}
        }
    }
    if scene.vertices.is_empty() || scene.triangles.is_empty() {
        return Err(IoError::Format {
            path: path.to_owned(),
            message: format!(
                "no mesh: {} vertices and {} faces found; expected `v x y z` and `f a b c` lines",
                scene.vertices.len(),
                scene.triangles.len()
            ),
        });
    }
    Ok(scene)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_vertices_faces_and_polygons() {
        let s = parse_obj("# c\nv 0 0 1\nv 1 0 2\nv 1 1 3\nv 0 1 4\nf 1/1/1 2 3 4\nf -1 -2 -3\n", Path::new("m.obj")).unwrap();
        assert_eq!(s.vertices.len(), 4);
        assert_eq!(s.triangles, vec![[0, 1, 2], [0, 2, 3], [3, 2, 1]]);
    }

    #[test]
    fn reports_line_and_problem() {
        let e = parse_obj("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 7\n", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.starts_with("m.obj:4:") && e.contains("out of range"), "{e}");
        let e = parse_obj("v 0 zero 0\n", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.contains("m.obj:1:") && e.contains("not a number"), "{e}");
        let e = parse_obj("", Path::new("m.obj")).unwrap_err().to_string();
        assert!(e.contains("no mesh"), "{e}");
    }

    #[test]
    fn written_meshes_read_back_bit_for_bit() {
        let scene = Scene::new(vec![[500_000.1, 5e6 + 1.0 / 3.0, -0.0], [1e-300, 2.5, f64::MAX], [7.0, 8.0, 9.125]], vec![[0, 1, 2], [2, 1, 0]]);
        let path = std::env::temp_dir().join(format!("tileraster-obj-{}.obj", std::process::id()));
        write_obj(&scene, &path).unwrap();
        let back = read_obj(&path).unwrap();
        std::fs::remove_file(&path).ok();
        assert_eq!(back.triangles, scene.triangles);
        let bits = |s: &Scene| s.vertices.iter().flatten().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&back), bits(&scene));
    }
}
