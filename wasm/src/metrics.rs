//! The HCI benchmark metrics of the core.

use lfdepth::metrics::{self, EvalOptions};
use wasm_bindgen::prelude::*;

use crate::js::{error, message, Fields};

/// HCI scores of one estimate (percentages, MSE × 100, Q25 × 100).
#[wasm_bindgen]
#[derive(Clone, Copy, Debug)]
pub struct Scores {
    /// % of evaluated pixels with |error| > 0.07.
    #[wasm_bindgen(readonly, js_name = badpix007)]
    pub badpix_007: f64,
    /// % with |error| > 0.03.
    #[wasm_bindgen(readonly, js_name = badpix003)]
    pub badpix_003: f64,
    /// % with |error| > 0.01.
    #[wasm_bindgen(readonly, js_name = badpix001)]
    pub badpix_001: f64,
    /// 100 × mean squared error.
    #[wasm_bindgen(readonly)]
    pub mse100: f64,
    /// 25th percentile of 100 × |error|.
    #[wasm_bindgen(readonly)]
    pub q25: f64,
    /// % of evaluated pixels that are NaN or infinite.
    #[wasm_bindgen(readonly, js_name = invalidPct)]
    pub invalid_pct: f64,
}

/// Scores `estimate` against `groundTruth` (both `width · height`, row-major, top row
/// first), ignoring `options.border` pixels (default 15) at each edge.
#[wasm_bindgen]
pub fn evaluate(
    estimate: &[f32],
    #[wasm_bindgen(js_name = groundTruth)] ground_truth: &[f32],
    width: usize,
    height: usize,
    #[wasm_bindgen(unchecked_param_type = "EvalOptions")] options: Option<JsValue>,
) -> Result<Scores, JsError> {
    let options = options.unwrap_or(JsValue::UNDEFINED);
    let f = Fields::new(&options, "options", &["border", "mask"], true)?;
    let border = f.count("border")?.unwrap_or(metrics::BORDER);
    let mask_value = f.get("mask");
    let mask = if mask_value.is_undefined() || mask_value.is_null() {
        None
    } else {
        Some(
            mask_value
                .dyn_ref::<js_sys::Uint8Array>()
                .ok_or_else(|| message("options.mask must be a Uint8Array"))?
                .to_vec(),
        )
    };
    // Sized by the estimate actually passed: a wrong width/height is reported by the core
    // (wrong map size) instead of allocating for it.
    let mut scratch = vec![0.0f32; metrics::scratch_len(width, height).min(estimate.len())];
    let s = metrics::evaluate(
        estimate,
        ground_truth,
        width,
        height,
        &EvalOptions {
            border,
            mask: mask.as_deref(),
        },
        &mut scratch,
    )
    .map_err(error)?;
    Ok(Scores {
        badpix_007: s.badpix_007,
        badpix_003: s.badpix_003,
        badpix_001: s.badpix_001,
        mse100: s.mse100,
        q25: s.q25,
        invalid_pct: s.invalid_pct,
    })
}
