//! PNG views decoded through the `png` crate, one reading for the `lfdepth` tool and the
//! wasm package's `decodePng`: palette and sub-byte images expanded to 8 bits per
//! sample, 16-bit samples kept, the header checked (empty, too many pixels for the
//! caller, more pixel data than the file can hold) before any pixel is decoded, and the
//! `png` crate's errors said in words a user can act on.

use core::fmt;
use std::io::Read;

use png::{BitDepth, ColorType, Decoder, Limits, Reader, Transformations};

/// Deflate cannot compress better than about 1032:1; a header promising more pixel data
/// than that is corrupt, and refusing it avoids allocating for it.
pub const MAX_DEFLATE_RATIO: u64 = 1100;

/// Most bytes the `png` crate may allocate besides the image (its row buffers and
/// metadata chunks such as text and ICC profiles): its own default, far more than the
/// rows of any image within the pixel caps or any real file's metadata need.
pub const METADATA_LIMIT: usize = 64 << 20;

/// What a PNG header promises, as [`finish`] decodes it (palette and sub-byte images
/// expanded to 8 bits per sample).
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

/// Samples of a decoded image, interleaved per pixel, top row first.
#[derive(Clone, Debug, PartialEq)]
pub enum Samples {
    /// 8 bits per sample.
    Eight(Vec<u8>),
    /// 16 bits per sample.
    Sixteen(Vec<u16>),
}

/// Why a PNG could not be decoded; its `Display` says what to change.
#[derive(Debug)]
#[non_exhaustive]
pub enum DecodeError {
    /// The `png` crate could not read the stream.
    Png(png::DecodingError),
    /// The header declares no pixels.
    Empty {
        /// Columns declared.
        width: usize,
        /// Rows declared.
        height: usize,
    },
    /// The caller's size check refused the header's size; its words follow "the PNG
    /// header declares".
    TooLarge(String),
    /// The header declares more pixel data than a file of `len` bytes can hold.
    Truncated {
        /// Columns declared.
        width: usize,
        /// Rows declared.
        height: usize,
        /// Bytes in the file.
        len: u64,
    },
    /// The palette could not be expanded.
    Palette,
    /// Samples of this many bits (not 8 or 16) after expansion.
    BitDepth(u8),
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::Png(e) => write!(f, "not a readable PNG image: {}", explain(e)),
            DecodeError::Empty { width, height } => write!(
                f,
                "the PNG image is {width}x{height} pixels: an empty image cannot be used"
            ),
            DecodeError::TooLarge(words) => write!(f, "the PNG header declares {words}"),
            DecodeError::Truncated { width, height, len } => write!(
                f,
                "the PNG header declares {width}x{height} pixels, far more than its {len} bytes can hold: the file is corrupt or truncated"
            ),
            DecodeError::Palette => write!(
                f,
                "the PNG palette could not be expanded: re-save the image as RGB"
            ),
            DecodeError::BitDepth(bits) => write!(
                f,
                "PNG samples of {bits} bits could not be expanded to 8: re-save the image with 8 or 16 bits"
            ),
        }
    }
}

impl std::error::Error for DecodeError {}

/// The `png` crate's message in words a user can act on: chunk types by their four
/// letters (the crate prints its `ChunkType` structure), checksum and deflate failures
/// as a damaged file, an early end as a truncated one.
fn explain(e: &png::DecodingError) -> String {
    use png::DecodingError;
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

/// Reads the header chunks of a PNG stream of `len` bytes (not its pixels) and checks
/// them: not empty, `check_size(width, height)` (the caller's pixel cap; its error's
/// words follow "the PNG header declares"), no more pixel data than `len` bytes can
/// hold, samples of 8 or 16 bits after expansion. [`finish`] decodes the pixels.
pub fn start<R: Read>(
    source: R,
    len: u64,
    check_size: impl FnOnce(usize, usize) -> Result<(), String>,
) -> Result<(Reader<R>, Header), DecodeError> {
    let mut decoder = Decoder::new(source);
    decoder.set_transformations(Transformations::EXPAND);
    decoder.set_limits(Limits {
        bytes: METADATA_LIMIT,
    });
    let reader = decoder.read_info().map_err(DecodeError::Png)?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    if width == 0 || height == 0 {
        return Err(DecodeError::Empty { width, height });
    }
    check_size(width, height).map_err(DecodeError::TooLarge)?;
    if info.raw_bytes() as u64 > len.saturating_mul(MAX_DEFLATE_RATIO) {
        return Err(DecodeError::Truncated { width, height, len });
    }
    let (color, depth) = reader.output_color_type();
    let channels = match color {
        ColorType::Grayscale => 1,
        ColorType::GrayscaleAlpha => 2,
        ColorType::Rgb => 3,
        ColorType::Rgba => 4,
        ColorType::Indexed => return Err(DecodeError::Palette),
    };
    let bit_depth = match depth {
        BitDepth::Sixteen => 16,
        BitDepth::Eight => 8,
        other => return Err(DecodeError::BitDepth(other as u8)),
    };
    let header = Header {
        width,
        height,
        channels,
        bit_depth,
    };
    Ok((reader, header))
}

/// Decodes the pixels of a stream [`start`] read the header of: 8-bit samples as they
/// are, 16-bit ones from their big-endian bytes.
pub fn finish<R: Read>(mut reader: Reader<R>, header: Header) -> Result<Samples, DecodeError> {
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut buf).map_err(DecodeError::Png)?;
    buf.truncate(frame.buffer_size());
    Ok(if header.bit_depth == 16 {
        Samples::Sixteen(
            buf.chunks_exact(2)
                .map(|b| u16::from_be_bytes([b[0], b[1]]))
                .collect(),
        )
    } else {
        Samples::Eight(buf)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG of `width`×`height` gray pixels at `depth` bits.
    fn gray(width: u32, height: u32, depth: BitDepth, data: &[u8]) -> Vec<u8> {
        let mut out = Vec::new();
        let mut encoder = png::Encoder::new(&mut out, width, height);
        encoder.set_color(ColorType::Grayscale);
        encoder.set_depth(depth);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(data).unwrap();
        writer.finish().unwrap();
        out
    }

    fn decode(bytes: &[u8], max_pixels: usize) -> Result<(Header, Samples), DecodeError> {
        let (reader, header) = start(bytes, bytes.len() as u64, |w, h| {
            if w * h > max_pixels {
                Err(format!("{w}x{h} pixels"))
            } else {
                Ok(())
            }
        })?;
        Ok((header, finish(reader, header)?))
    }

    #[test]
    fn eight_and_sixteen_bit_samples_and_expanded_sub_byte_ones() {
        let (header, samples) = decode(&gray(2, 1, BitDepth::Eight, &[3, 250]), 10).unwrap();
        assert_eq!(
            (
                header.width,
                header.height,
                header.channels,
                header.bit_depth
            ),
            (2, 1, 1, 8)
        );
        assert_eq!(samples, Samples::Eight(vec![3, 250]));
        let sixteen = gray(2, 1, BitDepth::Sixteen, &[1, 2, 255, 254]);
        assert_eq!(
            decode(&sixteen, 10).unwrap().1,
            Samples::Sixteen(vec![0x0102, 0xfffe])
        );
        // Two 4-bit pixels (0x1 and 0xf) expand to whole bytes.
        let four = gray(2, 1, BitDepth::Four, &[0x1f]);
        let (header, samples) = decode(&four, 10).unwrap();
        assert_eq!(header.bit_depth, 8);
        assert_eq!(samples, Samples::Eight(vec![0x11, 0xff]));
    }

    #[test]
    fn the_callers_cap_and_bad_streams_are_errors_in_words() {
        let image = gray(4, 4, BitDepth::Eight, &[7; 16]);
        let e = decode(&image, 15).unwrap_err();
        assert_eq!(e.to_string(), "the PNG header declares 4x4 pixels");
        let e = decode(&image[..image.len() - 20], 100).unwrap_err();
        assert!(
            e.to_string().starts_with("not a readable PNG image: "),
            "{e}"
        );
        let e = decode(b"\x89PNG\r\n\x1a\n garbage", 100).unwrap_err();
        assert!(matches!(e, DecodeError::Png(_)), "{e}");
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
}
