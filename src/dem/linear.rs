//! gdal_grid's `linear:radius=R:nodata=V`: inside the TIN, the rasteriser's values; outside
//! every triangle, the z of the nearest input point within R (any distance for R < 0,
//! gdal_grid's default; none for R = 0), chosen as gdal_grid 3.6 chooses it
//! ([`tileraster_tin::NearestPoints`]), at the cell centres gdal_grid computes.

use crate::{Grid, Raster};
use rayon::prelude::*;
use tileraster_tin::NearestPoints;

/// How cells outside every triangle are filled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Linear {
    /// `> 0`: the nearest point within this distance (gdal_grid 3.6 searches the square
    /// `[x − R, x + R] × [y − R, y + R]`); `< 0`: the nearest at any distance; `0`: none,
    /// the cells keep nodata (tileraster's default).
    pub radius: f64,
    /// `nodata=V`, when given: the value of cells left empty (and the file's nodata tag).
    pub nodata: Option<f32>,
}

impl Default for Linear {
    /// No fallback: cells outside every triangle are nodata.
    fn default() -> Self {
        Linear { radius: 0.0, nodata: None }
    }
}

impl std::str::FromStr for Linear {
    type Err = String;

    /// gdal_grid's `-a` spelling: `linear`, `linear:radius=-1`, `linear:radius=5:nodata=-9999`.
    /// Bare `linear` has gdal_grid's radius, −1.
    fn from_str(text: &str) -> Result<Linear, String> {
        let mut parts = text.split(':');
        let name = parts.next().unwrap_or_default();
        if !name.eq_ignore_ascii_case("linear") {
            return Err(format!("algorithm '{name}': tileraster interpolates linearly in a TIN; give linear[:radius=R][:nodata=V]"));
        }
        let mut linear = Linear { radius: -1.0, nodata: None };
        for option in parts {
            let (key, value) = option.split_once('=').ok_or_else(|| format!("'{option}' in '{text}' is not NAME=VALUE"))?;
            let number = || value.trim().parse::<f64>().map_err(|_| format!("{key}={value}: '{value}' is not a number"));
            match key.trim().to_ascii_lowercase().as_str() {
                "radius" if number()?.is_nan() => return Err(format!("radius={value}: give a number (negative: any distance)")),
                "radius" => linear.radius = number()?,
                "nodata" => linear.nodata = Some(number()? as f32),
                other => return Err(format!("linear has no option '{other}'; it takes radius=R and nodata=V")),
            }
        }
        Ok(linear)
    }
}

/// The nearest-point fallback over a point set.
pub struct Fallback {
    points: NearestPoints,
    radius: f64,
}

impl Fallback {
    /// Over `points`: every input point, repeats included, in file order, as gdal_grid reads
    /// them (a mesh's vertices for a mesh). `None` when the radius is 0.
    pub fn new(points: &[[f64; 3]], radius: f64) -> Option<Fallback> {
        (radius != 0.0).then(|| Fallback { points: NearestPoints::new(points), radius })
    }

    /// Fill the cells of `raster` that no triangle covers (its owner layer is `u32::MAX`
    /// there); returns how many were filled. The raster must have its owner layer.
    pub fn fill(&self, raster: &mut Raster) -> u64 {
        let owner = raster.owner.as_deref().expect("the fallback needs the owner layer");
        let (width, window) = (raster.window.width as usize, raster.window);
        let centres = CellCentres::of(&raster.grid);
        raster
            .values
            .par_chunks_mut(width)
            .zip(owner.par_chunks(width))
            .enumerate()
            .map(|(j, (values, owners))| {
                let y = centres.y(window.y0 + j as u32);
                let mut filled = 0;
                for (i, (value, _)) in values.iter_mut().zip(owners).enumerate().filter(|(_, (_, owner))| **owner == u32::MAX) {
                    if let Some(z) = self.points.value(centres.x(window.x0 + i as u32), y, self.radius) {
                        // As GDAL writes a double to a Float32 band: rounded to nearest.
                        *value = z as f32;
                        filled += 1;
                    }
                }
                filled
            })
            .sum()
    }
}

/// Cell centres as gdal_grid computes them: from the extent's west and north edges in steps
/// recomputed from the extent (`((x0 + dx·n) − x0) / n`), row 0 at the north.
struct CellCentres {
    west: f64,
    north: f64,
    dx: f64,
    dy: f64,
}

impl CellCentres {
    fn of(grid: &Grid) -> CellCentres {
        let (nx, ny) = (grid.width as f64, grid.height as f64);
        let dx = ((grid.xmin + ((grid.xmax - grid.xmin) / nx) * nx) - grid.xmin) / nx;
        let dy = ((grid.ymax + ((grid.ymin - grid.ymax) / ny) * ny) - grid.ymax) / ny;
        CellCentres { west: grid.xmin, north: grid.ymax, dx, dy }
    }

    fn x(&self, i: u32) -> f64 {
        self.west + (i as f64 + 0.5) * self.dx
    }

    fn y(&self, j: u32) -> f64 {
        self.north + (j as f64 + 0.5) * self.dy
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gdal_grids_spelling_is_parsed() {
        assert_eq!("linear".parse(), Ok(Linear { radius: -1.0, nodata: None }));
        assert_eq!("linear:radius=2.5:nodata=-9999".parse(), Ok(Linear { radius: 2.5, nodata: Some(-9999.0) }));
        assert_eq!("LINEAR:nodata=0:radius=0".parse(), Ok(Linear { radius: 0.0, nodata: Some(0.0) }));
        assert!("invdist:power=2".parse::<Linear>().unwrap_err().contains("give linear[:radius=R][:nodata=V]"));
        assert!("linear:radius=far".parse::<Linear>().unwrap_err().contains("'far' is not a number"));
        assert!("linear:smoothing=1".parse::<Linear>().unwrap_err().contains("no option 'smoothing'"));
        assert!("linear:radius".parse::<Linear>().unwrap_err().contains("not NAME=VALUE"));
    }
}
