//! Panoramas (cylindrical, equirectangular, fisheye) and jittered frames: their cube faces are
//! plain render calls of the faces' cameras, every output pixel is a face pixel, and both
//! backends give the same bits; a jittered frame is the integer mean of plain frames at the
//! sequence's offsets.

mod common;

use tileraster::Backend;
use tileraster::render::{
    CameraChoice, Frame, Lens, MeshSource, Model, ModelOptions, NO_FACE, Panorama, Shading, ViewOptions, face_camera, jitter_offset, jittered, render,
};
use tileraster_testkit::meshes;

/// A town of boxes around the eye, with a ground: something in every direction.
fn town() -> tileraster::render::Mesh {
    let mut mesh = meshes::soup(400, [-20.0, -20.0, -2.0], [20.0, 20.0, 8.0], 2.5, 11);
    let ground = meshes::sphere([0.0, 0.0, -60.0], 55.0, 24, 48);
    let offset = mesh.positions.len() as u32;
    mesh.positions.extend(&ground.positions);
    mesh.triangles.extend(ground.triangles.iter().map(|t| t.map(|v| v + offset)));
    if let Some(colours) = mesh.colours.as_mut() {
        colours.resize(mesh.positions.len(), [0.3, 0.6, 0.25, 1.0]);
    }
    mesh.normals = None;
    mesh
}

fn view(lens: Lens, size: [u32; 2]) -> ViewOptions {
    ViewOptions {
        size: Some(size),
        camera: CameraChoice::LookAt { eye: [0.5, -0.3, 1.5], target: [10.0, 2.0, 1.0], up: [0.0, 0.0, 1.0] },
        lens,
        shading: Some(Shading::Phong),
        cull: Some(tileraster::render::Cull::None),
        ..Default::default()
    }
}

fn draw(model: &Model, view: &ViewOptions, backend: Backend) -> Frame {
    model.draw(view, &mut |params| tileraster::render::render_world(model.world(), params, backend)).unwrap()
}

#[test]
fn every_pixel_of_a_panorama_is_a_pixel_of_a_face_drawn_by_a_plain_call() {
    let mesh = town();
    let model = Model::load(MeshSource::Mesh(mesh.clone()), &ModelOptions::default()).unwrap();
    for (lens, size) in [
        (Lens::Panorama(Panorama::Equirectangular), [256, 128]),
        (Lens::Panorama(Panorama::Cylindrical { fov_deg: 100.0 }), [240, 90]),
        (Lens::Panorama(Panorama::Fisheye { fov_deg: 300.0 }), [160, 120]),
    ] {
        let view = view(lens, size);
        let Lens::Panorama(panorama) = lens else { unreachable!() };
        let frame = draw(&model, &view, Backend::Cpu);
        assert_eq!((frame.width, frame.height, frame.colour.len()), (size[0], size[1], (size[0] * size[1]) as usize));
        // The faces as plain calls of their cameras.
        let params = model.params(&view).unwrap();
        let camera = model.look_at(&view, size[0], size[1]).unwrap();
        let face_size = panorama.face_size(size[0], size[1]);
        let faces: Vec<Frame> = (0..6)
            .map(|f| {
                let face = face_camera(&camera, f, &mesh).unwrap();
                let mut p = params.clone();
                (p.width, p.height, p.view_projection, p.eye) =
                    (face_size, face_size, face.view_projection(face_size, face_size).unwrap(), Some(face.viewer()));
                render(&mesh, &p, Backend::Cpu).unwrap()
            })
            .collect();
        // Each pixel is some face's pixel: its colour, depth and id together.
        let mut pixels = std::collections::HashMap::new();
        for (f, face) in faces.iter().enumerate() {
            for j in 0..face.ids.len() {
                pixels.entry((face.ids[j], face.colour[j], face.depth[j].to_bits())).or_insert(f);
            }
        }
        let mut seen = [false; 6];
        for k in 0..frame.ids.len() {
            if frame.ids[k] == NO_FACE && frame.colour[k] == u32::from_le_bytes(params.background) {
                continue;
            }
            let f = pixels.get(&(frame.ids[k], frame.colour[k], frame.depth[k].to_bits()));
            seen[*f.unwrap_or_else(|| panic!("{lens:?}: pixel {k} is no face's pixel"))] = true;
        }
        assert!(frame.ids.iter().filter(|&&id| id != NO_FACE).count() > frame.ids.len() / 3, "{lens:?} shows the town");
        if lens == Lens::Panorama(Panorama::Equirectangular) {
            assert_eq!(seen, [true; 6], "an equirectangular frame takes every face");
        }
        if let Lens::Panorama(Panorama::Fisheye { .. }) = lens {
            // The corners of a 300° fisheye 160 wide lie 186° from its axis: nothing is there.
            assert_eq!(frame.ids[0], NO_FACE);
        }
        if common::gpu_or_skip("panoramas on the GPU") {
            let gpu = draw(&model, &view, Backend::Gpu);
            assert_eq!(gpu.colour, frame.colour, "{lens:?}: colour");
            assert_eq!(gpu.ids, frame.ids, "{lens:?}: ids");
            assert_eq!(gpu.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>(), frame.depth.iter().map(|d| d.to_bits()).collect::<Vec<_>>());
        }
    }
}

#[test]
fn a_jittered_frame_is_the_rounded_mean_of_plain_frames_at_the_offsets() {
    let mesh = meshes::sphere([0.0, 0.0, 0.0], 1.0, 10, 16);
    let model = Model::load(MeshSource::Mesh(mesh.clone()), &ModelOptions::default()).unwrap();
    for lens in [Lens::Perspective { fov_deg: 50.0 }, Lens::Orthographic { width: None }] {
        let mut v = view(lens, [96, 64]);
        v.camera = CameraChoice::LookAt { eye: [3.0, -2.0, 1.0], target: [0.0; 3], up: [0.0, 0.0, 1.0] };
        v.jitter = 8;
        let frame = draw(&model, &v, Backend::Cpu);
        let params = model.params(&v).unwrap();
        let samples: Vec<Frame> = (0..8).map(|k| render(&mesh, &jittered(&params, jitter_offset(k)), Backend::Cpu).unwrap()).collect();
        for (p, &got) in frame.colour.iter().enumerate() {
            let want: [u8; 4] = std::array::from_fn(|c| {
                let sum: u32 = samples.iter().map(|s| s.colour[p].to_le_bytes()[c] as u32).sum();
                ((sum + 4) / 8) as u8
            });
            assert_eq!(got.to_le_bytes(), want, "{lens:?}, pixel {p}");
        }
        assert_eq!(frame.ids, samples[0].ids, "ids are the first sample's");
        // Edges are blended: some pixels lie strictly between the background and the sphere.
        let partial = frame.colour.iter().filter(|c| (1..255).contains(&c.to_le_bytes()[3])).count();
        assert!(partial > 20, "{lens:?}: {partial} pixels on the edge");
        if common::gpu_or_skip("jitter on the GPU") {
            assert_eq!(draw(&model, &v, Backend::Gpu).colour, frame.colour, "{lens:?}");
        }
    }
}

#[test]
fn panoramas_refuse_what_they_cannot_draw() {
    let model = Model::load(MeshSource::Mesh(meshes::sphere([0.0; 3], 1.0, 6, 8)), &ModelOptions::default()).unwrap();
    let mut v = view(Lens::Panorama(Panorama::Equirectangular), [64, 32]);
    v.jitter = 4;
    assert!(model.params(&v).unwrap_err().to_string().contains("--jitter"));
    v.jitter = 0;
    assert!(model.params(&v).unwrap_err().to_string().contains("--jitter"));
    let mut v = view(Lens::Panorama(Panorama::Fisheye { fov_deg: 400.0 }), [64, 32]);
    assert!(model.params(&v).unwrap_err().to_string().contains("--fov"));
    v.lens = Lens::Panorama(Panorama::Cylindrical { fov_deg: 180.0 });
    assert!(model.params(&v).unwrap_err().to_string().contains("--fov"));
    v.lens = Lens::Panorama(Panorama::Equirectangular);
    v.camera = CameraChoice::Matrix(tileraster::render::IDENTITY);
    assert!(model.params(&v).unwrap_err().to_string().contains("--projection"));
}
