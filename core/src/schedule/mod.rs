//! The one description of a run: the steps of the pipeline for a [`Plan`], each a stage
//! over independent parts, what each part reads and writes, and how its result is
//! placed. Every driver walks this list — core's serial [`crate::pipeline::run`], the
//! CLI's thread pool, the page's workers — and none of them names a stage: adding,
//! removing or reordering a stage edits [`Schedule::new`] and the step's arms here.
//!
//! # The maps of a run ([`State`])
//! A run carries two pairs of maps, *current* and *other* (disparity and confidence,
//! `plan.pixels()` each), the TV duals between its outer sweeps, its residual history
//! and the EPI hypotheses. A step's parts read the run's state and write their own
//! outputs ([`PartOutput`], sized by [`Schedule::part_len`]); [`Schedule::place`] puts
//! a part's output into the state, and [`Schedule::finish`] closes the step (swaps the
//! map it wrote with the one it read). A part never reads what a `place` of the same
//! step writes, so a driver may place each part as soon as it ran, or all of them after
//! the step: the
//! result is the same bits for any number of threads or workers (the determinism
//! contract, `docs/ARCHITECTURE.md`), as long as parts are placed in index order (the
//! TV residual histories are summed in tile order).
//!
//! With the plane sweep's per-pixel candidate (`PlaneSweepParams::candidate`) the sweep
//! places the candidate into the current disparity (the other one once the step
//! finishes), and the refinement, which reads the start and the candidate with a halo,
//! places its disparity into the other confidence and its confidence into the current
//! one; its `finish` makes its disparity current.
//!
//! # Scratch
//! Each step states its per-part scratch ([`Schedule::scratch_len`]): kernel scalars
//! (`T`), `f32` maps and optional flag bytes. A driver gives each concurrent part its
//! own; core's serial driver gives one of each, sized for every step
//! ([`Schedule::max_scratch_len`]).

use crate::epi::{self, Direction, Hypotheses};
use crate::error::{Error, Result};
use crate::geofill;
use crate::lightfield::{LightField, Sample};
use crate::median;
use crate::plan::Plan;
use crate::planesweep::{self, PlaneSweepParams};
use crate::refine;
use crate::refine::{RefineParams, Start};
use crate::scalar::Scalar;
use crate::setup::{DisparityOut, Setup};
use crate::tv::{self, Guide, Maps, SolveOutput};

mod part;
mod state;

use part::{put, write_range};
pub use part::{PartLen, PartOutput, PartScratch, Region, ScratchLen};
pub use state::{Cursor, State, StateMaps};
use state::{CURRENT_C, CURRENT_D, OTHER_C, OTHER_D};

/// How far a run goes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stages {
    /// The initial EPI disparity only.
    Epi,
    /// Every enabled stage: EPI → refinement → refill → median → TV (→ median).
    Full,
}

/// Lines (rows or columns) per part of an EPI step: small enough to balance two threads on small frames and to cancel quickly, large
/// enough that per-part overhead (scratch, progress) is negligible.
pub const BAND_LINES: usize = 16;

/// Most steps of a run: range, two EPI directions (one for a linear array), the
/// upsampling, refinement, the fused start's plane sweep and choice, refill, two
/// medians and TV with at most [`tv::MAX_SWEEPS`] outer sweeps.
pub const MAX_STEPS: usize = 10 + tv::MAX_SWEEPS + 1;

/// Full-resolution rows per part of the upsampling step.
pub const UPSAMPLE_ROWS: usize = 64;

/// The disparity range a run of `plan` tests (the ends of its EPI hypotheses), as its
/// first step, [`Step::Range`], computes it: a function of the plan and the views alone,
/// so a driver may compute it before the schedule runs (beside other work) and place it
/// as that step's one part, `[min, max]`. `kernel` holds [`range_scratch_len`] scalars.
pub fn range<T: Scalar, S: Sample>(
    plan: &Plan,
    lf: &LightField<'_, S>,
    kernel: &mut [T],
) -> Result<(f32, f32)> {
    let hypotheses = epi::hypotheses(plan.epi(), lf, kernel)?;
    Ok((hypotheses.min(), hypotheses.max()))
}

/// Scratch (elements of `T`) of [`range`].
pub fn range_scratch_len(plan: &Plan) -> usize {
    epi::scratch_len(plan.epi())
}

/// One step of a run: a stage over independent parts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Step {
    /// The disparity range to test (the EPI hypotheses): one part.
    Range,
    /// EPI estimates of one direction in bands of [`BAND_LINES`] lines: horizontal
    /// lines into the current maps (row-major), vertical ones into the other maps
    /// (transposed: line after line); closing the vertical step fuses both directions
    /// into the current maps, per pixel, on the placing driver's thread (a pass over
    /// the map that costs less than sending the four maps to workers). A linear array
    /// has the step of its one direction only: a row of cameras ends the EPI stage with
    /// the horizontal step, a column's vertical step moves its estimates into the
    /// current maps unfused.
    Epi(Direction),
    /// The plane sweep's initial disparity ([`crate::planesweep`], instead of the EPI
    /// steps when [`crate::plan::Params::sweep`] is enabled), in bands of
    /// [`planesweep::BAND_ROWS`] rows into the other maps. In the fused start
    /// ([`crate::plan::Params::fused`]) it runs after the EPI steps and their
    /// refinement and leaves the refined EPI maps current.
    PlaneSweep,
    /// The fused start's last step: the plane sweep's map (the other maps) refined in
    /// the plan's refine bands, and per pixel the refined start with the lower
    /// photometric residual kept ([`refine::choose`]) in the current maps. A part reads
    /// the current maps at its own rows only, which only its own `place` writes.
    Fuse,
    /// The half-resolution EPI map upsampled to full resolution guided by the centre
    /// view ([`epi::upsample_rows`], only with [`epi::EpiParams::half_resolution`]), in
    /// bands of [`UPSAMPLE_ROWS`] rows into the other maps.
    Upsample,
    /// Photometric refinement in the plan's refine bands.
    Refine,
    /// Geodesic refill of the band around depth steps: one whole-map part (its sweeps
    /// run in one raster order).
    Refill,
    /// Every weighted-median pass, in row bands ([`median::filter_band`]).
    Median,
    /// One outer sweep of TV over its tiles (sweep 0 is the first solve).
    Tv {
        /// The sweep, `0..=sweeps`.
        sweep: usize,
    },
}

impl Step {
    /// The stage's name in progress reports and timings.
    pub fn stage(self) -> &'static str {
        match self {
            Step::Range => epi::STAGE_RANGE,
            Step::Epi(Direction::Horizontal) => epi::STAGE_HORIZONTAL,
            Step::Epi(Direction::Vertical) => epi::STAGE_VERTICAL,
            Step::Upsample => epi::STAGE_UPSAMPLE,
            Step::PlaneSweep => planesweep::STAGE,
            Step::Refine => refine::STAGE,
            Step::Fuse => refine::STAGE_FUSED,
            Step::Refill => geofill::STAGE,
            Step::Median => median::STAGE,
            Step::Tv { .. } => tv::STAGE,
        }
    }
}

/// What one part of a step reads besides the light field: the maps of the run's
/// [`State`] a driver must hand to the part (the page sends them to its workers).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Reads {
    /// The current disparity.
    pub disparity: bool,
    /// The current confidence.
    pub confidence: bool,
    /// The other pair of maps (the transposed vertical EPI estimates, or the plane
    /// sweep's maps in the fused start).
    pub other: bool,
    /// The previous sweep's TV dual.
    pub dual: bool,
}

/// The steps of one run of a plan (see the module documentation).
#[derive(Clone, Debug, PartialEq)]
pub struct Schedule {
    plan: Plan,
    steps: heapless::Vec<Step, MAX_STEPS>,
    median_rows: usize,
    /// The refinement's parameters with the band rows for the workers.
    refine: RefineParams,
    /// The plane sweep's parameters, its candidate off unless the refinement reads it.
    sweep: PlaneSweepParams,
}

impl Schedule {
    /// The steps of `stages` for `plan`. `workers` (≥ 1) is how many parts of a step the
    /// driver runs at once: it sets the weighted median's row bands (one per worker, at
    /// least [`BAND_LINES`] rows: each band re-filters the rows its later passes read)
    /// and thins the refinement's bands where the plan's would leave workers idle,
    /// never the result.
    pub fn new(plan: &Plan, stages: Stages, workers: usize) -> Result<Self> {
        let mut steps = heapless::Vec::new();
        let mut push = |step| {
            steps.push(step).map_err(|_| Error::InvalidParameter {
                name: "tv.sweeps",
                reason: "makes more steps than a run holds: use fewer sweeps",
            })
        };
        push(Step::Range)?;
        let params = plan.params();
        if params.sweep.enabled && !params.fused {
            push(Step::PlaneSweep)?;
        } else {
            // A linear array (one row or column of cameras) has one EPI direction only.
            for direction in Direction::BOTH {
                if direction.exists(plan.layout()) {
                    push(Step::Epi(direction))?;
                }
            }
        }
        if params.epi.half_resolution {
            push(Step::Upsample)?;
        }
        // The fused start refines both starts (the plan requires the refinement), so
        // its refinement belongs to the start: with `Stages::Epi` too.
        if params.fused {
            push(Step::Refine)?;
            push(Step::PlaneSweep)?;
            push(Step::Fuse)?;
        }
        if stages == Stages::Full {
            if params.refine.enabled && !params.fused {
                push(Step::Refine)?;
            }
            if params.geofill.enabled {
                push(Step::Refill)?;
            }
            let median = params.median.enabled && params.median.passes > 0;
            if median && params.median.before_tv {
                push(Step::Median)?;
            }
            for sweep in 0..=params.tv.sweeps {
                push(Step::Tv { sweep })?;
            }
            if median && !params.median.before_tv {
                push(Step::Median)?;
            }
        }
        let height = plan.layout().height;
        let median_rows = height
            .div_ceil(workers.max(1))
            .max(BAND_LINES)
            .min(height.max(1));
        // The plan's refinement bands (128 rows) leave all but four workers idle on a
        // 512-row frame: with more workers, one band per worker, but none thinner than
        // its two halos, below which recomputing the halo costs more than a worker
        // gains. The bands do not change a bit (each is computed with its halo).
        let mut refine_params = params.refine;
        let per_worker = height.div_ceil(workers.max(1));
        let thinnest = refine::halo(plan.refine())
            .saturating_mul(2)
            .max(BAND_LINES);
        refine_params.band_rows = refine_params.band_rows.min(per_worker.max(thinnest)).max(1);
        // The sweep's per-pixel candidate is computed only for a refinement that
        // propagates from the sweep's map.
        let mut sweep = params.sweep;
        let offered =
            steps.contains(&Step::Refine) && !params.fused && params.refine.propagation > 0;
        if !offered {
            sweep.candidate = 0;
        }
        Ok(Schedule {
            plan: *plan,
            steps,
            median_rows,
            refine: refine_params,
            sweep,
        })
    }

    /// The plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The refinement's setup with this schedule's band rows.
    fn refine(&self) -> Setup<'_, RefineParams> {
        self.plan.refine().with_params(&self.refine)
    }

    /// The plane sweep's setup, its candidate on only where the refinement offers it.
    fn sweep(&self) -> Setup<'_, PlaneSweepParams> {
        self.plan.sweep().with_params(&self.sweep)
    }

    /// Whether the plane sweep writes its per-pixel candidate and the refinement offers
    /// it ([`PlaneSweepParams::candidate`]): the candidate takes the other disparity,
    /// so the refinement places its disparity elsewhere (see [`Schedule::place`]).
    fn candidate(&self) -> bool {
        self.sweep.candidate > 0 && self.steps.contains(&Step::PlaneSweep)
    }

    /// The steps, in the order they run.
    pub fn steps(&self) -> &[Step] {
        &self.steps
    }

    /// Floats of a run's [`State`]: four maps, the two TV duals when TV sweeps, and the
    /// residual history.
    pub fn state_len(&self) -> usize {
        self.plan
            .pixels()
            .saturating_mul(4)
            .saturating_add(self.dual_len().saturating_mul(2))
            .saturating_add(self.history_len())
    }

    pub(crate) fn dual_len(&self) -> usize {
        if self.plan.params().tv.sweeps > 0 && self.steps.contains(&Step::Tv { sweep: 0 }) {
            self.plan.pixels().saturating_mul(2)
        } else {
            0
        }
    }

    pub(crate) fn history_len(&self) -> usize {
        self.plan.params().tv.max_iterations
    }

    /// Number of parts of `step`.
    pub fn parts(&self, step: Step) -> usize {
        let layout = self.plan.layout();
        match step {
            Step::Range | Step::Refill => 1,
            Step::Epi(direction) => epi::lines(self.plan.epi(), direction).div_ceil(BAND_LINES),
            Step::Upsample => layout.height.div_ceil(UPSAMPLE_ROWS),
            Step::PlaneSweep => planesweep::band_count(self.sweep()),
            Step::Refine | Step::Fuse => refine::band_count(self.refine()),
            Step::Median => layout
                .height
                .checked_add(self.median_rows.saturating_sub(1))
                .and_then(|h| h.checked_div(self.median_rows))
                .unwrap_or(0),
            Step::Tv { .. } => {
                let (cols, rows) = tv::tile_count(self.plan.tv());
                cols.saturating_mul(rows)
            }
        }
    }

    /// The region part `index` of `step` writes.
    pub fn region(&self, step: Step, index: usize) -> Result<Region> {
        let parts = self.parts(step);
        if index >= parts {
            return Err(Error::OutOfRange {
                what: "part of a step",
                index,
                len: parts,
            });
        }
        let lines = |size: usize, total: usize| {
            let start = index * size;
            Region::Lines(start, (start + size).min(total))
        };
        let height = self.plan.layout().height;
        Ok(match step {
            Step::Range => Region::Range,
            Step::Epi(direction) => lines(BAND_LINES, epi::lines(self.plan.epi(), direction)),
            Step::Upsample => lines(UPSAMPLE_ROWS, height),
            Step::PlaneSweep => lines(planesweep::BAND_ROWS, height),
            Step::Refine | Step::Fuse => {
                let rows = refine::band_rows(self.refine(), index)?;
                Region::Lines(rows.start, rows.end)
            }
            Step::Refill => Region::Lines(0, height),
            Step::Median => lines(self.median_rows, height),
            Step::Tv { .. } => Region::Rect(tv::tile_rects(self.plan.tv(), index)?.0),
        })
    }

    /// What the parts of `step` read from the run's state.
    pub fn reads(&self, step: Step) -> Reads {
        let none = Reads::default();
        match step {
            Step::Range | Step::Epi(_) | Step::PlaneSweep => none,
            // Distrusting the sweep scales the refined confidence by the start's; the
            // sweep's per-pixel candidate is the other disparity.
            Step::Refine => Reads {
                disparity: true,
                confidence: distrusts_sweep(self.plan.params()),
                other: self.candidate(),
                ..none
            },
            Step::Refill | Step::Median => Reads {
                disparity: true,
                ..none
            },
            Step::Upsample => Reads {
                disparity: true,
                confidence: true,
                ..none
            },
            Step::Tv { sweep } => Reads {
                disparity: true,
                confidence: true,
                dual: sweep > 0,
                ..none
            },
            Step::Fuse => Reads {
                disparity: true,
                confidence: true,
                other: true,
                ..none
            },
        }
    }

    /// Lengths of part `index`'s outputs.
    pub fn part_len(&self, step: Step, index: usize) -> Result<PartLen> {
        let region = self.region(step, index)?;
        let line_len = match step {
            Step::Epi(direction) => epi::line_len(self.plan.epi(), direction),
            _ => self.plan.layout().width,
        };
        let both = |len: usize| PartLen {
            disparity: len,
            confidence: len,
            ..PartLen::default()
        };
        Ok(match (step, region) {
            (_, Region::Range) => PartLen {
                disparity: 2,
                ..PartLen::default()
            },
            (Step::Tv { sweep }, Region::Rect(core)) => {
                let len = core.width * core.height;
                PartLen {
                    disparity: len,
                    history: if sweep == 0 { self.history_len() } else { 0 },
                    dual: if sweep < self.plan.params().tv.sweeps {
                        2 * len
                    } else {
                        0
                    },
                    ..PartLen::default()
                }
            }
            (Step::Refill | Step::Median, Region::Lines(start, end)) => PartLen {
                disparity: (end - start) * line_len,
                ..PartLen::default()
            },
            (Step::PlaneSweep, Region::Lines(start, end)) if self.candidate() => PartLen {
                candidate: (end - start) * line_len,
                ..both((end - start) * line_len)
            },
            (_, Region::Lines(start, end)) => both((end - start) * line_len),
            (_, Region::Rect(core)) => both(core.width * core.height),
        })
    }

    /// The largest [`Schedule::part_len`] of any part of any step.
    pub fn max_part_len(&self) -> Result<PartLen> {
        let mut most = PartLen::default();
        for &step in &self.steps {
            for index in 0..self.parts(step) {
                most = most.max(self.part_len(step, index)?);
            }
        }
        Ok(most)
    }

    /// Scratch one part of `step` needs, computing in `T`.
    pub fn scratch_len(&self, step: Step) -> ScratchLen {
        let plan = &self.plan;
        let none = ScratchLen::default();
        match step {
            Step::Range => ScratchLen {
                kernel: range_scratch_len(plan),
                ..none
            },
            Step::Epi(direction) => ScratchLen {
                kernel: epi::band_scratch_len(plan.epi(), direction),
                ..none
            },
            Step::Upsample => ScratchLen {
                maps: epi::upsample_scratch_len(plan.epi(), UPSAMPLE_ROWS),
                ..none
            },
            Step::PlaneSweep => ScratchLen {
                maps: planesweep::scratch_len(self.sweep()),
                ..none
            },
            Step::Refine | Step::Fuse => ScratchLen {
                kernel: refine::scratch_len(self.refine()),
                ..none
            },
            Step::Refill => ScratchLen {
                maps: geofill::scratch_len(plan.geofill()),
                ..none
            },
            Step::Median => ScratchLen {
                maps: median::band_scratch_len(plan.median()),
                flags: plan.pixels(),
                ..none
            },
            Step::Tv { .. } => ScratchLen {
                kernel: tv::scratch_len(plan.tv()),
                ..none
            },
        }
    }

    /// The largest [`Schedule::scratch_len`] of any step: one part at a time needs no
    /// more.
    pub fn max_scratch_len(&self) -> ScratchLen {
        self.steps
            .iter()
            .fold(ScratchLen::default(), |most, &step| {
                most.max(self.scratch_len(step))
            })
    }

    /// Runs part `index` of `step` over `lf` (computing in `T`) from `state` into `out`
    /// ([`Schedule::part_len`]) with `scratch` ([`Schedule::scratch_len`]; `flags` may
    /// be empty).
    pub fn run_part<T: Scalar, S: Sample>(
        &self,
        step: Step,
        index: usize,
        lf: &LightField<'_, S>,
        state: &State<'_>,
        out: &mut PartOutput<'_>,
        scratch: PartScratch<'_, T>,
    ) -> Result<()> {
        let plan = &self.plan;
        let region = self.region(step, index)?;
        let hypotheses = || {
            state.hypotheses().ok_or(Error::InvalidParameter {
                name: "schedule",
                reason: "a step after the range ran before it: run the steps in order",
            })
        };
        let layout = plan.layout();
        let (width, height) = (layout.width, layout.height);
        let lines = match region {
            Region::Lines(start, end) => start..end,
            _ => 0..0,
        };
        match step {
            Step::Range => {
                alone(|| write_range(&mut *out.disparity, range(plan, lf, scratch.kernel)?))
            }
            Step::Epi(direction) => alone(|| {
                epi::estimate_band(
                    plan.epi(),
                    &hypotheses()?,
                    lf,
                    direction,
                    lines,
                    DisparityOut {
                        disparity: &mut *out.disparity,
                        confidence: &mut *out.confidence,
                    },
                    scratch.kernel,
                )
            }),
            Step::Upsample => alone(|| {
                epi::upsample_rows(
                    plan.epi(),
                    &lf.center_view(),
                    state.disparity(),
                    state.confidence(),
                    lines,
                    DisparityOut {
                        disparity: &mut *out.disparity,
                        confidence: &mut *out.confidence,
                    },
                    scratch.maps,
                )
            }),
            Step::PlaneSweep => alone(|| {
                let h = hypotheses()?;
                let map = DisparityOut {
                    disparity: &mut *out.disparity,
                    confidence: &mut *out.confidence,
                };
                if self.candidate() {
                    planesweep::estimate_rows_with_candidate(
                        self.sweep(),
                        (h.min(), h.max()),
                        lf,
                        lines,
                        planesweep::SweepOut {
                            map,
                            candidate: Some(&mut *out.candidate),
                        },
                        scratch.maps,
                    )
                } else {
                    planesweep::estimate_rows(
                        self.sweep(),
                        (h.min(), h.max()),
                        lf,
                        lines,
                        map,
                        scratch.maps,
                    )
                }
            }),
            Step::Refine => alone(|| {
                let h = hypotheses()?;
                let start = Start {
                    disparity: state.disparity(),
                    candidate: self.candidate().then(|| state.other().0),
                };
                refine_rows(
                    self.refine(),
                    lf,
                    &h,
                    start,
                    lines.clone(),
                    out,
                    scratch.kernel,
                )?;
                if distrusts_sweep(plan.params()) {
                    // The start's confidence is still the current one.
                    let start = band_of(
                        state.confidence(),
                        &lines,
                        width,
                        "the plane sweep's confidence",
                    )?;
                    distrust(plan.params().sweep.trust, start, &mut *out.confidence);
                }
                Ok(())
            }),
            Step::Fuse => alone(|| {
                let h = hypotheses()?;
                let start = Start {
                    disparity: state.other().0,
                    candidate: None,
                };
                refine_rows(
                    self.refine(),
                    lf,
                    &h,
                    start,
                    lines.clone(),
                    out,
                    scratch.kernel,
                )?;
                let what = "the refined EPI maps";
                let kept = (
                    band_of(state.disparity(), &lines, width, what)?,
                    band_of(state.confidence(), &lines, width, what)?,
                );
                refine::choose::<T, S>(
                    self.refine(),
                    lf,
                    lines,
                    kept,
                    DisparityOut {
                        disparity: &mut *out.disparity,
                        confidence: &mut *out.confidence,
                    },
                )
            }),
            Step::Refill => alone(|| {
                geofill::fill(
                    plan.geofill(),
                    &lf.center_view(),
                    state.disparity(),
                    &mut *out.disparity,
                    scratch.maps,
                )
            }),
            Step::Median => alone(|| {
                median::filter_band(
                    plan.median(),
                    &lf.center_view(),
                    state.disparity(),
                    lines,
                    &mut *out.disparity,
                    scratch.maps,
                    match scratch.flags.get_mut(..plan.pixels()) {
                        Some(flags) => flags,
                        None => &mut [],
                    },
                )
            }),
            Step::Tv { sweep } => alone(|| {
                let (core, region) = tv::tile_rects(plan.tv(), index)?;
                let maps =
                    Maps::checked_in(width, height, state.disparity(), state.confidence(), region)?;
                let maps = if sweep > 0 {
                    maps.with_dual_checked_in(state.dual(), region)?
                } else {
                    maps
                };
                out.history.fill(0.0);
                tv::refine_tile(
                    plan.tv(),
                    &maps,
                    &Guide::View(lf.center_view()),
                    index,
                    SolveOutput {
                        disparity: &mut *out.disparity,
                        stride: core.width,
                        history: &mut *out.history,
                        dual: (!out.dual.is_empty()).then_some(&mut *out.dual),
                    },
                    scratch.kernel,
                )
                .map(|_| ())
            }),
        }
    }

    /// Places part `index`'s output (as [`Schedule::run_part`] wrote it) into `state`.
    /// Parts of a step must be placed in index order.
    pub fn place(
        &self,
        step: Step,
        index: usize,
        part: &PartOutput<'_>,
        state: &mut State<'_>,
    ) -> Result<()> {
        let width = self.plan.layout().width;
        match (step, self.region(step, index)?) {
            (_, Region::Range) => {
                let (&[min, max], _) =
                    part.disparity
                        .split_first_chunk::<2>()
                        .ok_or(Error::OutputSize {
                            what: "the range part",
                            needed: 2,
                            got: part.disparity.len(),
                        })?;
                state.set_hypotheses(Hypotheses::new(&self.plan.params().epi, min, max)?);
                Ok(())
            }
            (Step::Tv { sweep }, Region::Rect(core)) => {
                let sweeps = self.plan.params().tv.sweeps;
                for y in 0..core.height {
                    let at = (core.y + y) * width + core.x;
                    let src = y * core.width..(y + 1) * core.width;
                    let short = Error::OutputSize {
                        what: "a TV tile's output",
                        needed: src.end,
                        got: part.disparity.len(),
                    };
                    put(
                        state.map_mut(OTHER_D),
                        at,
                        part.disparity.get(src.clone()).ok_or(short)?,
                    )?;
                    if sweep < sweeps {
                        let dual = part.dual.get(2 * src.start..2 * src.end).ok_or(short)?;
                        put(state.next_dual_mut(), 2 * at, dual)?;
                    }
                }
                if sweep == 0 {
                    for (h, t) in state.history_mut().iter_mut().zip(part.history.iter()) {
                        *h += t;
                    }
                }
                Ok(())
            }
            (_, Region::Rect(_)) => Err(Error::SizeOverflow { what: "a part" }),
            (step, Region::Lines(start, _)) => {
                let line_len = match step {
                    Step::Epi(direction) => epi::line_len(self.plan.epi(), direction),
                    _ => width,
                };
                let at = start * line_len;
                let (d, c) = match step {
                    Step::Epi(Direction::Horizontal) | Step::Fuse => (CURRENT_D, CURRENT_C),
                    // The refinement reads the start (current) and the candidate (other)
                    // disparities with a halo, which no place of its step may write:
                    // its disparity goes to the free other confidence, its confidence
                    // to the current one (read at a part's own rows only).
                    Step::Refine if self.candidate() => (OTHER_C, CURRENT_C),
                    _ => (OTHER_D, OTHER_C),
                };
                put(state.map_mut(d), at, part.disparity)?;
                if !part.confidence.is_empty() {
                    put(state.map_mut(c), at, part.confidence)?;
                }
                if !part.candidate.is_empty() {
                    // The sweep's candidate: the current disparity until the step
                    // finishes, then (swapped) the other one.
                    put(state.map_mut(CURRENT_D), at, part.candidate)?;
                }
                Ok(())
            }
        }
    }

    /// Closes `step` once every part is placed: the maps it wrote become the current
    /// ones, and after the last TV sweep the residual history is normalised.
    pub fn finish(&self, step: Step, state: &mut State<'_>) {
        let swap_d = |state: &mut State<'_>| state.swap_maps(CURRENT_D, OTHER_D);
        match step {
            // The fused start's choice is placed into the current maps; its plane sweep
            // leaves the refined EPI maps current for it.
            Step::Range | Step::Epi(Direction::Horizontal) | Step::Fuse => {}
            Step::PlaneSweep if self.plan.params().fused => {}
            // Both directions are in: the one fusion of every driver (a column of
            // cameras has no horizontal estimates to fuse with).
            Step::Epi(Direction::Vertical) => {
                let (width, height) = epi::map_size(self.plan.epi());
                let fusion = Direction::Horizontal
                    .exists(self.plan.layout())
                    .then_some(self.plan.params().epi.fusion);
                state.fuse(fusion, width, height);
            }
            // The refined disparity is in the other confidence's map ([`Schedule::place`]).
            Step::Refine if self.candidate() => state.swap_maps(CURRENT_D, OTHER_C),
            Step::Upsample | Step::PlaneSweep | Step::Refine => {
                swap_d(state);
                state.swap_maps(CURRENT_C, OTHER_C);
            }
            Step::Refill | Step::Median => swap_d(state),
            Step::Tv { sweep } => {
                if sweep < self.plan.params().tv.sweeps {
                    state.swap_duals();
                } else {
                    swap_d(state);
                    tv::normalise_history(self.plan.tv(), state.history_mut());
                }
            }
        }
    }
}

#[cfg(test)]
mod tests;

/// Refines the rows `lines` of the start map `start` into the part's output: the
/// refinement of the chosen start and, for the fused start, of the plane sweep's map.
fn refine_rows<T: Scalar, S: Sample>(
    setup: Setup<'_, RefineParams>,
    lf: &LightField<'_, S>,
    h: &Hypotheses,
    start: Start<'_>,
    lines: core::ops::Range<usize>,
    out: &mut PartOutput<'_>,
    kernel: &mut [T],
) -> Result<()> {
    refine::refine_band_from(
        setup,
        lf,
        (h.min(), h.max()),
        start,
        lines,
        DisparityOut {
            disparity: &mut *out.disparity,
            confidence: &mut *out.confidence,
        },
        kernel,
    )
}

/// The rows `lines` of the row-major map `map` (`width` per row); `what` names the map
/// in the error when it is shorter.
fn band_of<'m>(
    map: &'m [f32],
    lines: &core::ops::Range<usize>,
    width: usize,
    what: &'static str,
) -> Result<&'m [f32]> {
    let own = lines.start * width..lines.end * width;
    let needed = own.end;
    map.get(own).ok_or(Error::OutputSize {
        what,
        needed,
        got: map.len(),
    })
}

/// Whether the refinement scales its confidence by the plane sweep's ([`distrust`]):
/// the sweep starts the pipeline alone and its trust is on.
fn distrusts_sweep(params: &crate::plan::Params) -> bool {
    params.sweep.enabled && !params.fused && params.sweep.trust > 0.0
}

/// Scales each refined confidence in `refined` by `(start / trust)²` where the plane
/// sweep's confidence `start` of the same pixel is below `trust` (> 0): a pixel whose
/// cost curve was flat took its window's winner, which a whole patch shares, and TV
/// should lean on its neighbours there rather than keep the patch as a surface.
fn distrust(trust: f32, start: &[f32], refined: &mut [f32]) {
    for (c, &s) in refined.iter_mut().zip(start) {
        if s < trust {
            let r = s.max(0.0) / trust;
            *c *= r * r;
        }
    }
}

/// Runs one step's part in a frame of its own: the stages' locals (the EPI line
/// estimator, the refinement's per-view tables, the median's windows) never share one
/// frame, so the deepest stack is that of one stage, not of all of them together
/// (docs/EMBEDDED.md, "Stack").
#[inline(never)]
fn alone<R>(part: impl FnOnce() -> R) -> R {
    part()
}
