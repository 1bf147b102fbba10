//! The native engine: runs the core pipeline over a loaded light field, bands and tiles
//! in parallel with rayon, and reports progress and per-stage timings.
//!
//! Every stage computes in a scalar type `T` ([`estimate_in`]: `f32` or the Q16.16
//! [`lfdepth::Q16`]; [`estimate`] is `f32`). Every pixel is computed by the same core
//! code whatever the banding and the number of threads, so the result is bit-identical
//! for any `threads`, in either type.

use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use lfdepth::align::{self, AlignMode, AlignReport};
use lfdepth::epi::{self, Direction};
use lfdepth::geofill;
use lfdepth::median;
use lfdepth::pipeline::{self, Stages};
use lfdepth::tv::{self, Guide, Maps, SolveOutput};
use lfdepth::{refine, Homography, LightField, Params, Plan, Sample, Scalar, Q16};
use rayon::prelude::*;

/// How far the pipeline runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StageSelect {
    /// Initial disparity from EPIs only.
    Epi,
    /// Everything: (alignment when asked) → EPI → photometric refinement (when
    /// `params.refine.enabled`) → TV.
    Full,
}

/// What to run and with how many threads.
#[derive(Clone, Copy, Debug)]
pub struct EstimateOptions {
    /// Parameters of every stage.
    pub params: Params,
    /// How far to run.
    pub stage: StageSelect,
    /// Worker threads; `None` uses every core.
    pub threads: Option<usize>,
}

/// The result of one estimation.
#[derive(Clone, Debug, Default)]
pub struct Estimate {
    /// Centre-view width.
    pub width: usize,
    /// Centre-view height.
    pub height: usize,
    /// Disparity per pixel, row-major, top row first.
    pub disparity: Vec<f32>,
    /// Confidence per pixel in [0, 1].
    pub confidence: Vec<f32>,
    /// Wall time of each stage, in order.
    pub timings: Vec<(&'static str, Duration)>,
    /// TV residual norm per iteration (empty when TV did not run).
    pub residuals: Vec<f32>,
    /// What the alignment did (`None` when `params.align.mode` is off). A warning in it
    /// means auto mode could not align and the views were used as they are.
    pub align: Option<AlignReport>,
}

/// Lines per parallel band: small enough to balance two threads on small frames, large
/// enough that per-band overhead (scratch, progress) is negligible.
pub const BAND_LINES: usize = 16;

/// Rows per parallel band of the warp into the rectified array.
pub const WARP_BAND_ROWS: usize = 32;

/// The number type the stages compute in (the maps between them are `f32` either way).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Precision {
    /// IEEE single precision.
    #[default]
    F32,
    /// Q16.16 fixed point ([`lfdepth::Q16`]), as on a microcontroller without an FPU.
    Q16,
}

/// Estimates the disparity of the centre view, every stage computing in `f32`.
/// `progress(stage, done, total)` is called as work completes.
pub fn estimate<S: Sample + Sync>(
    lf: &LightField<'_, S>,
    options: &EstimateOptions,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    estimate_in::<f32, S>(lf, options, progress)
}

/// [`estimate`] with every stage computing in `precision`.
pub fn estimate_with<S: Sample + Sync>(
    lf: &LightField<'_, S>,
    options: &EstimateOptions,
    precision: Precision,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    match precision {
        Precision::F32 => estimate_in::<f32, S>(lf, options, progress),
        Precision::Q16 => estimate_in::<Q16, S>(lf, options, progress),
    }
}

/// [`estimate`] with every stage (EPI, refinement, TV) computing in `T`.
pub fn estimate_in<T: Scalar, S: Sample + Sync>(
    lf: &LightField<'_, S>,
    options: &EstimateOptions,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    let plan = Plan::new(*lf.layout(), options.params)?;
    let pool = match options.threads {
        None => None,
        Some(threads) => Some(
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads.max(1))
                .build()
                .map_err(|_| lfdepth::Error::InvalidParameter {
                    name: "threads",
                    reason: "could not start that many threads: use fewer",
                })?,
        ),
    };
    // The work runs on its own thread; this one forwards progress, so the callback
    // needs neither `Send` nor `Sync`.
    let done = AtomicU64::new(0);
    let total = AtomicU64::new(1);
    let stage = Mutex::new(epi::STAGE_RANGE);
    let finished = AtomicBool::new(false);
    let tracker = Tracker {
        done: &done,
        total: &total,
        stage: &stage,
    };
    std::thread::scope(|scope| {
        let worker = scope.spawn(|| {
            let result = match &pool {
                Some(pool) => {
                    pool.install(|| align_then_run::<T, S>(&plan, lf, options.stage, &tracker))
                }
                None => align_then_run::<T, S>(&plan, lf, options.stage, &tracker),
            };
            finished.store(true, Ordering::Release);
            result
        });
        let mut last = (u64::MAX, "");
        loop {
            let end = finished.load(Ordering::Acquire);
            let now = done.load(Ordering::Relaxed);
            let name = stage.lock().map(|s| *s).unwrap_or(epi::STAGE_RANGE);
            if (now, name) != last {
                progress(name, now, total.load(Ordering::Relaxed));
                last = (now, name);
            }
            if end {
                break;
            }
            std::thread::sleep(Duration::from_millis(15));
        }
        worker
            .join()
            .unwrap_or(Err(lfdepth::Error::InvalidParameter {
                name: "threads",
                reason: "a worker thread failed: run with fewer threads",
            }))
    })
}

/// Progress shared between the workers and the reporting thread.
struct Tracker<'a> {
    done: &'a AtomicU64,
    total: &'a AtomicU64,
    stage: &'a Mutex<&'static str>,
}

impl Tracker<'_> {
    fn start(&self, stage: &'static str, total: u64) {
        if let Ok(mut s) = self.stage.lock() {
            *s = stage;
        }
        self.done.store(0, Ordering::Relaxed);
        self.total.store(total, Ordering::Relaxed);
    }
    fn add(&self, units: u64) {
        self.done.fetch_add(units, Ordering::Relaxed);
    }
}

/// The alignment prelude (when `params.align.mode` is not off), then the stages on the
/// rectified views: homographies by the core estimate, the views the stages read warped
/// in parallel bands into an `f32` light field of the input's layout.
fn align_then_run<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stage: StageSelect,
    tracker: &Tracker<'_>,
) -> Result<Estimate, lfdepth::Error> {
    let stages = match stage {
        StageSelect::Epi => Stages::Epi,
        StageSelect::Full => Stages::Full,
    };
    let params = &pipeline::align_params(plan, stages);
    if params.mode == AlignMode::Off {
        return run_stages::<T, S>(plan, lf, stage, tracker);
    }
    let start = Instant::now();
    tracker.start(pipeline::STAGE_ALIGN, 1);
    let layout = *plan.layout();
    let mut homographies = vec![Homography::IDENTITY; layout.grid.len()];
    let mut scratch = vec![0.0f32; align::scratch_len(&layout, params)?];
    let report = align::estimate_with(
        lf,
        params,
        &mut homographies,
        &mut scratch,
        &mut ParallelViews,
    )?;
    drop(scratch);
    tracker.add(1);
    let mut timings = vec![(pipeline::STAGE_ALIGN, start.elapsed())];
    let mut estimate = if report.skipped {
        run_stages::<T, S>(plan, lf, stage, tracker)?
    } else {
        let start = Instant::now();
        // Zeroed pages that are never written (views no stage reads) cost no memory.
        let mut aligned = vec![0.0f32; pipeline::aligned_len(plan)?];
        warp_parallel(plan, lf, stages, &homographies, &mut aligned, tracker)?;
        timings.push((pipeline::STAGE_WARP, start.elapsed()));
        let rectified = LightField::new(&aligned[..], layout)?;
        let plan = &pipeline::resampled_plan(plan)?;
        run_stages::<T, f32>(plan, &rectified, stage, tracker)?
    };
    timings.append(&mut estimate.timings);
    estimate.timings = timings;
    estimate.align = Some(report);
    Ok(estimate)
}

/// The alignment estimate's per-view tracking over rayon's threads, each running job
/// with a pyramid buffer of its own (the core makes the result independent of how the
/// jobs are spread).
pub struct ParallelViews;

impl align::ViewMap for ParallelViews {
    fn map<F>(&mut self, tasks: &mut [align::ViewTask<'_>], scratch: &mut [f32], job: &F)
    where
        F: Fn(&mut align::ViewTask<'_>, &mut [f32]) + Sync,
    {
        if rayon::current_num_threads() <= 1 || tasks.len() <= 1 {
            align::Serial.map(tasks, scratch, job);
            return;
        }
        let len = scratch.len();
        tasks
            .par_iter_mut()
            .with_max_len(1)
            .for_each_init(|| vec![0.0f32; len], |buffer, task| job(task, buffer));
    }
}

/// The views `stages` read, warped in parallel bands of [`WARP_BAND_ROWS`] rows (every
/// row by the same core code as `pipeline::warp_views`).
fn warp_parallel<S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    homographies: &[Homography],
    aligned: &mut [f32],
    tracker: &Tracker<'_>,
) -> Result<(), lfdepth::Error> {
    let layout = *plan.layout();
    let row_len = layout.width * layout.channels;
    let views = (0..layout.grid.len())
        .filter(|&v| pipeline::reads_view(plan, stages, v))
        .count();
    tracker.start(pipeline::STAGE_WARP, views as u64);
    aligned
        .par_chunks_mut(layout.view_stride)
        .enumerate()
        .filter(|(view, _)| pipeline::reads_view(plan, stages, *view))
        .try_for_each(|(view, samples)| {
            samples
                .par_chunks_mut(WARP_BAND_ROWS * layout.row_stride)
                .enumerate()
                .try_for_each(|(band, samples)| {
                    let first = band * WARP_BAND_ROWS;
                    let last = (first + WARP_BAND_ROWS).min(layout.height);
                    for y in first..last {
                        let at = (y - first) * layout.row_stride;
                        let row = samples.get_mut(at..at + row_len).ok_or(
                            lfdepth::Error::SizeOverflow {
                                what: "the aligned light field",
                            },
                        )?;
                        align::warp_rows_with(
                            lf,
                            homographies,
                            view,
                            y..y + 1,
                            plan.params().align.interpolation,
                            row,
                        )?;
                    }
                    Ok::<(), lfdepth::Error>(())
                })?;
            align::finish_view(
                &layout,
                homographies,
                view,
                plan.params().align.interpolation,
                samples,
            )?;
            tracker.add(1);
            Ok(())
        })
}

/// The selected stages, one after another, each in parallel.
fn run_stages<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stage: StageSelect,
    tracker: &Tracker<'_>,
) -> Result<Estimate, lfdepth::Error> {
    let (mut estimate, range) = estimate_epi::<T, S>(plan, lf, tracker)?;
    if stage == StageSelect::Epi {
        return Ok(estimate);
    }
    if plan.params().refine.enabled {
        let start = Instant::now();
        let (d, c) = refine_parallel::<T, S>(plan, lf, range, &estimate.disparity, tracker)?;
        estimate.disparity = d;
        estimate.confidence = c;
        estimate.timings.push((refine::STAGE, start.elapsed()));
    }
    if plan.params().geofill.enabled {
        geofill_whole(plan, lf, &mut estimate, tracker)?;
    }
    let median = plan.params().median;
    if median.enabled && median.before_tv {
        median_passes(plan, lf, &mut estimate, tracker)?;
    }
    let start = Instant::now();
    let (d, residuals) =
        tv_parallel::<T, S>(plan, lf, &estimate.disparity, &estimate.confidence, tracker)?;
    estimate.disparity = d;
    estimate.residuals = residuals;
    estimate.timings.push((tv::STAGE, start.elapsed()));
    if median.enabled && !median.before_tv {
        median_passes(plan, lf, &mut estimate, tracker)?;
    }
    Ok(estimate)
}

/// The geodesic refill over the whole map, timed as one stage: its sweeps run in one
/// raster order over the frame, so it is one serial call (the core's, bit for bit).
fn geofill_whole<S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    estimate: &mut Estimate,
    tracker: &Tracker<'_>,
) -> Result<(), lfdepth::Error> {
    let start = Instant::now();
    tracker.start(geofill::STAGE, 1);
    let mut out = vec![0.0f32; plan.pixels()];
    let mut scratch = vec![0.0f32; geofill::scratch_len(plan)];
    geofill::fill(
        plan,
        &lf.center_view(),
        &estimate.disparity,
        &mut out,
        &mut scratch,
    )?;
    estimate.disparity = out;
    tracker.add(1);
    estimate.timings.push((geofill::STAGE, start.elapsed()));
    Ok(())
}

/// Every pass of the weighted median over `estimate.disparity`, timed as one stage.
fn median_passes<S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    estimate: &mut Estimate,
    tracker: &Tracker<'_>,
) -> Result<(), lfdepth::Error> {
    let start = Instant::now();
    // Each pass after the first is told the one before's input, so that it filters only
    // near the pixels that moved, and which pixels the one before settled on a part of
    // their window (`median::filter_pass`).
    let mut previous: Option<Vec<f32>> = None;
    let mut settled = vec![0u8; plan.pixels()];
    for _ in 0..plan.params().median.passes {
        let next = median_parallel(
            plan,
            lf,
            &estimate.disparity,
            previous.as_deref(),
            &mut settled,
            tracker,
        )?;
        previous = Some(std::mem::replace(&mut estimate.disparity, next));
    }
    estimate.timings.push((median::STAGE, start.elapsed()));
    Ok(())
}

/// One pass of the weighted median in parallel bands of rows (each pixel depends only
/// on its window, so the map does not depend on the banding); `previous` is the previous
/// pass's input, if any, and `settled` what the previous pass remembered per pixel (read
/// when `previous` is given, then overwritten for the next pass).
fn median_parallel<S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    disparity: &[f32],
    previous: Option<&[f32]>,
    settled: &mut [u8],
    tracker: &Tracker<'_>,
) -> Result<Vec<f32>, lfdepth::Error> {
    // 32 rows: each band reloads the window's 14 halo rows into its ring and re-counts
    // them, which cost 16-row bands about 4 % more of the stage's
    // instructions (docs/bench-median.md, session 7); 16 bands of a 512-row map still
    // balance across threads.
    const BAND_ROWS: usize = 32;
    let (width, height) = (plan.layout().width, plan.layout().height);
    tracker.start(median::STAGE, height.div_ceil(BAND_ROWS) as u64);
    let mut out = vec![0.0f32; plan.pixels()];
    let guide = lf.center_view();
    out.par_chunks_mut(BAND_ROWS * width)
        .zip(settled.par_chunks_mut(BAND_ROWS * width))
        .enumerate()
        .try_for_each_init(
            || vec![0.0f32; median::scratch_len(plan)],
            |scratch, (index, (band, settled))| {
                let start = index * BAND_ROWS;
                let rows = start..(start + BAND_ROWS).min(height);
                median::filter_pass(
                    plan, &guide, disparity, previous, rows, band, settled, scratch,
                )?;
                tracker.add(1);
                Ok::<(), lfdepth::Error>(())
            },
        )?;
    Ok(out)
}

/// The refinement stage in parallel bands.
fn refine_parallel<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    range: (f32, f32),
    disparity: &[f32],
    tracker: &Tracker<'_>,
) -> Result<(Vec<f32>, Vec<f32>), lfdepth::Error> {
    let width = plan.layout().width;
    let band = plan.params().refine.band_rows * width;
    tracker.start(refine::STAGE, refine::band_count(plan) as u64);
    let mut d = vec![0.0f32; plan.pixels()];
    let mut c = vec![0.0f32; plan.pixels()];
    d.par_chunks_mut(band)
        .zip(c.par_chunks_mut(band))
        .enumerate()
        .try_for_each_init(
            || vec![T::ZERO; refine::scratch_len(plan)],
            |scratch, (index, (d, c))| {
                let rows = refine::band_rows(plan, index)?;
                refine::refine_band(plan, lf, range, disparity, rows, d, c, scratch)?;
                tracker.add(1);
                Ok::<(), lfdepth::Error>(())
            },
        )?;
    Ok((d, c))
}

/// The TV stage: tiles in parallel into their own buffers, stitched in tile order, their
/// residual histories summed in tile order (so the sums do not depend on the threads).
/// Each outer sweep ([`lfdepth::tv::TvParams::sweeps`]) solves every tile again from the
/// dual the previous pass stitched together.
fn tv_parallel<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    disparity: &[f32],
    confidence: &[f32],
    tracker: &Tracker<'_>,
) -> Result<(Vec<f32>, Vec<f32>), lfdepth::Error> {
    let (width, height) = (plan.layout().width, plan.layout().height);
    let maps = Maps::new(width, height, disparity, confidence)?;
    let guide = Guide::View(lf.center_view());
    let iterations = plan.params().tv.max_iterations;
    let sweeps = plan.params().tv.sweeps;
    let (cols, rows) = tv::tile_count(plan);
    tracker.start(tv::STAGE, ((cols * rows) * (sweeps + 1)) as u64);
    let mut out = vec![0.0f32; width * height];
    let mut history = vec![0.0f32; iterations];
    let mut previous = Vec::new();
    for sweep in 0..=sweeps {
        let keep_dual = sweep < sweeps;
        let maps = if sweep == 0 {
            maps
        } else {
            maps.with_dual(&previous)?
        };
        let tiles: Vec<(Vec<f32>, Vec<f32>, Vec<f32>)> = (0..cols * rows)
            .into_par_iter()
            .map_init(
                || vec![T::ZERO; tv::scratch_len(plan)],
                |scratch, index| {
                    let (core, _) = tv::tile_rects(plan, index)?;
                    let mut out = vec![0.0f32; core.width * core.height];
                    let mut history = vec![0.0f32; if sweep == 0 { iterations } else { 0 }];
                    let mut dual = vec![0.0f32; if keep_dual { 2 * out.len() } else { 0 }];
                    tv::refine_tile(
                        plan,
                        &maps,
                        &guide,
                        index,
                        SolveOutput {
                            disparity: &mut out,
                            stride: core.width,
                            history: &mut history,
                            dual: keep_dual.then_some(&mut dual[..]),
                        },
                        scratch,
                    )?;
                    tracker.add(1);
                    Ok((out, history, dual))
                },
            )
            .collect::<Result<_, lfdepth::Error>>()?;
        let mut next = vec![0.0f32; if keep_dual { 2 * width * height } else { 0 }];
        for (index, (core_out, tile_history, core_dual)) in tiles.iter().enumerate() {
            let (core, _) = tv::tile_rects(plan, index)?;
            for y in 0..core.height {
                let dst = (core.y + y) * width + core.x;
                let src = y * core.width..(y + 1) * core.width;
                out[dst..dst + core.width].copy_from_slice(&core_out[src.clone()]);
                if keep_dual {
                    next[2 * dst..2 * (dst + core.width)]
                        .copy_from_slice(&core_dual[2 * src.start..2 * src.end]);
                }
            }
            for (h, t) in history.iter_mut().zip(tile_history) {
                *h += t;
            }
        }
        previous = next;
    }
    tv::normalise_history(plan, &mut history);
    // Iterations no tile ran are not part of the curve.
    while history.last() == Some(&0.0) {
        history.pop();
    }
    Ok((out, history))
}

/// The EPI stage in parallel bands (kernels in `T`), with its output range.
fn estimate_epi<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    tracker: &Tracker<'_>,
) -> Result<(Estimate, (f32, f32)), lfdepth::Error> {
    let (width, height) = (plan.layout().width, plan.layout().height);
    let mut timings = Vec::new();

    let start = Instant::now();
    tracker.start(epi::STAGE_RANGE, 1);
    let mut scratch = vec![T::ZERO; epi::scratch_len(plan)];
    let hyps = epi::hypotheses(plan, lf, &mut scratch)?;
    drop(scratch);
    tracker.add(1);
    timings.push(("epi range", start.elapsed()));

    let start = Instant::now();
    tracker.start("epi", (width + height) as u64);
    let bands = |direction: Direction| -> Result<(Vec<f32>, Vec<f32>), lfdepth::Error> {
        let n = direction.line_len(plan);
        let lines = direction.lines(plan);
        let mut d = vec![0.0f32; lines * n];
        let mut c = vec![0.0f32; lines * n];
        d.par_chunks_mut(BAND_LINES * n)
            .zip(c.par_chunks_mut(BAND_LINES * n))
            .enumerate()
            .try_for_each_init(
                || vec![T::ZERO; epi::band_scratch_len(plan, direction)],
                |scratch, (band, (d, c))| {
                    let first = band * BAND_LINES;
                    let count = d.len() / n;
                    epi::estimate_band(
                        plan,
                        &hyps,
                        lf,
                        direction,
                        first..first + count,
                        d,
                        c,
                        scratch,
                    )?;
                    tracker.add(count as u64);
                    Ok(())
                },
            )?;
        Ok((d, c))
    };
    let (dh, ch) = bands(Direction::Horizontal)?;
    let (dv, cv) = bands(Direction::Vertical)?;
    let fusion = plan.params().epi.fusion;
    let mut disparity = vec![0.0f32; width * height];
    let mut confidence = vec![0.0f32; width * height];
    disparity
        .par_chunks_mut(width)
        .zip(confidence.par_chunks_mut(width))
        .enumerate()
        .for_each(|(y, (d_row, c_row))| {
            for x in 0..width {
                let i = y * width + x;
                let t = x * height + y;
                let (d, c) = epi::fuse(fusion, dh[i], ch[i], dv[t], cv[t]);
                d_row[x] = d;
                c_row[x] = c;
            }
        });
    timings.push(("epi", start.elapsed()));
    let estimate = Estimate {
        width,
        height,
        disparity,
        confidence,
        timings,
        residuals: Vec::new(),
        align: None,
    };
    Ok((estimate, (hyps.min(), hyps.max())))
}
