//! glTF's metallic-roughness BRDF (glTF 2.0, appendix B): a Lambertian diffuse lobe and a GGX
//! specular lobe with the height-correlated Smith visibility, mixed by Schlick's Fresnel term,
//! for one light from one direction. The shade stage's physically based shading builds on it.
//!
//! The same bits on every device: additions, subtractions, multiplications, comparisons, and
//! `math::float`'s correctly rounded division and square root. Each term is written as a sum
//! or product of non-negative parts (`1 − x²` as `(1 − x)(1 + x)`, whose first factor is exact
//! for `x ≥ ½`), so that no subtraction cancels what the rounding left, and the result lies
//! within the numeric contract's bound (§10) of the `f64` evaluation of the same dot products.

use crate::math::float::{div, recip, sqrt};
use crate::programs::shade::{clamp01, per_component, powi};

/// The smallest perceptual roughness shaded (as Filament's): below it `α²` would leave `f32`'s
/// normal range and the specular peak would be narrower than a pixel's worth of normals.
pub const MIN_ROUGHNESS: f32 = 0.045;

/// The reflectance at normal incidence of a dielectric (glTF's `0.04`).
pub const DIELECTRIC_F0: f32 = 0.04;

/// The smallest `n·v` shaded: a normal that the interpolation turned away from the viewer is
/// shaded as if grazing.
pub const MIN_N_DOT_V: f32 = 1.0e-4;

/// `1/π`, rounded to `f32`.
const INV_PI: f32 = core::f32::consts::FRAC_1_PI;

/// What a metallic-roughness material gives one fragment: its base colour (linear RGB), how
/// metallic it is and its perceptual roughness, each in `[0, 1]`.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Surface {
    pub base: [f32; 3],
    pub metallic: f32,
    pub roughness: f32,
}

/// The cosines one light's reflection depends on: of the normal with the light, the viewer and
/// the half vector, and of the viewer with the half vector.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
pub struct Cosines {
    pub n_l: f32,
    pub n_v: f32,
    pub n_h: f32,
    pub v_h: f32,
}

/// `α²` of perceptual roughness `r` (`α = r²`), `r` clamped to `[MIN_ROUGHNESS, 1]`.
#[inline]
pub fn alpha_squared(r: f32) -> f32 {
    let r = if r > MIN_ROUGHNESS { clamp01(r) } else { MIN_ROUGHNESS };
    let a = r * r;
    a * a
}

/// The GGX normal distribution `D = α² / (π ((n·h)²(α² − 1) + 1)²)`, its denominator's base
/// written `(1 − n·h)(1 + n·h) + (n·h)²α²`: positive parts, no cancellation.
#[inline]
pub fn distribution(n_h: f32, a2: f32) -> f32 {
    let x = clamp01(n_h);
    let t = (1.0 - x) * (1.0 + x) + (x * x) * a2;
    div(a2 * INV_PI, t * t)
}

/// The height-correlated Smith visibility `V = G / (4 (n·l)(n·v))` in glTF's separable form,
/// `1 / ((n·l + √(α² + (1 − α²)(n·l)²)) (n·v + √(α² + (1 − α²)(n·v)²)))`.
#[inline]
pub fn visibility(n_l: f32, n_v: f32, a2: f32) -> f32 {
    let rest = 1.0 - a2;
    let lobe = |c: f32| c + sqrt(a2 + rest * (c * c));
    recip(lobe(n_l) * lobe(n_v))
}

/// Schlick's Fresnel term `F = F₀ + (1 − F₀)(1 − v·h)⁵` of one channel and its complement
/// `1 − F`, given `F₀` and `1 − F₀`. The complement is written `(1 − F₀)·v·h·(1 + y + y² + y³ +
/// y⁴)` with `y = 1 − v·h` (the same value): where `F` nears one (grazing light) subtracting
/// it would leave only rounding.
#[inline]
pub fn fresnel(f0: f32, one_minus_f0: f32, v_h: f32) -> (f32, f32) {
    let v_h = clamp01(v_h);
    let y = 1.0 - v_h;
    let f = f0 + one_minus_f0 * powi(y, 5);
    let complement = (one_minus_f0 * v_h) * (1.0 + y * (1.0 + y * (1.0 + y * (1.0 + y))));
    (f, complement)
}

/// The light a surface reflects towards the viewer per unit of radiance arriving from the
/// light, RGB: `(f_diffuse + f_specular) · n·l`, zero where the light is behind the surface.
/// `f_diffuse = (1 − F)(1 − metallic)·base/π`, `f_specular = F·D·V`, with
/// `F₀ = 0.04(1 − metallic) + base·metallic`.
#[inline]
pub fn reflected(s: &Surface, c: &Cosines) -> [f32; 3] {
    if c.n_l <= 0.0 {
        return [0.0; 3];
    }
    let n_l = clamp01(c.n_l);
    let n_v = if c.n_v > MIN_N_DOT_V { clamp01(c.n_v) } else { MIN_N_DOT_V };
    let metallic = clamp01(s.metallic);
    let dielectric = 1.0 - metallic;
    let a2 = alpha_squared(s.roughness);
    // D and V are shared by the channels; F and the diffuse colour are not.
    let specular = distribution(c.n_h, a2) * visibility(n_l, n_v, a2);
    per_component(s.base, |base| {
        let base = clamp01(base);
        // 1 − F₀ in positive parts: 0.96(1 − metallic) + metallic(1 − base).
        let f0 = DIELECTRIC_F0 * dielectric + base * metallic;
        let one_minus_f0 = (1.0 - DIELECTRIC_F0) * dielectric + metallic * (1.0 - base);
        let (f, one_minus_f) = fresnel(f0, one_minus_f0, c.v_h);
        let diffuse = one_minus_f * (base * dielectric) * INV_PI;
        (diffuse + f * specular) * n_l
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The BRDF of the same inputs in `f64`, as glTF's appendix writes it.
    fn reference(s: &Surface, c: &Cosines) -> [f64; 3] {
        if c.n_l <= 0.0 {
            return [0.0; 3];
        }
        let clamp = |x: f64| x.clamp(0.0, 1.0);
        let (n_l, n_v, n_h, v_h) = (clamp(c.n_l as f64), (c.n_v as f64).clamp(MIN_N_DOT_V as f64, 1.0), clamp(c.n_h as f64), clamp(c.v_h as f64));
        let metallic = clamp(s.metallic as f64);
        let r = (s.roughness as f64).clamp(MIN_ROUGHNESS as f64, 1.0);
        let a2 = r.powi(4);
        let d = a2 / (std::f64::consts::PI * (n_h * n_h * (a2 - 1.0) + 1.0).powi(2));
        let lobe = |x: f64| x + (a2 + (1.0 - a2) * x * x).sqrt();
        let v = 1.0 / (lobe(n_l) * lobe(n_v));
        std::array::from_fn(|k| {
            let base = clamp(s.base[k] as f64);
            let f0 = 0.04 * (1.0 - metallic) + base * metallic;
            let f = f0 + (1.0 - f0) * (1.0 - v_h).powi(5);
            ((1.0 - f) * base * (1.0 - metallic) / std::f64::consts::PI + f * d * v) * n_l
        })
    }

    /// Surfaces and cosines over their whole ranges (xorshift), with the ends of each range and
    /// the sharpest highlights (`n·h` and `v·h` near one, the smallest roughness).
    fn cases(n: usize) -> impl Iterator<Item = (Surface, Cosines)> {
        let mut state = 0x2545_f491u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            let u = state as f32 / u32::MAX as f32;
            // A quarter of the values at the ends of the range or just inside them.
            match state % 8 {
                0 => 0.0,
                1 => 1.0,
                2 => 1.0 - u * 1.0e-3,
                _ => u,
            }
        };
        std::iter::repeat_with(move || {
            let s = Surface { base: [next(), next(), next()], metallic: next(), roughness: next() };
            let c = Cosines { n_l: next(), n_v: next(), n_h: next(), v_h: next() };
            (s, c)
        })
        .take(n)
    }

    #[test]
    fn the_brdf_is_within_the_contracts_bound_of_its_f64_value() {
        // The numeric contract's §10: relative to the f64 value of the same cosines and
        // material, per channel.
        const BOUND: f64 = 1.0 / (1u64 << 19) as f64;
        let mut worst = (0.0f64, Surface::default(), Cosines::default());
        for (s, c) in cases(1_000_000) {
            let got = reflected(&s, &c);
            let want = reference(&s, &c);
            for k in 0..3 {
                let error = if want[k] == 0.0 { got[k].abs() as f64 } else { (got[k] as f64 - want[k]).abs() / want[k] };
                if error > worst.0 {
                    worst = (error, s, c);
                }
            }
        }
        let (error, s, c) = worst;
        println!("worst relative error {error:.3e} ({:.1} units of 2^-24) at {s:?} {c:?}", error * (1u64 << 24) as f64);
        assert!(error <= BOUND, "relative error {error:e} at {s:?} {c:?}");
    }

    #[test]
    fn a_white_dielectric_lit_head_on_reflects_what_lambert_and_ggx_say() {
        // n = v = l = h: D = 1/(πα²), V = 1/(4α²)·… at α² = r⁴, F = F₀.
        let s = Surface { base: [1.0, 0.5, 0.0], metallic: 0.0, roughness: 0.5 };
        let c = Cosines { n_l: 1.0, n_v: 1.0, n_h: 1.0, v_h: 1.0 };
        let a2 = 0.0625f64;
        let specular = 0.04 / (std::f64::consts::PI * a2) / 4.0;
        let got = reflected(&s, &c);
        for (k, base) in [1.0, 0.5, 0.0].into_iter().enumerate() {
            let want = 0.96 * base / std::f64::consts::PI + specular;
            assert!((got[k] as f64 - want).abs() <= want * 1e-6, "channel {k}: {} against {want}", got[k]);
        }
    }

    #[test]
    fn light_behind_the_surface_adds_nothing_and_metals_have_no_diffuse_lobe() {
        let metal = Surface { base: [0.9, 0.6, 0.2], metallic: 1.0, roughness: 1.0 };
        assert_eq!(reflected(&metal, &Cosines { n_l: -0.1, n_v: 1.0, n_h: 0.5, v_h: 0.5 }), [0.0; 3]);
        assert_eq!(reflected(&metal, &Cosines { n_l: 0.0, n_v: 1.0, n_h: 0.5, v_h: 0.5 }), [0.0; 3]);
        // At normal incidence a metal reflects its base colour (F = F₀ = base), all specular.
        let c = Cosines { n_l: 1.0, n_v: 1.0, n_h: 1.0, v_h: 1.0 };
        let got = reflected(&metal, &c);
        let specular = distribution(1.0, 1.0) * visibility(1.0, 1.0, 1.0);
        for (k, (got, base)) in got.iter().zip(metal.base).enumerate() {
            assert_eq!(*got, (base * specular) * 1.0, "channel {k}");
        }
    }
}
