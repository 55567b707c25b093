//! `--backend auto`: decided without opening a device, from a survey of the Vulkan adapters
//! that is kept between processes and agrees with the adapter the GPU backend opens. (Own test
//! binary: the cache directory is set for the whole process.)

mod common;

use std::path::PathBuf;
use std::process::Command;
use tileraster::{Backend, GPU_MIN_PIXELS, choose_backend};
use tileraster_gpu::survey::{self, AdapterKind, SurveySource};

fn cache_dir() -> PathBuf {
    std::env::temp_dir().join(format!("tileraster-auto-test-{}", std::process::id()))
}

#[test]
fn auto_decides_from_a_kept_survey_that_names_the_adapter_the_backend_opens() {
    let dir = cache_dir().join("library");
    let _ = std::fs::remove_dir_all(&dir);
    // SAFETY: set before any thread of this test binary reads the environment.
    unsafe { std::env::set_var("TILERASTER_CACHE_DIR", &dir) };

    let large = choose_backend(GPU_MIN_PIXELS);
    let surveyed = survey::survey();
    let file = dir.join("vulkan-adapters");
    match &surveyed.source {
        SurveySource::NoDrivers => assert!(!file.exists(), "no survey is kept without drivers"),
        source => assert_eq!(source, &SurveySource::Cache(file.clone()), "the first choice kept its survey for the next"),
    }
    // The survey predicts the adapter the GPU backend opens, and what kind it is.
    match tileraster::gpu_adapter() {
        Ok(adapter) => {
            let preferred = surveyed.preferred().unwrap_or_else(|| panic!("the backend opened {adapter}, the survey has none: {surveyed:?}"));
            assert_eq!(preferred.name, adapter.name);
            assert_eq!(preferred.kind == AdapterKind::Cpu, adapter.software, "{adapter}");
            assert_eq!(large.adapter.as_deref(), Some(adapter.name.as_str()));
            let expected = if adapter.software { Backend::Cpu } else { Backend::Gpu };
            assert_eq!(large.backend, expected, "{}", large.reason);
        }
        Err(e) => {
            assert!(surveyed.preferred().is_none(), "the survey has an adapter the backend cannot open ({e}): {surveyed:?}");
            assert_eq!(large.backend, Backend::Cpu, "{}", large.reason);
        }
    }
    // A small raster stays on the CPU whatever the machine has.
    let small = choose_backend(GPU_MIN_PIXELS - 1);
    assert_eq!(small.backend, Backend::Cpu, "{}", small.reason);

    if file.exists() {
        // A survey of other drivers (another version's, here) is not used: the adapters are
        // surveyed again, and the file replaced.
        let text = std::fs::read_to_string(&file).unwrap();
        let stale = text.replacen(&format!("tileraster-gpu {}", env!("CARGO_PKG_VERSION")), "tileraster-gpu 0.0.0-other", 1);
        assert_ne!(stale, text, "the key names the version");
        std::fs::write(&file, &stale).unwrap();
        let again = survey::survey();
        assert_eq!(again.source, SurveySource::Enumerated);
        assert_eq!(again.adapters, surveyed.adapters);
        assert_eq!(std::fs::read_to_string(&file).unwrap(), text, "the survey was kept anew");
        assert_eq!(survey::survey().source, SurveySource::Cache(file.clone()));
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The command line's default run: the choice and its reason in `--stats`, and no line on
/// stderr that says error, both when the adapters are surveyed and when the survey is read back.
#[test]
fn the_command_line_says_what_auto_chose_and_prints_no_error() {
    let dir = cache_dir().join("cli");
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("triangle.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    for run in ["surveyed", "read back"] {
        let png = dir.join("frame.png");
        let out = Command::new(env!("CARGO_BIN_EXE_tileraster"))
            .args(["render", obj.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64", "48", "--stats"])
            .env("TILERASTER_CACHE_DIR", dir.join("cache"))
            .env_remove("XDG_RUNTIME_DIR")
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(out.status.success(), "{run}: {stderr}");
        assert!(!stderr.to_lowercase().contains("error"), "{run}: stderr says error:\n{stderr}");
        let choice = stderr.lines().find(|l| l.contains("\"chosen_by\":\"auto\"")).unwrap_or_else(|| panic!("{run}: no choice in --stats:\n{stderr}"));
        let json: serde_json::Value = serde_json::from_str(choice).unwrap_or_else(|e| panic!("{run}: not JSON ({e}): {choice}"));
        assert_eq!(json["backend"], "cpu", "{run}: a 64×48 frame stays on the CPU: {choice}");
        assert!(json["reason"].as_str().is_some_and(|r| !r.is_empty()), "{choice}");
        if run == "read back" && dir.join("cache/vulkan-adapters").exists() {
            assert!(json["reason"].as_str().unwrap().contains("surveyed before"), "{choice}");
        }
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// The driver's pipeline cache is kept on disk for the next process (where the adapter has
/// one, as every Vulkan adapter wgpu opens does), and a frame drawn through a cache read back
/// is the same bits.
#[test]
fn the_pipeline_cache_is_kept_for_the_next_process() {
    if !common::gpu_or_skip("the_pipeline_cache_is_kept_for_the_next_process") {
        return;
    }
    let dir = cache_dir().join("pipelines");
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let obj = dir.join("triangle.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
    let kept = || -> Vec<PathBuf> {
        let entries: Vec<PathBuf> = std::fs::read_dir(dir.join("cache")).map(|d| d.flatten().map(|e| e.path()).collect()).unwrap_or_default();
        entries.into_iter().filter(|p| p.file_name().is_some_and(|n| n.to_string_lossy().starts_with("wgpu_pipeline_cache"))).collect()
    };
    let mut frames = Vec::new();
    for run in ["first", "second"] {
        let png = dir.join(format!("{run}.png"));
        let out = Command::new(env!("CARGO_BIN_EXE_tileraster"))
            .args(["render", obj.to_str().unwrap(), "-o", png.to_str().unwrap(), "--size", "64", "48", "--backend", "gpu"])
            .env("TILERASTER_CACHE_DIR", dir.join("cache"))
            .output()
            .unwrap();
        assert!(out.status.success(), "{run}: {}", String::from_utf8_lossy(&out.stderr));
        let files = kept();
        assert_eq!(files.len(), 1, "{run} run: one pipeline cache file kept, found {files:?}");
        assert!(std::fs::metadata(&files[0]).unwrap().len() > 0, "{run} run: the cache file is empty");
        frames.push(std::fs::read(&png).unwrap());
    }
    assert!(frames[0] == frames[1], "the frame drawn through the kept cache differs");
    std::fs::remove_dir_all(&dir).ok();
}
