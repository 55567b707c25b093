//! Elementary functions every device computes alike: `exp`, `exp2`, `ln`, `log2`, `pow`, `sin`,
//! `cos`, `asin` and `acos` on `f32`.
//!
//! A GPU's own `Exp`, `Log`, `Pow`, `Sin` and `Cos` are approximations that each driver makes
//! its own way (Vulkan asks only 3 ulp, or an absolute bound, of most), so a shader that calls
//! them gives other bits on every device. These are written from operations that are the same
//! everywhere: `f32` addition, subtraction and multiplication (correctly rounded on every
//! device, and never fused: the build marks them `NoContraction`), the correctly rounded
//! division and square root of [`super::float`], conversions of integers, and bit patterns.
//! Each reduces its argument exactly or nearly so (Cody and Waite's split constants), then
//! evaluates a Taylor polynomial short enough for its interval, by Horner's rule, in a fixed
//! order. The error bounds against `f64` (numeric contract, "Elementary functions") are held by
//! the tests over each domain, and `examples/elementary` holds the GPU to the CPU's bits.
//!
//! One rule beyond the contract's: no sum or product here chains two constants (`(c₁ − x) + c₂`,
//! `(x · c₁) · c₂`). `spirv-opt` runs inside rust-gpu's compilation, before the build marks the
//! arithmetic `NoContraction`, and merges such constants (`(c₁ + c₂) − x`), which the CPU does
//! not: a `π/2` split into two parts and added last gave other bits on lavapipe. So results
//! are scaled by their exponent's bits, and `π/2` is one constant.
//!
//! Domains: `exp` and `exp2` where the result is normal (`+∞` above, `+0` below); `ln`, `log2`
//! for positive finite arguments (`−∞` at zero, NaN below); `pow(x, y)` for `x ≥ 0`; `sin` and
//! `cos` for `|x| ≤ 4096`; `asin`, `acos` on `[−1, 1]` (NaN outside).

use super::float::{div_portable, floor, sqrt_portable};

/// `ln 2` in two parts: the first's 15 significant bits make `n · LN2_HI` exact for `|n| < 2^9`.
const LN2_HI: f32 = f32::from_bits(0x3f31_7200); // 0.69314575
const LN2_LO: f32 = f32::from_bits(0x35bf_be8e); // 1.4286068e-06
const LN2: f32 = f32::from_bits(0x3f31_7218); // 0.6931472
const LOG2_E: f32 = f32::from_bits(0x3fb8_aa3b); // 1.442695
const TWO_LOG2_E: f32 = f32::from_bits(0x4038_aa3b); // 2.88539
/// `π/2` in three parts (8 and 12 significant bits, then the rest): `k · C1` and `k · C2` are
/// exact for `|k| < 2^12`.
const PIO2_C1: f32 = f32::from_bits(0x3fc9_0000); // 1.5703125
const PIO2_C2: f32 = f32::from_bits(0x39fd_b000); // 0.0004838705
const PIO2_C3: f32 = f32::from_bits(0xb33b_bd2e); // -4.371139e-08
const FRAC_2_PI: f32 = f32::from_bits(0x3f22_f983); // 0.63661975
const PIO2: f32 = f32::from_bits(0x3fc9_0fdb); // 1.5707964
const PI: f32 = f32::from_bits(0x4049_0fdb); // 3.1415927

/// The nearest integer to `x` (halves up), for `|x| < 2^22`.
#[inline]
fn nearest(x: f32) -> i32 {
    floor(x + 0.5).0
}

/// `2^n` for `−126 ≤ n ≤ 127`, exactly.
#[inline]
fn pow2(n: i32) -> f32 {
    f32::from_bits(((n + 127) as u32) << 23)
}

/// `p · 2^n` for `p` in `(0.7, 1.5)`: `n` added to its exponent's bits (no product, which
/// `spirv-opt` could merge with another), `+∞` above the normal range, `+0` below it.
#[inline]
fn scaled(p: f32, n: i32) -> f32 {
    let bits = p.to_bits();
    let e = (bits >> 23) as i32 + n;
    if e >= 255 {
        return f32::from_bits(0x7f80_0000);
    }
    if e <= 0 {
        return 0.0;
    }
    f32::from_bits(bits.wrapping_add((n as u32) << 23))
}

/// `e^r` for `|r| ≤ 0.35`: Taylor's polynomial to `r^7` (the rest below `6·10^−9`).
#[inline]
fn exp_reduced(r: f32) -> f32 {
    let p = (((((r * (1.0 / 5040.0) + 1.0 / 720.0) * r + 1.0 / 120.0) * r + 1.0 / 24.0) * r + 1.0 / 6.0) * r + 0.5) * r;
    (p * r + r) + 1.0
}

/// An exponential's value where `x` is NaN (NaN) or outside `[low, high]` (`+0`, `+∞`).
#[inline]
fn beyond(x: f32, low: f32, high: f32) -> Option<f32> {
    match () {
        _ if is_nan(x) => Some(x),
        _ if x > high => Some(f32::from_bits(0x7f80_0000)),
        _ if x < low => Some(0.0),
        _ => None,
    }
}

/// `e^x`, within 2 ulp where the result is normal.
pub fn exp(x: f32) -> f32 {
    if let Some(outside) = beyond(x, -104.0, 89.0) {
        return outside;
    }
    let n = nearest(x * LOG2_E);
    let r = (x - n as f32 * LN2_HI) - n as f32 * LN2_LO;
    scaled(exp_reduced(r), n)
}

/// `2^x`, within 2 ulp where the result is normal.
pub fn exp2(x: f32) -> f32 {
    if let Some(outside) = beyond(x, -150.0, 129.0) {
        return outside;
    }
    let n = nearest(x);
    // Exact: `x` and `n` are within half of each other.
    let f = x - n as f32;
    scaled(exp_reduced(f * LN2), n)
}

/// `x = 2^e · m` with `m` in `[√½, √2)`, `s = (m − 1)/(m + 1)` and the series' correction
/// `c`: `ln m = 2s (1 + c)`, for a positive finite `x`.
#[inline]
fn log_parts(x: f32) -> (f32, f32, f32) {
    let (mut bits, mut e) = (x.to_bits(), 0);
    if bits >> 23 == 0 {
        // Subnormal: made normal exactly.
        bits = (x * pow2(25)).to_bits();
        e = -25;
    }
    e += (bits >> 23) as i32 - 127;
    let mut m = f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000);
    if m > core::f32::consts::SQRT_2 {
        m *= 0.5;
        e += 1;
    }
    // ln m = 2 atanh(s), s = (m − 1)/(m + 1) in ±0.172: the series to s^11 (the rest below 10^−10).
    let d = m - 1.0;
    if d == 0.0 {
        return (e as f32, 0.0, 0.0);
    }
    let s = if d > 0.0 { div_portable(d, m + 1.0) } else { -div_portable(-d, m + 1.0) };
    let z = s * s;
    let p = (((z * (1.0 / 11.0) + 1.0 / 9.0) * z + 1.0 / 7.0) * z + 1.0 / 5.0) * z + 1.0 / 3.0;
    // ln m = 2s + 2s · (z·p); scaled by `scale` before the correction is added, so that a
    // logarithm in another base rounds once more, not twice.
    (e as f32, s, z * p)
}

/// Whether `x` is NaN, from its bits.
#[inline]
fn is_nan(x: f32) -> bool {
    x.to_bits() & 0x7fff_ffff > 0x7f80_0000
}

/// Whether `x` is finite and not NaN.
#[inline]
fn finite(x: f32) -> bool {
    x.to_bits() & 0x7f80_0000 != 0x7f80_0000
}

/// A logarithm's value where it is not computed: NaN for NaN and below zero, `−∞` at zero,
/// `+∞` at `+∞`.
#[inline]
fn log_special(x: f32) -> Option<f32> {
    match () {
        _ if is_nan(x) || x < 0.0 => Some(f32::from_bits(0x7fc0_0000)),
        _ if x == 0.0 => Some(f32::from_bits(0xff80_0000)),
        _ if !finite(x) => Some(x),
        _ => None,
    }
}

/// `ln x`, within 2 ulp for positive finite `x`.
pub fn ln(x: f32) -> f32 {
    if let Some(special) = log_special(x) {
        return special;
    }
    let (e, s, c) = log_parts(x);
    let twice = s + s;
    e * LN2_HI + (e * LN2_LO + (twice + twice * c))
}

/// `log2 x`, within 3 ulp for positive finite `x` (`2s` scaled by `2 log2 e` rounds once
/// more than `ln`'s sum).
pub fn log2(x: f32) -> f32 {
    if let Some(special) = log_special(x) {
        return special;
    }
    let (e, s, c) = log_parts(x);
    let a = s * TWO_LOG2_E;
    e + (a + a * c)
}

/// `x^y` for `x ≥ 0` as `2^(y · log2 x)`: its relative error grows with `t = y · log2 x`, as
/// `(3 + |t|) · 2^−23` (numeric contract). `pow(x, 0) = 1`, `pow(0, y) = 0` for `y > 0` and
/// `+∞` for `y < 0`.
pub fn pow(x: f32, y: f32) -> f32 {
    if y == 0.0 || x == 1.0 {
        return 1.0;
    }
    if x == 0.0 {
        return if y > 0.0 { 0.0 } else { f32::from_bits(0x7f80_0000) };
    }
    exp2(y * log2(x))
}

/// `x − k · π/2` for the nearest `k`, and `k`: exact but for the last part's rounding, for
/// `|x| ≤ 4096`.
#[inline]
fn quadrant(x: f32) -> (f32, i32) {
    let k = nearest(x * FRAC_2_PI);
    let kf = k as f32;
    (((x - kf * PIO2_C1) - kf * PIO2_C2) - kf * PIO2_C3, k)
}

/// `sin r` for `|r| ≤ π/4 + ε`: to `r^9` (the rest below `2·10^−9`).
#[inline]
fn sin_reduced(r: f32) -> f32 {
    let z = r * r;
    let p = (((z * (1.0 / 362_880.0) - 1.0 / 5040.0) * z + 1.0 / 120.0) * z - 1.0 / 6.0) * z;
    r + r * p
}

/// `cos r` for `|r| ≤ π/4 + ε`: to `r^10` (the rest below `2·10^−10`).
#[inline]
fn cos_reduced(r: f32) -> f32 {
    let z = r * r;
    let p = ((((z * (-1.0 / 3_628_800.0) + 1.0 / 40_320.0) * z - 1.0 / 720.0) * z + 1.0 / 24.0) * z) * z;
    (1.0 - 0.5 * z) + p
}

/// `sin x` for `|x| ≤ 4096`, within `2^−23` absolutely.
pub fn sin(x: f32) -> f32 {
    let (r, k) = quadrant(x);
    match k & 3 {
        0 => sin_reduced(r),
        1 => cos_reduced(r),
        2 => -sin_reduced(r),
        _ => -cos_reduced(r),
    }
}

/// `cos x` for `|x| ≤ 4096`, within `2^−23` absolutely.
pub fn cos(x: f32) -> f32 {
    let (r, k) = quadrant(x);
    match k & 3 {
        0 => cos_reduced(r),
        1 => -sin_reduced(r),
        2 => -cos_reduced(r),
        _ => sin_reduced(r),
    }
}

/// `asin x` for `|x| ≤ ½`: Taylor's series to `x^23` (the rest below `3·10^−9` relatively).
#[inline]
fn asin_small(x: f32) -> f32 {
    // (2n)! / (4^n (n!)^2 (2n + 1)), n = 11 down to 1, by Horner's rule.
    let z = x * x;
    let mut p = 88179.0 / 12_058_624.0;
    p = p * z + 46189.0 / 5_505_024.0;
    p = p * z + 12155.0 / 1_245_184.0;
    p = p * z + 6435.0 / 557_056.0;
    p = p * z + 143.0 / 10240.0;
    p = p * z + 231.0 / 13312.0;
    p = p * z + 63.0 / 2816.0;
    p = p * z + 35.0 / 1152.0;
    p = p * z + 5.0 / 112.0;
    p = p * z + 3.0 / 40.0;
    p = p * z + 1.0 / 6.0;
    x + x * (z * p)
}

/// `asin √((1 − a)/2)` for `a` in `(½, 1]`: half of `acos a`.
#[inline]
fn half_acos(a: f32) -> f32 {
    // `1 − a` is exact (Sterbenz), the halving too.
    let h = (1.0 - a) * 0.5;
    if h == 0.0 { 0.0 } else { asin_small(sqrt_portable(h)) }
}

/// `asin x` on `[−1, 1]`, within 3 ulp.
pub fn asin(x: f32) -> f32 {
    let a = if x < 0.0 { -x } else { x };
    if is_nan(x) || a > 1.0 {
        return f32::from_bits(0x7fc0_0000);
    }
    if a <= 0.5 {
        return asin_small(x);
    }
    let r = PIO2 - 2.0 * half_acos(a);
    if x < 0.0 { -r } else { r }
}

/// `acos x` on `[−1, 1]`, within 2 ulp.
pub fn acos(x: f32) -> f32 {
    let a = if x < 0.0 { -x } else { x };
    if is_nan(x) || a > 1.0 {
        return f32::from_bits(0x7fc0_0000);
    }
    if a <= 0.5 {
        return PIO2 - asin_small(x);
    }
    let h = 2.0 * half_acos(a);
    if x < 0.0 { PI - h } else { h }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// The distance from `got` to the `f64` value `want` in units of `f32`'s last place at
    /// `want` (its spacing there, the smallest normal's below).
    fn ulps(got: f32, want: f64) -> f64 {
        let spacing = (want.abs().max(f32::MIN_POSITIVE as f64) as f32).to_bits();
        let ulp = f32::from_bits(spacing + 1) as f64 - f32::from_bits(spacing) as f64;
        (got as f64 - want).abs() / ulp
    }

    /// `n` values spread over `[lo, hi]` (a lattice and xorshift noise), and the ends.
    fn samples(lo: f32, hi: f32, n: usize) -> impl Iterator<Item = f32> {
        let mut s = 0x9e37_79b9u32;
        let lattice = (0..=n).map(move |k| lo + (hi - lo) * (k as f32 / n as f32));
        let noise = std::iter::repeat_with(move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            lo + (hi - lo) * (s as f32 / u32::MAX as f32)
        });
        lattice.chain(noise.take(n)).chain([lo, hi]).filter(move |x| (lo..=hi).contains(x))
    }

    /// The largest error in ulp of `f` against `reference` over `xs`, and where.
    fn worst(xs: impl Iterator<Item = f32>, f: impl Fn(f32) -> f32, reference: impl Fn(f64) -> f64) -> (f64, f32) {
        xs.map(|x| (ulps(f(x), reference(x as f64)), x)).fold((0.0, 0.0), |a, b| if b.0 > a.0 { b } else { a })
    }

    #[test]
    fn exponentials_are_within_two_ulp_where_the_result_is_normal() {
        let (e, at) = worst(samples(-87.0, 88.72, 400_000).chain(samples(88.3, 88.72, 10_000)), exp, f64::exp);
        eprintln!("exp: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "exp: {e} ulp at {at}");
        let (e, at) = worst(samples(-1.0, 1.0, 200_000), exp, f64::exp);
        eprintln!("exp near 0: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "exp near 0: {e} ulp at {at}");
        let (e, at) = worst(samples(-125.9, 127.99, 400_000).chain(samples(127.5, 127.99, 10_000)), exp2, f64::exp2);
        eprintln!("exp2: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "exp2: {e} ulp at {at}");
        // Integers give powers of two exactly.
        for n in -126..=127 {
            assert_eq!(exp2(n as f32), (n as f64).exp2() as f32, "2^{n}");
        }
        assert_eq!((exp(0.0), exp2(0.0)), (1.0, 1.0));
        assert_eq!((exp(100.0), exp(-200.0), exp2(200.0), exp2(-200.0)), (f32::INFINITY, 0.0, f32::INFINITY, 0.0));
        assert!(exp(f32::NAN).is_nan());
    }

    #[test]
    fn logarithms_are_within_two_and_three_ulp() {
        // Significands over a few binades either side of 1, then every binade.
        let (e, at) = worst(samples(0.25, 4.0, 400_000), ln, f64::ln);
        eprintln!("ln: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "ln: {e} ulp at {at}");
        let (e, at) = worst(samples(0.25, 4.0, 400_000), log2, f64::log2);
        eprintln!("log2: worst {e:.2} ulp at {at}");
        assert!(e <= 3.0, "log2: {e} ulp at {at}");
        let binades: Vec<f32> =
            (-149..128).flat_map(|k| samples(1.0, 2.0, 300).map(move |m| m * (k as f64).exp2() as f32)).filter(|x| *x > 0.0 && x.is_finite()).collect();
        let (e, at) = worst(binades.iter().copied(), ln, f64::ln);
        eprintln!("ln over every binade: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "ln over every binade: {e} ulp at {at}");
        let (e, at) = worst(binades.into_iter(), log2, f64::log2);
        eprintln!("log2 over every binade: worst {e:.2} ulp at {at}");
        assert!(e <= 3.0, "log2 over every binade: {e} ulp at {at}");
        for k in -149..128 {
            let x = (k as f64).exp2() as f32;
            assert_eq!(log2(x), k as f32, "log2 2^{k}");
        }
        assert_eq!((ln(1.0), log2(1.0)), (0.0, 0.0));
        assert_eq!((ln(0.0), log2(f32::INFINITY)), (f32::NEG_INFINITY, f32::INFINITY));
        assert!(ln(-1.0).is_nan() && log2(f32::NAN).is_nan());
    }

    #[test]
    fn powers_are_within_their_bound() {
        let mut s = 0x1234_5678u32;
        let mut next = move || {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            s as f32 / u32::MAX as f32
        };
        for _ in 0..400_000 {
            let x = (next() * 40.0 - 20.0).exp2();
            let y = next() * 16.0 - 8.0;
            let want = (x as f64).powf(y as f64);
            if !(want > f32::MIN_POSITIVE as f64 && want < f32::MAX as f64) {
                continue;
            }
            let t = (y as f64 * (x as f64).log2()).abs();
            let relative = ((pow(x, y) as f64 - want) / want).abs();
            assert!(relative <= (3.0 + t) * f64::from(f32::EPSILON), "pow({x}, {y}): relative error {relative:e}, t = {t}");
        }
        // sRGB's gamma over [10^−4, 1]: |t| ≤ 5.6, so within 8.6 · 2^−23.
        for x in samples(1e-4, 1.0, 200_000) {
            let want = (x as f64).powf((1.0f32 / 2.4) as f64);
            let t = (x as f64).log2() / 2.4;
            assert!(((pow(x, 1.0 / 2.4) as f64 - want) / want).abs() <= (3.0 + t.abs()) * f64::from(f32::EPSILON), "x^(1/2.4) at {x}");
        }
        assert_eq!((pow(2.0, 10.0), pow(3.0, 0.0), pow(0.0, 2.0), pow(0.0, -1.0), pow(1.0, 1e30)), (1024.0, 1.0, 0.0, f32::INFINITY, 1.0));
    }

    #[test]
    fn sines_and_cosines_are_within_their_bound() {
        let bound = f64::from(f32::EPSILON);
        for (f, reference, name) in [(sin as fn(f32) -> f32, f64::sin as fn(f64) -> f64, "sin"), (cos, f64::cos, "cos")] {
            for x in samples(-4096.0, 4096.0, 1_000_000).chain(samples(-7.0, 7.0, 300_000)) {
                let error = (f(x) as f64 - reference(x as f64)).abs();
                assert!(error <= bound, "{name}({x}): off by {error:e}");
            }
            // Near zero: relative, as the result is small there.
            let (e, at) = worst(samples(-0.785, 0.785, 200_000), f, reference);
            eprintln!("{name} on [−π/4, π/4]: worst {e:.2} ulp at {at}");
            assert!(e <= 2.0, "{name} on [−π/4, π/4]: {e} ulp at {at}");
        }
        assert_eq!((sin(0.0), cos(0.0)), (0.0, 1.0));
    }

    #[test]
    fn inverse_sines_and_cosines_are_within_their_bounds() {
        let (e, at) = worst(samples(-1.0, 1.0, 1_000_000), asin, f64::asin);
        eprintln!("asin: worst {e:.2} ulp at {at}");
        assert!(e <= 3.0, "asin: {e} ulp at {at}");
        let (e, at) = worst(samples(-1.0, 1.0, 1_000_000), acos, f64::acos);
        eprintln!("acos: worst {e:.2} ulp at {at}");
        assert!(e <= 2.0, "acos: {e} ulp at {at}");
        assert_eq!((acos(1.0), asin(0.0)), (0.0, 0.0));
        assert_eq!((acos(-1.0), asin(1.0)), (PI, PIO2));
        assert!(acos(1.5).is_nan() && asin(f32::NAN).is_nan());
    }
}
