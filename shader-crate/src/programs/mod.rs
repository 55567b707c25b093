//! Pixel programs: what fine raster computes at a pixel once coverage has found the
//! triangles over it (`stages::fine::PixelProgram`). One module per pipeline.

pub mod height;
