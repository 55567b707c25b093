//! gdal_grid's grid semantics: the extent is kept, the size given in cells or derived from a
//! cell size; row 0 lies at the top (`tye[1]`).

use super::DemError;
use crate::{Grid, Window, MAX_GRID_DIM};

/// A grid as gdal_grid's flags give it: `-txe XMIN XMAX`, `-tye YMIN YMAX`, and `-outsize` or
/// `-tr`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    pub txe: [f64; 2],
    pub tye: [f64; 2],
    pub size: GridSize,
}

/// How the grid's size is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GridSize {
    /// Cells along x and y (`-outsize`).
    Cells { width: u32, height: u32 },
    /// Cell size in world units (`-tr`): each extent over its cell size, rounded to the
    /// nearest whole cell; the extent is kept.
    Resolution { x: f64, y: f64 },
}

impl GridSpec {
    /// The grid, validated.
    pub fn grid(&self) -> Result<Grid, DemError> {
        let [xmin, xmax] = self.txe;
        let [ymin, ymax] = self.tye;
        let (width, height) = match self.size {
            GridSize::Cells { width, height } => (width, height),
            GridSize::Resolution { x, y } => (cells_for(xmax - xmin, x, 'x')?, cells_for(ymax - ymin, y, 'y')?),
        };
        let grid = Grid::new(xmin, xmax, ymin, ymax, width, height);
        grid.validate()?;
        Ok(grid)
    }
}

/// gdal_grid's `-tr`: cells along an extent, `floor(extent / res + 0.5)`.
fn cells_for(extent: f64, res: f64, axis: char) -> Result<u32, DemError> {
    if !(res.is_finite() && res > 0.0) {
        return Err(DemError::CellSize { axis, res });
    }
    let cells = (extent / res + 0.5).floor();
    if !(1.0..=MAX_GRID_DIM as f64).contains(&cells) {
        return Err(DemError::CellCount { axis, extent, res, cells });
    }
    Ok(cells as u32)
}

/// Part `k` (counted from 0) of `n` equal bands of the grid's rows (the last may be shorter):
/// the window a cluster job's index picks.
pub fn part_window(grid: &Grid, k: u32, n: u32) -> Result<Window, DemError> {
    let rows = grid.height.div_ceil(n.max(1));
    let y0 = k as u64 * rows as u64;
    if k >= n || y0 >= grid.height as u64 {
        return Err(DemError::NoSuchPart { k, n, rows: grid.height, parts: grid.height.div_ceil(rows), part_rows: rows });
    }
    Ok(Window { x0: 0, y0: y0 as u32, width: grid.width, height: rows.min(grid.height - y0 as u32) })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_sizes_round_to_whole_cells_and_keep_the_extent() {
        let spec = GridSpec { txe: [0.0, 10.0], tye: [5.0, 8.0], size: GridSize::Resolution { x: 0.3, y: 0.7 } };
        let grid = spec.grid().unwrap();
        // 10 / 0.3 = 33.3 → 33; 3 / 0.7 = 4.29 → 4.
        assert_eq!((grid.width, grid.height, grid.xmin, grid.xmax, grid.ymin, grid.ymax), (33, 4, 0.0, 10.0, 5.0, 8.0));
        let bad = GridSpec { size: GridSize::Resolution { x: 0.0, y: 1.0 }, ..spec };
        assert!(matches!(bad.grid(), Err(DemError::CellSize { axis: 'x', .. })));
        let huge = GridSpec { size: GridSize::Resolution { x: 1.0, y: 1e-9 }, ..spec };
        assert!(matches!(huge.grid(), Err(DemError::CellCount { axis: 'y', .. })));
    }

    #[test]
    fn parts_cover_the_rows_once() {
        let grid = Grid::new(0.0, 1.0, 0.0, 1.0, 7, 10);
        let parts: Vec<Window> = (0..4).map(|k| part_window(&grid, k, 4).unwrap()).collect();
        assert_eq!(parts.iter().map(|w| (w.y0, w.height)).collect::<Vec<_>>(), [(0, 3), (3, 3), (6, 3), (9, 1)]);
        // 10 rows in parts of 2 make 5 parts: part 5 of 6 is beyond them.
        assert!(matches!(part_window(&grid, 5, 6), Err(DemError::NoSuchPart { parts: 5, .. })));
        assert!(matches!(part_window(&grid, 3, 3), Err(DemError::NoSuchPart { .. })));
    }
}
