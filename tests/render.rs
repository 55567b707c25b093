//! The render pipeline: the same bits on both backends (colour, depth, ids, fragment counts
//! and statistics) on every feature and in combination; depth and attributes against an f64
//! reference; watertightness of closed meshes in perspective; bad input.

mod common;

use common::gpu_or_skip;
use tileraster::render::{
    Camera, Cull, DepthFunc, Eye, Frame, FrontFace, Interpolation, Light, Mesh, NO_FACE, Projection, RenderParams, Shading, ToneMap, Up, prepare_render, render,
};
use tileraster::{Backend, Error, Skips};
use tileraster_core::render::{GUARD_PX, RENDER_SNAP_BITS};
use tileraster_cpu::FinePath;
use tileraster_kernels::abi::ShadeParams;
use tileraster_kernels::math::edge::Side;
use tileraster_kernels::programs::shade::{interpolate, weights};
use tileraster_kernels::stages::fine::side;
use tileraster_kernels::stages::setup::{edges_fit_i32, setup_triangle};
use tileraster_testkit::meshes;

/// A camera looking at the origin from `distance` along a fixed direction.
fn view(width: u32, height: u32, eye: [f64; 3], near: f64, far: f64) -> [[f64; 4]; 4] {
    Camera { eye, target: [0.0, 0.0, 0.0], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 50.0 }, near, far }
        .view_projection(width, height)
        .unwrap()
}

fn cpu(mesh: &Mesh, params: &RenderParams) -> Frame {
    render(mesh, params, Backend::Cpu).unwrap_or_else(|e| panic!("CPU backend failed: {e}"))
}

/// Panic with the first differing pixels unless the two frames are the same bits.
fn assert_same_frame(what: &str, a: &Frame, b: &Frame) {
    let n = a.colour.len();
    assert_eq!((a.width, a.height), (b.width, b.height), "{what}: sizes");
    assert_eq!(a.fragments.len(), b.fragments.len(), "{what}: one frame counts fragments, the other does not");
    let differing: Vec<usize> = (0..n)
        .filter(|&k| {
            a.colour[k] != b.colour[k] || a.depth[k].to_bits() != b.depth[k].to_bits() || a.ids[k] != b.ids[k] || a.fragments.get(k) != b.fragments.get(k)
        })
        .collect();
    if !differing.is_empty() {
        let first: Vec<String> = differing
            .iter()
            .take(10)
            .map(|&k| {
                format!(
                    "  pixel ({}, {}): colour {:08x} vs {:08x}, depth {:e} vs {:e}, id {} vs {}, fragments {:?} vs {:?}",
                    k % a.width as usize,
                    k / a.width as usize,
                    a.colour[k],
                    b.colour[k],
                    a.depth[k],
                    b.depth[k],
                    a.ids[k],
                    b.ids[k],
                    a.fragments.get(k),
                    b.fragments.get(k)
                )
            })
            .collect();
        panic!("{what}: {} of {n} pixels differ; first ones:\n{}", differing.len(), first.join("\n"));
    }
    assert_eq!(a.stats, b.stats, "{what}: statistics differ");
}

/// The render pipeline's skip variants: all, none, and each of the three it uses turned off.
fn render_skips() -> [(&'static str, Skips); 5] {
    [
        ("all skips", Skips::ALL),
        ("no skips", Skips::NONE),
        ("all skips but cull_window", Skips { cull_window: false, ..Skips::ALL }),
        ("all skips but empty_tiles", Skips { empty_tiles: false, ..Skips::ALL }),
        ("all skips but hidden_triangles", Skips { hidden_triangles: false, ..Skips::ALL }),
    ]
}

/// The CPU's depth-test fast paths (each triangle against its rows of the tile, centre by
/// centre or in lanes), all together and each alone, against its plain twin (each tile as the
/// GPU runs its workgroup): the same layers and counters.
fn assert_plain_twin(name: &str, mesh: &Mesh, params: &RenderParams) {
    let (mut prepared, _) = prepare_render(mesh, params).unwrap_or_else(|e| panic!("{name}: {e}"));
    // The CPU's shade stages read each slot's face apart from its record (the GPU's, from it).
    let render = prepared.render.as_ref().expect("a frame's shading");
    assert!(render.faces.iter().eq(render.triangles.iter().map(|t| &t.face)), "{name}: the faces kept apart are not the records'");
    // The owner layers too, which a frame does not return.
    prepared.params.outputs.owner = true;
    let run = |path| tileraster_cpu::rasterise_with(&prepared, path).unwrap_or_else(|e| panic!("{name}, {path:?}: {e}"));
    let plain = run(FinePath::Plain);
    for path in FinePath::DEPTH {
        let fast = run(path);
        common::assert_same_bits(&format!("{name}: depth, CPU {path:?} vs plain twin"), &fast, &plain);
        for (layer, a, b) in [
            ("owner", &fast.owner, &plain.owner),
            ("coverage", &fast.coverage, &plain.coverage),
            ("colour", &fast.colours, &plain.colours),
            ("face", &fast.faces, &plain.faces),
        ] {
            assert!(a == b, "{name}: the {layer} layers of the CPU's {path:?} and plain twins differ");
        }
        assert_eq!(fast.stats, plain.stats, "{name}: the statistics of {path:?} and the plain twin differ");
    }
}

/// Both backends, every skip variant, and the CPU's fast paths and plain twin: the same bits everywhere.
/// Returns the CPU frame.
fn assert_render_parity(name: &str, mesh: &Mesh, params: &RenderParams) -> Frame {
    assert_plain_twin(name, mesh, params);
    let reference = cpu(mesh, params);
    let gpu = gpu_or_skip(name);
    for (variant, skips) in render_skips() {
        let params = RenderParams { skips, ..params.clone() };
        let c = cpu(mesh, &params);
        assert_same_frame(&format!("{name}, {variant}: CPU, all skips vs this"), &reference, &Frame { stats: reference.stats.clone(), ..c.clone() });
        assert_eq!(reference.stats.geometry, c.stats.geometry, "{name}, {variant}: geometry counts");
        if gpu {
            let g = render(mesh, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{name}, {variant}: GPU backend failed: {e}"));
            assert_same_frame(&format!("{name}, {variant}: CPU vs GPU"), &c, &g);
        }
    }
    // Without the fragment count: no fragments layer, the same colour, depth and ids.
    let params = RenderParams { count_fragments: false, ..params.clone() };
    let c = cpu(mesh, &params);
    assert!(c.fragments.is_empty() && c.stats.fragments == 0, "{name}: fragments counted when not asked for");
    let counted = Frame { fragments: Vec::new(), stats: c.stats.clone(), ..reference.clone() };
    assert_same_frame(&format!("{name}, fragments not counted: CPU"), &counted, &c);
    if gpu {
        let g = render(mesh, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{name}, fragments not counted: GPU backend failed: {e}"));
        assert_same_frame(&format!("{name}, fragments not counted: CPU vs GPU"), &c, &g);
    }
    reference
}

/// Hierarchical depth rejection: on full-frame layers drawn back to front (each layer hides
/// the ones before it) the tiles' depth bounds reject triangles, the same number on both
/// backends, with and without the fragment count, and every bit is what the frame is without
/// the rejection (`assert_render_parity` turns it off); drawn front to back, for every depth
/// function.
#[test]
fn hidden_triangles_are_rejected_the_same_way_on_both_backends() {
    let back_to_front = meshes::fill_layers(8);
    let mut front_to_back = back_to_front.clone();
    front_to_back.triangles.reverse();
    for (order, mesh) in [("back to front", &back_to_front), ("front to back", &front_to_back)] {
        for depth_func in DepthFunc::ALL {
            let clear_depth = if matches!(depth_func, DepthFunc::Greater | DepthFunc::GreaterEqual) { 0.0 } else { 1.0 };
            let params = RenderParams {
                cull: Cull::None,
                depth_func,
                clear_depth,
                eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                ..RenderParams::new(181, 133, tileraster::render::IDENTITY)
            };
            let name = format!("8 layers {order}, {}", depth_func.name());
            let frame = assert_render_parity(&name, mesh, &params);
            let hidden = frame.stats.raster.triangles_hidden;
            // 12 × 9 tiles; in those off the squares' diagonals, one triangle of each of the 8
            // layers covers the tile whole, and at least the farthest layers are hidden.
            assert!(hidden >= 12 * 9 * 4, "{name}: only {hidden} triangles hidden");
            let off = cpu(mesh, &RenderParams { skips: Skips { hidden_triangles: false, ..Skips::ALL }, ..params.clone() });
            assert_eq!(off.stats.raster.triangles_hidden, 0, "{name}: hidden triangles counted with the rejection off");
        }
    }
}

#[test]
fn every_shading_mode_is_the_same_bits_on_both_backends() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 24, 40);
    let base = RenderParams::new(197, 131, view(197, 131, [2.2, -2.6, 1.4], 0.5, 8.0));
    for shading in Shading::ALL {
        let params = RenderParams { shading, ..base.clone() };
        let frame = assert_render_parity(&format!("sphere, {}", shading.name()), &mesh, &params);
        assert!(frame.stats.pixels_covered > 4000, "{}: the sphere covers {} pixels", shading.name(), frame.stats.pixels_covered);
    }
}

/// The output transforms (each tone map, linear or sRGB-encoded) of lit, coloured
/// surfaces: the same bits on both backends, each its own frame; lines and the data
/// views are not transformed.
#[test]
fn tone_maps_and_srgb_encoding_are_the_same_bits_on_both_backends() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 24, 40);
    let base = RenderParams::new(97, 65, view(97, 65, [2.2, -2.6, 1.4], 0.5, 8.0));
    // Bright lights, so that the tone maps have colours above one to compress.
    let lights = vec![Light { direction: [0.4, -0.5, 0.75], colour: [2.5, 2.2, 1.8] }, Light { direction: [-0.6, -0.2, 0.3], colour: [0.6, 0.7, 1.2] }];
    for shading in [Shading::Smooth, Shading::Phong, Shading::Pbr, Shading::Normals] {
        let mut seen = std::collections::HashSet::new();
        for tone_map in ToneMap::ALL {
            for srgb in [false, true] {
                let params = RenderParams { shading, tone_map, srgb, lights: lights.clone(), ..base.clone() };
                let name = format!("sphere, {}, tone map {}, srgb {srgb}", shading.name(), tone_map.name());
                let frame = assert_render_parity(&name, &mesh, &params);
                seen.insert(frame.colour.clone());
            }
        }
        let want = if shading == Shading::Normals { 1 } else { 6 };
        assert_eq!(seen.len(), want, "{}: distinct frames of the six transforms", shading.name());
    }
}

/// Metallic-roughness shading: the surface's factors change the frame (a metal loses the
/// diffuse lobe, a rough surface spreads the highlight), and factors outside `[0, 1]` are
/// typed errors naming the factor.
#[test]
fn pbr_frames_follow_their_surface_and_refuse_factors_outside_zero_to_one() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 24, 40);
    let base = RenderParams { shading: Shading::Pbr, ..RenderParams::new(97, 65, view(97, 65, [2.2, -2.6, 1.4], 0.5, 8.0)) };
    let frame = |metallic: f64, roughness: f64| render(&mesh, &RenderParams { metallic, roughness, ..base.clone() }, Backend::Cpu).unwrap();
    let dielectric = frame(0.0, 0.5);
    for (metallic, roughness) in [(1.0, 0.5), (0.0, 0.1), (0.0, 1.0)] {
        let other = frame(metallic, roughness);
        let differing = (0..other.colour.len()).filter(|&k| other.colour[k] != dielectric.colour[k]).count();
        assert!(differing > 500, "metallic {metallic}, roughness {roughness}: {differing} pixels differ from the default surface");
    }
    for (metallic, roughness, what) in
        [(1.5, 0.5, "metallic factor"), (0.0, -0.1, "roughness"), (f64::NAN, 0.5, "metallic factor"), (0.0, f64::INFINITY, "roughness")]
    {
        match render(&mesh, &RenderParams { metallic, roughness, ..base.clone() }, Backend::Cpu) {
            Err(Error::InvalidMaterial { what: named, .. }) => assert_eq!(named, what),
            other => panic!("metallic {metallic}, roughness {roughness}: {:?}", other.map(|_| ())),
        }
    }
}

#[test]
fn depth_functions_writes_and_ties_are_the_same_bits_on_both_backends() {
    // Interpenetrating triangles, and every triangle twice (exact depth ties between copies).
    let mut mesh = meshes::soup(300, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.6, 7);
    let n = mesh.triangles.len() as u32;
    let copies: Vec<[u32; 3]> = mesh.triangles.clone();
    mesh.triangles.extend(copies);
    let base = RenderParams { cull: Cull::None, shading: Shading::Ids, ..RenderParams::new(160, 120, view(160, 120, [3.0, 1.0, 2.0], 0.5, 10.0)) };
    for depth_func in DepthFunc::ALL {
        for depth_write in [true, false] {
            let clear_depth = if matches!(depth_func, DepthFunc::Greater | DepthFunc::GreaterEqual) { 0.0 } else { 1.0 };
            let params = RenderParams { depth_func, depth_write, clear_depth, ..base.clone() };
            let frame = assert_render_parity(&format!("soup with ties, {} write {depth_write}", depth_func.name()), &mesh, &params);
            // A tie goes to the copy a graphics API keeps: the first for Less/Greater (an
            // original), the last for the …Equal functions and Always (a copy).
            let later_wins = !depth_write || matches!(depth_func, DepthFunc::LessEqual | DepthFunc::GreaterEqual | DepthFunc::Always);
            let ids: Vec<u32> = frame.ids.iter().copied().filter(|&id| id != NO_FACE).collect();
            assert!(!ids.is_empty());
            assert!(ids.iter().all(|&id| (id >= n) == later_wins), "{}, write {depth_write}: a tie went the wrong way", depth_func.name());
        }
    }
}

#[test]
fn clipping_and_culling_are_the_same_bits_on_both_backends() {
    // A terrain seen from inside it: triangles cross the near plane, the side planes and lie
    // behind the camera.
    let mesh = meshes::terrain(40, 100.0, 12.0);
    let eye = [50.0, 50.0, 3.0];
    let inside = Camera { eye, target: [90.0, 70.0, -2.0], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 70.0 }, near: 0.3, far: 60.0 }
        .view_projection(240, 160)
        .unwrap();
    for cull in [Cull::None, Cull::Back, Cull::Front] {
        for front_face in [FrontFace::CounterClockwise, FrontFace::Clockwise] {
            let params = RenderParams { cull, front_face, shading: Shading::Phong, eye: Some(Eye::Point(eye)), ..RenderParams::new(240, 160, inside) };
            let frame = assert_render_parity(&format!("terrain from inside, {cull:?}, {front_face:?}"), &mesh, &params);
            let g = frame.stats.geometry;
            assert!(g.clipped > 0 && g.culled_frustum > 0, "{cull:?}: {g:?}");
        }
    }
    // Huge triangles reaching far beyond the viewport (the guard band), and slivers.
    let mut big = meshes::soup(40, [-50.0, -50.0, -5.0], [50.0, 50.0, 5.0], 400.0, 11);
    big.triangles.extend(meshes::soup(200, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.002, 12).triangles.iter().map(|t| t.map(|v| v % 120)));
    let params = RenderParams { cull: Cull::None, shading: Shading::Normals, ..RenderParams::new(128, 96, view(128, 96, [4.0, 3.0, 2.0], 0.2, 500.0)) };
    let frame = assert_render_parity("huge triangles and slivers", &big, &params);
    assert!(frame.stats.geometry.clipped > 0);
}

#[test]
fn screen_linear_interpolation_and_window_edges_are_the_same_bits_on_both_backends() {
    let mesh = meshes::sphere([0.3, 0.0, 0.0], 1.4, 12, 18);
    // Sizes that are not multiples of the 16-pixel tile; the sphere crosses the frame's edges.
    for (k, (w, h)) in [(33, 47), (100, 1), (1, 64)].into_iter().enumerate() {
        let params = RenderParams {
            interpolation: if k == 0 { Interpolation::Flat } else { Interpolation::Screen },
            shading: Shading::Phong,
            background: [10, 20, 30, 255],
            ..RenderParams::new(w, h, view(w, h, [2.5, -2.0, 1.0], 0.3, 9.0))
        };
        assert_render_parity(&format!("{:?} sphere {w}×{h}", params.interpolation), &mesh, &params);
    }
    // Flat: every pixel of a face has its first vertex's colour, exactly.
    let quad = Mesh {
        positions: vec![[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [1.0, 1.0, 0.5], [-1.0, 1.0, 0.5]],
        triangles: vec![[0, 1, 2], [2, 3, 0]],
        colours: Some(vec![[1.0, 0.0, 0.0, 1.0], [0.0, 1.0, 0.0, 1.0], [0.0, 0.0, 1.0, 1.0], [1.0, 1.0, 1.0, 1.0]]),
        ..Default::default()
    };
    let params = RenderParams {
        cull: Cull::None,
        shading: Shading::Unlit,
        interpolation: Interpolation::Flat,
        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
        ..RenderParams::new(16, 16, tileraster::render::IDENTITY)
    };
    let frame = assert_render_parity("flat quad", &quad, &params);
    for (k, &c) in frame.colour.iter().enumerate() {
        let want = if frame.ids[k] == 0 { [255, 0, 0, 255] } else { [0, 0, 255, 255] };
        assert_eq!(c.to_le_bytes(), want, "pixel {k}, face {}", frame.ids[k]);
    }
}

/// A closed mesh seen from outside: with no culling every pixel centre inside its silhouette
/// is inside exactly one front face and one back face (no crack, no double hit), and with
/// back faces culled exactly one.
#[test]
fn closed_meshes_are_watertight_in_perspective() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 31, 57);
    for (eye, size) in [([2.0, -2.5, 1.2], (301, 257)), ([0.1, -0.2, 3.0], (128, 128)), ([1.4, 1.1, -0.3], (257, 190))] {
        let vp = view(size.0, size.1, eye, 0.3, 10.0);
        let none = cpu(&mesh, &RenderParams { cull: Cull::None, ..RenderParams::new(size.0, size.1, vp) });
        let back = cpu(&mesh, &RenderParams { cull: Cull::Back, ..RenderParams::new(size.0, size.1, vp) });
        let mut inside = 0;
        for k in 0..none.fragments.len() {
            assert!(matches!(none.fragments[k], 0 | 2), "eye {eye:?}: pixel {k} is inside {} faces", none.fragments[k]);
            assert_eq!(back.fragments[k], none.fragments[k] / 2, "eye {eye:?}: pixel {k}: front faces");
            inside += usize::from(none.fragments[k] == 2);
        }
        assert!(inside > 3000, "the sphere covers {inside} pixels");
        assert_eq!(back.stats.pixels_covered as usize, inside);
    }
}

/// The depth at every covered pixel against the f64 value at its centre: the screen-linear
/// interpolation of the vertices' `z/w` over the snapped triangle (Vulkan's rule), by exact
/// barycentrics. The bound is the contract's (docs/numeric-contract.md).
#[test]
fn depth_is_within_its_bound_of_the_f64_reference() {
    let mesh = meshes::soup(400, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.7, 3);
    let params = RenderParams { cull: Cull::None, ..RenderParams::new(211, 157, view(211, 157, [2.5, 2.0, 1.5], 0.4, 12.0)) };
    // Pixels inside exactly one triangle: there the owner is known without the depth test.
    let (prepared, _) = prepare_render(&mesh, &params).unwrap();
    let frame = cpu(&mesh, &params);
    let render = prepared.render.as_ref().unwrap();
    let mut worst: f64 = 0.0;
    let mut checked = 0;
    for (slot, t) in prepared.triangles.iter().enumerate() {
        let s = setup_triangle(t, slot as u32, prepared.snap_bits);
        let unit = 256.0;
        let (x, y) = (t.x.map(|v| v as f64 / unit), t.y.map(|v| v as f64 / unit));
        let area = (x[1] - x[0]) * (y[2] - y[0]) - (y[1] - y[0]) * (x[2] - x[0]);
        for j in t.rect.j0..=t.rect.j1 {
            for i in t.rect.i0..=t.rect.i1 {
                let k = j as usize * 211 + i as usize;
                if side(&s.coverage, i, j) != Side::Inside || frame.ids[k] != render.triangles[slot].face || frame.fragments[k] != 1 {
                    continue;
                }
                let (px, py) = (i as f64 + 0.5, j as f64 + 0.5);
                // Weight of the vertex opposite edge k: the edge function of edge k.
                let e = |a: usize, b: usize| (x[b] - x[a]) * (py - y[a]) - (y[b] - y[a]) * (px - x[a]);
                let z = t.coeffs.c;
                let reference = (e(0, 1) * z[0] as f64 + e(1, 2) * z[1] as f64 + e(2, 0) * z[2] as f64) / area;
                let err = (frame.depth[k] as f64 - reference).abs();
                worst = worst.max(err);
                checked += 1;
                assert!(err <= DEPTH_BOUND, "pixel ({i}, {j}): depth {:e}, reference {reference:e}, error {err:e} > {DEPTH_BOUND:e}", frame.depth[k]);
            }
        }
    }
    assert!(checked > 3000, "only {checked} pixels checked");
    println!("depth: {checked} pixels, largest error {worst:e} ({:.2} × 2^-24)", worst / 2f64.powi(-24));
}

/// Depth's bound against the f64 value (docs/numeric-contract.md): 8 · 2^-24 absolute, for
/// depths in [0, 1].
const DEPTH_BOUND: f64 = 8.0 / (1u64 << 24) as f64;

/// Perspective-correct and screen-linear attributes at pixel centres, through the kernels'
/// own functions, against the f64 interpolation (vertex `1/w` and attributes as the kernels
/// receive them, exact barycentrics of the snapped triangle).
#[test]
fn attributes_are_within_their_bound_of_the_f64_reference() {
    let mesh = meshes::soup(200, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.8, 5);
    let params = RenderParams { cull: Cull::None, ..RenderParams::new(173, 139, view(173, 139, [2.0, 2.2, 0.8], 0.3, 12.0)) };
    let (prepared, _) = prepare_render(&mesh, &params).unwrap();
    let render = prepared.render.as_ref().unwrap();
    let mut worst = [0.0f64; 2];
    let (mut checked, mut in_32_bits) = (0, 0);
    for (slot, t) in prepared.triangles.iter().enumerate() {
        let s = setup_triangle(t, slot as u32, prepared.snap_bits);
        let fits_32_bits = edges_fit_i32(t, prepared.snap_bits);
        let shading = &render.triangles[slot];
        let (x, y) = (t.x.map(|v| v as f64 / 256.0), t.y.map(|v| v as f64 / 256.0));
        for j in t.rect.j0..=t.rect.j1 {
            for i in t.rect.i0..=t.rect.i1 {
                if side(&s.coverage, i, j) != Side::Inside {
                    continue;
                }
                let (px, py) = (i as f64 + 0.5, j as f64 + 0.5);
                let e = [(0, 1), (1, 2), (2, 0)].map(|(a, b)| (x[b] - x[a]) * (py - y[a]) - (y[b] - y[a]) * (px - x[a]));
                for (m, interpolation) in [Interpolation::Perspective, Interpolation::Screen].into_iter().enumerate() {
                    let q = [0, 1, 2].map(|k| if interpolation == Interpolation::Screen { e[k] } else { e[k] * shading.inv_w[k] as f64 });
                    let sum: f64 = q.iter().sum();
                    let params = ShadeParams { interpolation: interpolation as u32, ..Default::default() };
                    let b = weights(&s, shading, &params, i, j);
                    // Where the triangle's edge functions fit 32 bits, that arithmetic gives the
                    // same weights.
                    if fits_32_bits {
                        let small = weights(&s, shading, &ShadeParams { small_edges: 1, ..params }, i, j);
                        assert_eq!(small.map(f32::to_bits), b.map(f32::to_bits), "32-bit and 64-bit edge functions at ({i}, {j})");
                        in_32_bits += 1;
                    }
                    for a in 0..12 {
                        let values = [0, 1, 2].map(|k| shading.attributes[k][a] as f64);
                        let reference: f64 = (0..3).map(|k| q[k] / sum * values[k]).sum();
                        let scale = values.iter().fold(0.0f64, |s, v| s.max(v.abs()));
                        let err = (interpolate(shading, &b, a) as f64 - reference).abs();
                        let bound = ATTRIBUTE_BOUND * scale;
                        worst[m] = worst[m].max(if scale > 0.0 { err / scale } else { 0.0 });
                        assert!(err <= bound, "{interpolation:?}, pixel ({i}, {j}), attribute {a}: error {err:e} > {bound:e}");
                    }
                    checked += 1;
                }
            }
        }
    }
    assert!(checked > 10_000, "only {checked} pixels checked");
    assert!(in_32_bits > 1_000, "only {in_32_bits} pixels compared in 32-bit arithmetic");
    println!(
        "attributes: {checked} pixel evaluations ({in_32_bits} also in 32 bits); largest error / largest vertex value: perspective {:e}, screen {:e}",
        worst[0], worst[1]
    );
}

/// Attributes' bound against the f64 value (docs/numeric-contract.md), relative to the
/// largest of the three vertex values: 2^-20.
const ATTRIBUTE_BOUND: f64 = 1.0 / (1u64 << 20) as f64;

#[test]
fn bad_input_is_a_typed_error() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 6, 8);
    let ok = RenderParams::new(64, 64, view(64, 64, [3.0, 0.0, 0.0], 0.5, 9.0));
    let err = |mesh: &Mesh, params: &RenderParams| render(mesh, params, Backend::Cpu).expect_err("bad input must be refused");
    let mut nan = ok.clone();
    nan.view_projection[2][1] = f64::NAN;
    assert!(matches!(err(&mesh, &nan), Error::NonFiniteMatrix { row: 2, column: 1, .. }));
    let mut projective = ok.clone();
    projective.model[3][2] = 0.5;
    assert!(matches!(err(&mesh, &projective), Error::NonAffineModel { .. }));
    let mut nan_model = ok.clone();
    nan_model.model[0][3] = f64::INFINITY;
    assert!(matches!(err(&mesh, &nan_model), Error::NonFiniteMatrix { name: "model", row: 0, column: 3, .. }));
    let mut inf_vertex = mesh.clone();
    inf_vertex.positions[5][1] = f64::INFINITY;
    assert!(matches!(err(&inf_vertex, &ok), Error::NonFiniteCoordinate { vertex: 5, axis: 'y', .. }));
    let mut bad_index = mesh.clone();
    bad_index.triangles[3][2] = 10_000;
    assert!(matches!(err(&bad_index, &ok), Error::IndexOutOfRange { triangle: 3, corner: 2, .. }));
    let mut short = mesh.clone();
    short.normals.as_mut().unwrap().pop();
    assert!(matches!(err(&short, &ok), Error::AttributeLength { .. }));
    assert!(matches!(err(&mesh, &RenderParams { width: 0, ..ok.clone() }), Error::ZeroSizedRaster { .. }));
    assert!(matches!(err(&Mesh::default(), &ok), Error::EmptyScene { .. }));
    let reason = |camera: Camera| match camera.view_projection(64, 48) {
        Err(Error::SingularCamera { reason }) => reason,
        other => panic!("a singular camera expected, not {other:?}"),
    };
    let looking_down = Camera {
        eye: [0.0, 0.0, 5.0],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 1.0, 0.0],
        projection: Projection::Perspective { fov_deg: 45.0 },
        near: 0.1,
        far: 10.0,
    };
    assert!(reason(Camera { eye: [1.0; 3], target: [1.0; 3], ..looking_down }).contains("same point"));
    assert!(reason(Camera { up: [0.0, 0.0, 1.0], ..looking_down }).contains("up vector"));
    // A matrix that sees neither a centre of projection nor a single viewing direction (its x
    // and y rows parallel) needs its eye given.
    let flat = [[0.5, 0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.1, 0.5], [0.0, 0.0, 0.0, 1.0]];
    assert!(matches!(err(&mesh, &RenderParams::new(64, 64, flat)), Error::SingularCamera { .. }));
    for (projection, cause) in [
        (Projection::Orthographic { width: 0.0 }, "orthographic width"),
        (Projection::Orthographic { width: f64::INFINITY }, "orthographic width"),
        (Projection::Perspective { fov_deg: 180.0 }, "field of view"),
    ] {
        let camera = Camera { projection, ..looking_down };
        assert!(reason(camera).contains(cause), "{projection:?}: {}", reason(camera));
    }
    let inverted = Camera { projection: Projection::Orthographic { width: 2.0 }, near: 3.0, far: 2.0, ..looking_down };
    assert!(reason(inverted).contains("near < far"), "{}", reason(inverted));
    // Each camera error names its own cause: a field of view of 0 (which frames the mesh from
    // infinitely far), an extent f64 cannot hold.
    assert!(reason(Camera::framing(&mesh, 4.0 / 3.0, Projection::Perspective { fov_deg: 0.0 }, Up::Z)).contains("field of view"));
    let triangle = |s: f64| Mesh { positions: vec![[0.0, 0.0, 0.0], [s, 0.0, 0.0], [0.0, s, 0.0]], triangles: vec![[0, 1, 2]], ..Default::default() };
    let mut beyond = triangle(1.7e308);
    beyond.positions[0][0] = -1.7e308;
    assert!(reason(Camera::framing(&beyond, 4.0 / 3.0, Projection::Perspective { fov_deg: 45.0 }, Up::Z)).contains("not finite"));
    // Coordinates whose squares overflow f64 still frame, as the same triangle at unit scale.
    let covered = |mesh: &Mesh| {
        let view = Camera::framing(mesh, 4.0 / 3.0, Projection::Perspective { fov_deg: 45.0 }, Up::Z).view_projection(64, 48).unwrap_or_else(|e| panic!("{e}"));
        cpu(mesh, &RenderParams { cull: Cull::None, ..RenderParams::new(64, 48, view) }).stats.pixels_covered
    };
    let unit = covered(&triangle(1.0));
    assert!(unit > 100 && covered(&triangle(1e200)) == unit && covered(&triangle(1e300)) == unit, "the framed triangle covers {unit} pixels at unit scale");
}

/// Blending: both backends give the same bits for every depth function, with and without
/// depth writes, and every pixel is what the definition gives: the fragments covering its
/// centre, taken from all of the frame's triangles in submission order, each tested against
/// the running depth and blended source-over (the kernels' own per-fragment functions, walked
/// here without bins).
#[test]
fn blending_is_in_submission_order_on_both_backends() {
    use tileraster_kernels::programs::depth::{DepthProgram, depth_bits};
    use tileraster_kernels::programs::shade::{fragment_colour, source_over};
    let mut mesh = meshes::soup(150, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.8, 21);
    for (k, c) in mesh.colours.as_mut().unwrap().iter_mut().enumerate() {
        c[3] = [0.25, 0.5, 0.75, 1.0][k % 4];
    }
    let base = RenderParams {
        cull: Cull::None,
        blend: true,
        shading: Shading::Unlit,
        background: [20, 40, 60, 255],
        ..RenderParams::new(96, 80, view(96, 80, [2.5, 1.5, 2.0], 0.5, 9.0))
    };
    for depth_func in [DepthFunc::Less, DepthFunc::GreaterEqual, DepthFunc::Always] {
        for depth_write in [true, false] {
            let clear_depth = if depth_func == DepthFunc::GreaterEqual { 0.0 } else { 1.0 };
            let params = RenderParams { depth_func, depth_write, clear_depth, ..base.clone() };
            let frame = assert_render_parity(&format!("blended soup, {} write {depth_write}", depth_func.name()), &mesh, &params);
            let (prepared, _) = prepare_render(&mesh, &params).unwrap();
            let render = prepared.render.as_ref().unwrap();
            let setups: Vec<_> = prepared.triangles.iter().enumerate().map(|(slot, t)| setup_triangle(t, slot as u32, prepared.snap_bits)).collect();
            let mut blended = 0;
            for j in 0..80 {
                for i in 0..96 {
                    let (mut colour, mut running, mut layers) = (u32::from_le_bytes(params.background), clear_depth, 0);
                    for (slot, s) in setups.iter().enumerate() {
                        if side(&s.coverage, i, j) != Side::Inside {
                            continue;
                        }
                        let d = depth_bits(s, i, j);
                        if (DepthProgram { func: depth_func, write: true, clear: running, small_edges: false }).passes(f32::from_bits(d)) {
                            colour = source_over(
                                fragment_colour(
                                    &render.params,
                                    s,
                                    &render.triangles[slot],
                                    render.triangles[slot].face,
                                    &render.textures,
                                    &render.texels,
                                    &render.materials,
                                    d,
                                    i,
                                    j,
                                ),
                                colour,
                            );
                            layers += 1;
                            if depth_write {
                                running = f32::from_bits(d);
                            }
                        }
                    }
                    blended += usize::from(layers > 1);
                    assert_eq!(frame.colour[(j * 96 + i) as usize], colour, "{}, write {depth_write}: pixel ({i}, {j})", depth_func.name());
                }
            }
            assert!(blended > 500, "only {blended} pixels blend two fragments or more");
        }
    }
    // A known answer: half-transparent red over an opaque blue background.
    let quad = Mesh {
        positions: vec![[-1.0, -1.0, 0.5], [1.0, -1.0, 0.5], [1.0, 1.0, 0.5], [-1.0, 1.0, 0.5]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        colours: Some(vec![[1.0, 0.0, 0.0, 0.5]; 4]),
        ..Default::default()
    };
    let params = RenderParams {
        cull: Cull::None,
        blend: true,
        shading: Shading::Unlit,
        background: [0, 0, 255, 255],
        eye: Some(Eye::Point([0.0, 0.0, -1.0])),
        ..RenderParams::new(8, 8, tileraster::render::IDENTITY)
    };
    let frame = assert_render_parity("half-transparent quad", &quad, &params);
    // α = 128/255: red (255·128 + 127) / 255 = 128, blue (255·127 + 127) / 255 = 127.
    assert!(frame.colour.iter().all(|&c| c.to_le_bytes() == [128, 0, 127, 255]), "{:08x}", frame.colour[0]);
}

/// A model matrix places the mesh as moving its vertices would: the same frame, normals
/// included (turned by the inverse transpose), on both backends.
#[test]
fn a_model_matrix_is_the_same_as_moved_vertices() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 16, 24);
    // Scale x by 2 and turn 90° about z, then move by (0.5, -0.25, 0.1); exact in f64.
    let model = [[0.0, -1.0, 0.0, 0.5], [2.0, 0.0, 0.0, -0.25], [0.0, 0.0, 1.0, 0.1], [0.0, 0.0, 0.0, 1.0]];
    let moved_positions: Vec<[f64; 3]> =
        mesh.positions.iter().map(|p| std::array::from_fn(|r| model[r][0] * p[0] + model[r][1] * p[1] + model[r][2] * p[2] + model[r][3])).collect();
    // Normals by the inverse transpose of the linear part: (nx, ny, nz) → (−ny/2·…): here
    // (x, y, z) ↦ (−y, 2x, z), whose inverse transpose maps n to (−n.y, n.x/2, n.z), normalised.
    let moved_normals = mesh.normals.as_ref().unwrap().iter().map(|n| {
        let t = [-(n[1] as f64), n[0] as f64 / 2.0, n[2] as f64];
        let len = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt();
        t.map(|c| (c / len) as f32)
    });
    let moved = Mesh { positions: moved_positions, normals: Some(moved_normals.collect()), ..mesh.clone() };
    let vp = view(120, 90, [4.0, -5.0, 3.0], 1.0, 20.0);
    let placed = RenderParams { model, shading: Shading::Phong, ..RenderParams::new(120, 90, vp) };
    let frame = assert_render_parity("model matrix", &mesh, &placed);
    let reference = cpu(&moved, &RenderParams { shading: Shading::Phong, ..RenderParams::new(120, 90, vp) });
    assert_eq!(frame.ids, reference.ids);
    assert!(frame.depth.iter().zip(&reference.depth).all(|(a, b)| a.to_bits() == b.to_bits()));
    // Normals turned by cofactors rather than by hand may differ in their last bit: colours
    // within one step.
    let close = frame.colour.iter().zip(&reference.colour).all(|(a, b)| a.to_le_bytes().iter().zip(b.to_le_bytes()).all(|(x, y)| x.abs_diff(y) <= 1));
    assert!(close && frame.stats.pixels_covered > 1000);
}

/// A prepared mesh (checked once, normals computed once, its frames' memory kept) gives every
/// frame bit for bit as `render` does, for meshes with and without normals, with and without a
/// model matrix; frames of one prepared mesh that follow each other at other sizes, shadings,
/// cameras (the mesh filling the frame, then in a corner of it) and backgrounds, into new
/// frames and into one reused frame, keep nothing of the frame before.
#[test]
fn a_prepared_mesh_renders_what_render_does() {
    use tileraster::render::PreparedMesh;
    let with_normals = meshes::sphere([0.0, 0.0, 0.0], 1.0, 12, 20);
    let without = meshes::soup(100, [-1.0, -1.0, -1.0], [1.0, 1.0, 1.0], 0.6, 9);
    let model = [[1.5, 0.0, 0.0, 0.0], [0.0, 1.0, 0.3, 0.0], [0.0, 0.0, 0.8, 0.2], [0.0, 0.0, 0.0, 1.0]];
    let gpu = gpu_or_skip("a prepared mesh");
    for mesh in [with_normals, without] {
        let mut prepared = PreparedMesh::new(mesh.clone()).unwrap();
        let mut reused = Frame::default();
        let frames = [
            (80, 60, [3.0, -2.0, 1.0], tileraster::render::IDENTITY, Shading::Phong, [0, 0, 0, 0], false),
            (80, 60, [-2.0, 3.0, 2.0], model, Shading::Phong, [0, 0, 0, 0], false),
            // Larger, then smaller with the mesh far off in a corner (an active window smaller
            // than the frame), then blended.
            (131, 97, [2.0, 2.5, -1.5], tileraster::render::IDENTITY, Shading::Smooth, [9, 8, 7, 255], false),
            (64, 48, [12.0, 9.0, 6.0], tileraster::render::IDENTITY, Shading::Ids, [1, 2, 3, 4], false),
            (90, 70, [2.5, -2.0, 1.0], model, Shading::Unlit, [0, 0, 40, 255], true),
            // Lit per vertex, then per face, then not at all, at one placement: the kernels
            // light the kept attributes, and flat shading keeps its face normals with them.
            (70, 50, [3.0, 1.0, 2.0], model, Shading::Smooth, [0, 0, 0, 255], false),
            (70, 50, [1.0, 3.0, 2.0], model, Shading::Flat, [0, 0, 0, 255], false),
            (70, 50, [1.0, 3.0, -2.0], model, Shading::Unlit, [0, 0, 0, 255], false),
        ];
        for (k, (w, h, eye, m, shading, background, blend)) in frames.into_iter().enumerate() {
            let mut v = view(w, h, eye, 0.5, 30.0);
            if k == 3 {
                // Shift the projection so that the mesh lands near the frame's top-left corner.
                let w_row = v[3];
                for row in &mut v[..2] {
                    for (x, w) in row.iter_mut().zip(w_row) {
                        *x -= 0.7 * w;
                    }
                }
            }
            let params = RenderParams { model: m, shading, background, blend, cull: Cull::None, ..RenderParams::new(w, h, v) };
            let name = format!("frame {k}");
            let expected = cpu(&mesh, &params);
            let first = prepared.render(&params, Backend::Cpu).unwrap();
            assert_same_frame(&format!("{name}: prepared mesh vs render"), &as_one_shot(first, &expected, &mesh, k > 0), &expected);
            prepared.render_into(&params, Backend::Cpu, &mut reused).unwrap();
            assert_same_frame(&format!("{name}: prepared mesh into a reused frame vs render"), &as_one_shot(reused.clone(), &expected, &mesh, true), &expected);
            if gpu {
                prepared.render_into(&params, Backend::Gpu, &mut reused).unwrap();
                let frame = as_one_shot(reused.clone(), &expected, &mesh, k > 0);
                assert_same_frame(&format!("{name}: prepared mesh on the GPU vs render on the CPU"), &frame, &expected);
            }
            if k == 3 {
                let covered = expected.ids.iter().enumerate().filter(|&(_, &id)| id != NO_FACE).map(|(p, _)| (p % w as usize, p / w as usize));
                let (right, bottom) = covered.fold((0, 0), |(r, b), (x, y)| (r.max(x), b.max(y)));
                assert!(
                    expected.stats.pixels_covered > 20 && right < w as usize / 2 && bottom < h as usize / 2,
                    "frame 3 puts the mesh in a corner (it reaches {right}, {bottom})"
                );
            }
        }
    }
    assert!(matches!(PreparedMesh::new(Mesh::default()), Err(Error::EmptyScene { .. })));
}

/// A mesh entirely behind the camera draws nothing, on both backends, and says why.
#[test]
fn a_mesh_behind_the_camera_draws_nothing() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 8, 12);
    let behind = Camera {
        eye: [5.0, 0.0, 0.0],
        target: [10.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 60.0 },
        near: 0.1,
        far: 20.0,
    };
    let params = RenderParams { background: [1, 2, 3, 4], ..RenderParams::new(48, 40, behind.view_projection(48, 40).unwrap()) };
    let frame = assert_render_parity("behind the camera", &mesh, &params);
    assert_eq!(frame.stats.geometry.rasterised, 0);
    assert_eq!(frame.stats.geometry.culled_frustum, mesh.triangles.len() as u64);
    assert!(frame.colour.iter().all(|&c| c == u32::from_le_bytes([1, 2, 3, 4])));
    assert!(frame.ids.iter().all(|&id| id == NO_FACE) && frame.depth.iter().all(|&d| d == 1.0));
}

/// A prepared mesh's `frame` with its upload counted as the one-shot frame `once`'s. Where
/// `kept` (not its first frame on that backend) it handed neither its positions nor its faces
/// again, and its vertex attributes (with its face normals under flat shading) neither where
/// the frame before made them for the same placement and shading; else it hands over what
/// `once` does.
fn as_one_shot(mut frame: Frame, once: &Frame, mesh: &Mesh, kept: bool) -> Frame {
    use tileraster_kernels::abi::{ATTRIBUTES, FaceNormal, RelativePosition};
    let (prepared, one_shot) = (frame.stats.geometry.bytes_uploaded, once.stats.geometry.bytes_uploaded);
    if kept {
        let saved = (mesh.positions.len() * std::mem::size_of::<RelativePosition>() + std::mem::size_of_val(mesh.triangles.as_slice())) as u64;
        let attributes = (mesh.positions.len() * ATTRIBUTES * 4) as u64;
        let face_normals = (mesh.triangles.len() * std::mem::size_of::<FaceNormal>()) as u64;
        let differs = one_shot.checked_sub(prepared);
        let expected = [saved, saved + attributes, saved + attributes + face_normals].map(Some);
        assert!(expected.contains(&differs), "a kept mesh's upload: {prepared}, {one_shot} at once");
    } else {
        assert_eq!(prepared, one_shot, "a first frame's upload");
    }
    frame.stats.geometry.bytes_uploaded = one_shot;
    frame.stats.raster.bytes_uploaded += one_shot - prepared;
    frame
}

/// A frame without its colour or depth layer has that layer empty and every other layer and
/// statistic of the full frame, on both backends, single-sampled and multisampled, rendered
/// at once and by a prepared mesh whose reused memory held frames of other layers before.
#[test]
fn frames_return_the_layers_asked_for() {
    use tileraster::render::PreparedMesh;
    let mesh = meshes::sphere([0.0; 3], 1.0, 24, 40);
    let backends: &[Backend] = if gpu_or_skip("frames_return_the_layers_asked_for") { &[Backend::Cpu, Backend::Gpu] } else { &[Backend::Cpu] };
    for samples in [1, 4] {
        let full = RenderParams { shading: Shading::Phong, samples, ..RenderParams::new(160, 120, view(160, 120, [2.5, -2.0, 1.5], 0.5, 9.0)) };
        let reference = cpu(&mesh, &full);
        assert!(reference.stats.pixels_covered > 1000, "the sphere must cover the frame");
        for &backend in backends {
            let mut prepared = PreparedMesh::new(mesh.clone()).unwrap();
            let mut reused = Frame::default();
            for (call, (colour, depth)) in [(false, false), (true, false), (true, true), (false, true), (false, false), (true, true)].into_iter().enumerate() {
                let what = format!("{samples} samples, {backend:?}, colour {colour}, depth {depth}");
                let params = RenderParams { return_colour: colour, return_depth: depth, ..full.clone() };
                let once = render(&mesh, &params, backend).unwrap_or_else(|e| panic!("{what}: {e}"));
                prepared.render_into(&params, backend, &mut reused).unwrap_or_else(|e| panic!("{what}, prepared: {e}"));
                let kept = as_one_shot(reused.clone(), &once, &mesh, call > 0);
                for (form, frame) in [("render", &once), ("prepared", &kept)] {
                    let bits = |d: &[f32]| d.iter().map(|v| v.to_bits()).collect::<Vec<u32>>();
                    assert_eq!(frame.colour, if colour { reference.colour.clone() } else { Vec::new() }, "{what}, {form}: colour");
                    assert_eq!(bits(&frame.depth), if depth { bits(&reference.depth) } else { Vec::new() }, "{what}, {form}: depth");
                    assert!(frame.ids == reference.ids && frame.fragments == reference.fragments, "{what}, {form}: ids or fragments");
                    assert_eq!(frame.stats, reference.stats, "{what}, {form}: statistics");
                }
            }
        }
    }
}

/// A square of side 2 facing an orthographic camera 4 units wide in a 64 × 64 frame: exactly
/// the 32 × 32 pixels whose centres it holds, wherever the eye stands along the view.
fn square_facing_the_viewer() -> Mesh {
    Mesh {
        positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        normals: Some(vec![[0.0, 0.0, 1.0]; 4]),
        ..Default::default()
    }
}

/// Orthographic cameras: the matrix maps world units to pixels as the width says, the frame
/// is the same bits on both backends for every shading, and the viewer lies at infinity (a
/// plane facing the camera takes one colour under Phong shading, as it does not in
/// perspective).
#[test]
fn orthographic_cameras_frame_and_light_as_parallel_projections() {
    let square = square_facing_the_viewer();
    let ortho =
        |eye: [f64; 3]| Camera { eye, target: [0.0; 3], up: [0.0, 1.0, 0.0], projection: Projection::Orthographic { width: 4.0 }, near: 1.0, far: 20.0 };
    let lit = |camera: Camera, shading| RenderParams {
        shading,
        eye: Some(camera.viewer()),
        lights: vec![tileraster::render::Light { direction: [0.3, 0.2, 1.0], colour: [0.5, 0.5, 0.5] }],
        specular: [0.3, 0.3, 0.3],
        shininess: 8,
        ..RenderParams::new(64, 64, camera.view_projection(64, 64).unwrap())
    };
    for distance in [3.0, 10.0] {
        let frame = cpu(&square, &lit(ortho([0.0, 0.0, distance]), Shading::Phong));
        assert_eq!(frame.stats.pixels_covered, 32 * 32, "the square seen from {distance}");
        let covered: Vec<u32> = (0..frame.ids.len()).filter(|&k| frame.ids[k] != NO_FACE).map(|k| frame.colour[k]).collect();
        assert!(covered.iter().all(|&c| c == covered[0]), "Phong shading varies across a plane seen orthographically");
    }
    let perspective = Camera { projection: Projection::Perspective { fov_deg: 60.0 }, ..ortho([0.0, 0.0, 3.0]) };
    let frame = cpu(&square, &lit(perspective, Shading::Phong));
    let colours: std::collections::HashSet<u32> = (0..frame.ids.len()).filter(|&k| frame.ids[k] != NO_FACE).map(|k| frame.colour[k]).collect();
    assert!(colours.len() > 10, "in perspective the highlight moves across the plane: {} colours", colours.len());

    // A sphere seen orthographically from an oblique eye, every shading, both backends.
    let sphere = meshes::sphere([0.2, -0.1, 0.3], 1.0, 12, 18);
    let oblique = Camera { eye: [2.5, -2.0, 1.5], up: [0.0, 0.0, 1.0], ..ortho([0.0; 3]) }.fit_orthographic(&sphere, 4.0 / 3.0);
    assert!(matches!(oblique.projection, Projection::Orthographic { width } if width > 2.0 && width < 5.0), "{:?}", oblique.projection);
    for shading in Shading::ALL {
        let params = RenderParams { cull: Cull::Back, ..lit(oblique, shading) };
        let params = RenderParams { width: 96, height: 72, view_projection: oblique.view_projection(96, 72).unwrap(), ..params };
        let frame = assert_render_parity(&format!("orthographic sphere, {}", shading.name()), &sphere, &params);
        assert!(frame.stats.pixels_covered > 1000, "{}: {} pixels", shading.name(), frame.stats.pixels_covered);
    }
}

/// The viewer of a matrix given as it is: a perspective matrix's centre of projection, an
/// orthographic matrix's direction towards which the depth decreases (increases for a
/// reversed depth test), the same frame as the camera's own viewer gives.
#[test]
fn a_matrix_names_its_viewer() {
    let camera =
        Camera { eye: [2.0, -3.0, 1.0], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Orthographic { width: 3.0 }, near: 0.5, far: 9.0 };
    let m = camera.view_projection(80, 60).unwrap();
    let towards = [2.0, -3.0, 1.0].map(|c: f64| c / 14f64.sqrt());
    let close = |a: [f64; 3], b: [f64; 3]| (0..3).all(|c| (a[c] - b[c]).abs() < 1e-12);
    match Eye::of(&m, DepthFunc::Less) {
        Some(Eye::Direction(d)) => assert!(close(d, towards), "{d:?}"),
        other => panic!("an orthographic matrix's viewer: {other:?}"),
    }
    match Eye::of(&m, DepthFunc::Greater) {
        Some(Eye::Direction(d)) => assert!(close(d, towards.map(|c| -c)), "reversed depth: {d:?}"),
        other => panic!("an orthographic matrix's viewer, reversed depth: {other:?}"),
    }
    let perspective = Camera { projection: Projection::Perspective { fov_deg: 50.0 }, ..camera };
    match Eye::of(&perspective.view_projection(80, 60).unwrap(), DepthFunc::Less) {
        Some(Eye::Point(p)) => assert!((0..3).all(|c| (p[c] - camera.eye[c]).abs() < 1e-9), "{p:?}"),
        other => panic!("a perspective matrix's viewer: {other:?}"),
    }
    let sphere = meshes::sphere([0.0; 3], 1.0, 10, 14);
    let given = RenderParams { shading: Shading::Phong, eye: Some(camera.viewer()), ..RenderParams::new(80, 60, m) };
    let derived = RenderParams { eye: None, ..given.clone() };
    assert_same_frame("orthographic matrix: derived viewer vs the camera's", &cpu(&sphere, &given), &cpu(&sphere, &derived));
}

/// A glTF file posed by its animation (`common::skinned_gltf`: a skin and a morph target) at
/// several times, in perspective with every shading: the same bits on both backends, and each
/// time its own frame.
#[test]
fn a_posed_skinned_and_morphing_gltf_file_is_the_same_bits_on_both_backends() {
    let dir = std::env::temp_dir().join(format!("tileraster-render-posed-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = common::skinned_gltf(&dir);
    let camera = common::skinned_camera();
    let mut seen = std::collections::HashSet::new();
    for time in [None, Some(0.25), Some(0.5), Some(0.9)] {
        let mesh = tileraster::render::read_world_at(&path, time).unwrap().flattened().unwrap();
        for shading in [Shading::Smooth, Shading::Phong] {
            let params =
                RenderParams { shading, cull: Cull::None, eye: Some(camera.viewer()), ..RenderParams::new(96, 72, camera.view_projection(96, 72).unwrap()) };
            let frame = assert_render_parity(&format!("skinned glTF at {time:?} s, {}", shading.name()), &mesh, &params);
            assert!(frame.stats.pixels_covered > 500, "{time:?} s: {} pixels", frame.stats.pixels_covered);
            seen.insert(frame.colour);
        }
    }
    assert_eq!(seen.len(), 8, "every time and shading gives its own frame");
    std::fs::remove_dir_all(&dir).ok();
}

/// A camera 3 units in front of `square_facing_the_viewer`, looking at it.
fn camera_facing_the_square() -> Camera {
    Camera { eye: [0.0, 0.0, 3.0], target: [0.0; 3], up: [0.0, 1.0, 0.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 1.0, far: 20.0 }
}

/// `Stats::bytes_uploaded` of a frame, worked out by hand: the vertex stage's parameters and
/// positions, the assembly's parameters (the count's and the fill's), faces and vertex
/// attributes, and the shade parameters (no textures here); the assembly writes the records
/// and lists where the raster stages read them. A frame assembled apart from the GPU (here by
/// the CPU's twins) goes up with its records and lists whole, besides the raster's share and
/// one `FrameParams` uniform per dispatch (the setup's and the window's), measured where the
/// call writes them.
#[test]
fn a_frames_upload_is_counted_whole() {
    use tileraster_kernels::abi::{ATTRIBUTES, AssembleParams, FrameParams, RelativePosition, TriangleInput, TriangleShading, VertexParams};
    let square = square_facing_the_viewer();
    let camera = camera_facing_the_square();
    let params = RenderParams { eye: Some(camera.viewer()), ..RenderParams::new(64, 64, camera.view_projection(64, 64).unwrap()) };
    assert_eq!(std::mem::size_of::<FrameParams>(), 72, "the README's figure");
    // The shade parameters and the frame's one material (its own surface).
    let raster = (std::mem::size_of::<ShadeParams>() + std::mem::size_of::<tileraster_kernels::abi::MaterialRecord>()) as u64;
    // The vertex stage's (its parameters and the square's four positions), and the assembly's.
    let vertex = (std::mem::size_of::<VertexParams>() + 4 * std::mem::size_of::<RelativePosition>()) as u64;
    let faces = 2 * 3 * 4;
    let attributes = (4 * ATTRIBUTES * 4) as u64;
    // (The default shading, Gouraud, hands the light stage its parameters and the frame's lights.)
    assert_eq!(params.shading, Shading::Smooth);
    let light = tileraster_core::render::light_bytes();
    assert_eq!(light, (std::mem::size_of::<tileraster_kernels::abi::LightParams>() + std::mem::size_of::<ShadeParams>()) as u64);
    let assembly = 2 * std::mem::size_of::<AssembleParams>() as u64 + light + faces + attributes;
    let geometry = vertex + assembly;
    assert_eq!(square.positions.len(), 4);
    let frame = cpu(&square, &params);
    assert_eq!(frame.stats.geometry.bytes_uploaded, geometry);
    assert_eq!(frame.stats.raster.bytes_uploaded, raster + geometry);
    if gpu_or_skip("a_frames_upload_is_counted_whole") {
        let g = render(&square, &params, Backend::Gpu).unwrap();
        assert_eq!(g.stats.raster.bytes_uploaded, raster + geometry);
        // Assembled apart from the call, its records and lists go up whole (where the device
        // holds them, none: `tests/device_assembly.rs`).
        let (prepared, _) = prepare_render(&square, &params).unwrap();
        let plan = prepared.plan(prepared.window, false).unwrap();
        let records = 2 * (std::mem::size_of::<TriangleInput>() + std::mem::size_of::<TriangleShading>() + 4) as u64;
        let (_, apart) = tileraster_gpu::rasterise_profiled(&prepared, &plan, &mut None, false, None).unwrap();
        assert_eq!(apart.bytes_up, records + raster + 2 * std::mem::size_of::<FrameParams>() as u64, "{apart:?}");
    }
    // A prepared mesh hands its positions, faces and attributes over once: its later frames
    // hand over the stages' parameters alone, on either backend (with the frame's lights where
    // the kernels light: the light stage's under Gouraud shading, this frame's, and the fill's
    // under flat shading, whose face normals go over with the attributes the first time).
    let backends: &[Backend] = if gpu_or_skip("a_frames_upload_is_counted_whole (prepared)") { &[Backend::Cpu, Backend::Gpu] } else { &[Backend::Cpu] };
    let parameters = (std::mem::size_of::<VertexParams>() + 2 * std::mem::size_of::<AssembleParams>()) as u64;
    let lights = std::mem::size_of::<ShadeParams>() as u64;
    let face_normals = 2 * std::mem::size_of::<tileraster_kernels::abi::FaceNormal>() as u64;
    assert_eq!(params.shading, Shading::Smooth);
    for &backend in backends {
        let mut prepared = tileraster::render::PreparedMesh::new(square.clone()).unwrap();
        let first = prepared.render(&params, backend).unwrap();
        let later = prepared.render(&params, backend).unwrap();
        let unlit = RenderParams { shading: Shading::Unlit, ..params.clone() };
        let (first_unlit, later_unlit) = (prepared.render(&unlit, backend).unwrap(), prepared.render(&unlit, backend).unwrap());
        let flat = RenderParams { shading: Shading::Flat, ..params.clone() };
        let (first_flat, later_flat) = (prepared.render(&flat, backend).unwrap(), prepared.render(&flat, backend).unwrap());
        assert_eq!(first.stats.geometry.bytes_uploaded, geometry, "{backend:?}");
        assert_eq!(later.stats.geometry.bytes_uploaded, parameters + light, "{backend:?}");
        assert_eq!(first_unlit.stats.geometry.bytes_uploaded, parameters, "{backend:?}");
        assert_eq!(later_unlit.stats.geometry.bytes_uploaded, parameters, "{backend:?}");
        assert_eq!(first_flat.stats.geometry.bytes_uploaded, parameters + lights + attributes + face_normals, "{backend:?}");
        assert_eq!(later_flat.stats.geometry.bytes_uploaded, parameters + lights, "{backend:?}");
        assert_eq!((first.colour, first.ids, first.depth), (later.colour, later.ids, later.depth), "{backend:?}");
        assert_ne!(first_flat.colour, first_unlit.colour, "{backend:?}: flat shading lights the square");
        assert_eq!((first_unlit.colour, first_unlit.depth), (later_unlit.colour, later_unlit.depth), "{backend:?}");
        assert_eq!((first_flat.colour, first_flat.depth), (later_flat.colour, later_flat.depth), "{backend:?}");
    }
}

/// `prepare_render_observed` reports the geometry stages' passes once each, in order, and
/// prepares what `prepare_render` prepares.
#[test]
fn the_geometry_passes_are_reported_in_order() {
    use tileraster::render::{GeometryPass, prepare_render_observed};
    let square = square_facing_the_viewer();
    let camera = camera_facing_the_square();
    let params = RenderParams::new(64, 64, camera.view_projection(64, 64).unwrap());
    let mut passes = Vec::new();
    let (observed, counts) = prepare_render_observed(&square, &params, Backend::Cpu, &mut |pass| passes.push(pass)).unwrap();
    assert_eq!(passes, GeometryPass::ALL);
    let (plain, plain_counts) = prepare_render(&square, &params).unwrap();
    assert_eq!((observed.triangles, observed.render), (plain.triangles, plain.render));
    assert_eq!(counts, plain_counts);
}

/// Faces with a corner at or near the centre of projection (clip-space `x = y = w = 0`), under
/// a matrix whose near plane passes through it: the points clipping makes there come from
/// differences of nearly equal numbers, and must still snap inside the guard band (else the
/// kernels' 64-bit edge functions overflow) with a finite `1/w` and depth in `[0, 1]`, the same
/// bits on both backends. (Before the points were taken onto the planes, 230 of the corners
/// below lay beyond the band and 1782 had an infinite `1/w`.)
#[test]
fn clipped_points_near_the_centre_of_projection_stay_in_the_guard_band() {
    // clip = (x, y, z/2, z): the near plane z = 0 is w = 0, through the eye at the origin.
    let m = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.5, 0.0], [0.0, 0.0, 1.0, 0.0]];
    let (w, h) = (64u32, 48u32);
    let (unit, guard) = ((1u64 << RENDER_SNAP_BITS) as f64, GUARD_PX);
    let (low, high) = (-guard * unit, [(w as f64 + guard) * unit, (h as f64 + guard) * unit]);
    let mut state = 0x9e37_79b9_7f4a_7c15u64;
    let mut next = move || {
        state = state.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = state;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let mut positions = Vec::new();
    let mut triangles = Vec::new();
    for k in 0..4000u32 {
        let scale = [0.0, 1e-300, 1e-40, 1e-30, 1e-20, 1e-12, 1e-6][k as usize % 7];
        let near = [next() * scale, next() * scale, next().abs() * scale * if k % 3 == 0 { -1.0 } else { 1.0 }];
        let far = |z: f64, a: f64, b: f64| [a * 3.0 * z, b * 3.0 * z, z];
        let (z1, z2) = (0.5 + 4.0 * next().abs(), 0.5 + 4.0 * next().abs());
        let v1 = far(z1, next(), next());
        let v2 = far(z2, next(), next());
        positions.extend([near, v1, v2]);
        triangles.push([3 * k, 3 * k + 1, 3 * k + 2]);
    }
    let mesh = Mesh { positions, triangles, ..Default::default() };
    // Lit per vertex (the host's assembly) and face ids (the kernels').
    for shading in [Shading::Smooth, Shading::Ids] {
        let params = RenderParams { cull: Cull::None, shading, ..RenderParams::new(w, h, m) };
        corners_stay_in_the_guard_band(&mesh, &params, low, high);
    }
}

fn corners_stay_in_the_guard_band(mesh: &Mesh, params: &RenderParams, low: f64, high: [f64; 2]) {
    let (mesh, params) = (mesh.clone(), params.clone());
    let (prepared, counts) = prepare_render(&mesh, &params).unwrap_or_else(|e| panic!("{e}"));
    assert!(counts.clipped > 1000, "{} faces clipped", counts.clipped);
    let shading = &prepared.render.as_ref().expect("a render frame").triangles;
    for (t, s) in prepared.triangles.iter().zip(shading) {
        for v in 0..3 {
            let (x, y) = (t.x[v] as f64, t.y[v] as f64);
            assert!(x >= low && y >= low && x <= high[0] && y <= high[1], "face {}: corner ({x}, {y}) beyond the guard band", s.face);
            assert!(s.inv_w[v].is_finite() && s.inv_w[v] > 0.0, "face {}: 1/w = {}", s.face, s.inv_w[v]);
        }
    }
    let frame = assert_render_parity(&format!("corners near the centre of projection, {}", params.shading.name()), &mesh, &params);
    assert!(frame.depth.iter().all(|d| (0.0..=1.0).contains(d) || d.to_bits() == params.clear_depth.to_bits()), "every depth in [0, 1]");
    assert!(frame.ids.iter().any(|&id| id != NO_FACE), "the faces cover pixels");
}

/// Faces the kernels assemble meet the faces the host clips without a crack or a double hit:
/// a flat grid seen from just above it, cut by the near plane under the camera and by the far
/// plane ahead, covers every pixel centre below the far plane's line exactly once, column by
/// column down to the bottom row, the same bits on both backends.
#[test]
fn kernel_assembled_faces_meet_host_clipped_faces_without_a_crack() {
    let mesh = meshes::terrain(120, 400.0, 0.0);
    let (w, h) = (180u32, 120u32);
    for (eye, target) in [([200.0, 200.0, 1.0], [300.0, 260.0, 1.0]), ([201.3, 197.9, 0.4], [180.0, 270.0, -3.0])] {
        let camera = Camera { eye, target, up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.3, far: 80.0 };
        let view = camera.view_projection(w, h).unwrap();
        // Host-clipped corners carry the stage's values as kept faces do: every shading's
        // attributes meet at the seam (lit per vertex and per face, flat interpolation).
        for (shading, interpolation) in
            [(Shading::Flat, Interpolation::Flat), (Shading::Smooth, Interpolation::Perspective), (Shading::Phong, Interpolation::Flat)]
        {
            let params = RenderParams { cull: Cull::None, shading, interpolation, eye: Some(Eye::Point(eye)), ..RenderParams::new(w, h, view) };
            assert_render_parity(&format!("a grid from {eye:?}, {}", shading.name()), &mesh, &params);
        }
        let params = RenderParams { cull: Cull::None, shading: Shading::Ids, ..RenderParams::new(w, h, view) };
        let frame = assert_render_parity(&format!("a grid from {eye:?}"), &mesh, &params);
        let g = frame.stats.geometry;
        assert!(g.clipped > 10 && g.rasterised > 100, "{eye:?}: {g:?}");
        for i in 0..w as usize {
            let column: Vec<u32> = (0..h as usize).map(|j| frame.fragments[j * w as usize + i]).collect();
            let first = column.iter().position(|&f| f != 0).unwrap_or_else(|| panic!("{eye:?}: column {i} is empty"));
            assert!(first > 0 && first < h as usize / 2 + 20, "{eye:?}: column {i} starts at row {first}");
            if let Some(j) = (first..h as usize).find(|&j| column[j] != 1) {
                panic!("{eye:?}: pixel ({i}, {j}) is inside {} faces (the run starts at row {first})", column[j]);
            }
        }
    }
}
