//! The command line's parts: messages and progress, and band-by-band streaming of a run.

pub mod progress;
pub mod stream;
