//! The hardware render pipeline running the procedural marble of `examples/procedural` as a
//! WGSL fragment shader: what a wgpu user writes for the same picture. The peer of
//! tileraster's programmable fragment stage, in time and in colour. It takes the vertex colour
//! as the base colour (no texture), draws every face (no culling: the depth test hides the
//! back faces of a closed mesh), and leaves the hardware its `floor`, `normalize`, `pow` (for
//! the shader's repeated squaring) and any fusing of products and sums.

use crate::device::{self, Gpu};
use tileraster_core::render::{Eye, Mesh, RenderParams};

/// The marble and the Blinn-Phong lighting of `procedural-shader` and `programs::shade`,
/// step for step, in the hardware's arithmetic.
const SHADER: &str = r#"
struct Uniforms {
    m: mat4x4<f32>,
    eye: vec4<f32>,
    ambient: vec4<f32>,
    // xyz: the specular colour, w: the shininess.
    specular: vec4<f32>,
    // x: veins per unit, y: turbulence, z: lights.
    constants: vec4<f32>,
    light_dir: array<vec4<f32>, 2>,
    light_colour: array<vec4<f32>, 2>,
};
@group(0) @binding(0) var<uniform> u: Uniforms;

struct Varyings {
    @builtin(position) position: vec4<f32>,
    @location(0) world: vec3<f32>,
    @location(1) normal: vec3<f32>,
    @location(2) colour: vec4<f32>,
};

@vertex
fn vs_main(@location(0) position: vec3<f32>, @location(1) normal: vec3<f32>, @location(2) colour: vec4<f32>) -> Varyings {
    let c = u.m * vec4<f32>(position, 1.0);
    var out: Varyings;
    out.position = vec4<f32>(c.x, -c.y, c.z, c.w);
    out.world = position;
    out.normal = normal;
    out.colour = colour;
    return out;
}

fn lattice(x: i32, y: i32, z: i32) -> f32 {
    var h = (bitcast<u32>(x) * 0x8da6b343u) ^ (bitcast<u32>(y) * 0xd8163841u) ^ (bitcast<u32>(z) * 0xcb1ab31fu);
    h ^= h >> 15u;
    h *= 0x2c1b3c6du;
    h ^= h >> 12u;
    h *= 0x297a2d39u;
    h ^= h >> 15u;
    return f32(h >> 8u) * (1.0 / 16777216.0);
}

fn smooth_weight(t: f32) -> f32 {
    return t * t * (3.0 - t * 2.0);
}

fn lerp(a: f32, b: f32, t: f32) -> f32 {
    return a + (b - a) * t;
}

fn plane(x: i32, y: i32, z: i32, w: vec2<f32>) -> f32 {
    let bottom = lerp(lattice(x, y, z), lattice(x + 1, y, z), w.x);
    let top = lerp(lattice(x, y + 1, z), lattice(x + 1, y + 1, z), w.x);
    return lerp(bottom, top, w.y);
}

fn noise(p: vec3<f32>) -> f32 {
    let q = clamp(p, vec3<f32>(-4194304.0), vec3<f32>(4194304.0));
    let i = floor(q);
    let f = q - i;
    let w = vec3<f32>(smooth_weight(f.x), smooth_weight(f.y), smooth_weight(f.z));
    let x = i32(i.x);
    let y = i32(i.y);
    let z = i32(i.z);
    return lerp(plane(x, y, z, w.xy), plane(x, y, z + 1, w.xy), w.z);
}

fn fbm(p: vec3<f32>) -> f32 {
    var sum = 0.0;
    var q = p;
    var amplitude = 1.0;
    for (var octave = 0; octave < 3; octave++) {
        sum += amplitude * noise(q);
        q = q * 2.0;
        amplitude *= 0.5;
    }
    return sum;
}

fn triangle_wave(x: f32) -> f32 {
    let d = (x - floor(x)) * 2.0 - 1.0;
    return 1.0 - abs(d);
}

@fragment
fn fs_main(v: Varyings) -> @location(0) vec4<f32> {
    let p = v.world * u.constants.x;
    let t = triangle_wave(p.x + p.y * 0.5 + u.constants.y * fbm(p));
    let t2 = t * t;
    let t4 = t2 * t2;
    let vein = t4 * t4;
    let light_stone = vec3<f32>(0.93, 0.91, 0.86);
    let stone = (light_stone + (vec3<f32>(0.22, 0.25, 0.32) - light_stone) * vein) * v.colour.rgb;
    // Blinn-Phong, as programs::shade::phong.
    let n = normalize(v.normal);
    let view = normalize(u.eye.xyz - v.world * u.eye.w);
    var diffuse = u.ambient.rgb;
    var specular = vec3<f32>(0.0);
    for (var k = 0; k < i32(u.constants.z); k++) {
        let l = u.light_dir[k].xyz;
        let ndl = dot(n, l);
        if ndl > 0.0 {
            diffuse += ndl * u.light_colour[k].rgb;
            let ndh = dot(n, normalize(l + view));
            if ndh > 0.0 {
                specular += pow(ndh, u.specular.w) * u.light_colour[k].rgb;
            }
        }
    }
    return vec4<f32>(stone * diffuse + u.specular.rgb * specular, v.colour.a);
}
"#;

const COLOUR: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8Unorm;

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    colour: [f32; 4],
}

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct Uniforms {
    m: [f32; 16],
    eye: [f32; 4],
    ambient: [f32; 4],
    specular: [f32; 4],
    constants: [f32; 4],
    light_dir: [[f32; 4]; 2],
    light_colour: [[f32; 4]; 2],
}

/// A wgpu render pipeline drawing a mesh with the marble shader into an RGBA8 target, with a
/// `Depth32Float` buffer and the `Less` test, no culling.
pub struct MarblePipeline {
    gpu: Gpu,
    pipeline: wgpu::RenderPipeline,
}

impl MarblePipeline {
    pub fn new() -> Result<Self, String> {
        let _turn = device::turn();
        let mut gpu = device::open()?;
        let pipeline = gpu.scoped(|gpu| {
            let module =
                gpu.device.create_shader_module(wgpu::ShaderModuleDescriptor { label: Some("marble peer"), source: wgpu::ShaderSource::Wgsl(SHADER.into()) });
            let attributes = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
            Ok(device::mesh_pipeline(
                &gpu.device,
                &module,
                "marble peer",
                wgpu::PrimitiveTopology::TriangleList,
                std::mem::size_of::<Vertex>() as u64,
                &attributes,
                COLOUR,
                true,
            ))
        })?;
        Ok(MarblePipeline { gpu, pipeline })
    }

    /// The adapter's name.
    pub fn adapter_name(&self) -> String {
        self.gpu.info.name.clone()
    }

    /// Draw `mesh` (with its normals; white where it has no colours) as `params` frame it
    /// (its view-projection, eye, at most two lights, ambient and specular colours, shininess,
    /// background, and the marble's constants: veins per unit and turbulence, 3 and 1.5 where
    /// not positive). Returns RGBA8 per pixel, row 0 at the top.
    pub fn draw(&mut self, mesh: &Mesh, params: &RenderParams) -> Result<Vec<u32>, String> {
        let _turn = device::turn();
        let normals = mesh.normals.as_ref().ok_or("the mesh has no normals")?;
        let eye = params.eye.ok_or("the frame names no eye")?;
        let (width, height) = (params.width, params.height);
        let max_dim = self.gpu.limits.max_texture_dimension_2d;
        if width == 0 || height == 0 || width > max_dim || height > max_dim {
            return Err(format!("the target is not between 1×1 and the device's {max_dim}×{max_dim}"));
        }
        let vertices: Vec<Vertex> = mesh
            .triangles
            .iter()
            .flat_map(|t| t.map(|v| v as usize))
            .map(|v| Vertex { position: mesh.positions[v].map(|c| c as f32), normal: normals[v], colour: mesh.colours.as_ref().map_or([1.0; 4], |c| c[v]) })
            .collect();
        let f4 = |v: [f64; 3], w: f32| [v[0] as f32, v[1] as f32, v[2] as f32, w];
        let unit = |v: [f64; 3]| {
            let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
            v.map(|c| c / n)
        };
        let lights = &params.lights[..params.lights.len().min(2)];
        let mut uniforms = Uniforms {
            m: std::array::from_fn(|k| params.view_projection[k % 4][k / 4] as f32),
            // Homogeneous, as the kernels take it: a point, or a direction at infinity.
            eye: match eye {
                Eye::Point(p) => f4(p, 1.0),
                Eye::Direction(d) => f4(unit(d), 0.0),
            },
            ambient: f4(params.ambient, 0.0),
            specular: f4(params.specular, params.shininess as f32),
            constants: [
                if params.fragment_constants[0] > 0.0 { params.fragment_constants[0] } else { 3.0 },
                if params.fragment_constants[1] > 0.0 { params.fragment_constants[1] } else { 1.5 },
                lights.len() as f32,
                0.0,
            ],
            light_dir: [[0.0; 4]; 2],
            light_colour: [[0.0; 4]; 2],
        };
        for (k, l) in lights.iter().enumerate() {
            uniforms.light_dir[k] = f4(unit(l.direction), 0.0);
            uniforms.light_colour[k] = f4(l.colour, 0.0);
        }
        let [r, g, b, a] = params.background.map(|c| c as f64 / 255.0);
        let readback_bytes = device::readback_bytes(width, height);
        let pipeline = self.pipeline.clone();
        self.gpu.scoped(|gpu| {
            let device = &gpu.device;
            let colour = device::render_target(device, "marble peer colour", width, height, COLOUR);
            let depth = device::render_target(device, "marble peer depth", width, height, wgpu::TextureFormat::Depth32Float);
            let uniform_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("marble peer uniforms"),
                size: std::mem::size_of::<Uniforms>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&uniform_buffer, 0, bytemuck::bytes_of(&uniforms));
            let vertex_bytes = (std::mem::size_of_val(vertices.as_slice()) as u64).max(4);
            let vertex_buffer = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("marble peer vertices"),
                size: vertex_bytes,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            gpu.queue.write_buffer(&vertex_buffer, 0, bytemuck::cast_slice(&vertices));
            let readback = device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("marble peer readback"),
                size: readback_bytes,
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            });
            let bind = device.create_bind_group(&wgpu::BindGroupDescriptor {
                label: Some("marble peer"),
                layout: &pipeline.get_bind_group_layout(0),
                entries: &[wgpu::BindGroupEntry { binding: 0, resource: uniform_buffer.as_entire_binding() }],
            });
            let (colour_view, depth_view) = (colour.create_view(&Default::default()), depth.create_view(&Default::default()));
            let mut encoder = device.create_command_encoder(&Default::default());
            {
                let mut pass = device::begin_pass(&mut encoder, "marble peer", &colour_view, wgpu::Color { r, g, b, a }, Some(&depth_view));
                pass.set_pipeline(&pipeline);
                pass.set_bind_group(0, &bind, &[]);
                pass.set_vertex_buffer(0, vertex_buffer.slice(..));
                pass.draw(0..vertices.len() as u32, 0..1);
            }
            device::read_target(gpu, encoder, &colour, &readback, width, height)
        })
    }
}
