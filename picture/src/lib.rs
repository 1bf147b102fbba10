//! Colour-mapped disparity pictures: the Turbo colour map, a legend bar labelled with a
//! small bitmap font, drawn into an 8-bit RGB picture. Shared by the `lfdepth` tool's
//! `--png` and the wasm package's `disparityPng`, so both draw the same pixels.

pub mod colormap;
pub mod font;
pub mod rgb;

pub use rgb::Rgb;
