//! The hardware rasteriser peer: a plain wgpu render pipeline.

use crate::device::{self, Gpu, Grown};
use tileraster_core::{Grid, Scene};

/// Pass-through vertex stage and a fragment stage that writes the interpolated height. With
/// `w = 1` perspective-correct and linear interpolation agree; `linear` says what is meant.
const SHADER: &str = r#"
struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) @interpolate(linear) height: f32,
};

@vertex
fn vs_main(@location(0) ndc: vec2<f32>, @location(1) height: f32) -> Varyings {
    var out: Varyings;
    out.position = vec4<f32>(ndc, 0.0, 1.0);
    out.height = height;
    return out;
}

@fragment
fn fs_main(in: Varyings) -> @location(0) vec4<f32> {
    return vec4<f32>(in.height, 0.0, 0.0, 1.0);
}
"#;

const FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::R32Float;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    ndc: [f32; 2],
    height: f32,
}

/// A wgpu render pipeline (vertex + fragment shader in WGSL) drawing the scene's triangles into
/// an R32Float render target of the grid's size, as a user of a hardware rasteriser would:
/// vertices mapped to NDC in f64 on the host then cast to f32, the height passed as an f32
/// vertex attribute and interpolated linearly, the target cleared to nodata. Where triangles
/// overlap, the one drawn last (highest index) wins, by the API's primitive order.
pub struct RenderPipeline {
    gpu: Gpu,
    pipeline: wgpu::RenderPipeline,
    /// The render target, kept while the grid size stays the same.
    target: Option<(wgpu::Texture, u32, u32)>,
    vertices: Grown,
    indices: Grown,
    readback: Grown,
}

impl RenderPipeline {
    /// Open the adapter (a discrete GPU first; `TILERASTER_ADAPTER` picks one by name) and build
    /// the pipeline.
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let pipeline = gpu.scoped(|gpu| {
            let module =
                gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("render peer"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
            let attributes = wgpu::vertex_attr_array![0 => Float32x2, 1 => Float32];
            Ok(gpu.device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some("render peer"),
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
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    // Scenes come in either winding.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: None,
                multisample: Default::default(),
                fragment: Some(wgpu::FragmentState {
                    module: &module,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState { format: FORMAT, blend: None, write_mask: wgpu::ColorWrites::ALL })],
                }),
                multiview_mask: None,
                cache: None,
            }))
        })?;
        Ok(RenderPipeline {
            gpu,
            pipeline,
            target: None,
            vertices: Grown::new("render peer vertices", wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST),
            indices: Grown::new("render peer indices", wgpu::BufferUsages::INDEX | wgpu::BufferUsages::COPY_DST),
            readback: Grown::new("render peer readback", wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST),
        })
    }

    /// The adapter's name, e.g. "llvmpipe (LLVM 15.0.6, 256 bits)".
    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Render and read back: row-major values, row 0 at the top (`ymax`), `grid.width *
    /// grid.height` cells, `nodata` where no triangle covers a cell centre. Grids larger than
    /// the device's texture or buffer limits are an error.
    pub fn rasterise(&mut self, scene: &Scene, grid: &Grid, nodata: f32) -> Result<Vec<f32>, String> {
        let _turn = device::turn();
        grid.validate().map_err(|e| e.to_string())?;
        let (width, height) = (grid.width, grid.height);
        let limits = &self.gpu.limits;
        let max_dim = limits.max_texture_dimension_2d;
        if width > max_dim || height > max_dim {
            return Err(format!("a {width}×{height} grid exceeds the device's largest render target ({max_dim}×{max_dim})"));
        }
        // Texture-to-buffer copies need rows padded to 256 bytes; the padding is dropped below.
        let readback_bytes = crate::device::readback_bytes(width, height);
        let vertex_bytes = (scene.vertices.len() * std::mem::size_of::<Vertex>()) as u64;
        let index_count = scene.triangles.len() as u64 * 3;
        for (what, bytes) in [("readback", readback_bytes), ("vertex", vertex_bytes), ("index", index_count * 4)] {
            if bytes > limits.max_buffer_size {
                return Err(format!(
                    "a {width}×{height} grid needs a {what} buffer of {bytes} bytes, more than the device's \
                     largest buffer ({} bytes)",
                    limits.max_buffer_size
                ));
            }
        }
        if index_count > u32::MAX as u64 {
            return Err(format!("{} triangles are more than one draw call takes", scene.triangles.len()));
        }
        // An out-of-range index would be undefined behaviour for the GPU: reject it here.
        let vertex_count = scene.vertices.len();
        if let Some((t, tri)) = scene.triangles.iter().enumerate().find(|(_, t)| t.iter().any(|&i| i as usize >= vertex_count)) {
            return Err(format!("triangle {t} ({tri:?}) refers to a vertex beyond the {vertex_count} vertices"));
        }

        // World → raster pixels → NDC, in f64 on the host; framebuffer y grows downwards and NDC
        // y upwards, so raster row 0 (ymax) lands at the top of the target.
        let vertices: Vec<Vertex> = scene
            .vertices
            .iter()
            .map(|&[x, y, z]| {
                let (u, v) = grid.to_raster(x, y);
                Vertex { ndc: [(2.0 * u / width as f64 - 1.0) as f32, (1.0 - 2.0 * v / height as f64) as f32], height: z as f32 }
            })
            .collect();

        if self.target.as_ref().is_none_or(|&(_, w, h)| (w, h) != (width, height)) {
            self.target = None;
            self.target = Some((crate::device::render_target(&self.gpu.device, "render peer target", width, height, FORMAT), width, height));
        }
        let target = self.target.as_ref().expect("just created").0.clone();
        let vertex_buffer = self.vertices.get(&self.gpu.device, vertex_bytes);
        let index_buffer = self.indices.get(&self.gpu.device, index_count * 4);
        let readback = self.readback.get(&self.gpu.device, readback_bytes);
        let pipeline = self.pipeline.clone();

        self.gpu.scoped(|gpu| {
            gpu.queue.write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&vertices));
            gpu.queue.write_buffer(&index_buffer, 0, bytemuck::cast_slice(&scene.triangles));
            let view = target.create_view(&Default::default());
            let mut encoder = gpu.device.create_command_encoder(&Default::default());
            {
                let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                    label: Some("render peer"),
                    color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                        view: &view,
                        depth_slice: None,
                        resolve_target: None,
                        ops: wgpu::Operations {
                            load: wgpu::LoadOp::Clear(wgpu::Color { r: nodata as f64, g: 0.0, b: 0.0, a: 1.0 }),
                            store: wgpu::StoreOp::Store,
                        },
                    })],
                    depth_stencil_attachment: None,
                    timestamp_writes: None,
                    occlusion_query_set: None,
                    multiview_mask: None,
                });
                if index_count > 0 {
                    pass.set_pipeline(&pipeline);
                    pass.set_vertex_buffer(0, vertex_buffer.slice(..vertex_bytes));
                    pass.set_index_buffer(index_buffer.slice(..index_count * 4), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(0..index_count as u32, 0, 0..1);
                }
            }
            let values: Vec<f32> = crate::device::read_target(gpu, encoder, &target, &readback, width, height)?;
            Ok(values)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pipeline() -> RenderPipeline {
        RenderPipeline::new().unwrap_or_else(|e| {
            panic!(
                "the render pipeline peer needs a Vulkan adapter and none could be opened: {e}. \
                 Install one (apt-get install mesa-vulkan-drivers libvulkan1 gives lavapipe)"
            )
        })
    }

    /// A square from (10.3, 12.7) to (50.1, 41.9) on a 64×64 grid over [0, 64]², cut into two
    /// triangles of opposite winding, carrying the plane z = 100 + 0.5x − 0.25y. No cell centre
    /// lies near an edge, so coverage is unambiguous.
    fn check_square(nodata: f32) {
        let plane = |x: f64, y: f64| 100.0 + 0.5 * x - 0.25 * y;
        let (x0, x1, y0, y1) = (10.3, 50.1, 12.7, 41.9);
        let corners = [[x0, y0], [x1, y0], [x1, y1], [x0, y1]];
        let vertices = corners.iter().map(|&[x, y]| [x, y, plane(x, y)]).collect();
        let scene = Scene::new(vertices, vec![[0, 1, 2], [0, 3, 2]]);
        let grid = Grid::new(0.0, 64.0, 0.0, 64.0, 64, 64);
        let mut peer = pipeline();
        let values = peer.rasterise(&scene, &grid, nodata).expect("render");
        assert_eq!(values.len(), 64 * 64);
        for j in 0..64 {
            for i in 0..64 {
                let (x, y) = grid.cell_centre(i, j);
                let got = values[(j * 64 + i) as usize];
                if x > x0 && x < x1 && y > y0 && y < y1 {
                    let want = plane(x, y);
                    let rel = ((got as f64 - want) / want).abs();
                    assert!(rel <= 1e-3, "cell ({i}, {j}) at ({x}, {y}): got {got}, the plane gives {want}");
                } else {
                    assert!(got.to_bits() == nodata.to_bits(), "cell ({i}, {j}) at ({x}, {y}) is outside the square but holds {got}, not nodata {nodata}");
                }
            }
        }
    }

    #[test]
    fn square_matches_the_plane() {
        check_square(-9999.0);
    }

    #[test]
    fn nan_nodata_survives_the_clear() {
        check_square(f32::NAN);
    }

    #[test]
    fn reuses_its_target_across_sizes() {
        let mut peer = pipeline();
        let scene = Scene::new(vec![[0.0, 0.0, 1.0], [10.0, 0.0, 1.0], [0.0, 10.0, 1.0]], vec![[0, 1, 2]]);
        for size in [8, 8, 3, 300] {
            let grid = Grid::new(0.0, 10.0, 0.0, 10.0, size, size);
            let values = peer.rasterise(&scene, &grid, -1.0).expect("render");
            assert_eq!(values.len(), (size * size) as usize);
            // The bottom-left cell is inside the triangle, the top-right one outside.
            assert_eq!(values[((size - 1) * size) as usize], 1.0, "size {size}");
            assert_eq!(values[(size - 1) as usize], -1.0, "size {size}");
        }
    }

    #[test]
    fn too_large_a_grid_is_an_error() {
        let mut peer = pipeline();
        let side = peer.gpu.limits.max_texture_dimension_2d + 1;
        let scene = Scene::new(vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], vec![[0, 1, 2]]);
        let err = peer.rasterise(&scene, &Grid::new(0.0, 1.0, 0.0, 1.0, side, 1), 0.0).unwrap_err();
        assert!(err.contains("largest render target"), "{err}");
    }

    #[test]
    fn empty_scene_is_all_nodata() {
        let mut peer = pipeline();
        let values = peer.rasterise(&Scene::default(), &Grid::new(0.0, 1.0, 0.0, 1.0, 5, 3), 7.0).expect("render");
        assert_eq!(values, vec![7.0; 15]);
    }

    #[test]
    fn bad_index_is_an_error() {
        let mut peer = pipeline();
        let scene = Scene::new(vec![[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [0.0, 1.0, 1.0]], vec![[0, 1, 3]]);
        assert!(peer.rasterise(&scene, &Grid::new(0.0, 1.0, 0.0, 1.0, 4, 4), 0.0).is_err());
    }
}
