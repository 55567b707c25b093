//! A GeoTIFF DEM as a terrain mesh: a vertex at the centre of every cell with a height, two
//! triangles for every 2 × 2 block of cell centres that all have one (each block split along
//! its north-west to south-east diagonal), counter-clockwise seen from above (`+Z` up), in the
//! DEM's own coordinates. Cells without a height (nodata, NaN) leave holes.

use super::Mesh;
use tileraster_io::Dem;

/// The terrain mesh of `dem`. Faces count the blocks row by row from the north-west, two per
/// block (the south-west triangle first), skipping blocks with a hole.
pub fn dem_mesh(dem: &Dem) -> Mesh {
    let (w, h) = (dem.width, dem.height);
    // Each cell's vertex, where it has a height (only those become vertices, so that a nodata
    // value such as −9999 never reaches the mesh's bounds).
    let mut index = vec![u32::MAX; w as usize * h as usize];
    let mut positions = Vec::new();
    for row in 0..h {
        for column in 0..w {
            if dem.has_value(column, row) {
                index[(row * w + column) as usize] = positions.len() as u32;
                positions.push(dem.centre(column, row));
            }
        }
    }
    let mut triangles = Vec::new();
    for row in 0..h.saturating_sub(1) {
        for column in 0..w.saturating_sub(1) {
            let at = |c: u32, r: u32| index[(r * w + c) as usize];
            let (nw, ne, sw, se) = (at(column, row), at(column + 1, row), at(column, row + 1), at(column + 1, row + 1));
            if [nw, ne, sw, se].contains(&u32::MAX) {
                continue;
            }
            // North up: the row below lies south (smaller y), so these turn counter-clockwise.
            triangles.push([nw, sw, se]);
            triangles.push([nw, se, ne]);
        }
    }
    Mesh { positions, triangles, ..Default::default() }
}
