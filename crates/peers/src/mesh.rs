//! The hardware render pipeline for meshes: what a wgpu user draws a depth-tested mesh with.

use crate::device::{self, Gpu, Grown};

/// The vertex stage of the peers that draw ids: it multiplies by one 4×4 matrix (in `f32`, as
/// a shader does) and flips `y` (wgpu's NDC `y` points up, tileraster's, as Vulkan's, down),
/// and passes the primitive's id on flat ([`Vertex`]).
pub(crate) const ID_VERTEX_STAGE: &str = r#"
struct Uniforms {
    m: mat4x4<f32>,
};
@group(0) @binding(0) var<uniform> u: Uniforms;

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(flat) id: u32,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) id: u32) -> Varyings {
    let c = u.m * vec4<f32>(position, 1.0);
    var out: Varyings;
    out.position = vec4<f32>(c.x, -c.y, c.z, c.w);
    out.id = id;
    return out;
}
"#;

/// The fragment stage writes the id.
const FRAGMENT: &str = r#"
@fragment
fn fs_main(v: Varyings) -> @location(0) u32 {
    return v.id;
}
"#;

const IDS: wgpu::TextureFormat = wgpu::TextureFormat::R32Uint;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// A corner of a primitive, with the primitive's id.
#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
pub(crate) struct Vertex {
    pub position: [f32; 3],
    pub id: u32,
}

/// The id of a pixel no triangle covers.
pub const NO_ID: u32 = u32::MAX;

/// A wgpu render pipeline drawing a mesh's triangles into an R32Uint target of triangle ids:
/// with a `Depth32Float` depth buffer and the `Less` test, or with none (the last triangle drawn
/// over a pixel keeps it, by the API's primitive order). No culling; pixel centres sampled
/// with the device's rasterisation rules. It draws line and point lists likewise, without a
/// depth test, as the device rasterises lines and points one pixel wide.
pub struct MeshPipeline {
    gpu: Gpu,
    depth_tested: wgpu::RenderPipeline,
    in_order: wgpu::RenderPipeline,
    lines: wgpu::RenderPipeline,
    points: wgpu::RenderPipeline,
    uniforms: wgpu::Buffer,
    vertices: Grown,
    readback: Grown,
}

impl MeshPipeline {
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let (depth_tested, in_order, lines, points, uniforms) = gpu.scoped(|gpu| {
            use wgpu::PrimitiveTopology::TriangleList as Triangles;
            let module = gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some("mesh peer"),
                source: wgpu::ShaderSource::Wgsl(format!("{ID_VERTEX_STAGE}{FRAGMENT}").into()),
            });
            let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Uint32];
            let stride = std::mem::size_of::<Vertex>() as u64;
            let pipeline = |topology, depth: bool| device::mesh_pipeline(&gpu.device, &module, "mesh peer", topology, stride, &attributes, IDS, depth);
            let uniforms = gpu.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("mesh peer matrix"),
                size: 64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            Ok((
                pipeline(Triangles, true),
                pipeline(Triangles, false),
                pipeline(wgpu::PrimitiveTopology::LineList, false),
                pipeline(wgpu::PrimitiveTopology::PointList, false),
                uniforms,
            ))
        })?;
        Ok(MeshPipeline {
            gpu,
            depth_tested,
            in_order,
            lines,
            points,
            uniforms,
            vertices: Grown::new("mesh peer vertices", wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST),
            readback: Grown::new("mesh peer readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
        })
    }

    /// The adapter's name, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Draw `triangles` (indices into `positions`) transformed by `matrix` (row-major, to clip
    /// space with depth 0..1 and NDC `y` down) into a `width × height` target and read back the
    /// triangle index per pixel, row 0 at the top, [`NO_ID`] where none.
    pub fn draw_ids(
        &mut self,
        positions: &[[f32; 3]],
        triangles: &[[u32; 3]],
        matrix: &[[f32; 4]; 4],
        width: u32,
        height: u32,
        depth_test: bool,
    ) -> Result<Vec<u32>, String> {
        let pipeline = if depth_test { self.depth_tested.clone() } else { self.in_order.clone() };
        self.draw(positions, triangles, matrix, width, height, pipeline, depth_test)
    }

    /// Draw `lines` (pairs of indices into `positions`) as `draw_ids` draws triangles, without
    /// a depth test (the last line drawn over a pixel keeps it): the line index per pixel.
    pub fn draw_line_ids(&mut self, positions: &[[f32; 3]], lines: &[[u32; 2]], matrix: &[[f32; 4]; 4], width: u32, height: u32) -> Result<Vec<u32>, String> {
        let pipeline = self.lines.clone();
        self.draw(positions, lines, matrix, width, height, pipeline, false)
    }

    /// Draw every vertex of `positions` as a point (one pixel wide, as WebGPU's points are), as
    /// `draw_line_ids` draws lines: the vertex index per pixel.
    pub fn draw_point_ids(&mut self, positions: &[[f32; 3]], matrix: &[[f32; 4]; 4], width: u32, height: u32) -> Result<Vec<u32>, String> {
        let points: Vec<[u32; 1]> = (0..positions.len() as u32).map(|v| [v]).collect();
        let pipeline = self.points.clone();
        self.draw(positions, &points, matrix, width, height, pipeline, false)
    }

    #[allow(clippy::too_many_arguments)]
    fn draw<const N: usize>(
        &mut self,
        positions: &[[f32; 3]],
        primitives: &[[u32; N]],
        matrix: &[[f32; 4]; 4],
        width: u32,
        height: u32,
        pipeline: wgpu::RenderPipeline,
        depth_test: bool,
    ) -> Result<Vec<u32>, String> {
        let _turn = device::turn();
        let limits = &self.gpu.limits;
        let max_dim = limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max_dim || height > max_dim {
            return Err(format!("a {width}×{height} target is not between 1×1 and the device's {max_dim}×{max_dim}"));
        }
        if let Some((t, p)) = primitives.iter().enumerate().find(|(_, p)| p.iter().any(|&i| i as usize >= positions.len())) {
            return Err(format!("primitive {t} ({p:?}) refers to a vertex beyond the {} vertices", positions.len()));
        }
        // One vertex per corner, each carrying its primitive's id (no primitive-id feature needed).
        let vertices: Vec<Vertex> =
            primitives.iter().enumerate().flat_map(|(t, p)| p.map(|v| Vertex { position: positions[v as usize], id: t as u32 })).collect();
        let vertex_bytes = std::mem::size_of_val(vertices.as_slice()) as u64;
        let readback_bytes = device::readback_bytes(width, height);
        for (what, bytes) in [("vertex", vertex_bytes), ("readback", readback_bytes)] {
            if bytes > limits.max_buffer_size {
                return Err(format!("the {what} buffer needs {bytes} bytes, more than the device's largest buffer ({} bytes)", limits.max_buffer_size));
            }
        }
        // WGSL matrices are column-major.
        let columns: [f32; 16] = std::array::from_fn(|k| matrix[k % 4][k / 4]);
        let device = self.gpu.device.clone();
        let texture = |label, format| device::render_target(&device, label, width, height, format);
        let ids = texture("mesh peer ids", IDS);
        let depth = depth_test.then(|| texture("mesh peer depth", DEPTH));
        let vertex_buffer = self.vertices.get(&device, vertex_bytes.max(4));
        let readback = self.readback.get(&device, readback_bytes);
        let uniforms = self.uniforms.clone();
        self.gpu.scoped(|gpu| {
            gpu.queue.write_buffer(&uniforms, 0, bytemuck::cast_slice(&columns));
            gpu.queue.write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&vertices));
            let bind = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("mesh peer"),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() }],
            });
            let ids_view = ids.create_view(&Default::default());
            let depth_view = depth.as_ref().map(|d| d.create_view(&Default::default()));
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass =
                    device::begin_pass(&mut encoder, "mesh peer", &ids_view, wgpu::Color { r: NO_ID as f64, g: 0.0, b: 0.0, a: 0.0 }, depth_view.as_ref());
                if !vertices.is_empty() {
                    pass.set_pipeline(&pipeline);
                    pass.set_bind_group(0, &bind, &[]);
                    pass.set_vertex_buffer(0, vertex_buffer.slice(..vertex_bytes));
                    pass.draw(0..vertices.len() as u32, 0..1);
                }
            }
            device::read_target(gpu, encoder, &ids, &readback, width, height)
        })
    }
}
