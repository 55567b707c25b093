//! The kernels' elementary functions computed on the GPU give the CPU's bits: a frame of each
//! function's values over its domain (65,536 arguments), drawn by a user's fragment shader on
//! both backends, equals the native functions' bits pixel by pixel. So do glTF's BRDF
//! (`brdf`) and chains of float constants (`chains`), which the build's optimiser must not
//! fold.

#[path = "../../../tests/common/mod.rs"]
mod common;

use common::render_frame;
use elementary::{FUNCTIONS, argument, evaluate, params, screen};
use tileraster::Backend;

/// Each function's arguments across its domain (and `pow`'s exponent).
const DOMAINS: [([f32; 2], f32); 11] = [
    ([-87.0, 88.72], 0.0),
    ([-125.0, 127.99], 0.0),
    ([1e-30, 1e30], 0.0),
    ([1e-3, 40.0], 0.0),
    ([1e-3, 30.0], 2.4),
    ([-4096.0, 4096.0], 0.0),
    ([-20.0, 20.0], 0.0),
    ([-1.0, 1.0], 0.0),
    ([-1.0, 1.0], 0.0),
    ([0.0, 1.0], 0.0),
    ([-1000.0, 1000.0], 0.0),
];

#[test]
fn every_device_computes_the_elementary_functions_with_the_cpus_bits() {
    let (width, height) = (256, 256);
    let gpu = common::gpu_or_skip("elementary functions on the GPU");
    for (k, name) in FUNCTIONS.iter().enumerate() {
        let (range, y) = DOMAINS[k];
        let p = params(width, height, k, range, y).unwrap();
        let c = p.fragment_constants;
        let cpu = render_frame(&screen(), &p, Backend::Cpu);
        let mut distinct = std::collections::BTreeSet::new();
        for (n, &word) in cpu.colour.iter().enumerate() {
            let pixel = [(n % width as usize) as i32, (n / width as usize) as i32];
            let x = argument(pixel, c);
            let want = evaluate(k as u32, x, y);
            assert_eq!(word, want.to_bits(), "{name}({x}) on the CPU backend: the frame holds its bits");
            distinct.insert(word);
        }
        assert!(distinct.len() > 30_000, "{name}: {} distinct values", distinct.len());
        if gpu {
            let device = render_frame(&screen(), &p, Backend::Gpu);
            let first = device.colour.iter().zip(&cpu.colour).position(|(a, b)| a != b);
            if let Some(n) = first {
                let x = argument([(n % width as usize) as i32, (n / width as usize) as i32], c);
                panic!("{name}({x}): the GPU gives {:e}, the CPU {:e}", f32::from_bits(device.colour[n]), f32::from_bits(cpu.colour[n]));
            }
        }
    }
}
