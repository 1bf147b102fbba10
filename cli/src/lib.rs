//! The std side of lfdepth: file formats, scene loading, the parallel engine and the
//! commands of the `lfdepth` tool.

pub mod commands;
pub mod engine;
pub mod io;
pub mod progress;
pub mod report;

/// The colour map and legend of `--png` (shared with the wasm package).
pub use lfdepth_picture::colormap;
