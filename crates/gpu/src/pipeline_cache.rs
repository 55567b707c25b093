//! The driver's pipeline cache, kept on disk between processes where the adapter has one
//! (`wgpu::Features::PIPELINE_CACHE`), so that a second process does not pay the driver's
//! compile of the same stages again.
//!
//! The file lives in the cache directory the adapter survey uses (`survey::cache_dir`), named
//! by `wgpu::util::pipeline_cache_key` (the adapter, its driver and wgpu's cache format), and
//! is written whole beside itself and renamed into place. It is only a cache: data the driver
//! does not recognise is dropped by it (`fallback`), and a cache that cannot be read or
//! written costs compiles, never a frame.
//!
//! Measured on lavapipe (Mesa 22.3.6): the driver reports the feature, but its cache holds a
//! 96-byte header and nothing else, and Mesa's own shader cache already keeps the LLVM code;
//! what a process still pays there is the driver's translation of the module (about 0.75 s for
//! the generic `shade` kernel), which neither cache skips.

use std::path::PathBuf;

/// A pipeline cache and the file it is kept in.
pub(crate) struct DiskPipelineCache {
    pub(crate) cache: wgpu::PipelineCache,
    file: PathBuf,
}

impl DiskPipelineCache {
    /// The device's cache, filled from its file where there is one; `None` where the device
    /// has no pipeline cache or there is nowhere to keep it.
    pub(crate) fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo) -> Option<DiskPipelineCache> {
        if !device.features().contains(wgpu::Features::PIPELINE_CACHE) {
            return None;
        }
        let file = crate::survey::cache_dir()?.join(wgpu::util::pipeline_cache_key(info)?);
        let data = std::fs::read(&file).ok();
        // SAFETY: the data is either absent or what `get_data` of a cache with this key wrote
        // (the key names the adapter and driver); `fallback` has the driver drop data it
        // does not accept rather than fail.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor { label: Some("tileraster pipelines"), data: data.as_deref(), fallback: true })
        };
        Some(DiskPipelineCache { cache, file })
    }

    /// Write the cache's data to its file (the caller does so after it built new pipelines).
    pub(crate) fn save(&self) {
        let Some(data) = self.cache.get_data() else { return };
        let Some(dir) = self.file.parent() else { return };
        let partial = self.file.with_extension(format!("partial-{}", std::process::id()));
        let written = std::fs::create_dir_all(dir).and_then(|_| std::fs::write(&partial, &data)).and_then(|_| std::fs::rename(&partial, &self.file));
        if written.is_err() {
            let _ = std::fs::remove_file(&partial);
        }
    }
}
