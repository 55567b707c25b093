//! One module per pipeline stage. Each stage is a plain function of its inputs; the GPU entry
//! points (`crate::entry`) and the host dispatcher call exactly these functions.

pub mod assemble;
pub mod bin;
pub mod fine;
pub mod light;
pub mod scan;
pub mod setup;
pub mod small;
pub mod vertex;
pub mod viewport;
