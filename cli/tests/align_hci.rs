//! Alignment on the shared real data (`../shared/data`): the rectified HCI scenes and
//! the Lytro capture must be recognised as rectified (auto leaves them alone), and HCI
//! scenes misaligned with synth-style homographies must be realigned to within 0.1 px
//! reprojection error. Heavy: run with `cargo test --release`.

mod align_scene;

use std::path::{Path, PathBuf};
use std::time::Instant;

use lfdepth::align::{self, gauge_fit, reprojection_rms, AlignMode, AlignParams};
use lfdepth::metrics::{self, EvalOptions, Scores, BORDER};
use lfdepth::{Grid, Homography, Layout, LightField, Params};
use lfdepth_cli::engine::{self, EstimateOptions, StageSelect};

/// A packed RGB light field and its layout.
type Loaded = (Vec<u8>, Layout);

fn data_dir() -> PathBuf {
    PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/data"))
}

/// Reads an 8-bit RGB(A) or gray PNG as RGB.
fn read_rgb(path: &Path) -> Option<(usize, usize, Vec<u8>)> {
    let decoder = png::Decoder::new(std::fs::File::open(path).ok()?);
    let mut reader = decoder.read_info().ok()?;
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).ok()?;
    if info.bit_depth != png::BitDepth::Eight {
        return None;
    }
    let (w, h) = (info.width as usize, info.height as usize);
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        png::ColorType::Grayscale => 1,
        _ => return None,
    };
    let mut rgb = Vec::with_capacity(w * h * 3);
    for px in buf[..w * h * channels].chunks_exact(channels) {
        if channels == 1 {
            rgb.extend_from_slice(&[px[0]; 3]);
        } else {
            rgb.extend_from_slice(&px[..3]);
        }
    }
    Some((w, h, rgb))
}

/// 9×9 views named by `name(row, col)` in `dir`, packed RGB.
fn load(dir: &Path, name: &dyn Fn(usize, usize) -> String) -> Option<Loaded> {
    let mut data = Vec::new();
    let mut size = None;
    for r in 0..9 {
        for c in 0..9 {
            let (w, h, rgb) = read_rgb(&dir.join(name(r, c)))?;
            if *size.get_or_insert((w, h)) != (w, h) {
                return None;
            }
            data.extend_from_slice(&rgb);
        }
    }
    let (w, h) = size?;
    Some((data, Layout::packed(Grid::new(9, 9), w, h, 3)))
}

fn hci(scene: &str) -> Option<Loaded> {
    load(&data_dir().join("hci").join(scene), &|r, c| {
        format!("input_Cam{:03}.png", r * 9 + c)
    })
}

fn lytro() -> Option<Loaded> {
    load(&data_dir().join("real/lytro-2067"), &|r, c| {
        format!("2067_{:02}_{:02}.png", r + 1, c + 1)
    })
}

/// A little-endian or big-endian gray PFM as top-row-first f32.
fn read_pfm(path: &Path) -> Option<(usize, usize, Vec<f32>)> {
    let bytes = std::fs::read(path).ok()?;
    let mut fields = Vec::new();
    let mut start = 0;
    let mut pos = 0;
    while fields.len() < 4 && pos < bytes.len() {
        if bytes[pos].is_ascii_whitespace() {
            if pos > start {
                fields.push(std::str::from_utf8(&bytes[start..pos]).ok()?.to_string());
            }
            start = pos + 1;
        }
        pos += 1;
    }
    if fields.len() < 4 || fields[0] != "Pf" {
        return None;
    }
    let (w, h): (usize, usize) = (fields[1].parse().ok()?, fields[2].parse().ok()?);
    let little = fields[3].parse::<f32>().ok()? < 0.0;
    let body = bytes.get(start..start + w * h * 4)?;
    let mut out = vec![0.0f32; w * h];
    for (i, c) in body.chunks_exact(4).enumerate() {
        let b = [c[0], c[1], c[2], c[3]];
        let v = if little {
            f32::from_le_bytes(b)
        } else {
            f32::from_be_bytes(b)
        };
        // Rows are stored bottom to top.
        let (x, y) = (i % w, h - 1 - i / w);
        out[y * w + x] = v;
    }
    Some((w, h, out))
}

fn epi_scores(data: &[u8], layout: Layout, gt: &[f32], adjust: &dyn Fn(f32) -> f32) -> Scores {
    let lf = LightField::new(data, layout).unwrap();
    let options = EstimateOptions {
        params: Params::default(),
        stage: StageSelect::Epi,
        threads: None,
    };
    let est: Vec<f32> = engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
        .iter()
        .map(|&d| adjust(d))
        .collect();
    let (w, h) = (layout.width, layout.height);
    let mut scratch = vec![0.0f32; metrics::scratch_len(w, h)];
    let eval = EvalOptions {
        border: BORDER,
        mask: None,
    };
    metrics::evaluate(&est, gt, w, h, &eval, &mut scratch).unwrap()
}

fn run(data: &[u8], layout: Layout, params: &AlignParams) -> (align::AlignReport, Vec<Homography>) {
    let lf = LightField::new(data, layout).unwrap();
    let mut hs = vec![Homography::IDENTITY; 81];
    let mut scratch = vec![0.0f32; align::scratch_len(&layout, params).unwrap()];
    let (t, cpu) = (Instant::now(), align_scene::thread_cpu_ns());
    let report = align::estimate(&lf, params, &mut hs, &mut scratch)
        .unwrap_or_else(|e| panic!("{params:?}: {e}"));
    eprintln!(
        "  {:?}: {:.1} ms wall, {:.1} ms on-CPU",
        params.mode,
        t.elapsed().as_secs_f64() * 1e3,
        (align_scene::thread_cpu_ns() - cpu) as f64 * 1e-6
    );
    (report, hs)
}

#[test]
fn rectified_real_arrays_are_left_alone() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 512x512 test, run it with `cargo test --release`");
        return;
    }
    let scenes: [(&str, Option<Loaded>); 3] = [
        ("hci/stratified/backgammon", hci("stratified/backgammon")),
        ("hci/training/cotton", hci("training/cotton")),
        ("real/lytro-2067", lytro()),
    ];
    for (name, loaded) in scenes {
        let Some((data, layout)) = loaded else {
            eprintln!("SKIPPED: ../shared/data not found: {name} is missing or unreadable");
            continue;
        };
        let (report, hs) = run(&data, layout, &AlignParams::default());
        eprintln!(
            "{name}: skipped {} identity RMS {:.4} px, warning {:?}",
            report.skipped, report.identity_rms, report.warning
        );
        assert!(
            report.skipped && report.warning.is_none(),
            "{name}: {report:?}"
        );
        assert!(hs.iter().all(|h| *h == Homography::IDENTITY));
        // Forced alignment agrees that there is (almost) nothing to undo.
        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let (report, hs) = run(&data, layout, &on);
        let (w, h) = (layout.width, layout.height);
        let identity = vec![Homography::IDENTITY; 81];
        let change =
            reprojection_rms(&identity, &hs, layout.grid, w, h, &[-1.5, 0.0, 1.5]).unwrap();
        eprintln!(
            "{name}: forced alignment moves the array by {change:.4} px (reprojection), track RMS {:.4} -> {:.4}",
            report.identity_rms, report.rms
        );
    }
}

#[test]
fn misaligned_hci_scenes_are_realigned() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 512x512 test, run it with `cargo test --release`");
        return;
    }
    for scene in ["stratified/backgammon", "training/cotton"] {
        let Some((data, layout)) = hci(scene) else {
            eprintln!("SKIPPED: ../shared/data not found: hci/{scene} is missing or unreadable");
            continue;
        };
        let (w, h) = (layout.width, layout.height);
        let o = ((w as f32 - 1.0) * 0.5, (h as f32 - 1.0) * 0.5);
        // Synth-style misalignment: up to 2°, 3 px, 1 %, a little perspective.
        let truth: Vec<Homography> = (0..81u32)
            .map(|v| {
                let u = |k| align_scene::unit(v * 8 + 5000, k);
                align_scene::misalignment(
                    o,
                    2.0 * u(0),
                    (3.0 * u(1), 3.0 * u(2)),
                    0.01 * u(3),
                    (1e-5 * u(4), 1e-5 * u(5)),
                )
            })
            .collect();
        // Observed view = ideal view resampled at H⁻¹: warp with the inverses.
        let inverses: Vec<Homography> = truth.iter().map(|t| t.inverse().unwrap()).collect();
        let lf = LightField::new(&data[..], layout).unwrap();
        let mut misaligned = vec![0u8; data.len()];
        align::warp_band(&lf, &inverses, 0..h, &mut misaligned).unwrap();

        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let (report, hs) = run(&misaligned, layout, &on);
        let disparities = [-1.5, 0.0, 1.5];
        let identity = vec![Homography::IDENTITY; 81];
        let before = reprojection_rms(&identity, &truth, layout.grid, w, h, &disparities).unwrap();
        let after = reprojection_rms(&hs, &truth, layout.grid, w, h, &disparities).unwrap();
        eprintln!(
            "hci/{scene}: reprojection {before:.3} -> {after:.4} px, track RMS {:.4}, {} corners",
            report.rms, report.features
        );
        assert!(after < 0.1, "{scene}: {after}");
        // Disparity accuracy of the EPI stage: original, misaligned, realigned (the
        // unobservable disparity offset and scale removed, see `align::gauge_fit`).
        if let Some((_, _, gt)) = read_pfm(
            &data_dir()
                .join("hci")
                .join(scene)
                .join("gt_disp_lowres.pfm"),
        ) {
            let gauge = gauge_fit(&hs, &truth, layout.grid, w, h).unwrap();
            let mut aligned = vec![0u8; data.len()];
            let lf = LightField::new(&misaligned[..], layout).unwrap();
            align::warp_band(&lf, &hs, 0..h, &mut aligned).unwrap();
            let mut oracle = vec![0u8; data.len()];
            align::warp_band(&lf, &truth, 0..h, &mut oracle).unwrap();
            let same = |d: f32| d;
            let corrected = |d: f32| (d + gauge.disparity_offset) / gauge.scale;
            for (label, views, adjust) in [
                ("original (rectified)", &data, &same as &dyn Fn(f32) -> f32),
                ("misaligned, not aligned", &misaligned, &same),
                ("misaligned, warped with the true H", &oracle, &same),
                ("misaligned, aligned (raw)", &aligned, &same),
                ("misaligned, aligned (offset removed)", &aligned, &corrected),
            ] {
                let s = epi_scores(views, layout, &gt, adjust);
                eprintln!(
                    "| {scene} | {label} | {:.2} | {:.2} | {:.2} |",
                    s.badpix_007, s.mse100, s.q25
                );
            }
            eprintln!(
                "{scene}: disparity offset {:.4} px, scale {:.5}",
                gauge.disparity_offset, gauge.scale
            );
        }
        let (auto, _) = run(&misaligned, layout, &AlignParams::default());
        assert!(
            !auto.skipped,
            "{scene}: auto missed the misalignment: {auto:?}"
        );
    }
}
