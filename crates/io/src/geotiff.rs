use crate::{write_atomically, IoError};
use std::path::Path;
use tiff::encoder::{colortype::Gray32Float, TiffEncoder};
use tiff::tags::Tag;
use tileraster_core::Raster;

/// GeoKey directory: version 1.1.0, two keys: GTModelTypeGeoKey = user-defined (no CRS
/// given), GTRasterTypeGeoKey = PixelIsArea (cell corners at the geotransform's lattice).
const GEO_KEYS: [u16; 12] = [1, 1, 0, 2, 1024, 0, 1, 32767, 1025, 0, 1, 1];

/// Write a raster as a single-band Float32 GeoTIFF with the geotransform `gdal_grid` writes
/// for the same grid (north-up, row 0 at the top of the window) and the `GDAL_NODATA` tag.
pub fn write_geotiff(raster: &Raster, path: &Path) -> Result<(), IoError> {
    let grid = &raster.grid;
    let (dx, dy) = (grid.dx(), grid.dy());
    // The window's own top-left corner.
    let x0 = grid.xmin + raster.window.x0 as f64 * dx;
    let y0 = grid.ymax - raster.window.y0 as f64 * dy;
    write_atomically(path, |out| {
        let e = |e: tiff::TiffError| e.to_string();
        let mut tiff = TiffEncoder::new(out).map_err(e)?;
        let mut image = tiff.new_image::<Gray32Float>(raster.width(), raster.height()).map_err(e)?;
        let dir = image.encoder();
        dir.write_tag(Tag::ModelPixelScaleTag, &[dx, dy, 0.0][..]).map_err(e)?;
        dir.write_tag(Tag::ModelTiepointTag, &[0.0, 0.0, 0.0, x0, y0, 0.0][..]).map_err(e)?;
        dir.write_tag(Tag::GeoKeyDirectoryTag, &GEO_KEYS[..]).map_err(e)?;
        dir.write_tag(Tag::GdalNodata, nodata_text(raster.nodata).as_str()).map_err(e)?;
        image.write_data(&raster.values).map_err(e)
    })
}

/// The nodata value as GDAL writes it: shortest text that reads back to the same f32.
fn nodata_text(v: f32) -> String {
    if v.is_nan() { "nan".into() } else { format!("{v}") }
}
