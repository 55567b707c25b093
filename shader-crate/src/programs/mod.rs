//! Pixel programs: what fine raster computes at a pixel once coverage has found the
//! triangles over it (`stages::fine::PixelProgram`), one module per pipeline, and what the
//! render pipeline's shade stage computes from the pixel's owner (`shade`); multisampled
//! frames test, key and shade their samples in one stage (`multisample`).

pub mod depth;
pub mod height;
pub mod multisample;
pub mod occlusion;
pub mod shade;
pub mod texture;
