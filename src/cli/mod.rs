//! The command line's parts: messages and the progress bar.

pub mod progress;
