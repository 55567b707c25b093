//! Exact integer helpers: floor/ceil by powers of two and the correctly rounded conversion
//! of a fixed-point value to `f32`, done bit by bit so that no device rounding mode, flush
//! or fused operation can change the result.

/// `floor(v / 2^s)` for `0 <= s < 64`.
pub fn floor_shr(v: i64, s: u32) -> i64 {
    v >> s
}

/// `ceil(v / 2^s)` for `0 <= s < 64`.
pub fn ceil_shr(v: i64, s: u32) -> i64 {
    -((-v) >> s)
}

/// Index of the highest set bit of `v` (`v != 0`), from 32-bit bit searches (`FindUMsb` in
/// SPIR-V: exact on every device, and one instruction where a loop would be six branches).
#[inline]
pub fn msb(v: u64) -> u32 {
    let (hi, lo) = ((v >> 32) as u32, v as u32);
    if hi != 0 { 63 - hi.leading_zeros() } else { 31 - lo.leading_zeros() }
}

/// Bits of the `f32` nearest to `n · 2^−frac_bits` (round to nearest, ties to even,
/// subnormals kept, ±∞ on overflow; zero is +0).
///
/// Natively the CPU's own conversion gives the same bits faster: `n as f32` is correctly
/// rounded (Rust guarantees it), and scaling by a normal power of two is then exact unless the
/// product overflows (to the same ±∞) or is subnormal, which needs `|n| · 2^−frac_bits <
/// 2^−126`, impossible for `n ≠ 0` when `frac_bits <= 126`. Vulkan leaves the rounding of its
/// integer conversion to the implementation, so the SPIR-V build always rounds by hand.
#[inline]
pub fn fixed_to_f32_bits(n: i64, frac_bits: i32) -> u32 {
    #[cfg(not(target_arch = "spirv"))]
    if converts_natively(frac_bits) {
        let scale = f32::from_bits(((127 - frac_bits) as u32) << 23);
        return ((n as f32) * scale).to_bits();
    }
    fixed_to_f32_bits_by_hand(n, frac_bits)
}

/// Whether [`fixed_to_f32_bits`] takes the native path for `frac_bits` (`2^−frac_bits` is a
/// normal `f32`). Loops that test it once outside let the compiler vectorise the conversion.
#[inline]
pub fn converts_natively(frac_bits: i32) -> bool {
    (-127..=126).contains(&frac_bits)
}

/// `n` rounded to the nearest `f32`, ties to even: the conversion of the paths that compute in
/// `f32` anyway (barycentric weights, depth, shading). The exact height mode, which promises no
/// float operation, converts with [`fixed_to_f32_bits`] instead.
///
/// Natively this is Rust's own conversion, correctly rounded; the SPIR-V build takes
/// [`i64_to_f32_portable`], a few 32-bit operations where the bit-by-bit conversion is a loop
/// of 64-bit ones.
#[inline]
pub fn i64_to_f32(n: i64) -> f32 {
    #[cfg(not(target_arch = "spirv"))]
    return n as f32;
    #[cfg(target_arch = "spirv")]
    i64_to_f32_portable(n)
}

/// [`i64_to_f32`] of a value in `(−2^31, 2^31)`, in 32-bit operations: natively the CPU's
/// conversion (correctly rounded), on the GPU [`i32_to_f32_portable`]. The same bits.
#[inline]
pub fn i32_to_f32(n: i32) -> f32 {
    #[cfg(not(target_arch = "spirv"))]
    return n as f32;
    #[cfg(target_arch = "spirv")]
    i32_to_f32_portable(n)
}

/// [`i32_to_f32`] on every device alike: the magnitude is `hi · 2^16 + lo` with both halves
/// below `2^16`, which convert exactly on any device; the product by `2^16` is exact and the
/// one addition rounds once, to nearest even (as in [`i64_to_f32_portable`]).
#[inline]
pub fn i32_to_f32_portable(n: i32) -> f32 {
    let m = n.unsigned_abs();
    let magnitude = (m >> 16) as f32 * 65_536.0 + (m & 0xffff) as f32;
    if n < 0 { -magnitude } else { magnitude }
}

/// [`i64_to_f32`] with no branch (a SIMD lane computes every branch, taken or not):
///
/// 1. The magnitude `m` is cut to at most 48 significant bits, `m' = ⌊m / 2^s⌋` with the cut
///    bits' OR kept in its last bit (rounding to odd). Rounding `m'` to 24 bits then gives the
///    same result as rounding `m` (round-to-odd with two or more spare bits is innocuous before
///    round-to-nearest).
/// 2. `m' = hi · 2^24 + lo` with `hi`, `lo < 2^24`: both convert exactly on any device, the
///    product by `2^24` is exact, and the one addition rounds once, to nearest even (fused
///    with the product or not: the product is exact either way).
/// 3. Scaling by `2^s` and the sign are exact.
#[inline]
pub fn i64_to_f32_portable(n: i64) -> f32 {
    let m = n.unsigned_abs();
    // The highest set bit of the upper half (−1 for none) gives the cut: at most 15 bits.
    let top = 31 - ((m >> 32) as u32).leading_zeros() as i32;
    let s = (top + 32 - 47).max(0) as u32;
    let kept = (m >> s) | (m & ((1u64 << s) - 1) != 0) as u64;
    let (hi, lo) = ((kept >> 24) as u32, (kept & 0x00ff_ffff) as u32);
    let magnitude = (hi as f32 * 16_777_216.0 + lo as f32) * f32::from_bits((127 + s) << 23);
    if n < 0 { -magnitude } else { magnitude }
}

/// [`fixed_to_f32_bits`] with integer operations only, and no branch: a SIMD lane runs every
/// branch, taken or not, so the normal, subnormal and overflowing cases share one path.
///
/// The result's biased exponent is that of the leading bit, at least 1 (a subnormal's unit is
/// the smallest normal's); the bits of `|n|` below the result's last significand bit are
/// dropped with rounding to nearest, ties to even (or zeros appended). Then
/// `(exponent − 1) · 2^23 + m` is the encoding: a significand with its implicit bit adds the
/// one back, a rounding that carries into `2^24` moves to the next binade, and a subnormal's
/// `m` (below `2^23`, or exactly `2^23`: the smallest normal) stays below the exponent field.
/// Past the largest finite value it is `+∞`.
pub fn fixed_to_f32_bits_by_hand(n: i64, frac_bits: i32) -> u32 {
    let sign: u32 = if n < 0 { 0x8000_0000 } else { 0 };
    let mag = n.unsigned_abs();
    let top = msb(mag | 1) as i64;
    let frac = frac_bits as i64;
    let biased = if top - frac + 127 > 1 { top - frac + 127 } else { 1 };
    // Bits of `mag` below the result's last significand bit (negative: bits to append, at most
    // 23, since a normal result keeps 24 and a subnormal one needs `top < 23`).
    let drop = biased - 150 + frac;
    let right = drop.clamp(0, 63) as u32;
    let left = if drop < 0 { (-drop) as u32 } else { 0 };
    let q = mag >> right;
    let rem = mag & ((1u64 << right) - 1);
    let half = (1u64 << right) >> 1;
    let up = drop > 0 && (rem > half || (rem == half && q & 1 == 1));
    // Beyond 63 bits dropped the value is below half a unit (`|n| ≤ 2^63`): zero.
    let m = if drop > 63 {
        0
    } else if drop < 0 {
        mag << left
    } else {
        q + up as u64
    };
    let bits = ((biased - 1) as u64) * (1 << 23) + m;
    let bits = if bits >= 0x7f80_0000 { 0x7f80_0000 } else { bits as u32 };
    if n == 0 { 0 } else { sign | bits }
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

    /// Reference: reduce to 53 bits with a sticky bit (round to odd), then let the hardware
    /// round f64 → f32, which is then correctly rounded.
    fn reference(n: i64, frac_bits: i32) -> f32 {
        if n == 0 {
            return 0.0;
        }
        let mag = n.unsigned_abs();
        let top = 63 - mag.leading_zeros() as i32;
        let (m, shift) = if top > 52 {
            let s = (top - 52) as u32;
            let sticky = u64::from(mag & ((1u64 << s) - 1) != 0);
            ((mag >> s) | sticky, s as i32)
        } else {
            (mag, 0)
        };
        let exp = shift - frac_bits;
        // m·2^exp with exp split in two steps so the intermediate never under/overflows.
        let v = (m as f64) * 2f64.powi(exp / 2) * 2f64.powi(exp - exp / 2);
        let v = if n < 0 { -v } else { v };
        v as f32
    }

    /// Both the native path and the integer-only path the GPU runs must give the reference.
    fn check(n: i64, f: i32) {
        let want = reference(n, f);
        for (path, got) in [("native", fixed_to_f32_bits(n, f)), ("by hand", fixed_to_f32_bits_by_hand(n, f))] {
            let got = f32::from_bits(got);
            assert_eq!(got.to_bits(), want.to_bits(), "{path}: n={n} f={f}: got {got:e}, want {want:e}");
        }
    }

    #[test]
    fn the_portable_conversion_is_rusts() {
        let mut s = 0x2545_f491_4f6c_dd1du64;
        let check = |n: i64| assert_eq!(i64_to_f32_portable(n).to_bits(), (n as f32).to_bits(), "{n}");
        for n in [0, 1, -1, (1 << 24) + 1, -(1 << 24) - 1, (1 << 48) - 1, 1 << 48, -(1 << 48), 1 - (1 << 48), i64::MAX, i64::MIN] {
            check(n);
        }
        for _ in 0..1_000_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            // Every magnitude, and halfway cases: a tie sits just below each shift.
            let n = (s as i64) >> (s % 63);
            check(n);
            check(n & !0x7f | 0x80);
        }
    }

    /// Every magnitude in 32 bits, the ties of each binade, and the extremes.
    #[test]
    fn the_small_conversion_is_rusts() {
        let check = |n: i32| assert_eq!(i32_to_f32_portable(n).to_bits(), (n as f32).to_bits(), "{n}");
        for n in [0, 1, -1, i32::MAX, -i32::MAX, (1 << 24) + 1, -(1 << 24) - 1, (1 << 30) + (1 << 6), (1 << 30) + 3 * (1 << 6)] {
            check(n);
        }
        let mut s = 0x2545_f491u32;
        for _ in 0..2_000_000 {
            s ^= s << 13;
            s ^= s >> 17;
            s ^= s << 5;
            let n = (s as i32) >> (s % 31);
            if n != i32::MIN {
                check(n);
                check(n & !0x7f | 0x40);
            }
        }
    }

    #[test]
    fn msb_matches_leading_zeros() {
        for s in 0..64 {
            let v = 1u64 << s;
            assert_eq!(msb(v), s);
            assert_eq!(msb(v | 1), s);
            assert_eq!(msb(v | (v >> 1)), s);
        }
        assert_eq!(msb(u64::MAX), 63);
    }

    #[test]
    fn shifts_floor_and_ceil() {
        for v in -70i64..70 {
            for s in 0..5 {
                let d = (1i64 << s) as f64;
                assert_eq!(floor_shr(v, s), (v as f64 / d).floor() as i64);
                assert_eq!(ceil_shr(v, s), (v as f64 / d).ceil() as i64);
            }
        }
    }

    #[test]
    fn exact_small_values() {
        check(1, 0);
        check(-1, 0);
        check(3, 1);
        check(1 << 40, 40);
        check(123_456_789, 10);
    }

    #[test]
    fn ties_round_to_even() {
        // 2^24 + 1 and 2^24 + 3 are ties in f32.
        check((1 << 24) + 1, 0);
        check((1 << 24) + 3, 0);
        check(-((1 << 24) + 1), 0);
        check((1 << 25) + 2, 0);
        check((1 << 25) + 6, 0);
    }

    #[test]
    fn carry_into_next_binade_and_overflow() {
        check((1 << 25) - 1, 0);
        check(i64::MAX, 0);
        check(i64::MIN, 0);
        check(i64::MAX, -64); // 2^127 rounds up to 2^127
        check(i64::MAX, -65); // overflows to infinity
        check(-i64::MAX, -80);
        check(1, -127);
        check(1, -128);
    }

    #[test]
    fn subnormals_and_underflow() {
        for f in [140, 149, 150, 151, 170, 200, 212, 213, 214, 300] {
            for n in [1i64, 2, 3, 5, 7, (1 << 23) - 1, 1 << 23, (1 << 24) - 1, 123_456_789_012, i64::MAX, -9] {
                check(n, f);
            }
        }
    }

    #[test]
    fn random_values_match_reference() {
        // xorshift: deterministic, no dependency.
        let mut s = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let bits = (s % 64) as u32;
            let n = (s as i64) >> (63 - bits.min(63));
            let f = ((s >> 20) % 400) as i32 - 130;
            check(n, f);
        }
    }
}
