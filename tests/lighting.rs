//! Flat and Gouraud shading's lighting, which the kernels' assembly runs on every backend
//! (`programs::shade::lit_vertex` and `lit_face`, Lambert + Blinn-Phong in `f32`), against
//! the same lighting in `f64` of the same `f32` inputs, within the bound
//! `docs/numeric-contract.md` states ("Shading").

use tileraster_kernels::abi::{ATTR_COLOUR, ATTR_NORMAL, ATTR_POSITION, ATTRIBUTES, MAX_LIGHTS, ShadeParams};
use tileraster_kernels::programs::shade::{lit_face, lit_vertex};

/// A fixed sequence of inputs, rounded to `f32`.
struct Rng(tileraster_testkit::scenes::Rng);

impl Rng {
    /// Uniform in `[lo, hi)`, rounded to `f32`.
    fn uniform(&mut self, lo: f64, hi: f64) -> f32 {
        self.0.range(lo, hi) as f32
    }

    fn vector(&mut self, r: f64) -> [f32; 3] {
        [self.uniform(-r, r), self.uniform(-r, r), self.uniform(-r, r)]
    }
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn unit(v: [f64; 3]) -> [f64; 3] {
    let len = dot(v, v).sqrt();
    if len > 0.0 { v.map(|c| c / len) } else { [0.0; 3] }
}

/// Lambert + Blinn-Phong in `f64` of the kernels' `f32` inputs: the colour, the largest value
/// each channel could take (`base · (ambient + Σ light) + specular · Σ light`, the scale of the
/// bound), and how near a light comes to grazing the surface (the least `|n · l|`).
fn reference(params: &ShadeParams, base: [f32; 4], n: [f32; 3], p: [f32; 3]) -> ([f64; 4], [f64; 3], f64) {
    let f = |v: &[f32]| [v[0] as f64, v[1] as f64, v[2] as f64];
    let (e, w) = (f(&params.eye), params.eye[3] as f64);
    let n = unit(f(&n));
    let v = unit([e[0] - p[0] as f64 * w, e[1] - p[1] as f64 * w, e[2] - p[2] as f64 * w]);
    let (mut diffuse, mut specular, mut scale_lights, mut grazing) = (f(&params.ambient), [0.0; 3], [0.0; 3], f64::INFINITY);
    for k in 0..params.lights as usize {
        let (l, c) = (f(&params.light_dir[k]), f(&params.light_colour[k]));
        let ndl = dot(n, l);
        grazing = grazing.min(ndl.abs());
        for ch in 0..3 {
            scale_lights[ch] += c[ch];
        }
        if ndl > 0.0 {
            let h = unit([l[0] + v[0], l[1] + v[1], l[2] + v[2]]);
            let s = dot(n, h).max(0.0).powi(params.shininess as i32);
            for ch in 0..3 {
                diffuse[ch] += ndl * c[ch];
                specular[ch] += s * c[ch];
            }
        }
    }
    let b = base.map(f64::from);
    let sc = f(&params.specular);
    let colour = [b[0] * diffuse[0] + sc[0] * specular[0], b[1] * diffuse[1] + sc[1] * specular[1], b[2] * diffuse[2] + sc[2] * specular[2], b[3]];
    let ambient = f(&params.ambient);
    let scale = std::array::from_fn(|ch| b[ch].abs() * (ambient[ch] + scale_lights[ch]) + sc[ch] * scale_lights[ch]);
    (colour, scale, grazing)
}

/// The contract's bound for a channel of scale `scale` at specular power `shininess`.
fn bound(scale: f64, shininess: u32) -> f64 {
    (32.0 + 2.0 * shininess as f64) * f64::powi(2.0, -24) * scale
}

/// A frame's lights: `lights` of them, a viewer at a point near `centre` or at infinity.
fn params(rng: &mut Rng, lights: u32, shininess: u32, centre: [f32; 3], at_infinity: bool) -> ShadeParams {
    let mut s = ShadeParams { lights, shininess, ..Default::default() };
    let a = rng.uniform(0.0, 0.4);
    s.ambient = [a, rng.uniform(0.0, 0.4), a, 0.0];
    s.specular = [rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), 0.0];
    for k in 0..lights as usize {
        let d = unit(rng.vector(1.0).map(f64::from)).map(|c| c as f32);
        s.light_dir[k] = [d[0], d[1], d[2], 0.0];
        s.light_colour[k] = [rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), 0.0];
    }
    s.eye = if at_infinity {
        let d = unit(rng.vector(1.0).map(f64::from)).map(|c| c as f32);
        [d[0], d[1], d[2], 0.0]
    } else {
        let o = rng.vector(2000.0);
        [centre[0] + o[0], centre[1] + o[1], centre[2] + o[2], 1.0]
    };
    s
}

#[test]
fn flat_and_gouraud_lighting_lie_within_the_contract_of_f64() {
    assert_eq!(MAX_LIGHTS, 2, "the cases below light with one and with both lights");
    let mut rng = Rng(tileraster_testkit::scenes::Rng::new(0x05EE_D0F1_1687));
    let (mut checked, mut grazing_skipped) = (0u64, 0u64);
    let mut worst = [0.0f64; 5];
    for (s, &shininess) in [1u32, 8, 32, 128, 1024].iter().enumerate() {
        // A scene near the origin, and terrain in UTM coordinates (5,000,000 m north).
        for centre in [[0.0f32, 0.0, 0.0], [500_000.0, 5_000_000.0, 300.0]] {
            for at_infinity in [false, true] {
                for lights in 1..=MAX_LIGHTS as u32 {
                    for _ in 0..4_000 {
                        let params = params(&mut rng, lights, shininess, centre, at_infinity);
                        let mut a = [0.0f32; ATTRIBUTES];
                        let colour = [rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0), rng.uniform(0.0, 1.0)];
                        let normal = rng.vector(3.0);
                        let p = rng.vector(1000.0);
                        let position = [centre[0] + p[0], centre[1] + p[1], centre[2] + p[2]];
                        a[ATTR_COLOUR..ATTR_COLOUR + 4].copy_from_slice(&colour);
                        a[ATTR_NORMAL..ATTR_NORMAL + 3].copy_from_slice(&normal);
                        a[ATTR_POSITION..ATTR_POSITION + 3].copy_from_slice(&position);
                        // Gouraud: the vertex's normal as it comes; flat: the face's unit normal.
                        let unit_normal = unit(normal.map(f64::from)).map(|c| c as f32);
                        for (got, n) in [(lit_vertex(&params, &a), normal), (lit_face(&params, &a, unit_normal), unit_normal)] {
                            let (want, scale, grazing) = reference(&params, colour, n, position);
                            // Where a light grazes the surface, whether it lights the point at all
                            // is decided by `n · l > 0` within the roundings of either.
                            if grazing < f64::powi(2.0, -20) {
                                grazing_skipped += 1;
                                continue;
                            }
                            assert_eq!(got[3] as f64, want[3], "alpha passes through");
                            for ch in 0..3 {
                                let error = (got[ch] as f64 - want[ch]).abs();
                                assert!(
                                    error <= bound(scale[ch], shininess),
                                    "channel {ch}: {} against {} (scale {}, shininess {shininess}, {params:?})",
                                    got[ch],
                                    want[ch],
                                    scale[ch]
                                );
                                if scale[ch] > 0.0 {
                                    worst[s] = worst[s].max(error / scale[ch] / f64::powi(2.0, -24));
                                }
                            }
                            checked += 1;
                        }
                    }
                }
            }
        }
    }
    println!(
        "{checked} colours checked ({grazing_skipped} grazing a light skipped); largest error over the channel's scale, in units of 2^-24, by shininess 1, 8, 32, 128, 1024: {worst:.1?}"
    );
    assert!(grazing_skipped * 1000 < checked, "the grazing cases are rare: {grazing_skipped} of {checked}");
}
