//! JPEG and TIFF views and float-TIFF maps, through the binary: a synthetic scene's
//! views converted with the `tiff` and `jpeg-encoder` crates estimate like the PNGs
//! (8-bit TIFF bit for bit), 16-bit TIFF keeps its precision, the decode caps hold for
//! the new containers, `-o out.tif` writes the PFM's values as 32-bit float TIFF and
//! `-o out.exr` as OpenEXR (NaN included), and a map named with another extension is
//! refused before any work.

mod common;

use std::io::Cursor;
use std::path::{Path, PathBuf};

use common::{arg, assert_fails, lfdepth};
use lfdepth_cli::io::png::{self, Image, Samples};
use lfdepth_cli::io::scene::{self, LoadOptions, Views};
use lfdepth_cli::io::{formats, pfm};
use tiff::encoder::{colortype, TiffEncoder};

/// The `mixed` scene of 48² PNG views in `dir/png`.
fn synth(dir: &Path) -> PathBuf {
    common::synth_scene(&dir.join("png"), "mixed", 48, &[])
}

fn eight_bit(image: &Image) -> &[u8] {
    match &image.samples {
        Samples::Eight(s) => s,
        Samples::Sixteen(_) => panic!("synth writes 8-bit views"),
    }
}

fn tiff_bytes(image: &Image, sixteen: bool) -> Vec<u8> {
    let (w, h) = (image.width as u32, image.height as u32);
    let samples = eight_bit(image);
    let mut out = Cursor::new(Vec::new());
    let mut encoder = TiffEncoder::new(&mut out).unwrap();
    match (image.channels, sixteen) {
        (3, false) => encoder.write_image::<colortype::RGB8>(w, h, samples),
        (3, true) => {
            let wide: Vec<u16> = samples.iter().map(|&v| u16::from(v) * 257).collect();
            encoder.write_image::<colortype::RGB16>(w, h, &wide)
        }
        (1, false) => encoder.write_image::<colortype::Gray8>(w, h, samples),
        other => panic!("unexpected view format {other:?}"),
    }
    .unwrap();
    out.into_inner()
}

fn jpeg_bytes(image: &Image) -> Vec<u8> {
    let mut out = Vec::new();
    let color = match image.channels {
        3 => jpeg_encoder::ColorType::Rgb,
        _ => jpeg_encoder::ColorType::Luma,
    };
    jpeg_encoder::Encoder::new(&mut out, 95)
        .encode(
            eight_bit(image),
            image.width as u16,
            image.height as u16,
            color,
        )
        .unwrap();
    out
}

/// A copy of the scene `from` with every view re-encoded by `encode` under extension
/// `ext` (other files copied).
fn convert(from: &Path, to: &Path, ext: &str, encode: impl Fn(&Image) -> Vec<u8>) {
    std::fs::create_dir_all(to).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let path = entry.unwrap().path();
        let name = path.file_name().unwrap().to_str().unwrap().to_string();
        match name.strip_suffix(".png") {
            Some(stem) => {
                let image = png::read(&path).unwrap();
                std::fs::write(to.join(format!("{stem}.{ext}")), encode(&image)).unwrap();
            }
            None => {
                std::fs::copy(&path, to.join(&name)).unwrap();
            }
        }
    }
}

fn estimate(input: &Path, out: &Path, extra: &[&str]) -> Vec<f32> {
    let mut args = vec![
        "estimate",
        arg(input),
        "-o",
        arg(out),
        "-q",
        "--align",
        "off",
    ];
    args.extend_from_slice(extra);
    let run = lfdepth(&args);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    if out.extension().is_some_and(|e| e == "pfm") {
        pfm::read(out).unwrap().data
    } else {
        Vec::new()
    }
}

fn mean_abs_diff(a: &[f32], b: &[f32]) -> f32 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).sum::<f32>() / a.len() as f32
}

#[test]
fn tiff_and_jpeg_views_estimate_like_png() {
    let dir = common::temp();
    let png_scene = synth(dir.path());
    let reference = estimate(&png_scene, &dir.path().join("png.pfm"), &[]);

    let tif8 = dir.path().join("tif8");
    convert(&png_scene, &tif8, "tif", |i| tiff_bytes(i, false));
    let got = estimate(&tif8, &dir.path().join("tif8.pfm"), &[]);
    assert_eq!(got, reference, "8-bit TIFF holds the PNG's samples");

    let tif16 = dir.path().join("tif16");
    convert(&png_scene, &tif16, "tiff", |i| tiff_bytes(i, true));
    let got = estimate(&tif16, &dir.path().join("tif16.pfm"), &[]);
    // The same intensities as f32: equal up to the rounding of v/255 against v·257/65535.
    let diff = mean_abs_diff(&got, &reference);
    assert!(diff < 0.01, "16-bit TIFF: mean |Δ| {diff}");

    let jpg = dir.path().join("jpg");
    convert(&png_scene, &jpg, "jpg", jpeg_bytes);
    let got = estimate(&jpg, &dir.path().join("jpg.pfm"), &[]);
    let diff = mean_abs_diff(&got, &reference);
    assert!(diff < 0.1, "JPEG at quality 95: mean |Δ| {diff}");
    assert!(diff > 0.0, "JPEG is lossy: the map cannot be the same");
}

#[test]
fn sixteen_bit_tiff_keeps_full_precision() {
    let dir = common::temp();
    // No value is a multiple of 257: 8 bits could not hold any of them.
    let values: Vec<u16> = (0..16 * 16).map(|i| (i * 257 + 1) as u16).collect();
    for i in 0..9 {
        let mut out = Cursor::new(Vec::new());
        TiffEncoder::new(&mut out)
            .unwrap()
            .write_image::<colortype::Gray16>(16, 16, &values)
            .unwrap();
        std::fs::write(
            dir.path().join(format!("input_Cam{i:03}.tif")),
            out.into_inner(),
        )
        .unwrap();
    }
    let scene = scene::load(dir.path(), &LoadOptions::default()).unwrap();
    let Views::F32(data) = &scene.views else {
        panic!("16-bit views load as f32");
    };
    for (got, v) in data.iter().zip(&values) {
        assert_eq!(*got, f32::from(*v) / 65535.0);
    }
}

#[test]
fn decode_caps_hold_for_tiff_and_jpeg() {
    let dir = common::temp();
    let png_scene = synth(dir.path());
    for (ext, name) in [("tif", "tif"), ("jpg", "jpg")] {
        let folder = dir.path().join(name);
        convert(&png_scene, &folder, ext, |i| {
            if ext == "tif" {
                tiff_bytes(i, false)
            } else {
                jpeg_bytes(i)
            }
        });
        let out = dir.path().join("capped.pfm");
        let run = lfdepth(&[
            "estimate",
            arg(&folder),
            "-o",
            arg(&out),
            "--max-view-pixels",
            "1000",
        ]);
        assert_fails(&run, &[&format!(".{ext}"), "--max-view-pixels", "48x48"]);
        assert!(!out.exists());
    }
    // Not an image at all: said so, naming the file.
    let folder = dir.path().join("jpg");
    std::fs::write(folder.join("input_Cam040.jpg"), b"GIF89a not a jpeg").unwrap();
    let run = lfdepth(&[
        "estimate",
        arg(&folder),
        "-o",
        arg(&dir.path().join("x.pfm")),
    ]);
    assert_fails(&run, &["input_Cam040.jpg", "not a PNG, JPEG or TIFF"]);
}

#[test]
fn maps_as_float_tiff() {
    let dir = common::temp();
    let png_scene = synth(dir.path());
    let pfm_out = dir.path().join("d.pfm");
    let tif_out = dir.path().join("d.tif");
    let conf_out = dir.path().join("c.TIFF");
    let reference = estimate(&png_scene, &pfm_out, &[]);
    estimate(&png_scene, &tif_out, &["--confidence", arg(&conf_out)]);
    let read = |path: &Path| {
        let file = std::fs::File::open(path).unwrap();
        let mut decoder = tiff::decoder::Decoder::new(std::io::BufReader::new(file)).unwrap();
        assert_eq!(decoder.dimensions().unwrap(), (48, 48));
        match decoder.read_image().unwrap() {
            tiff::decoder::DecodingResult::F32(v) => v,
            _ => panic!("{} is not a float TIFF", path.display()),
        }
    };
    let got = read(&tif_out);
    assert!(got
        .iter()
        .zip(&reference)
        .all(|(a, b)| a.to_bits() == b.to_bits()));
    assert!(read(&conf_out).iter().all(|c| (0.0..=1.0).contains(c)));
}

/// The one float channel of an OpenEXR file, its size and the channel's name.
fn read_exr(path: &Path) -> ((usize, usize), String, Vec<f32>) {
    let bytes = std::fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let channel =
        formats::decode_float_exr(&bytes).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    (channel.size, channel.name, channel.values)
}

fn same_bits(a: &[f32], b: &[f32]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[test]
fn maps_as_openexr() {
    let dir = common::temp();
    let png_scene = synth(dir.path());
    // Camera parameters for --depth, focused so far away that every negative disparity
    // lies beyond infinity: the depth map holds NaN there.
    let cfg = png_scene.join("parameters.cfg");
    let text = std::fs::read_to_string(&cfg)
        .unwrap()
        .replace(
            "image_resolution_x_px = 48",
            "image_resolution_x_px = 48\nfocal_length_mm = 100\nsensor_size_mm = 35",
        )
        .replace(
            "num_cams_y = 9",
            "num_cams_y = 9\nbaseline_mm = 90\nfocus_distance_m = 1000",
        );
    std::fs::write(&cfg, text).unwrap();
    let out = |name: &str| dir.path().join(name);
    let reference = estimate(
        &png_scene,
        &out("d.pfm"),
        &[
            "--confidence",
            arg(&out("c.pfm")),
            "--depth",
            arg(&out("z.pfm")),
        ],
    );
    estimate(
        &png_scene,
        &out("d.exr"),
        &[
            "--confidence",
            arg(&out("c.EXR")),
            "--depth",
            arg(&out("z.exr")),
        ],
    );
    for (exr, pfm) in [("d.exr", "d.pfm"), ("c.EXR", "c.pfm"), ("z.exr", "z.pfm")] {
        let (size, name, values) = read_exr(&out(exr));
        let pfm = pfm::read(&out(pfm)).unwrap();
        assert_eq!(size, (pfm.width, pfm.height), "{exr}");
        assert_eq!(name, "Y", "{exr}");
        // Same values in the same order: both top row first, so the orientation holds.
        assert!(same_bits(&values, &pfm.data), "{exr} differs from its PFM");
    }
    assert!(same_bits(&read_exr(&out("d.exr")).2, &reference));
    let depth = read_exr(&out("z.exr")).2;
    assert!(
        depth.iter().any(|z| z.is_nan()) && depth.iter().any(|z| z.is_finite()),
        "the depth map should hold NaN and finite depths"
    );
    // Not a symmetric picture: a flip of rows or columns would not compare equal.
    let (w, h) = (48, 48);
    let flipped: Vec<f32> = (0..w * h)
        .map(|i| reference[(h - 1 - i / w) * w + i % w])
        .collect();
    assert!(!same_bits(&flipped, &reference));
}

#[test]
fn a_map_with_an_unknown_extension_is_refused_before_any_work() {
    let dir = common::temp();
    let png_scene = synth(dir.path());
    // A corrupt view: had the views been decoded first, the error would be about it.
    std::fs::write(png_scene.join("input_Cam040.png"), b"not a png").unwrap();
    for flag in ["-o", "--confidence", "--depth"] {
        let bad = dir.path().join("map.png");
        let ok = dir.path().join("d.pfm");
        let mut args = vec!["estimate", arg(&png_scene), "-q"];
        if flag == "-o" {
            args.extend(["-o", arg(&bad)]);
        } else {
            args.extend(["-o", arg(&ok), flag, arg(&bad)]);
        }
        let msg = assert_fails(
            &lfdepth(&args),
            &[
                flag,
                "map.png",
                ".png is none of them",
                ".pfm, .tif, .tiff or .exr",
            ],
        );
        assert!(!msg.contains("input_Cam040"), "{msg}");
        assert!(!bad.exists() && !ok.exists());
    }
}

#[test]
fn a_jpeg_the_decoder_panics_on_is_an_error_in_words() {
    // Found by the view_decode fuzz target: a 24x20 JPEG whose second colour component
    // is sampled more finely than the first makes zune-jpeg panic in its IDCT.
    let kept = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../fuzz/regressions/view_decode/jpeg-chroma-sampled-finer-than-luma"
    );
    // The target's first byte (0: the bytes as they are) is not part of the file.
    let bytes = std::fs::read(kept).unwrap()[1..].to_vec();
    let dir = common::temp();
    let views = dir.path().join("views");
    std::fs::create_dir(&views).unwrap();
    for i in 0..9 {
        std::fs::write(views.join(format!("input_Cam{i:03}.jpg")), &bytes).unwrap();
    }
    let out = dir.path().join("d.pfm");
    let msg = assert_fails(
        &lfdepth(&[
            "estimate",
            arg(&views),
            "-o",
            arg(&out),
            "-q",
            "--align",
            "off",
        ]),
        &[".jpg", "not a readable JPEG image", "re-save the view"],
    );
    assert!(!msg.contains("panicked"), "{msg}");
    assert!(!out.exists());
}
