//! Lighting on the host: the viewer ([`Eye`]), Lambert + Blinn-Phong in `f64` for flat and
//! Gouraud shading (the kernels' per-pixel version is `programs::shade`), and the shade
//! stage's parameters for a frame.

use super::params::{Eye, Light, RenderParams, Shading};
use super::vector::{cross, dot, sub, unit};
use crate::Error;
use tileraster_kernels::abi::{ATTR_COLOUR, ATTR_NORMAL, ATTRIBUTES, DepthTest, LitFace, MAX_LIGHTS, ShadeMode, ShadeParams};

/// A face's values under flat shading ([`Lighting::light_face`]).
pub(super) struct FaceLight {
    colour: [f64; 4],
    normal: [f64; 3],
}

impl FaceLight {
    /// Written over a corner's colour and normal.
    pub(super) fn apply(&self, attributes: &mut [f64; ATTRIBUTES]) {
        attributes[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&self.colour);
        attributes[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&self.normal);
    }

    /// What the kernels' assembly writes over a face's corners: [`Self::apply`]'s values, each rounded
    /// to `f32` once (as an `f64` corner's are on their way to the kernels).
    pub(super) fn to_lit_face(&self) -> LitFace {
        let (c, n) = (self.colour.map(|v| v as f32), self.normal.map(|v| v as f32));
        LitFace { values: [c[0], c[1], c[2], c[3], n[0], n[1], n[2], 0.0] }
    }
}

/// A frame's lighting as the host's stages take it: the viewer, homogeneous (`[x, y, z, 1]`
/// for a point, `[x, y, z, 0]` for a direction at infinity), and the lights, normalised.
pub(super) struct Lighting<'a> {
    params: &'a RenderParams,
    eye: [f64; 4],
    lights: Vec<Light>,
}

impl<'a> Lighting<'a> {
    /// The frame's viewer (given, or the view-projection's: [`Eye::of`]) and its first
    /// `MAX_LIGHTS` lights.
    pub(super) fn of(params: &'a RenderParams) -> Result<Lighting<'a>, Error> {
        let eye = match params.eye {
            Some(e) => e.homogeneous(),
            None => Eye::of(&params.view_projection, params.depth_func).map(Eye::homogeneous).ok_or_else(|| Error::SingularCamera {
                reason: "the view-projection matrix has neither a centre of projection (x = y = w = 0 has no single solution) nor a single viewing direction; give the eye".into(),
            })?,
        };
        let lights = params.lights.iter().take(MAX_LIGHTS).map(|l| Light { direction: unit(l.direction), colour: l.colour }).collect();
        Ok(Lighting { params, eye, lights })
    }

    /// `base` lit at the point `p` with unit normal `n` (Lambert + Blinn-Phong in `f64`: flat
    /// and Gouraud shading; the kernels' per-pixel version is `programs::shade`).
    pub(super) fn lit(&self, base: [f64; 4], n: [f64; 3], p: [f64; 3]) -> [f64; 4] {
        blinn_phong(self.params, &self.lights, self.eye, base, n, p)
    }

    /// Flat shading's values for a face whose corners lie at `q` in the world and whose first
    /// vertex has colour `base`: its normal, and that colour lit with it at the first corner.
    pub(super) fn light_face(&self, base: [f64; 4], q: [[f64; 3]; 3]) -> FaceLight {
        let normal = unit(cross(sub(q[1], q[0]), sub(q[2], q[0])));
        FaceLight { colour: self.lit(base, normal, q[0]), normal }
    }

    /// The kernels' shade parameters for the frame, the depth view spanning `depths`.
    pub(super) fn shade_params(&self, depths: (f64, f64)) -> ShadeParams {
        shade_params(self.params, &self.lights, self.eye, depths)
    }
}

/// The kernels' shade parameters for a frame.
fn shade_params(params: &RenderParams, lights: &[Light], eye: [f64; 4], (near, far): (f64, f64)) -> ShadeParams {
    let mode = match params.shading {
        Shading::Unlit | Shading::Flat | Shading::Smooth => ShadeMode::Colour,
        Shading::Phong => ShadeMode::Phong,
        Shading::Depth => ShadeMode::Depth,
        Shading::Normals => ShadeMode::Normals,
        Shading::Ids => ShadeMode::Ids,
    };
    let f4 = |v: [f64; 3]| [v[0] as f32, v[1] as f32, v[2] as f32, 0.0];
    let mut s = ShadeParams {
        shading: mode as u32,
        interpolation: params.interpolation as u32,
        background: u32::from_le_bytes(params.background),
        lights: lights.len() as u32,
        shininess: params.shininess,
        blend: u32::from(params.blend),
        depth_test: DepthTest::new(params.depth_func, params.depth_write),
        ambient: f4(params.ambient),
        specular: f4(params.specular),
        eye: eye.map(|c| c as f32),
        depth_view: [near as f32, (1.0 / (far - near).max(1e-6)) as f32, 0.0, 0.0],
        samples: params.samples,
        layer_sample: params.layer_sample,
        constants: params.fragment_constants,
        ..Default::default()
    };
    for (k, l) in lights.iter().enumerate() {
        s.light_dir[k] = f4(l.direction);
        s.light_colour[k] = f4(l.colour);
    }
    s
}

/// Lambert + Blinn-Phong in `f64`.
fn blinn_phong(params: &RenderParams, lights: &[Light], eye: [f64; 4], base: [f64; 4], n: [f64; 3], p: [f64; 3]) -> [f64; 4] {
    let v = unit(std::array::from_fn(|c| eye[c] - p[c] * eye[3]));
    let mut diffuse = params.ambient;
    let mut specular = [0.0; 3];
    for l in lights {
        let ndl = dot(n, l.direction);
        if ndl > 0.0 {
            let h = unit([l.direction[0] + v[0], l.direction[1] + v[1], l.direction[2] + v[2]]);
            let s = dot(n, h).max(0.0).powi(params.shininess as i32);
            for c in 0..3 {
                diffuse[c] += ndl * l.colour[c];
                specular[c] += s * l.colour[c];
            }
        }
    }
    let channel = |c: usize| base[c] * diffuse[c] + params.specular[c] * specular[c];
    [channel(0), channel(1), channel(2), base[3]]
}
