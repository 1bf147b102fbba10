//! How far the auto alignment's decisions are from flipping on the real arrays of
//! `../shared/data` (HCI backgammon and cotton, the Lytro capture): on each rectified
//! array, whether the probe still says "rectified" with only one of its two criteria
//! (`rectified_rms` 0: only "identity no worse than 1.25 × the model"; the identity RMS
//! is printed for the other), and on the same arrays misaligned by ever smaller synthetic
//! homographies (1 … 0.05 × the 2°, 3 px, 1 %, 0.002 of `lfdepth synth --misalign`), from
//! which size on the probe sees the misalignment. The margins in docs/stages/align.md:
//!
//! ```text
//! cargo run --release -p lfdepth-cli --example align_auto_margins
//! ```

use lfdepth::align::{self, warp_rows_with, AlignParams, Interpolation};
use lfdepth::synth::{self, Misalignment, SceneKind, SynthSpec};
use lfdepth::{Homography, LightField};
// The helpers the alignment tests use too.
#[path = "../tests/align_support/mod.rs"]
mod align_support;
use align_support::{align_views, load};

fn main() {
    for name in [
        "hci/stratified/backgammon",
        "hci/training/cotton",
        "real/lytro-2067",
    ] {
        let Some((data, layout)) = load(name) else {
            continue;
        };
        let (default, _) = align_views(&data, layout, &AlignParams::default());
        let model_only = AlignParams {
            rectified_rms: 0.0,
            ..AlignParams::default()
        };
        let (strict, _) = align_views(&data, layout, &model_only);
        eprintln!(
            "{name}: rectified: skipped {} (identity RMS {:.4} px); with the model criterion alone: skipped {}",
            default.skipped, default.identity_rms, strict.skipped
        );
        let (w, h) = (layout.width, layout.height);
        let lf = LightField::new(&data[..], layout).unwrap();
        for scale in [1.0f32, 0.5, 0.25, 0.1, 0.05] {
            let mut spec = SynthSpec::new(SceneKind::Planes, layout.grid, w, h);
            spec.seed = 5;
            spec.misalign = Some(Misalignment {
                max_rotation_deg: 2.0 * scale,
                max_translation_px: 3.0 * scale,
                max_scale: 0.01 * scale,
                max_perspective: 0.002 * scale,
            });
            let cols = layout.grid.cols;
            let inverses: Vec<Homography> = (0..layout.grid.len())
                .map(|v| {
                    synth::view_homography(&spec, v / cols, v % cols)
                        .unwrap()
                        .inverse()
                        .unwrap()
                })
                .collect();
            let misaligned: Vec<u8> = warp_all(&lf, &inverses);
            let (auto, _) = align_views(&misaligned, layout, &AlignParams::default());
            eprintln!(
                "{name}: misaligned at {scale} × (2°, 3 px, 1 %, 0.002): skipped {} (identity RMS {:.4} px, model {:.4} px, warning {:?})",
                auto.skipped, auto.identity_rms, auto.rms, auto.warning
            );
        }
    }
}

/// Every view of `lf` warped by `hs` (the pipeline's default interpolation).
fn warp_all(lf: &LightField<'_, u8>, hs: &[Homography]) -> Vec<u8> {
    let l = lf.layout();
    let view = l.width * l.height * l.channels;
    let mut out = vec![0u8; l.validate().unwrap()];
    let how = Interpolation::default();
    for (v, chunk) in out.chunks_exact_mut(view).enumerate() {
        warp_rows_with(lf, hs, v, 0..l.height, how, chunk).unwrap();
        align::finish_view(l, hs, v, how, chunk).unwrap();
    }
    out
}
