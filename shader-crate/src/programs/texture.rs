//! Texture sampling in the shade stage, the same bits on every device: nearest, bilinear and
//! trilinear filtering; repeat, clamp-to-edge and mirrored-repeat addressing; the level of
//! detail from the texture coordinates' differences across the pixel's 2×2 quad.
//!
//! Everything after the texture coordinate is integer arithmetic:
//! - a coordinate in texels goes to fixed point with 8 fractional bits (Direct3D's sub-texel
//!   precision), floored, by reading the `f32`'s bits ([`fixed_floor`]): no conversion whose
//!   rounding a device chooses;
//! - bilinear weights are products of those 8-bit fractions, and the sums of weighted texels
//!   are exact in `u32` (texels are 16-bit linear values), rounded once;
//! - the level of detail is `log2` of the longer of the two derivative vectors, from their
//!   squared lengths in 16.16 fixed point, with 8 fractional bits by repeated squaring
//!   ([`lod`]).
//!
//! The only float operations are the coordinates' products with the texture's size and their
//! differences (correctly rounded, never contracted) and the final scaling of a 16-bit channel
//! to `[0, 1]`.

use crate::abi::{Address, Filter, MAX_MIP_LEVELS, TextureInfo};
use crate::math::fixed::msb;
use crate::math::float::recip_estimate;

/// Sub-texel bits of a filtered coordinate.
pub const SUBTEXEL_BITS: u32 = 8;

/// `floor(x · 2^frac_bits)` from the bits of `x`, clamped to `±limit`; NaN gives 0.
#[inline]
pub fn fixed_floor(x: f32, frac_bits: u32, limit: i64) -> i64 {
    let b = x.to_bits();
    let negative = b >> 31 == 1;
    let biased = (b >> 23 & 0xff) as i32;
    if biased == 255 {
        if b & 0x007f_ffff != 0 {
            return 0;
        }
        return if negative { -limit } else { limit };
    }
    let mantissa = (b & 0x007f_ffff) as u64 | if biased > 0 { 1 << 23 } else { 0 };
    // x = ±mantissa · 2^(e − 150), with e = 1 for subnormals.
    let shift = if biased > 0 { biased } else { 1 } - 150 + frac_bits as i32;
    if mantissa == 0 {
        return 0;
    }
    if shift >= 0 {
        // Beyond 2^62 certainly past any limit.
        if shift > 38 {
            return if negative { -limit } else { limit };
        }
        let magnitude = (mantissa << shift as u32) as i64;
        let clamped = if magnitude > limit { limit } else { magnitude };
        return if negative { -clamped } else { clamped };
    }
    let s = (-shift) as u32;
    if s > 40 {
        // |x · 2^frac| < 2^-16: floor is 0 or −1.
        return if negative { -1 } else { 0 };
    }
    let magnitude = if negative { (mantissa + (1 << s) - 1) >> s } else { mantissa >> s } as i64;
    let clamped = if magnitude > limit { limit } else { magnitude };
    if negative { -clamped } else { clamped }
}

/// `i mod m` in `[0, m)` (the remainder of floored division) for `|i| ≤ 2^30 + 2` and
/// `1 ≤ m ≤ 2^15`, without an integer division: a GPU has none in hardware, and a CPU
/// implementation of Vulkan divides one lane at a time.
///
/// Two rounds of a quotient estimated in `f32`, each followed by the exact integer remainder.
/// Whatever the device rounds, the estimate of `i/m` is within `|i/m|·2^−19` of it (the
/// reciprocal within `2^−20`, the conversion of `i` and the product within `2^−23` each), and
/// the conversion back truncates within one more, so the first remainder lies within
/// `|i|·2^−19 + m < 2^16` of zero and converts exactly. The second estimate is then within
/// `2^−8` of its quotient, which leaves a remainder in `(−(1 + 2^−8)·m, (1 + 2^−8)·m)`, and
/// three steps of `±m` settle it. The result is the one remainder: the same bits on every
/// device.
#[inline]
pub fn modulo(i: i32, m: u32) -> u32 {
    let m = m as i32;
    let inv = recip_estimate(m as f32);
    let r = i - ((i as f32) * inv) as i32 * m;
    let r = r - ((r as f32) * inv) as i32 * m;
    let r = if r < 0 { r + m } else { r };
    let r = if r >= m { r - m } else { r };
    (if r < 0 { r + m } else { r }) as u32
}

/// Texel indices `i` and `i + 1` of a level `n` texels across, as `mode` addresses them: the
/// pair a bilinear filter reads (nearest filtering takes the first). One remainder serves both
/// and each mode is then a few selects (a CPU implementation of Vulkan runs every arm). `i` is
/// within `±(2^30 + 1)`: coordinates are clamped to `±2^30` texels.
#[inline]
pub fn address_pair(i: i32, n: u32, mode: Address) -> (u32, u32) {
    let period = if mode == Address::MirroredRepeat { 2 * n } else { n };
    let r = modulo(i, period);
    let next = if r + 1 == period { 0 } else { r + 1 };
    let clamp = |i: i32| {
        (if i < 0 {
            0
        } else if i >= n as i32 {
            n as i32 - 1
        } else {
            i
        }) as u32
    };
    // A mirrored period reads 0 1 … n−1 n−1 … 1 0.
    let reflect = |m: u32| if m >= n { 2 * n - 1 - m } else { m };
    match mode {
        Address::Repeat => (r, next),
        Address::ClampToEdge => (clamp(i), clamp(i + 1)),
        Address::MirroredRepeat => (reflect(r), reflect(next)),
    }
}

/// Width and height of mip level `level`.
#[inline]
pub fn level_size(info: &TextureInfo, level: u32) -> (u32, u32) {
    let w = info.width >> level;
    let h = info.height >> level;
    (if w == 0 { 1 } else { w }, if h == 0 { 1 } else { h })
}

/// Texel `(x, y)` of `level`: four 16-bit channels, red in the low bits (one load).
#[inline]
fn fetch(texels: &[u64], info: &TextureInfo, level: u32, x: u32, y: u32) -> u64 {
    let (w, _) = level_size(info, level);
    texels[(info.offsets[level as usize] + y * w + x) as usize]
}

/// The four 16-bit channels of a texel.
#[inline]
fn channels(texel: u64) -> [u32; 4] {
    [texel as u32 & 0xffff, (texel >> 16) as u32 & 0xffff, (texel >> 32) as u32 & 0xffff, (texel >> 48) as u32]
}

/// Four channels weighted and summed: `sums` plus `weight` times each channel of `texel`.
/// (Named sums rather than a loop over an array: a CPU implementation of Vulkan keeps an array
/// indexed by a loop counter in memory and reaches it one lane at a time.)
#[inline]
fn add_weighted(sums: [u32; 4], texel: u64, weight: u32) -> [u32; 4] {
    let [c0, c1, c2, c3] = channels(texel);
    let [s0, s1, s2, s3] = sums;
    [s0 + weight * c0, s1 + weight * c1, s2 + weight * c2, s3 + weight * c3]
}

/// Weighted sums rounded back to 16-bit channels: `⌊s / 2^bits + ½⌋` each, packed as a texel.
#[inline]
fn rounded(sums: [u32; 4], bits: u32) -> u64 {
    let round = |s: u32| ((s + (1 << (bits - 1))) >> bits) as u64;
    round(sums[0]) | round(sums[1]) << 16 | round(sums[2]) << 32 | round(sums[3]) << 48
}

/// Coordinate `u` (texture space, `[0, 1)` across) in a level `n` texels across, in fixed
/// point with [`SUBTEXEL_BITS`], floored. Far-off coordinates are clamped to ±2^30 texels
/// (repeat and mirror then read a texel a device's own arithmetic may not, documented).
#[inline]
fn subtexel(u: f32, n: u32) -> i64 {
    fixed_floor(u * n as f32, SUBTEXEL_BITS, 1 << (30 + SUBTEXEL_BITS))
}

/// The texel coordinate `(u, v)` falls in, at `level`.
#[inline]
pub fn nearest(texels: &[u64], info: &TextureInfo, level: u32, u: f32, v: f32) -> u64 {
    let (w, h) = level_size(info, level);
    let (x, _) = address_pair((subtexel(u, w) >> SUBTEXEL_BITS) as i32, w, info.address_u());
    let (y, _) = address_pair((subtexel(v, h) >> SUBTEXEL_BITS) as i32, h, info.address_v());
    fetch(texels, info, level, x, y)
}

/// The four texels around `(u, v)` at `level`, weighted by the 8-bit fractions of the
/// coordinate past their centres, rounded to 16 bits. (A loop over the texels, so that the
/// stage holds one copy of the fetch.)
#[inline]
pub fn bilinear(texels: &[u64], info: &TextureInfo, level: u32, u: f32, v: f32) -> u64 {
    let (w, h) = level_size(info, level);
    let half = 1 << (SUBTEXEL_BITS - 1);
    let one = 1u32 << SUBTEXEL_BITS;
    // Per axis: the fraction past the first texel's centre, and the two texels' indices
    // (within ±(2^30 + 1): `i32`s).
    let (su, sv) = (subtexel(u, w) - half, subtexel(v, h) - half);
    let (fx, fy) = ((su & (one as i64 - 1)) as u32, (sv & (one as i64 - 1)) as u32);
    let (x0, x1) = address_pair((su >> SUBTEXEL_BITS) as i32, w, info.address_u());
    let (y0, y1) = address_pair((sv >> SUBTEXEL_BITS) as i32, h, info.address_v());
    // At most 2^16 · 65535 < 2^32 in all.
    let mut sums = [0u32; 4];
    let mut k = 0;
    while k < 4 {
        let (x, wx) = if k & 1 == 0 { (x0, one - fx) } else { (x1, fx) };
        let (y, wy) = if k & 2 == 0 { (y0, one - fy) } else { (y1, fy) };
        sums = add_weighted(sums, fetch(texels, info, level, x, y), wx * wy);
        k += 1;
    }
    rounded(sums, 2 * SUBTEXEL_BITS)
}

/// `floor(log2(x) · 2^9)` for `x > 0`, by the leading bit and nine squarings of the
/// normalised mantissa (each truncated to 30 fractional bits: a lower bound, exact in integers).
#[inline]
fn log2_fixed9(x: u64) -> i32 {
    let n = msb(x);
    let mut m = if n >= 30 { x >> (n - 30) } else { x << (30 - n) };
    let mut frac = 0i32;
    let mut k = 0;
    while k < 9 {
        m = (m * m) >> 30;
        frac <<= 1;
        if m >= 1 << 31 {
            frac |= 1;
            m >>= 1;
        }
        k += 1;
    }
    n as i32 * 512 + frac
}

/// The level of detail, in fixed point with 8 fractional bits, of a texture `width × height`
/// texels whose coordinates change by `(du_dx, dv_dx)` from a pixel to its right neighbour
/// and `(du_dy, dv_dy)` to the one below: `log2` of the longer derivative vector in texels
/// (as Vulkan's scale factor ρ), floored; `i32::MIN` where both are zero (magnified without
/// bound). Derivatives are clamped to 2^14 texels (no level beyond 14).
#[inline]
pub fn lod(width: u32, height: u32, d: [f32; 4]) -> i32 {
    const LIMIT: i64 = 1 << 30;
    // In one loop: one copy of the conversion.
    let (mut lx, mut ly) = (0u64, 0u64);
    let mut k = 0;
    while k < 4 {
        let (x, n) = match k {
            0 => (d[0], width),
            1 => (d[1], height),
            2 => (d[2], width),
            _ => (d[3], height),
        };
        let f = fixed_floor(x * n as f32, 16, LIMIT);
        if k < 2 {
            lx += (f * f) as u64;
        } else {
            ly += (f * f) as u64;
        }
        k += 1;
    }
    let l = if lx > ly { lx } else { ly };
    if l == 0 {
        return i32::MIN;
    }
    // ρ² = l · 2^-32: log2 ρ = (log2 l − 32) / 2, which in 8 fractional bits is the 9-bit
    // fixed point of log2 l, less 32, over 4 (floored: floor(floor(y · 512) / 4) = floor(y · 128)).
    (log2_fixed9(l) - 32 * 512) >> 2
}

/// The filtered texel of texture `info` at `(u, v)` with level of detail `lod` (from [`lod`]):
/// 16-bit linear channels.
#[inline]
pub fn filtered(texels: &[u64], info: &TextureInfo, u: f32, v: f32, lod: i32) -> [u32; 4] {
    // The level to read, and the weight of the one above it (trilinear between two levels).
    let (level, upper) = match info.filter() {
        Filter::Nearest => return channels(nearest(texels, info, 0, u, v)),
        Filter::Bilinear => (0, 0),
        Filter::Trilinear => {
            let top = info.levels as i32 - 1;
            if lod <= 0 || top <= 0 {
                (0, 0)
            } else if lod >> SUBTEXEL_BITS >= top {
                (top as u32, 0)
            } else {
                ((lod >> SUBTEXEL_BITS) as u32, (lod & ((1 << SUBTEXEL_BITS) - 1)) as u32)
            }
        }
    };
    // One level, or the two weighted, in one loop (one copy of the bilinear filter): a single
    // level weighs 2^8 and is rounded back exactly.
    let one = 1u32 << SUBTEXEL_BITS;
    let mut sums = [0u32; 4];
    let mut k = 0;
    while k < 1 + (upper != 0) as u32 {
        sums = add_weighted(sums, bilinear(texels, info, level + k, u, v), if k == 0 { one - upper } else { upper });
        k += 1;
    }
    channels(rounded(sums, SUBTEXEL_BITS))
}

/// A 16-bit channel in `[0, 1]`: `c / 65535`, as one correctly rounded product.
#[inline]
pub fn unit(c: u32) -> f32 {
    const INV: f32 = 1.0 / 65535.0;
    c as f32 * INV
}

const _: () = assert!(MAX_MIP_LEVELS >= 15);

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// A small deterministic generator of test values.
    fn values() -> impl Iterator<Item = f32> {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        (0..20_000).map(move |k| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            let scale = [1e-6f32, 0.01, 1.0, 37.0, 5e3, 1e7, 3e9][k % 7];
            ((state >> 40) as f32 / (1u64 << 24) as f32 - 0.5) * scale
        })
    }

    #[test]
    fn fixed_floor_is_the_floor_of_the_scaled_value() {
        let limit = 1i64 << 38;
        let specials = [
            0.0,
            -0.0,
            0.5,
            -0.5,
            1.0 / 256.0,
            -1.0 / 256.0,
            f32::MIN_POSITIVE,
            -f32::MIN_POSITIVE,
            1e-45,
            -1e-45,
            f32::MAX,
            f32::MIN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        for x in values().chain(specials) {
            let exact = (x as f64 * 256.0).floor().clamp(-limit as f64, limit as f64) as i64;
            assert_eq!(fixed_floor(x, 8, limit), exact, "{x:e}");
        }
        assert_eq!(fixed_floor(f32::NAN, 8, limit), 0);
    }

    /// Euclid's remainder, over every modulus a level can need (a side, or twice one for the
    /// mirror) at the coordinates' extremes and around zero, and at random ones.
    #[test]
    fn modulo_is_the_remainder() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let extremes = [0i32, 1, -1, (1 << 30) + 2, -(1 << 30) - 2, (1 << 30) - 1, -(1 << 30) + 1, 1 << 24, -(1 << 24) - 1];
        for m in 1..=1u32 << 15 {
            let random = (0..6).map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                ((state >> 33) as i64 % (2 * (1i64 << 30) + 5) - (1i64 << 30) - 2) as i32
            });
            for i in extremes.into_iter().chain(extremes.map(|e| e.saturating_add(m as i32).min((1 << 30) + 2))).chain(random) {
                assert_eq!(modulo(i, m) as i64, (i as i64).rem_euclid(m as i64), "{i} mod {m}");
            }
        }
    }

    #[test]
    fn address_modes_follow_their_definitions() {
        for n in [1u32, 2, 5, 16, 16384] {
            for i in (-40i32..40).chain([-(1 << 30) - 1, -(1 << 30), 1 << 30, 1_000_000_007, -999_999_937]) {
                let n64 = n as i64;
                let repeat = |i: i64| i.rem_euclid(n64);
                let clamp = |i: i64| i.clamp(0, n64 - 1);
                // Mirrored: 0 1 .. n−1 n−1 .. 0 0 1 ..
                let mirror = |i: i64| i.rem_euclid(2 * n64).min(2 * n64 - 1 - i.rem_euclid(2 * n64));
                for (mode, want) in [(Address::Repeat, &repeat as &dyn Fn(i64) -> i64), (Address::ClampToEdge, &clamp), (Address::MirroredRepeat, &mirror)] {
                    let (a, b) = address_pair(i, n, mode);
                    assert_eq!((a as i64, b as i64), (want(i as i64), want(i as i64 + 1)), "{mode:?} of {i} and {} in {n}", i as i64 + 1);
                }
            }
        }
    }

    /// The level of detail is `floor(256 · log2 ρ)` of the fixed-point derivatives, exactly,
    /// and within one unit of the float definition.
    #[test]
    fn lod_is_log2_of_the_longer_derivative() {
        let d: Vec<f32> = values().map(|v| v * 1e-3).collect();
        for (k, q) in d.as_chunks::<4>().0.iter().enumerate() {
            let (w, h) = ([16u32, 256, 1000, 4096][k % 4], [16u32, 64, 333, 4096][k / 4 % 4]);
            let got = lod(w, h, [q[0], q[1], q[2], q[3]]);
            let fixed = |x: f32, n: u32| fixed_floor(x * n as f32, 16, 1 << 30) as f64 / 65536.0;
            let (sx, tx, sy, ty) = (fixed(q[0], w), fixed(q[1], h), fixed(q[2], w), fixed(q[3], h));
            let rho2 = (sx * sx + tx * tx).max(sy * sy + ty * ty);
            if rho2 == 0.0 {
                assert_eq!(got, i32::MIN);
                continue;
            }
            let exact = (128.0 * rho2.log2()).floor() as i32;
            // The f64 log2 may be off in its last place: allow the neighbour only at an integer.
            assert!(got == exact || ((128.0 * rho2.log2()) - exact as f64) < 1e-9 && got == exact - 1, "{q:?} on {w}×{h}: {got} against {exact}");
            let scaled = [q[0] as f64 * w as f64, q[1] as f64 * h as f64, q[2] as f64 * w as f64, q[3] as f64 * h as f64];
            if scaled.iter().any(|x| x.abs() >= 16384.0) {
                // Clamped to 2^14 texels.
                assert!(got >= 14 * 256, "{q:?}: {got}");
                continue;
            }
            let float = 256.0 * scaled[0].hypot(scaled[1]).max(scaled[2].hypot(scaled[3])).log2();
            assert!((got as f64 - float).abs() <= 1.0 + 256.0 * 2.0 / 65536.0 / rho2.sqrt(), "{q:?}: {got} against {float}");
        }
    }
}
