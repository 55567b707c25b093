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
            "tif" | "tiff" => return Err(DemError::RasterInput { path: path.to_owned() }),
            _ => return Err(DemError::UnsupportedInput { path: path.to_owned(), extension }),
        })
    }

    /// Whether the file holds points (triangulated by Delaunay) rather than a mesh.
    pub fn is_points(self) -> bool {
        matches!(self, InputKind::Las | InputKind::Text)
    }
}

/// How [`read_scene`] reads and filters its input.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReadOptions {
    /// Delimited text: which columns hold x, y and z.
    pub columns: PointColumns,
    /// LAS/LAZ: keep only the points of these classifications (`--class 2`: ground); all when
    /// empty.
    pub classes: Vec<u8>,
    /// Leave out every triangle with an edge longer than this (in map units, measured in x
    /// and y), so that water bodies and gaps in the data stay nodata instead of being bridged.
    pub max_edge: Option<f64>,
    /// Keep a point file's points, repeats included, in [`Input::points_read`] (for
    /// [`Fallback`](super::Fallback), which searches them as gdal_grid does).
    pub keep_points: bool,
}

/// A scene read from a file.
pub struct Input {
    pub scene: Scene,
    /// For a point file, what reading and triangulating it did.
    pub points: Option<PointsRead>,
    /// Triangles left out by [`ReadOptions::max_edge`].
    pub long_triangles: usize,
    /// A point file's points in file order, repeats included, when
    /// [`ReadOptions::keep_points`] asks for them.
    pub points_read: Option<Vec<[f64; 3]>>,
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
/// a point file (`.las`, `.laz`, or delimited text with `options.columns`), whose vertices are
/// the points kept, in file order; then without the triangles `options.max_edge` leaves out
/// (the others keep their order).
pub fn read_scene(path: &Path, options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    let kind = InputKind::of(path)?;
    if let Some(max_edge) = options.max_edge.filter(|l| !(l.is_finite() && *l > 0.0)) {
        return Err(DemError::MaxEdge(max_edge));
    }
    if kind != InputKind::Las && !options.classes.is_empty() {
        return Err(DemError::ClassesOfText { path: path.to_owned() });
    }
    let mut input = read(path, kind, options, progress)?;
    if let Some(max_edge) = options.max_edge {
        input.long_triangles = drop_long_triangles(&mut input.scene, max_edge);
    }
    Ok(input)
}

fn read(path: &Path, kind: InputKind, options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    let mesh = |scene| Ok(Input { scene, points: None, long_triangles: 0, points_read: None });
    match kind {
        InputKind::Obj => mesh(tileraster_io::read_obj(path)?),
        InputKind::Ply => mesh(tileraster_io::read_ply(path)?),
        InputKind::Stl => mesh(tileraster_io::read_stl(path)?),
        InputKind::Gltf => {
            let m = tileraster_io::read_gltf(path, None)?;
            mesh(Scene::new(m.positions, m.triangles))
        }
        InputKind::Las | InputKind::Text => {
            let start = Instant::now();
            let points = match kind {
                InputKind::Las => tileraster_io::read_las_classes(path, &options.classes)?,
                _ => tileraster_io::read_points(path, &options.columns)?,
            };
            let read = start.elapsed();
            progress.stage(&format!("triangulating {} points", points.len()));
            let tin = tileraster_tin::triangulate(&points).map_err(|source| DemError::Triangulation { path: path.to_owned(), source })?;
            let summary = PointsRead { count: points.len(), duplicates: tin.duplicates, read, triangulated: start.elapsed() - read };
            Ok(Input { scene: tin.scene, points: Some(summary), long_triangles: 0, points_read: options.keep_points.then_some(points) })
        }
    }
}

/// Leave out the triangles with an edge longer than `max_edge` in x and y; returns how many.
pub fn drop_long_triangles(scene: &mut Scene, max_edge: f64) -> usize {
    let before = scene.triangles.len();
    let vertices = &scene.vertices;
    let longest = max_edge * max_edge;
    let short = |a: u32, b: u32| {
        let (p, q) = (vertices[a as usize], vertices[b as usize]);
        (p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) <= longest
    };
    scene.triangles.retain(|&[a, b, c]| short(a, b) && short(b, c) && short(c, a));
    before - scene.triangles.len()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_triangles_are_left_out_and_the_rest_keep_their_order() {
        // Two small triangles either side of a long thin one bridging a gap.
        let vertices = vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [10.0, 0.0, 0.0], [10.0, 1.0, 0.0], [9.0, 1.0, 0.0]];
        let mut scene = Scene::new(vertices, vec![[0, 1, 2], [1, 3, 2], [3, 4, 5]]);
        // Edges of exactly the limit stay: sqrt(2) for the small ones.
        assert_eq!(drop_long_triangles(&mut scene.clone(), 2f64.sqrt()), 1);
        assert_eq!(drop_long_triangles(&mut scene, 5.0), 1);
        assert_eq!(scene.triangles, [[0, 1, 2], [3, 4, 5]]);
        // Height does not count: the edge is measured in x and y.
        let mut tall = Scene::new(vec![[0.0, 0.0, 0.0], [1.0, 0.0, 100.0], [0.0, 1.0, -100.0]], vec![[0, 1, 2]]);
        assert_eq!(drop_long_triangles(&mut tall, 1.5), 0);
    }
}
