//! The alignment on random views, through its public entry points: `align::estimate`,
//! `align::estimate_present` (some views absent, the views run in reverse order),
//! the warp (`warp_rows_with`, `finish_view`, `warp_band`) with estimated or arbitrary
//! homographies, and the prelude `pipeline::run_aligned` (alignment, warp, EPI).
//!
//! Each execution is kept cheap so that a campaign of 10⁵ runs fits in minutes: small
//! grids (3×3…5×5, rails of 3…9, sometimes a grid the layout refuses), views of
//! 14…52 px (views under 16 px are refused; corners need sides of more than twice
//! the tracker's 12 px margin, which about half of the views have), at most 67
//! corners and 8 alternation rounds (drawn with every other alignment parameter,
//! sometimes out of range). The views show two
//! textured planes at their own disparities (an occluding foreground), each view
//! moved by its own random rotation, scale, shift and perspective (or none: a
//! rectified array); or a degenerate picture: flat, stripes (corners in one direction
//! only), two levels, extreme float samples (NaN-free). What must hold: nothing panics;
//! an `Ok` estimate has finite homographies, identities when skipped and for every
//! absent view; what an absent view holds never changes the result; the views run in
//! any order give the same result bit for bit; a warp of 8-bit views by finite
//! homographies gives finite samples, within [0, 1] when bilinear.
#![no_main]

mod common;

use core::ops::ControlFlow;

use common::Setting;
use lfdepth::align::testscene::bilinear_noise;
use lfdepth::align::{
    self, AlignMode, AlignModel, AlignParams, AlignReport, AlignedViews, Interpolation, Reference,
    ViewMap, ViewTask,
};
use lfdepth::pipeline::{self, AlignBuffers, Stages};
use lfdepth::{Grid, Homography, Layout, LightField, Plan, Sample};
use libfuzzer_sys::arbitrary::{self, Arbitrary};
use libfuzzer_sys::fuzz_target;

/// Scratch beyond this many elements is not allocated (the caps below keep far under).
const MAX_SCRATCH: usize = 1 << 24;

/// The light field's shape and picture.
#[derive(Arbitrary, Debug, Clone, Copy)]
struct Scene {
    /// 0…8: 3×3, 3×5, 5×3, 5×5, 4×4, 1×N, N×1 (N from `rail`), 2×2, 1×1.
    grid: u8,
    rail: u8,
    width: u8,
    height: u8,
    /// 1…4 channels (2 is refused by the layout).
    channels: u8,
    picture: Picture,
    /// Background and foreground disparity between adjacent views, in eighths of a
    /// pixel (±3 px).
    background: i8,
    foreground: i8,
    seed: u32,
    /// Misalignment: 0 none, else its amplitude in 64ths of the largest (below).
    misalign: u8,
    /// Noise amplitude in 8-bit levels.
    noise: u8,
}

/// What the views show.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Picture {
    /// Value noise of this cell size (1…8 px): a trackable texture.
    Texture(u8),
    /// One level everywhere.
    Flat(u8),
    /// Vertical or horizontal stripes: no corner in one direction.
    Stripes(bool, u8),
    /// The texture thresholded to two levels.
    TwoLevels(u8, u8),
}

/// How samples are stored.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Samples {
    Eight,
    /// `f32` samples: the unit intensity times the scale, plus the offset (NaN-free).
    Float(FloatScale),
}

#[derive(Arbitrary, Debug, Clone, Copy)]
enum FloatScale {
    Unit,
    /// 8-bit levels as floats (0…255): far outside the nominal range.
    Levels,
    Huge,
    Tiny,
    Negative,
    Any(f32, f32),
}

impl FloatScale {
    fn map(self, unit: f32) -> f32 {
        let v = match self {
            FloatScale::Unit => unit,
            FloatScale::Levels => unit * 255.0,
            FloatScale::Huge => unit * 3.0e38,
            FloatScale::Tiny => unit * 1.0e-38,
            FloatScale::Negative => -unit,
            FloatScale::Any(s, o) => unit * s + o,
        };
        if v.is_nan() {
            0.0
        } else {
            v
        }
    }
}

/// A value of a float parameter: mostly in its range, sometimes any.
#[derive(Arbitrary, Debug, Clone, Copy)]
enum Pick {
    /// `n / 255` of the way from the parameter's least to its largest usual value.
    Usual(u8),
    Any(f32),
}

impl Pick {
    fn value(self, least: f32, most: f32) -> f32 {
        match self {
            Pick::Usual(n) => least + (most - least) * f32::from(n) / 255.0,
            Pick::Any(x) => x,
        }
    }
}

/// The alignment parameters, each drawn.
#[derive(Arbitrary, Debug, Clone, Copy)]
struct Draw {
    mode: u8,
    plane_patches: bool,
    centre_reference: bool,
    views: u8,
    interpolation: u8,
    /// Corners: 4…67 (under 8 is refused).
    features: u8,
    min_inliers: u8,
    /// Alternation rounds: 0…8 (0 is refused).
    max_iterations: u8,
    target_rms: Pick,
    inlier_threshold: Pick,
    rectified_rms: Pick,
    disparity_step: Pick,
    centre_anchor: Pick,
    seed: u64,
}

impl Draw {
    fn params(&self) -> AlignParams {
        let features = 4 + usize::from(self.features % 64);
        AlignParams {
            mode: match self.mode % 4 {
                0 => AlignMode::Auto,
                1 => AlignMode::Off,
                _ => AlignMode::On,
            },
            model: if self.plane_patches {
                AlignModel::PlanePatches
            } else {
                AlignModel::PerView
            },
            reference: if self.centre_reference {
                Reference::CentreView
            } else {
                Reference::Estimated
            },
            features,
            target_rms: self.target_rms.value(0.0, 0.5),
            max_iterations: usize::from(self.max_iterations % 9),
            inlier_threshold: self.inlier_threshold.value(0.04, 4.0),
            rectified_rms: self.rectified_rms.value(0.0, 1.0),
            min_inliers: 7 + usize::from(self.min_inliers) % features.saturating_sub(5).max(1),
            seed: self.seed,
            interpolation: interpolation(self.interpolation),
            views: match self.views % 3 {
                0 => AlignedViews::Read,
                1 => AlignedViews::All,
                _ => AlignedViews::Cross,
            },
            disparity_step: self.disparity_step.value(0.0, 4.5),
            centre_anchor: self.centre_anchor.value(0.0, 3.0),
        }
    }
}

fn interpolation(n: u8) -> Interpolation {
    match n % 3 {
        0 => Interpolation::Bilinear,
        1 => Interpolation::CatmullRom,
        _ => Interpolation::SharpenedBilinear,
    }
}

/// Which entry point runs.
#[derive(Arbitrary, Debug)]
enum Entry {
    /// `align::estimate`.
    Estimate,
    /// `estimate_present` on the views of the mask (bit `v % 32` of it) in reverse
    /// order: every absent view keeps the identity and what it holds does not matter;
    /// with every view present the result is `estimate`'s.
    Present(u32),
    /// The estimate, then the warp of one view's rows and of a band of every view.
    Warp(WarpDraw),
    /// The warp alone, by arbitrary homographies.
    WarpAny(WarpDraw, Vec<[f32; 3]>),
    /// `pipeline::run_aligned` with the EPI stage, the other parameters drawn through
    /// the options table.
    Prelude(bool, Vec<Setting>),
}

#[derive(Arbitrary, Debug, Clone, Copy)]
struct WarpDraw {
    view: u8,
    first: u8,
    last: u8,
    interpolation: u8,
    float_out: bool,
    /// A buffer this many samples too long (0: the right length).
    extra: u8,
}

#[derive(Arbitrary, Debug)]
struct Input {
    scene: Scene,
    samples: Samples,
    draw: Draw,
    entry: Entry,
}

/// xorshift32, never zero.
struct Rng(u32);

impl Rng {
    fn next(&mut self) -> u32 {
        let mut s = self.0;
        s ^= s << 13;
        s ^= s >> 17;
        s ^= s << 5;
        self.0 = s;
        s
    }
    /// Uniform in [−1, 1].
    fn signed(&mut self) -> f32 {
        (self.next() >> 8) as f32 / (1u32 << 23) as f32 - 1.0
    }
}

impl Scene {
    fn layout(&self) -> Layout {
        let n = 3 + usize::from(self.rail % 7);
        let grid = match self.grid % 9 {
            0 => Grid::new(3, 3),
            1 => Grid::new(3, 5),
            2 => Grid::new(5, 3),
            3 => Grid::new(5, 5),
            4 => Grid::new(4, 4),
            5 => Grid::new(1, n),
            6 => Grid::new(n, 1),
            7 => Grid::new(2, 2),
            _ => Grid::new(1, 1),
        };
        Layout::packed(
            grid,
            14 + usize::from(self.width % 39),
            14 + usize::from(self.height % 39),
            1 + usize::from(self.channels % 4),
        )
    }

    /// Intensity in [0, 1] of the scene point at rectified `(x, y)` (`seed` tells the
    /// two planes apart).
    fn intensity(&self, x: f32, y: f32, seed: u32) -> f32 {
        match self.picture {
            Picture::Texture(cell) => bilinear_noise(x, y, 1.0 + f32::from(cell % 8), seed),
            Picture::Flat(level) => f32::from(level) / 255.0,
            Picture::Stripes(vertical, period) => {
                let t = if vertical { x } else { y };
                let p = 2.0 + f32::from(period % 8);
                0.5 + 0.5 * (t * core::f32::consts::TAU / p + seed as f32).sin()
            }
            Picture::TwoLevels(cell, threshold) => {
                let v = bilinear_noise(x, y, 1.0 + f32::from(cell % 8), seed);
                if v * 255.0 > f32::from(threshold) {
                    1.0
                } else {
                    0.0
                }
            }
        }
    }

    /// The unit intensities of every view (row-major grid, then rows, pixels, channels).
    fn render(&self, l: &Layout) -> Vec<f32> {
        let (rows, cols) = (l.grid.rows, l.grid.cols);
        let (r0, c0) = l.grid.center();
        let (w, h) = (l.width as f32, l.height as f32);
        let (cx, cy) = (0.5 * (w - 1.0), 0.5 * (h - 1.0));
        let d_back = f32::from(self.background) / 8.0 * 3.0 / 16.0;
        let d_front = f32::from(self.foreground) / 8.0 * 3.0 / 16.0;
        // The foreground square in rectified centre-view coordinates.
        let (fx0, fx1, fy0, fy1) = (0.3 * w, 0.7 * w, 0.25 * h, 0.65 * h);
        let amplitude = f32::from(self.misalign) / 64.0;
        let mut out = Vec::with_capacity(l.grid.len() * l.width * l.height * l.channels);
        let mut rng = Rng(self.seed | 1);
        for r in 0..rows {
            for c in 0..cols {
                let (br, bc) = (r as f32 - r0 as f32, c as f32 - c0 as f32);
                // This view's pixels → rectified pixels: a rotation, scale, shift and
                // perspective about the image centre, none for the centre view of a
                // rectified array.
                let angle = 0.03 * amplitude * rng.signed();
                let scale = 1.0 + 0.02 * amplitude * rng.signed();
                let shift = (
                    2.0 * amplitude * rng.signed(),
                    2.0 * amplitude * rng.signed(),
                );
                let tilt = (
                    2e-3 * amplitude * rng.signed() / w,
                    2e-3 * amplitude * rng.signed() / h,
                );
                let (sin, cos) = angle.sin_cos();
                for y in 0..l.height {
                    for x in 0..l.width {
                        let (dx, dy) = (x as f32 - cx, y as f32 - cy);
                        let q = 1.0 + tilt.0 * dx + tilt.1 * dy;
                        let u = (scale * (cos * dx - sin * dy) + shift.0) / q + cx;
                        let v = (scale * (sin * dx + cos * dy) + shift.1) / q + cy;
                        // A point of disparity d at X in the centre view is at
                        // X − d·b in this view.
                        let (ux, uy) = (u + d_front * bc, v + d_front * br);
                        let front = (fx0..fx1).contains(&ux) && (fy0..fy1).contains(&uy);
                        for ch in 0..l.channels {
                            let seed = self.seed.wrapping_add(ch as u32 * 0x9E37);
                            let mut i = if front {
                                self.intensity(ux, uy, seed ^ 0x5555)
                            } else {
                                self.intensity(u + d_back * bc, v + d_back * br, seed)
                            };
                            if self.noise > 0 {
                                i += (rng.next() % u32::from(self.noise)) as f32 / 255.0;
                            }
                            out.push(i);
                        }
                    }
                }
            }
        }
        out
    }
}

/// Runs the views of a batch in reverse order: the estimate must not depend on it.
struct Reverse;

impl ViewMap for Reverse {
    fn map<F>(&mut self, tasks: &mut [ViewTask<'_>], scratch: &mut [f32], job: &F)
    where
        F: Fn(&mut ViewTask<'_>, &mut [f32]) + Sync,
    {
        for task in tasks.iter_mut().rev() {
            scratch.fill(f32::NAN);
            job(task, scratch);
        }
    }
}

/// The report and homographies as text, NaN and all (bit-for-bit comparison).
fn outcome(result: &lfdepth::Result<AlignReport>, hs: &[Homography]) -> String {
    let bits: Vec<[u32; 9]> = hs.iter().map(|h| h.m.map(f32::to_bits)).collect();
    format!("{result:?} {bits:?}")
}

fn check_estimate(result: &lfdepth::Result<AlignReport>, hs: &[Homography]) {
    if let Ok(report) = result {
        for h in hs {
            assert!(
                h.m.iter().all(|v| v.is_finite()),
                "a non-finite homography {h:?}"
            );
        }
        if report.skipped {
            assert!(
                hs.iter().all(|h| *h == Homography::IDENTITY),
                "a skipped estimate left a homography other than the identity"
            );
        }
    }
}

fn run<S: Sample>(input: &Input, layout: Layout, samples: &[S], blank: impl Fn(&mut [S])) {
    let Ok(lf) = LightField::new(samples, layout) else {
        return;
    };
    let params = input.draw.params();
    let views = layout.grid.len();
    let Ok(scratch_len) = align::scratch_len(&layout, &params) else {
        return;
    };
    if scratch_len > MAX_SCRATCH {
        return;
    }
    let mut scratch = vec![0f32; scratch_len];
    let mut hs = vec![Homography::IDENTITY; views];
    match &input.entry {
        Entry::Estimate => {
            let result = align::estimate(&lf, &params, &mut hs, &mut scratch);
            check_estimate(&result, &hs);
            // A homography slice of the wrong length is an error.
            let mut short = vec![Homography::IDENTITY; views.saturating_sub(1)];
            assert!(align::estimate(&lf, &params, &mut short, &mut scratch).is_err());
        }
        Entry::Present(mask) => {
            let present = |v: usize| mask >> (v % 32) & 1 == 1;
            let result = align::estimate_present(
                &lf,
                &params,
                &present,
                &mut hs,
                &mut scratch,
                &mut Reverse,
            );
            check_estimate(&result, &hs);
            if result.is_ok() {
                for (v, h) in hs.iter().enumerate() {
                    assert!(
                        present(v) || *h == Homography::IDENTITY,
                        "absent view {v} got {h:?}"
                    );
                }
            }
            let first = outcome(&result, &hs);
            if (0..views).all(present) {
                let serial = align::estimate(&lf, &params, &mut hs, &mut scratch);
                assert_eq!(
                    first,
                    outcome(&serial, &hs),
                    "the views in reverse order changed the estimate"
                );
            } else {
                // The absent views blanked: the estimate must not see it.
                let mut other = samples.to_vec();
                let stride = layout.view_stride;
                for (v, view) in other.chunks_mut(stride).enumerate() {
                    if !present(v) {
                        blank(view);
                    }
                }
                let Ok(lf) = LightField::new(&other, layout) else {
                    return;
                };
                let again = align::estimate_present(
                    &lf,
                    &params,
                    &present,
                    &mut hs,
                    &mut scratch,
                    &mut align::Serial,
                );
                assert_eq!(
                    first,
                    outcome(&again, &hs),
                    "the estimate read a view it was told is absent"
                );
            }
        }
        Entry::Warp(draw) => {
            let _ = align::estimate(&lf, &params, &mut hs, &mut scratch);
            warp(&lf, &hs, draw);
        }
        Entry::WarpAny(draw, entries) => {
            for (h, rows) in hs.iter_mut().zip(entries.chunks(3)) {
                for (k, row) in rows.iter().enumerate() {
                    for (j, v) in row.iter().enumerate() {
                        h.m[3 * k + j] += v;
                    }
                }
            }
            warp(&lf, &hs, draw);
        }
        Entry::Prelude(fast, settings) => {
            let mut all = common::params(*fast, settings);
            all.align = params;
            let Ok(plan) = Plan::new(layout, all) else {
                return;
            };
            let stages = Stages::Epi;
            let kernel = pipeline::stage_scratch_len(&plan, stages);
            let maps_len = pipeline::stage_map_scratch_len(&plan, stages);
            if kernel > MAX_SCRATCH || maps_len > MAX_SCRATCH {
                return;
            }
            let mut aligned = vec![0u8; samples.len()];
            let mut buffers = AlignBuffers {
                homographies: &mut hs,
                scratch: &mut scratch,
                aligned: &mut aligned,
            };
            let pixels = plan.pixels();
            let (mut d, mut c) = (vec![0f32; pixels], vec![0f32; pixels]);
            let mut k = vec![0f32; kernel];
            let mut maps = vec![0f32; maps_len];
            let result = pipeline::run_aligned(
                &plan,
                &lf,
                stages,
                &mut buffers,
                pipeline::RunOutput {
                    disparity: &mut d,
                    confidence: &mut c,
                    history: &mut [],
                },
                pipeline::RunScratch {
                    kernel: &mut k,
                    maps: &mut maps,
                },
                &mut |_| ControlFlow::Continue(()),
            );
            if result.is_ok() {
                for h in buffers.homographies.iter() {
                    assert!(h.m.iter().all(|v| v.is_finite()), "{h:?}");
                }
            }
        }
    }
}

/// Warps rows `first..last` of one view (then, when they are all its rows, finishes
/// it) and the same band of every view.
fn warp<S: Sample>(lf: &LightField<'_, S>, hs: &[Homography], draw: &WarpDraw) {
    let (width, height, channels) = (lf.width(), lf.height(), lf.channels());
    let views = lf.grid().len();
    let view = usize::from(draw.view) % (views + 1);
    let first = usize::from(draw.first) % (height + 2);
    let last = usize::from(draw.last) % (height + 2);
    let rows = first..last;
    let interp = interpolation(draw.interpolation);
    let len = rows.len() * width * channels + usize::from(draw.extra);
    let finite = hs
        .get(view)
        .is_some_and(|h| h.m.iter().all(|v| v.is_finite()));
    let valid = view < views && first <= last && last <= height && draw.extra == 0;
    let eight = S::IS_U8;
    if draw.float_out {
        let mut out = vec![0f32; len];
        let result = align::warp_rows_with(lf, hs, view, rows.clone(), interp, &mut out);
        assert_eq!(result.is_ok(), valid && finite, "{result:?}");
        if result.is_ok() && eight {
            for &v in &out {
                assert!(v.is_finite(), "a warp of 8-bit views gave {v}");
                if interp == Interpolation::Bilinear {
                    assert!((-1e-5..=1.0 + 1e-5).contains(&v), "bilinear gave {v}");
                }
            }
        }
        if result.is_ok() && first == 0 && last == height {
            let _ = align::finish_view(lf.layout(), hs, view, interp, &mut out);
        }
    } else {
        let mut out = vec![0u8; len];
        let result = align::warp_rows_with(lf, hs, view, rows.clone(), interp, &mut out);
        assert_eq!(result.is_ok(), valid && finite, "{result:?}");
        if result.is_ok() && first == 0 && last == height {
            let _ = align::finish_view(lf.layout(), hs, view, interp, &mut out);
        }
    }
    if first <= last && last <= height {
        let mut band = vec![0u8; views * rows.len() * width * channels];
        let _ = align::warp_band(lf, hs, rows, &mut band);
    }
}

fuzz_target!(|input: Input| {
    let layout = input.scene.layout();
    let Ok(len) = layout.validate() else {
        // A grid or view size the layout refuses: every entry point says so.
        let samples = vec![0u8; layout.grid.len() * layout.width * layout.height * layout.channels];
        assert!(LightField::new(&samples, layout).is_err());
        assert!(align::scratch_len(&layout, &input.draw.params()).is_err());
        return;
    };
    let unit = input.scene.render(&layout);
    debug_assert_eq!(unit.len(), len);
    match input.samples {
        Samples::Eight => {
            let samples: Vec<u8> = unit
                .iter()
                .map(|&u| (u * 255.0 + 0.5).clamp(0.0, 255.0) as u8)
                .collect();
            run(&input, layout, &samples, |view| view.fill(255));
        }
        Samples::Float(scale) => {
            let samples: Vec<f32> = unit.iter().map(|&u| scale.map(u)).collect();
            run(&input, layout, &samples, |view| view.fill(f32::NAN));
        }
    }
});
