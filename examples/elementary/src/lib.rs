//! The kernels' elementary functions in a user's fragment shader (`elementary-shader`): a
//! frame whose every pixel holds the bits of one function at the pixel's argument, on either
//! backend. The tests hold both backends to the native functions' bits.

use tileraster::Error;
use tileraster::render::{Cull, FragmentStage, IDENTITY, Mesh, RenderParams};

/// The shader on both backends.
pub static VALUES: FragmentStage = tileraster::fragment_stage!(elementary_shader);

pub use elementary_shader::{FUNCTIONS, argument, evaluate};

/// A square over the whole of clip space: every pixel of any frame is one of its fragments.
pub fn screen() -> Mesh {
    Mesh {
        positions: vec![[-2.0, -2.0, 0.5], [2.0, -2.0, 0.5], [2.0, 2.0, 0.5], [-2.0, 2.0, 0.5]],
        triangles: vec![[0, 1, 2], [0, 2, 3]],
        ..Default::default()
    }
}

/// A `width` × `height` frame of function `function` (an index into [`FUNCTIONS`]) over
/// arguments from `lo` to `hi` (`pow`'s exponent `y`).
pub fn params(width: u32, height: u32, function: usize, [lo, hi]: [f32; 2], y: f32) -> Result<RenderParams, Error> {
    let mut params = RenderParams::new(width, height, IDENTITY);
    params.cull = Cull::None;
    params.fragment = Some(VALUES);
    params.fragment_constants = [function as f32, lo, hi, width as f32, y, 1.0 / (width as f32 * height as f32), 0.0, 0.0];
    Ok(params)
}
