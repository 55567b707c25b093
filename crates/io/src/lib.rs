//! File formats: meshes (OBJ, PLY, STL, glTF 2.0) and point sets (CSV and XYZ text, LAS and LAZ) in;
//! OBJ meshes (a point set's TIN),
//! single-band GeoTIFFs (streamed band by band), VRT mosaics of them, and PNG hillshade
//! previews out.
//! Writers go through a temporary file in the destination's folder and rename it into place,
//! so a failed run never leaves a partial file behind.

mod geotiff;
mod gltf_mesh;
mod las;
mod obj;
mod ply;
mod points;
mod preview;
mod stl;
mod vrt;

pub use geotiff::{parse_epsg, write_geotiff, write_geotiff_with, BigTiff, GeoTiffOptions, GeoTiffWriter, Sample, TILE};
pub use gltf_mesh::read_gltf;
pub use obj::{parse_obj, parse_obj_mesh, read_obj, read_obj_mesh, write_obj};
pub use las::{parse_las, read_las};
pub use ply::{parse_ply, parse_ply_mesh, read_ply, read_ply_mesh};
pub use stl::{parse_stl, read_stl};
pub use points::{parse_points, read_points, Column, PointColumns};
pub use preview::{write_preview_png, write_rgba_png};
pub use vrt::{parse_part, read_part, write_mosaic_vrt, Mosaic, Part};

use std::path::{Path, PathBuf};

/// A file could not be read, parsed or written.
#[derive(Debug, thiserror::Error)]
pub enum IoError {
    #[error("{path}: {source}")]
    Io { path: PathBuf, source: std::io::Error },
    #[error("{path}:{line}: {message}")]
    Parse { path: PathBuf, line: usize, message: String },
    #[error("{path}: {message}")]
    Format { path: PathBuf, message: String },
}

/// A file written as `<name>.partial` beside its destination: [`commit`](Self::commit) makes
/// it durable and renames it into place; dropped before that (an error, a panic), it is
/// removed, so a failed run leaves no partial file behind.
pub(crate) struct PartialFile {
    path: PathBuf,
    tmp: PathBuf,
    out: std::io::BufWriter<std::fs::File>,
    committed: bool,
}

impl PartialFile {
    pub(crate) fn create(path: &Path) -> Result<Self, IoError> {
        let mut tmp_name = path.file_name().unwrap_or_default().to_owned();
        tmp_name.push(".partial");
        let tmp = path.with_file_name(tmp_name);
        let file = std::fs::File::create(&tmp).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
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
        std::fs::rename(&self.tmp, &self.path).map_err(io)?;
        self.committed = true;
        Ok(())
    }
}

impl Drop for PartialFile {
    fn drop(&mut self) {
        if !self.committed {
            let _ = std::fs::remove_file(&self.tmp);
        }
    }
}

/// Write a whole file at once through a [`PartialFile`].
pub(crate) fn write_atomically(
    path: &Path,
    write: impl FnOnce(&mut std::io::BufWriter<std::fs::File>) -> Result<(), String>,
) -> Result<(), IoError> {
    let mut file = PartialFile::create(path)?;
    write(file.out()).map_err(|message| IoError::Format { path: path.to_owned(), message })?;
    file.commit()
}
