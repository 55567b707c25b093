//! Helpers shared by the integration tests.
#![allow(dead_code)]

use tileraster::{rasterise, Backend, Error, Params, Raster, Scene};

/// Whether GPU tests should run. Without an adapter they fail loudly, unless the user asked
/// to skip them with `TILERASTER_SKIP_GPU=1`, in which case the skip is printed.
pub fn gpu_or_skip(test: &str) -> bool {
    match tileraster::gpu_adapter() {
        Ok(_) => true,
        Err(e) if std::env::var("TILERASTER_SKIP_GPU").as_deref() == Ok("1") => {
            // Straight to the process's stderr: the test harness would swallow `eprintln!`
            // of a passing test, and a skip must be seen.
            use std::io::Write;
            let _ = writeln!(std::io::stderr(), "SKIPPED (TILERASTER_SKIP_GPU=1): {test}: {e}");
            false
        }
        Err(e) => panic!(
            "{test}: the GPU backend is unavailable: {e}\n\
             To skip GPU tests deliberately, set TILERASTER_SKIP_GPU=1."
        ),
    }
}

/// Rasterise on both backends and require bit-identical results; print the first differing
/// pixels with both values if they are not.
pub fn assert_parity(name: &str, scene: &Scene, params: &Params) -> Option<(Raster, Raster)> {
    if !gpu_or_skip(name) {
        return None;
    }
    let cpu = rasterise(scene, params, Backend::Cpu).unwrap_or_else(|e| panic!("{name}: CPU backend failed: {e}"));
    let gpu = rasterise(scene, params, Backend::Gpu).unwrap_or_else(|e| panic!("{name}: GPU backend failed: {e}"));
    let (count, first) = cpu.compare_bits(&gpu, 12);
    if count > 0 {
        let list: Vec<String> = first.iter().map(|d| format!("  {d} (cpu vs gpu)")).collect();
        panic!("{name}: CPU and GPU rasters differ in {count} cells; first ones:\n{}", list.join("\n"));
    }
    Some((cpu, gpu))
}

/// Run on the CPU, expecting success.
pub fn cpu(scene: &Scene, params: &Params) -> Raster {
    rasterise(scene, params, Backend::Cpu).unwrap_or_else(|e| panic!("CPU backend failed: {e}"))
}

pub fn expect_err(result: Result<Raster, Error>) -> Error {
    match result {
        Ok(_) => panic!("expected an error, got a raster"),
        Err(e) => e,
    }
}

