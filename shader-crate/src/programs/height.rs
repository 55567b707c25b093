//! The heightfield's pixel program: the lowest-index triangle owns a pixel (the scene's order,
//! as gdal_grid's first hit), the hull's edges are covered, and the value is the owner's
//! height at the pixel centre in the frame's [`ValueMode`], as `f32` bits.

use crate::NO_OWNER;
use crate::abi::{Coverage, FloatCoeffs, FrameParams, PixelRect, Plane, TriangleSetup, ValueMode};
use crate::math::fixed::{fixed_to_f32_bits, i32_to_f32, i64_to_f32};
use crate::stages::fine::PixelProgram;

/// Heights of the frame's triangles: [`PixelProgram`] for the heightfield pipeline.
#[derive(Copy, Clone)]
pub struct HeightProgram {
    pub mode: ValueMode,
    pub nodata_bits: u32,
}

impl HeightProgram {
    /// The program a frame asks for.
    #[inline]
    pub fn of(frame: &FrameParams) -> HeightProgram {
        HeightProgram { mode: frame.value_mode(), nodata_bits: frame.nodata_bits }
    }

    /// [`Self::of`] with the value mode fixed by `variant` where it is not
    /// [`Self::GENERIC_MODE`]: `mode as u32 + 1`, the `fine_raster` entry point's
    /// specialisation constant [`Self::MODE_SPEC_ID`], which the GPU backend sets to the frame's
    /// mode so that the driver compiles that mode's arithmetic alone (a CPU implementation of
    /// Vulkan runs every branch).
    #[inline]
    pub fn specialised(frame: &FrameParams, variant: u32) -> HeightProgram {
        let mode = if variant == Self::GENERIC_MODE { frame.value_mode() } else { ValueMode::from_code(variant - 1) };
        HeightProgram { mode, nodata_bits: frame.nodata_bits }
    }

    /// The `SpecId` of the `fine_raster` entry point's value mode.
    pub const MODE_SPEC_ID: u32 = 1;
    /// Its default: the frame's mode, read at run time.
    pub const GENERIC_MODE: u32 = 0;
    /// A bit of the same constant: the tile's pixels walk its bin each on their own
    /// (`fine::fine_walk`), with no batches staged and no barrier in the pipeline.
    pub const WALK: u32 = crate::stages::fine::WALK;
}

impl PixelProgram for HeightProgram {
    type Setup = TriangleSetup;
    type Staged = Coverage;
    type Key = u32;
    type Value = u32;
    const NO_KEY: u32 = NO_OWNER;
    const HULL_EDGES: bool = true;

    #[inline(always)]
    fn staged(setup: &TriangleSetup) -> &Coverage {
        &setup.coverage
    }

    #[inline(always)]
    fn coverage(staged: &Coverage) -> &Coverage {
        staged
    }

    /// The triangle's index: the scene's order decides.
    #[inline(always)]
    fn key(&self, staged: &Coverage, _i: i32, _j: i32) -> u32 {
        staged.index
    }

    #[inline(always)]
    fn value(&self, setup: &TriangleSetup, i: i32, j: i32) -> u32 {
        pixel_value_bits(setup, i, j, self.mode)
    }

    #[inline(always)]
    fn background(&self) -> u32 {
        self.nodata_bits
    }
}

/// The owner's plane at pixel `(i, j)`, correctly rounded to `f32`, or `±f32::MAX` where it
/// lies beyond the `f32` range. Inside a triangle the plane lies between the vertex heights;
/// only a centre that snapping lets it cover from just outside can be beyond them.
#[inline]
pub fn plane_value_bits(plane: &Plane, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    saturate_infinity(fixed_to_f32_bits(plane.z + plane.gi * di + plane.gj * dj, plane.frac_bits))
}

/// `±∞` becomes `±f32::MAX` (the bits just below); every other value stays.
#[inline]
pub fn saturate_infinity(bits: u32) -> u32 {
    if bits & 0x7fff_ffff == 0x7f80_0000 { bits - 1 } else { bits }
}

/// `ValueMode::PlaneF32`: `(z + gi·Δi) + gj·Δj` in `f32`. `Δi`, `Δj` convert exactly (they are below
/// 2^24); each product and sum rounds once, unless a device contracts `a·b + c`.
#[inline]
pub fn plane_f32_bits(coeffs: &FloatCoeffs, rect: &PixelRect, i: i32, j: i32) -> u32 {
    let c = &coeffs.c;
    let di = (i - rect.i0) as f32;
    let dj = (j - rect.j0) as f32;
    (c[0] + c[1] * di + c[2] * dj).to_bits()
}

/// `ValueMode::Barycentric`: the barycentric weights `wk / Σw` of the snapped triangle in `f32`, as a
/// hardware rasteriser computes them, times the vertex heights. The edge functions are
/// converted with the exact integer conversion so that only the products and sums round.
#[inline]
pub fn barycentric_bits(s: &TriangleSetup, i: i32, j: i32) -> u32 {
    let rect = &s.coverage.rect;
    let di = (i - rect.i0) as i64;
    let dj = (j - rect.j0) as i64;
    let e = &s.coverage.edges;
    barycentric_bits_of(s, [e[0].at(di, dj), e[1].at(di, dj), e[2].at(di, dj)])
}

/// [`barycentric_bits`] from the edge functions' values at a point (a pixel centre, or one of
/// its samples).
#[inline]
pub fn barycentric_bits_of(s: &TriangleSetup, edges: [i64; 3]) -> u32 {
    let c = &s.coeffs.c;
    let weight = |k: usize| i64_to_f32(edges[k]) * c[3];
    (weight(0) * c[0] + weight(1) * c[1] + weight(2) * c[2]).to_bits()
}

/// [`barycentric_bits_of`] for edge values in `(−2^31, 2^31)` (`stages::setup::edges_fit_i32`),
/// converted in 32-bit operations: the same bits.
#[inline]
pub fn barycentric_bits_small(s: &TriangleSetup, edges: [i64; 3]) -> u32 {
    let c = &s.coeffs.c;
    let weight = |k: usize| i32_to_f32(edges[k] as i32) * c[3];
    (weight(0) * c[0] + weight(1) * c[1] + weight(2) * c[2]).to_bits()
}

/// The value bits of pixel `(i, j)` on the triangle in setup slot `slot`, in the frame's mode.
#[inline]
pub fn pixel_value_bits(s: &TriangleSetup, i: i32, j: i32, mode: ValueMode) -> u32 {
    match mode {
        ValueMode::PlaneF32 => plane_f32_bits(&s.coeffs, &s.coverage.rect, i, j),
        ValueMode::Barycentric => barycentric_bits(s, i, j),
        ValueMode::Exact => plane_value_bits(&s.plane, &s.coverage.rect, i, j),
    }
}
