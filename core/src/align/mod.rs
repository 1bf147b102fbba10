//! Alignment of an imperfect camera array: per-view homographies that bring every view
//! into a rectified array, and the warp that applies them.
//!
//! # What is estimated
//! Views of a light field differ by parallax, so no single homography maps a view onto
//! the centre view. What is recoverable is the *rectifying* homography `H_v` of each view
//! `v` (centre included): it maps rectified pixel coordinates to the pixel coordinates
//! of the misaligned view, such that in rectified coordinates every scene point obeys the
//! epipolar model of a rectified array,
//! `x_v = X − d · b_v` with `b_v = (c − c0, r − r0)` and one disparity `d` per point
//! shared by all views. Corners are found in the centre view, tracked into every view
//! (pyramidal Lucas–Kanade template matching, which gives sub-pixel matches), and the
//! homographies and the per-point `(X, d)` are estimated by alternating least squares
//! after a seeded RANSAC start (see the `solve` module).
//!
//! # Gauge (what no image can tell)
//! Replacing every rectified frame by `x ↦ s·x + t + δ·b_v` (uniform scale `s`,
//! translation `t`, disparity offset `δ`) gives another exact rectified array. The
//! estimate fixes these four degrees of freedom by convention: the centre view keeps its
//! own scale and the position of its image centre (by default it is the reference and
//! keeps the identity, see [`Reference`]), and the view translations have no mean
//! component along the baselines (zero-mean misalignment) — after which the offset `δ`
//! is moved by at most half of [`AlignParams::disparity_step`] so that the tracked
//! points' disparities lie nearest the EPI stage's shear hypotheses (0 keeps the
//! zero-mean convention). [`gauge_rms`] compares
//! homographies modulo this gauge, [`reprojection_rms`] measures what the EPI stage
//! sees. To first order in the disparity the same holds for a disparity *plane*: moving
//! every view by `(δ + βx + γy)·b_v` is adding `δ + βx + γy` to every disparity, so the
//! slopes `β, γ` are as unobservable as `δ` ([`gauge_fit`] fits all three; no
//! convention fixes the slopes, so they land where the alternation leaves them, about
//! 0.1 px across the image on the synthetic tests). A rotation common to all views is
//! observable only through parallax (an error of θ rotates the parallax of a point by
//! θ·d·|b|), so with small disparities it is weakly determined; [`Reference::CentreView`]
//! does not estimate it.
//!
//! # Entry points
//! [`scratch_len`] and [`estimate`] fill one homography per view (row-major grid order,
//! the convention of `synth::render`); [`estimate_with`] does the same with the per-view
//! work run through a [`ViewMap`] (the CLI spreads it over threads, same result); [`warp_rows`] / [`warp_rows_with`] /
//! [`warp_band`] write rectified views into caller buffers, a band of rows at a time.
//! `pipeline::align_views` / `pipeline::run_aligned` run both before the other stages,
//! on the views those stages read.

mod corners;
mod gauge;
mod model;
mod pyramid;
mod solve;
mod track;
mod warp;

use heapless::Vec as FixedVec;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::geometry::Homography;
use crate::lightfield::{Grid, Layout, LightField, Sample, GRID_MAX};
use crate::setup::StageParams;

pub use gauge::{gauge_fit, gauge_fit_where, gauge_rms, reprojection_rms, GaugeFit};
pub use warp::{
    finish_view, sharpen_columns, warp_band, warp_rows, warp_rows_with, Interpolation, WarpSample,
};

/// Most corners tracked from the centre view (compile-time capacity).
pub const MAX_FEATURES: usize = 512;
/// Most views of a grid (17 × 17).
pub const MAX_VIEWS: usize = GRID_MAX * GRID_MAX;

/// Whether to align.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlignMode {
    /// Never align: the array is trusted to be rectified.
    Off,
    /// Always estimate and apply homographies.
    On,
    /// Check cheaply whether the array is rectified (a few outer views) and align only
    /// if it is not. A failed estimate falls back to the unaligned path with a warning.
    #[default]
    Auto,
}

/// How the disparity of the tracked points is modelled while the homographies are
/// estimated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlignModel {
    /// One free disparity per tracked point, shared by all views; one homography per view.
    #[default]
    PerView,
    /// The paper's joint model (Javidnia & Corcoran, Eq. 1–7): points are grouped into
    /// plane patches (a coarse grid over the centre view), each patch's disparity is an
    /// affine function (its plane, `ΔN_t`) estimated with the homographies fixed, then
    /// the homographies with the planes fixed, alternating.
    PlanePatches,
}

/// Which rectified frame the homographies map from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Reference {
    /// The centre camera is the reference: its homography is the identity and every other
    /// view is rectified onto it (as in the paper). Its roll and perspective relative to
    /// the baselines are left alone, so the disparity map stays registered to the centre
    /// view as captured — exact when the centre camera is well mounted, but a misaligned
    /// centre camera then leaves its error in every EPI.
    CentreView,
    /// The centre view is estimated like the others (its rotation and perspective from
    /// the parallax directions, weakly determined when disparities are small); scale and
    /// position of its image centre are kept.
    #[default]
    Estimated,
}

/// Which views get a homography.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum AlignedViews {
    /// The views the pipeline's stages read: [`AlignedViews::Cross`] when they read no
    /// other view (the EPI stage and the default refinement), else every view
    /// (`pipeline::align_params` decides; [`estimate`] alone treats it as `All`).
    #[default]
    Read,
    /// Every view of the grid.
    All,
    /// The centre row and column only (the others keep the identity), at a fifth of the
    /// tracking work on a 9×9 grid. Fewer views average the random part of the
    /// misalignment less, so the disparity offset no image can observe (see the module
    /// docs) tends to be larger (measured 0.27 px against 0.05 px with every view).
    Cross,
}

/// Parameters of the alignment stage.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlignParams {
    /// Off, on, or automatic detection of a rectified array.
    pub mode: AlignMode,
    /// Disparity model used while estimating.
    pub model: AlignModel,
    /// The frame of the rectified array.
    pub reference: Reference,
    /// Corners tracked from the centre view (8 … [`MAX_FEATURES`]).
    pub features: usize,
    /// Stop when the RMS reprojection error (pixels) falls below this.
    pub target_rms: f32,
    /// Most alternation rounds.
    pub max_iterations: usize,
    /// Final inlier threshold on the reprojection error (pixels).
    pub inlier_threshold: f32,
    /// Auto mode: an array whose identity-homography RMS error (pixels) is below this
    /// is considered rectified and left alone.
    pub rectified_rms: f32,
    /// Fewest inlier tracks a view needs for its homography.
    pub min_inliers: usize,
    /// Seed of the RANSAC sampler (results are deterministic for a seed).
    pub seed: u64,
    /// How the pipeline resamples the views into the rectified array.
    pub interpolation: Interpolation,
    /// Which views to estimate.
    pub views: AlignedViews,
    /// Disparity grid of the gauge offset (px; 0 = off). The disparity offset common to
    /// every point is unobservable (module docs); by convention it is fixed by
    /// zero-mean view translations along the baselines, and then, when this is > 0,
    /// moved by at most half of it so that the tracked points' disparities lie as near
    /// as possible to multiples of it (their circular mean) — when they cluster on one
    /// phase (coherence ≥ 0.3, see [`AlignReport::disparity_coherence`]), see
    /// `solve::snap_disparity_offset`. The EPI stage shears at multiples of its
    /// `shear_step` (0.5 px by default, the default here) and measures surfaces that
    /// lie on a shear most accurately; any `shear_step` that divides this value has the
    /// same multiples.
    pub disparity_step: f32,
    /// [`Reference::Estimated`] only: when the estimated frame lies within this many
    /// pixels of the centre camera's at the view's corners (beyond a common translation),
    /// the frame is moved onto the centre camera's, every estimated map composed with
    /// the inverse of the centre view's (0 = never). The estimated frame's own
    /// rotation and shears are fixed only through the parallax and were off by
    /// 0.26–0.48 px at the corners of the synthetic 384² arrays, whose centre camera is
    /// exact; within that the centre camera is the better frame, and its view is then
    /// not resampled (final disparity +28.6 / +26.7 % → +21.3 / +17.8 % BadPix0.07 against
    /// the rectified arrays, docs/stages/align.md). A centre camera further
    /// off keeps the estimated frame.
    pub centre_anchor: f32,
}

impl Default for AlignParams {
    fn default() -> Self {
        AlignParams {
            mode: AlignMode::Auto,
            model: AlignModel::PerView,
            reference: Reference::Estimated,
            features: 256,
            target_rms: 0.02,
            max_iterations: 30,
            inlier_threshold: 0.75,
            rectified_rms: 0.1,
            min_inliers: 12,
            seed: 0x5eed_a11e,
            interpolation: Interpolation::SharpenedBilinear,
            views: AlignedViews::Read,
            disparity_step: 0.5,
            centre_anchor: 1.0,
        }
    }
}

impl StageParams for AlignParams {
    fn validate(&self) -> Result<()> {
        AlignParams::validate(self)
    }
}

impl AlignParams {
    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(8..=MAX_FEATURES).contains(&self.features) {
            return bad("align.features", "must be between 8 and 512");
        }
        if !(self.target_rms.is_finite() && self.target_rms >= 0.0) {
            return bad("align.target_rms", "must be a finite number ≥ 0 (pixels)");
        }
        if !(1..=200).contains(&self.max_iterations) {
            return bad("align.max_iterations", "must be between 1 and 200");
        }
        if !(self.inlier_threshold.is_finite() && self.inlier_threshold > 0.05) {
            return bad(
                "align.inlier_threshold",
                "must be a finite number > 0.05 (pixels)",
            );
        }
        if !(self.rectified_rms.is_finite() && self.rectified_rms >= 0.0) {
            return bad(
                "align.rectified_rms",
                "must be a finite number ≥ 0 (pixels)",
            );
        }
        if !(self.disparity_step.is_finite() && (0.0..=4.0).contains(&self.disparity_step)) {
            return bad(
                "align.disparity_step",
                "must be a finite number between 0 (off) and 4 (pixels)",
            );
        }
        if !(self.centre_anchor.is_finite() && self.centre_anchor >= 0.0) {
            return bad(
                "align.centre_anchor",
                "must be a finite number ≥ 0 (pixels; 0 = off)",
            );
        }
        if !(8..=MAX_FEATURES).contains(&self.min_inliers) || self.min_inliers > self.features {
            return bad(
                "align.min_inliers",
                "must be between 8 and 512 and at most align.features",
            );
        }
        Ok(())
    }
}

/// What one view's estimate rests on.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ViewReport {
    /// Tracks of this view used in the final fit.
    pub inliers: u16,
    /// RMS reprojection error of those tracks (rectified pixels).
    pub rms: f32,
}

/// The outcome of [`estimate`].
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AlignReport {
    /// No homography was estimated: mode off, or auto found the array rectified (or
    /// could not align it, see `warning`). The output homographies are identities.
    pub skipped: bool,
    /// Auto mode only: the error that made it fall back to the unaligned path.
    pub warning: Option<Error>,
    /// Corners detected in the centre view.
    pub features: usize,
    /// Per view, row-major grid order (empty when nothing was estimated).
    pub views: FixedVec<ViewReport, MAX_VIEWS>,
    /// RMS reprojection error over all inlier observations with identity homographies
    /// (the misalignment as measured; on the views tracked).
    pub identity_rms: f32,
    /// RMS reprojection error of the estimated homographies (pixels).
    pub rms: f32,
    /// Alternation rounds run.
    pub iterations: usize,
    /// Disparity (px) added to every point by the choice of the gauge offset
    /// ([`AlignParams::disparity_step`]); 0 when it is off or left the offset alone
    /// (coherence under 0.3).
    pub disparity_shift: f32,
    /// How closely the tracked points' disparities cluster on one phase of the
    /// disparity step, 0 (spread evenly) … 1 (all on one phase): the length of their
    /// mean phase vector.
    pub disparity_coherence: f32,
}

impl AlignReport {
    /// The report of no estimate (equal to `AlignReport::default()`), for constants: a
    /// firmware keeps its report in static memory and has the pipeline fill it in place.
    pub const EMPTY: AlignReport = AlignReport {
        skipped: false,
        warning: None,
        features: 0,
        views: FixedVec::new(),
        identity_rms: 0.0,
        rms: 0.0,
        iterations: 0,
        disparity_shift: 0.0,
        disparity_coherence: 0.0,
    };

    /// Sets every field as `AlignReport { features, ..AlignReport::default() }` would,
    /// in place (no second report on the stack).
    pub(crate) fn start(&mut self, features: usize) {
        let AlignReport {
            skipped,
            warning,
            features: f,
            views,
            identity_rms,
            rms,
            iterations,
            disparity_shift,
            disparity_coherence,
        } = self;
        *skipped = false;
        *warning = None;
        *f = features;
        views.clear();
        *identity_rms = 0.0;
        *rms = 0.0;
        *iterations = 0;
        *disparity_shift = 0.0;
        *disparity_coherence = 0.0;
    }
}

/// One view's share of a batch of per-view work — tracking the centre view's corners
/// into it (its row of the track table: `(x, y)` per corner, NaN where not found) or
/// fitting its homography to its tracks. The views of a batch are independent of each
/// other, so a [`ViewMap`] may run them in any order or concurrently.
#[derive(Debug)]
pub struct ViewTask<'a> {
    view: usize,
    obs: &'a mut [f32],
    pub(crate) outcome: Result<usize>,
    /// The view's homography, for the jobs that fit one.
    pub(crate) homography: Option<Homography>,
}

impl<'a> ViewTask<'a> {
    pub(crate) fn new(view: usize, obs: &'a mut [f32]) -> Self {
        ViewTask {
            view,
            obs,
            outcome: Ok(0),
            homography: None,
        }
    }

    /// The view (row-major grid index) this task tracks.
    pub fn view(&self) -> usize {
        self.view
    }

    pub(crate) fn get(&self, i: usize) -> Option<(f32, f32)> {
        let (x, y) = (*self.obs.get(2 * i)?, *self.obs.get(2 * i + 1)?);
        x.is_finite().then_some((x, y))
    }

    pub(crate) fn set(&mut self, i: usize, q: Option<(f32, f32)>) {
        let (x, y) = q.unwrap_or((f32::NAN, f32::NAN));
        if let Some(slot) = self.obs.get_mut(2 * i..2 * i + 2) {
            slot[0] = x;
            slot[1] = y;
        }
    }
}

/// Runs the per-view jobs of [`estimate_with`] (tracking, and the per-view homography
/// fits with their RANSAC start): `job(task, scratch)` once per task. Each job writes only its own task and reads shared, unchanging data, so the
/// estimate is the same (bit for bit) however an implementation orders or spreads the
/// jobs. [`Serial`] runs them one after another; the CLI maps them over threads.
pub trait ViewMap {
    /// Calls `job` once for every task of `tasks`. `scratch` is the estimate's own
    /// scratch for one job (an image pyramid for tracking, empty for the fits); an
    /// implementation that runs jobs concurrently gives each running job a buffer of its
    /// own of the same length (the contents on entry do not matter).
    fn map<F>(&mut self, tasks: &mut [ViewTask<'_>], scratch: &mut [f32], job: &F)
    where
        F: Fn(&mut ViewTask<'_>, &mut [f32]) + Sync;
}

/// The [`ViewMap`] of [`estimate`]: one job after another, in the estimate's scratch.
#[derive(Clone, Copy, Debug, Default)]
pub struct Serial;

impl ViewMap for Serial {
    fn map<F>(&mut self, tasks: &mut [ViewTask<'_>], scratch: &mut [f32], job: &F)
    where
        F: Fn(&mut ViewTask<'_>, &mut [f32]) + Sync,
    {
        for task in tasks {
            job(task, scratch);
        }
    }
}

/// Scratch [`estimate`] needs for `layout`, in `f32` elements: two image pyramids (centre
/// and current view) and the track table. It grows with the view size, not with the
/// number of bands the caller warps.
pub fn scratch_len(layout: &Layout, params: &AlignParams) -> Result<usize> {
    layout.validate()?;
    let _ = params;
    let pyramid = pyramid::Pyramid::len_for(layout.width, layout.height)?;
    let tracks = solve::Tracks::len_for(layout.grid.len())?;
    checked_product(&[pyramid, 2], "alignment scratch")?
        .checked_add(tracks)
        .ok_or(Error::SizeOverflow {
            what: "alignment scratch",
        })
}

/// Estimates one homography per view (row-major grid order; rectified → view pixel
/// coordinates, pixel centres at integer coordinates) into `homographies`.
///
/// Mode [`AlignMode::Off`] writes identities. [`AlignMode::Auto`] first tracks a few
/// outer views and keeps identities when the array is already rectified; if estimation
/// then fails, it keeps identities and reports the error as a warning. [`AlignMode::On`]
/// returns the error ([`Error::Alignment`] for textureless or too different views).
pub fn estimate<S: Sample>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    homographies: &mut [Homography],
    scratch: &mut [f32],
) -> Result<AlignReport> {
    estimate_with(lf, params, homographies, scratch, &mut Serial)
}

/// [`estimate`] with the per-view tracking (corner matching into each view, the bulk of
/// the work) run through `map`, e.g. over threads. The result is identical to
/// [`estimate`]'s for any [`ViewMap`]: views are tracked in batches that depend only on
/// earlier batches (the first pass ring by ring around the centre, the second pass all
/// at once); in the alternating least squares the view step (each view's homography
/// from its own tracks, RANSAC seeded per view) runs through `map` too, while the point
/// step, the gauge and the common-distortion fit, which couple the views, are serial.
pub fn estimate_with<S: Sample, M: ViewMap>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    homographies: &mut [Homography],
    scratch: &mut [f32],
    map: &mut M,
) -> Result<AlignReport> {
    estimate_present(lf, params, &|_| true, homographies, scratch, map)
}

/// [`estimate_with`] on a light field of which only the views `present` accepts
/// (row-major grid index) exist: the others are never read and keep the identity. The
/// probe of [`AlignMode::Auto`] and the estimate use the views of their set that exist;
/// the centre view must exist ([`Error::Alignment`] in mode on, a skipped estimate with
/// that warning in auto). With every view present the result is [`estimate_with`]'s.
pub fn estimate_present<S: Sample, M: ViewMap>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    present: &dyn Fn(usize) -> bool,
    homographies: &mut [Homography],
    scratch: &mut [f32],
    map: &mut M,
) -> Result<AlignReport> {
    let mut report = AlignReport::default();
    estimate_into(lf, params, present, homographies, scratch, map, &mut report)?;
    Ok(report)
}

/// [`estimate_present`] into `report`, the one report of the whole estimate: passed down
/// instead of returned from each level, it is on a firmware's stack once instead of once
/// or twice per frame (≈ 2.4 KB each, a `ViewReport` per view of a 17×17 grid).
pub(crate) fn estimate_into<S: Sample, M: ViewMap>(
    lf: &LightField<'_, S>,
    params: &AlignParams,
    present: &dyn Fn(usize) -> bool,
    homographies: &mut [Homography],
    scratch: &mut [f32],
    map: &mut M,
    report: &mut AlignReport,
) -> Result<()> {
    params.validate()?;
    let layout = *lf.layout();
    let views = layout.grid.len();
    if homographies.len() != views {
        return Err(Error::OutputSize {
            what: "the homography slice (one per view)",
            needed: views,
            got: homographies.len(),
        });
    }
    let needed = scratch_len(&layout, params)?;
    check_scratch(needed, scratch.len())?;
    homographies.fill(Homography::IDENTITY);
    report.start(0);
    let (r0, c0) = layout.grid.center();
    let centre = layout.grid.index(r0, c0);
    if params.mode != AlignMode::Off && !present(centre) {
        // Every view is aligned by the centre view's corners: it is never optional.
        let error = Error::Alignment {
            view: centre,
            reason: "the centre view is absent: alignment tracks its corners into the other views, so supply it or turn alignment off",
        };
        if params.mode == AlignMode::On {
            return Err(error);
        }
        report.skipped = true;
        report.warning = Some(error);
        return Ok(());
    }
    let set = match params.views {
        AlignedViews::All | AlignedViews::Read => solve::ViewSet::All,
        AlignedViews::Cross => solve::ViewSet::Cross,
    };
    match params.mode {
        AlignMode::Off => {
            report.skipped = true;
            Ok(())
        }
        AlignMode::On => {
            solve::run(
                lf,
                params,
                solve::Tracked { set, present },
                homographies,
                scratch,
                map,
                report,
            )?;
            anchor_on_centre(&layout, params, set, present, homographies);
            Ok(())
        }
        AlignMode::Auto => {
            let probe = solve::run(
                lf,
                params,
                solve::Tracked {
                    set: solve::ViewSet::Probe,
                    present,
                },
                homographies,
                scratch,
                map,
                report,
            );
            homographies.fill(Homography::IDENTITY);
            if let Err(e) = probe {
                report.start(0);
                report.skipped = true;
                report.warning = Some(e);
                return Ok(());
            }
            if report.identity_rms <= params.rectified_rms.max(1.25 * report.rms) {
                let (features, identity_rms) = (report.features, report.identity_rms);
                report.start(features);
                report.skipped = true;
                report.identity_rms = identity_rms;
                report.rms = identity_rms;
                return Ok(());
            }
            match solve::run(
                lf,
                params,
                solve::Tracked { set, present },
                homographies,
                scratch,
                map,
                report,
            ) {
                Ok(()) => {
                    anchor_on_centre(&layout, params, set, present, homographies);
                    Ok(())
                }
                Err(e) => {
                    homographies.fill(Homography::IDENTITY);
                    report.start(0);
                    report.skipped = true;
                    report.warning = Some(e);
                    Ok(())
                }
            }
        }
    }
}

/// Whether [`estimate`] with `params` may read view `view` (row-major grid index) of a
/// `grid`: none when off; the centre view and the views of `params.views`
/// ([`AlignedViews::Read`] counts as every view, as in [`estimate`]) when on; in auto
/// mode also the probe's views (a few near the centre and the four corners).
pub fn reads_view(grid: Grid, params: &AlignParams, view: usize) -> bool {
    if view >= grid.len() {
        return false;
    }
    let set = match params.views {
        AlignedViews::All | AlignedViews::Read => solve::ViewSet::All,
        AlignedViews::Cross => solve::ViewSet::Cross,
    };
    let (r0, c0) = grid.center();
    let in_set =
        |set| view == grid.index(r0, c0) || solve::view_order(grid, set, &|_| true).contains(&view);
    match params.mode {
        AlignMode::Off => false,
        AlignMode::On => in_set(set),
        AlignMode::Auto => in_set(set) || in_set(solve::ViewSet::Probe),
    }
}

/// Moves an estimated frame onto the centre camera's when the two differ by at most
/// `params.centre_anchor` pixels at the view's corners beyond a common translation (see
/// [`AlignParams::centre_anchor`]): every map of `set` is composed with the inverse of
/// the centre view's, which becomes the identity. Returns whether it moved.
fn anchor_on_centre(
    layout: &Layout,
    params: &AlignParams,
    set: solve::ViewSet,
    present: &dyn Fn(usize) -> bool,
    homographies: &mut [Homography],
) -> bool {
    if params.reference != Reference::Estimated || params.centre_anchor <= 0.0 {
        return false;
    }
    let grid = layout.grid;
    let (r0, c0) = grid.center();
    let Some(centre) = homographies.get(grid.index(r0, c0)).copied() else {
        return false;
    };
    let Some(back) = centre.inverse() else {
        return false;
    };
    let (w, h) = (layout.width as f32 - 1.0, layout.height as f32 - 1.0);
    let mut moves = [(0.0f32, 0.0f32); 4];
    for (m, (x, y)) in moves
        .iter_mut()
        .zip([(0.0, 0.0), (w, 0.0), (0.0, h), (w, h)])
    {
        let Some((u, v)) = centre.apply(x, y) else {
            return false;
        };
        *m = (u - x, v - y);
    }
    let mean = moves
        .iter()
        .fold((0.0, 0.0), |a, m| (a.0 + 0.25 * m.0, a.1 + 0.25 * m.1));
    let spread = moves
        .iter()
        .map(|m| libm::hypotf(m.0 - mean.0, m.1 - mean.1))
        .fold(0.0f32, |a, b| if b > a { b } else { a });
    // A NaN spread (a degenerate map) is not within the tolerance either.
    if spread.is_nan() || spread > params.centre_anchor {
        return false;
    }
    let cols = grid.cols.max(1);
    for (v, map) in homographies.iter_mut().enumerate() {
        let estimated = present(v)
            && match set {
                solve::ViewSet::Cross => v / cols == r0 || v % cols == c0,
                _ => true,
            };
        if estimated {
            *map = map.compose(&back);
        }
    }
    // Exactly the identity, so the centre view is copied, not resampled.
    if let Some(map) = homographies.get_mut(grid.index(r0, c0)) {
        *map = Homography::IDENTITY;
    }
    true
}

#[cfg(any(test, feature = "testscene"))]
pub mod testscene;

#[cfg(test)]
mod anchor_tests;

#[cfg(test)]
mod tests;

#[cfg(test)]
mod gauge_offset_tests;

#[cfg(test)]
mod mode_tests;
