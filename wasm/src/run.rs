//! The core's schedule driven from JavaScript, part by part, so the page can spread every
//! step over Web Workers: the page's thread holds a [`Run`] (it lists the steps, gives
//! each step's inputs to the workers and places their outputs in part order), each
//! worker's [`Estimator`] runs parts ([`Estimator::run_part`]). No stage is named here or
//! in the page: the steps, their parts and their placing are the core's. The run also
//! keeps the disparity after each stage ([`Run::snapshots`], labelled here), so the page
//! can show what every stage did without naming one.

use lfdepth::pipeline::Stages;
use lfdepth::schedule::{Cursor, PartOutput, PartScratch, Schedule, State, StateMaps, Step};
use lfdepth::Plan;
use wasm_bindgen::prelude::*;

use crate::estimator::{iterations_run, Estimator, WorkerRun};
use crate::js::{error, message};
use crate::params;
use crate::samples::with_light_field;

/// The state of one run on the page's thread: the maps between the steps.
#[wasm_bindgen]
pub struct Run {
    schedule: Schedule,
    buffer: Vec<f32>,
    cursor: Cursor,
    /// The disparity after each stage so far, with its label ([`snapshot_label`]).
    snapshots: Vec<(String, Vec<f32>)>,
}

/// The label of the disparity map a run holds once step `index` of `steps` is finished,
/// when that map is a stage's result worth showing: the fused EPI estimate, the
/// refined, refilled and median-filtered maps, and TV's after its last sweep; the last
/// step's map is also marked final. `None` for the steps before the EPI fusion and
/// between TV sweeps.
fn snapshot_label(steps: &[Step], index: usize) -> Option<String> {
    let step = *steps.get(index)?;
    let next = steps.get(index + 1);
    if next.is_some_and(|n| n.stage() == step.stage()) {
        return None;
    }
    let label = match step {
        // The EPI estimate is complete after its last direction (a linear array has one),
        // and at half resolution only once upsampled (the fused map is a quarter of the
        // frame until then).
        Step::Range => return None,
        Step::Epi(_) if matches!(next, Some(Step::Epi(_)) | Some(Step::Upsample)) => return None,
        Step::Epi(_) | Step::Upsample => "EPI estimate",
        // In the fused start the plane sweep's map is not the current one until chosen.
        Step::PlaneSweep if next == Some(&Step::Fuse) => return None,
        Step::PlaneSweep => "plane-sweep estimate",
        Step::Fuse => "fused start",
        Step::Refine => "refined",
        Step::Refill => "refilled at depth steps",
        Step::Median => "edge-snapping median",
        Step::Tv { .. } => "TV",
    };
    Some(if next.is_none() {
        format!("{label} (final)")
    } else {
        label.to_string()
    })
}

fn step_at(schedule: &Schedule, step: usize) -> Result<Step, JsError> {
    schedule.steps().get(step).copied().ok_or_else(|| {
        message(&format!(
            "step {step} does not exist: the run has {} steps",
            schedule.steps().len()
        ))
    })
}

fn array(values: &[f32]) -> JsValue {
    js_sys::Float32Array::from(values).into()
}

#[wasm_bindgen]
impl Run {
    /// A run of `params` (as `Estimator` takes them; `stage` says how far) over a light
    /// field of `shape`, for a driver that runs `workers` parts at once (this sets the
    /// median's row bands and the refinement's with many workers, never the result).
    /// Workers must run parts with the same `workers` and parameters.
    #[wasm_bindgen(constructor)]
    pub fn new(
        #[wasm_bindgen(unchecked_param_type = "Shape")] shape: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EstimateParams")] params: Option<JsValue>,
        workers: usize,
    ) -> Result<Run, JsError> {
        let (_, plan, stages) = params::plan(&shape, params)?;
        Run::for_plan(&plan, stages, workers)
    }

    /// Number of steps.
    #[wasm_bindgen(getter)]
    pub fn steps(&self) -> usize {
        self.schedule.steps().len()
    }

    /// The stage name of step `step` (progress and timings).
    pub fn stage(&self, step: usize) -> Result<String, JsError> {
        Ok(step_at(&self.schedule, step)?.stage().to_string())
    }

    /// Number of parts of step `step`.
    pub fn parts(&self, step: usize) -> Result<usize, JsError> {
        Ok(self.schedule.parts(step_at(&self.schedule, step)?))
    }

    /// What the parts of step `step` read, to hand to every worker before its parts
    /// (`Estimator.setInputs`): an object with `range` once known and the maps the step
    /// reads (`disparity`, `confidence`, `otherDisparity`, `otherConfidence`, `dual`).
    pub fn inputs(&mut self, step: usize) -> Result<JsValue, JsError> {
        let step = step_at(&self.schedule, step)?;
        let reads = self.schedule.reads(step);
        let state = self.state()?;
        let object = js_sys::Object::new();
        let set = |key: &str, value: JsValue| {
            js_sys::Reflect::set(&object, &key.into(), &value)
                .map(|_| ())
                .map_err(|_| message("could not build the inputs object"))
        };
        if let Some((min, max)) = state.range() {
            set("range", array(&[min, max]))?;
        }
        if reads.disparity {
            set("disparity", array(state.disparity()))?;
        }
        if reads.confidence {
            set("confidence", array(state.confidence()))?;
        }
        if reads.other {
            let (d, c) = state.other();
            set("otherDisparity", array(d))?;
            set("otherConfidence", array(c))?;
        }
        if reads.dual {
            set("dual", array(state.dual()))?;
        }
        Ok(object.into())
    }

    /// Places part `index` of step `step` (the array a worker's `runPart` returned).
    /// Place the parts of a step in index order.
    pub fn place(&mut self, step: usize, index: usize, output: &mut [f32]) -> Result<(), JsError> {
        let step = step_at(&self.schedule, step)?;
        let len = self.schedule.part_len(step, index).map_err(error)?;
        if output.len() != len.total() {
            return Err(message(&format!(
                "part {index} has {} values but its step's parts have {}",
                output.len(),
                len.total()
            )));
        }
        let part = PartOutput::split(output, len).map_err(error)?;
        let schedule = self.schedule.clone();
        let mut state = self.state()?;
        schedule
            .place(step, index, &part, &mut state)
            .map_err(error)?;
        self.cursor = state.cursor();
        Ok(())
    }

    /// Closes step `step` once every part is placed.
    pub fn finish(&mut self, step: usize) -> Result<(), JsError> {
        let step = step_at(&self.schedule, step)?;
        let schedule = self.schedule.clone();
        let mut state = self.state()?;
        schedule.finish(step, &mut state);
        self.cursor = state.cursor();
        let index = schedule.steps().iter().position(|s| *s == step);
        if let Some(label) = index.and_then(|k| snapshot_label(schedule.steps(), k)) {
            let disparity = self.state()?.disparity().to_vec();
            self.snapshots.retain(|(l, _)| *l != label);
            self.snapshots.push((label, disparity));
        }
        Ok(())
    }

    /// The disparity after each stage finished so far, in schedule order: an array of
    /// `{ label, disparity }` (a `Float32Array`, row-major); the last one of a whole run
    /// is the result, its label marked "(final)". Labels name the stages for people.
    #[wasm_bindgen(
        getter,
        unchecked_return_type = "{ label: string, disparity: Float32Array }[]"
    )]
    pub fn snapshots(&self) -> Result<js_sys::Array, JsError> {
        let out = js_sys::Array::new();
        for (label, disparity) in &self.snapshots {
            let object = js_sys::Object::new();
            for (key, value) in [
                ("label", JsValue::from_str(label)),
                ("disparity", array(disparity)),
            ] {
                js_sys::Reflect::set(&object, &key.into(), &value)
                    .map_err(|_| message("could not build a snapshot object"))?;
            }
            out.push(&object);
        }
        Ok(out)
    }

    /// The disparity after the last step (row-major, top row first).
    #[wasm_bindgen(getter)]
    pub fn disparity(&mut self) -> Result<js_sys::Float32Array, JsError> {
        Ok(js_sys::Float32Array::from(self.state()?.disparity()))
    }

    /// The confidence after the last step.
    #[wasm_bindgen(getter)]
    pub fn confidence(&mut self) -> Result<js_sys::Float32Array, JsError> {
        Ok(js_sys::Float32Array::from(self.state()?.confidence()))
    }

    /// The TV residual per iteration run (empty when TV did not run).
    #[wasm_bindgen(getter)]
    pub fn residuals(&mut self) -> Result<js_sys::Float32Array, JsError> {
        let tv = self.schedule.steps().contains(&Step::Tv { sweep: 0 });
        let history = if tv {
            iterations_run(self.state()?.history().to_vec())
        } else {
            Vec::new()
        };
        Ok(js_sys::Float32Array::from(&history[..]))
    }

    /// The disparity range the EPI stage tested, `[min, max]` (empty before the range
    /// step).
    #[wasm_bindgen(getter)]
    pub fn range(&mut self) -> Result<Vec<f32>, JsError> {
        Ok(self
            .state()?
            .range()
            .map_or_else(Vec::new, |(min, max)| vec![min, max]))
    }
}

impl Run {
    pub(crate) fn for_plan(plan: &Plan, stages: Stages, workers: usize) -> Result<Run, JsError> {
        let schedule = Schedule::new(plan, stages, workers.max(1)).map_err(error)?;
        let mut buffer = vec![0.0f32; schedule.state_len()];
        let cursor = State::new(&schedule, &mut buffer).map_err(error)?.cursor();
        Ok(Run {
            schedule,
            buffer,
            cursor,
            snapshots: Vec::new(),
        })
    }

    fn state(&mut self) -> Result<State<'_>, JsError> {
        State::resume(&self.schedule, &mut self.buffer, self.cursor).map_err(error)
    }
}

/// The `Float32Array` at `key` of `object`, if any.
fn map_of(object: &JsValue, key: &str) -> Result<Option<Vec<f32>>, JsError> {
    let value = js_sys::Reflect::get(object, &key.into())
        .map_err(|_| message(&format!("could not read `{key}` of the inputs")))?;
    if value.is_undefined() || value.is_null() {
        return Ok(None);
    }
    let array = value
        .dyn_into::<js_sys::Float32Array>()
        .map_err(|_| message(&format!("`{key}` of the inputs must be a Float32Array")))?;
    Ok(Some(array.to_vec()))
}

/// The `range` of `object`: `[min, max]` as an array or a `Float32Array`, if any.
fn range_of(object: &JsValue) -> Result<Option<Vec<f32>>, JsError> {
    let value = js_sys::Reflect::get(object, &"range".into())
        .map_err(|_| message("could not read `range` of the inputs"))?;
    if value.is_undefined() || value.is_null() {
        return Ok(None);
    }
    if !(js_sys::Array::is_array(&value) || value.is_instance_of::<js_sys::Float32Array>()) {
        return Err(message("`range` of the inputs must hold [min, max]"));
    }
    Ok(Some(js_sys::Float32Array::new(&value).to_vec()))
}

#[wasm_bindgen]
impl Estimator {
    /// Takes the inputs of a step (`Run.inputs`) for the parts this worker will run with
    /// `runPart(workers, …)`.
    #[wasm_bindgen(js_name = setInputs)]
    pub fn set_inputs(&mut self, workers: usize, inputs: JsValue) -> Result<(), JsError> {
        let run = self.worker_run(workers)?;
        let range = match range_of(&inputs)? {
            Some(range) => match range[..] {
                [min, max] => Some((min, max)),
                _ => return Err(message("`range` of the inputs must hold [min, max]")),
            },
            None => None,
        };
        let maps = [
            map_of(&inputs, "disparity")?,
            map_of(&inputs, "confidence")?,
            map_of(&inputs, "otherDisparity")?,
            map_of(&inputs, "otherConfidence")?,
            map_of(&inputs, "dual")?,
        ];
        let plan = *run.schedule.plan();
        let mut state = State::new(&run.schedule, &mut run.buffer).map_err(error)?;
        state
            .set(
                &plan,
                StateMaps {
                    disparity: maps[0].as_deref(),
                    confidence: maps[1].as_deref(),
                    other_disparity: maps[2].as_deref(),
                    other_confidence: maps[3].as_deref(),
                    dual: maps[4].as_deref(),
                },
                range,
            )
            .map_err(error)?;
        run.range = range.or(run.range);
        Ok(())
    }

    /// Runs part `index` of step `step` of the schedule for `workers` from the inputs of
    /// `setInputs`: the array to hand to `Run.place`.
    #[wasm_bindgen(js_name = runPart)]
    pub fn run_part(
        &mut self,
        workers: usize,
        step: usize,
        index: usize,
    ) -> Result<js_sys::Float32Array, JsError> {
        self.worker_run(workers)?;
        let Some(run) = self.run.as_mut() else {
            return Err(message("no run: call setInputs first"));
        };
        let step = step_at(&run.schedule, step)?;
        let len = run.schedule.part_len(step, index).map_err(error)?;
        let lens = run.schedule.scratch_len(step);
        let mut output = vec![0.0f32; len.total()];
        let mut kernel = vec![0.0f32; lens.kernel];
        let mut maps = vec![0.0f32; lens.maps];
        let mut flags = vec![0u8; lens.flags];
        let plan = *run.schedule.plan();
        let mut state = State::new(&run.schedule, &mut run.buffer).map_err(error)?;
        state
            .set(&plan, StateMaps::default(), run.range)
            .map_err(error)?;
        let mut out = PartOutput::split(&mut output, len).map_err(error)?;
        let scratch = PartScratch {
            kernel: &mut kernel,
            maps: &mut maps,
            flags: &mut flags,
        };
        with_light_field!(&self.views, self.layout, |lf| {
            run.schedule
                .run_part(step, index, &lf?, &state, &mut out, scratch)
        })
        .map_err(error)?;
        Ok(js_sys::Float32Array::from(&output[..]))
    }

    /// Frees the inputs of `setInputs`.
    #[wasm_bindgen(js_name = clearInputs)]
    pub fn clear_inputs(&mut self) {
        self.run = None;
    }
}

impl Estimator {
    /// The worker run for `workers` over the current plan (a new one when either
    /// changed).
    fn worker_run(&mut self, workers: usize) -> Result<&mut WorkerRun, JsError> {
        let stale = self
            .run
            .as_ref()
            .is_none_or(|r| r.workers != workers || r.schedule.plan() != &self.plan);
        if stale {
            let schedule =
                Schedule::new(&self.plan, self.stages(), workers.max(1)).map_err(error)?;
            let buffer = vec![0.0f32; schedule.state_len()];
            self.run = Some(WorkerRun {
                workers,
                schedule,
                buffer,
                range: None,
            });
        }
        self.run
            .as_mut()
            .ok_or_else(|| message("no run: call setInputs first"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use lfdepth::epi::Direction;

    #[test]
    fn a_snapshot_after_each_stage_and_the_last_marked_final() {
        use Direction::{Horizontal, Vertical};
        // (what, the steps, the label after each step: "" for none).
        let cases: &[(&str, &[Step], &[&str])] = &[
            (
                "the EPI start's full pipeline",
                &[
                    Step::Range,
                    Step::Epi(Horizontal),
                    Step::Epi(Vertical),
                    Step::Refine,
                    Step::Refill,
                    Step::Median,
                    Step::Tv { sweep: 0 },
                    Step::Tv { sweep: 1 },
                ],
                &[
                    "",
                    "",
                    "EPI estimate",
                    "refined",
                    "refilled at depth steps",
                    "edge-snapping median",
                    "",
                    "TV (final)",
                ],
            ),
            (
                "the EPI stage alone: its estimate is the result",
                &[Step::Range, Step::Epi(Horizontal), Step::Epi(Vertical)],
                &["", "", "EPI estimate (final)"],
            ),
            (
                "the median after TV",
                &[Step::Epi(Vertical), Step::Tv { sweep: 0 }, Step::Median],
                &["EPI estimate", "TV", "edge-snapping median (final)"],
            ),
            (
                "the plane-sweep start",
                &[Step::Range, Step::PlaneSweep, Step::Refine, Step::Median],
                &[
                    "",
                    "plane-sweep estimate",
                    "refined",
                    "edge-snapping median (final)",
                ],
            ),
            (
                "the fused start: the plane sweep's map is not shown before the choice",
                &[
                    Step::Range,
                    Step::Epi(Horizontal),
                    Step::Epi(Vertical),
                    Step::Refine,
                    Step::PlaneSweep,
                    Step::Fuse,
                    Step::Refill,
                ],
                &[
                    "",
                    "",
                    "EPI estimate",
                    "refined",
                    "",
                    "fused start",
                    "refilled at depth steps (final)",
                ],
            ),
            (
                "the half-resolution EPI: complete once upsampled",
                &[
                    Step::Range,
                    Step::Epi(Horizontal),
                    Step::Epi(Vertical),
                    Step::Upsample,
                    Step::Refine,
                ],
                &["", "", "", "EPI estimate", "refined (final)"],
            ),
            (
                "a row of cameras: its horizontal step is the EPI estimate",
                &[Step::Range, Step::Epi(Horizontal), Step::Refine],
                &["", "EPI estimate", "refined (final)"],
            ),
        ];
        for &(what, steps, expected) in cases {
            assert_eq!(steps.len(), expected.len(), "{what}: one label per step");
            // One index past the last step has no map.
            let labels: Vec<_> = (0..=steps.len())
                .map(|k| snapshot_label(steps, k))
                .collect();
            let expected: Vec<_> = expected
                .iter()
                .map(|l| (!l.is_empty()).then(|| l.to_string()))
                .chain([None])
                .collect();
            assert_eq!(labels, expected, "{what}");
        }
    }
}
