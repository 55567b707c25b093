//! Bad input gives a typed error with a clear message, never a panic.

mod common;

use common::expect_err;
use tileraster::{Backend, Error, Grid, Params, Scene, Window, rasterise, rasterise_window};

fn triangle() -> Scene {
    Scene::new(vec![[0.0, 0.0, 1.0], [10.0, 0.0, 2.0], [0.0, 10.0, 3.0]], vec![[0, 1, 2]])
}

fn params() -> Params {
    Params::new(Grid::new(0.0, 10.0, 0.0, 10.0, 16, 16))
}

fn both(scene: &Scene, params: &Params) -> Error {
    let cpu = expect_err(rasterise(scene, params, Backend::Cpu));
    // Input is validated before any device is touched, so the GPU backend says the same.
    let gpu = expect_err(rasterise(scene, params, Backend::Gpu));
    assert_eq!(cpu.to_string(), gpu.to_string());
    cpu
}

fn message(e: &Error) -> String {
    e.to_string()
}

#[test]
fn empty_scenes() {
    let e = both(&Scene::default(), &params());
    assert!(matches!(e, Error::EmptyScene { what: "vertices" }), "{e:?}");
    let e = both(&Scene::new(triangle().vertices, vec![]), &params());
    assert!(matches!(e, Error::EmptyScene { what: "triangles" }), "{e:?}");
    assert!(message(&e).contains("no triangles"), "{e}");
}

#[test]
fn non_finite_coordinates() {
    for (vertex, axis, value) in [(0, 0, f64::NAN), (1, 1, f64::INFINITY), (2, 2, f64::NEG_INFINITY)] {
        let mut scene = triangle();
        scene.vertices[vertex][axis] = value;
        let e = both(&scene, &params());
        let want_axis = ['x', 'y', 'z'][axis];
        assert!(matches!(e, Error::NonFiniteCoordinate { vertex: v, axis: a, .. } if v == vertex && a == want_axis), "{e:?}");
        assert!(message(&e).contains(&format!("vertex {vertex}")), "{e}");
    }
}

#[test]
fn heights_beyond_f32() {
    let mut scene = triangle();
    scene.vertices[1][2] = 1e39;
    let e = both(&scene, &params());
    assert!(matches!(e, Error::HeightOutOfRange { vertex: 1, .. }), "{e:?}");
}

#[test]
fn indices_out_of_range() {
    let scene = Scene::new(triangle().vertices, vec![[0, 1, 2], [0, 3, 1]]);
    let e = both(&scene, &params());
    assert!(matches!(e, Error::IndexOutOfRange { triangle: 1, corner: 1, index: 3, vertex_count: 3 }), "{e:?}");
    assert!(message(&e).contains("triangle 1") && message(&e).contains("vertex 3"), "{e}");
}

#[test]
fn zero_sized_rasters() {
    for (w, h) in [(0, 16), (16, 0), (0, 0)] {
        let e = both(&triangle(), &Params::new(Grid::new(0.0, 10.0, 0.0, 10.0, w, h)));
        assert!(matches!(e, Error::ZeroSizedRaster { .. }), "{e:?}");
    }
}

#[test]
fn invalid_extents() {
    for grid in [
        Grid::new(10.0, 0.0, 0.0, 10.0, 16, 16),
        Grid::new(0.0, 10.0, 5.0, 5.0, 16, 16),
        Grid::new(f64::NAN, 10.0, 0.0, 10.0, 16, 16),
        Grid::new(0.0, f64::INFINITY, 0.0, 10.0, 16, 16),
    ] {
        let e = both(&triangle(), &Params::new(grid));
        assert!(matches!(e, Error::InvalidExtent { .. }), "{e:?}");
    }
}

#[test]
fn rasters_too_large_for_memory() {
    // 2^30 × 2^30 cells: 4 EiB of Float32.
    let huge = 1u32 << 30;
    let grid = Grid::new(0.0, huge as f64, 0.0, huge as f64, huge, huge);
    let e = expect_err(rasterise(&triangle(), &Params::new(grid), Backend::Cpu));
    assert!(matches!(e, Error::RasterTooLarge { .. }), "{e:?}");
    assert!(message(&e).contains("too large"), "{e}");
    // Beyond the supported side length.
    let e = both(&triangle(), &Params::new(Grid::new(0.0, 10.0, 0.0, 10.0, huge + 1, 4)));
    assert!(matches!(e, Error::RasterTooLarge { .. }), "{e:?}");
}

#[test]
fn triangles_too_large_for_exact_coverage() {
    // 1e9 px across, over the grid.
    let scene = Scene::new(vec![[-1e9, -1e9, 0.0], [1e9, -1e9, 0.0], [0.0, 1e9, 0.0]], vec![[0, 1, 2]]);
    let e = both(&scene, &Params::new(Grid::new(0.0, 1.0, 0.0, 1.0, 1, 1)));
    assert!(matches!(e, Error::TriangleTooLarge { triangle: 0, .. }), "{e:?}");
    // The same triangle far away from the grid is culled instead.
    let far = scene.translated(1e12, 0.0, 0.0);
    rasterise(&far, &Params::new(Grid::new(0.0, 1.0, 0.0, 1.0, 1, 1)), Backend::Cpu).expect("culled, not an error");
}

#[test]
fn windows_outside_the_grid() {
    for window in [Window { x0: 0, y0: 0, width: 0, height: 4 }, Window { x0: 10, y0: 0, width: 7, height: 4 }, Window { x0: 0, y0: 16, width: 1, height: 1 }] {
        let e = expect_err(rasterise_window(&triangle(), &params(), Some(window), Backend::Cpu));
        assert!(matches!(e, Error::InvalidWindow { .. }), "{e:?}");
    }
}
