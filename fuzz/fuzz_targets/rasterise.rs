//! Fuzz target: any bytes, decoded into a small scene, grid and value mode, must rasterise on
//! the CPU to a typed error or to a clean raster (see `decode.rs`).
#![no_main]

mod decode;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let case = decode::decode(data);
    if let Err(what) = decode::check(&case) {
        panic!("{what}\n{case:?}");
    }
});
