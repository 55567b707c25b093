//! The GPU peers open their device with the GPU backend's helpers
//! (`tileraster_gpu::device`), on the adapter the backend itself uses.

pub(crate) use tileraster_gpu::device::{Gpu, Grown};

/// Open the adapter tileraster's GPU backend uses (its choice, `TILERASTER_ADAPTER` included),
/// so that the peers run on the same device as the kernels they are compared with.
pub(crate) fn open(label: &str) -> Result<Gpu, String> {
    let name = tileraster_gpu::adapter().map_err(|e| e.to_string())?.name;
    let choose = |adapters: Vec<wgpu::Adapter>| {
        let seen: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
        adapters.into_iter().find(|a| a.get_info().name == name).ok_or_else(|| format!("tileraster's adapter {name:?} is not among {seen:?}"))
    };
    Gpu::open(label, wgpu::Features::empty(), choose).map(|(gpu, _)| gpu)
}
