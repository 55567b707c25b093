//! Early depth rejection in the CPU's `fine_depth`: a triangle that cannot own any pixel of a
//! tile is only counted there, its depth keys never computed. It changes no bit, and the plain
//! twin (which has no such rejection) is compared with it on every render scene.
//!
//! A triangle that covers the tile whole (`FULL_TILE_BIT`) and passes the depth test all over
//! it bounds every pixel's final key from above by its own largest key in the tile. A triangle
//! whose smallest key in the tile is above the smallest such bound loses every pixel.
//!
//! The bounds are exact, not estimated: the depth (`programs::height::barycentric_bits`) is
//! `Σ fl(fl(f32(e_k) · c3) · c_k)`, summed left to right, with `c3 > 0` and depths `c_k ≥ 0`,
//! and each step (the conversion, the products, the sums) is monotone, so evaluating it with
//! each edge function at its smallest (largest) value over the tile's centres, found at the
//! tile's corners as the edge functions are affine, gives a lower (upper) bound of every
//! centre's depth. A zero bound is taken as −0 below and +0 above, the ends of the zeros in
//! the keys' order. The bounds ignore that the weights sum to one, so they are tight only for
//! triangles much larger than a tile, the occluders that matter.

use tileraster_kernels::abi::{PixelRect, TriangleSetup};
use tileraster_kernels::math::fixed::fixed_to_f32_bits;
use tileraster_kernels::programs::depth::{ordered, DepthOrder, DepthProgram};
use tileraster_kernels::stages::fine::PixelProgram;
use tileraster_kernels::FULL_TILE_BIT;

/// The depth bounds of triangle `s` over the centres of `tile`, or `None` where the bounds
/// argument does not hold (a coefficient that is negative or not finite).
fn depth_bounds(s: &TriangleSetup, tile: &PixelRect) -> Option<(f32, f32)> {
    let c = &s.coeffs.c;
    if !(c[3] > 0.0 && c[3].is_finite() && c[..3].iter().all(|&z| z >= 0.0 && z.is_finite())) {
        return None;
    }
    let rect = &s.coverage.rect;
    let corners = [(tile.i0, tile.j0), (tile.i1, tile.j0), (tile.i0, tile.j1), (tile.i1, tile.j1)];
    let weight = |e: i64| f32::from_bits(fixed_to_f32_bits(e, 0)) * c[3];
    let mut lo = [0.0f32; 3];
    let mut hi = [0.0f32; 3];
    for (k, edge) in s.coverage.edges.iter().enumerate() {
        let at = corners.map(|(i, j)| edge.at((i - rect.i0) as i64, (j - rect.j0) as i64));
        lo[k] = weight(*at.iter().min().expect("four corners"));
        hi[k] = weight(*at.iter().max().expect("four corners"));
    }
    let depth = |w: [f32; 3]| w[0] * c[0] + w[1] * c[1] + w[2] * c[2];
    let (low, high) = (depth(lo), depth(hi));
    if !(low.is_finite() && high.is_finite()) {
        return None;
    }
    // The zeros' ends in the keys' order: −0 below +0.
    Some((if low == 0.0 { -0.0 } else { low }, if high == 0.0 { 0.0 } else { high }))
}

/// The key of depth `d` for triangle `s` (`DepthProgram::key` given the depth, without the
/// test).
fn key(program: &DepthProgram, s: &TriangleSetup, d: f32) -> u64 {
    let depth = match program.depth_order() {
        DepthOrder::Ascending => ordered(d.to_bits()),
        DepthOrder::Descending => !ordered(d.to_bits()),
        DepthOrder::Ignored => 0,
    };
    let index = s.coverage.index;
    let tie = if program.later_wins() { !index } else { index };
    (depth as u64) << 32 | tie as u64
}

/// Bounds of triangle `s`'s keys where its depth lies in `[low, high]` and passes the test.
fn key_bounds(program: &DepthProgram, s: &TriangleSetup, (low, high): (f32, f32)) -> (u64, u64) {
    let (a, b) = (key(program, s, low), key(program, s, high));
    (a.min(b), a.max(b))
}

/// The largest key any pixel of `tile` can end with, given its bin: the smallest upper key
/// bound of the triangles that cover the tile whole and pass the test all over it (each test
/// is one interval of depths, so passing at both bounds is passing everywhere between).
/// `NO_KEY` where there is none.
pub(super) fn occluding_key(program: &DepthProgram, setups: &[TriangleSetup], bin: &[u32], tile: &PixelRect) -> u64 {
    let mut bound = DepthProgram::NO_KEY;
    for &entry in bin.iter().filter(|&&e| e & FULL_TILE_BIT != 0) {
        let s = &setups[(entry & !FULL_TILE_BIT) as usize];
        if let Some((low, high)) = depth_bounds(s, tile).filter(|&(low, high)| program.passes(low) && program.passes(high)) {
            bound = bound.min(key_bounds(program, s, (low, high)).1);
        }
    }
    bound
}

/// Whether triangle `s` owns no pixel of `tile` because its keys there are all above
/// `occluding` (from [`occluding_key`]).
pub(super) fn hidden(program: &DepthProgram, s: &TriangleSetup, tile: &PixelRect, occluding: u64) -> bool {
    occluding != DepthProgram::NO_KEY && depth_bounds(s, tile).is_some_and(|depths| key_bounds(program, s, depths).0 > occluding)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_core::render::{prepare_render, Cull, RenderParams, IDENTITY};
    use tileraster_kernels::abi::DepthFunc;
    use tileraster_kernels::math::edge::Side;
    use tileraster_kernels::programs::height::barycentric_bits;
    use tileraster_kernels::stages::fine::{bin_range, side};
    use tileraster_kernels::TILE;
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
            let params = RenderParams { cull: Cull::None, depth_func: func, clear_depth, eye: Some([0.0, 0.0, -1.0]), ..RenderParams::new(400, 300, IDENTITY) };
            let (prepared, _) = prepare_render(&mesh, &params).unwrap();
            let plan = prepared.plan(prepared.window, false).unwrap();
            let frame = plan.frame(&prepared, plan.active.unwrap());
            let buffers = crate::stage_buffers(&prepared).unwrap().unwrap();
            let program = DepthProgram::of(&frame);
            let (mut hidden_count, mut layered_tiles) = (0, 0);
            for tile_index in 0..frame.tile_count() {
                let (tx, ty) = (tile_index % frame.tiles_x, tile_index / frame.tiles_x);
                let i0 = (frame.win_x0 + tx * TILE) as i32;
                let j0 = (frame.win_y0 + ty * TILE) as i32;
                let tile = PixelRect { i0, j0, i1: (i0 + TILE as i32 - 1).min((frame.win_x0 + frame.win_w) as i32 - 1), j1: (j0 + TILE as i32 - 1).min((frame.win_y0 + frame.win_h) as i32 - 1) };
                let (start, len) = bin_range(&buffers.offsets, tile_index);
                let bin = &buffers.bins[start as usize..][..len as usize];
                let occluding = occluding_key(&program, &buffers.setups, bin, &tile);
                // Off the quads' diagonals, one triangle of each layer covers the tile whole.
                layered_tiles += u32::from(bin.len() == 6 && bin.iter().all(|&e| e & FULL_TILE_BIT != 0));
                let key_at = |s: &TriangleSetup, i: i32, j: i32| {
                    let d = f32::from_bits(barycentric_bits(s, i, j));
                    if program.passes(d) { key(&program, s, d) } else { DepthProgram::NO_KEY }
                };
                for &entry in bin {
                    let s = &buffers.setups[(entry & !FULL_TILE_BIT) as usize];
                    if !hidden(&program, s, &tile, occluding) {
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
}
