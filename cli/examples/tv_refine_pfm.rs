//! TV refinement alone on a disparity map given as PFM, guided by an HCI scene's centre
//! view and scored against its ground truth: the harness behind the TV choices in
//! docs/stages/tv.md. SCENE_DIR holds `input_Cam040.png` and `gt_disp_lowres.pfm`; the
//! confidence is read from `IN_conf.pfm` beside `IN.pfm`. A TV input is what the default
//! pipeline hands TV, dumped with TV made inert:
//!
//! ```text
//! lfdepth estimate -q --threads 1 --lambda 1e-7 --tv-iterations 1 SCENE_DIR -o IN.pfm --confidence IN_conf.pfm
//! TV_LAMBDA=0.25 cargo run --release -p lfdepth-cli --example tv_refine_pfm -- SCENE_DIR IN.pfm
//! ```
//!
//! Parameters (default: `TvParams::default()`): `TV_LAMBDA`, `TV_TIKHONOV`,
//! `TV_THRESHOLD`, `TV_POWER`, `TV_SIGMA`, `TV_FLOOR`, `TV_NORM=l1`, `TV_ITERS`, `TV_TOL`,
//! `TV_STEP`, `TV_RELAX`, `TV_TILE`, `TV_HALO`, `TV_SWEEPS`. `TV_Q16=1` also runs Q16.16
//! and prints its distance to `f32`; `TV_HISTORY=FILE` writes the residual history,
//! `TV_OUT=FILE.pfm` the refined map.

#[path = "../tests/tv_support.rs"]
mod tv_support;

use std::path::{Path, PathBuf};

use lfdepth::tv::{TvNorm, TvParams};
use lfdepth_cli::io::pfm;
use tv_support::*;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [scene, input] = &args[..] else {
        fail("usage: tv_refine_pfm SCENE_DIR IN.pfm (IN_conf.pfm beside it; TV_* variables set the parameters)");
    };
    let scene = PathBuf::from(scene);
    let conf = input
        .strip_suffix(".pfm")
        .map(|stem| format!("{stem}_conf.pfm"));
    let Some(conf) = conf else {
        fail(&format!("{input}: the input map must be a .pfm file"));
    };
    let (w, h, d) = pfm_map(Path::new(input));
    let (cw, ch, c) = pfm_map(Path::new(&conf));
    let (gw, gh, gt) = pfm_map(&scene.join("gt_disp_lowres.pfm"));
    if (cw, ch) != (w, h) || (gw, gh) != (w, h) {
        fail(&format!(
            "{input} is {w}×{h}, its confidence {cw}×{ch}, the ground truth {gw}×{gh}: they must match"
        ));
    }
    if !scene.join("input_Cam040.png").is_file() {
        fail(&format!(
            "{}: no input_Cam040.png (the centre view that guides TV)",
            scene.display()
        ));
    }
    let params = params_from_env();
    let (out, history, report, secs) = refine_guided::<f32>(&scene, &d, &c, params);
    if std::env::var("TV_Q16").is_ok() {
        let (q, _, qreport, qsecs) = refine_guided::<lfdepth::Q16>(&scene, &d, &c, params);
        let diffs: Vec<f32> = q.iter().zip(&out).map(|(a, b)| (a - b).abs()).collect();
        let max = diffs.iter().cloned().fold(0.0, f32::max);
        let mean = diffs.iter().sum::<f32>() / diffs.len() as f32;
        let over = diffs.iter().filter(|&&d| d > 0.01).count();
        println!(
            "q16: max |q16 − f32| {max:.5} px, mean {mean:.6}, {over} px over 0.01; {qreport:?} in {:.1} ms",
            qsecs * 1e3
        );
    }
    let before = scores(&d, &gt, w, h);
    let after = scores(&out, &gt, w, h);
    println!(
        "params {params:?}\ninput  badpix {:.3} mse {:.4}\noutput badpix {:.3} mse {:.4}\n\
         {report:?} in {:.1} ms",
        before.0,
        before.1,
        after.0,
        after.1,
        secs * 1e3
    );
    if let Ok(path) = std::env::var("TV_HISTORY") {
        let text: Vec<String> = history.iter().map(|v| format!("{v:e}")).collect();
        std::fs::write(path, text.join("\n")).unwrap();
    }
    if let Ok(path) = std::env::var("TV_OUT") {
        write_pfm(path.as_ref(), w, h, &out);
    }
}

fn params_from_env() -> TvParams {
    let d = TvParams::default();
    TvParams {
        lambda: env_f32("TV_LAMBDA", d.lambda),
        tikhonov: env_f32("TV_TIKHONOV", d.tikhonov),
        confidence_threshold: env_f32("TV_THRESHOLD", d.confidence_threshold),
        confidence_power: env_f32("TV_POWER", d.confidence_power),
        edge_sigma: env_f32("TV_SIGMA", d.edge_sigma),
        edge_floor: env_f32("TV_FLOOR", d.edge_floor),
        norm: if std::env::var("TV_NORM").as_deref() == Ok("l1") {
            TvNorm::L1
        } else {
            d.norm
        },
        max_iterations: env_f32("TV_ITERS", d.max_iterations as f32) as usize,
        tolerance: env_f32("TV_TOL", d.tolerance),
        step: env_f32("TV_STEP", d.step),
        relaxation: env_f32("TV_RELAX", d.relaxation),
        tile: env_f32("TV_TILE", d.tile as f32) as usize,
        halo: env_f32("TV_HALO", d.halo as f32) as usize,
        sweeps: env_f32("TV_SWEEPS", d.sweeps as f32) as usize,
    }
}

fn fail(why: &str) -> ! {
    eprintln!("error: {why}");
    std::process::exit(2);
}

/// A one-channel PFM map as (width, height, values), or a clear error and exit.
fn pfm_map(path: &Path) -> (usize, usize, Vec<f32>) {
    match pfm::read(path) {
        Ok(map) => (map.width, map.height, map.data),
        Err(e) => fail(&e.to_string()),
    }
}
