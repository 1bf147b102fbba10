//! The full pipeline (EPI → refine → TV) on the shared HCI scenes, release only, and an
//! ignored development harness for tuning (parameters from environment variables).

#[path = "tv_support.rs"]
mod tv_support;

use std::path::Path;
use std::time::Instant;

use lfdepth::refine::{self, RefineParams, ViewSet};
use lfdepth::tv::{self, Guide, Maps, TvParams};
use lfdepth::{LightField, Params, Plan};
use lfdepth_cli::engine::{estimate, EstimateOptions, Stages};
use tv_support::*;

fn params_from_env() -> Params {
    let r = RefineParams::default();
    let t = TvParams::default();
    Params {
        refine: RefineParams {
            enabled: env_f32("RF_ON", 1.0) > 0.0, // on unless RF_ON=0
            views: match std::env::var("RF_VIEWS").as_deref() {
                Ok("all") => ViewSet::All,
                Ok("diag") => ViewSet::CrossDiagonals,
                Ok("cross") => ViewSet::Cross,
                _ => r.views,
            },
            iterations: env_f32("RF_ITERS", r.iterations as f32) as usize,
            radius: env_f32("RF_RADIUS", r.radius as f32) as usize,
            max_step: env_f32("RF_STEP", r.max_step),
            propagation: env_f32("RF_PROP", r.propagation as f32) as usize,
            occlusion: env_f32("RF_OCC", 1.0) > 0.0,
            confidence_scale: env_f32("RF_SCALE", r.confidence_scale),
            robust_scale: env_f32("RF_ROBUST", r.robust_scale),
            band_rows: r.band_rows,
            sampling_slack: env_f32("RF_SLACK", r.sampling_slack),
            skip_settled: env_f32("RF_SKIP", r.skip_settled),
        },
        tv: TvParams {
            lambda: env_f32("TV_LAMBDA", t.lambda),
            confidence_threshold: env_f32("TV_THRESHOLD", t.confidence_threshold),
            confidence_power: env_f32("TV_POWER", t.confidence_power),
            edge_sigma: env_f32("TV_SIGMA", t.edge_sigma),
            max_iterations: env_f32("TV_ITERS", t.max_iterations as f32) as usize,
            tolerance: env_f32("TV_TOL", t.tolerance),
            ..t
        },
        ..Params::default()
    }
}

/// EPI (engine, all threads), then refine and TV serially, with the scores and CPU-side
/// timings of each stage: (epi, refined, tv) maps.
fn stages(dir: &Path, params: Params) -> [(Vec<f32>, f64); 3] {
    let (views, layout) = load_hci(dir);
    let lf = LightField::new(&views, layout).unwrap();
    let plan = Plan::new(layout, params).unwrap();
    let options = EstimateOptions {
        params,
        stage: Stages::Epi,
        threads: Some(1),
    };
    let t = Instant::now();
    let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
    let epi_s = t.elapsed().as_secs_f64();
    let mut scratch = vec![0.0f32; lfdepth::epi::scratch_len(&plan)];
    let hyps = lfdepth::epi::hypotheses(&plan, &lf, &mut scratch).unwrap();
    let range = (hyps.min(), hyps.max());
    let mut input = e.disparity.clone();
    if std::env::var("RF_FROM_GT").is_ok() {
        input = read_pfm(&dir.join("gt_disp_lowres.pfm")).2;
    }
    let (mut d, mut c) = (input.clone(), e.confidence.clone());
    let t = Instant::now();
    if params.refine.enabled {
        let mut scratch = vec![0.0f32; refine::scratch_len(&plan)];
        refine::refine(&plan, &lf, range, &input, &mut d, &mut c, &mut scratch).unwrap();
    }
    let refine_s = t.elapsed().as_secs_f64();
    let t = Instant::now();
    let maps = Maps::new(layout.width, layout.height, &d, &c).unwrap();
    let mut out = vec![0.0f32; plan.pixels()];
    let mut scratch = vec![0.0f32; tv::scratch_len(&plan)];
    tv::refine(
        &plan,
        &maps,
        &Guide::View(lf.center_view()),
        &mut out,
        &mut [],
        &mut scratch,
        &mut vec![0.0; tv::dual_len(&plan)],
    )
    .unwrap();
    let tv_s = t.elapsed().as_secs_f64();
    if std::env::var("RF_DUMP").is_ok() {
        let w = layout.width;
        let h = layout.height;
        let scene = dir_name(dir);
        let name = format!("{}/{scene}_", std::env::var("RF_DUMP").unwrap());
        write_pfm(Path::new(&(name.clone() + "refined.pfm")), w, h, &d);
        write_pfm(Path::new(&(name.clone() + "refined_conf.pfm")), w, h, &c);
        write_pfm(Path::new(&(name + "tv.pfm")), w, h, &out);
    }
    [(input, epi_s), (d, refine_s), (out, tv_s)]
}

#[test]
#[ignore = "development harness: RF_* and TV_* environment variables"]
fn pipeline_hci_dev_harness() {
    let Some(data) = shared_data("the pipeline harness") else {
        return;
    };
    let params = params_from_env();
    println!("{params:?}");
    for scene in ["stratified/backgammon", "training/cotton"] {
        let dir = data.join("hci").join(scene);
        let (w, h, gt) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
        let maps = stages(&dir, params);
        let s: Vec<(f64, f64)> = maps.iter().map(|(m, _)| scores(m, &gt, w, h)).collect();
        println!(
            "{scene:24} epi {:.2}/{:.3}  refine {:.2}/{:.3}  +tv {:.2}/{:.3}   ms {:.0} {:.0} {:.0}",
            s[0].0,
            s[0].1,
            s[1].0,
            s[1].1,
            s[2].0,
            s[2].1,
            maps[0].1 * 1e3,
            maps[1].1 * 1e3,
            maps[2].1 * 1e3
        );
    }
}

fn dir_name(dir: &Path) -> String {
    dir.file_name().unwrap().to_string_lossy().to_string()
}

/// The engine's full pipeline with default parameters on one scene: (BadPix0.07 %,
/// MSE×100) of the default (EPI → refine → TV) and of the paper's pipeline (EPI → TV).
fn engine_scores(dir: &Path) -> ((f64, f64), (f64, f64)) {
    let (views, layout) = load_hci(dir);
    let (w, h, gt) = read_pfm(&dir.join("gt_disp_lowres.pfm"));
    let lf = LightField::new(&views, layout).unwrap();
    let run = |params: Params| {
        let options = EstimateOptions {
            params,
            stage: Stages::Full,
            threads: None,
        };
        let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
        assert!(e.disparity.iter().all(|v| v.is_finite()));
        scores(&e.disparity, &gt, w, h)
    };
    let full = run(Params::default());
    let paper = run(Params::paper());
    (full, paper)
}

#[test]
#[cfg_attr(debug_assertions, ignore)]
fn full_pipeline_accuracy_on_both_hci_scenes() {
    if cfg!(debug_assertions) {
        eprintln!("SKIPPED: the HCI pipeline accuracy test runs only with --release");
        return;
    }
    let Some(data) = shared_data("the HCI pipeline accuracy test") else {
        return;
    };
    // The goal: beat SPO (2.55 / 3.24 and 2.59 / 1.31) on both scenes. Measured
    // with the geodesic refill (docs/stages/refill.md): 2.04 / 3.07 and 2.06 / 1.15.
    for (scene, bad_max, mse_max) in [
        ("stratified/backgammon", 2.55, 3.24),
        ("training/cotton", 2.59, 1.31),
    ] {
        let (full, paper) = engine_scores(&data.join("hci").join(scene));
        eprintln!(
            "{scene}: EPI→refine→refill→median→TV {:.2} % / {:.3}, paper EPI→TV {:.2} % / {:.3} \
             (BadPix0.07 / MSE×100)",
            full.0, full.1, paper.0, paper.1
        );
        assert!(full.0 < bad_max, "{scene}: BadPix0.07 {:.2} %", full.0);
        assert!(full.1 < mse_max, "{scene}: MSE×100 {:.3}", full.1);
        assert!(
            full.0 < paper.0,
            "{scene}: the pipeline did not beat the paper's on BadPix0.07"
        );
    }
}

#[test]
#[ignore = "timing report: per-stage wall time and CPU time of the engine on cotton"]
fn pipeline_stage_timings() {
    let Some(data) = shared_data("the timing report") else {
        return;
    };
    let (views, layout) = load_hci(&data.join("hci/training/cotton"));
    let lf = LightField::new(&views, layout).unwrap();
    let no_propagation = Params {
        refine: RefineParams {
            propagation: 0,
            ..RefineParams::default()
        },
        ..Params::default()
    };
    let paper = Params {
        refine: RefineParams::off(),
        ..Params::default()
    };
    let repeats = 5;
    for threads in [1, 2] {
        for (name, params, stage) in [
            ("epi only", Params::default(), Stages::Epi),
            ("paper epi+tv", paper, Stages::Full),
            ("refine without propagation", no_propagation, Stages::Full),
            ("default", Params::default(), Stages::Full),
        ] {
            let options = EstimateOptions {
                params,
                stage,
                threads: Some(threads),
            };
            let mut walls: Vec<Vec<(&str, f64)>> = Vec::new();
            let cpu = cpu_seconds();
            let t = Instant::now();
            for _ in 0..repeats {
                let e = estimate(&lf, &options, &mut |_, _, _| {}).unwrap();
                walls.push(
                    e.timings
                        .iter()
                        .map(|(s, d)| (*s, d.as_secs_f64()))
                        .collect(),
                );
            }
            let wall = t.elapsed().as_secs_f64() / repeats as f64;
            let cpu = (cpu_seconds() - cpu) / repeats as f64;
            let stages: Vec<String> = walls[0]
                .iter()
                .enumerate()
                .map(|(i, (s, _))| {
                    let mut v: Vec<f64> = walls.iter().map(|w| w[i].1).collect();
                    v.sort_by(|a, b| a.partial_cmp(b).unwrap());
                    format!("{s} {:.0} ms", v[v.len() / 2] * 1e3)
                })
                .collect();
            println!(
                "{threads} thread(s), {name}: wall {:.0} ms, CPU {:.0} ms per run; median per stage: {}",
                wall * 1e3,
                cpu * 1e3,
                stages.join(", ")
            );
        }
    }
}
