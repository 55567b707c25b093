//! The pipeline, written once: every kernel stage in the order it runs, with its entry point,
//! the buffers it binds (in binding order) and the shape of its dispatch.
//!
//! - The GPU backend builds its pipelines, bind group layouts and bind groups from this table
//!   and dispatches the stages in its order.
//! - The CPU backend runs the twin of each stage (same name) in the same order.
//! - `Stats::passes` names the kernel passes by the table's names.
//!
//! The entry points in `entry.rs` must bind what the table says: a test reads the compiled
//! SPIR-V and compares every entry point's bindings and workgroup size with this table.
//! Adding a stage or a buffer is one edit here (plus its entry point and its CPU twin, which
//! the test and an exhaustive `match` on [`Stage`] ask for).
//!
//! Three pipelines share the table ([`Pipeline`]): the heightfield's, the render pipeline's
//! and its multisampled form. They share every stage up to fine raster; each has its own
//! fine-raster program; the render pipeline shades the pixels afterwards, the multisampled one
//! in the same stage (a pixel's samples never leave its invocation).
//!
//! ```text
//!  frame:   vertex params, positions ─▶ vertex ─▶ projected
//!           light params, shade params, vertex attributes ─▶ light ─▶ lit colours (Gouraud)
//!           assemble params, face indices, projected ─▶ assemble_count ─▶ group counts,
//!               assembly counters, clipped faces (read back: the host clips those)
//!           group counts, patches ─▶ assemble_scan ─▶ group offsets
//!           face indices, projected, vertex attributes, lit colours, face normals, shade
//!               params, face textures, patches, pieces, group offsets ─▶ assemble_fill
//!               ─▶ inputs, shading, listed, small listed
//!  scene:   inputs ─▶ setup ─▶ setups (kept for every later window)
//!  window:  setups, listed ─▶ bin_count ─▶ counts ─▶ bin_scan ─▶ offsets
//!           setups, listed, offsets ─▶ bin_fill ─▶ bins, bin keys (cursors: its atomics)
//!  height:  setups (and as words), offsets, bins ─▶ fine_raster ─▶ values, owners, coverage, stats, tile stats
//!  render:  setups, small listed ─▶ fine_small ─▶ pixel keys, coverage (where the plan lists small triangles)
//!           setups (and as words), offsets, bins, bin keys, pixel keys ─▶ fine_depth ─▶ values (depth), owners (slots), coverage, stats, tile stats
//!           shade params, setups, shading, textures, texels, offsets, bins, values, owners ─▶ shade ─▶ colours, faces
//!  multisampled render:
//!           setups, offsets, bins, shade params, shading, textures, texels ─▶ fine_samples ─▶ values, owners, coverage, stats, tile stats, colours, faces
//! ```

use crate::abi::{FrameFlags, OutputSet};
use crate::{SCAN_GROUP, SHADE_PASSES, TILE, TRIANGLE_GROUP};

/// A kernel stage.
#[repr(u32)]
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Stage {
    Vertex,
    Light,
    AssembleCount,
    AssembleScan,
    AssembleFill,
    Setup,
    BinCount,
    BinScan,
    BinFill,
    FineRaster,
    FineSmall,
    FineDepth,
    Shade,
    FineSamples,
}

/// A pipeline: the rows of the table it runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Pipeline {
    /// Heights of the lowest-index triangle (DEMs).
    Height,
    /// Depth-tested, shaded 3D triangles.
    Render,
    /// The render pipeline with several samples per pixel: coverage, depth and shading in one
    /// stage (`programs::multisample`).
    RenderMultisampled,
}

const ALL_PIPELINES: &[Pipeline] = &[Pipeline::Height, Pipeline::Render, Pipeline::RenderMultisampled];

impl Pipeline {
    /// Whether the pipeline renders 3D triangles (and so shades them).
    pub fn renders(self) -> bool {
        matches!(self, Pipeline::Render | Pipeline::RenderMultisampled)
    }
}

/// A buffer the stages share, by role. Every binding of every stage is one of these.
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Buffer {
    /// `VertexParams` of the frame (`stages::vertex`).
    VertexParams,
    /// `RelativePosition` per vertex of the frame.
    Positions,
    /// The frame's vertex texture: `f32` texels row by row (`programs::vertex::texel`).
    VertexTexture,
    /// `ProjectedVertex` per vertex of the frame, read back by the host's clipping and
    /// assembly.
    Projected,
    /// `AssembleParams` of a placed mesh's faces (`stages::assemble`).
    AssembleParams,
    /// The mesh's faces, three vertex indices each (`u32`).
    FaceIndices,
    /// The mesh's vertices' attributes, `[f32; ATTRIBUTES]` each (where they carry any).
    VertexAttributes,
    /// `LightParams` of the frame (`stages::light`).
    LightParams,
    /// Per vertex of the frame, its colour as the light stage lit it, `[f32; 4]` (Gouraud
    /// shading).
    LitColours,
    /// `FaceNormal` per face of the frame's placed meshes, one after the other (flat shading).
    FaceNormals,
    /// `FaceMaterial` per face of the mesh (where the faces name theirs).
    FaceMaterials,
    /// Per workgroup of faces, its kept faces' listed and small records (`u32` each).
    GroupCounts,
    /// `ASSEMBLY_COUNTERS` words: faces dropped for each cause and left to the host.
    AssemblyCounters,
    /// The faces left to the host, in no order (their number is the counters').
    ClippedFaces,
    /// `AssemblyPatch` per face the host clipped, by face.
    Patches,
    /// The pieces of the faces the host clipped: their `TriangleInput`s and their
    /// `TriangleShading`s, in the patches' order.
    Pieces,
    PieceShading,
    /// Per workgroup of faces, its first listed and small rank, then the totals.
    GroupOffsets,
    /// `FrameParams` of the dispatch.
    Frame,
    /// `TriangleInput` per prepared triangle (uploaded once per scene).
    Inputs,
    /// `TriangleSetup` per prepared triangle (set up once per scene, kept).
    Setups,
    /// The same buffer as `Setups`, as `u64`s: for records the lanes of a group read together
    /// (`memory::Lanes`).
    SetupWords,
    /// Setup slots of the window's triangles, `u32` each.
    Listed,
    /// Setup slots of the window's small triangles, which skip binning (`stages::small`).
    SmallListed,
    /// Per window pixel, the complement of the smallest key of the small triangles' fragments
    /// there (`stages::small`), `u64` each.
    PixelKeys,
    /// Entries per tile.
    Counts,
    /// Exclusive prefix sum of `Counts`, one more entry for the total.
    Offsets,
    /// The tiles `fine_depth` takes, after its indirect dispatch's arguments
    /// (`stages::scan`).
    TileQueue,
    /// Per-tile atomics of `bin_fill`.
    Cursors,
    /// The bins: setup slots, `FULL_TILE_BIT` on entries that cover their tile whole.
    Bins,
    /// Two keys per bin entry of the window, where `fine_depth` walks its bins and rejects
    /// hidden triangles (`bin_fill` writes them then, `stages::bin::entry_keys`): the entry's
    /// occluder key over its tile at the entry's index, its lowest key at the window's number of
    /// entries (`Offsets`' last) past it.
    BinKeys,
    /// Value bits per window pixel.
    Values,
    /// Owner triangle per window pixel (written when asked for).
    Owners,
    /// Coverage count per window pixel (written when asked for).
    Coverage,
    /// `Counter::COUNT` statistics counters.
    Stats,
    /// Two words per window tile (written when asked for): the entries of its bin, and how
    /// many of them its depth bound hid.
    TileStats,
    /// `ShadeParams` of the frame (render pipeline).
    ShadeParams,
    /// `TriangleShading` per prepared triangle (uploaded once per scene; render pipeline).
    Shading,
    /// RGBA8 per window pixel (render pipeline).
    Colours,
    /// Input face per window pixel (render pipeline).
    Faces,
    /// `TextureInfo` per texture of the frame (uploaded once per scene; render pipeline).
    Textures,
    /// `MaterialRecord` per material of the frame (uploaded once per scene; render pipeline).
    Materials,
    /// The textures' texels, two words each (uploaded once per scene; render pipeline).
    Texels,
}

/// An output layer: what the raster stages leave per pixel of a window (or per tile) that a
/// call may return. The layer table ([`LAYERS`]) says of each where it lives on the device,
/// its cells, what it holds where no stage writes it and when the stages write it; the host's
/// raster, the GPU's buffers and read-back and the CPU's spare layers follow it.
#[repr(u32)]
#[derive(Copy, Clone, Debug, PartialEq, Eq, Hash)]
pub enum Layer {
    /// Value bits per pixel: a heightfield's heights, a frame's depth.
    Values,
    /// The owning triangle per pixel.
    Owners,
    /// How many triangles cover each pixel centre.
    Coverage,
    /// A frame's RGBA8 colour per pixel.
    Colours,
    /// A frame's input face per pixel.
    Faces,
    /// Two words per tile: its bin's entries and how many of them its depth bound hid.
    Tiles,
}

/// What a layer has a cell for.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Cells {
    /// Each pixel of the window.
    Pixel,
    /// Each `TILE × TILE` tile of the window, row by row.
    Tile,
}

/// What a layer holds where no stage writes it: outside the window's active area.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Inactive {
    /// The call's nodata value.
    Nodata,
    /// No triangle (`u32::MAX`).
    NoOwner,
    Zero,
    /// The frame's background colour.
    Background,
}

/// When the raster stages write a layer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Written {
    Always,
    /// In the pipelines that render 3D triangles ([`Pipeline::renders`]).
    Renders,
    /// Where the frame's `FrameParams::outputs` holds the flag.
    Asked(OutputSet),
}

/// One row of the layer table.
#[derive(Copy, Clone, Debug)]
pub struct LayerInfo {
    pub layer: Layer,
    pub name: &'static str,
    /// The buffer the stages write it to.
    pub buffer: Buffer,
    pub cells: Cells,
    /// Words per cell.
    pub words: u32,
    pub inactive: Inactive,
    pub written: Written,
}

impl LayerInfo {
    /// Whether the stages of `pipeline` write the layer for a frame of `outputs`.
    pub fn written_by(&self, pipeline: Pipeline, outputs: OutputSet) -> bool {
        match self.written {
            Written::Always => true,
            Written::Renders => pipeline.renders(),
            Written::Asked(flag) => outputs.contains(flag),
        }
    }
}

/// The layer table, in [`Layer`] order.
pub const LAYERS: [LayerInfo; 6] = [
    LayerInfo {
        layer: Layer::Values,
        name: "values",
        buffer: Buffer::Values,
        cells: Cells::Pixel,
        words: 1,
        inactive: Inactive::Nodata,
        written: Written::Always,
    },
    LayerInfo {
        layer: Layer::Owners,
        name: "owners",
        buffer: Buffer::Owners,
        cells: Cells::Pixel,
        words: 1,
        inactive: Inactive::NoOwner,
        written: Written::Asked(OutputSet::OWNER),
    },
    LayerInfo {
        layer: Layer::Coverage,
        name: "coverage",
        buffer: Buffer::Coverage,
        cells: Cells::Pixel,
        words: 1,
        inactive: Inactive::Zero,
        written: Written::Asked(OutputSet::COVERAGE),
    },
    LayerInfo {
        layer: Layer::Colours,
        name: "colours",
        buffer: Buffer::Colours,
        cells: Cells::Pixel,
        words: 1,
        inactive: Inactive::Background,
        written: Written::Renders,
    },
    LayerInfo {
        layer: Layer::Faces,
        name: "faces",
        buffer: Buffer::Faces,
        cells: Cells::Pixel,
        words: 1,
        inactive: Inactive::NoOwner,
        written: Written::Renders,
    },
    LayerInfo {
        layer: Layer::Tiles,
        name: "tile statistics",
        buffer: Buffer::TileStats,
        cells: Cells::Tile,
        words: 2,
        inactive: Inactive::Zero,
        written: Written::Asked(OutputSet::TILES),
    },
];

impl Layer {
    pub const ALL: [Layer; 6] = [Layer::Values, Layer::Owners, Layer::Coverage, Layer::Colours, Layer::Faces, Layer::Tiles];

    /// The layer's row of [`LAYERS`].
    pub fn info(self) -> &'static LayerInfo {
        &LAYERS[self as usize]
    }
}

/// How a stage binds a buffer.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Access {
    /// A storage buffer the stage only reads.
    Read,
    /// A storage buffer the stage reads and writes.
    ReadWrite,
    /// A uniform buffer: small, read-only, the same for every invocation. A CPU implementation
    /// of Vulkan (lavapipe) loads a uniform at a constant offset once per SIMD group, where it
    /// loads a storage word once per lane, each load behind a branch on its lane's mask.
    Uniform,
}

/// One binding of a stage: binding number = position in [`StageInfo::bindings`].
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub struct Binding {
    pub buffer: Buffer,
    pub access: Access,
}

/// How many invocations a stage runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Dispatch {
    /// One per vertex of the frame, `TRIANGLE_GROUP` a workgroup, in 2D past 65,535 workgroups
    /// (`VertexParams::dispatch_width`).
    PerVertex,
    /// One per face of a placed mesh, `FACE_GROUP` a workgroup, laid out as `PerVertex`
    /// (`AssembleParams::dispatch_width`).
    PerFace,
    /// One per prepared triangle, `TRIANGLE_GROUP` a workgroup, in 2D past 65,535 workgroups
    /// (`FrameParams::dispatch_width`).
    PerTriangle,
    /// One per listed triangle and band of its tile rows (`FrameParams::bin_parts`), laid out
    /// as `PerTriangle`.
    PerTrianglePart,
    /// One workgroup.
    Single,
    /// One workgroup per window tile, one invocation per pixel.
    PerTile,
    /// One workgroup per tile of the tile queue, indirect (`stages::scan`).
    Queued,
    /// One per small triangle of the window (`FrameParams::small_triangles`), `TRIANGLE_GROUP`
    /// a workgroup, in 2D past 65,535 workgroups (its own width: the dispatch's).
    PerSmallTriangle,
}

/// How often a stage runs.
#[derive(Copy, Clone, Debug, PartialEq, Eq)]
pub enum Scope {
    /// Once per frame, before the host assembles its triangles (the geometry stages).
    Frame,
    /// Once per prepared scene; its outputs stay with the scene.
    Scene,
    /// Once per rasterised window.
    Window,
}

/// One row of the stage table.
#[derive(Copy, Clone, Debug)]
pub struct StageInfo {
    pub stage: Stage,
    /// The stage's name: its entry point in `entry.rs`, its CPU twin and its pass in `Stats`.
    pub name: &'static str,
    /// The SPIR-V entry point (rust-gpu names it by its path in the kernel crate).
    pub entry_point: &'static str,
    pub scope: Scope,
    pub workgroup: [u32; 3],
    pub dispatch: Dispatch,
    pub bindings: &'static [Binding],
    /// The pipelines that run this stage.
    pub pipelines: &'static [Pipeline],
}

impl StageInfo {
    /// Whether the stage runs for a frame with `flags` (of a pipeline it is in): every stage
    /// does but `fine_small`, which runs where the frame lists small triangles.
    pub fn runs_for(&self, flags: FrameFlags) -> bool {
        self.stage != Stage::FineSmall || flags.contains(FrameFlags::SMALL_TRIANGLES)
    }

    pub fn runs_in(&self, pipeline: Pipeline) -> bool {
        let mut k = 0;
        while k < self.pipelines.len() {
            if self.pipelines[k] as u32 == pipeline as u32 {
                return true;
            }
            k += 1;
        }
        false
    }
}

const fn read(buffer: Buffer) -> Binding {
    Binding { buffer, access: Access::Read }
}

const fn write(buffer: Buffer) -> Binding {
    Binding { buffer, access: Access::ReadWrite }
}

const fn uniform(buffer: Buffer) -> Binding {
    Binding { buffer, access: Access::Uniform }
}

/// What the heightfield's fine raster binds.
const FINE_BINDINGS: [Binding; 10] = [
    uniform(Buffer::Frame),
    read(Buffer::Setups),
    read(Buffer::Offsets),
    read(Buffer::Bins),
    write(Buffer::Values),
    write(Buffer::Owners),
    write(Buffer::Coverage),
    write(Buffer::Stats),
    write(Buffer::TileStats),
    read(Buffer::SetupWords),
];

/// What the render pipeline's fine raster binds: the heightfield's bindings, the bin entries'
/// keys its walk reads where it rejects hidden triangles, the keys the small triangles left,
/// and the tile queue.
const DEPTH_BINDINGS: [Binding; 13] =
    appended(appended::<11, 12>(appended::<10, 11>(FINE_BINDINGS, read(Buffer::BinKeys)), read(Buffer::PixelKeys)), read(Buffer::TileQueue));

/// `bindings` and then `last`.
const fn appended<const N: usize, const M: usize>(bindings: [Binding; N], last: Binding) -> [Binding; M] {
    assert!(M == N + 1);
    let mut out = [last; M];
    let mut k = 0;
    while k < N {
        out[k] = bindings[k];
        k += 1;
    }
    out
}

/// The stages in the order they run.
pub const STAGES: [StageInfo; 14] = [
    StageInfo {
        stage: Stage::Vertex,
        name: "vertex",
        entry_point: "entry::vertex",
        scope: Scope::Frame,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerVertex,
        bindings: &[read(Buffer::VertexParams), read(Buffer::Positions), write(Buffer::Projected), read(Buffer::VertexTexture)],
        pipelines: &[Pipeline::Render, Pipeline::RenderMultisampled],
    },
    StageInfo {
        stage: Stage::Light,
        name: "light",
        entry_point: "entry::light",
        scope: Scope::Frame,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerVertex,
        bindings: &[read(Buffer::LightParams), read(Buffer::ShadeParams), read(Buffer::VertexAttributes), write(Buffer::LitColours)],
        pipelines: &[Pipeline::Render, Pipeline::RenderMultisampled],
    },
    StageInfo {
        stage: Stage::AssembleCount,
        name: "assemble_count",
        entry_point: "entry::assemble_count",
        scope: Scope::Frame,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerFace,
        bindings: &[
            read(Buffer::AssembleParams),
            read(Buffer::FaceIndices),
            read(Buffer::Projected),
            read(Buffer::FaceMaterials),
            write(Buffer::GroupCounts),
            write(Buffer::AssemblyCounters),
            write(Buffer::ClippedFaces),
        ],
        pipelines: &[Pipeline::Render, Pipeline::RenderMultisampled],
    },
    StageInfo {
        stage: Stage::AssembleScan,
        name: "assemble_scan",
        entry_point: "entry::assemble_scan",
        scope: Scope::Frame,
        workgroup: [SCAN_GROUP, 1, 1],
        dispatch: Dispatch::Single,
        bindings: &[read(Buffer::AssembleParams), read(Buffer::GroupCounts), read(Buffer::Patches), write(Buffer::GroupOffsets)],
        pipelines: &[Pipeline::Render, Pipeline::RenderMultisampled],
    },
    StageInfo {
        stage: Stage::AssembleFill,
        name: "assemble_fill",
        entry_point: "entry::assemble_fill",
        scope: Scope::Frame,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerFace,
        bindings: &[
            read(Buffer::AssembleParams),
            read(Buffer::FaceIndices),
            read(Buffer::Projected),
            read(Buffer::VertexAttributes),
            read(Buffer::LitColours),
            read(Buffer::FaceNormals),
            read(Buffer::ShadeParams),
            read(Buffer::FaceMaterials),
            read(Buffer::Patches),
            read(Buffer::Pieces),
            read(Buffer::PieceShading),
            read(Buffer::GroupOffsets),
            write(Buffer::Inputs),
            write(Buffer::Shading),
            write(Buffer::Listed),
            write(Buffer::SmallListed),
        ],
        pipelines: &[Pipeline::Render, Pipeline::RenderMultisampled],
    },
    StageInfo {
        stage: Stage::Setup,
        name: "setup",
        entry_point: "entry::setup",
        scope: Scope::Scene,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerTriangle,
        bindings: &[uniform(Buffer::Frame), read(Buffer::Inputs), write(Buffer::Setups)],
        pipelines: ALL_PIPELINES,
    },
    StageInfo {
        stage: Stage::BinCount,
        name: "bin_count",
        entry_point: "entry::bin_count",
        scope: Scope::Window,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerTrianglePart,
        bindings: &[uniform(Buffer::Frame), read(Buffer::Setups), read(Buffer::Listed), write(Buffer::Counts)],
        pipelines: ALL_PIPELINES,
    },
    StageInfo {
        stage: Stage::BinScan,
        name: "bin_scan",
        entry_point: "entry::bin_scan",
        scope: Scope::Window,
        workgroup: [SCAN_GROUP, 1, 1],
        dispatch: Dispatch::Single,
        bindings: &[uniform(Buffer::Frame), read(Buffer::Counts), write(Buffer::Offsets), write(Buffer::TileQueue)],
        pipelines: ALL_PIPELINES,
    },
    StageInfo {
        stage: Stage::BinFill,
        name: "bin_fill",
        entry_point: "entry::bin_fill",
        scope: Scope::Window,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerTrianglePart,
        bindings: &[
            uniform(Buffer::Frame),
            read(Buffer::Setups),
            read(Buffer::Listed),
            read(Buffer::Offsets),
            write(Buffer::Cursors),
            write(Buffer::Bins),
            write(Buffer::BinKeys),
        ],
        pipelines: ALL_PIPELINES,
    },
    StageInfo {
        stage: Stage::FineRaster,
        name: "fine_raster",
        entry_point: "entry::fine_raster",
        scope: Scope::Window,
        workgroup: [TILE, TILE, 1],
        dispatch: Dispatch::PerTile,
        bindings: &FINE_BINDINGS,
        pipelines: &[Pipeline::Height],
    },
    StageInfo {
        stage: Stage::FineSmall,
        name: "fine_small",
        entry_point: "entry::fine_small",
        scope: Scope::Window,
        workgroup: [TRIANGLE_GROUP, 1, 1],
        dispatch: Dispatch::PerSmallTriangle,
        bindings: &[uniform(Buffer::Frame), read(Buffer::Setups), read(Buffer::SmallListed), write(Buffer::PixelKeys), write(Buffer::Coverage)],
        pipelines: &[Pipeline::Render],
    },
    StageInfo {
        stage: Stage::FineDepth,
        name: "fine_depth",
        entry_point: "entry::fine_depth",
        scope: Scope::Window,
        workgroup: [TILE, TILE, 1],
        dispatch: Dispatch::Queued,
        bindings: &DEPTH_BINDINGS,
        pipelines: &[Pipeline::Render],
    },
    StageInfo {
        stage: Stage::Shade,
        name: "shade",
        entry_point: "entry::shade",
        scope: Scope::Window,
        workgroup: [TILE, TILE / SHADE_PASSES, 1],
        dispatch: Dispatch::PerTile,
        bindings: &[
            uniform(Buffer::Frame),
            read(Buffer::ShadeParams),
            read(Buffer::Setups),
            read(Buffer::Shading),
            read(Buffer::Textures),
            read(Buffer::Texels),
            read(Buffer::Offsets),
            read(Buffer::Bins),
            // Written in the tiles fine raster leaves to it (`fine::left_to_shade`).
            write(Buffer::Values),
            write(Buffer::Owners),
            write(Buffer::Colours),
            write(Buffer::Faces),
            read(Buffer::PixelKeys),
            write(Buffer::Coverage),
            read(Buffer::Materials),
        ],
        pipelines: &[Pipeline::Render],
    },
    StageInfo {
        stage: Stage::FineSamples,
        name: "fine_samples",
        entry_point: "entry::fine_samples",
        scope: Scope::Window,
        workgroup: [TILE, TILE, 1],
        dispatch: Dispatch::PerTile,
        bindings: &[
            uniform(Buffer::Frame),
            read(Buffer::Setups),
            read(Buffer::Offsets),
            read(Buffer::Bins),
            write(Buffer::Values),
            write(Buffer::Owners),
            write(Buffer::Coverage),
            write(Buffer::Stats),
            write(Buffer::TileStats),
            read(Buffer::ShadeParams),
            read(Buffer::Shading),
            read(Buffer::Textures),
            read(Buffer::Texels),
            write(Buffer::Colours),
            write(Buffer::Faces),
            read(Buffer::SetupWords),
            read(Buffer::Materials),
        ],
        pipelines: &[Pipeline::RenderMultisampled],
    },
];

impl Stage {
    pub const ALL: [Stage; 14] = [
        Stage::Vertex,
        Stage::Light,
        Stage::AssembleCount,
        Stage::AssembleScan,
        Stage::AssembleFill,
        Stage::Setup,
        Stage::BinCount,
        Stage::BinScan,
        Stage::BinFill,
        Stage::FineRaster,
        Stage::FineSmall,
        Stage::FineDepth,
        Stage::Shade,
        Stage::FineSamples,
    ];

    /// The stage's row of the table.
    pub fn info(self) -> &'static StageInfo {
        &STAGES[self as usize]
    }

    pub fn name(self) -> &'static str {
        self.info().name
    }

    /// Whether the stage colours fragments: its entry point comes from
    /// `shading_entry_points!`, in the kernels or in a user's shader crate
    /// (`programs::fragment`).
    pub fn colours_fragments(self) -> bool {
        matches!(self, Stage::Shade | Stage::FineSamples)
    }
}

/// The stages of `pipeline`, in order.
pub fn stages(pipeline: Pipeline) -> impl Iterator<Item = &'static StageInfo> {
    STAGES.iter().filter(move |s| s.runs_in(pipeline))
}

/// The stages of `pipeline` that rasterise a prepared scene (all but the geometry stages, which
/// run as the host prepares a frame), in order.
pub fn raster_stages(pipeline: Pipeline) -> impl Iterator<Item = &'static StageInfo> {
    stages(pipeline).filter(|s| s.scope != Scope::Frame)
}

/// The stages of `pipeline` that run once per window, in order.
pub fn window_stages(pipeline: Pipeline) -> impl Iterator<Item = &'static StageInfo> {
    stages(pipeline).filter(|s| s.scope == Scope::Window)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_table_is_in_stage_order_and_names_its_entry_points() {
        for (k, info) in STAGES.iter().enumerate() {
            assert_eq!(info.stage as usize, k, "{}: STAGES[k] must be the stage numbered k", info.name);
            assert_eq!(Stage::ALL[k], info.stage);
            assert_eq!(info.entry_point, format!("entry::{}", info.name));
        }
    }

    /// Each layer's row is its own, and in every pipeline that writes the layer some window
    /// stage writes its buffer; no pipeline writes a layer's buffer that the table says it
    /// does not write.
    #[test]
    fn the_layer_table_names_what_the_stages_write() {
        for (k, info) in LAYERS.iter().enumerate() {
            assert_eq!(info.layer as usize, k, "{}: LAYERS[k] must be the layer numbered k", info.name);
            assert_eq!(Layer::ALL[k].info().layer, info.layer);
            for &pipeline in ALL_PIPELINES {
                let writes = window_stages(pipeline).any(|s| s.bindings.iter().any(|b| b.buffer == info.buffer && b.access == Access::ReadWrite));
                let written = [OutputSet::NONE, OutputSet::OWNER.with(OutputSet::COVERAGE, true).with(OutputSet::TILES, true)]
                    .iter()
                    .any(|&outputs| info.written_by(pipeline, outputs));
                assert_eq!(writes, written, "{} in {pipeline:?}", info.name);
            }
        }
    }
}

/// What the stages before fine raster leave in their buffers for one window: the backends
/// read them out for a stage-by-stage comparison (`tests/stages.rs`). The order of entries
/// within a tile's bin depends on the scheduling of `bin_fill`'s atomics; everything else is
/// fixed.
#[derive(Debug, Clone, PartialEq)]
pub struct StageBuffers {
    /// One per prepared triangle (`Buffer::Setups`).
    pub setups: Vec<crate::abi::TriangleSetup>,
    /// Bin entries per tile (`Buffer::Counts`).
    pub counts: Vec<u32>,
    /// Where each tile's bin starts, and the total last (`Buffer::Offsets`).
    pub offsets: Vec<u32>,
    /// Every tile's bin, one after the other (`Buffer::Bins`).
    pub bins: Vec<u32>,
}
