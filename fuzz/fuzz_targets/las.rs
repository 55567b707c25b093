//! Fuzz target: any bytes, read as a LAS or LAZ file, must be refused with the file named or
//! give finite points that triangulate consistently (see `las_check.rs`).
#![no_main]

#[path = "las_check.rs"]
mod las_check;

use std::sync::Once;

/// libFuzzer's panic hook aborts at once, before anything can catch the panic. `parse_las`
/// turns panics inside `laz` into errors (they end its decoding thread, which it joins): those
/// alone go on unwinding; every other panic still aborts here, and one that `parse_las` does
/// not catch still aborts in libfuzzer-sys.
fn let_laz_panics_unwind() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let abort = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            let in_laz = info.location().is_some_and(|at| at.file().replace('\\', "/").contains("/laz-"));
            if !in_laz {
                abort(info);
            }
        }));
    });
}

libfuzzer_sys::fuzz_target!(|data: &[u8]| {
    let_laz_panics_unwind();
    if let Err(problem) = las_check::check(data) {
        panic!("{problem}");
    }
});
