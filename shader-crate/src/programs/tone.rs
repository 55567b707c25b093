//! The frame's output transform (`ShadeParams::output`): a lit colour, linear and unbounded,
//! tone mapped (Khronos PBR Neutral, or ACES as glTF's sample viewer fits it) and encoded
//! (sRGB's transfer function, or left linear) before the 8-bit quantisation.
//!
//! The same bits on every device: additions, subtractions, multiplications, comparisons,
//! `math::float`'s division, and `math::elementary::pow` for sRGB's curve.

use crate::abi::ShadeParams;
use crate::math::elementary::pow;
use crate::math::float::{Divisor, div};
use crate::programs::shade::{rgba8, scale_div};

/// `ShadeParams::output`, bits 0–1: no tone mapping (channels clamped to `[0, 1]`).
pub const TONE_NONE: u32 = 0;
/// Khronos PBR Neutral.
pub const TONE_NEUTRAL: u32 = 1;
/// ACES, Stephen Hill's fit of its reference transforms (glTF Sample Viewer's `toneMapACES_Hill`).
pub const TONE_ACES: u32 = 2;
/// `ShadeParams::output`, bit 2: the channels sRGB-encoded.
pub const OUTPUT_SRGB: u32 = 4;

#[inline]
fn max3(c: [f32; 3]) -> f32 {
    let m = if c[0] > c[1] { c[0] } else { c[1] };
    if m > c[2] { m } else { c[2] }
}

#[inline]
fn min3(c: [f32; 3]) -> f32 {
    let m = if c[0] < c[1] { c[0] } else { c[1] };
    if m < c[2] { m } else { c[2] }
}

/// Khronos PBR Neutral of a non-negative linear colour: below 0.76 unchanged but for a small
/// offset that keeps blacks black, above it compressed towards white, hue kept.
#[inline]
pub fn neutral(c: [f32; 3]) -> [f32; 3] {
    const START: f32 = 0.76;
    const D: f32 = 0.24;
    let c = [if c[0] > 0.0 { c[0] } else { 0.0 }, if c[1] > 0.0 { c[1] } else { 0.0 }, if c[2] > 0.0 { c[2] } else { 0.0 }];
    let x = min3(c);
    let offset = if x < 0.08 { x - (6.25 * x) * x } else { 0.04 };
    let c = [c[0] - offset, c[1] - offset, c[2] - offset];
    let peak = max3(c);
    if peak < START {
        return c;
    }
    // peak + d − start, with d − start = −0.52 exactly in one constant.
    let new_peak = 1.0 - div(D * D, peak - 0.52);
    let scale = div(new_peak, peak);
    let g = 1.0 - div(1.0, 0.15 * (peak - new_peak) + 1.0);
    let keep = 1.0 - g;
    let white = new_peak * g;
    [(c[0] * scale) * keep + white, (c[1] * scale) * keep + white, (c[2] * scale) * keep + white]
}

/// ACES's reference rendering and output transforms as Hill fits them: into ACES's working
/// space, a rational curve per channel, and back, clamped to `[0, 1]`.
#[inline]
pub fn aces(c: [f32; 3]) -> [f32; 3] {
    let (r, g, b) = (c[0], c[1], c[2]);
    let v = [0.59719 * r + 0.35458 * g + 0.04823 * b, 0.07600 * r + 0.90834 * g + 0.01566 * b, 0.02840 * r + 0.13383 * g + 0.83777 * b];
    let fit = |v: f32| {
        let v = if v > 0.0 { v } else { 0.0 };
        scale_div(v * (v + 0.0245786) - 0.000090537, &Divisor::new(v * (0.983729 * v + 0.432951) + 0.238081))
    };
    let (r, g, b) = (fit(v[0]), fit(v[1]), fit(v[2]));
    [1.60475 * r - 0.53108 * g - 0.07367 * b, -0.10208 * r + 1.10813 * g - 0.00605 * b, -0.00327 * r - 0.07276 * g + 1.07602 * b]
}

/// sRGB's transfer function of a linear channel, clamped to `[0, 1]` first.
#[inline]
pub fn srgb_encode(x: f32) -> f32 {
    if x <= 0.0031308 {
        if x > 0.0 { 12.92 * x } else { 0.0 }
    } else if x >= 1.0 {
        1.0
    } else {
        1.055 * pow(x, 1.0 / 2.4) - 0.055
    }
}

/// A lit linear colour as the frame stores it, RGBA8: tone mapped and encoded as
/// `params.output` says (alpha as it is), then quantised.
#[inline]
pub fn encoded(params: &ShadeParams, c: [f32; 4]) -> u32 {
    let tone = params.output & 3;
    let rgb = [c[0], c[1], c[2]];
    let rgb = if tone == TONE_NEUTRAL {
        neutral(rgb)
    } else if tone == TONE_ACES {
        aces(rgb)
    } else {
        rgb
    };
    if params.output & OUTPUT_SRGB != 0 {
        rgba8([srgb_encode(rgb[0]), srgb_encode(rgb[1]), srgb_encode(rgb[2]), c[3]])
    } else {
        rgba8([rgb[0], rgb[1], rgb[2], c[3]])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn neutral_f64(c: [f64; 3]) -> [f64; 3] {
        let c = c.map(|v| v.max(0.0));
        let x = c[0].min(c[1]).min(c[2]);
        let offset = if x < 0.08 { x - 6.25 * x * x } else { 0.04 };
        let c = c.map(|v| v - offset);
        let peak = c[0].max(c[1]).max(c[2]);
        if peak < 0.76 {
            return c;
        }
        let d = 0.24;
        let new_peak = 1.0 - d * d / (peak + d - 0.76);
        let g = 1.0 - 1.0 / (0.15 * (peak - new_peak) + 1.0);
        c.map(|v| v * new_peak / peak * (1.0 - g) + new_peak * g)
    }

    fn aces_f64(c: [f64; 3]) -> [f64; 3] {
        let m = |m: [[f64; 3]; 3], v: [f64; 3]| std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2]);
        let v: [f64; 3] = m([[0.59719, 0.35458, 0.04823], [0.07600, 0.90834, 0.01566], [0.02840, 0.13383, 0.83777]], c);
        let v = v.map(|v| {
            let v = v.max(0.0);
            (v * (v + 0.0245786) - 0.000090537) / (v * (0.983729 * v + 0.432951) + 0.238081)
        });
        m([[1.60475, -0.53108, -0.07367], [-0.10208, 1.10813, -0.00605], [-0.00327, -0.07276, 1.07602]], v)
    }

    fn colours() -> impl Iterator<Item = [f32; 3]> {
        let mut s = 0x1234_5677u32;
        std::iter::repeat_with(move || {
            let mut next = || {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                // Mostly [0, 4], some dark.
                let u = s as f32 / u32::MAX as f32;
                if s.is_multiple_of(4) { u * 0.1 } else { u * 4.0 }
            };
            [next(), next(), next()]
        })
        .take(200_000)
    }

    #[test]
    fn the_tone_maps_are_within_2_to_the_minus_20_of_their_f64_values() {
        for (name, f, reference) in [("neutral", neutral as fn([f32; 3]) -> [f32; 3], neutral_f64 as fn([f64; 3]) -> [f64; 3]), ("aces", aces, aces_f64)] {
            let mut worst = 0.0f64;
            for c in colours() {
                let got = f(c);
                let want = reference(c.map(f64::from));
                for k in 0..3 {
                    worst = worst.max((got[k] as f64 - want[k]).abs());
                }
            }
            println!("{name}: worst absolute error {worst:.3e} ({:.1} units of 2^-24)", worst * (1u64 << 24) as f64);
            assert!(worst <= 1.0 / (1u64 << 20) as f64, "{name}: {worst:e}");
        }
    }

    #[test]
    fn srgb_encoding_gives_the_nearest_8_bit_code_away_from_ties() {
        let mut codes_seen = std::collections::BTreeSet::new();
        for k in 0..=1_000_000u32 {
            let x = k as f32 / 1_000_000.0;
            let want = {
                let x = x as f64;
                255.0 * if x <= 0.0031308 { 12.92 * x } else { 1.055 * x.powf(1.0 / 2.4) - 0.055 }
            };
            let got = (srgb_encode(x) * 255.0 + 0.5) as u32;
            // Within 10^-4 of a tie the f32 curve may fall on either side.
            if (want.fract() - 0.5).abs() > 1e-4 {
                assert_eq!(got, (want + 0.5) as u32, "x = {x}");
            }
            codes_seen.insert(got);
        }
        assert_eq!(codes_seen.len(), 256);
    }

    #[test]
    fn the_output_word_chooses_the_transform() {
        let params = |output| ShadeParams { output, ..Default::default() };
        let grey = [0.5f32, 0.5, 0.5, 1.0];
        assert_eq!(encoded(&params(0), grey) & 0xff, 128);
        assert_eq!(encoded(&params(OUTPUT_SRGB), grey) & 0xff, 188);
        assert_ne!(encoded(&params(TONE_NEUTRAL), [2.0, 1.0, 0.5, 1.0]), encoded(&params(0), [2.0, 1.0, 0.5, 1.0]));
        assert_eq!(encoded(&params(TONE_ACES | OUTPUT_SRGB), grey) >> 24, 255, "alpha as it is");
    }
}
