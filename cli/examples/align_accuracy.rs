//! How alignment changes the final disparity of synthetic 9×9 arrays (384², `planes` and
//! `mixed`, rendered rectified and misaligned by up to 2°, 3 px, 1 % and perspective
//! 0.002): BadPix0.07 against the rectified array through the same pipeline, after the
//! disparity plane that no image can observe (`align::gauge_fit_where`). The numbers
//! behind the alignment choices in docs/stages/align.md and docs/stages/refine.md.
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example align_accuracy -- final-disparity
//! cargo run --release -p lfdepth-cli --example align_accuracy -- sampling-slack [0,0.25,0.5]
//! ```
//!
//! `final-disparity`: the pipeline's estimate (cross views and every view, disparity step
//! 0 and 0.5) warped bilinear, sharpened bilinear (the default) and Catmull–Rom; the EPI
//! stage and the whole pipeline. `sampling-slack`: the refinement's sampling slack
//! (`RefineParams::sampling_slack`, comma list, default `0,0.5`) on the rectified views,
//! on views warped with the true homographies and with the estimated ones. Each takes a
//! few minutes on one core.

use lfdepth::align::{gauge_fit_where, AlignMode, AlignParams, AlignedViews, Interpolation};
use lfdepth::metrics::BORDER;
use lfdepth::synth::{SceneKind, SynthSpec};
use lfdepth::{pipeline, LightField, Params, Plan};
use lfdepth_cli::engine::{self, EstimateOptions, Stages};

// The helpers the alignment tests use too.
#[path = "../tests/align_support/mod.rs"]
mod align_support;
use align_support::{badpix, engine_map, epi, estimate, scenes, warp_all};

const SIZE: usize = 384;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    match args.first().map(String::as_str) {
        Some("final-disparity") if args.len() == 1 => final_disparity(),
        Some("sampling-slack") if args.len() <= 2 => {
            let list = args.get(1).map_or("0,0.5", String::as_str);
            let slacks: Result<Vec<f32>, _> =
                list.split(',').map(|s| s.trim().parse::<f32>()).collect();
            match slacks {
                Ok(slacks) if slacks.iter().all(|s| (0.0..=1.0).contains(s)) => {
                    sampling_slack(&slacks)
                }
                _ => {
                    eprintln!(
                        "error: `{list}` is not a comma list of slacks in 0…1 px (for example 0,0.25,0.5)"
                    );
                    std::process::exit(2);
                }
            }
        }
        _ => {
            eprintln!(
                "usage: align_accuracy final-disparity | align_accuracy sampling-slack [S1,S2,…]"
            );
            std::process::exit(2);
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

/// The final disparity (every stage, `Stages::Full`) of the aligned arrays against
/// the rectified one: the pipeline's cross-only estimate
/// and every view, bilinear, sharpened bilinear (the default) and Catmull–Rom, after
/// the unobservable disparity plane.
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

/// The refinement's sampling slack (`RefineParams::sampling_slack`) on the rectified
/// scene (a measurement, run by hand), on the views warped with the TRUE homographies and with the
/// pipeline's estimated ones (cross, sharpened bilinear, after the gauge plane), whole
/// pipeline; BadPix0.07 near depth steps / elsewhere in brackets. `SLACK` (comma list,
/// default `0,0.5`) picks the slacks.
fn sampling_slack(slacks: &[f32]) {
    let n = SIZE;
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
        for &slack in slacks {
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
