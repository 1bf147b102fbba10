//! Portable float maps (PFM): `Pf` (one channel) and `PF` (three channels, accepted only
//! when all three are equal, as a grey map saved in colour), either endianness (negative scale = little-endian), rows
//! stored bottom-to-top. Header parsing follows the benchmark's reference reader
//! (`shared/tools/hci_metrics.py`): one field per line, lines starting with `#` skipped,
//! width and height on one line or two, samples multiplied by `|scale|`.

use std::path::Path;

use super::{read_bytes, write_bytes, IoError};

/// A single-channel float map, row-major with the TOP row first.
#[derive(Clone, Debug, PartialEq)]
pub struct Pfm {
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
    /// `width * height` samples, top row first.
    pub data: Vec<f32>,
}

/// Byte order of the samples in a file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Endian {
    /// Scale written as `-1` (what the benchmark and most tools write).
    Little,
    /// Scale written as `1`.
    Big,
}

impl Pfm {
    /// A map of `width` × `height` samples (top row first); checks the length.
    pub fn new(width: usize, height: usize, data: Vec<f32>) -> Result<Self, IoError> {
        if width.checked_mul(height) != Some(data.len()) {
            return Err(IoError::format(format!(
                "a {width}x{height} float map needs {} samples but {} were given",
                width.saturating_mul(height),
                data.len()
            )));
        }
        Ok(Pfm {
            width,
            height,
            data,
        })
    }
}

/// Reads header fields line by line, as the reference reader does.
struct Header<'a> {
    bytes: &'a [u8],
    pos: usize,
}

impl<'a> Header<'a> {
    /// The next non-comment line with trailing whitespace removed.
    fn line(&mut self, what: &str) -> Result<&'a str, IoError> {
        loop {
            let rest = self.bytes.get(self.pos..).unwrap_or(&[]);
            let Some(end) = rest.iter().position(|&b| b == b'\n') else {
                return Err(IoError::format(format!(
                    "not a valid PFM file: the header ends before its {what} line"
                )));
            };
            self.pos += end + 1;
            let raw = &rest[..end];
            if raw.first() == Some(&b'#') {
                continue;
            }
            let text = std::str::from_utf8(raw)
                .map_err(|_| {
                    IoError::format(format!(
                        "not a valid PFM file: the {what} line is not plain text"
                    ))
                })?
                .trim_end();
            return Ok(text);
        }
    }
}

fn parse_dimension(text: &str, which: &str) -> Result<usize, IoError> {
    let value: usize = text.parse().map_err(|_| {
        IoError::format(format!(
            "not a valid PFM file: {which} `{}` is not a whole number",
            truncate(text)
        ))
    })?;
    if value == 0 {
        return Err(IoError::format(format!(
            "PFM {which} is 0: the map must have at least one row and one column"
        )));
    }
    Ok(value)
}

/// At most 40 characters of untrusted text for an error message.
fn truncate(text: &str) -> String {
    let mut s: String = text.chars().take(40).collect();
    if s.len() < text.len() {
        s.push('…');
    }
    s
}

/// Decodes a PFM file held in memory: exactly the bytes the header declares (trailing
/// bytes are refused). A `PF` (colour) file must have three equal channels; its first is
/// returned. Never panics; the declared size is checked against the byte count before
/// anything is allocated.
pub fn decode(bytes: &[u8]) -> Result<Pfm, IoError> {
    let mut header = Header { bytes, pos: 0 };
    let ident = header.line("identifier")?;
    let channels = match ident {
        "Pf" => 1usize,
        "PF" => 3,
        other => {
            return Err(IoError::format(format!(
                "not a PFM file: it starts with `{}` instead of `Pf` or `PF`",
                truncate(other)
            )))
        }
    };
    let dims = header.line("size")?;
    let mut fields = dims.split_whitespace();
    let width_text = fields.next().unwrap_or("");
    let height_text = match fields.next() {
        Some(h) => h,
        None => header.line("height")?.trim(),
    };
    if fields.next().is_some() {
        return Err(IoError::format(format!(
            "not a valid PFM file: the size line `{}` should hold just width and height",
            truncate(dims)
        )));
    }
    let width = parse_dimension(width_text, "width")?;
    let height = parse_dimension(height_text, "height")?;
    let scale_text = header.line("scale")?.trim();
    let scale: f32 = scale_text.parse().map_err(|_| {
        IoError::format(format!(
            "not a valid PFM file: scale `{}` is not a number",
            truncate(scale_text)
        ))
    })?;
    if !(scale.is_finite() && scale != 0.0) {
        return Err(IoError::format(format!(
            "PFM scale is {scale}: it must be a non-zero number (negative = little-endian)"
        )));
    }
    let endian = if scale < 0.0 {
        Endian::Little
    } else {
        Endian::Big
    };
    let pixels = width.checked_mul(height);
    let needed = pixels
        .and_then(|p| p.checked_mul(channels))
        .and_then(|s| s.checked_mul(4));
    let body = bytes.get(header.pos..).unwrap_or(&[]);
    let (Some(pixels), Some(needed)) = (pixels, needed) else {
        return Err(IoError::format(format!(
            "PFM header declares {width}x{height} pixels, too many to address: the file is corrupt"
        )));
    };
    if body.len() > needed {
        return Err(IoError::format(format!(
            "PFM data has {} byte(s) more than the {width}x{height} map the header declares: the header's size is wrong or the file holds more than one map",
            body.len() - needed
        )));
    }
    if body.len() < needed {
        return Err(IoError::format(format!(
            "PFM data is truncated: a {width}x{height} {} map needs {needed} bytes after the header but the file has {}",
            if channels == 1 { "gray" } else { "colour" },
            body.len()
        )));
    }
    let magnitude = scale.abs();
    let mut data = vec![0f32; pixels];
    let row_bytes = width * channels * 4;
    // Rows are stored bottom-to-top; out row y comes from stored row height-1-y.
    for (y, out_row) in data.chunks_exact_mut(width).enumerate() {
        let stored = height - 1 - y;
        let row = &body[stored * row_bytes..(stored + 1) * row_bytes];
        for (out, sample) in out_row.iter_mut().zip(row.chunks_exact(4 * channels)) {
            let raw = [sample[0], sample[1], sample[2], sample[3]];
            let value = match endian {
                Endian::Little => f32::from_le_bytes(raw),
                Endian::Big => f32::from_be_bytes(raw),
            };
            *out = if magnitude == 1.0 {
                value
            } else {
                value * magnitude
            };
        }
    }
    if channels == 3 && !grey(body, width * height) {
        return Err(IoError::format(
            "a colour PFM (`PF`) whose channels differ is not a disparity map: save the map as one-channel `Pf` (a `PF` file with three equal channels is read as its first)",
        ));
    }
    Ok(Pfm {
        width,
        height,
        data,
    })
}

/// Whether every pixel of `pixels` three-channel samples has three equal channels (bit
/// for bit, so NaN maps compare equal too).
fn grey(body: &[u8], pixels: usize) -> bool {
    body.chunks_exact(12)
        .take(pixels)
        .all(|p| p[0..4] == p[4..8] && p[0..4] == p[8..12])
}

/// Encodes a single-channel map as `Pf`, little-endian (scale `-1`), bottom row first.
pub fn encode(map: &Pfm) -> Vec<u8> {
    encode_with(map, Endian::Little)
}

/// Encodes a single-channel map as `Pf` in the given byte order.
pub fn encode_with(map: &Pfm, endian: Endian) -> Vec<u8> {
    let scale = match endian {
        Endian::Little => "-1",
        Endian::Big => "1",
    };
    let mut out = format!("Pf\n{} {}\n{}\n", map.width, map.height, scale).into_bytes();
    out.reserve(map.data.len() * 4);
    if map.width > 0 {
        for row in map.data.chunks_exact(map.width).rev() {
            for &v in row {
                out.extend_from_slice(&match endian {
                    Endian::Little => v.to_le_bytes(),
                    Endian::Big => v.to_be_bytes(),
                });
            }
        }
    }
    out
}

/// Reads a PFM file; errors name the file.
pub fn read(path: &Path) -> Result<Pfm, IoError> {
    let bytes = read_bytes(path)?;
    decode(&bytes).map_err(|e| e.in_file(path))
}

/// Writes a map as little-endian `Pf`; errors name the file.
pub fn write(path: &Path, map: &Pfm) -> Result<(), IoError> {
    write_bytes(path, &encode(map))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_line_size_comments_and_scale_are_honoured() {
        let mut bytes = b"# made by hand\nPf\n# size follows\n2\n1\n-0.5\n".to_vec();
        bytes.extend_from_slice(&4f32.to_le_bytes());
        bytes.extend_from_slice(&(-2f32).to_le_bytes());
        let map = decode(&bytes).unwrap();
        assert_eq!((map.width, map.height), (2, 1));
        assert_eq!(map.data, vec![2.0, -1.0]);
    }

    #[test]
    fn grey_colour_maps_yield_the_first_channel_bottom_up() {
        let mut bytes = b"PF\n1 2\n1.0\n".to_vec();
        // Stored bottom row first: bottom pixel 1, top pixel 2, each in three channels.
        for v in [1f32, 1.0, 1.0, 2.0, 2.0, 2.0] {
            bytes.extend_from_slice(&v.to_be_bytes());
        }
        assert_eq!(decode(&bytes).unwrap().data, vec![2.0, 1.0]);
        // Channels that differ: a colour image, not a map.
        let mut colour = b"PF\n1 2\n1.0\n".to_vec();
        for v in [1f32, 9.0, 9.0, 2.0, 9.0, 9.0] {
            colour.extend_from_slice(&v.to_be_bytes());
        }
        let msg = decode(&colour).unwrap_err().to_string();
        assert!(
            msg.contains("channels differ") && msg.contains("`Pf`"),
            "{msg}"
        );
    }

    #[test]
    fn trailing_bytes_are_refused() {
        let mut bytes = encode(&Pfm::new(2, 1, vec![1.0, 2.0]).unwrap());
        assert!(decode(&bytes).is_ok());
        bytes.push(0);
        let msg = decode(&bytes).unwrap_err().to_string();
        assert!(msg.contains("1 byte(s) more than the 2x1 map"), "{msg}");
    }

    #[test]
    fn hostile_headers_are_errors() {
        let cases: [&[u8]; 9] = [
            b"",
            b"P6\n1 1\n255\n",
            b"Pf\n",
            b"Pf\n0 4\n-1\n",
            b"Pf\nx 4\n-1\n",
            b"Pf\n4 4\nnan\n",
            b"Pf\n4 4 4\n-1\n",
            b"Pf\n18446744073709551615 18446744073709551615\n-1\n",
            b"Pf\n100000 100000\n-1\n\0\0\0\0",
        ];
        for bytes in cases {
            assert!(
                decode(bytes).is_err(),
                "{:?}",
                String::from_utf8_lossy(bytes)
            );
        }
        let msg = decode(b"Pf\n100000 100000\n-1\n\0\0\0\0")
            .unwrap_err()
            .to_string();
        assert!(msg.contains("truncated"), "{msg}");
    }
}
