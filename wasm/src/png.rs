//! PNG in and out through the `png` crate, as the `lfdepth` tool does: views decoded into
//! the samples `Estimator` takes, and the tool's colour-mapped `--png` picture.

use ::png::{BitDepth, ColorType, Encoder};
use lfdepth_picture::colormap;
use lfdepth_picture::decode::{self, DecodeError, Header, Samples};
use wasm_bindgen::prelude::*;

use crate::js::message;

/// The most pixels one view may have unless `maxPixels` says otherwise: 64Mi (8192×8192),
/// as the tool's `--max-view-pixels`.
pub const DEFAULT_MAX_VIEW_PIXELS: f64 = (1u64 << 26) as f64;

/// A decoded PNG view: 8-bit samples, interleaved per pixel, top row first.
#[wasm_bindgen]
pub struct PngImage {
    width: usize,
    height: usize,
    channels: usize,
    samples: Vec<u8>,
}

#[wasm_bindgen]
impl PngImage {
    /// Columns.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> usize {
        self.width
    }
    /// Rows.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> usize {
        self.height
    }
    /// Samples per pixel: 1 (gray), 3 (RGB) or 4 (RGBA), as `Shape.channels` takes them.
    #[wasm_bindgen(getter)]
    pub fn channels(&self) -> usize {
        self.channels
    }
    /// `width · height · channels` samples (a copy).
    #[wasm_bindgen(getter)]
    pub fn samples(&self) -> js_sys::Uint8Array {
        js_sys::Uint8Array::from(&self.samples[..])
    }
}

/// Decodes a PNG file's bytes into the samples an `Estimator` takes, as `lfdepth
/// estimate` reads a view: palette and sub-byte images are expanded to 8 bits, gray+alpha
/// keeps its gray channel, RGBA keeps its alpha (the estimator ignores it). 16-bit images
/// are refused (the `lfdepth` tool reads them). A header declaring more than
/// `maxPixels` pixels (default 64Mi) is refused before any pixel is decoded.
#[wasm_bindgen(js_name = decodePng)]
pub fn decode_png(bytes: &[u8], max_pixels: Option<f64>) -> Result<PngImage, JsError> {
    let max_pixels = max_pixels.unwrap_or(DEFAULT_MAX_VIEW_PIXELS);
    if max_pixels.is_nan() || max_pixels < 1.0 {
        return Err(message(&format!(
            "maxPixels must be at least 1, not {max_pixels}"
        )));
    }
    let (reader, header) = decode::start(bytes, bytes.len() as u64, |width, height| {
        if (width as f64) * (height as f64) > max_pixels {
            Err(format!(
                "{width}x{height} pixels, more than the {max_pixels} a view may have: pass a larger maxPixels"
            ))
        } else {
            Ok(())
        }
    })
    .map_err(|e| match e {
        DecodeError::BitDepth(bits) => message(&format!(
            "PNG samples of {bits} bits could not be expanded to 8: re-save the image with 8 bits"
        )),
        other => message(&other.to_string()),
    })?;
    let Header {
        width,
        height,
        channels,
        ..
    } = header;
    let buf = match decode::finish(reader, header).map_err(|e| message(&e.to_string()))? {
        Samples::Eight(samples) => samples,
        Samples::Sixteen(_) => {
            return Err(message(
                "the PNG image has 16-bit samples: the package takes 8-bit views (the lfdepth tool reads 16-bit ones)",
            ))
        }
    };
    if buf.len() != width * height * channels {
        return Err(message(&format!(
            "the PNG image decoded to {} samples, not the {width}x{height}x{channels} its header declares",
            buf.len()
        )));
    }
    // Gray+alpha keeps gray only, as the tool reads it.
    let (channels, samples) = if channels == 2 {
        (1, buf.iter().step_by(2).copied().collect())
    } else {
        (channels, buf)
    };
    Ok(PngImage {
        width,
        height,
        channels,
        samples,
    })
}

/// The disparity map colour-mapped (Turbo) with a legend bar, as PNG bytes: the picture
/// `lfdepth estimate --png` writes, byte for byte. `min` and `max` set the colour range
/// (both or neither; default: the map's finite range, as without `--png-range`).
#[wasm_bindgen(js_name = disparityPng)]
pub fn disparity_png(
    disparity: &[f32],
    width: usize,
    height: usize,
    min: Option<f32>,
    max: Option<f32>,
) -> Result<Vec<u8>, JsError> {
    let pixels = width.checked_mul(height);
    if width == 0 || height == 0 || pixels != Some(disparity.len()) {
        return Err(message(&format!(
            "a {width}x{height} map needs {} values but the disparity has {}",
            pixels.map_or("too many".into(), |n| n.to_string()),
            disparity.len()
        )));
    }
    let (min, max) = match (min, max) {
        (Some(min), Some(max)) if min.is_finite() && max.is_finite() && min < max => (min, max),
        (Some(min), Some(max)) => {
            return Err(message(&format!(
                "the colour range {min}..{max} must be finite with min < max"
            )))
        }
        (None, None) => colormap::finite_range(disparity).unwrap_or((0.0, 1.0)),
        _ => {
            return Err(message(
                "give both min and max of the colour range, or neither",
            ))
        }
    };
    let picture = colormap::with_legend(width, height, disparity, min, max);
    encode_rgb8(picture.width, picture.height, &picture.pixels)
}

/// 8-bit RGB as PNG with the `png` crate's default compression and filter (what the
/// tool writes).
fn encode_rgb8(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, JsError> {
    let (Ok(w), Ok(h)) = (u32::try_from(width), u32::try_from(height)) else {
        return Err(message(&format!(
            "a {width}x{height} picture is too large for PNG"
        )));
    };
    let fail = |e: ::png::EncodingError| message(&format!("PNG encoding failed: {e}"));
    let mut out = Vec::new();
    let mut encoder = Encoder::new(&mut out, w, h);
    encoder.set_color(ColorType::Rgb);
    encoder.set_depth(BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(fail)?;
    writer.write_image_data(rgb).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(out)
}
