//! The interface between the host and the kernels: plain-old-data buffers (`#[repr(C)]` with
//! no implicit padding, so the bytes the host uploads are the bytes the SPIR-V reads) and the
//! typed codes inside them (`#[repr(u32)]` enums and flag sets). Host and kernels name every
//! mode, flag, output and counter through these types; no bare numbers cross the boundary.

use crate::memory::{Lanes, Words8, halves};
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
        /// A depth-tested tile rejects the triangles its depth bound hides
        /// (`programs::occlusion`).
        HIDDEN_TRIANGLES = 8,
        /// The frame's small triangles were rasterised apart, one invocation each
        /// (`stages::small`): its bins hold only the others, and each pixel starts from the
        /// key and count they left.
        SMALL_TRIANGLES = 16,
    }
}

flag_set! {
    /// The per-pixel layers a frame writes besides the values (`FrameParams::outputs`).
    OutputSet {
        /// The owning triangle's index per pixel.
        OWNER = 1,
        /// How many triangles cover each pixel centre.
        COVERAGE = 2,
        /// Per tile: its bin's entries and how many of them its depth bound hid
        /// (`Buffer::TileStats`).
        TILES = 4,
    }
}

/// The statistics counters fine raster adds to, by index into the statistics buffer.
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
    /// Bin entries a tile's depth bound rejected: triangles that could own no pixel of the
    /// tile, whose depths were never computed there.
    TrianglesHidden = 3,
}

impl Counter {
    /// Length of the statistics buffer.
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

    /// Whether the two rectangles share a pixel.
    #[inline]
    pub fn overlaps(&self, other: &PixelRect) -> bool {
        self.i0 <= other.i1 && other.i0 <= self.i1 && self.j0 <= other.j1 && other.j0 <= self.j1
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
    /// Bit `k` set: edge `k` is not top-left, so by the fill rule it does not own the pixel
    /// centres exactly on it.
    pub excluded_edges: u32,
    /// Position of the triangle in the setup buffer, to fetch its plane once it wins. Last
    /// of what a walk reads (`SetupPart`), which knows it from the bin entry.
    pub slot: u32,
    pub _pad: u32,
}

/// What a program stages of a triangle, read from the setup buffer as 64-bit words by the
/// lanes of a group together (`memory::Lanes`): the walk's reads (`stages::fine::fine_walk`).
pub trait SetupPart: Sized {
    /// The part of setup slot `slot`, from `setup_words` (the setup buffer as `u64`s).
    fn read_setup(lanes: &Lanes, setup_words: &[u64], slot: u32) -> Self;
}

/// `u64`s per `TriangleSetup`.
pub const SETUP_WORDS: u32 = (core::mem::size_of::<TriangleSetup>() / 8) as u32;

/// The word of a setup record that holds its rectangle's `(i0, j0)`; `(i1, j1)` follows.
const RECT_WORD: u32 = 9;

/// A record's words 0..12 (two reads of eight): the edges (`e0`, `step_i`, `step_j`), the
/// rectangle, the index and the excluded edges.
#[inline(always)]
fn coverage_of(a: &Words8<u64>, b: &Words8<u64>, slot: u32) -> Coverage {
    let edge = |e0: u64, step_i: u64, step_j: u64| EdgeEq { e0: e0 as i64, step_i: step_i as i64, step_j: step_j as i64 };
    let edges = [edge(a.get(0), a.get(1), a.get(2)), edge(a.get(3), a.get(4), a.get(5)), edge(a.get(6), a.get(7), b.get(0))];
    let rect = rect_of(b.get(1), b.get(2));
    let (index, excluded_edges) = halves(b.get(3));
    Coverage { edges, rect, index, excluded_edges, slot, _pad: 0 }
}

/// A rectangle from its two words.
#[inline(always)]
fn rect_of(first: u64, last: u64) -> PixelRect {
    let ((i0, j0), (i1, j1)) = (halves(first), halves(last));
    PixelRect { i0: i0 as i32, j0: j0 as i32, i1: i1 as i32, j1: j1 as i32 }
}

/// The rectangle of setup slot `slot`, read by this lane alone (two loads, where the typed
/// record would take four).
#[inline(always)]
pub fn setup_rect(setup_words: &[u64], slot: u32) -> PixelRect {
    let at = (slot * SETUP_WORDS + RECT_WORD) as usize;
    rect_of(setup_words[at], setup_words[at + 1])
}

impl SetupPart for Coverage {
    #[inline(always)]
    fn read_setup(lanes: &Lanes, setup_words: &[u64], slot: u32) -> Coverage {
        let at = slot * SETUP_WORDS;
        coverage_of(&lanes.read8(setup_words, at), &lanes.read8(setup_words, at + 8), slot)
    }
}

impl SetupPart for TriangleSetup {
    /// Word 12 is the coverage's slot and padding; then the `f32` coefficients (13..15) and the
    /// plane (15..19). A program that reads no plane (the render pipeline's) leaves the third
    /// group's loads unused, and the driver's compiler drops them.
    #[inline(always)]
    fn read_setup(lanes: &Lanes, setup_words: &[u64], slot: u32) -> TriangleSetup {
        let at = slot * SETUP_WORDS;
        let (a, b, c) = (lanes.read8(setup_words, at), lanes.read8(setup_words, at + 8), lanes.read8(setup_words, at + 16));
        let (c01, c23) = (halves(b.get(5)), halves(b.get(6)));
        let coeffs = FloatCoeffs { c: [f32::from_bits(c01.0), f32::from_bits(c01.1), f32::from_bits(c23.0), f32::from_bits(c23.1)] };
        let plane = Plane { z: b.get(7) as i64, gi: c.get(0) as i64, gj: c.get(1) as i64, frac_bits: c.get(2) as u32 as i32, _pad: 0 };
        TriangleSetup { coverage: coverage_of(&a, &b, slot), coeffs, plane }
    }
}

// The word offsets `coverage_of`, `setup_rect` and `TriangleSetup::read_setup` read.
#[cfg(not(target_arch = "spirv"))]
const _: () = {
    use core::mem::offset_of;
    assert!(
        offset_of!(Coverage, rect) == RECT_WORD as usize * 8 && offset_of!(Coverage, index) == 11 * 8 && offset_of!(Coverage, excluded_edges) == 11 * 8 + 4
    );
    assert!(offset_of!(Coverage, slot) == 12 * 8 && offset_of!(TriangleSetup, coeffs) == 13 * 8 && offset_of!(TriangleSetup, plane) == 15 * 8);
    assert!(offset_of!(Plane, frac_bits) == 24 && SETUP_WORDS == 19 && core::mem::align_of::<TriangleSetup>() == 8);
};

/// Output of the setup stage, one per prepared triangle.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct TriangleSetup {
    pub coverage: Coverage,
    /// Before the plane: the render pipeline's walks read the coverage and these, the first
    /// sixteen words, in two reads of eight (`SetupPart for TriangleSetup`).
    pub coeffs: FloatCoeffs,
    pub plane: Plane,
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
    /// Tile rows each binning invocation takes of its triangle (at most `BIN_PART_TILES` tiles'
    /// worth; fewer where the frame has few triangles, `Plan::frame_listing`)...
    pub bin_part_rows: u32,
    /// ... and invocations per triangle, enough for the tallest triangle of the window.
    pub bin_parts: u32,
    /// The specialisations this frame may use.
    pub flags: FrameFlags,
    /// The render pipeline's depth test (unused by the heightfield's).
    pub depth_test: DepthTest,
    /// Samples per pixel of a multisampled frame (binning reaches its tiles' border samples);
    /// 0 or 1: one, at the centre.
    pub samples: u32,
    /// Triangles of the frame's small list (`stages::small`), rasterised one invocation each.
    pub small_triangles: u32,
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

/// The render pipeline's depth comparison: a fragment passes where its depth compares so with
/// the depth buffer's (here: the clear value, `FrameParams::nodata_bits`, since the pipeline
/// resolves every fragment of a pixel at once). Ties in depth go to the triangle the graphics
/// APIs would keep: the earlier for `Less`/`Greater`, the later for `LessEqual`/`GreaterEqual`.
#[repr(u32)]
#[derive(Copy, Clone, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum DepthFunc {
    #[default]
    Less = 0,
    LessEqual = 1,
    Greater = 2,
    GreaterEqual = 3,
    /// Every fragment passes; the last submitted one is kept.
    Always = 4,
}

impl DepthFunc {
    #[inline]
    pub fn from_code(code: u32) -> DepthFunc {
        if code == DepthFunc::LessEqual as u32 {
            DepthFunc::LessEqual
        } else if code == DepthFunc::Greater as u32 {
            DepthFunc::Greater
        } else if code == DepthFunc::GreaterEqual as u32 {
            DepthFunc::GreaterEqual
        } else if code == DepthFunc::Always as u32 {
            DepthFunc::Always
        } else {
            DepthFunc::Less
        }
    }
}

#[cfg(not(target_arch = "spirv"))]
impl DepthFunc {
    pub const ALL: [DepthFunc; 5] = [DepthFunc::Less, DepthFunc::LessEqual, DepthFunc::Greater, DepthFunc::GreaterEqual, DepthFunc::Always];

    /// The name the command line uses.
    pub fn name(self) -> &'static str {
        match self {
            DepthFunc::Less => "less",
            DepthFunc::LessEqual => "less-equal",
            DepthFunc::Greater => "greater",
            DepthFunc::GreaterEqual => "greater-equal",
            DepthFunc::Always => "always",
        }
    }
}

/// A depth function and whether passing fragments write their depth: one word of
/// `FrameParams`, the function's code in the low byte and `WRITE` above it.
#[repr(transparent)]
#[derive(Copy, Clone, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, Hash))]
pub struct DepthTest(pub u32);

impl DepthTest {
    const WRITE: u32 = 1 << 8;

    pub const fn new(func: DepthFunc, write: bool) -> DepthTest {
        DepthTest(func as u32 | if write { Self::WRITE } else { 0 })
    }

    #[inline]
    pub fn func(self) -> DepthFunc {
        DepthFunc::from_code(self.0 & 0xff)
    }

    #[inline]
    pub fn write(self) -> bool {
        self.0 & Self::WRITE != 0
    }
}

/// What the shade stage computes per pixel (`ShadeParams::shading`).
#[repr(u32)]
#[derive(Copy, Clone, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum ShadeMode {
    /// The interpolated vertex colour as it is (flat and Gouraud shading: lit per face or per
    /// vertex by the assembly, `programs::shade::lit_face` and `lit_vertex`).
    #[default]
    Colour = 0,
    /// Lambert diffuse and Blinn-Phong specular per pixel, from the interpolated normal.
    Phong = 1,
    /// The depth as grey, `ShadeParams::depth_view` mapped to white..black.
    Depth = 2,
    /// The interpolated unit normal, `n·0.5 + 0.5` as RGB.
    Normals = 3,
    /// A colour per input face id.
    Ids = 4,
    /// glTF's metallic-roughness BRDF per pixel (`programs::brdf`), from the interpolated
    /// normal, the frame's lights and each triangle's material (`MaterialRecord`).
    Pbr = 5,
}

impl ShadeMode {
    #[inline]
    pub fn from_code(code: u32) -> ShadeMode {
        if code == ShadeMode::Phong as u32 {
            ShadeMode::Phong
        } else if code == ShadeMode::Depth as u32 {
            ShadeMode::Depth
        } else if code == ShadeMode::Normals as u32 {
            ShadeMode::Normals
        } else if code == ShadeMode::Ids as u32 {
            ShadeMode::Ids
        } else if code == ShadeMode::Pbr as u32 {
            ShadeMode::Pbr
        } else {
            ShadeMode::Colour
        }
    }
}

/// How attributes are interpolated (`ShadeParams::interpolation`).
#[repr(u32)]
#[derive(Copy, Clone, Default, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum Interpolation {
    /// Perspective-correct: linear in the triangle's plane in the world.
    #[default]
    Perspective = 0,
    /// Linear on the screen (`noperspective`).
    Screen = 1,
    /// The face's first vertex's values everywhere (`flat`; the host gives every corner of a
    /// face, and of its clipped pieces, that vertex's attributes).
    Flat = 2,
}

/// Directional lights the shade stage takes.
pub const MAX_LIGHTS: usize = 2;

/// Scalars carried per vertex: colour RGBA, normal xyz, world position xyz, texture uv.
pub const ATTRIBUTES: usize = 12;
/// Where each attribute starts in a vertex's `ATTRIBUTES` scalars.
pub const ATTR_COLOUR: usize = 0;
pub const ATTR_NORMAL: usize = 4;
pub const ATTR_POSITION: usize = 7;
pub const ATTR_UV: usize = 10;

/// The shade stage's parameters: one per frame, the same for every pixel.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct ShadeParams {
    /// A [`ShadeMode`] code.
    pub shading: u32,
    /// An [`Interpolation`] code.
    pub interpolation: u32,
    /// RGBA8 of pixels no triangle covers (red in the low byte).
    pub background: u32,
    /// Lights in use, at most [`MAX_LIGHTS`].
    pub lights: u32,
    /// Blinn-Phong exponent (an integer, raised by repeated squaring).
    pub shininess: u32,
    /// Non-zero: fragments are blended source-over in submission order (`programs::shade`).
    pub blend: u32,
    /// The frame's depth test, for the blended walk (as `FrameParams::depth_test`).
    pub depth_test: DepthTest,
    /// Samples per pixel: 1 (0 reads as 1), or 4 or 8 at the standard positions
    /// (`programs::multisample`).
    pub samples: u32,
    /// The sample whose depth and owner a multisampled frame's depth, owner and face layers
    /// take.
    pub layer_sample: u32,
    /// Non-zero where some triangle of the frame has a texture; zero lets shading leave the
    /// sampling out.
    pub textured: u32,
    /// Non-zero where every triangle's edge functions fit 32 bits within two pixels of its
    /// snapped box (`stages::setup::edges_fit_i32`), so that the interpolation weights take
    /// them in 32-bit arithmetic (the same bits).
    pub small_edges: u32,
    /// The output transform of lit colours (`programs::tone`): a tone map in bits 0–1
    /// (`TONE_NONE`, `TONE_NEUTRAL`, `TONE_ACES`), `OUTPUT_SRGB` for sRGB encoding.
    pub output: u32,
    /// Ambient light, RGB.
    pub ambient: [f32; 4],
    /// Specular colour, RGB.
    pub specular: [f32; 4],
    /// The viewer, homogeneous: a perspective camera's position `[x, y, z, 1]`, or for an
    /// orthographic camera the unit direction towards it `[x, y, z, 0]`
    /// ([`ShadeParams::towards_viewer`]).
    pub eye: [f32; 4],
    /// Unit direction towards each light, xyz.
    pub light_dir: [[f32; 4]; MAX_LIGHTS],
    /// Each light's colour, RGB.
    pub light_colour: [[f32; 4]; MAX_LIGHTS],
    /// The depth view's range: `[near, 1 / (far − near)]`, depth `near` white, `far` black.
    pub depth_view: [f32; 4],
    /// Values for a fragment program (`programs::fragment`), as the frame gives them.
    pub constants: [f32; FRAGMENT_CONSTANTS],
}

/// Values a frame hands its fragment program (`ShadeParams::constants`).
pub const FRAGMENT_CONSTANTS: usize = 8;

impl ShadeParams {
    /// From the point `p` in the world towards the viewer (not normalised): `eye − p` for a
    /// perspective camera, the camera's direction for an orthographic one.
    #[inline]
    pub fn towards_viewer(&self, p: [f32; 3]) -> [f32; 3] {
        let e = &self.eye;
        [e[0] - p[0] * e[3], e[1] - p[1] * e[3], e[2] - p[2] * e[3]]
    }

    #[inline]
    pub fn mode(&self) -> ShadeMode {
        ShadeMode::from_code(self.shading)
    }
}

/// The frame-wide choices of the stages that colour fragments, in one word: the shading mode,
/// the interpolation, blending, the number of lights, the samples, whether anything is
/// textured, whether the edge functions fit 32 bits, and the output transform. On the GPU each frame's word is a specialisation constant of its shading
/// pipelines, so that the driver compiles only the branches the frame takes: a CPU
/// implementation of Vulkan runs every branch of a kernel, taken or not, and a GPU's registers
/// are sized for the longest. Every field repeats one of `ShadeParams`, so a specialised stage
/// computes exactly what the generic one computes from the parameters.
#[derive(Copy, Clone, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub struct ShadeVariant(pub u32);

const _: () = assert!(MAX_LIGHTS < 4, "ShadeVariant holds the lights in two bits");

impl ShadeVariant {
    /// Not specialised: every choice is read from `ShadeParams` (the modules' default, and the
    /// CPU backend's).
    pub const GENERIC: ShadeVariant = ShadeVariant(0);
    /// The specialisation constant's `SpecId` in the shading entry points.
    pub const SPEC_ID: u32 = 0;
    const SPECIALISED: u32 = 1 << 31;

    /// The word that fixes `params`' choices.
    #[inline]
    pub fn of(params: &ShadeParams) -> ShadeVariant {
        let field = |value: u32, bits: u32, at: u32| (value & ((1 << bits) - 1)) << at;
        ShadeVariant(
            Self::SPECIALISED
                | field(params.shading, 4, 0)
                | field(params.interpolation, 2, 4)
                | field((params.blend != 0) as u32, 1, 6)
                | field(params.lights, 2, 7)
                | field(params.samples, 4, 9)
                | field((params.textured != 0) as u32, 1, 13)
                | field((params.small_edges != 0) as u32, 1, 14)
                | field(params.output, 3, 15),
        )
    }

    /// Whether `params` has choices this word cannot hold (then the frame runs the generic
    /// stage).
    #[inline]
    pub fn holds(params: &ShadeParams) -> bool {
        params.shading < 16 && params.interpolation < 4 && params.lights <= MAX_LIGHTS as u32 && params.samples < 16 && params.output < 8
    }

    /// `params` with this word's choices in place of its own (unchanged where generic). A
    /// specialisation constant makes every one of them a constant to the driver's compiler.
    #[inline]
    pub fn apply(self, params: &ShadeParams) -> ShadeParams {
        let mut p = *params;
        let w = self.0;
        if w & Self::SPECIALISED != 0 {
            p.shading = w & 0xf;
            p.interpolation = w >> 4 & 0x3;
            p.blend = w >> 6 & 1;
            p.lights = w >> 7 & 0x3;
            p.samples = w >> 9 & 0xf;
            p.textured = w >> 13 & 1;
            p.small_edges = w >> 14 & 1;
            p.output = w >> 15 & 0x7;
        }
        p
    }
}

/// What the shade stage needs of one triangle besides its coverage (one per setup slot): its
/// vertices' attributes and `1/w`, each paired with the edge function that weighs it (entry `k`
/// belongs to the vertex opposite edge `k`, as the depth coefficients in `FloatCoeffs`).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct TriangleShading {
    pub attributes: [[f32; ATTRIBUTES]; 3],
    /// `1/w` of each vertex in clip space.
    pub inv_w: [f32; 3],
    /// The input face this triangle comes from (clipping may cut a face into several).
    pub face: u32,
    /// Its surface: its texture an index into the frame's `TextureInfo`s (or [`NO_TEXTURE`]),
    /// its flags `SHADING_*`, its material an index into the frame's [`MaterialRecord`]s.
    pub material: FaceMaterial,
}

/// A face's surface besides its colour: its base-colour texture, how it is drawn and lit
/// (`SHADING_*` flags), and its material. One per face of a mesh that names its faces'
/// (`FaceMaterials`, the texture an index into the mesh's textures, the material into its
/// materials), else the mesh's `AssembleParams::material` (indices into the frame's); the
/// assembly copies it into each of the face's triangles' [`TriangleShading`] (the indices then
/// the frame's).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct FaceMaterial {
    pub texture: u32,
    pub flags: u32,
    pub material: u32,
    pub _pad: u32,
}

impl FaceMaterial {
    /// A surface of `texture` and `flags` of the frame's first material (its own surface, for
    /// meshes without materials, lines and points).
    pub const fn plain(texture: u32, flags: u32) -> FaceMaterial {
        FaceMaterial { texture, flags, material: 0, _pad: 0 }
    }

    /// A mesh's face surface in the frame: its texture and material indices after the mesh's
    /// first texture and material (no texture stays none).
    #[inline]
    pub fn placed(self, first_texture: u32, first_material: u32) -> FaceMaterial {
        let texture = if self.texture == NO_TEXTURE { NO_TEXTURE } else { first_texture + self.texture };
        FaceMaterial { texture, material: first_material + self.material, ..self }
    }
}

/// One material of a frame as the shade stage reads it (`Materials`: the frame's own surface
/// first, then its meshes' materials): glTF's metallic and roughness factors in `[0, 1]`, the
/// cutoff of a masked surface's alpha (`SHADING_MASK`), the strength of its occlusion texture,
/// the light it emits (linear RGB), and its textures besides the base colour's (indices into
/// the frame's `TextureInfo`s, or `NO_TEXTURE`): metallic-roughness (metallic in blue,
/// roughness in green), occlusion (red) and emission (sRGB).
#[repr(C)]
#[derive(Copy, Clone)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct MaterialRecord {
    pub metallic: f32,
    pub roughness: f32,
    pub alpha_cutoff: f32,
    pub occlusion_strength: f32,
    pub emissive: [f32; 4],
    pub metallic_roughness_texture: u32,
    pub occlusion_texture: u32,
    pub emissive_texture: u32,
    pub _pad: u32,
}

impl Default for MaterialRecord {
    /// A dielectric of medium roughness without textures or emission.
    fn default() -> MaterialRecord {
        MaterialRecord {
            metallic: 0.0,
            roughness: 0.5,
            alpha_cutoff: 0.0,
            occlusion_strength: 1.0,
            emissive: [0.0; 4],
            metallic_roughness_texture: NO_TEXTURE,
            occlusion_texture: NO_TEXTURE,
            emissive_texture: NO_TEXTURE,
            _pad: 0,
        }
    }
}

const _: () = assert!(core::mem::size_of::<AssembleParams>().is_multiple_of(16) && core::mem::offset_of!(AssembleParams, material).is_multiple_of(16));

/// 16-byte words per [`TriangleShading`].
pub const SHADING_VEC4S: u32 = (core::mem::size_of::<TriangleShading>() / 16) as u32;
const _: () = assert!(core::mem::size_of::<TriangleShading>() == 16 * SHADING_VEC4S as usize && SHADING_VEC4S == 11);

/// Where the shade stages read a triangle's [`TriangleShading`]: the typed records on the host
/// (borrowed); on the GPU the same buffer as 16-byte words, so that a record is eleven loads.
/// (A CPU implementation of Vulkan loads storage memory a lane at a time, in a loop per load
/// instruction whatever its width: field by field, a record would be 44 such loops.)
pub trait ShadingRecords {
    type Record<'a>: core::ops::Deref<Target = TriangleShading>
    where
        Self: 'a;
    fn record(&self, slot: u32) -> Self::Record<'_>;
    /// The record's `face`, which a backend may keep apart, so that on the CPU the face-id view
    /// and the face layer read nothing else of a record (the GPU reads the record's word).
    fn face(&self, slot: u32) -> u32;
}

impl ShadingRecords for [TriangleShading] {
    type Record<'a> = &'a TriangleShading;
    #[inline(always)]
    fn record(&self, slot: u32) -> &TriangleShading {
        &self[slot as usize]
    }
    #[inline(always)]
    fn face(&self, slot: u32) -> u32 {
        self[slot as usize].face
    }
}

/// The records with their faces also kept apart, one per slot (`faces[k] == records[k].face`),
/// as the host's geometry stages write them: where a pixel needs only its face (the face-id
/// view, and the face layer in every view), the CPU's shade stage reads 4 bytes of a compact
/// array instead of a cache line of the 176-byte records (17.6 MB for 100k triangles: a sixth
/// of a 1080p face-id frame of the 100k-triangle terrain went to that cache miss).
#[cfg(not(target_arch = "spirv"))]
#[derive(Clone, Copy)]
pub struct RecordsAndFaces<'a> {
    pub records: &'a [TriangleShading],
    pub faces: &'a [u32],
}

#[cfg(not(target_arch = "spirv"))]
impl ShadingRecords for RecordsAndFaces<'_> {
    type Record<'a>
        = &'a TriangleShading
    where
        Self: 'a;
    #[inline(always)]
    fn record(&self, slot: u32) -> &TriangleShading {
        &self.records[slot as usize]
    }
    #[inline(always)]
    fn face(&self, slot: u32) -> u32 {
        self.faces[slot as usize]
    }
}

/// A record put together from words.
#[cfg(target_arch = "spirv")]
pub struct Assembled<T>(T);

#[cfg(target_arch = "spirv")]
impl<T> core::ops::Deref for Assembled<T> {
    type Target = T;
    #[inline(always)]
    fn deref(&self) -> &T {
        &self.0
    }
}

#[cfg(target_arch = "spirv")]
impl ShadingRecords for [spirv_std::glam::UVec4] {
    type Record<'a> = Assembled<TriangleShading>;
    #[inline(always)]
    fn record(&self, slot: u32) -> Assembled<TriangleShading> {
        let at = (slot * SHADING_VEC4S) as usize;
        Assembled(TriangleShading {
            attributes: [
                vertex_attributes(self[at], self[at + 1], self[at + 2]),
                vertex_attributes(self[at + 3], self[at + 4], self[at + 5]),
                vertex_attributes(self[at + 6], self[at + 7], self[at + 8]),
            ],
            inv_w: [f32::from_bits(self[at + 9].x), f32::from_bits(self[at + 9].y), f32::from_bits(self[at + 9].z)],
            face: self[at + 9].w,
            material: FaceMaterial { texture: self[at + 10].x, flags: self[at + 10].y, material: self[at + 10].z, _pad: self[at + 10].w },
        })
    }
    #[inline(always)]
    fn face(&self, slot: u32) -> u32 {
        self[(slot * SHADING_VEC4S + 9) as usize].w
    }
}

#[cfg(target_arch = "spirv")]
#[inline(always)]
fn floats4(v: spirv_std::glam::UVec4) -> [f32; 4] {
    [f32::from_bits(v.x), f32::from_bits(v.y), f32::from_bits(v.z), f32::from_bits(v.w)]
}

/// A vertex's twelve attributes from its three words.
#[cfg(target_arch = "spirv")]
#[inline(always)]
fn vertex_attributes(a: spirv_std::glam::UVec4, b: spirv_std::glam::UVec4, c: spirv_std::glam::UVec4) -> [f32; ATTRIBUTES] {
    let (a, b, c) = (floats4(a), floats4(b), floats4(c));
    [a[0], a[1], a[2], a[3], b[0], b[1], b[2], b[3], c[0], c[1], c[2], c[3]]
}

/// `FaceMaterial::flags`: the fragment's colour is its interpolated colour attribute,
/// neither lit nor textured, in every mode that shows colours (lines: a wireframe keeps its
/// colour under any shading).
pub const SHADING_UNLIT: u32 = 1;
/// `FaceMaterial::flags`, set by the assembly: the triangle shows its back, which a
/// double-sided surface lights with its normal turned round.
pub const SHADING_BACK: u32 = 2;
/// `FaceMaterial::flags`: the face is kept whichever way it faces, whatever the frame culls
/// (glTF's `doubleSided`).
pub const SHADING_DOUBLE_SIDED: u32 = 4;
/// `FaceMaterial::flags`: the surface is opaque: its colour's alpha is 1 (glTF's `OPAQUE`),
/// where without it the alpha is kept for blending.
pub const SHADING_OPAQUE: u32 = 8;
/// `FaceMaterial::flags`: the surface is not lit: its base colour (textured), through the
/// frame's output transform, in the modes that light (glTF's `KHR_materials_unlit`).
pub const SHADING_NOT_LIT: u32 = 16;
/// `FaceMaterial::flags`: the surface is masked: its alpha is 1 where it reaches the material's
/// `alpha_cutoff`, else 0, and a frame that blends discards such a fragment (glTF's `MASK`).
pub const SHADING_MASK: u32 = 32;

/// `TriangleShading::texture` of an untextured triangle.
pub const NO_TEXTURE: u32 = u32::MAX;

/// Most mip levels a texture has (a 16384-texel side has 15).
pub const MAX_MIP_LEVELS: usize = 16;

/// How a texture is filtered (`TextureInfo::flags`, bits 0–1).
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum Filter {
    /// The texel the coordinate falls in, of the full-size level.
    Nearest = 0,
    /// The four texels around the coordinate, weighted, of the full-size level.
    Bilinear = 1,
    /// Bilinear in the two mip levels the level of detail lies between, blended by it
    /// (bilinear in the full-size level where the texture is magnified).
    Trilinear = 2,
}

impl Filter {
    pub const ALL: [Filter; 3] = [Filter::Nearest, Filter::Bilinear, Filter::Trilinear];

    #[inline]
    pub fn from_code(code: u32) -> Filter {
        match code {
            0 => Filter::Nearest,
            1 => Filter::Bilinear,
            _ => Filter::Trilinear,
        }
    }
}

/// What a texture coordinate outside `[0, 1)` reads (`TextureInfo::flags`, bits 2–3 for `u`,
/// 4–5 for `v`).
#[repr(u32)]
#[derive(Copy, Clone, PartialEq, Eq)]
#[cfg_attr(not(target_arch = "spirv"), derive(Debug, Hash))]
pub enum Address {
    Repeat = 0,
    ClampToEdge = 1,
    MirroredRepeat = 2,
}

impl Address {
    pub const ALL: [Address; 3] = [Address::Repeat, Address::ClampToEdge, Address::MirroredRepeat];

    #[inline]
    pub fn from_code(code: u32) -> Address {
        match code {
            0 => Address::Repeat,
            1 => Address::ClampToEdge,
            _ => Address::MirroredRepeat,
        }
    }
}

/// One texture of a frame: its mip levels in the texel buffer (a `u64` a texel: red, green,
/// blue and alpha from the low bits, 16 bits each, linear: sRGB textures are decoded on the
/// host before any filtering) and how it is sampled.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct TextureInfo {
    /// The full-size level's width and height in texels.
    pub width: u32,
    pub height: u32,
    /// Mip levels (1: no chain), at most [`MAX_MIP_LEVELS`].
    pub levels: u32,
    /// [`Filter`] in bits 0–1, the [`Address`] of `u` in bits 2–3 and of `v` in bits 4–5.
    pub flags: u32,
    /// The texel (a `u64`, red in its low 16 bits) at which each level starts in the texel
    /// buffer; level `k` is `max(1, width >> k)` × `max(1, height >> k)` texels, row by row.
    pub offsets: [u32; MAX_MIP_LEVELS],
}

impl TextureInfo {
    #[inline]
    pub fn filter(&self) -> Filter {
        Filter::from_code(self.flags & 3)
    }

    #[inline]
    pub fn address_u(&self) -> Address {
        Address::from_code(self.flags >> 2 & 3)
    }

    #[inline]
    pub fn address_v(&self) -> Address {
        Address::from_code(self.flags >> 4 & 3)
    }

    /// The flags of a filter and two address modes.
    pub const fn flags_of(filter: Filter, u: Address, v: Address) -> u32 {
        filter as u32 | (u as u32) << 2 | (v as u32) << 4
    }
}

/// The vertex stage's uniform (`stages::vertex`): the frame's matrix from positions relative to
/// its origin to clip space (`M · T(o)`, row-major), each entry as the double-`f32` pair
/// `hi + lo` (`math::double`), and the viewport.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct VertexParams {
    pub matrix_hi: [[f32; 4]; 4],
    pub matrix_lo: [[f32; 4]; 4],
    /// Half the frame's size in snapped units (`2^snap_bits` per pixel), per axis: exact in
    /// `f32` for frames up to `2^16` px.
    pub half_units: [f32; 2],
    /// How far beyond `±w` a vertex may lie in `x` and `y` and still be projected: twice the
    /// guard band's factor, so that every vertex inside the clipping planes is.
    pub reach: [f32; 2],
    /// Positions of the frame.
    pub vertices: u32,
    /// Invocations per row of the 2D dispatch that stands for a 1D one.
    pub dispatch_width: u32,
    /// The guard band in snapped units: a projected vertex the assembly may take lies within
    /// `[band_low, band_high]` on both axes (`stages::vertex::UNASSEMBLED`).
    pub band_low: i32,
    /// 1: pose each position by the frame's vertex program (`programs::vertex`) before the
    /// matrix; 0: take it as it is (the built-in program, or positions the host posed).
    pub posed: u32,
    pub band_high: [i32; 2],
    /// What the frame hands its vertex program.
    pub uniforms: VertexUniforms,
    /// The index in the frame of the dispatch's first vertex (a frame dispatched in parts).
    pub first_vertex: u32,
    pub _pad: [u32; 3],
}

/// Values a frame hands its vertex program (`VertexParams::uniforms`).
pub const VERTEX_CONSTANTS: usize = 8;

/// What a vertex program reads of the frame besides its vertex: the user's constants, the
/// frame's time and the size of its vertex texture (`programs::vertex::texel`).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct VertexUniforms {
    pub constants: [f32; VERTEX_CONSTANTS],
    /// Seconds (`RenderParams::time`).
    pub time: f32,
    /// The vertex texture's columns and rows (0 × 0 where the frame has none).
    pub texture_size: [u32; 2],
    /// Which built-in program the kernels' own vertex stage runs (`programs::vertex::Builtin`):
    /// `BUILTIN_NONE`, `BUILTIN_HEIGHTS` or `BUILTIN_DEFORM`; a user's shader ignores it.
    pub builtin: u32,
}

/// A vertex's position relative to the stage's origin, each coordinate as the double-`f32`
/// pair `hi + lo`.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct RelativePosition {
    pub hi: [f32; 3],
    pub lo: [f32; 3],
}

/// A vertex through the vertex stage, as the rasteriser takes it.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct ProjectedVertex {
    /// Snapped, in `2^-snap_bits` px, `y` down.
    pub screen: [i32; 2],
    /// `z/w` rounded to `f32` and clamped to `[0, 1]`; [`ProjectedVertex::NONE`]'s `-1` where
    /// the vertex lies outside the stage's domain (behind the camera, far beyond the guard band,
    /// or too large for the pairs), which the host then projects in `f64` if it lies inside the
    /// clipping planes at all.
    pub depth: f32,
    /// `1/w` rounded to `f32`.
    pub inverse_w: f32,
    /// Bits of `stages::vertex`: the frustum planes it lies beyond, and whether the kernels'
    /// assembly may take it as projected (`UNASSEMBLED` where not).
    pub planes: u32,
}

impl ProjectedVertex {
    /// What the stage writes for a vertex it does not project: the same bits on every device.
    pub const NONE: ProjectedVertex = ProjectedVertex::none(0);

    /// [`Self::NONE`] beyond the frustum planes `planes` (and so `UNASSEMBLED`).
    #[inline]
    pub const fn none(planes: u32) -> ProjectedVertex {
        ProjectedVertex { screen: [0, 0], depth: -1.0, inverse_w: 0.0, planes: planes | crate::stages::vertex::UNASSEMBLED }
    }

    #[inline]
    pub fn is_projected(&self) -> bool {
        self.depth >= 0.0
    }
}

/// What the assembly stages take for the faces of one placed mesh (`stages::assemble`): how
/// they are culled and snapped, and what their records carry.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct AssembleParams {
    /// Faces of the mesh, and the id of its first (a frame numbers its instances' faces in turn).
    pub faces: u32,
    pub first_face: u32,
    /// `stages::assemble::CULL_*`, and 1 where counter-clockwise triangles face the viewer.
    pub cull: u32,
    pub front_counter_clockwise: u32,
    /// The target's pixels, the snapped coordinates' sub-pixel bits, and how far beyond its
    /// snapped box a triangle's samples reach, in snapped units (0 with one sample).
    pub width: u32,
    pub height: u32,
    pub snap_bits: u32,
    pub reach: u32,
    /// 1 where the placement mirrors the mesh: its faces' second and third corners swap.
    pub mirrored: u32,
    /// 1 where the vertices carry attributes (else every attribute is 0).
    pub attributes: u32,
    /// 1 for flat interpolation: every corner takes the face's first vertex's attributes.
    pub flat: u32,
    /// How the assembly lights the corners' colours: `LIGHT_NONE`, `LIGHT_VERTICES` (Gouraud
    /// shading: each corner takes its vertex's colour as the light stage lit it) or `LIGHT_FACES`
    /// (flat shading: each face's first vertex's colour lit with its `FaceNormal`, both written
    /// over every corner), with the frame's `ShadeParams`.
    pub lighting: u32,
    /// 1 where each face names its surface (`FaceMaterials`, its texture offset by
    /// `first_texture` unless `NO_TEXTURE`, its material by `first_material`); else every face
    /// takes `material`, whose indices are the frame's.
    pub face_materials: u32,
    pub first_texture: u32,
    pub first_material: u32,
    /// 1 where small triangles go to their own list (`Plan::small`, `stages::small`).
    pub split_small: u32,
    /// Faces the host clipped (`AssemblyPatch` entries), and workgroups of faces.
    pub patches: u32,
    pub groups: u32,
    /// Invocations per row of the 2D dispatch that stands for a 1D one.
    pub dispatch_width: u32,
    /// Records of the frame's earlier placements in the listed and the small list: this
    /// mesh's records follow theirs (slot = listed rank + small rank).
    pub first_listed: u32,
    pub first_small: u32,
    /// The mesh's first vertex in the frame's vertices (`Projected`, `VertexAttributes`: the
    /// placements' one after the other); its faces index its own.
    pub first_vertex: u32,
    /// The mesh's first face in the frame's `FaceNormal`s (the placements' one after the
    /// other), under flat shading.
    pub first_face_normal: u32,
    /// 1 where a double-sided surface's faces are kept whichever way they face
    /// (`stages::assemble::Assembly::double_sided`).
    pub double_sided: u32,
    /// Every face's surface where they do not name theirs.
    pub material: FaceMaterial,
}

/// A face the host clipped, patched into the assembly's output in its place: its pieces'
/// records (`Pieces`, `PieceShading`) start at `first`; `listed` and `small` count those that
/// go to each list.
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq, Eq))]
pub struct AssemblyPatch {
    pub face: u32,
    pub first: u32,
    pub listed: u32,
    pub small: u32,
}

/// The light stage's parameters (`stages::light`).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct LightParams {
    /// Vertices of the frame.
    pub vertices: u32,
    /// Invocations per row of the 2D dispatch that stands for a 1D one.
    pub dispatch_width: u32,
    pub _pad: [u32; 2],
}

/// `AssembleParams::lighting`: the corners' colours as the vertices give them.
pub const LIGHT_NONE: u32 = 0;
/// Gouraud shading: each vertex lit by the light stage (`stages::light`).
pub const LIGHT_VERTICES: u32 = 1;
/// Flat shading: each face lit (`programs::shade::lit_face`).
pub const LIGHT_FACES: u32 = 2;

/// A face's unit normal in the world under flat shading (`normal[3]` is 0), which the
/// assembly writes over its corners' and lights the face with (`programs::shade::lit_face`).
#[repr(C)]
#[derive(Copy, Clone, Default)]
#[cfg_attr(not(target_arch = "spirv"), derive(Pod, Zeroable, Debug, PartialEq))]
pub struct FaceNormal {
    pub normal: [f32; 4],
}
