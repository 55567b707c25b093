//! Small `f64` vector and matrix arithmetic the host's stages share, and how a model matrix
//! turns normals.

pub(super) fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

pub(super) fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]
}

pub(super) fn unit(v: [f64; 3]) -> [f64; 3] {
    let len = dot(v, v).sqrt();
    if len > 0.0 { v.map(|c| c / len) } else { [0.0; 3] }
}

/// The product `a · b` of two row-major 4×4 matrices.
pub fn multiply(a: &[[f64; 4]; 4], b: &[[f64; 4]; 4]) -> [[f64; 4]; 4] {
    std::array::from_fn(|r| std::array::from_fn(|c| a[r][0] * b[0][c] + a[r][1] * b[1][c] + a[r][2] * b[2][c] + a[r][3] * b[3][c]))
}

/// What turns normals as `m` (affine, row-major) turns positions: the cofactors of its linear
/// part, that is its inverse transpose times the determinant, with the determinant's sign
/// taken out so that a mirroring transform does not turn normals inside out.
pub fn normal_matrix(m: &[[f64; 4]; 4]) -> [[f64; 3]; 3] {
    let cofactor: [[f64; 3]; 3] = std::array::from_fn(|r| {
        std::array::from_fn(|c| {
            let (r1, r2, c1, c2) = ((r + 1) % 3, (r + 2) % 3, (c + 1) % 3, (c + 2) % 3);
            m[r1][c1] * m[r2][c2] - m[r1][c2] * m[r2][c1]
        })
    });
    let det: f64 = (0..3).map(|c| m[0][c] * cofactor[0][c]).sum();
    cofactor.map(|row| row.map(|v| if det < 0.0 { -v } else { v }))
}

/// Normal `n` turned by `normal_matrix` and normalised (zero stays zero).
pub fn transform_normal(normal_matrix: &[[f64; 3]; 3], n: [f32; 3]) -> [f32; 3] {
    let v = n.map(f64::from);
    let m = normal_matrix;
    unit(std::array::from_fn(|r| m[r][0] * v[0] + m[r][1] * v[1] + m[r][2] * v[2])).map(|c| c as f32)
}
