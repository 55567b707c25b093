//! Points: every vertex drawn as a square of a given width in pixels, depth-tested and counted
//! like triangles, the same bits on both backends; a point of integer width covers exactly
//! width² pixel centres wherever it lies; points whose vertex is outside the view volume are
//! dropped; bad sizes are typed errors.

mod common;

use common::assert_frame_parity as assert_parity;
use tileraster::render::{Camera, Cull, Eye, IDENTITY, Mesh, NO_FACE, Projection, RenderParams, Shading, Up, render};
use tileraster::{Backend, Error};
use tileraster_testkit::meshes;

/// Points alone (a point cloud) and over the faces (the vertices view), at several sizes, a
/// sphere crossing the near plane and the frame's edges: CPU = GPU; every vertex is drawn or
/// dropped; the vertices view shows points over the faces.
#[test]
fn points_are_the_same_bits_on_both_backends() {
    let sphere = meshes::sphere([0.0, 0.0, 0.0], 1.0, 12, 20);
    let n = sphere.positions.len() as u64;
    // Close enough that the near plane and the frame's edges cut the sphere.
    let camera =
        Camera { eye: [0.3, -1.6, 0.5], target: [0.0; 3], up: [0.0, 0.0, 1.0], projection: Projection::Perspective { fov_deg: 70.0 }, near: 0.8, far: 5.0 };
    let (w, h) = (120, 90);
    for size in [1.0, 2.5, 4.0, 9.0] {
        for faces in [false, true] {
            let params = RenderParams {
                cull: Cull::None,
                shading: Shading::Smooth,
                points: Some(size),
                faces,
                eye: Some(camera.viewer()),
                ..RenderParams::new(w, h, camera.view_projection(w, h).unwrap())
            };
            let what = format!("size {size}, faces {faces}");
            let f = assert_parity(&what, &sphere, &params);
            let g = f.stats.geometry;
            assert_eq!(g.points_drawn + g.points_culled, n, "{what}");
            assert!(g.points_drawn > 20 && g.points_culled > 0, "{what}: {g:?}");
            let faces_n = sphere.triangles.len() as u32;
            let point_pixels = f.ids.iter().filter(|&&id| id != NO_FACE && id >= faces_n).count();
            assert!(point_pixels > 20, "{what}: {point_pixels} pixels show a point");
            if faces {
                assert!(f.ids.iter().any(|&id| id < faces_n), "{what}: no face shows");
            }
        }
    }
}

/// A point of width `s` (whole pixels) covers exactly `s²` pixel centres, wherever its centre
/// lies on the sub-pixel lattice: the square's two triangles share a diagonal the top-left
/// rule gives to one of them, and each side of the square takes the centres of a half-open
/// interval `s` pixels long.
#[test]
fn a_point_of_whole_width_covers_its_square_of_pixels() {
    let (w, h) = (64, 64);
    for (k, size) in [1.0f32, 2.0, 3.0, 5.0, 8.0].into_iter().enumerate() {
        for step in 0..7 {
            // Positions across a pixel, in NDC (a pixel is 2/64 wide), including centres and edges.
            let off = (k as f64 * 7.0 + step as f64) / 17.0;
            let (x, y) = (-0.2 + off * 2.0 / 64.0, 0.1 - off * 1.3 / 64.0);
            // The other two vertices lie beyond the far plane: their points are dropped.
            let mesh = Mesh { positions: vec![[x, y, 0.5], [0.0, 0.0, 5.0], [0.1, 0.0, 5.0]], triangles: vec![[0, 1, 2]], ..Default::default() };
            let params = RenderParams {
                cull: Cull::None,
                shading: Shading::Ids,
                points: Some(size),
                faces: false,
                eye: Some(Eye::Point([0.0, 0.0, -1.0])),
                ..RenderParams::new(w, h, IDENTITY)
            };
            let f = assert_parity(&format!("size {size}, offset {off:.3}"), &mesh, &params);
            let covered = f.ids.iter().filter(|&&id| id == 1).count();
            assert_eq!(covered, (size * size) as usize, "size {size}, offset {off:.3}: {covered} pixels");
            assert_eq!(f.fragments.iter().max(), Some(&1), "size {size}: a pixel covered twice");
        }
    }
}

#[test]
fn bad_point_sizes_are_typed_errors() {
    let mesh = meshes::sphere([0.0; 3], 1.0, 4, 6);
    let base = RenderParams::new(16, 16, Camera::framing(&mesh, 1.0, Projection::Perspective { fov_deg: 45.0 }, Up::Y).view_projection(16, 16).unwrap());
    for size in [0.0, -1.0, f32::NAN, 2000.0] {
        let e = render(&mesh, &RenderParams { points: Some(size), ..base.clone() }, Backend::Cpu).map(|_| ()).unwrap_err();
        assert!(matches!(e, Error::InvalidPointSize { .. }), "{size}: {e}");
    }
    let e = render(&mesh, &RenderParams { faces: false, ..base }, Backend::Cpu).map(|_| ()).unwrap_err();
    assert!(matches!(e, Error::NothingToDraw), "{e}");
}
