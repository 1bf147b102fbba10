//! Streams synthetic 9×9 light fields band by band, as firmware would: the "sensor" (the
//! 17 cross views, rendered up front) delivers each image row once into a sliding band
//! buffer, the stream estimates each band into the output map, and every working byte is
//! in two fixed arrays (kernel scalars and `f32` region maps) of 256 KiB together, sized
//! at compile time and checked against the plan.
//!
//! ```sh
//! cargo run --release -p lfdepth --features scenes --example stream             # 512², 1024², mixed
//! cargo run --release -p lfdepth --features scenes --example stream -- 512 --compare  # + whole frame
//! cargo run --release -p lfdepth --features scenes --example stream -- 256 --scene planes --q16 --halo 8
//! ```
//!
//! The host side uses std (Vec) only for what stands for the outside world: the sensor's
//! frames, the band buffer, the output map and the ground truth used to score it. The
//! stream itself allocates nothing.

use std::time::Instant;

/// CPU time of this thread (Linux `schedstat`, ns on CPU), or wall time elsewhere: the
/// development machine is shared, so CPU time is the steadier figure.
fn cpu_seconds(since: Instant) -> f64 {
    std::fs::read_to_string("/proc/thread-self/schedstat")
        .ok()
        .and_then(|s| s.split_whitespace().next()?.parse::<f64>().ok())
        .map_or(since.elapsed().as_secs_f64(), |ns| ns * 1e-9)
}

use lfdepth::epi::{DisparityRange, EpiParams};
use lfdepth::metrics::{self, EvalOptions};
use lfdepth::pipeline::{self, Stages};
use lfdepth::refine::RefineParams;
use lfdepth::stream::{CrossBand, StreamPlan};
use lfdepth::synth::{self, SceneKind, SynthSpec};
use lfdepth::tv::{self, TvParams};
use lfdepth::{Grid, Layout, LightField, Params, Plan, Scalar, Q16};

/// The scratch budget, 256 KiB: kernel scalars (4 bytes, `f32` or `Q16`) and the `f32`
/// region maps, split so that a 68-pixel region (tile 36 + halo 16) fits exactly.
const KERNEL_ELEMENTS: usize = 56_064;
const MAP_ELEMENTS: usize = 256 * 1024 / 4 - KERNEL_ELEMENTS;
/// TV context around each tile, unless `--halo` says otherwise.
const HALO: usize = 16;

/// Stream parameters: the defaults with the camera's disparity range, no refinement, and
/// the largest TV tile whose scratch fits the two arrays.
fn stream_params(layout: Layout, min: f32, max: f32, halo: usize) -> (Params, StreamPlan) {
    let mut best = None;
    for tile in 8..=512 {
        let params = Params {
            epi: EpiParams {
                range: DisparityRange::Fixed { min, max },
                ..EpiParams::default()
            },
            refine: RefineParams::off(),
            median: lfdepth::median::MedianParams::off(),
            geofill: lfdepth::geofill::GeoFillParams::off(),
            tv: TvParams {
                tile,
                halo,
                ..TvParams::default()
            },
            sweep: lfdepth::planesweep::PlaneSweepParams::off(),
            ..Params::default()
        };
        let Ok(plan) = StreamPlan::new(layout, params) else {
            continue;
        };
        if plan.scratch_len() <= KERNEL_ELEMENTS && plan.map_scratch_len() <= MAP_ELEMENTS {
            best = Some((params, plan));
        }
    }
    best.expect("a tile of 8 px fits the budget")
}

/// The sensor: the 17 cross views of a rendered frame; it hands out each row once.
struct Sensor {
    layout: Layout,
    views: Vec<Vec<u8>>,
}

impl Sensor {
    fn new(spec: &SynthSpec) -> Self {
        let layout = spec.layout();
        let view_len = spec.width * spec.height * spec.channels;
        let slots = CrossBand::<u8>::slots(spec.grid);
        let mut views = vec![vec![0u8; view_len]; slots];
        for r in 0..spec.grid.rows {
            for c in 0..spec.grid.cols {
                if let Some(slot) = CrossBand::<u8>::slot(spec.grid, r, c) {
                    synth::render_view(spec, r, c, &mut views[slot]).unwrap();
                }
            }
        }
        Sensor { layout, views }
    }
    fn row(&self, slot: usize, y: usize) -> &[u8] {
        let len = self.layout.width * self.layout.channels;
        &self.views[slot][y * len..(y + 1) * len]
    }
}

struct Figures {
    scratch_bytes: usize,
    band_bytes: usize,
    output_bytes: usize,
    tile: usize,
    seconds: f64,
    epi_overhead: f64,
    tv_overhead: f64,
}

/// Streams one frame into `disparity` / `confidence` with kernels in `T`.
fn run_stream<T: Scalar>(
    plan: &StreamPlan,
    sensor: &Sensor,
    disparity: &mut [f32],
    confidence: &mut [f32],
) -> Figures {
    let layout = *plan.plan().layout();
    let row_len = layout.width * layout.channels;
    let slots = CrossBand::<u8>::slots(layout.grid);
    let max_rows = plan.max_input_rows();
    let view_stride = max_rows * row_len;
    // The working area, 256 KiB in all: kernel scalars and the f32 region maps.
    let mut kernel = [T::ZERO; KERNEL_ELEMENTS];
    let mut maps_area = [0.0f32; MAP_ELEMENTS];
    let scratch = &mut kernel[..plan.scratch_len()];
    let maps = &mut maps_area[..plan.map_scratch_len()];

    let mut band = vec![0u8; slots * view_stride];
    let mut held: core::ops::Range<usize> = 0..0;
    let start = Instant::now();
    let cpu0 = cpu_seconds(start);
    for b in 0..plan.bands() {
        let rows = plan.input_rows(b).unwrap();
        // Slide: keep the rows already held, read only the new ones from the sensor.
        let keep = rows.start.max(held.start)..held.end.min(rows.end);
        for slot in 0..slots {
            let base = slot * view_stride;
            if !keep.is_empty() {
                let from = base + (keep.start - held.start) * row_len;
                band.copy_within(from..from + keep.len() * row_len, base);
            }
            for y in keep.end.max(rows.start)..rows.end {
                let at = base + (y - rows.start) * row_len;
                band[at..at + row_len].copy_from_slice(sensor.row(slot, y));
            }
        }
        held = rows.clone();
        let input = CrossBand::new(&band, &layout, rows, row_len, view_stride).unwrap();
        let out = plan.output_rows(b).unwrap();
        let span = out.start * layout.width..out.end * layout.width;
        plan.process_band(
            b,
            &input,
            &mut disparity[span.clone()],
            &mut confidence[span],
            scratch,
            maps,
        )
        .unwrap();
    }
    let seconds = cpu_seconds(start) - cpu0;

    // Work of the overlaps: EPI line samples and TV nodes against the whole frame's.
    let (mh, mv) = plan.margins();
    let (cols, rows) = tv::tile_count(plan.plan().tv());
    let (mut epi, mut nodes) = (0usize, 0usize);
    for index in 0..cols * rows {
        let (_, region) = tv::tile_rects(plan.plan().tv(), index).unwrap();
        // Columns shared with the tile to the left are moved, not estimated again.
        let shared = if index % cols == 0 {
            0
        } else {
            let (_, left) = tv::tile_rects(plan.plan().tv(), index - 1).unwrap();
            (left.x + left.width).saturating_sub(region.x)
        };
        let (x0, x1) = (region.x + shared, region.x + region.width);
        let n_h = (x1 + mh).min(layout.width) - x0.saturating_sub(mh);
        let n_v = (region.y + region.height + mv).min(layout.height) - region.y.saturating_sub(mv);
        epi += region.height * n_h + (x1 - x0) * n_v;
        nodes += region.width * region.height;
    }
    let pixels = layout.pixels();
    Figures {
        scratch_bytes: plan.scratch_bytes(core::mem::size_of::<T>()),
        band_bytes: band.len(),
        output_bytes: 2 * pixels * 4,
        tile: plan.plan().params().tv.tile,
        seconds,
        epi_overhead: epi as f64 / (2 * pixels) as f64,
        tv_overhead: nodes as f64 / pixels as f64,
    }
}

fn score(est: &[f32], gt: &[f32], side: usize) -> f64 {
    let mut scratch = vec![0.0f32; metrics::scratch_len(side, side)];
    metrics::evaluate(est, gt, side, side, &EvalOptions::default(), &mut scratch)
        .unwrap()
        .badpix_007
}

/// The whole-frame pipeline (all 81 views rendered) with `params`; returns its disparity.
fn whole_frame(spec: &SynthSpec, params: Params) -> (Vec<f32>, f64) {
    let mut views = vec![0u8; spec.layout().validate().unwrap()];
    let mut gt = vec![0.0f32; spec.width * spec.height];
    let mut h = vec![lfdepth::Homography::IDENTITY; spec.grid.len()];
    synth::render(spec, &mut views, &mut gt, &mut h).unwrap();
    let plan = Plan::new(spec.layout(), params).unwrap();
    let lf = LightField::new(&views, spec.layout()).unwrap();
    let mut d = vec![0.0; plan.pixels()];
    let mut c = vec![0.0; plan.pixels()];
    let mut scratch = vec![0.0f32; pipeline::scratch_len(&plan)];
    let mut maps = vec![0.0f32; pipeline::map_scratch_len(&plan)];
    let start = Instant::now();
    let cpu0 = cpu_seconds(start);
    pipeline::run(
        &plan,
        &lf,
        Stages::Full,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut [],
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| core::ops::ControlFlow::Continue(()),
    )
    .unwrap();
    (d, cpu_seconds(start) - cpu0)
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut sides = Vec::new();
    let (mut compare, mut q16, mut scene, mut halo) = (false, false, SceneKind::Mixed, HALO);
    let mut it = args.iter();
    while let Some(a) = it.next() {
        match a.as_str() {
            "--compare" => compare = true,
            "--q16" => q16 = true,
            "--halo" => {
                halo = it
                    .next()
                    .and_then(|h| h.parse().ok())
                    .expect("--halo PIXELS");
            }
            "--scene" => {
                let name = it.next().expect("--scene NAME");
                scene = SceneKind::from_name(name).expect("a scene name");
            }
            side => sides.push(side.parse::<usize>().expect("a frame side in pixels")),
        }
    }
    if sides.is_empty() {
        sides = vec![512, 1024];
    }
    println!(
        "| frame | scalar | tile+halo | scratch B | input band B | output B | stream CPU s | EPI work | TV work | BadPix0.07 % |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|");
    for side in sides {
        let spec = SynthSpec::new(scene, Grid::new(9, 9), side, side);
        let (params, plan) =
            stream_params(spec.layout(), spec.disparity_min, spec.disparity_max, halo);
        let sensor = Sensor::new(&spec);
        let mut gt = vec![0.0f32; side * side];
        synth::render_ground_truth(&spec, &mut gt).unwrap();
        let mut d = vec![0.0f32; side * side];
        let mut c = vec![0.0f32; side * side];
        let f = if q16 {
            run_stream::<Q16>(&plan, &sensor, &mut d, &mut c)
        } else {
            run_stream::<f32>(&plan, &sensor, &mut d, &mut c)
        };
        println!(
            "| 9×9×{side}² {} | {} | {}+{halo} | {} | {} | {} | {:.2} | {:.2}× | {:.2}× | {:.3} |",
            scene.name(),
            if q16 { "Q16" } else { "f32" },
            f.tile,
            f.scratch_bytes,
            f.band_bytes,
            f.output_bytes,
            f.seconds,
            f.epi_overhead,
            f.tv_overhead,
            score(&d, &gt, side),
        );
        if compare && !q16 {
            let (same, t_same) = whole_frame(&spec, params);
            let identical = same.iter().zip(&d).all(|(a, b)| a.to_bits() == b.to_bits());
            println!(
                "whole frame, same params (tile {}): {t_same:.2} s CPU, BadPix0.07 {:.3} %, bit-identical to the stream: {identical}",
                f.tile,
                score(&same, &gt, side)
            );
            let mut default_tiles = params;
            default_tiles.tv = TvParams::default();
            let (dflt, t_dflt) = whole_frame(&spec, default_tiles);
            println!(
                "whole frame, default TV tiles (128+16): {t_dflt:.2} s CPU, BadPix0.07 {:.3} %",
                score(&dflt, &gt, side)
            );
        }
    }
}
