//! Materials: each face's surface (its metallic and roughness factors, double-sided, its alpha
//! mode, unlit) the same bits on both backends, through the kernels' assembly and the host's
//! clipping, and each doing what it says.

mod common;

use common::assert_frame_parity;
use tileraster::render::{AlphaMode, Camera, Cull, Frame, Light, Material, Mesh, NO_FACE, Projection, RenderParams, Shading, World};
use tileraster_testkit::meshes;

/// A camera on the +z axis looking at the origin.
fn from_above(width: u32, height: u32) -> [[f64; 4]; 4] {
    Camera { eye: [0.0, 0.0, 3.0], target: [0.0; 3], up: [0.0, 1.0, 0.0], projection: Projection::Perspective { fov_deg: 60.0 }, near: 0.5, far: 10.0 }
        .view_projection(width, height)
        .unwrap()
}

/// A square in the plane z = 0 seen from above: facing the camera (counter-clockwise, normals
/// +z), or its back (clockwise, normals −z: the side away from the camera).
fn square(facing: bool) -> Mesh {
    let (triangles, normal) = match facing {
        true => (vec![[0, 1, 2], [0, 2, 3]], [0.0, 0.0, 1.0]),
        false => (vec![[0, 2, 1], [0, 3, 2]], [0.0, 0.0, -1.0]),
    };
    Mesh {
        positions: vec![[-1.0, -1.0, 0.0], [1.0, -1.0, 0.0], [1.0, 1.0, 0.0], [-1.0, 1.0, 0.0]],
        triangles,
        normals: Some(vec![normal; 4]),
        colours: Some(vec![[0.9, 0.6, 0.3, 1.0]; 4]),
        ..Default::default()
    }
}

fn with_material(mut mesh: Mesh, material: Material) -> Mesh {
    mesh.materials = vec![material];
    mesh
}

/// A light over the square, a little to one side so that the frame is not uniform.
fn lit(shading: Shading) -> RenderParams {
    let light = Light { direction: [0.3, 0.2, 1.0], colour: [1.0, 1.0, 1.0] };
    RenderParams { shading, lights: vec![light], ambient: [0.1, 0.1, 0.1], ..RenderParams::new(64, 48, from_above(64, 48)) }
}

fn drawn(frame: &Frame) -> usize {
    frame.ids.iter().filter(|&&id| id != NO_FACE).count()
}

fn brightness(frame: &Frame) -> u64 {
    frame.colour.iter().map(|&c| (c & 0xff) as u64 + (c >> 8 & 0xff) as u64 + (c >> 16 & 0xff) as u64).sum()
}

/// A double-sided material's faces are kept whatever the frame culls, and their backs are lit
/// with the normal turned round: the square's back, whose normals point away from the camera,
/// looks as its front does (to a unit of rounding: the corners come in another order). A
/// single-sided back face is culled, or drawn dark with `Cull::None`.
#[test]
fn a_double_sided_material_keeps_its_back_faces_and_lights_them_turned_round() {
    let single = Material { double_sided: false, ..Material::PLAIN };
    let double = Material { double_sided: true, ..Material::PLAIN };
    for shading in [Shading::Phong, Shading::Pbr] {
        let params = lit(shading);
        let front = assert_frame_parity(&format!("{shading:?}, front"), &with_material(square(true), single), &params);
        assert!(drawn(&front) > 500, "{shading:?}: the square covers {} pixels", drawn(&front));
        let culled = assert_frame_parity(&format!("{shading:?}, single-sided back"), &with_material(square(false), single), &params);
        assert_eq!(drawn(&culled), 0, "{shading:?}: a single-sided back face is culled");
        for cull in [Cull::Back, Cull::Front, Cull::None] {
            let params = RenderParams { cull, ..params.clone() };
            let back = assert_frame_parity(&format!("{shading:?}, double-sided back, {cull:?}"), &with_material(square(false), double), &params);
            assert_eq!(back.ids.iter().map(|&id| id != NO_FACE).collect::<Vec<_>>(), front.ids.iter().map(|&id| id != NO_FACE).collect::<Vec<_>>());
            for (k, (&b, &f)) in back.colour.iter().zip(&front.colour).enumerate() {
                let close = (0..4).all(|c| ((b >> (8 * c) & 0xff) as i32 - (f >> (8 * c) & 0xff) as i32).abs() <= 1);
                assert!(close, "{shading:?}, {cull:?}: pixel {k} is {b:08x} on the back, {f:08x} on the front");
            }
        }
        // A frame that culls every face as it says culls the double-sided back too.
        let every = RenderParams { double_sided: false, ..params.clone() };
        let culled = assert_frame_parity(&format!("{shading:?}, double-sided back, culled"), &with_material(square(false), double), &every);
        assert_eq!(drawn(&culled), 0, "{shading:?}: double_sided false culls a double-sided back face");
        let params = RenderParams { cull: Cull::None, ..params.clone() };
        let dark = assert_frame_parity(&format!("{shading:?}, single-sided back drawn"), &with_material(square(false), single), &params);
        assert_eq!(drawn(&dark), drawn(&front));
        assert!(brightness(&dark) * 2 < brightness(&front), "{shading:?}: a single-sided back is lit with its own normal, away from the light");
    }
}

/// Four materials on the faces of one sphere: each face looks exactly as it does where every
/// face takes its material. Opaque surfaces take alpha 1, blended ones keep the colours'; an
/// unlit surface shows its base colour; the factors change the light.
#[test]
fn each_face_takes_its_own_material() {
    let mut sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 16, 24);
    sphere.colours = Some(vec![[0.8, 0.5, 0.2, 0.5]; sphere.positions.len()]);
    let materials = [
        Material { metallic: 0.0, roughness: 0.5, ..Material::default() },
        Material { metallic: 1.0, roughness: 0.2, ..Material::default() },
        Material { unlit: true, alpha: AlphaMode::Blend, ..Material::default() },
        Material { metallic: 0.3, roughness: 0.9, alpha: AlphaMode::Blend, ..Material::default() },
    ];
    let params = RenderParams { width: 96, height: 96, view_projection: from_above(96, 96), ..lit(Shading::Pbr) };
    let faces = sphere.triangles.len();
    let mixed = Mesh { materials: materials.to_vec(), face_materials: Some((0..faces as u32).map(|f| f % 4).collect()), ..sphere.clone() };
    let frame = assert_frame_parity("four materials", &mixed, &params);
    let alone: Vec<Frame> =
        materials.iter().enumerate().map(|(k, m)| assert_frame_parity(&format!("material {k} alone"), &with_material(sphere.clone(), *m), &params)).collect();
    let unlit = assert_frame_parity("unlit shading", &sphere, &RenderParams { shading: Shading::Unlit, ..params.clone() });
    let mut seen = [0usize; 4];
    for (k, &id) in frame.ids.iter().enumerate().filter(|(_, id)| **id != NO_FACE) {
        let m = id as usize % 4;
        seen[m] += 1;
        assert_eq!(frame.colour[k], alone[m].colour[k], "pixel {k} of face {id} (material {m})");
        let alpha = frame.colour[k] >> 24;
        assert_eq!(alpha == 255, materials[m].alpha == AlphaMode::Opaque, "pixel {k}, material {m}: alpha {alpha}");
        if materials[m].unlit {
            assert_eq!(frame.colour[k], unlit.colour[k], "pixel {k}: an unlit material shows its base colour");
        }
    }
    assert!(seen.iter().all(|&n| n > 200), "pixels of each material: {seen:?}");
    let differing = (0..frame.colour.len()).filter(|&k| alone[0].colour[k] != alone[1].colour[k]).count();
    assert!(differing > 1000, "metallic and roughness change the light: {differing} pixels differ");
}

/// A masked material (glTF's `MASK`) in a frame that blends: where its alpha falls short of the
/// cutoff its fragments are discarded, colour and depth, and the square behind it shows; where
/// it reaches the cutoff it is opaque. Drawn first, so that a depth it wrote would hide the
/// square behind. A blended material instead covers the whole square, partly transparent; a
/// frame that does not blend keeps the masked fragments, transparent.
#[test]
fn a_masked_material_discards_what_its_cutoff_cuts() {
    // The masked square at z = 0.5, its alpha 0 at the left and 1 at the right; then an
    // opaque one at z = 0.
    let mut mesh = square(true);
    mesh.positions.iter_mut().for_each(|p| p[2] = 0.5);
    mesh.colours = Some(vec![[0.9, 0.6, 0.3, 0.0], [0.9, 0.6, 0.3, 1.0], [0.9, 0.6, 0.3, 1.0], [0.9, 0.6, 0.3, 0.0]]);
    let behind = square(true);
    mesh.positions.extend(&behind.positions);
    mesh.triangles.extend(behind.triangles.iter().map(|t| t.map(|v| v + 4)));
    mesh.normals.as_mut().unwrap().extend(behind.normals.as_ref().unwrap());
    mesh.colours.as_mut().unwrap().extend([[0.1, 0.2, 0.9, 1.0]; 4]);
    let masked = Material { alpha: AlphaMode::Mask { cutoff: 0.5 }, ..Material::PLAIN };
    mesh.materials = vec![masked, Material { alpha: AlphaMode::Opaque, ..Material::PLAIN }];
    mesh.face_materials = Some(vec![0, 0, 1, 1]);
    let params = RenderParams { blend: true, ..lit(Shading::Pbr) };
    let frame = assert_frame_parity("masked over opaque, blended", &mesh, &params);
    let blended = Mesh { materials: vec![Material { alpha: AlphaMode::Blend, ..Material::PLAIN }, mesh.materials[1]], ..mesh.clone() };
    let through = assert_frame_parity("blended over opaque", &blended, &params);
    // (The nearer square is the larger on the screen: where it is cut, the background may show.)
    let (mut cut, mut kept) = (0, 0);
    for k in (0..frame.ids.len()).filter(|&k| through.ids[k] < 2) {
        if frame.ids[k] < 2 {
            kept += 1;
            assert_eq!(frame.colour[k] >> 24, 255, "pixel {k}: a masked fragment kept is opaque");
        } else {
            cut += 1;
        }
    }
    assert!((0..frame.ids.len()).all(|k| through.ids[k] < 2 || frame.ids[k] == through.ids[k]), "the mask changes only its own pixels");
    assert!(cut > 100 && kept > 100, "{cut} pixels cut, {kept} kept");
    let unblended = assert_frame_parity("masked over opaque, not blended", &mesh, &RenderParams { blend: false, ..params.clone() });
    let transparent = (0..unblended.ids.len()).filter(|&k| unblended.ids[k] < 2 && unblended.colour[k] >> 24 == 0).count();
    assert_eq!(transparent, cut, "without blending the cut fragments stay, transparent");
}

/// A material's emission adds to the light: without lights a sphere is black but for it.
#[test]
fn emission_adds_to_the_light() {
    let sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 12, 16);
    let dark = RenderParams { lights: Vec::new(), ambient: [0.0; 3], ..lit(Shading::Pbr) };
    let glowing = with_material(sphere.clone(), Material { emissive: [0.2, 0.4, 0.0], ..Material::PLAIN });
    let frame = assert_frame_parity("emissive sphere in the dark", &glowing, &dark);
    let unlit = assert_frame_parity("sphere in the dark", &with_material(sphere, Material::PLAIN), &dark);
    let covered: Vec<usize> = (0..frame.ids.len()).filter(|&k| frame.ids[k] != NO_FACE).collect();
    assert!(covered.len() > 500);
    for &k in &covered {
        assert_eq!(unlit.colour[k] & 0xffffff, 0, "pixel {k}: no light, no colour");
        assert_eq!(frame.colour[k] & 0xffffff, 51 | 102 << 8, "pixel {k}: the emission, 0.2 and 0.4 of 255");
    }
}

/// A material's textures besides the base colour's, sampled where the base colour's is: the
/// metallic-roughness texture scales the factors by its blue and green (a frame of a material
/// without it and the texel's factors gives the same pixels), the occlusion texture's red the
/// ambient light (strength 0.5 over a black texel: the ambient light halved), the emissive
/// texture the emission.
#[test]
fn a_materials_textures_scale_its_factors_occlusion_and_emission() {
    use tileraster::render::{Address, Filter, Texture};
    use tileraster_kernels::programs::texture::unit;
    let texture = |width: u32, rgba: Vec<u8>, srgb: bool| Texture {
        width,
        height: 1,
        rgba,
        srgb,
        filter: Filter::Nearest,
        address_u: Address::ClampToEdge,
        address_v: Address::ClampToEdge,
    };
    let mut mesh = square(true);
    mesh.uvs = Some(vec![[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]);
    // Metallic-roughness: the left half rough and not metallic, the right half smoother and
    // metallic; occlusion: no ambient light; emission: white.
    mesh.textures = vec![texture(2, vec![0, 255, 0, 255, 0, 50, 255, 255], false), texture(1, vec![0, 0, 0, 255], false), texture(1, vec![255; 4], true)];
    // (None of them the faces' base colour, which would be texture 0 by default.)
    mesh.face_textures = Some(vec![tileraster::render::NO_TEXTURE; 2]);
    let params = lit(Shading::Pbr);
    let textured = Material { metallic: 1.0, roughness: 0.8, metallic_roughness_texture: Some(0), ..Material::PLAIN };
    let frame = assert_frame_parity("metallic-roughness texture", &with_material(mesh.clone(), textured), &params);
    let halves = [(unit(0), unit(255 * 257)), (unit(255 * 257), unit(50 * 257))];
    let [left, right] = halves.map(|(metallic, roughness)| {
        let factors = Material { metallic: 1.0 * metallic, roughness: 0.8 * roughness, ..Material::PLAIN };
        assert_frame_parity("the texel's factors", &with_material(mesh.clone(), factors), &params)
    });
    let centre = params.width as usize / 2;
    let mut compared = 0;
    for k in (0..frame.ids.len()).filter(|&k| frame.ids[k] != NO_FACE) {
        let x = k % params.width as usize;
        if x + 2 < centre || x > centre + 1 {
            let reference = if x < centre { &left } else { &right };
            assert_eq!(frame.colour[k], reference.colour[k], "pixel {k}");
            compared += 1;
        }
    }
    assert!(compared > 500 && left.colour != right.colour, "{compared} pixels compared");
    // Occlusion.
    let dim = RenderParams { lights: Vec::new(), ..params.clone() };
    let occluded = Material { occlusion_texture: Some(1), occlusion_strength: 0.5, ..Material::PLAIN };
    let frame = assert_frame_parity("occlusion texture", &with_material(mesh.clone(), occluded), &dim);
    let halved = RenderParams { ambient: dim.ambient.map(|a| a * 0.5), ..dim.clone() };
    let reference = assert_frame_parity("ambient halved", &with_material(mesh.clone(), Material::PLAIN), &halved);
    assert_eq!(frame.colour, reference.colour, "strength 0.5 of a black occlusion texel halves the ambient light");
    assert!(frame.colour.iter().any(|&c| c & 0xff != 0), "some ambient light remains");
    // Emission.
    let dark = RenderParams { ambient: [0.0; 3], ..dim };
    let glowing = Material { emissive: [0.2, 0.4, 0.0], ..Material::PLAIN };
    let frame = assert_frame_parity("emissive texture", &with_material(mesh.clone(), Material { emissive_texture: Some(2), ..glowing }), &dark);
    let reference = assert_frame_parity("emission alone", &with_material(mesh.clone(), glowing), &dark);
    assert_eq!(frame.colour, reference.colour, "a white emissive texture keeps the emission");
    // A texture index beyond the mesh's is refused.
    let bad = with_material(mesh, Material { emissive_texture: Some(3), ..Material::PLAIN });
    let error = tileraster::render::render(&bad, &params, tileraster::Backend::Cpu).map(|_| ()).unwrap_err();
    assert_eq!(error.to_string(), "texture 3: material 0's emissive texture, but the mesh has 3 textures");
}

/// Faces the host clips (across the near plane) and faces the kernels assemble take their
/// materials alike: a terrain seen from inside it, its faces single- and double-sided, the
/// same bits on both backends and the same frame as the faces drawn without the kernels'
/// assembly (a frame that draws a placed world in two instances).
#[test]
fn clipped_faces_and_instances_take_their_materials() {
    let mut terrain = meshes::terrain(24, 100.0, 12.0);
    terrain.materials = vec![
        Material { double_sided: true, ..Material::PLAIN },
        Material { metallic: 0.7, roughness: 0.3, ..Material::PLAIN },
        Material { unlit: true, ..Material::PLAIN },
    ];
    terrain.face_materials = Some((0..terrain.triangles.len() as u32).map(|f| (f * 7 / 3) % 3).collect());
    let camera = Camera {
        eye: [50.0, 50.0, 3.0],
        target: [90.0, 70.0, -2.0],
        up: [0.0, 0.0, 1.0],
        projection: Projection::Perspective { fov_deg: 70.0 },
        near: 0.3,
        far: 60.0,
    };
    let params = RenderParams { shading: Shading::Pbr, cull: Cull::Back, ..RenderParams::new(160, 120, camera.view_projection(160, 120).unwrap()) };
    let frame = assert_frame_parity("terrain from inside", &terrain, &params);
    assert!(frame.stats.geometry.clipped > 0, "faces cross the near plane");
    assert!(drawn(&frame) > 5000);
    // Two instances: a world the frame flattens takes each mesh's materials in turn.
    let world = World::instanced(terrain.clone(), &[tileraster::render::IDENTITY; 2]);
    let flat = world.flattened().unwrap();
    assert_eq!(flat.materials, terrain.materials, "a mesh's materials once");
    assert_eq!(flat.face_materials.as_ref().unwrap()[..terrain.triangles.len()], terrain.face_materials.as_ref().unwrap()[..]);
    assert_eq!(flat.face_materials.as_ref().unwrap()[terrain.triangles.len()..], terrain.face_materials.as_ref().unwrap()[..]);
}

/// A flattened world's materials name their textures in the flattened mesh's list: each mesh's
/// textures follow the meshes' before it.
#[test]
fn a_flattened_worlds_materials_keep_their_textures() {
    use tileraster::render::{IDENTITY, Instance, Texture};
    let textured = |value: u8| Mesh {
        textures: vec![Texture::srgb(1, 1, vec![value; 4])],
        face_textures: Some(vec![tileraster::render::NO_TEXTURE; 2]),
        ..with_material(square(true), Material { emissive: [1.0; 3], emissive_texture: Some(0), ..Material::PLAIN })
    };
    let world = World {
        meshes: vec![textured(10), textured(200)],
        instances: vec![Instance { mesh: 0, transform: IDENTITY }, Instance { mesh: 1, transform: IDENTITY }],
    };
    let flat = world.flattened().unwrap();
    assert_eq!(flat.materials.iter().map(|m| m.emissive_texture).collect::<Vec<_>>(), vec![Some(0), Some(1)]);
    assert_eq!(flat.textures[1].rgba[0], 200);
}

/// Bad materials are typed errors naming the material or the face.
#[test]
fn bad_materials_are_typed_errors() {
    let mesh = with_material(square(true), Material { roughness: 1.5, ..Material::PLAIN });
    let error = tileraster::render::render(&mesh, &lit(Shading::Pbr), tileraster::Backend::Cpu).map(|_| ()).unwrap_err();
    assert_eq!(error.to_string(), "material 0's roughness is 1.5: give a number from 0 to 1");
    let mesh = Mesh { face_materials: Some(vec![0, 1]), ..with_material(square(true), Material::PLAIN) };
    let error = tileraster::render::render(&mesh, &lit(Shading::Pbr), tileraster::Backend::Cpu).map(|_| ()).unwrap_err();
    assert!(error.to_string().starts_with("face 1 takes material 1, but the mesh has 1"), "{error}");
    for (material, what) in [
        (Material { alpha: AlphaMode::Mask { cutoff: -0.5 }, ..Material::PLAIN }, "material 0's alpha cutoff is -0.5"),
        (Material { emissive: [0.0, f32::NAN, 0.0], ..Material::PLAIN }, "material 0's emission is NaN"),
    ] {
        let error = tileraster::render::render(&with_material(square(true), material), &lit(Shading::Pbr), tileraster::Backend::Cpu).map(|_| ()).unwrap_err();
        assert_eq!(error.to_string(), format!("{what}: give a number finite and not negative"));
    }
    let mesh = Mesh { face_materials: Some(vec![0]), ..with_material(square(true), Material::PLAIN) };
    let error = tileraster::render::render(&mesh, &lit(Shading::Pbr), tileraster::Backend::Cpu).map(|_| ()).unwrap_err();
    assert_eq!(error.to_string(), "the mesh has 1 face materials for 2 faces; give one per face, or none");
}
