//! # lfdepth
//!
//! Dense depth (disparity) from a light field — a grid of views from a camera array or
//! a plenoptic camera — after Javidnia & Corcoran, "Total Variation-Based Dense Depth
//! from Multi-Camera Array": initial disparity from the structure tensor on
//! epipolar-plane images, refined by weighted total variation solved in the dual with
//! the parallel proximal algorithm.
//!
//! The crate is `no_std` and never allocates: every stage writes into caller-owned
//! outputs and takes caller-owned scratch sized by its `scratch_len(&Plan)`. Kernels are
//! generic over [`Scalar`] (`f32` or the Q16.16 fixed-point [`Q16`]).
#![cfg_attr(not(test), no_std)]
#![forbid(unsafe_code)]

// Only for the float intrinsics (`float`); everything else is `core`.
#[cfg(all(feature = "std", not(test)))]
extern crate std;

pub mod align;
pub mod epi;
pub mod error;
pub mod float;
pub mod geofill;
pub mod geometry;
#[cfg(test)]
mod layer_tests;
pub mod lightfield;
pub mod median;
/// Evaluation against ground truth (feature `scenes`: for tools and the page, not
/// firmware).
#[cfg(any(test, feature = "scenes"))]
pub mod metrics;
pub mod options;
pub mod pipeline;
pub mod plan;
pub mod planesweep;
pub mod progress;
pub mod refine;
pub mod scalar;
pub mod schedule;
pub mod setup;
pub mod stream;
/// Synthetic light fields with exact ground truth (feature `scenes`: for tests, the demo
/// and the page, not firmware).
#[cfg(any(test, feature = "scenes"))]
pub mod synth;
pub mod tv;

pub use error::{Error, Result};
pub use geometry::Homography;
pub use lightfield::{Epi, Grid, Layout, LightField, Sample, View};
pub use plan::{Params, Plan, Preset};
pub use scalar::{Scalar, Q16};
