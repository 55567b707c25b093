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

/// Texel index `i` of a level `n` texels across, as `mode` addresses it. (`i32`: coordinates
/// are clamped to ±2^30 texels, and a GPU divides 32-bit integers in hardware where a 64-bit
/// remainder is a long routine.)
#[inline]
pub fn address(i: i32, n: u32, mode: Address) -> u32 {
    let n = n as i32;
    match mode {
        Address::Repeat => i.rem_euclid(n) as u32,
        Address::ClampToEdge => {
            (if i < 0 {
                0
            } else if i >= n {
                n - 1
            } else {
                i
            }) as u32
        }
        Address::MirroredRepeat => {
            let m = i.rem_euclid(2 * n);
            (if m >= n { 2 * n - 1 - m } else { m }) as u32
        }
    }
}

/// Width and height of mip level `level`.
#[inline]
pub fn level_size(info: &TextureInfo, level: u32) -> (u32, u32) {
    let w = info.width >> level;
    let h = info.height >> level;
    (if w == 0 { 1 } else { w }, if h == 0 { 1 } else { h })
}

/// The 16-bit channels of texel `(x, y)` of `level` (a texel is a `u64`, red in its low bits:
/// one load).
#[inline]
fn fetch(texels: &[u64], info: &TextureInfo, level: u32, x: u32, y: u32) -> [u32; 4] {
    let (w, _) = level_size(info, level);
    let texel = texels[(info.offsets[level as usize] + y * w + x) as usize];
    [texel as u32 & 0xffff, (texel >> 16) as u32 & 0xffff, (texel >> 32) as u32 & 0xffff, (texel >> 48) as u32]
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
pub fn nearest(texels: &[u64], info: &TextureInfo, level: u32, u: f32, v: f32) -> [u32; 4] {
    let (w, h) = level_size(info, level);
    let x = address((subtexel(u, w) >> SUBTEXEL_BITS) as i32, w, info.address_u());
    let y = address((subtexel(v, h) >> SUBTEXEL_BITS) as i32, h, info.address_v());
    fetch(texels, info, level, x, y)
}

/// The four texels around `(u, v)` at `level`, weighted by the 8-bit fractions of the
/// coordinate past their centres, rounded to 16 bits. (Loops over the axes and the texels, so
/// that the stage holds one copy of the addressing.)
#[inline]
pub fn bilinear(texels: &[u64], info: &TextureInfo, level: u32, u: f32, v: f32) -> [u32; 4] {
    let (w, h) = level_size(info, level);
    let half = 1 << (SUBTEXEL_BITS - 1);
    let one = 1u32 << SUBTEXEL_BITS;
    // Per axis: the fraction past the first texel's centre, and the two texels' indices.
    let (mut frac, mut first, mut second) = ([0u32; 2], [0u32; 2], [0u32; 2]);
    let mut axis = 0;
    while axis < 2 {
        let (c, n, mode) = if axis == 0 { (u, w, info.address_u()) } else { (v, h, info.address_v()) };
        let sc = subtexel(c, n) - half;
        frac[axis] = (sc & (one as i64 - 1)) as u32;
        // Within ±(2^30 + 1): an `i32`, and so is the next.
        let i0 = (sc >> SUBTEXEL_BITS) as i32;
        first[axis] = address(i0, n, mode);
        second[axis] = address(i0 + 1, n, mode);
        axis += 1;
    }
    let (fx, fy) = (frac[0], frac[1]);
    let wt = [(one - fx) * (one - fy), fx * (one - fy), (one - fx) * fy, fx * fy];
    let mut sums = [0u32; 4];
    let mut k = 0;
    while k < 4 {
        let x = if k & 1 == 0 { first[0] } else { second[0] };
        let y = if k & 2 == 0 { first[1] } else { second[1] };
        let texel = fetch(texels, info, level, x, y);
        let mut c = 0;
        while c < 4 {
            // At most 2^16 · 65535 < 2^32 in all.
            sums[c] += wt[k] * texel[c];
            c += 1;
        }
        k += 1;
    }
    let mut out = [0u32; 4];
    let mut c = 0;
    while c < 4 {
        out[c] = (sums[c] + (1 << (2 * SUBTEXEL_BITS - 1))) >> (2 * SUBTEXEL_BITS);
        c += 1;
    }
    out
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
    let mut f = [0i64; 4];
    let mut k = 0;
    while k < 4 {
        let n = if k % 2 == 0 { width } else { height };
        f[k] = fixed_floor(d[k] * n as f32, 16, LIMIT);
        k += 1;
    }
    let [sx, tx, sy, ty] = f;
    let lx = (sx * sx + tx * tx) as u64;
    let ly = (sy * sy + ty * ty) as u64;
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
        Filter::Nearest => return nearest(texels, info, 0, u, v),
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
        let texel = bilinear(texels, info, level + k, u, v);
        let weight = if k == 0 { one - upper } else { upper };
        let mut c = 0;
        while c < 4 {
            sums[c] += texel[c] * weight;
            c += 1;
        }
        k += 1;
    }
    let mut out = [0u32; 4];
    let mut c = 0;
    while c < 4 {
        out[c] = (sums[c] + (one >> 1)) >> SUBTEXEL_BITS;
        c += 1;
    }
    out
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

    #[test]
    fn address_modes_follow_their_definitions() {
        for n in [1u32, 2, 5, 16] {
            for i in (-40i32..40).chain([-(1 << 30) - 1, -(1 << 30), (1 << 30) + 2, 1_234_567_891]) {
                let (n64, i) = (n as i64, i as i64);
                assert_eq!(address(i as i32, n, Address::Repeat) as i64, ((i % n64) + n64) % n64);
                assert_eq!(address(i as i32, n, Address::ClampToEdge) as i64, i.clamp(0, n64 - 1));
                // Mirrored: 0 1 .. n−1 n−1 .. 0 0 1 ..
                let period = i.rem_euclid(2 * n64);
                assert_eq!(address(i as i32, n, Address::MirroredRepeat) as i64, period.min(2 * n64 - 1 - period), "i {i}, n {n}");
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
