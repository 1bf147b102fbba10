//! Helpers of the EPI integration tests: minimal HCI loading (PNG views, PFM ground
//! truth), the benchmark's general metrics, and a small analytic light field.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use std::time::Instant;

use lfdepth::epi::EpiParams;
use lfdepth::{Grid, Layout, LightField, Params};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};

/// `../shared/data`, or `None` (with a loud SKIPPED message) when it is absent.
pub fn shared_data(what: &str) -> Option<PathBuf> {
    let dir = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"));
    if dir.is_dir() {
        Some(dir.to_path_buf())
    } else {
        eprintln!("SKIPPED: ../shared/data not found: {what} needs the HCI scenes");
        None
    }
}

/// Reads one 8-bit PNG as interleaved samples; returns (samples, width, height, channels).
pub fn read_png(path: &Path) -> (Vec<u8>, usize, usize, usize) {
    let decoder = png::Decoder::new(std::fs::File::open(path).expect("open png"));
    let mut reader = decoder.read_info().expect("png header");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("png frame");
    assert_eq!(info.bit_depth, png::BitDepth::Eight, "{path:?}");
    let channels = info.color_type.samples();
    buf.truncate(info.width as usize * info.height as usize * channels);
    (buf, info.width as usize, info.height as usize, channels)
}

/// The 9×9 HCI scene in `dir` as packed RGB views (row-major grid).
pub fn load_hci(dir: &Path) -> (Vec<u8>, Layout) {
    let mut data = Vec::new();
    let mut dims = (0, 0);
    for i in 0..81 {
        let (px, w, h, ch) = read_png(&dir.join(format!("input_Cam{i:03}.png")));
        dims = (w, h);
        if ch == 3 {
            data.extend_from_slice(&px);
        } else {
            for p in px.chunks(ch) {
                data.extend_from_slice(&p[..3]);
            }
        }
    }
    (data, Layout::packed(Grid::new(9, 9), dims.0, dims.1, 3))
}

/// A PFM (gray, rows bottom-to-top on disk) as top-to-bottom row-major values.
pub fn read_pfm(path: &Path) -> (Vec<f32>, usize, usize) {
    let bytes = std::fs::read(path).expect("read pfm");
    let mut fields = Vec::new();
    let mut at = 0;
    while fields.len() < 4 {
        while bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        let start = at;
        while !bytes[at].is_ascii_whitespace() {
            at += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..at]).to_string());
    }
    at += 1;
    assert_eq!(fields[0], "Pf");
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let little = fields[3].parse::<f32>().unwrap() < 0.0;
    let mut out = vec![0.0; w * h];
    for row in 0..h {
        for x in 0..w {
            let i = at + (row * w + x) * 4;
            let b = [bytes[i], bytes[i + 1], bytes[i + 2], bytes[i + 3]];
            let v = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
            out[(h - 1 - row) * w + x] = v;
        }
    }
    (out, w, h)
}

/// HCI general metrics on the window 15 px inside the border.
#[derive(Clone, Copy, Debug)]
pub struct Scores {
    pub badpix_007: f64,
    pub badpix_003: f64,
    pub mse100: f64,
    pub q25: f64,
}

pub fn score(est: &[f32], gt: &[f32], w: usize, h: usize) -> Scores {
    let b = 15;
    let (mut bad7, mut bad3, mut n, mut se) = (0usize, 0usize, 0usize, 0f64);
    let mut errs = Vec::new();
    for y in b..h - b {
        for x in b..w - b {
            let e = (est[y * w + x] as f64 - gt[y * w + x] as f64).abs();
            n += 1;
            bad7 += (e > 0.07) as usize;
            bad3 += (e > 0.03) as usize;
            se += e * e;
            errs.push(e * 100.0);
        }
    }
    errs.sort_by(|a, b| a.total_cmp(b));
    Scores {
        badpix_007: 100.0 * bad7 as f64 / n as f64,
        badpix_003: 100.0 * bad3 as f64 / n as f64,
        mse100: 100.0 * se / n as f64,
        q25: errs[errs.len() * 25 / 100],
    }
}

/// A fronto-parallel textured plane at disparity `d` over a `grid` of `w`×`h` RGB views,
/// with a nearer strip in the middle third at `d + 1.5` (u8 samples).
pub fn plane_scene(grid: Grid, w: usize, h: usize, d: f32) -> (Vec<u8>, Layout) {
    let layout = Layout::packed(grid, w, h, 3);
    let (r0, c0) = grid.center();
    let mut data = Vec::with_capacity(layout.validate().unwrap());
    let front = d + 1.5;
    for r in 0..grid.rows {
        for c in 0..grid.cols {
            let (dr, dc) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
            for v in 0..h {
                for u in 0..w {
                    let (fx, fy) = (u as f32 + front * dc, v as f32 + front * dr);
                    let (x, y, p) = if fx >= w as f32 / 3.0 && fx < 2.0 * w as f32 / 3.0 {
                        (fx, fy, 1.0)
                    } else {
                        (u as f32 + d * dc, v as f32 + d * dr, 0.0)
                    };
                    for ch in 0..3 {
                        let ph = p * 1.3 + ch as f32;
                        let t = 0.5
                            + 0.2 * (0.8 * x + 0.3 * y + ph).sin()
                            + 0.15 * (0.3 * x - 0.7 * y + 2.0 * ph).sin()
                            + 0.1 * (1.1 * x + 0.9 * y - ph).sin();
                        data.push((t * 255.0).round().clamp(0.0, 255.0) as u8);
                    }
                }
            }
        }
    }
    (data, layout)
}

/// The EPI stage with `epi` on the HCI scene `scene` (under `../shared/data/hci`): its
/// scores and seconds, or `None` (with a loud SKIPPED line naming `who`) without the data.
pub fn epi_on_hci_scene(who: &str, scene: &str, epi: EpiParams) -> Option<(Scores, f64)> {
    let data = shared_data(who)?;
    let dir = data.join("hci").join(scene);
    let (views, layout) = load_hci(&dir);
    let (gt, w, h) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
    assert_eq!((w, h), (layout.width, layout.height));
    let lf = LightField::new(&views, layout).unwrap();
    let options = EstimateOptions {
        params: Params {
            epi,
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        },
        stage: Stages::Epi,
        threads: None,
    };
    let start = Instant::now();
    let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
    let seconds = start.elapsed().as_secs_f64();
    assert!(e.disparity.iter().all(|v| v.is_finite()));
    Some((score(&e.disparity, &gt, w, h), seconds))
}
