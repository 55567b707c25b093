use crate::{Grid, Stats, Window};
use rayon::prelude::*;
use tileraster_kernels::pipeline::Layer;

/// The result of a call: Float32 heights for a window of the grid (the whole grid unless a
/// window was asked for), row-major, row 0 at the window's top (north).
#[derive(Debug, Clone, PartialEq)]
pub struct Raster {
    pub grid: Grid,
    pub window: Window,
    pub nodata: f32,
    /// Empty where the call does not return them (a frame without its depth layer).
    pub values: Vec<f32>,
    /// Owning triangle index per pixel (`u32::MAX` where none), when asked for.
    pub owner: Option<Vec<u32>>,
    /// Number of triangles covering each pixel centre, when asked for.
    pub coverage: Option<Vec<u32>>,
    /// The render pipeline's RGBA8 colour per pixel (red in the low byte), where the call
    /// returns it.
    pub colours: Option<Vec<u32>>,
    /// The render pipeline's input face per pixel (`u32::MAX` where none).
    pub faces: Option<Vec<u32>>,
    /// When asked for (`Outputs::tiles`): two words per `TILE × TILE` tile of the window, row
    /// by row: the entries of its bin (the triangles that reach it) and how many of them its
    /// depth bound hid. Zeros for tiles no triangle reaches.
    pub tiles: Option<Vec<u32>>,
    /// Sub-pixel bits of the snapping lattice used (the step is `2^-snap_bits` pixels).
    pub snap_bits: u32,
    /// What the call did and skipped.
    pub stats: Stats,
}

impl Raster {
    /// `layer`'s cells as words, where the raster has it (a values layer it does not return is
    /// empty: none).
    pub fn layer(&self, layer: Layer) -> Option<&[u32]> {
        match layer {
            Layer::Values => (!self.values.is_empty()).then(|| bytemuck::cast_slice(&self.values[..])),
            Layer::Owners => self.owner.as_deref(),
            Layer::Coverage => self.coverage.as_deref(),
            Layer::Colours => self.colours.as_deref(),
            Layer::Faces => self.faces.as_deref(),
            Layer::Tiles => self.tiles.as_deref(),
        }
    }

    /// [`Raster::layer`], to write.
    pub fn layer_mut(&mut self, layer: Layer) -> Option<&mut [u32]> {
        match layer {
            Layer::Values => (!self.values.is_empty()).then(|| bytemuck::cast_slice_mut(&mut self.values[..])),
            Layer::Owners => self.owner.as_deref_mut(),
            Layer::Coverage => self.coverage.as_deref_mut(),
            Layer::Colours => self.colours.as_deref_mut(),
            Layer::Faces => self.faces.as_deref_mut(),
            Layer::Tiles => self.tiles.as_deref_mut(),
        }
    }

    /// Takes `layer`'s memory out of the raster (a values layer leaves an empty one).
    pub fn take_layer(&mut self, layer: Layer) -> Option<Vec<u32>> {
        match layer {
            Layer::Values => Some(bytemuck::allocation::cast_vec(std::mem::take(&mut self.values))).filter(|v: &Vec<u32>| v.capacity() > 0),
            Layer::Owners => self.owner.take(),
            Layer::Coverage => self.coverage.take(),
            Layer::Colours => self.colours.take(),
            Layer::Faces => self.faces.take(),
            Layer::Tiles => self.tiles.take(),
        }
    }

    /// Puts `cells` in as `layer` (`None`: the raster has no such layer).
    pub fn put_layer(&mut self, layer: Layer, cells: Option<Vec<u32>>) {
        match layer {
            Layer::Values => self.values = cells.map(bytemuck::allocation::cast_vec).unwrap_or_default(),
            Layer::Owners => self.owner = cells,
            Layer::Coverage => self.coverage = cells,
            Layer::Colours => self.colours = cells,
            Layer::Faces => self.faces = cells,
            Layer::Tiles => self.tiles = cells,
        }
    }
}

/// A raster's layers as memory for a later call's raster (`Plan::allocate_raster_reusing`),
/// by layer (`tileraster_kernels::pipeline::Layer`), as words.
#[derive(Debug, Default)]
pub struct Layers {
    cells: [Option<Vec<u32>>; Layer::ALL.len()],
}

impl Layers {
    /// These layers with `cells` as `layer`'s (none: as they are).
    pub fn with(mut self, layer: Layer, cells: Option<Vec<u32>>) -> Self {
        if cells.is_some() {
            self.cells[layer as usize] = cells;
        }
        self
    }

    /// [`Layers::with`] for a values layer of `f32`s.
    pub fn with_values(self, values: Option<Vec<f32>>) -> Self {
        self.with(Layer::Values, values.map(bytemuck::allocation::cast_vec))
    }

    /// Takes `layer`'s memory out.
    pub fn take(&mut self, layer: Layer) -> Option<Vec<u32>> {
        self.cells[layer as usize].take()
    }

    /// Each layer's memory from these where they have it, else from `other`.
    pub fn or(self, other: Layers) -> Layers {
        let mut other = other.cells.into_iter();
        Layers { cells: self.cells.map(|cells| cells.or(other.next().flatten())) }
    }
}

/// `len` cells in `spare`'s memory where it holds them (its old entries kept, zeroes after
/// them: for arrays the caller overwrites), else fresh zeroed memory as [`zeroed_cells`] gives
/// (rather than a copy of the old entries into a larger allocation).
pub fn reuse_cells<T: bytemuck::Zeroable + Clone>(spare: Option<Vec<T>>, len: usize) -> Result<Vec<T>, String> {
    match spare {
        Some(mut cells) if cells.capacity() >= len => {
            cells.resize(len, T::zeroed());
            Ok(cells)
        }
        _ => zeroed_cells(len),
    }
}

/// Layers from twice this size up (and below [`FRESH_MAPPING`]) are zeroed on all cores, in
/// pieces of it.
const ZERO_PIECE: usize = 1 << 20;

/// glibc's allocator maps a block of this size or more fresh from the kernel, whose pages read
/// as zeros until first written (its mmap threshold never rises above
/// `DEFAULT_MMAP_THRESHOLD_MAX`, 32 MiB on 64-bit targets, and a block carries a header):
/// `calloc` clears nothing there, and clearing it ourselves would write the layer twice. A
/// heuristic for glibc; other allocators (musl, jemalloc, mimalloc) differ, and there the
/// parallel clear costs at most one extra pass over a fresh block.
const FRESH_MAPPING: usize = 32 << 20;

/// `len` zeroed cells the way a raster's layers are allocated (what a store-bandwidth
/// roofline should allocate too), or why not.
///
/// A layer of 2 MiB up to 32 MiB is zeroed on all cores here rather than by the allocator:
/// once a process has freed such a block, glibc serves the next one from its heap and `calloc`
/// clears it on one core (a 1080p frame's layers took 3 ms so on a 2-core host; on a 16-core
/// one, with the fill of the frame's inactive border, 7 ms of a 13 ms GPU call).
pub fn zeroed_cells<T: bytemuck::Zeroable>(len: usize) -> Result<Vec<T>, String> {
    let bytes = len as u128 * std::mem::size_of::<T>() as u128;
    let layout = std::alloc::Layout::array::<T>(len).map_err(|e| format!("{bytes} bytes ({e})"))?;
    if layout.size() == 0 {
        return Ok(Vec::new());
    }
    // SAFETY: the layout has a non-zero size; `T: Zeroable` makes all-zero bytes a valid `T`;
    // the pointer comes from the global allocator with `T`'s layout for `len` elements, as
    // `Vec::from_raw_parts` requires.
    unsafe {
        let size = layout.size();
        let zero_here = (2 * ZERO_PIECE..FRESH_MAPPING).contains(&size);
        let ptr = if zero_here { std::alloc::alloc(layout) } else { std::alloc::alloc_zeroed(layout) };
        if ptr.is_null() {
            return Err(format!("allocating {bytes} bytes failed"));
        }
        advise_huge_pages(ptr, size);
        if zero_here {
            // The address as an integer: each piece is written by one task alone.
            let base = ptr as usize;
            (0..size.div_ceil(ZERO_PIECE)).into_par_iter().for_each(|k| {
                let start = k * ZERO_PIECE;
                // SAFETY: the piece lies inside the allocation, and no other task writes it.
                std::ptr::write_bytes((base + start) as *mut u8, 0, ZERO_PIECE.min(size - start));
            });
        }
        Ok(Vec::from_raw_parts(ptr.cast::<T>(), len, len))
    }
}

/// Ask Linux to back a large fresh allocation with transparent huge pages: the first stores
/// into a 64 MiB raster then fault 32 pages in instead of 16,384 (where the system allows
/// them; otherwise nothing changes). Memory contents are untouched.
#[cfg(target_os = "linux")]
fn advise_huge_pages(ptr: *mut u8, bytes: usize) {
    const PAGE: usize = 4096;
    const HUGE_PAGE: usize = 2 << 20;
    if bytes < 2 * HUGE_PAGE {
        return;
    }
    let start = (ptr as usize).next_multiple_of(PAGE);
    let end = (ptr as usize + bytes) & !(PAGE - 1);
    // SAFETY: the range lies inside an allocation we own; the advice changes no contents.
    unsafe {
        libc::madvise(start as *mut libc::c_void, end - start, libc::MADV_HUGEPAGE);
    }
}

#[cfg(not(target_os = "linux"))]
fn advise_huge_pages(_ptr: *mut u8, _bytes: usize) {}

impl Raster {
    /// The value at window pixel `(i, j)` (of a raster that returns its values: not a frame's
    /// without its depth layer).
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
        // Tile statistics: a difference is placed by the word's index in the layer.
        layer("tiles", &mut self.tiles.iter().flatten().copied(), &mut other.tiles.iter().flatten().copied());
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
