//! Instances and object culling: a world of placed meshes renders as the one mesh its
//! instances flatten to, bit for bit, on both backends; culling instances outside the view
//! frustum changes no bit and is counted; bad instances are typed errors.

mod common;

use common::gpu_or_skip;
use tileraster::render::{Camera, Cull, DepthFunc, Frame, GeometryCounts, Instance, Mesh, Projection, RenderParams, Shading, Up, World, render, render_world};
use tileraster::{Backend, Error, Skips};
use tileraster_testkit::meshes;

fn frame(world: &World, params: &RenderParams, backend: Backend) -> Frame {
    render_world(world, params, backend).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

/// Panics unless the frames have the same bits in every layer.
fn assert_same_layers(what: &str, a: &Frame, b: &Frame) {
    let differing = (0..a.colour.len())
        .filter(|&k| {
            a.colour[k] != b.colour[k] || a.depth[k].to_bits() != b.depth[k].to_bits() || a.ids[k] != b.ids[k] || a.fragments.get(k) != b.fragments.get(k)
        })
        .count();
    assert_eq!(differing, 0, "{what}: {differing} pixels differ");
    assert_eq!(a.fragments.len(), b.fragments.len(), "{what}: fragment layers");
}

/// The geometry counts without the instance counts (a flattened world is one instance).
fn faces_only(g: &GeometryCounts) -> GeometryCounts {
    // (And not the upload: each placement hands the assembly its own parameters and faces.)
    GeometryCounts { instances_culled: 0, instances_drawn: 0, bytes_uploaded: 0, ..*g }
}

fn translate(x: f64, y: f64, z: f64) -> [[f64; 4]; 4] {
    [[1.0, 0.0, 0.0, x], [0.0, 1.0, 0.0, y], [0.0, 0.0, 1.0, z], [0.0, 0.0, 0.0, 1.0]]
}

/// Two meshes (a coloured sphere with normals, a box-like soup without) placed five times:
/// moved, turned, scaled unevenly and mirrored.
fn mixed_world() -> World {
    let mut sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 10, 16);
    sphere.colours = Some((0..sphere.positions.len()).map(|k| [(k % 7) as f32 / 7.0, 0.5, (k % 3) as f32 / 3.0, 1.0]).collect());
    sphere.normals = Some(tileraster::render::face_normals(&sphere));
    let mut soup = meshes::soup(60, [-0.8, -0.8, -0.8], [0.8, 0.8, 0.8], 0.7, 3);
    // Textured faces (every other one), so that the flattened mesh must carry the textures.
    soup.uvs = Some(soup.positions.iter().map(|p| [p[0] as f32 * 2.0, p[1] as f32 * 3.0]).collect());
    let texels: Vec<u8> = (0..8 * 8 * 4).map(|k| (k * 37 % 251) as u8).collect();
    soup.textures = vec![tileraster::render::Texture::srgb(8, 8, texels)];
    soup.face_textures = Some((0..soup.triangles.len() as u32).map(|k| if k % 2 == 0 { 0 } else { tileraster::render::NO_TEXTURE }).collect());
    let (c, s) = (0.6f64.cos(), 0.6f64.sin());
    let turned = [[c, -s, 0.0, 1.5], [s, c, 0.0, -0.5], [0.0, 0.0, 1.0, 0.2], [0.0, 0.0, 0.0, 1.0]];
    let uneven = [[0.5, 0.0, 0.0, -1.6], [0.0, 1.3, 0.0, 0.4], [0.0, 0.0, 0.8, -0.3], [0.0, 0.0, 0.0, 1.0]];
    let mirrored = [[-1.0, 0.0, 0.0, 0.3], [0.0, 1.0, 0.0, 1.7], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]];
    World {
        meshes: vec![sphere, soup],
        instances: vec![
            Instance::of(0),
            Instance { mesh: 1, transform: turned },
            Instance { mesh: 0, transform: uneven },
            Instance { mesh: 1, transform: mirrored },
            Instance { mesh: 0, transform: translate(0.2, -1.8, 0.5) },
        ],
    }
}

/// Every instance's faces, in order, are the flattened mesh's faces: colour, depth, ids and
/// fragments are the same bits, for lit, flat-shaded, unlit and id frames with back faces
/// culled (the mirrored instance keeps its front faces in front), on both backends.
#[test]
fn a_world_renders_as_its_flattened_mesh() {
    let world = mixed_world();
    let flat = world.flattened().unwrap();
    let gpu = gpu_or_skip("a_world_renders_as_its_flattened_mesh");
    let camera = Camera {
        eye: [3.0, -5.0, 3.5],
        target: [0.0, 0.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 50.0 },
        near: 0.5,
        far: 20.0,
    };
    let (w, h) = (171, 133);
    for shading in [Shading::Phong, Shading::Flat, Shading::Smooth, Shading::Ids] {
        let params = RenderParams { shading, eye: Some(camera.viewer()), ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap()) };
        let instanced = frame(&world, &params, Backend::Cpu);
        let flattened = render(&flat, &params, Backend::Cpu).unwrap();
        let what = shading.name().to_string();
        assert_same_layers(&format!("{what}: world vs flattened"), &instanced, &flattened);
        assert_eq!(faces_only(&instanced.stats.geometry), faces_only(&flattened.stats.geometry), "{what}: geometry counts");
        assert_eq!(instanced.stats.geometry.instances_drawn, 5, "{what}");
        // Every instance shows: its faces' ids are on the screen.
        let first_faces: Vec<u32> = world
            .instances
            .iter()
            .scan(0, |n, i| {
                let f = *n;
                *n += world.meshes[i.mesh as usize].triangles.len() as u32;
                Some(f)
            })
            .collect();
        for (k, pair) in first_faces.windows(2).enumerate() {
            assert!(instanced.ids.iter().any(|&id| id >= pair[0] && id < pair[1]), "{what}: instance {k} is not on the screen");
        }
        if gpu {
            let g = frame(&world, &params, Backend::Gpu);
            assert_same_layers(&format!("{what}: CPU vs GPU"), &instanced, &g);
            assert_eq!(instanced.stats, g.stats, "{what}: statistics");
        }
    }
}

/// A 30 × 30 field of spheres seen from close by: most instances lie outside the frustum and
/// are culled before any vertex work, and the frame is what it is without the culling, on both
/// backends; the culled instances' faces are in no face count.
#[test]
fn culling_instances_changes_no_bit() {
    let sphere = meshes::sphere([0.0, 0.0, 0.0], 0.4, 6, 10);
    let transforms: Vec<[[f64; 4]; 4]> = (0..900).map(|k| translate((k % 30) as f64, (k / 30) as f64, 0.0)).collect();
    let world = World::instanced(sphere, &transforms);
    let camera = Camera {
        eye: [2.0, -3.0, 2.5],
        target: [4.0, 3.0, 0.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 45.0 },
        near: 0.3,
        far: 7.0,
    };
    let (w, h) = (160, 120);
    let gpu = gpu_or_skip("culling_instances_changes_no_bit");
    // The depth view ranges over the visible vertices, and a less-or-equal test passes a face
    // at the far plane's depth: neither sees the culled instances.
    for (cull, shading, depth_func) in
        [(Cull::Back, Shading::Phong, DepthFunc::Less), (Cull::None, Shading::Phong, DepthFunc::Less), (Cull::None, Shading::Depth, DepthFunc::LessEqual)]
    {
        let view = camera.view_projection(w, h).unwrap();
        let on = RenderParams { cull, shading, depth_func, eye: Some(camera.viewer()), ..RenderParams::new(w, h, view) };
        let off = RenderParams { skips: Skips { cull_instances: false, ..Skips::ALL }, ..on.clone() };
        let (a, b) = (frame(&world, &on, Backend::Cpu), frame(&world, &off, Backend::Cpu));
        assert_same_layers(&format!("{cull:?}: culling on vs off"), &a, &b);
        let (g_on, g_off) = (a.stats.geometry, b.stats.geometry);
        assert_eq!((g_on.instances_culled + g_on.instances_drawn, g_off.instances_drawn, g_off.instances_culled), (900, 900, 0), "{cull:?}");
        assert!(g_on.instances_culled > 800 && g_on.instances_drawn >= 10, "{cull:?}: {g_on:?}");
        assert_eq!(g_on.rasterised, g_off.rasterised, "{cull:?}");
        assert!(g_on.culled_frustum < g_off.culled_frustum, "{cull:?}: the culled instances' faces are not counted one by one");
        if gpu {
            let g = frame(&world, &on, Backend::Gpu);
            assert_same_layers(&format!("{cull:?}: CPU vs GPU"), &a, &g);
            assert_eq!(a.stats, g.stats, "{cull:?}: statistics");
        }
        // One instance left by the culling: still a world's frame, the same bits as without it.
        let two = World { instances: vec![world.instances[3], world.instances[899]], ..world.clone() };
        let (a, b) = (frame(&two, &on, Backend::Cpu), frame(&two, &off, Backend::Cpu));
        assert_eq!((a.stats.geometry.instances_drawn, a.stats.geometry.instances_culled), (1, 1), "{cull:?}");
        assert_same_layers(&format!("{cull:?}: one instance left, culling on vs off"), &a, &b);
        assert!(a.stats.pixels_covered > 100, "{cull:?}: the instance left is on the screen");
    }
}

#[test]
fn bad_instances_are_typed_errors() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 4, 6);
    let params = RenderParams::new(32, 32, Camera::framing(&mesh, 1.0, Projection::Perspective { fov_deg: 45.0 }, Up::Y).view_projection(32, 32).unwrap());
    let with = |instances: Vec<Instance>| render_world(&World { meshes: vec![mesh.clone()], instances }, &params, Backend::Cpu).map(|_| ());
    assert!(matches!(with(vec![]), Err(Error::EmptyScene { what: "instances" })));
    let e = with(vec![Instance::of(0), Instance::of(3)]).unwrap_err();
    assert!(matches!(e, Error::InvalidInstance { instance: 1, .. }) && e.to_string().contains("mesh 3"), "{e}");
    let mut t = translate(1.0, 2.0, 3.0);
    t[1][2] = f64::NAN;
    let e = with(vec![Instance { mesh: 0, transform: t }]).unwrap_err();
    assert!(matches!(e, Error::InvalidInstance { instance: 0, .. }) && e.to_string().contains("row 1, column 2"), "{e}");
    let mut t = translate(1.0, 2.0, 3.0);
    t[3][0] = 0.5;
    let e = with(vec![Instance { mesh: 0, transform: t }]).unwrap_err();
    assert!(e.to_string().contains("affine"), "{e}");
    let bad_mesh = Mesh { triangles: vec![[0, 1, 100_000]], ..mesh.clone() };
    let e = render_world(&World { meshes: vec![mesh.clone(), bad_mesh], instances: vec![Instance::of(0)] }, &params, Backend::Cpu).map(|_| ()).unwrap_err();
    assert!(matches!(e, Error::IndexOutOfRange { .. }), "{e}");
}
