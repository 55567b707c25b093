//! The vertex stage: a position to clip space and on to the rasteriser's snapped pixels, depth
//! and `1/w`, in double-`f32`.
//!
//! The host subtracts a local origin `o` from every position once (in `f64`, where the
//! difference of two nearby coordinates is exact or nearly so) and composes the frame's matrix
//! with the translation back, `M · T(o)`, once per frame. What reaches the kernels is small
//! relative positions and a matrix in double-`f32` (`math::double`): 48 significant bits where
//! `f32` has 24, so a vertex of UTM terrain at 5,000,000 m snaps where the `f64` pipeline snaps
//! it (`docs/numeric-contract.md`, "Geometry in the kernels").

use crate::abi::{ProjectedVertex, RelativePosition, VertexParams, VertexUniforms};
use crate::math::double::Double;
use crate::programs::vertex::VertexProgram;
use crate::stages::viewport;

/// `m · (r, 1)`: a position relative to the stage's origin (the host's choice: the centre of
/// the positions' box) to clip space, `m` row-major with the origin composed in.
#[inline]
pub fn to_clip(m: &[[Double; 4]; 4], r: &[Double; 3]) -> [Double; 4] {
    let mut clip = [Double::ZERO; 4];
    let mut row = 0;
    while row < 4 {
        let m = &m[row];
        clip[row] = m[0] * r[0] + m[1] * r[1] + m[2] * r[2] + m[3];
        row += 1;
    }
    clip
}

/// The largest position (relative to the stage's origin) the stage projects, and the largest
/// matrix entry the host hands it: products and sums then stay far from `f32`'s overflow (and
/// the Veltkamp splits' `2^115`), so no infinity or NaN ever enters the arithmetic, whose
/// handling of them Vulkan leaves to the driver. The host sends only finite values.
pub const POSITION_LIMIT: f32 = (1u64 << 50) as f32;
pub const MATRIX_LIMIT: f32 = (1u64 << 60) as f32;

/// The smallest `w` the stage projects: its pairs' low parts stay far above the subnormals.
const W_LOWEST: f32 = 1.0 / (1u64 << 60) as f32;
/// The largest: `x / w` and the products before it stay far below `f32`'s overflow.
const W_HIGHEST: f32 = (1u128 << 100) as f32;

/// [`ProjectedVertex::planes`]: beyond the frustum plane `x = -w`, `x = w`, `y = -w`, `y = w`,
/// `z = 0` (near), `z = w` (far). A face whose corners share one is wholly outside the frustum.
pub const BEYOND_LEFT: u32 = 1;
pub const BEYOND_RIGHT: u32 = 2;
pub const BEYOND_TOP: u32 = 4;
pub const BEYOND_BOTTOM: u32 = 8;
pub const BEYOND_NEAR: u32 = 16;
pub const BEYOND_FAR: u32 = 32;
/// All six frustum bits.
pub const FRUSTUM: u32 = 63;
/// The kernels' assembly may not take the vertex as projected: it lies outside the stage's
/// domain, beyond the near or far plane, or beyond the guard band once snapped. A face with
/// such a corner (and not wholly outside the frustum) is clipped by the host.
pub const UNASSEMBLED: u32 = 64;

/// The frustum bits of a clip-space position: the signs of `x + w`, `w − x`, `y + w`, `w − y`,
/// `z` and `w − z` in pairs (a normalised pair's high part carries its sign), so within a few
/// units of `2^-44` of the exact comparisons, far below the margin by which the host culls
/// whole instances (`instances::outside_frustum`): a vertex of an instance it culls lies
/// beyond a plane by these bits too.
#[inline]
pub fn frustum_planes(clip: &[Double; 4]) -> u32 {
    let (x, y, z, w) = (clip[0], clip[1], clip[2], clip[3]);
    let bit = |beyond: bool, b: u32| if beyond { b } else { 0 };
    bit((x + w).hi < 0.0, BEYOND_LEFT)
        | bit((w - x).hi < 0.0, BEYOND_RIGHT)
        | bit((y + w).hi < 0.0, BEYOND_TOP)
        | bit((w - y).hi < 0.0, BEYOND_BOTTOM)
        | bit(z.hi < 0.0, BEYOND_NEAR)
        | bit((w - z).hi < 0.0, BEYOND_FAR)
}

/// Vertex `index` through the stage: posed by `program` (with the frame's vertex `texture`)
/// where `params.posed` says so, then
/// projected where its position (before and after the pose) lies within [`POSITION_LIMIT`] and
/// it lies in front of the camera (`w` in `[2^-60, 2^100]`), within `params.reach` of the view in
/// `x` and `y` and within `[-w, 2w]` in `z`, else [`ProjectedVertex::none`] (the host then
/// projects it in `f64` if it lies inside the clipping planes at all). Its [`FRUSTUM`] bits are
/// set wherever its position is within the limit; [`UNASSEMBLED`] where the kernels' assembly
/// may not take it.
#[inline]
// Plain comparisons, as the CPU twin's `f64` path mirrors them.
#[allow(clippy::manual_range_contains)]
pub fn vertex<P: VertexProgram + ?Sized>(program: &P, params: &VertexParams, texture: &[f32], index: u32, position: &RelativePosition) -> ProjectedVertex {
    if !bounded(position.hi) {
        return ProjectedVertex::NONE;
    }
    let mut m = [[Double::ZERO; 4]; 4];
    let mut row = 0;
    while row < 4 {
        let mut col = 0;
        while col < 4 {
            m[row][col] = Double { hi: params.matrix_hi[row][col], lo: params.matrix_lo[row][col] };
            col += 1;
        }
        row += 1;
    }
    let r = if params.posed != 0 { posed(program, &params.uniforms, texture, index, position) } else { pairs(position) };
    // (A NaN fails every comparison: a pose to NaN is not projected.)
    if !bounded([r[0].hi, r[1].hi, r[2].hi]) {
        return ProjectedVertex::NONE;
    }
    let clip = to_clip(&m, &r);
    let planes = frustum_planes(&clip);
    let w = clip[3].hi;
    let within = |v: f32, reach: f32| v <= reach * w && -v <= reach * w;
    let in_domain = w >= W_LOWEST
        && w <= W_HIGHEST
        && within(clip[0].hi, params.reach[0])
        && within(clip[1].hi, params.reach[1])
        && clip[2].hi >= -w
        && clip[2].hi <= 2.0 * w;
    if !in_domain {
        return ProjectedVertex::none(planes);
    }
    let (depth, inverse_w) = viewport::depth_and_inverse_w(&clip);
    let screen = viewport::snap(&clip, params.half_units);
    ProjectedVertex { screen, depth, inverse_w, planes: planes | assembly_bit(params, screen, planes) }
}

/// Whether a position (a pair's high parts) lies within the stage's range, [`POSITION_LIMIT`]
/// (not NaN).
#[inline]
pub fn bounded(p: [f32; 3]) -> bool {
    p[0] < POSITION_LIMIT && p[0] > -POSITION_LIMIT && p[1] < POSITION_LIMIT && p[1] > -POSITION_LIMIT && p[2] < POSITION_LIMIT && p[2] > -POSITION_LIMIT
}

/// A position's pairs.
#[inline]
pub fn pairs(position: &RelativePosition) -> [Double; 3] {
    [Double { hi: position.hi[0], lo: position.lo[0] }, Double { hi: position.hi[1], lo: position.lo[1] }, Double { hi: position.hi[2], lo: position.lo[2] }]
}

/// Vertex `index` at `position` as `program` poses it (with the frame's `uniforms` and vertex
/// `texture`) where the position lies within the stage's range ([`bounded`]), else as it is:
/// what the stage projects, and what its CPU twin and the host's stages take of a posed mesh.
#[inline]
pub fn posed<P: VertexProgram + ?Sized>(program: &P, uniforms: &VertexUniforms, texture: &[f32], index: u32, position: &RelativePosition) -> [Double; 3] {
    let r = pairs(position);
    if bounded(position.hi) { program.pose(uniforms, texture, index, r) } else { r }
}

/// [`UNASSEMBLED`] for a projected vertex beyond the near or far plane or beyond the guard
/// band (`screen` snapped), else 0.
#[inline]
pub fn assembly_bit(params: &VertexParams, screen: [i32; 2], planes: u32) -> u32 {
    let inside = screen[0] >= params.band_low
        && screen[1] >= params.band_low
        && screen[0] <= params.band_high[0]
        && screen[1] <= params.band_high[1]
        && planes & (BEYOND_NEAR | BEYOND_FAR) == 0;
    if inside { 0 } else { UNASSEMBLED }
}
