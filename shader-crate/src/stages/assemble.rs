//! Assembly of a snapped triangle in the render pipeline: whether it reaches the rasteriser
//! (area, facing, pixel centres), its orientation for the edge functions, and its records for
//! setup and shading. Integers and the `f32` values it is given, nothing else, so that every
//! device assembles the same bits. The host's assembly (`tileraster_core::render`, its `cull`
//! stage) takes every face's triangles through these functions.
//!
//! Range: snapped coordinates within the guard band (below `2^28` in magnitude), so that
//! differences stay below `2^29` and the doubled area below `2^59`.

use crate::abi::{
    ATTR_COLOUR, ATTR_NORMAL, ATTRIBUTES, AssembleParams, AssemblyPatch, FaceMaterial, FaceNormal, FloatCoeffs, PixelRect, ProjectedVertex, SHADING_BACK,
    SHADING_DOUBLE_SIDED, ShadeParams,
};
use crate::abi::{LIGHT_FACES, LIGHT_VERTICES};
use crate::abi::{TriangleInput, TriangleShading};
use crate::math::fixed::{ceil_shr, floor_shr};
use crate::math::float::recip_u64;
use crate::memory::Slots;
use crate::programs::shade::lit_face;
use crate::stages::scan::{ScanShared, chunk};
use crate::stages::small::is_small;
use crate::stages::vertex::{FRUSTUM, UNASSEMBLED};
use crate::{SCAN_GROUP, TRIANGLE_GROUP};

/// Culling by facing: none.
pub const CULL_NONE: u32 = 0;
/// Culling by facing: back faces.
pub const CULL_BACK: u32 = 1;
/// Culling by facing: front faces.
pub const CULL_FRONT: u32 = 2;

/// What a frame's assembly decides with.
#[derive(Copy, Clone)]
pub struct Assembly {
    /// [`CULL_NONE`], [`CULL_BACK`] or [`CULL_FRONT`].
    pub cull: u32,
    /// 1 where triangles counter-clockwise on the screen face the viewer, 0 where clockwise ones do.
    pub front_counter_clockwise: u32,
    /// The target's pixels.
    pub width: u32,
    pub height: u32,
    /// Sub-pixel bits of the snapped coordinates.
    pub snap_bits: u32,
    /// How far beyond its snapped box a triangle's samples reach, in snapped units (0 with one
    /// sample per pixel).
    pub reach: i64,
    /// 1 where a double-sided surface's faces are kept whichever way they face; 0 where every
    /// face is culled as `cull` says.
    pub double_sided: u32,
}

/// The triangle reaches the rasteriser.
pub const KEPT: u32 = 0;
/// Dropped: its snapped corners lie on one line.
pub const DROPPED_ZERO_AREA: u32 = 1;
/// Dropped: a back face, culled.
pub const DROPPED_BACK: u32 = 2;
/// Dropped: a front face, culled.
pub const DROPPED_FRONT: u32 = 3;
/// Dropped: no pixel centre (or sample) lies in its box.
pub const DROPPED_NO_CENTRE: u32 = 4;
/// Dropped: its corners lie beyond one plane of the view frustum ([`assemble_face`]).
pub const DROPPED_FRUSTUM: u32 = 5;
/// Left to the host's clipping: a corner the vertex stage marked `UNASSEMBLED` ([`assemble_face`]).
pub const CLIPPED_ON_HOST: u32 = 6;

/// A snapped triangle as assembly leaves it.
#[derive(Copy, Clone, Default)]
pub struct Snapped {
    /// [`KEPT`], or why it was dropped (the rest is then unspecified).
    pub dropped: u32,
    /// Its corners (indices into what it was given) in the kernels' orientation.
    pub order: [usize; 3],
    pub x: [i64; 3],
    pub y: [i64; 3],
    /// Twice its area, in squared snapped units.
    pub area: u64,
    /// The pixels it may cover.
    pub rect: PixelRect,
    /// 1 where it shows its back to the viewer.
    pub back: u32,
}

/// The triangle of snapped corners `x`, `y`: dropped (zero area, culled by facing, no pixel
/// centre), or oriented so that its edge functions are positive inside.
pub fn snap_triangle(x: [i64; 3], y: [i64; 3], a: &Assembly) -> Snapped {
    let mut t = Snapped { dropped: KEPT, order: [0, 1, 2], x, y, ..Snapped::default() };
    let signed = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
    if signed == 0 {
        t.dropped = DROPPED_ZERO_AREA;
        return t;
    }
    // Vulkan's rule: with y down, a triangle counter-clockwise on the screen has a negative
    // cross product here.
    let front = (signed < 0) == (a.front_counter_clockwise == 1);
    t.back = u32::from(!front);
    if a.cull == CULL_BACK && !front {
        t.dropped = DROPPED_BACK;
        return t;
    }
    if a.cull == CULL_FRONT && front {
        t.dropped = DROPPED_FRONT;
        return t;
    }
    if signed < 0 {
        t.order = [0, 2, 1];
        t.x = [x[0], x[2], x[1]];
        t.y = [y[0], y[2], y[1]];
    }
    t.area = signed.unsigned_abs();
    t.rect = reach_rect(&t.x, &t.y, a);
    if t.rect.is_empty() {
        t.dropped = DROPPED_NO_CENTRE;
    }
    t
}

/// A face of three vertices through the vertex stage: dropped wholly outside one frustum plane
/// (by the stage's bits), left to the host where a corner is `UNASSEMBLED` (beyond the near or
/// far plane or the guard band, or outside the stage's domain), else [`snap_triangle`]. What
/// the assembly decides is the stage's bits alone, so every device decides alike, and a vertex
/// shared by faces is taken the same way by each of them.
#[inline]
pub fn assemble_face(corners: [ProjectedVertex; 3], a: &Assembly) -> Snapped {
    let (p0, p1, p2) = (corners[0].planes, corners[1].planes, corners[2].planes);
    if p0 & p1 & p2 & FRUSTUM != 0 {
        return Snapped { dropped: DROPPED_FRUSTUM, ..Snapped::default() };
    }
    if (p0 | p1 | p2) & UNASSEMBLED != 0 {
        return Snapped { dropped: CLIPPED_ON_HOST, ..Snapped::default() };
    }
    let x = [corners[0].screen[0] as i64, corners[1].screen[0] as i64, corners[2].screen[0] as i64];
    let y = [corners[0].screen[1] as i64, corners[1].screen[1] as i64, corners[2].screen[1] as i64];
    snap_triangle(x, y, a)
}

/// The records of a kept triangle: for setup (its corners, pixels and depth coefficients) and
/// for shading (its corners' attributes and `1/w`, its face and surface, `SHADING_BACK` added
/// where a double-sided one shows its back). `depth`, `inv_w` and `attributes` are its corners'
/// in the order it was given (before [`snap_triangle`] oriented it).
pub fn triangle_records(
    t: &Snapped,
    depth: &[f32; 3],
    inv_w: &[f32; 3],
    attributes: &[[f32; ATTRIBUTES]; 3],
    face: u32,
    material: FaceMaterial,
) -> (TriangleInput, TriangleShading) {
    // Entry k of the kernels' per-vertex data belongs to the vertex opposite edge k.
    let opposite = [t.order[2], t.order[0], t.order[1]];
    let coeffs = FloatCoeffs { c: [pick(depth, opposite[0]), pick(depth, opposite[1]), pick(depth, opposite[2]), recip_u64(t.area)] };
    (
        TriangleInput { x: t.x, y: t.y, rect: t.rect, coeffs, ..Default::default() },
        TriangleShading {
            attributes: [pick(attributes, opposite[0]), pick(attributes, opposite[1]), pick(attributes, opposite[2])],
            inv_w: [pick(inv_w, opposite[0]), pick(inv_w, opposite[1]), pick(inv_w, opposite[2])],
            face,
            material: shown(material, t),
        },
    )
}

/// `material` as triangle `t` shows it: `SHADING_BACK` added where it is double-sided and shows
/// its back.
#[inline]
fn shown(material: FaceMaterial, t: &Snapped) -> FaceMaterial {
    let back = material.flags & SHADING_DOUBLE_SIDED != 0 && t.back == 1;
    FaceMaterial { flags: material.flags | if back { SHADING_BACK } else { 0 }, ..material }
}

/// The frame's assembly for a face of `material`: a double-sided one is never culled, where
/// the frame keeps double-sided faces.
#[inline]
pub fn assembly_for(a: Assembly, material: &FaceMaterial) -> Assembly {
    if a.double_sided == 1 && material.flags & SHADING_DOUBLE_SIDED != 0 { Assembly { cull: CULL_NONE, ..a } } else { a }
}

/// Entry `k` (0, 1 or 2) of `v`, chosen rather than indexed: a private array indexed by a
/// value the compiler cannot see is kept in memory and read lane by lane on a CPU device.
#[inline]
fn pick<T: Copy>(v: &[T; 3], k: usize) -> T {
    if k == 0 {
        v[0]
    } else if k == 1 {
        v[1]
    } else {
        v[2]
    }
}

/// The pixels a triangle of snapped vertices `x`, `y` may cover: those whose centre lies in its
/// box or, with several samples, whose samples may (`Assembly::reach`).
pub fn reach_rect(x: &[i64; 3], y: &[i64; 3], a: &Assembly) -> PixelRect {
    let (x0, x1) = (min3(x) - a.reach, max3(x) + a.reach);
    let (y0, y1) = (min3(y) - a.reach, max3(y) + a.reach);
    pixel_rect(&[x0, x1, x1], &[y0, y1, y1], a.snap_bits, a.width, a.height)
}

/// The pixels whose centres lie in the box of the snapped vertices `x`, `y`, clamped to a
/// `width` × `height` grid (an empty rectangle stays empty).
pub fn pixel_rect(x: &[i64; 3], y: &[i64; 3], snap_bits: u32, width: u32, height: u32) -> PixelRect {
    let half = 1i64 << (snap_bits - 1);
    let first = |v: i64, n: u32| clamp(ceil_shr(v - half, snap_bits), 0, n as i64) as i32;
    let last = |v: i64, n: u32| clamp(floor_shr(v - half, snap_bits), -1, n as i64 - 1) as i32;
    PixelRect { i0: first(min3(x), width), j0: first(min3(y), height), i1: last(max3(x), width), j1: last(max3(y), height) }
}

fn min3(v: &[i64; 3]) -> i64 {
    v[0].min(v[1]).min(v[2])
}

fn max3(v: &[i64; 3]) -> i64 {
    v[0].max(v[1]).max(v[2])
}

fn clamp(v: i64, lo: i64, hi: i64) -> i64 {
    v.max(lo).min(hi)
}

/// Faces a workgroup of `assemble_count` and `assemble_fill` takes, in order: group `g` holds
/// faces `g · FACE_GROUP ..`.
pub const FACE_GROUP: u32 = TRIANGLE_GROUP;

/// Words of the assembly's counters: faces dropped for each cause and left to the host,
/// at the index of their code (`DROPPED_ZERO_AREA` ..= `CLIPPED_ON_HOST`).
pub const ASSEMBLY_COUNTERS: usize = 8;

/// A face's records go to the listed triangles (binned) or the small ones: a face puts out
/// `listed + (small << SMALL_SHIFT)`, packed so that one prefix sum ranks both.
pub const SMALL_SHIFT: u32 = 16;
const LISTED_MASK: u32 = (1 << SMALL_SHIFT) - 1;

/// The frame's [`Assembly`] as the stages' parameters give it.
#[inline]
pub fn assembly_of(p: &AssembleParams) -> Assembly {
    Assembly {
        cull: p.cull,
        front_counter_clockwise: p.front_counter_clockwise,
        width: p.width,
        height: p.height,
        snap_bits: p.snap_bits,
        reach: p.reach as i64,
        double_sided: p.double_sided,
    }
}

/// Face `f`'s vertices (three indices a face in `faces`) in the frame's vertices, in drawing
/// order: a mirroring placement swaps the second and third, so that facing stays the mesh's.
#[inline]
pub fn face_vertices(p: &AssembleParams, faces: &[u32], f: u32) -> [u32; 3] {
    let base = 3 * f as usize;
    let (a, b, c) = (p.first_vertex + faces[base], p.first_vertex + faces[base + 1], p.first_vertex + faces[base + 2]);
    if p.mirrored == 1 { [a, c, b] } else { [a, b, c] }
}

/// A face of the mesh through [`assemble_face`]: its vertices (in drawing order), their
/// projections and the decision. `assemble_fill` decides once and keeps it between its phases.
#[derive(Copy, Clone, Default)]
pub struct FaceFate {
    pub tri: [u32; 3],
    pub corners: [ProjectedVertex; 3],
    pub t: Snapped,
    pub material: FaceMaterial,
}

/// What [`face_fate`] says past the mesh's last face (an invocation of the last group with no
/// face): nothing to write, nothing counted.
pub const NO_FACE: u32 = 7;

/// Face `f` (of surface `materials[f]` where the faces name theirs) through [`assemble_face`].
#[inline]
pub fn face_fate(p: &AssembleParams, faces: &[u32], materials: &[FaceMaterial], projected: &[ProjectedVertex], f: u32) -> FaceFate {
    if f >= p.faces {
        return FaceFate { t: Snapped { dropped: NO_FACE, ..Snapped::default() }, ..FaceFate::default() };
    }
    let tri = face_vertices(p, faces, f);
    let corners = [projected[tri[0] as usize], projected[tri[1] as usize], projected[tri[2] as usize]];
    let material = face_material(p, materials, f);
    FaceFate { tri, corners, t: assemble_face(corners, &assembly_for(assembly_of(p), &material)), material }
}

/// Whether a kept triangle of rectangle `rect` goes to the small list.
#[inline]
pub fn goes_small(p: &AssembleParams, rect: &PixelRect) -> bool {
    p.split_small == 1 && is_small(rect)
}

/// What `assemble_count` adds for face `f`: its fate (a `DROPPED_*` code, [`KEPT`],
/// [`CLIPPED_ON_HOST`] or [`NO_FACE`]) and, where kept, the packed output it puts out (1 listed
/// or 1 small).
#[inline]
pub fn count_face(p: &AssembleParams, faces: &[u32], materials: &[FaceMaterial], projected: &[ProjectedVertex], f: u32) -> (u32, u32) {
    let t = face_fate(p, faces, materials, projected, f).t;
    (t.dropped, kept_output(p, &t))
}

/// The packed output of a face decided `t`: 1 listed or 1 small record where kept, else none.
#[inline]
fn kept_output(p: &AssembleParams, t: &Snapped) -> u32 {
    if t.dropped != KEPT {
        0
    } else if goes_small(p, &t.rect) {
        1 << SMALL_SHIFT
    } else {
        1
    }
}

/// The word of `GroupCounts` a kept face `f` that puts out `out` adds 1 to: its group's
/// listed or small records.
#[inline]
pub fn count_word(f: u32, out: u32) -> usize {
    2 * (f / FACE_GROUP) as usize + if out & LISTED_MASK != 0 { 0 } else { 1 }
}

/// The first of `patches` (sorted by face) whose face is `face` or later.
#[inline]
pub fn first_patch_from(patches: &[AssemblyPatch], count: u32, face: u32) -> u32 {
    let (mut lo, mut hi) = (0, count);
    while lo < hi {
        let mid = (lo + hi) / 2;
        if patches[mid as usize].face < face { lo = mid + 1 } else { hi = mid }
    }
    lo
}

/// Workgroup memory of `assemble_scan`: per invocation, its chunk's listed and then its small
/// records (the bins' scan's layout, `stages::scan`, whose chunks and partials it shares).
pub type AssemblyScanShared = ScanShared;

/// Group `g`'s records (listed, small): its kept faces' (`counts`, two words a group) and its
/// clipped faces' pieces, the patches from `*next` on (advanced past the group's).
#[inline]
fn group_records(p: &AssembleParams, counts: &[u32], patches: &[AssemblyPatch], g: u32, next: &mut u32) -> (u32, u32) {
    let (mut listed, mut small) = (counts[2 * g as usize], counts[2 * g as usize + 1]);
    let end = (g + 1) * FACE_GROUP;
    while *next < p.patches && patches[*next as usize].face < end {
        listed += patches[*next as usize].listed;
        small += patches[*next as usize].small;
        *next += 1;
    }
    (listed, small)
}

/// `assemble_scan`, phase 1: `shared[lid]` and `shared[SCAN_GROUP + lid]` = the listed and
/// small records of this invocation's chunk of groups.
pub fn assemble_scan_reduce(lid: u32, p: &AssembleParams, counts: &[u32], patches: &[AssemblyPatch], shared: &mut AssemblyScanShared) {
    let (start, end) = chunk(lid, p.groups);
    let mut next = first_patch_from(patches, p.patches, start * FACE_GROUP);
    let (mut listed, mut small) = (0, 0);
    let mut g = start;
    while g < end {
        let (l, s) = group_records(p, counts, patches, g, &mut next);
        listed += l;
        small += s;
        g += 1;
    }
    shared[lid as usize] = listed;
    shared[(SCAN_GROUP + lid) as usize] = small;
}

/// Phase 2: the chunks' two sums into exclusive prefixes, as the bins' scan turns its own
/// (`stages::scan::scan_partials`).
pub use crate::stages::scan::scan_partials as assemble_scan_partials;

/// Phase 3: each group's first listed and small rank (`offsets[2g]`, `offsets[2g + 1]`); the
/// last invocation writes the totals after them.
pub fn assemble_scan_write(lid: u32, p: &AssembleParams, counts: &[u32], patches: &[AssemblyPatch], shared: &AssemblyScanShared, offsets: &mut [u32]) {
    let (start, end) = chunk(lid, p.groups);
    let mut next = first_patch_from(patches, p.patches, start * FACE_GROUP);
    let (mut listed, mut small) = (shared[lid as usize], shared[(SCAN_GROUP + lid) as usize]);
    let mut g = start;
    while g < end {
        offsets[2 * g as usize] = listed;
        offsets[2 * g as usize + 1] = small;
        let (l, s) = group_records(p, counts, patches, g, &mut next);
        listed += l;
        small += s;
        g += 1;
    }
    if lid == SCAN_GROUP - 1 {
        offsets[2 * p.groups as usize] = listed;
        offsets[2 * p.groups as usize + 1] = small;
    }
}

/// `assemble_fill`, phase 1: what face `f`, decided `face` ([`face_fate`]), puts out (packed as
/// `count_face`'s): a kept face one record, a clipped one its pieces, any other none.
#[inline]
pub fn fill_output(p: &AssembleParams, patches: &[AssemblyPatch], f: u32, face: &FaceFate) -> u32 {
    if face.t.dropped != CLIPPED_ON_HOST {
        return kept_output(p, &face.t);
    }
    let k = first_patch_from(patches, p.patches, f);
    let patch = &patches[k as usize];
    patch.listed | (patch.small << SMALL_SHIFT)
}

/// Phase 2: invocation 0 turns the group's outputs into exclusive prefixes (its ranks).
pub fn fill_ranks(lid: u32, shared: &mut [u32; FACE_GROUP as usize]) {
    if lid != 0 {
        return;
    }
    let mut running = 0;
    let mut k = 0;
    while k < FACE_GROUP as usize {
        let out = shared[k];
        shared[k] = running;
        running += out;
        k += 1;
    }
}

/// Phase 3: face `f`'s records (decided `face`), its group's first ranks `offsets[2g..]` plus its own `rank`
/// (phase 2's, packed): a kept face's made from its corners and, per vertex of the mesh, its
/// `attributes` (empty where `AssembleParams::attributes` is 0), lit as `AssembleParams::lighting`
/// says (per vertex of the frame, its colour as the light stage lit it: `lit`; per face of the
/// frame, its normal under flat shading, `normals`, lit with the frame's `shade` parameters),
/// and its surface as [`face_fate`] found it; a clipped face's pieces
/// copied from `piece_inputs` and `piece_shading` in their order. (Slices apart, not structs
/// of them: the kernels' compiler keeps no reference in a struct.) Slot = listed rank + small rank: the frame's records are in
/// face order, and each list in slot order.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn fill_face<I: Slots<TriangleInput> + ?Sized, S: Slots<TriangleShading> + ?Sized, L: Slots + ?Sized>(
    p: &AssembleParams,
    attributes: &[[f32; ATTRIBUTES]],
    lit: &[[f32; 4]],
    normals: &[FaceNormal],
    shade: &ShadeParams,
    patches: &[AssemblyPatch],
    piece_inputs: &[TriangleInput],
    piece_shading: &[TriangleShading],
    f: u32,
    face: &FaceFate,
    offsets: &[u32],
    rank: u32,
    out_inputs: &mut I,
    out_shading: &mut S,
    out_listed: &mut L,
    out_small: &mut L,
) {
    if face.t.dropped != KEPT && face.t.dropped != CLIPPED_ON_HOST {
        return;
    }
    let g = (f / FACE_GROUP) as usize;
    let mut listed = p.first_listed + offsets[2 * g] + (rank & LISTED_MASK);
    let mut small = p.first_small + offsets[2 * g + 1] + (rank >> SMALL_SHIFT);
    let (tri, corners, t) = (face.tri, &face.corners, &face.t);
    if t.dropped == KEPT {
        let attributes = face_attributes(p, attributes, lit, normals, shade, tri, f);
        let depth = [corners[0].depth, corners[1].depth, corners[2].depth];
        let inv_w = [corners[0].inverse_w, corners[1].inverse_w, corners[2].inverse_w];
        let (mut input, shading) = triangle_records(t, &depth, &inv_w, &attributes, p.first_face + f, face.material);
        let slot = listed + small;
        input.index = slot;
        out_inputs.store(slot as usize, input);
        out_shading.store(slot as usize, shading);
        if goes_small(p, &input.rect) {
            out_small.store(small as usize, slot)
        } else {
            out_listed.store(listed as usize, slot)
        }
        return;
    }
    let patch = patches[first_patch_from(patches, p.patches, f) as usize];
    let mut k = 0;
    while k < patch.listed + patch.small {
        let mut input = piece_inputs[(patch.first + k) as usize];
        let slot = listed + small;
        input.index = slot;
        out_inputs.store(slot as usize, input);
        out_shading.store(slot as usize, piece_shading[(patch.first + k) as usize]);
        if goes_small(p, &input.rect) {
            out_small.store(small as usize, slot);
            small += 1;
        } else {
            out_listed.store(listed as usize, slot);
            listed += 1;
        }
        k += 1;
    }
}

/// A kept face's corners' attributes: its vertices' (every corner its first vertex's under
/// flat interpolation), lit as `p.lighting` says (Gouraud: each corner its vertex's lit colour;
/// flat: the face's colour and normal written over every corner); all 0 where the vertices
/// carry none.
#[inline]
fn face_attributes(
    p: &AssembleParams,
    attributes: &[[f32; ATTRIBUTES]],
    lit: &[[f32; 4]],
    normals: &[FaceNormal],
    shade: &ShadeParams,
    tri: [u32; 3],
    f: u32,
) -> [[f32; ATTRIBUTES]; 3] {
    let mut a = [[0.0; ATTRIBUTES]; 3];
    if p.attributes == 1 {
        let flat = p.flat == 1;
        a[0] = attributes[tri[0] as usize];
        a[1] = attributes[if flat { tri[0] } else { tri[1] } as usize];
        a[2] = attributes[if flat { tri[0] } else { tri[2] } as usize];
    }
    if p.lighting == LIGHT_VERTICES {
        let flat = p.flat == 1;
        set_colour(&mut a[0], lit[tri[0] as usize]);
        set_colour(&mut a[1], lit[if flat { tri[0] } else { tri[1] } as usize]);
        set_colour(&mut a[2], lit[if flat { tri[0] } else { tri[2] } as usize]);
    } else if p.lighting == LIGHT_FACES {
        let n = normals[(p.first_face_normal + f) as usize].normal;
        let normal = [n[0], n[1], n[2]];
        let colour = lit_face(shade, &a[0], normal);
        let mut k = 0;
        while k < 3 {
            set_colour(&mut a[k], colour);
            let mut c = 0;
            while c < 3 {
                a[k][ATTR_NORMAL + c] = normal[c];
                c += 1;
            }
            k += 1;
        }
    }
    a
}

/// Write `colour` over a corner's.
#[inline]
fn set_colour(a: &mut [f32; ATTRIBUTES], colour: [f32; 4]) {
    let mut c = 0;
    while c < 4 {
        a[ATTR_COLOUR + c] = colour[c];
        c += 1;
    }
}

/// Face `f`'s surface, its texture and material the frame's.
#[inline]
pub fn face_material(p: &AssembleParams, materials: &[FaceMaterial], f: u32) -> FaceMaterial {
    if p.face_materials == 0 {
        return p.material;
    }
    materials[f as usize].placed(p.first_texture, p.first_material)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;
    use crate::abi::NO_TEXTURE;

    const UNIT: i64 = 256;

    fn frame(cull: u32, reach: i64) -> Assembly {
        Assembly { cull, front_counter_clockwise: 1, width: 16, height: 16, snap_bits: 8, reach, double_sided: 1 }
    }

    /// Edge `k` (from corner `k` to the next) at the point `(px, py)`, positive inside.
    fn edge(t: &Snapped, k: usize, px: i64, py: i64) -> i64 {
        let b = (k + 1) % 3;
        (t.x[b] - t.x[k]) * (py - t.y[k]) - (t.y[b] - t.y[k]) * (px - t.x[k])
    }

    #[test]
    fn facing_decides_culling_and_orientation() {
        // Top left, bottom left, top right: counter-clockwise on a screen whose y points down.
        let (x, y) = ([UNIT, UNIT, 5 * UNIT], [UNIT, 5 * UNIT, UNIT]);
        assert_eq!(snap_triangle(x, y, &frame(CULL_FRONT, 0)).dropped, DROPPED_FRONT);
        let clockwise = ([x[0], x[2], x[1]], [y[0], y[2], y[1]]);
        assert_eq!(snap_triangle(clockwise.0, clockwise.1, &frame(CULL_BACK, 0)).dropped, DROPPED_BACK);
        for (x, y) in [(x, y), clockwise] {
            let t = snap_triangle(x, y, &frame(CULL_NONE, 0));
            assert_eq!(t.dropped, KEPT);
            assert_eq!(t.area, 16 * UNIT as u64 * UNIT as u64);
            // Oriented: every edge function positive at a centre inside, whichever way it came.
            assert!((0..3).all(|k| edge(&t, k, 2 * UNIT + UNIT / 2, 2 * UNIT + UNIT / 2) > 0));
            assert_eq!(t.order.map(|i| (x[i], y[i])), [0, 1, 2].map(|k| (t.x[k], t.y[k])));
            // Centres 1.5 … 4.5 lie in the box [1, 5].
            assert_eq!((t.rect.i0, t.rect.i1, t.rect.j0, t.rect.j1), (1, 4, 1, 4));
        }
    }

    #[test]
    fn lines_and_boxes_without_a_centre_are_dropped() {
        let line = snap_triangle([0, UNIT, 2 * UNIT], [0, UNIT, 2 * UNIT], &frame(CULL_NONE, 0));
        assert_eq!(line.dropped, DROPPED_ZERO_AREA);
        // Between the centres 0.5 and 1.5 on both axes: none inside, but samples within 7/16
        // px of a centre reach it.
        let (x, y) = ([UNIT - 40, UNIT - 40, UNIT + 40], [UNIT - 40, UNIT + 40, UNIT - 40]);
        assert_eq!(snap_triangle(x, y, &frame(CULL_NONE, 0)).dropped, DROPPED_NO_CENTRE);
        let reached = snap_triangle(x, y, &frame(CULL_NONE, 7 << 4));
        assert_eq!(reached.dropped, KEPT);
        assert_eq!((reached.rect.i0, reached.rect.i1), (0, 1));
    }

    #[test]
    fn a_face_is_decided_by_its_corners_planes() {
        use crate::stages::vertex::{BEYOND_FAR, BEYOND_LEFT, BEYOND_NEAR, UNASSEMBLED};
        let corner = |x: i64, y: i64, planes: u32| ProjectedVertex { screen: [x as i32, y as i32], depth: 0.5, inverse_w: 1.0, planes };
        let (a, b, c) = (corner(UNIT, UNIT, 0), corner(UNIT, 5 * UNIT, 0), corner(5 * UNIT, UNIT, 0));
        let kept = assemble_face([a, b, c], &frame(CULL_NONE, 0));
        assert_eq!((kept.dropped, kept.area), (KEPT, 16 * UNIT as u64 * UNIT as u64));
        // Beyond one plane together: dropped, even where a corner is not projected.
        let left = |v: &ProjectedVertex, more: u32| ProjectedVertex { planes: BEYOND_LEFT | more, ..*v };
        let outside = [left(&a, 0), left(&b, BEYOND_NEAR | UNASSEMBLED), left(&c, BEYOND_FAR)];
        assert_eq!(assemble_face(outside, &frame(CULL_NONE, 0)).dropped, DROPPED_FRUSTUM);
        // Beyond different planes, or one corner left to the host: clipped there.
        let across = [left(&a, 0), ProjectedVertex { planes: BEYOND_NEAR | UNASSEMBLED, ..b }, c];
        assert_eq!(assemble_face(across, &frame(CULL_NONE, 0)).dropped, CLIPPED_ON_HOST);
        let none = ProjectedVertex::NONE;
        assert_eq!(assemble_face([a, none, c], &frame(CULL_BACK, 0)).dropped, CLIPPED_ON_HOST);
        // Beyond a side plane but projected: the assembly takes it (the guard band holds it).
        let wide = [left(&a, 0), b, c];
        assert_eq!(assemble_face(wide, &frame(CULL_NONE, 0)).dropped, KEPT);
    }

    #[test]
    fn records_follow_the_orientation() {
        let (x, y) = ([UNIT, UNIT, 5 * UNIT], [UNIT, 5 * UNIT, UNIT]);
        let t = snap_triangle(x, y, &frame(CULL_NONE, 0));
        assert_eq!(t.order, [0, 2, 1], "counter-clockwise as given: turned");
        let mut attributes = [[0.0; ATTRIBUTES]; 3];
        (0..3).for_each(|k| attributes[k][0] = k as f32);
        let (input, shading) = triangle_records(&t, &[0.0, 0.5, 1.0], &[1.0, 2.0, 3.0], &attributes, 7, FaceMaterial::plain(9, 0));
        // Entry k belongs to the corner opposite edge k: oriented corners 2, 0, 1, given ones
        // 1, 0, 2.
        assert_eq!(input.coeffs.c[..3], [0.5, 0.0, 1.0]);
        assert_eq!(input.coeffs.c[3], (1.0 / t.area as f64) as f32);
        assert_eq!(shading.inv_w, [2.0, 1.0, 3.0]);
        assert_eq!(shading.attributes.map(|a| a[0]), [1.0, 0.0, 2.0]);
        assert_eq!((shading.face, shading.material, input.x, input.y), (7, FaceMaterial::plain(9, 0), t.x, t.y));
    }

    #[test]
    fn a_double_sided_face_is_never_culled_and_its_back_is_marked() {
        // Top left, top right, bottom left: clockwise on the screen, a back face.
        let (x, y) = ([UNIT, 5 * UNIT, UNIT], [UNIT, UNIT, 5 * UNIT]);
        let double = FaceMaterial::plain(NO_TEXTURE, SHADING_DOUBLE_SIDED);
        let single = FaceMaterial::plain(NO_TEXTURE, 0);
        for cull in [CULL_BACK, CULL_FRONT, CULL_NONE] {
            let t = snap_triangle(x, y, &assembly_for(frame(cull, 0), &double));
            assert_eq!((t.dropped, t.back), (KEPT, 1), "cull {cull}");
            let shown = triangle_records(&t, &[0.0; 3], &[1.0; 3], &[[0.0; ATTRIBUTES]; 3], 0, double).1.material;
            assert_eq!(shown.flags, SHADING_DOUBLE_SIDED | SHADING_BACK);
        }
        assert_eq!(snap_triangle(x, y, &assembly_for(frame(CULL_BACK, 0), &single)).dropped, DROPPED_BACK);
        // A frame that culls every face as it says culls the double-sided one too.
        let every = Assembly { double_sided: 0, ..frame(CULL_BACK, 0) };
        assert_eq!(snap_triangle(x, y, &assembly_for(every, &double)).dropped, DROPPED_BACK);
        // A single-sided face kept with its back to the viewer is not marked: only a
        // double-sided surface turns its normal round.
        let t = snap_triangle(x, y, &assembly_for(frame(CULL_NONE, 0), &single));
        assert_eq!(triangle_records(&t, &[0.0; 3], &[1.0; 3], &[[0.0; ATTRIBUTES]; 3], 0, single).1.material.flags, 0);
        // Its front is not marked either.
        let (x, y) = ([UNIT, UNIT, 5 * UNIT], [UNIT, 5 * UNIT, UNIT]);
        let t = snap_triangle(x, y, &assembly_for(frame(CULL_BACK, 0), &double));
        assert_eq!(triangle_records(&t, &[0.0; 3], &[1.0; 3], &[[0.0; ATTRIBUTES]; 3], 0, double).1.material.flags, SHADING_DOUBLE_SIDED);
    }
}
