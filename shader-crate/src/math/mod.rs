//! The arithmetic every stage shares: exact fixed-point conversions (`fixed`) and the integer
//! edge functions with the fill rule (`edge`), correctly rounded division and square root
//! (`float`), and double-`f32` arithmetic for positions beyond `f32`'s reach (`double`).

pub mod double;
pub mod edge;
pub mod fixed;
pub mod float;
