//! The native engine: runs the core pipeline over a loaded light field, bands and tiles
//! in parallel with rayon, and reports progress and per-stage timings.
//!
//! Every stage computes in a scalar type `T` ([`estimate_in`]: `f32` or the Q16.16
//! [`lfdepth::Q16`]; [`estimate`] is `f32`). Every pixel is computed by the same core
//! code whatever the banding and the number of threads, so the result is bit-identical
//! for any `threads`, in either type.

use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::{Duration, Instant};

use lfdepth::align::{self, AlignMode, AlignReport};
use lfdepth::pipeline;
use lfdepth::schedule::{self, PartOutput, PartScratch, Schedule, State, Step};
use lfdepth::{Homography, LightField, Params, Plan, Sample, Scalar, Q16};
use rayon::prelude::*;

pub use lfdepth::pipeline::Stages;

/// What to run and with how many threads.
#[derive(Clone, Copy, Debug)]
pub struct EstimateOptions {
    /// Parameters of every stage.
    pub params: Params,
    /// How far to run.
    pub stage: Stages,
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
    Runner::new(*options)?.estimate(lf, precision, &[], progress)
}

/// [`estimate`] with every stage (EPI, refinement, TV) computing in `T`.
pub fn estimate_in<T: Scalar, S: Sample + Sync>(
    lf: &LightField<'_, S>,
    options: &EstimateOptions,
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    let runner = Runner::new(*options)?;
    estimate_among::<T, S>(lf, &runner, &[], progress)
}

/// The worker threads of one run with what they run: a command builds one, decodes the
/// views in it ([`Runner::install`]) and estimates in it ([`Runner::estimate`]), so a
/// run starts `options.threads` threads once and `--threads` bounds all of its work.
pub struct Runner {
    options: EstimateOptions,
    /// `None` when `options.threads` is `None`: rayon's global pool, every core.
    pool: Option<rayon::ThreadPool>,
}

/// Worker threads the engine's pools have started in this process (rayon's global pool
/// is not counted).
static THREADS_STARTED: AtomicUsize = AtomicUsize::new(0);

impl Runner {
    /// Starts the pool of `options.threads` threads (at least one); `None` runs in
    /// rayon's global pool of every core.
    pub fn new(options: EstimateOptions) -> Result<Self, lfdepth::Error> {
        let pool = options
            .threads
            .map(|threads| {
                rayon::ThreadPoolBuilder::new()
                    .num_threads(threads.max(1))
                    .start_handler(|_| {
                        THREADS_STARTED.fetch_add(1, Ordering::Relaxed);
                    })
                    .build()
                    .map_err(|_| lfdepth::Error::InvalidParameter {
                        name: "threads",
                        reason: "could not start that many threads: use fewer",
                    })
            })
            .transpose()?;
        Ok(Runner { options, pool })
    }

    /// What the runner runs.
    pub fn options(&self) -> &EstimateOptions {
        &self.options
    }

    /// Runs `work` on the runner's threads (its parallel iterators and joins use them).
    pub fn install<R: Send>(&self, work: impl FnOnce() -> R + Send) -> R {
        match &self.pool {
            Some(pool) => pool.install(work),
            None => work(),
        }
    }

    /// Estimates the disparity of `lf`'s centre view on the runner's threads, every
    /// stage computing in `precision`. Only the views `present` marks (row-major; an
    /// empty slice marks every view) hold data: the alignment reads no other view, and
    /// the stages must read none (the loader checks, `io::needs`).
    pub fn estimate<S: Sample + Sync>(
        &self,
        lf: &LightField<'_, S>,
        precision: Precision,
        present: &[bool],
        progress: &mut dyn FnMut(&str, u64, u64),
    ) -> Result<Estimate, lfdepth::Error> {
        match precision {
            Precision::F32 => estimate_among::<f32, S>(lf, self, present, progress),
            Precision::Q16 => estimate_among::<Q16, S>(lf, self, present, progress),
        }
    }
}

/// Worker threads every [`Runner`] of this process has started, for checking that a
/// run starts its threads once.
pub fn threads_started() -> usize {
    THREADS_STARTED.load(Ordering::Relaxed)
}

/// [`Runner::estimate`] computing in `T`.
fn estimate_among<T: Scalar, S: Sample + Sync>(
    lf: &LightField<'_, S>,
    runner: &Runner,
    present: &[bool],
    progress: &mut dyn FnMut(&str, u64, u64),
) -> Result<Estimate, lfdepth::Error> {
    let options = runner.options();
    let plan = Plan::new(*lf.layout(), options.params)?;
    // The work runs on its own thread; this one forwards progress, so the callback
    // needs neither `Send` nor `Sync`.
    let done = AtomicU64::new(0);
    let total = AtomicU64::new(1);
    // No stage until the first one starts (its name is the schedule's).
    let stage = Mutex::new("");
    let finished = AtomicBool::new(false);
    let tracker = Tracker {
        done: &done,
        total: &total,
        stage: &stage,
    };
    std::thread::scope(|scope| {
        let worker = scope.spawn(|| {
            let result = runner
                .install(|| align_then_run::<T, S>(&plan, lf, options.stage, present, &tracker));
            finished.store(true, Ordering::Release);
            result
        });
        let mut last = (u64::MAX, "");
        loop {
            let end = finished.load(Ordering::Acquire);
            let now = done.load(Ordering::Relaxed);
            let name = stage.lock().map(|s| *s).unwrap_or("");
            if (now, name) != last && !name.is_empty() {
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
    stages: Stages,
    present: &[bool],
    tracker: &Tracker<'_>,
) -> Result<Estimate, lfdepth::Error> {
    let params = &pipeline::align_params(plan, stages);
    if params.mode == AlignMode::Off {
        return run_schedule::<T, S>(plan, lf, stages, tracker, None);
    }
    let start = Instant::now();
    tracker.start(pipeline::STAGE_ALIGN, 1);
    let layout = *plan.layout();
    let mut homographies = vec![Homography::IDENTITY; layout.grid.len()];
    // The run's first step (the range) reads only the views: in auto mode it runs
    // beside the alignment, on a thread the alignment's serial parts leave idle, and is
    // used when the rectified check leaves the views as they are. On one thread, or
    // when the views are warped anyway (mode on), it would only add work.
    let beside = params.mode == AlignMode::Auto && rayon::current_num_threads() > 1;
    let (report, ahead) = rayon::join(
        || {
            let mut scratch = vec![0.0f32; align::scratch_len(&layout, params)?];
            align::estimate_present(
                lf,
                params,
                &|v| present.get(v).copied().unwrap_or(present.is_empty()),
                &mut homographies,
                &mut scratch,
                &mut ParallelViews,
            )
        },
        || beside.then(|| range_ahead::<T, S>(plan, lf)).flatten(),
    );
    let report = report?;
    tracker.add(1);
    let mut timings = vec![(pipeline::STAGE_ALIGN, start.elapsed())];
    let mut estimate = if report.skipped {
        run_schedule::<T, S>(plan, lf, stages, tracker, ahead)?
    } else {
        let start = Instant::now();
        // Zeroed pages that are never written (views no stage reads) cost no memory.
        let mut aligned = vec![0.0f32; pipeline::aligned_len(plan)?];
        warp_parallel(plan, lf, stages, &homographies, &mut aligned, tracker)?;
        timings.push((pipeline::STAGE_WARP, start.elapsed()));
        let rectified = LightField::new(&aligned[..], layout)?;
        let plan = &pipeline::resampled_plan(plan)?;
        run_schedule::<T, f32>(plan, &rectified, stages, tracker, None)?
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

/// One worker thread's scratch, kept for the whole run and grown to the largest step's
/// need. Fresh zeroed buffers per part (or per rayon split) cost a page fault per 4 KiB
/// touched and an unmap whose TLB shootdown interrupts every other thread: serial work
/// in the kernel that grew with the thread count. Reuse does not change a bit, as in
/// core's serial driver, which runs every part in one dirty scratch.
struct Workspace<T> {
    kernel: Vec<T>,
    maps: Vec<f32>,
    flags: Vec<u8>,
}

impl<T: Scalar> Workspace<T> {
    const EMPTY: Self = Workspace {
        kernel: Vec::new(),
        maps: Vec::new(),
        flags: Vec::new(),
    };

    /// The first `lens` of each buffer, each replaced by a longer one where it is
    /// shorter.
    fn take(&mut self, lens: lfdepth::schedule::ScratchLen) -> PartScratch<'_, T> {
        fn grown<V: Copy>(buffer: &mut Vec<V>, len: usize, zero: V) -> &mut [V] {
            if buffer.len() < len {
                // A fresh zeroed allocation, not `resize`: its pages stay untouched
                // until a kernel writes them (the median's scratch spans three maps,
                // of which a band writes its own rows).
                *buffer = vec![zero; len];
            }
            &mut buffer[..len]
        }
        PartScratch {
            kernel: grown(&mut self.kernel, lens.kernel, T::ZERO),
            maps: grown(&mut self.maps, lens.maps, 0.0),
            flags: grown(&mut self.flags, lens.flags, 0),
        }
    }
}

/// Runs every part of `step` on rayon's threads into `outputs` (one buffer per part),
/// each with its thread's workspace.
fn run_parts<T: Scalar, S: Sample + Sync>(
    schedule: &Schedule,
    step: Step,
    lf: &LightField<'_, S>,
    state: &State<'_>,
    workspaces: &[Mutex<Workspace<T>>],
    outputs: &mut [Vec<f32>],
    tracker: &Tracker<'_>,
) -> Result<(), lfdepth::Error> {
    let lens = schedule.scratch_len(step);
    outputs
        .par_iter_mut()
        .enumerate()
        .try_for_each(|(index, buffer)| {
            let len = schedule.part_len(step, index)?;
            buffer.resize(len.total(), 0.0);
            let mut out = PartOutput::split(buffer, len)?;
            // A part runs no rayon work, so its thread's workspace is free; any other
            // thread (or a busy workspace) gets buffers of its own.
            let slot = rayon::current_thread_index().and_then(|i| workspaces.get(i));
            let mut guard = slot.and_then(|w| w.try_lock().ok());
            let mut own = Workspace::EMPTY;
            let workspace = match guard.as_deref_mut() {
                Some(workspace) => workspace,
                None => &mut own,
            };
            schedule.run_part(step, index, lf, state, &mut out, workspace.take(lens))?;
            tracker.add(1);
            Ok(())
        })
}

/// The disparity range of `plan` over `lf` (the schedule's first step, [`Step::Range`],
/// which reads only the views), computed ahead of the schedule. `None` when it fails:
/// the schedule then runs the step and reports the error in its place.
fn range_ahead<T: Scalar, S: Sample>(plan: &Plan, lf: &LightField<'_, S>) -> Option<(f32, f32)> {
    let mut kernel = vec![T::ZERO; schedule::range_scratch_len(plan)];
    schedule::range(plan, lf, &mut kernel).ok()
}

/// Walks the plan's schedule: every step's parts in parallel on rayon's threads, each
/// into its own output buffer, then placed in part order (so the result does not
/// depend on the threads), each step timed under its stage's name. Scratch is one
/// [`Workspace`] per thread and the output buffers are kept from step to step.
fn run_schedule<T: Scalar, S: Sample + Sync>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    stages: Stages,
    tracker: &Tracker<'_>,
    mut ahead: Option<(f32, f32)>,
) -> Result<Estimate, lfdepth::Error> {
    let threads = rayon::current_num_threads();
    let schedule = Schedule::new(plan, stages, threads)?;
    let mut buffer = vec![0.0f32; schedule.state_len()];
    // The first touch of a page faults; the state's maps would first be touched by the
    // placing thread, one page after the other. Touch them on every thread instead.
    buffer
        .par_chunks_mut(1 << 16)
        .for_each(|chunk| chunk.fill(0.0));
    let mut state = State::new(&schedule, &mut buffer)?;
    let mut timings: Vec<(&'static str, Duration)> = Vec::new();
    let workspaces: Vec<Mutex<Workspace<T>>> =
        (0..threads).map(|_| Mutex::new(Workspace::EMPTY)).collect();
    let mut outputs: Vec<Vec<f32>> = Vec::new();
    for &step in schedule.steps() {
        let start = Instant::now();
        let parts = schedule.parts(step);
        tracker.start(step.stage(), parts as u64);
        if outputs.len() < parts {
            outputs.resize_with(parts, Vec::new);
        }
        // The range may have been computed already ([`range_ahead`]): it is the range
        // step's one part, `[min, max]`.
        let done = ahead.take().filter(|_| step == Step::Range);
        if let (Some((min, max)), Some(slot)) = (done, outputs.first_mut()) {
            *slot = vec![min, max];
            tracker.add(1);
        } else {
            run_parts(
                &schedule,
                step,
                lf,
                &state,
                &workspaces,
                &mut outputs[..parts],
                tracker,
            )?;
        }
        for (index, buffer) in outputs[..parts].iter_mut().enumerate() {
            let out = PartOutput::split(buffer, schedule.part_len(step, index)?)?;
            schedule.place(step, index, &out, &mut state)?;
        }
        schedule.finish(step, &mut state);
        match timings.last_mut() {
            Some((name, time)) if *name == step.stage() => *time += start.elapsed(),
            _ => timings.push((step.stage(), start.elapsed())),
        }
    }
    let (width, height) = (plan.layout().width, plan.layout().height);
    let mut residuals = if schedule.steps().contains(&Step::Tv { sweep: 0 }) {
        state.history().to_vec()
    } else {
        Vec::new()
    };
    // Iterations no tile ran are not part of the curve.
    while residuals.last() == Some(&0.0) {
        residuals.pop();
    }
    Ok(Estimate {
        width,
        height,
        disparity: state.disparity().to_vec(),
        confidence: state.confidence().to_vec(),
        timings,
        residuals,
        align: None,
    })
}
