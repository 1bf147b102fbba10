//! View containers besides PNG — JPEG (`zune-jpeg`) and TIFF (`tiff`) — behind one
//! header/decode pair that dispatches on the file's first bytes, and float maps as
//! 32-bit TIFF (`tiff`) or OpenEXR (`exr`) beside PFM, chosen by the output's extension.
//!
//! Every format answers its header first, so the caps of [`super::limits`] hold before
//! any pixel is decoded. Decoded views are [`Image`]s as from PNG: 8-bit samples stay
//! 8-bit, 16-bit TIFF samples stay 16-bit (full precision: the loader scales them to
//! `f32` in `[0, 1]`). JPEG views are 8-bit gray or RGB (CMYK and YCbCr are converted
//! to RGB); TIFF views may be gray, gray+alpha, RGB or RGBA of 8 or 16 bits, in any
//! compression the `tiff` crate reads.

use std::fs::File;
use std::io::{BufRead, BufReader, Cursor, Read, Seek, SeekFrom};
use std::path::Path;

use tiff::decoder::{Decoder as TiffDecoder, DecodingResult, Limits as TiffLimits};
use tiff::ColorType as TiffColor;
use zune_jpeg::zune_core::colorspace::ColorSpace;
use zune_jpeg::zune_core::options::DecoderOptions;
use zune_jpeg::JpegDecoder;

use super::png::{self as pngio, Header, Image, Samples};
use super::{write_bytes, IoError};

/// File name extensions of views, lower case (matched case-insensitively).
pub const VIEW_EXTENSIONS: [&str; 5] = ["png", "jpg", "jpeg", "tif", "tiff"];

/// A view file's container, from its first bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Format {
    /// PNG.
    Png,
    /// JPEG (JFIF, EXIF).
    Jpeg,
    /// TIFF (little- or big-endian, classic or BigTIFF).
    Tiff,
}

/// The container `magic` (a file's first four bytes) starts, if any.
pub fn sniff(magic: &[u8]) -> Option<Format> {
    match magic {
        [0x89, b'P', b'N', b'G', ..] => Some(Format::Png),
        [0xFF, 0xD8, 0xFF, ..] => Some(Format::Jpeg),
        [b'I', b'I', 42 | 43, 0, ..] | [b'M', b'M', 0, 42 | 43, ..] => Some(Format::Tiff),
        _ => None,
    }
}

fn open(path: &Path) -> Result<(BufReader<File>, Format), IoError> {
    let (file, _) = super::open_regular(path, "views must be PNG, JPEG or TIFF files")?;
    let mut reader = BufReader::new(file);
    let mut magic = [0u8; 4];
    let got = read_up_to(&mut reader, &mut magic).map_err(|e| IoError::os(path, "read", e))?;
    reader
        .seek(SeekFrom::Start(0))
        .map_err(|e| IoError::os(path, "read", e))?;
    let format = sniff(&magic[..got]).ok_or_else(|| {
        IoError::format("is not a PNG, JPEG or TIFF image (its first bytes say so): save the views as PNG, JPEG or TIFF")
            .in_file(path)
    })?;
    Ok((reader, format))
}

fn read_up_to(reader: &mut impl Read, buf: &mut [u8]) -> std::io::Result<usize> {
    let mut got = 0;
    while got < buf.len() {
        match reader.read(&mut buf[got..])? {
            0 => break,
            n => got += n,
        }
    }
    Ok(got)
}

/// Reads the header of a view file (PNG, JPEG or TIFF) without decoding its pixels,
/// refusing more than `max_pixels`; errors name the file.
pub fn read_header(path: &Path, max_pixels: u64) -> Result<Header, IoError> {
    let (reader, format) = open(path)?;
    match format {
        Format::Png => pngio::read_header(path, max_pixels),
        Format::Jpeg => contained(|| jpeg_start(reader, max_pixels), jpeg_panicked).map(|(_, h)| h),
        Format::Tiff => tiff_start(reader, max_pixels).map(|(_, h)| h),
    }
    .map_err(|e| e.in_file(path))
}

/// Decodes a view file (PNG, JPEG or TIFF) whose header declares at most `max_pixels`
/// pixels; a larger one is refused before its pixels are decoded. Errors name the file.
pub fn read_limited(path: &Path, max_pixels: u64) -> Result<Image, IoError> {
    let (reader, format) = open(path)?;
    match format {
        Format::Png => pngio::read_limited(path, max_pixels),
        Format::Jpeg => contained(
            || jpeg_start(reader, max_pixels).and_then(|(d, h)| jpeg_finish(d, h)),
            jpeg_panicked,
        ),
        Format::Tiff => tiff_start(reader, max_pixels).and_then(|(d, h)| tiff_finish(d, h)),
    }
    .map_err(|e| e.in_file(path))
}

/// Decodes an 8-bit PNG view whose header is `expected` straight into `out` (exactly
/// its samples); `Ok(false)`, with nothing read, for any other view, which
/// [`read_limited`] decodes.
pub fn read_eight_into(
    path: &Path,
    max_pixels: u64,
    expected: Header,
    out: &mut [u8],
) -> Result<bool, IoError> {
    match open(path)? {
        (_, Format::Png) => pngio::read_eight_into(path, max_pixels, expected, out),
        _ => Ok(false),
    }
}

/// Decodes a view held in memory (PNG, JPEG or TIFF, told by its first bytes) whose
/// header declares at most `max_pixels` pixels, as [`read_limited`] decodes a file.
pub fn decode_limited(bytes: &[u8], max_pixels: u64) -> Result<Image, IoError> {
    let reader = Cursor::new(bytes);
    match sniff(bytes.get(..4).unwrap_or(bytes)) {
        Some(Format::Png) => pngio::decode_limited(bytes, max_pixels),
        Some(Format::Jpeg) => contained(
            || jpeg_start(reader, max_pixels).and_then(|(d, h)| jpeg_finish(d, h)),
            jpeg_panicked,
        ),
        Some(Format::Tiff) => tiff_start(reader, max_pixels).and_then(|(d, h)| tiff_finish(d, h)),
        None => Err(IoError::format(
            "is not a PNG, JPEG or TIFF image (its first bytes say so): save the views as PNG, JPEG or TIFF",
        )),
    }
}

/// Checks a declared size against the cap, in the words of the format.
fn check_size(kind: &str, width: usize, height: usize, max_pixels: u64) -> Result<(), IoError> {
    if width == 0 || height == 0 {
        return Err(IoError::format(format!(
            "the {kind} image is {width}x{height} pixels: an empty image cannot be used"
        )));
    }
    let limits = super::limits::Limits {
        max_view_pixels: max_pixels,
        ..super::limits::Limits::default()
    };
    limits
        .check_view(width, height)
        .map_err(|e| IoError::format(format!("the {kind} header declares {e}")))
}

fn jpeg_error(e: impl std::fmt::Display) -> IoError {
    IoError::format(format!("not a readable JPEG image: {e}"))
}

std::thread_local! {
    /// Set while this thread runs a decoder under [`contained`]: its panics are caught
    /// there and answered as errors, so the panic hook stays quiet.
    static CONTAINED: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Runs `decode` (a call into a decoder crate) so that a panic inside it becomes the
/// error `failed` instead of ending the process: `zune-jpeg` 0.5.15 panics (an
/// `unwrap` in its IDCT) on some malformed files, e.g. a colour component sampled more
/// finely than the first one (found by the `view_decode` fuzz target). The panic hook,
/// wrapped once, keeps quiet for panics it contains; others are reported as before.
fn contained<T>(
    decode: impl FnOnce() -> Result<T, IoError>,
    failed: impl FnOnce() -> IoError,
) -> Result<T, IoError> {
    static QUIET_HOOK: std::sync::Once = std::sync::Once::new();
    QUIET_HOOK.call_once(|| {
        let previous = std::panic::take_hook();
        std::panic::set_hook(Box::new(move |info| {
            if !CONTAINED.with(std::cell::Cell::get) {
                previous(info);
            }
        }));
    });
    let was = CONTAINED.with(|c| c.replace(true));
    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(decode));
    CONTAINED.with(|c| c.set(was));
    result.unwrap_or_else(|_| Err(failed()))
}

/// The JPEG decoder's failure on a file it panics on.
fn jpeg_panicked() -> IoError {
    jpeg_error(
        "its contents make the JPEG decoder fail (a malformed or unusual file): re-save the view",
    )
}

/// Reads a JPEG's headers (not its pixels) and checks them against `max_pixels`.
fn jpeg_start<R: BufRead + Seek>(
    reader: R,
    max_pixels: u64,
) -> Result<(JpegDecoder<R>, Header), IoError> {
    // JPEG sizes are 16-bit; the caps below are the ones that count.
    let options = DecoderOptions::default()
        .set_max_width(usize::from(u16::MAX))
        .set_max_height(usize::from(u16::MAX));
    let mut decoder = JpegDecoder::new_with_options(reader, options);
    decoder.decode_headers().map_err(jpeg_error)?;
    let info = decoder
        .info()
        .ok_or_else(|| jpeg_error("no frame header"))?;
    let (width, height) = (usize::from(info.width), usize::from(info.height));
    check_size("JPEG", width, height, max_pixels)?;
    let gray = decoder.input_colorspace() == Some(ColorSpace::Luma);
    let out = if gray {
        ColorSpace::Luma
    } else {
        ColorSpace::RGB
    };
    decoder.set_options(options.jpeg_set_out_colorspace(out));
    let header = Header {
        width,
        height,
        channels: if gray { 1 } else { 3 },
        bit_depth: 8,
    };
    Ok((decoder, header))
}

fn jpeg_finish<R: BufRead + Seek>(
    mut decoder: JpegDecoder<R>,
    header: Header,
) -> Result<Image, IoError> {
    let len = header.width * header.height * header.channels;
    let mut samples = vec![0u8; len];
    decoder.decode_into(&mut samples).map_err(jpeg_error)?;
    Ok(Image {
        width: header.width,
        height: header.height,
        channels: header.channels,
        samples: Samples::Eight(samples),
    })
}

fn tiff_error(e: impl std::fmt::Display) -> IoError {
    IoError::format(format!("not a readable TIFF image: {e}"))
}

/// Reads a TIFF's first image directory (not its pixels) and checks it against
/// `max_pixels`.
fn tiff_start<R: Read + Seek>(
    reader: R,
    max_pixels: u64,
) -> Result<(TiffDecoder<R>, Header), IoError> {
    let mut decoder = TiffDecoder::new(reader).map_err(tiff_error)?;
    let (w, h) = decoder.dimensions().map_err(tiff_error)?;
    let (width, height) = (w as usize, h as usize);
    check_size("TIFF", width, height, max_pixels)?;
    let color = decoder.colortype().map_err(tiff_error)?;
    let (channels, bit_depth) = match color {
        TiffColor::Gray(d) => (1, d),
        TiffColor::GrayA(d) => (2, d),
        TiffColor::RGB(d) => (3, d),
        TiffColor::RGBA(d) => (4, d),
        other => {
            return Err(IoError::format(format!(
                "TIFF images of {} are not supported: re-save the view as gray or RGB",
                tiff_colour_words(other)
            )))
        }
    };
    if bit_depth != 8 && bit_depth != 16 {
        return Err(IoError::format(format!(
            "TIFF samples of {bit_depth} bits are not supported: re-save the view with 8 or 16 bits"
        )));
    }
    // The whole image is decoded at once: room for exactly that, nothing more.
    let bytes = width * height * channels * usize::from(bit_depth / 8);
    let limits = {
        let mut l = TiffLimits::default();
        l.decoding_buffer_size = bytes;
        l
    };
    let header = Header {
        width,
        height,
        channels,
        bit_depth,
    };
    Ok((decoder.with_limits(limits), header))
}

/// A TIFF colour type the loader does not take, in words (its `Debug` form is a Rust
/// structure).
fn tiff_colour_words(color: TiffColor) -> String {
    let bits = color.bit_depth();
    match color {
        TiffColor::Palette(_) => format!("palette colour ({bits}-bit indices)"),
        TiffColor::CMYK(_) => format!("CMYK colour ({bits}-bit samples)"),
        TiffColor::CMYKA(_) => format!("CMYK colour with alpha ({bits}-bit samples)"),
        TiffColor::YCbCr(_) => format!("YCbCr colour ({bits}-bit samples)"),
        TiffColor::Lab(_) => format!("CIE L*a*b* colour ({bits}-bit samples)"),
        TiffColor::Multiband { num_samples, .. } => {
            format!("{num_samples} bands per pixel ({bits}-bit samples)")
        }
        _ => format!("this colour type ({bits}-bit samples)"),
    }
}

fn tiff_finish<R: Read + Seek>(
    mut decoder: TiffDecoder<R>,
    header: Header,
) -> Result<Image, IoError> {
    let samples = match decoder.read_image().map_err(tiff_error)? {
        DecodingResult::U8(s) if header.bit_depth == 8 => Samples::Eight(s),
        DecodingResult::U16(s) if header.bit_depth == 16 => Samples::Sixteen(s),
        _ => {
            return Err(IoError::format(
                "the TIFF samples are not of the type its header declares: re-save the view",
            ))
        }
    };
    let len = match &samples {
        Samples::Eight(s) => s.len(),
        Samples::Sixteen(s) => s.len(),
    };
    if len != header.width * header.height * header.channels {
        return Err(IoError::format(
            "the TIFF image holds fewer samples than its size needs: the file is truncated",
        ));
    }
    Ok(Image {
        width: header.width,
        height: header.height,
        channels: header.channels,
        samples,
    })
}

/// The container a float map (disparity, confidence, depth) is written in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MapFormat {
    /// PFM, one channel, rows bottom-to-top (`.pfm`, or a name without extension such
    /// as `/dev/null`).
    Pfm,
    /// 32-bit float TIFF, one channel (`.tif`, `.tiff`).
    Tiff,
    /// OpenEXR, one 32-bit float channel `Y`, ZIP-compressed (lossless) (`.exr`).
    Exr,
}

/// The extensions float maps may have, as named in errors and help.
pub const MAP_EXTENSIONS: &str = ".pfm, .tif, .tiff or .exr";

/// The container of a float map written to `path`, from its extension (any case); an
/// unknown extension is an error naming the known ones, so that a map is never written
/// in a container its name does not say.
pub fn map_format(path: &Path) -> Result<MapFormat, IoError> {
    let Some(ext) = path.extension() else {
        return Ok(MapFormat::Pfm);
    };
    let lower = ext.to_str().map(str::to_ascii_lowercase);
    match lower.as_deref() {
        Some("pfm") => Ok(MapFormat::Pfm),
        Some("tif" | "tiff") => Ok(MapFormat::Tiff),
        Some("exr") => Ok(MapFormat::Exr),
        _ => Err(IoError::format(format!(
            "maps are written as PFM, 32-bit float TIFF or OpenEXR, told by the name's extension, and .{} is none of them: name the file with {MAP_EXTENSIONS}",
            ext.to_string_lossy()
        ))
        .in_file(path)),
    }
}

/// Whether `path` names a TIFF file (`.tif`, `.tiff`, any case): maps written there are
/// 32-bit float TIFF instead of PFM.
pub fn is_tiff_name(path: &Path) -> bool {
    matches!(map_format(path), Ok(MapFormat::Tiff))
}

/// The one channel's name in the EXR maps: `Y`, which viewers show as gray.
pub const EXR_CHANNEL: &str = "Y";

/// Encodes a one-channel float map (row-major, top row first) as OpenEXR: one 32-bit
/// float channel [`EXR_CHANNEL`], scan lines top to bottom, ZIP compression (lossless:
/// every value, NaN and infinities included, reads back bit for bit).
pub fn encode_float_exr(width: usize, height: usize, values: &[f32]) -> Result<Vec<u8>, IoError> {
    use exr::prelude::{AnyChannel, AnyChannels, Encoding, FlatSamples, Layer, LayerAttributes};
    use exr::prelude::{Image as ExrImage, WritableImage};
    if Some(values.len()) != width.checked_mul(height) {
        return Err(IoError::format(format!(
            "a {width}x{height} map needs {} values but has {}",
            width.saturating_mul(height),
            values.len()
        )));
    }
    let channel = AnyChannel::new(EXR_CHANNEL, FlatSamples::F32(values.to_vec()));
    let layer = Layer::new(
        (width, height),
        LayerAttributes::default(),
        Encoding::SMALL_LOSSLESS,
        AnyChannels::sort(vec![channel].into()),
    );
    let mut out = Cursor::new(Vec::new());
    ExrImage::from_layer(layer)
        .write()
        .non_parallel()
        .to_buffered(&mut out)
        .map_err(|e| IoError::format(format!("OpenEXR encoding failed: {e}")))?;
    Ok(out.into_inner())
}

/// A one-channel float map read from OpenEXR ([`decode_float_exr`]).
#[derive(Clone, Debug, PartialEq)]
pub struct FloatChannel {
    /// Width and height in pixels.
    pub size: (usize, usize),
    /// The channel's name ([`EXR_CHANNEL`] in the maps `estimate` writes).
    pub name: String,
    /// The values, row-major, top row first.
    pub values: Vec<f32>,
}

/// Decodes an OpenEXR image of one 32-bit float channel, as [`encode_float_exr`] writes
/// the maps; any other layout is an error saying what the file holds.
pub fn decode_float_exr(bytes: &[u8]) -> Result<FloatChannel, IoError> {
    use exr::prelude::{FlatSamples, ReadChannels, ReadLayers};
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .non_parallel()
        .from_buffered(Cursor::new(bytes))
        .map_err(|e| IoError::format(format!("OpenEXR decoding failed: {e}")))?;
    let layer = image.layer_data;
    let [channel] = layer.channel_data.list.as_slice() else {
        return Err(IoError::format(format!(
            "an OpenEXR map must hold one channel, this one holds {}",
            layer.channel_data.list.len()
        )));
    };
    let FlatSamples::F32(values) = &channel.sample_data else {
        return Err(IoError::format(format!(
            "the OpenEXR channel `{}` must hold 32-bit float samples",
            channel.name
        )));
    };
    Ok(FloatChannel {
        size: (layer.size.0, layer.size.1),
        name: channel.name.to_string(),
        values: values.clone(),
    })
}

/// Encodes a one-channel float map (row-major, top row first) as a 32-bit float TIFF.
pub fn encode_float_tiff(width: usize, height: usize, values: &[f32]) -> Result<Vec<u8>, IoError> {
    let too_large = || IoError::format(format!("a {width}x{height} map is too large for TIFF"));
    let (w, h) = (
        u32::try_from(width).map_err(|_| too_large())?,
        u32::try_from(height).map_err(|_| too_large())?,
    );
    if values.len() != width * height {
        return Err(IoError::format(format!(
            "a {width}x{height} map needs {} values but has {}",
            width * height,
            values.len()
        )));
    }
    let mut out = Cursor::new(Vec::new());
    let fail = |e: tiff::TiffError| IoError::format(format!("TIFF encoding failed: {e}"));
    tiff::encoder::TiffEncoder::new(&mut out)
        .map_err(fail)?
        .write_image::<tiff::encoder::colortype::Gray32Float>(w, h, values)
        .map_err(fail)?;
    Ok(out.into_inner())
}

/// Writes a float map in the container its extension names ([`map_format`]: PFM,
/// 32-bit float TIFF or OpenEXR); atomically, like every output.
pub fn write_map(path: &Path, map: &super::pfm::Pfm) -> Result<(), IoError> {
    let encoded = match map_format(path)? {
        MapFormat::Pfm => return super::pfm::write(path, map),
        MapFormat::Tiff => encode_float_tiff(map.width, map.height, &map.data),
        MapFormat::Exr => encode_float_exr(map.width, map.height, &map.data),
    };
    write_bytes(path, &encoded.map_err(|e| e.in_file(path))?)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn magic_bytes() {
        assert_eq!(sniff(b"\x89PNG"), Some(Format::Png));
        assert_eq!(sniff(&[0xFF, 0xD8, 0xFF, 0xE0]), Some(Format::Jpeg));
        assert_eq!(sniff(b"II*\0"), Some(Format::Tiff));
        assert_eq!(sniff(b"MM\0*"), Some(Format::Tiff));
        assert_eq!(sniff(b"PF\n1"), None);
        assert_eq!(sniff(b""), None);
    }

    #[test]
    fn float_tiff_round_trips() {
        let values = [0.5f32, -1.25, f32::NAN, 3.0, 1e-7, 7.5];
        let bytes = encode_float_tiff(3, 2, &values).unwrap();
        let mut decoder = TiffDecoder::new(Cursor::new(bytes)).unwrap();
        assert_eq!(decoder.dimensions().unwrap(), (3, 2));
        let DecodingResult::F32(back) = decoder.read_image().unwrap() else {
            panic!("not f32");
        };
        assert_eq!(back.len(), 6);
        for (a, b) in back.iter().zip(values) {
            assert!(a.to_bits() == b.to_bits(), "{a} {b}");
        }
        assert!(encode_float_tiff(3, 3, &values).is_err());
    }

    #[test]
    fn float_exr_round_trips() {
        let values = [0.5f32, -1.25, f32::NAN, 3.0, f32::INFINITY, 7.5];
        let bytes = encode_float_exr(3, 2, &values).unwrap();
        let back = decode_float_exr(&bytes).unwrap();
        assert_eq!(back.size, (3, 2));
        assert_eq!(back.name, EXR_CHANNEL);
        assert_eq!(back.values.len(), values.len());
        assert!(back
            .values
            .iter()
            .zip(values)
            .all(|(a, b)| a.to_bits() == b.to_bits()));
        assert!(encode_float_exr(3, 3, &values).is_err());
        assert!(decode_float_exr(&bytes[..bytes.len() / 2]).is_err());
    }

    #[test]
    fn views_decode_from_memory_by_their_first_bytes() {
        let samples: Vec<u8> = (0..4 * 3 * 3).map(|i| (i * 7) as u8).collect();
        let mut tiff = Cursor::new(Vec::new());
        tiff::encoder::TiffEncoder::new(&mut tiff)
            .unwrap()
            .write_image::<tiff::encoder::colortype::RGB8>(4, 3, &samples)
            .unwrap();
        let tiff = tiff.into_inner();
        let image = decode_limited(&tiff, 12).unwrap();
        assert_eq!((image.width, image.height, image.channels), (4, 3, 3));
        assert!(matches!(&image.samples, Samples::Eight(s) if *s == samples));
        // Over the cap: refused from the header, in words naming the cap.
        let e = decode_limited(&tiff, 11).unwrap_err().to_string();
        assert!(e.contains("TIFF header declares"), "{e}");
        let e = decode_limited(b"\xFF\xD8\xFF\xE0 truncated", 100).unwrap_err();
        assert!(e.to_string().contains("JPEG"), "{e}");
        // A colour type the loader does not take is named in words.
        let mut cmyk = Cursor::new(Vec::new());
        tiff::encoder::TiffEncoder::new(&mut cmyk)
            .unwrap()
            .write_image::<tiff::encoder::colortype::CMYK8>(1, 1, &[1, 2, 3, 4])
            .unwrap();
        let e = decode_limited(&cmyk.into_inner(), 100)
            .unwrap_err()
            .to_string();
        assert!(e.contains("CMYK colour (8-bit samples)"), "{e}");
        assert!(!e.contains(" { ") && !e.contains("CMYK(8)"), "{e}");
        let e = decode_limited(b"GIF89a", 100).unwrap_err();
        assert!(e.to_string().contains("not a PNG, JPEG or TIFF"), "{e}");
    }

    #[test]
    fn map_formats_by_extension() {
        for (name, format) in [
            ("d.pfm", MapFormat::Pfm),
            ("d.PFM", MapFormat::Pfm),
            ("/dev/null", MapFormat::Pfm),
            ("d.tif", MapFormat::Tiff),
            ("d.TIFF", MapFormat::Tiff),
            ("d.exr", MapFormat::Exr),
            ("d.EXR", MapFormat::Exr),
        ] {
            assert_eq!(map_format(Path::new(name)).unwrap(), format, "{name}");
        }
        let e = map_format(Path::new("d.png")).unwrap_err().to_string();
        assert!(
            e.contains("d.png") && e.contains(".png") && e.contains(".exr"),
            "{e}"
        );
    }
}
