//! The GPU peers open their device with the GPU backend's helpers
//! (`tileraster_gpu::device`), on the adapter the backend itself uses.
//!
//! They share one device per process and take turns on it, as tileraster's own GPU calls do
//! (one context behind a lock). On an NVIDIA H200 the peers' tests, each opening its own device
//! and drawing on it while the others did, hung in 2 of 5 runs with four or more test threads
//! and in none with one or two; opening the devices one at a time did not cure it.

use std::sync::{Mutex, MutexGuard, OnceLock, PoisonError};

pub(crate) use tileraster_gpu::device::{Gpu, Grown};

/// A render pipeline of `topology` (triangle or line lists) from `module`'s `vs_main` and
/// `fs_main`, with one vertex buffer of `stride`-byte vertices, no culling, one colour target of
/// `format`, and a `Depth32Float` buffer with the `Less` test where `depth_tested`: how the
/// peers draw meshes.
#[allow(clippy::too_many_arguments)]
pub(crate) fn mesh_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    label: &str,
    topology: wgpu::PrimitiveTopology,
    stride: u64,
    attributes: &[wgpu::VertexAttribute],
    format: wgpu::TextureFormat,
    depth_tested: bool,
) -> wgpu::RenderPipeline {
    device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
        label: Some(label),
        layout: None,
        vertex: wgpu::VertexState {
            module,
            entry_point: Some("vs_main"),
            compilation_options: Default::default(),
            buffers: &[Some(wgpu::VertexBufferLayout { array_stride: stride, step_mode: wgpu::VertexStepMode::Vertex, attributes })],
        },
        primitive: wgpu::PrimitiveState { topology, cull_mode: None, ..Default::default() },
        depth_stencil: depth_tested.then(|| wgpu::DepthStencilState {
            format: wgpu::TextureFormat::Depth32Float,
            depth_write_enabled: Some(true),
            depth_compare: Some(wgpu::CompareFunction::Less),
            stencil: Default::default(),
            bias: Default::default(),
        }),
        multisample: Default::default(),
        fragment: Some(wgpu::FragmentState {
            module,
            entry_point: Some("fs_main"),
            compilation_options: Default::default(),
            targets: &[Some(wgpu::ColorTargetState { format, blend: None, write_mask: wgpu::ColorWrites::ALL })],
        }),
        multiview_mask: None,
        cache: None,
    })
}

/// A render pass clearing `colour` to `clear` and, where given, `depth` to 1 (the depth is not
/// kept): how the peers draw a frame.
pub(crate) fn begin_pass<'e>(
    encoder: &'e mut wgpu::CommandEncoder,
    label: &str,
    colour: &wgpu::TextureView,
    clear: wgpu::Color,
    depth: Option<&wgpu::TextureView>,
) -> wgpu::RenderPass<'e> {
    encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
        label: Some(label),
        color_attachments: &[Some(wgpu::RenderPassColorAttachment {
            view: colour,
            depth_slice: None,
            resolve_target: None,
            ops: wgpu::Operations { load: wgpu::LoadOp::Clear(clear), store: wgpu::StoreOp::Store },
        })],
        depth_stencil_attachment: depth.map(|view| wgpu::RenderPassDepthStencilAttachment {
            view,
            depth_ops: Some(wgpu::Operations { load: wgpu::LoadOp::Clear(1.0), store: wgpu::StoreOp::Discard }),
            stencil_ops: None,
        }),
        timestamp_writes: None,
        occlusion_query_set: None,
        multiview_mask: None,
    })
}

/// A `width × height` render target of `format` that the peers draw into and copy out of.
pub(crate) fn render_target(device: &wgpu::Device, label: &str, width: u32, height: u32, format: wgpu::TextureFormat) -> wgpu::Texture {
    device.create_texture(&wgpu::TextureDescriptor {
        label: Some(label),
        size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format,
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    })
}

/// Bytes of a readback buffer for a `width × height` target of 4-byte texels: texture-to-buffer
/// copies pad each row to 256 bytes.
pub(crate) fn readback_bytes(width: u32, height: u32) -> u64 {
    padded_row(width) * height as u64
}

fn padded_row(width: u32) -> u64 {
    (width as u64 * 4).next_multiple_of(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT as u64)
}

/// Copy `target` (4-byte texels, `width × height`) into `readback` after what `encoder`
/// recorded, submit, and return its texels row by row, the rows' padding dropped.
pub(crate) fn read_target<T: bytemuck::Pod>(
    gpu: &Gpu,
    mut encoder: wgpu::CommandEncoder,
    target: &wgpu::Texture,
    readback: &wgpu::Buffer,
    width: u32,
    height: u32,
) -> Result<Vec<T>, String> {
    let padded = padded_row(width);
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo { texture: target, mip_level: 0, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
        wgpu::TexelCopyBufferInfo {
            buffer: readback,
            layout: wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(padded as u32), rows_per_image: Some(height) },
        },
        wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
    );
    let mut out = Vec::with_capacity(width as usize * height as usize);
    gpu.submit_and_read(encoder, readback, padded * height as u64, |bytes| {
        for row in bytes.chunks_exact(padded as usize) {
            out.extend_from_slice(bytemuck::cast_slice::<u8, T>(&row[..width as usize * 4]));
        }
    })?;
    Ok(out)
}

/// The peers' device, opened on first use on the adapter tileraster's GPU backend uses (its
/// choice, `TILERASTER_ADAPTER` included), so that the peers run on the same device as the
/// kernels they are compared with. Call it during a [`turn`].
pub(crate) fn open() -> Result<Gpu, String> {
    static SHARED: OnceLock<Result<Gpu, String>> = OnceLock::new();
    SHARED
        .get_or_init(|| {
            let name = tileraster_gpu::adapter().map_err(|e| e.to_string())?.name;
            let choose = |adapters: Vec<wgpu::Adapter>| {
                let seen: Vec<String> = adapters.iter().map(|a| a.get_info().name).collect();
                adapters.into_iter().find(|a| a.get_info().name == name).ok_or_else(|| format!("tileraster's adapter {name:?} is not among {seen:?}"))
            };
            Gpu::open("tileraster-peers", wgpu::Features::empty(), wgpu::Features::empty(), choose).map(|(gpu, _)| gpu)
        })
        .clone()
}

/// The right to use the peers' device until the guard drops: each peer holds it while it builds
/// its pipelines and while it draws, so no two peers' work on the device overlaps.
pub(crate) fn turn() -> MutexGuard<'static, ()> {
    static TURN: Mutex<()> = Mutex::new(());
    // A peer that panicked mid-turn leaves no state behind the lock.
    TURN.lock().unwrap_or_else(PoisonError::into_inner)
}
