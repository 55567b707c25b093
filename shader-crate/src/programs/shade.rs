//! The render pipeline's shade stage: one invocation per pixel, after fine raster has left the
//! owner of every pixel (a visibility buffer), so each pixel is shaded once whatever the
//! overdraw. It interpolates the owner's vertex attributes at the pixel centre and lights them.
//!
//! Every float operation here is an addition, subtraction, multiplication or comparison
//! (correctly rounded on every Vulkan device, and never contracted: the build marks them
//! `NoContraction`), or one of `math::float`'s correctly rounded divisions and square roots
//! (settled in integers); the exact edge functions convert to `f32` from exact pieces with one
//! rounding addition (`math::fixed::i64_to_f32`). So the colour is the same on every device.

use crate::abi::{
    ATTR_COLOUR, ATTR_NORMAL, ATTR_POSITION, ATTR_UV, ATTRIBUTES, Interpolation, MAX_LIGHTS, MaterialRecord, NO_TEXTURE, SHADING_BACK, SHADING_MASK,
    SHADING_NOT_LIT, SHADING_OPAQUE, SHADING_UNLIT, ShadeMode, ShadeParams, ShadingRecords, TextureInfo, TriangleSetup, TriangleShading,
};
use crate::math::edge::Side;
use crate::math::fixed::{i32_to_f32, i64_to_f32};
use crate::math::float::{Divisor, recip, sqrt};
use crate::programs::brdf::{Cosines, Surface, reflected};
use crate::programs::depth::{DepthProgram, depth_bits};
use crate::programs::fragment::FragmentProgram;
use crate::programs::texture::{self, lod};
use crate::programs::tone::encoded;
use crate::stages::fine::side;
use crate::{FULL_TILE_BIT, NO_OWNER};

/// A pixel's shaded outputs.
#[derive(Copy, Clone)]
pub struct Shaded {
    /// RGBA8, red in the low byte.
    pub colour: u32,
    /// The input face that owns the pixel (`NO_OWNER` where none).
    pub face: u32,
}

/// The weights of the owner's three vertices at pixel `(i, j)` (entry `k` for the vertex
/// opposite edge `k`), summing to one up to rounding: perspective-correct (`w_k / w_vertex`,
/// normalised), linear on the screen (`w_k / Σw`), or flat (`[1, 0, 0]`), as
/// `params.interpolation` says. The edge functions in 32-bit arithmetic where
/// `params.small_edges` says they fit, else in 64 bits: the same values.
#[inline]
pub fn weights(s: &TriangleSetup, t: &TriangleShading, params: &ShadeParams, i: i32, j: i32) -> [f32; 3] {
    let interpolation = params.interpolation;
    if interpolation == Interpolation::Flat as u32 {
        // Every entry holds the same values: one weight of exactly one reads them unchanged.
        return [1.0, 0.0, 0.0];
    }
    let rect = &s.coverage.rect;
    let e = &s.coverage.edges;
    let w = if params.small_edges != 0 {
        let (di, dj) = (i - rect.i0, j - rect.j0);
        let weight = |k: usize| i32_to_f32(e[k].at_i32(di, dj, 0, 0));
        [weight(0), weight(1), weight(2)]
    } else {
        let (di, dj) = ((i - rect.i0) as i64, (j - rect.j0) as i64);
        let weight = |k: usize| i64_to_f32(e[k].at(di, dj));
        [weight(0), weight(1), weight(2)]
    };
    if interpolation == Interpolation::Screen as u32 {
        let inv_area = s.coeffs.c[3];
        return [w[0] * inv_area, w[1] * inv_area, w[2] * inv_area];
    }
    let q = [w[0] * t.inv_w[0], w[1] * t.inv_w[1], w[2] * t.inv_w[2]];
    let r = recip(q[0] + q[1] + q[2]);
    [q[0] * r, q[1] * r, q[2] * r]
}

/// Attribute `a` interpolated with weights `b`.
#[inline]
pub fn interpolate(t: &TriangleShading, b: &[f32; 3], a: usize) -> f32 {
    b[0] * t.attributes[0][a] + b[1] * t.attributes[1][a] + b[2] * t.attributes[2][a]
}

/// The colour attribute interpolated with weights `b`.
#[inline]
pub(crate) fn colour_at(t: &TriangleShading, b: &[f32; 3]) -> [f32; 4] {
    [interpolate(t, b, ATTR_COLOUR), interpolate(t, b, ATTR_COLOUR + 1), interpolate(t, b, ATTR_COLOUR + 2), interpolate(t, b, ATTR_COLOUR + 3)]
}

/// Three consecutive attributes from `a`.
#[inline]
pub(crate) fn interpolate3(t: &TriangleShading, b: &[f32; 3], a: usize) -> [f32; 3] {
    [interpolate(t, b, a), interpolate(t, b, a + 1), interpolate(t, b, a + 2)]
}

#[inline]
fn dot(a: &[f32; 3], b: &[f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// `v / |v|` with correctly rounded root and division; zero stays zero.
#[inline]
pub fn normalise(v: [f32; 3]) -> [f32; 3] {
    let len2 = dot(&v, &v);
    // Zero, NaN, or too long to square: no direction.
    if len2.is_nan() || len2 <= 0.0 || len2 >= f32::MAX {
        return [0.0; 3];
    }
    let len = sqrt(len2);
    if len <= 1.0e-30 {
        return [0.0; 3];
    }
    // One copy of the division, its divisor's part shared.
    let len = Divisor::new(len);
    per_component(v, |c| scale_div(c, &len))
}

/// `[f(v₀), f(v₁), f(v₂)]` with one copy of `f`: a loop over named components (a driver
/// reads each inlined copy of a body; and a CPU implementation of Vulkan keeps an array indexed
/// by the loop in memory and reaches it one lane at a time, see `sampled`).
#[inline]
pub(crate) fn per_component(v: [f32; 3], f: impl Fn(f32) -> f32) -> [f32; 3] {
    let (mut x, mut y, mut z) = (0.0, 0.0, 0.0);
    let mut k = 0;
    while k < 3 {
        let q = f(match k {
            0 => v[0],
            1 => v[1],
            _ => v[2],
        });
        match k {
            0 => x = q,
            1 => y = q,
            _ => z = q,
        }
        k += 1;
    }
    [x, y, z]
}

/// `x / d` for `d > 0` and any finite `x`, by the sign of `x` (one division).
#[inline]
pub(crate) fn scale_div(x: f32, d: &Divisor) -> f32 {
    let q = d.divide(if x > 0.0 { x } else { -x });
    if x > 0.0 {
        q
    } else if x < 0.0 {
        -q
    } else {
        0.0
    }
}

/// `x^n` for an integer `n`, by repeated squaring (multiplications only).
#[inline]
pub fn powi(x: f32, n: u32) -> f32 {
    let (mut base, mut e, mut out) = (x, n, 1.0f32);
    while e > 0 {
        if e & 1 == 1 {
            out *= base;
        }
        base *= base;
        e >>= 1;
    }
    out
}

/// `x` clamped to `[0, 1]` (NaN to 0).
#[inline]
pub(crate) fn clamp01(x: f32) -> f32 {
    if x > 1.0 {
        1.0
    } else if x > 0.0 {
        x
    } else {
        0.0
    }
}

/// A channel in `[0, 1]` to 8 bits, rounded to nearest (the conversion truncates exactly).
#[inline]
fn unorm8(x: f32) -> u32 {
    (clamp01(x) * 255.0 + 0.5) as u32
}

/// RGBA8 from four channels in `[0, 1]`.
#[inline]
pub fn rgba8(c: [f32; 4]) -> u32 {
    unorm8(c[0]) | unorm8(c[1]) << 8 | unorm8(c[2]) << 16 | unorm8(c[3]) << 24
}

/// A colour that tells neighbouring ids apart (a 32-bit integer hash of the id), opaque.
#[inline]
pub fn id_colour(id: u32) -> u32 {
    let mut h = id ^ 0x9e37_79b9;
    h = (h ^ (h >> 16)).wrapping_mul(0x7feb_352d);
    h = (h ^ (h >> 15)).wrapping_mul(0x846c_a68b);
    h ^= h >> 16;
    // Keep every channel away from black, so that no id looks like the background.
    (h & 0x00ff_ffff) | 0x0040_4040 | 0xff00_0000
}

/// Lambert diffuse plus Blinn-Phong specular of the lights at a point with unit normal `n`,
/// on the base colour `base`; `p` is the point in the world. A fragment shader may light its
/// own colour with it.
#[inline]
pub fn phong(params: &ShadeParams, base: [f32; 4], n: [f32; 3], p: [f32; 3]) -> [f32; 4] {
    occluded_phong(params, base, 1.0, n, p)
}

/// [`phong`] with the share `occlusion` of the ambient light reaching the point.
#[inline]
pub fn occluded_phong(params: &ShadeParams, base: [f32; 4], occlusion: f32, n: [f32; 3], p: [f32; 3]) -> [f32; 4] {
    let v = normalise(params.towards_viewer(p));
    let a = &params.ambient;
    let mut diffuse = [a[0] * occlusion, a[1] * occlusion, a[2] * occlusion];
    let mut specular = [0.0f32; 3];
    let mut k = 0;
    while k < MAX_LIGHTS {
        if (k as u32) < params.lights {
            let l = [params.light_dir[k][0], params.light_dir[k][1], params.light_dir[k][2]];
            let c = &params.light_colour[k];
            let ndl = dot(&n, &l);
            if ndl > 0.0 {
                diffuse = [diffuse[0] + ndl * c[0], diffuse[1] + ndl * c[1], diffuse[2] + ndl * c[2]];
                let h = normalise([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
                let ndh = dot(&n, &h);
                if ndh > 0.0 {
                    let s = powi(ndh, params.shininess);
                    specular = [specular[0] + s * c[0], specular[1] + s * c[1], specular[2] + s * c[2]];
                }
            }
        }
        k += 1;
    }
    let sc = &params.specular;
    [base[0] * diffuse[0] + sc[0] * specular[0], base[1] * diffuse[1] + sc[1] * specular[1], base[2] * diffuse[2] + sc[2] * specular[2], base[3]]
}

/// glTF's metallic-roughness BRDF (`programs::brdf`) under the frame's lights at a point with
/// unit normal `n` of the surface `at` (its base colour's alpha kept); `p` is the point in the
/// world. Each light's colour is what it gives a white Lambertian surface facing it (the BRDF
/// times `π`: the same diffuse light as [`phong`]); the ambient light, its share that the
/// occlusion lets through, lights the base colour as in [`phong`], until image-based lighting
/// replaces it.
#[inline]
pub fn pbr(params: &ShadeParams, at: &SurfaceAt, n: [f32; 3], p: [f32; 3]) -> [f32; 4] {
    let v = normalise(params.towards_viewer(p));
    let base = at.base;
    let surface = Surface { base: [base[0], base[1], base[2]], metallic: at.metallic, roughness: at.roughness };
    let a = &params.ambient;
    let mut out = [base[0] * a[0] * at.occlusion, base[1] * a[1] * at.occlusion, base[2] * a[2] * at.occlusion];
    let n_v = dot(&n, &v);
    let mut k = 0;
    while k < MAX_LIGHTS {
        if (k as u32) < params.lights {
            let l = [params.light_dir[k][0], params.light_dir[k][1], params.light_dir[k][2]];
            let c = &params.light_colour[k];
            let h = normalise([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
            let r = reflected(&surface, &Cosines { n_l: dot(&n, &l), n_v, n_h: dot(&n, &h), v_h: dot(&v, &h) });
            let pi = core::f32::consts::PI;
            out = [out[0] + (pi * r[0]) * c[0], out[1] + (pi * r[1]) * c[1], out[2] + (pi * r[2]) * c[2]];
        }
        k += 1;
    }
    [out[0], out[1], out[2], base[3]]
}

/// Gouraud shading's colour of a vertex (`a`, its attributes as the assembly reads them): its
/// colour lit with its normal, normalised, at its position in the world. A vertex shared by
/// several faces is lit alike in each: the colour is a function of its attributes alone.
#[inline]
pub fn lit_vertex(params: &ShadeParams, a: &[f32; ATTRIBUTES]) -> [f32; 4] {
    let colour = [a[ATTR_COLOUR], a[ATTR_COLOUR + 1], a[ATTR_COLOUR + 2], a[ATTR_COLOUR + 3]];
    let n = normalise([a[ATTR_NORMAL], a[ATTR_NORMAL + 1], a[ATTR_NORMAL + 2]]);
    phong(params, colour, n, [a[ATTR_POSITION], a[ATTR_POSITION + 1], a[ATTR_POSITION + 2]])
}

/// Flat shading's colour of a face: its first vertex's colour (`first`, that vertex's
/// attributes) lit with the face's unit `normal` at that vertex.
#[inline]
pub fn lit_face(params: &ShadeParams, first: &[f32; ATTRIBUTES], normal: [f32; 3]) -> [f32; 4] {
    let colour = [first[ATTR_COLOUR], first[ATTR_COLOUR + 1], first[ATTR_COLOUR + 2], first[ATTR_COLOUR + 3]];
    phong(params, colour, normal, [first[ATTR_POSITION], first[ATTR_POSITION + 1], first[ATTR_POSITION + 2]])
}

/// The shaded pixel `(i, j)` owned by setup slot `slot` (`NO_OWNER`: the background), whose
/// depth is `depth_bits`, coloured by `program`.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn shade_pixel<P: FragmentProgram + ?Sized, R: ShadingRecords + ?Sized>(
    program: &P,
    params: &ShadeParams,
    setups: &[TriangleSetup],
    shading: &R,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    slot: u32,
    depth_bits: u32,
    i: i32,
    j: i32,
) -> Shaded {
    let unblended = ShadeParams { blend: 0, ..*params };
    shaded_pixel(program, &unblended, 0, setups, shading, textures, texels, materials, &[], 0, 0, slot, depth_bits, i, j)
}

/// The texture coordinates of triangle `(s, t)` at pixel `(i, j)`.
#[inline]
fn uv_at(s: &TriangleSetup, t: &TriangleShading, params: &ShadeParams, i: i32, j: i32) -> [f32; 2] {
    let b = weights(s, t, params, i, j);
    [interpolate(t, &b, ATTR_UV), interpolate(t, &b, ATTR_UV + 1)]
}

/// A fragment's surface as its material and textures give it (glTF's metallic-roughness
/// material): the base colour (the vertex colour times the base-colour texture), the metallic
/// and roughness factors times the metallic-roughness texture's blue and green, the share of
/// the ambient light that reaches it (`1 + strength·(occlusion − 1)`, the occlusion texture's
/// red), and the emission times the emissive texture. Without textures, the colour and the
/// factors as they are.
#[derive(Copy, Clone)]
pub struct SurfaceAt {
    pub base: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
    pub occlusion: f32,
    pub emissive: [f32; 3],
}

/// Triangle `(s, t)`'s surface of `material` at pixel `(i, j)` (weights `b`): the base colour
/// alone unless it `lights` (the other textures are read only where a light needs them).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn surface_at(
    params: &ShadeParams,
    s: &TriangleSetup,
    t: &TriangleShading,
    material: &MaterialRecord,
    textures: &[TextureInfo],
    texels: &[u64],
    b: &[f32; 3],
    lights: bool,
    i: i32,
    j: i32,
) -> SurfaceAt {
    let colour = colour_at(t, b);
    let uv = [interpolate(t, b, ATTR_UV), interpolate(t, b, ATTR_UV + 1)];
    let mut quad = Quad::default();
    // The textures in one loop, so that the stage holds one copy of the filter (named values,
    // not an array indexed by the loop: see `per_component`).
    let (mut base, mut metal_rough, mut occlusion, mut emission) = ([1.0f32; 4], [1.0f32; 4], [1.0f32; 4], [1.0f32; 4]);
    // (A frame without textures reads none: every sample would be white.)
    let textures_read = if params.textured == 0 {
        0
    } else if lights {
        4
    } else {
        1
    };
    let mut k = 0;
    while k < textures_read {
        let texture = match k {
            0 => t.material.texture,
            1 => material.metallic_roughness_texture,
            2 => material.occlusion_texture,
            _ => material.emissive_texture,
        };
        let c = sampled(params, s, t, textures, texels, texture, uv, &mut quad, i, j);
        match k {
            0 => base = c,
            1 => metal_rough = c,
            2 => occlusion = c,
            _ => emission = c,
        }
        k += 1;
    }
    let e = &material.emissive;
    SurfaceAt {
        base: [colour[0] * base[0], colour[1] * base[1], colour[2] * base[2], colour[3] * base[3]],
        metallic: material.metallic * metal_rough[2],
        roughness: material.roughness * metal_rough[1],
        occlusion: 1.0 + material.occlusion_strength * (occlusion[0] - 1.0),
        emissive: [e[0] * emission[0], e[1] * emission[1], e[2] * emission[2]],
    }
}

/// The texture coordinates' differences across a pixel's 2×2 quad, once found.
#[derive(Copy, Clone, Default)]
pub struct Quad {
    known: bool,
    d: [f32; 4],
}

/// Texture `texture` of the frame (white where `NO_TEXTURE`) at the coordinates `uv`, unit
/// RGBA. The level of detail comes from the coordinates' differences across the pixel's 2×2
/// quad (its top-left pixel to the one right of it and the one below: every pixel of a quad
/// takes the same, as graphics APIs' coarse derivatives do), the triangle's attributes
/// evaluated at those centres whether or not they lie inside it; found the first time a
/// trilinear texture needs them and kept in `quad`.
#[inline]
#[allow(clippy::too_many_arguments)]
fn sampled(
    params: &ShadeParams,
    s: &TriangleSetup,
    t: &TriangleShading,
    textures: &[TextureInfo],
    texels: &[u64],
    texture: u32,
    uv: [f32; 2],
    quad: &mut Quad,
    i: i32,
    j: i32,
) -> [f32; 4] {
    if params.textured == 0 || texture == NO_TEXTURE {
        return [1.0; 4];
    }
    let info = &textures[texture as usize];
    let level = if info.filter() == crate::abi::Filter::Trilinear && info.levels > 1 {
        if !quad.known {
            // The quad's top-left pixel, the one right of it and the one below, in one loop
            // (one copy of the weights' division).
            let (qx, qy) = (i & !1, j & !1);
            let (mut at, mut right, mut below) = ([0.0f32; 2], [0.0f32; 2], [0.0f32; 2]);
            let mut k = 0;
            while k < 3 {
                let uv = uv_at(s, t, params, qx + (k == 1) as i32, qy + (k == 2) as i32);
                match k {
                    0 => at = uv,
                    1 => right = uv,
                    _ => below = uv,
                }
                k += 1;
            }
            *quad = Quad { known: true, d: [right[0] - at[0], right[1] - at[1], below[0] - at[0], below[1] - at[1]] };
        }
        lod(info.width, info.height, quad.d)
    } else {
        0
    };
    let texel = texture::filtered(texels, info, uv[0], uv[1], level);
    [texture::unit(texel[0]), texture::unit(texel[1]), texture::unit(texel[2]), texture::unit(texel[3])]
}

/// The colour, RGBA8, of triangle `(s, t)`'s fragment at pixel `(i, j)`, of depth `depth_bits`,
/// in the built-in shading the frame names (`programs::fragment::Builtin`); a lit or coloured
/// surface through the frame's output transform (`programs::tone`), a line's own colour and the
/// data views (depth, normals, ids) as they are.
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn fragment_colour(
    params: &ShadeParams,
    s: &TriangleSetup,
    t: &TriangleShading,
    face: u32,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    depth_bits: u32,
    i: i32,
    j: i32,
) -> u32 {
    // Each piece once, whatever the mode: a driver reads every branch of the generic stage
    // before the frame's specialisation folds them away, so a piece inlined in several arms
    // costs it several times. The interpolation weights (a correctly rounded division each)
    // only where the mode interpolates attributes.
    let mode = params.mode();
    match mode {
        ShadeMode::Depth => {
            let g = 1.0 - (f32::from_bits(depth_bits) - params.depth_view[0]) * params.depth_view[1];
            return rgba8([g, g, g, 1.0]);
        }
        ShadeMode::Ids => return id_colour(face),
        ShadeMode::Colour | ShadeMode::Phong | ShadeMode::Normals | ShadeMode::Pbr => {}
    }
    let b = weights(s, t, params, i, j);
    let flags = t.material.flags;
    if flags & SHADING_UNLIT != 0 {
        return rgba8(colour_at(t, &b));
    }
    let n = if mode == ShadeMode::Colour { [0.0; 3] } else { facing_normal(flags, normalise(interpolate3(t, &b, ATTR_NORMAL))) };
    if mode == ShadeMode::Normals {
        return rgba8([n[0] * 0.5 + 0.5, n[1] * 0.5 + 0.5, n[2] * 0.5 + 0.5, 1.0]);
    }
    let material = &materials[t.material.material as usize];
    let lights = mode != ShadeMode::Colour && flags & SHADING_NOT_LIT == 0;
    let mut at = surface_at(params, s, t, material, textures, texels, &b, lights, i, j);
    if flags & SHADING_OPAQUE != 0 {
        at.base[3] = 1.0;
    } else if flags & SHADING_MASK != 0 {
        at.base[3] = if at.base[3] >= material.alpha_cutoff { 1.0 } else { 0.0 };
    }
    let lit = if !lights {
        at.base
    } else {
        let p = interpolate3(t, &b, ATTR_POSITION);
        let lit = if mode == ShadeMode::Pbr { pbr(params, &at, n, p) } else { occluded_phong(params, at.base, at.occlusion, n, p) };
        let e = &at.emissive;
        [lit[0] + e[0], lit[1] + e[1], lit[2] + e[2], lit[3]]
    };
    encoded(params, lit)
}

/// The normal a fragment is lit with: `n`, turned round on the back of a double-sided surface
/// (`SHADING_BACK` is set only there), as glTF lights it.
#[inline]
pub fn facing_normal(flags: u32, n: [f32; 3]) -> [f32; 3] {
    if flags & SHADING_BACK != 0 { [-n[0], -n[1], -n[2]] } else { n }
}

/// Source-over of RGBA8 `src` onto RGBA8 `dst` in 8-bit integers, rounded to nearest:
/// colour `(c_s·a + c_d·(255 − a)) / 255`, alpha `a + a_d·(255 − a) / 255`, `a` the source's
/// alpha.
#[inline]
pub fn source_over(src: u32, dst: u32) -> u32 {
    let a = src >> 24;
    let channel = |k: u32| ((src >> k & 0xff) * a + (dst >> k & 0xff) * (255 - a) + 127) / 255;
    let alpha = a + ((dst >> 24) * (255 - a) + 127) / 255;
    channel(0) | channel(8) << 8 | channel(16) << 16 | alpha << 24
}

/// Pixel `(i, j)` as the shade stage leaves it. Blended where `params.blend` says: every
/// fragment of the tile's bin (`bin`, setup slots) whose triangle covers the centre, in
/// submission order (ascending slot), tested against the running depth as the frame's depth
/// test says (written back when it writes depth) and blended source-over onto the background,
/// each coloured by `program`; the face is the last fragment that passed (each step finds the
/// next slot by a walk over the bin: `(fragments + 1) × bin` iterations). Else its owner
/// `slot`, of depth `owner_depth_bits`, shaded ([`shade_pixel`]).
#[inline]
#[allow(clippy::too_many_arguments)]
pub fn shaded_pixel<P: FragmentProgram + ?Sized, R: ShadingRecords + ?Sized>(
    program: &P,
    params: &ShadeParams,
    clear_bits: u32,
    setups: &[TriangleSetup],
    shading: &R,
    textures: &[TextureInfo],
    texels: &[u64],
    materials: &[MaterialRecord],
    bin: &[u32],
    bin_start: u32,
    bin_len: u32,
    slot: u32,
    owner_depth_bits: u32,
    i: i32,
    j: i32,
) -> Shaded {
    // One loop for both, so that the stage holds one copy of `program` (a driver reads every
    // inlined copy before the frame's specialisation removes one).
    let blend = params.blend != 0;
    let test = DepthProgram { func: params.depth_test.func(), write: true, clear: f32::from_bits(clear_bits), small_edges: false };
    let write = params.depth_test.write();
    let mut out = Shaded { colour: params.background, face: NO_OWNER };
    let mut running = f32::from_bits(clear_bits);
    // The next slot to look for is above `after` (none yet: `started` false).
    let (mut after, mut started) = (0u32, false);
    loop {
        let mut next = NO_OWNER;
        if !blend {
            if !started {
                next = slot;
            }
        } else {
            let mut k = 0;
            while k < bin_len {
                let candidate = bin[(bin_start + k) as usize] & !FULL_TILE_BIT;
                if (!started || candidate > after) && candidate < next && side(&setups[candidate as usize].coverage, i, j) == Side::Inside {
                    next = candidate;
                }
                k += 1;
            }
        }
        if next == NO_OWNER {
            return out;
        }
        after = next;
        started = true;
        let s = &setups[next as usize];
        let d = if blend { depth_bits(s, i, j) } else { owner_depth_bits };
        if blend && !(DepthProgram { clear: running, ..test }).passes(f32::from_bits(d)) {
            continue;
        }
        // The face from where the backend keeps it: a face-id frame reads no more of the record.
        let face = shading.face(next);
        let record = shading.record(next);
        let colour = program.colour(params, s, &record, face, textures, texels, materials, d, i, j);
        // A masked surface's transparent fragment is discarded: no colour, no depth.
        if blend && record.material.flags & SHADING_MASK != 0 && colour >> 24 == 0 {
            continue;
        }
        out = Shaded { colour: if blend { source_over(colour, out.colour) } else { colour }, face };
        if blend && write {
            running = f32::from_bits(d);
        }
    }
}

const _: () = assert!(ATTRIBUTES == 12 && ATTR_POSITION + 3 <= ATTRIBUTES);
