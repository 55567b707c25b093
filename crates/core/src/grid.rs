use crate::Error;

/// Largest supported width or height, so pixel coordinates stay comfortably inside `i32`.
pub const MAX_GRID_DIM: u64 = 1 << 30;

/// A north-up raster grid with `gdal_grid` semantics: `-txe xmin xmax -tye ymin ymax
/// -outsize width height`, values sampled at cell centres, row 0 at `ymax`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Grid {
    pub xmin: f64,
    pub xmax: f64,
    pub ymin: f64,
    pub ymax: f64,
    pub width: u32,
    pub height: u32,
}

impl Grid {
    pub fn new(xmin: f64, xmax: f64, ymin: f64, ymax: f64, width: u32, height: u32) -> Self {
        Grid { xmin, xmax, ymin, ymax, width, height }
    }

    /// Cell width in world units.
    pub fn dx(&self) -> f64 {
        (self.xmax - self.xmin) / self.width as f64
    }

    /// Cell height in world units.
    pub fn dy(&self) -> f64 {
        (self.ymax - self.ymin) / self.height as f64
    }

    /// GDAL geotransform: `(xmin, dx, 0, ymax, 0, -dy)`.
    pub fn geotransform(&self) -> [f64; 6] {
        [self.xmin, self.dx(), 0.0, self.ymax, 0.0, -self.dy()]
    }

    /// World coordinates of the centre of pixel `(i, j)` (column, row), as gdal_grid samples.
    pub fn cell_centre(&self, i: u32, j: u32) -> (f64, f64) {
        (self.xmin + (i as f64 + 0.5) * self.dx(), self.ymax - (j as f64 + 0.5) * self.dy())
    }

    /// Raster-space position (pixels from the top-left corner, x right, y down).
    pub fn to_raster(&self, x: f64, y: f64) -> (f64, f64) {
        ((x - self.xmin) / self.dx(), (self.ymax - y) / self.dy())
    }

    pub fn pixel_count(&self) -> u64 {
        self.width as u64 * self.height as u64
    }

    pub fn validate(&self) -> Result<(), Error> {
        let (w, h) = (self.width as u64, self.height as u64);
        if w == 0 || h == 0 {
            return Err(Error::ZeroSizedRaster { width: w, height: h });
        }
        if w > MAX_GRID_DIM || h > MAX_GRID_DIM {
            return Err(Error::RasterTooLarge {
                width: w,
                height: h,
                reason: format!("each side may be at most {MAX_GRID_DIM} pixels"),
            });
        }
        for (name, v) in [("xmin", self.xmin), ("xmax", self.xmax), ("ymin", self.ymin), ("ymax", self.ymax)] {
            if !v.is_finite() {
                return Err(Error::InvalidExtent { reason: format!("{name} is {v}; it must be a finite number") });
            }
        }
        if self.xmax <= self.xmin {
            return Err(Error::InvalidExtent {
                reason: format!("xmax ({}) must be greater than xmin ({})", self.xmax, self.xmin),
            });
        }
        if self.ymax <= self.ymin {
            return Err(Error::InvalidExtent {
                reason: format!("ymax ({}) must be greater than ymin ({})", self.ymax, self.ymin),
            });
        }
        let (dx, dy) = (self.dx(), self.dy());
        if !(dx.is_normal() && dy.is_normal()) {
            return Err(Error::InvalidExtent {
                reason: format!("the cell size ({dx:e} × {dy:e}) is not a normal positive number"),
            });
        }
        Ok(())
    }
}

/// Optional per-pixel outputs beside the height raster.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Outputs {
    /// The index of the triangle that owns each pixel (`u32::MAX` where none does).
    pub owner: bool,
    /// How many triangles cover each pixel centre (1 inside a watertight mesh).
    pub coverage: bool,
}

/// What to rasterise onto: the grid, the value of uncovered cells, and the extra outputs.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub grid: Grid,
    pub nodata: f32,
    pub outputs: Outputs,
}

impl Params {
    pub fn new(grid: Grid) -> Self {
        Params { grid, nodata: f32::NAN, outputs: Outputs::default() }
    }

    pub fn with_nodata(mut self, nodata: f32) -> Self {
        self.nodata = nodata;
        self
    }

    pub fn with_outputs(mut self, outputs: Outputs) -> Self {
        self.outputs = outputs;
        self
    }

    pub(crate) fn output_bits(&self) -> u32 {
        use tileraster_kernels::{OUTPUT_COVERAGE, OUTPUT_OWNER};
        (if self.outputs.owner { OUTPUT_OWNER } else { 0 }) | (if self.outputs.coverage { OUTPUT_COVERAGE } else { 0 })
    }
}
