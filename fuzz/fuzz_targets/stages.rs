//! Every public stage entry point and `pipeline::run` on small random light fields
//! (grid 1…9 × 1…9, views 1…24 px, gray or RGB, 8-bit or float samples) with random
//! parameters drawn through the options table (any band and tile size, both presets),
//! computing in `f32` or Q16.16. Each call returns `Ok` or an error; on `Ok` the maps
//! have the plan's size and every confidence is in [0, 1] (or NaN where the disparity is
//! unknown); nothing panics.
#![no_main]

mod common;

use core::ops::ControlFlow;

use common::{Setting, Shape};
use lfdepth::pipeline::{self, Stages};
use lfdepth::setup::DisparityOut;
use lfdepth::tv::{self, Guide, Maps};
use lfdepth::{epi, geofill, median, refine};
use lfdepth::{LightField, Plan, Sample, Scalar, Q16};
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug, Clone, Copy)]
enum Entry {
    RunEpi,
    RunFull,
    Epi,
    Refine,
    Median,
    Geofill,
    Tv,
}

#[derive(Arbitrary, Debug)]
struct Input {
    shape: Shape,
    fast: bool,
    settings: Vec<Setting>,
    entry: Entry,
    fixed_point: bool,
    float_samples: bool,
    /// Input disparity of the map stages: sixteenths of a pixel, `i8::MIN` is NaN.
    map: Vec<i8>,
}

/// Elements above which a scratch buffer is not allocated (the plan is still made).
const MAX_SCRATCH: usize = 1 << 24;

fn buffer<T: Clone + Default>(len: usize) -> Option<Vec<T>> {
    (len <= MAX_SCRATCH).then(|| vec![T::default(); len])
}

fn confidence_ok(confidence: &[f32]) {
    for &c in confidence {
        // NaN is allowed: it marks a pixel without an estimate (module docs).
        assert!(
            c.is_nan() || (0.0..=1.0).contains(&c),
            "confidence {c} outside [0, 1]"
        );
    }
}

fn run_entry<T: Scalar, S: Sample>(plan: &Plan, lf: &LightField<'_, S>, input: &Input) {
    let pixels = plan.pixels();
    let mut disparity = vec![0f32; pixels];
    let mut confidence = vec![0f32; pixels];
    let map: Vec<f32> = (0..pixels)
        .map(|i| match input.map.get(i % input.map.len().max(1)) {
            Some(&i8::MIN) => f32::NAN,
            Some(&v) => f32::from(v) / 16.0,
            None => 0.0,
        })
        .collect();
    let weights: Vec<f32> = map
        .iter()
        .map(|d| {
            if d.is_finite() {
                (d.abs() / 8.0).min(1.0)
            } else {
                0.0
            }
        })
        .collect();
    let mut progress = |_| ControlFlow::Continue(());
    match input.entry {
        Entry::RunEpi | Entry::RunFull => {
            let stages = if matches!(input.entry, Entry::RunEpi) {
                Stages::Epi
            } else {
                Stages::Full
            };
            let (Some(mut scratch), Some(mut maps)) = (
                buffer::<T>(pipeline::stage_scratch_len(plan, stages)),
                buffer::<f32>(pipeline::stage_map_scratch_len(plan, stages)),
            ) else {
                return;
            };
            let mut history = vec![0f32; 8];
            if pipeline::run(
                plan,
                lf,
                stages,
                pipeline::RunOutput {
                    disparity: &mut disparity,
                    confidence: &mut confidence,
                    history: &mut history,
                },
                pipeline::RunScratch {
                    kernel: &mut scratch,
                    maps: &mut maps,
                },
                &mut progress,
            )
            .is_ok()
            {
                confidence_ok(&confidence);
            }
        }
        Entry::Epi => {
            let Some(mut scratch) = buffer::<T>(epi::scratch_len(plan.epi())) else {
                return;
            };
            if let Ok(h) = epi::estimate(
                plan.epi(),
                lf,
                &mut disparity,
                &mut confidence,
                &mut scratch,
            ) {
                assert!(
                    h.min().partial_cmp(&h.max()) != Some(core::cmp::Ordering::Greater),
                    "hypotheses {} > {}",
                    h.min(),
                    h.max()
                );
                confidence_ok(&confidence);
            }
        }
        Entry::Refine => {
            let Some(mut scratch) = buffer::<T>(refine::scratch_len(plan.refine())) else {
                return;
            };
            if refine::refine(
                plan.refine(),
                lf,
                (-2.0, 2.0),
                &map,
                DisparityOut {
                    disparity: &mut disparity,
                    confidence: &mut confidence,
                },
                &mut scratch,
            )
            .is_ok()
            {
                confidence_ok(&confidence);
            }
        }
        Entry::Median => {
            let Some(mut scratch) = buffer::<f32>(median::scratch_len(plan.median())) else {
                return;
            };
            let _ = median::filter(
                plan.median(),
                &lf.center_view(),
                &map,
                &mut disparity,
                &mut scratch,
            );
        }
        Entry::Geofill => {
            let Some(mut scratch) = buffer::<f32>(geofill::scratch_len(plan.geofill())) else {
                return;
            };
            let _ = geofill::fill(
                plan.geofill(),
                &lf.center_view(),
                &map,
                &mut disparity,
                &mut scratch,
            );
        }
        Entry::Tv => {
            let (Some(mut scratch), Some(mut duals)) = (
                buffer::<T>(tv::scratch_len(plan.tv())),
                buffer::<f32>(tv::dual_len(plan.tv())),
            ) else {
                return;
            };
            let layout = plan.layout();
            let Ok(maps) = Maps::new(layout.width, layout.height, &map, &weights) else {
                return;
            };
            let mut history = vec![0f32; 4];
            let _ = tv::refine(
                plan.tv(),
                &maps,
                &Guide::View(lf.center_view()),
                &mut disparity,
                &mut history,
                tv::TvScratch {
                    kernel: &mut scratch,
                    duals: &mut duals,
                },
            );
        }
    }
}

fn with_scalar<S: Sample>(plan: &Plan, samples: &[S], input: &Input) {
    let Ok(lf) = LightField::new(samples, *plan.layout()) else {
        panic!("a packed layout's buffer was refused");
    };
    if input.fixed_point {
        run_entry::<Q16, S>(plan, &lf, input);
    } else {
        run_entry::<f32, S>(plan, &lf, input);
    }
}

fuzz_target!(|input: Input| {
    let layout = input.shape.layout();
    let params = common::params(input.fast, &input.settings);
    let Ok(plan) = Plan::new(layout, params) else {
        return;
    };
    let samples = input.shape.samples();
    if input.float_samples {
        let floats: Vec<f32> = samples.iter().map(|&s| f32::from(s) / 255.0).collect();
        with_scalar(&plan, &floats, &input);
    } else {
        with_scalar(&plan, &samples, &input);
    }
});
