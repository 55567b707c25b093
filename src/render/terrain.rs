//! A GeoTIFF DEM as a terrain mesh: a vertex at the centre of every cell with a height, two
//! triangles for every 2 × 2 block of cell centres that all have one (each block split along
//! its north-west to south-east diagonal), counter-clockwise seen from above (`+Z` up), in the
//! DEM's own coordinates. Cells without a height (nodata, NaN) leave holes.

use super::Mesh;
use std::path::PathBuf;
use tileraster_io::{Dem, IoError};

/// The terrain mesh of `dem`. Faces count the blocks row by row from the north-west, two per
/// block (the south-west triangle first), skipping blocks with a hole.
pub fn dem_mesh(dem: &Dem) -> Result<Mesh, IoError> {
    let (w, h) = (dem.width as usize, dem.height as usize);
    // Each cell's vertex, where it has a height (only those become vertices, so that a nodata
    // value such as −9999 never reaches the mesh's bounds). `read_dem` caps the cells far
    // below `u32::MAX`.
    let mut index = vec![u32::MAX; w * h];
    let valid = (0..w * h).filter(|&k| dem.has_value((k % w) as u32, (k / w) as u32)).count();
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    let reserved = positions.try_reserve_exact(valid).and_then(|()| triangles.try_reserve_exact(2 * valid));
    reserved.map_err(|e| IoError::Format { path: PathBuf::new(), message: format!("{valid} vertices do not fit in memory ({e})") })?;
    for (k, slot) in index.iter_mut().enumerate() {
        let (column, row) = ((k % w) as u32, (k / w) as u32);
        if dem.has_value(column, row) {
            *slot = positions.len() as u32;
            positions.push(dem.centre(column, row));
        }
    }
    for row in 0..h.saturating_sub(1) {
        for column in 0..w.saturating_sub(1) {
            let at = |c: usize, r: usize| index[r * w + c];
            let (nw, ne, sw, se) = (at(column, row), at(column + 1, row), at(column, row + 1), at(column + 1, row + 1));
            if [nw, ne, sw, se].contains(&u32::MAX) {
                continue;
            }
            // North up: the row below lies south (smaller y), so these turn counter-clockwise.
            triangles.push([nw, sw, se]);
            triangles.push([nw, se, ne]);
        }
    }
    Ok(Mesh { positions, triangles, ..Default::default() })
}
