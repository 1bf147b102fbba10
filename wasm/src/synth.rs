//! The core's synthetic light fields with exact ground truth, rendered in the page.

use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Grid, Homography};
use wasm_bindgen::prelude::*;

use crate::js::{error, message, Fields};

const SPEC_KEYS: [&str; 13] = [
    "scene",
    "rows",
    "cols",
    "width",
    "height",
    "channels",
    "disparityMin",
    "disparityMax",
    "noiseSigma",
    "photometric",
    "seed",
    "supersample",
    "misalign",
];

/// What `spec.misalign: true` applies (as `lfdepth synth --misalign`): per view a random
/// homography up to these bounds, what a loosely calibrated rig shows.
const MISALIGNMENT: Misalignment = Misalignment {
    max_rotation_deg: 0.5,
    max_translation_px: 2.0,
    max_scale: 0.01,
    max_perspective: 0.002,
};

/// The names `synthesize` accepts as `spec.scene`.
#[wasm_bindgen(js_name = sceneNames)]
pub fn scene_names() -> Vec<String> {
    SceneKind::ALL
        .iter()
        .map(|k| k.name().to_string())
        .collect()
}

fn spec(object: &JsValue) -> Result<SynthSpec, JsError> {
    let f = Fields::new(object, "spec", &SPEC_KEYS, false)?;
    let name = f
        .string("scene")?
        .ok_or_else(|| message("spec.scene is missing"))?;
    let scene = SceneKind::from_name(&name).ok_or_else(|| {
        message(&format!(
            "spec.scene `{name}` is unknown: use one of {}",
            scene_names().join(", ")
        ))
    })?;
    let grid = Grid::new(f.count("rows")?.unwrap_or(9), f.count("cols")?.unwrap_or(9));
    let mut s = SynthSpec::new(
        scene,
        grid,
        f.required_count("width")?,
        f.required_count("height")?,
    );
    if let Some(c) = f.count("channels")? {
        s.channels = c;
    }
    let float = |key: &str, into: &mut f32| -> Result<(), JsError> {
        if let Some(v) = f.number(key)? {
            *into = v as f32;
        }
        Ok(())
    };
    float("disparityMin", &mut s.disparity_min)?;
    float("disparityMax", &mut s.disparity_max)?;
    float("noiseSigma", &mut s.noise_sigma)?;
    float("photometric", &mut s.photometric)?;
    if let Some(seed) = f.count("seed")? {
        s.seed = seed as u64;
    }
    if let Some(n) = f.count("supersample")? {
        s.supersample = n;
    }
    if f.boolean("misalign")? == Some(true) {
        s.misalign = Some(MISALIGNMENT);
    }
    s.validate().map_err(error)?;
    Ok(s)
}

/// A rendered light field: packed views (row-major grid order) and the centre view's
/// exact disparity.
#[wasm_bindgen]
pub struct SyntheticLightField {
    views: Vec<u8>,
    ground_truth: Vec<f32>,
    spec: SynthSpec,
}

#[wasm_bindgen]
impl SyntheticLightField {
    /// Packed `u8` views, `rows · cols · height · width · channels`.
    #[wasm_bindgen(getter)]
    pub fn views(&self) -> js_sys::Uint8Array {
        js_sys::Uint8Array::from(&self.views[..])
    }
    /// Disparity of the centre view, `width · height`, top row first.
    #[wasm_bindgen(getter, js_name = groundTruth)]
    pub fn ground_truth(&self) -> js_sys::Float32Array {
        js_sys::Float32Array::from(&self.ground_truth[..])
    }
    /// Views along the vertical camera axis.
    #[wasm_bindgen(getter)]
    pub fn rows(&self) -> usize {
        self.spec.grid.rows
    }
    /// Views along the horizontal camera axis.
    #[wasm_bindgen(getter)]
    pub fn cols(&self) -> usize {
        self.spec.grid.cols
    }
    /// View width.
    #[wasm_bindgen(getter)]
    pub fn width(&self) -> usize {
        self.spec.width
    }
    /// View height.
    #[wasm_bindgen(getter)]
    pub fn height(&self) -> usize {
        self.spec.height
    }
    /// Samples per pixel.
    #[wasm_bindgen(getter)]
    pub fn channels(&self) -> usize {
        self.spec.channels
    }
}

/// Renders a whole synthetic light field (rectified views).
#[wasm_bindgen]
pub fn synthesize(
    #[wasm_bindgen(js_name = spec, unchecked_param_type = "SynthSpec")] spec_object: JsValue,
) -> Result<SyntheticLightField, JsError> {
    let s = spec(&spec_object)?;
    let len = s.layout().validate().map_err(error)?;
    let mut views = vec![0u8; len];
    let mut ground_truth = vec![0.0f32; s.width * s.height];
    let mut homographies = vec![Homography::default(); s.grid.len()];
    synth::render(&s, &mut views, &mut ground_truth, &mut homographies).map_err(error)?;
    Ok(SyntheticLightField {
        views,
        ground_truth,
        spec: s,
    })
}

/// Renders one view (`height · width · channels` bytes): lets workers share the work.
#[wasm_bindgen(js_name = renderView)]
pub fn render_view(
    #[wasm_bindgen(js_name = spec, unchecked_param_type = "SynthSpec")] spec_object: JsValue,
    row: usize,
    col: usize,
) -> Result<Vec<u8>, JsError> {
    let s = spec(&spec_object)?;
    let mut out = vec![0u8; s.width * s.height * s.channels];
    synth::render_view(&s, row, col, &mut out).map_err(error)?;
    Ok(out)
}

/// The centre view's exact disparity (`width · height`, top row first).
#[wasm_bindgen(js_name = renderGroundTruth)]
pub fn render_ground_truth(
    #[wasm_bindgen(js_name = spec, unchecked_param_type = "SynthSpec")] spec_object: JsValue,
) -> Result<Vec<f32>, JsError> {
    let s = spec(&spec_object)?;
    let mut gt = vec![0.0f32; s.width * s.height];
    synth::render_ground_truth(&s, &mut gt).map_err(error)?;
    Ok(gt)
}
