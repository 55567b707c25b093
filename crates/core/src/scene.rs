/// A triangle mesh in world coordinates: vertices `(x, y, z)` with `z` the height, and
/// triangles as vertex indices. Triangles may be given in either winding.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Scene {
    pub vertices: Vec<[f64; 3]>,
    pub triangles: Vec<[u32; 3]>,
}

impl Scene {
    pub fn new(vertices: Vec<[f64; 3]>, triangles: Vec<[u32; 3]>) -> Self {
        Scene { vertices, triangles }
    }

    /// The same mesh moved by `(dx, dy, dz)`.
    pub fn translated(&self, dx: f64, dy: f64, dz: f64) -> Scene {
        let vertices = self.vertices.iter().map(|v| [v[0] + dx, v[1] + dy, v[2] + dz]).collect();
        Scene { vertices, triangles: self.triangles.clone() }
    }
}
