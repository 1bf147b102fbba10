//! The alignment on random views: `align::estimate` and the prelude
//! `pipeline::run_aligned` (alignment, warp, then the EPI stage) on random light fields
//! of views 40…63 px (a sheared texture, optionally with noise), in mode `on` half the
//! time (else `auto` or `off`), any views, interpolation and other parameters drawn
//! through the options table. Each call gives `Ok` with one finite homography per view,
//! or an error; nothing panics.
#![no_main]

mod common;

use core::ops::ControlFlow;

use common::{Setting, Shape};
use lfdepth::options::{self, Value};
use lfdepth::pipeline::{self, AlignBuffers, Stages};
use lfdepth::{align, Homography, LightField, Plan};
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    shape: Shape,
    fast: bool,
    settings: Vec<Setting>,
    /// `run_aligned` (EPI after the prelude) instead of the estimate alone.
    prelude: bool,
    /// The alignment mode, set over the drawn settings: `on` half the time, so that the
    /// estimate runs even on the rectified arrays `Shape` makes (where `auto` keeps the
    /// identities after its first check), else `auto` or `off`.
    mode: u8,
}

const MAX_SCRATCH: usize = 1 << 24;

fuzz_target!(|input: Input| {
    // Views of 40…63 px: on smaller ones the centre view has too few corners and the
    // estimate stops at its first check.
    let layout = input.shape.layout_from(40);
    let mut params = common::params(input.fast, &input.settings);
    let mode = match input.mode % 4 {
        0 => "auto",
        1 => "off",
        _ => "on",
    };
    if let Some(t) = options::by_flag("--align") {
        let _ = t.apply(&mut params, Value::Choice(mode));
    }
    let Ok(plan) = Plan::new(layout, params) else {
        return;
    };
    let samples = input.shape.samples_for(layout);
    let lf = LightField::new(&samples, layout).expect("a packed layout's buffer");
    let views = layout.grid.len();
    let mut homographies = vec![Homography::IDENTITY; views];
    let Ok(scratch_len) = pipeline::align_scratch_len(&plan) else {
        return;
    };
    if scratch_len > MAX_SCRATCH {
        return;
    }
    let mut scratch = vec![0f32; scratch_len];
    if input.prelude {
        let stages = Stages::Epi;
        let kernel = pipeline::stage_scratch_len(&plan, stages);
        let maps_len = pipeline::stage_map_scratch_len(&plan, stages);
        if kernel > MAX_SCRATCH || maps_len > MAX_SCRATCH {
            return;
        }
        let mut aligned = vec![0u8; samples.len()];
        let mut buffers = AlignBuffers {
            homographies: &mut homographies,
            scratch: &mut scratch,
            aligned: &mut aligned,
        };
        let pixels = plan.pixels();
        let (mut d, mut c) = (vec![0f32; pixels], vec![0f32; pixels]);
        let mut k = vec![0f32; kernel];
        let mut maps = vec![0f32; maps_len];
        let _ = pipeline::run_aligned(
            &plan,
            &lf,
            stages,
            &mut buffers,
            pipeline::RunOutput {
                disparity: &mut d,
                confidence: &mut c,
                history: &mut [],
            },
            pipeline::RunScratch {
                kernel: &mut k,
                maps: &mut maps,
            },
            &mut |_| ControlFlow::Continue(()),
        );
    } else if align::estimate(&lf, &plan.params().align, &mut homographies, &mut scratch).is_ok() {
        for h in &homographies {
            assert!(
                h.m.iter().all(|v| v.is_finite()),
                "a non-finite homography {h:?}"
            );
        }
    }
});
