//! The frame's lighting: the viewer ([`Eye`]), the lights, and the shade stage's parameters
//! that carry them. Flat and Gouraud shading are lit by the kernels' functions
//! (`programs::shade::lit_face` and `lit_vertex`, Lambert + Blinn-Phong in `f32`), which the
//! assembly runs on every backend and the host's clipping and its path for lines and points
//! call natively, so a colour is the same bits wherever it is lit.

use super::params::{Eye, Light, RenderParams, Shading, ToneMap};
use super::vector::{cross, sub, unit};
use crate::Error;
use tileraster_kernels::abi::{ATTR_COLOUR, ATTR_NORMAL, ATTR_POSITION, ATTRIBUTES, DepthTest, FaceNormal, MAX_LIGHTS, ShadeMode, ShadeParams};
use tileraster_kernels::programs::shade::{lit_face, lit_vertex};
use tileraster_kernels::programs::tone::{OUTPUT_SRGB, TONE_ACES, TONE_NEUTRAL, TONE_NONE};

/// A face's values under flat shading ([`Lighting::light_face`]).
pub(super) struct FaceLight {
    colour: [f32; 4],
    normal: [f32; 3],
}

impl FaceLight {
    /// Written over a corner's colour and normal.
    pub(super) fn apply(&self, attributes: &mut [f64; ATTRIBUTES]) {
        attributes[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&self.colour.map(f64::from));
        attributes[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&self.normal.map(f64::from));
    }
}

/// The unit normal of a face whose corners lie at `q` in the world (in drawing order), from
/// its corners in `f64`, rounded to `f32` once: what flat shading lights the face with.
pub(super) fn face_normal(q: [[f64; 3]; 3]) -> FaceNormal {
    let n = unit(cross(sub(q[1], q[0]), sub(q[2], q[0]))).map(|c| c as f32);
    FaceNormal { normal: [n[0], n[1], n[2], 0.0] }
}

/// A frame's lighting: the shade stage's parameters, whose viewer (homogeneous: `[x, y, z, 1]`
/// for a point, `[x, y, z, 0]` for a direction at infinity) and lights (normalised) the
/// kernels' lighting reads.
pub(super) struct Lighting {
    shade: ShadeParams,
}

impl Lighting {
    /// The frame's viewer (given, or the view-projection's: [`Eye::of`]) and its first
    /// `MAX_LIGHTS` lights.
    pub(super) fn of(params: &RenderParams) -> Result<Lighting, Error> {
        let eye = match params.eye {
            Some(e) => e.homogeneous(),
            None => Eye::of(&params.view_projection, params.depth_func).map(Eye::homogeneous).ok_or_else(|| Error::SingularCamera {
                reason: "the view-projection matrix has neither a centre of projection (x = y = w = 0 has no single solution) nor a single viewing direction; give the eye".into(),
            })?,
        };
        let lights: Vec<Light> = params.lights.iter().take(MAX_LIGHTS).map(|l| Light { direction: unit(l.direction), colour: l.colour }).collect();
        Ok(Lighting { shade: shade_params(params, &lights, eye) })
    }

    /// The shade parameters the assembly lights with (their depth view is not the frame's).
    pub(super) fn params(&self) -> &ShadeParams {
        &self.shade
    }

    /// Gouraud shading: the colour of a vertex of attributes `a` (in `f64`; the kernels take
    /// them rounded to `f32`, as here), lit by `programs::shade::lit_vertex`.
    pub(super) fn lit_vertex(&self, a: &[f64; ATTRIBUTES]) -> [f64; 4] {
        lit_vertex(&self.shade, &a.map(|v| v as f32)).map(f64::from)
    }

    /// Flat shading's values for a face whose corners lie at `q` in the world and whose first
    /// vertex has colour `base`: its normal ([`face_normal`]), and that colour lit with it at
    /// the first corner by `programs::shade::lit_face` (the corner and colour rounded to `f32`,
    /// as the kernels take them).
    pub(super) fn light_face(&self, base: [f64; 4], q: [[f64; 3]; 3]) -> FaceLight {
        let n = face_normal(q).normal;
        let normal = [n[0], n[1], n[2]];
        let mut first = [0.0f32; ATTRIBUTES];
        first[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&base.map(|c| c as f32));
        first[ATTR_POSITION..ATTR_POSITION + 3].copy_from_slice(&q[0].map(|c| c as f32));
        FaceLight { colour: lit_face(&self.shade, &first, normal), normal }
    }

    /// The kernels' shade parameters for the frame, the depth view spanning `(near, far)`.
    pub(super) fn shade_params(&self, (near, far): (f64, f64)) -> ShadeParams {
        ShadeParams { depth_view: [near as f32, (1.0 / (far - near).max(1e-6)) as f32, 0.0, 0.0], ..self.shade }
    }
}

/// The kernels' shade parameters for a frame but its depth view.
fn shade_params(params: &RenderParams, lights: &[Light], eye: [f64; 4]) -> ShadeParams {
    let mode = match params.shading {
        Shading::Unlit | Shading::Flat | Shading::Smooth => ShadeMode::Colour,
        Shading::Phong => ShadeMode::Phong,
        Shading::Pbr => ShadeMode::Pbr,
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
        samples: params.samples,
        layer_sample: params.layer_sample,
        constants: params.fragment_constants,
        output: match params.tone_map {
            ToneMap::None => TONE_NONE,
            ToneMap::Neutral => TONE_NEUTRAL,
            ToneMap::Aces => TONE_ACES,
        } | if params.srgb { OUTPUT_SRGB } else { 0 },
        ..Default::default()
    };
    for (k, l) in lights.iter().enumerate() {
        s.light_dir[k] = f4(l.direction);
        s.light_colour[k] = f4(l.colour);
    }
    s
}
