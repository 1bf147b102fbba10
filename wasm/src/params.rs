//! JS parameter objects → core `Params` and `Layout`.

use lfdepth::align::AlignMode;
use lfdepth::epi::{ColorMode, DisparityRange, Fusion};
use lfdepth::pipeline::Stages;
use lfdepth::{Grid, Layout, Params, Plan, Preset};
use wasm_bindgen::prelude::*;

use crate::js::{error, message, Fields};

const SHAPE_KEYS: [&str; 5] = ["rows", "cols", "width", "height", "channels"];
const PARAM_KEYS: [&str; 21] = [
    "preset",
    "range",
    "innerSigma",
    "outerSigma",
    "shear",
    "shearStep",
    "window",
    "interpolate",
    "fusion",
    "color",
    "stage",
    "refine",
    "median",
    "geofill",
    "lambda",
    "iterations",
    "align",
    "refineBandRows",
    "medianBeforeTv",
    "tvTile",
    "resampled",
];

/// The packed layout of views described by a `Shape` object.
pub fn layout(shape: &JsValue) -> Result<Layout, JsError> {
    let f = Fields::new(shape, "shape", &SHAPE_KEYS, false)?;
    let grid = Grid::new(f.required_count("rows")?, f.required_count("cols")?);
    Ok(Layout::packed(
        grid,
        f.required_count("width")?,
        f.required_count("height")?,
        f.required_count("channels")?,
    ))
}

/// Core parameters from an `EstimateParams` object (`undefined` = defaults). Ranges are
/// checked later by `Plan::new`, so the messages are the core's.
pub fn params(object: &JsValue) -> Result<Params, JsError> {
    let f = Fields::new(object, "params", &PARAM_KEYS, true)?;
    // The named preset first; every other key then overrides it, as on the CLI.
    let mut params = match f.string("preset")? {
        None => Params::default(),
        Some(name) => Params::preset(Preset::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
            message(&format!(
                "params.preset `{name}` is unknown: use one of \"{}\"",
                names.join("\", \"")
            ))
        })?),
    };
    // As the CLI: align only when the array is found not to be rectified.
    params.align.mode = AlignMode::Auto;
    if let Some(v) = f.string("align")? {
        params.align.mode = match v.as_str() {
            "off" => AlignMode::Off,
            "on" => AlignMode::On,
            "auto" => AlignMode::Auto,
            _ => {
                return Err(message(&format!(
                    "params.align `{v}` is unknown: use \"off\", \"on\" or \"auto\""
                )))
            }
        };
    }
    let epi = &mut params.epi;
    let range = f.get("range");
    if !range.is_undefined() && range.as_string().as_deref() != Some("auto") {
        let pair: Option<Vec<f32>> = range
            .dyn_ref::<js_sys::Array>()
            .filter(|a| a.length() == 2)
            .map(|a| {
                a.iter()
                    .filter_map(|v| v.as_f64())
                    .map(|v| v as f32)
                    .collect()
            })
            .filter(|v: &Vec<f32>| v.len() == 2);
        match pair.as_deref() {
            Some(&[min, max]) => epi.range = DisparityRange::Fixed { min, max },
            _ => {
                return Err(message(
                    "params.range must be \"auto\" or [min, max] in px between adjacent views",
                ))
            }
        }
    }
    let float = |key: &str, into: &mut f32| -> Result<(), JsError> {
        if let Some(v) = f.number(key)? {
            *into = v as f32;
        }
        Ok(())
    };
    float("innerSigma", &mut epi.inner_sigma)?;
    float("outerSigma", &mut epi.outer_sigma)?;
    float("shearStep", &mut epi.shear_step)?;
    float("window", &mut epi.window)?;
    if let Some(v) = f.boolean("shear")? {
        epi.shear = v;
    }
    if let Some(v) = f.boolean("interpolate")? {
        epi.interpolate = v;
    }
    if let Some(v) = f.string("fusion")? {
        epi.fusion = match v.as_str() {
            "coherence" => Fusion::Coherence,
            "weighted" => Fusion::Weighted,
            _ => {
                return Err(message(&format!(
                    "params.fusion `{v}` is unknown: use \"coherence\" or \"weighted\""
                )))
            }
        };
    }
    if let Some(v) = f.string("color")? {
        epi.color = match v.as_str() {
            "tensor" => ColorMode::Tensor,
            "gray" => ColorMode::Gray,
            _ => {
                return Err(message(&format!(
                    "params.color `{v}` is unknown: use \"tensor\" or \"gray\""
                )))
            }
        };
    }
    if let Some(v) = f.boolean("refine")? {
        params.refine.enabled = v;
    }
    if let Some(v) = f.boolean("median")? {
        params.median.enabled = v;
    }
    if let Some(v) = f.boolean("geofill")? {
        params.geofill.enabled = v;
    }
    float("lambda", &mut params.tv.lambda)?;
    if let Some(v) = f.count("iterations")? {
        params.tv.max_iterations = v;
    }
    // How the later stages are cut into parts (the Web Workers' unit of work).
    if let Some(v) = f.count("refineBandRows")? {
        params.refine.band_rows = v;
    }
    if let Some(v) = f.boolean("medianBeforeTv")? {
        params.median.before_tv = v;
    }
    if let Some(v) = f.count("tvTile")? {
        params.tv.tile = v;
    }
    // Views an aligner warped (the page's workers load its `readViews`): the refinement
    // as `pipeline::run_aligned` runs it on them.
    if f.boolean("resampled")? == Some(true) {
        params.refine = params.refine.for_resampled_views();
    }
    Ok(params)
}

/// How far `Estimator.estimate` goes: `params.stage`, "full" (EPI → refine → TV) when
/// absent.
pub fn stages(object: &JsValue) -> Result<Stages, JsError> {
    let f = Fields::new(object, "params", &PARAM_KEYS, true)?;
    match f.string("stage")?.as_deref() {
        None | Some("full") => Ok(Stages::Full),
        Some("epi") => Ok(Stages::Epi),
        Some(v) => Err(message(&format!(
            "params.stage `{v}` is unknown: use \"full\" or \"epi\""
        ))),
    }
}

/// The layout of `shape`, the plan of `params` (absent: the defaults) for it, and how far
/// the estimate goes: what every constructor of an `Estimator` checks first.
pub fn plan(shape: &JsValue, params: Option<JsValue>) -> Result<(Layout, Plan, Stages), JsError> {
    let layout = layout(shape)?;
    let object = params.unwrap_or(JsValue::UNDEFINED);
    let stages = stages(&object)?;
    let plan = Plan::new(layout, self::params(&object)?).map_err(error)?;
    Ok((layout, plan, stages))
}
