//! The `auto` backend: the CPU unless a hardware GPU is there and the call is big enough to pay
//! for it, decided without opening a device (`tileraster_gpu::survey` remembers the machine's
//! adapters between processes), so that choosing the CPU costs nothing.
//!
//! - A CPU implementation of Vulkan (lavapipe, llvmpipe) runs the kernels on the same cores as
//!   the CPU backend, through a driver, and is many times slower than the CPU backend
//!   (`docs/results.md`). It is never chosen.
//! - A hardware GPU pays a fixed cost per process (opening the device, building the pipelines)
//!   and per call (uploading, reading back) that a small raster does not earn back: below
//!   [`GPU_MIN_PIXELS`] cells the CPU backend is chosen.

use crate::Backend;
use tileraster_gpu::survey::{self, AdapterKind, SurveySource};

/// Rasters smaller than this (1024 × 1024 cells) stay on the CPU even with a GPU present.
pub const GPU_MIN_PIXELS: u64 = 1 << 20;

/// What `auto` chose for a call, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BackendChoice {
    pub backend: Backend,
    pub reason: String,
    /// The Vulkan adapter the GPU backend would open, if there is one.
    pub adapter: Option<String>,
}

impl BackendChoice {
    /// `{"backend":"cpu","reason":"..."}`
    pub fn to_json(&self) -> String {
        let reason: String = self.reason.chars().flat_map(|c| if c == '"' || c == '\\' { vec!['\\', c] } else { vec![c] }).collect();
        format!("{{\"backend\":\"{}\",\"chosen_by\":\"auto\",\"reason\":\"{reason}\"}}", self.backend.name())
    }
}

/// The backend for a call that writes `pixels` cells (or pixels), and why.
pub fn choose_backend(pixels: u64) -> BackendChoice {
    let survey = survey::survey();
    let known = match &survey.source {
        SurveySource::NoDrivers => "no Vulkan driver is installed".to_string(),
        SurveySource::Enumerated => "the Vulkan adapters, surveyed now".to_string(),
        SurveySource::Cache(file) => format!("the Vulkan adapters as surveyed before ({})", file.display()),
    };
    let preferred = survey.preferred();
    let adapter = preferred.map(|a| a.name.clone());
    let cpu = |reason: String| BackendChoice { backend: Backend::Cpu, reason, adapter: adapter.clone() };
    match preferred {
        None if survey.adapters.is_empty() => {
            cpu(if matches!(survey.source, SurveySource::NoDrivers) { known } else { format!("no Vulkan adapter ({known})") })
        }
        None => match std::env::var("TILERASTER_ADAPTER") {
            Ok(name) => cpu(format!("no usable Vulkan adapter is named like TILERASTER_ADAPTER={name:?} ({known})")),
            Err(_) => {
                cpu(format!("no Vulkan adapter has 64-bit integers, 64-bit atomic minima and subgroup operations in shaders and SPIR-V passthrough ({known})"))
            }
        },
        Some(a) if a.kind != AdapterKind::Gpu => {
            cpu(format!("the Vulkan adapter, {}, is a CPU implementation, slower than the CPU backend on the same cores ({known})", a.name))
        }
        Some(a) if pixels < GPU_MIN_PIXELS => {
            cpu(format!("{pixels} cells are fewer than {GPU_MIN_PIXELS}: the GPU's fixed cost would outweigh its speed ({}; {known})", a.name))
        }
        Some(a) => {
            BackendChoice { backend: Backend::Gpu, reason: format!("{}, a hardware GPU, for {pixels} cells ({known})", a.name), adapter: adapter.clone() }
        }
    }
}
