//! The scene in a file: a mesh as it is, or the Delaunay TIN of a point file, chosen by the
//! file's extension.

use super::block::BlockRead;
use super::{DemError, Progress};
use crate::Scene;
use std::path::{Path, PathBuf};
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
    /// A NumPy array of points, a row each: `.npy`.
    Array,
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
            "npy" => InputKind::Array,
            "tif" | "tiff" => return Err(DemError::RasterInput { path: path.to_owned() }),
            _ => return Err(DemError::UnsupportedInput { path: path.to_owned(), extension }),
        })
    }

    /// Whether the file holds points (triangulated by Delaunay) rather than a mesh.
    pub fn is_points(self) -> bool {
        matches!(self, InputKind::Las | InputKind::Text | InputKind::Array)
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
    /// For a block's TIN ([`block_scene`]), how it was made.
    pub block: Option<BlockRead>,
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
    read_scenes(&[path.to_owned()], options, progress)
}

/// A mesh file's scene, as it is.
fn read_mesh(path: &Path, kind: InputKind) -> Result<Scene, DemError> {
    Ok(match kind {
        InputKind::Obj => tileraster_io::read_obj(path)?,
        InputKind::Ply => tileraster_io::read_ply(path)?,
        InputKind::Stl => tileraster_io::read_stl(path)?,
        InputKind::Gltf => {
            let m = tileraster_io::read_gltf(path, None)?;
            Scene::new(m.positions, m.triangles)
        }
        InputKind::Las | InputKind::Text | InputKind::Array => unreachable!("point files are triangulated"),
    })
}

/// The files `inputs` name, in their order: a file as it is; a directory's point files
/// (`.las`, `.laz`, `.csv`, `.xyz`, `.txt`, `.pts`, `.npy`; not its subdirectories') by name; a glob
/// pattern's matches by name (a pattern the shell left alone: `"tiles/*.laz"`). A directory or
/// pattern that names no file is an error, and so is a file named twice.
pub fn input_files(inputs: &[PathBuf]) -> Result<Vec<PathBuf>, DemError> {
    let mut files = Vec::new();
    for input in inputs {
        let text = input.to_string_lossy();
        let pattern = !input.exists() && text.contains(['*', '?', '[']);
        let mut found: Vec<PathBuf> = if input.is_dir() {
            let entries = std::fs::read_dir(input).map_err(|source| tileraster_io::IoError::Io { path: input.clone(), source })?;
            let mut found = Vec::new();
            for entry in entries {
                let path = entry.map_err(|source| tileraster_io::IoError::Io { path: input.clone(), source })?.path();
                if path.is_file() && InputKind::of(&path).is_ok_and(InputKind::is_points) {
                    found.push(path);
                }
            }
            found
        } else if pattern {
            let matches = glob::glob(&text).map_err(|e| DemError::InputPattern { pattern: text.to_string(), reason: e.to_string() })?;
            matches.filter_map(Result::ok).filter(|p| p.is_file()).collect()
        } else {
            vec![input.clone()]
        };
        if found.is_empty() {
            return Err(DemError::NoInputFiles { input: input.clone(), directory: input.is_dir() });
        }
        found.sort();
        files.extend(found);
    }
    let mut seen = std::collections::HashSet::new();
    if let Some(twice) = files.iter().find(|f| !seen.insert(std::fs::canonicalize(f).unwrap_or_else(|_| (*f).clone()))) {
        return Err(DemError::InputTwice { path: twice.clone() });
    }
    Ok(files)
}

/// The scene of the files `paths` ([`input_files`]): one mesh file as it is, or the TIN of the
/// points of one or several point files, as if they were one file's in the order given (each
/// file read on its own core, its points appended in turn), triangulated once; then without
/// the triangles `options.max_edge` leaves out.
pub fn read_scenes(paths: &[PathBuf], options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    if paths.is_empty() {
        return Err(DemError::NoInputs);
    }
    let kinds = paths.iter().map(|p| InputKind::of(p)).collect::<Result<Vec<_>, _>>()?;
    if let Some(max_edge) = options.max_edge.filter(|l| !(l.is_finite() && *l > 0.0)) {
        return Err(DemError::MaxEdge(max_edge));
    }
    if let Some(k) = kinds.iter().position(|&k| k != InputKind::Las && !options.classes.is_empty()) {
        return Err(DemError::ClassesOfText { path: paths[k].clone() });
    }
    let mut input = match (paths, &kinds[..]) {
        ([path], [kind]) if !kind.is_points() => Input { scene: read_mesh(path, *kind)?, points: None, long_triangles: 0, points_read: None, block: None },
        _ => match kinds.iter().position(|k| !k.is_points()) {
            Some(k) => return Err(DemError::MeshAmongInputs { path: paths[k].clone(), inputs: paths.len() }),
            None => triangulate_files(paths, &kinds, options, progress)?,
        },
    };
    if let Some(max_edge) = options.max_edge {
        input.long_triangles = drop_long_triangles(&mut input.scene, max_edge);
    }
    Ok(input)
}

/// The Delaunay TIN of the point files `paths` (of `kinds`), read on all cores.
fn triangulate_files(paths: &[PathBuf], kinds: &[InputKind], options: &ReadOptions, progress: &dyn Progress) -> Result<Input, DemError> {
    let start = Instant::now();
    let points = read_kinds(paths, kinds, options)?;
    let read = start.elapsed();
    match paths.len() {
        1 => progress.stage(&format!("triangulating {} points", points.len())),
        n => progress.stage(&format!("triangulating {} points from {n} files", points.len())),
    }
    let tin = tileraster_tin::triangulate(&points).map_err(|source| DemError::Triangulation { path: describe(paths), source })?;
    let summary = PointsRead { count: points.len(), duplicates: tin.duplicates, read, triangulated: start.elapsed() - read };
    Ok(Input { scene: tin.scene, points: Some(summary), long_triangles: 0, points_read: options.keep_points.then_some(points), block: None })
}

/// The points of the point files `paths` ([`input_files`]), as one file's in the order given,
/// each file read on its own core; with `options.columns` and `options.classes`.
pub fn read_points(paths: &[PathBuf], options: &ReadOptions) -> Result<Vec<[f64; 3]>, DemError> {
    if paths.is_empty() {
        return Err(DemError::NoInputs);
    }
    let kinds = paths.iter().map(|p| InputKind::of(p)).collect::<Result<Vec<_>, _>>()?;
    if let Some(k) = kinds.iter().position(|k| !k.is_points()) {
        return Err(DemError::MeshAmongInputs { path: paths[k].clone(), inputs: paths.len() });
    }
    if let Some(k) = kinds.iter().position(|&k| k != InputKind::Las && !options.classes.is_empty()) {
        return Err(DemError::ClassesOfText { path: paths[k].clone() });
    }
    read_kinds(paths, &kinds, options)
}

fn read_kinds(paths: &[PathBuf], kinds: &[InputKind], options: &ReadOptions) -> Result<Vec<[f64; 3]>, DemError> {
    use rayon::prelude::*;
    let read = |(path, kind): (&PathBuf, &InputKind)| match kind {
        InputKind::Las => tileraster_io::read_las_classes(path, &options.classes),
        InputKind::Array => tileraster_io::read_npy(path, &options.columns),
        _ => tileraster_io::read_points(path, &options.columns),
    };
    let parts = paths.par_iter().zip(kinds).map(read).collect::<Result<Vec<_>, _>>()?;
    let mut points = Vec::with_capacity(parts.iter().map(Vec::len).sum());
    parts.into_iter().for_each(|part| points.extend(part));
    Ok(points)
}

/// `paths` as one name, for messages: the first and how many more.
pub fn describe(paths: &[PathBuf]) -> PathBuf {
    match paths {
        [one] => one.clone(),
        [first, rest @ ..] => PathBuf::from(format!("{} and {} more files", first.display(), rest.len())),
        [] => PathBuf::new(),
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
