#![no_main]

#[path = "points_check.rs"]
mod points_check;

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    if let Err(problem) = points_check::check(data) {
        panic!("{problem}");
    }
});
