//! Pixel programs: what fine raster computes at a pixel once coverage has found the
//! triangles over it (`stages::fine::PixelProgram`), one module per pipeline, and what the
//! render pipeline's shade stage computes from the pixel's owner (`shade`); multisampled
//! frames test, key and shade their samples in one stage (`multisample`). What colours a
//! fragment is a program of its own (`fragment`): the built-in shadings or a user's; so is
//! where the vertex stage puts a vertex (`vertex`), glTF's morph targets and skins among its
//! built-in programs (`deform`). glTF's metallic-roughness BRDF is `brdf`; the tone mapping
//! and encoding of the shaded colour, `tone`.

pub mod brdf;
pub mod deform;
pub mod depth;
pub mod fragment;
pub mod height;
pub mod multisample;
pub mod occlusion;
pub mod shade;
pub mod texture;
pub mod tone;
pub mod vertex;
