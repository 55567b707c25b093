//! Fuzz target: any bytes, read as a GeoTIFF part for `tileraster mosaic`, must be refused
//! with the file named or give a part a mosaic can place (see `part_check.rs`).
#![no_main]

#[path = "part_check.rs"]
mod part_check;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(problem) = part_check::check(data) {
        panic!("{problem}");
    }
});
