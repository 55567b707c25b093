use crate::{Error, Grid, Window};

/// The result of a call: Float32 heights for a window of the grid (the whole grid unless a
/// window was asked for), row-major, row 0 at the window's top (north).
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    pub grid: Grid,
    pub window: Window,
    pub nodata: f32,
    pub values: Vec<f32>,
    /// Owning triangle index per pixel (`u32::MAX` where none), when asked for.
    pub owner: Option<Vec<u32>>,
    /// Number of triangles covering each pixel centre, when asked for.
    pub coverage: Option<Vec<u32>>,
    /// Sub-pixel bits of the snapping lattice used (the step is `2^-snap_bits` pixels).
    pub snap_bits: u32,
}

/// A zeroed `Vec`, or a clear error instead of an abort when memory runs out.
pub(crate) fn try_zeroed<T: Copy + Default>(len: usize, window: &Window) -> Result<Vec<T>, Error> {
    let mut v = Vec::new();
    v.try_reserve_exact(len).map_err(|e| Error::RasterTooLarge {
        width: window.width as u64,
        height: window.height as u64,
        reason: format!("allocating {} bytes failed ({e})", len as u128 * std::mem::size_of::<T>() as u128),
    })?;
    v.resize(len, T::default());
    Ok(v)
}

impl Raster {
    /// The value at window pixel `(i, j)`.
    pub fn value(&self, i: u32, j: u32) -> f32 {
        self.values[j as usize * self.window.width as usize + i as usize]
    }

    pub fn width(&self) -> u32 {
        self.window.width
    }

    pub fn height(&self) -> u32 {
        self.window.height
    }

    /// Whether `(i, j)` holds the nodata value (bit for bit, so NaN nodata works too).
    pub fn is_nodata(&self, i: u32, j: u32) -> bool {
        self.value(i, j).to_bits() == self.nodata.to_bits()
    }

    /// Compare two rasters bit for bit (values, owner and coverage): the number of differing
    /// cells and the first `limit` of them.
    pub fn compare_bits(&self, other: &Raster, limit: usize) -> (u64, Vec<Difference>) {
        let mut count = 0;
        let mut first = Vec::new();
        let width = self.window.width.max(1);
        let mut layer = |name: &'static str, a: &mut dyn Iterator<Item = u32>, b: &mut dyn Iterator<Item = u32>| {
            let mut k = 0u64;
            loop {
                let (x, y) = (a.next(), b.next());
                if x.is_none() && y.is_none() {
                    break;
                }
                if x != y {
                    count += 1;
                    if first.len() < limit {
                        let (i, j) = ((k % width as u64) as u32, (k / width as u64) as u32);
                        first.push(Difference { layer: name, i, j, left: x, right: y });
                    }
                }
                k += 1;
            }
        };
        layer("value", &mut self.values.iter().map(|v| v.to_bits()), &mut other.values.iter().map(|v| v.to_bits()));
        layer("owner", &mut self.owner.iter().flatten().copied(), &mut other.owner.iter().flatten().copied());
        layer("coverage", &mut self.coverage.iter().flatten().copied(), &mut other.coverage.iter().flatten().copied());
        (count, first)
    }
}

/// A cell where two rasters differ: the layer, the window pixel, and both sides' bits
/// (`None` where one raster has no such cell).
#[derive(Debug, Clone, PartialEq)]
pub struct Difference {
    pub layer: &'static str,
    pub i: u32,
    pub j: u32,
    pub left: Option<u32>,
    pub right: Option<u32>,
}

impl std::fmt::Display for Difference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let show = |v: Option<u32>| match (v, self.layer) {
            (None, _) => "missing".to_string(),
            (Some(b), "value") => format!("{:e} (0x{b:08x})", f32::from_bits(b)),
            (Some(b), _) => b.to_string(),
        };
        write!(f, "{} at pixel ({}, {}): {} vs {}", self.layer, self.i, self.j, show(self.left), show(self.right))
    }
}
