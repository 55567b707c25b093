//! Helpers shared by the integration tests.
#![allow(dead_code)]

use tileraster::{Backend, Error, Params, Raster, Scene, Skip, Skips, rasterise};
use tileraster_cpu::FinePath;

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

/// Every way the tests run the pipeline: with all of its skips, with none, and with each
/// one turned off alone. No skip may change a bit.
pub fn skip_variants() -> Vec<(String, Skips)> {
    let mut out = vec![("all skips".to_string(), Skips::ALL), ("no skips".to_string(), Skips::NONE)];
    out.extend(Skip::ALL.iter().map(|&skip| (format!("all skips but {skip}"), Skips::all_but(skip))));
    out
}

/// Panic with the first differing pixels unless `a` and `b` are bit-identical.
pub fn assert_same_bits(what: &str, a: &Raster, b: &Raster) {
    let (count, first) = a.compare_bits(b, 12);
    if count > 0 {
        let list: Vec<String> = first.iter().map(|d| format!("  {d}")).collect();
        panic!("{what}: rasters differ in {count} cells; first ones:\n{}", list.join("\n"));
    }
}

/// Rasterise on both backends, with every skip variant, and require bit-identical results
/// everywhere and equal statistics on both backends; print the first differing pixels with
/// both values if they are not. Returns the rasters with all skips.
pub fn assert_parity(name: &str, scene: &Scene, params: &Params) -> Option<(Raster, Raster)> {
    assert_plain_twin(name, scene, params);
    if !gpu_or_skip(name) {
        return None;
    }
    let mut first: Option<(Raster, Raster)> = None;
    for (variant, skips) in skip_variants() {
        let params = params.with_skips(skips);
        let cpu = rasterise(scene, &params, Backend::Cpu).unwrap_or_else(|e| panic!("{name}, {variant}: CPU backend failed: {e}"));
        let gpu = rasterise(scene, &params, Backend::Gpu).unwrap_or_else(|e| panic!("{name}, {variant}: GPU backend failed: {e}"));
        assert_same_bits(&format!("{name}, {variant}, cpu vs gpu"), &cpu, &gpu);
        assert_eq!(cpu.stats, gpu.stats, "{name}, {variant}: the backends' statistics differ");
        match &first {
            None => first = Some((cpu, gpu)),
            Some((reference, _)) => assert_same_bits(&format!("{name}, all skips vs {variant}"), reference, &cpu),
        }
    }
    first
}

/// The CPU backend's fine-raster fast paths (row spans, whole and overlap-free tiles, wide
/// vectors), all together and each alone, against its plain twin, which runs each tile as the
/// GPU runs its workgroup: the same bits and statistics, with every skip variant.
pub fn assert_plain_twin(name: &str, scene: &Scene, params: &Params) {
    for (variant, skips) in skip_variants() {
        let prepared = tileraster::prepare(scene, &params.with_skips(skips), None).unwrap_or_else(|e| panic!("{name}, {variant}: {e}"));
        let run = |path| tileraster_cpu::rasterise_with(&prepared, path).unwrap_or_else(|e| panic!("{name}, {variant}, {path:?}: {e}"));
        let plain = run(FinePath::Plain);
        for path in FinePath::HEIGHTFIELD {
            let fast = run(path);
            assert_same_bits(&format!("{name}, {variant}, CPU {path:?} vs plain twin"), &fast, &plain);
            assert_eq!(fast.stats, plain.stats, "{name}, {variant}: the statistics of {path:?} and the plain twin differ");
        }
    }
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

/// Render `mesh` on `backend`, panicking with the backend and the error on failure.
pub fn render_frame(mesh: &tileraster::render::Mesh, params: &tileraster::render::RenderParams, backend: Backend) -> tileraster::render::Frame {
    tileraster::render::render(mesh, params, backend).unwrap_or_else(|e| panic!("{backend:?}: {e}"))
}

/// The CPU frame, after checking that the GPU backend gives the same bits: colour, ids,
/// fragment counts, depth and statistics.
pub fn assert_frame_parity(what: &str, mesh: &tileraster::render::Mesh, params: &tileraster::render::RenderParams) -> tileraster::render::Frame {
    let cpu = render_frame(mesh, params, Backend::Cpu);
    if gpu_or_skip(what) {
        let gpu = render_frame(mesh, params, Backend::Gpu);
        assert!(cpu.colour == gpu.colour && cpu.ids == gpu.ids && cpu.fragments == gpu.fragments, "{what}: the frames differ");
        assert!(cpu.depth.iter().zip(&gpu.depth).all(|(a, b)| a.to_bits() == b.to_bits()), "{what}: depths differ");
        assert_eq!(cpu.stats, gpu.stats, "{what}: statistics");
    }
    cpu
}
