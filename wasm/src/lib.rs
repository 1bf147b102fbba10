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
//! * With the feature `png` (the npm package; the page decodes images in the browser):
//!   `decodePng` and `disparityPng`, views from PNG files and the colour-mapped picture of
//!   a map, through the `png` crate as the `lfdepth` tool reads and writes them.
//!
//! Parameter objects and stage names follow the core: the keys of `EstimateParams` are
//! the core's tunables (`lfdepth::options`), a key the core does not know is an error,
//! so a page written for a newer core fails loudly instead of silently.

mod estimator;
mod js;
mod metrics;
mod params;
#[cfg(feature = "png")]
mod png;
mod run;
mod samples;
mod synth;
mod views;

pub use estimator::{stage_names, EstimateResult, Estimator, StageTiming};
pub use metrics::{evaluate, Scores};
pub use params::estimate_params_typescript;
#[cfg(feature = "png")]
pub use png::{decode_png, disparity_png, PngImage};
pub use run::Run;
pub use synth::{render_ground_truth, render_view, scene_names, synthesize, SyntheticLightField};
pub use views::read_views;

use wasm_bindgen::prelude::*;

/// The version of the package (the workspace version).
#[wasm_bindgen]
pub fn version() -> String {
    env!("CARGO_PKG_VERSION").to_string()
}

/// `EstimateParams`, generated from the core's tunable table
/// ([`estimate_params_typescript`]; `cargo xtask types` rewrites the file).
#[wasm_bindgen(typescript_custom_section)]
const ESTIMATE_PARAMS: &str = include_str!("estimate_params.d.ts");

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
