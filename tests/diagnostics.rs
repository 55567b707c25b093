//! Diagnostics: per-tile counts, checksums and the tile heat map are the same on both
//! backends and say what they claim.

mod common;

use common::gpu_or_skip;
use tileraster::render::{Camera, Cull, Eye, Frame, Mesh, NO_FACE, Projection, RenderParams, Shading, render};
use tileraster::{Backend, Error};
use tileraster_testkit::meshes;

/// CRC-32 bit by bit (reflected, polynomial 0xEDB88320), as zlib defines it: the reference the
/// checksums are held to.
fn crc32_reference(bytes: &[u8]) -> u32 {
    let mut crc = !0u32;
    for &b in bytes {
        crc ^= b as u32;
        for _ in 0..8 {
            crc = if crc & 1 == 1 { (crc >> 1) ^ 0xEDB8_8320 } else { crc >> 1 };
        }
    }
    !crc
}

fn scene() -> (Mesh, RenderParams) {
    let mut mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 16, 24);
    mesh.triangles.extend(meshes::fill_layers(3).triangles.iter().map(|t| t.map(|v| v % 4)));
    let camera =
        Camera { eye: [2.0, -2.5, 1.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near: 0.5, far: 9.0 };
    let params =
        RenderParams { cull: Cull::None, shading: Shading::Phong, count_tiles: true, ..RenderParams::new(133, 97, camera.view_projection(133, 97).unwrap()) };
    (mesh, params)
}

fn frame(mesh: &Mesh, params: &RenderParams, backend: Backend) -> Frame {
    render(mesh, params, backend).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

/// Per-tile counts: the same on both backends; the hidden triangles add up to the statistics'
/// count; every tile with a covered pixel has a triangle; a tile's fragments come from at most
/// its triangles (each covers a pixel centre once).
#[test]
fn tile_counts_are_the_same_on_both_backends_and_add_up() {
    let layers = meshes::fill_layers(6);
    let (sphere, params) = scene();
    let flat = RenderParams { eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(150, 100, tileraster::render::IDENTITY) };
    for (name, mesh, params) in [("sphere", &sphere, params.clone()), ("layers", &layers, RenderParams { count_tiles: true, cull: Cull::None, ..flat })] {
        let cpu = frame(mesh, &params, Backend::Cpu);
        let tiles = cpu.tiles.as_ref().expect("tile counts asked for");
        assert_eq!((tiles.tiles_x, tiles.tiles_y), (params.width.div_ceil(16), params.height.div_ceil(16)), "{name}");
        assert_eq!(tiles.hidden.iter().map(|&h| h as u64).sum::<u64>(), cpu.stats.raster.triangles_hidden, "{name}: hidden");
        let w = params.width as usize;
        for (t, (&n, &hidden)) in tiles.triangles.iter().zip(&tiles.hidden).enumerate() {
            let (tx, ty) = (t % tiles.tiles_x as usize, t / tiles.tiles_x as usize);
            let pixels = (ty * 16..(ty * 16 + 16).min(params.height as usize)).flat_map(|y| (tx * 16..(tx * 16 + 16).min(w)).map(move |x| y * w + x));
            let (covered, most) = pixels.fold((0, 0), |(c, m), k| (c + u32::from(cpu.ids[k] != NO_FACE), m.max(cpu.fragments[k])));
            assert!(covered == 0 || n > 0, "{name}: tile {t} has covered pixels and no triangle");
            assert!(most <= n && hidden <= n, "{name}: tile {t}: {most} fragments at a pixel, {hidden} hidden, {n} triangles");
        }
        if name == "layers" {
            assert!(cpu.stats.raster.triangles_hidden > 0, "{name}: nothing hidden");
        }
        if gpu_or_skip("tile_counts_are_the_same_on_both_backends_and_add_up") {
            let gpu = frame(mesh, &params, Backend::Gpu);
            assert_eq!(cpu.tiles, gpu.tiles, "{name}: tile counts differ between the backends");
        }
        let without = frame(mesh, &RenderParams { count_tiles: false, ..params.clone() }, Backend::Cpu);
        assert!(without.tiles.is_none() && without.colour == cpu.colour, "{name}");
    }
}

/// The checksums are CRC-32 of the layers' little-endian bytes, the same on both backends, and
/// change with any pixel.
#[test]
fn checksums_are_crc32_of_every_layer_on_both_backends() {
    let (mesh, params) = scene();
    let cpu = frame(&mesh, &params, Backend::Cpu);
    let sums = cpu.checksums();
    let bytes = |words: &mut dyn Iterator<Item = u32>| -> Vec<u8> { words.flat_map(u32::to_le_bytes).collect() };
    assert_eq!(sums.colour, crc32_reference(&bytes(&mut cpu.colour.iter().copied())));
    assert_eq!(sums.depth, crc32_reference(&bytes(&mut cpu.depth.iter().map(|d| d.to_bits()))));
    assert_eq!(sums.ids, crc32_reference(&bytes(&mut cpu.ids.iter().copied())));
    assert_eq!(sums.fragments, Some(crc32_reference(&bytes(&mut cpu.fragments.iter().copied()))));
    let mut changed = cpu.clone();
    changed.colour[777] ^= 1;
    assert_ne!(changed.checksums().colour, sums.colour);
    let unfragmented = frame(&mesh, &RenderParams { count_fragments: false, ..params.clone() }, Backend::Cpu);
    assert_eq!(unfragmented.checksums().fragments, None);
    if gpu_or_skip("checksums_are_crc32_of_every_layer_on_both_backends") {
        assert_eq!(frame(&mesh, &params, Backend::Gpu).checksums(), sums);
    }
}

/// The heat map: three panels of the frame's size side by side, black where no triangle reaches
/// a tile, the same image on both backends; a frame without its counts is a typed error.
#[test]
fn the_heat_map_is_the_same_on_both_backends() {
    let (mesh, params) = scene();
    let cpu = frame(&mesh, &params, Backend::Cpu);
    let (w, h, rgba) = cpu.heat_map().unwrap();
    assert_eq!((w, h, rgba.len()), (3 * 133 + 8, 97, (3 * 133 + 8) as usize * 97 * 4));
    let tiles = cpu.tiles.as_ref().unwrap();
    let pixel = |x: usize, y: usize| &rgba[(y * w as usize + x) * 4..][..4];
    for (t, &n) in tiles.triangles.iter().enumerate() {
        let (x, y) = (t % tiles.tiles_x as usize * 16, t / tiles.tiles_x as usize * 16);
        assert_eq!(n == 0, pixel(x, y) == [0, 0, 0, 255], "tile {t}: {n} triangles, colour {:?}", pixel(x, y));
    }
    assert!(tiles.triangles.contains(&0) && tiles.triangles.iter().any(|&n| n > 0));
    if gpu_or_skip("the_heat_map_is_the_same_on_both_backends") {
        assert!(frame(&mesh, &params, Backend::Gpu).heat_map().unwrap().2 == rgba, "the heat maps differ");
    }
    let e = frame(&mesh, &RenderParams { count_tiles: false, ..params.clone() }, Backend::Cpu).heat_map().unwrap_err();
    assert!(matches!(e, Error::HeatMapNeeds { flag: "count_tiles", .. }), "{e}");
    let e = frame(&mesh, &RenderParams { count_fragments: false, ..params }, Backend::Cpu).heat_map().unwrap_err();
    assert!(matches!(e, Error::HeatMapNeeds { flag: "count_fragments", .. }), "{e}");
}
