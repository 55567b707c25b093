//! Multisampling: coverage and depth per sample at Vulkan's standard sample positions, each
//! triangle shaded once per pixel (at the pixel centre, as a fragment shader without sample
//! shading runs), and the samples' colours averaged (a box resolve) in integers.
//!
//! A sample's edge functions are the pixel centre's plus the steps times the sample's offset:
//! the render pipeline snaps to 1/256 px, so a step is a whole multiple of 256 and a sixteenth
//! of it is exact, and the offsets are whole sixteenths. The fill rule holds per sample as it
//! does per centre (the same `side_of` on exact integers), so meshes stay watertight at every
//! sample. A sample's depth is the barycentric depth of its edge functions, the owner of a
//! sample the smallest depth key among the triangles covering it (`programs::depth`).
//!
//! The depth, owner and face layers take one sample's (`ShadeParams::layer_sample`, sample 0
//! by default, as OpenGL resolves integer targets); the coverage layer counts the triangles
//! that cover at least one sample of the pixel.

use crate::abi::{Coverage, MaterialRecord, SetupPart, ShadeParams, ShadingRecords, TextureInfo, TriangleSetup};
use crate::math::edge::{Side, side_of};
use crate::memory::{LANE_GROUP, Lanes};
use crate::programs::depth::{DepthProgram, depth_bits};
use crate::programs::fragment::FragmentProgram;
use crate::stages::fine::FineShared;
use crate::{FULL_TILE_BIT, NO_OWNER};

/// Most samples per pixel.
pub const MAX_SAMPLES: usize = 8;

/// Sample `s`'s position in Vulkan's standard table for `samples` (4 or 8), in sixteenths of a
/// pixel from its top-left corner.
#[inline]
pub fn sample_position(samples: u32, s: u32) -> (i64, i64) {
    if samples == 4 {
        match s {
            0 => (6, 2),
            1 => (14, 6),
            2 => (2, 10),
            _ => (10, 14),
        }
    } else {
        match s {
            0 => (9, 5),
            1 => (7, 11),
            2 => (13, 9),
            3 => (5, 3),
            4 => (3, 13),
            5 => (1, 7),
            6 => (11, 15),
            _ => (15, 1),
        }
    }
}

/// Calls `f(s)` for every sample `s` of a pixel of `samples` (4 or 8), written out rather than
/// looped: a CPU implementation of Vulkan keeps an array indexed by a loop counter in memory and
/// reaches it one lane at a time, where with a constant index in each call the per-sample
/// states stay in registers. (`samples` is a specialisation constant of the stage, so the
/// driver drops the second half at 4 samples.)
#[inline(always)]
pub fn for_each_sample(samples: u32, mut f: impl FnMut(usize)) {
    f(0);
    f(1);
    f(2);
    f(3);
    if samples > 4 {
        f(4);
        f(5);
        f(6);
        f(7);
    }
}

/// The edge functions of coverage `c` at sample `s` of pixel `(i, j)`.
#[inline]
pub fn sample_edges(c: &Coverage, i: i32, j: i32, samples: u32, s: u32) -> [i64; 3] {
    let (sx, sy) = sample_position(samples, s);
    let (ox, oy) = (sx - 8, sy - 8);
    let di = (i - c.rect.i0) as i64;
    let dj = (j - c.rect.j0) as i64;
    let e = &c.edges;
    let at = |k: usize| e[k].at(di, dj) + (e[k].step_i >> 4) * ox + (e[k].step_j >> 4) * oy;
    [at(0), at(1), at(2)]
}

/// [`sample_edges`] in 32-bit wrapping arithmetic, exact for a triangle whose edge functions fit
/// 32 bits at its pixels' samples (`stages::setup::edges_fit_i32`; see
/// `stages::fine::side_and_edges_small`).
#[inline]
pub fn sample_edges_small(c: &Coverage, i: i32, j: i32, samples: u32, s: u32) -> [i64; 3] {
    let (sx, sy) = sample_position(samples, s);
    let (ox, oy) = (sx as i32 - 8, sy as i32 - 8);
    let (di, dj) = (i - c.rect.i0, j - c.rect.j0);
    let e = &c.edges;
    [e[0].at_i32(di, dj, ox, oy) as i64, e[1].at_i32(di, dj, ox, oy) as i64, e[2].at_i32(di, dj, ox, oy) as i64]
}

/// The edge functions of sample `s`, in 32-bit arithmetic where `program`'s triangles allow it.
#[inline(always)]
fn program_sample_edges(program: &DepthProgram, c: &Coverage, i: i32, j: i32, samples: u32, s: u32) -> [i64; 3] {
    if program.small_edges { sample_edges_small(c, i, j, samples, s) } else { sample_edges(c, i, j, samples, s) }
}

/// What a pixel keeps of one sample: the smallest depth key of a triangle covering it and that
/// triangle's setup slot (`NO_OWNER` where none).
#[derive(Copy, Clone)]
pub struct SampleState {
    pub key: u64,
    pub slot: u32,
}

impl SampleState {
    pub const EMPTY: SampleState = SampleState { key: u64::MAX, slot: NO_OWNER };
}

/// Phase 2 of a multisampled tile: test pixel `(i, j)`'s samples against the `batch_len`
/// staged triangles, keeping each sample's nearest passing fragment; `count` counts the
/// triangles that cover at least one sample.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn test_samples(
    program: &DepthProgram,
    i: i32,
    j: i32,
    batch_len: u32,
    shared: &FineShared<TriangleSetup, u64>,
    samples: u32,
    states: &mut [SampleState; MAX_SAMPLES],
    count: &mut u32,
) {
    let mut k = 0;
    while k < batch_len {
        test_triangle_samples(program, &shared.batch[k as usize], i, j, samples, states, count);
        k += 1;
    }
}

/// The walk instead of the batches (as `fine::fine_walk` for pixel centres): pixel `(i, j)`
/// tests its samples against every triangle of the tile's bin whose rectangle holds it, a
/// group of eight lanes (the spans of its pixels, each pixel's bit `span`, ORed) taking the bin
/// eight entries at a time, voting on which reach its spans (the masks binning wrote after the
/// window's `entries` entries of `bin`), and reading each record it must test together (`memory::Lanes`). No
/// workgroup memory and no barrier. It tests every triangle that holds the pixel, as the batches do, and
/// a sample's owner is the smallest key whatever the order: the CPU backend's twin keeps the
/// batches, with the same states and count.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn walk_samples(
    program: &DepthProgram,
    lanes: &Lanes,
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    entries: u32,
    setup_words: &[u64],
    span: u32,
    i: i32,
    j: i32,
    samples: u32,
    states: &mut [SampleState; MAX_SAMPLES],
    count: &mut u32,
) {
    let group_spans = lanes.group_or(1 << span);
    let mut k = 0;
    while k < bin_len {
        let slots = lanes.read8(bin, bin_start + k);
        let run = if bin_len - k < LANE_GROUP { bin_len - k } else { LANE_GROUP };
        let mut left = lanes.read8(bin, entries + bin_start + k).select(run, move |spans| spans & group_spans != 0);
        while left != 0 {
            let m = left.trailing_zeros();
            left &= left - 1;
            let staged = TriangleSetup::read_setup(lanes, setup_words, slots.get(m) & !FULL_TILE_BIT);
            test_triangle_samples(program, &staged, i, j, samples, states, count);
        }
        k += LANE_GROUP;
    }
}

/// Pixel `(i, j)`'s samples against one triangle: each sample inside it whose fragment passes
/// the depth test and keys below its nearest so far takes it; `count` counts the triangle if
/// it covers a sample.
#[inline(always)]
fn test_triangle_samples(
    program: &DepthProgram,
    staged: &TriangleSetup,
    i: i32,
    j: i32,
    samples: u32,
    states: &mut [SampleState; MAX_SAMPLES],
    count: &mut u32,
) {
    let c = &staged.coverage;
    if c.rect.contains(i, j) {
        let mut covered = false;
        for_each_sample(samples, |s| {
            let w = program_sample_edges(program, c, i, j, samples, s as u32);
            if side_of(w[0], w[1], w[2], c.excluded_edges) == Side::Inside {
                covered = true;
                let bits = program.depth_of_edges(staged, w);
                if program.passes(f32::from_bits(bits)) {
                    let key = program.key_of(bits, c.index);
                    if key < states[s].key {
                        states[s] = SampleState { key, slot: c.slot };
                    }
                }
            }
        });
        if covered {
            *count += 1;
        }
    }
}

/// A multisampled pixel's outputs.
#[derive(Copy, Clone)]
pub struct Resolved {
    /// The samples' colours averaged, RGBA8.
    pub colour: u32,
    /// The layer sample's face, setup slot and depth bits (`ShadeParams::layer_sample`).
    pub face: u32,
    pub slot: u32,
    pub depth: u32,
}

/// Phase 3: shade each triangle that owns a sample of pixel `(i, j)` once, at the centre, with
/// the fragment program `fragment`; the background where a sample has no owner; average the
/// samples' colours channel by channel, rounded to nearest.
#[allow(clippy::too_many_arguments)]
#[inline]
pub fn resolve_samples<F: FragmentProgram + ?Sized, R: ShadingRecords + ?Sized>(
    fragment: &F,
    params: &ShadeParams,
    program: &DepthProgram,
    setups: &[TriangleSetup],
    shading: &R,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    states: &[SampleState; MAX_SAMPLES],
    samples: u32,
    i: i32,
    j: i32,
) -> Resolved {
    let shade = |slot: u32| {
        let setup = &setups[slot as usize];
        fragment.colour(params, setup, &shading.record(slot), shading.face(slot), textures, texels, materials, depth_bits(setup, i, j), i, j)
    };
    let colours = sample_colours(shade, params.background, states, samples);
    let (mut r, mut g, mut b, mut a) = (0u32, 0u32, 0u32, 0u32);
    for_each_sample(samples, |s| {
        let c = colours[s];
        (r, g, b, a) = (r + (c & 0xff), g + (c >> 8 & 0xff), b + (c >> 16 & 0xff), a + (c >> 24));
    });
    let mean = |sum: u32| (sum + samples / 2) / samples;
    let colour = mean(r) | mean(g) << 8 | mean(b) << 16 | mean(a) << 24;
    let layer = if params.layer_sample < samples { params.layer_sample } else { 0 };
    let mut slot = NO_OWNER;
    for_each_sample(samples, |s| {
        if s as u32 == layer {
            slot = states[s].slot;
        }
    });
    if slot == NO_OWNER {
        return Resolved { colour, face: NO_OWNER, slot, depth: program.clear.to_bits() };
    }
    let setup = &setups[slot as usize];
    let depth = if program.write {
        program.depth_of_edges(setup, program_sample_edges(program, &setup.coverage, i, j, samples, layer))
    } else {
        program.clear.to_bits()
    };
    Resolved { colour, face: shading.face(slot), slot, depth }
}

/// Each sample's colour: its owner's, `shade(slot)`, evaluated once per owner; `background`
/// where it has none. On the GPU the owners are shaded in one loop, each iteration the owner of
/// the first sample still without a colour, so that the stage holds one copy of the fragment
/// program: a CPU implementation of Vulkan runs every copy inlined, whether a lane takes it or
/// not, and a SIMD group then runs as many iterations as its pixels have owners at most (the
/// 1080p terrain at 4× on lavapipe: `fine_samples` 2684 → 2559 ms).
#[cfg(target_arch = "spirv")]
#[inline]
fn sample_colours(shade: impl Fn(u32) -> u32, background: u32, states: &[SampleState; MAX_SAMPLES], samples: u32) -> [u32; MAX_SAMPLES] {
    let mut colours = [background; MAX_SAMPLES];
    let mut coloured = 0u32;
    let mut slot = first_uncoloured(states, samples, coloured);
    loop {
        if slot != NO_OWNER {
            let colour = shade(slot);
            for_each_sample(samples, |s| {
                if states[s].slot == slot {
                    colours[s] = colour;
                    coloured |= 1 << s;
                }
            });
        }
        slot = first_uncoloured(states, samples, coloured);
        if slot == NO_OWNER {
            return colours;
        }
    }
}

/// The owner of the first of the `samples` samples that has one and no colour yet (bit `s` of
/// `coloured`); `NO_OWNER` if none.
#[cfg(target_arch = "spirv")]
#[inline]
fn first_uncoloured(states: &[SampleState; MAX_SAMPLES], samples: u32, coloured: u32) -> u32 {
    let mut slot = NO_OWNER;
    for_each_sample(samples, |s| {
        if slot == NO_OWNER && coloured >> s & 1 == 0 {
            slot = states[s].slot;
        }
    });
    slot
}

/// The host's twin, sample by sample, each sample's colour that of an earlier sample with the
/// same owner or its owner shaded now: the same colours (the loop above cost the CPU backend's
/// `fine_samples` 5 %, 110–114 → 118 ms on that frame).
#[cfg(not(target_arch = "spirv"))]
#[inline]
fn sample_colours(shade: impl Fn(u32) -> u32, background: u32, states: &[SampleState; MAX_SAMPLES], samples: u32) -> [u32; MAX_SAMPLES] {
    let mut colours = [background; MAX_SAMPLES];
    for s in 0..samples as usize {
        let slot = states[s].slot;
        if slot != NO_OWNER {
            colours[s] = match (0..s).find(|&t| states[t].slot == slot) {
                Some(t) => colours[t],
                None => shade(slot),
            };
        }
    }
    colours
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    #[test]
    fn the_standard_positions_are_distinct_and_inside_the_pixel() {
        for samples in [4, 8] {
            let mut seen = [[false; 16]; 16];
            for s in 0..samples {
                let (x, y) = sample_position(samples, s);
                assert!((0..16).contains(&x) && (0..16).contains(&y));
                assert!(!seen[x as usize][y as usize], "{samples}×: sample {s} repeats");
                seen[x as usize][y as usize] = true;
            }
        }
    }
}
