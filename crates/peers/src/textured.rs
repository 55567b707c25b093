//! The hardware render pipeline drawing a textured mesh: what a wgpu user writes for a
//! base-colour texture. The reference for tileraster's texture sampling, and its speed peer.

use crate::device::{self, Gpu};
use tileraster_core::render::{Address, Filter, Mesh, Texture};

/// Vertex colour times the texture's sample, interpolated perspective-correct; the matrix in
/// `f32` and `y` flipped as in the mesh peer.
const SHADER: &str = r#"
struct Uniforms {
    m: mat4x4<f32>,
};
@group(0) @binding(0) var<uniform> u: Uniforms;
@group(0) @binding(1) var base: texture_2d<f32>;
@group(0) @binding(2) var base_sampler: sampler;

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) uv: vec2<f32>,
    @location(1) colour: vec4<f32>,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) uv: vec2<f32>, @location(2) colour: vec4<f32>) -> Varyings {
    let c = u.m * vec4<f32>(position, 1.0);
    var out: Varyings;
    out.position = vec4<f32>(c.x, -c.y, c.z, c.w);
    out.uv = uv;
    out.colour = colour;
    return out;
}

@fragment
fn fs_main(v: Varyings) -> @location(0) vec4<f32> {
    return v.colour * textureSample(base, base_sampler, v.uv);
}
"#;

const COLOUR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;
const DEPTH: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    uv: [f32; 2],
    colour: [f32; 4],
}

/// A wgpu render pipeline drawing a mesh with its first texture (an `Rgba8UnormSrgb` texture
/// where the texture is sRGB, so the hardware decodes before filtering) into an RGBA8 target,
/// with a `Depth32Float` buffer and the `Less` test, no culling.
pub struct TexturedPipeline {
    gpu: Gpu,
    pipeline: wgpu::RenderPipeline,
    /// The mip chain of the last texture drawn trilinearly, with that texture, built once as an
    /// application builds its chains once.
    chain: Option<(Texture, Vec<Level>)>,
}

/// A mip level: width, height and RGBA8 texels.
pub type Level = (u32, u32, Vec<u8>);

/// The mip levels of `texture` as a GPU user builds them: 2×2 means of the linear values
/// (sRGB decoded, averaged in `f64`, encoded again), level 0 the texture's own bytes.
pub fn mip_levels(texture: &Texture) -> Vec<Level> {
    let decode = |c: u8, channel: usize| {
        let x = c as f64 / 255.0;
        if texture.srgb && channel < 3 { if x <= 0.04045 { x / 12.92 } else { ((x + 0.055) / 1.055).powf(2.4) } } else { x }
    };
    let encode = |x: f64, channel: usize| {
        let y = if texture.srgb && channel < 3 { if x <= 0.0031308 { x * 12.92 } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 } } else { x };
        (y * 255.0).round().clamp(0.0, 255.0) as u8
    };
    let mut levels = vec![(texture.width, texture.height, texture.rgba.clone())];
    while let Some((w, h, last)) = levels.last().filter(|(w, h, _)| *w > 1 || *h > 1) {
        let (w, h) = (*w, *h);
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let at = |x: u32, y: u32, c: usize| decode(last[((y.min(h - 1) * w + x.min(w - 1)) * 4) as usize + c], c);
        let next: Vec<u8> = (0..nh)
            .flat_map(|y| (0..nw).map(move |x| (x, y)))
            .flat_map(|(x, y)| (0..4).map(move |c| (x, y, c)))
            .map(|(x, y, c)| encode((at(2 * x, 2 * y, c) + at(2 * x + 1, 2 * y, c) + at(2 * x, 2 * y + 1, c) + at(2 * x + 1, 2 * y + 1, c)) / 4.0, c))
            .collect();
        levels.push((nw, nh, next));
    }
    levels
}

impl TexturedPipeline {
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let pipeline = gpu.scoped(|gpu| {
            let module =
                gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("textured peer"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
            let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x2, 2 => Float32x4];
            Ok(device::mesh_pipeline(
                &gpu.device,
                &module,
                "textured peer",
                wgpu::PrimitiveTopology::TriangleList,
                std::mem::size_of::<Vertex>() as u64,
                &attributes,
                COLOUR,
                true,
            ))
        })?;
        Ok(TexturedPipeline { gpu, pipeline, chain: None })
    }

    /// The adapter's name.
    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Draw `mesh` (its first texture on every face, white where it has no colours) transformed
    /// by `matrix` into a `width × height` RGBA8 target cleared to transparent black, sampling
    /// as `filter` and `address` say: nearest and bilinear read the full-size level only,
    /// trilinear the chain of [`mip_levels`] (built once for the texture drawn last; the texture
    /// itself is uploaded on every call). Returns RGBA8 per pixel, row 0 at the top.
    pub fn draw(&mut self, mesh: &Mesh, matrix: &[[f64; 4]; 4], width: u32, height: u32, filter: Filter, address: Address) -> Result<Vec<u32>, String> {
        let _turn = device::turn();
        let texture = mesh.textures.first().ok_or("the mesh has no texture")?;
        let uvs = mesh.uvs.as_ref().ok_or("the mesh has no texture coordinates")?;
        let max_dim = self.gpu.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max_dim || height > max_dim || texture.width > max_dim || texture.height > max_dim {
            return Err(format!("the target or the texture is not between 1×1 and the device's {max_dim}×{max_dim}"));
        }
        let vertices: Vec<Vertex> = mesh
            .triangles
            .iter()
            .flat_map(|t| t.map(|v| v as usize))
            .map(|v| Vertex { position: mesh.positions[v].map(|c| c as f32), uv: uvs[v], colour: mesh.colours.as_ref().map_or([1.0; 4], |c| c[v]) })
            .collect();
        let levels = if filter == Filter::Trilinear {
            // The chain is the texture's while the texture is the one it was built from.
            if self.chain.as_ref().is_none_or(|(source, _)| source != texture) {
                self.chain = Some((texture.clone(), mip_levels(texture)));
            }
            self.chain.as_ref().expect("built above").1.clone()
        } else {
            vec![(texture.width, texture.height, texture.rgba.clone())]
        };
        let columns: [f32; 16] = std::array::from_fn(|k| matrix[k % 4][k / 4] as f32);
        let readback_bytes = device::readback_bytes(width, height);
        let pipeline = self.pipeline.clone();
        self.gpu.scoped(|gpu| {
            let device = &gpu.device;
            let target = |label, format| device::render_target(device, label, width, height, format);
            let (colour, depth) = (target("textured peer colour", COLOUR), target("textured peer depth", DEPTH));
            let base = device.create_texture(&wgpu::TextureDescriptor {
                label: Some("textured peer base colour"),
                size: wgpu::Extent3d { width: texture.width, height: texture.height, depth_or_array_layers: 1 },
                mip_level_count: levels.len() as u32,
                sample_count: 1,
                dimension: wgpu::TextureDimension::D2,
                format: if texture.srgb { wgpu::TextureFormat::Rgba8UnormSrgb } else { wgpu::TextureFormat::Rgba8Unorm },
                usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
                view_formats: &[],
            });
            for (level, (w, h, bytes)) in levels.iter().enumerate() {
                gpu.queue.write_texture(
                    wgpu::TexelCopyTextureInfo { texture: &base, mip_level: level as u32, origin: wgpu::Origin3d::ZERO, aspect: wgpu::TextureAspect::All },
                    bytes,
                    wgpu::TexelCopyBufferLayout { offset: 0, bytes_per_row: Some(w * 4), rows_per_image: Some(*h) },
                    wgpu::Extent3d { width: *w, height: *h, depth_or_array_layers: 1 },
                );
            }
            let mode = match address {
                Address::Repeat => wgpu::AddressMode::Repeat,
                Address::ClampToEdge => wgpu::AddressMode::ClampToEdge,
                Address::MirroredRepeat => wgpu::AddressMode::MirrorRepeat,
            };
            let (texel, mip) = match filter {
                Filter::Nearest => (wgpu::FilterMode::Nearest, wgpu::MipmapFilterMode::Nearest),
                Filter::Bilinear => (wgpu::FilterMode::Linear, wgpu::MipmapFilterMode::Nearest),
                Filter::Trilinear => (wgpu::FilterMode::Linear, wgpu::MipmapFilterMode::Linear),
            };
            let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
                label: Some("textured peer"),
                address_mode_u: mode,
                address_mode_v: mode,
                mag_filter: texel,
                min_filter: texel,
                mipmap_filter: mip,
                ..Default::default()
            });
            let uniforms = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("textured peer matrix"),
                size: 64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&uniforms, 0, bytemuck::cast_slice(&columns));
            let vertex_bytes = (std::mem::size_of_val(vertices.as_slice()) as u64).max(4);
            let vertex_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("textured peer vertices"),
                size: vertex_bytes,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&vertices));
            let readback = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("textured peer readback"),
                size: readback_bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let base_view = base.create_view(&Default::default());
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("textured peer"),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[
                    wgpu::BindGroupEntry { binding: 0, resource: uniforms.as_entire_binding() },
                    wgpu::BindGroupEntry { binding: 1, resource: wgpu::BindingResource::TextureView(&base_view) },
                    wgpu::BindGroupEntry { binding: 2, resource: wgpu::BindingResource::Sampler(&sampler) },
                ],
            });
            let (colour_view, depth_view) = (colour.create_view(&Default::default()), depth.create_view(&Default::default()));
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = device::begin_pass(&mut encoder, "textured peer", &colour_view, wgpu::Color::TRANSPARENT, Some(&depth_view));
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.set_vertex_buffer(0, vertex_buffer.slice(..));
                pass.draw(0..vertices.len() as u32, 0..1);
            }
            device::read_target(gpu, encoder, &colour, &readback, width, height)
        })
    }
}
