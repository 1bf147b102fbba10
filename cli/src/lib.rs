//! The std side of lfdepth: file formats, scene loading, the parallel engine and the
//! commands of the `lfdepth` tool.

pub mod colormap;
pub mod commands;
pub mod engine;
pub mod font;
pub mod io;
pub mod picture;
pub mod progress;
pub mod report;
