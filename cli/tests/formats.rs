//! Round trips and hostile inputs of the file formats (PFM, PNG, parameters.cfg).

mod common;

use lfdepth_cli::io::cfg;
use lfdepth_cli::io::pfm::{self, Endian, Pfm};
use lfdepth_cli::io::png::{self, Image, Samples};

fn ramp(width: usize, height: usize) -> Pfm {
    let data = (0..width * height).map(|i| i as f32 * 0.25 - 3.0).collect();
    Pfm::new(width, height, data).unwrap()
}

#[test]
fn pfm_round_trips_in_both_byte_orders() {
    let mut map = ramp(5, 3);
    map.data[7] = f32::NAN;
    map.data[8] = f32::NEG_INFINITY;
    for endian in [Endian::Little, Endian::Big] {
        let bytes = pfm::encode_with(&map, endian);
        let back = pfm::decode(&bytes).unwrap();
        assert_eq!((back.width, back.height), (5, 3));
        for (a, b) in map.data.iter().zip(&back.data) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }
}

#[test]
fn pfm_rows_are_stored_bottom_up() {
    let map = ramp(2, 3); // top row: -3.0, -2.75
    let bytes = pfm::encode(&map);
    let header = b"Pf\n2 3\n-1\n";
    assert_eq!(&bytes[..header.len()], header);
    let first_stored =
        f32::from_le_bytes(bytes[header.len()..header.len() + 4].try_into().unwrap());
    assert_eq!(first_stored, map.data[4], "the bottom row comes first");
    let big = pfm::encode_with(&map, Endian::Big);
    assert!(big.starts_with(b"Pf\n2 3\n1\n"));
}

#[test]
fn pfm_files_name_themselves_in_errors() {
    let dir = common::temp();
    let path = dir.path().join("bad.pfm");
    // 65536² floats would be 16 GiB: refused before allocating.
    std::fs::write(&path, b"Pf\n65536 65536\n-1\n\0\0\0\0").unwrap();
    let msg = pfm::read(&path).unwrap_err().to_string();
    assert!(
        msg.contains("bad.pfm") && msg.contains("truncated"),
        "{msg}"
    );
    std::fs::write(&path, b"PF\n4294967296 4294967296\n-1\n\0\0\0\0").unwrap();
    let msg = pfm::read(&path).unwrap_err().to_string();
    assert!(msg.contains("bad.pfm") && msg.contains("too many"), "{msg}");
    let msg = pfm::read(&dir.path().join("absent.pfm"))
        .unwrap_err()
        .to_string();
    assert!(msg.contains("absent.pfm"), "{msg}");
}

#[test]
fn pfm_decode_never_panics_on_prefixes_and_bit_flips() {
    let bytes = pfm::encode(&ramp(4, 4));
    for len in 0..bytes.len() {
        let _ = pfm::decode(&bytes[..len]);
    }
    for i in 0..bytes.len() {
        for bit in 0..8 {
            let mut b = bytes.clone();
            b[i] ^= 1 << bit;
            let _ = pfm::decode(&b);
        }
    }
}

#[test]
fn cfg_round_trips_the_shared_cotton_file() {
    let Some(data) = common::shared_data("cfg_round_trips_the_shared_cotton_file") else {
        return;
    };
    let c = cfg::read(&data.join("hci/training/cotton/parameters.cfg")).unwrap();
    assert_eq!(c.grid(), Some((9, 9)));
    assert_eq!(c.focal_length_mm, Some(100.0));
    assert_eq!(c.image_resolution_x_px, Some(512));
    assert_eq!(c.disparity_range(), Some((-1.6, 1.5)));
    assert!(c
        .other
        .iter()
        .any(|(s, k, v)| s == "meta" && k == "scene" && v == "cotton"));
    assert_eq!(cfg::parse(&cfg::write(&c)).unwrap(), c);
}

#[test]
fn cfg_round_trips_a_built_config() {
    let c = cfg::SceneConfig {
        num_cams_x: Some(7),
        num_cams_y: Some(5),
        baseline_mm: Some(0.1 + 0.2),
        disp_min: Some(-2.5),
        disp_max: Some(1e-7),
        other: vec![("custom".into(), "note".into(), "a = b".into())],
        ..Default::default()
    };
    let text = cfg::write(&c);
    assert!(
        text.contains("[extrinsics]") && text.contains("[custom]"),
        "{text}"
    );
    assert_eq!(cfg::parse(&text).unwrap(), c);
}

fn round_trip(image: &Image) {
    let dir = common::temp();
    let path = dir.path().join("x.png");
    png::write(&path, image).unwrap();
    assert_eq!(&png::read(&path).unwrap(), image);
}

#[test]
fn png_round_trips_8_and_16_bit_in_every_channel_count() {
    for channels in 1..=4 {
        round_trip(&common::view(7, 5, channels, channels));
        let samples = (0..7 * 5 * channels)
            .map(|i| (i * 2027 % 65536) as u16)
            .collect();
        round_trip(&Image {
            width: 7,
            height: 5,
            channels,
            samples: Samples::Sixteen(samples),
        });
    }
}

#[test]
fn palette_pngs_are_expanded_to_rgb() {
    let mut bytes = Vec::new();
    {
        let mut encoder = ::png::Encoder::new(&mut bytes, 2, 1);
        encoder.set_color(::png::ColorType::Indexed);
        encoder.set_depth(::png::BitDepth::Eight);
        encoder.set_palette(vec![10, 20, 30, 200, 100, 50]);
        let mut writer = encoder.write_header().unwrap();
        writer.write_image_data(&[1, 0]).unwrap();
    }
    let image = png::decode(&bytes).unwrap();
    assert_eq!(image.channels, 3);
    assert_eq!(
        image.samples,
        Samples::Eight(vec![200, 100, 50, 10, 20, 30])
    );
}

#[test]
fn disparity_png16_keeps_its_mapping() {
    let dir = common::temp();
    let path = dir.path().join("d.png");
    png::write_disparity16(&path, 3, 1, &[-2.0, 0.0, 2.0], -2.0, 2.0).unwrap();
    let image = png::read(&path).unwrap();
    assert_eq!(image.samples, Samples::Sixteen(vec![0, 32768, 65535]));
    let raw = std::fs::read(&path).unwrap();
    let text = String::from_utf8_lossy(&raw);
    assert!(text.contains("disparity_min") && text.contains("disparity_max"));
}

#[test]
fn hostile_pngs_are_errors() {
    assert!(png::decode(&common::png_with_header(0, 16)).is_err());
    let msg = png::decode(&common::png_with_header(1 << 30, 1 << 30))
        .unwrap_err()
        .to_string();
    assert!(!msg.is_empty());
    let good = png::encode(&common::view(16, 16, 3, 1), &[]).unwrap();
    // Cut anywhere before the 12-byte IEND chunk, the pixels are incomplete.
    for len in 0..good.len() - 12 {
        assert!(png::decode(&good[..len]).is_err(), "cut at {len}");
    }
}

#[test]
fn cfg_parse_never_panics_on_mangled_text() {
    let text = "[intrinsics]\nfocal_length_mm = 100.0\n[extrinsics]\nnum_cams_x = 9\n[meta]\ndisp_min = -1.6\n";
    let bytes = text.as_bytes();
    let specials = [b'[', b']', b'=', b'\n', b'#', b' ', b'-', b'9', 0xff];
    for i in 0..bytes.len() {
        for &s in &specials {
            let mut b = bytes.to_vec();
            b[i] = s;
            let _ = cfg::parse(&String::from_utf8_lossy(&b));
        }
        let _ = cfg::parse(&text[..i]);
    }
}
