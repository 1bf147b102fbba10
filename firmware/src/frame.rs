//! The whole-frame pipeline (`pipeline::run_aligned_into`: alignment prelude → EPI → refine →
//! refill → weighted median → TV) on a small synthetic frame held in fixed memory. The stream is
//! the firmware's way to process a large frame in bounded memory; this entry exists so
//! that the panic-free link check (`--features panic-free,whole-frame`) also covers every
//! whole-frame public entry point, with the default parameters (every stage on) but the
//! EPI start: the stream cannot run the plane sweep, so both images start alike, and the
//! buffers below are sized for the EPI start.
// A device image runs either this or the stream (feature `whole-frame`); the host runs both.
#![cfg_attr(
    all(target_os = "none", not(feature = "whole-frame")),
    allow(dead_code)
)]

use core::ops::ControlFlow;

use lfdepth::align::AlignReport;
use lfdepth::geometry::Homography;
use lfdepth::pipeline::{self, AlignBuffers, Stages};
use lfdepth::planesweep::PlaneSweepParams;
use lfdepth::{Error, Grid, Layout, LightField, Params, Plan, Result, Scalar};

use crate::sensor;
use crate::stream::{Kernel, Summary};

pub const WIDTH: usize = 32;
pub const HEIGHT: usize = 32;
const GRID: Grid = Grid::new(9, 9);
const VIEWS: usize = 81 * WIDTH * HEIGHT;
const KERNEL_ELEMENTS: usize = 48 * 1024;
// The map scratch: the run's state (four maps and the TV history), one part's outputs
// and the weighted median's three maps (14,772 at 32×32 with `Params::default()` and
// the EPI start).
const MAP_ELEMENTS: usize = 16 * 1024;
const ALIGN_ELEMENTS: usize = 128 * 1024;
const HISTORY: usize = 300;

/// Every buffer of a whole-frame run.
pub struct Memory {
    views: [u8; VIEWS],
    aligned: [u8; VIEWS],
    homographies: [Homography; 81],
    align: [f32; ALIGN_ELEMENTS],
    kernel: [Kernel; KERNEL_ELEMENTS],
    maps: [f32; MAP_ELEMENTS],
    history: [f32; HISTORY],
    disparity: [f32; WIDTH * HEIGHT],
    confidence: [f32; WIDTH * HEIGHT],
}

impl Memory {
    pub const ZERO: Memory = Memory {
        views: [0; VIEWS],
        aligned: [0; VIEWS],
        // All zeros (the estimate writes every one) keeps the whole struct in `.bss`.
        homographies: [Homography { m: [0.0; 9] }; 81],
        align: [0.0; ALIGN_ELEMENTS],
        kernel: [<Kernel as Scalar>::ZERO; KERNEL_ELEMENTS],
        maps: [0.0; MAP_ELEMENTS],
        history: [0.0; HISTORY],
        disparity: [0.0; WIDTH * HEIGHT],
        confidence: [0.0; WIDTH * HEIGHT],
    };
}

fn slice<T>(buffer: &mut [T], needed: usize) -> Result<&mut [T]> {
    let got = buffer.len();
    buffer
        .get_mut(..needed)
        .ok_or(Error::ScratchTooSmall { needed, got })
}

/// Renders the sensor's frame into `memory` and runs the default pipeline on it.
/// `mark(stage)` is called when the work of `stage` begins (`sensor`; `pipeline`, the
/// pipeline's work before the first stage reports progress; each stage from its first
/// progress report on; `checksum`), so that a device can count the cost of each.
/// The alignment's report goes to `report`: a device keeps it in a static of its own
/// (≈ 2.4 KB off the stack; not in `Memory`, which must stay all zeros to stay in `.bss`).
pub fn run(
    memory: &mut Memory,
    report: &mut AlignReport,
    mark: &mut impl FnMut(&'static str),
) -> Result<Summary> {
    mark("sensor");
    let layout = Layout::packed(GRID, WIDTH, HEIGHT, 1);
    let params = Params {
        sweep: PlaneSweepParams::off(),
        ..Params::default()
    };
    let plan = Plan::new(layout, params)?;
    let (r0, c0) = GRID.center();
    for (v, view) in memory.views.chunks_exact_mut(WIDTH * HEIGHT).enumerate() {
        let (r, c) = (v / GRID.cols, v % GRID.cols);
        let (du, dv) = (c as f32 - c0 as f32, r as f32 - r0 as f32);
        for (y, row) in view.chunks_exact_mut(WIDTH).enumerate() {
            sensor::row(du, dv, y, WIDTH, HEIGHT, row);
        }
    }
    let lf = LightField::new(&memory.views, layout)?;
    let mut buffers = AlignBuffers {
        homographies: &mut memory.homographies,
        scratch: slice(&mut memory.align, pipeline::align_scratch_len(&plan)?)?,
        aligned: slice(&mut memory.aligned, pipeline::aligned_len(&plan)?)?,
    };
    let scratch = slice(&mut memory.kernel, pipeline::scratch_len(&plan))?;
    let maps = slice(&mut memory.maps, pipeline::map_scratch_len(&plan))?;
    mark("pipeline");
    pipeline::run_aligned_into(
        &plan,
        &lf,
        Stages::Full,
        pipeline::Prelude {
            buffers: &mut buffers,
            report,
        },
        pipeline::RunOutput {
            disparity: &mut memory.disparity,
            confidence: &mut memory.confidence,
            history: &mut memory.history,
        },
        pipeline::RunScratch {
            kernel: scratch,
            maps,
        },
        &mut |progress| {
            mark(progress.stage);
            ControlFlow::Continue(())
        },
    )?;
    mark("checksum");
    let mut checksum = 0u32;
    let mut error = 0.0f32;
    for (i, &d) in memory.disparity.iter().enumerate() {
        checksum = checksum.wrapping_add(d.to_bits());
        error += libm::fabsf(d - sensor::disparity(i % WIDTH, i / WIDTH, WIDTH, HEIGHT));
    }
    Ok(Summary {
        scratch_bytes: pipeline::scratch_len(&plan) * core::mem::size_of::<Kernel>()
            + pipeline::map_scratch_len(&plan) * 4
            + pipeline::align_scratch_len(&plan)? * 4,
        checksum,
        mean_abs_error: error / (WIDTH * HEIGHT) as f32,
    })
}
