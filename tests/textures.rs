//! Texture sampling: the same bits on both backends at every filter and address mode,
//! magnified and minified, sRGB and linear; nearest and bilinear against an f64 reference
//! sampler written here; the level of detail against its definition; bad textures as typed
//! errors.

mod common;

use common::gpu_or_skip;
use tileraster::render::{
    Address, Camera, Cull, Eye, Filter, Frame, IDENTITY, MAX_TEXTURE_DIM, Mesh, NO_TEXTURE, Projection, RenderParams, Shading, Texture, render,
};
use tileraster::{Backend, Error};

/// A texture whose every texel differs from its neighbours: smooth gradients and a checker.
fn pattern(w: u32, h: u32, srgb: bool) -> Texture {
    let rgba = (0..h)
        .flat_map(|y| (0..w).map(move |x| (x, y)))
        .flat_map(|(x, y)| {
            let checker = if (x / 2 + y / 2) % 2 == 0 { 200 } else { 40 };
            [
                (x * 255 / w.max(2).saturating_sub(1).max(1)).min(255) as u8,
                (y * 255 / h.max(2).saturating_sub(1).max(1)).min(255) as u8,
                checker,
                (128 + (x * 7 + y * 13) % 128) as u8,
            ]
        })
        .collect();
    Texture { srgb, ..Texture::srgb(w, h, rgba) }
}

/// A quad over the whole frame in clip space (depth 0.5, the identity camera), white, its
/// texture coordinates `uv0` at the top-left corner and `uv1` at the bottom-right.
fn screen_quad(uv0: [f32; 2], uv1: [f32; 2], texture: Texture) -> Mesh {
    Mesh {
        positions: vec![[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [1.0, 1.0, 0.5], [-1.0, 1.0, 0.5]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        colours: Some(vec![[1.0; 4]; 4]),
        uvs: Some(vec![uv0, [uv1[0], uv0[1]], uv1, [uv0[0], uv1[1]]]),
        textures: vec![texture],
        ..Default::default()
    }
}

fn unlit(w: u32, h: u32) -> RenderParams {
    RenderParams { cull: Cull::None, shading: Shading::Unlit, eye: Some(Eye::Point([0.0, 0.0, -1.0])), ..RenderParams::new(w, h, IDENTITY) }
}

fn cpu(mesh: &Mesh, params: &RenderParams) -> Frame {
    render(mesh, params, Backend::Cpu).unwrap_or_else(|e| panic!("CPU: {e}"))
}

/// CPU and GPU frames (and the CPU's plain twin) are the same bits.
fn assert_parity(what: &str, mesh: &Mesh, params: &RenderParams) -> Frame {
    let frame = cpu(mesh, params);
    let (prepared, _) = tileraster::render::prepare_render(mesh, params).unwrap();
    let plain = tileraster_cpu::rasterise_with(&prepared, tileraster_cpu::FinePath::Plain).unwrap();
    assert!(plain.colours.as_deref() == Some(&frame.colour[..]), "{what}: the CPU's plain twin differs");
    if gpu_or_skip(what) {
        let gpu = render(mesh, params, Backend::Gpu).unwrap_or_else(|e| panic!("{what}: GPU: {e}"));
        let differing = (0..frame.colour.len()).filter(|&k| frame.colour[k] != gpu.colour[k]).count();
        assert_eq!(differing, 0, "{what}: {differing} pixels differ between CPU and GPU");
        assert_eq!(frame.stats, gpu.stats, "{what}: statistics");
    }
    frame
}

/// A textured ground plane in perspective, its coordinates repeating many times towards the
/// horizon (minified far away, magnified near), at every filter and address mode, sRGB and
/// linear, power-of-two and odd sizes, lit and unlit: CPU = GPU.
#[test]
fn every_filter_and_address_mode_is_the_same_bits_on_both_backends() {
    let camera = Camera {
        eye: [0.0, -1.2, 0.6],
        target: [0.0, 3.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 60.0 },
        near: 0.1,
        far: 40.0,
    };
    let (w, h) = (96, 64);
    let view = camera.view_projection(w, h).unwrap();
    for (tw, th, srgb) in [(64, 64, true), (37, 23, false)] {
        for filter in Filter::ALL {
            for address in Address::ALL {
                let mut texture = pattern(tw, th, srgb);
                (texture.filter, texture.address_u, texture.address_v) = (filter, address, address);
                let mut ground = screen_quad([-1.3, -2.2], [6.7, 12.8], texture);
                ground.positions = vec![[-3.0, -1.0, 0.0], [3.0, -1.0, 0.0], [3.0, 30.0, 0.0], [-3.0, 30.0, 0.0]];
                for shading in [Shading::Unlit, Shading::Phong] {
                    let params = RenderParams { cull: Cull::None, shading, eye: Some(camera.viewer()), ..RenderParams::new(w, h, view) };
                    let what = format!("{tw}×{th} srgb {srgb}, {filter:?}, {address:?}, {}", shading.name());
                    let frame = assert_parity(&what, &ground, &params);
                    let distinct: std::collections::HashSet<u32> = frame.colour.iter().copied().collect();
                    assert!(distinct.len() > 50, "{what}: only {} colours: the texture does not show", distinct.len());
                }
            }
        }
    }
}

/// Exact sampling, against an f64 reference: a texture magnified on a screen-aligned quad,
/// every pixel's texel found from its centre's coordinates in f64. Nearest gives exactly the
/// texel; bilinear is within 2/255 of the f64 bilinear value (8 sub-texel bits, one rounding
/// to 16 bits, one to 8); sRGB texels are decoded before filtering.
#[test]
fn nearest_and_bilinear_match_an_f64_reference() {
    let (w, h) = (64, 48);
    // 24 × 20 texels over 64 × 48 pixels: no pixel centre lies within 1/16 texel of a texel
    // edge, so the rounding of the interpolated coordinates cannot choose another texel.
    for srgb in [false, true] {
        let texture = pattern(24, 20, srgb);
        let decode = |c: u8, channel: usize| -> f64 {
            let x = c as f64 / 255.0;
            if srgb && channel < 3 { if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) } } else { x }
        };
        let texel = |x: i64, y: i64, channel: usize| -> f64 {
            let (x, y) = (x.rem_euclid(24) as usize, y.rem_euclid(20) as usize);
            decode(texture.rgba[(y * 24 + x) * 4 + channel], channel)
        };
        for filter in [Filter::Nearest, Filter::Bilinear] {
            let mesh = screen_quad([0.0, 0.0], [1.0, 1.0], Texture { filter, ..texture.clone() });
            let frame = assert_parity(&format!("reference, srgb {srgb}, {filter:?}"), &mesh, &unlit(w, h));
            let mut worst = 0.0f64;
            for j in 0..h as usize {
                for i in 0..w as usize {
                    let (s, t) = ((i as f64 + 0.5) / w as f64 * 24.0, (j as f64 + 0.5) / h as f64 * 20.0);
                    let got = frame.colour[j * w as usize + i].to_le_bytes();
                    for (c, &got) in got.iter().enumerate() {
                        let expected = match filter {
                            Filter::Nearest => texel(s.floor() as i64, t.floor() as i64, c),
                            _ => {
                                let (u, v) = (s - 0.5, t - 0.5);
                                let (x0, y0) = (u.floor() as i64, v.floor() as i64);
                                let (fx, fy) = (u - x0 as f64, v - y0 as f64);
                                (1.0 - fx) * (1.0 - fy) * texel(x0, y0, c)
                                    + fx * (1.0 - fy) * texel(x0 + 1, y0, c)
                                    + (1.0 - fx) * fy * texel(x0, y0 + 1, c)
                                    + fx * fy * texel(x0 + 1, y0 + 1, c)
                            }
                        };
                        let error = (got as f64 - expected * 255.0).abs();
                        worst = worst.max(error);
                        let bound = if filter == Filter::Nearest { 0.5 } else { 2.0 };
                        assert!(error <= bound, "srgb {srgb}, {filter:?}, pixel ({i}, {j}), channel {c}: {got} against {:.3}", expected * 255.0);
                    }
                }
            }
            eprintln!("srgb {srgb}, {filter:?}: largest difference from the f64 reference {worst:.3} / 255");
        }
    }
}

/// The level of detail: a screen-aligned quad whose coordinates step `2^k` texels a pixel
/// reads mip level `k` alone (trilinear at an integer level), which is the level-0 texels
/// box-filtered `2^k × 2^k`: within 3/255 of that mean in f64 (one rounding per level).
/// Magnified, trilinear is bilinear of the full-size level.
#[test]
fn trilinear_reads_the_level_the_derivatives_give() {
    let (w, h) = (32, 32);
    // Linear texels, so the box means are plain means.
    let texture = Texture { filter: Filter::Trilinear, ..pattern(256, 256, false) };
    for k in 1..=3u32 {
        let scale = (1u32 << k) as f32 * w as f32 / 256.0;
        // Pixel centres at texel-block centres: each pixel's bilinear sample of level k lands
        // on one texel of it exactly.
        let mesh = screen_quad([0.0, 0.0], [scale, scale], texture.clone());
        let frame = assert_parity(&format!("lod {k}"), &mesh, &unlit(w, h));
        let block = 1usize << k;
        for j in 0..h as usize {
            for i in 0..w as usize {
                let got = frame.colour[j * w as usize + i].to_le_bytes();
                for (c, &got) in got.iter().enumerate() {
                    let mean: f64 =
                        (0..block * block).map(|n| texture.rgba[((j * block + n / block) * 256 + i * block + n % block) * 4 + c] as f64).sum::<f64>()
                            / (block * block) as f64;
                    assert!((got as f64 - mean).abs() <= 3.0, "level {k}, pixel ({i}, {j}), channel {c}: {got} against the mean {mean:.2}");
                }
            }
        }
    }
    let magnified = screen_quad([0.0, 0.0], [0.25, 0.25], texture.clone());
    let bilinear = screen_quad([0.0, 0.0], [0.25, 0.25], Texture { filter: Filter::Bilinear, ..texture });
    assert_eq!(cpu(&magnified, &unlit(w, h)).colour, cpu(&bilinear, &unlit(w, h)).colour, "magnified, trilinear is bilinear of level 0");
}

/// Faces take their own textures (or none); the frame's filter and address overrides apply
/// to every texture.
#[test]
fn faces_take_their_textures_and_the_frame_overrides_apply() {
    let (w, h) = (40, 30);
    let mut mesh = screen_quad([0.0, 0.0], [3.0, 3.0], pattern(16, 16, true));
    mesh.textures.push(pattern(5, 7, false));
    mesh.face_textures = Some(vec![1, NO_TEXTURE]);
    let frame = assert_parity("two textures", &mesh, &unlit(w, h));
    // The untextured face is its vertex colour: white.
    assert!(frame.colour.iter().filter(|&&c| c == 0xffff_ffff).count() > 400);
    for filter in Filter::ALL {
        for address in Address::ALL {
            let params = RenderParams { texture_filter: Some(filter), texture_address: Some(address), ..unlit(w, h) };
            let overridden = assert_parity(&format!("override {filter:?} {address:?}"), &mesh, &params);
            let mut by_hand = mesh.clone();
            for t in &mut by_hand.textures {
                (t.filter, t.address_u, t.address_v) = (filter, address, address);
            }
            assert_eq!(overridden.colour, cpu(&by_hand, &unlit(w, h)).colour, "{filter:?} {address:?}");
        }
    }
}

#[test]
fn bad_textures_are_typed_errors() {
    let params = unlit(16, 16);
    let with = |texture: Texture| render(&screen_quad([0.0; 2], [1.0; 2], texture), &params, Backend::Cpu).map(|_| ());
    let e = with(Texture::srgb(MAX_TEXTURE_DIM + 1, 1, vec![0; (MAX_TEXTURE_DIM as usize + 1) * 4])).unwrap_err();
    assert!(matches!(e, Error::TextureTooLarge { texture: 0, .. }) && e.to_string().contains("16384"), "{e}");
    let e = with(Texture::srgb(4, 4, vec![0; 60])).unwrap_err();
    assert!(matches!(e, Error::InvalidTexture { texture: 0, .. }) && e.to_string().contains("give 64"), "{e}");
    let e = with(Texture::srgb(0, 4, vec![])).unwrap_err();
    assert!(matches!(e, Error::InvalidTexture { .. }), "{e}");
    let mut mesh = screen_quad([0.0; 2], [1.0; 2], pattern(4, 4, true));
    mesh.face_textures = Some(vec![0, 3]);
    let e = render(&mesh, &params, Backend::Cpu).map(|_| ()).unwrap_err();
    assert!(matches!(e, Error::InvalidTexture { texture: 3, .. }) && e.to_string().contains("face 1"), "{e}");
    mesh.face_textures = Some(vec![0]);
    let e = render(&mesh, &params, Backend::Cpu).map(|_| ()).unwrap_err();
    assert_eq!(e.to_string(), "the mesh has 1 face textures for 2 faces; give one per face, or none");
}

/// A prepared mesh lays its textures out once and hands their texels to a backend once:
/// its later frames (another camera) count no texel bytes (nor position bytes), on each backend, until a frame
/// overrides the filter (laid out again, handed over again); every frame is the one-shot
/// `render`'s bits, whose count includes the texels.
#[test]
fn a_prepared_meshs_texels_are_handed_over_once() {
    use tileraster::render::PreparedMesh;
    let mesh = screen_quad([0.0, 0.0], [3.0, 2.0], pattern(64, 48, true));
    let mut prepared = PreparedMesh::new(mesh.clone()).unwrap();
    let texel_bytes = |params: &RenderParams| {
        let (p, _) = tileraster::render::prepare_render(&mesh, params).unwrap();
        8 * p.render.unwrap().texels.len() as u64
    };
    let mut backends = vec![Backend::Cpu];
    if gpu_or_skip("a_prepared_meshs_texels_are_handed_over_once") {
        backends.push(Backend::Gpu);
    }
    let filters = [None, None, Some(Filter::Nearest), Some(Filter::Nearest), None];
    for backend in backends {
        for (k, filter) in filters.into_iter().enumerate() {
            // Each frame a little smaller: another view of the same textures.
            let params = RenderParams { texture_filter: filter, ..unlit(64 - k as u32, 40) };
            let frame = prepared.render(&params, backend).unwrap();
            let once = render(&mesh, &params, backend).unwrap();
            assert_eq!(frame.colour, once.colour, "{backend:?}, frame {k}");
            let first = k == 0 || filter != filters[k - 1];
            // Nor are its positions, faces and vertex attributes (the same placement, unlit),
            // after its first frame on the backend.
            let kept = match k {
                0 => 0,
                _ => {
                    let positions = mesh.positions.len() * std::mem::size_of::<tileraster_kernels::abi::RelativePosition>();
                    let attributes = mesh.positions.len() * tileraster_kernels::abi::ATTRIBUTES * 4;
                    (positions + std::mem::size_of_val(mesh.triangles.as_slice()) + attributes) as u64
                }
            };
            let handed = once.stats.raster.bytes_uploaded - frame.stats.raster.bytes_uploaded;
            assert_eq!(handed, kept + if first { 0 } else { texel_bytes(&params) }, "{backend:?}, frame {k}: bytes not handed over again");
            assert!(texel_bytes(&params) > 0);
        }
    }
}
