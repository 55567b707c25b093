//! The command line's parts: messages and the progress bar, and `render`.

pub mod progress;
pub mod render;
