//! tileraster's kernels: the types shared with the host, one pure function per pipeline
//! stage, and thin `#[spirv(compute)]` entry points.
//!
//! The same source is compiled twice: to SPIR-V by rust-gpu (run through wgpu) and natively
//! (linked into the rayon host dispatcher). Every decision a stage makes is integer
//! arithmetic, so both compilations produce the same bits on every device.
//!
//! Pipeline, per raster window:
//!
//! ```text
//! setup ─▶ bin_count ─▶ bin_scan ─▶ bin_fill ─▶ fine_raster
//! (per      (per          (one        (per         (one workgroup per tile,
//! triangle)  triangle)    workgroup)  triangle)    one invocation per pixel)
//! ```
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod fixed;
pub mod memory;
pub mod stages;
pub mod types;

#[cfg(target_arch = "spirv")]
pub mod entry;

/// Screen tiles are `TILE` × `TILE` pixels; one workgroup rasterises one tile.
pub const TILE: u32 = 16;
/// Invocations in a fine-raster workgroup: one per pixel of a tile.
pub const TILE_PIXELS: u32 = TILE * TILE;
/// Triangles staged in workgroup memory per fine-raster batch.
pub const BATCH: u32 = 64;
/// Invocations per workgroup of the per-triangle stages.
pub const TRIANGLE_GROUP: u32 = 64;
/// Invocations of the single-workgroup prefix sum.
pub const SCAN_GROUP: u32 = 256;
/// Most tiles one binning invocation visits. A triangle larger than that is binned by several
/// invocations, each taking a band of its tile rows: some drivers end an invocation after a
/// fixed number of loop iterations (llvmpipe: 65,535 over all its loops, about 10,900 tiles),
/// silently, so no invocation may loop long.
pub const BIN_PART_TILES: u32 = 4096;
/// Most sub-pixel bits the snapping uses; fewer only for enormous triangles.
pub const MAX_SNAP_BITS: u32 = 16;
/// Snapped triangles must satisfy `(extent_px + 1) << snap_bits < 2^EXTENT_LIMIT_BITS`, which
/// keeps every edge function and plane step inside `i64` (see `stages::setup`).
pub const EXTENT_LIMIT_BITS: u32 = 29;

// `#[spirv(compute(threads(..)))]` takes literals: keep `entry.rs` and these in step.
const _: () = assert!(TILE == 16 && TRIANGLE_GROUP == 64 && SCAN_GROUP == 256);

/// `FrameParams::outputs` bit: write the owning triangle's index per pixel.
pub const OUTPUT_OWNER: u32 = 1;
/// `FrameParams::outputs` bit: write how many triangles cover each pixel centre.
pub const OUTPUT_COVERAGE: u32 = 2;
/// Owner value of a pixel no triangle covers.
pub const NO_OWNER: u32 = u32::MAX;

/// `FrameParams::mode`: the correctly rounded `f32` of the fixed-point plane (the default).
pub const MODE_EXACT: u32 = 0;
/// `FrameParams::mode`: the plane evaluated in `f32` arithmetic.
pub const MODE_PLANE_F32: u32 = 1;
/// `FrameParams::mode`: `f32` barycentric interpolation of the vertex heights.
pub const MODE_BARYCENTRIC: u32 = 2;

/// `FrameParams::flags`: a tile with an empty bin writes nodata without the per-pixel state.
pub const FLAG_EMPTY_TILES: u32 = 1;
/// `FrameParams::flags`: a tile one triangle covers whole skips the edge tests.
pub const FLAG_FULL_TILES: u32 = 2;
/// `FrameParams::flags`: the host proved that no pixel centre is inside two triangles, so a
/// pixel stops testing at the first triangle it is inside (no ownership resolution).
pub const FLAG_OVERLAP_FREE: u32 = 4;

/// Counters fine raster adds to, one increment per tile: tiles that took the empty path...
pub const STAT_TILES_EMPTY: usize = 0;
/// ... the full-tile path...
pub const STAT_TILES_FULL: usize = 1;
/// ... or tested their pixels against their bin.
pub const STAT_TILES_PARTIAL: usize = 2;
/// Length of the statistics buffer.
pub const STAT_COUNTERS: usize = 4;

/// Bit of a bin entry: the triangle covers every pixel centre of the tile (in the window), so
/// the tile needs no edge tests if it is the only entry.
pub const FULL_TILE_BIT: u32 = 1 << 31;
