//! Thin wasm-bindgen layer over the `lfdepth` core: no algorithm code lives here, only
//! marshalling between JS values and the core's borrowed slices, and `Error` → JS `Error`.
//!
//! * [`Estimator`] owns a copy of the views and a validated plan; it runs the whole
//!   pipeline ([`Estimator::estimate`], with progress and cancel) or, on a worker, one
//!   part of a step of the core's schedule ([`Estimator::run_part`]), while the page's
//!   thread holds the [`Run`] that lists the steps and places their parts.
//! * [`read_views`] and `Estimator.fromReadViews`: an estimator holding only the views
//!   its stages read (what the page sends each worker).
//! * [`synthesize`], [`render_view`], [`render_ground_truth`]: the core's synthetic scenes.
//! * [`evaluate`]: the HCI benchmark metrics.
//!
//! Parameter objects and stage names follow the core: a key the core does not know is
//! an error, so a page written for a newer core fails loudly instead of silently.

mod estimator;
mod js;
mod metrics;
mod params;
mod run;
mod synth;
mod views;

pub use estimator::{stage_names, EstimateResult, Estimator, StageTiming};
pub use metrics::{evaluate, Scores};
pub use run::Run;
pub use synth::{render_ground_truth, render_view, scene_names, synthesize, SyntheticLightField};
pub use views::read_views;

use wasm_bindgen::prelude::*;

/// The version of the package (the workspace version).
#[wasm_bindgen]
pub fn version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}

#[wasm_bindgen(typescript_custom_section)]
const TS_TYPES: &str = r#"
/** Grid and size of a light field: `rows` × `cols` views of `width` × `height` pixels. */
export interface Shape {
  rows: number;
  cols: number;
  width: number;
  height: number;
  /** Samples per pixel: 1 (gray), 3 (RGB) or 4 (RGBA, alpha ignored). */
  channels: number;
}

/** Estimation parameters; every key is optional and defaults to the core's default. */
export interface EstimateParams {
  /** Named settings the other keys then override: "default" (the most accurate) or
   * "fast" (about 1.3× less CPU, still more accurate than SPO on the HCI scenes). */
  preset?: "default" | "fast";
  /** Disparity range in px between adjacent views: "auto" (estimated) or [min, max]. */
  range?: "auto" | [number, number];
  /** Gaussian pre-smoothing along the EPI line (px), 0…4. */
  innerSigma?: number;
  /** Gaussian smoothing of the structure tensor, 0…5. */
  outerSigma?: number;
  /** Shear the EPIs over the range (false: the paper's single unsheared EPI). */
  shear?: boolean;
  /** Distance between shear hypotheses (px), 0.1…2. */
  shearStep?: number;
  /** Largest residual slope a hypothesis accepts, in shear steps, 0.5…2. */
  window?: number;
  /** Interpolate between adjacent shears (zero crossing of the residual slope). */
  interpolate?: boolean;
  /** How horizontal and vertical estimates are combined. */
  fusion?: "coherence" | "weighted";
  /** Colour handling: one tensor over R, G, B, or their mean first. */
  color?: "tensor" | "gray";
  /** How far `estimate` goes: "full" (EPI → refine → TV, the default) or "epi" alone. */
  stage?: "epi" | "full";
  /** Photometric refinement of the EPI disparity over many views (default true). */
  refine?: boolean;
  /** Edge-snapping weighted median guided by the centre view, between refine and TV (default true). */
  median?: boolean;
  /** Geodesic refill of the band around depth steps inside uniform colour, after refine and before the median (default false): a foreground fattened into a flat background returns to its colour edge. */
  geofill?: boolean;
  /** Weight λ of the total variation against the data term (larger: smoother), 0…1000. */
  lambda?: number;
  /** Most TV (PPXA) iterations per tile, 1…100000. */
  iterations?: number;
  /** Image rows per refine band, 1…4096 (default 128): a part of the refinement step. */
  refineBandRows?: number;
  /** Run the median between refine and TV (true, the default) or after TV (false). */
  medianBeforeTv?: boolean;
  /** Side of a TV tile in pixels, 8…4096 (default 256): a part of each TV step. */
  tvTile?: number;
  /** Align the views by per-view homographies first: "off", "on", or "auto" (the
   * default: only when the array is found not to be rectified). */
  align?: "off" | "on" | "auto";
  /** The views were warped (rectified by an alignment elsewhere, e.g. another
   * estimator's `readViews` after `align()`): the refinement compares them with its
   * sampling slack, as an estimator that aligned them itself does (default false). */
  resampled?: boolean;
}

/** A progress report; return `false` from the callback to cancel. */
export interface Progress {
  stage: string;
  done: number;
  total: number;
}

/** A synthetic scene; all keys but `scene`, `width` and `height` are optional. */
export interface SynthSpec {
  /** One of `sceneNames()`. */
  scene: string;
  rows?: number;
  cols?: number;
  width: number;
  height: number;
  /** 1 (gray) or 3 (RGB, default). */
  channels?: number;
  /** Disparity range of the scene, within -4…4 (default -1.5…1.5). */
  disparityMin?: number;
  disparityMax?: number;
  /** Gaussian noise, 8-bit levels. */
  noiseSigma?: number;
  /** Largest relative per-view brightness/contrast change. */
  photometric?: number;
  seed?: number;
  supersample?: number;
  /** Misalign the views by small random homographies (as `lfdepth synth --misalign`). */
  misalign?: boolean;
}

/** Which pixels `evaluate` scores. */
export interface EvalOptions {
  /** Pixels closer than this to an edge are ignored (default 15, as the HCI benchmark). */
  border?: number;
  /** Nonzero = evaluate; `width * height` bytes. */
  mask?: Uint8Array;
}
"#;
