//! PNG reading (8- and 16-bit; gray, gray+alpha, RGB, RGBA, palette) and writing, on top
//! of the `png` crate. Views are decoded by `lfdepth_picture::decode`, as the wasm
//! package's `decodePng` decodes them: palette and sub-byte images are expanded to 8 bits
//! per sample.
//!
//! Disparity maps are written as 16-bit gray with the linear mapping
//! `value = round((d − min) / (max − min) · 65535)`, i.e. `d = min + value / 65535 ·
//! (max − min)`; `min` and `max` are stored in the text chunks `disparity_min` and
//! `disparity_max`. Non-finite disparities are written as 0.

use std::fs::File;
use std::io::{BufReader, Cursor, Read};
use std::path::Path;

use ::png::{BitDepth, ColorType, Encoder};
use lfdepth_picture::decode;

use super::{write_bytes, IoError};

pub use lfdepth_picture::decode::{Header, Samples};

/// A decoded image.
#[derive(Clone, Debug, PartialEq)]
pub struct Image {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Samples per pixel: 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA.
    pub channels: usize,
    /// `width * height * channels` samples.
    pub samples: Samples,
}

impl Image {
    /// Bits per sample: 8 or 16.
    pub fn bit_depth(&self) -> u8 {
        match self.samples {
            Samples::Eight(_) => 8,
            Samples::Sixteen(_) => 16,
        }
    }

    /// Checks that the sample count matches the size.
    fn check(&self) -> Result<(), IoError> {
        let len = match &self.samples {
            Samples::Eight(s) => s.len(),
            Samples::Sixteen(s) => s.len(),
        };
        let needed = self
            .width
            .checked_mul(self.height)
            .and_then(|p| p.checked_mul(self.channels));
        if !(1..=4).contains(&self.channels) {
            return Err(IoError::format(format!(
                "a PNG image has 1 to 4 channels, not {}",
                self.channels
            )));
        }
        if self.width == 0 || self.height == 0 || needed != Some(len) {
            return Err(IoError::format(format!(
                "a {}x{}x{} image needs {} samples but has {len}",
                self.width,
                self.height,
                self.channels,
                needed.map_or("too many".into(), |n| n.to_string())
            )));
        }
        Ok(())
    }
}

/// Reads the header chunks of a PNG stream (not its pixels) and checks them against
/// `max_pixels` and the stream length `len` in bytes.
fn start<R: Read>(
    source: R,
    len: u64,
    max_pixels: u64,
) -> Result<(::png::Reader<R>, Header), IoError> {
    let limits = super::limits::Limits {
        max_view_pixels: max_pixels,
        ..super::limits::Limits::default()
    };
    decode::start(source, len, |width, height| {
        limits.check_view(width, height).map_err(|e| e.to_string())
    })
    .map_err(|e| IoError::format(e.to_string()))
}

/// Decodes the pixels of a started stream.
fn finish<R: Read>(reader: ::png::Reader<R>, header: Header) -> Result<Image, IoError> {
    let samples = decode::finish(reader, header).map_err(|e| IoError::format(e.to_string()))?;
    let image = Image {
        width: header.width,
        height: header.height,
        channels: header.channels,
        samples,
    };
    image.check()?;
    Ok(image)
}

/// Decodes a PNG held in memory, of at most the default
/// [`super::limits::DEFAULT_MAX_VIEW_PIXELS`].
pub fn decode(bytes: &[u8]) -> Result<Image, IoError> {
    decode_limited(bytes, super::limits::DEFAULT_MAX_VIEW_PIXELS)
}

/// Decodes a PNG held in memory whose header declares at most `max_pixels` pixels;
/// a larger one is refused before its pixels are decoded.
pub fn decode_limited(bytes: &[u8], max_pixels: u64) -> Result<Image, IoError> {
    let (reader, header) = start(Cursor::new(bytes), bytes.len() as u64, max_pixels)?;
    finish(reader, header)
}

fn open(path: &Path) -> Result<(BufReader<File>, u64), IoError> {
    let (file, len) = super::open_regular(path, "a view must be a PNG file")?;
    Ok((BufReader::new(file), len))
}

/// Reads the header of a PNG file without decoding its pixels, refusing more than
/// `max_pixels`; errors name the file.
pub fn read_header(path: &Path, max_pixels: u64) -> Result<Header, IoError> {
    let (source, len) = open(path)?;
    start(source, len, max_pixels)
        .map(|(_, header)| header)
        .map_err(|e| e.in_file(path))
}

/// Text chunks to store with an image (keyword, text).
pub type TextChunks<'a> = &'a [(&'a str, String)];

/// Encodes an image (1–4 channels, 8 or 16 bits) as PNG.
pub fn encode(image: &Image, text: TextChunks<'_>) -> Result<Vec<u8>, IoError> {
    image.check()?;
    let (w, h) = match (u32::try_from(image.width), u32::try_from(image.height)) {
        (Ok(w), Ok(h)) => (w, h),
        _ => {
            return Err(IoError::format(format!(
                "a {}x{} image is too large for PNG",
                image.width, image.height
            )))
        }
    };
    let mut out = Vec::new();
    let mut encoder = Encoder::new(&mut out, w, h);
    encoder.set_color(match image.channels {
        1 => ColorType::Grayscale,
        2 => ColorType::GrayscaleAlpha,
        3 => ColorType::Rgb,
        _ => ColorType::Rgba,
    });
    let fail = |e: ::png::EncodingError| IoError::format(format!("PNG encoding failed: {e}"));
    for (keyword, value) in text {
        encoder
            .add_text_chunk((*keyword).to_string(), value.clone())
            .map_err(fail)?;
    }
    let bytes: Vec<u8> = match &image.samples {
        Samples::Eight(s) => {
            encoder.set_depth(BitDepth::Eight);
            s.clone()
        }
        Samples::Sixteen(s) => {
            encoder.set_depth(BitDepth::Sixteen);
            s.iter().flat_map(|v| v.to_be_bytes()).collect()
        }
    };
    let mut writer = encoder.write_header().map_err(fail)?;
    writer.write_image_data(&bytes).map_err(fail)?;
    writer.finish().map_err(fail)?;
    Ok(out)
}

/// Reads a PNG file of at most the default
/// [`super::limits::DEFAULT_MAX_VIEW_PIXELS`]; errors name the file.
pub fn read(path: &Path) -> Result<Image, IoError> {
    read_limited(path, super::limits::DEFAULT_MAX_VIEW_PIXELS)
}

/// Reads a PNG file whose header declares at most `max_pixels` pixels, streaming it
/// from disk (only the decoded pixels are held); errors name the file.
pub fn read_limited(path: &Path, max_pixels: u64) -> Result<Image, IoError> {
    let (source, len) = open(path)?;
    start(source, len, max_pixels)
        .and_then(|(reader, header)| finish(reader, header))
        .map_err(|e| e.in_file(path))
}

/// Decodes an 8-bit PNG file whose header is `expected` straight into `out`, which
/// holds exactly its samples: no image buffer of its own, so no page of memory is
/// touched twice. `Ok(false)` (nothing read into `out`) when the file is not such an
/// image, for the caller to decode it through [`read_limited`] (whose errors say why).
pub fn read_eight_into(
    path: &Path,
    max_pixels: u64,
    expected: Header,
    out: &mut [u8],
) -> Result<bool, IoError> {
    let (source, len) = open(path)?;
    let Ok((mut reader, header)) = start(source, len, max_pixels) else {
        return Ok(false);
    };
    if header != expected || header.bit_depth != 8 || reader.output_buffer_size() != out.len() {
        return Ok(false);
    }
    let frame = reader
        .next_frame(out)
        .map_err(|e| IoError::format(decode::DecodeError::Png(e).to_string()).in_file(path))?;
    if frame.buffer_size() != out.len() {
        return Err(IoError::format(format!(
            "a {}x{}x{} image needs {} samples but has {}",
            header.width,
            header.height,
            header.channels,
            out.len(),
            frame.buffer_size()
        ))
        .in_file(path));
    }
    Ok(true)
}

/// Writes an image as PNG; errors name the file.
pub fn write(path: &Path, image: &Image) -> Result<(), IoError> {
    let bytes = encode(image, &[]).map_err(|e| e.in_file(path))?;
    write_bytes(path, &bytes)
}

/// Writes 8-bit RGB pixels (`width * height * 3` bytes).
pub fn write_rgb8(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<(), IoError> {
    write(
        path,
        &Image {
            width,
            height,
            channels: 3,
            samples: Samples::Eight(rgb.to_vec()),
        },
    )
}

/// A disparity map as a 16-bit gray image with the linear mapping described in the
/// module docs; `min < max` must hold.
pub fn disparity_to_gray16(
    width: usize,
    height: usize,
    disparity: &[f32],
    min: f32,
    max: f32,
) -> Image {
    let span = if max > min { max - min } else { 1.0 };
    let samples = disparity
        .iter()
        .map(|&d| {
            if d.is_finite() {
                (((d - min) / span).clamp(0.0, 1.0) * 65535.0).round() as u16
            } else {
                0
            }
        })
        .collect();
    Image {
        width,
        height,
        channels: 1,
        samples: Samples::Sixteen(samples),
    }
}

/// Writes a disparity map as 16-bit gray PNG over `[min, max]`, recording the mapping.
pub fn write_disparity16(
    path: &Path,
    width: usize,
    height: usize,
    disparity: &[f32],
    min: f32,
    max: f32,
) -> Result<(), IoError> {
    let image = disparity_to_gray16(width, height, disparity, min, max);
    let text = [
        ("disparity_min", min.to_string()),
        ("disparity_max", max.to_string()),
        (
            "disparity_mapping",
            "d = disparity_min + value / 65535 * (disparity_max - disparity_min)".to_string(),
        ),
    ];
    let bytes = encode(&image, &text).map_err(|e| e.in_file(path))?;
    write_bytes(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bit_gray_round_trips() {
        let image = Image {
            width: 3,
            height: 2,
            channels: 1,
            samples: Samples::Sixteen(vec![0, 1, 256, 4095, 40000, 65535]),
        };
        let bytes = encode(&image, &[]).unwrap();
        assert_eq!(decode(&bytes).unwrap(), image);
    }

    #[test]
    fn disparity_mapping_hits_both_ends() {
        let img = disparity_to_gray16(4, 1, &[-1.0, 1.0, 0.0, f32::NAN], -1.0, 1.0);
        assert_eq!(img.samples, Samples::Sixteen(vec![0, 65535, 32768, 0]));
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode(b"").is_err());
        assert!(decode(b"\x89PNG\r\n\x1a\n garbage").is_err());
    }
}
