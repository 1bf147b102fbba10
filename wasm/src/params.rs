//! JS parameter objects → core `Params` and `Layout`. The keys of an `EstimateParams`
//! object are the core's tunables (`lfdepth::options::TUNABLES`) plus the few this layer
//! reads itself ([`LAYER_KEYS`]); [`estimate_params_typescript`] writes their TypeScript
//! type from the same table.

use lfdepth::epi::DisparityRange;
use lfdepth::options::{self, Flag, Front, Kind, Value, TUNABLES};
use lfdepth::pipeline::Stages;
use lfdepth::{Grid, Layout, Params, Plan, Preset};
use wasm_bindgen::prelude::*;

use crate::js::{error, message, Fields};

const SHAPE_KEYS: [&str; 5] = ["rows", "cols", "width", "height", "channels"];

/// The keys of `EstimateParams` that are not core tunables: (key, TypeScript type, doc).
const LAYER_KEYS: [(&str, &str, &str); 3] = [
    (
        "preset",
        "",
        "Named settings the other keys then override (as the CLI's `--preset`)",
    ),
    (
        "stage",
        "\"epi\" | \"full\"",
        "How far `estimate` goes: \"full\" (every stage, the default) or \"epi\" (the initial disparity alone: the plane sweep, or the EPI stage with `initial: \"epi\"`)",
    ),
    (
        "resampled",
        "boolean",
        "The views were warped (rectified by an alignment elsewhere, e.g. another estimator's `readViews` after `align()`): the refinement compares them with its sampling slack, as an estimator that aligned them itself does (default false)",
    ),
];

/// Every key an `EstimateParams` object may have.
fn param_keys() -> Vec<&'static str> {
    LAYER_KEYS
        .iter()
        .map(|k| k.0)
        .chain(TUNABLES.iter().filter_map(|t| t.key))
        .collect()
}

/// `"a", "b" or "c"`: the names a choice accepts, as the error messages list them.
fn quoted_choices(names: &[&str]) -> String {
    let quoted: Vec<String> = names.iter().map(|n| format!("\"{n}\"")).collect();
    match quoted.split_last() {
        Some((last, rest)) if !rest.is_empty() => format!("{} or {last}", rest.join(", ")),
        _ => quoted.join(""),
    }
}

/// The value of `key` in `f` as a tunable of `kind` takes it, `None` when absent.
fn value(f: &Fields<'_>, key: &str, kind: Kind) -> Result<Option<Value>, JsError> {
    Ok(match kind {
        // NaN (what an empty number field of a form reads as) goes to the stage's check,
        // which refuses it with the tunable's range; other numbers must be finite here.
        Kind::Float { .. } => match f.get(key).as_f64() {
            Some(v) if v.is_nan() => Some(Value::Float(f32::NAN)),
            _ => f.number(key)?.map(|v| Value::Float(v as f32)),
        },
        Kind::Int { .. } => f.count(key)?.map(Value::Int),
        Kind::Bool => f.boolean(key)?.map(Value::Bool),
        Kind::Choice(names) => match f.string(key)? {
            None => None,
            Some(v) => {
                let name = names.iter().find(|n| **n == v).ok_or_else(|| {
                    message(&format!(
                        "params.{key} `{v}` is unknown: use {}",
                        quoted_choices(names)
                    ))
                })?;
                Some(Value::Choice(name))
            }
        },
        Kind::Range => {
            let range = f.get(key);
            if range.is_undefined() {
                return Ok(None);
            }
            if range.as_string().as_deref() == Some("auto") {
                return Ok(Some(Value::Range(DisparityRange::Auto)));
            }
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
                Some(&[min, max]) => Some(Value::Range(DisparityRange::Fixed { min, max })),
                _ => {
                    return Err(message(&format!(
                        "params.{key} must be \"auto\" or [min, max] in px between adjacent views"
                    )))
                }
            }
        }
    })
}

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

/// Core parameters from an `EstimateParams` object (`undefined` = defaults): the preset,
/// then every tunable key over it in the table's order. Ranges are checked later by
/// [`checked_plan`], whose messages name the keys.
pub fn params(object: &JsValue) -> Result<Params, JsError> {
    let keys = param_keys();
    let f = Fields::new(object, "params", &keys, true)?;
    let preset = match f.string("preset")? {
        None => Preset::Default,
        Some(name) => Preset::from_name(&name).ok_or_else(|| {
            let names: Vec<&str> = Preset::ALL.iter().map(|p| p.name()).collect();
            message(&format!(
                "params.preset `{name}` is unknown: use one of \"{}\"",
                names.join("\", \"")
            ))
        })?,
    };
    // As the CLI: alignment on auto, the preset, then each key.
    let mut params = options::base(preset);
    for t in TUNABLES {
        let Some(key) = t.key else { continue };
        if let Some(v) = value(&f, key, t.kind)? {
            t.apply(&mut params, v)
                .map_err(|e| error(options::rename(e, Front::Js)))?;
        }
    }
    // Views an aligner warped (the page's workers load its `readViews`): the refinement
    // as `pipeline::run_aligned` runs it on them.
    if f.boolean("resampled")? == Some(true) {
        params.refine = params.refine.for_resampled_views();
    }
    Ok(params)
}

/// The plan of `params` for `layout`; a parameter out of range is named by its key.
pub fn checked_plan(layout: Layout, params: Params) -> Result<Plan, JsError> {
    Plan::new(layout, params).map_err(|e| error(options::rename(e, Front::Js)))
}

/// How far `Estimator.estimate` goes: `params.stage`, "full" (the start → refine → refill
/// → median → TV) when absent.
pub fn stages(object: &JsValue) -> Result<Stages, JsError> {
    let keys = param_keys();
    let f = Fields::new(object, "params", &keys, true)?;
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
    let plan = checked_plan(layout, self::params(&object)?)?;
    Ok((layout, plan, stages))
}

/// `/** doc */` over `lines`, wrapped at 90 columns, indented by two spaces.
fn doc_comment(doc: &str) -> String {
    let mut lines: Vec<String> = Vec::new();
    let mut line = String::from("  /**");
    for word in doc.split_whitespace() {
        if line.len() + 1 + word.len() > 90 && line.len() > 5 {
            lines.push(line);
            line = String::from("   *");
        }
        line.push(' ');
        line.push_str(word);
    }
    line.push_str(" */");
    lines.push(line);
    lines.join("\n") + "\n"
}

/// The TypeScript type of a tunable's values.
fn typescript_type(kind: Kind) -> String {
    match kind {
        Kind::Float { .. } | Kind::Int { .. } => "number".into(),
        Kind::Bool => "boolean".into(),
        Kind::Choice(names) => names
            .iter()
            .map(|n| format!("\"{n}\""))
            .collect::<Vec<_>>()
            .join(" | "),
        Kind::Range => "\"auto\" | [number, number]".into(),
    }
}

/// The TypeScript declaration of `EstimateParams`, generated from the core's tunables
/// and [`LAYER_KEYS`]: what `src/estimate_params.d.ts` holds (`cargo xtask types` writes
/// it; a test checks that it is current).
pub fn estimate_params_typescript() -> String {
    let mut out = String::from(
        "// Generated from lfdepth::options::TUNABLES by `cargo xtask types`: do not edit.\n\n\
         /** Estimation parameters; every key is optional and defaults to the core's default. */\n\
         export interface EstimateParams {\n",
    );
    let presets: Vec<String> = Preset::ALL
        .iter()
        .map(|p| format!("\"{}\"", p.name()))
        .collect();
    let preset_docs: Vec<String> = Preset::ALL
        .iter()
        .map(|&p| format!("\"{}\" ({})", p.name(), options::preset_doc(p)))
        .collect();
    for (key, ty, doc) in LAYER_KEYS {
        let (ty, doc) = if key == "preset" {
            (
                presets.join(" | "),
                format!("{doc}: {}.", preset_docs.join(", or ")),
            )
        } else {
            (ty.to_string(), format!("{doc}."))
        };
        out += &doc_comment(&doc);
        out += &format!("  {key}?: {ty};\n");
    }
    for t in TUNABLES {
        let Some(key) = t.key else { continue };
        let default = t.default_value();
        let range = match t.kind {
            Kind::Float { .. } | Kind::Int { .. } => format!("{}; ", t.kind),
            _ => String::new(),
        };
        let default = match default {
            Value::Choice(name) => format!("\"{name}\""),
            Value::Range(DisparityRange::Auto) => "\"auto\"".into(),
            other => other.to_string(),
        };
        let flag = match t.flag {
            None => String::new(),
            Some(Flag::Value(name)) => format!(" CLI: `{name}`."),
            Some(Flag::Switch { name, sets, .. }) => format!(" CLI: `{name}` sets {sets}."),
        };
        out += &doc_comment(&format!("{} ({range}default {default}).{flag}", t.doc));
        out += &format!("  {key}?: {};\n", typescript_type(t.kind));
    }
    out += "}\n";
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed declaration is the generated one.
    #[test]
    fn committed_typescript_is_generated() {
        let committed = include_str!("estimate_params.d.ts");
        let generated = estimate_params_typescript();
        assert!(
            committed == generated,
            "wasm/src/estimate_params.d.ts is not what the tunable table gives: run `cargo xtask types`\n--- generated:\n{generated}"
        );
    }

    /// Every tunable with a key, and every key this layer reads, is typed; no key twice.
    #[test]
    fn every_key_is_typed_once() {
        let ts = estimate_params_typescript();
        let keys = param_keys();
        for key in &keys {
            assert_eq!(ts.matches(&format!("\n  {key}?: ")).count(), 1, "{key}");
        }
        let mut sorted = keys.clone();
        sorted.sort_unstable();
        sorted.dedup();
        assert_eq!(sorted.len(), keys.len());
        // Existing keys keep their names.
        for key in [
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
        ] {
            assert!(keys.contains(&key), "{key}");
        }
    }

    #[test]
    fn choices_are_listed_as_the_messages_say() {
        assert_eq!(
            quoted_choices(&["off", "on", "auto"]),
            "\"off\", \"on\" or \"auto\""
        );
        assert_eq!(quoted_choices(&["a", "b"]), "\"a\" or \"b\"");
        assert_eq!(quoted_choices(&["a"]), "\"a\"");
    }
}
