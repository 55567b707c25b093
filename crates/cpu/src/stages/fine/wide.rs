//! The fast paths' bands compiled for AVX-512 (`vcvtqq2ps` converts eight 64-bit fixed-point
//! values to `f32` at once, correctly rounded as the scalar conversion is, and `vpmullq`
//! multiplies them), called only where the CPU has it: the same code and the same bits.

use super::super::SmallBins;
use super::FinePath;
use super::band::{Band, StatCounters};
use super::depth::fine_depth_band_rows;
use super::height::fine_raster_band;
use tileraster_kernels::abi::{FrameParams, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;

/// Every `fine_depth` workgroup of one row of tiles, rows of lanes at a time, compiled for
/// AVX-512 (`vcvtqq2ps` converts eight 64-bit edge functions to `f32` at once, correctly
/// rounded as the scalar conversion is; the products and sums are the scalar ones, lane by
/// lane).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
#[allow(clippy::too_many_arguments)]
pub(super) fn fine_depth_band_wide(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    small: &SmallBins,
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_depth_band_rows(program, frame, setups, offsets, bins, small, band, stats)
}

#[cfg(not(target_arch = "x86_64"))]
#[allow(clippy::too_many_arguments)]
pub(super) unsafe fn fine_depth_band_wide(
    program: &DepthProgram,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    small: &SmallBins,
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_depth_band_rows(program, frame, setups, offsets, bins, small, band, stats)
}

/// Whether the CPU has the vector instructions that turn a row of fixed-point values into
/// `f32` eight at a time (AVX-512 `vcvtqq2ps`, `vpmullq`).
pub(super) fn wide_vectors() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::is_x86_feature_detected!("avx512f") && std::is_x86_feature_detected!("avx512dq") && std::is_x86_feature_detected!("avx512vl")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// [`fine_raster_band`] compiled for AVX-512: the same code, the same bits (integer and
/// correctly rounded conversion instructions only), vectorised by the compiler.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f,avx512dq,avx512vl")]
pub(super) fn fine_raster_band_wide(
    path: FinePath,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_raster_band(path, frame, setups, offsets, bins, band, stats)
}

#[cfg(not(target_arch = "x86_64"))]
pub(super) unsafe fn fine_raster_band_wide(
    path: FinePath,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    band: &mut Band,
    stats: &StatCounters,
) {
    fine_raster_band(path, frame, setups, offsets, bins, band, stats)
}
