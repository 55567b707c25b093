//! Without a usable adapter the GPU backend fails with a typed error that says how to install
//! the Vulkan CPU driver. (Own test binary: the GPU context is chosen once per process.)

use tileraster::{Backend, Error, Grid, Params, Scene, rasterise};

#[test]
fn missing_adapter_is_a_clear_error() {
    // SAFETY: set before any thread of this test binary touches the GPU context.
    unsafe { std::env::set_var("TILERASTER_ADAPTER", "no adapter is called like this") };
    let scene = Scene::new(vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], vec![[0, 1, 2]]);
    let e = rasterise(&scene, &Params::new(Grid::new(0.0, 1.0, 0.0, 1.0, 4, 4)), Backend::Gpu).unwrap_err();
    assert!(matches!(e, Error::NoAdapter { .. }), "{e:?}");
    let text = e.to_string();
    assert!(text.contains("mesa-vulkan-drivers") && text.contains("CPU backend"), "{text}");
    // The CPU backend is unaffected.
    rasterise(&scene, &Params::new(Grid::new(0.0, 1.0, 0.0, 1.0, 4, 4)), Backend::Cpu).unwrap();
}
