#![no_main]

#[path = "mesh_check.rs"]
mod mesh_check;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(problem) = mesh_check::check(data) {
        panic!("{problem}");
    }
});
