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
//!
//! Fine raster is generic over what a pixel computes (`stages::fine::PixelProgram`); the
//! programs live in `programs/` (today: `height`).
#![cfg_attr(target_arch = "spirv", no_std)]

pub mod abi;
pub mod math;
pub mod memory;
#[cfg(not(target_arch = "spirv"))]
pub mod pipeline;
pub mod programs;
pub mod stages;

#[cfg(target_arch = "spirv")]
pub mod entry;

/// Screen tiles are `TILE` × `TILE` pixels; one workgroup rasterises one tile.
pub const TILE: u32 = 16;
/// Invocations in a fine-raster workgroup: one per pixel of a tile.
pub const TILE_PIXELS: u32 = TILE * TILE;
/// Pixels each invocation of the shade stage colours, two rows apart (`entry::shade_pixels`;
/// its workgroup is `TILE × TILE / SHADE_PASSES`: 32 invocations, one NVIDIA warp). On
/// lavapipe, against one pixel each, 4 took the Phong terrain's `shade` 116 → 91 ms, 8 to 86
/// and 16 to 80, but 16 leaves half of a 32-lane warp idle.
pub const SHADE_PASSES: u32 = 8;
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

/// Owner value of a pixel no triangle covers.
pub const NO_OWNER: u32 = u32::MAX;

/// Bit of a bin entry: the triangle covers every pixel centre of the tile (in the window), so
/// the tile needs no edge tests if it is the only entry.
pub const FULL_TILE_BIT: u32 = 1 << 31;
