//! A GeoTIFF DEM as a terrain mesh: a vertex at the centre of every cell with a height, two
//! triangles for every 2 × 2 block of cell centres that all have one (each block split along
//! its north-west to south-east diagonal), counter-clockwise seen from above (`+Z` up), in the
//! DEM's own coordinates. Cells without a height (nodata, NaN) leave holes.
//!
//! Or, for the kernels' built-in heightfield program (`VertexStage::HEIGHTS`), the same faces
//! over a flat grid of every cell's centre and the heights as a vertex texture ([`dem_grid`]):
//! the vertex stage lifts the grid, so a prepared DEM's frames hand over the heights once and a
//! vertical exaggeration is a constant of the frame.

use super::{Mesh, VertexTexture};
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

/// The terrain of `dem` for the built-in heightfield program (`VertexStage::HEIGHTS`, with
/// `vertex_constants[0] = 1`): a vertex at every cell's centre at height 0, row by row, the
/// faces of [`dem_mesh`] in its order, and the heights as the vertex texture (0 in the cells
/// without one, whose vertices no face uses). Posed, its positions are [`dem_mesh`]'s wherever
/// the heights are `f32` values (a GeoTIFF's `Float32` band): `None` where one is not, or the
/// grid is too large for one vertex texture.
pub fn dem_grid(dem: &Dem) -> Option<(Mesh, VertexTexture)> {
    let (w, h) = (dem.width as usize, dem.height as usize);
    let has = |k: usize| dem.has_value((k % w) as u32, (k / w) as u32);
    let exact = (0..w * h).filter(|&k| has(k)).all(|k| dem.heights[k] as f32 as f64 == dem.heights[k]);
    if !exact || w * h > u32::MAX as usize {
        return None;
    }
    let texels = (0..w * h).map(|k| if has(k) { dem.heights[k] as f32 } else { 0.0 }).collect();
    let positions = (0..w * h).map(|k| dem.centre((k % w) as u32, (k / w) as u32)).map(|[x, y, _]| [x, y, 0.0]).collect();
    let mut triangles = Vec::new();
    for row in 0..h.saturating_sub(1) {
        for column in 0..w.saturating_sub(1) {
            let at = |c: usize, r: usize| r * w + c;
            let (nw, ne, sw, se) = (at(column, row), at(column + 1, row), at(column, row + 1), at(column + 1, row + 1));
            if ![nw, ne, sw, se].into_iter().all(has) {
                continue;
            }
            triangles.push([nw, sw, se].map(|v| v as u32));
            triangles.push([nw, se, ne].map(|v| v as u32));
        }
    }
    let texture = VertexTexture { width: dem.width, height: dem.height, texels };
    Some((Mesh { positions, triangles, ..Default::default() }, texture))
}
