//! The arithmetic every stage shares: exact fixed-point conversions (`fixed`) and the integer
//! edge functions with the fill rule (`edge`).

pub mod edge;
pub mod fixed;
