//! Helpers shared by the TV integration tests, benches and examples (included with
//! `#[path]`): PFM and PNG loading, the HCI scores, and the light field around one guide
//! image.
#![allow(dead_code)]

use std::fs;
use std::path::{Path, PathBuf};

use std::time::Instant;

use lfdepth::tv::{self, Guide, Maps, TvParams};
use lfdepth::{Grid, Layout, LightField, Params, Plan};

/// The environment variable `name` as a number, or `default` when unset or unparsable
/// (the `tv_refine_pfm` example takes its parameters this way).
pub fn env_f32(name: &str, default: f32) -> f32 {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// `../shared/data`, or `None` with a loud SKIPPED line.
pub fn shared_data(test: &str) -> Option<PathBuf> {
    let dir = PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"));
    if dir.is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: ../shared/data not found: {test} needs the HCI scenes");
        None
    }
}

/// A PFM (one channel) as (width, height, row-major values, top row first).
pub fn read_pfm(path: &Path) -> (usize, usize, Vec<f32>) {
    let bytes = fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut fields = Vec::new();
    let mut pos = 0;
    while fields.len() < 4 {
        while bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        let start = pos;
        while !bytes[pos].is_ascii_whitespace() {
            pos += 1;
        }
        fields.push(String::from_utf8_lossy(&bytes[start..pos]).to_string());
    }
    pos += 1;
    assert_eq!(fields[0], "Pf", "{}: only one-channel PFM", path.display());
    let (w, h): (usize, usize) = (fields[1].parse().unwrap(), fields[2].parse().unwrap());
    let little = fields[3].parse::<f32>().unwrap() < 0.0;
    let mut out = vec![0.0f32; w * h];
    for row in 0..h {
        for x in 0..w {
            let o = pos + 4 * (row * w + x);
            let b = [bytes[o], bytes[o + 1], bytes[o + 2], bytes[o + 3]];
            let v = if little {
                f32::from_le_bytes(b)
            } else {
                f32::from_be_bytes(b)
            };
            out[(h - 1 - row) * w + x] = v;
        }
    }
    (w, h, out)
}

/// Writes a one-channel little-endian PFM (rows bottom-to-top).
pub fn write_pfm(path: &Path, w: usize, h: usize, data: &[f32]) {
    let mut bytes = format!("Pf\n{w} {h}\n-1\n").into_bytes();
    for row in (0..h).rev() {
        for v in &data[row * w..(row + 1) * w] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
    }
    fs::write(path, bytes).unwrap();
}

/// An 8-bit RGB PNG as (width, height, packed RGB).
pub fn read_rgb_png(path: &Path) -> (usize, usize, Vec<u8>) {
    let decoder = png::Decoder::new(fs::File::open(path).unwrap());
    let mut reader = decoder.read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).unwrap();
    let (w, h) = (info.width as usize, info.height as usize);
    let ch = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Grayscale => 1,
        other => panic!("unsupported PNG colour type {other:?}"),
    };
    let mut rgb = Vec::with_capacity(w * h * 3);
    for p in buf[..w * h * ch].chunks_exact(ch) {
        if ch == 1 {
            rgb.extend_from_slice(&[p[0]; 3]);
        } else {
            rgb.extend_from_slice(&p[..3]);
        }
    }
    (w, h, rgb)
}

/// A 3×3 light field whose every view is `image` (only the centre view is used as guide),
/// with its plan.
pub fn guide_light_field(w: usize, h: usize, image: &[u8], params: Params) -> (Vec<u8>, Plan) {
    let layout = Layout::packed(Grid::new(3, 3), w, h, 3);
    let data: Vec<u8> = (0..9).flat_map(|_| image.iter().copied()).collect();
    let plan = Plan::new(layout, params).unwrap();
    (data, plan)
}

/// Borrows the light field of [`guide_light_field`].
pub fn light_field<'a>(data: &'a [u8], plan: &Plan) -> LightField<'a, u8> {
    LightField::new(data, *plan.layout()).unwrap()
}

/// HCI scores inside the 15-pixel border: (BadPix0.07 in %, MSE×100).
pub fn scores(est: &[f32], gt: &[f32], w: usize, h: usize) -> (f64, f64) {
    let border = 15;
    let (mut bad, mut se, mut n) = (0usize, 0.0f64, 0usize);
    for y in border..h - border {
        for x in border..w - border {
            let e = (est[y * w + x] - gt[y * w + x]) as f64;
            bad += usize::from(e.abs() > 0.07);
            se += e * e;
            n += 1;
        }
    }
    (100.0 * bad as f64 / n as f64, 100.0 * se / n as f64)
}

/// The 81 views of an HCI scene, packed RGB, with their layout.
pub fn load_hci(dir: &Path) -> (Vec<u8>, Layout) {
    let mut data = Vec::new();
    let (mut w, mut h) = (0, 0);
    for i in 0..81 {
        let (vw, vh, rgb) = read_rgb_png(&dir.join(format!("input_Cam{i:03}.png")));
        (w, h) = (vw, vh);
        data.extend_from_slice(&rgb);
    }
    (data, Layout::packed(Grid::new(9, 9), w, h, 3))
}

/// CPU seconds (user + system, all threads) of this process so far, from /proc.
pub fn cpu_seconds() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat
        .rsplit(')')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .collect();
    let ticks = |i: usize| {
        fields
            .get(i)
            .and_then(|v| v.parse::<f64>().ok())
            .unwrap_or(0.0)
    };
    // Fields 14 and 15 of stat (utime, stime), counted after the command name.
    (ticks(11) + ticks(12)) / 100.0
}

/// The benches' 9×9×512×512 scene: HCI cotton when `../shared/data` is present, else a
/// synthetic Mixed one (said on stderr); its views, layout and name.
pub fn bench_scene() -> (Vec<u8>, Layout, &'static str) {
    let cotton = std::path::PathBuf::from(concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/../../shared/data/hci/training/cotton"
    ));
    if cotton.is_dir() {
        let (views, layout) = load_hci(&cotton);
        return (views, layout, "cotton");
    }
    eprintln!("../shared/data not found: benchmarking a synthetic Mixed scene instead");
    let spec =
        lfdepth::synth::SynthSpec::new(lfdepth::synth::SceneKind::Mixed, Grid::new(9, 9), 512, 512);
    let layout = spec.layout();
    let mut views = vec![0u8; layout.validate().unwrap()];
    let mut gt = vec![0.0f32; 512 * 512];
    let mut homographies = vec![lfdepth::Homography::IDENTITY; 81];
    lfdepth::synth::render(&spec, &mut views, &mut gt, &mut homographies).unwrap();
    (views, layout, "synthetic")
}

/// Refines `disparity` with confidence `confidence` guided by the scene's centre view:
/// the refined map, the residual history, the report and the seconds it took.
pub fn refine_guided<S: lfdepth::Scalar>(
    scene: &std::path::Path,
    disparity: &[f32],
    confidence: &[f32],
    params: TvParams,
) -> (Vec<f32>, Vec<f32>, tv::RefineReport, f64) {
    let (w, h, rgb) = read_rgb_png(&scene.join("input_Cam040.png"));
    let (data, plan) = guide_light_field(
        w,
        h,
        &rgb,
        Params {
            tv: params,
            ..Params::default()
        },
    );
    let lf = light_field(&data, &plan);
    let maps = Maps::new(w, h, disparity, confidence).unwrap();
    let guide = Guide::View(lf.center_view());
    let mut out = vec![0.0f32; w * h];
    let mut history = vec![0.0f32; params.max_iterations];
    let mut scratch = vec![S::ZERO; tv::scratch_len(plan.tv())];
    let t = Instant::now();
    let report = tv::refine(
        plan.tv(),
        &maps,
        &guide,
        &mut out,
        &mut history,
        tv::TvScratch {
            kernel: &mut scratch,
            duals: &mut vec![0.0; tv::dual_len(plan.tv())],
        },
    )
    .unwrap();
    let secs = t.elapsed().as_secs_f64();
    (out, history, report, secs)
}
