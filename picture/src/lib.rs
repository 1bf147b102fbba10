//! Pictures in and out, shared by the `lfdepth` tool and the wasm package so both read
//! and draw the same pixels: PNG views decoded through the `png` crate ([`decode`]: the
//! tool's views and `decodePng`), and colour-mapped disparity pictures (the Turbo colour
//! map, a legend bar labelled with a small bitmap font, drawn into an 8-bit RGB picture:
//! the tool's `--png` and `disparityPng`).

pub mod colormap;
pub mod decode;
pub mod font;
pub mod rgb;

pub use rgb::Rgb;
