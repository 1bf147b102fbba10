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
//! banding and thread count whatever order the taps are added in. Matching on
//! luminance, a band converts the view rows it reads to luminance once before the
//! hypotheses (the centre's and the row views' rows of the band and its halo, each
//! column view's rows that those reach at any hypothesis), so the per-hypothesis pass
//! over a row reads one `f32` value per pixel: the same bits as converting per
//! hypothesis. Per-channel matching reads the views' own samples at every hypothesis
//! (`keeps_rows` says why).
//!
//! # Numbers
//! The stage matches in `f32` and sums the windows in `i32` fixed point whatever the
//! pipeline's scalar type; the winners are kept in `f32` (the window sums converted,
//! exactly up to 2²⁴ and rounded beyond). Its scratch is the run's `f32` map scratch,
//! the integer rows reinterpreted in place.

mod costs;
mod fixedpoint;
mod params;
mod rows;
#[cfg(test)]
pub(crate) mod tests;
mod volume;

use core::ops::Range;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::lightfield::{LightField, Sample};
use crate::setup::{DisparityOut, Setup};

use costs::{pixel_costs, source_row, Shift, SweepView};
use fixedpoint::{channel_sums, fixed_scale};
use rows::{Luma, RowCache};
use volume::{Source, Volume};

pub use params::{PlaneSweepParams, SweepColor, MAX_CANDIDATE, MAX_LINE, MAX_RADIUS};

/// Progress and timing stage name.
pub const STAGE: &str = "sweep";

/// Image rows per band (a part of the schedule's step): the cost rows of a band's halo
/// (`2 · radius`) are computed again by the next band, so a band should be much taller
/// than the window.
pub const BAND_ROWS: usize = 64;

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
/// values per pixel of the band, and with [`SweepColor::Gray`] the views' rows in
/// luminance that a band keeps (`cache_rows` rows of one value per pixel,
/// `keeps_rows`).
pub fn scratch_len(setup: Setup<'_, PlaneSweepParams>) -> usize {
    let layout = setup.layout();
    let (width, channels) = (layout.width, layout.channels);
    let luma = Luma::of(setup.params(), channels);
    let matched = Luma::values(luma, channels);
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
        if keeps_rows(luma) {
            cache_rows(layout.grid, height_rows(layout.height, line), layout.height)
                .saturating_mul(width.saturating_mul(matched))
        } else {
            0
        },
    ];
    parts.iter().fold(0usize, |a, &b| a.saturating_add(b))
}

/// Whether a band converts the views' rows it reads once and keeps them ([`RowCache`]):
/// only to luminance. Per-channel matching reads the views' own rows at every
/// hypothesis: kept rows of `f32` samples are four times the bytes of 8-bit views, and
/// streaming them once per hypothesis, beyond the L2 cache, costs more time than
/// converting each tap (docs/stages/sweep.md, "Kept rows"). Luminance rows are one value
/// per pixel and save the averaging of the channels at every hypothesis.
fn keeps_rows(luma: Option<Luma>) -> bool {
    luma.is_some()
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

/// [`estimate_rows`], converting the views' rows to luminance once for the band into the
/// scratch (`keep_rows`, where [`keeps_rows`]) or per hypothesis as they are read: the
/// same bits either way.
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

    let centre = lf.center_view();
    let mut views = cross_views(lf)?;

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

    // With luminance (`keeps_rows`), the band's rows of every view converted once for
    // all hypotheses: the centre's and the row views' rows of the region, each column
    // view's rows that the region reaches at any hypothesis. Without, every view is
    // read and converted per hypothesis.
    let keep = keep_rows && keeps_rows(luma);
    let cache: &mut [f32] = if keep { rest } else { &mut [] };
    let mut centre_rows = RowCache::default();
    if keep {
        let mut used_cache = 0;
        centre_rows = RowCache::fill(
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
    write_winners(&volumes, params.select, out, candidate)?;
    Ok(())
}

/// The views of the centre row (group 0) and column (group 1) but the centre, with their
/// camera offsets.
fn cross_views<'a, S: Sample>(
    lf: &LightField<'a, S>,
) -> Result<heapless::Vec<SweepView<'a, S>, { 2 * crate::lightfield::GRID_MAX }>> {
    let grid = lf.grid();
    let (r0, c0) = grid.center();
    let mut views: heapless::Vec<SweepView<'_, S>, { 2 * crate::lightfield::GRID_MAX }> =
        heapless::Vec::new();
    // (row, column, camera offset (u, v), group)
    let row_views = (0..grid.cols)
        .filter(|&c| c != c0)
        .map(|c| (r0, c, (c as f32 - c0 as f32, 0.0), 0));
    let column_views = (0..grid.rows)
        .filter(|&r| r != r0)
        .map(|r| (r, c0, (0.0, r as f32 - r0 as f32), 1));
    for (r, c, (u, v), group) in row_views.chain(column_views) {
        views
            .push(SweepView {
                view: lf.view(r, c)?,
                u,
                v,
                group,
                shift: Shift::default(),
                rows: RowCache::default(),
            })
            .map_err(|_| Error::SizeOverflow { what: "the views" })?;
    }
    Ok(views)
}

/// The map from the finished volumes: per pixel the combined volume's winner unless a
/// one-axis volume's confidence exceeds the combined one's times `select` (and the other
/// one-axis volumes'), and the per-pixel candidate where asked for.
fn write_winners(
    volumes: &[Volume<'_>],
    select: f32,
    out: DisparityOut<'_>,
    candidate: Option<&mut [f32]>,
) -> Result<()> {
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
            if cv > ca * select && cv > *c {
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
