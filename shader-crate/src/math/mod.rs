//! The arithmetic every stage shares: exact fixed-point conversions (`fixed`) and the integer
//! edge functions with the fill rule (`edge`), correctly rounded division and square root
//! (`float`), double-`f32` arithmetic for positions beyond `f32`'s reach (`double`), and
//! elementary functions (`exp`, `log`, `pow`, `sin`, `cos`, `acos`, ...) with the same bits on
//! every device (`elementary`).

pub mod double;
pub mod edge;
pub mod elementary;
pub mod fixed;
pub mod float;
