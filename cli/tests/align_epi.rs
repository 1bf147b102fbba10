//! End-to-end effect of alignment on the EPI disparity: synthetic 9×9 arrays
//! (`lfdepth::synth`) rendered rectified and misaligned (2°, 3 px, 1 %, perspective);
//! the misaligned array, aligned and warped as the pipeline does (its default
//! interpolation, into `f32`), is scored against the perfectly aligned array (goal: BadPix0.07 within 10 %
//! relative; measured numbers in docs/stages/align.md) and against a warp with the true
//! homographies. The disparity plane that no image can observe (see `align::gauge_fit`)
//! is removed before scoring and reported.
//! Run with `cargo test --release` (skipped in debug builds: too slow there).

use lfdepth::align::{
    self, gauge_fit_where, warp_rows_with, AlignMode, AlignModel, AlignParams, AlignedViews,
    Interpolation, Reference,
};
use lfdepth::metrics::{self, EvalOptions, BORDER};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{pipeline, Grid, Homography, LightField, Params, Plan, Sample};
use lfdepth_cli::engine::{self, EstimateOptions, Stages};

const SIZE: usize = 384;

fn epi<S: Sample + Sync>(data: &[S], spec: &SynthSpec) -> Vec<f32> {
    let lf = LightField::new(data, spec.layout()).unwrap();
    let options = EstimateOptions {
        params: Params::default(),
        stage: Stages::Epi,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

fn badpix(est: &[f32], gt: &[f32], n: usize) -> f64 {
    badpix_border(est, gt, n, BORDER)
}

fn badpix_border(est: &[f32], gt: &[f32], n: usize, border: usize) -> f64 {
    let mut scratch = vec![0.0f32; metrics::scratch_len(n, n)];
    let options = EvalOptions { border, mask: None };
    metrics::evaluate(est, gt, n, n, &options, &mut scratch)
        .unwrap()
        .badpix_007
}

/// Every view of `lf` warped by `hs` into `f32` (the pipeline warps only the views the
/// stages read; the EPI stage reads only those).
fn warp_all(lf: &LightField<'_, u8>, hs: &[Homography], how: Interpolation) -> Vec<f32> {
    let l = lf.layout();
    let view = l.width * l.height * l.channels;
    let mut out = vec![0.0f32; l.validate().unwrap()];
    for (v, chunk) in out.chunks_exact_mut(view).enumerate() {
        warp_rows_with(lf, hs, v, 0..l.height, how, chunk).unwrap();
        align::finish_view(l, hs, v, how, chunk).unwrap();
    }
    out
}

/// The scene rendered rectified and misaligned: (rectified views, misaligned views,
/// ground truth, true homographies).
fn scenes(scene: SceneKind, n: usize) -> (SynthSpec, Vec<u8>, Vec<u8>, Vec<f32>, Vec<Homography>) {
    let mut spec = SynthSpec::new(scene, Grid::new(9, 9), n, n);
    spec.seed = 11;
    let views = spec.grid.len();
    let mut ideal = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; n * n];
    let mut hs = vec![Homography::IDENTITY; views];
    synth::render(&spec, &mut ideal, &mut gt, &mut hs).unwrap();
    spec.misalign = Some(Misalignment {
        max_rotation_deg: 2.0,
        max_translation_px: 3.0,
        max_scale: 0.01,
        max_perspective: 0.002,
    });
    let mut misaligned = vec![0u8; ideal.len()];
    let mut truth = vec![Homography::IDENTITY; views];
    synth::render(&spec, &mut misaligned, &mut gt, &mut truth).unwrap();
    (spec, ideal, misaligned, gt, truth)
}

fn estimate(lf: &LightField<'_, u8>, params: AlignParams) -> (Vec<Homography>, f32) {
    let mut est = vec![Homography::IDENTITY; lf.grid().len()];
    let mut scratch = vec![0.0f32; align::scratch_len(lf.layout(), &params).unwrap()];
    let report = align::estimate(lf, &params, &mut est, &mut scratch).unwrap();
    eprintln!(
        "  estimate {:?}/{:?}: disparity shift {:+.4} px, coherence {:.3}",
        params.views, params.disparity_step, report.disparity_shift, report.disparity_coherence
    );
    (est, report.rms)
}

#[test]
fn aligned_arrays_score_like_rectified_ones() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 384x384 test, run it with `cargo test --release`");
        return;
    }
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = badpix(&epi(&ideal, &spec), &gt, n);
        let unaligned = badpix(&epi(&misaligned, &spec), &gt, n);
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        // The best any estimate can do with this warp: the true homographies.
        let oracle = badpix(
            &epi(&warp_all(&lf, &truth, Interpolation::default()), &spec),
            &gt,
            n,
        );
        eprintln!("{name} {n}x{n}: BadPix0.07 rectified {reference:.2}, misaligned {unaligned:.2}, warped with the true homographies {oracle:.2}");
        // The pipeline estimates the cross only (all its stages read by default).
        let variants = [
            (
                AlignModel::PerView,
                Reference::Estimated,
                AlignedViews::Cross,
            ),
            (AlignModel::PerView, Reference::Estimated, AlignedViews::All),
            (
                AlignModel::PerView,
                Reference::CentreView,
                AlignedViews::All,
            ),
            (
                AlignModel::PlanePatches,
                Reference::Estimated,
                AlignedViews::All,
            ),
        ];
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        for (model, frame, views) in variants {
            let params = AlignParams {
                mode: AlignMode::On,
                model,
                reference: frame,
                views,
                ..AlignParams::default()
            };
            let (est, rms) = estimate(&lf, params);
            let raw = epi(&warp_all(&lf, &est, params.interpolation), &spec);
            let include = |v: usize| views == AlignedViews::All || v / cols == r0 || v % cols == c0;
            let gauge = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
            let remove_gauge = |raw: &[f32]| -> Vec<f32> {
                raw.iter()
                    .enumerate()
                    .map(|(i, &d)| gauge.true_disparity(d, (i % n) as f32, (i / n) as f32))
                    .collect()
            };
            let corrected = remove_gauge(&raw);
            // The true homographies moved into the estimate's gauge: what a perfect
            // estimate with the same (unobservable) disparity plane would score.
            let b = |v: usize| ((v % cols) as f32 - c0 as f32, (v / cols) as f32 - r0 as f32);
            let in_gauge: Vec<Homography> = (0..truth.len())
                .map(|v| {
                    if include(v) {
                        truth[v].compose(&gauge_map(&gauge, b(v)).inverse().unwrap())
                    } else {
                        Homography::IDENTITY
                    }
                })
                .collect();
            let ideal_estimate =
                remove_gauge(&epi(&warp_all(&lf, &in_gauge, params.interpolation), &spec));
            let (raw_score, score) = (badpix(&raw, &gt, n), badpix(&corrected, &gt, n));
            let ideal_score = badpix(&ideal_estimate, &gt, n);
            eprintln!(
                "{name} {n}x{n} {model:?}/{frame:?}/{views:?}: BadPix0.07 aligned {raw_score:.2} raw, {score:.2} ({:+.1} % vs rectified; true H in the same gauge {ideal_score:.2}, {:+.1} %) after the unobservable disparity plane {:.4} px + ({:.2e}, {:.2e}) px/px, scale {:.5} (track RMS {rms:.4}, registration {:.3} px)",
                100.0 * (score / reference - 1.0),
                100.0 * (ideal_score / reference - 1.0),
                gauge.disparity_offset,
                gauge.disparity_slope.0,
                gauge.disparity_slope.1,
                gauge.scale,
                gauge.rms,
            );
            assert!(
                score < 0.1 * unaligned,
                "{name} {model:?}/{frame:?}/{views:?}: {score} vs unaligned {unaligned}"
            );
            // What the estimated homographies themselves cost, beyond the true ones in the
            // same gauge (measured ≤ 1.5 % with the per-view model).
            assert!(
                model == AlignModel::PlanePatches || score <= 1.03 * ideal_score,
                "{name} {model:?}/{frame:?}/{views:?}: {score} vs {ideal_score} with the true homographies"
            );
            // The goal is 10 % relative BadPix0.07. Measured: +7.3 … +8.8 % for every
            // per-view variant except `planes` with the cross (the pipeline's default),
            // +10.8 %, where the true homographies in the same gauge score the same
            // (+10.4 %): what is left is the bilinear warp. So this guards against
            // regressions at 12 % (docs/stages/align.md). On `planes` the
            // gauge offset on the EPI stage's shears (`AlignParams::disparity_step`)
            // matters: without it the unobservable offset alone cost 6–12 %.
            assert!(
                model == AlignModel::PlanePatches || score <= 1.12 * reference,
                "{name} {model:?}/{frame:?}/{views:?}: {score} vs {reference}"
            );
        }
    }
}

/// The goal for the whole pipeline: the final disparity (every stage) of the
/// misaligned arrays through the CLI engine with `align = on` (the pipeline's defaults:
/// cross-only estimate, sharpened bilinear warp, the refinement's sampling slack on the
/// warped views), after the unobservable disparity plane, within 10 % relative
/// BadPix0.07 of the perfectly aligned scene through the same engine (measured:
/// `planes` +6.4 %, `mixed` −0.7 %; docs/stages/align.md).
#[test]
fn the_final_disparity_of_aligned_arrays_is_within_ten_percent() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 384x384 test, run it with `cargo test --release`");
        return;
    }
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = badpix(
            &engine_map(&ideal, &spec, Params::default(), Stages::Full),
            &gt,
            n,
        );
        let mut params = Params::default();
        params.align.mode = AlignMode::On;
        let raw = engine_map(&misaligned, &spec, params, Stages::Full);
        // The engine's estimate is the core's, bit for bit (`align_synthetic`): the same
        // homographies give the gauge plane its map was computed in.
        let plan = Plan::new(spec.layout(), params).unwrap();
        let (est, _) = estimate(
            &LightField::new(&misaligned[..], spec.layout()).unwrap(),
            pipeline::align_params(&plan, pipeline::Stages::Full),
        );
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        let include = |v: usize| v / cols == r0 || v % cols == c0;
        let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
        let fixed: Vec<f32> = raw
            .iter()
            .enumerate()
            .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
            .collect();
        let score = badpix(&fixed, &gt, n);
        eprintln!(
            "{name} {n}x{n}: final BadPix0.07 rectified {reference:.3}, aligned {score:.3} ({:+.1} %)",
            100.0 * (score / reference - 1.0)
        );
        assert!(
            score <= 1.10 * reference,
            "{name}: final disparity {score} vs rectified {reference}"
        );
    }
}

/// Where the gap to the rectified array comes from (a measurement, run by hand):
/// resampling (true homographies, bilinear vs Catmull–Rom), the estimated homographies
/// (with the unobservable disparity plane removed), corner count and reference frame,
/// the border. An affine fit of the error map to the rectified estimate shows what is a
/// smooth bias and what is noise.
/// `cargo test --release -p lfdepth-cli --test align_epi gap -- --ignored --nocapture`
#[test]
#[ignore]
fn gap() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = epi(&ideal, &spec);
        for border in [BORDER, 30] {
            let score = badpix_border(&reference, &gt, n, border);
            eprintln!("{name} border {border}: rectified {score:.2}");
        }
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let on = AlignParams {
            mode: AlignMode::On,
            ..AlignParams::default()
        };
        let with = |params: AlignParams| estimate(&lf, params).0;
        let cross = AlignParams {
            views: AlignedViews::Cross,
            ..on
        };
        let variants = [
            ("true H", truth.clone(), false),
            ("estimated H", with(on), false),
            (
                "estimated H, 512 corners",
                with(AlignParams {
                    features: 512,
                    ..on
                }),
                false,
            ),
            (
                "estimated H, 128 corners",
                with(AlignParams {
                    features: 128,
                    ..on
                }),
                false,
            ),
            (
                "estimated H, centre reference",
                with(AlignParams {
                    reference: Reference::CentreView,
                    ..on
                }),
                false,
            ),
            ("estimated H, cross only", with(cross), true),
            (
                "estimated H, cross only, 128 corners",
                with(AlignParams {
                    features: 128,
                    ..cross
                }),
                true,
            ),
        ];
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        let on_cross = |v: usize| v / cols == r0 || v % cols == c0;
        for (label, hs, cross_only) in &variants {
            let include = |v: usize| !cross_only || on_cross(v);
            let gauge = gauge_fit_where(hs, &truth, spec.grid, n, n, &include).unwrap();
            for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
                let d: Vec<f32> = epi(&warp_all(&lf, hs, how), &spec)
                    .iter()
                    .enumerate()
                    .map(|(i, &d)| gauge.true_disparity(d, (i % n) as f32, (i / n) as f32))
                    .collect();
                let (mut sums, mut count) = ([[0.0f64; 4]; 3], 0usize);
                for y in BORDER..n - BORDER {
                    for x in BORDER..n - BORDER {
                        let e = f64::from(d[y * n + x] - reference[y * n + x]);
                        if e.abs() > 0.2 {
                            continue;
                        }
                        let f = [1.0, x as f64 / n as f64, y as f64 / n as f64];
                        for i in 0..3 {
                            for j in 0..3 {
                                sums[i][j] += f[i] * f[j];
                            }
                            sums[i][3] += f[i] * e;
                        }
                        count += 1;
                    }
                }
                let c = solve3(&sums);
                eprintln!(
                    "{name} {label} {how:?}: BadPix0.07 {:.2} (border 30: {:.2}); error vs the rectified map: {:.4} + {:.4}x + {:.4}y (x, y in image widths) over {count} px; gauge plane {:.4} + ({:.2e}, {:.2e}) px/px",
                    badpix(&d, &gt, n),
                    badpix_border(&d, &gt, n, 30),
                    c[0],
                    c[1],
                    c[2],
                    gauge.disparity_offset,
                    gauge.disparity_slope.0,
                    gauge.disparity_slope.1,
                );
            }
        }
    }
}

/// Solves the 3 × 3 system `[A | b]` by Cramer's rule.
fn solve3(m: &[[f64; 4]; 3]) -> [f64; 3] {
    let det = |a: [[f64; 3]; 3]| {
        a[0][0] * (a[1][1] * a[2][2] - a[1][2] * a[2][1])
            - a[0][1] * (a[1][0] * a[2][2] - a[1][2] * a[2][0])
            + a[0][2] * (a[1][0] * a[2][1] - a[1][1] * a[2][0])
    };
    let a = |col: Option<usize>| {
        let mut out = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                out[i][j] = if Some(j) == col { m[i][3] } else { m[i][j] };
            }
        }
        out
    };
    let d = det(a(None));
    [
        det(a(Some(0))) / d,
        det(a(Some(1))) / d,
        det(a(Some(2))) / d,
    ]
}

/// The gauge transform `G_v` of `gauge` for the view with baseline `b`: true rectified →
/// estimated rectified coordinates (an affine map).
fn gauge_map(g: &align::GaugeFit, b: (f32, f32)) -> Homography {
    let (ox, oy) = g.centre;
    let (s, (g1, g2), g3, (g4, g5)) = (
        g.scale,
        g.translation,
        g.disparity_offset,
        g.disparity_slope,
    );
    let (m0, m1, m3, m4) = (s + g4 * b.0, g5 * b.0, g4 * b.1, s + g5 * b.1);
    Homography {
        m: [
            m0,
            m1,
            g1 + g3 * b.0 + ox - m0 * ox - m1 * oy,
            m3,
            m4,
            g2 + g3 * b.1 + oy - m3 * ox - m4 * oy,
            0.0,
            0.0,
            1.0,
        ],
    }
}

/// `d` (on the estimated rectified grid) read at the true centre-view pixels and with
/// the gauge removed: where the map lands once registered to the centre camera.
fn registered(
    d: &[f32],
    n: usize,
    est_c: &Homography,
    true_c: &Homography,
    g: &align::GaugeFit,
) -> Vec<f32> {
    let inv = est_c.inverse().unwrap();
    (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f32, (i / n) as f32);
            let q = true_c.apply(x, y).unwrap();
            let e = inv.apply(q.0, q.1).unwrap();
            let (ex, ey) = (
                e.0.clamp(0.0, (n - 1) as f32),
                e.1.clamp(0.0, (n - 1) as f32),
            );
            let (ix, iy) = ((ex + 0.5) as usize, (ey + 0.5) as usize);
            let v = d[iy.min(n - 1) * n + ix.min(n - 1)];
            g.true_disparity(v, e.0, e.1)
        })
        .collect()
}

/// What the estimated homographies cost, one cause at a time (a measurement, run by hand):
/// the estimate scored in its own frame and registered to the centre camera, and the true
/// homographies moved by the estimate's own gauge (no per-view error).
/// `cargo test --release -p lfdepth-cli --test align_epi causes -- --ignored --nocapture`
#[test]
#[ignore]
fn causes() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = badpix(&epi(&ideal, &spec), &gt, n);
        eprintln!("{name}: rectified {reference:.2}");
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let (r0, c0) = spec.grid.center();
        let centre = spec.grid.index(r0, c0);
        let cols = spec.grid.cols;
        let b = |v: usize| ((v % cols) as f32 - c0 as f32, (v / cols) as f32 - r0 as f32);
        for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
            let s = badpix(&epi(&warp_all(&lf, &truth, how), &spec), &gt, n);
            eprintln!(
                "{name} {how:?} true H: {s:.2} ({:+.1} %)",
                100.0 * (s / reference - 1.0)
            );
        }
        for frame in [Reference::Estimated, Reference::CentreView] {
            let params = AlignParams {
                mode: AlignMode::On,
                reference: frame,
                views: AlignedViews::All,
                ..AlignParams::default()
            };
            let (est, _) = estimate(&lf, params);
            let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &|_| true).unwrap();
            let hybrid: Vec<Homography> = (0..truth.len())
                .map(|v| truth[v].compose(&gauge_map(&g, b(v)).inverse().unwrap()))
                .collect();
            for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
                for (label, hs) in [
                    ("estimated", &est),
                    ("truth in the estimate's gauge", &hybrid),
                ] {
                    let raw = epi(&warp_all(&lf, hs, how), &spec);
                    let own: Vec<f32> = raw
                        .iter()
                        .enumerate()
                        .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                        .collect();
                    let reg = registered(&raw, n, &hs[centre], &truth[centre], &g);
                    let (a, r) = (badpix(&own, &gt, n), badpix(&reg, &gt, n));
                    eprintln!(
                        "{name} {frame:?} {how:?} {label}: own frame {a:.2} ({:+.1} %), registered {r:.2} ({:+.1} %); gauge s {:.5} t ({:.3}, {:.3}) plane {:.4} ({:.2e}, {:.2e}) registration rms {:.3}",
                        100.0 * (a / reference - 1.0),
                        100.0 * (r / reference - 1.0),
                        g.scale, g.translation.0, g.translation.1, g.disparity_offset,
                        g.disparity_slope.0, g.disparity_slope.1, g.rms
                    );
                }
            }
        }
    }
}

/// BadPix0.07 (15 px border) split into pixels within 3 px of a ground-truth depth step
/// (> 0.3 px between neighbours) and the rest: (near steps, elsewhere).
fn badpix_split(est: &[f32], gt: &[f32], n: usize) -> (f64, f64) {
    let step = |i: usize, j: usize| (gt[i] - gt[j]).abs() > 0.3;
    let mut near = vec![false; n * n];
    for y in 0..n {
        for x in 0..n {
            let i = y * n + x;
            if (x + 1 < n && step(i, i + 1)) || (y + 1 < n && step(i, i + n)) {
                for yy in y.saturating_sub(3)..(y + 4).min(n) {
                    for xx in x.saturating_sub(3)..(x + 4).min(n) {
                        near[yy * n + xx] = true;
                    }
                }
            }
        }
    }
    let (mut bad, mut count) = ([0usize; 2], [0usize; 2]);
    for y in BORDER..n - BORDER {
        for x in BORDER..n - BORDER {
            let i = y * n + x;
            let k = usize::from(!near[i]);
            count[k] += 1;
            bad[k] += usize::from((est[i] - gt[i]).abs() > 0.07);
        }
    }
    let pct = |k: usize| 100.0 * bad[k] as f64 / count[k].max(1) as f64;
    (pct(0), pct(1))
}

/// Every view of `lf` warped by `hs` with a Lanczos-3 kernel (6 × 6 taps, weights
/// normalised, coordinates clamped): a reference for what a sharper kernel than
/// Catmull–Rom would give.
fn warp_lanczos(lf: &LightField<'_, u8>, hs: &[Homography]) -> Vec<f32> {
    let l = lf.layout();
    let (w, h, ch) = (l.width, l.height, l.channels);
    let kernel = |t: f32| {
        if t.abs() < 1e-6 {
            1.0
        } else if t.abs() >= 3.0 {
            0.0
        } else {
            let p = std::f32::consts::PI * t;
            3.0 * p.sin() * (p / 3.0).sin() / (p * p)
        }
    };
    let mut out = vec![0.0f32; l.validate().unwrap()];
    for (v, chunk) in out.chunks_exact_mut(w * h * ch).enumerate() {
        let (r, c) = (v / l.grid.cols, v % l.grid.cols);
        for y in 0..h {
            for x in 0..w {
                let (u, vv) = hs[v].apply(x as f32, y as f32).unwrap();
                let (x0, y0) = (u.floor() as i64, vv.floor() as i64);
                let mut acc = [0.0f32; 4];
                let mut wsum = 0.0f32;
                for j in -2..=3 {
                    let wy = kernel(vv - (y0 + j) as f32);
                    let sy = (y0 + j).clamp(0, h as i64 - 1) as usize;
                    for i in -2..=3 {
                        let wk = wy * kernel(u - (x0 + i) as f32);
                        let sx = (x0 + i).clamp(0, w as i64 - 1) as usize;
                        for (k, a) in acc.iter_mut().enumerate().take(ch) {
                            *a += wk * lf.pixel(r, c, sx, sy, k).unwrap() as f32 / 255.0;
                        }
                        wsum += wk;
                    }
                }
                let at = (y * w + x) * ch;
                for (o, a) in chunk[at..at + ch].iter_mut().zip(acc) {
                    *o = a / wsum;
                }
            }
        }
    }
    out
}

/// Resampling and a pure gauge transform, with the true homographies (a measurement, run
/// by hand): bilinear, Catmull–Rom and Lanczos-3, scored with a 15 and a 40 px border;
/// the true homographies moved by a disparity offset or slope alone.
/// `cargo test --release -p lfdepth-cli --test align_epi resampling -- --ignored --nocapture`
#[test]
#[ignore]
fn resampling() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let rect = epi(&ideal, &spec);
        let (r15, r40) = (badpix(&rect, &gt, n), badpix_border(&rect, &gt, n, 40));
        let (re, ri) = badpix_split(&rect, &gt, n);
        eprintln!("{name}: rectified {r15:.2} (border 40: {r40:.2}; near depth steps {re:.2}, elsewhere {ri:.2})");
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let cases = [
            (
                "bilinear",
                epi(&warp_all(&lf, &truth, Interpolation::Bilinear), &spec),
            ),
            (
                "catmull-rom",
                epi(&warp_all(&lf, &truth, Interpolation::CatmullRom), &spec),
            ),
            ("lanczos-3", epi(&warp_lanczos(&lf, &truth), &spec)),
        ];
        for (label, d) in cases {
            let (a, b) = (badpix(&d, &gt, n), badpix_border(&d, &gt, n, 40));
            let (e, i) = badpix_split(&d, &gt, n);
            eprintln!(
                "{name} true H {label}: {a:.2} ({:+.1} %), border 40: {b:.2} ({:+.1} %); near depth steps {e:.2} ({:+.1} %), elsewhere {i:.2} ({:+.1} %)",
                100.0 * (a / r15 - 1.0),
                100.0 * (b / r40 - 1.0),
                100.0 * (e / re - 1.0),
                100.0 * (i / ri - 1.0)
            );
        }
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        let b = |v: usize| ((v % cols) as f32 - c0 as f32, (v / cols) as f32 - r0 as f32);
        for (label, offset, slope) in [
            ("offset 0.05", 0.05f32, (0.0f32, 0.0f32)),
            ("offset -0.05", -0.05, (0.0, 0.0)),
            ("offset 0.25", 0.25, (0.0, 0.0)),
            ("slope (2.7e-4, 1.5e-4)", 0.0, (2.7e-4, 1.5e-4)),
        ] {
            let g = align::GaugeFit {
                scale: 1.0,
                translation: (0.0, 0.0),
                disparity_offset: offset,
                disparity_slope: slope,
                centre: (n as f32 * 0.5, n as f32 * 0.5),
                rms: 0.0,
            };
            let moved: Vec<Homography> = (0..truth.len())
                .map(|v| truth[v].compose(&gauge_map(&g, b(v)).inverse().unwrap()))
                .collect();
            let d: Vec<f32> = epi(&warp_all(&lf, &moved, Interpolation::CatmullRom), &spec)
                .iter()
                .enumerate()
                .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                .collect();
            let a = badpix(&d, &gt, n);
            eprintln!(
                "{name} true H + gauge {label}, Catmull-Rom: {a:.2} ({:+.1} %)",
                100.0 * (a / r15 - 1.0)
            );
        }
    }
}

/// How far the alternation runs (a measurement, run by hand): registration to the true
/// frame (modulo the gauge) and BadPix after the gauge, for the stopping rule's target
/// and round limit.
/// `cargo test --release -p lfdepth-cli --test align_epi convergence -- --ignored --nocapture`
#[test]
#[ignore]
fn convergence() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let reference = badpix(&epi(&ideal, &spec), &gt, n);
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        for (target_rms, max_iterations) in [(0.02, 30), (0.0, 30), (0.0, 200)] {
            let params = AlignParams {
                mode: AlignMode::On,
                views: AlignedViews::All,
                target_rms,
                max_iterations,
                ..AlignParams::default()
            };
            let mut est = vec![Homography::IDENTITY; lf.grid().len()];
            let mut scratch = vec![0.0f32; align::scratch_len(lf.layout(), &params).unwrap()];
            let report = align::estimate(&lf, &params, &mut est, &mut scratch).unwrap();
            let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &|_| true).unwrap();
            let d: Vec<f32> = epi(&warp_all(&lf, &est, Interpolation::Bilinear), &spec)
                .iter()
                .enumerate()
                .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                .collect();
            let s = badpix(&d, &gt, n);
            eprintln!(
                "{name} target {target_rms} max {max_iterations}: {} rounds, track RMS {:.4}, registration {:.3} px, BadPix {s:.2} ({:+.1} %)",
                report.iterations,
                report.rms,
                g.rms,
                100.0 * (s / reference - 1.0)
            );
        }
    }
}

/// The plane-patch model's estimate on the 384² scenes (a measurement, run by hand).
/// `cargo test --release -p lfdepth-cli --test align_epi plane_patches_report -- --ignored --nocapture`
#[test]
#[ignore]
fn plane_patches_report() {
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, _, misaligned, _, truth) = scenes(scene, n);
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        for model in [AlignModel::PerView, AlignModel::PlanePatches] {
            let params = AlignParams {
                mode: AlignMode::On,
                model,
                views: AlignedViews::All,
                ..AlignParams::default()
            };
            let mut est = vec![Homography::IDENTITY; lf.grid().len()];
            let mut scratch = vec![0.0f32; align::scratch_len(lf.layout(), &params).unwrap()];
            let r = align::estimate(&lf, &params, &mut est, &mut scratch).unwrap();
            let reproj =
                align::reprojection_rms(&est, &truth, spec.grid, n, n, &[-1.5, 0.0, 1.5]).unwrap();
            let min = r
                .views
                .iter()
                .filter(|v| v.inliers > 0)
                .map(|v| v.inliers)
                .min();
            eprintln!(
                "{} {model:?}: track RMS {:.4}, {} rounds, reprojection {reproj:.4} px, min inliers {min:?}",
                scene.name(),
                r.rms,
                r.iterations
            );
        }
    }
}

/// Why an unobservable disparity offset moves the score (a measurement, run by hand): the
/// scene rendered rectified with every disparity shifted by `δ` (no warp at all; the
/// synthetic scenes place their surfaces at fractions of `[disparity_min,
/// disparity_max]`, so shifting both shifts every disparity), scored by the EPI stage
/// with its defaults (auto range), with the range fixed to the shifted true range, with
/// an exhaustive search, and by the full pipeline.
/// `cargo test --release -p lfdepth-cli --test align_epi offset_sensitivity -- --ignored --nocapture`
#[test]
#[ignore]
fn offset_sensitivity() {
    use lfdepth::epi::{DisparityRange, Search};
    let n = SIZE;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        for delta in [-0.1f32, -0.05, -0.025, 0.0, 0.025, 0.05, 0.1, 0.25] {
            let mut spec = SynthSpec::new(scene, Grid::new(9, 9), n, n);
            spec.seed = 11;
            spec.disparity_min += delta;
            spec.disparity_max += delta;
            let mut views = vec![0u8; spec.layout().validate().unwrap()];
            let mut gt = vec![0.0f32; n * n];
            let mut hs = vec![Homography::IDENTITY; spec.grid.len()];
            synth::render(&spec, &mut views, &mut gt, &mut hs).unwrap();
            let lf = LightField::new(&views[..], spec.layout()).unwrap();
            let plan = lfdepth::Plan::new(spec.layout(), Params::default()).unwrap();
            let mut scratch = vec![0.0f32; lfdepth::epi::scratch_len(&plan)];
            let range = lfdepth::epi::estimate_range(&plan, &lf, &mut scratch).unwrap();
            let run = |params: Params, stage: Stages| {
                let options = EstimateOptions {
                    params,
                    stage,
                    threads: None,
                };
                let d = engine::estimate(&lf, &options, &mut |_, _, _| {})
                    .unwrap()
                    .disparity;
                (badpix(&d, &gt, n), badpix_split(&d, &gt, n))
            };
            let mut fixed = Params::default();
            fixed.epi.range = DisparityRange::Fixed {
                min: spec.disparity_min - 0.2,
                max: spec.disparity_max + 0.2,
            };
            let mut exhaustive = Params::default();
            exhaustive.epi.search = Search::Exhaustive;
            let mut fixed_exh = fixed;
            fixed_exh.epi.search = Search::Exhaustive;
            let cases = [
                ("epi", run(Params::default(), Stages::Epi)),
                ("epi fixed range", run(fixed, Stages::Epi)),
                ("epi exhaustive", run(exhaustive, Stages::Epi)),
                ("epi fixed+exh", run(fixed_exh, Stages::Epi)),
                ("full", run(Params::default(), Stages::Full)),
            ];
            let mut line = format!(
                "{} offset {delta:+.3}: range ({:.3}, {:.3})",
                scene.name(),
                range.0,
                range.1
            );
            for (label, (s, (near, far))) in cases {
                line += &format!("; {label} {s:.2} ({near:.2}/{far:.2})");
            }
            eprintln!("{line}");
        }
    }
}

/// The disparity map `engine::estimate` gives for the views `data` of `spec` with
/// `params`, run as far as `stage`.
fn engine_map<S: Sample + Sync>(
    data: &[S],
    spec: &SynthSpec,
    params: Params,
    stage: Stages,
) -> Vec<f32> {
    let lf = LightField::new(data, spec.layout()).unwrap();
    let options = EstimateOptions {
        params,
        stage,
        threads: None,
    };
    engine::estimate(&lf, &options, &mut |_, _, _| {})
        .unwrap()
        .disparity
}

/// The final disparity (every stage, `Stages::Full`) of the aligned arrays against
/// the rectified one (a measurement, run by hand): the pipeline's cross-only estimate
/// and every view, bilinear, sharpened bilinear (the default) and Catmull–Rom, after
/// the unobservable disparity plane.
/// `cargo test --release -p lfdepth-cli --test align_epi final_disparity -- --ignored --nocapture`
#[test]
#[ignore]
fn final_disparity() {
    let n = SIZE;
    // Warped views go through the stages with the plan the pipelines give them
    // (`pipeline::resampled_plan`: the refinement's sampling slack).
    let full = |data: &[f32], spec: &SynthSpec| {
        let lf = LightField::new(data, spec.layout()).unwrap();
        let plan = Plan::new(spec.layout(), Params::default()).unwrap();
        let options = EstimateOptions {
            params: *pipeline::resampled_plan(&plan).unwrap().params(),
            stage: Stages::Full,
            threads: None,
        };
        engine::estimate(&lf, &options, &mut |_, _, _| {})
            .unwrap()
            .disparity
    };
    let rectified =
        |data: &[f32], spec: &SynthSpec| engine_map(data, spec, Params::default(), Stages::Full);
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let ideal_f: Vec<f32> = ideal.iter().map(|&v| f32::from(v) / 255.0).collect();
        let (rect_epi, rect_full) = (
            badpix(&epi(&ideal, &spec), &gt, n),
            badpix(&rectified(&ideal_f, &spec), &gt, n),
        );
        eprintln!("{name}: rectified EPI {rect_epi:.2}, full {rect_full:.2}");
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        for views in [AlignedViews::Cross, AlignedViews::All] {
            for step in [0.0f32, 0.5] {
                let params = AlignParams {
                    mode: AlignMode::On,
                    views,
                    disparity_step: step,
                    ..AlignParams::default()
                };
                let (est, _) = estimate(&lf, params);
                let include =
                    |v: usize| views == AlignedViews::All || v / cols == r0 || v % cols == c0;
                let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
                let fix = |raw: Vec<f32>| -> Vec<f32> {
                    raw.iter()
                        .enumerate()
                        .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                        .collect()
                };
                for how in [
                    Interpolation::Bilinear,
                    Interpolation::SharpenedBilinear,
                    Interpolation::CatmullRom,
                ] {
                    let warped = warp_all(&lf, &est, how);
                    let e = badpix(&fix(epi(&warped, &spec)), &gt, n);
                    let f = badpix(&fix(full(&warped, &spec)), &gt, n);
                    eprintln!(
                        "{name} {views:?} disparity_step {step} {how:?}: EPI {e:.2} ({:+.1} %), full {f:.2} ({:+.1} %); gauge offset {:.4}",
                        100.0 * (e / rect_epi - 1.0),
                        100.0 * (f / rect_full - 1.0),
                        g.disparity_offset
                    );
                }
            }
        }
    }
}

/// Which stage after the EPI stage loses the accuracy on warped views (a measurement, run
/// by hand): rectified views against views warped with the true homographies (bilinear
/// and Catmull–Rom, no estimate, no gauge), the pipeline with stages switched off one at
/// a time; BadPix0.07 near depth steps / elsewhere in brackets.
/// `cargo test --release -p lfdepth-cli --test align_epi final_stages -- --ignored --nocapture`
#[test]
#[ignore]
fn final_stages() {
    let n = SIZE;
    let run = engine_map;
    let no_refine = {
        let mut p = Params::default();
        p.refine.enabled = false;
        p
    };
    let refine_only = {
        let mut p = Params::default();
        p.geofill.enabled = false;
        p.median.enabled = false;
        p
    };
    let no_median = {
        let mut p = Params::default();
        p.median.enabled = false;
        p
    };
    let variants = [
        ("EPI", Params::default(), Stages::Epi),
        ("full", Params::default(), Stages::Full),
        ("full, no refine", no_refine, Stages::Full),
        ("full, no geofill/median", refine_only, Stages::Full),
        ("full, no median", no_median, Stages::Full),
    ];
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let ideal_f: Vec<f32> = ideal.iter().map(|&v| f32::from(v) / 255.0).collect();
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let inputs = [
            ("rectified", ideal_f),
            (
                "true H bilinear",
                warp_all(&lf, &truth, Interpolation::Bilinear),
            ),
            (
                "true H Catmull-Rom",
                warp_all(&lf, &truth, Interpolation::CatmullRom),
            ),
            ("true H Lanczos-3", warp_lanczos(&lf, &truth)),
        ];
        for (label, params, stage) in variants {
            let mut line = format!("{name} {label}:");
            let mut reference = 0.0;
            for (k, (input, data)) in inputs.iter().enumerate() {
                let d = run(data, &spec, params, stage);
                let s = badpix(&d, &gt, n);
                let (near, far) = badpix_split(&d, &gt, n);
                if k == 0 {
                    reference = s;
                }
                line += &format!(
                    " {input} {s:.2} ({:+.1} %; {near:.2}/{far:.3})",
                    100.0 * (s / reference - 1.0)
                );
            }
            eprintln!("{line}");
        }
    }
}

/// The refinement's own output (no refill, median or TV) from the EPI map of the same
/// input: on the rectified scene; on the misaligned one read through the TRUE
/// homographies (`refine_band_mapped`, one interpolation of the input, bilinear and
/// Catmull–Rom); on its warped copy (true homographies, bilinear: two interpolations).
/// Asserted: through the homographies with Catmull–Rom within the bounds measured
/// (docs/stages/align.md) and better than the warped copy.
/// `cargo test --release -p lfdepth-cli --test align_epi refine_through_homographies -- --nocapture`
#[test]
fn refine_through_homographies() {
    use lfdepth::{epi, refine, Plan};
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: heavy 384x384 test, run it with `cargo test --release`");
        return;
    }
    let n = SIZE;
    // Measured +13.2 % (planes) and +23.1 % (mixed).
    for (scene, bound) in [(SceneKind::Planes, 1.20), (SceneKind::Mixed, 1.30)] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let plan = Plan::new(spec.layout(), Params::default()).unwrap();
        let epi_of = |data: &[f32]| {
            let lf = LightField::new(data, spec.layout()).unwrap();
            let (mut d, mut c) = (vec![0.0f32; n * n], vec![0.0f32; n * n]);
            let mut scratch = vec![0.0f32; epi::scratch_len(&plan)];
            let h = epi::estimate(&plan, &lf, &mut d, &mut c, &mut scratch).unwrap();
            (d, (h.min(), h.max()))
        };
        let refine_of = |data: &[f32],
                         maps: Option<(&[Homography], Interpolation)>,
                         init: &(Vec<f32>, (f32, f32))| {
            let lf = LightField::new(data, spec.layout()).unwrap();
            let (mut d, mut c) = (vec![0.0f32; n * n], vec![0.0f32; n * n]);
            let mut scratch = vec![0.0f32; refine::scratch_len(&plan)];
            let start = std::time::Instant::now();
            for b in 0..refine::band_count(&plan) {
                let rows = refine::band_rows(&plan, b).unwrap();
                let span = rows.start * n..rows.end * n;
                let (d, c) = (&mut d[span.clone()], &mut c[span]);
                match maps {
                    None => {
                        refine::refine_band(&plan, &lf, init.1, &init.0, rows, d, c, &mut scratch)
                    }
                    Some((maps, how)) => refine::refine_band_mapped(
                        &plan,
                        &lf,
                        maps,
                        how,
                        init.1,
                        &init.0,
                        rows,
                        d,
                        c,
                        &mut scratch,
                    ),
                }
                .unwrap();
            }
            (badpix(&d, &gt, n), start.elapsed().as_secs_f64())
        };
        let ideal_f: Vec<f32> = ideal.iter().map(|&v| f32::from(v) / 255.0).collect();
        let mis_f: Vec<f32> = misaligned.iter().map(|&v| f32::from(v) / 255.0).collect();
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let warped = warp_all(&lf, &truth, Interpolation::Bilinear);
        let ident = vec![Homography::IDENTITY; truth.len()];
        let (rect_init, warped_init) = (epi_of(&ideal_f), epi_of(&warped));
        let (rect, rect_s) = refine_of(&ideal_f, None, &rect_init);
        let rel = |v: f64| 100.0 * (v / rect - 1.0);
        let mut line = format!("{name}: refine output, rectified {rect:.2} ({rect_s:.3} s)");
        for how in [Interpolation::Bilinear, Interpolation::CatmullRom] {
            let (id, _) = refine_of(&ideal_f, Some((&ident, how)), &rect_init);
            line += &format!(
                "; rectified through identities, {how:?} {id:.2} ({:+.1} %)",
                rel(id)
            );
        }
        let mut through = [0.0; 2];
        for (k, how) in [Interpolation::Bilinear, Interpolation::CatmullRom]
            .into_iter()
            .enumerate()
        {
            let seconds;
            (through[k], seconds) = refine_of(&mis_f, Some((&truth, how)), &warped_init);
            let (from_rect, _) = refine_of(&mis_f, Some((&truth, how)), &rect_init);
            line += &format!(
                "; true H, through H {how:?} {:.2} ({:+.1} %, {seconds:.3} s; from the rectified EPI map {from_rect:.2}, {:+.1} %)",
                through[k],
                rel(through[k]),
                rel(from_rect)
            );
        }
        let (on_warped, _) = refine_of(&warped, None, &warped_init);
        line += &format!(
            "; true H, on the warped copy {on_warped:.2} ({:+.1} %)",
            rel(on_warped)
        );
        eprintln!("{line}");
        assert!(
            through[1] <= bound * rect,
            "{name}: {} vs rectified {rect}",
            through[1]
        );
        assert!(
            through[1] < on_warped && through[0] < on_warped,
            "{name}: {through:?} vs {on_warped}"
        );
    }
}

/// Separable 3-tap blur `[a, 1 − 2a, a]` of every view, in place (borders repeat).
fn blur3(data: &mut [f32], l: &lfdepth::Layout, a: f32) {
    let mut tmp = vec![0.0f32; l.width * l.height * l.channels];
    for view in data.chunks_exact_mut(l.width * l.height * l.channels) {
        three_tap(view, &mut tmp, l, |_, _| (a, a));
    }
}

/// Separable 3-tap filter `[a, 1 − 2a, a]` of one view in place (borders repeat), whose
/// weight `a` at pixel `(x, y)` is `weights(x, y).0` across the row and `.1` down the
/// column; `tmp` holds the view between the passes.
#[allow(clippy::needless_range_loop)] // Index loops read as the formulas.
fn three_tap(
    view: &mut [f32],
    tmp: &mut [f32],
    l: &lfdepth::Layout,
    weights: impl Fn(usize, usize) -> (f32, f32),
) {
    let (w, h, ch) = (l.width, l.height, l.channels);
    for y in 0..h {
        for x in 0..w {
            let a = weights(x, y).0;
            for c in 0..ch {
                let at = |xx: usize| view[(y * w + xx) * ch + c];
                tmp[(y * w + x) * ch + c] = a * at(x.saturating_sub(1))
                    + (1.0 - 2.0 * a) * at(x)
                    + a * at((x + 1).min(w - 1));
            }
        }
    }
    for y in 0..h {
        for x in 0..w {
            let a = weights(x, y).1;
            for c in 0..ch {
                let at = |yy: usize| tmp[(yy * w + x) * ch + c];
                view[(y * w + x) * ch + c] = a * at(y.saturating_sub(1))
                    + (1.0 - 2.0 * a) * at(y)
                    + a * at((y + 1).min(h - 1));
            }
        }
    }
}

/// In-place cubic B-spline prefilter of a strided line (mirror boundary).
#[allow(clippy::needless_range_loop)] // Index loops read as the formulas.
fn bspline_prefilter(line: &mut [f32]) {
    let z = 3.0f32.sqrt() - 2.0;
    let n = line.len();
    if n < 2 {
        return;
    }
    for v in line.iter_mut() {
        *v *= 6.0;
    }
    // Causal init: truncated sum.
    let mut zk = z;
    let mut sum = line[0];
    for v in line.iter().take(n.min(24)).skip(1) {
        sum += zk * v;
        zk *= z;
    }
    line[0] = sum;
    for k in 1..n {
        line[k] += z * line[k - 1];
    }
    line[n - 1] = (z / (z * z - 1.0)) * (z * line[n - 2] + line[n - 1]);
    for k in (0..n - 1).rev() {
        line[k] = z * (line[k + 1] - line[k]);
    }
}

/// Every view warped by `hs` with a prefiltered cubic B-spline (an interpolator).
#[allow(clippy::needless_range_loop)] // Index loops read as the formulas.
fn warp_bspline(lf: &LightField<'_, u8>, hs: &[Homography]) -> Vec<f32> {
    let l = lf.layout();
    let (w, h, ch) = (l.width, l.height, l.channels);
    let mut out = vec![0.0f32; l.validate().unwrap()];
    let mut coef = vec![0.0f32; w * h];
    let mut line = vec![0.0f32; w.max(h)];
    let wts = |t: f32| {
        let s = 1.0 - t;
        [
            s * s * s / 6.0,
            (3.0 * t * t * t - 6.0 * t * t + 4.0) / 6.0,
            (-3.0 * t * t * t + 3.0 * t * t + 3.0 * t + 1.0) / 6.0,
            t * t * t / 6.0,
        ]
    };
    for (v, chunk) in out.chunks_exact_mut(w * h * ch).enumerate() {
        let (r, c) = (v / l.grid.cols, v % l.grid.cols);
        for k in 0..ch {
            for y in 0..h {
                for x in 0..w {
                    line[x] = lf.pixel(r, c, x, y, k).unwrap() as f32 / 255.0;
                }
                bspline_prefilter(&mut line[..w]);
                coef[y * w..(y + 1) * w].copy_from_slice(&line[..w]);
            }
            for x in 0..w {
                for y in 0..h {
                    line[y] = coef[y * w + x];
                }
                bspline_prefilter(&mut line[..h]);
                for y in 0..h {
                    coef[y * w + x] = line[y];
                }
            }
            for y in 0..h {
                for x in 0..w {
                    let (u, vv) = hs[v].apply(x as f32, y as f32).unwrap();
                    let u = u.clamp(0.0, (w - 1) as f32);
                    let vv = vv.clamp(0.0, (h - 1) as f32);
                    let (x0, y0) = (u.floor() as i64, vv.floor() as i64);
                    let (wx, wy) = (wts(u - x0 as f32), wts(vv - y0 as f32));
                    let mut acc = 0.0;
                    for j in 0..4 {
                        let sy = (y0 + j as i64 - 1).clamp(0, h as i64 - 1) as usize;
                        for i in 0..4 {
                            let sx = (x0 + i as i64 - 1).clamp(0, w as i64 - 1) as usize;
                            acc += wy[j] * wx[i] * coef[sy * w + sx];
                        }
                    }
                    chunk[(y * w + x) * ch + k] = acc;
                }
            }
        }
    }
    out
}

/// Every view warped by `hs` with Catmull–Rom along `cubic_x`/`cubic_y` (per view, from
/// its grid offset) and linear interpolation along the other axis.
#[allow(clippy::needless_range_loop)] // Index loops read as the formulas.
fn warp_mixed_kernel(
    lf: &LightField<'_, u8>,
    hs: &[Homography],
    cubic: impl Fn(isize, isize) -> (bool, bool),
) -> Vec<f32> {
    let l = lf.layout();
    let (w, h, ch) = (l.width, l.height, l.channels);
    let (r0, c0) = l.grid.center();
    let cr = |t: f32| {
        let (t2, t3) = (t * t, t * t * t);
        [
            0.5 * (-t3 + 2.0 * t2 - t),
            0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
            0.5 * (-3.0 * t3 + 4.0 * t2 + t),
            0.5 * (t3 - t2),
        ]
    };
    let lin = |t: f32| [0.0, 1.0 - t, t, 0.0];
    let mut out = vec![0.0f32; l.validate().unwrap()];
    for (v, chunk) in out.chunks_exact_mut(w * h * ch).enumerate() {
        let (r, c) = (v / l.grid.cols, v % l.grid.cols);
        let (cx, cy) = cubic(c as isize - c0 as isize, r as isize - r0 as isize);
        for y in 0..h {
            for x in 0..w {
                let (u, vv) = hs[v].apply(x as f32, y as f32).unwrap();
                let u = u.clamp(0.0, (w - 1) as f32);
                let vv = vv.clamp(0.0, (h - 1) as f32);
                let (x0, y0) = (u.floor() as i64, vv.floor() as i64);
                let (fx, fy) = (u - x0 as f32, vv - y0 as f32);
                let wx = if cx { cr(fx) } else { lin(fx) };
                let wy = if cy { cr(fy) } else { lin(fy) };
                for k in 0..ch {
                    let mut acc = 0.0;
                    for j in 0..4 {
                        let sy = (y0 + j as i64 - 1).clamp(0, h as i64 - 1) as usize;
                        for i in 0..4 {
                            let sx = (x0 + i as i64 - 1).clamp(0, w as i64 - 1) as usize;
                            acc += wy[j] * wx[i] * f32::from(lf.pixel(r, c, sx, sy, k).unwrap())
                                / 255.0;
                        }
                    }
                    chunk[(y * w + x) * ch + k] = acc;
                }
            }
        }
    }
    out
}

/// Every non-centre view of a bilinearly warped array sharpened by a separable 3-tap
/// `[a, 1 − 2a, a]` whose `a = −k·t(1 − t)/2` undoes the variance `t(1 − t)` that
/// bilinear interpolation at phase `t` adds (per axis, per pixel); `k = 0` leaves it.
fn sharpen_adaptive(data: &mut [f32], l: &lfdepth::Layout, hs: &[Homography], k: f32) {
    let centre = l.grid.len() / 2;
    let mut tmp = vec![0.0f32; l.width * l.height * l.channels];
    for (v, view) in data
        .chunks_exact_mut(l.width * l.height * l.channels)
        .enumerate()
    {
        if v == centre {
            continue;
        }
        three_tap(view, &mut tmp, l, |x, y| {
            let (u, vv) = hs[v].apply(x as f32, y as f32).unwrap();
            let (tx, ty) = (u - u.floor(), vv - vv.floor());
            (-k * tx * (1.0 - tx) / 2.0, -k * ty * (1.0 - ty) / 2.0)
        });
    }
}

/// What matched blur and sharper kernels do to the final disparity with the true
/// homographies (a measurement, run by hand; `PROBE` picks the variants).
/// `cargo test --release -p lfdepth-cli --test align_epi warp_kernels_and_blur_final_disparity -- --ignored --nocapture`
#[test]
#[ignore]
fn warp_kernels_and_blur_final_disparity() {
    let n = SIZE;
    let run = engine_map;
    let only = std::env::var("PROBE").unwrap_or_default();
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let l = spec.layout();
        let name = scene.name();
        let ideal_f: Vec<f32> = ideal.iter().map(|&v| f32::from(v) / 255.0).collect();
        let lf = LightField::new(&misaligned[..], l).unwrap();
        let blurred = |mut d: Vec<f32>, a: f32| {
            blur3(&mut d, &l, a);
            d
        };
        let bil = warp_all(&lf, &truth, Interpolation::Bilinear);
        let cr = warp_all(&lf, &truth, Interpolation::CatmullRom);
        let mut inputs: Vec<(&str, Vec<f32>)> = vec![
            ("rectified", ideal_f.clone()),
            ("bilinear", bil.clone()),
            ("CR", cr.clone()),
            (
                "sharpened bilinear",
                warp_all(&lf, &truth, Interpolation::SharpenedBilinear),
            ),
        ];
        if only.contains("gauge") {
            // The pipeline's estimate, and the true homographies moved into its gauge:
            // what is per-view error and what is the unobservable gauge. Scored after
            // the estimate's disparity plane, in the estimate's frame.
            let (r0, c0) = spec.grid.center();
            let cols = spec.grid.cols;
            let b = |v: usize| ((v % cols) as f32 - c0 as f32, (v / cols) as f32 - r0 as f32);
            for frame in [Reference::Estimated, Reference::CentreView] {
                let params = AlignParams {
                    mode: AlignMode::On,
                    reference: frame,
                    views: AlignedViews::Cross,
                    ..AlignParams::default()
                };
                let (est, _) = estimate(&lf, params);
                let include = |v: usize| v / cols == r0 || v % cols == c0;
                let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
                let hybrid: Vec<Homography> = (0..truth.len())
                    .map(|v| truth[v].compose(&gauge_map(&g, b(v)).inverse().unwrap()))
                    .collect();
                // The estimate re-anchored on the centre camera: every map composed with
                // the inverse of the centre view's, so the centre view is not warped.
                let centre = spec.grid.index(r0, c0);
                let back = est[centre].inverse().unwrap();
                let anchored: Vec<Homography> = est.iter().map(|h| h.compose(&back)).collect();
                // How far the estimated frame is from the centre camera's, beyond a
                // common translation: the corners' displacement minus its mean.
                let corners = [
                    (0.0, 0.0),
                    (n as f32, 0.0),
                    (0.0, n as f32),
                    (n as f32, n as f32),
                ];
                let moves: Vec<(f32, f32)> = corners
                    .iter()
                    .map(|&(x, y)| {
                        let (u, v) = est[centre].apply(x, y).unwrap();
                        (u - x, v - y)
                    })
                    .collect();
                let mean = moves
                    .iter()
                    .fold((0.0, 0.0), |a, m| (a.0 + m.0 / 4.0, a.1 + m.1 / 4.0));
                let spread = moves
                    .iter()
                    .map(|m| (m.0 - mean.0).hypot(m.1 - mean.1))
                    .fold(0.0f32, f32::max);
                eprintln!(
                    "{name} {frame:?}: centre view's map, translation ({:.3}, {:.3}) px, corners beyond it up to {spread:.3} px",
                    mean.0, mean.1
                );
                for (label, hs) in [
                    ("estimated", &est),
                    ("true H in its gauge", &hybrid),
                    ("estimated, re-anchored on the centre camera", &anchored),
                ] {
                    let g = gauge_fit_where(hs, &truth, spec.grid, n, n, &include).unwrap();
                    let warped = warp_all(&lf, hs, Interpolation::SharpenedBilinear);
                    let mut line = format!(
                        "{name} {frame:?} {label} (gauge offset {:.3}, translation ({:.3}, {:.3}), scale {:.5}):",
                        g.disparity_offset, g.translation.0, g.translation.1, g.scale
                    );
                    for (stage_name, stage) in [("EPI", Stages::Epi), ("full", Stages::Full)] {
                        let raw = run(&warped, &spec, Params::default(), stage);
                        let own: Vec<f32> = raw
                            .iter()
                            .enumerate()
                            .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                            .collect();
                        let s = badpix(&own, &gt, n);
                        line += &format!(" {stage_name} {s:.2}");
                    }
                    eprintln!("{line}");
                }
            }
        }
        if only.contains("sharp") {
            for k in [1.0f32, 2.0] {
                let mut d = bil.clone();
                sharpen_adaptive(&mut d, &l, &truth, k);
                inputs.push(("bil, adaptive sharpen", d));
            }
            let centre = spec.grid.len() / 2;
            let view = l.width * l.height * l.channels;
            for a in [-1.0f32 / 12.0, -1.0 / 8.0] {
                let mut d = bil.clone();
                for (v, chunk) in d.chunks_exact_mut(view).enumerate() {
                    if v != centre {
                        let one =
                            lfdepth::Layout::packed(Grid::new(1, 1), l.width, l.height, l.channels);
                        blur3(chunk, &one, a);
                    }
                }
                inputs.push(("bil, uniform sharpen", d));
            }
        }
        if only.contains("centre") {
            let centre = spec.grid.len() / 2;
            let view = l.width * l.height * l.channels;
            let centre_blurred = |mut d: Vec<f32>, a: f32| {
                let one = lfdepth::Layout::packed(Grid::new(1, 1), l.width, l.height, l.channels);
                blur3(&mut d[centre * view..(centre + 1) * view], &one, a);
                d
            };
            for a in [1.0 / 12.0, 1.0 / 24.0] {
                inputs.push(("bil, centre blurred", centre_blurred(bil.clone(), a)));
                inputs.push(("CR, centre blurred", centre_blurred(cr.clone(), a)));
            }
        }
        if only.contains("blur") {
            inputs.push(("rect blur1/4", blurred(ideal_f.clone(), 0.25)));
            inputs.push(("bil blur1/4", blurred(bil.clone(), 0.25)));
            inputs.push(("bil blur1/8", blurred(bil, 0.125)));
            inputs.push(("CR blur1/8", blurred(cr, 0.125)));
        }
        if only.contains("axis") {
            inputs.push((
                "CR along baseline",
                warp_mixed_kernel(&lf, &truth, |dc, dr| (dr == 0, dc == 0)),
            ));
            inputs.push((
                "CR across baseline",
                warp_mixed_kernel(&lf, &truth, |dc, dr| (dc == 0, dr == 0)),
            ));
            inputs.push((
                "CR both (test)",
                warp_mixed_kernel(&lf, &truth, |_, _| (true, true)),
            ));
        }
        if only.contains("bs") {
            inputs.push(("B-spline", warp_bspline(&lf, &truth)));
        }
        for (label, stage) in [("EPI", Stages::Epi), ("full", Stages::Full)] {
            let mut line = format!("{name} {label}:");
            let mut reference = 0.0;
            for (k, (input, data)) in inputs.iter().enumerate() {
                let d = run(data, &spec, Params::default(), stage);
                let s = badpix(&d, &gt, n);
                if k == 0 {
                    reference = s;
                }
                line += &format!(
                    " | {input} {s:.2} ({:+.1} %)",
                    100.0 * (s / reference - 1.0)
                );
            }
            eprintln!("{line}");
        }
    }
}

/// The refinement's sampling slack (`RefineParams::sampling_slack`) on the rectified
/// scene (a measurement, run by hand), on the views warped with the TRUE homographies and with the
/// pipeline's estimated ones (cross, sharpened bilinear, after the gauge plane), whole
/// pipeline; BadPix0.07 near depth steps / elsewhere in brackets. `SLACK` (comma list,
/// default `0,0.5`) picks the slacks.
/// `cargo test --release -p lfdepth-cli --test align_epi sampling_slack_on_synthetic_arrays -- --ignored --nocapture`
#[test]
#[ignore]
fn sampling_slack_on_synthetic_arrays() {
    let n = SIZE;
    let slacks: Vec<f32> = std::env::var("SLACK")
        .unwrap_or_else(|_| "0,0.5".into())
        .split(',')
        .map(|s| s.trim().parse().unwrap())
        .collect();
    let how = Interpolation::SharpenedBilinear;
    for scene in [SceneKind::Planes, SceneKind::Mixed] {
        let (spec, ideal, misaligned, gt, truth) = scenes(scene, n);
        let name = scene.name();
        let ideal_f: Vec<f32> = ideal.iter().map(|&v| f32::from(v) / 255.0).collect();
        let lf = LightField::new(&misaligned[..], spec.layout()).unwrap();
        let params = AlignParams {
            mode: AlignMode::On,
            views: AlignedViews::Cross,
            ..AlignParams::default()
        };
        let (est, _) = estimate(&lf, params);
        let (r0, c0) = spec.grid.center();
        let cols = spec.grid.cols;
        let include = |v: usize| v / cols == r0 || v % cols == c0;
        let g = gauge_fit_where(&est, &truth, spec.grid, n, n, &include).unwrap();
        let fix = |raw: Vec<f32>| -> Vec<f32> {
            raw.iter()
                .enumerate()
                .map(|(i, &d)| g.true_disparity(d, (i % n) as f32, (i / n) as f32))
                .collect()
        };
        let true_warp = warp_all(&lf, &truth, how);
        let est_warp = warp_all(&lf, &est, how);
        let reference = badpix(
            &engine_map(&ideal_f, &spec, Params::default(), Stages::Full),
            &gt,
            n,
        );
        eprintln!("{name}: rectified, slack 0 (the pipeline): {reference:.3}");
        for &slack in &slacks {
            let mut p = Params::default();
            p.refine.sampling_slack = slack;
            let mut line = format!("{name} slack {slack}:");
            for (label, data, gauge) in [
                ("rectified", &ideal_f, false),
                ("true H", &true_warp, false),
                ("estimated H", &est_warp, true),
            ] {
                let mut d = engine_map(data, &spec, p, Stages::Full);
                if gauge {
                    d = fix(d);
                }
                let s = badpix(&d, &gt, n);
                let (near, far) = badpix_split(&d, &gt, n);
                line += &format!(
                    " {label} {s:.3} ({:+.1} %; {near:.2}/{far:.3})",
                    100.0 * (s / reference - 1.0)
                );
            }
            eprintln!("{line}");
        }
    }
}
