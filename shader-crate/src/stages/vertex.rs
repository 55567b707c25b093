//! The vertex stage's transform: a position to clip space in double-`f32`.
//!
//! The host subtracts a local origin `o` from every position once (in `f64`, where the
//! difference of two nearby coordinates is exact or nearly so) and composes the frame's matrix
//! with the translation back, `M · T(o)`, once per frame. What reaches the kernels is small
//! relative positions and a matrix in double-`f32` (`math::double`): 48 significant bits where
//! `f32` has 24, so a vertex of UTM terrain at 5,000,000 m snaps where the `f64` pipeline snaps
//! it (`docs/numeric-contract.md`, "Geometry in the kernels").

use crate::math::double::Double;

/// `m · (r, 1)`: a position relative to the frame's origin to clip space, `m` row-major with
/// the origin composed in.
#[inline]
pub fn to_clip(m: &[[Double; 4]; 4], r: &[Double; 3]) -> [Double; 4] {
    let mut clip = [Double::ZERO; 4];
    let mut row = 0;
    while row < 4 {
        let m = &m[row];
        clip[row] = m[0] * r[0] + m[1] * r[1] + m[2] * r[2] + m[3];
        row += 1;
    }
    clip
}
