//! Compute entry points: unpack invocation ids and buffers, call the stage functions. The
//! stages that colour fragments come from `shading_entry_points!` (`programs::fragment`),
//! whose bodies are here. Without the `entry-points` feature (in a fragment shader crate,
//! which makes its own shading stages) only those bodies are compiled.
#![cfg_attr(not(feature = "entry-points"), allow(unused_imports, dead_code))]
//! The host dispatcher (`tileraster-cpu`) has one twin per entry point, with the same name.
//! Each entry point binds the buffers its row of the stage table (`crate::pipeline`) lists, in
//! that order; a test compares the compiled SPIR-V with the table.

use crate::abi::{ATTRIBUTES, AssembleParams, AssemblyPatch, FaceMaterial, FaceNormal, LightParams, MaterialRecord, TriangleShading};
use crate::abi::{
    Counter, Coverage, FrameParams, OutputSet, ProjectedVertex, SetupPart, ShadeParams, ShadingRecords, TextureInfo, TriangleInput, TriangleSetup,
};
use crate::memory::{Counters, LaneValue, Lanes};
use crate::programs::depth::DepthProgram;
use crate::programs::fragment::FragmentProgram;
use crate::programs::height::HeightProgram;
use crate::programs::multisample::{self, MAX_SAMPLES, SampleState};
use crate::programs::shade::shaded_pixel;
use crate::stages::assemble::{self, AssemblyScanShared, FACE_GROUP};
use crate::stages::bin::{self, bin_count as count_tiles, bin_fill as fill_tiles};
use crate::stages::fine::{self, FineShared, PixelProgram};
use crate::stages::scan::{self, ScanShared};
use crate::stages::setup::setup_triangle;
use crate::stages::small;
use crate::{BATCH, NO_OWNER, SHADE_PASSES, TILE_PIXELS, TRIANGLE_GROUP};
use spirv_std::arch::workgroup_memory_barrier_with_group_sync as barrier;
pub use spirv_std::glam::{UVec3, UVec4};
pub use spirv_std::spirv;

// `#[spirv(spec_constant(..))]` takes literals: keep `fine_raster`'s and these in step.
const _: () = assert!(HeightProgram::MODE_SPEC_ID == 1 && HeightProgram::GENERIC_MODE == 0 && fine::WALK_SPEC_ID == 1 && bin::KEYS_SPEC_ID == 1);

/// Per-triangle stages are dispatched in 2D when there are more than 65,535 workgroups.
fn triangle_slot(gid: UVec3, frame: &FrameParams) -> u32 {
    gid.y * frame.dispatch_width + gid.x
}

// The vertex stage with the built-in program (`programs::vertex`); a vertex shader crate
// makes its own.
#[cfg(feature = "entry-points")]
crate::vertex_entry_points!(crate::programs::vertex::Builtin);

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
pub fn light(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &LightParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] shade: &ShadeParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] attributes: &[[f32; ATTRIBUTES]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] lit: &mut [[f32; 4]],
) {
    let v = gid.y * params.dispatch_width + gid.x;
    if v < params.vertices {
        lit[v as usize] = crate::stages::light::light(shade, attributes, v);
    }
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
pub fn assemble_count(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &AssembleParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] faces: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] projected: &[ProjectedVertex],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] materials: &[FaceMaterial],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] group_counts: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] counters: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] clipped: &mut [u32],
) {
    let f = gid.y * params.dispatch_width + gid.x;
    if f < params.faces {
        let (fate, out) = assemble::count_face(params, faces, materials, projected, f);
        if fate == assemble::KEPT {
            group_counts.fetch_add(assemble::count_word(f, out), 1);
        } else if fate == assemble::CLIPPED_ON_HOST {
            let k = counters.fetch_add(fate as usize, 1);
            clipped[k as usize] = f;
        } else {
            counters.fetch_add(fate as usize, 1);
        }
    }
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(256)))]
pub fn assemble_scan(
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &AssembleParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] group_counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] patches: &[AssemblyPatch],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] offsets: &mut [u32],
    #[spirv(workgroup)] shared: &mut AssemblyScanShared,
) {
    assemble::assemble_scan_reduce(lid, params, group_counts, patches, shared);
    barrier();
    assemble::assemble_scan_partials(lid, shared);
    barrier();
    assemble::assemble_scan_write(lid, params, group_counts, patches, shared, offsets);
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
#[allow(clippy::too_many_arguments)]
pub fn assemble_fill(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 0)] params: &AssembleParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] faces: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] projected: &[ProjectedVertex],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] attributes: &[[f32; ATTRIBUTES]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] lit: &[[f32; 4]],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] normals: &[FaceNormal],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] shade: &ShadeParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] materials: &[FaceMaterial],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] patches: &[AssemblyPatch],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] piece_inputs: &[TriangleInput],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] piece_shading: &[TriangleShading],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] inputs: &mut [TriangleInput],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 13)] shading: &mut [TriangleShading],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 14)] listed: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 15)] small: &mut [u32],
    #[spirv(workgroup)] shared: &mut [u32; FACE_GROUP as usize],
) {
    let f = gid.y * params.dispatch_width + gid.x;
    let face = assemble::face_fate(params, faces, materials, projected, f);
    shared[lid as usize] = assemble::fill_output(params, patches, f, &face);
    barrier();
    assemble::fill_ranks(lid, shared);
    barrier();
    let rank = shared[lid as usize];
    assemble::fill_face(params, attributes, lit, normals, shade, patches, piece_inputs, piece_shading, f, &face, offsets, rank, inputs, shading, listed, small);
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
pub fn setup(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] inputs: &[TriangleInput],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] setups: &mut [TriangleSetup],
) {
    let t = triangle_slot(gid, frame);
    if t < frame.triangles {
        setups[t as usize] = setup_triangle(&inputs[t as usize], t, frame.snap_bits);
    }
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
pub fn bin_count(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] listed: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] counts: &mut [u32],
) {
    let id = triangle_slot(gid, frame);
    let (t, part) = (id / frame.bin_parts, id % frame.bin_parts);
    if t < frame.triangles {
        count_tiles(&setups[listed[t as usize] as usize], frame, part, counts);
    }
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(256)))]
pub fn bin_scan(
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] counts: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] tile_queue: &mut [u32],
    #[spirv(workgroup)] shared: &mut ScanShared,
) {
    let n = frame.tile_count();
    scan::scan_reduce(lid, counts, n, frame, shared);
    barrier();
    scan::scan_partials(lid, shared);
    barrier();
    scan::scan_write(lid, counts, n, frame, shared, offsets, tile_queue);
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
pub fn bin_fill(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] listed: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] cursors: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] bins: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] bin_keys: &mut [u64],
    #[spirv(spec_constant(id = 1, default = 0))] keys: u32,
) {
    let id = triangle_slot(gid, frame);
    let (t, part) = (id / frame.bin_parts, id % frame.bin_parts);
    if t < frame.triangles {
        let setup = &setups[listed[t as usize] as usize];
        fill_tiles(keys & bin::WRITE_KEYS != 0, keys & bin::WRITE_SPANS != 0, keys, setup, frame, part, offsets, cursors, bins, bin_keys);
    }
}

#[cfg(feature = "entry-points")]
#[spirv(compute(threads(16, 16)))]
#[allow(clippy::too_many_arguments)]
pub fn fine_raster(
    #[spirv(workgroup_id)] wg: UVec3,
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bins: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] values: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owners: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] coverage: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] stats: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] tile_stats: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] setup_words: &[u64],
    #[spirv(subgroup_local_invocation_id)] subgroup_lane: u32,
    #[spirv(workgroup)] shared: &mut FineShared<Coverage, u32>,
    #[spirv(spec_constant(id = 1, default = 0))] mode: u32,
) {
    let program = HeightProgram::specialised(frame, mode & !HeightProgram::WALK);
    fine_raster_workgroup(
        &program,
        mode & HeightProgram::WALK != 0,
        &Lanes::new(subgroup_lane),
        wg,
        lid,
        frame,
        setups,
        setup_words,
        offsets,
        bins,
        // The heightfield rejects no hidden triangle, and rasterises no small triangle apart:
        // it reads no key.
        bins,
        setup_words,
        values,
        owners,
        coverage,
        stats,
        tile_stats,
        shared,
    );
}

/// Fine raster of the frame's small triangles, one invocation each (`stages::small`), for the
/// depth test of `fine_depth`, which then starts each pixel from their keys and counts. Its
/// own 2D layout: invocation `y · (groups in x) · 64 + x`.
#[cfg(feature = "entry-points")]
#[spirv(compute(threads(64)))]
#[allow(clippy::too_many_arguments)]
pub fn fine_small(
    #[spirv(global_invocation_id)] gid: UVec3,
    #[spirv(num_workgroups)] groups: UVec3,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] small_listed: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] keys: &mut [u64],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] coverage: &mut [u32],
    #[spirv(spec_constant(id = 1, default = 0))] way: u32,
) {
    let t = gid.y * groups.x * TRIANGLE_GROUP + gid.x;
    if t < frame.small_triangles {
        small::fine_small(&DepthProgram::specialised(frame, way), &setups[small_listed[t as usize] as usize], frame, keys, coverage);
    }
}

/// Fine raster of the render pipeline: the depth test (`programs::depth`).
#[cfg(feature = "entry-points")]
#[spirv(compute(threads(16, 16)))]
#[allow(clippy::too_many_arguments)]
pub fn fine_depth(
    #[spirv(workgroup_id)] wg: UVec3,
    #[spirv(local_invocation_index)] lid: u32,
    #[spirv(uniform, descriptor_set = 0, binding = 0)] frame: &FrameParams,
    #[spirv(storage_buffer, descriptor_set = 0, binding = 1)] setups: &[TriangleSetup],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 2)] offsets: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 3)] bins: &[u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 4)] values: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 5)] owners: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 6)] coverage: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 7)] stats: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 8)] tile_stats: &mut [u32],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 9)] setup_words: &[u64],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 10)] bin_keys: &[u64],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 11)] pixel_keys: &[u64],
    #[spirv(storage_buffer, descriptor_set = 0, binding = 12)] tile_queue: &[u32],
    #[spirv(subgroup_local_invocation_id)] subgroup_lane: u32,
    #[spirv(workgroup)] shared: &mut FineShared<TriangleSetup, u64>,
    #[spirv(spec_constant(id = 1, default = 0))] way: u32,
) {
    // The workgroups take the tile queue (`stages::scan`), not every tile.
    fine::count_left_tiles(wg.x, wg.y, lid, frame, tile_queue, stats);
    let (tx, ty, queued) = scan::queued_tile(wg.x, wg.y, frame, tile_queue);
    if !queued {
        return;
    }
    fine_raster_workgroup(
        &DepthProgram::specialised(frame, way),
        way & fine::WALK != 0,
        &Lanes::new(subgroup_lane),
        UVec3::new(tx, ty, 0),
        lid,
        frame,
        setups,
        setup_words,
        offsets,
        bins,
        bin_keys,
        pixel_keys,
        values,
        owners,
        coverage,
        stats,
        tile_stats,
        shared,
    );
}

// The stages that colour fragments, with the built-in shadings (`programs::fragment`); a
// user's shader crate compiles the same two around its own program.
#[cfg(feature = "entry-points")]
crate::shading_entry_points!(crate::programs::fragment::Builtin);

/// The body of every `shade` entry point: `SHADE_PASSES` window pixels per invocation, from the
/// owner fine raster left there (or, in a tile it left to this stage, the owner of the small
/// triangles' key, whose depth and owner it writes: `fine::left_to_shade`; where
/// `resolves_left_tiles`, which the host turns off where the scene leaves no tile), coloured
/// by `program`.
#[allow(clippy::too_many_arguments)]
pub fn shade_pixels<F: FragmentProgram, R: ShadingRecords + ?Sized>(
    program: &F,
    depth_program: &DepthProgram,
    resolves_left_tiles: bool,
    wg: UVec3,
    lid: u32,
    frame: &FrameParams,
    params: &ShadeParams,
    setups: &[TriangleSetup],
    shading: &R,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    offsets: &[u32],
    bins: &[u32],
    pixel_keys: &[u64],
    values: &mut [u32],
    owners: &mut [u32],
    coverage: &mut [u32],
    colours: &mut [u32],
    faces: &mut [u32],
) {
    let bin = fine::bin_range(offsets, wg.y * frame.tiles_x + wg.x);
    // `SHADE_PASSES` pixels per invocation: a CPU implementation of Vulkan pays a fixed cost
    // for every group of invocations it starts, a GPU for every invocation.
    let mut pass = 0;
    while pass < SHADE_PASSES {
        let (i, j, inside) = fine::tile_pixel(wg.x, wg.y, lid + pass * TILE_PIXELS / SHADE_PASSES, frame);
        if inside {
            let k = fine::window_index(i, j, frame);
            // Blended: the tile's bin; else the owner fine raster left, or this stage resolves.
            let ((bin_start, bin_len), (owner, depth)) = if params.blend != 0 {
                (bin, (NO_OWNER, 0))
            } else if resolves_left_tiles && fine::left_to_shade(bin.1, frame) {
                let out = fine::resolve_left(depth_program, i, j, pixel_keys[k], setups);
                values[k] = out.value;
                owners[k] = out.owner;
                // `fine_small` counted every fragment; a pixel nothing owns counts none.
                if out.owner == NO_OWNER && fine::counts_hidden(frame) {
                    coverage[k] = 0;
                }
                ((0, 0), (out.owner, out.value))
            } else {
                ((0, 0), (owners[k], values[k]))
            };
            let out =
                shaded_pixel(program, params, frame.nodata_bits, setups, shading, textures, texels, materials, bins, bin_start, bin_len, owner, depth, i, j);
            colours[k] = out.colour;
            faces[k] = out.face;
        }
        pass += 1;
    }
}

/// The body of every `fine_samples` entry point: every sample's coverage and depth, then each
/// pixel coloured by `fragment` and resolved, in one workgroup per tile. Its tiles take neither
/// the full-tile path nor the depth bounds (both speak of pixel centres). With `walk`, each
/// pixel walks the bin (`multisample::walk_samples`) instead of the staged batches.
#[allow(clippy::too_many_arguments)]
pub fn fine_samples_workgroup<F: FragmentProgram, R: ShadingRecords + ?Sized>(
    fragment: &F,
    program: &DepthProgram,
    walk: bool,
    lanes: &Lanes,
    setup_words: &[u64],
    wg: UVec3,
    lid: u32,
    frame: &FrameParams,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    values: &mut [u32],
    owners: &mut [u32],
    coverage: &mut [u32],
    stats: &mut [u32],
    tile_stats: &mut [u32],
    params: &ShadeParams,
    shading: &R,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    colours: &mut [u32],
    faces: &mut [u32],
    shared: &mut FineShared<TriangleSetup, u64>,
) {
    let tile = wg.y * frame.tiles_x + wg.x;
    let (bin_start, bin_len) = fine::bin_range(offsets, tile);
    let (i, j, inside) = fine::tile_pixel(wg.x, wg.y, lid, frame);
    let mut states = [SampleState::EMPTY; MAX_SAMPLES];
    let mut count = 0;
    // Uniform per workgroup: the whole tile takes the same branch, barriers included.
    if fine::empty_tile(bin_len, frame) {
        fine::count_tile(lid, Counter::TilesEmpty, stats);
    } else {
        fine::count_tile(lid, Counter::TilesPartial, stats);
        if walk {
            let entries = offsets[frame.tile_count() as usize];
            multisample::walk_samples(
                program,
                lanes,
                bins,
                bin_start,
                bin_len,
                entries,
                setup_words,
                fine::span_bit(lid),
                i,
                j,
                params.samples,
                &mut states,
                &mut count,
            );
        } else {
            let tile_rect = fine::tile_rect(wg.x, wg.y, frame);
            let mut batch_start = 0;
            while batch_start < bin_len {
                let batch_len = fine::batch_len(bin_len, batch_start);
                fine::fine_load(program, lid, bins, bin_start, bin_len, batch_start, setups, &tile_rect, u64::MAX, shared);
                barrier();
                multisample::test_samples(program, i, j, batch_len, shared, params.samples, &mut states, &mut count);
                barrier();
                batch_start += BATCH;
            }
        }
    }
    fine::write_tile_stats(lid, tile, bin_len, 0, frame, tile_stats);
    if inside {
        let out = multisample::resolve_samples(fragment, params, program, setups, shading, textures, texels, materials, &states, params.samples, i, j);
        let k = fine::window_index(i, j, frame);
        values[k] = out.depth;
        colours[k] = out.colour;
        faces[k] = out.face;
        if frame.outputs.contains(OutputSet::OWNER) {
            owners[k] = out.slot;
        }
        if frame.outputs.contains(OutputSet::COVERAGE) {
            coverage[k] = count;
        }
    }
}

/// One fine-raster workgroup, for any pixel program: the body of every fine-raster entry point.
/// It writes the values layer, and the owner and coverage layers where the frame asks for them.
/// With `walk`, each pixel walks the bin on its own (`fine::fine_walk`) instead of the staged
/// batches.
#[allow(clippy::too_many_arguments)]
fn fine_raster_workgroup<P: PixelProgram<Setup = TriangleSetup>>(
    program: &P,
    walk: bool,
    lanes: &Lanes,
    wg: UVec3,
    lid: u32,
    frame: &FrameParams,
    setups: &[P::Setup],
    setup_words: &[u64],
    offsets: &[u32],
    bins: &[u32],
    bin_keys: &[P::Key],
    pixel_keys: &[u64],
    values: &mut [P::Value],
    owners: &mut [u32],
    coverage: &mut [u32],
    stats: &mut [u32],
    tile_stats: &mut [u32],
    shared: &mut FineShared<P::Staged, P::Key>,
) where
    P::Staged: SetupPart,
    P::Key: LaneValue,
{
    let tile = wg.y * frame.tiles_x + wg.x;
    let (bin_start, bin_len) = fine::bin_range(offsets, tile);
    let (i, j, inside) = fine::tile_pixel(wg.x, wg.y, lid, frame);
    let mut state = fine::starting_state(program, i, j, inside, frame, pixel_keys, coverage);
    let mut hidden = 0;
    // Uniform per workgroup: the whole tile takes the same branch, barriers included.
    let out = if fine::empty_tile(bin_len, frame) {
        fine::count_tile(lid, Counter::TilesEmpty, stats);
        // What the small triangles left, or the background.
        fine::fine_resolve(program, i, j, &state, setups)
    } else {
        if fine::full_tile::<P>(bins, bin_start, bin_len, setups, frame, &mut state) {
            fine::count_tile(lid, Counter::TilesFull, stats);
        } else {
            fine::count_tile(lid, Counter::TilesPartial, stats);
            let tile_rect = fine::tile_rect(wg.x, wg.y, frame);
            let overlap_free = fine::overlap_free::<P>(frame);
            let count_hidden = fine::counts_hidden(frame);
            let rejects_hidden = fine::rejects_hidden::<P>(frame);
            if walk {
                let walk_hidden = fine::fine_walk(
                    program,
                    lanes,
                    bins,
                    bin_start,
                    bin_len,
                    bin_keys,
                    offsets[frame.tile_count() as usize],
                    setup_words,
                    rejects_hidden,
                    count_hidden,
                    fine::span_bit(lid),
                    i,
                    j,
                    overlap_free,
                    &mut state,
                );
                if lid == 0 {
                    hidden = walk_hidden;
                }
            } else {
                let mut occluding = P::NO_KEY;
                if rejects_hidden {
                    fine::fine_occluders(program, lid, bins, bin_start, bin_len, setups, &tile_rect, shared);
                    barrier();
                    occluding = fine::occluding_key::<P>(shared);
                }
                let mut batch_start = 0;
                while batch_start < bin_len {
                    let batch_len = fine::batch_len(bin_len, batch_start);
                    fine::fine_load(program, lid, bins, bin_start, bin_len, batch_start, setups, &tile_rect, occluding, shared);
                    barrier();
                    if lid == 0 {
                        hidden += fine::batch_hidden(batch_len, shared);
                    }
                    fine::span_lists::<P>(lid, wg.x, wg.y, frame, batch_len, count_hidden, shared);
                    barrier();
                    fine::fine_test(program, lid, i, j, shared, overlap_free, count_hidden, &mut state);
                    barrier();
                    batch_start += BATCH;
                }
            }
            fine::count_hidden_triangles(lid, hidden, stats);
        }
        fine::fine_resolve(program, i, j, &state, setups)
    };
    fine::write_tile_stats(lid, tile, bin_len, hidden, frame, tile_stats);
    if inside {
        let k = fine::window_index(i, j, frame);
        values[k] = out.value;
        if frame.outputs.contains(OutputSet::OWNER) {
            owners[k] = out.owner;
        }
        if frame.outputs.contains(OutputSet::COVERAGE) {
            coverage[k] = out.count;
        }
    }
}
