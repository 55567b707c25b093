//! Single-band GeoTIFFs (Float32 heights, UInt32 owner triangles), written block by block:
//! a grid larger than memory streams through [`GeoTiffWriter`] in bands of rows, and only one
//! row of blocks is ever held. Classic TIFF, or BigTIFF when the file may pass 4 GiB.

use crate::{IoError, PartialFile};
use rayon::prelude::*;
use std::borrow::Cow;
use std::io::{Seek, SeekFrom, Write};
use std::path::Path;
use tiff::encoder::compression::{CompressionAlgorithm, Deflate, DeflateLevel};
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
    /// Deflate compression (`-co COMPRESS=DEFLATE`).
    pub deflate: bool,
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

/// Side of a tile in tiled output, as GDAL's default.
pub const TILE: u32 = 256;

impl GeoTiffOptions {
    /// Apply a creation option as gdal_grid takes them (`TILED=YES`, `COMPRESS=DEFLATE`,
    /// `BIGTIFF=YES`, ...).
    pub fn apply(&mut self, option: &str) -> Result<(), String> {
        let (name, value) = option.split_once('=').ok_or_else(|| format!("creation option '{option}' is not NAME=VALUE"))?;
        match (name.to_ascii_uppercase().as_str(), value.to_ascii_uppercase().as_str()) {
            ("TILED", "YES" | "TRUE" | "ON") => self.tiled = true,
            ("TILED", "NO" | "FALSE" | "OFF") => self.tiled = false,
            ("COMPRESS", "DEFLATE") => self.deflate = true,
            ("COMPRESS", "NONE") => self.deflate = false,
            ("BIGTIFF", "YES") => self.bigtiff = BigTiff::Yes,
            ("BIGTIFF", "NO") => self.bigtiff = BigTiff::No,
            // Sizes are judged uncompressed, so "if safer" is "if needed" here.
            ("BIGTIFF", "IF_NEEDED" | "IF_SAFER") => self.bigtiff = BigTiff::IfNeeded,
            _ => {
                return Err(format!(
                    "unsupported creation option '{option}'; supported: TILED=YES|NO, COMPRESS=DEFLATE|NONE, BIGTIFF=YES|NO|IF_NEEDED"
                ))
            }
        }
        Ok(())
    }
}

/// The EPSG code of `--a_srs` (`EPSG:32633`, case-insensitive).
pub fn parse_epsg(srs: &str) -> Result<u16, String> {
    let code = srs.trim().strip_prefix("EPSG:").or_else(|| srs.trim().strip_prefix("epsg:")).ok_or_else(|| {
        format!("'{srs}': only EPSG codes are supported as a CRS (for example EPSG:32633 or EPSG:4326)")
    })?;
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

/// [`write_geotiff`] with a CRS, tiles, compression or BigTIFF.
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
    deflate: bool,
    sample: Sample,
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
    pub fn create(path: &Path, grid: &Grid, window: Window, sample: Sample, options: &GeoTiffOptions) -> Result<Self, IoError> {
        let (width, height) = (window.width, window.height);
        let format = |message: String| IoError::Format { path: path.to_owned(), message };
        if width == 0 || height == 0 {
            return Err(format(format!("a {width}×{height} image has no cells to write")));
        }
        let row_bytes = width as u64 * 4;
        let block = match options.tiled {
            true => Block::Tiles,
            false => Block::Strips { rows: (8192 / row_bytes).clamp(1, TILE as u64) as u32 },
        };
        let (across, down) = match block {
            Block::Tiles => (width.div_ceil(TILE) as u64, height.div_ceil(TILE) as u64),
            Block::Strips { rows } => (1, height.div_ceil(rows) as u64),
        };
        // Uncompressed data (tiles padded), deflate's worst case, and the offset arrays.
        let data = match block {
            Block::Tiles => across * down * (TILE as u64 * TILE as u64 * 4),
            Block::Strips { .. } => row_bytes * height as u64,
        };
        let bound = data + data / 1000 + across * down * (64 + 16) + 4096;
        let big = match options.bigtiff {
            BigTiff::Yes => true,
            BigTiff::IfNeeded => bound > CLASSIC_LIMIT,
            BigTiff::No if bound > CLASSIC_LIMIT && !options.deflate => {
                return Err(format(format!(
                    "{data} bytes of image do not fit a classic TIFF (4 GiB); allow BigTIFF (-co BIGTIFF=IF_NEEDED or YES)"
                )))
            }
            BigTiff::No => false,
        };
        let (dx, dy) = (grid.dx(), grid.dy());
        let mut writer = GeoTiffWriter {
            file: PartialFile::create(path)?,
            position: 0,
            big,
            width,
            height,
            rows_in: 0,
            pending: Vec::new(),
            block,
            deflate: options.deflate,
            sample,
            offsets: Vec::with_capacity((across * down) as usize),
            counts: Vec::with_capacity((across * down) as usize),
            scale: [dx, dy, 0.0],
            tiepoint: [0.0, 0.0, 0.0, grid.xmin + window.x0 as f64 * dx, grid.ymax - window.y0 as f64 * dy, 0.0],
            keys: geo_keys(options.epsg),
        };
        // The header; the first IFD's offset is filled in by `finish`.
        let header: &[u8] = if big { &[b'I', b'I', 43, 0, 8, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0] } else { &[b'I', b'I', 42, 0, 0, 0, 0, 0] };
        writer.put(header)?;
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

    /// Write the last blocks and the directory, make the file durable, and rename it into
    /// place. Refused unless every row has been written.
    pub fn finish(mut self) -> Result<(), IoError> {
        if self.rows_in != self.height {
            return Err(self.error(format!("only {} of {} rows were written", self.rows_in, self.height)));
        }
        let pending = std::mem::take(&mut self.pending);
        self.write_blocks(&pending)?;
        self.write_directory()?;
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

    /// Whole block rows (or the image's last, shorter one), as blocks.
    fn write_blocks(&mut self, rows: &[u8]) -> Result<(), IoError> {
        let row_bytes = self.width as usize * 4;
        let block_bytes = self.block.rows() as usize * row_bytes;
        if rows.is_empty() {
            return Ok(());
        }
        if let (Block::Strips { .. }, false) = (self.block, self.deflate) {
            // Uncompressed strips are the rows themselves: one write for all of them.
            for strip in rows.chunks(block_bytes) {
                self.offsets.push(self.position + (strip.as_ptr() as usize - rows.as_ptr() as usize) as u64);
                self.counts.push(strip.len() as u64);
            }
            return self.put(rows);
        }
        for block_row in rows.chunks(block_bytes) {
            let blocks: Vec<Cow<[u8]>> = match self.block {
                Block::Strips { .. } => vec![Cow::Borrowed(block_row)],
                Block::Tiles => {
                    let pad = self.sample.nodata_bytes();
                    let across = self.width.div_ceil(TILE) as usize;
                    (0..across).into_par_iter().map(|tx| Cow::Owned(tile(block_row, row_bytes, tx, pad))).collect()
                }
            };
            let blocks: Vec<Cow<[u8]>> = match self.deflate {
                true => blocks.into_par_iter().map(|b| Cow::Owned(deflate(&b))).collect(),
                false => blocks,
            };
            for data in blocks {
                self.offsets.push(self.position);
                self.counts.push(data.len() as u64);
                self.put(&data)?;
            }
        }
        Ok(())
    }

    /// The image file directory after the data, then its offset into the header.
    fn write_directory(&mut self) -> Result<(), IoError> {
        const SHORT: u16 = 3;
        const LONG: u16 = 4;
        const ASCII: u16 = 2;
        const DOUBLE: u16 = 12;
        const LONG8: u16 = 16;
        let shorts = |v: &[u16]| (SHORT, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        let long = |v: u32| (LONG, 1, v.to_le_bytes().to_vec());
        let doubles = |v: &[f64]| (DOUBLE, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>());
        let offsets = |v: &[u64]| match self.big {
            true => (LONG8, v.len() as u64, v.iter().flat_map(|x| x.to_le_bytes()).collect::<Vec<u8>>()),
            false => (LONG, v.len() as u64, v.iter().flat_map(|&x| (x as u32).to_le_bytes()).collect()),
        };
        let mut nodata = self.sample.nodata_text().into_bytes();
        nodata.push(0);
        let mut entries: Vec<(u16, Field)> = vec![
            (256, long(self.width)),
            (257, long(self.height)),
            (258, shorts(&[32])),
            (259, shorts(&[if self.deflate { 8 } else { 1 }])),
            (262, shorts(&[1])), // BlackIsZero
            (277, shorts(&[1])),
            (284, shorts(&[1])), // one plane
            (339, shorts(&[self.sample.format()])),
            (33550, doubles(&self.scale)),
            (33922, doubles(&self.tiepoint)),
            (34735, shorts(&self.keys)),
            (42113, (ASCII, nodata.len() as u64, nodata)),
        ];
        match self.block {
            Block::Tiles => entries.extend([(322, long(TILE)), (323, long(TILE)), (324, offsets(&self.offsets)), (325, offsets(&self.counts))]),
            Block::Strips { rows } => entries.extend([(273, offsets(&self.offsets)), (278, long(rows)), (279, offsets(&self.counts))]),
        }
        entries.sort_by_key(|e| e.0);

        // Classic: 2-byte count, 12-byte entries with 4 bytes inline, 4-byte next offset.
        // BigTIFF: 8-byte count, 20-byte entries with 8 bytes inline, 8-byte next offset.
        let (count_bytes, inline, entry, word) = if self.big { (8u64, 8usize, 20u64, 8u64) } else { (2, 4, 12, 4) };
        let align = self.position.next_multiple_of(8) - self.position;
        self.put(&vec![0u8; align as usize])?;
        let ifd = self.position;
        // The out-of-line values follow the table, each on a word boundary.
        let values_at = ifd + count_bytes + entries.len() as u64 * entry + word;
        let mut table = Vec::new();
        let mut values = Vec::new();
        let put_word = |table: &mut Vec<u8>, v: u64| match self.big {
            true => table.extend(v.to_le_bytes()),
            false => table.extend((v as u32).to_le_bytes()),
        };
        table.extend(&(entries.len() as u64).to_le_bytes()[..count_bytes as usize]);
        for (tag, (kind, count, bytes)) in &entries {
            table.extend(tag.to_le_bytes());
            table.extend(kind.to_le_bytes());
            put_word(&mut table, *count);
            if bytes.len() <= inline {
                table.extend(bytes);
                table.extend(std::iter::repeat_n(0u8, inline - bytes.len()));
            } else {
                put_word(&mut table, values_at + values.len() as u64);
                values.extend(bytes);
                values.resize(values.len().next_multiple_of(2), 0);
            }
        }
        put_word(&mut table, 0); // no next IFD
        debug_assert_eq!(ifd + table.len() as u64, values_at);
        self.put(&table)?;
        self.put(&values)?;
        let path = self.file.path().to_owned();
        let io = |source| IoError::Io { path, source };
        let at: Vec<u8> = if self.big { ifd.to_le_bytes().to_vec() } else { (ifd as u32).to_le_bytes().to_vec() };
        let out = self.file.out();
        out.seek(SeekFrom::Start(if self.big { 8 } else { 4 })).and_then(|_| out.write_all(&at)).map_err(io)?;
        Ok(())
    }
}

/// A directory entry's value: its TIFF type, count and little-endian bytes.
type Field = (u16, u64, Vec<u8>);

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

fn deflate(data: &[u8]) -> Vec<u8> {
    let mut packed = Vec::with_capacity(data.len() / 2);
    Deflate::with_level(DeflateLevel::Balanced).write_to(&mut packed, data).expect("writing to a Vec cannot fail");
    packed
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::decoder::{Decoder, DecodingResult};
    use tiff::tags::Tag;

    fn raster(w: u32, h: u32) -> Raster {
        let grid = Grid::new(500_000.0, 500_000.0 + w as f64, 5_000_000.0, 5_000_000.0 + h as f64, w, h);
        let values = (0..w * h).map(|k| if k % 7 == 0 { -9999.0 } else { k as f32 * 0.25 }).collect();
        Raster { grid, window: Window::whole(&grid), nodata: -9999.0, values, owner: None, coverage: None, colours: None, faces: None, snap_bits: 16, stats: Default::default() }
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
        let mut all = Vec::new();
        for bigtiff in [BigTiff::IfNeeded, BigTiff::Yes] {
            for (tiled, deflate) in [(false, false), (true, false), (false, true), (true, true)] {
                all.push(GeoTiffOptions { tiled, deflate, bigtiff, epsg: [None, Some(32633), Some(4326)][all.len() % 3] });
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
            assert_eq!(back.compression, if options.deflate { 8 } else { 1 }, "{options:?}");
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
        for (k, options) in all_options().into_iter().enumerate() {
            let whole = dir.join(format!("whole-{k}.tif"));
            write_geotiff_with(&r, &whole, &options).unwrap();
            for band in [1u32, 7, 256, 300, 529] {
                let banded = dir.join(format!("banded-{k}-{band}.tif"));
                let mut w = GeoTiffWriter::create(&banded, &r.grid, r.window, Sample::Float32 { nodata: r.nodata }, &options).unwrap();
                for rows in r.values.chunks(band as usize * 300) {
                    w.write_rows(rows).unwrap();
                }
                w.finish().unwrap();
                assert!(std::fs::read(&whole).unwrap() == std::fs::read(&banded).unwrap(), "{options:?}, bands of {band} rows");
            }
        }
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn owner_files_are_uint32_with_their_nodata() {
        let dir = scratch("owner");
        let r = raster(70, 40);
        let owner: Vec<u32> = (0..70 * 40).map(|k| if k % 5 == 0 { u32::MAX } else { k * 3 }).collect();
        for options in [GeoTiffOptions::default(), GeoTiffOptions { tiled: true, deflate: true, ..Default::default() }] {
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
        let partial = dir.join("x.tif.tileraster-partial");
        let options = GeoTiffOptions::default();
        let create = || GeoTiffWriter::create(&path, &r.grid, r.window, Sample::Float32 { nodata: 0.0 }, &options).unwrap();
        let mut w = create();
        assert!(w.write_rows(&[0f32; 15]).unwrap_err().to_string().contains("not whole rows of 10"));
        assert!(w.write_rows(&[0f64; 10]).unwrap_err().to_string().contains("8 bytes"));
        assert!(w.write_rows(&[0f32; 110]).unwrap_err().to_string().contains("more rows than the image has"));
        w.write_rows(&[0f32; 50]).unwrap();
        assert!(partial.exists());
        assert!(w.finish().unwrap_err().to_string().contains("only 5 of 10 rows"));
        assert!(!partial.exists() && !path.exists());
        let w = create();
        drop(w);
        assert!(!partial.exists() && !path.exists());
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
        assert_eq!(o, GeoTiffOptions { tiled: true, deflate: true, epsg: None, bigtiff: BigTiff::Yes });
        o.apply("bigtiff=if_safer").unwrap();
        assert_eq!(o.bigtiff, BigTiff::IfNeeded);
        assert!(o.apply("COMPRESS=JPEG").unwrap_err().contains("supported: TILED=YES|NO, COMPRESS=DEFLATE|NONE, BIGTIFF=YES|NO|IF_NEEDED"));
        assert!(o.apply("TILED").unwrap_err().contains("not NAME=VALUE"));
    }
}
