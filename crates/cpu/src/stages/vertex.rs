//! Twin of the `vertex` entry point: one invocation per vertex of the frame.
//!
//! The kernel works in double-`f32` pairs, which cost a CPU about ten times what `f64` costs.
//! So the twin first computes the vertex in `f64` from the same pairs, with a bound on how far
//! both the pairs' result and its own may lie from the exact value; where no rounding boundary
//! (of `f32`, or of the snapping to an integer) lies within that bound, both round alike and the
//! `f64` result is the kernel's bits. Near a boundary, or outside the range the bound covers,
//! it runs the kernel's own function ([`exact_in_f64`] says which). A frame's vertex program
//! poses each position first, as the kernel does, with the same function ([`posed`]).

use rayon::prelude::*;
use tileraster_kernels::abi::{ProjectedVertex, RelativePosition, VertexParams};
use tileraster_kernels::programs::vertex::{Builtin, VertexProgram};
use tileraster_kernels::stages::vertex::{
    BEYOND_BOTTOM, BEYOND_FAR, BEYOND_LEFT, BEYOND_NEAR, BEYOND_RIGHT, BEYOND_TOP, POSITION_LIMIT, assembly_bit, vertex as project,
};

/// The frame's vertices through the vertex stage with the vertex program `program` (and the
/// frame's vertex `texture`), into `projected` (its memory reused).
pub fn vertex(
    program: &(dyn VertexProgram + Sync),
    params: &VertexParams,
    texture: &[f32],
    positions: &[RelativePosition],
    projected: &mut Vec<ProjectedVertex>,
) {
    let matrix = Matrix::of(params);
    // Posed already: the kernel's function told not to pose again.
    let unposed = VertexParams { posed: 0, ..*params };
    let one = |(v, p): (usize, &RelativePosition)| {
        let index = params.first_vertex + v as u32;
        let p = &posed(program, params, texture, index, p);
        exact_in_f64(params, &matrix, p).unwrap_or_else(|| project(&Builtin, &unposed, &[], index, p))
    };
    positions.par_iter().enumerate().with_min_len(1 << 10).map(one).collect_into_vec(projected);
}

/// Vertex `index` at `position` as the kernel poses it before its matrix (`stages::vertex`):
/// by `program` where `params.posed` says so and the position lies within the stage's range,
/// else as it is.
pub fn posed(program: &(dyn VertexProgram + Sync), params: &VertexParams, texture: &[f32], index: u32, position: &RelativePosition) -> RelativePosition {
    if params.posed == 0 {
        return *position;
    }
    let r = tileraster_kernels::stages::vertex::posed(program, &params.uniforms, texture, index, position);
    RelativePosition { hi: r.map(|d| d.hi), lo: r.map(|d| d.lo) }
}

/// The frame's matrix in `f64`: the value of each pair (exact, or within `2^-53` of it where
/// the low part lies far below the high one), where the bound covers the frame: every entry
/// in range and a normalised pair, the viewport's sizes finite and not negative.
pub struct Matrix(Option<[[f64; 4]; 4]>);

impl Matrix {
    pub fn of(params: &VertexParams) -> Matrix {
        let m: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|c| params.matrix_hi[r][c] as f64 + params.matrix_lo[r][c] as f64));
        let entries = (0..16).all(|k| {
            let (hi, v) = (params.matrix_hi[k / 4][k % 4], m[k / 4][k % 4]);
            v.abs() < LARGEST && normalised(hi, v)
        });
        let sizes = params.half_units.iter().chain(&params.reach).all(|&v| v.is_finite() && v >= 0.0);
        Matrix((entries && sizes).then_some(m))
    }
}

/// Whether `hi` is the pair's value rounded to `f32`, as the pairs' bounds assume.
fn normalised(hi: f32, value: f64) -> bool {
    value as f32 == hi
}

/// Relative error of each pair operation of the kernel (sum, product, quotient, scaling), with
/// room to spare: double-`f32` sums, products and quotients are within `16 · 2^-48` of exact
/// (Joldes, Muller and Popescu 2017 bound these algorithms by at most that; `math::double`'s
/// tests measure them within `2^-44`).
const PAIR_ERROR: f64 = 1.0 / (1u64 << 40) as f64;
/// The same for this twin's `f64` operations (`2^-53` each), with as much room.
const F64_ERROR: f64 = 1.0 / (1u64 << 49) as f64;
/// Both together: each step's bound on the gap between the two results.
const STEP: f64 = PAIR_ERROR + F64_ERROR;
/// Absolute room for pair parts that fall below `f32`'s normal range (each such rounding is
/// below `2^-149`; a vertex has fewer than a hundred).
const TINY: f64 = 1.0 / (1u128 << 120) as f64;
/// Magnitudes the bound covers: the pairs' products and sums stay far from overflow (the
/// kernel's Veltkamp splits overflow from `2^115`).
const LARGEST: f64 = (1u128 << 100) as f64;

/// The kernel's result for `position` where `f64` arithmetic proves it, else `None`.
pub fn exact_in_f64(params: &VertexParams, matrix: &Matrix, position: &RelativePosition) -> Option<ProjectedVertex> {
    // The kernel's first test, on the same `f32`s.
    let bounded = |v: f32| v < POSITION_LIMIT && v > -POSITION_LIMIT;
    if !position.hi.iter().all(|&v| bounded(v)) {
        return Some(ProjectedVertex::NONE);
    }
    let matrix = matrix.0.as_ref()?;
    let r: [f64; 3] = std::array::from_fn(|k| position.hi[k] as f64 + position.lo[k] as f64);
    if !(0..3).all(|k| normalised(position.hi[k], r[k])) {
        return None;
    }
    // Each row in `f64`, and the sum of its terms' magnitudes, which bounds both results' error.
    let mut clip = [0.0f64; 4];
    let mut error = [0.0f64; 4];
    for row in 0..4 {
        let m = &matrix[row];
        let size = (m[0] * r[0]).abs() + (m[1] * r[1]).abs() + (m[2] * r[2]).abs() + m[3].abs();
        if size >= LARGEST {
            return None;
        }
        clip[row] = m[0] * r[0] + m[1] * r[1] + m[2] * r[2] + m[3];
        // Three products and three sums, each within `STEP` of the terms it adds.
        error[row] = 8.0 * STEP * size + TINY;
    }
    // The kernel's domain test compares the pairs' high parts (each `clip` rounded to `f32`):
    // decided here where every value those parts may take decides it alike.
    let hi: [Span; 4] = std::array::from_fn(|k| Span::around(clip[k], error[k]));
    let w = hi[3];
    // The frustum bits: the signs of the kernel's pair sums and differences
    // (`stages::vertex::frustum_planes`), decided where the `f64` value lies farther from zero
    // than both results' error.
    let sign_of = |a: usize, b: Option<(usize, f64)>| -> Option<bool> {
        let (v, e) = match b {
            Some((b, k)) => (clip[b] + k * clip[a], error[a] + error[b] + 2.0 * STEP * (clip[a].abs() + clip[b].abs())),
            None => (clip[a], error[a]),
        };
        let e = 2.0 * e + TINY;
        if v > e {
            Some(false)
        } else if v < -e {
            Some(true)
        } else {
            None
        }
    };
    let beyond = [
        (sign_of(0, Some((3, 1.0))), BEYOND_LEFT),
        (sign_of(0, Some((3, -1.0))), BEYOND_RIGHT),
        (sign_of(1, Some((3, 1.0))), BEYOND_TOP),
        (sign_of(1, Some((3, -1.0))), BEYOND_BOTTOM),
        (sign_of(2, None), BEYOND_NEAR),
        (sign_of(2, Some((3, -1.0))), BEYOND_FAR),
    ];
    let mut planes = 0;
    for (negative, bit) in beyond {
        planes |= if negative? { bit } else { 0 };
    }
    let within = |v: Span, reach: f32| all(at_most(v, w.times(reach)), at_most(v.negated(), w.times(reach)));
    let lowest = Span::exactly(1.0 / (1u64 << 60) as f32);
    let highest = Span::exactly((1u128 << 100) as f32);
    let checks = [
        at_most(lowest, w),
        at_most(w, highest),
        within(hi[0], params.reach[0]),
        within(hi[1], params.reach[1]),
        at_most(w.negated(), hi[2]),
        at_most(hi[2], w.times(2.0)),
    ];
    if checks.contains(&Some(false)) {
        return Some(ProjectedVertex::none(planes));
    }
    if checks.contains(&None) {
        return None;
    }
    let (w, w_error) = (clip[3], error[3]);
    if w_error >= w / 4.0 {
        return None;
    }
    // `v / w` (one division for all four), and a bound on both results' distance from it.
    let inverse = 1.0 / w;
    let ratio = |v: f64, v_error: f64| {
        let q = v * inverse;
        (q, 2.0 * (2.0 * (v_error + q.abs() * w_error) * inverse + 2.0 * STEP * q.abs()) + TINY)
    };
    let snapped = |axis: usize| -> Option<i32> {
        let (q, q_error) = ratio(clip[axis], error[axis]);
        let half = params.half_units[axis] as f64;
        let v = (q + 1.0) * half;
        let e = 2.0 * (half * (q_error + 2.0 * STEP * (q.abs() + 1.0)) + 2.0 * STEP * v.abs()) + TINY;
        if v.abs() + e >= (1u32 << 29) as f64 {
            return None;
        }
        // `v`'s integer part and fraction (exact); the kernel rounds halves away from zero, so
        // the answer is decided unless a half lies within `e`.
        let whole = v as i32;
        let fraction = v - whole as f64;
        let distance = fraction.abs();
        if (distance - 0.5).abs() <= e {
            return None;
        }
        Some(if distance > 0.5 { whole + fraction.signum() as i32 } else { whole })
    };
    let screen = [snapped(0)?, snapped(1)?];
    let (z, z_error) = ratio(clip[2], error[2]);
    let depth = rounded(z, z_error)?;
    // As the kernel clamps (`depth` is no NaN; a negative zero stays, as there).
    let depth = depth.clamp(0.0, 1.0);
    let inverse_error = 2.0 * (2.0 * w_error * inverse * inverse + 2.0 * STEP * inverse) + TINY;
    let inverse_w = rounded(inverse, inverse_error)?;
    Some(ProjectedVertex { screen, depth, inverse_w, planes: planes | assembly_bit(params, screen, planes) })
}

/// The `f32`s a value within `error` of `v` may round to: rounding is monotonic, so the ends of
/// the interval bound them.
#[derive(Clone, Copy)]
struct Span {
    low: f32,
    high: f32,
}

impl Span {
    fn around(v: f64, error: f64) -> Span {
        Span { low: (v - error) as f32, high: (v + error) as f32 }
    }

    fn exactly(v: f32) -> Span {
        Span { low: v, high: v }
    }

    fn negated(self) -> Span {
        Span { low: -self.high, high: -self.low }
    }

    /// `self · k` rounded to `f32`, for `k ≥ 0`.
    fn times(self, k: f32) -> Span {
        Span { low: self.low * k, high: self.high * k }
    }
}

/// Whether `a ≤ b` for every value of both, or for none; `None` where it depends. (A NaN end
/// decides nothing.)
fn at_most(a: Span, b: Span) -> Option<bool> {
    if a.high <= b.low {
        Some(true)
    } else if a.low > b.high {
        Some(false)
    } else {
        None
    }
}

/// Both, where both are decided or one is false.
fn all(a: Option<bool>, b: Option<bool>) -> Option<bool> {
    match (a, b) {
        (Some(false), _) | (_, Some(false)) => Some(false),
        (Some(true), Some(true)) => Some(true),
        _ => None,
    }
}

/// The `f32` nearest every value within `error` of `v` (the same one, bit for bit), if there is
/// one: rounding is monotonic, so the ends of the interval decide.
fn rounded(v: f64, error: f64) -> Option<f32> {
    let (low, high) = ((v - error) as f32, (v + error) as f32);
    (low.to_bits() == high.to_bits()).then_some(low)
}

#[cfg(test)]
mod tests {
    use super::*;
    use tileraster_kernels::abi::VertexUniforms;
    use tileraster_kernels::math::double::Double;
    use tileraster_kernels::stages::vertex::UNASSEMBLED;

    fn pairs(v: [f64; 3]) -> RelativePosition {
        let d = v.map(Double::from_f64);
        RelativePosition { hi: d.map(|d| d.hi), lo: d.map(|d| d.lo) }
    }

    fn params(m: [[f64; 4]; 4], width: u32, height: u32) -> VertexParams {
        let d = m.map(|row| row.map(Double::from_f64));
        VertexParams {
            matrix_hi: d.map(|row| row.map(|d| d.hi)),
            matrix_lo: d.map(|row| row.map(|d| d.lo)),
            half_units: [width, height].map(|n| (n << 8) as f32 / 2.0),
            reach: [width, height].map(|n| (2.0 * (1.0 + 2.0 * (1u32 << 19) as f64 / n as f64)) as f32),
            // The guard band, 2^19 px beyond each side, in snapped units.
            band_low: -(1 << 27),
            band_high: [width, height].map(|n| ((n + (1 << 19)) << 8) as i32),
            ..VertexParams::default()
        }
    }

    /// A deterministic stream in `[0, 1)`.
    fn stream(seed: u64) -> impl FnMut() -> f64 {
        let mut state = seed;
        move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        }
    }

    /// The twin poses each vertex once, as the kernel does, where the `f64` path answers and
    /// where it leaves the vertex to the kernel's pairs: here the built-in deform program moves
    /// every vertex by a joint's translation, onto points a hair from sub-pixel boundaries.
    #[test]
    fn a_posed_vertex_is_posed_once_on_every_path() {
        use tileraster_kernels::programs::deform::DeformLayout;
        use tileraster_kernels::programs::vertex::BUILTIN_DEFORM;
        let (w, h, n) = (1920u32, 1080u32, 20_000u32);
        let ortho = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.5, 0.25], [0.0, 0.0, 0.0, 1.0]];
        let layout = DeformLayout { joints: 1, weights: 0, targets: 0 };
        let mut texture = vec![0.0f32; layout.texels(n as u64) as usize];
        texture[..12].copy_from_slice(&[1.0, 0.0, 0.0, 0.25, 0.0, 1.0, 0.0, -0.125, 0.0, 0.0, 1.0, 0.0]);
        for v in 0..n {
            texture[layout.vertex(v) as usize + 4] = 1.0;
        }
        let uniforms =
            VertexUniforms { constants: layout.constants(), texture_size: [texture.len() as u32, 1], builtin: BUILTIN_DEFORM, ..VertexUniforms::default() };
        let p = VertexParams { posed: 1, uniforms, vertices: n, ..params(ortho, w, h) };
        let half = p.half_units[0] as f64;
        let mut next = stream(0x9e37_79b9_7f4a_7c15);
        let positions: Vec<RelativePosition> = (0..n)
            .map(|k| {
                let x = ((k % 1000) as f64 + 0.5 + (next() - 0.5) * 2f64.powi(-30)) / half - 1.0 - 0.25;
                pairs([x, 0.25 * next() + 0.125, next() - 0.5])
            })
            .collect();
        let mut twin = Vec::new();
        vertex(&Builtin, &p, &texture, &positions, &mut twin);
        let mut moved = 0;
        for (v, (position, twin)) in positions.iter().zip(&twin).enumerate() {
            let kernel = project(&Builtin, &p, &texture, v as u32, position);
            assert_eq!(bytemuck::bytes_of(twin), bytemuck::bytes_of(&kernel), "vertex {v}: twin {twin:?}, kernel {kernel:?}");
            let unposed = project(&Builtin, &VertexParams { posed: 0, ..p }, &[], v as u32, position);
            moved += usize::from(unposed.screen != kernel.screen);
        }
        assert!(moved > n as usize / 2, "the pose moved {moved} of {n} vertices");
    }

    /// Wherever the `f64` path answers, it is the kernel's answer, bit for bit: on a perspective
    /// view of terrain seen from within (vertices behind the camera and beyond the guard band
    /// among them), and on vertices placed within `2^-30` px of a snapping boundary, where it
    /// must leave most to the kernel.
    #[test]
    fn the_f64_path_gives_the_kernels_bits_or_nothing() {
        let (w, h) = (1920u32, 1080u32);
        // A perspective view (Vulkan depth) 400 m above the origin, looking along +x and down.
        let (sy, near, far) = (1.0 / (35f64.to_radians()).tan(), 1.0, 40_000.0);
        let sx = sy * h as f64 / w as f64;
        let a = far / (far - near);
        let (c, s) = (0.2f64.cos(), 0.2f64.sin());
        // Eye space: x right (world -y), y down, z forward (world +x tilted down by 0.2 rad).
        let view = [[0.0, -1.0, 0.0, 0.0], [-s, 0.0, -c, 400.0 * c], [c, 0.0, -s, 400.0 * s], [0.0, 0.0, 0.0, 1.0]];
        let proj = [[sx, 0.0, 0.0, 0.0], [0.0, sy, 0.0, 0.0], [0.0, 0.0, a, -a * near], [0.0, 0.0, 1.0, 0.0]];
        let m: [[f64; 4]; 4] = std::array::from_fn(|r| std::array::from_fn(|k| (0..4).map(|j| proj[r][j] * view[j][k]).sum()));
        let p = params(m, w, h);
        let mut next = stream(0x2545_f491_4f6c_dd1d);
        let (mut answered, mut projected, mut assembled, mut total) = (0, 0, 0, 0);
        for _ in 0..400_000 {
            let v = [next() * 20_000.0 - 5_000.0, next() * 20_000.0 - 10_000.0, next() * 300.0];
            let position = pairs(v);
            let kernel = project(&Builtin, &p, &[], 0, &position);
            total += 1;
            projected += usize::from(kernel.is_projected());
            assembled += usize::from(kernel.planes & UNASSEMBLED == 0);
            if let Some(fast) = exact_in_f64(&p, &Matrix::of(&p), &position) {
                answered += 1;
                assert_eq!(bytemuck::bytes_of(&fast), bytemuck::bytes_of(&kernel), "{v:?}: f64 {fast:?}, kernel {kernel:?}");
            }
        }
        println!("terrain: the f64 path answered {answered} of {total} vertices ({projected} projected, {assembled} for the assembly)");
        assert!(projected > total / 4 && projected < total, "{projected} of {total} projected");
        assert!(assembled > total / 10 && assembled < projected, "{assembled} of {projected} projected vertices for the assembly");
        // (The bound's room leaves about one vertex in 400 to the kernel's pairs.)
        assert!(answered as f64 >= 0.99 * total as f64, "{answered} of {total}");

        // On a boundary: an orthographic view where `x` maps to `(x + 1) · half` exactly, at
        // points a hair from the middle between two sub-pixel steps.
        let ortho = [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.5, 0.25], [0.0, 0.0, 0.0, 1.0]];
        let p = params(ortho, w, h);
        let half = p.half_units[0] as f64;
        let (mut answered, mut total) = (0, 0);
        for k in 0..20_000 {
            let step = (k % 1000) as f64 + 0.5;
            let hair = (next() - 0.5) * 2f64.powi(-30);
            let x = (step + hair) / half - 1.0;
            let position = pairs([x, 0.25 * next(), next() - 0.5]);
            let kernel = project(&Builtin, &p, &[], 0, &position);
            total += 1;
            if let Some(fast) = exact_in_f64(&p, &Matrix::of(&p), &position) {
                answered += 1;
                assert_eq!(bytemuck::bytes_of(&fast), bytemuck::bytes_of(&kernel), "x {x}: f64 {fast:?}, kernel {kernel:?}");
            }
        }
        println!("boundary: the f64 path answered {answered} of {total} vertices");
        assert!(answered < total / 10, "{answered} of {total} answered a hair from a boundary");

        // A hair from the frustum's planes (`x = ±w`, `y = ±w`, `z = 0`, `z = w` of the same
        // view): where the `f64` path answers, its bits are the kernel's, and each bit comes out
        // both ways.
        let (mut answered, mut total, mut set, mut clear) = (0, 0, [0; 6], [0; 6]);
        for k in 0..6000 {
            let hair = (next() - 0.5) * 2f64.powi(-12 - (k % 40));
            let v = match k % 6 {
                0 => [-1.0 + hair, (next() * 1.6 - 0.8), next()],
                1 => [1.0 + hair, (next() * 1.6 - 0.8), next()],
                2 => [(next() * 1.6 - 0.8), -1.0 + hair, next()],
                3 => [(next() * 1.6 - 0.8), 1.0 + hair, next()],
                // z = 0.5 · z_in + 0.25: 0 at -0.5, w at 1.5.
                4 => [(next() * 1.6 - 0.8), (next() * 1.6 - 0.8), -0.5 + hair],
                _ => [(next() * 1.6 - 0.8), (next() * 1.6 - 0.8), 1.5 + hair],
            };
            let position = pairs(v);
            let kernel = project(&Builtin, &p, &[], 0, &position);
            total += 1;
            for b in 0..6 {
                if kernel.planes & (1 << b) != 0 { set[b] += 1 } else { clear[b] += 1 }
            }
            if let Some(fast) = exact_in_f64(&p, &Matrix::of(&p), &position) {
                answered += 1;
                assert_eq!(bytemuck::bytes_of(&fast), bytemuck::bytes_of(&kernel), "{v:?}: f64 {fast:?}, kernel {kernel:?}");
            }
        }
        println!("planes: the f64 path answered {answered} of {total} vertices; bits set {set:?}");
        assert!(answered > total / 4 && answered < total, "{answered} of {total} answered a hair from a plane");
        assert!(set.iter().zip(clear).all(|(&s, c)| s > 100 && c > 100), "set {set:?}, clear {clear:?}");
    }
}
