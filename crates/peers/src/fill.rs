//! Store-bandwidth rooflines: the least work any raster call does, writing every cell once and
//! handing the raster to the host.

use crate::device::{self, Gpu, Grown};
use rayon::prelude::*;

/// Cells each rayon task fills: large enough to amortise scheduling, small enough to balance.
const CPU_CHUNK: usize = 1 << 16;

/// Store-bandwidth roofline on the CPU: allocate `cells` zeroed cells and fill them
/// with `value` on all cores. The buffer is returned so the caller can keep the optimiser from
/// removing the stores.
pub fn fill_cpu(cells: usize, value: f32) -> Vec<f32> {
    // Allocated as tileraster allocates its rasters (`zeroed_cells`: huge pages where the
    // system gives them; lazily mapped zeros above 32 MiB, so the page faults land in the
    // parallel fill as they do when the rasteriser writes its output; below, cleared on all
    // cores first, as a raster's layers are).
    let mut out: Vec<f32> = tileraster_core::zeroed_cells(cells).expect("memory for the roofline raster");
    out.par_chunks_mut(CPU_CHUNK).for_each(|chunk| chunk.fill(value));
    out
}

const SHADER: &str = r#"
struct Params {
    value: f32,
    count: u32,
    row: u32,
    pad: u32,
};

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read_write> cells: array<f32>;

@compute @workgroup_size(256)
fn fill(@builtin(global_invocation_id) id: vec3<u32>) {
    let i = id.y * params.row + id.x;
    if (i < params.count) {
        cells[i] = params.value;
    }
}
"#;

const WORKGROUP: u64 = 256;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Params {
    value: f32,
    count: u32,
    row: u32,
    pad: u32,
}

/// Store-bandwidth roofline on the GPU: a WGSL compute shader writes `value` into a storage
/// buffer of `cells` f32 and the buffer is read back to the host, the same work a raster call
/// must do at least. The device, pipeline and buffers are kept across calls.
pub struct GpuFill {
    gpu: Gpu,
    pipeline: wgpu::ComputePipeline,
    params: wgpu::Buffer,
    storage: Grown,
    readback: Grown,
    /// Most cells one dispatch writes: one storage binding's worth. Larger fills are done in
    /// chunks of this size, one after the other.
    chunk_cells: u64,
}

impl GpuFill {
    /// Open the adapter (a discrete GPU first; `TILERASTER_ADAPTER` picks one by name) and build
    /// the pipeline.
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let pipeline = gpu.scoped(|gpu| {
            let module =
                gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("fill peer"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
            Ok(gpu.device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("fill peer"),
                layout: None,
                module: &module,
                entry_point: Some("fill"),
                compilation_options: Default::default(),
                cache: None,
            }))
        })?;
        let params = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("fill peer params"),
            size: std::mem::size_of::<Params>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        // Whole 256-byte blocks, so every chunk's copy stays aligned, and at most 2^31 cells, so
        // the shader's u32 cell index cannot wrap.
        let chunk_cells = ((gpu.max_storage_binding() / 4).min(1 << 31) / 64 * 64).max(64);
        Ok(GpuFill {
            gpu,
            pipeline,
            params,
            storage: Grown::new("fill peer cells", wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC),
            readback: Grown::new("fill peer readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
            chunk_cells,
        })
    }

    /// The adapter's name.
    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Fill `cells` values with `value` on the GPU and read them back.
    pub fn fill(&mut self, cells: usize, value: f32) -> Result<Vec<f32>, String> {
        let _turn = device::turn();
        // Allocated as tileraster allocates its rasters (see `fill_cpu`): a plain zeroed
        // vector would fault in 4 KiB pages during the read-back copy, which the rasteriser's
        // own read-back does not, and make the roofline slower than a whole raster call.
        let mut out: Vec<f32> = tileraster_core::zeroed_cells(cells)?;
        let chunk_cells = self.chunk_cells;
        let max_groups = self.gpu.limits.max_compute_workgroups_per_dimension as u64;
        let pipeline = self.pipeline.clone();
        let params = self.params.clone();
        let storage = self.storage.get(&self.gpu.device, chunk_cells.min(cells as u64) * 4);
        let readback = self.readback.get(&self.gpu.device, chunk_cells.min(cells as u64) * 4);
        self.gpu.scoped(|gpu| {
            for chunk in out.chunks_mut(chunk_cells as usize) {
                let count = chunk.len() as u64;
                // A 2D grid of workgroups: one dimension alone holds only 65,535 of them.
                let groups = count.div_ceil(WORKGROUP);
                let gx = groups.min(max_groups);
                let gy = groups.div_ceil(gx);
                if gy > max_groups {
                    return Err(format!("{count} cells need more workgroups than the device dispatches at once"));
                }
                let p = Params { value, count: count as u32, row: (gx * WORKGROUP) as u32, pad: 0 };
                gpu.queue.write_buffer(&params, 0, bytemuck::bytes_of(&p));
                let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                    label: None,
                    layout: &pipeline.get_bind_group_layout(0),
                    entries: &[
                        wgpu::BindGroupEntry { binding: 0, resource: params.as_entire_binding() },
                        wgpu::BindGroupEntry { binding: 1, resource: storage.as_entire_binding() },
                    ],
                });
                let mut encoder = gpu.device.create_command_encoder(&Default::default());
                {
                    let mut pass = encoder.begin_compute_pass(&Default::default());
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.dispatch_workgroups(gx as u32, gy as u32, 1);
                }
                encoder.copy_buffer_to_buffer(&storage, 0, &readback, 0, count * 4);
                gpu.submit_and_read(encoder, &readback, count * 4, |bytes| {
                    // On all cores, as the GPU backend copies its rasters out.
                    let words: &[f32] = bytemuck::cast_slice(bytes);
                    chunk.par_chunks_mut(CPU_CHUNK).zip(words.par_chunks(CPU_CHUNK)).for_each(|(d, s)| d.copy_from_slice(s));
                })?;
            }
            Ok(())
        })?;
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cpu_fill_writes_every_cell() {
        for cells in [0, 1, CPU_CHUNK - 1, 3 * CPU_CHUNK + 7] {
            let out = fill_cpu(cells, 2.5);
            assert_eq!(out.len(), cells);
            assert!(out.iter().all(|&v| v == 2.5), "{cells} cells");
        }
    }

    fn gpu_fill() -> GpuFill {
        GpuFill::new().unwrap_or_else(|e| {
            panic!(
                "the GPU fill peer needs a Vulkan adapter and none could be opened: {e}. \
                 Install one (apt-get install mesa-vulkan-drivers libvulkan1 gives lavapipe)"
            )
        })
    }

    #[test]
    fn gpu_fill_writes_every_cell() {
        let mut fill = gpu_fill();
        for (cells, value) in [(0, 1.0), (1, -3.0), (1000, 7.25), ((1 << 20) + 3, f32::NAN)] {
            let out = fill.fill(cells, value).expect("fill");
            assert_eq!(out.len(), cells);
            assert!(out.iter().all(|v| v.to_bits() == value.to_bits()), "{cells} cells of {value}");
        }
    }

    #[test]
    fn gpu_fill_in_chunks() {
        let mut fill = gpu_fill();
        // Pretend one binding holds only 64 × 100 cells, so the fill takes several dispatches.
        fill.chunk_cells = 6400;
        let cells = 6400 * 3 + 17;
        let out = fill.fill(cells, 4.0).expect("fill");
        assert_eq!(out.len(), cells);
        assert!(out.iter().all(|&v| v == 4.0));
        let out = fill.fill(10, 5.0).expect("fill");
        assert!(out.iter().all(|&v| v == 5.0));
    }
}
