//! Initial disparity from a plane sweep with window-aggregated matching costs: an
//! alternative to the EPI stage ([`crate::epi`]) for the start of the pipeline.
//!
//! For each hypothesis `d` on a grid over the disparity range (spacing at most
//! [`PlaneSweepParams::step`], both ends included), every view of the centre row and
//! column of cameras is compared with the centre view where `d` puts the centre pixel in
//! that view: view `(r, c)` at camera offset `(u, v) = (c − c0, r − r0)` is read at
//! `(x − d·u, y − d·v)`, linearly interpolated. For a horizontal view that is the view's
//! row `y` shifted by the constant `−d·u`, for a vertical view a blend of two of its rows
//! with constant weights: either way a contiguous, branch-free pass over a row that the
//! compiler vectorises. With `f` the fractional part of the shift and `g = 1 − f`, a view
//! contributes per colour channel
//!
//! ```text
//! e = min(w·|g·I(⌊s⌋) + f·I(⌊s⌋ + 1) − I_centre|, τ),     w = √2 / √(1 + g² + f²)
//! ```
//!
//! (`τ` [`PlaneSweepParams::truncate`], unit intensity): `w` divides by the residual's
//! deviation under independent noise of equal deviation in every view, relative to a
//! whole-pixel shift. Without it, interpolation that averages two noisy samples lowers
//! the cost at half-pixel shifts and pulls faint texture towards those hypotheses.
//!
//! The costs are summed into five volumes, each aggregated over its own window
//! (`r` = [`PlaneSweepParams::radius`], `ℓ = line · r`, [`PlaneSweepParams::line`]; the
//! cost is replicated at the image edges):
//!
//! | volume | views | window |
//! |---|---|---|
//! | combined | row and column | `(2r + 1)²` square |
//! | horizontal, along | centre row | `2ℓ + 1` along x |
//! | vertical, along | centre column | `2ℓ + 1` along y |
//! | horizontal, across | centre row | `2ℓ + 1` along y |
//! | vertical, across | centre column | `2ℓ + 1` along x |
//!
//! A square window straddles thin structures and the gaps between them (the slats of
//! HCI backgammon, poles); a line window along the structure keeps them, and the views
//! of one axis avoid the other axis's occlusions. Per volume and pixel the stage keeps
//! the lowest cost `c₀`, its hypothesis and its neighbours' costs `c₋`, `c₊`, and refines
//! the winner by the equiangular fit `Δ = (c₋ − c₊) / (2 (max(c₋, c₊) − c₀))` (clamped
//! to half a step; absolute differences make V-shaped minima, which a parabola biases
//! towards the hypotheses). The confidence is `1 − c₀ / c̄`, `c̄` the mean cost over the
//! hypotheses: near 1 where one hypothesis stands out, 0 on textureless surfaces. Each
//! pixel takes the combined volume's winner unless a one-axis volume's confidence
//! exceeds the combined one's times [`PlaneSweepParams::select`] (and the other
//! one-axis volumes').
//!
//! # Bands
//! The stage runs over bands of [`BAND_ROWS`] rows; a band computes the costs of its
//! rows and `ℓ` rows on each side (clamped to the image). Each pixel's summed cost is
//! rounded once to fixed point (a scale at which a window of the largest costs cannot
//! overflow `i32`), and the windows are summed in integers, which is exact: along x by
//! doubling (sums of 2, 4, 8, … taps), along y as a running sum per band row (the
//! entering row added, the leaving one subtracted). So the map is bit-identical for any
//! banding and thread count whatever order the taps are added in. Before the
//! hypotheses a band converts the view rows it reads to unit intensity once (the
//! centre's and the row views' rows of the band and its halo, each column view's rows
//! that those reach at any hypothesis), so the per-hypothesis pass over a row reads
//! `f32` values: the same bits as converting the taps per hypothesis.
//!
//! # Numbers
//! The stage matches in `f32` and sums the windows in `i32` fixed point whatever the
//! pipeline's scalar type; the winners are kept in `f32` (the window sums converted,
//! exactly up to 2²⁴ and rounded beyond). Its scratch is the run's `f32` map scratch,
//! the integer rows reinterpreted in place.

mod params;
#[cfg(test)]
pub(crate) mod tests;

use core::ops::Range;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::lightfield::{LightField, Sample, View};
use crate::setup::{DisparityOut, Setup};

pub use params::{PlaneSweepParams, SweepColor, MAX_CANDIDATE, MAX_LINE, MAX_RADIUS};

/// Progress and timing stage name.
pub const STAGE: &str = "sweep";

/// Image rows per band (a part of the schedule's step): the cost rows of a band's halo
/// (`2 · radius`) are computed again by the next band, so a band should be much taller
/// than the window.
pub const BAND_ROWS: usize = 64;

/// `√2`: the noise weight of a whole-pixel shift is 1.
const NOISE_SCALE: f32 = core::f32::consts::SQRT_2;

/// `1/√3`: the luminance difference's truncation relative to a channel's
/// ([`SweepColor::Gray`]).
const GRAY_TRUNCATE: f32 = 0.577_350_26;

/// View groups: the centre row's views and the centre column's.
const GROUPS: usize = 2;

/// Per-pixel state a band keeps over the hypotheses, per volume.
const STATE: usize = 6;

/// Cost volumes: every view in a square window, then each axis's views in a line
/// window along and across its axis.
const VOLUMES: usize = 5;

/// The per-pixel candidate's confidence (`1 − c₀ / c̄` of its window's cost curve)
/// below which the map's disparity is written in its place: the winner of a flat
/// curve is noise (docs/stages/sweep.md, "A per-pixel candidate": 512² hall, corridor
/// and every other scene better with it than without).
const CANDIDATE_CONFIDENCE: f32 = 0.5;

/// Most cost volumes a band keeps: [`VOLUMES`] and the per-pixel candidate's
/// ([`PlaneSweepParams::candidate`]).
const MOST_VOLUMES: usize = VOLUMES + 1;

/// Volumes a band keeps: the candidate's besides the others when it is on.
fn volume_count(params: &PlaneSweepParams) -> usize {
    if params.candidate > 0 {
        MOST_VOLUMES
    } else {
        VOLUMES
    }
}

/// Padding (px) of a volume's pixel-cost row: the widest window along x.
fn padding(params: &PlaneSweepParams) -> usize {
    (params.line * params.radius).max(params.candidate / 2)
}

/// Where the stage writes a band: its map and, with [`PlaneSweepParams::candidate`],
/// the per-pixel candidate (the winner of the candidate's small window, refined as the
/// map's, where that window's confidence reaches `CANDIDATE_CONFIDENCE`; the map's
/// disparity elsewhere), one value per pixel of the band each.
#[derive(Debug)]
pub struct SweepOut<'a> {
    /// The disparity and confidence of the band.
    pub map: DisparityOut<'a>,
    /// The per-pixel candidate of the band (`None` when the candidate is off).
    pub candidate: Option<&'a mut [f32]>,
}

/// Scratch (`f32` elements) of [`estimate_rows`] for a band of up to [`BAND_ROWS`] rows:
/// two interleaved rows of matching costs (row and column views) and the centre row,
/// the two groups' fixed-point pixel costs of a row, per volume (with the candidate's,
/// when on) four padded rows (the pixel costs, two of partial window sums along x and
/// the running window sum along y), the filtered rows of the band and its halo and six
/// values per pixel of the band, and the views' rows in unit intensity that a band keeps
/// (`cache_rows` rows of interleaved samples, one value per pixel with
/// [`SweepColor::Gray`]).
pub fn scratch_len(setup: Setup<'_, PlaneSweepParams>) -> usize {
    let layout = setup.layout();
    let (width, channels) = (layout.width, layout.channels);
    let matched = Luma::values(Luma::of(setup.params(), channels), channels);
    let line = setup.params().line * setup.params().radius;
    let rows = BAND_ROWS.min(layout.height);
    let volume = [
        width
            .saturating_add(2 * padding(setup.params()))
            .saturating_mul(4),
        rows.saturating_add(2 * line).saturating_mul(width),
        rows.saturating_mul(width).saturating_mul(STATE),
    ]
    .iter()
    .fold(0usize, |a, &b| a.saturating_add(b));
    let parts = [
        width.saturating_mul(channels).saturating_mul(GROUPS + 1),
        width.saturating_mul(GROUPS),
        volume.saturating_mul(volume_count(setup.params())),
        cache_rows(layout.grid, height_rows(layout.height, line), layout.height)
            .saturating_mul(width.saturating_mul(matched)),
    ];
    parts.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

/// Rows a band computes costs for, halo included: at most [`BAND_ROWS`] `+ 2·line`,
/// at most the image.
fn height_rows(height: usize, line: usize) -> usize {
    BAND_ROWS.saturating_add(line.saturating_mul(2)).min(height)
}

/// Rows of the views in unit intensity that a band keeps ([`RowCache`]) when the
/// disparity range lies within ±[`crate::epi::MAX_DISPARITY`]: the centre view's and
/// each row view's rows of the band and its halo (`region` rows), and each column view's
/// rows that those rows reach at any hypothesis (`region + 2·⌈8·|v|⌉ + 2`, at most the
/// image).
fn cache_rows(grid: crate::lightfield::Grid, region: usize, height: usize) -> usize {
    let (r0, _) = grid.center();
    let reach = |r: usize| {
        let v = r.abs_diff(r0) as f32;
        let shift = libm::ceilf(crate::epi::MAX_DISPARITY * v) as usize;
        region
            .saturating_add(shift.saturating_mul(2))
            .saturating_add(2)
            .min(height)
    };
    let vertical = (0..grid.rows)
        .filter(|&r| r != r0)
        .fold(0usize, |a, r| a.saturating_add(reach(r)));
    region.saturating_mul(grid.cols).saturating_add(vertical)
}

/// Number of bands of [`BAND_ROWS`] rows.
pub fn band_count(setup: Setup<'_, PlaneSweepParams>) -> usize {
    setup.layout().height.div_ceil(BAND_ROWS)
}

/// The hypotheses over `[min, max]`: their number and spacing (at most `step`, both ends
/// included).
fn hypotheses(step: f32, min: f32, max: f32) -> (usize, f32) {
    let span = max - min;
    if span.is_nan() || span <= 0.0 {
        return (1, 0.0);
    }
    // `span / step` ≤ 16 / 0.05 by the parameters' and the range's bounds.
    let intervals = libm::ceilf(span / step - 1.0e-4).max(1.0) as usize;
    (intervals + 1, span / intervals as f32)
}

/// One view of the sweep: its image and camera offset from the centre, the current
/// hypothesis's shift and where the band keeps its rows in unit intensity.
#[derive(Clone, Copy)]
struct SweepView<'a, S: Sample> {
    view: View<'a, S>,
    u: f32,
    v: f32,
    /// 0 for the centre row's views, 1 for the centre column's.
    group: usize,
    /// The current hypothesis's shift ([`Shift::at`]).
    shift: Shift,
    /// The view's rows the band converted ([`RowCache`]).
    rows: RowCache,
}

/// A view's shift `t = −d·u` (row views) or `−d·v` (column views) at hypothesis `d`,
/// split into `⌊t⌋` and the blend weights `f = t − ⌊t⌋`, `g = 1 − f`, and the noise
/// weight `w = √2 / √(1 + g² + f²)`.
#[derive(Clone, Copy, Default)]
struct Shift {
    floor: f32,
    f: f32,
    g: f32,
    w: f32,
}

impl Shift {
    fn at(d: f32, offset: f32) -> Self {
        let t = -d * offset;
        let floor = libm::floorf(t);
        let f = t - floor;
        let g = 1.0 - f;
        // Under i.i.d. noise of deviation σ the residual's deviation is
        // σ·√(1 + g² + f²): linear interpolation averages noise away at half-pixel
        // shifts, which would pull faint texture towards those hypotheses.
        let w = NOISE_SCALE / libm::sqrtf(1.0 + g * g + f * f);
        Shift { floor, f, g, w }
    }
}

/// Rows `first..first + rows` of a view in unit intensity ([`Sample::to_unit`]), kept
/// for a band at `start` of the cache (`row_len` values a row); `rows` 0 where the
/// cache had no room: that view is read and converted per hypothesis, to the same bits.
#[derive(Clone, Copy, Default)]
struct RowCache {
    start: usize,
    first: usize,
    rows: usize,
}

impl RowCache {
    /// Row `y` from `cache`, if kept.
    fn row<'c>(&self, cache: &'c [f32], y: usize, row_len: usize) -> Option<&'c [f32]> {
        let k = y.checked_sub(self.first).filter(|&k| k < self.rows)?;
        let at = self.start.checked_add(k.checked_mul(row_len)?)?;
        cache.get(at..at.checked_add(row_len)?)
    }

    /// Takes room for rows `rows` of `view` from `cache[*used..]` and converts them
    /// ([`unit_row`]); no room leaves the view uncached.
    fn fill<S: Sample>(
        view: &View<'_, S>,
        rows: Range<usize>,
        cache: &mut [f32],
        used: &mut usize,
        row_len: usize,
        luma: Option<Luma>,
    ) -> Self {
        let Some(len) = rows.len().checked_mul(row_len) else {
            return RowCache::default();
        };
        let start = *used;
        let Some(room) = start
            .checked_add(len)
            .and_then(|end| cache.get_mut(start..end))
        else {
            return RowCache::default();
        };
        for (to, y) in room.chunks_exact_mut(row_len.max(1)).zip(rows.clone()) {
            match view.row(y) {
                Some(from) => unit_row(from, to, luma),
                None => return RowCache::default(),
            }
        }
        *used = start + len;
        RowCache {
            start,
            first: rows.start,
            rows: rows.len(),
        }
    }
}

/// Matching on luminance ([`SweepColor::Gray`]): the views' interleaved `channels`, of
/// which the first `channels.min(3)` (the colour channels, as the RGB matching's) are
/// averaged.
#[derive(Clone, Copy)]
struct Luma {
    channels: usize,
}

impl Luma {
    /// The luminance matching of views with `channels` interleaved samples under
    /// `params`: with [`SweepColor::Gray`] and more than one channel (one channel is
    /// matched as it is).
    fn of(params: &PlaneSweepParams, channels: usize) -> Option<Luma> {
        (params.color == SweepColor::Gray && channels != 1).then_some(Luma { channels })
    }

    /// Values per pixel that the sweep matches (and keeps in a band's converted rows)
    /// of views with `channels` interleaved samples: one with `luma`, else every sample.
    fn values(luma: Option<Luma>, channels: usize) -> usize {
        if luma.is_some() {
            1
        } else {
            channels
        }
    }
}

/// A view's row `from` in unit intensity into `to` ([`Sample::to_unit`]): its samples as
/// they are, or with `luma` one value per pixel, the mean of its colour channels (the
/// same bits wherever a row is converted).
fn unit_row<S: Sample>(from: &[S], to: &mut [f32], luma: Option<Luma>) {
    match luma {
        None => {
            for (t, s) in to.iter_mut().zip(from) {
                *t = s.to_unit();
            }
        }
        // The usual channel counts as literals: `luma_row` is inlined, so the pixel's
        // width is known to the compiler and the loop over its channels unrolls (the
        // loop with a run-time width costs more instructions than the one-channel
        // matching it feeds, docs/stages/sweep.md).
        Some(Luma { channels: 3 }) => luma_row(from, to, 3),
        Some(Luma { channels: 4 }) => luma_row(from, to, 4),
        Some(Luma { channels }) => luma_row(from, to, channels),
    }
}

/// [`unit_row`]'s luminance for pixels of `channels` interleaved samples.
#[inline(always)]
fn luma_row<S: Sample>(from: &[S], to: &mut [f32], channels: usize) {
    let used = channels.min(3);
    let scale = mean_scale::<S>(used);
    for (t, px) in to.iter_mut().zip(from.chunks_exact(channels.max(1))) {
        *t = pixel_mean(px.get(..used).unwrap_or(px), scale);
    }
}

/// What [`pixel_mean`] multiplies the sum of `used` samples by: `1/used`, and for 8-bit
/// levels, summed as they are, `1/255` as well.
fn mean_scale<S: Sample>(used: usize) -> f32 {
    let used = used.max(1) as f32;
    if S::IS_U8 {
        1.0 / (255.0 * used)
    } else {
        1.0 / used
    }
}

/// The mean of a pixel's colour `channels` in unit intensity (`scale` from
/// [`mean_scale`]): 8-bit levels summed as integers (exact) and scaled once, other
/// samples summed in unit intensity in channel order.
#[inline(always)]
fn pixel_mean<S: Sample>(channels: &[S], scale: f32) -> f32 {
    if S::IS_U8 {
        let sum = channels.iter().fold(0u32, |a, s| a + u32::from(s.level()));
        sum as f32 * scale
    } else {
        channels.iter().fold(0.0f32, |a, s| a + s.to_unit()) * scale
    }
}

/// Estimates rows `rows` (at most [`BAND_ROWS`]) of the disparity of `lf`'s centre view
/// over the hypotheses of `range` (`(min, max)`, px) into `out` (one value per pixel of
/// the rows), with `scratch` ([`scratch_len`] `f32` elements). The per-pixel candidate
/// is not computed: [`estimate_rows_with_candidate`] writes it too.
pub fn estimate_rows<S: Sample>(
    setup: Setup<'_, PlaneSweepParams>,
    range: (f32, f32),
    lf: &LightField<'_, S>,
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [f32],
) -> Result<()> {
    let out = SweepOut {
        map: out,
        candidate: None,
    };
    estimate_band(setup, range, lf, rows, out, scratch, true)
}

/// [`estimate_rows`] that also writes the per-pixel candidate
/// ([`PlaneSweepParams::candidate`], which must be on) into `out.candidate`. The map is
/// the same bits as without it.
pub fn estimate_rows_with_candidate<S: Sample>(
    setup: Setup<'_, PlaneSweepParams>,
    range: (f32, f32),
    lf: &LightField<'_, S>,
    rows: Range<usize>,
    out: SweepOut<'_>,
    scratch: &mut [f32],
) -> Result<()> {
    if setup.params().candidate == 0 || out.candidate.is_none() {
        return Err(Error::InvalidParameter {
            name: "sweep.candidate",
            reason: "is off (0) or has no output: set a window side (1, 3, …) and give the candidate's rows",
        });
    }
    estimate_band(setup, range, lf, rows, out, scratch, true)
}

/// [`estimate_rows`], converting the views' rows once for the band into the scratch
/// (`keep_rows`) or per hypothesis as they are read: the same bits either way.
fn estimate_band<S: Sample>(
    setup: Setup<'_, PlaneSweepParams>,
    range: (f32, f32),
    lf: &LightField<'_, S>,
    rows: Range<usize>,
    out: SweepOut<'_>,
    scratch: &mut [f32],
    keep_rows: bool,
) -> Result<()> {
    let SweepOut {
        map: out,
        mut candidate,
    } = out;
    let layout = setup.layout();
    if lf.layout() != layout {
        return Err(Error::InvalidParameter {
            name: "plan",
            reason: "was made for a different light-field layout: build it from this light field",
        });
    }
    let params = setup.params();
    let (width, height, channels) = (layout.width, layout.height, layout.channels);
    if rows.start > rows.end || rows.end > height || rows.len() > BAND_ROWS {
        return Err(Error::InvalidParameter {
            name: "rows",
            reason: "must be a run of at most BAND_ROWS rows inside the image",
        });
    }
    let len = checked_product(&[rows.len(), width], "a band of the plane sweep")?;
    if params.candidate == 0 {
        candidate = None;
    }
    for (what, got) in [
        ("the plane sweep's disparity", out.disparity.len()),
        ("the plane sweep's confidence", out.confidence.len()),
        (
            "the plane sweep's candidate",
            candidate.as_deref().map_or(len, <[f32]>::len),
        ),
    ] {
        if got != len {
            return Err(Error::OutputSize {
                what,
                needed: len,
                got,
            });
        }
    }
    // Without an output for it the candidate's volume is not computed (its scratch is
    // left unused).
    check_scratch(scratch_len(setup), scratch.len())?;
    let (min, max) = range;
    if !(min.is_finite() && max.is_finite() && min <= max) {
        return Err(Error::InvalidParameter {
            name: "range",
            reason: "must be finite with min ≤ max",
        });
    }
    if rows.is_empty() {
        return Ok(());
    }

    let grid = lf.grid();
    let (r0, c0) = grid.center();
    let centre = lf.center_view();
    let mut views: heapless::Vec<SweepView<'_, S>, { 2 * crate::lightfield::GRID_MAX }> =
        heapless::Vec::new();
    for c in (0..grid.cols).filter(|&c| c != c0) {
        let view = lf.view(r0, c)?;
        let u = c as f32 - c0 as f32;
        views
            .push(SweepView {
                view,
                u,
                v: 0.0,
                group: 0,
                shift: Shift::default(),
                rows: RowCache::default(),
            })
            .map_err(|_| Error::SizeOverflow { what: "the views" })?;
    }
    for r in (0..grid.rows).filter(|&r| r != r0) {
        let view = lf.view(r, c0)?;
        let v = r as f32 - r0 as f32;
        views
            .push(SweepView {
                view,
                u: 0.0,
                v,
                group: 1,
                shift: Shift::default(),
                rows: RowCache::default(),
            })
            .map_err(|_| Error::SizeOverflow { what: "the views" })?;
    }

    let r = params.radius;
    let tau = params.truncate;
    // With luminance matching one value per pixel: the matched rows are a channel
    // wide, and the per-hypothesis conversion of uncached views has room in the
    // scratch of the interleaved rows (`(GROUPS + 1)·channels ≥ GROUPS + 3` rows).
    let luma = Luma::of(params, channels);
    let matched = Luma::values(luma, channels);
    // The mean of three channels carries a third of the noise variance: its difference
    // is truncated at `τ/√3`, the same multiple of its noise as a channel's at `τ`.
    let tau = if luma.is_some() {
        tau * GRAY_TRUNCATE
    } else {
        tau
    };
    let row_len = width * matched;
    let (acc, rest) = take(scratch, (GROUPS + 1) * width * channels)?;
    let (sums, rest) = take(rest, GROUPS * width)?;
    let sums = ints(sums)?;
    let line = params.line * r;
    let region = rows.start.saturating_sub(line)..(rows.end + line).min(height);
    let mut rest = rest;
    let mut volumes: heapless::Vec<Volume<'_>, MOST_VOLUMES> = heapless::Vec::new();
    let small = params.candidate / 2;
    let kinds = [
        (Source::All, (r, r)),
        (Source::Horizontal, (line, 0)),
        (Source::Vertical, (0, line)),
        (Source::Horizontal, (0, line)),
        (Source::Vertical, (line, 0)),
        // The per-pixel candidate: every view in a small square (last).
        (Source::All, (small, small)),
    ];
    let used = if luma.is_some() { 1 } else { channels.min(3) };
    let taps = kinds
        .iter()
        .map(|&(_, (rx, ry))| (2 * rx + 1) * (2 * ry + 1))
        .max()
        .unwrap_or(1);
    let scale = fixed_scale(taps, views.len() * used, tau);
    let kept = if candidate.is_some() {
        MOST_VOLUMES
    } else {
        VOLUMES
    };
    let pad = padding(params);
    for (source, radii) in kinds.into_iter().take(kept) {
        let (volume, tail) = Volume::take(
            rest,
            source,
            radii,
            width + 2 * pad,
            region.len() * width,
            len,
        )?;
        rest = tail;
        volumes.push(volume).map_err(|_| Error::SizeOverflow {
            what: "the volumes",
        })?;
    }

    let (count, spacing) = hypotheses(params.step, min, max);

    // The band's rows of every view in unit intensity, converted once for all
    // hypotheses: the centre's and the row views' rows of the region, each column
    // view's rows that the region reaches at any hypothesis.
    let cache: &mut [f32] = if keep_rows { rest } else { &mut [] };
    let mut used_cache = 0;
    let centre_rows = RowCache::fill(
        &centre,
        region.clone(),
        cache,
        &mut used_cache,
        row_len,
        luma,
    );
    for sv in views.iter_mut() {
        let reach = if sv.v == 0.0 {
            region.clone()
        } else {
            let (mut lo, mut hi) = (height, 0);
            let last = region.end.saturating_sub(1);
            for i in 0..count {
                let d = min + i as f32 * spacing;
                let floor = libm::floorf(-d * sv.v);
                lo = lo.min(source_row(region.start, floor, 0.0, height));
                hi = hi.max(source_row(last, floor, 1.0, height));
            }
            lo..(hi + 1).max(lo)
        };
        sv.rows = RowCache::fill(&sv.view, reach, cache, &mut used_cache, row_len, luma);
    }
    let cache = &*cache;

    for i in 0..count {
        let d = min + i as f32 * spacing;
        for sv in views.iter_mut() {
            sv.shift = Shift::at(d, if sv.v == 0.0 { sv.u } else { sv.v });
        }
        for (k, y) in region.clone().enumerate() {
            pixel_costs(&centre, centre_rows, cache, &views, y, tau, luma, acc)?;
            let (across, along) = acc.split_at_checked(row_len).unwrap_or((&[], &[]));
            let (h_sum, v_sum) = take_ints(sums, width)?;
            for (sum, costs) in [(&mut *h_sum, across), (&mut *v_sum, along)] {
                channel_sums(sum, costs, matched, used, scale);
            }
            for volume in volumes.iter_mut() {
                let source = volume.source;
                let body = volume.body_mut(width, k);
                match source {
                    Source::All => {
                        for ((p, &h), &v) in body.iter_mut().zip(h_sum.iter()).zip(v_sum.iter()) {
                            *p = h.wrapping_add(v);
                        }
                    }
                    Source::Horizontal => copy(body, h_sum),
                    Source::Vertical => copy(body, v_sum),
                }
                volume.filter_row(width, k)?;
            }
        }
        let at = i as f32;
        for (b, y) in rows.clone().enumerate() {
            for volume in volumes.iter_mut() {
                let band = b * width..(b + 1) * width;
                if volume.ry == 0 {
                    // A window one row tall: the filtered row itself.
                    let yy = y.saturating_sub(region.start);
                    volume.update_from_row(yy * width..(yy + 1) * width, band, at)?;
                } else {
                    volume.aggregate(width, height, y, region.start, b > 0)?;
                    volume.update_from_column(band, at);
                }
            }
        }
    }

    // Per pixel, the combined volume's winner unless a one-axis volume's stands out
    // more.
    let mean_scale = 1.0 / count as f32;
    for volume in volumes.iter_mut() {
        volume.finish(mean_scale, min, max, spacing);
    }
    let (winners, extra) = volumes
        .split_at_checked(VOLUMES.min(volumes.len()))
        .unwrap_or((&[], &[]));
    let Some((all, axes)) = winners.split_first() else {
        return Err(Error::SizeOverflow {
            what: "the volumes",
        });
    };
    copy(out.disparity, all.best_at);
    copy(out.confidence, all.sum);
    for volume in axes {
        let pixels = out
            .disparity
            .iter_mut()
            .zip(out.confidence.iter_mut())
            .zip(all.sum.iter())
            .zip(volume.best_at.iter().zip(volume.sum.iter()));
        for (((d, c), &ca), (&dv, &cv)) in pixels {
            if cv > ca * params.select && cv > *c {
                *d = dv;
                *c = cv;
            }
        }
    }
    if let (Some(candidate), Some(volume)) = (candidate, extra.first()) {
        // The winner of a flat cost curve is noise: the map's own disparity in its place
        // (which the refinement does not offer).
        let pixels = candidate
            .iter_mut()
            .zip(volume.best_at.iter().zip(volume.sum.iter()))
            .zip(out.disparity.iter());
        for ((k, (&d, &c)), &map) in pixels {
            *k = if c >= CANDIDATE_CONFIDENCE { d } else { map };
        }
    }
    Ok(())
}

/// The views a cost volume sums.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Source {
    All,
    Horizontal,
    Vertical,
}

/// One cost volume's rows and per-pixel winners over a band.
struct Volume<'a> {
    /// Which views it sums.
    source: Source,
    /// Window radii along x and y.
    rx: usize,
    ry: usize,
    /// One row of fixed-point pixel costs, padded by the radius on each side (unused
    /// when `rx` is 0: the costs go straight into their filtered row).
    padded: &'a mut [i32],
    /// Two rows of partial window sums along x ([`window_sum`]).
    partial: [&'a mut [i32]; 2],
    /// Horizontally filtered cost rows of the band and its halo.
    costs: &'a mut [i32],
    /// The window sum of the band row last aggregated ([`Volume::aggregate`]), in its
    /// first `width` values (a padded row's room).
    column: &'a mut [i32],
    best: &'a mut [f32],
    best_at: &'a mut [f32],
    before: &'a mut [f32],
    after: &'a mut [f32],
    last: &'a mut [f32],
    /// The sum of the costs over the hypotheses (then the confidence).
    sum: &'a mut [f32],
}

impl<'a> Volume<'a> {
    fn take(
        s: &'a mut [f32],
        source: Source,
        (rx, ry): (usize, usize),
        padded: usize,
        costs: usize,
        len: usize,
    ) -> Result<(Self, &'a mut [f32])> {
        let (padded, s) = take(s, padded)?;
        let (partial0, s) = take(s, padded.len())?;
        let (partial1, s) = take(s, padded.len())?;
        let (costs, s) = take(s, costs)?;
        let (column, s) = take(s, padded.len())?;
        let (best, s) = take(s, len)?;
        let (best_at, s) = take(s, len)?;
        let (before, s) = take(s, len)?;
        let (after, s) = take(s, len)?;
        let (last, s) = take(s, len)?;
        let (sum, s) = take(s, len)?;
        best.fill(f32::INFINITY);
        best_at.fill(0.0);
        before.fill(f32::INFINITY);
        after.fill(f32::INFINITY);
        last.fill(f32::INFINITY);
        sum.fill(0.0);
        Ok((
            Volume {
                source,
                rx,
                ry,
                padded: ints(padded)?,
                partial: [ints(partial0)?, ints(partial1)?],
                costs: ints(costs)?,
                column: ints(column)?,
                best,
                best_at,
                before,
                after,
                last,
                sum,
            },
            s,
        ))
    }

    /// Where the fixed-point pixel costs of region row `k` go: the unpadded part of the
    /// padded row, or for a window one pixel wide (`rx` 0) the filtered row `k` itself.
    fn body_mut(&mut self, width: usize, k: usize) -> &mut [i32] {
        let r = self.rx;
        if r == 0 {
            let at = k.saturating_mul(width);
            self.costs
                .get_mut(at..at.saturating_add(width))
                .unwrap_or(&mut [])
        } else {
            self.padded.get_mut(r..r + width).unwrap_or(&mut [])
        }
    }

    /// Pads the pixel-cost row with its end values and sums its windows along x into
    /// cost row `k` (a window one pixel wide is already there).
    fn filter_row(&mut self, width: usize, k: usize) -> Result<()> {
        let r = self.rx;
        if r == 0 {
            return Ok(());
        }
        let (lead, tail) = take_ints(self.padded, r)?;
        let (body, trail) = take_ints(tail, width)?;
        lead.fill(body.first().copied().unwrap_or(0));
        trail.fill(body.last().copied().unwrap_or(0));
        let row = self
            .costs
            .get_mut(k * width..(k + 1) * width)
            .ok_or(Error::SizeOverflow { what: "a cost row" })?;
        let [p0, p1] = &mut self.partial;
        window_sum(self.padded, 2 * r + 1, row, p0, p1);
        Ok(())
    }

    /// The window sum over rows `y − r ..= y + r` (clamped to the image) into
    /// `column`: from the previous row's sum (`next`, the band row above `y` was the last
    /// aggregated) by adding the entering row and subtracting the leaving one, else tap
    /// by tap. The sums are exact in integers, so both give the same value.
    fn aggregate(
        &mut self,
        width: usize,
        height: usize,
        y: usize,
        first: usize,
        next: bool,
    ) -> Result<()> {
        let r = self.ry;
        let costs = &*self.costs;
        let row = |yy: usize| {
            let k = yy.min(height.saturating_sub(1)).saturating_sub(first);
            costs
                .get(k * width..(k + 1) * width)
                .ok_or(Error::SizeOverflow { what: "a cost row" })
        };
        if next {
            let enter = row(y + r)?;
            let leave = row(y.saturating_sub(1).saturating_sub(r))?;
            for ((c, &e), &l) in self.column.iter_mut().zip(enter).zip(leave) {
                *c = c.wrapping_sub(l).wrapping_add(e);
            }
        } else {
            for j in 0..=2 * r {
                let src = row((y + j).saturating_sub(r))?;
                if j == 0 {
                    copy(self.column, src);
                } else {
                    for (c, &s) in self.column.iter_mut().zip(src) {
                        *c = c.wrapping_add(s);
                    }
                }
            }
        }
        Ok(())
    }

    /// Takes hypothesis `at`'s costs of band row `band` from the filtered rows `row`
    /// (a window one row tall).
    fn update_from_row(&mut self, row: Range<usize>, band: Range<usize>, at: f32) -> Result<()> {
        let costs = core::mem::take(&mut self.costs);
        let result = match costs.get(row) {
            Some(row) => {
                self.update(row, band, at);
                Ok(())
            }
            None => Err(Error::SizeOverflow { what: "a cost row" }),
        };
        self.costs = costs;
        result
    }

    /// Takes hypothesis `at`'s window sums of band row `band` from `column`.
    fn update_from_column(&mut self, band: Range<usize>, at: f32) {
        let column = core::mem::take(&mut self.column);
        self.update(column, band, at);
        self.column = column;
    }

    /// Takes hypothesis `at`'s window sums `agg` (fixed point) of band row `band`.
    fn update(&mut self, agg: &[i32], band: Range<usize>, at: f32) {
        let best = self.best.get_mut(band.clone()).unwrap_or(&mut []);
        let best_at = self.best_at.get_mut(band.clone()).unwrap_or(&mut []);
        let before = self.before.get_mut(band.clone()).unwrap_or(&mut []);
        let after = self.after.get_mut(band.clone()).unwrap_or(&mut []);
        let last = self.last.get_mut(band.clone()).unwrap_or(&mut []);
        let sum = self.sum.get_mut(band).unwrap_or(&mut []);
        let state = best
            .iter_mut()
            .zip(best_at.iter_mut())
            .zip(before.iter_mut())
            .zip(after.iter_mut())
            .zip(last.iter_mut())
            .zip(sum.iter_mut());
        for ((((((b, bi), be), af), l), s), &a) in state.zip(agg.iter()) {
            // Window sums are below 2³¹ ([`fixed_scale`]): one conversion per lane.
            let a = a as f32;
            let better = a < *b;
            let next = *bi + 1.0 == at;
            *af = if better {
                f32::INFINITY
            } else if next {
                a
            } else {
                *af
            };
            *be = if better { *l } else { *be };
            *b = if better { a } else { *b };
            *bi = if better { at } else { *bi };
            *l = a;
            *s += a;
        }
    }

    /// Turns the winners into disparities (in `best_at`) and confidences (in `sum`).
    fn finish(&mut self, mean_scale: f32, min: f32, max: f32, spacing: f32) {
        let pixels = self.best_at.iter_mut().zip(self.sum.iter_mut()).zip(
            self.best
                .iter()
                .zip(self.before.iter().zip(self.after.iter())),
        );
        for ((bi, c), (&b, (&be, &af))) in pixels {
            let curvature = 2.0 * (be.max(af) - b);
            let offset = if be.is_finite() && af.is_finite() && curvature > 0.0 {
                ((be - af) / curvature).clamp(-0.5, 0.5)
            } else {
                0.0
            };
            *bi = (min + (*bi + offset) * spacing).max(min).min(max);
            let mean = *c * mean_scale;
            *c = if mean > 0.0 {
                (1.0 - b / mean).clamp(0.0, 1.0)
            } else {
                0.0
            };
        }
    }
}

/// Largest window sum of fixed-point costs ([`fixed_scale`]): half the range of `i32`,
/// leaving room for the rounding of each pixel's cost.
const WINDOW_LIMIT: f32 = (1u32 << 30) as f32;

/// Largest fixed-point cost of a pixel ([`fixed_scale`]): half of `2²³`, below which
/// [`fixed`] rounds exactly.
const PIXEL_LIMIT: f32 = (1u32 << 22) as f32;

/// `2²³`: an `f32` in `[2²³, 2²⁴)` holds whole numbers, its low mantissa bits the
/// integer.
const ROUNDING: f32 = (1u32 << 23) as f32;

/// The fixed-point scale of the pixel costs: a pixel's cost, the sum of `terms`
/// truncated differences (every view and channel, each at most `tau`), stays below
/// [`PIXEL_LIMIT`], and a window of `taps` such pixels below [`WINDOW_LIMIT`], so the
/// window sums never overflow `i32` and convert to `f32` in one instruction. For the
/// defaults (9×9 views, RGB, `τ` 0.1) one unit is 1.1·10⁻⁶ of a pixel's cost (whose
/// typical values are 0.1–2).
fn fixed_scale(taps: usize, terms: usize, tau: f32) -> f32 {
    let per_pixel = (WINDOW_LIMIT / taps.max(1) as f32).min(PIXEL_LIMIT);
    per_pixel / (terms.max(1) as f32 * tau)
}

/// A pixel's summed cost in fixed point, rounded to the nearest unit (ties to even):
/// `cost · scale` lies in `[0, 2²³)` ([`fixed_scale`]; the differences are truncated,
/// so `cost` is finite and ≥ 0), where adding `2²³` leaves the rounded integer in the
/// mantissa. Three vector instructions per eight lanes, where `as i32` (saturating) is
/// not vectorised.
#[inline(always)]
fn fixed(cost: f32, scale: f32) -> i32 {
    ((cost * scale + ROUNDING).to_bits() as i32).wrapping_sub(ROUNDING.to_bits() as i32)
}

/// Per pixel, the sum of the first `used` of its `channels` interleaved samples, in
/// channel order (the common layouts unrolled), in fixed point at `scale`.
fn channel_sums(sum: &mut [i32], costs: &[f32], channels: usize, used: usize, scale: f32) {
    match (channels, used) {
        (3, 3) => {
            for (s, px) in sum.iter_mut().zip(costs.chunks_exact(3)) {
                if let [a, b, c] = *px {
                    *s = fixed(a + b + c, scale);
                }
            }
        }
        (1, 1) => {
            for (s, &c) in sum.iter_mut().zip(costs) {
                *s = fixed(c, scale);
            }
        }
        _ => {
            for (s, px) in sum.iter_mut().zip(costs.chunks_exact(channels.max(1))) {
                *s = fixed(px.iter().take(used).sum(), scale);
            }
        }
    }
}

/// `out[x] = Σ a[x + j]` over `j < n` (`a` at least `out.len() + n − 1` long): by
/// doubling, the sums of 2, 4, 8, … taps each one pass over the previous (in `p0`, `p1`
/// in turn), and per set bit of `n` one pass adding that many taps to `out` (the first
/// two in one pass). Integer sums are exact, so the order of the taps does not matter.
fn window_sum(a: &[i32], n: usize, out: &mut [i32], p0: &mut [i32], p1: &mut [i32]) {
    let (mut current, mut spare) = (p0, p1);
    // `span` taps per sum; the sums start at `a` itself.
    let mut span = 1;
    let mut from_a = true;
    let mut offset = 0;
    // `out` holds nothing yet; `a` is its first term, still to be added (bit 0).
    let (mut empty, mut a_pending) = (true, false);
    loop {
        let sums: &[i32] = if from_a { a } else { current };
        if n & span != 0 {
            let src = sums.get(offset..).unwrap_or(&[]);
            if from_a {
                a_pending = true;
            } else if a_pending {
                for ((o, &x), &s) in out.iter_mut().zip(a).zip(src) {
                    *o = x.wrapping_add(s);
                }
                a_pending = false;
                empty = false;
            } else if empty {
                copy(out, src);
                empty = false;
            } else {
                for (o, &s) in out.iter_mut().zip(src) {
                    *o = o.wrapping_add(s);
                }
            }
            offset += span;
        }
        if span > n / 2 {
            break;
        }
        let ahead = sums.get(span..).unwrap_or(&[]);
        for ((t, &l), &h) in spare.iter_mut().zip(sums).zip(ahead) {
            *t = l.wrapping_add(h);
        }
        core::mem::swap(&mut current, &mut spare);
        from_a = false;
        span *= 2;
    }
    if a_pending {
        copy(out, a);
    }
}

/// Copies what `from` and `to` have in common (no length check that could panic).
fn copy<T: Copy>(to: &mut [T], from: &[T]) {
    for (t, &f) in to.iter_mut().zip(from) {
        *t = f;
    }
}

/// The first `n` elements of `s` and the rest; a too-short slice is an error.
fn take(s: &mut [f32], n: usize) -> Result<(&mut [f32], &mut [f32])> {
    let got = s.len();
    s.split_at_mut_checked(n)
        .ok_or(Error::ScratchTooSmall { needed: n, got })
}

/// [`take`] of integer rows.
fn take_ints(s: &mut [i32], n: usize) -> Result<(&mut [i32], &mut [i32])> {
    let got = s.len();
    s.split_at_mut_checked(n)
        .ok_or(Error::ScratchTooSmall { needed: n, got })
}

/// `f32` scratch as integer rows (the same size and alignment: never an error).
fn ints(s: &mut [f32]) -> Result<&mut [i32]> {
    bytemuck::try_cast_slice_mut(s).map_err(|_| Error::SizeOverflow {
        what: "the plane sweep's integer rows",
    })
}

/// Row `y + floor + dy` of a view `height` rows tall, clamped to the image: the first
/// (`dy` 0) and second (`dy` 1) row a column view blends for row `y`.
fn source_row(y: usize, floor: f32, dy: f32, height: usize) -> usize {
    (y as f32 + floor + dy).min(height as f32 - 1.0).max(0.0) as usize
}

/// The weighted, truncated absolute differences of row `y` of the centre view to every
/// view at the current hypothesis (each view's [`SweepView::shift`]), per interleaved
/// sample, summed over the centre row's views into the first row of `acc` and over the
/// centre column's into the second (one value per pixel with `luma`, else per sample).
/// Rows the band kept in `cache` are read from there, the others converted here (with
/// `luma` into two rows of `acc` after the centre row).
#[allow(clippy::too_many_arguments)]
fn pixel_costs<S: Sample>(
    centre: &View<'_, S>,
    centre_rows: RowCache,
    cache: &[f32],
    views: &[SweepView<'_, S>],
    y: usize,
    tau: f32,
    luma: Option<Luma>,
    acc: &mut [f32],
) -> Result<()> {
    let missing = Error::InvalidParameter {
        name: "light field",
        reason: "holds fewer rows than its layout: build the light field from the whole frame",
    };
    let width = centre.width();
    let row_len = width * Luma::values(luma, centre.channels());
    let (acc, rest) = take(acc, GROUPS * row_len)?;
    let (cen, spare) = take(rest, row_len)?;
    let cen = match centre_rows.row(cache, y, row_len) {
        Some(row) => row,
        None => {
            // The centre row in unit intensity, converted once for every view.
            let c_row = centre.row(y).ok_or(missing)?;
            unit_row(c_row, cen, luma);
            &*cen
        }
    };
    // The first view of a group stores its terms, the others add theirs (bit-identical
    // to adding to zero: the terms are never −0); a group without views is zeroed.
    let mut seen = [false; GROUPS];
    for sv in views {
        let acc = acc
            .get_mut(sv.group * row_len..(sv.group + 1) * row_len)
            .ok_or(Error::ScratchTooSmall {
                needed: GROUPS * row_len,
                got: 0,
            })?;
        let first = match seen.get_mut(sv.group) {
            Some(seen) => !core::mem::replace(seen, true),
            None => false,
        };
        let read = Read {
            cache,
            luma,
            missing,
        };
        if first {
            view_costs::<S, true>(sv, read, cen, y, tau, acc, spare)?;
        } else {
            view_costs::<S, false>(sv, read, cen, y, tau, acc, spare)?;
        }
    }
    for (group, seen) in acc.chunks_mut(row_len.max(1)).zip(seen) {
        if !seen {
            group.fill(0.0);
        }
    }
    Ok(())
}

/// `x.min(tau)` as one `minps`: `x` when below `tau`, else `tau` (also for a NaN `x`,
/// as `f32::min` gives), the same bits as `f32::min` for the non-negative `x` and
/// positive `tau` here without its extra NaN test.
#[inline(always)]
fn truncated(x: f32, tau: f32) -> f32 {
    if x < tau {
        x
    } else {
        tau
    }
}

/// Adds `term` to `a`, or stores it for a group's first view.
#[inline(always)]
fn put<const FIRST: bool>(a: &mut f32, term: f32) {
    if FIRST {
        *a = term;
    } else {
        *a += term;
    }
}

/// Where [`view_costs`] reads a view's rows: the band's converted rows, the
/// luminance matching if on, the error for a row the view lacks.
#[derive(Clone, Copy)]
struct Read<'c> {
    cache: &'c [f32],
    luma: Option<Luma>,
    missing: Error,
}

/// One view's weighted, truncated absolute differences to the centre row `cen` at its
/// current shift into its group's row `acc` (stored if `FIRST`, else added), from the
/// band's converted rows in `read.cache` where kept, else from the view: its samples
/// converted as they are read, or with luminance matching its rows converted into
/// `spare` first ([`unit_row`], the same bits as the kept rows).
fn view_costs<S: Sample, const FIRST: bool>(
    sv: &SweepView<'_, S>,
    read: Read<'_>,
    cen: &[f32],
    y: usize,
    tau: f32,
    acc: &mut [f32],
    spare: &mut [f32],
) -> Result<()> {
    let Read {
        cache,
        luma,
        missing,
    } = read;
    let width = sv.view.width();
    let row_len = width * Luma::values(luma, sv.view.channels());
    let shift = sv.shift;
    if sv.v == 0.0 {
        // Source x = x + t, t = −d·u: the row shifted by ⌊t⌋ and blended by f.
        match sv.rows.row(cache, y, row_len) {
            Some(src) => shifted::<f32, FIRST>(src, width, shift, cen, tau, acc),
            None => {
                let src = sv.view.row(y).ok_or(missing)?;
                if luma.is_some() {
                    let (row, _) = take(spare, row_len)?;
                    unit_row(src, row, luma);
                    shifted::<f32, FIRST>(row, width, shift, cen, tau, acc);
                } else {
                    shifted::<S, FIRST>(src, width, shift, cen, tau, acc);
                }
            }
        }
    } else {
        // Source y + t, t = −d·v: a blend of two rows (clamped to the image).
        let height = sv.view.height();
        let (y0, y1) = (
            source_row(y, shift.floor, 0.0, height),
            source_row(y, shift.floor, 1.0, height),
        );
        match (
            sv.rows.row(cache, y0, row_len),
            sv.rows.row(cache, y1, row_len),
        ) {
            (Some(s0), Some(s1)) => blend::<f32, FIRST>(s0, s1, shift, cen, tau, acc),
            _ => {
                let s0 = sv.view.row(y0).ok_or(missing)?;
                let s1 = sv.view.row(y1).ok_or(missing)?;
                if luma.is_some() {
                    let (r0, rest) = take(spare, row_len)?;
                    let (r1, _) = take(rest, row_len)?;
                    unit_row(s0, r0, luma);
                    unit_row(s1, r1, luma);
                    blend::<f32, FIRST>(r0, r1, shift, cen, tau, acc);
                } else {
                    blend::<S, FIRST>(s0, s1, shift, cen, tau, acc);
                }
            }
        }
    }
    Ok(())
}

/// `min(w·|g·s0 + f·s1 − c|, τ)` per sample into `acc` (stored if `FIRST`, else added):
/// the kernel of every view, on rows in unit intensity (`T = f32`) or converted here.
#[inline(always)]
fn blend<T: Sample, const FIRST: bool>(
    s0: &[T],
    s1: &[T],
    shift: Shift,
    cen: &[f32],
    tau: f32,
    acc: &mut [f32],
) {
    let Shift { f, g, w, .. } = shift;
    for (((a, &p0), &p1), &c) in acc.iter_mut().zip(s0).zip(s1).zip(cen) {
        let value = g * p0.to_unit() + f * p1.to_unit();
        put::<FIRST>(a, truncated(w * libm::fabsf(value - c), tau));
    }
}

/// A row view's costs: its row `src` (`width` pixels) shifted by `⌊t⌋` pixels and
/// blended by `f`, the taps clamped to the row at its ends.
fn shifted<T: Sample, const FIRST: bool>(
    src: &[T],
    width: usize,
    shift: Shift,
    cen: &[f32],
    tau: f32,
    acc: &mut [f32],
) {
    let channels = src.len() / width.max(1);
    let k = shift.floor as isize;
    // Pixels whose two taps x + k and x + k + 1 lie inside the row.
    let lo = (-k).max(0).min(width as isize) as usize;
    let hi = (width as isize - 1 - k)
        .min(width as isize)
        .max(lo as isize) as usize;
    let inner = lo * channels..hi * channels;
    let from = (lo as isize + k).max(0) as usize * channels;
    let s0 = src.get(from..from + inner.len()).unwrap_or(&[]);
    let s1 = src
        .get(from + channels..from + channels + inner.len())
        .unwrap_or(&[]);
    let c_in = cen.get(inner.clone()).unwrap_or(&[]);
    blend::<T, FIRST>(
        s0,
        s1,
        shift,
        c_in,
        tau,
        acc.get_mut(inner).unwrap_or(&mut []),
    );
    // The edges, with the taps clamped to the row: left of `lo` they are the row's first
    // two pixels, from `hi` on its last pixel twice, so per channel one blended value.
    let Shift { f, g, w, .. } = shift;
    let last = width.saturating_sub(1);
    for (edge, (x0, x1)) in [(0..lo, (0, last.min(1))), (hi..width, (last, last))] {
        let mut values = [0.0f32; 4];
        for (ch, value) in values.iter_mut().enumerate().take(channels) {
            let p0 = src.get(x0 * channels + ch).map_or(0.0, |s| s.to_unit());
            let p1 = src.get(x1 * channels + ch).map_or(0.0, |s| s.to_unit());
            *value = g * p0 + f * p1;
        }
        let span = edge.start * channels..edge.end * channels;
        let (Some(a), Some(c)) = (acc.get_mut(span.clone()), cen.get(span)) else {
            continue;
        };
        let n = channels.max(1);
        for (a, c) in a.chunks_exact_mut(n).zip(c.chunks_exact(n)) {
            for ((a, &c), &value) in a.iter_mut().zip(c).zip(&values) {
                put::<FIRST>(a, truncated(w * libm::fabsf(value - c), tau));
            }
        }
    }
}
