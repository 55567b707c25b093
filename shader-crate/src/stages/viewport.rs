//! The viewport stage's arithmetic: a clip-space vertex inside the clipping planes (`w > 0`)
//! to snapped pixels, depth and `1/w`, in double-`f32` (`math::double`), rounded as the host's
//! `f64` pipeline rounds them.

use crate::math::double::Double;

/// `(x / w + 1) · half_units` per axis, rounded to the nearest integer (halves away from
/// zero): the vertex in `2^-bits` px, `y` down, where `half_units` is half the frame's size in
/// those units (exact in `f32` for frames up to `2^16` px and 8 sub-pixel bits).
#[inline]
pub fn snap(clip: &[Double; 4], half_units: [f32; 2]) -> [i32; 2] {
    let one = Double::from_f32(1.0);
    let x = (clip[0].div_positive(clip[3]) + one).scale(half_units[0]);
    let y = (clip[1].div_positive(clip[3]) + one).scale(half_units[1]);
    [x.round_to_i32(), y.round_to_i32()]
}

/// `z / w` clamped to `[0, 1]` and `1 / w`, each rounded to `f32`.
#[inline]
// Comparisons rather than `f32::clamp`, which SPIR-V lowers to `FClamp`, whose NaNs and signed
// zeros each driver treats its own way.
#[allow(clippy::manual_clamp)]
pub fn depth_and_inverse_w(clip: &[Double; 4]) -> (f32, f32) {
    let depth = clip[2].div_positive(clip[3]).hi;
    let depth = if depth < 0.0 {
        0.0
    } else if depth > 1.0 {
        1.0
    } else {
        depth
    };
    (depth, Double::from_f32(1.0).div_positive(clip[3]).hi)
}
