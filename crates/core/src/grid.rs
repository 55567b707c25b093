use crate::Error;
use tileraster_kernels::abi::OutputSet;

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
            return Err(Error::RasterTooLarge { width: w, height: h, reason: format!("each side may be at most {MAX_GRID_DIM} pixels") });
        }
        for (name, v) in [("xmin", self.xmin), ("xmax", self.xmax), ("ymin", self.ymin), ("ymax", self.ymax)] {
            if !v.is_finite() {
                return Err(Error::InvalidExtent { reason: format!("{name} is {v}; it must be a finite number") });
            }
        }
        if self.xmax <= self.xmin {
            return Err(Error::InvalidExtent { reason: format!("xmax ({}) must be greater than xmin ({})", self.xmax, self.xmin) });
        }
        if self.ymax <= self.ymin {
            return Err(Error::InvalidExtent { reason: format!("ymax ({}) must be greater than ymin ({})", self.ymax, self.ymin) });
        }
        let (dx, dy) = (self.dx(), self.dy());
        if !(dx.is_normal() && dy.is_normal()) {
            return Err(Error::InvalidExtent { reason: format!("the cell size ({dx:e} × {dy:e}) is not a normal positive number") });
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
    /// Per `TILE × TILE` tile of the window: its bin's entries and the triangles its depth
    /// bound hid (`Raster::tiles`).
    pub tiles: bool,
}

/// How covered cells get their values: the kernels' [`ValueMode`](tileraster_kernels::abi::ValueMode),
/// one type from the command line to the kernel. Each mode's accuracy bound, and on which
/// adapters its bits match the CPU's, is in `docs/numeric-contract.md`; the tests check exactly
/// that.
pub use tileraster_kernels::abi::ValueMode as Mode;

/// The work the pipeline may skip when the scene does not need it. Every skip is exact: it
/// changes no bit of any output, and the tests check each one by turning it off. All are on
/// by default; turning one off is for measuring its gain and for testing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct Skips {
    /// Triangles that cannot reach the called window are dropped before binning.
    pub cull_window: bool,
    /// Tiles no triangle reaches get no fine-raster work: the part of the window around all
    /// triangles is filled with nodata on the host, and empty tiles inside it write nodata
    /// without per-pixel state.
    pub empty_tiles: bool,
    /// A tile one triangle covers whole skips the per-pixel edge tests.
    pub full_tiles: bool,
    /// When the scene analysis proves that no pixel centre lies inside two triangles (every
    /// TIN, every heightfield), pixels stop at the first triangle they are inside: no
    /// ownership resolution.
    pub overlap_free: bool,
    /// In a depth-tested frame, each tile takes a depth bound from the triangles that cover it
    /// whole and rejects the triangles that lie behind it everywhere: they get no depth test
    /// there (hierarchical depth rejection; `Stats::triangles_hidden` counts them).
    pub hidden_triangles: bool,
    /// In a rendered world of several instances, an instance whose bounding box lies outside
    /// the view frustum gets no vertex work (`GeometryCounts::instances_culled` counts them).
    pub cull_instances: bool,
    /// In a depth-tested frame (one sample per pixel, no blending, no tile counts), triangles whose rectangle
    /// spans at most `SMALL_SIDE` pixels each way skip binning: one invocation each tests its
    /// centres and keeps each pixel's smallest key with an atomic minimum (`fine_small`), and
    /// the tiles walk only the large triangles (`Stats::triangles_small` counts the others).
    pub small_triangles: bool,
}

/// One of the pipeline's skips, by name (see [`Skips`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Skip {
    CullWindow,
    EmptyTiles,
    FullTiles,
    OverlapFree,
    HiddenTriangles,
    CullInstances,
    SmallTriangles,
}

impl Skip {
    pub const ALL: [Skip; 7] =
        [Skip::CullWindow, Skip::EmptyTiles, Skip::FullTiles, Skip::OverlapFree, Skip::HiddenTriangles, Skip::CullInstances, Skip::SmallTriangles];

    /// The name the command line (`--no-skip NAME`) and the reports use.
    pub fn name(self) -> &'static str {
        match self {
            Skip::CullWindow => "cull_window",
            Skip::EmptyTiles => "empty_tiles",
            Skip::FullTiles => "full_tiles",
            Skip::OverlapFree => "overlap_free",
            Skip::HiddenTriangles => "hidden_triangles",
            Skip::CullInstances => "cull_instances",
            Skip::SmallTriangles => "small_triangles",
        }
    }
}

impl std::fmt::Display for Skip {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl std::str::FromStr for Skip {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self, Error> {
        Skip::ALL.into_iter().find(|k| k.name() == s).ok_or_else(|| Error::UnknownName {
            what: "skip",
            name: s.to_string(),
            choices: Skip::ALL.iter().map(|k| k.name()).collect::<Vec<_>>().join(", "),
        })
    }
}

impl Skips {
    pub const ALL: Skips = Skips {
        cull_window: true,
        empty_tiles: true,
        full_tiles: true,
        overlap_free: true,
        hidden_triangles: true,
        cull_instances: true,
        small_triangles: true,
    };
    pub const NONE: Skips = Skips {
        cull_window: false,
        empty_tiles: false,
        full_tiles: false,
        overlap_free: false,
        hidden_triangles: false,
        cull_instances: false,
        small_triangles: false,
    };

    /// All skips but `skip`.
    pub fn all_but(skip: Skip) -> Skips {
        Skips::ALL.without(skip)
    }

    /// These skips without `skip`.
    pub fn without(self, skip: Skip) -> Skips {
        let mut s = self;
        *s.flag(skip) = false;
        s
    }

    /// Whether `skip` is on.
    pub fn has(self, skip: Skip) -> bool {
        let mut s = self;
        *s.flag(skip)
    }

    fn flag(&mut self, skip: Skip) -> &mut bool {
        match skip {
            Skip::CullWindow => &mut self.cull_window,
            Skip::EmptyTiles => &mut self.empty_tiles,
            Skip::FullTiles => &mut self.full_tiles,
            Skip::OverlapFree => &mut self.overlap_free,
            Skip::HiddenTriangles => &mut self.hidden_triangles,
            Skip::CullInstances => &mut self.cull_instances,
            Skip::SmallTriangles => &mut self.small_triangles,
        }
    }
}

impl Default for Skips {
    fn default() -> Self {
        Skips::ALL
    }
}

/// What to rasterise onto: the grid, the value of uncovered cells, the extra outputs, how
/// values are computed and which work may be skipped.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Params {
    pub grid: Grid,
    pub nodata: f32,
    pub outputs: Outputs,
    pub mode: Mode,
    pub skips: Skips,
}

impl Params {
    pub fn new(grid: Grid) -> Self {
        Params { grid, nodata: f32::NAN, outputs: Outputs::default(), mode: Mode::Exact, skips: Skips::ALL }
    }

    pub fn with_skips(mut self, skips: Skips) -> Self {
        self.skips = skips;
        self
    }

    pub fn with_mode(mut self, mode: Mode) -> Self {
        self.mode = mode;
        self
    }

    pub fn with_nodata(mut self, nodata: f32) -> Self {
        self.nodata = nodata;
        self
    }

    pub fn with_outputs(mut self, outputs: Outputs) -> Self {
        self.outputs = outputs;
        self
    }

    pub(crate) fn output_set(&self) -> OutputSet {
        OutputSet::NONE.with(OutputSet::OWNER, self.outputs.owner).with(OutputSet::COVERAGE, self.outputs.coverage).with(OutputSet::TILES, self.outputs.tiles)
    }
}
