//! Twins of the fine-raster entry points (`fine_raster`, `fine_depth`), two ways:
//!
//! - the plain twin ([`FinePath::Plain`], `plain.rs`) runs each tile as the GPU runs its
//!   workgroup: the entry point's branches and the stage functions, invocation by invocation;
//! - the fast paths take a tile's phases the CPU's way round where the result cannot tell:
//!   each triangle against a row of 16 pixels (`rows.rs`; the GPU's pixels test triangles in
//!   turn, and `fine::accumulate` does not depend on the order), the heightfield's whole and
//!   overlap-free tiles written row by row (`height.rs`), the depth test centre by centre or
//!   in lanes (`depth.rs`), and the whole band compiled for AVX-512 where the CPU has it
//!   (`wide.rs`).
//!
//! The default runs every fast path where it applies. Each fast path also has a
//! [`FinePath`] of its own that runs it alone, every other tile as the plain twin does: the
//! parity tests run each against the plain twin on every scene, for the same bits and
//! statistics.
//!
//! `band.rs` holds what the paths share: a row of tiles' part of the output layers, and the
//! statistics counters.

mod band;
mod depth;
mod height;
mod plain;
mod rows;
mod wide;

#[cfg(test)]
mod tests;

pub(crate) use band::StatCounters;
use tileraster_core::Raster;
use tileraster_kernels::abi::{FrameFlags, FrameParams, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::programs::height::HeightProgram;

use super::{SmallSeeds, SmallTriangles};
pub(crate) use plain::fine_raster_plain;

/// Which fine-raster twin runs: every fast path (the default), the plain twin that runs each
/// tile as the GPU runs its workgroup, or one fast path alone (the rest of the tiles plain).
/// All give the same bits and statistics; the tests run each on every parity scene.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FinePath {
    /// Every fast path where it applies, the AVX-512 build where the CPU has it.
    #[default]
    Specialised,
    /// The entry point's branches and the stage functions, invocation by invocation.
    Plain,
    /// [`FinePath::Plain`] with the heightfield's pixels walking their bins (`fine::fine_walk`:
    /// the GPU backend's way for short bins on a CPU implementation of Vulkan).
    Walk,
    /// Heightfield tiles with an empty bin, or one triangle covering them whole, written row by
    /// row (`height::fine_resolve_empty_tile`, `height::fine_resolve_full_tile`).
    WholeTiles,
    /// Heightfield partial tiles of a frame proven overlap-free: each triangle writes its rows
    /// of the tile, 16 lanes at a time (`height::fine_raster_tile_overlap_free`).
    OverlapFreeRows,
    /// Heightfield partial tiles where triangles may overlap: each triangle against its rows
    /// of the tile, 16 lanes at a time (`height::fine_raster_tile_overlapping`).
    OverlappingRows,
    /// The depth test centre by centre, each triangle against its rows of the tile
    /// (`depth::fine_depth_tile`; the default's path without AVX-512).
    DepthCentres,
    /// The depth test 16 lanes at a time (`depth::fine_depth_tile_rows`; the default's path
    /// with AVX-512), here built for the CPU's baseline.
    DepthLanes,
}

impl FinePath {
    /// The fast paths of `fine_raster` (the heightfield), all of them first: the tests run
    /// each against the plain twin.
    pub const HEIGHTFIELD: [FinePath; 5] = [FinePath::Specialised, FinePath::Walk, FinePath::WholeTiles, FinePath::OverlapFreeRows, FinePath::OverlappingRows];
    /// The fast paths of `fine_depth` (the render pipeline), all of them first.
    pub const DEPTH: [FinePath; 3] = [FinePath::Specialised, FinePath::DepthCentres, FinePath::DepthLanes];

    /// Whether the path takes the heightfield's tiles of `kind` its own way (else the plain
    /// twin takes them).
    fn takes(self, kind: height::TileKind) -> bool {
        use height::TileKind::*;
        match self {
            FinePath::Specialised => true,
            FinePath::WholeTiles => matches!(kind, Empty | Full),
            FinePath::OverlapFreeRows => kind == OverlapFree,
            FinePath::OverlappingRows => kind == Overlapping,
            FinePath::Plain | FinePath::Walk | FinePath::DepthCentres | FinePath::DepthLanes => false,
        }
    }
}

/// Twin of the `fine_raster` entry point: one workgroup per tile, the tiles of a row as one
/// rayon task.
pub fn fine_raster(path: FinePath, frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], raster: &mut Raster) -> StatCounters {
    match path {
        FinePath::Plain => fine_raster_plain(&HeightProgram::of(frame), false, frame, setups, offsets, bins, &SmallSeeds::default(), raster),
        FinePath::Walk => fine_raster_plain(&HeightProgram::of(frame), true, frame, setups, offsets, bins, &SmallSeeds::default(), raster),
        FinePath::Specialised => height::fine_raster_using(path, wide::wide_vectors(), frame, setups, offsets, bins, raster),
        _ => height::fine_raster_using(path, false, frame, setups, offsets, bins, raster),
    }
}

/// Twin of the `fine_depth` entry point (the render pipeline's depth test): the CPU's way
/// round (the default), or as the GPU runs its workgroups; each pixel starts from what the
/// small triangles left (`fine_small`), which the fast paths take binned apart instead.
#[allow(clippy::too_many_arguments)]
pub fn fine_depth(
    path: FinePath,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    small: &SmallTriangles,
    raster: &mut Raster,
) -> StatCounters {
    let program = DepthProgram::of(frame);
    // `FinePath::bins_small` makes the small triangles' form for the path; given the other
    // form, the path that takes it runs (the same bits).
    match (path.depth_way(frame), small) {
        (way, SmallTriangles::Binned(small)) => {
            depth::fine_depth_using(way.unwrap_or(depth::Way::Centres), &program, frame, setups, offsets, bins, small, raster)
        }
        (_, SmallTriangles::Seeded(seeds)) => fine_raster_plain(&program, false, frame, setups, offsets, bins, seeds, raster),
    }
}

impl FinePath {
    /// How `fine_depth` takes a frame: a fast path's way, or `None` for the plain twin. Render
    /// frames never take the full-tile path (the depth test needs every fragment's key); a
    /// frame that allowed it goes the GPU's way.
    fn depth_way(self, frame: &FrameParams) -> Option<depth::Way> {
        if frame.flags.contains(FrameFlags::FULL_TILES) {
            return None;
        }
        match self {
            FinePath::Specialised => Some(depth::Way::fastest(wide::wide_vectors())),
            FinePath::DepthCentres => Some(depth::Way::Centres),
            FinePath::DepthLanes => Some(depth::Way::Lanes),
            FinePath::Plain | FinePath::Walk | FinePath::WholeTiles | FinePath::OverlapFreeRows | FinePath::OverlappingRows => None,
        }
    }

    /// Whether `fine_small`'s twin bins the frame's small triangles apart for this path (a fast
    /// path of `fine_depth`) rather than running them as the GPU does (the plain twin).
    pub fn bins_small(self, frame: &FrameParams) -> bool {
        self.depth_way(frame).is_some()
    }
}
