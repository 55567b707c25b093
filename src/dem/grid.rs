//! gdal_grid's grid semantics: the extent is kept, the size given in cells or derived from a
//! cell size; row 0 lies at the top (`tye[1]`). Without an extent the input's is taken, as
//! gdal_grid does, and `--tap` aligns it to the cell size, as GDAL's tools do.

use super::DemError;
use crate::{Grid, MAX_GRID_DIM, Window};

/// A grid as gdal_grid's flags give it: `-txe XMIN XMAX`, `-tye YMIN YMAX`, and `-outsize` or
/// `-tr`, with GDAL's `-tap`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridSpec {
    /// The x extent; `None`: the input's (its vertices' or points' least and greatest x).
    pub txe: Option<[f64; 2]>,
    /// The y extent; `None`: the input's.
    pub tye: Option<[f64; 2]>,
    pub size: GridSize,
    /// Align the extent to whole multiples of the cell size (`-tap`; needs a cell size):
    /// the least one is rounded down, the greatest up, so the grid covers the extent.
    pub tap: bool,
}

/// How the grid's size is given.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum GridSize {
    /// Cells along x and y (`-outsize`).
    Cells { width: u32, height: u32 },
    /// Cell size in world units (`-tr`). With an extent given (and no `tap`), gdal_grid's
    /// rule: each extent over its cell size, rounded to the nearest whole cell, and the extent
    /// kept. Otherwise cells of exactly this size from the extent's west and north edges, as
    /// many as round the extent to whole cells (gdalwarp's rule for `-tr` without `-te`).
    Resolution { x: f64, y: f64 },
}

impl GridSpec {
    /// The grid of an extent given in full; [`grid_for`](Self::grid_for) takes a missing one
    /// from the input.
    pub fn grid(&self) -> Result<Grid, DemError> {
        match (self.txe, self.tye) {
            (Some(txe), Some(tye)) => self.grid_over(txe, tye, true),
            _ => Err(DemError::NoExtent),
        }
    }

    /// What can be checked before the input is read: the whole grid when its extent is given
    /// (returned), otherwise the size (`--tap` with a size in cells, cell sizes).
    pub fn check(&self) -> Result<Option<Grid>, DemError> {
        match (self.txe, self.tye) {
            (Some(_), Some(_)) => self.grid().map(Some),
            _ => self.check_size().map(|_| None),
        }
    }

    fn check_size(&self) -> Result<(), DemError> {
        match self.size {
            GridSize::Cells { .. } if self.tap => Err(DemError::TapNeedsResolution),
            GridSize::Cells { .. } => Ok(()),
            GridSize::Resolution { x, y } => positive(x, 'x').and(positive(y, 'y')),
        }
    }

    /// The grid, with the extent `vertices` span (x and y) where none is given.
    pub fn grid_for(&self, vertices: &[[f64; 3]]) -> Result<Grid, DemError> {
        let span = |axis: usize| vertices.iter().fold([f64::INFINITY, f64::NEG_INFINITY], |[lo, hi], v| [lo.min(v[axis]), hi.max(v[axis])]);
        let given = self.txe.is_some() && self.tye.is_some();
        if !given && vertices.is_empty() {
            return Err(DemError::EmptyExtent);
        }
        self.grid_over(self.txe.unwrap_or_else(|| span(0)), self.tye.unwrap_or_else(|| span(1)), given)
    }

    fn grid_over(&self, [mut xmin, mut xmax]: [f64; 2], [mut ymin, mut ymax]: [f64; 2], given: bool) -> Result<Grid, DemError> {
        self.check_size()?;
        let (width, height) = match self.size {
            GridSize::Cells { width, height } => (width, height),
            GridSize::Resolution { x, y } => {
                if self.tap {
                    (xmin, xmax) = ((xmin / x).floor() * x, (xmax / x).ceil() * x);
                    (ymin, ymax) = ((ymin / y).floor() * y, (ymax / y).ceil() * y);
                }
                let (width, height) = (cells_for(xmax - xmin, x, 'x')?, cells_for(ymax - ymin, y, 'y')?);
                if !given || self.tap {
                    // Exactly the cell size, from the west and north edges.
                    xmax = xmin + width as f64 * x;
                    ymin = ymax - height as f64 * y;
                }
                (width, height)
            }
        };
        let grid = Grid::new(xmin, xmax, ymin, ymax, width, height);
        grid.validate()?;
        Ok(grid)
    }
}

fn positive(res: f64, axis: char) -> Result<(), DemError> {
    match res.is_finite() && res > 0.0 {
        true => Ok(()),
        false => Err(DemError::CellSize { axis, res }),
    }
}

/// gdal_grid's `-tr`: cells along an extent, `floor(extent / res + 0.5)`.
fn cells_for(extent: f64, res: f64, axis: char) -> Result<u32, DemError> {
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
    use crate::Scene;

    #[test]
    fn cell_sizes_round_to_whole_cells_and_keep_the_extent() {
        let spec = GridSpec { txe: Some([0.0, 10.0]), tye: Some([5.0, 8.0]), size: GridSize::Resolution { x: 0.3, y: 0.7 }, tap: false };
        let grid = spec.grid().unwrap();
        // 10 / 0.3 = 33.3 → 33; 3 / 0.7 = 4.29 → 4.
        assert_eq!((grid.width, grid.height, grid.xmin, grid.xmax, grid.ymin, grid.ymax), (33, 4, 0.0, 10.0, 5.0, 8.0));
        let bad = GridSpec { size: GridSize::Resolution { x: 0.0, y: 1.0 }, ..spec };
        assert!(matches!(bad.grid(), Err(DemError::CellSize { axis: 'x', .. })));
        let huge = GridSpec { size: GridSize::Resolution { x: 1.0, y: 1e-9 }, ..spec };
        assert!(matches!(huge.grid(), Err(DemError::CellCount { axis: 'y', .. })));
    }

    /// Without an extent the input's is taken: kept whole with a size in cells (gdal_grid),
    /// from its west and north edges in cells of exactly the size asked with `--tr`
    /// (gdalwarp); `--tap` aligns either to the cell size and covers it.
    #[test]
    fn the_inputs_extent_is_taken_when_none_is_given() {
        let scene = Scene::new(vec![[10.3, 20.6, 0.0], [15.2, 20.1, 0.0], [12.0, 24.45, 0.0]], vec![[0, 1, 2]]);
        let cells = GridSpec { txe: None, tye: None, size: GridSize::Cells { width: 7, height: 9 }, tap: false };
        let g = cells.grid_for(&scene.vertices).unwrap();
        assert_eq!((g.xmin, g.xmax, g.ymin, g.ymax, g.width, g.height), (10.3, 15.2, 20.1, 24.45, 7, 9));
        assert!(matches!(cells.grid(), Err(DemError::NoExtent)));
        // 4.9 / 0.5 = 9.8 → 10 cells from x 10.3; 4.35 / 0.5 = 8.7 → 9 cells down from y 24.45.
        let tr = GridSpec { size: GridSize::Resolution { x: 0.5, y: 0.5 }, ..cells };
        let g = tr.grid_for(&scene.vertices).unwrap();
        assert_eq!((g.xmin, g.ymax, g.width, g.height, g.dx(), g.dy()), (10.3, 24.45, 10, 9, 0.5, 0.5));
        // Aligned: x 10 to 15.5, y 20 to 24.5.
        let g = GridSpec { tap: true, ..tr }.grid_for(&scene.vertices).unwrap();
        assert_eq!((g.xmin, g.xmax, g.ymin, g.ymax, g.width, g.height), (10.0, 15.5, 20.0, 24.5, 11, 9));
        // A given extent is aligned too; the other axis still comes from the input.
        let g = GridSpec { txe: Some([0.2, 3.9]), tap: true, ..tr }.grid_for(&scene.vertices).unwrap();
        assert_eq!((g.xmin, g.xmax, g.width, g.ymin, g.ymax), (0.0, 4.0, 8, 20.0, 24.5));
        assert!(matches!(GridSpec { tap: true, ..cells }.grid_for(&scene.vertices), Err(DemError::TapNeedsResolution)));
        // Before the input is read: the size alone, or the whole grid when the extent is given.
        assert!(matches!(GridSpec { tap: true, ..cells }.check(), Err(DemError::TapNeedsResolution)));
        assert!(matches!(GridSpec { size: GridSize::Resolution { x: -1.0, y: 1.0 }, ..cells }.check(), Err(DemError::CellSize { axis: 'x', .. })));
        assert_eq!(tr.check().unwrap(), None);
        assert_eq!(GridSpec { txe: Some([0.0, 5.0]), tye: Some([0.0, 2.0]), ..tr }.check().unwrap().map(|g| (g.width, g.height)), Some((10, 4)));
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
