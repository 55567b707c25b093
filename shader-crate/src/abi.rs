//! The interface between the host and the kernels: plain-old-data buffers (`#[repr(C)]` with
//! no implicit padding, so the bytes the host uploads are the bytes the SPIR-V reads) and the
//! typed codes inside them (`#[repr(u32)]` enums and flag sets). Host and kernels name every
//! mode, flag, output and counter through these types; no bare numbers cross the boundary.

#[cfg(not(target_arch = "spirv"))]
use bytemuck::{Pod, Zeroable};

/// How covered values are computed (`FrameParams::mode`). Each mode's accuracy bound, and on
/// which adapters its bits match the CPU's, is in `docs/numeric-contract.md`.
#[repr(u32)]
#[derive(Copy, Clone, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum ValueMode {
    /// The correctly rounded `f32` of the plane through the unsnapped vertices, evaluated
    /// exactly in fixed point: within 0.5 ulp (plus the plane's 2^-60 quantisation) and
    /// bit-identical on every backend.
    #[default]
    Exact = 0,
    /// The same plane evaluated in `f32` arithmetic: cheaper on GPUs without fast `i64`.
    PlaneF32 = 1,
    /// `f32` barycentric interpolation of the vertex heights on the snapped triangle, as a
    /// hardware rasteriser does it.
    Barycentric = 2,
}

impl ValueMode {
    /// The mode a `FrameParams::mode` word names. The host writes only valid codes; anything
    /// else reads as `Exact` so that a kernel never has an unnamed state.
    #[inline]
    pub fn from_code(code: u32) -> ValueMode {
        if code == ValueMode::PlaneF32 as u32 {
            ValueMode::PlaneF32
        } else if code == ValueMode::Barycentric as u32 {
            ValueMode::Barycentric
        } else {
            ValueMode::Exact
        }
    }
}

#[cfg(not(target_arch = "spirv"))]
impl ValueMode {
    pub const ALL: [ValueMode; 3] = [ValueMode::Exact, ValueMode::PlaneF32, ValueMode::Barycentric];

    /// The name the command line and the reports use.
    pub fn name(self) -> &'static str {
        match self {
            ValueMode::Exact => "exact",
            ValueMode::PlaneF32 => "plane-f32",
            ValueMode::Barycentric => "barycentric",
        }
    }
}

#[cfg(not(target_arch = "spirv"))]
impl core::str::FromStr for ValueMode {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        ValueMode::ALL.into_iter().find(|m| m.name() == s).ok_or_else(|| {
            let names: Vec<_> = ValueMode::ALL.iter().map(|m| m.name()).collect();
            format!("unknown mode '{s}'; choose one of {}", names.join(", "))
        })
    }
}

/// A set of bits of one `u32` word, named by the constants of its type.
macro_rules! flag_set {
    ($(#[$doc:meta])* $name:ident { $($(#[$fdoc:meta])* $flag:ident = $bit:expr,)* }) => {
        $(#[$doc])*
        #[repr(transparent)]
        #[derive(Copy, Clone, Default, PartialEq, Eq)]
        #[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, Hash))]
        pub struct $name(pub u32);

        impl $name {
            pub const NONE: $name = $name(0);
            $($(#[$fdoc])* pub const $flag: $name = $name($bit);)*

            /// Whether every bit of `other` is set.
            #[inline]
            pub const fn contains(self, other: $name) -> bool {
                self.0 & other.0 == other.0
            }

            /// These bits, with those of `other` set when `on`.
            #[inline]
            pub const fn with(self, other: $name, on: bool) -> $name {
                if on { $name(self.0 | other.0) } else { $name(self.0 & !other.0) }
            }
        }
    };
}

flag_set! {
    /// The specialisations a frame may use (`FrameParams::flags`). None changes a result; each
    /// only skips work.
    FrameFlags {
        /// A tile with an empty bin writes nodata without the per-pixel state.
        EMPTY_TILES = 1,
        /// A tile one triangle covers whole skips the edge tests.
        FULL_TILES = 2,
        /// The host proved that no pixel centre is inside two triangles, so a pixel stops
        /// testing at the first triangle it is inside (no ownership resolution).
        OVERLAP_FREE = 4,
    }
}

flag_set! {
    /// The per-pixel layers a frame writes besides the values (`FrameParams::outputs`).
    OutputSet {
        /// The owning triangle's index per pixel.
        OWNER = 1,
        /// How many triangles cover each pixel centre.
        COVERAGE = 2,
    }
}

/// The statistics counters fine raster adds to, one increment per tile, by index into the
/// statistics buffer.
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug))]
pub enum Counter {
    /// Tiles that took the empty path...
    TilesEmpty = 0,
    /// ... the full-tile path...
    TilesFull = 1,
    /// ... or tested their pixels against their bin.
    TilesPartial = 2,
}

impl Counter {
    /// Length of the statistics buffer (one spare word keeps it 16 bytes).
    pub const COUNT: usize = 4;
}

/// Pixels `i0..=i1` × `j0..=j1` (inclusive, grid coordinates, row 0 at the top).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct PixelRect {
    pub i0: i32,
    pub j0: i32,
    pub i1: i32,
    pub j1: i32,
}

impl PixelRect {
    pub fn is_empty(&self) -> bool {
        self.i0 > self.i1 || self.j0 > self.j1
    }

    pub fn contains(&self, i: i32, j: i32) -> bool {
        i >= self.i0 && i <= self.i1 && j >= self.j0 && j <= self.j1
    }
}

/// A height plane in fixed point, relative to the pixel `(rect.i0, rect.j0)`:
/// `value(i, j) = (z + gi·(i − i0) + gj·(j − j0)) · 2^−frac_bits`, exact in `i64` over the
/// triangle's pixel rectangle (the host picks `frac_bits` so that it is).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct Plane {
    pub z: i64,
    pub gi: i64,
    pub gj: i64,
    pub frac_bits: i32,
    pub _pad: u32,
}

/// A triangle as the host prepares it: vertices snapped to the grid's fixed-point lattice
/// (`1 px = 2^snap_bits` units, x right, y down) in positive orientation, its pixel
/// rectangle clipped to the grid, and its height plane.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct TriangleInput {
    pub x: [i64; 3],
    pub y: [i64; 3],
    pub rect: PixelRect,
    pub plane: Plane,
    /// Index of the triangle in the scene: the lowest index owns overlapping pixels.
    pub index: u32,
    pub _pad: u32,
    /// The cheaper modes' `f32` coefficients (see [`FloatCoeffs`]); zero in exact mode.
    pub coeffs: FloatCoeffs,
}

/// What the cheaper value modes interpolate with, in `f32`:
/// - `ValueMode::PlaneF32`: `c = [z, gi, gj, 0]`, the plane relative to the rectangle's corner
///   pixel, evaluated as `(z + gi·Δi) + gj·Δj`;
/// - `ValueMode::Barycentric`: `c = [h0, h1, h2, 1/Σw]`, `hk` the height of the vertex opposite
///   edge `k`, so the value is `Σ (wk · c3) · hk` with `wk` the edge functions.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct FloatCoeffs {
    pub c: [f32; 4],
}

/// One edge function stepped over pixels: `e(i, j) = e0 + step_i·(i − i0) + step_j·(j − j0)`,
/// positive on the triangle's side of the edge.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct EdgeEq {
    pub e0: i64,
    pub step_i: i64,
    pub step_j: i64,
}

/// What the coverage test needs of a triangle, staged in workgroup memory by fine raster.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct Coverage {
    pub edges: [EdgeEq; 3],
    pub rect: PixelRect,
    pub index: u32,
    /// Position of the triangle in the setup buffer, to fetch its plane once it wins.
    pub slot: u32,
    /// Bit `k` set: edge `k` is not top-left, so by the fill rule it does not own the pixel
    /// centres exactly on it.
    pub excluded_edges: u32,
    pub _pad: u32,
}

/// Output of the setup stage, one per prepared triangle.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct TriangleSetup {
    pub coverage: Coverage,
    pub plane: Plane,
    pub coeffs: FloatCoeffs,
}

/// Everything a dispatch needs to know about the window of the grid it rasterises.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct FrameParams {
    pub win_x0: u32,
    pub win_y0: u32,
    pub win_w: u32,
    pub win_h: u32,
    pub tiles_x: u32,
    pub tiles_y: u32,
    /// Triangles the binning stages take: entries of the frame's list of setup slots.
    pub triangles: u32,
    pub snap_bits: u32,
    pub nodata_bits: u32,
    /// The layers written besides the values.
    pub outputs: OutputSet,
    /// Invocations per row of a 2D dispatch that stands for a 1D one (per-triangle stages).
    pub dispatch_width: u32,
    /// How covered values are computed: a [`ValueMode`] code.
    pub mode: u32,
    /// Tile rows each binning invocation takes of its triangle (see `BIN_PART_TILES`)...
    pub bin_part_rows: u32,
    /// ... and invocations per triangle, enough for the tallest triangle of the window.
    pub bin_parts: u32,
    /// The specialisations this frame may use.
    pub flags: FrameFlags,
    pub _pad: u32,
}

impl FrameParams {
    pub fn tile_count(&self) -> u32 {
        self.tiles_x * self.tiles_y
    }

    #[inline]
    pub fn value_mode(&self) -> ValueMode {
        ValueMode::from_code(self.mode)
    }
}
