//! Cloud-optimised GeoTIFF (`-co COG=YES`): the layout GDAL's COG driver writes and
//! `validate_cloud_optimized_geotiff.py --full-check=yes` accepts. After the header, GDAL's
//! structural metadata ("ghost area"), then every IFD (the image's, then one per overview,
//! halving), then the arrays of tile offsets and byte counts, then the tiles: the smallest
//! overview's first and the image's last, each level's row-major, each tile led by its byte
//! count (u32) and trailed by a copy of its last 4 bytes.
//!
//! Why a spill: a COG puts the directories, whose sizes depend on every tile's compressed
//! size, before the data, and the image's tiles after its overviews', while the writer is fed
//! rows top to bottom and holds one row of blocks. So the tiles of every level are compressed
//! as their rows arrive and appended to an unnamed temporary file in the destination's folder
//! (nothing is left behind, even on SIGKILL); `finish` then writes the file in COG order,
//! copying the tiles from the spill. Each overview level is a 2:1 reducer of the level above,
//! fed a block row at a time and holding at most one block row of its own: memory stays one
//! row of blocks per level; the spill needs about the compressed file's size on disk.
//!
//! Overviews are computed from the image's final bits, on the host, so they do not depend on
//! the backend or on how the rows were banded: factors 2, 4, 8, ... until the smallest fits
//! one tile (none when the image does), each level `ceil(w / 2)` × `ceil(h / 2)` of the level
//! above and computed from it. A Float32 cell is the mean of the 2×2 cells above it (fewer at
//! an odd edge) that are not nodata (NaN-aware), summed in f64 in row-major order and rounded
//! once to f32; nodata if none is valid. A UInt32 (owner-triangle) cell is the top-left one of
//! its 2×2 (nearest: averaging ids is meaningless). GDAL's own COG driver sizes overviews
//! rounding down and resamples them otherwise; readers take either.

use crate::IoError;
use crate::geotiff::{Coding, Sample, TILE};
use rayon::prelude::*;
use std::fs::File;
use std::io::{BufWriter, Read, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

/// The ghost area's text, as GDAL 3.6 writes it for a single band with no mask (the trailing
/// space included in the size it states).
const GHOST_BODY: &str =
    "LAYOUT=IFDS_BEFORE_DATA\nBLOCK_ORDER=ROW_MAJOR\nBLOCK_LEADER=SIZE_AS_UINT4\nBLOCK_TRAILER=LAST_4_BYTES_REPEATED\nKNOWN_INCOMPATIBLE_EDITION=NO\n ";

/// GDAL's structural metadata, written right after the header.
pub(crate) fn ghost() -> Vec<u8> {
    format!("GDAL_STRUCTURAL_METADATA_SIZE={:06} bytes\n{GHOST_BODY}", GHOST_BODY.len()).into_bytes()
}

/// The size of each level, the image's first, then its overviews': halving (rounding up)
/// until the level fits one tile.
pub(crate) fn levels(width: u32, height: u32) -> Vec<(u32, u32)> {
    let mut sizes = vec![(width, height)];
    let (mut w, mut h) = (width, height);
    while w.max(h) > TILE {
        (w, h) = (w.div_ceil(2), h.div_ceil(2));
        sizes.push((w, h));
    }
    sizes
}

/// Tiles across and down a `width` × `height` level.
pub(crate) fn tiles(width: u32, height: u32) -> u64 {
    width.div_ceil(TILE) as u64 * height.div_ceil(TILE) as u64
}

/// Rows of a level (`width` samples each, an even number of them but for the level's last)
/// reduced 2:1 both ways into the rows of the next level: see the module's docs.
pub(crate) fn reduce(rows: &[u8], width: u32, sample: Sample) -> Vec<u8> {
    let row_bytes = width as usize * 4;
    let half = width.div_ceil(2) as usize;
    let count = rows.len() / row_bytes;
    let mut out = vec![0u8; count.div_ceil(2) * half * 4];
    let cell = |row: &[u8], x: usize| row.get(4 * x..4 * x + 4).map(|b| [b[0], b[1], b[2], b[3]]);
    out.par_chunks_mut(half * 4).zip(rows.par_chunks(2 * row_bytes)).for_each(|(out, pair)| {
        // The bottom row is missing at an odd level's foot.
        let (top, bottom) = pair.split_at(row_bytes);
        for (i, o) in out.as_chunks_mut::<4>().0.iter_mut().enumerate() {
            let value = match sample {
                Sample::UInt32 => cell(top, 2 * i).expect("the top-left cell is inside"),
                Sample::Float32 { nodata } => {
                    let (mut sum, mut n) = (0f64, 0u32);
                    for v in [cell(top, 2 * i), cell(top, 2 * i + 1), cell(bottom, 2 * i), cell(bottom, 2 * i + 1)].into_iter().flatten() {
                        let v = f32::from_le_bytes(v);
                        if !(v == nodata || nodata.is_nan() && v.is_nan()) {
                            sum += v as f64;
                            n += 1;
                        }
                    }
                    match n {
                        0 => nodata.to_le_bytes(),
                        n => ((sum / n as f64) as f32).to_le_bytes(),
                    }
                }
            };
            o.copy_from_slice(&value);
        }
    });
    out
}

/// A COG being written: every level's tiles, compressed, in the spill as they come.
pub(crate) struct Cog {
    /// The destination, for errors.
    path: PathBuf,
    spill: BufWriter<File>,
    spilled: u64,
    /// Every level's size, the image's first.
    sizes: Vec<(u32, u32)>,
    /// Every level's tiles in the spill, row-major: (offset, byte count).
    tiles: Vec<Vec<(u64, u64)>>,
    /// Each overview's rows not yet a whole block row (index 0, the image's, is unused: the
    /// writer holds those).
    pending: Vec<Vec<u8>>,
}

impl Cog {
    /// Start the spill: an unnamed file in `path`'s folder.
    pub(crate) fn create(path: &Path, width: u32, height: u32) -> Result<Self, IoError> {
        let folder = path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
        let spill = tempfile::tempfile_in(folder).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
        let sizes = levels(width, height);
        Ok(Cog {
            path: path.to_owned(),
            spill: BufWriter::with_capacity(1 << 20, spill),
            spilled: 0,
            tiles: sizes.iter().map(|&(w, h)| Vec::with_capacity(tiles(w, h) as usize)).collect(),
            pending: vec![Vec::new(); sizes.len()],
            sizes,
        })
    }

    fn io(&self) -> impl Fn(std::io::Error) -> IoError + '_ {
        |source| IoError::Io { path: self.path.clone(), source }
    }

    /// Every level's size, the image's first.
    pub(crate) fn sizes(&self) -> &[(u32, u32)] {
        &self.sizes
    }

    /// A block row of `level` (`TILE` rows, or fewer for the level's last): its tiles to the
    /// spill, its rows reduced into the next level, whose block rows follow as they fill.
    pub(crate) fn block_row(&mut self, level: usize, rows: &[u8], coding: &Coding) -> Result<(), IoError> {
        let width = self.sizes[level].0;
        for tile in coding.blocks(rows, width, true) {
            self.tiles[level].push((self.spilled, tile.len() as u64));
            self.spill.write_all(&tile).map_err(self.io())?;
            self.spilled += tile.len() as u64;
        }
        let next = level + 1;
        if next < self.sizes.len() {
            let reduced = reduce(rows, width, coding.sample);
            self.pending[next].extend_from_slice(&reduced);
            let full = TILE as usize * self.sizes[next].0 as usize * 4;
            debug_assert!(self.pending[next].len() <= full, "block rows of TILE (even) rows reduce to half block rows");
            if self.pending[next].len() >= full {
                let mut rows = std::mem::take(&mut self.pending[next]);
                self.block_row(next, &rows, coding)?;
                rows.clear();
                self.pending[next] = rows;
            }
        }
        Ok(())
    }

    /// Each overview's last block row, once the image's last has been given.
    pub(crate) fn flush(&mut self, coding: &Coding) -> Result<(), IoError> {
        for level in 1..self.sizes.len() {
            let rows = std::mem::take(&mut self.pending[level]);
            if !rows.is_empty() {
                self.block_row(level, &rows, coding)?;
            }
        }
        self.spill.flush().map_err(self.io())?;
        debug_assert!(self.sizes.iter().zip(&self.tiles).all(|(&(w, h), t)| t.len() as u64 == tiles(w, h)));
        Ok(())
    }

    /// Every level's tiles' byte counts, row-major.
    pub(crate) fn byte_counts(&self) -> Vec<Vec<u64>> {
        self.tiles.iter().map(|level| level.iter().map(|t| t.1).collect()).collect()
    }

    /// The spilled tiles in the COG's order, the smallest overview's first, to `put`.
    pub(crate) fn copy_tiles(&mut self, mut put: impl FnMut(&[u8]) -> Result<(), IoError>) -> Result<(), IoError> {
        let mut tile = Vec::new();
        for level in (0..self.tiles.len()).rev() {
            for k in 0..self.tiles[level].len() {
                let (offset, count) = self.tiles[level][k];
                tile.resize(count as usize, 0);
                let spill = self.spill.get_mut();
                spill.seek(SeekFrom::Start(offset)).and_then(|_| spill.read_exact(&mut tile)).map_err(self.io())?;
                put(&tile)?;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ghost_is_gdals() {
        let ghost = ghost();
        assert!(ghost.starts_with(b"GDAL_STRUCTURAL_METADATA_SIZE=000140 bytes\nLAYOUT=IFDS_BEFORE_DATA\n"));
        assert_eq!(ghost.len(), 43 + 140);
    }

    #[test]
    fn levels_halve_until_one_tile() {
        assert_eq!(levels(256, 100), vec![(256, 100)]);
        assert_eq!(levels(257, 3), vec![(257, 3), (129, 2)]);
        assert_eq!(levels(1000, 700), vec![(1000, 700), (500, 350), (250, 175)]);
        assert_eq!(levels(1003, 5), vec![(1003, 5), (502, 3), (251, 2)]);
    }

    #[test]
    fn reduce_averages_valid_cells_and_keeps_uint32_top_left() {
        let f = |v: &[f32]| v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>();
        let back = |b: Vec<u8>| b.chunks(4).map(|c| f32::from_le_bytes(c.try_into().unwrap())).collect::<Vec<f32>>();
        // 3 × 3: a 2×2, a 1×2 edge, a 2×1 foot and a lone corner.
        let rows = f(&[1.0, 2.0, 5.0, 3.0, -1.0, 7.0, 4.0, 8.0, -1.0]);
        assert_eq!(back(reduce(&rows, 3, Sample::Float32 { nodata: -1.0 })), vec![2.0, 6.0, 6.0, -1.0]);
        let nan = f(&[f32::NAN, f32::NAN, 1.0, f32::NAN]);
        let out = back(reduce(&nan, 2, Sample::Float32 { nodata: f32::NAN }));
        assert_eq!(out, vec![1.0]);
        assert!(back(reduce(&f(&[f32::NAN; 4]), 2, Sample::Float32 { nodata: f32::NAN }))[0].is_nan());
        let ids: Vec<u8> = [10u32, 11, 12, 13, 14, 15].iter().flat_map(|x| x.to_le_bytes()).collect();
        assert_eq!(reduce(&ids, 3, Sample::UInt32), [10u32, 12].iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
    }
}
