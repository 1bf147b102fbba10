//! PNG reading (8- and 16-bit; gray, gray+alpha, RGB, RGBA, palette) and writing, on top
//! of the `png` crate. Palette and sub-byte images are expanded to 8 bits per sample.
//!
//! Disparity maps are written as 16-bit gray with the linear mapping
//! `value = round((d − min) / (max − min) · 65535)`, i.e. `d = min + value / 65535 ·
//! (max − min)`; `min` and `max` are stored in the text chunks `disparity_min` and
//! `disparity_max`. Non-finite disparities are written as 0.

use std::fs::File;
use std::io::{BufReader, Cursor, Read};
use std::path::Path;

use ::png::{BitDepth, ColorType, Decoder, Encoder, Limits, Transformations};

use super::{write_bytes, IoError};

/// Samples of a decoded image, interleaved per pixel, top row first.
#[derive(Clone, Debug, PartialEq)]
pub enum Samples {
    /// 8 bits per sample.
    Eight(Vec<u8>),
    /// 16 bits per sample.
    Sixteen(Vec<u16>),
}

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

/// Deflate cannot compress better than about 1032:1; a header promising more pixel data
/// than that is corrupt, and refusing it avoids allocating for it.
const MAX_DEFLATE_RATIO: u64 = 1100;

/// Most bytes the `png` crate may allocate besides the image (its row buffers and
/// metadata chunks such as text and ICC profiles): its own default, far more than the
/// rows of any image within the pixel caps or any real file's metadata need.
const METADATA_LIMIT: usize = 64 << 20;

fn describe(e: ::png::DecodingError) -> IoError {
    IoError::format(format!("not a readable PNG image: {}", explain(&e)))
}

/// The `png` crate's message in words a user can act on: chunk types by their four
/// letters (the crate prints its `ChunkType` structure), checksum and deflate failures
/// as a damaged file, an early end as a truncated one.
fn explain(e: &::png::DecodingError) -> String {
    use ::png::DecodingError;
    let damaged = "the file is damaged: export or copy it again";
    match e {
        DecodingError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            format!("the file ends early (truncated): {damaged}")
        }
        DecodingError::IoError(io) => format!("reading it failed: {io}"),
        DecodingError::LimitsExceeded => format!(
            "its metadata chunks need more than {} MiB: the file is corrupt or not a light-field view",
            METADATA_LIMIT >> 20
        ),
        other => {
            let text = chunk_names(&other.to_string());
            if text.starts_with("CRC error") {
                let chunk = text
                    .rsplit_once("while decoding ")
                    .map(|(_, rest)| rest.trim_end_matches(" chunk."))
                    .filter(|name| name.len() == 4)
                    .map_or_else(|| "a chunk".to_string(), |name| format!("its {name} chunk"));
                format!("the checksum (CRC) of {chunk} does not match: {damaged}")
            } else if text.starts_with("Corrupt deflate stream") {
                format!("its compressed pixel data is corrupt: {damaged}")
            } else {
                format!("{}: {damaged}", text.trim_end_matches('.'))
            }
        }
    }
}

/// `text` with every `ChunkType { type: IHDR, critical: … }` replaced by `IHDR` (by
/// `an invalid` when the type is not four ASCII letters).
fn chunk_names(text: &str) -> String {
    const OPEN: &str = "ChunkType { type: ";
    let mut out = String::with_capacity(text.len());
    let mut rest = text;
    while let Some(start) = rest.find(OPEN) {
        out.push_str(&rest[..start]);
        let after = &rest[start + OPEN.len()..];
        // The type's characters come from the file and may be anything, braces included:
        // the structure ends at the first ` }` after its `critical` field.
        let end = after.find(", critical: ").and_then(|critical| {
            after[critical..]
                .find(" }")
                .map(|close| (critical, critical + close))
        });
        let Some((critical, close)) = end else {
            out.push_str("an invalid");
            return out;
        };
        let name = &after[..critical];
        if name.len() == 4 && name.bytes().all(|b| b.is_ascii_alphabetic()) {
            out.push_str(name);
        } else {
            out.push_str("an invalid");
        }
        rest = &after[close + 2..];
    }
    out.push_str(rest);
    out
}

/// What a PNG header promises, as [`decode`] would return it (palette and sub-byte
/// images expanded to 8 bits per sample).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Header {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// Samples per pixel: 1 gray, 2 gray+alpha, 3 RGB, 4 RGBA.
    pub channels: usize,
    /// Bits per sample: 8 or 16.
    pub bit_depth: u8,
}

/// Reads the header chunks of a PNG stream (not its pixels) and checks them against
/// `max_pixels` and the stream length `len` in bytes.
fn start<R: Read>(
    source: R,
    len: u64,
    max_pixels: u64,
) -> Result<(::png::Reader<R>, Header), IoError> {
    let mut decoder = Decoder::new(source);
    decoder.set_transformations(Transformations::EXPAND);
    decoder.set_limits(Limits {
        bytes: METADATA_LIMIT,
    });
    let reader = decoder.read_info().map_err(describe)?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    if width == 0 || height == 0 {
        return Err(IoError::format(format!(
            "the PNG image is {width}x{height} pixels: an empty image cannot be used"
        )));
    }
    let limits = super::limits::Limits {
        max_view_pixels: max_pixels,
        ..super::limits::Limits::default()
    };
    limits
        .check_view(width, height)
        .map_err(|e| IoError::format(format!("the PNG header declares {e}")))?;
    if info.raw_bytes() as u64 > len.saturating_mul(MAX_DEFLATE_RATIO) {
        return Err(IoError::format(format!(
            "the PNG header declares {width}x{height} pixels, far more than its {len} bytes can hold: the file is corrupt or truncated"
        )));
    }
    let (color, depth) = reader.output_color_type();
    let channels = match color {
        ColorType::Grayscale => 1,
        ColorType::GrayscaleAlpha => 2,
        ColorType::Rgb => 3,
        ColorType::Rgba => 4,
        ColorType::Indexed => {
            return Err(IoError::format(
                "the PNG palette could not be expanded: re-save the image as RGB",
            ))
        }
    };
    let bit_depth = match depth {
        BitDepth::Sixteen => 16,
        BitDepth::Eight => 8,
        other => {
            return Err(IoError::format(format!(
                "PNG samples of {} bits could not be expanded to 8: re-save the image with 8 or 16 bits",
                other as u8
            )))
        }
    };
    let header = Header {
        width,
        height,
        channels,
        bit_depth,
    };
    Ok((reader, header))
}

/// Decodes the pixels of a started stream.
fn finish<R: Read>(mut reader: ::png::Reader<R>, header: Header) -> Result<Image, IoError> {
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut buf).map_err(describe)?;
    buf.truncate(frame.buffer_size());
    let samples = if header.bit_depth == 16 {
        Samples::Sixteen(
            buf.chunks_exact(2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .collect(),
        )
    } else {
        Samples::Eight(buf)
    };
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
    fn chunk_types_are_named_by_their_letters() {
        assert_eq!(
            chunk_names("while decoding ChunkType { type: IHDR, critical: true, private: false, reserved: false, safecopy: false } chunk."),
            "while decoding IHDR chunk."
        );
        assert_eq!(chunk_names("no chunk here"), "no chunk here");
        assert_eq!(
            chunk_names("ChunkType { type: e { , critical: false } chunk appeared before IHDR"),
            "an invalid chunk appeared before IHDR"
        );
        assert_eq!(chunk_names("cut ChunkType { type: IDAT"), "cut an invalid");
        assert_eq!(
            chunk_names("ChunkType { type: a }b, critical: false, safecopy: true } chunk"),
            "an invalid chunk"
        );
    }

    #[test]
    fn garbage_is_an_error() {
        assert!(decode(b"").is_err());
        assert!(decode(b"\x89PNG\r\n\x1a\n garbage").is_err());
    }
}
