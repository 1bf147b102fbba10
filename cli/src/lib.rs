//! The std side of lfdepth: file formats, scene loading, the parallel engine and the
//! commands of the `lfdepth` tool.

pub mod engine;
pub mod io;
