//! The hardware render pipeline with 4× multisampling: a mesh drawn depth-tested into a
//! multisampled target of triangle ids, every sample read back (a compute pass loads each
//! one), the reference for tileraster's per-sample coverage and depth.

use crate::device::{self, Gpu};
use crate::mesh::{ID_VERTEX_STAGE, Vertex};

/// After `MeshPipeline`'s vertex stage, the fragment stage writes the triangle's id in the
/// colour's three low bytes (exact in `Rgba8Unorm`, which every WebGPU device multisamples 4×).
const FRAGMENT: &str = r#"
@fragment
fn fs_main(v: Varyings) -> @location(0) vec4<f32> {
    return vec4<f32>(f32(v.id & 255u), f32((v.id >> 8u) & 255u), f32((v.id >> 16u) & 255u), 255.0) / 255.0;
}
"#;

/// Every sample of every pixel, `samples` words per pixel.
const READ: &str = r#"
@group(0) @binding(0) var frame: texture_multisampled_2d<f32>;
@group(0) @binding(1) var<storage, read_write> out: array<u32>;
@group(0) @binding(2) var<uniform> size: vec4<u32>;

@compute @workgroup_size(8, 8)
fn main(@builtin(global_invocation_id) g: vec3<u32>) {
    if (g.x >= size.x || g.y >= size.y) {
        return;
    }
    for (var s = 0u; s < size.z; s++) {
        out[(g.y * size.x + g.x) * size.z + s] = pack4x8unorm(textureLoad(frame, vec2<i32>(g.xy), i32(s)));
    }
}
"#;

/// The samples per pixel: the count WebGPU guarantees for `Rgba8Unorm` and `Depth32Float`.
pub const PEER_SAMPLES: u32 = 4;

/// The id of a sample no triangle covers.
pub const NO_SAMPLE_ID: u32 = 0x00ff_ffff;

/// A wgpu render pipeline drawing a mesh's triangles 4× multisampled, depth-tested (`Less`),
/// with no culling; its samples' triangle ids are read back.
pub struct MultisampledPipeline {
    gpu: Gpu,
    draw: wgpu::RenderPipeline,
    read: wgpu::ComputePipeline,
}

impl MultisampledPipeline {
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let (draw, read) = gpu.scoped(|gpu| {
            let device = &gpu.device;
            let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("multisampled peer"),
                source: wgpu::ShaderSource::Wgsl(format!("{ID_VERTEX_STAGE}{FRAGMENT}").into()),
            });
            let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
            let draw = device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("multisampled peer"),
                layout: None,
                vertex: wgpu::VertexState {
                    module: &module,
                    entry_point: Some("vs_main"),
                    compilation_options: Default::default(),
                    buffers: &[Some(wgpu::VertexBufferLayout {
                        array_stride: std::mem::size_of::<Vertex>() as u64,
                        step_mode: wgpu::VertexStepMode::Vertex,
                        attributes: &attributes,
                    })],
                },
                primitive: wgpu::PrimitiveState { topology: wgpu::PrimitiveTopology::TriangleList, cull_mode: None, ..Default::default() },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: wgpu::TextureFormat::Depth32Float,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::Less),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState { count: PEER_SAMPLES, mask: !0, alpha_to_coverage_enabled: false },
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format: wgpu::TextureFormat::Rgba8Unorm, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            });
            let reader = device
                .create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("multisampled peer read"), source: wgpu::ShaderSource::Wgsl(READ.into()) });
            let read = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some("multisampled peer read"),
                layout: None,
                module: &reader,
                entry_point: Some("main"),
                compilation_options: Default::default(),
                cache: None,
            });
            Ok((draw, read))
        })?;
        Ok(MultisampledPipeline { gpu, draw, read })
    }

    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Draw `triangles` (indices into `positions`) transformed by `matrix` (row-major, to clip
    /// space with depth 0..1 and NDC `y` down) into a `width × height` target, and read back
    /// the triangle index of every sample: [`PEER_SAMPLES`] per pixel, rows from the top,
    /// [`NO_SAMPLE_ID`] where none. At most 2^24 − 1 triangles.
    pub fn draw_sample_ids(
        &mut self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        matrix: &[[f32; 4]; 4],
        width: u32,
        height: u32,
    ) -> Result<Vec<u32>, String> {
        let _turn = device::turn();
        if triangles.len() >= NO_SAMPLE_ID as usize {
            return Err(format!("{} triangles: at most {} have ids in three bytes", triangles.len(), NO_SAMPLE_ID - 1));
        }
        if let Some((t, tri)) = triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&i| i as usize >= positions.len())) {
            return Err(format!("triangle {t} ({tri:?}) refers to a vertex beyond the {} vertices", positions.len()));
        }
        let max_dim = self.gpu.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max_dim || height > max_dim {
            return Err(format!("a {width}×{height} target is not between 1×1 and the device's {max_dim}×{max_dim}"));
        }
        let vertices: Vec<Vertex> =
            triangles.iter().enumerate().flat_map(|(t, tri)| tri.map(|v| Vertex { position: positions[v as usize], id: t as u32 })).collect();
        let columns: [f32; 16] = std::array::from_fn(|k| matrix[k % 4][k / 4]);
        let out_bytes = width as u64 * height as u64 * PEER_SAMPLES as u64 * 4;
        let (draw, read) = (self.draw.clone(), self.read.clone());
        self.gpu.scoped(|gpu| {
            use wgpu::util::DeviceExt;
            let device = &gpu.device;
            let buffer = |label, contents: &[u8], usage| device.create_buffer_init(&wgpu::util::BufferInitDescriptor { label: Some(label), contents, usage });
            let uniforms = buffer("multisampled peer matrix", bytemuck::cast_slice(&columns), wgpu::BufferUsages::UNIFORM);
            let size = buffer("multisampled peer size", bytemuck::cast_slice(&[width, height, PEER_SAMPLES, 0]), wgpu::BufferUsages::UNIFORM);
            let vertex_buffer = buffer("multisampled peer vertices", bytemuck::cast_slice(&vertices), wgpu::BufferUsages::VERTEX);
            let texture = |label, format, usage| {
                device.create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: wgpu::Extent3d { width, height, depth_or_array_layers: 1 },
                    mip_level_count: 1,
                    sample_count: PEER_SAMPLES,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage,
                    view_formats: &[],
                })
            };
            let target = texture(
                "multisampled peer ids",
                wgpu::TextureFormat::Rgba8Unorm,
                wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::TEXTURE_BINDING,
            );
            let depth = texture("multisampled peer depth", wgpu::TextureFormat::Depth32Float, wgpu::TextureUsages::RENDER_ATTACHMENT);
            let out = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("multisampled peer samples"),
                size: out_bytes,
                usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
                mapped_at_creation: false,
            });
            let readback = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("multisampled peer readback"),
                size: out_bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let (target_view, depth_view) = (target.create_view(&Default::default()), depth.create_view(&Default::default()));
            let draw_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("multisampled peer"),
                layout: &draw.get_bind_group_layout(0),
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
            });
            let read_bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("multisampled peer read"),
                layout: &read.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: wgpu::BindingResource::TextureView(&target_view) },
                    wgpu::BindGroupEntry { binding: 1, resource: out.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 2, resource: size.as_entire_binding() },
                ],
            });
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass =
                    device::begin_pass(&mut encoder, "multisampled peer", &target_view, wgpu::Color { r: 1.0, g: 1.0, b: 1.0, a: 1.0 }, Some(&depth_view));
                pass.set_pipeline(&draw);
                pass.set_bind_group(0, &draw_bind, &[]);
                pass.set_vertex_buffer(0, vertex_buffer.slice(..));
                pass.draw(0..vertices.len() as u32, 0..1);
            }
            {
                let mut pass = encoder.begin_compute_pass(&Default::default());
                pass.set_pipeline(&read);
                pass.set_bind_group(0, &read_bind, &[]);
                pass.dispatch_workgroups(width.div_ceil(8), height.div_ceil(8), 1);
            }
            encoder.copy_buffer_to_buffer(&out, 0, &readback, 0, out_bytes);
            let mut ids = Vec::with_capacity((out_bytes / 4) as usize);
            gpu.submit_and_read(encoder, &readback, out_bytes, |bytes| {
                ids.extend(bytemuck::cast_slice::<u8, u32>(bytes).iter().map(|&rgba| rgba & 0x00ff_ffff));
            })?;
            Ok(ids)
        })
    }
}
