//! Twin of the `shade` entry point: every pixel of the frame, rows in parallel, through the
//! kernel's `shaded_pixel` (blended over the pixel's tile's bin where the frame blends), with the frame's
//! fragment program: the built-in shadings, or the user's shader called natively. First, where
//! `fine_depth` ran as the GPU runs it, the tiles it left to this stage are resolved from the
//! small triangles' keys (`fine::left_to_shade`).
//!
//! The built-in id view reads nothing of a pixel but its owner (`fragment_colour`'s `Ids` arm): there a
//! run of pixels with the same owner is shaded once, with the kernel's function, so the bits
//! are the GPU's.

use rayon::prelude::*;
use tileraster_core::{Raster, RenderInputs};
use tileraster_kernels::abi::{FrameFlags, FrameParams, ShadeMode, TriangleSetup};
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::programs::fragment::{Builtin, FragmentProgram};
use tileraster_kernels::programs::shade::{shade_pixel, shaded_pixel};
use tileraster_kernels::stages::fine;
use tileraster_kernels::{NO_OWNER, TILE, TILE_PIXELS};

use super::small::{SmallSeeds, SmallTriangles};

#[allow(clippy::too_many_arguments)]
pub fn shade(frame: &FrameParams, inputs: &RenderInputs, setups: &[TriangleSetup], offsets: &[u32], bins: &[u32], small: &SmallTriangles, raster: &mut Raster) {
    // The fast paths of `fine_depth` resolve every tile (they take the small triangles binned).
    if let SmallTriangles::Seeded(seeds) = small {
        resolve_left_tiles(frame, setups, offsets, seeds, raster);
    }
    // The program is chosen once per frame: the built-in shadings are called directly.
    match &inputs.fragment {
        None => shade_with(&Builtin, frame, inputs, setups, offsets, bins, raster),
        Some(stage) => shade_with(stage.program(), frame, inputs, setups, offsets, bins, raster),
    }
}

/// [`shade`] with the fragment program `program`.
fn shade_with<P: FragmentProgram + Sync + ?Sized>(
    program: &P,
    frame: &FrameParams,
    inputs: &RenderInputs,
    setups: &[TriangleSetup],
    offsets: &[u32],
    bins: &[u32],
    raster: &mut Raster,
) {
    let (params, shading) = (&inputs.params, &inputs.records());
    let (textures, texels, materials) = (&inputs.textures[..], &inputs.texels[..], &inputs.materials[..]);
    let stride = raster.window.width as usize;
    let (x0, y0) = (raster.window.x0, raster.window.y0);
    let owners = raster.owner.as_deref().expect("the render pipeline writes the owner layer");
    let depths = &raster.values;
    let (Some(colours), Some(faces)) = (raster.colours.as_deref_mut(), raster.faces.as_deref_mut()) else {
        panic!("the render pipeline's raster has colour and face layers")
    };
    let first_row = (frame.win_y0 - y0) as usize;
    let columns = (frame.win_x0 - x0) as usize..(frame.win_x0 - x0 + frame.win_w) as usize;
    let by_owner = inputs.fragment.is_none() && params.blend == 0 && params.mode() == ShadeMode::Ids;
    colours.par_chunks_mut(stride).zip(faces.par_chunks_mut(stride)).enumerate().skip(first_row).take(frame.win_h as usize).for_each(
        |(row, (colour_row, face_row))| {
            let j = (y0 as usize + row) as i32;
            if by_owner {
                let mut last = None;
                for x in columns.clone() {
                    let k = row * stride + x;
                    let owner = owners[k];
                    let out = match last {
                        Some((o, out)) if o == owner => out,
                        _ => {
                            shade_pixel(program, params, setups, shading, textures, texels, materials, owner, depths[k].to_bits(), (x0 as usize + x) as i32, j)
                        }
                    };
                    last = Some((owner, out));
                    colour_row[x] = out.colour;
                    face_row[x] = out.face;
                }
                return;
            }
            for x in columns.clone() {
                let k = row * stride + x;
                let i = (x0 as usize + x) as i32;
                // As the entry point: blended, the tile's bin; else the owner fine raster left.
                let ((bin_start, bin_len), (owner, depth)) = if params.blend != 0 {
                    let tile = (j as u32 - frame.win_y0) / TILE * frame.tiles_x + (i as u32 - frame.win_x0) / TILE;
                    (fine::bin_range(offsets, tile), (NO_OWNER, 0))
                } else {
                    ((0, 0), (owners[k], depths[k].to_bits()))
                };
                let out = shaded_pixel(
                    program,
                    params,
                    frame.nodata_bits,
                    setups,
                    shading,
                    textures,
                    texels,
                    materials,
                    bins,
                    bin_start,
                    bin_len,
                    owner,
                    depth,
                    i,
                    j,
                );
                colour_row[x] = out.colour;
                face_row[x] = out.face;
            }
        },
    );
}

/// The pixels of the tiles `fine_depth` left to the shade stage (`fine::left_to_shade`),
/// resolved from the small triangles' keys by the kernel's `resolve_left`, into the depth and
/// owner layers as the entry point writes them; and their counts into the coverage layer, where
/// the GPU's `fine_small` counts in place (here the counts are the seeds'), none where nothing
/// owns the pixel (as the entry point zeroes them).
pub(crate) fn resolve_left_tiles(frame: &FrameParams, setups: &[TriangleSetup], offsets: &[u32], seeds: &SmallSeeds, raster: &mut Raster) {
    if !frame.flags.contains(FrameFlags::SMALL_TRIANGLES) {
        return;
    }
    let program = DepthProgram::of(frame);
    let stride = raster.window.width as usize;
    let (x0, y0) = (raster.window.x0, raster.window.y0);
    for ty in 0..frame.tiles_y {
        for tx in 0..frame.tiles_x {
            if !fine::left_to_shade(fine::bin_range(offsets, ty * frame.tiles_x + tx).1, frame) {
                continue;
            }
            for lid in 0..TILE_PIXELS {
                let (i, j, inside) = fine::tile_pixel(tx, ty, lid, frame);
                if !inside {
                    continue;
                }
                let at = fine::window_index(i, j, frame);
                let out = fine::resolve_left(&program, i, j, seeds.keys[at], setups);
                let k = (j as u32 - y0) as usize * stride + (i as u32 - x0) as usize;
                raster.values[k] = f32::from_bits(out.value);
                if let Some(owner) = raster.owner.as_deref_mut() {
                    owner[k] = out.owner;
                }
                if let Some(coverage) = raster.coverage.as_deref_mut() {
                    coverage[k] = if out.owner != NO_OWNER { seeds.counts.get(at).copied().unwrap_or(0) } else { 0 };
                }
            }
        }
    }
}
