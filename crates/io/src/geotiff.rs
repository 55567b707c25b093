use crate::{write_atomically, IoError};
use std::path::Path;
use tiff::encoder::compression::{CompressionAlgorithm, Deflate, DeflateLevel};
use tiff::encoder::{colortype::Gray32Float, Compression, DirectoryEncoder, TiffEncoder, TiffKindStandard};
use tiff::tags::Tag;
use tileraster_core::Raster;

/// How a GeoTIFF is written; the default is gdal_grid's: strips, uncompressed, no CRS.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct GeoTiffOptions {
    /// The CRS as an EPSG code, written as GeoKeys (gdal_grid's `-a_srs EPSG:n`).
    pub epsg: Option<u16>,
    /// `TILE` × `TILE` tiles instead of strips (`-co TILED=YES`).
    pub tiled: bool,
    /// Deflate compression (`-co COMPRESS=DEFLATE`).
    pub deflate: bool,
}

/// Side of a tile in tiled output, as GDAL's default.
pub const TILE: u32 = 256;

impl GeoTiffOptions {
    /// Apply a creation option as gdal_grid takes them (`TILED=YES`, `COMPRESS=DEFLATE`, ...).
    pub fn apply(&mut self, option: &str) -> Result<(), String> {
        let (name, value) = option.split_once('=').ok_or_else(|| format!("creation option '{option}' is not NAME=VALUE"))?;
        match (name.to_ascii_uppercase().as_str(), value.to_ascii_uppercase().as_str()) {
            ("TILED", "YES" | "TRUE" | "ON") => self.tiled = true,
            ("TILED", "NO" | "FALSE" | "OFF") => self.tiled = false,
            ("COMPRESS", "DEFLATE") => self.deflate = true,
            ("COMPRESS", "NONE") => self.deflate = false,
            _ => return Err(format!("unsupported creation option '{option}'; supported: TILED=YES|NO, COMPRESS=DEFLATE|NONE")),
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

/// [`write_geotiff`] with a CRS, tiles or compression.
pub fn write_geotiff_with(raster: &Raster, path: &Path, options: &GeoTiffOptions) -> Result<(), IoError> {
    let bytes = raster.values.len() as u64 * 4;
    if bytes > u32::MAX as u64 - (1 << 20) {
        return Err(IoError::Format {
            path: path.to_owned(),
            message: format!("{bytes} bytes of raster: more than a classic TIFF holds (4 GiB); write it in windows"),
        });
    }
    write_atomically(path, |out| {
        let e = |e: tiff::TiffError| e.to_string();
        let compression = if options.deflate { Compression::Deflate(DeflateLevel::Balanced) } else { Compression::Uncompressed };
        let mut tiff = TiffEncoder::new(out).map_err(e)?.with_compression(compression);
        if options.tiled {
            let mut dir = tiff.image_directory().map_err(e)?;
            write_tiles(&mut dir, raster, options.deflate).map_err(e)?;
            write_geo_tags(&mut dir, raster, options).map_err(e)?;
            dir.finish().map_err(e)
        } else {
            let mut image = tiff.new_image::<Gray32Float>(raster.width(), raster.height()).map_err(e)?;
            write_geo_tags(image.encoder(), raster, options).map_err(e)?;
            image.write_data(&raster.values).map_err(e)
        }
    })
}

type Directory<'a, 'w> = DirectoryEncoder<'a, &'w mut std::io::BufWriter<std::fs::File>, TiffKindStandard>;

fn write_geo_tags(dir: &mut Directory, raster: &Raster, options: &GeoTiffOptions) -> tiff::TiffResult<()> {
    let grid = &raster.grid;
    let (dx, dy) = (grid.dx(), grid.dy());
    // The window's own top-left corner.
    let x0 = grid.xmin + raster.window.x0 as f64 * dx;
    let y0 = grid.ymax - raster.window.y0 as f64 * dy;
    dir.write_tag(Tag::ModelPixelScaleTag, &[dx, dy, 0.0][..])?;
    dir.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, x0, y0, 0.0][..])?;
    dir.write_tag(Tag::GeoKeyDirectoryTag, &geo_keys(options.epsg)[..])?;
    dir.write_tag(Tag::GdalNodata, nodata_text(raster.nodata).as_str())
}

/// The image as `TILE` × `TILE` tiles, row by row of tiles, edge tiles padded with nodata;
/// then the tags that describe them.
fn write_tiles(dir: &mut Directory, raster: &Raster, deflate: bool) -> tiff::TiffResult<()> {
    let (w, h) = (raster.width(), raster.height());
    let (across, down) = (w.div_ceil(TILE), h.div_ceil(TILE));
    let mut offsets = Vec::with_capacity((across * down) as usize);
    let mut counts = Vec::with_capacity(offsets.capacity());
    let mut tile = vec![0u8; (TILE * TILE * 4) as usize];
    let pad = raster.nodata.to_le_bytes();
    for ty in 0..down {
        for tx in 0..across {
            for row in 0..TILE {
                let line = &mut tile[(row * TILE * 4) as usize..][..(TILE * 4) as usize];
                let (y, x0) = (ty * TILE + row, tx * TILE);
                let inside = if y < h { (w - x0).min(TILE) } else { 0 };
                let start = y as usize * w as usize + x0 as usize;
                for (k, cell) in line.as_chunks_mut::<4>().0.iter_mut().enumerate() {
                    let v = if (k as u32) < inside { raster.values[start + k].to_le_bytes() } else { pad };
                    cell.copy_from_slice(&v);
                }
            }
            let data = if deflate {
                let mut packed = Vec::new();
                Deflate::with_level(DeflateLevel::Balanced).write_to(&mut packed, &tile)?;
                packed
            } else {
                tile.clone()
            };
            offsets.push(u32::try_from(dir.write_data(&data[..])?).map_err(|_| std::io::Error::other("offset beyond 4 GiB"))?);
            counts.push(data.len() as u32);
        }
    }
    dir.write_tag(Tag::ImageWidth, w)?;
    dir.write_tag(Tag::ImageLength, h)?;
    dir.write_tag(Tag::BitsPerSample, 32u16)?;
    dir.write_tag(Tag::SampleFormat, 3u16)?; // IEEE floating point
    dir.write_tag(Tag::SamplesPerPixel, 1u16)?;
    dir.write_tag(Tag::PhotometricInterpretation, 1u16)?; // BlackIsZero
    dir.write_tag(Tag::PlanarConfiguration, 1u16)?;
    dir.write_tag(Tag::Compression, if deflate { 8u16 } else { 1u16 })?;
    dir.write_tag(Tag::TileWidth, TILE)?;
    dir.write_tag(Tag::TileLength, TILE)?;
    dir.write_tag(Tag::TileOffsets, &offsets[..])?;
    dir.write_tag(Tag::TileByteCounts, &counts[..])
}

/// The nodata value as GDAL writes it: shortest text that reads back to the same f32.
fn nodata_text(v: f32) -> String {
    if v.is_nan() { "nan".into() } else { format!("{v}") }
}

#[cfg(test)]
mod tests {
    use super::*;
    use tiff::decoder::{Decoder, DecodingResult};
    use tileraster_core::{Grid, Window};

    fn raster(w: u32, h: u32) -> Raster {
        let grid = Grid::new(500_000.0, 500_000.0 + w as f64, 5_000_000.0, 5_000_000.0 + h as f64, w, h);
        let values = (0..w * h).map(|k| if k % 7 == 0 { -9999.0 } else { k as f32 * 0.25 }).collect();
        Raster { grid, window: Window::whole(&grid), nodata: -9999.0, values, owner: None, coverage: None, snap_bits: 16, stats: Default::default() }
    }

    fn read(path: &Path) -> (Vec<f32>, Vec<u16>, Option<u32>, u16) {
        let mut d = Decoder::new(std::io::BufReader::new(std::fs::File::open(path).unwrap())).unwrap();
        let keys = d.get_tag_u16_vec(Tag::GeoKeyDirectoryTag).unwrap();
        let tile = d.find_tag(Tag::TileWidth).unwrap().map(|v| v.into_u32().unwrap());
        let compression = d.get_tag_u32(Tag::Compression).unwrap() as u16;
        let DecodingResult::F32(values) = d.read_image().unwrap() else { panic!("not Float32") };
        (values, keys, tile, compression)
    }

    #[test]
    fn tiles_compression_and_crs_keep_every_value() {
        let dir = std::env::temp_dir().join(format!("tileraster-geotiff-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let r = raster(600, 300); // edge tiles on both sides
        for (k, options) in [
            GeoTiffOptions::default(),
            GeoTiffOptions { tiled: true, ..Default::default() },
            GeoTiffOptions { deflate: true, ..Default::default() },
            GeoTiffOptions { tiled: true, deflate: true, epsg: Some(32633) },
            GeoTiffOptions { epsg: Some(4326), ..Default::default() },
        ]
        .into_iter()
        .enumerate()
        {
            let path = dir.join(format!("{k}.tif"));
            write_geotiff_with(&r, &path, &options).unwrap();
            let (values, keys, tile, compression) = read(&path);
            assert_eq!(values.len(), r.values.len(), "{options:?}");
            assert!(values.iter().zip(&r.values).all(|(a, b)| a.to_bits() == b.to_bits()), "{options:?}");
            assert_eq!(tile, options.tiled.then_some(TILE), "{options:?}");
            assert_eq!(compression, if options.deflate { 8 } else { 1 }, "{options:?}");
            assert_eq!(keys, geo_keys(options.epsg), "{options:?}");
        }
        // 32633 is projected, 4326 geographic.
        assert_eq!(&geo_keys(Some(32633))[12..], &[3072, 0, 1, 32633]);
        assert_eq!(&geo_keys(Some(4326))[12..], &[2048, 0, 1, 4326]);
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
        assert_eq!(o, GeoTiffOptions { tiled: true, deflate: true, epsg: None });
        assert!(o.apply("COMPRESS=JPEG").unwrap_err().contains("supported: TILED=YES|NO, COMPRESS=DEFLATE|NONE"));
        assert!(o.apply("TILED").unwrap_err().contains("not NAME=VALUE"));
    }
}
