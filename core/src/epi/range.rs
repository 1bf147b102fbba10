//! Automatic disparity range: probe every `RANGE_LINE_STEP`-th line of both directions (the
//! one of a linear array) with
//! integer shears over the whole supported range, histogram the confident estimates and
//! keep the outermost 0.3 px windows holding at least 1 % of them (surfaces), widened to
//! the outermost estimates of 1 px windows holding at least 0.5 % of them (thin
//! structures), padded (docs/stages/epi.md).

use super::hypotheses::Hypotheses;
use super::{check_layout, scratch_len, BandEstimator, ColorMode, Direction, EpiParams};
use crate::error::{check_scratch, Result};
use crate::lightfield::{LightField, Sample};
use crate::scalar::Scalar;
use crate::setup::Setup;

/// Every how many lines the range probe looks (16 rather than 8: a third of the probe's
/// time; the HCI ranges moved by at most one 0.05 px bin, docs/stages/epi.md).
pub const RANGE_LINE_STEP: usize = 16;
/// Probed disparities (integer shears ±PROBE_REACH, each accepting ±1 px residuals).
const PROBE_REACH: f32 = 4.0;
/// Only estimates at least this coherent enter the histogram.
const MIN_COHERENCE: f32 = 0.8;
/// Histogram resolution (px).
const BIN: f32 = 0.05;
const BINS: usize = 2 * ((PROBE_REACH + 1.0) / BIN) as usize;
/// Share of confident samples left out on each side, and the padding added back.
const TAIL: f32 = 0.01;
const CLUSTER: usize = 6;
const PAD: f32 = 0.2;
/// Thin structures (wires, bars: a few pixels across) give few confident probe samples,
/// and those scatter over several tenths of a pixel, so no CLUSTER window beyond the
/// surfaces reaches TAIL; a window of SPREAD bins (1 px) holding THIN_TAIL of the
/// samples whose estimate is not shear-exact moves the end out to its outermost sample.
/// 0.3–0.7 % give the same ranges on every measured scene; 0.2 % also widens 256²
/// `relief` (to its wires, which the estimator loses anyway), 1 % loses `thin`'s bars
/// (docs/stages/epi.md).
const SPREAD: usize = 20;
const THIN_TAIL: f32 = 0.005;
/// Samples this close to a line end see clamped (constant) views and are not probed.
const MARGIN: usize = 16;

/// Estimates the disparity range of the scene. `scratch` needs [`scratch_len`] elements.
/// Returns the supported extremes when too few samples are confident to tell.
pub fn estimate_range<T: Scalar, S: Sample>(
    setup: Setup<'_, EpiParams>,
    lf: &LightField<'_, S>,
    scratch: &mut [T],
) -> Result<(f32, f32)> {
    check_layout(setup, lf)?;
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    let probe = Hypotheses::sheared(-PROBE_REACH, PROBE_REACH, 1.0, 1.0)?;
    let mut histogram = Histogram::default();
    // The probe runs on the gray mean of the channels (a third of the work of the colour
    // tensor; the range ends are padded histogram windows, docs/stages/epi.md), on
    // full-resolution lines whatever resolution the EPI stage then runs at (its lines
    // and disparities are the frame's).
    let gray = EpiParams {
        color: ColorMode::Gray,
        half_resolution: false,
        ..*setup.params()
    };
    let gray = setup.with_params(&gray);
    for direction in Direction::BOTH {
        if !direction.exists(setup.layout()) {
            continue;
        }
        let band = BandEstimator::new(gray, probe, lf, direction);
        let (d, c, work) = band.split_scratch(scratch)?;
        let n = direction.line_len(setup.layout());
        let margin = if n > 4 * MARGIN { MARGIN } else { 0 };
        let mut line = RANGE_LINE_STEP / 2;
        while line < direction.lines(setup.layout()) {
            band.line(line, work, d, c)?;
            // `split_scratch` gave lines of `n` values and `margin` ≤ n / 4.
            let inner = margin..n - margin;
            let (d, c) = (
                d.get(inner.clone()).unwrap_or(&[]),
                c.get(inner).unwrap_or(&[]),
            );
            for (&dv, &cv) in d.iter().zip(c) {
                if cv.to_f32() >= MIN_COHERENCE {
                    histogram.add(dv.to_f32());
                }
            }
            line += RANGE_LINE_STEP;
        }
    }
    let limit = PROBE_REACH;
    let Some((lo, hi)) = histogram.ends() else {
        return Ok((-limit, limit));
    };
    let lo = (lo - PAD).clamp(-limit, limit);
    let hi = (hi + PAD).clamp(-limit, limit);
    Ok((lo.min(hi), hi.max(lo)))
}

/// The confident probe estimates, binned over ±(PROBE_REACH + 1) px.
struct Histogram {
    /// Every confident estimate.
    all: [u32; BINS],
    /// The shear-exact ones, per integer −REACH…REACH (they lie nowhere else): an
    /// estimate bit-exactly on an integer shear comes from a residual slope of exactly
    /// zero there (an exactly zero mixed term of the smoothed tensor), not from the
    /// texture's own slope. Measured on the far backgrounds of `thin`, the 512² `dusk`
    /// and `hall` and the Lytro capture: 0.3–0.6 % of the samples, at integers where
    /// nothing lies (docs/stages/epi.md). They may hold a surface's samples too (a
    /// noise-free plane at an integer disparity), so only the thin-structure rule, which
    /// no surface needs, leaves them out. Kept per integer rather than as a second
    /// histogram: the firmware's stack holds this.
    exact: [u32; EXACT],
    /// The bin of each integer of `exact`.
    exact_bin: [usize; EXACT],
    total: u64,
    exact_total: u64,
}

/// Integers within ±(PROBE_REACH + 1).
const EXACT: usize = 2 * (PROBE_REACH as usize + 1) + 1;

/// The bin of estimate `d` (px). Truncation toward zero and `min` keep it inside:
/// estimates lie within ±(PROBE_REACH + 1) (integer shears ±PROBE_REACH, residuals ±1).
fn bin(d: f32) -> usize {
    (((d + PROBE_REACH + 1.0) / BIN) as usize).min(BINS - 1)
}

impl Default for Histogram {
    fn default() -> Self {
        Self {
            all: [0; BINS],
            exact: [0; EXACT],
            exact_bin: core::array::from_fn(|slot| bin(slot as f32 - PROBE_REACH - 1.0)),
            total: 0,
            exact_total: 0,
        }
    }
}

impl Histogram {
    /// Adds one confident estimate (px).
    fn add(&mut self, d: f32) {
        if let Some(h) = self.all.get_mut(bin(d)) {
            *h += 1;
        }
        self.total += 1;
        // |d| ≤ PROBE_REACH + 1: the cast is exact for every integer it can hold.
        let k = d as i32;
        if d == k as f32 {
            let slot = (k + PROBE_REACH as i32 + 1).clamp(0, EXACT as i32 - 1) as usize;
            if let Some(h) = self.exact.get_mut(slot) {
                *h += 1;
            }
            self.exact_total += 1;
        }
    }

    /// The samples of bin `b` that are not shear-exact.
    fn resolved(&self, b: usize) -> u32 {
        let all = self.all.get(b).copied().unwrap_or(0);
        let exact = self
            .exact_bin
            .iter()
            .zip(&self.exact)
            .filter(|&(&at, _)| at == b)
            .map(|(_, &n)| n)
            .sum::<u32>();
        all.saturating_sub(exact)
    }

    /// The range's ends before padding (px), or `None` when too few samples are
    /// confident to tell.
    fn ends(&self) -> Option<(f32, f32)> {
        if self.total < 64 {
            return None;
        }
        let reach = PROBE_REACH + 1.0;
        // Outliers scatter thinly over many bins while surfaces pile up: the surfaces'
        // ends are the outermost windows of CLUSTER bins that hold at least TAIL of the
        // samples (first bin from below, one past the last from above).
        let all = |b: usize| self.all.get(b).copied().unwrap_or(0);
        let (mut lo, mut hi) = outermost_windows(all, CLUSTER, share(self.total, TAIL))
            .map(|(first, last)| (first, last + CLUSTER))
            .unwrap_or((BINS / 2, BINS / 2));
        // Thin structures beyond those ends: the outermost non-empty bins of the outermost
        // SPREAD windows holding THIN_TAIL of the samples that are not shear-exact, counting
        // only samples outside the surfaces' range (a lone outlier beside a surface never
        // makes up such a window).
        let resolved_total = self.total - self.exact_total;
        if resolved_total >= 64 {
            let surfaces = lo..hi;
            let beyond = |b: usize| -> u32 {
                if surfaces.contains(&b) {
                    0
                } else {
                    self.resolved(b)
                }
            };
            let need = share(resolved_total, THIN_TAIL);
            if let Some((first, last)) = outermost_windows(beyond, SPREAD, need) {
                if let Some(b) = (first..first + SPREAD).find(|&b| beyond(b) > 0) {
                    lo = lo.min(b);
                }
                if let Some(b) = (last..last + SPREAD).rev().find(|&b| beyond(b) > 0) {
                    hi = hi.max(b + 1);
                }
            }
        }
        let at = |edge: usize| edge as f32 * BIN - reach;
        Some((at(lo), at(hi)))
    }
}

/// `share` of `total`, at least one sample.
fn share(total: u64, share: f32) -> u64 {
    ((total as f32 * share) as u64).max(1)
}

/// The first bins of the lowest and the highest windows of `width` bins of a histogram
/// (`count` of each bin) that hold at least `need` samples, or `None` when no window does.
/// One running sum over the bins (a bin enters, the one `width` back leaves): each bin
/// is read twice rather than `width` times, and the loop stays scalar, which valgrind
/// 3.19 decodes (it cannot decode the `vmovq` of a vectorised window sum in an
/// `x86-64-v3` build).
fn outermost_windows(
    count: impl Fn(usize) -> u32,
    width: usize,
    need: u64,
) -> Option<(usize, usize)> {
    let width = width.clamp(1, BINS);
    let (mut low, mut high) = (None, None);
    let mut mass = 0u64;
    for b in 0..BINS {
        mass += u64::from(count(b));
        if let Some(left) = b.checked_sub(width) {
            mass -= u64::from(count(left));
        }
        if let Some(first) = (b + 1).checked_sub(width) {
            if mass >= need {
                low.get_or_insert(first);
                high = Some(first);
            }
        }
    }
    Some((low?, high?))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `count` estimates spread evenly over `[from, to)`, none shear-exact.
    fn spread(h: &mut Histogram, from: f32, to: f32, count: usize) {
        for i in 0..count {
            h.add(from + (to - from) * (i as f32 + 0.37) / count as f32);
        }
    }

    /// A surface over −0.5…0.5 px: 10 000 samples.
    fn surface() -> Histogram {
        let mut h = Histogram::default();
        spread(&mut h, -0.5, 0.5, 10_000);
        h
    }

    /// The ends of [`surface`]: the outermost CLUSTER windows still holding TAIL reach
    /// a little beyond it.
    fn surface_ends() -> (f32, f32) {
        surface().ends().unwrap()
    }

    #[test]
    fn a_surface_alone_keeps_its_windows_ends() {
        let (lo, hi) = surface_ends();
        assert!(
            (-0.8..=-0.5).contains(&lo) && (0.5..=0.8).contains(&hi),
            "[{lo}, {hi}]"
        );
    }

    #[test]
    fn a_thin_structure_beyond_the_tail_is_covered() {
        // 0.7 % of the samples scattered over 1.2…1.8 px: under TAIL in every CLUSTER
        // window, but a SPREAD window holds more than THIN_TAIL.
        let mut h = surface();
        spread(&mut h, 1.2, 1.8, 70);
        let (lo, hi) = h.ends().unwrap();
        assert!(
            (1.75..=1.85).contains(&hi) && lo == surface_ends().0,
            "[{lo}, {hi}]"
        );
        // Below THIN_TAIL (0.3 %) it stays out.
        let mut h = surface();
        spread(&mut h, 1.2, 1.8, 30);
        assert_eq!(h.ends().unwrap(), surface_ends());
    }

    #[test]
    fn scattered_outliers_of_the_same_mass_are_not() {
        // The same 70 samples scattered over 1…4 px and −4…−1 px: about 0.23 % a px.
        let mut h = surface();
        spread(&mut h, 1.0, 4.0, 70);
        spread(&mut h, -4.0, -1.0, 70);
        assert_eq!(h.ends().unwrap(), surface_ends());
    }

    #[test]
    fn lone_outliers_beside_a_surface_do_not_widen_it() {
        // A few samples within a SPREAD window of the surface's end: the surface's own
        // samples do not make up that window.
        let mut h = surface();
        for d in [0.8, 1.1, 1.4, -0.9, -1.3] {
            h.add(d);
        }
        assert_eq!(h.ends().unwrap(), surface_ends());
    }

    #[test]
    fn shear_exact_estimates_make_no_thin_structure_but_count_as_surface() {
        // 0.7 % of the samples bit-exactly on the shear 2 (the probe's artefact).
        let mut h = surface();
        for _ in 0..70 {
            h.add(2.0);
        }
        assert_eq!(h.ends().unwrap(), surface_ends());
        // A surface at an integer disparity (a noise-free plane) still counts.
        for _ in 0..500 {
            h.add(3.0);
        }
        let (_, hi) = h.ends().unwrap();
        assert!((3.0..=3.35).contains(&hi), "{hi}");
    }

    #[test]
    fn too_few_samples_tell_nothing() {
        let mut h = Histogram::default();
        spread(&mut h, 0.0, 1.0, 63);
        assert!(h.ends().is_none());
        h.add(0.5);
        assert!(h.ends().is_some());
    }
}
