//! The GPU peers open their device with the GPU backend's helpers
//! (`tileraster_gpu::device`), on the adapter the backend itself uses.

pub(crate) use tileraster_gpu::device::{Gpu, Grown};

/// A render pipeline of triangle lists from `module`'s `vs_main` and `fs_main`, with one vertex
/// buffer of `stride`-byte vertices, no culling, one colour target of `format`, and a
/// `Depth32Float` buffer with the `Less` test where `depth_tested`: how the peers draw meshes.
pub(crate) fn triangle_pipeline(
    device: &wgpu::Device,
    module: &wgpu::ShaderModule,
    label: &str,
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
        primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleList, cull_mode: None, ..Default::default() },
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
