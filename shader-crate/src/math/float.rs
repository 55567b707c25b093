//! Correctly rounded `f32` division and square root in integer arithmetic.
//!
//! Vulkan lets `OpFDiv` be off by 2.5 ulp and `sqrt` by 3 ulp, differently on every driver, so
//! the kernels never use them where bits must match. These functions compute the exact
//! quotient or root of the significands with integer division and shifts (exact on every
//! device) and round it to nearest, ties to even, as IEEE 754 does: on the CPU they give
//! exactly `a / b` and `x.sqrt()`, which the tests check.
//!
//! Domain: positive, normal, finite operands, and results in the normal range (what the render
//! pipeline feeds them: sums of positive weights, squared lengths). Outside it they return
//! `+0` for zero or an underflowing result and `+∞` for an overflowing one.
//!
//! Natively the CPU's own division and square root give the same bits faster wherever the
//! operands and the result are in that domain: IEEE 754 rounds them correctly too (Rust
//! guarantees it), and a correctly rounded result is unique. The SPIR-V build always computes
//! by hand; the tests hold the by-hand versions to the CPU's operations.

/// The significand with its implicit bit (24 bits) and the biased exponent of a positive
/// normal `f32`.
#[inline]
fn parts(bits: u32) -> (u64, i32) {
    (((bits & 0x007f_ffff) | 0x0080_0000) as u64, (bits >> 23) as i32)
}

/// `m · 2^(e − 150)`, `m` a 24-bit significand with its implicit bit (or `2^24` after a carry),
/// `e` the biased exponent: `+0` below the normal range, `+∞` above it.
#[inline]
fn assemble(m: u64, e: i32) -> f32 {
    let (m, e) = if m == 1 << 24 { (m >> 1, e + 1) } else { (m, e) };
    if e <= 0 {
        0.0
    } else if e >= 255 {
        f32::from_bits(0x7f80_0000)
    } else {
        f32::from_bits(((e as u32) << 23) | (m as u32 & 0x007f_ffff))
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
    div_by_hand(a, b)
}

/// [`div`] with integer operations only.
#[inline]
pub fn div_by_hand(a: f32, b: f32) -> f32 {
    let (ab, bb) = (a.to_bits(), b.to_bits());
    if !normal(ab) || !normal(bb) {
        return if ab == 0 { 0.0 } else { f32::from_bits(0x7f80_0000) };
    }
    let (ma, ea) = parts(ab);
    let (mb, eb) = parts(bb);
    // ma / mb lies in (1/2, 2): 40 fraction bits give a quotient of 40 or 41 bits, 16 or 17
    // more than the 24 kept, and the remainder says whether anything is left beyond them.
    let num = ma << 40;
    let q = num / mb;
    let sticky = num - q * mb != 0;
    let top: u32 = if q >> 40 != 0 { 40 } else { 39 };
    let shift = top - 23;
    let kept = q >> shift;
    let rest = q & ((1u64 << shift) - 1);
    let half = 1u64 << (shift - 1);
    let up = rest > half || (rest == half && (sticky || kept & 1 == 1));
    assemble(kept + up as u64, ea - eb + 127 + top as i32 - 40)
}

/// `1 / x`, correctly rounded, for positive normal `x`.
#[inline]
pub fn recip(x: f32) -> f32 {
    div(1.0, x)
}

/// `√x`, correctly rounded, for positive normal `x` (`+0` for `+0`).
#[inline]
pub fn sqrt(x: f32) -> f32 {
    // The root of a positive normal number is a positive normal number.
    #[cfg(not(target_arch = "spirv"))]
    if normal(x.to_bits()) {
        return x.sqrt();
    }
    sqrt_by_hand(x)
}

/// [`sqrt`] with integer operations only.
#[inline]
pub fn sqrt_by_hand(x: f32) -> f32 {
    let bits = x.to_bits();
    if !normal(bits) {
        return if bits == 0 { 0.0 } else { f32::from_bits(0x7f80_0000) };
    }
    let (m, e) = parts(bits);
    // x = m · 2^(e − 150); make the exponent even so that it halves exactly.
    let (m, p) = if (e - 150) & 1 != 0 { (m << 1, e - 151) } else { (m, e - 150) };
    // Scale m to [2^48, 2^50) by an even shift: its root then has exactly 25 bits.
    let s: u32 = if m >> 24 != 0 { 24 } else { 26 };
    let r = isqrt(m << s);
    // √x = √(m·2^s) · 2^((p − s)/2). Rounding 25 bits to 24 cannot meet a tie: r odd with no
    // remainder would make m·2^s odd. So half up is to nearest.
    let k = (p - s as i32) / 2 + 1;
    assemble((r + 1) >> 1, k + 150)
}

/// `⌊√n⌋` for `n < 2^62`, digit by digit (no division, no float).
#[inline]
fn isqrt(n: u64) -> u64 {
    let mut rem = n;
    let mut root = 0u64;
    let mut bit = 1u64 << 60;
    while bit > n {
        bit >>= 2;
    }
    while bit != 0 {
        if rem >= root + bit {
            rem -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    root
}

#[cfg(all(test, not(target_arch = "spirv")))]
mod tests {
    use super::*;

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
    fn division_is_the_ieee_quotient() {
        let xs = samples();
        let mut checked = 0;
        for (k, &a) in xs.iter().enumerate() {
            for &b in xs.iter().skip(k % 7).step_by(7) {
                let want = a / b;
                if !want.is_normal() {
                    continue;
                }
                assert_eq!(div_by_hand(a, b).to_bits(), want.to_bits(), "{a:e} / {b:e}");
                assert_eq!(div(a, b).to_bits(), want.to_bits(), "native: {a:e} / {b:e}");
                checked += 1;
            }
        }
        assert!(checked > 100_000, "only {checked} quotients checked");
    }

    #[test]
    fn square_root_is_the_ieee_root() {
        for x in samples().into_iter().chain([1.0f32, 2.0, 4.0, 0.25, 3.0, f32::MAX, f32::MIN_POSITIVE]) {
            assert_eq!(sqrt_by_hand(x).to_bits(), x.sqrt().to_bits(), "√{x:e}");
            assert_eq!(sqrt(x).to_bits(), x.sqrt().to_bits(), "native: √{x:e}");
        }
    }

    /// Outside the domain both paths give the by-hand results: zero, infinity.
    #[test]
    fn both_paths_agree_outside_the_domain() {
        for (a, b) in [(0.0f32, 3.0f32), (1e-30, 1e30), (1e30, 1e-30), (f32::MIN_POSITIVE, 4.0), (1.0, f32::from_bits(1))] {
            assert_eq!(div(a, b).to_bits(), div_by_hand(a, b).to_bits(), "{a:e} / {b:e}");
        }
        for x in [0.0f32, f32::from_bits(1), f32::INFINITY] {
            assert_eq!(sqrt(x).to_bits(), sqrt_by_hand(x).to_bits(), "√{x:e}");
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
