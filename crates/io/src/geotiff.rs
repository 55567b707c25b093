//! Single-band GeoTIFFs (Float32 heights, UInt32 owner triangles), written block by block:
//! a grid larger than memory streams through [`GeoTiffWriter`] in bands of rows, and only one
//! row of blocks is ever held. Classic TIFF, or BigTIFF when the file may pass 4 GiB; strips,
//! tiles, or a cloud-optimised GeoTIFF with overviews (see the `cog` module); uncompressed,
//! Deflate or ZSTD, with libtiff's horizontal or floating-point predictor.

use crate::cog::{self, Cog};
use crate::{IoError, PartialFile};
use rayon::prelude::*;
use std::borrow::Cow;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;
use tileraster_core::{Grid, Raster, Window};

// Samples are written as the host holds them, and the header says little-endian.
const _: () = assert!(cfg!(target_endian = "little"), "the GeoTIFF writer writes host-order samples as little-endian");

/// How a GeoTIFF is written; the default is gdal_grid's: strips, uncompressed, no CRS,
/// BigTIFF only if needed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GeoTiffOptions {
    /// The CRS as an EPSG code, written as GeoKeys (gdal_grid's `-a_srs EPSG:n`).
    pub epsg: Option<u16>,
    /// `TILE` × `TILE` tiles instead of strips (`-co TILED=YES`).
    pub tiled: bool,
    /// How blocks are compressed (`-co COMPRESS=NONE|DEFLATE|ZSTD`).
    pub compress: Compression,
    /// The predictor applied to each block's rows before compression (`-co PREDICTOR=...`);
    /// only with compression.
    pub predictor: Predictor,
    /// A cloud-optimised GeoTIFF with overviews (`-co COG=YES`, or gdal_translate's `-of COG`
    /// through [`apply_format`](Self::apply_format)). Always tiled: `tiled` must be set too,
    /// as `apply("COG=YES")` does.
    pub cog: bool,
    /// Classic TIFF or BigTIFF (`-co BIGTIFF=YES|NO|IF_NEEDED`).
    pub bigtiff: BigTiff,
}

/// When to write BigTIFF (64-bit offsets) instead of classic TIFF (32-bit, at most 4 GiB).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum BigTiff {
    /// When the uncompressed image might not fit a classic TIFF.
    #[default]
    IfNeeded,
    Yes,
    No,
}

/// How blocks are compressed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Compression {
    #[default]
    None,
    /// Deflate (zlib), TIFF compression 8.
    Deflate,
    /// Zstandard at GDAL's default level (9), TIFF compression 50000.
    Zstd,
}

impl Compression {
    /// TIFF's Compression tag.
    fn tag(self) -> u16 {
        match self {
            Compression::None => 1,
            Compression::Deflate => 8,
            Compression::Zstd => 50000,
        }
    }
}

/// libtiff's predictors, applied to each row of a block (a tile's 256 samples, padding
/// included; a strip's whole rows) before it is compressed.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum Predictor {
    /// `PREDICTOR=1|NO|NONE`.
    #[default]
    None,
    /// `PREDICTOR=2|STANDARD`: each 32-bit sample minus the one before it (wrapping; on
    /// Float32 samples, their bit patterns, as libtiff does).
    Horizontal,
    /// `PREDICTOR=3|FLOATING_POINT`: libtiff's floating-point predictor (bytes shuffled into
    /// planes, most significant first, then differenced); Float32 samples only.
    FloatingPoint,
    /// `PREDICTOR=YES`, as GDAL's COG driver takes it: floating point on Float32 samples,
    /// horizontal on UInt32 ones (so heights and owner files can share the options).
    Yes,
}

impl Predictor {
    /// TIFF's Predictor tag for `sample`.
    fn tag(self, sample: Sample) -> Result<u16, GeoTiffOptionError> {
        match (self, sample) {
            (Predictor::None, _) => Ok(1),
            (Predictor::Horizontal, _) | (Predictor::Yes, Sample::UInt32) => Ok(2),
            (Predictor::FloatingPoint | Predictor::Yes, Sample::Float32 { .. }) => Ok(3),
            (Predictor::FloatingPoint, Sample::UInt32) => Err(GeoTiffOptionError::FloatingPointPredictorOnUInt32),
        }
    }
}

/// Options that cannot make a file together, or not for its samples.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum GeoTiffOptionError {
    #[error("PREDICTOR={predictor} needs compression: add -co COMPRESS=DEFLATE (or COMPRESS=ZSTD), or drop PREDICTOR")]
    PredictorWithoutCompression { predictor: u16 },
    #[error(
        "PREDICTOR=3 (FLOATING_POINT) is for Float32 samples, and this file holds UInt32 owner-triangle ids: use PREDICTOR=2 (STANDARD), or PREDICTOR=YES, which takes 3 for Float32 files and 2 for UInt32 ones"
    )]
    FloatingPointPredictorOnUInt32,
    #[error("a COG is always tiled (256×256), but strips were asked for (TILED=NO): drop TILED=NO, or write COG=NO for a striped GeoTIFF")]
    CogWithoutTiles,
}

/// Side of a tile in tiled output, as GDAL's default.
pub const TILE: u32 = 256;

impl GeoTiffOptions {
    /// Apply a creation option as gdal_grid and gdal_translate take them (`TILED=YES`,
    /// `COMPRESS=DEFLATE`, `PREDICTOR=3`, `BIGTIFF=YES`, `COG=YES`, ...).
    pub fn apply(&mut self, option: &str) -> Result<(), String> {
        let (name, value) = option.split_once('=').ok_or_else(|| format!("creation option '{option}' is not NAME=VALUE"))?;
        match (name.to_ascii_uppercase().as_str(), value.to_ascii_uppercase().as_str()) {
            ("TILED", "YES" | "TRUE" | "ON") => self.tiled = true,
            ("TILED", "NO" | "FALSE" | "OFF") => self.tiled = false,
            ("COMPRESS", "NONE") => self.compress = Compression::None,
            ("COMPRESS", "DEFLATE") => self.compress = Compression::Deflate,
            ("COMPRESS", "ZSTD") => self.compress = Compression::Zstd,
            ("PREDICTOR", "1" | "NO" | "NONE" | "FALSE") => self.predictor = Predictor::None,
            ("PREDICTOR", "2" | "STANDARD") => self.predictor = Predictor::Horizontal,
            ("PREDICTOR", "3" | "FLOATING_POINT") => self.predictor = Predictor::FloatingPoint,
            ("PREDICTOR", "YES" | "TRUE") => self.predictor = Predictor::Yes,
            ("BIGTIFF", "YES") => self.bigtiff = BigTiff::Yes,
            ("BIGTIFF", "NO") => self.bigtiff = BigTiff::No,
            // Sizes are judged uncompressed, so "if safer" is "if needed" here.
            ("BIGTIFF", "IF_NEEDED" | "IF_SAFER") => self.bigtiff = BigTiff::IfNeeded,
            ("COG", "YES" | "TRUE" | "ON") => (self.cog, self.tiled) = (true, true),
            ("COG", "NO" | "FALSE" | "OFF") => self.cog = false,
            _ => {
                return Err(format!(
                    "unsupported creation option '{option}'; supported: TILED=YES|NO, COMPRESS=NONE|DEFLATE|ZSTD, PREDICTOR=NO|STANDARD|FLOATING_POINT|YES (or 1|2|3), BIGTIFF=YES|NO|IF_NEEDED, COG=YES|NO"
                ));
            }
        }
        Ok(())
    }

    /// Apply an output format as gdal_translate names them (`-of GTiff`, `-of COG`).
    pub fn apply_format(&mut self, format: &str) -> Result<(), String> {
        match format.to_ascii_uppercase().as_str() {
            "GTIFF" => self.apply("COG=NO"),
            "COG" => self.apply("COG=YES"),
            _ => Err(format!("output format '{format}' is not supported; supported: GTiff, COG")),
        }
    }

    /// Whether the options can write a file of `sample`s: [`GeoTiffWriter::create`] refuses
    /// them otherwise.
    pub fn check(&self, sample: Sample) -> Result<(), GeoTiffOptionError> {
        if self.cog && !self.tiled {
            return Err(GeoTiffOptionError::CogWithoutTiles);
        }
        match self.predictor.tag(sample)? {
            1 => Ok(()),
            predictor if self.compress == Compression::None => Err(GeoTiffOptionError::PredictorWithoutCompression { predictor }),
            _ => Ok(()),
        }
    }
}

/// The EPSG code of `--a_srs` (`EPSG:32633`, case-insensitive).
pub fn parse_epsg(srs: &str) -> Result<u16, String> {
    let code = srs
        .trim()
        .strip_prefix("EPSG:")
        .or_else(|| srs.trim().strip_prefix("epsg:"))
        .ok_or_else(|| format!("'{srs}': only EPSG codes are supported as a CRS (for example EPSG:32633 or EPSG:4326)"))?;
    match code.parse::<u32>() {
        Ok(n) if (1024..=32766).contains(&n) => Ok(n as u16),
        Ok(n) => Err(format!("EPSG:{n} is outside the codes GeoTIFF's keys hold (1024 to 32766)")),
        Err(_) => Err(format!("'{code}' in '{srs}' is not an EPSG code number")),
    }
}

/// The GeoKey directory: version 1.1.0, the model type, PixelIsArea, and the CRS if given.
/// EPSG codes 4000–4999 are geographic CRSs (GeographicTypeGeoKey); all others are written
/// as projected ones (ProjectedCSTypeGeoKey).
fn geo_keys(epsg: Option<u16>) -> Vec<u16> {
    const MODEL_TYPE: u16 = 1024;
    const RASTER_TYPE: u16 = 1025;
    const GEOGRAPHIC_TYPE: u16 = 2048;
    const PROJECTED_TYPE: u16 = 3072;
    const PIXEL_IS_AREA: u16 = 1;
    match epsg {
        // No CRS: GTModelTypeGeoKey = user-defined.
        None => vec![1, 1, 0, 2, MODEL_TYPE, 0, 1, 32767, RASTER_TYPE, 0, 1, PIXEL_IS_AREA],
        Some(code) if (4000..5000).contains(&code) => vec![1, 1, 0, 3, MODEL_TYPE, 0, 1, 2, RASTER_TYPE, 0, 1, PIXEL_IS_AREA, GEOGRAPHIC_TYPE, 0, 1, code],
        Some(code) => vec![1, 1, 0, 3, MODEL_TYPE, 0, 1, 1, RASTER_TYPE, 0, 1, PIXEL_IS_AREA, PROJECTED_TYPE, 0, 1, code],
    }
}

/// Write a raster as a single-band Float32 GeoTIFF with the geotransform `gdal_grid` writes
/// for the same grid (north-up, row 0 at the top of the window) and the `GDAL_NODATA` tag.
pub fn write_geotiff(raster: &Raster, path: &Path) -> Result<(), IoError> {
    write_geotiff_with(raster, path, &GeoTiffOptions::default())
}

/// [`write_geotiff`] with a CRS, tiles, compression, a predictor, COG layout or BigTIFF.
pub fn write_geotiff_with(raster: &Raster, path: &Path, options: &GeoTiffOptions) -> Result<(), IoError> {
    let mut file = GeoTiffWriter::create(path, &raster.grid, raster.window, Sample::Float32 { nodata: raster.nodata }, options)?;
    file.write_rows(&raster.values)?;
    file.finish()
}

/// What each cell of a file holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sample {
    /// Heights, with the value of cells no triangle covers.
    Float32 { nodata: f32 },
    /// Owner triangles' indices; `u32::MAX` where there is none (the nodata value).
    UInt32,
}

impl Sample {
    fn nodata_bytes(self) -> [u8; 4] {
        match self {
            Sample::Float32 { nodata } => nodata.to_le_bytes(),
            Sample::UInt32 => u32::MAX.to_le_bytes(),
        }
    }

    /// The nodata value as GDAL writes it: the shortest text that reads back to the value.
    fn nodata_text(self) -> String {
        match self {
            Sample::Float32 { nodata } if nodata.is_nan() => "nan".into(),
            Sample::Float32 { nodata } => format!("{nodata}"),
            Sample::UInt32 => u32::MAX.to_string(),
        }
    }

    /// TIFF's SampleFormat: 3 IEEE floating point, 1 unsigned integer.
    fn format(self) -> u16 {
        match self {
            Sample::Float32 { .. } => 3,
            Sample::UInt32 => 1,
        }
    }
}

/// How a file's blocks are coded: the samples, the predictor (TIFF's tag value) and the
/// compression.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Coding {
    pub(crate) sample: Sample,
    predictor: u16,
    compression: Compression,
}

impl Coding {
    /// A block row of a `width`-sample image (`TILE` rows, or fewer at its foot, for tiles),
    /// as the file holds its blocks: cut into tiles padded with nodata (or one strip),
    /// predicted and compressed, the blocks in parallel.
    pub(crate) fn blocks<'a>(&self, block_row: &'a [u8], width: u32, tiled: bool) -> Vec<Cow<'a, [u8]>> {
        let row_bytes = width as usize * 4;
        if !tiled {
            return vec![self.encode(Cow::Borrowed(block_row), row_bytes)];
        }
        let pad = self.sample.nodata_bytes();
        let across = width.div_ceil(TILE) as usize;
        (0..across).into_par_iter().map(|tx| self.encode(Cow::Owned(tile(block_row, row_bytes, tx, pad)), TILE as usize * 4)).collect()
    }

    /// A block of rows of `row_bytes`, predicted, then compressed.
    fn encode<'a>(&self, block: Cow<'a, [u8]>, row_bytes: usize) -> Cow<'a, [u8]> {
        let block = match self.predictor {
            1 => block,
            predictor => {
                let mut block = block.into_owned();
                predict(&mut block, row_bytes, predictor);
                Cow::Owned(block)
            }
        };
        match self.compression {
            Compression::None => block,
            Compression::Deflate => Cow::Owned(deflate(&block)),
            Compression::Zstd => Cow::Owned(zstd(&block)),
        }
    }
}

/// A GeoTIFF written a band of rows at a time, top to bottom, through a [`PartialFile`]:
/// [`finish`](Self::finish) puts it in place; a writer dropped before that leaves nothing.
pub struct GeoTiffWriter {
    file: PartialFile,
    /// Bytes written so far: where the next block starts.
    position: u64,
    big: bool,
    width: u32,
    height: u32,
    /// Rows handed to the writer, including those still in `pending`.
    rows_in: u32,
    /// Rows of a block row not yet complete.
    pending: Vec<u8>,
    block: Block,
    coding: Coding,
    /// A COG's tiles and overviews until `finish` lays them out.
    cog: Option<Cog>,
    offsets: Vec<u64>,
    counts: Vec<u64>,
    /// The georeferencing tags, ready to write.
    scale: [f64; 3],
    tiepoint: [f64; 6],
    keys: Vec<u16>,
}

/// How the image is cut into blocks.
#[derive(Debug, Clone, Copy)]
enum Block {
    /// `TILE` × `TILE` tiles, edge tiles padded with nodata.
    Tiles,
    /// Strips of whole rows, about 8 KiB each as GDAL cuts them.
    Strips { rows: u32 },
}

impl Block {
    fn rows(self) -> u32 {
        match self {
            Block::Tiles => TILE,
            Block::Strips { rows } => rows,
        }
    }
}

/// Classic TIFF's offsets are 32-bit; what the IFD and its arrays may need past the data.
const CLASSIC_LIMIT: u64 = u32::MAX as u64;

impl GeoTiffWriter {
    /// Start a file for `window` of `grid`: georeferenced to the window's own top-left corner.
    /// Options that do not go together, or not with `sample`, are refused
    /// ([`GeoTiffOptions::check`]) before any file is made.
    pub fn create(path: &Path, grid: &Grid, window: Window, sample: Sample, options: &GeoTiffOptions) -> Result<Self, IoError> {
        let (width, height) = (window.width, window.height);
        let format = |message: String| IoError::Format { path: path.to_owned(), message };
        if width == 0 || height == 0 {
            return Err(format(format!("a {width}×{height} image has no cells to write")));
        }
        options.check(sample).map_err(|source| IoError::Options { path: path.to_owned(), source })?;
        let predictor = options.predictor.tag(sample).map_err(|source| IoError::Options { path: path.to_owned(), source })?;
        let row_bytes = width as u64 * 4;
        let block = match options.tiled {
            true => Block::Tiles,
            false => Block::Strips { rows: (8192 / row_bytes).clamp(1, TILE as u64) as u32 },
        };
        let (across, down) = match block {
            Block::Tiles => (width.div_ceil(TILE) as u64, height.div_ceil(TILE) as u64),
            Block::Strips { rows } => (1, height.div_ceil(rows) as u64),
        };
        // Uncompressed data (tiles padded, a COG's overviews too), the compressor's worst
        // case, and per block its offsets and (in a COG) its leader and trailer.
        let (blocks, data, extra) = match (block, options.cog) {
            (Block::Tiles, true) => {
                let levels = cog::levels(width, height);
                let tiles: u64 = levels.iter().map(|&(w, h)| cog::tiles(w, h)).sum();
                (tiles, tiles * (TILE as u64 * TILE as u64 * 4), tiles * 8 + levels.len() as u64 * 1024)
            }
            (Block::Tiles, false) => (across * down, across * down * (TILE as u64 * TILE as u64 * 4), 0),
            (Block::Strips { .. }, _) => (across * down, row_bytes * height as u64, 0),
        };
        let worst = match options.compress {
            Compression::Zstd => data / 256,
            Compression::None | Compression::Deflate => data / 1000,
        };
        let bound = data + worst + blocks * (64 + 16) + extra + 4096;
        let big = match options.bigtiff {
            BigTiff::Yes => true,
            BigTiff::IfNeeded => bound > CLASSIC_LIMIT,
            BigTiff::No if bound > CLASSIC_LIMIT && options.compress == Compression::None => {
                return Err(format(format!("{data} bytes of image do not fit a classic TIFF (4 GiB); allow BigTIFF (-co BIGTIFF=IF_NEEDED or YES)")));
            }
            BigTiff::No => false,
        };
        let (dx, dy) = (grid.dx(), grid.dy());
        let file = PartialFile::create(path)?;
        let cog = match options.cog {
            true => Some(Cog::create(path, width, height)?),
            false => None,
        };
        let mut writer = GeoTiffWriter {
            file,
            position: 0,
            big,
            width,
            height,
            rows_in: 0,
            pending: Vec::new(),
            block,
            coding: Coding { sample, predictor, compression: options.compress },
            cog,
            offsets: Vec::with_capacity(if options.cog { 0 } else { (across * down) as usize }),
            counts: Vec::with_capacity(if options.cog { 0 } else { (across * down) as usize }),
            scale: [dx, dy, 0.0],
            tiepoint: [0.0, 0.0, 0.0, grid.xmin + window.x0 as f64 * dx, grid.ymax - window.y0 as f64 * dy, 0.0],
            keys: geo_keys(options.epsg),
        };
        // The header; the first IFD's offset is filled in by `finish`, which writes all of a
        // COG.
        if writer.cog.is_none() {
            writer.put(writer.header(0).as_slice())?;
        }
        Ok(writer)
    }

    /// Whether the file is BigTIFF.
    pub fn is_bigtiff(&self) -> bool {
        self.big
    }

    /// The next rows of the image, top to bottom: whole rows of `width` samples (`f32` for a
    /// Float32 file, `u32` for UInt32), any number of them per call.
    pub fn write_rows<T: bytemuck::Pod>(&mut self, rows: &[T]) -> Result<(), IoError> {
        if std::mem::size_of::<T>() != 4 || !rows.len().is_multiple_of(self.width as usize) {
            return Err(self.error(format!("{} samples of {} bytes are not whole rows of {} 4-byte cells", rows.len(), std::mem::size_of::<T>(), self.width)));
        }
        let count = (rows.len() / self.width as usize) as u64;
        if self.rows_in as u64 + count > self.height as u64 {
            return Err(self.error(format!("{count} more rows after {} of {}: more rows than the image has", self.rows_in, self.height)));
        }
        self.rows_in += count as u32;
        let mut bytes: &[u8] = bytemuck::cast_slice(rows);
        let block_bytes = self.block.rows() as usize * self.width as usize * 4;
        if !self.pending.is_empty() {
            let take = (block_bytes - self.pending.len()).min(bytes.len());
            self.pending.extend_from_slice(&bytes[..take]);
            bytes = &bytes[take..];
            if self.pending.len() == block_bytes {
                let pending = std::mem::take(&mut self.pending);
                self.write_blocks(&pending)?;
            }
        }
        let whole = bytes.len() / block_bytes * block_bytes;
        self.write_blocks(&bytes[..whole])?;
        self.pending.extend_from_slice(&bytes[whole..]);
        Ok(())
    }

    /// Write the last blocks and the directory (a COG: all of it), make the file durable,
    /// and rename it into place. Refused unless every row has been written.
    pub fn finish(mut self) -> Result<(), IoError> {
        if self.rows_in != self.height {
            return Err(self.error(format!("only {} of {} rows were written", self.rows_in, self.height)));
        }
        let pending = std::mem::take(&mut self.pending);
        self.write_blocks(&pending)?;
        match self.cog.take() {
            Some(cog) => self.write_cog(cog)?,
            None => self.write_directory()?,
        }
        self.file.commit()
    }

    fn error(&self, message: String) -> IoError {
        IoError::Format { path: self.file.path().to_owned(), message }
    }

    fn put(&mut self, bytes: &[u8]) -> Result<(), IoError> {
        self.file.out().write_all(bytes).map_err(|source| IoError::Io { path: self.file.path().to_owned(), source })?;
        self.position += bytes.len() as u64;
        if !self.big && self.position > CLASSIC_LIMIT {
            return Err(self.error("the file passes the 4 GiB a classic TIFF can address; allow BigTIFF (-co BIGTIFF=YES)".into()));
        }
        Ok(())
    }

    /// The header, pointing at the first IFD.
    fn header(&self, ifd: u64) -> Vec<u8> {
        match self.big {
            true => [&[b'I', b'I', 43, 0, 8, 0, 0, 0][..], &ifd.to_le_bytes()].concat(),
            false => [&[b'I', b'I', 42, 0][..], &(ifd as u32).to_le_bytes()].concat(),
        }
    }

    /// Whole block rows (or the image's last, shorter one), as blocks.
    fn write_blocks(&mut self, rows: &[u8]) -> Result<(), IoError> {
        let row_bytes = self.width as usize * 4;
        let block_bytes = self.block.rows() as usize * row_bytes;
        if rows.is_empty() {
            return Ok(());
        }
        if let Some(cog) = &mut self.cog {
            for block_row in rows.chunks(block_bytes) {
                cog.block_row(0, block_row, &self.coding)?;
            }
            return Ok(());
        }
        if let (Block::Strips { .. }, Compression::None) = (self.block, self.coding.compression) {
            // Uncompressed strips are the rows themselves: one write for all of them.
            for strip in rows.chunks(block_bytes) {
                self.offsets.push(self.position + (strip.as_ptr() as usize - rows.as_ptr() as usize) as u64);
                self.counts.push(strip.len() as u64);
            }
            return self.put(rows);
        }
        for block_row in rows.chunks(block_bytes) {
            for data in self.coding.blocks(block_row, self.width, matches!(self.block, Block::Tiles)) {
                self.offsets.push(self.position);
                self.counts.push(data.len() as u64);
                self.put(&data)?;
            }
        }
        Ok(())
    }

    /// The directory entries of the image (`overview` false) or of an overview: its size,
    /// blocks, coding and nodata; the image's also its georeferencing.
    fn entries(&self, overview: bool, (width, height): (u32, u32), offsets: &[u64], counts: &[u64]) -> Vec<(u16, Field)> {
        const SHORT: u16 = 3;
        const LONG: u16 = 4;
        const ASCII: u16 = 2;
        const DOUBLE: u16 = 12;
        const LONG8: u16 = 16;
        let shorts = |v: &[u16]| (SHORT, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        let long = |v: u32| (LONG, 1, v.to_le_bytes().to_vec());
        let doubles = |v: &[f64]| (DOUBLE, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        let words = |v: &[u64]| match self.big {
            true => (LONG8, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>()),
            false => (LONG, v.len() as u64, v.iter().flat_map(|&x| (x as u32).to_le_bytes()).collect()),
        };
        let mut nodata = self.coding.sample.nodata_text().into_bytes();
        nodata.push(0);
        let mut entries: Vec<(u16, Field)> = vec![
            (256, long(width)),
            (257, long(height)),
            (258, shorts(&[32])),
            (259, shorts(&[self.coding.compression.tag()])),
            (262, shorts(&[1])), // BlackIsZero
            (277, shorts(&[1])),
            (284, shorts(&[1])), // one plane
            (339, shorts(&[self.coding.sample.format()])),
            (42113, (ASCII, nodata.len() as u64, nodata)),
        ];
        match overview {
            // NewSubfileType: a reduced-resolution image.
            true => entries.push((254, long(1))),
            false => entries.extend([(33550, doubles(&self.scale)), (33922, doubles(&self.tiepoint)), (34735, shorts(&self.keys))]),
        }
        if self.coding.predictor != 1 {
            entries.push((317, shorts(&[self.coding.predictor])));
        }
        match self.block {
            Block::Tiles => entries.extend([(322, long(TILE)), (323, long(TILE)), (324, words(offsets)), (325, words(counts))]),
            Block::Strips { rows } => entries.extend([(273, words(offsets)), (278, long(rows)), (279, words(counts))]),
        }
        entries.sort_by_key(|e| e.0);
        entries
    }

    /// The image file directory after the data, then its offset into the header.
    fn write_directory(&mut self) -> Result<(), IoError> {
        let entries = self.entries(false, (self.width, self.height), &self.offsets, &self.counts);
        let align = self.position.next_multiple_of(8) - self.position;
        self.put(&vec![0u8; align as usize])?;
        let ifd = self.position;
        self.put(&directory(&entries, ifd, self.big, 0, &[]))?;
        let path = self.file.path().to_owned();
        let io = |source| IoError::Io { path, source };
        let at: Vec<u8> = if self.big { ifd.to_le_bytes().to_vec() } else { (ifd as u32).to_le_bytes().to_vec() };
        let out = self.file.out();
        out.seek(SeekFrom::Start(if self.big { 8 } else { 4 })).and_then(|_| out.write_all(&at)).map_err(io)?;
        Ok(())
    }

    /// A COG, all of it (see the `cog` module): the header, the ghost area, every level's
    /// IFD, the tile arrays that do not fit their IFD, then the tiles from the spill.
    fn write_cog(&mut self, mut cog: Cog) -> Result<(), IoError> {
        cog.flush(&self.coding)?;
        let sizes = cog.sizes().to_vec();
        let counts = cog.byte_counts();
        let (word, inline) = if self.big { (8u64, 8u64) } else { (4, 4) };
        let ghost = cog::ghost();
        let first = (self.header(0).len() as u64 + ghost.len() as u64).next_multiple_of(2);
        let counts_of = |k: usize| counts[k].len() as u64;
        let elsewhere = |k: usize, offsets: u64, counts: u64| match counts_of(k) * word > inline {
            true => vec![(324, offsets), (325, counts)],
            false => vec![],
        };
        // Where each IFD goes: their sizes do not depend on the offsets they hold.
        let mut ifds = vec![first];
        for (k, &size) in sizes.iter().enumerate() {
            let entries = self.entries(k > 0, size, &vec![0; counts[k].len()], &counts[k]);
            let at = ifds[k] + directory(&entries, 0, self.big, 0, &elsewhere(k, 0, 0)).len() as u64;
            ifds.push(at);
        }
        // Then the arrays, offsets and byte counts of each level in turn, then the tiles.
        let mut at = ifds.pop().expect("one IFD per level");
        let mut arrays = Vec::new();
        for k in 0..sizes.len() {
            let bytes = counts_of(k) * word;
            arrays.push(if bytes > inline { (at, at + bytes) } else { (0, 0) });
            at += if bytes > inline { 2 * bytes } else { 0 };
        }
        let mut offsets = vec![Vec::new(); sizes.len()];
        for k in (0..sizes.len()).rev() {
            for &count in &counts[k] {
                offsets[k].push(at + 4);
                at += 4 + count + 4;
            }
        }
        if !self.big && at > CLASSIC_LIMIT {
            return Err(self.error(format!("the COG's {at} bytes pass the 4 GiB a classic TIFF can address; allow BigTIFF (-co BIGTIFF=YES)")));
        }
        self.put(&self.header(first))?;
        self.put(&ghost)?;
        self.put(&vec![0u8; (first - self.position) as usize])?;
        for (k, &size) in sizes.iter().enumerate() {
            let entries = self.entries(k > 0, size, &offsets[k], &counts[k]);
            let next = ifds.get(k + 1).copied().unwrap_or(0);
            debug_assert_eq!(self.position, ifds[k]);
            self.put(&directory(&entries, ifds[k], self.big, next, &elsewhere(k, arrays[k].0, arrays[k].1)))?;
        }
        for k in 0..sizes.len() {
            if arrays[k].0 != 0 {
                debug_assert_eq!(self.position, arrays[k].0);
                for array in [&offsets[k], &counts[k]] {
                    let bytes: Vec<u8> = match self.big {
                        true => array.iter().flat_map(|x| x.to_le_bytes()).collect(),
                        false => array.iter().flat_map(|&x| (x as u32).to_le_bytes()).collect(),
                    };
                    self.put(&bytes)?;
                }
            }
        }
        // Each tile led by its byte count and trailed by its last 4 bytes again.
        cog.copy_tiles(|tile| {
            let last = &tile[tile.len().saturating_sub(4)..];
            self.put(&(tile.len() as u32).to_le_bytes())?;
            self.put(tile)?;
            self.put(&[last, &[0u8; 4][..4 - last.len()]].concat())
        })?;
        debug_assert_eq!(self.position, at);
        Ok(())
    }
}

/// A directory entry's value: its TIFF type, count and little-endian bytes.
type Field = (u16, u64, Vec<u8>);

/// An image file directory to be written at `at`, pointing at the `next` (0: none): its
/// table, then the values too long to sit in it, each on a word boundary, but for the tags
/// whose values are `elsewhere` (at the offset given there).
fn directory(entries: &[(u16, Field)], at: u64, big: bool, next: u64, elsewhere: &[(u16, u64)]) -> Vec<u8> {
    // Classic: 2-byte count, 12-byte entries with 4 bytes inline, 4-byte next offset.
    // BigTIFF: 8-byte count, 20-byte entries with 8 bytes inline, 8-byte next offset.
    let (count_bytes, inline, entry, word) = if big { (8u64, 8usize, 20u64, 8u64) } else { (2, 4, 12, 4) };
    let values_at = at + count_bytes + entries.len() as u64 * entry + word;
    let mut table = Vec::new();
    let mut values = Vec::new();
    let put_word = |table: &mut Vec<u8>, v: u64| match big {
        true => table.extend(v.to_le_bytes()),
        false => table.extend((v as u32).to_le_bytes()),
    };
    table.extend(&(entries.len() as u64).to_le_bytes()[..count_bytes as usize]);
    for (tag, (kind, count, bytes)) in entries {
        table.extend(tag.to_le_bytes());
        table.extend(kind.to_le_bytes());
        put_word(&mut table, *count);
        if bytes.len() <= inline {
            table.extend(bytes);
            table.extend(std::iter::repeat_n(0u8, inline - bytes.len()));
        } else if let Some(&(_, there)) = elsewhere.iter().find(|(t, _)| t == tag) {
            put_word(&mut table, there);
        } else {
            put_word(&mut table, values_at + values.len() as u64);
            values.extend(bytes);
            values.resize(values.len().next_multiple_of(2), 0);
        }
    }
    put_word(&mut table, next);
    debug_assert_eq!(at + table.len() as u64, values_at);
    table.extend(values);
    table
}

/// Tile `tx` of a block row of `TILE` rows (fewer at the image's foot), padded with nodata.
fn tile(block_row: &[u8], row_bytes: usize, tx: usize, pad: [u8; 4]) -> Vec<u8> {
    let line = TILE as usize * 4;
    let size = line * TILE as usize;
    let mut tile = Vec::with_capacity(size);
    let x0 = tx * line;
    for row in block_row.chunks(row_bytes) {
        let inside = &row[x0..(x0 + line).min(row_bytes)];
        tile.extend_from_slice(inside);
        for _ in 0..(line - inside.len()) / 4 {
            tile.extend_from_slice(&pad);
        }
    }
    while tile.len() < size {
        tile.extend_from_slice(&pad);
    }
    tile
}

/// libtiff's predictor `predictor` (2 or 3) on each row of `row_bytes` of a block, in place.
fn predict(block: &mut [u8], row_bytes: usize, predictor: u16) {
    let mut planes = Vec::new();
    for row in block.chunks_exact_mut(row_bytes) {
        match predictor {
            // horDiff32: each sample minus the one before, from the end.
            2 => {
                for i in (1..row.len() / 4).rev() {
                    let [a, b] = [i - 1, i].map(|k| u32::from_le_bytes(row[4 * k..4 * k + 4].try_into().expect("4 bytes")));
                    row[4 * i..4 * i + 4].copy_from_slice(&b.wrapping_sub(a).to_le_bytes());
                }
            }
            // fpDiff: the samples' bytes in planes, the most significant first, then each
            // byte minus the one before it across the whole row, from the end.
            3 => {
                let n = row.len() / 4;
                planes.clear();
                planes.resize(row.len(), 0);
                for (i, sample) in row.as_chunks::<4>().0.iter().enumerate() {
                    for (b, &byte) in sample.iter().enumerate() {
                        planes[(3 - b) * n + i] = byte;
                    }
                }
                row.copy_from_slice(&planes);
                for i in (1..row.len()).rev() {
                    row[i] = row[i].wrapping_sub(row[i - 1]);
                }
            }
            _ => unreachable!("predictor {predictor}"),
        }
    }
}

/// zlib-wrapped deflate (TIFF's compression 8) at GDAL's default `ZLEVEL`, 6, by libdeflate,
/// as GDAL builds use it: several times faster than a streaming deflater.
fn deflate(data: &[u8]) -> Vec<u8> {
    let mut compressor = libdeflater::Compressor::new(libdeflater::CompressionLvl::new(6).expect("6 is a valid level"));
    let mut packed = vec![0; compressor.zlib_compress_bound(data.len())];
    let size = compressor.zlib_compress(data, &mut packed).expect("the bound holds the output");
    packed.truncate(size);
    packed
}

/// Zstandard at GDAL's default `ZSTD_LEVEL`.
fn zstd(data: &[u8]) -> Vec<u8> {
    zstd::bulk::compress(data, 9).expect("compressing into a Vec cannot fail")
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::process::Command;
    use tiff::decoder::{Decoder, DecodingResult};
    use tiff::tags::Tag;

    fn raster(w: u32, h: u32) -> Raster {
        let grid = Grid::new(500_000.0, 500_000.0 + w as f64, 5_000_000.0, 5_000_000.0 + h as f64, w, h);
        let values = (0..w * h).map(|k| if k % 7 == 0 { -9999.0 } else { k as f32 * 0.25 }).collect();
        Raster {
            grid,
            window: Window::whole(&grid),
            nodata: -9999.0,
            values,
            owner: None,
            coverage: None,
            colours: None,
            faces: None,
            tiles: None,
            snap_bits: 16,
            stats: Default::default(),
        }
    }

    struct Read {
        values: DecodingResult,
        keys: Vec<u16>,
        tile: Option<u32>,
        compression: u16,
        tiepoint: Vec<f64>,
        nodata: String,
    }

    fn read(path: &Path) -> Read {
        let mut d = Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap())).unwrap();
        Read {
            keys: d.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap(),
            tile: d.find_tag(Tag::TileWidth).unwrap().map(|v| v.into_u32().unwrap()),
            compression: d.get_tag_u32(Tag::Compression).unwrap() as u16,
            tiepoint: d.get_tag_f64_vec(Tag::ModelTiepointTag).unwrap(),
            nodata: d.get_tag_ascii_string(Tag::GdalNodata).unwrap().trim_end_matches('\0').to_string(),
            values: d.read_image().unwrap(),
        }
    }

    fn f32s(r: &Read) -> &[f32] {
        match &r.values {
            DecodingResult::F32(v) => v,
            _ => panic!("not Float32"),
        }
    }

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("tileraster-geotiff-{}-{name}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    fn all_options() -> Vec<GeoTiffOptions> {
        use {Compression as C, Predictor as P};
        let mut all = Vec::new();
        for bigtiff in [BigTiff::IfNeeded, BigTiff::Yes] {
            for (tiled, compress, predictor, cog) in [
                (false, C::None, P::None, false),
                (true, C::None, P::None, false),
                (false, C::Deflate, P::None, false),
                (true, C::Deflate, P::None, false),
                (false, C::Zstd, P::FloatingPoint, false),
                (true, C::Deflate, P::Horizontal, false),
                (true, C::None, P::None, true),
                (true, C::Zstd, P::Yes, true),
            ] {
                all.push(GeoTiffOptions { tiled, compress, predictor, cog, bigtiff, epsg: [None, Some(32633), Some(4326)][all.len() % 3] });
            }
        }
        all
    }

    #[test]
    fn tiles_strips_compression_bigtiff_and_crs_keep_every_value() {
        let dir = scratch("options");
        let r = raster(600, 300); // edge tiles on both sides
        for (k, options) in all_options().into_iter().enumerate() {
            let path = dir.join(format!("{k}.tif"));
            write_geotiff_with(&r, &path, &options).unwrap();
            let back = read(&path);
            assert_eq!(f32s(&back).len(), r.values.len(), "{options:?}");
            assert!(f32s(&back).iter().zip(&r.values).all(|(a, b)| a.to_bits() == b.to_bits()), "{options:?}");
            assert_eq!(back.tile, options.tiled.then_some(TILE), "{options:?}");
            assert_eq!(back.compression, options.compress.tag(), "{options:?}");
            assert_eq!(back.keys, geo_keys(options.epsg), "{options:?}");
            assert_eq!(back.tiepoint, vec![0.0, 0.0, 0.0, 500_000.0, 5_000_300.0, 0.0]);
            assert_eq!(back.nodata, "-9999");
            let magic = std::fs::read(&path).unwrap()[2];
            assert_eq!(magic, if options.bigtiff == BigTiff::Yes { 43 } else { 42 }, "{options:?}");
        }
        // 32633 is projected, 4326 geographic.
        assert_eq!(&geo_keys(Some(32633))[12..], &[3072, 0, 1, 32633]);
        assert_eq!(&geo_keys(Some(4326))[12..], &[2048, 0, 1, 4326]);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn bands_of_any_height_give_the_same_file_as_one_write() {
        let dir = scratch("bands");
        let r = raster(300, 530);
        let owner: Vec<u32> = (0..300 * 530).map(|k| if k % 5 == 0 { u32::MAX } else { k * 3 }).collect();
        for (k, options) in all_options().into_iter().enumerate() {
            for sample in [Sample::Float32 { nodata: r.nodata }, Sample::UInt32] {
                if options.check(sample).is_err() {
                    continue;
                }
                let write = |path: &Path, band: usize| {
                    let mut w = GeoTiffWriter::create(path, &r.grid, r.window, sample, &options).unwrap();
                    match sample {
                        Sample::Float32 { .. } => r.values.chunks(band * 300).try_for_each(|rows| w.write_rows(rows)).unwrap(),
                        Sample::UInt32 => owner.chunks(band * 300).try_for_each(|rows| w.write_rows(rows)).unwrap(),
                    }
                    w.finish().unwrap();
                };
                let whole = dir.join(format!("whole-{k}.tif"));
                write(&whole, 530);
                for band in [1usize, 7, 256, 300, 529] {
                    let banded = dir.join(format!("banded-{k}-{band}.tif"));
                    write(&banded, band);
                    assert!(std::fs::read(&whole).unwrap() == std::fs::read(&banded).unwrap(), "{options:?} {sample:?}, bands of {band} rows");
                }
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn owner_files_are_uint32_with_their_nodata() {
        let dir = scratch("owner");
        let r = raster(70, 40);
        let owner: Vec<u32> = (0..70 * 40).map(|k| if k % 5 == 0 { u32::MAX } else { k * 3 }).collect();
        for options in [GeoTiffOptions::default(), GeoTiffOptions { tiled: true, compress: Compression::Deflate, ..Default::default() }] {
            let path = dir.join("owner.tif");
            let mut w = GeoTiffWriter::create(&path, &r.grid, r.window, Sample::UInt32, &options).unwrap();
            w.write_rows(&owner).unwrap();
            w.finish().unwrap();
            let back = read(&path);
            assert_eq!(back.nodata, "4294967295");
            let DecodingResult::U32(values) = back.values else { panic!("not UInt32") };
            assert_eq!(values, owner, "{options:?}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn a_window_is_georeferenced_to_its_corner() {
        let dir = scratch("window");
        let grid = Grid::new(100.0, 200.0, 0.0, 50.0, 100, 50);
        let window = Window { x0: 10, y0: 20, width: 30, height: 5 };
        let path = dir.join("w.tif");
        let mut w = GeoTiffWriter::create(&path, &grid, window, Sample::Float32 { nodata: f32::NAN }, &GeoTiffOptions::default()).unwrap();
        w.write_rows(&[1.5f32; 150]).unwrap();
        w.finish().unwrap();
        let back = read(&path);
        assert_eq!(back.tiepoint, vec![0.0, 0.0, 0.0, 110.0, 30.0, 0.0]);
        assert_eq!(back.nodata, "nan");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn wrong_rows_are_refused_and_leave_no_file() {
        let dir = scratch("refused");
        let r = raster(10, 10);
        let path = dir.join("x.tif");
        // The partial file beside the destination, whatever its name.
        let files = || std::fs::read_dir(&dir).unwrap().count();
        let options = GeoTiffOptions::default();
        let create = || GeoTiffWriter::create(&path, &r.grid, r.window, Sample::Float32 { nodata: 0.0 }, &options).unwrap();
        let mut w = create();
        assert!(w.write_rows(&[0f32; 15]).unwrap_err().to_string().contains("not whole rows of 10"));
        assert!(w.write_rows(&[0f64; 10]).unwrap_err().to_string().contains("8 bytes"));
        assert!(w.write_rows(&[0f32; 110]).unwrap_err().to_string().contains("more rows than the image has"));
        w.write_rows(&[0f32; 50]).unwrap();
        assert!(files() == 1 && !path.exists());
        assert!(w.finish().unwrap_err().to_string().contains("only 5 of 10 rows"));
        assert_eq!(files(), 0);
        let w = create();
        drop(w);
        assert_eq!(files(), 0);
        // Too large for a classic TIFF when BigTIFF is refused: said before anything is written.
        let huge = Grid::new(0.0, 1.0, 0.0, 1.0, 40_000, 40_000);
        let no = GeoTiffOptions { bigtiff: BigTiff::No, ..Default::default() };
        let e = GeoTiffWriter::create(&path, &huge, Window::whole(&huge), Sample::UInt32, &no).err().unwrap().to_string();
        assert!(e.contains("do not fit a classic TIFF") && e.contains("BIGTIFF"), "{e}");
        assert!(GeoTiffWriter::create(&path, &huge, Window::whole(&huge), Sample::UInt32, &GeoTiffOptions::default()).unwrap().is_bigtiff());
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn options_and_crs_are_checked() {
        assert_eq!(parse_epsg("EPSG:32633"), Ok(32633));
        assert_eq!(parse_epsg("epsg:4326"), Ok(4326));
        assert!(parse_epsg("+proj=utm +zone=33").unwrap_err().contains("only EPSG codes"));
        assert!(parse_epsg("EPSG:900913").unwrap_err().contains("outside the codes"));
        assert!(parse_epsg("EPSG:abc").unwrap_err().contains("not an EPSG code number"));
        let mut o = GeoTiffOptions::default();
        o.apply("tiled=yes").unwrap();
        o.apply("COMPRESS=DEFLATE").unwrap();
        o.apply("BIGTIFF=YES").unwrap();
        assert_eq!(o, GeoTiffOptions { tiled: true, compress: Compression::Deflate, bigtiff: BigTiff::Yes, ..Default::default() });
        o.apply("bigtiff=if_safer").unwrap();
        assert_eq!(o.bigtiff, BigTiff::IfNeeded);
        for (option, predictor) in [
            ("PREDICTOR=2", Predictor::Horizontal),
            ("predictor=floating_point", Predictor::FloatingPoint),
            ("PREDICTOR=YES", Predictor::Yes),
            ("PREDICTOR=NO", Predictor::None),
            ("PREDICTOR=3", Predictor::FloatingPoint),
            ("PREDICTOR=STANDARD", Predictor::Horizontal),
            ("PREDICTOR=1", Predictor::None),
        ] {
            o.apply(option).unwrap();
            assert_eq!(o.predictor, predictor, "{option}");
        }
        o.apply("COMPRESS=ZSTD").unwrap();
        assert_eq!(o.compress, Compression::Zstd);
        let mut cog = GeoTiffOptions::default();
        cog.apply("COG=YES").unwrap();
        assert!(cog.cog && cog.tiled);
        cog.apply_format("GTiff").unwrap();
        assert!(!cog.cog && cog.tiled);
        cog = GeoTiffOptions::default();
        cog.apply_format("cog").unwrap();
        assert_eq!(cog, GeoTiffOptions { cog: true, tiled: true, ..Default::default() });
        assert!(cog.apply_format("PNG").unwrap_err().contains("supported: GTiff, COG"));
        let e = o.apply("COMPRESS=JPEG").unwrap_err();
        assert!(e.contains("unsupported creation option 'COMPRESS=JPEG'"), "{e}");
        for every in ["TILED=YES|NO", "COMPRESS=NONE|DEFLATE|ZSTD", "PREDICTOR=NO|STANDARD|FLOATING_POINT|YES", "BIGTIFF=YES|NO|IF_NEEDED", "COG=YES|NO"] {
            assert!(e.contains(every), "{e} lacks {every}");
        }
        assert!(o.apply("PREDICTOR=4").is_err());
        assert!(o.apply("TILED").unwrap_err().contains("not NAME=VALUE"));
    }

    /// Predictors 2 and 3 byte for byte as libtiff's horDiff32 and fpDiff write them.
    #[test]
    fn predictors_are_libtiffs() {
        let mut row: Vec<u8> = [5u32, 3, 10].iter().flat_map(|x| x.to_le_bytes()).collect();
        predict(&mut row, 12, 2);
        assert_eq!(row, [5u32, 0xffff_fffe, 7].iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        // 1.0 = 3f800000, 2.0 = 40000000: planes [3f 40] [80 00] [00 00] [00 00], differenced;
        // the second row's [40 3f] [00 80] [00 00] [00 00].
        let mut rows: Vec<u8> = [1.0f32, 2.0, 2.0, 1.0].iter().flat_map(|x| x.to_le_bytes()).collect();
        predict(&mut rows, 8, 3);
        assert_eq!(rows, [0x3f, 0x01, 0x40, 0x80, 0, 0, 0, 0, 0x40, 0xff, 0xc1, 0x80, 0x80, 0, 0, 0]);
    }

    /// Heights with nodata cells (a scatter and a block, so some overview cells have none
    /// valid) and NaNs where nodata is NaN.
    fn heights(w: u32, h: u32, nodata: f32) -> Vec<f32> {
        let mut v = Vec::with_capacity((w * h) as usize);
        for y in 0..h {
            for x in 0..w {
                let scattered = (x * 7 + y * 13) % 23 == 0;
                let block = (100..140).contains(&x) && (50..90).contains(&y);
                v.push(if scattered || block { nodata } else { (x as f32 * 0.05).sin() * 40.0 + y as f32 * 0.3 - 17.0 + (x ^ y) as f32 * 1e-3 });
            }
        }
        v
    }

    fn owners(w: u32, h: u32) -> Vec<u32> {
        (0..h).flat_map(|y| (0..w).map(move |x| if (x + 2 * y) % 9 == 0 { u32::MAX } else { x * 31 + y * 7 })).collect()
    }

    /// The overview chain, written plainly: each level from the one above, 2×2 cells (fewer
    /// at odd edges), until a level fits one tile.
    fn reference_f32(values: &[f32], w: u32, h: u32, nodata: f32) -> Vec<(u32, u32, Vec<f32>)> {
        let mut levels = vec![(w, h, values.to_vec())];
        while let Some((w, h, above)) = levels.last().filter(|l| l.0.max(l.1) > 256) {
            let (nw, nh) = (w.div_ceil(2), h.div_ceil(2));
            let mut next = Vec::new();
            for y in 0..nh {
                for x in 0..nw {
                    let (mut sum, mut n) = (0f64, 0);
                    for (dy, dx) in [(0, 0), (0, 1), (1, 0), (1, 1)] {
                        let (sx, sy) = (2 * x + dx, 2 * y + dy);
                        if sx < *w && sy < *h {
                            let v = above[(sy * w + sx) as usize];
                            let is_nodata = if nodata.is_nan() { v.is_nan() } else { v == nodata };
                            if !is_nodata {
                                sum += v as f64;
                                n += 1;
                            }
                        }
                    }
                    next.push(if n == 0 { nodata } else { (sum / n as f64) as f32 });
                }
            }
            levels.push((nw, nh, next));
        }
        levels
    }

    fn reference_u32(values: &[u32], w: u32, h: u32) -> Vec<(u32, u32, Vec<u32>)> {
        let mut levels = vec![(w, h, values.to_vec())];
        while let Some((w, _, above)) = levels.last().filter(|l| l.0.max(l.1) > 256) {
            let (nw, nh) = (w.div_ceil(2), levels.last().unwrap().1.div_ceil(2));
            let next = (0..nh).flat_map(|y| (0..nw).map(move |x| (y, x))).map(|(y, x)| above[(2 * y * w + 2 * x) as usize]).collect();
            levels.push((nw, nh, next));
        }
        levels
    }

    /// An image of a file as the tiff crate reads it: size, NewSubfileType, Compression,
    /// Predictor, the samples' bits.
    type Image = ((u32, u32), u32, u16, u16, Vec<u32>);

    /// Every image of a file.
    fn read_images(path: &Path) -> Vec<Image> {
        let mut d = Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap())).unwrap();
        let mut images = Vec::new();
        loop {
            let size = d.dimensions().unwrap();
            let subfile = d.find_tag(Tag::NewSubfileType).unwrap().map_or(0, |v| v.into_u32().unwrap());
            let compression = d.get_tag_u32(Tag::Compression).unwrap() as u16;
            let predictor = d.find_tag(Tag::Predictor).unwrap().map_or(1, |v| v.into_u32().unwrap() as u16);
            let bits = match d.read_image().unwrap() {
                DecodingResult::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
                DecodingResult::U32(v) => v,
                _ => panic!("neither Float32 nor UInt32"),
            };
            images.push((size, subfile, compression, predictor, bits));
            if !d.more_images() {
                return images;
            }
            d.next_image().unwrap();
        }
    }

    /// What a test writes: its samples' bits at every level (the image's, then the
    /// overviews' a COG holds).
    fn write_case(path: &Path, w: u32, h: u32, sample: Sample, options: &GeoTiffOptions) -> Vec<(u32, u32, Vec<u32>)> {
        let grid = Grid::new(500_000.0, 500_000.0 + w as f64, 5_000_000.0, 5_000_000.0 + h as f64, w, h);
        let mut file = GeoTiffWriter::create(path, &grid, Window::whole(&grid), sample, options).unwrap();
        let levels = match sample {
            Sample::Float32 { nodata } => {
                let values = heights(w, h, nodata);
                file.write_rows(&values).unwrap();
                reference_f32(&values, w, h, nodata).into_iter().map(|(w, h, v)| (w, h, v.iter().map(|x| x.to_bits()).collect())).collect()
            }
            Sample::UInt32 => {
                let values = owners(w, h);
                file.write_rows(&values).unwrap();
                reference_u32(&values, w, h)
            }
        };
        file.finish().unwrap();
        if options.cog { levels } else { levels[..1].to_vec() }
    }

    /// Every layout × compression × predictor × sample type reads back bit for bit, and a
    /// COG's overviews are the reference chain's.
    #[test]
    fn every_layout_compression_predictor_and_sample_reads_back() {
        use {Compression as C, Predictor as P};
        let dir = scratch("combinations");
        let (w, h) = (600, 530); // two overviews, 300×265 and 150×133: odd sizes, edge tiles
        let mut written = 0;
        for (tiled, cog) in [(false, false), (true, false), (true, true)] {
            for compress in [C::None, C::Deflate, C::Zstd] {
                for predictor in [P::None, P::Horizontal, P::FloatingPoint, P::Yes] {
                    for sample in [Sample::Float32 { nodata: -9999.0 }, Sample::Float32 { nodata: f32::NAN }, Sample::UInt32] {
                        let options = GeoTiffOptions { tiled, cog, compress, predictor, ..Default::default() };
                        let Ok(()) = options.check(sample) else { continue };
                        let path = dir.join("case.tif");
                        let expected = write_case(&path, w, h, sample, &options);
                        let images = read_images(&path);
                        assert_eq!(images.len(), expected.len(), "{options:?} {sample:?}");
                        for (k, ((size, subfile, compression, pred, bits), (ew, eh, ebits))) in images.iter().zip(&expected).enumerate() {
                            let what = format!("{options:?} {sample:?}, level {k}");
                            assert_eq!(*size, (*ew, *eh), "{what}");
                            assert_eq!(*subfile, (k > 0) as u32, "{what}");
                            assert_eq!(*compression, compress.tag(), "{what}");
                            assert_eq!(*pred, predictor.tag(sample).unwrap(), "{what}");
                            assert!(bits == ebits, "{what}: values differ");
                        }
                        written += 1;
                    }
                }
            }
        }
        assert_eq!(written, 3 * (3 + 2 * (3 * 4 - 1)), "every valid combination");
        std::fs::remove_dir_all(&dir).ok();
    }

    /// Refused options: typed errors that say how to fix them, before any file is made.
    #[test]
    fn refused_options_are_typed_and_leave_no_file() {
        let dir = scratch("refused-options");
        let grid = Grid::new(0.0, 600.0, 0.0, 300.0, 600, 300);
        let f32s = Sample::Float32 { nodata: -9999.0 };
        let deflate = GeoTiffOptions { compress: Compression::Deflate, ..Default::default() };
        for (sample, options, error, fix) in [
            (
                f32s,
                GeoTiffOptions { predictor: Predictor::Horizontal, ..Default::default() },
                GeoTiffOptionError::PredictorWithoutCompression { predictor: 2 },
                "add -co COMPRESS=DEFLATE",
            ),
            (
                f32s,
                GeoTiffOptions { predictor: Predictor::Yes, cog: true, tiled: true, ..Default::default() },
                GeoTiffOptionError::PredictorWithoutCompression { predictor: 3 },
                "or drop PREDICTOR",
            ),
            (
                Sample::UInt32,
                GeoTiffOptions { predictor: Predictor::FloatingPoint, ..deflate },
                GeoTiffOptionError::FloatingPointPredictorOnUInt32,
                "use PREDICTOR=2",
            ),
            (f32s, GeoTiffOptions { cog: true, ..deflate }, GeoTiffOptionError::CogWithoutTiles, "drop TILED=NO"),
        ] {
            assert_eq!(options.check(sample), Err(error));
            let e = GeoTiffWriter::create(&dir.join("x.tif"), &grid, Window::whole(&grid), sample, &options).err().unwrap();
            assert!(matches!(&e, IoError::Options { source, .. } if *source == error), "{e:?}");
            assert!(e.to_string().contains(fix) && e.to_string().contains("x.tif"), "{e}");
            assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0, "{options:?} left a file");
        }
        // A COG given too few rows, or dropped unfinished, leaves nothing either: its spill
        // has no name.
        let cog = GeoTiffOptions { cog: true, tiled: true, ..deflate };
        let mut w = GeoTiffWriter::create(&dir.join("x.tif"), &grid, Window::whole(&grid), f32s, &cog).unwrap();
        w.write_rows(&heights(600, 290, -9999.0)).unwrap();
        assert!(w.finish().unwrap_err().to_string().contains("only 290 of 300 rows"));
        let mut w = GeoTiffWriter::create(&dir.join("x.tif"), &grid, Window::whole(&grid), f32s, &cog).unwrap();
        w.write_rows(&heights(600, 290, -9999.0)).unwrap();
        drop(w);
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// A COG's overviews count towards the size that decides BigTIFF (IF_NEEDED).
    #[test]
    fn a_cogs_overviews_count_towards_bigtiff() {
        let dir = scratch("cog-bigtiff");
        let path = dir.join("x.tif");
        // 118² tiles of 256 KiB: 3.4 GiB; its overviews add 4691 tiles, 1.1 GiB.
        let grid = Grid::new(0.0, 1.0, 0.0, 1.0, 30_000, 30_000);
        let create = |options: GeoTiffOptions| GeoTiffWriter::create(&path, &grid, Window::whole(&grid), Sample::UInt32, &options).unwrap().is_bigtiff();
        assert!(!create(GeoTiffOptions { tiled: true, ..Default::default() }));
        assert!(create(GeoTiffOptions { tiled: true, cog: true, ..Default::default() }));
        assert!(!create(GeoTiffOptions { tiled: true, cog: true, bigtiff: BigTiff::No, compress: Compression::Deflate, ..Default::default() }));
        assert_eq!(std::fs::read_dir(&dir).unwrap().count(), 0);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// GDAL is there, or the test fails, unless TILERASTER_SKIP_GDAL=1 says to skip it.
    fn gdal() -> bool {
        let runs = |program: &str, args: &[&str]| Command::new(program).args(args).output().is_ok_and(|o| o.status.success());
        if runs("/usr/bin/python3", &["-c", "import osgeo_utils.samples.validate_cloud_optimized_geotiff"])
            && runs("gdalinfo", &["--version"])
            && runs("gdal_translate", &["--version"])
        {
            return true;
        }
        if std::env::var("TILERASTER_SKIP_GDAL").as_deref() == Ok("1") {
            eprintln!("GDAL checks skipped (TILERASTER_SKIP_GDAL=1): gdalinfo, gdal_translate or Python's osgeo_utils is missing");
            return false;
        }
        panic!(
            "GDAL is not installed: this test runs GDAL's COG validator, gdalinfo and gdal_translate on the files written \
             (apt-get install gdal-bin python3-gdal); set TILERASTER_SKIP_GDAL=1 to skip it"
        );
    }

    /// Run a GDAL tool; it must succeed and print nothing on stderr (no warning).
    fn gdal_run(program: &str, args: &[&str]) -> String {
        let out = Command::new(program).args(args).output().unwrap();
        let (stdout, stderr) = (String::from_utf8_lossy(&out.stdout).into_owned(), String::from_utf8_lossy(&out.stderr).into_owned());
        assert!(out.status.success() && stderr.is_empty(), "{program} {args:?}: {}\n{stdout}\n{stderr}", out.status);
        stdout
    }

    /// The bits GDAL reads from `path` (an overview of it with `level`): through
    /// gdal_translate to a plain GTiff, read by the tiff crate.
    fn gdal_reads(path: &Path, level: Option<usize>) -> Vec<u32> {
        let plain = path.with_extension(format!("plain{}.tif", level.map_or(String::new(), |l| l.to_string())));
        let (input, output) = (path.to_str().unwrap(), plain.to_str().unwrap());
        let overview = level.map(|l| format!("OVERVIEW_LEVEL={l}"));
        let mut args = vec!["-q", "-of", "GTiff"];
        if let Some(o) = &overview {
            args.extend(["-oo", o]);
        }
        gdal_run("gdal_translate", &[&args[..], &[input, output]].concat());
        let images = read_images(&plain);
        std::fs::remove_file(&plain).unwrap();
        assert_eq!((images.len(), images[0].2, images[0].3), (1, 1, 1), "a plain GTiff");
        images.into_iter().next().unwrap().4
    }

    /// GDAL's COG validator passes the COGs written (strictest check, no warning), gdalinfo
    /// sees LAYOUT=COG, the overviews' sizes and checksums, and GDAL reads back every level,
    /// and the non-COG files' predictors and ZSTD, bit for bit.
    #[test]
    fn gdal_validates_and_reads_back_cogs() {
        if !gdal() {
            return;
        }
        use {Compression as C, Predictor as P};
        let dir = scratch("gdal");
        let cog = |compress, predictor| GeoTiffOptions { cog: true, tiled: true, compress, predictor, epsg: Some(32633), ..Default::default() };
        let cases = [
            ("f32-deflate-fp-1000x700", 1000, 700, Sample::Float32 { nodata: -9999.0 }, cog(C::Deflate, P::FloatingPoint)),
            ("f32-nan-zstd-200x120-no-overview", 200, 120, Sample::Float32 { nodata: f32::NAN }, cog(C::Zstd, P::Yes)),
            ("u32-deflate-pred2-600x300", 600, 300, Sample::UInt32, cog(C::Deflate, P::Horizontal)),
            (
                "f32-bigtiff-zstd-pred2-700x500",
                700,
                500,
                Sample::Float32 { nodata: -9999.0 },
                GeoTiffOptions { bigtiff: BigTiff::Yes, ..cog(C::Zstd, P::Horizontal) },
            ),
            ("f32-uncompressed-300x300", 300, 300, Sample::Float32 { nodata: 0.0 }, cog(C::None, P::None)),
            ("u32-zstd-yes-1030x257", 1030, 257, Sample::UInt32, cog(C::Zstd, P::Yes)),
        ];
        for (name, w, h, sample, options) in cases {
            let path = dir.join(format!("{name}.tif"));
            let levels = write_case(&path, w, h, sample, &options);
            let file = path.to_str().unwrap();
            let validator = gdal_run("/usr/bin/python3", &["-m", "osgeo_utils.samples.validate_cloud_optimized_geotiff", "--full-check=yes", file]);
            eprintln!("{name}: {}", validator.trim().replace('\n', " | "));
            assert!(validator.contains("is a valid cloud optimized GeoTIFF") && !validator.contains("warning"), "{name}: {validator}");
            let info = gdal_run("gdalinfo", &["-checksum", file]);
            assert!(info.contains("LAYOUT=COG"), "{name}: {info}");
            let sizes: Vec<String> = levels[1..].iter().map(|(w, h, _)| format!("{w}x{h}")).collect();
            let listed = info
                .lines()
                .find_map(|l| l.trim().strip_prefix("Overviews: "))
                .map(|l| l.split(", ").map(String::from).collect::<Vec<_>>())
                .unwrap_or_default();
            assert_eq!(listed, sizes, "{name}: gdalinfo's overviews");
            let checksum = info.lines().find_map(|l| l.trim().strip_prefix("Checksum=")).unwrap_or_else(|| panic!("{name}: no checksum in {info}"));
            checksum.parse::<u32>().unwrap();
            let overview_checksums: Vec<u32> = info
                .lines()
                .find_map(|l| l.trim().strip_prefix("Overviews checksum: "))
                .map(|l| l.split(", ").map(|c| c.parse().unwrap()).collect())
                .unwrap_or_default();
            assert_eq!(overview_checksums.len(), sizes.len(), "{name}: {info}");
            for (k, (_, _, bits)) in levels.iter().enumerate() {
                assert!(gdal_reads(&path, k.checked_sub(1)) == *bits, "{name}: GDAL reads other values at level {k}");
            }
        }
        // GDAL reads the predictors and ZSTD of tiles and strips too (Float32 PREDICTOR=2
        // included).
        for (name, sample, tiled, compress, predictor) in [
            ("strips-f32-zstd-pred2", Sample::Float32 { nodata: -9999.0 }, false, C::Zstd, P::Horizontal),
            ("strips-f32-deflate-pred3", Sample::Float32 { nodata: f32::NAN }, false, C::Deflate, P::FloatingPoint),
            ("tiles-f32-zstd-pred3", Sample::Float32 { nodata: -9999.0 }, true, C::Zstd, P::FloatingPoint),
            ("tiles-u32-deflate-pred2", Sample::UInt32, true, C::Deflate, P::Horizontal),
        ] {
            let path = dir.join(format!("{name}.tif"));
            let levels = write_case(&path, 300, 270, sample, &GeoTiffOptions { tiled, compress, predictor, ..Default::default() });
            assert!(gdal_reads(&path, None) == levels[0].2, "{name}: GDAL reads other values");
            let info = gdal_run("gdalinfo", &[path.to_str().unwrap()]);
            assert!(!info.contains("LAYOUT=COG"), "{name}");
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
