//! The views the stages read, and an [`Estimator`] that holds those alone: the page
//! hands each worker only these (17 of 81 views on a 9×9 grid with the default
//! parameters) instead of the whole light field. The core says which views a stage
//! reads (`pipeline::reads_view`, the same rule that decides which views the alignment
//! warps), so an estimator whose other views are zero gives the same bits.

use lfdepth::align::AlignMode;
use lfdepth::pipeline::{self, Stages};
use lfdepth::{Layout, Plan};
use wasm_bindgen::prelude::*;

use crate::estimator::Estimator;
use crate::js::{error, message};
use crate::params;
use crate::samples::{with_light_field, Samples};

/// The grid indices (row-major) of the views `plan`'s `stages` read, ascending.
fn read_indices(plan: &Plan, stages: Stages) -> Vec<usize> {
    (0..plan.layout().grid.len())
        .filter(|&v| pipeline::reads_view(plan, stages, v))
        .collect()
}

/// Samples of one packed view of `layout`.
fn view_len(layout: &Layout) -> usize {
    layout.view_stride
}

/// Grid indices (row-major, ascending) of the views the stages of `params` read: the
/// centre row and column of the grid, and the refinement's views when it runs. Every
/// other view may be left out of `Estimator.fromReadViews`. The alignment reads other
/// views too: this is the set for `params` with `align: "off"`.
#[wasm_bindgen(js_name = readViews)]
pub fn read_views(
    #[wasm_bindgen(unchecked_param_type = "Shape")] shape: JsValue,
    #[wasm_bindgen(unchecked_param_type = "EstimateParams")] params: Option<JsValue>,
) -> Result<Vec<u32>, JsError> {
    let (_, plan, stages) = params::plan(&shape, params)?;
    read_indices(&plan, stages)
        .into_iter()
        .map(|v| u32::try_from(v).map_err(|_| message("the grid has too many views")))
        .collect()
}

#[wasm_bindgen]
impl Estimator {
    /// An estimator from only the views its stages read: `views` holds one
    /// `Uint8Array` (or `Uint8ClampedArray`) of `height · width · channels` bytes per
    /// index of `readViews(shape, params)`, in that order (e.g. `subarray`s of one
    /// packed buffer, or of a `SharedArrayBuffer` with the whole light field: each is
    /// copied once, into wasm memory), or one `Float32Array` of as many samples per index
    /// (the rectified views of an aligned estimator's `readViews`). Gives the same bits as
    /// `new Estimator` with every view for the estimate and every part (`runPart`).
    /// `params.align` must be "off": the alignment reads views outside this set (align
    /// with `new Estimator(...).align()` first, then send its `readViews`).
    #[wasm_bindgen(js_name = fromReadViews)]
    pub fn from_read_views(
        #[wasm_bindgen(
            unchecked_param_type = "Array<Uint8Array | Uint8ClampedArray> | Array<Float32Array>"
        )]
        views: js_sys::Array,
        #[wasm_bindgen(unchecked_param_type = "Shape")] shape: JsValue,
        #[wasm_bindgen(unchecked_param_type = "EstimateParams")] params: Option<JsValue>,
    ) -> Result<Estimator, JsError> {
        let (layout, plan, stages) = params::plan(&shape, params)?;
        if plan.params().align.mode != AlignMode::Off {
            return Err(message(
                "fromReadViews holds only the views the stages read, and the alignment reads \
                 others: pass params.align \"off\" (align first with new Estimator(...).align())",
            ));
        }
        let indices = read_indices(&plan, stages);
        let given = views.length() as usize;
        if given != indices.len() {
            return Err(message(&format!(
                "views has {given} entries but the stages read {} views: pass one per index of \
                 readViews(shape, params)",
                indices.len()
            )));
        }
        // The other views stay zero. The allocator writes every byte of this buffer (on a
        // fresh worker that is most of this call's time: the page keeps its workers'
        // estimators between estimates). The first view says the sample type.
        let mut all = Samples::zeros_like(&views.get(0), layout.validate().map_err(error)?);
        let len = view_len(&layout);
        for (i, (value, &index)) in views.iter().zip(&indices).enumerate() {
            let range = index
                .checked_mul(len)
                .and_then(|start| Some(start..start.checked_add(len)?))
                .ok_or_else(|| message("the light field is too large"))?;
            all.copy_in(&value, range).map_err(|got| {
                message(&format!(
                    "views[{i}] (grid view {index}) must be a Uint8Array of {len} bytes \
                     (height · width · channels), or a Float32Array of as many samples \
                     when every view is, not {got}"
                ))
            })?;
        }
        with_light_field!(&all, layout, |lf| lf.map(|_| ())).map_err(error)?;
        Ok(Estimator::with_views(all, layout, plan, stages, true))
    }

    /// New parameters for the views this estimator holds, without copying them (the
    /// page's next estimate of the same light field): as `new Estimator(views, shape,
    /// params)` over the same views, with the inputs of `setInputs` forgotten and the
    /// alignment, if it ran, kept (the views stay rectified). An estimator from
    /// `fromReadViews`, or one whose views were rectified, takes only parameters whose
    /// stages read no other view (the others are absent or not rectified); one from
    /// `fromReadViews` also needs `align: "off"`.
    #[wasm_bindgen(js_name = setParams)]
    pub fn set_params(
        &mut self,
        #[wasm_bindgen(unchecked_param_type = "EstimateParams")] params: Option<JsValue>,
    ) -> Result<(), JsError> {
        let object = params.unwrap_or(JsValue::UNDEFINED);
        let stages = params::stages(&object)?;
        let plan = params::checked_plan(*self.layout(), params::params(&object)?)?;
        if self.partial && plan.params().align.mode != AlignMode::Off {
            return Err(message(
                "this estimator holds only the views its stages read, and the alignment \
                 reads others: pass params.align \"off\"",
            ));
        }
        // Views outside the old read set are absent (fromReadViews) or not rectified.
        if self.partial || self.warped() {
            let held = read_indices(&self.plan, self.stages());
            if let Some(missing) = read_indices(&plan, stages)
                .into_iter()
                .find(|v| !held.contains(v))
            {
                return Err(message(&format!(
                    "these parameters read view {missing}, which this estimator does not hold \
                     (or did not rectify): make a new one"
                )));
            }
        }
        self.replan(plan, stages);
        Ok(())
    }

    /// The views the stages read (`readViews(shape, params)` of this estimator's
    /// parameters with `align: "off"`), packed one after the other: a copy, after
    /// `align()` the rectified ones (a `Float32Array`). What `fromReadViews` takes, cut
    /// per view.
    #[wasm_bindgen(
        getter,
        js_name = readViews,
        unchecked_return_type = "Uint8Array | Float32Array"
    )]
    pub fn read_views_packed(&self) -> JsValue {
        let layout = *self.plan.layout();
        let indices = read_indices(&self.plan, self.stages());
        self.samples().packed_js(&indices, view_len(&layout))
    }
}
