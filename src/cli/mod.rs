//! The command line's parts: messages and the progress bar, `render` and `view`.

pub mod progress;
pub mod render;
pub mod view;
