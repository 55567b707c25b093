//! A GeoTIFF DEM read back: a north-up grid of heights (one band of any integer or float
//! sample type, stripped or tiled, compressed as the `tiff` crate reads) with its cell size,
//! corner and GDAL's nodata value.

/// The most cells a DEM may have (8192 × 8192): rendered, every cell is a vertex of some 200
/// bytes through the geometry stages.
pub const MAX_DEM_CELLS: u64 = 1 << 26;

use crate::IoError;
use std::path::Path;
use tiff::decoder::{Decoder, DecodingResult, Limits};
use tiff::tags::Tag;

/// A DEM: `heights` row by row from the north, `nodata` (and NaN) where the grid has no value.
#[derive(Debug, Clone, PartialEq)]
pub struct Dem {
    pub width: u32,
    pub height: u32,
    /// The grid's north-west corner and its cell size (both positive).
    pub x0: f64,
    pub y0: f64,
    pub dx: f64,
    pub dy: f64,
    pub nodata: Option<f64>,
    pub heights: Vec<f64>,
}

impl Dem {
    /// Whether the cell at `(column, row)` has a height.
    pub fn has_value(&self, column: u32, row: u32) -> bool {
        let h = self.heights[row as usize * self.width as usize + column as usize];
        !h.is_nan() && Some(h) != self.nodata
    }

    /// The centre of the cell at `(column, row)` with its height.
    pub fn centre(&self, column: u32, row: u32) -> [f64; 3] {
        let h = self.heights[row as usize * self.width as usize + column as usize];
        [self.x0 + (column as f64 + 0.5) * self.dx, self.y0 - (row as f64 + 0.5) * self.dy, h]
    }
}

/// The grid's north-west corner and cell size `(x0, y0, dx, dy)` from a GeoTIFF's tie point at
/// pixel (0, 0) and its pixel scale: a north-up grid of positive, finite cells, or an error
/// that says what it is instead.
pub(crate) fn north_up_grid<R: std::io::Read + std::io::Seek>(d: &mut Decoder<R>, path: &Path) -> Result<(f64, f64, f64, f64), IoError> {
    let fail = |message: String| IoError::Format { path: path.to_owned(), message };
    let scale = d.get_tag_f64_vec(Tag::ModelPixelScaleTag).map_err(|_| fail("no ModelPixelScale tag: not georeferenced".into()))?;
    let tie = d.get_tag_f64_vec(Tag::ModelTiepointTag).map_err(|_| fail("no ModelTiepoint tag: not georeferenced".into()))?;
    if scale.len() < 2 || tie.len() < 6 || tie[0] != 0.0 || tie[1] != 0.0 {
        return Err(fail("georeferenced other than by one tie point at pixel (0, 0) and a pixel scale".into()));
    }
    if !(scale[0].is_finite() && scale[1].is_finite() && scale[0] > 0.0 && scale[1] > 0.0 && tie[3].is_finite() && tie[4].is_finite()) {
        return Err(fail(format!("cell size {} × {} at corner ({}, {}): not a north-up grid of positive, finite cells", scale[0], scale[1], tie[3], tie[4])));
    }
    Ok((tie[3], tie[4], scale[0], scale[1]))
}

/// Read a single-band GeoTIFF DEM.
pub fn read_dem(path: &Path) -> Result<Dem, IoError> {
    let fail = |message: String| IoError::Format { path: path.to_owned(), message };
    let file = std::fs::File::open(path).map_err(|source| IoError::Io { path: path.to_owned(), source })?;
    let mut d = Decoder::new(std::io::BufReader::new(file)).map_err(|e| fail(format!("not a readable TIFF: {e}")))?;
    let (width, height) = d.dimensions().map_err(|e| fail(e.to_string()))?;
    let (mut x0, mut y0, dx, dy) = north_up_grid(&mut d, path)?;
    // GTRasterTypeGeoKey (1025) 2, PixelIsPoint: the tie point is the first cell's centre.
    let keys = d.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap_or_default();
    if keys.chunks(4).skip(1).any(|k| k.len() == 4 && k[0] == 1025 && k[1] == 0 && k[3] == 2) {
        (x0, y0) = (x0 - dx / 2.0, y0 + dy / 2.0);
    }
    let cells = width as u64 * height as u64;
    if cells > MAX_DEM_CELLS {
        return Err(fail(format!(
            "{width} × {height} cells, more than the {MAX_DEM_CELLS} a DEM may have here: resample it first (e.g. gdal_translate -outsize 25% 25% -r average)"
        )));
    }
    let bands = d.find_tag(Tag::SamplesPerPixel).ok().flatten().and_then(|v| v.into_u32().ok()).unwrap_or(1);
    if bands != 1 {
        return Err(fail(format!("{bands} bands: a DEM has one (extract it first, e.g. gdal_translate -b 1)")));
    }
    let nodata = match d.get_tag_ascii_string(Tag::GdalNodata) {
        Ok(text) => {
            let text = text.trim_end_matches('\0').trim();
            Some(text.parse::<f64>().map_err(|e| fail(format!("GDAL nodata value '{text}': {e}")))?)
        }
        Err(_) => None,
    };
    // Up to the cap above, whatever the sample type (the crate's default stops at 256 MiB).
    let mut limits = Limits::default();
    limits.decoding_buffer_size = limits.decoding_buffer_size.max(cells as usize * 8);
    let mut d = d.with_limits(limits);
    let image = d.read_image().map_err(|e| fail(format!("reading its samples: {e}")))?;
    // The nodata value as the samples hold it: a Float32 band stores the text's value rounded
    // to `f32` (GDAL and this crate's writer print it in fewer digits than an exact `f64`).
    let narrow = matches!(image, DecodingResult::F32(_));
    let nodata = nodata.map(|v| if narrow { v as f32 as f64 } else { v });
    let heights: Vec<f64> = match image {
        DecodingResult::U8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::U64(v) => v.into_iter().map(|h| h as f64).collect(),
        DecodingResult::I8(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::I64(v) => v.into_iter().map(|h| h as f64).collect(),
        DecodingResult::F16(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F32(v) => v.into_iter().map(f64::from).collect(),
        DecodingResult::F64(v) => v,
    };
    if heights.len() != width as usize * height as usize {
        return Err(fail(format!("{} samples for a {width} × {height} grid", heights.len())));
    }
    if let Some((k, h)) = heights.iter().enumerate().find(|(_, h)| h.is_infinite() && Some(**h) != nodata) {
        return Err(fail(format!("cell ({}, {}) holds {h}: not a height", k % width as usize, k / width as usize)));
    }
    Ok(Dem { width, height, x0, y0, dx, dy, nodata, heights })
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::encoder::{TiffEncoder, colortype};

    /// A 3 × 2 Int16 GeoTIFF with 2 × 3 m cells, the first centred on (100, 200)
    /// (PixelIsPoint), and nodata −9999, written by the `tiff` crate (not by this crate's
    /// writer).
    fn int16_dem(path: &Path) {
        let mut file = std::fs::File::create(path).unwrap();
        let mut tiff = TiffEncoder::new(&mut file).unwrap();
        let mut image = tiff.new_image::<colortype::GrayI16>(3, 2).unwrap();
        image.encoder().write_tag(Tag::ModelPixelScaleTag, &[2.0f64, 3.0, 0.0][..]).unwrap();
        image.encoder().write_tag(Tag::ModelTiepointTag, &[0.0f64, 0.0, 0.0, 100.0, 200.0, 0.0][..]).unwrap();
        image.encoder().write_tag(Tag::GdalNodata, "-9999").unwrap();
        // PixelIsPoint: the tie point names the first cell's centre.
        image.encoder().write_tag(Tag::GeoKeyDirectoryTag, &[1u16, 1, 0, 1, 1025, 0, 1, 2][..]).unwrap();
        image.write_data(&[10i16, 20, -9999, 40, 50, 60]).unwrap();
    }

    #[test]
    fn an_integer_dem_reads_with_its_grid_and_holes() {
        let dir = std::env::temp_dir().join(format!("tileraster-dem-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("int16.tif");
        int16_dem(&path);
        let dem = read_dem(&path).unwrap();
        assert_eq!((dem.width, dem.height, dem.x0, dem.y0, dem.dx, dem.dy, dem.nodata), (3, 2, 99.0, 201.5, 2.0, 3.0, Some(-9999.0)));
        assert_eq!(dem.heights, vec![10.0, 20.0, -9999.0, 40.0, 50.0, 60.0]);
        assert!(dem.has_value(1, 0) && !dem.has_value(2, 0));
        assert_eq!(dem.centre(1, 1), [102.0, 197.0, 50.0]);
        // A Float32 band whose nodata text is shorter than an exact f64 (as GDAL and this
        // crate's writer print it) still matches its cells.
        for nodata in [f32::MIN, -9999.9f32] {
            let grid = tileraster_core::Grid::new(0.0, 2.0, 0.0, 1.0, 2, 1);
            let raster = tileraster_core::Raster {
                grid,
                window: tileraster_core::Window::whole(&grid),
                nodata,
                values: vec![nodata, 7.5],
                owner: None,
                coverage: None,
                colours: None,
                faces: None,
                tiles: None,
                snap_bits: 16,
                stats: Default::default(),
            };
            let path = dir.join("float.tif");
            crate::write_geotiff(&raster, &path).unwrap();
            let dem = read_dem(&path).unwrap();
            assert!(!dem.has_value(0, 0) && dem.has_value(1, 0), "nodata {nodata} read as {:?}", dem.nodata);
        }
        // Not a DEM: a file that is no TIFF, a TIFF without georeferencing.
        std::fs::write(dir.join("text.tif"), "not a tiff").unwrap();
        assert!(read_dem(&dir.join("text.tif")).unwrap_err().to_string().contains("not a readable TIFF"));
        let mut file = std::fs::File::create(dir.join("plain.tif")).unwrap();
        TiffEncoder::new(&mut file).unwrap().write_image::<colortype::Gray32Float>(2, 2, &[1.0, 2.0, 3.0, 4.0]).unwrap();
        assert!(read_dem(&dir.join("plain.tif")).unwrap_err().to_string().contains("not georeferenced"));
    }
}
