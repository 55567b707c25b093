//! The tile depth bound of `programs::occlusion` on the stages' own buffers: every triangle it
//! hides loses every pixel of its tile. (That it changes no bit is checked on whole frames by
//! the render parity tests and `tests/skips.rs`.)

use tileraster_core::render::{Cull, Eye, IDENTITY, RenderParams, prepare_render};
use tileraster_kernels::FULL_TILE_BIT;
use tileraster_kernels::abi::{DepthFunc, TriangleSetup};
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::programs::depth::DepthProgram;
use tileraster_kernels::programs::height::barycentric_bits;
use tileraster_kernels::stages::fine::{PixelProgram, bin_range, side, tile_rect};
use tileraster_testkit::meshes;

/// On full-frame layers drawn back to front, every tile's nearest layer hides the others
/// (the rejection fires), and every triangle called hidden in a tile has, at every centre
/// of the tile it covers, a key above the key some occluder has there (the rejection is
/// exact), for every depth function.
#[test]
fn hidden_triangles_lose_every_pixel_of_their_tile() {
    let mesh = meshes::fill_layers(6);
    for func in DepthFunc::ALL {
        let clear_depth = if matches!(func, DepthFunc::Greater | DepthFunc::GreaterEqual) { 0.0 } else { 1.0 };
        let params =
            RenderParams { cull: Cull::None, depth_func: func, clear_depth, eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(400, 300, IDENTITY) };
        let (prepared, _) = prepare_render(&mesh, &params, &mut crate::GeometryTwins::default()).unwrap();
        let plan = prepared.plan(prepared.window, false).unwrap();
        let frame = plan.frame(&prepared, plan.active.unwrap());
        let buffers = crate::stage_buffers(&prepared).unwrap().unwrap();
        let program = DepthProgram::of(&frame);
        let (mut hidden_count, mut layered_tiles) = (0, 0);
        for tile_index in 0..frame.tile_count() {
            let (tx, ty) = (tile_index % frame.tiles_x, tile_index / frame.tiles_x);
            let tile = tile_rect(tx, ty, &frame);
            let (start, len) = bin_range(&buffers.offsets, tile_index);
            let bin = &buffers.bins[start as usize..][..len as usize];
            let occluders = bin.iter().filter(|&&e| e & FULL_TILE_BIT != 0);
            let occluding =
                occluders.map(|&e| program.occluder_key(&buffers.setups[(e & !FULL_TILE_BIT) as usize], &tile)).min().unwrap_or(DepthProgram::NO_KEY);
            // Off the quads' diagonals, one triangle of each layer covers the tile whole.
            layered_tiles += u32::from(bin.len() == 6 && bin.iter().all(|&e| e & FULL_TILE_BIT != 0));
            let key_at = |s: &TriangleSetup, i: i32, j: i32| {
                let d = f32::from_bits(barycentric_bits(s, i, j));
                if program.passes(d) { program.key_of(d.to_bits(), s.coverage.index) } else { DepthProgram::NO_KEY }
            };
            for &entry in bin {
                let s = &buffers.setups[(entry & !FULL_TILE_BIT) as usize];
                if !program.hidden(s, &tile, occluding) {
                    continue;
                }
                hidden_count += 1;
                for j in tile.j0..=tile.j1 {
                    for i in tile.i0..=tile.i1 {
                        if side(&s.coverage, i, j) != Side::Inside {
                            continue;
                        }
                        let best_occluder = bin
                            .iter()
                            .filter(|&&e| e & FULL_TILE_BIT != 0)
                            .map(|&e| key_at(&buffers.setups[(e & !FULL_TILE_BIT) as usize], i, j))
                            .min()
                            .unwrap();
                        assert!(key_at(s, i, j) > best_occluder, "{func:?}: triangle {} called hidden wins pixel ({i}, {j})", s.coverage.index);
                    }
                }
            }
        }
        // Of the five layers each of those tiles could hide, most are hidden (the bounds are
        // loosest where the winning layer is farthest).
        assert!(layered_tiles > 0 && hidden_count >= 3 * layered_tiles, "{func:?}: {hidden_count} hidden, {layered_tiles} tiles of whole layers");
    }
}
