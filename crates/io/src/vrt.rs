//! A GDAL VRT mosaic of GeoTIFF parts: windows of one grid rasterised apart (separate
//! processes, cluster jobs) read back as one raster. Each part's place comes from its own
//! georeferencing, so the parts may be listed in any order.

use crate::{IoError, write_atomically};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use tiff::decoder::Decoder;
use tiff::tags::Tag;

/// What a mosaic needs of one part.
#[derive(Debug, Clone, PartialEq)]
pub struct Part {
    pub path: PathBuf,
    pub width: u32,
    pub height: u32,
    /// The top-left corner and the cell size.
    pub x0: f64,
    pub y0: f64,
    pub dx: f64,
    pub dy: f64,
    pub nodata: Option<String>,
    /// `Float32` or `UInt32`.
    pub data_type: &'static str,
    pub epsg: Option<u16>,
}

/// The mosaic written: its size and where each part sits (pixel offsets), in input order.
#[derive(Debug, Clone, PartialEq)]
pub struct Mosaic {
    pub width: u32,
    pub height: u32,
    pub offsets: Vec<(u32, u32)>,
    /// Cells no part covers (nodata in the mosaic).
    pub uncovered: u64,
}

/// Read a part's size, georeferencing, nodata, sample type and EPSG code.
pub fn read_part(path: &Path) -> Result<Part, IoError> {
    let file = std::fs::File::open(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    part_from(std::io::BufReader::new(file), path)
}

/// [`read_part`] of a file's bytes; errors name `origin`.
pub fn parse_part(bytes: &[u8], origin: &Path) -> Result<Part, IoError> {
    part_from(std::io::Cursor::new(bytes), origin)
}

fn part_from<R: std::io::Read + std::io::Seek>(reader: R, path: &Path) -> Result<Part, IoError> {
    let fail = |message: String| IoError::Format { path: path.to_owned(), message };
    let mut d = Decoder::new(reader).map_err(|e| fail(format!("not a readable TIFF: {e}")))?;
    let (width, height) = d.dimensions().map_err(|e| fail(e.to_string()))?;
    let (x0, y0, dx, dy) = crate::dem::north_up_grid(&mut d, path)?;
    let bits = d.get_tag_u32(Tag::BitsPerSample).map_err(|e| fail(e.to_string()))?;
    let format = d.find_tag(Tag::SampleFormat).ok().flatten().and_then(|v| v.into_u32().ok()).unwrap_or(1);
    let data_type = match (format, bits) {
        (3, 32) => "Float32",
        (1, 32) => "UInt32",
        _ => return Err(fail(format!("{bits}-bit samples of format {format}: only Float32 and UInt32 parts are mosaicked"))),
    };
    let nodata = d.get_tag_ascii_string(Tag::GdalNodata).ok().map(|s| s.trim_end_matches('\0').to_string());
    let keys = d.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap_or_default();
    // GeographicTypeGeoKey (2048) or ProjectedCSTypeGeoKey (3072), stored in the directory.
    let epsg = keys.chunks(4).skip(1).find(|k| k.len() == 4 && (k[0] == 2048 || k[0] == 3072) && k[1] == 0).map(|k| k[3]);
    Ok(Part { path: path.to_owned(), width, height, x0, y0, dx, dy, nodata, data_type, epsg })
}

/// Write `parts`, windows of one grid, as a VRT at `output`. Refused unless they share the
/// cell size, nodata, sample type and CRS, and sit on one lattice.
pub fn write_mosaic_vrt(output: &Path, parts: &[Part]) -> Result<Mosaic, IoError> {
    let fail = |message: String| IoError::Format { path: output.to_owned(), message };
    let first = parts.first().ok_or_else(|| fail("no parts to mosaic".into()))?;
    for p in parts {
        let differs = |what: &str, a: String, b: String| {
            fail(format!("{} has {what} {a}, but {} has {b}: not windows of one grid", p.path.display(), first.path.display()))
        };
        if (p.dx, p.dy) != (first.dx, first.dy) {
            return Err(differs("cell size", format!("{} × {}", p.dx, p.dy), format!("{} × {}", first.dx, first.dy)));
        }
        if p.nodata != first.nodata {
            return Err(differs("nodata", format!("{:?}", p.nodata), format!("{:?}", first.nodata)));
        }
        if p.data_type != first.data_type {
            return Err(differs("samples", p.data_type.into(), first.data_type.into()));
        }
        if p.epsg != first.epsg {
            return Err(differs("CRS", format!("{:?}", p.epsg), format!("{:?}", first.epsg)));
        }
    }
    let left = parts.iter().map(|p| p.x0).fold(f64::INFINITY, f64::min);
    let top = parts.iter().map(|p| p.y0).fold(f64::NEG_INFINITY, f64::max);
    // Each part's offset in cells: a whole number, up to the rounding of its corner.
    let cells = |distance: f64, size: f64, p: &Part| -> Result<u32, IoError> {
        let k = (distance / size).round();
        if (distance / size - k).abs() > 1e-6 || !(0.0..=u32::MAX as f64).contains(&k) {
            return Err(fail(format!("{} is {} cells from the mosaic's corner: not on the lattice of the other parts", p.path.display(), distance / size)));
        }
        Ok(k as u32)
    };
    let mut offsets = Vec::with_capacity(parts.len());
    let (mut width, mut height) = (0u64, 0u64);
    for p in parts {
        let (i, j) = (cells(p.x0 - left, first.dx, p)?, cells(top - p.y0, first.dy, p)?);
        width = width.max(i as u64 + p.width as u64);
        height = height.max(j as u64 + p.height as u64);
        offsets.push((i, j));
    }
    let (width, height) =
        (u32::try_from(width).map_err(|_| fail("wider than 2^32 cells".into()))?, u32::try_from(height).map_err(|_| fail("taller than 2^32 cells".into()))?);
    let covered = covered_cells(parts, &offsets);
    let folder = output.parent().map(|p| if p.as_os_str().is_empty() { Path::new(".") } else { p }).unwrap_or(Path::new("."));
    let mut xml = format!("<VRTDataset rasterXSize=\"{width}\" rasterYSize=\"{height}\">\n");
    if let Some(code) = first.epsg {
        let _ = writeln!(xml, "  <SRS>EPSG:{code}</SRS>");
    }
    let _ = writeln!(xml, "  <GeoTransform>{:?}, {:?}, 0.0, {:?}, 0.0, {:?}</GeoTransform>", left, first.dx, top, -first.dy);
    let _ = writeln!(xml, "  <VRTRasterBand dataType=\"{}\" band=\"1\">", first.data_type);
    if let Some(nodata) = &first.nodata {
        let _ = writeln!(xml, "    <NoDataValue>{}</NoDataValue>", escape(nodata));
    }
    for (p, (i, j)) in parts.iter().zip(&offsets) {
        let (name, relative) = source_name(&p.path, folder);
        let _ = writeln!(xml, "    <SimpleSource>");
        let _ = writeln!(xml, "      <SourceFilename relativeToVRT=\"{}\">{}</SourceFilename>", relative as u8, escape(&name));
        let _ = writeln!(xml, "      <SourceBand>1</SourceBand>");
        let _ = writeln!(xml, "      <SrcRect xOff=\"0\" yOff=\"0\" xSize=\"{}\" ySize=\"{}\"/>", p.width, p.height);
        let _ = writeln!(xml, "      <DstRect xOff=\"{i}\" yOff=\"{j}\" xSize=\"{}\" ySize=\"{}\"/>", p.width, p.height);
        let _ = writeln!(xml, "    </SimpleSource>");
    }
    xml.push_str("  </VRTRasterBand>\n</VRTDataset>\n");
    write_atomically(output, |out| std::io::Write::write_all(out, xml.as_bytes()).map_err(|e| e.to_string()))?;
    Ok(Mosaic { width, height, offsets, uncovered: width as u64 * height as u64 - covered })
}

/// Cells covered by at least one part (overlaps counted once), row by row of the parts'
/// distinct row boundaries.
fn covered_cells(parts: &[Part], offsets: &[(u32, u32)]) -> u64 {
    let mut rows: Vec<u64> = offsets.iter().zip(parts).flat_map(|(&(_, j), p)| [j as u64, j as u64 + p.height as u64]).collect();
    rows.sort_unstable();
    rows.dedup();
    let mut covered = 0;
    for pair in rows.windows(2) {
        let mut spans: Vec<(u64, u64)> = offsets
            .iter()
            .zip(parts)
            .filter(|&(&(_, j), p)| (j as u64) <= pair[0] && pair[0] < j as u64 + p.height as u64)
            .map(|(&(i, _), p)| (i as u64, i as u64 + p.width as u64))
            .collect();
        spans.sort_unstable();
        let (mut length, mut end) = (0, 0);
        for (a, b) in spans {
            length += b.saturating_sub(a.max(end));
            end = end.max(b);
        }
        covered += length * (pair[1] - pair[0]);
    }
    covered
}

/// A part's name for the VRT: relative to the VRT's folder when it lies inside it.
fn source_name(part: &Path, folder: &Path) -> (String, bool) {
    let absolute = |p: &Path| std::fs::canonicalize(p).unwrap_or_else(|_| p.to_owned());
    let (part, folder) = (absolute(part), absolute(folder));
    match part.strip_prefix(&folder) {
        Ok(relative) => (relative.to_string_lossy().into_owned(), true),
        Err(_) => (part.to_string_lossy().into_owned(), false),
    }
}

fn escape(text: &str) -> String {
    text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

#[cfg(test)]
mod tests {
    use super::*;

    fn part(name: &str, width: u32, height: u32, x0: f64, y0: f64) -> Part {
        Part { path: PathBuf::from(name), width, height, x0, y0, dx: 2.5, dy: 2.5, nodata: Some("-9999".into()), data_type: "Float32", epsg: Some(32633) }
    }

    #[test]
    fn parts_are_placed_by_their_corners() {
        let dir = std::env::temp_dir().join(format!("tileraster-vrt-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let vrt = dir.join("m.vrt");
        // Listed out of order; the second row of parts is 40 cells down.
        let parts = [part("b.tif", 100, 60, 1000.0, 900.0), part("a.tif", 100, 40, 1000.0, 1000.0)];
        let m = write_mosaic_vrt(&vrt, &parts).unwrap();
        assert_eq!(m, Mosaic { width: 100, height: 100, offsets: vec![(0, 40), (0, 0)], uncovered: 0 });
        let xml = std::fs::read_to_string(&vrt).unwrap();
        assert!(xml.contains("<GeoTransform>1000.0, 2.5, 0.0, 1000.0, 0.0, -2.5</GeoTransform>"), "{xml}");
        assert!(xml.contains("<SRS>EPSG:32633</SRS>") && xml.contains("<NoDataValue>-9999</NoDataValue>"), "{xml}");
        assert!(xml.contains("<DstRect xOff=\"0\" yOff=\"40\" xSize=\"100\" ySize=\"60\"/>"), "{xml}");
        // A gap and an overlap are counted once each.
        let gappy = [part("a.tif", 10, 10, 0.0, 100.0), part("b.tif", 10, 10, 50.0, 100.0), part("c.tif", 10, 10, 12.5, 100.0)];
        // Columns 0..15 and 20..30 of 30, ten rows each.
        assert_eq!(write_mosaic_vrt(&vrt, &gappy).unwrap().uncovered, 300 - 250);
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn parts_are_read_from_the_files_written() {
        use crate::{GeoTiffOptions, GeoTiffWriter, Sample};
        use tileraster_core::{Grid, Window};
        let dir = std::env::temp_dir().join(format!("tileraster-vrt-read-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let (path, grid) = (dir.join("p.tif"), Grid::new(100.0, 200.0, 0.0, 50.0, 100, 50));
        for (sample, data_type) in [(Sample::Float32 { nodata: -9999.0 }, "Float32"), (Sample::UInt32, "UInt32")] {
            let options = GeoTiffOptions { epsg: Some(4326), tiled: true, ..Default::default() };
            let mut w = GeoTiffWriter::create(&path, &grid, Window { x0: 10, y0: 20, width: 30, height: 5 }, sample, &options).unwrap();
            w.write_rows(&[7u32; 150]).unwrap();
            w.finish().unwrap();
            let part = read_part(&path).unwrap();
            let nodata = if data_type == "Float32" { "-9999" } else { "4294967295" };
            let expected = Part {
                path: path.clone(),
                width: 30,
                height: 5,
                x0: 110.0,
                y0: 30.0,
                dx: 1.0,
                dy: 1.0,
                nodata: Some(nodata.into()),
                data_type,
                epsg: Some(4326),
            };
            assert_eq!(part, expected);
            assert_eq!(parse_part(&std::fs::read(&path).unwrap(), &path).unwrap(), expected);
        }
        let e = parse_part(b"II*\0garbage", Path::new("g.tif")).unwrap_err().to_string();
        assert!(e.starts_with("g.tif: not a readable TIFF"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn parts_of_different_grids_are_refused() {
        let vrt = std::env::temp_dir().join("never-written.vrt");
        let a = part("a.tif", 10, 10, 0.0, 100.0);
        let cases = [
            (Part { dx: 3.0, ..part("b.tif", 10, 10, 0.0, 75.0) }, "cell size"),
            (Part { nodata: None, ..part("b.tif", 10, 10, 0.0, 75.0) }, "nodata"),
            (Part { data_type: "UInt32", ..part("b.tif", 10, 10, 0.0, 75.0) }, "samples"),
            (Part { epsg: Some(4326), ..part("b.tif", 10, 10, 0.0, 75.0) }, "CRS"),
            (part("b.tif", 10, 10, 1.0, 75.0), "not on the lattice"),
        ];
        for (b, what) in cases {
            let e = write_mosaic_vrt(&vrt, &[a.clone(), b]).unwrap_err().to_string();
            assert!(e.contains(what), "{e}");
        }
        assert!(write_mosaic_vrt(&vrt, &[]).unwrap_err().to_string().contains("no parts"));
        assert!(!vrt.exists());
    }
}
