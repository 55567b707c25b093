//! The scene in a file: a mesh as it is, or the Delaunay TIN of a point file, chosen by the
//! file's extension.

use super::{DemError, Progress};
use crate::Scene;
use std::path::Path;
use std::time::{Duration, Instant};
use tileraster_io::PointColumns;

/// The kinds of file [`read_scene`] takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InputKind {
    Obj,
    Ply,
    Stl,
    /// glTF 2.0, `.gltf` or `.glb` (its scene's triangles in world coordinates).
    Gltf,
    /// `.las` or `.laz` points.
    Las,
    /// Delimited text points: `.csv`, `.xyz`, `.txt`, `.pts`.
    Text,
}

impl InputKind {
    /// The kind of `path`, by its extension (any case).
    pub fn of(path: &Path) -> Result<InputKind, DemError> {
        let extension = path.extension().and_then(|e| e.to_str()).unwrap_or("").to_lowercase();
        Ok(match extension.as_str() {
            "obj" => InputKind::Obj,
            "ply" => InputKind::Ply,
            "stl" => InputKind::Stl,
            "gltf" | "glb" => InputKind::Gltf,
            "las" | "laz" => InputKind::Las,
            "csv" | "xyz" | "txt" | "pts" => InputKind::Text,
            _ => return Err(DemError::UnsupportedInput { path: path.to_owned(), extension }),
        })
    }

    /// Whether the file holds points (triangulated by Delaunay) rather than a mesh.
    pub fn is_points(self) -> bool {
        matches!(self, InputKind::Las | InputKind::Text)
    }
}

/// A scene read from a file.
pub struct Input {
    pub scene: Scene,
    /// For a point file, what reading and triangulating it did.
    pub points: Option<PointsRead>,
}

/// What reading and triangulating a point file did.
#[derive(Debug, Clone, Copy)]
pub struct PointsRead {
    /// Points in the file.
    pub count: usize,
    /// Points that repeat an earlier point's x, y (the first of each is kept).
    pub duplicates: usize,
    pub read: Duration,
    pub triangulated: Duration,
}

/// The scene in `path`: a mesh (`.obj`, `.ply`, `.stl`, `.gltf`, `.glb`; heights in z), or the Delaunay TIN of
/// a point file (`.las`, `.laz`, or delimited text with `columns`), whose vertices are the
/// points in file order.
pub fn read_scene(path: &Path, columns: &PointColumns, progress: &dyn Progress) -> Result<Input, DemError> {
    let kind = InputKind::of(path)?;
    let mesh = |scene| Ok(Input { scene, points: None });
    match kind {
        InputKind::Obj => mesh(tileraster_io::read_obj(path)?),
        InputKind::Ply => mesh(tileraster_io::read_ply(path)?),
        InputKind::Stl => mesh(tileraster_io::read_stl(path)?),
        InputKind::Gltf => {
            let m = tileraster_io::read_gltf(path)?;
            mesh(Scene::new(m.positions, m.triangles))
        }
        InputKind::Las | InputKind::Text => {
            let start = Instant::now();
            let points = if kind == InputKind::Las { tileraster_io::read_las(path)? } else { tileraster_io::read_points(path, columns)? };
            let read = start.elapsed();
            progress.stage(&format!("triangulating {} points", points.len()));
            let tin = tileraster_tin::triangulate(&points).map_err(|source| DemError::Triangulation { path: path.to_owned(), source })?;
            let points = PointsRead { count: points.len(), duplicates: tin.duplicates, read, triangulated: start.elapsed() - read };
            Ok(Input { scene: tin.scene, points: Some(points) })
        }
    }
}
