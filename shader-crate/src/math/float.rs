//! Correctly rounded `f32` division and square root that every device computes alike.
//!
//! Vulkan lets `OpFDiv` be off by 2.5 ulp and `sqrt` by 3 ulp, differently on every driver, so
//! the kernels never use them where bits must match. Each function here estimates its result
//! with a few `f32` multiplications and subtractions (a Newton iteration from a bit-pattern
//! guess), then settles the last bit with 32-bit integers. The estimate's significand `Q` is
//! the correctly rounded one exactly when the true result lies within half a unit of it; the
//! distance to the true result, scaled to an integer (`2n − 2Q·m_b` for a quotient `n / m_b`,
//! `T − 4S²` for a root `√T / 2`), is small, so wrapping 32-bit arithmetic gives it exactly
//! (it agrees with the true value modulo `2^32`, and only one value in `(−2^31, 2^31)` does).
//! That distance, times an estimate of its scale, names the correct significand up to one
//! unit, and one exact comparison settles that unit. So the result does not depend on how the
//! device rounds, fuses or flushes the estimate's arithmetic: any estimate within fifteen
//! units (sixty for a quotient) gives the same bits, those IEEE 754 round-to-nearest-even
//! gives, as the tests check against the CPU's own operations. On a GPU the settling is a
//! dozen 32-bit operations with no loop and no 64-bit product (which a GPU emulates).
//!
//! [`recip_u64`], the reciprocal of an integer with the host's `f64` roundings, is apart: a loop
//! of 64-bit integer steps, for the assembly's once-per-triangle `1/Σw`. So is [`floor`], for
//! shaders: an integer part and a fraction from a conversion and one subtraction, exact.
//!
//! Domain: positive, normal, finite operands, and results in the normal range (what the render
//! pipeline feeds them: sums of positive weights, squared lengths). Outside it they return
//! `+0` for zero or an underflowing result and `+∞` for an overflowing one.
//!
//! Natively the CPU's own division and square root give the same bits faster wherever the
//! operands and the result are in that domain: IEEE 754 rounds them correctly too (Rust
//! guarantees it), and a correctly rounded result is unique. The SPIR-V build always takes the
//! portable path; the tests hold it to the CPU's operations.

use crate::math::fixed::msb;

/// The significand with its implicit bit (24 bits) and the biased exponent of a positive
/// normal `f32`.
#[inline]
fn parts(bits: u32) -> (u32, i32) {
    ((bits & 0x007f_ffff) | 0x0080_0000, (bits >> 23) as i32)
}

/// `m · 2^(e − 150)`, `m` a 24-bit significand with its implicit bit (or `2^24` after a carry),
/// `e` the biased exponent: `+0` below the normal range, `+∞` above it.
#[inline]
fn assemble(m: u32, e: i32) -> f32 {
    let (m, e) = if m == 1 << 24 { (m >> 1, e + 1) } else { (m, e) };
    if e <= 0 {
        0.0
    } else if e >= 255 {
        f32::from_bits(0x7f80_0000)
    } else {
        f32::from_bits(((e as u32) << 23) | (m & 0x007f_ffff))
    }
}

/// Whether a positive `f32` is normal and finite.
#[inline]
fn normal(bits: u32) -> bool {
    let e = bits >> 23;
    e > 0 && e < 255
}

/// `a / b`, correctly rounded, for positive normal `a` and `b`.
#[inline]
pub fn div(a: f32, b: f32) -> f32 {
    #[cfg(not(target_arch = "spirv"))]
    if normal(a.to_bits()) && normal(b.to_bits()) {
        let q = a / b;
        if normal(q.to_bits()) {
            return q;
        }
    }
    div_portable(a, b)
}

/// The significand of `x` in `[1, 2)` as an `f32` (its exponent bits replaced by the bias).
#[inline]
fn unit_significand(bits: u32) -> f32 {
    f32::from_bits((bits & 0x007f_ffff) | 0x3f80_0000)
}

/// A positive `f32` estimate `x` in `[2^-2, 2^2)` as an integer `X` with `x ≈ X · 2^−shift`
/// (its significand shifted by its exponent: exact where `x` has no bits below `2^−shift`,
/// truncated otherwise, which the correction that follows tolerates). Below `2^26`.
#[inline]
fn scaled_estimate(x: f32, shift: u32) -> u32 {
    let bits = x.to_bits();
    let m = (bits & 0x007f_ffff) | 0x0080_0000;
    // x = m · 2^(e − 150): scale by 2^shift.
    let k = (bits >> 23) as i32 - 150 + shift as i32;
    if k >= 0 { m << k as u32 } else { m >> (-k) as u32 }
}

/// [`div`] on every device alike: an `f32` estimate of the significands' quotient, then its
/// last bit settled in integers.
#[inline]
pub fn div_portable(a: f32, b: f32) -> f32 {
    quotient_portable(a, b, &DivisorParts::of(b))
}

/// A divisor that several quotients share (a vector's three components over its length): on
/// the GPU its parts and the estimate of its significand's reciprocal are worked out once.
/// Each [`Divisor::divide`] gives [`div`]'s bits; the host divides natively, as `div` does.
#[derive(Copy, Clone)]
pub struct Divisor {
    b: f32,
    #[cfg(target_arch = "spirv")]
    parts: DivisorParts,
}

impl Divisor {
    #[inline]
    pub fn new(b: f32) -> Divisor {
        Divisor {
            b,
            #[cfg(target_arch = "spirv")]
            parts: DivisorParts::of(b),
        }
    }

    /// `a / b`, correctly rounded, for positive normal `a` (as [`div`]).
    #[inline]
    pub fn divide(&self, a: f32) -> f32 {
        #[cfg(not(target_arch = "spirv"))]
        return div(a, self.b);
        #[cfg(target_arch = "spirv")]
        quotient_portable(a, self.b, &self.parts)
    }
}

/// What a portable division needs of its divisor besides the divisor itself.
#[derive(Copy, Clone)]
struct DivisorParts {
    /// Its significand (24 bits) and biased exponent.
    mb: u32,
    eb: i32,
    /// `1/b'` for its significand `b'` in `[1, 2)`, estimated ([`unit_recip`]).
    recip: f32,
}

impl DivisorParts {
    #[inline]
    fn of(b: f32) -> DivisorParts {
        let bits = b.to_bits();
        let (mb, eb) = parts(bits);
        DivisorParts { mb, eb, recip: unit_recip(unit_significand(bits)) }
    }
}

/// `a / b` on every device alike, with `b`'s parts `d`.
#[inline]
fn quotient_portable(a: f32, b: f32, d: &DivisorParts) -> f32 {
    let (ab, bb) = (a.to_bits(), b.to_bits());
    if !normal(ab) || !normal(bb) {
        return if ab == 0 { 0.0 } else { f32::from_bits(0x7f80_0000) };
    }
    let (ma, ea) = parts(ab);
    // The quotient of the significands lies in (1/2, 2). Its correctly rounded significand Q
    // has 24 bits: Q = RN(n / mb) with n = ma·2^23 where ma ≥ mb (quotient in [1, 2)), else
    // ma·2^24 (quotient in (1/2, 1)).
    let shift: u32 = if ma >= d.mb { 23 } else { 24 };
    let estimate = scaled_estimate(unit_significand(ab) * d.recip, shift);
    // 1/(2·mb) = (1/b') · 2^−24, with b' = mb · 2^−23.
    let q = settle_quotient(estimate, ma << (shift + 1), d.mb, d.recip * f32::from_bits((127 - 24) << 23));
    assemble(q, ea - d.eb + 127 + 23 - shift as i32)
}

/// The correctly rounded significand `Q = RN(n / mb)` from an estimate `q` within some sixty
/// units of it, given `2n` modulo `2^32` and an estimate `inv` of `1/(2·mb)` (within a
/// thousandth of it, relative).
///
/// `D = 2n − 2q·mb` is below `2^31` in magnitude (`2^25 · 61`), so wrapping arithmetic gives
/// it exactly, and `D / (2·mb)` is `n / mb − q`, whose nearest integer is `Q − q`: its estimate
/// (off by 0.06 at most), truncated, is within one of `Q − q` (less than
/// `1/2 + 1 + 0.1` apart). Then `R = 2n − 2q'·mb` places the true quotient
/// within half a unit of `q'` when `|R| < mb`, above when `R > mb`, below when `R < −mb` (never
/// equal: a quotient of two significands is never halfway between two `f32`s).
#[inline]
fn settle_quotient(q: u32, twice_n: u32, mb: u32, inv: f32) -> u32 {
    let distance = twice_n.wrapping_sub(q.wrapping_mul(mb) << 1) as i32;
    let q = q.wrapping_add((distance as f32 * inv) as i32 as u32);
    let rest = twice_n.wrapping_sub(q.wrapping_mul(mb) << 1) as i32;
    let mb = mb as i32;
    q.wrapping_add((rest > mb) as u32).wrapping_sub((rest < -mb) as u32)
}

/// The quotient of the significands of `a` and `b` (bits), times `2^shift`, estimated in
/// `f32`: `1/b'` for `b'` in `[1, 2)` ([`unit_recip`]), times `a'`.
#[cfg(test)]
fn quotient_estimate(ab: u32, bb: u32, shift: u32) -> u32 {
    let (fa, fb) = (unit_significand(ab), unit_significand(bb));
    scaled_estimate(fa * unit_recip(fb), shift)
}

/// `1/x` for `x` in `[1, 2)`, estimated: a bit-pattern guess (within 1/8) and three Newton
/// steps.
#[inline]
fn unit_recip(x: f32) -> f32 {
    let mut r = f32::from_bits(0x7ef3_11c3 - x.to_bits());
    let mut k = 0;
    while k < 3 {
        r = r * (2.0 - x * r);
        k += 1;
    }
    r
}

/// An estimate of `1/x` for a positive normal `x` below `2^126`, within `2^−20` of it
/// (relative) whatever the device's rounding: for callers that settle their result exactly
/// afterwards (`programs::texture::modulo`), where a correctly rounded [`recip`] would be wasted.
#[inline]
pub fn recip_estimate(x: f32) -> f32 {
    let bits = x.to_bits();
    // x = x' · 2^(e − 127) with x' in [1, 2): 1/x = (1/x') · 2^(127 − e), a normal power of two.
    unit_recip(unit_significand(bits)) * f32::from_bits((254 - (bits >> 23)) << 23)
}

/// `1 / x`, correctly rounded, for positive normal `x`.
#[inline]
pub fn recip(x: f32) -> f32 {
    div(1.0, x)
}

/// `(1.0 / n as f64) as f32` for `0 < n < 2^63`: the reciprocal of an integer (a triangle's
/// doubled area in snapped units, up to `2^59`) with the host's `f64` roundings, which a GPU
/// without `f64` gives through [`recip_u64_portable`]. The host divides natively.
#[inline]
pub fn recip_u64(n: u64) -> f32 {
    #[cfg(not(target_arch = "spirv"))]
    return (1.0 / n as f64) as f32;
    #[cfg(target_arch = "spirv")]
    recip_u64_portable(n)
}

/// [`recip_u64`] in integers, on every device alike: `n` rounded to 53 bits (`n as f64`), its
/// reciprocal to 53 bits by long division (`1.0 / …`), that to 24 bits (`as f32`), each to
/// nearest with ties to even. `n` must be positive and below `2^63`.
#[inline]
pub fn recip_u64_portable(n: u64) -> f32 {
    const F64_BITS: u32 = 53;
    // `n as f64` = m · 2^e, m in [2^52, 2^53). (`msb`, not `leading_zeros`: 32-bit bit
    // searches, which every device gives alike.)
    let width = msb(n) + 1;
    let (mut m, mut e) =
        if width <= F64_BITS { (n << (F64_BITS - width), -((F64_BITS - width) as i32)) } else { (round_shift(n, width - F64_BITS), (width - F64_BITS) as i32) };
    if m == 1 << F64_BITS {
        m >>= 1;
        e += 1;
    }
    // `1.0 / (m · 2^e)` = (2^105 / m) · 2^(−105 − e): the quotient q in (2^52, 2^53], from 54
    // steps of long division starting at 2^51 (below m, so every remainder stays below 2^54).
    let (mut q, mut r) = (0u64, 1u64 << 51);
    let mut k = 0;
    while k < 54 {
        r <<= 1;
        q <<= 1;
        if r >= m {
            r -= m;
            q |= 1;
        }
        k += 1;
    }
    // Rounded to 53 bits: up where the remainder is above half of m, or half with q odd.
    if 2 * r > m || (2 * r == m && q & 1 == 1) {
        q += 1;
    }
    let mut p = -105 - e;
    if q == 1 << F64_BITS {
        q >>= 1;
        p += 1;
    }
    // `as f32`: q · 2^p to 24 bits.
    let q24 = round_shift(q, F64_BITS - 24);
    p += (F64_BITS - 24) as i32;
    // q24 · 2^p with q24 in [2^23, 2^24] (2^24 after a carry): `assemble`'s biased exponent is
    // p + 150.
    assemble(q24 as u32, p + 150)
}

/// `v >> s` rounded to nearest, ties to even (`0 < s < 64`).
#[inline]
fn round_shift(v: u64, s: u32) -> u64 {
    let (kept, rest, half) = (v >> s, v & ((1u64 << s) - 1), 1u64 << (s - 1));
    if rest > half || (rest == half && kept & 1 == 1) { kept + 1 } else { kept }
}

/// `√x`, correctly rounded, for positive normal `x` (`+0` for `+0`).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    // The root of a positive normal number is a positive normal number.
    #[cfg(not(target_arch = "spirv"))]
    if normal(x.to_bits()) {
        return x.sqrt();
    }
    sqrt_portable(x)
}

/// [`sqrt`] on every device alike: an `f32` estimate of the root of the significand, then
/// its last bit settled in integers.
#[inline]
pub fn sqrt_portable(x: f32) -> f32 {
    let bits = x.to_bits();
    if !normal(bits) {
        return if bits == 0 { 0.0 } else { f32::from_bits(0x7f80_0000) };
    }
    // x = m · 2^e with m in [1, 4) and e even, so that √x = √m · 2^(e/2).
    let unbiased = (bits >> 23) as i32 - 127;
    let odd = unbiased & 1;
    let e = unbiased - odd;
    let m = f32::from_bits((bits & 0x007f_ffff) | ((127 + odd as u32) << 23));
    // m = M · 2^−23 with M an integer below 2^25; the root's significand is
    // S = RN(√m · 2^23) = RN(√(M · 2^23)), so (2S ± 1)² bracket T = 4 · M · 2^23 = M · 2^25.
    let big_m = (bits & 0x007f_ffff) | 0x0080_0000;
    let inv_root = unit_inv_root(m);
    let estimate = scaled_estimate(m * inv_root, 23);
    // 1/(8·S) ≈ (1/√m) · 2^−26.
    let s = settle_root(estimate, big_m << (25 + odd as u32), inv_root * f32::from_bits((127 - 26) << 23));
    assemble(s, e / 2 + 127)
}

/// The correctly rounded root's significand `S = RN(√T / 2)` from an estimate `s` within
/// fifteen units of it, given `T` modulo `2^32` and an estimate `inv` of `1/(8·s)` (within a
/// thousandth of it, relative).
///
/// `D = T − 4s²` is `8s·c + 4c²` for the true offset `c = √T/2 − s`: below `2^31` in magnitude,
/// (below `2^27 · 15.5 + 2^12`) so wrapping arithmetic gives it exactly, and `D / (8s)` is `c` up to
/// `c²/(2s)`: its estimate, truncated, is within one of `S − s`, the integer nearest `c`. Then `R = T − 4s'²` places `√T / 2` within half a unit of `s'`
/// (`(2s' − 1)² < T < (2s' + 1)²`) when `1 − 4s' < R < 4s' + 1`, above or below past those
/// ends (never on them: `T` is even, `(2s' ± 1)²` odd).
#[inline]
fn settle_root(s: u32, target: u32, inv: f32) -> u32 {
    let distance = target.wrapping_sub(s.wrapping_mul(s) << 2) as i32;
    let s = s.wrapping_add((distance as f32 * inv) as i32 as u32);
    let rest = target.wrapping_sub(s.wrapping_mul(s) << 2) as i32;
    let bound = (s << 2) as i32 + 1;
    s.wrapping_add((rest > bound) as u32).wrapping_sub((rest < 2 - bound) as u32)
}

/// `1/√m` for `m` in `[1, 4)`, estimated in `f32`: a bit-pattern guess (within 4 %) and three
/// Newton steps.
#[inline]
fn unit_inv_root(m: f32) -> f32 {
    let mut y = f32::from_bits(0x5f37_59df - (m.to_bits() >> 1));
    let mut k = 0;
    while k < 3 {
        y = y * (1.5 - 0.5 * m * y * y);
        k += 1;
    }
    y
}

/// `√m · 2^23` for `m` in `[1, 4)`, estimated in `f32` ([`unit_inv_root`] times `m`).
#[cfg(test)]
fn root_estimate(m: f32) -> u32 {
    scaled_estimate(m * unit_inv_root(m), 23)
}

/// The largest integer not above `x`, and `x` minus it rounded once (exact where `x ≥ 0`; a
/// negative `x` just below an integer may round up to 1), in `[0, 1]`. `x` is clamped into
/// `±2^22` first, where the conversion to an integer neither overflows nor saturates and the
/// integer converts back exactly.
#[inline]
// Comparisons, not `f32::clamp`: the GPU's float clamp leaves NaN to the driver, and the build
// refuses it.
#[allow(clippy::manual_clamp)]
pub fn floor(x: f32) -> (i32, f32) {
    const LIMIT: f32 = 4_194_304.0;
    let x = if x > LIMIT {
        LIMIT
    } else if x < -LIMIT {
        -LIMIT
    } else {
        x
    };
    let t = x as i32;
    let i = if (t as f32) > x { t - 1 } else { t };
    (i, x - i as f32)
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// Values across the range, both signs, integers and their neighbours.
    fn floor_samples() -> impl Iterator<Item = f32> {
        let mut x = 0x1234_5678u32;
        let random = std::iter::repeat_with(move || {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            (x as f32 / u32::MAX as f32 - 0.5) * 2e6
        });
        let near_integers = (-40..40).flat_map(|k| [k as f32, f32::from_bits((k as f32).to_bits() + 1), k as f32 - 1e-3, k as f32 + 0.5]);
        near_integers.chain(random.take(100_000))
    }

    #[test]
    fn floor_is_the_float_floor_and_the_fraction_is_rounded_once() {
        for x in floor_samples() {
            let (i, f) = floor(x);
            assert_eq!(i as f32, x.floor(), "floor({x})");
            // The difference of two floats is exact in f64: rounded once to f32, it is the
            // correctly rounded fraction.
            let exact = x as f64 - (x as f64).floor();
            assert_eq!(f, exact as f32, "fraction of {x}");
            if x >= 0.0 {
                assert_eq!(f as f64, exact, "the fraction of {x} is exact");
            }
            assert!((0.0..=1.0).contains(&f), "fraction of {x}: {f}");
        }
        assert_eq!(floor(1e30).0, 4_194_304, "clamped, never overflowing");
        assert_eq!(floor(-1e30).0, -4_194_304);
    }

    /// Positive normal `f32`s spread over the exponent range, with random significands and
    /// the edge cases of each binade.
    fn samples() -> Vec<f32> {
        let mut out = Vec::new();
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        for e in (1..255u32).step_by(3) {
            for m in [0, 1, 0x7f_ffff, 0x40_0000, 0x40_0001] {
                out.push(f32::from_bits(e << 23 | m));
            }
            for _ in 0..40 {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                out.push(f32::from_bits(e << 23 | (state >> 41) as u32 & 0x7f_ffff));
            }
        }
        out
    }

    #[test]
    fn reciprocals_of_integers_round_as_f64_then_f32() {
        let mut ns: Vec<u64> = (1..1 << 16).collect();
        // Around every power of two and every binade's edges, where the roundings carry.
        for b in 1..63u32 {
            for d in 0..64u64 {
                ns.extend([(1u64 << b).saturating_sub(d).max(1), ((1u64 << b) + d).min((1 << 63) - 1)]);
            }
        }
        let mut state = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..2_000_000 {
            let mut next = || {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                state
            };
            // Every width up to 63 bits alike.
            let width = 1 + (next() >> 58) as u32 % 63;
            ns.push((next() >> 1 >> (63 - width)).max(1));
        }
        for n in ns {
            let want = (1.0 / n as f64) as f32;
            assert_eq!(recip_u64_portable(n).to_bits(), want.to_bits(), "1 / {n}");
            assert_eq!(recip_u64(n).to_bits(), want.to_bits(), "native: 1 / {n}");
        }
    }

    #[test]
    fn division_is_the_ieee_quotient() {
        let xs = samples();
        let mut checked = 0;
        for (k, &a) in xs.iter().enumerate() {
            for &b in xs.iter().skip(k % 7).step_by(7) {
                let want = a / b;
                if !want.is_normal() {
                    continue;
                }
                assert_eq!(div_portable(a, b).to_bits(), want.to_bits(), "{a:e} / {b:e}");
                assert_eq!(div(a, b).to_bits(), want.to_bits(), "native: {a:e} / {b:e}");
                checked += 1;
            }
        }
        assert!(checked > 100_000, "only {checked} quotients checked");
    }

    #[test]
    fn square_root_is_the_ieee_root() {
        for x in samples().into_iter().chain([1.0f32, 2.0, 4.0, 0.25, 3.0, f32::MAX, f32::MIN_POSITIVE]) {
            assert_eq!(sqrt_portable(x).to_bits(), x.sqrt().to_bits(), "√{x:e}");
            assert_eq!(sqrt(x).to_bits(), x.sqrt().to_bits(), "native: √{x:e}");
        }
    }

    /// Outside the domain both paths give the by-hand results: zero, infinity.
    #[test]
    fn both_paths_agree_outside_the_domain() {
        for (a, b) in [(0.0f32, 3.0f32), (1e-30, 1e30), (1e30, 1e-30), (f32::MIN_POSITIVE, 4.0), (1.0, f32::from_bits(1))] {
            assert_eq!(div(a, b).to_bits(), div_portable(a, b).to_bits(), "{a:e} / {b:e}");
        }
        for x in [0.0f32, f32::from_bits(1), f32::INFINITY] {
            assert_eq!(sqrt(x).to_bits(), sqrt_portable(x).to_bits(), "√{x:e}");
        }
    }

    /// Every significand of the divisor against a few dividends, and every radicand in
    /// `[1, 4)`: the portable paths give the IEEE result, and their estimates are within three
    /// units of it (the settling steps' further reach is a margin, not the rule).
    #[test]
    fn exhaustive_significands_match_ieee() {
        let mut worst = 0i64;
        for fa in [0x3f80_0000u32, 0x3fc0_0000, 0x3f9e_3779, 0x3fff_ffff, 0x3f80_0001] {
            for fb in 0x3f80_0000u32..0x4000_0000 {
                let (a, b) = (f32::from_bits(fa), f32::from_bits(fb));
                let want = a / b;
                assert_eq!(div_portable(a, b).to_bits(), want.to_bits(), "{a:e} / {b:e}");
                let shift = if parts(fa).0 >= parts(fb).0 { 23 } else { 24 };
                let exact = ((want.to_bits() & 0x7f_ffff) | 0x80_0000) as i64;
                worst = worst.max((quotient_estimate(fa, fb, shift) as i64 - exact).abs());
            }
        }
        assert!(worst <= 3, "a quotient estimate was {worst} units off");
        let mut worst = 0i64;
        for bits in 0x3f80_0000u32..0x4080_0000 {
            let m = f32::from_bits(bits);
            let want = m.sqrt();
            assert_eq!(sqrt_portable(m).to_bits(), want.to_bits(), "√{m:e}");
            let exact = ((want.to_bits() & 0x7f_ffff) | 0x80_0000) as i64;
            worst = worst.max((root_estimate(m) as i64 - exact).abs());
        }
        assert!(worst <= 3, "a root estimate was {worst} units off");
    }

    /// The settling steps reach the correctly rounded significand from any estimate within
    /// their stated reach (sixty units for a quotient, fifteen for a root), whatever a device's
    /// arithmetic made of the estimate: the result is checked against its definition in `u64`.
    #[test]
    fn settling_reaches_from_distant_estimates() {
        let xs = samples();
        let mut checked = 0;
        for (k, &b) in xs.iter().enumerate().step_by(17) {
            let d = DivisorParts::of(b);
            for &a in xs.iter().skip(k % 13).step_by(13) {
                let (ma, _) = parts(a.to_bits());
                let shift = if ma >= d.mb { 23 } else { 24 };
                let (twice_n, mb) = (2 * ((ma as u64) << shift), d.mb as u64);
                let inv = d.recip * f32::from_bits((127 - 24) << 23);
                // The correctly rounded significand, from its definition.
                let q = (twice_n + mb) / (2 * mb);
                assert!((2 * q - 1) * mb < twice_n && twice_n < (2 * q + 1) * mb);
                for off in -60i64..=60 {
                    let estimate = (q as i64 + off) as u32;
                    assert_eq!(settle_quotient(estimate, ma << (shift + 1), d.mb, inv) as u64, q, "{a:e} / {b:e}, estimate {off:+}");
                }
                checked += 1;
            }
        }
        assert!(checked > 1000, "only {checked} quotients checked");
        for bits in (0x3f80_0000u32..0x4080_0000).step_by(997) {
            let m = f32::from_bits(bits);
            let odd = (bits >> 23) - 127;
            let big_m = (bits & 0x007f_ffff) | 0x0080_0000;
            let target = (big_m as u64) << (25 + odd);
            let inv_root = unit_inv_root(m);
            let s = ((target as f64).sqrt() / 2.0).round() as u64;
            assert!((2 * s - 1) * (2 * s - 1) < target && target < (2 * s + 1) * (2 * s + 1), "√{m:e}");
            for off in -15i64..=15 {
                let estimate = (s as i64 + off) as u32;
                let got = settle_root(estimate, big_m << (25 + odd), inv_root * f32::from_bits((127 - 26) << 23));
                assert_eq!(got as u64, s, "√{m:e}, estimate {off:+}");
            }
        }
    }

    /// The estimate's stated bound, on every significand and across the exponents.
    #[test]
    fn reciprocal_estimates_are_within_their_bound() {
        let mut worst = 0f64;
        for bits in (0x3f80_0000u32..0x4000_0000).chain(samples().into_iter().map(f32::to_bits).filter(|&b| b >> 23 < 253)) {
            let x = f32::from_bits(bits);
            let exact = 1.0 / x as f64;
            worst = worst.max(((recip_estimate(x) as f64 - exact) / exact).abs());
        }
        assert!(worst <= 2f64.powi(-20), "a reciprocal estimate was {worst:e} off");
    }

    /// A divisor's parts, worked out once, give each quotient the IEEE bits, as the GPU's
    /// `Divisor` uses them.
    #[test]
    fn shared_divisor_parts_divide_as_div_does() {
        let xs = samples();
        for (k, &b) in xs.iter().enumerate().step_by(11) {
            let (d, shared) = (DivisorParts::of(b), Divisor::new(b));
            for &a in xs.iter().skip(k % 5).step_by(5) {
                assert_eq!(quotient_portable(a, b, &d).to_bits(), div(a, b).to_bits(), "{a:e} / {b:e}");
                assert_eq!(shared.divide(a).to_bits(), div(a, b).to_bits(), "{a:e} / {b:e}");
            }
        }
    }

    #[test]
    fn reciprocals_of_exact_powers_are_exact() {
        for k in -120..120 {
            let x = 2f32.powi(k);
            assert_eq!(recip(x), 1.0 / x);
        }
        assert_eq!(recip(3.0).to_bits(), (1.0f32 / 3.0).to_bits());
    }
}
