//! The stream over the synthetic sensor, in fixed memory: a sliding band of the 17 cross
//! views, the 256 KiB scratch split into kernel scalars and region maps, and one band of
//! output rows.
// A device image runs either this or the whole frame (feature `whole-frame`); the host
// runs both. `Kernel` and `Summary` serve both.
#![cfg_attr(all(target_os = "none", feature = "whole-frame"), allow(dead_code))]

use lfdepth::epi::{ColorMode, DisparityRange, EpiParams};
use lfdepth::planesweep::PlaneSweepParams;
use lfdepth::refine::RefineParams;
use lfdepth::stream::{CrossBand, StreamPlan};
use lfdepth::tv::TvParams;
use lfdepth::{Error, Grid, Layout, Params, Result, Scalar};

use crate::sensor;

/// Kernel scalars: `f32` with an FPU, Q16.16 without (thumbv6m) or with the feature
/// `q16` (so that the host runs what the thumbv6m image runs).
#[cfg(not(any(feature = "q16", all(target_os = "none", not(target_abi = "eabihf")))))]
pub type Kernel = f32;
#[cfg(any(feature = "q16", all(target_os = "none", not(target_abi = "eabihf"))))]
pub type Kernel = lfdepth::Q16;

/// The frame side: 128, or `LFDEPTH_FIRMWARE_SIDE` at build time (for measuring how the
/// cost grows with the frame, docs/EMBEDDED.md; the band buffer grows with it).
pub const WIDTH: usize = match build_option(option_env!("LFDEPTH_FIRMWARE_SIDE")) {
    Some(side) => side,
    None => 128,
};
pub const HEIGHT: usize = WIDTH;
/// TV's most iterations per tile: `LFDEPTH_FIRMWARE_TV_ITERATIONS` at build time, or the
/// default (runs with 1 and 2 measure what the first iteration and one more cost).
const TV_ITERATIONS: Option<usize> = build_option(option_env!("LFDEPTH_FIRMWARE_TV_ITERATIONS"));
const GRID: Grid = Grid::new(9, 9);
const TILE: usize = 36;
const HALO: usize = 16;
/// Views of the cross and the most rows a band holds (checked against the plan).
const SLOTS: usize = 17;
const BAND_ROWS: usize = 115;
/// The 256 KiB scratch: kernel scalars and `f32` region maps.
const KERNEL_ELEMENTS: usize = 56_064;
const MAP_ELEMENTS: usize = 256 * 1024 / 4 - KERNEL_ELEMENTS;

/// Every buffer the stream uses.
pub struct Memory {
    band: [u8; SLOTS * BAND_ROWS * WIDTH],
    kernel: [Kernel; KERNEL_ELEMENTS],
    maps: [f32; MAP_ELEMENTS],
    disparity: [f32; TILE * WIDTH],
    confidence: [f32; TILE * WIDTH],
}

impl Memory {
    pub const ZERO: Memory = Memory {
        band: [0; SLOTS * BAND_ROWS * WIDTH],
        kernel: [<Kernel as Scalar>::ZERO; KERNEL_ELEMENTS],
        maps: [0.0; MAP_ELEMENTS],
        disparity: [0.0; TILE * WIDTH],
        confidence: [0.0; TILE * WIDTH],
    };
}

/// What a run produced.
pub struct Summary {
    #[cfg_attr(target_os = "none", allow(dead_code))]
    pub scratch_bytes: usize,
    /// Bits of every output disparity, summed (so nothing is optimised away).
    pub checksum: u32,
    #[cfg_attr(target_os = "none", allow(dead_code))]
    pub mean_abs_error: f32,
}

/// A decimal build-time option (`None` when unset). A value that is not a positive
/// decimal number stops the build.
const fn build_option(value: Option<&str>) -> Option<usize> {
    let Some(text) = value else {
        return None;
    };
    let bytes = text.as_bytes();
    let mut n = 0usize;
    let mut i = 0;
    while i < bytes.len() {
        let digit = bytes[i];
        assert!(
            digit.is_ascii_digit() && n < 1_000_000,
            "LFDEPTH_FIRMWARE_* options are positive decimal numbers below 1000000"
        );
        n = n * 10 + (digit - b'0') as usize;
        i += 1;
    }
    assert!(
        n > 0,
        "LFDEPTH_FIRMWARE_* options are positive decimal numbers"
    );
    Some(n)
}

fn too_small(needed: usize, got: usize) -> Error {
    Error::ScratchTooSmall { needed, got }
}

/// Streams one frame of the sensor through `memory`. `mark(stage)` is called when the
/// work of `stage` begins (`sensor`: rendering the band's rows; `stream`: the band's
/// estimate; `checksum`), so that a device can count the cost of each.
pub fn run(memory: &mut Memory, mark: &mut impl FnMut(&'static str)) -> Result<Summary> {
    let layout = Layout::packed(GRID, WIDTH, HEIGHT, 1);
    let params = Params {
        epi: EpiParams {
            range: DisparityRange::Fixed {
                min: sensor::FAR - 0.25,
                max: sensor::NEAR + 0.25,
            },
            color: ColorMode::Gray,
            ..EpiParams::default()
        },
        refine: RefineParams::off(),
        median: lfdepth::median::MedianParams::off(),
        geofill: lfdepth::geofill::GeoFillParams::off(),
        tv: TvParams {
            tile: TILE,
            halo: HALO,
            max_iterations: match TV_ITERATIONS {
                Some(n) => n,
                None => TvParams::default().max_iterations,
            },
            ..TvParams::default()
        },
        // The stream runs the EPI start: the plane sweep is not streamed.
        sweep: PlaneSweepParams::off(),
        ..Params::default()
    };
    let plan = StreamPlan::new(layout, params)?;
    if plan.max_input_rows() > BAND_ROWS {
        return Err(too_small(plan.max_input_rows(), BAND_ROWS));
    }
    let scratch = memory
        .kernel
        .get_mut(..plan.scratch_len())
        .ok_or(too_small(plan.scratch_len(), KERNEL_ELEMENTS))?;
    let maps = memory
        .maps
        .get_mut(..plan.map_scratch_len())
        .ok_or(too_small(plan.map_scratch_len(), MAP_ELEMENTS))?;
    let view_stride = BAND_ROWS * WIDTH;
    let (r0, c0) = GRID.center();
    let mut checksum = 0u32;
    let mut error = 0.0f32;
    for band in 0..plan.bands() {
        let rows = plan.input_rows(band)?;
        mark("sensor");
        // The sensor delivers the band's rows of every cross view.
        for r in 0..GRID.rows {
            for c in 0..GRID.cols {
                let Some(slot) = CrossBand::<u8>::slot(GRID, r, c) else {
                    continue;
                };
                let (du, dv) = (c as f32 - c0 as f32, r as f32 - r0 as f32);
                for (i, y) in rows.clone().enumerate() {
                    let at = slot * view_stride + i * WIDTH;
                    if let Some(out) = memory.band.get_mut(at..at + WIDTH) {
                        sensor::row(du, dv, y, WIDTH, HEIGHT, out);
                    }
                }
            }
        }
        let input = CrossBand::new(&memory.band, &layout, rows, WIDTH, view_stride)?;
        let out = plan.output_rows(band)?;
        let len = out.len() * WIDTH;
        let (disparity, confidence) = (
            memory
                .disparity
                .get_mut(..len)
                .ok_or(too_small(len, TILE * WIDTH))?,
            memory
                .confidence
                .get_mut(..len)
                .ok_or(too_small(len, TILE * WIDTH))?,
        );
        mark("stream");
        plan.process_band(band, &input, disparity, confidence, scratch, maps)?;
        mark("checksum");
        // The rows are ready: a real device would send them on here.
        for (y, row) in out.zip(disparity.chunks_exact(WIDTH)) {
            for (x, &d) in row.iter().enumerate() {
                checksum = checksum.wrapping_add(d.to_bits());
                error += libm::fabsf(d - sensor::disparity(x, y, WIDTH, HEIGHT));
            }
        }
    }
    Ok(Summary {
        scratch_bytes: plan.scratch_bytes(core::mem::size_of::<Kernel>()),
        checksum,
        mean_abs_error: error / (WIDTH * HEIGHT) as f32,
    })
}
