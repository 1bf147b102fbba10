//! CPU seconds of each serial core stage (EPI, refinement, TV, the whole
//! `pipeline::run`: firmware's whole-frame path) in `f32` and in Q16.16 on HCI cotton
//! (`../shared/data`), each stage from the same `f32` input, one thread, the mean of
//! REPEATS runs (default 2). Prints the Markdown table of docs/stages/fixed-point.md:
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example fixed_point_stage_times [-- REPEATS]
//! ```

#[path = "../tests/tv_support.rs"]
mod tv_support;

use std::ops::ControlFlow;

use lfdepth::pipeline::{self, Stages};
use lfdepth::refine;
use lfdepth::setup::DisparityOut;
use lfdepth::tv::{self, Guide, Maps};
use lfdepth::{LightField, Params, Plan, Scalar, Q16};
use tv_support::{cpu_seconds, load_hci, shared_data};

fn main() {
    let repeats = match std::env::args().nth(1).map(|v| v.parse::<usize>()) {
        None => 2,
        Some(Ok(n)) if n >= 1 => n,
        Some(_) => {
            eprintln!(
                "error: the argument is the number of repeats per stage (a positive integer)"
            );
            std::process::exit(2);
        }
    };
    let Some(data) = shared_data("the fixed-point stage times") else {
        return;
    };
    let (views, layout) = load_hci(&data.join("hci/training/cotton"));
    let lf = LightField::new(&views, layout).unwrap();
    let float = stage_cpu::<f32>(&lf, repeats);
    let fixed = stage_cpu::<Q16>(&lf, repeats);
    println!("| stage | f32 CPU s | Q16.16 CPU s | Q16 / f32 |");
    println!("|---|---:|---:|---:|");
    for (i, name) in ["EPI", "refinement", "TV", "whole pipeline::run"]
        .iter()
        .enumerate()
    {
        println!(
            "| {name} | {:.2} | {:.2} | {:.1}× |",
            float[i],
            fixed[i],
            fixed[i] / float[i]
        );
    }
}

/// CPU seconds of each serial core stage in `T` on HCI cotton (each stage from the same
/// `f32` input): EPI, refinement, TV, and the whole `pipeline::run`.
fn stage_cpu<T: Scalar>(lf: &LightField<'_, u8>, repeats: usize) -> [f64; 4] {
    let plan = Plan::new(*lf.layout(), Params::default()).unwrap();
    let n = plan.pixels();
    let (mut d, mut c) = (vec![0.0f32; n], vec![0.0f32; n]);
    let mut scratch = vec![0.0f32; pipeline::scratch_len(&plan)];
    let hyps = lfdepth::epi::estimate(plan.epi(), lf, &mut d, &mut c, &mut scratch).unwrap();
    let range = (hyps.min(), hyps.max());
    let (mut rd, mut rc) = (vec![0.0f32; n], vec![0.0f32; n]);
    refine::refine(
        plan.refine(),
        lf,
        range,
        &d,
        DisparityOut {
            disparity: &mut rd,
            confidence: &mut rc,
        },
        &mut scratch,
    )
    .unwrap();
    let mut work = vec![T::ZERO; pipeline::scratch_len(&plan)];
    let mut duals = vec![0.0f32; tv::dual_len(plan.tv())];
    let (mut od, mut oc) = (vec![0.0f32; n], vec![0.0f32; n]);
    let maps = Maps::new(lf.width(), lf.height(), &rd, &rc).unwrap();
    let guide = Guide::View(lf.center_view());
    let mut mid = vec![0.0f32; pipeline::map_scratch_len(&plan)];
    let time = |f: &mut dyn FnMut()| {
        let start = cpu_seconds();
        for _ in 0..repeats {
            f();
        }
        (cpu_seconds() - start) / repeats as f64
    };
    let epi = time(&mut || {
        lfdepth::epi::estimate(plan.epi(), lf, &mut od, &mut oc, &mut work).unwrap();
    });
    let refined = time(&mut || {
        refine::refine(
            plan.refine(),
            lf,
            range,
            &d,
            DisparityOut {
                disparity: &mut od,
                confidence: &mut oc,
            },
            &mut work,
        )
        .unwrap();
    });
    let regularised = time(&mut || {
        tv::refine(
            plan.tv(),
            &maps,
            &guide,
            &mut od,
            &mut [],
            tv::TvScratch {
                kernel: &mut work,
                duals: &mut duals,
            },
        )
        .unwrap();
    });
    let whole = time(&mut || {
        pipeline::run(
            &plan,
            lf,
            Stages::Full,
            pipeline::RunOutput {
                disparity: &mut od,
                confidence: &mut oc,
                history: &mut [],
            },
            pipeline::RunScratch {
                kernel: &mut work,
                maps: &mut mid,
            },
            &mut |_| ControlFlow::Continue(()),
        )
        .unwrap();
    });
    [epi, refined, regularised, whole]
}
