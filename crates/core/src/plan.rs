//! One call's plan, decided on the host and identical for both backends: which prepared
//! triangles reach the window (the rest are culled before binning), which tile-aligned part
//! of the window they can cover (the rest is nodata with no kernel work), the specialisations
//! the kernels may use, and the statistics the host already knows.

use crate::raster::{Layers, reuse_cells};
use crate::{Error, Prepared, Raster, Window};
use rayon::prelude::*;
use tileraster_kernels::abi::DepthTest;
use tileraster_kernels::abi::{Counter, FrameFlags, FrameParams, PixelRect, ShadeParams};
use tileraster_kernels::pipeline::{Cells, Inactive, LAYERS, Pipeline, Stage, window_stages};
use tileraster_kernels::stages::bin::tile_span;
use tileraster_kernels::stages::small::is_small;
use tileraster_kernels::{BIN_PART_TILES, NO_OWNER, TILE};

/// Binning invocations a frame's bands aim for: enough to fill a large GPU. A frame with fewer
/// (listed triangles × tile rows) takes one tile row a band; the count changes no bit (the
/// order inside a bin is free, `stages::bin`).
const BIN_INVOCATIONS: u64 = 16_384;

/// A pass of a call, as `Stats::passes` lists them: the kernel stages of the stage table
/// (`tileraster_kernels::pipeline`) and the host's own passes around them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Pass {
    /// The prepared triangles go to the backend (first call of a prepared scene).
    Upload,
    /// A kernel stage of the stage table.
    Kernel(Stage),
    /// The window's triangles are listed, the others left out (`Skip::CullWindow`).
    Cull,
    /// Part of the window lies outside every listed triangle's tiles: nodata there, on the host.
    FillNodata,
    /// Fine raster resolves overlaps (the scene was not proven overlap-free).
    Ownership,
    /// The owner layer is written.
    WriteOwner,
    /// The coverage layer is written.
    WriteCoverage,
}

impl Pass {
    /// The name `--stats` prints: a kernel stage's name from the stage table, or the host
    /// pass's own.
    pub fn name(self) -> &'static str {
        match self {
            Pass::Upload => "upload",
            Pass::Kernel(stage) => stage.name(),
            Pass::Cull => "cull",
            Pass::FillNodata => "fill_nodata",
            Pass::Ownership => "ownership",
            Pass::WriteOwner => "write_owner",
            Pass::WriteCoverage => "write_coverage",
        }
    }
}

impl From<Stage> for Pass {
    fn from(stage: Stage) -> Self {
        Pass::Kernel(stage)
    }
}

impl Stats {
    /// Add another call's counts to these (of windows side by side): the passes stay these.
    pub fn absorb(&mut self, other: &Stats) {
        self.tiles_total += other.tiles_total;
        self.tiles_empty_skipped += other.tiles_empty_skipped;
        self.tiles_full += other.tiles_full;
        self.tiles_partial += other.tiles_partial;
        self.triangles_culled += other.triangles_culled;
        self.triangles_flat += other.triangles_flat;
        self.triangles_binned += other.triangles_binned;
        self.triangles_small += other.triangles_small;
        self.triangles_hidden += other.triangles_hidden;
        self.overlap_free &= other.overlap_free;
        self.bytes_uploaded += other.bytes_uploaded;
    }
}

impl std::fmt::Display for Pass {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// What a call did, from the host's plan and the kernels' counters: equal on both backends
/// for the same input.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Stats {
    /// `TILE × TILE` tiles of the called window.
    pub tiles_total: u64,
    /// Tiles no triangle reaches, which got no per-pixel work: those outside the part of the
    /// window the triangles can cover, filled with nodata on the host, and those inside it
    /// whose bin was empty (where small triangles skip binning, such a tile still resolves
    /// what they left there).
    pub tiles_empty_skipped: u64,
    /// Tiles covered whole by one triangle, written with no edge test.
    pub tiles_full: u64,
    /// Tiles whose pixels were tested against their bin.
    pub tiles_partial: u64,
    /// Triangles dropped before binning because they cannot reach a pixel centre of the grid
    /// (at preparation) or of the called window.
    pub triangles_culled: u64,
    /// Triangles dropped at preparation because snapping left them no area.
    pub triangles_flat: u64,
    /// Triangles the binning stages took.
    pub triangles_binned: u64,
    /// Triangles small enough to skip binning (`Skip::SmallTriangles`): one invocation each
    /// rasterised them.
    pub triangles_small: u64,
    /// Bin entries (a triangle in a tile) that a depth-tested tile's depth bound rejected
    /// before their depth tests: triangles hidden all over the tile (`Skip::HiddenTriangles`).
    pub triangles_hidden: u64,
    /// Whether the scene analysis proved that no pixel centre is inside two triangles, and
    /// fine raster used it. (The analysis runs only where it can pay: on triangles whose
    /// rectangles average at least 96 pixels.)
    pub overlap_free: bool,
    /// The passes that ran, in order (see [`Plan`]).
    pub passes: Vec<Pass>,
    /// Bytes of scene and frame data the call hands the device: the prepared triangles (and a
    /// render's shading records) the first time a prepared scene is rasterised, and on every
    /// call the lists of the window's triangles and a render's shade parameters, textures,
    /// materials and texels (those a prepared mesh's earlier frame left on the backend excepted). A frame the
    /// kernels assembled (`RenderInputs::records_held`) hands over neither its records nor, in
    /// a call over its whole window, its lists: the assembly wrote them where setup and
    /// binning read them. The GPU backend
    /// writes these and, besides, one `FrameParams` uniform per dispatch window (one more
    /// where it sets the scene up); a scene too large for one binding goes up part by part,
    /// each window's triangles with its own lists, a frame's records assembled apart from the
    /// device that rasterises it go up whole (every frame on a CPU implementation of Vulkan,
    /// where the host's twins assemble: `tileraster_gpu::AssemblyOn`; `passes` then lists no
    /// `upload` either), and a call in an `f32` mode first checks the adapter on probe scenes
    /// of its own, none of them in this figure. The CPU backend reads
    /// everything where it is, and reports the same figure.
    pub bytes_uploaded: u64,
}

impl Stats {
    /// One JSON object, with the field names above.
    pub fn to_json(&self) -> String {
        let passes: Vec<String> = self.passes.iter().map(|p| format!("\"{}\"", p.name())).collect();
        format!(
            "{{\"tiles_total\":{},\"tiles_empty_skipped\":{},\"tiles_full\":{},\"tiles_partial\":{},\
             \"triangles_culled\":{},\"triangles_flat\":{},\"triangles_binned\":{},\"triangles_small\":{},\"triangles_hidden\":{},\
             \"overlap_free\":{},\
             \"passes\":[{}],\"bytes_uploaded\":{}}}",
            self.tiles_total,
            self.tiles_empty_skipped,
            self.tiles_full,
            self.tiles_partial,
            self.triangles_culled,
            self.triangles_flat,
            self.triangles_binned,
            self.triangles_small,
            self.triangles_hidden,
            self.overlap_free,
            passes.join(","),
            self.bytes_uploaded
        )
    }
}

/// One call's plan. Its passes, in the order they run:
///
/// | pass | runs when |
/// | --- | --- |
/// | `upload` | the first call that rasterises anything with a prepared scene: its triangles go to the backend |
/// | `setup` (the stage table's scene stage) | the same call: edge functions and planes, kept with the triangles for later calls |
/// | `cull` | `Skip::CullWindow`: the window's triangles are listed, the others left out |
/// | `fill_nodata` | part of the window lies outside every listed triangle's tiles |
/// | the stage table's window stages (`bin_count`, `bin_scan`, `bin_fill`, `fine_raster`) | some triangle reaches the window |
/// | `ownership` | fine raster resolves overlaps (the scene was not proven overlap-free) |
/// | `write_owner`, `write_coverage` | those outputs were asked for |
#[derive(Debug, Clone)]
pub struct Plan {
    /// The called window: the raster the call returns.
    pub window: Window,
    /// Setup slots of the triangles the binning stages take.
    pub listed: Vec<u32>,
    /// Setup slots of the small triangles, which skip binning (`Skip::SmallTriangles`,
    /// `stages::small`): each is rasterised by one invocation of `fine_small`.
    pub small: Vec<u32>,
    /// The part of `window` the kernels rasterise, aligned to the window's tiles; `None` when
    /// no triangle reaches the window.
    pub active: Option<Window>,
    /// `FrameParams::flags`.
    pub flags: FrameFlags,
    /// What the host knows of the statistics before the kernels run.
    pub stats: Stats,
}

impl Prepared {
    /// Whether the scene's small triangles skip binning (`Skip::SmallTriangles`): in a
    /// single-sample depth-tested frame that does not blend (blending walks the bins in the
    /// shade stage) and counts no tile's triangles (the tile statistics count bin entries:
    /// every triangle stays in the bins).
    pub fn splits_small_triangles(&self) -> bool {
        self.params.skips.small_triangles
            && self.pipeline() == Pipeline::Render
            && self.render.as_ref().is_some_and(|r| r.params.blend == 0)
            && !self.params.outputs.tiles
    }

    /// Whether some window of the scene may have small triangles rasterised apart, so that
    /// fine raster leaves tiles to the shade stage (`stages::fine::left_to_shade`).
    pub fn may_leave_tiles_to_shade(&self) -> bool {
        self.splits_small_triangles() && self.params.skips.empty_tiles && self.triangles.par_iter().any(|t| is_small(&t.rect))
    }

    /// Plan a call over `window` (any window of the grid). `resident`: the backend already holds
    /// this preparation's triangles and their setup.
    pub fn plan(&self, window: Window, resident: bool) -> Result<Plan, Error> {
        window.validate(&self.params.grid)?;
        let skips = self.params.skips;
        let area =
            PixelRect { i0: window.x0 as i32, j0: window.y0 as i32, i1: (window.x0 + window.width - 1) as i32, j1: (window.y0 + window.height - 1) as i32 };
        // One pass over the triangles, on all cores, in chunks kept in scene order: the ones
        // listed (with `cull_window`, those reaching the window), and the union of what they
        // reach of it.
        let union = |a: Option<PixelRect>, b: Option<PixelRect>| match (a, b) {
            (Some(a), Some(b)) => Some(PixelRect { i0: a.i0.min(b.i0), j0: a.j0.min(b.j0), i1: a.i1.max(b.i1), j1: a.j1.max(b.j1) }),
            (a, b) => a.or(b),
        };
        let splits = self.splits_small_triangles();
        let pieces: Vec<(Vec<u32>, Vec<u32>, Option<PixelRect>)> = self
            .triangles
            .par_chunks(PLAN_CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let (mut listed, mut small, mut reached) = (Vec::with_capacity(chunk.len()), Vec::new(), None);
                for (k, t) in chunk.iter().enumerate() {
                    let r = intersect(&t.rect, &area);
                    if !r.is_empty() {
                        reached = union(reached, Some(r));
                    }
                    if !skips.cull_window || !r.is_empty() {
                        let slot = (c * PLAN_CHUNK + k) as u32;
                        if splits && is_small(&t.rect) { small.push(slot) } else { listed.push(slot) }
                    }
                }
                (listed, small, reached)
            })
            .collect();
        let listed: Vec<u32> = pieces.iter().flat_map(|p| p.0.iter().copied()).collect();
        let small: Vec<u32> = pieces.iter().flat_map(|p| p.1.iter().copied()).collect();
        let reached = pieces.iter().fold(None, |r, p| union(r, p.2));
        let active = if skips.empty_tiles { reached.map(|r| tile_aligned(&r, &window)) } else { Some(window) };
        let rows = self.overlap_free_rows.as_ref();
        let overlap_free = skips.overlap_free && rows.is_some_and(|r| r.start <= window.y0 && window.y0 + window.height <= r.end);
        let flags = FrameFlags::NONE
            .with(FrameFlags::EMPTY_TILES, skips.empty_tiles)
            .with(FrameFlags::FULL_TILES, skips.full_tiles)
            .with(FrameFlags::OVERLAP_FREE, overlap_free)
            .with(FrameFlags::HIDDEN_TRIANGLES, skips.hidden_triangles)
            .with(FrameFlags::SMALL_TRIANGLES, !small.is_empty());

        let tiles = |w: &Window| w.width.div_ceil(TILE) as u64 * w.height.div_ceil(TILE) as u64;
        let tiles_total = tiles(&window);
        let mut passes = Vec::new();
        let mut bytes_uploaded = 0;
        // Records the kernels assembled are where the stages read them, and so are their lists
        // (the frame's window's).
        let held = self.render.as_ref().is_some_and(|r| r.records_held.is_some());
        let held_lists = held && window == self.window;
        if active.is_some() && !resident {
            if !held {
                passes.push(Pass::Upload);
                bytes_uploaded += std::mem::size_of_val(self.triangles.as_slice()) as u64;
                bytes_uploaded += self.render.as_ref().map_or(0, |r| std::mem::size_of_val(r.triangles.as_slice()) as u64);
            }
            passes.push(Stage::Setup.into());
        }
        if skips.cull_window {
            passes.push(Pass::Cull);
        }
        if active != Some(window) {
            passes.push(Pass::FillNodata);
        }
        if active.is_some() {
            passes.extend(window_stages(self.pipeline()).filter(|s| s.runs_for(flags)).map(|s| Pass::from(s.stage)));
            if !overlap_free {
                passes.push(Pass::Ownership);
            }
            if !held_lists {
                bytes_uploaded += std::mem::size_of_val(listed.as_slice()) as u64 + std::mem::size_of_val(small.as_slice()) as u64;
            }
            bytes_uploaded += self.render.as_ref().map_or(0, |r| {
                let texels = if r.texels_resident { 0 } else { std::mem::size_of_val(r.texels.as_slice()) };
                (std::mem::size_of::<ShadeParams>() + std::mem::size_of_val(r.textures.as_slice()) + std::mem::size_of_val(r.materials.as_slice()) + texels)
                    as u64
            });
        }
        if self.params.outputs.owner {
            passes.push(Pass::WriteOwner);
        }
        if self.params.outputs.coverage {
            passes.push(Pass::WriteCoverage);
        }
        let stats = Stats {
            tiles_total,
            tiles_empty_skipped: tiles_total - active.as_ref().map_or(0, tiles),
            triangles_culled: (self.culled + self.triangles.len() - listed.len() - small.len()) as u64,
            triangles_flat: self.degenerate as u64,
            triangles_binned: if active.is_some() { listed.len() as u64 } else { 0 },
            triangles_small: if active.is_some() { small.len() as u64 } else { 0 },
            overlap_free,
            passes,
            bytes_uploaded,
            ..Stats::default()
        };
        Ok(Plan { window, listed, small, active, flags, stats })
    }
}

/// Triangles per task of the plan's pass over them.
const PLAN_CHUNK: usize = 1 << 14;

/// The part two pixel rectangles share (empty if none).
fn intersect(a: &PixelRect, b: &PixelRect) -> PixelRect {
    PixelRect { i0: a.i0.max(b.i0), j0: a.j0.max(b.j0), i1: a.i1.min(b.i1), j1: a.j1.min(b.j1) }
}

/// The tiles of `window` that `r` (inside it) touches, as a window.
fn tile_aligned(r: &PixelRect, window: &Window) -> Window {
    let down = |v: i32, origin: u32| origin + (v as u32 - origin) / TILE * TILE;
    let (x0, y0) = (down(r.i0, window.x0), down(r.j0, window.y0));
    let x1 = (down(r.i1, window.x0) + TILE).min(window.x0 + window.width);
    let y1 = (down(r.j1, window.y0) + TILE).min(window.y0 + window.height);
    Window { x0, y0, width: x1 - x0, height: y1 - y0 }
}

impl Plan {
    /// Kernel parameters for rasterising `part` of the active window.
    pub fn frame(&self, prepared: &Prepared, part: Window) -> FrameParams {
        self.frame_listing(prepared, part, &self.listed, &self.small)
    }

    /// Kernel parameters for rasterising `part` with the binning stages taking `listed` (setup
    /// slots of `prepared`'s triangles; the plan's list, or the part of it that reaches `part`),
    /// and `fine_small` the small ones `small`.
    pub fn frame_listing(&self, prepared: &Prepared, part: Window, listed: &[u32], small: &[u32]) -> FrameParams {
        let tiles_x = part.width.div_ceil(TILE);
        let tiles_y = part.height.div_ceil(TILE);
        let mut frame = FrameParams {
            win_x0: part.x0,
            win_y0: part.y0,
            win_w: part.width,
            win_h: part.height,
            tiles_x,
            tiles_y,
            triangles: listed.len() as u32,
            snap_bits: prepared.snap_bits,
            nodata_bits: prepared.params.nodata.to_bits(),
            outputs: prepared.output_set(),
            dispatch_width: 0,
            mode: prepared.params.mode as u32,
            bin_part_rows: (BIN_PART_TILES / tiles_x.max(1)).max(1),
            bin_parts: 1,
            flags: self.flags,
            depth_test: prepared.render.as_ref().map_or(DepthTest::default(), |s| s.depth_test),
            samples: prepared.render.as_ref().map_or(1, |s| s.params.samples),
            small_triangles: small.len() as u32,
        };
        // Enough bands for the tallest listed triangle in the part (the CPU's fast paths bin the
        // small ones apart, in one band).
        let rows = listed.par_iter().map(|&s| tile_span(&prepared.triangles[s as usize].rect, &frame)).filter(|s| !s.empty).map(|s| s.ty1 - s.ty0 + 1).max();
        let rows = rows.unwrap_or(1);
        // Bands as short as keeps `BIN_INVOCATIONS` busy: a frame of a few large triangles
        // (eight full-frame layers are 16 triangles) would otherwise leave each of a few dozen
        // invocations a loop over thousands of tiles while the rest of the device idles.
        let share = (listed.len() as u64 * rows as u64 / BIN_INVOCATIONS).clamp(1, frame.bin_part_rows as u64);
        frame.bin_part_rows = share as u32;
        frame.bin_parts = rows.div_ceil(frame.bin_part_rows).max(1);
        frame
    }

    /// The plan's triangles whose rectangle reaches `part` (of the active window), in the
    /// plan's order: all that binning `part` can take.
    pub fn listed_reaching(&self, prepared: &Prepared, part: Window) -> Vec<u32> {
        Self::reaching(prepared, &self.listed, part)
    }

    /// The plan's small triangles whose rectangle reaches `part`, in the plan's order.
    pub fn small_reaching(&self, prepared: &Prepared, part: Window) -> Vec<u32> {
        Self::reaching(prepared, &self.small, part)
    }

    fn reaching(prepared: &Prepared, slots: &[u32], part: Window) -> Vec<u32> {
        let area = PixelRect { i0: part.x0 as i32, j0: part.y0 as i32, i1: (part.x0 + part.width - 1) as i32, j1: (part.y0 + part.height - 1) as i32 };
        slots.par_iter().copied().filter(|&s| !intersect(&prepared.triangles[s as usize].rect, &area).is_empty()).collect()
    }

    /// Most (triangle, tile) entries binning can write for `frame` (every tile of every listed
    /// rectangle; binning leaves out the tiles a triangle cannot reach): the size to allocate
    /// before the bins are filled.
    pub fn bin_capacity(&self, prepared: &Prepared, frame: &FrameParams) -> u64 {
        Self::bin_capacity_listing(prepared, frame, &self.listed)
    }

    /// [`Self::bin_capacity`] with the binning stages taking `listed`.
    pub fn bin_capacity_listing(prepared: &Prepared, frame: &FrameParams, listed: &[u32]) -> u64 {
        listed.par_iter().map(|&s| tile_span(&prepared.triangles[s as usize].rect, frame).tile_count() as u64).sum()
    }

    /// The call's raster: zeroed, with nodata (and no owner) already written outside the
    /// active window. With `stages_in_raster` (a backend whose stages work in the raster's
    /// layers, as the CPU's do) it has every layer the stages write, also those the call does
    /// not return (a frame's owner layer, [`Prepared::keeps_owner`], and its depth or colour
    /// where not asked for); otherwise only the layers the call returns (a values layer not
    /// returned is empty).
    pub fn allocate_raster(&self, prepared: &Prepared, stages_in_raster: bool) -> Result<Raster, Error> {
        self.allocate_raster_reusing(prepared, Layers::default(), stages_in_raster)
    }

    /// [`Plan::allocate_raster`], taking the layers of `spare` (an earlier call's raster) where
    /// it has them instead of fresh memory: a frame after the first then faults no page in.
    /// Their old contents are harmless: the stages write every pixel of the active window, and
    /// the rest is filled here.
    pub fn allocate_raster_reusing(&self, prepared: &Prepared, spare: Layers, stages_in_raster: bool) -> Result<Raster, Error> {
        let window = self.window;
        let n = usize::try_from(window.pixel_count()).map_err(|_| Error::RasterTooLarge {
            width: window.width as u64,
            height: window.height as u64,
            reason: "the pixel count does not fit this machine's address space".into(),
        })?;
        let tiles = window.width.div_ceil(TILE) as usize * window.height.div_ceil(TILE) as usize;
        let mut raster = Raster {
            grid: prepared.params.grid,
            window,
            nodata: prepared.params.nodata,
            values: Vec::new(),
            owner: None,
            coverage: None,
            colours: None,
            faces: None,
            tiles: None,
            snap_bits: prepared.snap_bits,
            stats: Stats::default(),
        };
        let mut spare = spare;
        for info in &LAYERS {
            let wanted = prepared.returns(info.layer) || (stages_in_raster && prepared.writes(info.layer));
            let cells = match info.cells {
                Cells::Pixel => n,
                Cells::Tile => tiles,
            };
            raster.put_layer(info.layer, reuse_layer(wanted, spare.take(info.layer), cells * info.words as usize, &window)?);
        }
        self.fill_inactive(&mut raster, prepared.render.as_ref().map_or(0, |s| s.params.background));
        Ok(raster)
    }

    /// Each pixel layer's inactive value (the layer table's `Inactive`) outside the active
    /// window: nodata, no owner or face, no coverage, the background colour.
    fn fill_inactive(&self, raster: &mut Raster, background: u32) {
        let w = self.window;
        let a = self.active.unwrap_or(Window { x0: w.x0, y0: w.y0, width: 0, height: 0 });
        if a == w {
            return;
        }
        let (ax0, ax1) = ((a.x0 - w.x0) as usize, (a.x0 - w.x0 + a.width) as usize);
        let (ay0, ay1) = ((a.y0 - w.y0) as usize, (a.y0 - w.y0 + a.height) as usize);
        let nodata = raster.nodata;
        let width = w.width as usize;
        // On all cores: with the clearing of the layers on one core, this fill took 7 ms of a
        // 13 ms GPU call for a 1080p frame on a 16-core host (the first stores into a fresh
        // layer also fault its pages in).
        let fill = |layer: &mut [u32], value: u32| {
            layer.par_chunks_mut(width).enumerate().for_each(|(y, row)| {
                if (ay0..ay1).contains(&y) {
                    row[..ax0].fill(value);
                    row[ax1..].fill(value);
                } else {
                    row.fill(value);
                }
            })
        };
        for info in LAYERS.iter().filter(|i| i.cells == Cells::Pixel && i.words == 1) {
            let value = match info.inactive {
                Inactive::Nodata => nodata.to_bits(),
                Inactive::NoOwner => NO_OWNER,
                Inactive::Zero => 0,
                Inactive::Background => background,
            };
            if let Some(layer) = raster.layer_mut(info.layer) {
                fill(layer, value);
            }
        }
    }

    /// The statistics, given the kernels' counters (summed over the call's dispatches).
    pub fn stats(&self, counters: &[u64; Counter::COUNT]) -> Stats {
        let mut stats = self.stats.clone();
        stats.tiles_empty_skipped += counters[Counter::TilesEmpty as usize];
        stats.tiles_full = counters[Counter::TilesFull as usize];
        stats.tiles_partial = counters[Counter::TilesPartial as usize];
        stats.triangles_hidden = counters[Counter::TrianglesHidden as usize];
        stats
    }
}

/// A layer of `n` cells if `wanted`, in `spare`'s memory where it has it.
fn reuse_layer<T: bytemuck::Zeroable + Clone>(wanted: bool, spare: Option<Vec<T>>, n: usize, window: &Window) -> Result<Option<Vec<T>>, Error> {
    if !wanted {
        return Ok(None);
    }
    reuse_cells(spare, n).map(Some).map_err(|reason| Error::RasterTooLarge { width: window.width as u64, height: window.height as u64, reason })
}
