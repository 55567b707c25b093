//! The kernels' vertex stage (`stages::vertex`: double-`f32`, a local origin subtracted on the
//! host, as `tileraster_core::render` does) against the `f64` pipeline, vertex by vertex, on terrain where users have it: UTM
//! coordinates near 500,000 m east and 5,000,000 m north, seen whole, close up and at a grazing
//! angle. The contract (`docs/numeric-contract.md`, "Geometry in the kernels"): the snapped
//! position equals the `f64` pipeline's for at least 99.99 % of the vertices and is never more
//! than one sub-pixel step away; depth and `1/w` likewise, in `f32` units in the last place.
//! The same frames in plain `f32` (the local origin subtracted too) are measured beside them:
//! they miss the target, which is why the kernels carry 48 bits (and without the local origin
//! they break the one-step bound everywhere).

use tileraster_kernels::abi::{RelativePosition, VertexParams};
use tileraster_kernels::math::double::Double;
use tileraster_kernels::stages::vertex;

type Matrix = [[f64; 4]; 4];

/// Sub-pixel bits of the render pipeline's snapping.
const SNAP_BITS: u32 = 8;

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    a.map(|c| c / n)
}

/// A look-at perspective view in Vulkan's conventions (depth 0 at `near`, NDC `y` down), as
/// `tileraster::render::Camera` builds it.
fn perspective(eye: [f64; 3], target: [f64; 3], fov_deg: f64, near: f64, far: f64, width: u32, height: u32) -> Matrix {
    let f = unit(sub(target, eye));
    let r = unit(cross(f, [0.0, 0.0, 1.0]));
    let u = cross(r, f);
    let t = |a: [f64; 3]| -(a[0] * eye[0] + a[1] * eye[1] + a[2] * eye[2]);
    let view = [[r[0], r[1], r[2], t(r)], [-u[0], -u[1], -u[2], -t(u)], [f[0], f[1], f[2], t(f)], [0.0, 0.0, 0.0, 1.0]];
    let sy = 1.0 / (fov_deg.to_radians() / 2.0).tan();
    let sx = sy * height as f64 / width as f64;
    let a = far / (far - near);
    let proj = [[sx, 0.0, 0.0, 0.0], [0.0, sy, 0.0, 0.0], [0.0, 0.0, a, -a * near], [0.0, 0.0, 1.0, 0.0]];
    multiply(&proj, &view)
}

fn multiply(a: &Matrix, b: &Matrix) -> Matrix {
    std::array::from_fn(|r| std::array::from_fn(|c| (0..4).map(|k| a[r][k] * b[k][c]).sum()))
}

/// A terrain of `n × n` cells `extent` metres wide from `(x0, y0)`, hills up to ~120 m.
fn terrain(x0: f64, y0: f64, extent: f64, n: u32) -> Vec<[f64; 3]> {
    let mut out = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            let (x, y) = (extent * i as f64 / n as f64, extent * j as f64 / n as f64);
            let (u, v) = (x / extent * 7.0, y / extent * 5.0);
            out.push([x0 + x, y0 + y, 300.0 + 80.0 * u.sin() * v.cos() + 40.0 * (2.3 * u + 0.4).cos() * (1.9 * v).sin()]);
        }
    }
    out
}

/// What the `f64` pipeline makes of a vertex inside the view: snapped pixels, depth, `1/w`.
fn reference(m: &Matrix, p: [f64; 3], width: u32, height: u32) -> Option<([i64; 2], f32, f32)> {
    let c: [f64; 4] = std::array::from_fn(|r| m[r][0] * p[0] + m[r][1] * p[1] + m[r][2] * p[2] + m[r][3]);
    let inside = c[3] > 0.0 && c[2] >= 0.0 && c[2] <= c[3] && c[0].abs() <= c[3] && c[1].abs() <= c[3];
    if !inside {
        return None;
    }
    let unit = (1u64 << SNAP_BITS) as f64;
    let px = (c[0] / c[3] + 1.0) * (width as f64 / 2.0);
    let py = (c[1] / c[3] + 1.0) * (height as f64 / 2.0);
    Some(([(px * unit).round() as i64, (py * unit).round() as i64], (c[2] / c[3]).clamp(0.0, 1.0) as f32, (1.0 / c[3]) as f32))
}

/// The same in plain `f32` from the same relative positions and composed matrix (or, given the
/// frame's own matrix and the world positions, without a local origin).
fn plain_f32(m: &Matrix, r: [f64; 3], width: u32, height: u32) -> [i64; 2] {
    let m = m.map(|row| row.map(|v| v as f32));
    let r = r.map(|v| v as f32);
    let c: [f32; 4] = std::array::from_fn(|k| m[k][0] * r[0] + m[k][1] * r[1] + m[k][2] * r[2] + m[k][3]);
    let unit = (1u32 << SNAP_BITS) as f32;
    let px = (c[0] / c[3] + 1.0) * (width as f32 / 2.0 * unit);
    let py = (c[1] / c[3] + 1.0) * (height as f32 / 2.0 * unit);
    [px.round() as i64, py.round() as i64]
}

/// Distance in units in the last place of two positive `f32`s.
fn ulps(a: f32, b: f32) -> u32 {
    a.to_bits().abs_diff(b.to_bits())
}

#[derive(Default, Debug)]
struct Agreement {
    vertices: usize,
    snapped_equal: usize,
    snapped_worst: i64,
    depth_equal: usize,
    depth_worst: u32,
    inverse_w_equal: usize,
    inverse_w_worst: u32,
    f32_equal: usize,
    f32_worst: i64,
    f32_world_worst: i64,
}

fn measure(points: &[[f64; 3]], m: &Matrix, width: u32, height: u32) -> Agreement {
    // The host: the origin at the centre of the points' box, the matrix composed with the
    // translation back in `f64`, both to double-`f32`.
    let lo = points.iter().fold([f64::INFINITY; 3], |lo, p| std::array::from_fn(|k| lo[k].min(p[k])));
    let hi = points.iter().fold([f64::NEG_INFINITY; 3], |hi, p| std::array::from_fn(|k| hi[k].max(p[k])));
    let origin: [f64; 3] = std::array::from_fn(|k| lo[k] / 2.0 + hi[k] / 2.0);
    let translate = [[1.0, 0.0, 0.0, origin[0]], [0.0, 1.0, 0.0, origin[1]], [0.0, 0.0, 1.0, origin[2]], [0.0, 0.0, 0.0, 1.0]];
    let composed = multiply(m, &translate);
    let pairs = composed.map(|row| row.map(Double::from_f64));
    let params = VertexParams {
        matrix_hi: pairs.map(|row| row.map(|d| d.hi)),
        matrix_lo: pairs.map(|row| row.map(|d| d.lo)),
        half_units: [width, height].map(|n| (n << SNAP_BITS) as f32 / 2.0),
        // The render pipeline's guard band, 2^19 px, twice.
        reach: [width, height].map(|n| (2.0 * (1.0 + 2.0 * (1u32 << 19) as f64 / n as f64)) as f32),
        vertices: points.len() as u32,
        ..VertexParams::default()
    };
    let mut a = Agreement::default();
    for &p in points {
        let Some((snapped, depth, inverse_w)) = reference(m, p, width, height) else { continue };
        a.vertices += 1;
        let r = sub(p, origin);
        let pairs = r.map(Double::from_f64);
        let projected = vertex::vertex(
            &tileraster_kernels::programs::vertex::Builtin,
            &params,
            &[],
            0,
            &RelativePosition { hi: pairs.map(|d| d.hi), lo: pairs.map(|d| d.lo) },
        );
        assert!(projected.is_projected(), "a vertex in view is projected: {p:?}");
        let kernel = projected.screen.map(i64::from);
        let (kernel_depth, kernel_inverse_w) = (projected.depth, projected.inverse_w);
        let off = (kernel[0] - snapped[0]).abs().max((kernel[1] - snapped[1]).abs());
        a.snapped_equal += usize::from(off == 0);
        a.snapped_worst = a.snapped_worst.max(off);
        a.depth_equal += usize::from(kernel_depth == depth);
        a.depth_worst = a.depth_worst.max(ulps(kernel_depth, depth));
        a.inverse_w_equal += usize::from(kernel_inverse_w == inverse_w);
        a.inverse_w_worst = a.inverse_w_worst.max(ulps(kernel_inverse_w, inverse_w));
        let single = plain_f32(&composed, r, width, height);
        let off = (single[0] - snapped[0]).abs().max((single[1] - snapped[1]).abs());
        a.f32_equal += usize::from(off == 0);
        a.f32_worst = a.f32_worst.max(off);
        let world = plain_f32(m, p, width, height);
        a.f32_world_worst = a.f32_world_worst.max((world[0] - snapped[0]).abs().max((world[1] - snapped[1]).abs()));
    }
    a
}

#[test]
fn snapped_vertices_depth_and_inverse_w_match_the_f64_pipeline() {
    let (w, h) = (1920, 1080);
    // A 10 km UTM tile (zone 10's northing near 5,000 km), and one at 5,000 km east too.
    let utm = terrain(500_000.0, 5_000_000.0, 10_000.0, 400);
    let far_east = terrain(5_000_000.0, 5_000_000.0, 10_000.0, 400);
    let views: [(&str, &[[f64; 3]], Matrix); 5] = [
        ("whole tile, oblique", &utm, perspective([492_000.0, 4_992_000.0, 9_000.0], [505_000.0, 5_005_000.0, 300.0], 45.0, 100.0, 40_000.0, w, h)),
        ("close up, 60 m above", &utm, perspective([503_000.0, 5_004_000.0, 420.0], [503_150.0, 5_004_120.0, 330.0], 50.0, 1.0, 5_000.0, w, h)),
        ("grazing, 3 m above", &utm, perspective([500_500.0, 5_000_500.0, 390.0], [509_000.0, 5_009_000.0, 330.0], 70.0, 0.5, 20_000.0, w, h)),
        ("5,000 km east, oblique", &far_east, perspective([4_992_000.0, 4_992_000.0, 9_000.0], [5_005_000.0, 5_005_000.0, 300.0], 45.0, 100.0, 40_000.0, w, h)),
        ("5,000 km east, close up", &far_east, perspective([5_003_000.0, 5_004_000.0, 420.0], [5_003_150.0, 5_004_120.0, 330.0], 50.0, 1.0, 5_000.0, w, h)),
    ];
    let mut f32_misses_somewhere = false;
    for (name, points, m) in views {
        let a = measure(points, &m, w, h);
        let share = |n: usize| 100.0 * n as f64 / a.vertices.max(1) as f64;
        println!(
            "{name}: {} vertices in view; double-f32: snapped equal {:.4} % (worst {} step), depth equal {:.4} % (worst {} ulp), 1/w equal {:.4} % (worst {} ulp); plain f32: snapped equal {:.2} % (worst {} steps), without the local origin worst {} steps",
            a.vertices,
            share(a.snapped_equal),
            a.snapped_worst,
            share(a.depth_equal),
            a.depth_worst,
            share(a.inverse_w_equal),
            a.inverse_w_worst,
            share(a.f32_equal),
            a.f32_worst,
            a.f32_world_worst
        );
        assert!(a.vertices > 5_000, "{name}: only {} vertices in view", a.vertices);
        assert!(share(a.snapped_equal) >= 99.99 && a.snapped_worst <= 1, "{name}: {a:?}");
        assert!(share(a.depth_equal) >= 99.99 && a.depth_worst <= 1, "{name}: {a:?}");
        assert!(share(a.inverse_w_equal) >= 99.99 && a.inverse_w_worst <= 1, "{name}: {a:?}");
        f32_misses_somewhere |= share(a.f32_equal) < 99.99;
        assert!(a.f32_world_worst > 1, "{name}: f32 world coordinates within one step: {a:?}");
    }
    assert!(f32_misses_somewhere, "plain f32 met the target everywhere: the measurement no longer argues for double-f32");
}
