//! Double-`f32` arithmetic: a value as the unevaluated sum `hi + lo` of two `f32`s, with
//! `|lo| ≤ ulp(hi) / 2`, about 48 significant bits (Dekker 1971; Knuth's two-sum; Shewchuk's
//! and the QD library's double-double, one level down).
//!
//! Why: most GPUs have no `f64` worth using, and a vertex of UTM terrain (5,000,000 m) or a
//! camera close to it needs more than `f32`'s 24 bits to snap where the `f64` pipeline snaps.
//!
//! Every operation here is built from `f32` additions, subtractions and multiplications,
//! correctly rounded to nearest even (IEEE 754; on a Vulkan device where it declares
//! `RoundingModeRTE`, which the float-controls check asks for), and from
//! [`super::float::div`], correctly rounded on every device. No fused multiply-add is used
//! (Vulkan does not promise one, and the build marks every product `NoContraction`): products
//! are split by Veltkamp's constant `2^12 + 1` instead. So the operations are designed to give
//! every device the CPU's bits; the tests hold them to exact `f64` arithmetic natively, and
//! the vertex stage's parity test holds a device to the CPU.
//!
//! Domain: finite operands below `2^115` in magnitude (Veltkamp's split overflows above it)
//! whose low parts stay above the subnormal range (parts near `2^-126` lose bits where a device
//! flushes subnormals to zero); a division's divisor normal and positive. The vertex stage
//! keeps its values inside (`stages::vertex`: positions below `2^50`, matrix entries below
//! `2^60`, `w` in `[2^-60, 2^100]` before it divides).

use super::float::div;

/// `hi + lo`, normalised: `hi` is the sum rounded to `f32` and `|lo| ≤ ulp(hi) / 2`.
#[derive(Copy, Clone, Debug, Default, PartialEq)]
#[repr(C)]
pub struct Double {
    pub hi: f32,
    pub lo: f32,
}

/// `a + b` exactly, as a sum and its rounding error (Knuth's two-sum: any order of magnitudes).
#[inline]
pub fn two_sum(a: f32, b: f32) -> Double {
    let s = a + b;
    let bb = s - a;
    let err = (a - (s - bb)) + (b - bb);
    Double { hi: s, lo: err }
}

/// `a + b` exactly where `|a| ≥ |b|` (or `a` is 0) (Dekker's fast two-sum).
#[inline]
fn fast_two_sum(a: f32, b: f32) -> Double {
    let s = a + b;
    Double { hi: s, lo: b - (s - a) }
}

/// `a` as two halves of 12 significant bits each, whose products are exact (Veltkamp).
#[inline]
fn split(a: f32) -> (f32, f32) {
    let c = 4097.0 * a;
    let hi = c - (c - a);
    (hi, a - hi)
}

/// `a · b` exactly, as a product and its rounding error (Dekker's two-product).
#[inline]
pub fn two_product(a: f32, b: f32) -> Double {
    let p = a * b;
    let (ah, al) = split(a);
    let (bh, bl) = split(b);
    let err = ((ah * bh - p) + ah * bl + al * bh) + al * bl;
    Double { hi: p, lo: err }
}

impl Double {
    pub const ZERO: Double = Double { hi: 0.0, lo: 0.0 };

    #[inline]
    pub fn from_f32(v: f32) -> Double {
        Double { hi: v, lo: 0.0 }
    }

    /// The nearest double-`f32` to an `f64` (to 48 bits; exact for `f64`s of at most 48
    /// significant bits within the domain).
    #[cfg(not(target_arch = "spirv"))]
    pub fn from_f64(v: f64) -> Double {
        let hi = v as f32;
        Double { hi, lo: (v - hi as f64) as f32 }
    }

    /// The pair's value in `f64` (exact wherever `lo` lies within 29 binades of `hi`, as a
    /// normalised pair's does unless `lo` is far below `hi`'s last bit).
    #[cfg(not(target_arch = "spirv"))]
    pub fn to_f64(self) -> f64 {
        self.hi as f64 + self.lo as f64
    }

    /// `self · k` for an `f32` `k`.
    #[inline]
    pub fn scale(self, k: f32) -> Double {
        let p = two_product(self.hi, k);
        fast_two_sum(p.hi, p.lo + self.lo * k)
    }

    /// `self / d` for a positive `d`: a correctly rounded quotient of the high parts, then the
    /// remainder `self − q·d` (exact to the pair's precision) divided again.
    #[inline]
    pub fn div_positive(self, d: Double) -> Double {
        let q = signed_div(self.hi, d.hi);
        let remainder = self - d.scale(q);
        fast_two_sum(q, signed_div(remainder.hi, d.hi))
    }

    /// The nearest integer, halves away from zero (as `f64::round`), for `|self| < 2^30`;
    /// outside it (or NaN) `±2^30` (0 for NaN), the same on every device (a conversion of an
    /// `f32` beyond `i32` is undefined in SPIR-V).
    #[inline]
    pub fn round_to_i32(self) -> i32 {
        const LIMIT: f32 = (1u32 << 30) as f32;
        let in_range = self.hi > -LIMIT && self.hi < LIMIT;
        if !in_range {
            return if self.hi >= LIMIT {
                1 << 30
            } else if self.hi <= -LIMIT {
                -(1 << 30)
            } else {
                0
            };
        }
        // `hi` to an integer and a fraction (exact: `t` is `hi` with its fraction cut off),
        // then that fraction and `lo` together, which reach a few units where `hi` is large.
        let t = self.hi as i32;
        let rest = two_sum(self.hi - t as f32, self.lo);
        let u = rest.hi as i32;
        // What is left, `f`, lies in (−1, 1); the value is `n + f`.
        let n = t + u;
        let f = two_sum(rest.hi - u as f32, rest.lo);
        let non_negative = n > 0 || (n == 0 && at_least(f, 0.0));
        let (up, down) = if non_negative { (at_least(f, 0.5), !at_least(f, -0.5)) } else { (above(f, 0.5), !above(f, -0.5)) };
        n + i32::from(up) - i32::from(down)
    }
}

/// Whether `f ≥ h` (`f.hi` is `f` rounded, so it decides unless it equals `h`).
#[inline]
fn at_least(f: Double, h: f32) -> bool {
    f.hi > h || (f.hi == h && f.lo >= 0.0)
}

/// Whether `f > h`.
#[inline]
fn above(f: Double, h: f32) -> bool {
    f.hi > h || (f.hi == h && f.lo > 0.0)
}

impl core::ops::Neg for Double {
    type Output = Double;
    #[inline]
    fn neg(self) -> Double {
        Double { hi: -self.hi, lo: -self.lo }
    }
}

/// The accurate sum: both pairs' errors carried (two two-sums).
impl core::ops::Add for Double {
    type Output = Double;
    #[inline]
    fn add(self, o: Double) -> Double {
        let s = two_sum(self.hi, o.hi);
        let t = two_sum(self.lo, o.lo);
        let s = fast_two_sum(s.hi, s.lo + t.hi);
        fast_two_sum(s.hi, s.lo + t.lo)
    }
}

impl core::ops::Sub for Double {
    type Output = Double;
    #[inline]
    fn sub(self, o: Double) -> Double {
        self + -o
    }
}

impl core::ops::Mul for Double {
    type Output = Double;
    #[inline]
    fn mul(self, o: Double) -> Double {
        let p = two_product(self.hi, o.hi);
        fast_two_sum(p.hi, p.lo + (self.hi * o.lo + self.lo * o.hi))
    }
}

/// `a / b` correctly rounded for a positive normal `b` and any `a` (zero and subnormal `a`
/// give zero: `float::div` takes normal operands, and a device may flush them anyway).
#[inline]
fn signed_div(a: f32, b: f32) -> f32 {
    if a >= f32::MIN_POSITIVE {
        div(a, b)
    } else if a <= -f32::MIN_POSITIVE {
        -div(-a, b)
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic stream of `f64`s across many magnitudes and both signs.
    fn values(n: usize) -> Vec<f64> {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        (0..n)
            .map(|_| {
                state ^= state << 13;
                state ^= state >> 7;
                state ^= state << 17;
                let unit = (state >> 11) as f64 / (1u64 << 53) as f64;
                let exponent = ((state >> 3) % 40) as i32 - 20;
                let sign = if state & 1 == 0 { 1.0 } else { -1.0 };
                sign * (1.0 + unit) * 2f64.powi(exponent)
            })
            .collect()
    }

    /// The error of a pair against the exact `f64` value, in units of `2^-44` of its size.
    fn relative(d: Double, exact: f64) -> f64 {
        (d.to_f64() - exact).abs() / (exact.abs() * 2f64.powi(-44)).max(f64::MIN_POSITIVE)
    }

    #[test]
    fn two_sum_and_two_product_are_exact() {
        let v = values(20_000);
        for pair in v.chunks(2) {
            let (a, b) = (pair[0] as f32, pair[1] as f32);
            let s = two_sum(a, b);
            assert_eq!(s.hi as f64 + s.lo as f64, a as f64 + b as f64, "{a} + {b}");
            let p = two_product(a, b);
            assert_eq!(p.hi as f64 + p.lo as f64, a as f64 * b as f64, "{a} · {b}");
        }
    }

    #[test]
    fn operations_keep_about_44_bits() {
        let v = values(30_000);
        let mut worst = [0.0f64; 3];
        for pair in v.chunks(2) {
            let (a, b) = (Double::from_f64(pair[0]), Double::from_f64(pair[1]));
            let (x, y) = (a.to_f64(), b.to_f64());
            // Sums whose result cancels to far below the operands are exact in the pair only
            // to the operands' precision: measure against the larger operand.
            let sum = (a + b).to_f64() - (x + y);
            worst[0] = worst[0].max(sum.abs() / (x.abs().max(y.abs()) * 2f64.powi(-44)));
            worst[1] = worst[1].max(relative(a * b, x * y));
            worst[2] = worst[2].max(relative(a.div_positive(Double::from_f64(y.abs())), x / y.abs()));
        }
        assert!(worst.iter().all(|&w| w <= 1.0), "errors in units of 2^-44: add {}, mul {}, div {}", worst[0], worst[1], worst[2]);
    }

    #[test]
    fn rounding_to_an_integer_is_f64_round() {
        let mut cases: Vec<f64> = values(20_000).into_iter().map(|v| v * 1e3).filter(|v| v.abs() < 1e9).collect();
        for k in [0.0, 1.0, 7.0, 1e6, 123_456_789.0, 5e8] {
            for f in [0.5, 0.49999, 0.50001, 0.0, 0.99999] {
                cases.push(k + f);
                cases.push(-(k + f));
            }
        }
        for (v, expected) in [(2e9, 1 << 30), (-2e9, -(1 << 30)), (f64::NAN, 0)] {
            assert_eq!(Double::from_f64(v).round_to_i32(), expected, "{v} beyond the domain");
        }
        for v in cases {
            let d = Double::from_f64(v);
            let exact = d.to_f64();
            assert_eq!(d.round_to_i32() as i64, exact.round() as i64, "{v} as ({}, {})", d.hi, d.lo);
        }
    }
}
