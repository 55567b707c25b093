//! Plain-old-data types shared by the host and the kernels. `#[repr(C)]` with no implicit
//! padding, so the bytes the host uploads are the bytes the SPIR-V reads.

#[cfg(not(target_arch = "spirv"))]
use bytemuck::{Pod, Zeroable};

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
/// - `MODE_PLANE_F32`: `c = [z, gi, gj, 0]`, the plane relative to the rectangle's corner
///   pixel, evaluated as `(z + gi·Δi) + gj·Δj`;
/// - `MODE_BARYCENTRIC`: `c = [h0, h1, h2, 1/Σw]`, `hk` the height of the vertex opposite
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
    /// `OUTPUT_OWNER | OUTPUT_COVERAGE` bits.
    pub outputs: u32,
    /// Invocations per row of a 2D dispatch that stands for a 1D one (per-triangle stages).
    pub dispatch_width: u32,
    /// How covered values are computed: `MODE_EXACT`, `MODE_PLANE_F32` or `MODE_BARYCENTRIC`.
    pub mode: u32,
    /// Tile rows each binning invocation takes of its triangle (see `BIN_PART_TILES`)...
    pub bin_part_rows: u32,
    /// ... and invocations per triangle, enough for the tallest triangle of the window.
    pub bin_parts: u32,
    /// The specialisations this frame may use: `FLAG_EMPTY_TILES | FLAG_FULL_TILES |
    /// FLAG_OVERLAP_FREE` bits. None changes a result; each only skips work.
    pub flags: u32,
    pub _pad: u32,
}

impl FrameParams {
    pub fn tile_count(&self) -> u32 {
        self.tiles_x * self.tiles_y
    }
}
