//! The half-resolution EPI ([`crate::epi::EpiParams::half_resolution`]) through the
//! schedule on an exactly rendered scene: its upsampled map against the ground truth, and
//! Q16.16 against `f32`.

extern crate std;
use std::vec;
use std::vec::Vec;

use core::ops::ControlFlow;

use crate::epi::test_scenes::{strips, Scene};
use crate::epi::{DisparityRange, EpiParams};
use crate::lightfield::{Grid, LightField};
use crate::pipeline::{self, Stages};
use crate::plan::{Params, Plan};
use crate::scalar::{Scalar, Q16};

/// Two fronto-parallel strips at 1.4 and 0.9 px (the middle third is background) over a
/// background at −0.6 px: 9×9 views of 96×64.
fn scene() -> Scene {
    strips(Grid::new(9, 9), 96, 64, 3, -0.6, &[1.4, -0.6, 0.9])
}

fn params(half: bool) -> Params {
    Params {
        epi: EpiParams {
            half_resolution: half,
            range: DisparityRange::Fixed {
                min: -2.0,
                max: 2.0,
            },
            ..EpiParams::default()
        },
        sweep: crate::planesweep::PlaneSweepParams::off(),
        ..Params::default()
    }
}

/// The EPI stage (upsampled when `half`) computing in `T`.
fn epi<T: Scalar>(scene: &Scene, half: bool) -> Vec<f32> {
    let plan = Plan::new(scene.layout, params(half)).unwrap();
    let lf = LightField::new(&scene.data[..], scene.layout).unwrap();
    let mut d = vec![0.0f32; plan.pixels()];
    let mut c = vec![0.0f32; plan.pixels()];
    let mut scratch = vec![T::ZERO; pipeline::stage_scratch_len(&plan, Stages::Epi)];
    let mut maps = vec![0.0f32; pipeline::stage_map_scratch_len(&plan, Stages::Epi)];
    pipeline::run(
        &plan,
        &lf,
        Stages::Epi,
        pipeline::RunOutput {
            disparity: &mut d,
            confidence: &mut c,
            history: &mut [],
        },
        pipeline::RunScratch {
            kernel: &mut scratch,
            maps: &mut maps,
        },
        &mut |_| ControlFlow::Continue(()),
    )
    .unwrap();
    d
}

/// Share of the pixels at least 6 px inside the frame and from a depth step (in the
/// ground truth) whose disparity is within `tol` of `truth`.
fn share_within(d: &[f32], truth: &[f32], width: usize, tol: f32) -> f32 {
    let height = truth.len() / width;
    let (mut inside, mut good) = (0usize, 0usize);
    for y in 6..height - 6 {
        for x in 6..width - 6 {
            let t = truth[y * width + x];
            let flat = (x - 6..=x + 6).all(|u| truth[y * width + u] == t);
            if !flat {
                continue;
            }
            inside += 1;
            good += usize::from((d[y * width + x] - t).abs() <= tol);
        }
    }
    good as f32 / inside as f32
}

#[test]
fn the_half_resolution_epi_finds_each_plane() {
    let scene = scene();
    let width = scene.layout.width;
    let half = epi::<f32>(&scene, true);
    let full = epi::<f32>(&scene, false);
    let (h, f) = (
        share_within(&half, &scene.gt, width, 0.07),
        share_within(&full, &scene.gt, width, 0.07),
    );
    std::println!("within 0.07 px away from steps: half {h:.4}, full {f:.4}");
    assert!(h >= 0.97, "half resolution: {h}");
    // A step lands within a pixel of its place: most pixels next to one are right too.
    let all = half
        .iter()
        .zip(&scene.gt)
        .filter(|(d, t)| (**d - **t).abs() <= 0.1)
        .count() as f32
        / half.len() as f32;
    assert!(all >= 0.85, "every pixel: {all}");
}

#[test]
fn q16_half_resolution_stays_within_two_hundredths_of_f32() {
    let scene = scene();
    let a = epi::<f32>(&scene, true);
    let b = epi::<Q16>(&scene, true);
    let close = a
        .iter()
        .zip(&b)
        .filter(|(x, y)| (**x - **y).abs() <= 0.02)
        .count() as f32
        / a.len() as f32;
    assert!(close >= 0.99, "Q16.16 within 0.02 px of f32 on {close}");
}
