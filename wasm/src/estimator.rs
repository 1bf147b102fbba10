//! The estimator: a copy of the views and a validated plan, run whole or band by band.

use core::ops::ControlFlow;

use lfdepth::align::{AlignMode, AlignReport};
use lfdepth::epi;
use lfdepth::pipeline::{self, AlignBuffers, Progress, Stages};
use lfdepth::schedule::Schedule;
use lfdepth::tv;
use lfdepth::{median, refine, Homography, Layout, Plan};
use wasm_bindgen::prelude::*;

use crate::js::{self, error, message};
use crate::params;
use crate::samples::{with_light_field, Samples};

/// The progress stage names of the core pipeline, in the order they run (the plane sweep,
/// the default start, in place of the two EPI directions).
#[wasm_bindgen(js_name = stageNames)]
pub fn stage_names() -> Vec<String> {
    [
        pipeline::STAGE_ALIGN,
        pipeline::STAGE_WARP,
        epi::STAGE_RANGE,
        lfdepth::planesweep::STAGE,
        epi::STAGE_HORIZONTAL,
        epi::STAGE_VERTICAL,
        refine::STAGE,
        lfdepth::geofill::STAGE,
        median::STAGE,
        tv::STAGE,
    ]
    .iter()
    .map(|s| s.to_string())
    .collect()
}

/// Wall time of one stage.
#[wasm_bindgen]
#[derive(Clone, Debug)]
pub struct StageTiming {
    stage: String,
    /// Milliseconds.
    #[wasm_bindgen(readonly)]
    pub ms: f64,
}

#[wasm_bindgen]
impl StageTiming {
    /// The core's stage name.
    #[wasm_bindgen(getter)]
    pub fn stage(&self) -> String {
        self.stage.clone()
    }
}

/// What [`Estimator::estimate`] returns.
#[wasm_bindgen]
pub struct EstimateResult {
    width: usize,
    height: usize,
    disparity: Vec<f32>,
    confidence: Vec<f32>,
    residuals: Vec<f32>,
    timings: Vec<StageTiming>,
    align: Option<AlignResult>,
}

#[wasm_bindgen]
impl EstimateResult {
    /// What the alignment did (`undefined` when `params.align` is "off").
    #[wasm_bindgen(getter)]
    pub fn align(&self) -> Option<AlignResult> {
        self.align.clone()
    }
    /// Centre-view width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> usize {
        self.width
    }
    /// Centre-view height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> usize {
        self.height
    }
    /// Disparity per pixel (px between adjacent views), row-major, top row first.
    #[wasm_bindgen(getter)]
    pub fn disparity(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.disparity[..])
    }
    /// Confidence per pixel in [0, 1].
    #[wasm_bindgen(getter)]
    pub fn confidence(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.confidence[..])
    }
    /// TV residual (RMS dual update) per iteration run, summed over the tiles (empty
    /// when the TV stage did not run).
    #[wasm_bindgen(getter)]
    pub fn residuals(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.residuals[..])
    }
    /// Wall time of each stage that ran, in order.
    #[wasm_bindgen(getter)]
    pub fn timings(&self) -> Vec<StageTiming> {
        self.timings.clone()
    }
}

/// What [`Estimator::align`] did.
#[wasm_bindgen]
#[derive(Clone, Debug)]
pub struct AlignResult {
    report: AlignReport,
    homographies: Vec<Homography>,
    timings: Vec<StageTiming>,
}

#[wasm_bindgen]
impl AlignResult {
    /// True when the views were left as they are: `align: "off"`, or `"auto"` found the
    /// array rectified or could not align it (see `warning`).
    #[wasm_bindgen(getter)]
    pub fn skipped(&self) -> bool {
        self.report.skipped
    }
    /// `"auto"` only: why alignment failed and the views were used as they are.
    #[wasm_bindgen(getter)]
    pub fn warning(&self) -> Option<String> {
        self.report.warning.map(|e| e.to_string())
    }
    /// RMS reprojection error of the tracked corners with identity homographies (px):
    /// the misalignment as measured.
    #[wasm_bindgen(getter, js_name = identityRms)]
    pub fn identity_rms(&self) -> f32 {
        self.report.identity_rms
    }
    /// RMS reprojection error after alignment (px).
    #[wasm_bindgen(getter)]
    pub fn rms(&self) -> f32 {
        self.report.rms
    }
    /// Per view (row-major grid order) the 3×3 homography, row-major, mapping rectified
    /// pixel coordinates to the view's (identities when skipped).
    #[wasm_bindgen(getter)]
    pub fn homographies(&self) -> js_sys::Float32Array {
        let flat: Vec<f32> = self.homographies.iter().flat_map(|h| h.m).collect();
        js_sys::Float32Array::from(&flat[..])
    }
    /// Wall time of the alignment stages that ran.
    #[wasm_bindgen(getter)]
    pub fn timings(&self) -> Vec<StageTiming> {
        self.timings.clone()
    }
}

/// What a worker's estimator keeps between the parts of a run: the schedule (for its
/// `workers`), the inputs of the current step and the range.
pub(crate) struct WorkerRun {
    pub(crate) workers: usize,
    pub(crate) schedule: Schedule,
    pub(crate) buffer: Vec<f32>,
    pub(crate) range: Option<(f32, f32)>,
}

/// Disparity of the centre view of a light field held in wasm memory.
#[wasm_bindgen]
pub struct Estimator {
    /// The views, packed; `f32` once the alignment warped them.
    pub(crate) views: Samples,
    pub(crate) layout: Layout,
    pub(crate) plan: Plan,
    stages: Stages,
    /// Set once the alignment prelude ran: `views` are then the rectified views.
    aligned: Option<AlignResult>,
    /// The schedule and the inputs of the parts this worker runs (`setInputs`,
    /// `runPart`).
    pub(crate) run: Option<WorkerRun>,
    /// True when only the views the stages read are held (`fromReadViews`; the others
    /// are zero).
    pub(crate) partial: bool,
}

impl Estimator {
    /// The alignment prelude (once): estimates the homographies and, unless skipped,
    /// replaces the views by the rectified views the stages read, in `f32` (the others
    /// zero), as the `lfdepth` tool warps them.
    fn align_views(
        &mut self,
        report: &mut dyn FnMut(Progress) -> ControlFlow<()>,
    ) -> lfdepth::Result<()> {
        if self.aligned.is_some() || self.plan.params().align.mode == AlignMode::Off {
            return Ok(());
        }
        let mut homographies = vec![Homography::IDENTITY; self.layout.grid.len()];
        let mut scratch = vec![0.0f32; pipeline::align_scratch_len(&self.plan)?];
        // Zeroed pages never written (views no stage reads) cost no memory.
        let mut rectified = vec![0.0f32; pipeline::aligned_len(&self.plan)?];
        let mut buffers = AlignBuffers {
            homographies: &mut homographies,
            scratch: &mut scratch,
            aligned: &mut rectified,
        };
        let outcome = with_light_field!(&self.views, self.layout, |lf| {
            pipeline::align_views(&self.plan, &lf?, self.stages, &mut buffers, report)?
        });
        drop(scratch);
        if !outcome.skipped {
            self.views = Samples::F32(rectified);
            // The stages compare warped views from now on (`replan` keeps this).
            self.plan = pipeline::resampled_plan(&self.plan)?;
        }
        self.aligned = Some(AlignResult {
            report: outcome,
            homographies,
            timings: Vec::new(),
        });
        Ok(())
    }
}

impl Estimator {
    /// An estimator over `views` (validated against `layout` by the caller); `partial`:
    /// only the views `stages` read are filled.
    pub(crate) fn with_views(
        views: Samples,
        layout: Layout,
        plan: Plan,
        stages: Stages,
        partial: bool,
    ) -> Self {
        Estimator {
            views,
            layout,
            plan,
            stages,
            aligned: None,
            run: None,
            partial,
        }
    }

    /// Replaces the plan and stages (same layout, same views) and forgets the maps.
    pub(crate) fn replan(&mut self, plan: Plan, stages: Stages) {
        // Warped views keep the refinement's sampling slack (`pipeline::resampled_plan`
        // of a valid plan only sets a valid value: the fallback never happens).
        self.plan = if self.warped() {
            pipeline::resampled_plan(&plan).unwrap_or(plan)
        } else {
            plan
        };
        self.stages = stages;
        self.run = None;
    }

    /// True when the alignment rectified the views (only those the stages read).
    pub(crate) fn warped(&self) -> bool {
        self.aligned.as_ref().is_some_and(|a| !a.report.skipped)
    }

    /// The layout of the views.
    pub(crate) fn layout(&self) -> &Layout {
        &self.layout
    }

    /// The views the stages read from (rectified once aligned), packed.
    pub(crate) fn samples(&self) -> &Samples {
        &self.views
    }

    /// How far `estimate` goes.
    pub(crate) fn stages(&self) -> Stages {
        self.stages
    }
}

#[wasm_bindgen]
impl Estimator {
    /// Copies `views` (packed, row-major grid order, `rows · cols · height · width ·
    /// channels` samples: bytes, or `f32` intensities in nominal [0, 1] as `views` of
    /// an aligned estimator holds them) and validates `shape` and `params` against the
    /// core's limits.
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "Uint8Array | Uint8ClampedArray | Float32Array")]
        views: JsValue,
        #[wasm_bindgen(unchecked_param_type = "Shape")] shape: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EstimateParams")] params: Option<JsValue>,
    ) -> Result<Estimator, JsError> {
        let (layout, plan, stages) = params::plan(&shape, params)?;
        let views = Samples::from_js(&views, "views")?;
        with_light_field!(&views, layout, |lf| lf.map(|_| ())).map_err(error)?;
        Ok(Estimator::with_views(views, layout, plan, stages, false))
    }

    /// View width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> usize {
        self.layout.width
    }
    /// View height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> usize {
        self.layout.height
    }

    /// Runs the pipeline on this thread: the start (the plane sweep, or the EPI stage with
    /// `params.initial: "epi"`) → refine (unless `params.refine` is false) → refill →
    /// median → TV, or the start alone with `params.stage: "epi"`. `onProgress` is called as
    /// work completes with `{ stage, done, total }`; returning `false` cancels (the call
    /// then throws an `Error` "cancelled by the caller"); an exception it throws is
    /// rethrown.
    pub fn estimate(
        &mut self,
        #[wasm_bindgen(
            js_name = onProgress,
            unchecked_param_type = "(progress: Progress) => boolean | void"
        )]
        on_progress: Option<JsValue>,
    ) -> Result<EstimateResult, JsValue> {
        let pixels = self.plan.pixels();
        let mut disparity = vec![0.0f32; pixels];
        let mut confidence = vec![0.0f32; pixels];
        let mut maps = vec![0.0f32; pipeline::stage_map_scratch_len(&self.plan, self.stages)];
        let mut history = match self.stages {
            Stages::Epi => Vec::new(),
            Stages::Full => vec![0.0f32; self.plan.params().tv.max_iterations],
        };
        let timings = with_progress(on_progress, |report| {
            self.align_views(report)?;
            let mut scratch = vec![0.0f32; pipeline::stage_scratch_len(&self.plan, self.stages)];
            with_light_field!(&self.views, self.layout, |lf| {
                pipeline::run(
                    &self.plan,
                    &lf?,
                    self.stages,
                    pipeline::RunOutput {
                        disparity: &mut disparity,
                        confidence: &mut confidence,
                        history: &mut history,
                    },
                    pipeline::RunScratch {
                        kernel: &mut scratch,
                        maps: &mut maps,
                    },
                    report,
                )
            })
        })?;
        Ok(EstimateResult {
            width: self.layout.width,
            height: self.layout.height,
            disparity,
            confidence,
            residuals: iterations_run(history),
            timings,
            align: self.aligned.clone(),
        })
    }

    /// The alignment prelude alone, on this thread (what `estimate()` runs first): with
    /// `params.align` "on", or "auto" on an array found not rectified, estimates one
    /// homography per view and replaces the views the stages read by their rectified
    /// versions (`views`), for `estimate()` and every `runPart()`. Runs once; later calls return the same result. "on" throws an `Error` when
    /// a view cannot be aligned (textureless or too different); "auto" then reports a
    /// `warning` and keeps the views. `onProgress` as for `estimate`.
    pub fn align(
        &mut self,
        #[wasm_bindgen(
            js_name = onProgress,
            unchecked_param_type = "(progress: Progress) => boolean | void"
        )]
        on_progress: Option<JsValue>,
    ) -> Result<AlignResult, JsValue> {
        let timings = with_progress(on_progress, |report| self.align_views(report))?;
        Ok(match &self.aligned {
            Some(result) => AlignResult {
                timings,
                ..result.clone()
            },
            None => AlignResult {
                report: AlignReport {
                    skipped: true,
                    ..AlignReport::default()
                },
                homographies: vec![Homography::IDENTITY; self.layout.grid.len()],
                timings,
            },
        })
    }

    /// The views the stages read from (a copy, packed as given): once `align()`
    /// aligned them, a `Float32Array` of the rectified views the stages read (intensity
    /// in [0, 1], not rounded to 8 bits; the views no stage reads are zero), which
    /// `new Estimator` takes as it is.
    #[wasm_bindgen(getter, unchecked_return_type = "Uint8Array | Float32Array")]
    pub fn views(&self) -> JsValue {
        self.views.to_js()
    }
}

/// The TV history without the iterations no tile ran (as the native engine trims it).
pub(crate) fn iterations_run(mut history: Vec<f32>) -> Vec<f32> {
    while history.last() == Some(&0.0) {
        history.pop();
    }
    history
}

/// Runs `work` with a progress callback that forwards `{ stage, done, total }` to the JS
/// `on_progress` (returning `false` cancels; an exception it throws is rethrown) and
/// returns the wall time of each stage: from its first report to the next stage's first
/// report.
fn with_progress(
    on_progress: Option<JsValue>,
    work: impl FnOnce(&mut dyn FnMut(Progress) -> ControlFlow<()>) -> lfdepth::Result<()>,
) -> Result<Vec<StageTiming>, JsValue> {
    let on_progress = on_progress.unwrap_or(JsValue::UNDEFINED);
    let callback = on_progress.dyn_ref::<js_sys::Function>();
    if callback.is_none() && !on_progress.is_undefined() && !on_progress.is_null() {
        return Err(message("onProgress must be a function").into());
    }
    let mut starts: Vec<(&'static str, f64)> = Vec::new();
    let mut thrown: Option<JsValue> = None;
    let mut report = |p: Progress| -> ControlFlow<()> {
        if starts.last().map(|s| s.0) != Some(p.stage) {
            starts.push((p.stage, js::now_ms()));
        }
        let Some(f) = callback else {
            return ControlFlow::Continue(());
        };
        let object = js_sys::Object::new();
        let set = |k: &str, v: JsValue| js_sys::Reflect::set(&object, &k.into(), &v);
        let _ = set("stage", p.stage.into());
        let _ = set("done", (p.done as f64).into());
        let _ = set("total", (p.total as f64).into());
        match f.call1(&JsValue::NULL, &object) {
            Ok(v) if v.as_bool() == Some(false) => ControlFlow::Break(()),
            Ok(_) => ControlFlow::Continue(()),
            Err(e) => {
                thrown = Some(e);
                ControlFlow::Break(())
            }
        }
    };
    let result = work(&mut report);
    let end = js::now_ms();
    if let Some(e) = thrown {
        return Err(e);
    }
    result.map_err(error)?;
    Ok(starts
        .iter()
        .enumerate()
        .map(|(i, &(stage, start))| StageTiming {
            stage: stage.to_string(),
            ms: starts.get(i + 1).map_or(end, |next| next.1) - start,
        })
        .collect())
}
