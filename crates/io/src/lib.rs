//! File formats: meshes (OBJ, PLY, STL, glTF 2.0), point sets (CSV and XYZ text, LAS and LAZ,
//! COPC read by octree node, NumPy arrays)
//! and GeoTIFF DEMs in;
//! OBJ meshes (a point set's TIN),
//! single-band GeoTIFFs and COGs (streamed band by band), VRT mosaics of them, and PNG hillshade
//! previews out.
//! Writers go through a temporary file in the destination's folder and rename it into place,
//! so a failed run never leaves a partial file behind.

mod chunks;
mod cog;
mod copc;
mod dem;
mod geotiff;
mod gltf_mesh;
mod gltf_pose;
mod gltf_rig;
mod las;
mod npy;
mod obj;
mod ply;
mod points;
mod preview;
mod stl;
mod vrt;

pub use copc::{Copc, CopcNode, NodePoints};
pub use dem::{Dem, read_dem};
pub use geotiff::{
    BigTiff, Compression, GeoTiffOptionError, GeoTiffOptions, GeoTiffWriter, Predictor, Sample, TILE, parse_epsg, write_geotiff, write_geotiff_with,
};
pub use gltf_mesh::{GltfCamera, GltfProjection, read_gltf, read_gltf_cameras, read_gltf_posable, read_gltf_world};
pub use gltf_rig::PosableGltf;
pub use las::{las_point_count, parse_las, read_las, read_las_classes};
pub use npy::read_npy;
pub use obj::{parse_obj, parse_obj_mesh, read_obj, read_obj_mesh, read_texture, write_obj, write_obj_textured};
pub use ply::{parse_ply, parse_ply_mesh, read_ply, read_ply_mesh};
pub use points::{Column, PointColumns, parse_points, read_points};
pub use preview::{write_preview_png, write_rgba_png};
pub use stl::{parse_stl, read_stl};
pub use vrt::{Mosaic, Part, parse_part, read_part, write_mosaic_vrt};

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard};

/// A file could not be read, parsed or written.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}:{line}: {message}")]
    Parse { path: PathBuf, line: usize, message: String },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
    /// GeoTIFF creation options that do not go together, or not with the file's samples.
    #[error("{path}: {source}")]
    Options { path: PathBuf, source: GeoTiffOptionError },
}

/// The suffix of a file being written: `dem.tif` is written as `dem.tif.tileraster-partial`
/// beside its destination. One orphaned by SIGKILL or a power cut is recognisable by it, and
/// the next run to the same destination replaces it.
pub const PARTIAL_SUFFIX: &str = ".tileraster-partial";

/// The partial files this process is writing, so that an interrupted run can remove them
/// ([`abandon_partial_files`]). A file is listed from its creation until it is renamed into
/// place or removed, both done under the lock.
static IN_PROGRESS: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn in_progress() -> MutexGuard<'static, Vec<PathBuf>> {
    IN_PROGRESS.lock().unwrap_or_else(|e| e.into_inner())
}

/// The partial files an interrupted process removed (and those it could not), and the lock
/// that keeps any other file from being created or renamed into place while it is held: a
/// process exits holding it.
pub struct Abandoned {
    pub removed: Vec<PathBuf>,
    pub not_removed: Vec<(PathBuf, std::io::Error)>,
    _held: MutexGuard<'static, Vec<PathBuf>>,
}

/// Remove every partial file this process is writing (for a signal handler, which then exits
/// holding the returned lock). A destination is never touched: each was either renamed into
/// place whole before this, or never will be.
pub fn abandon_partial_files() -> Abandoned {
    let mut held = in_progress();
    let (mut removed, mut not_removed) = (Vec::new(), Vec::new());
    for tmp in held.drain(..) {
        match std::fs::remove_file(&tmp) {
            Ok(()) => removed.push(tmp),
            Err(e) => not_removed.push((tmp, e)),
        }
    }
    Abandoned { removed, not_removed, _held: held }
}

/// A file written as `<name>.tileraster-partial` beside its destination:
/// [`commit`](Self::commit) makes it durable and renames it into place; dropped before that
/// (an error, a panic), it is removed, so a failed run leaves no partial file behind.
///
/// The writer holds an exclusive lock on it (`flock`), which the system drops when the file is
/// closed, however the process ends: a partial file nobody holds is an orphan, replaced; one
/// that is held belongs to a run still writing the same destination (another process, or
/// this one asked to write one file twice), and is refused.
pub(crate) struct PartialFile {
    path: PathBuf,
    tmp: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    committed: bool,
}

impl PartialFile {
    pub(crate) fn create(path: &Path) -> Result<Self, IoError> {
        let mut tmp_name = path.file_name().unwrap_or_default().to_owned();
        tmp_name.push(PARTIAL_SUFFIX);
        let tmp = path.with_file_name(tmp_name);
        let io = |source| IoError::Io { path: path.to_owned(), source };
        let mut listed = in_progress();
        let file = std::fs::OpenOptions::new().write(true).create(true).truncate(false).open(&tmp).map_err(io)?;
        match file.try_lock() {
            Ok(()) => {}
            Err(std::fs::TryLockError::WouldBlock) => {
                return Err(IoError::Format {
                    path: path.to_owned(),
                    message: format!("another run is writing this file ({} is in use); wait for it, or give another destination", tmp.display()),
                });
            }
            Err(std::fs::TryLockError::Error(e)) => return Err(io(e)),
        }
        // An orphan of an earlier run, replaced.
        file.set_len(0).map_err(io)?;
        listed.push(tmp.clone());
        Ok(PartialFile { path: path.to_owned(), tmp, out: std::io::BufWriter::with_capacity(1 << 20, file), committed: false })
    }

    /// The destination, for errors.
    pub(crate) fn path(&self) -> &Path {
        &self.path
    }

    pub(crate) fn out(&mut self) -> &mut std::io::BufWriter<std::fs::File> {
        &mut self.out
    }

    pub(crate) fn commit(mut self) -> Result<(), IoError> {
        let io = |source| IoError::Io { path: self.path.clone(), source };
        std::io::Write::flush(&mut self.out).map_err(io)?;
        self.out.get_ref().sync_all().map_err(io)?;
        let mut listed = in_progress();
        if !listed.contains(&self.tmp) {
            // Abandoned by an interrupt: the process is exiting.
            return Err(io(std::io::Error::new(std::io::ErrorKind::Interrupted, "interrupted")));
        }
        std::fs::rename(&self.tmp, &self.path).map_err(io)?;
        listed.retain(|p| *p != self.tmp);
        self.committed = true;
        Ok(())
    }
}

impl Drop for PartialFile {
    fn drop(&mut self) {
        if !self.committed {
            let mut listed = in_progress();
            if let Some(k) = listed.iter().position(|p| *p == self.tmp) {
                listed.swap_remove(k);
                let _ = std::fs::remove_file(&self.tmp);
            }
        }
    }
}

/// Write a whole file at once through a [`PartialFile`].
pub(crate) fn write_atomically(path: &Path, write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<(), String>) -> Result<(), IoError> {
    let mut file = PartialFile::create(path)?;
    write(file.out()).map_err(|message| IoError::Format { path: path.to_owned(), message })?;
    file.commit()
}
