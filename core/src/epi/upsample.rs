//! Joint bilateral upsampling of the half-resolution EPI map
//! ([`super::EpiParams::half_resolution`]): each full-resolution pixel `p` takes the
//! weighted mean of the 3×3 half-resolution estimates `q` around it,
//!
//! ```text
//! w(p, q) = s(x) · s(y) · (σ² / (σ² + ‖I(p) − Ī(q)‖²))² · (c(q) + ε)
//! ```
//!
//! `s` a tent over the distance between `p` and `q`'s centre in full-resolution px
//! (`3 − |Δ|`: 2.5, 1.5, 0.5), `I(p)` the centre view's colour, `Ī(q)` its 2×2 mean over
//! `q`'s footprint (unit intensity, at most three channels), `σ` [`UPSAMPLE_SIGMA`], `c`
//! the EPI confidence, `ε` [`CONFIDENCE_FLOOR`]. Across a colour edge the weights of the
//! other side's estimates fall by `(Δ/σ)⁴`, so a depth step lands on its colour edge
//! instead of being smeared over the two full-resolution pixels a half-resolution pixel
//! covers. O(1) per pixel: nine weights.

use core::ops::Range;

use super::EpiParams;
use crate::error::{check_scratch, Error, Result};
use crate::lightfield::{Sample, View};
use crate::setup::{DisparityOut, Setup};

/// Colour scale σ of the upsampling's range weight (unit intensity).
pub const UPSAMPLE_SIGMA: f32 = 0.04;

/// Added to each half-resolution confidence in the weights, so that a window of zero
/// confidence still averages.
const CONFIDENCE_FLOOR: f32 = 1e-3;

/// Channels of the colour guide.
const GUIDE_CHANNELS: usize = 3;

/// Half-resolution rows whose mean colours the full-resolution rows `rows` read.
fn half_rows(rows: &Range<usize>, half_height: usize) -> Range<usize> {
    let first = (rows.start / 2).saturating_sub(1);
    let last = (rows.end.saturating_sub(1) / 2 + 2).min(half_height);
    first..last.max(first)
}

/// `f32` scratch of [`upsample_rows`] for a band of `rows` full-resolution rows.
pub fn upsample_scratch_len(setup: Setup<'_, EpiParams>, rows: usize) -> usize {
    let half_width = setup.layout().width / 2;
    (rows / 2 + 3)
        .saturating_mul(half_width)
        .saturating_mul(GUIDE_CHANNELS)
}

/// The full-resolution disparity and confidence of rows `rows` (row-major into `out`,
/// `rows.len() · width` each) from the half-resolution maps (the first
/// `(width / 2) · (height / 2)` values of `half_disparity` and `half_confidence`,
/// row-major), guided by `centre`. `scratch` needs [`upsample_scratch_len`] values for
/// `rows.len()` rows.
pub fn upsample_rows<S: Sample>(
    setup: Setup<'_, EpiParams>,
    centre: &View<'_, S>,
    half_disparity: &[f32],
    half_confidence: &[f32],
    rows: Range<usize>,
    out: DisparityOut<'_>,
    scratch: &mut [f32],
) -> Result<()> {
    let layout = setup.layout();
    let (width, height) = (layout.width, layout.height);
    let (hw, hh) = (width / 2, height / 2);
    if hw == 0 || hh == 0 || centre.width() != width || centre.height() != height {
        return Err(Error::InvalidParameter {
            name: "half_resolution",
            reason: "needs views of at least 2×2 px and the centre view of the plan's size",
        });
    }
    if rows.start > rows.end || rows.end > height {
        return Err(Error::OutOfRange {
            what: "band end row",
            index: rows.end,
            len: height,
        });
    }
    let half_len = hw * hh;
    for (what, got) in [
        ("the half-resolution disparity", half_disparity.len()),
        ("the half-resolution confidence", half_confidence.len()),
    ] {
        if got < half_len {
            return Err(Error::BufferTooSmall {
                what,
                needed: half_len,
                got,
            });
        }
    }
    let needed = rows.len() * width;
    if out.disparity.len() != needed || out.confidence.len() != needed {
        return Err(Error::OutputSize {
            what: "the upsampled band",
            needed,
            got: out.disparity.len().min(out.confidence.len()),
        });
    }
    check_scratch(upsample_scratch_len(setup, rows.len()), scratch.len())?;

    // The 2×2 mean colour of every half-resolution pixel the band reads.
    let channels = centre.channels().min(GUIDE_CHANNELS);
    let guide_rows = half_rows(&rows, hh);
    let row_len = hw * GUIDE_CHANNELS;
    for (j, means) in guide_rows
        .clone()
        .zip(scratch.chunks_exact_mut(row_len.max(1)))
    {
        let (Some(top), Some(bottom)) = (centre.row(2 * j), centre.row(2 * j + 1)) else {
            continue;
        };
        for (i, mean) in means.chunks_exact_mut(GUIDE_CHANNELS).enumerate() {
            for (c, m) in mean.iter_mut().enumerate() {
                let at = |row: &[S], x: usize| {
                    row.get(x * centre.channels() + c)
                        .map_or(0.0, |s| s.to_unit())
                };
                // Channels the view lacks stay zero, as in the pixel's own colour.
                *m = if c < channels {
                    0.25 * ((at(top, 2 * i) + at(top, 2 * i + 1))
                        + (at(bottom, 2 * i) + at(bottom, 2 * i + 1)))
                } else {
                    0.0
                };
            }
        }
    }

    let sigma2 = UPSAMPLE_SIGMA * UPSAMPLE_SIGMA;
    // Tent weight of a half-resolution neighbour `k − 1` of the pixel's own (`k` in
    // 0..3), for an even and an odd full-resolution coordinate.
    const TENT: [[f32; 3]; 2] = [[1.5, 2.5, 0.5], [0.5, 2.5, 1.5]];
    let out_rows = out
        .disparity
        .chunks_exact_mut(width.max(1))
        .zip(out.confidence.chunks_exact_mut(width.max(1)));
    for (y, (d_row, c_row)) in rows.zip(out_rows) {
        let Some(guide) = centre.row(y) else {
            continue;
        };
        let jy = (y / 2).min(hh - 1);
        // The three half-resolution rows around the pixel's: tent weight, disparity,
        // confidence and mean colours (`None` outside the map).
        let half_row = |ky: usize| {
            let j = (jy + ky).checked_sub(1).filter(|&j| j < hh)?;
            let means = j
                .checked_sub(guide_rows.start)
                .and_then(|r| scratch.get(r * row_len..(r + 1) * row_len))?;
            Some((
                TENT[y % 2][ky],
                half_disparity.get(j * hw..(j + 1) * hw)?,
                half_confidence.get(j * hw..(j + 1) * hw)?,
                means,
            ))
        };
        let near = [half_row(0), half_row(1), half_row(2)];
        let pixels = d_row
            .iter_mut()
            .zip(c_row.iter_mut())
            .zip(guide.chunks_exact(centre.channels().max(1)));
        for (x, ((d, c), px)) in pixels.enumerate() {
            let ix = (x / 2).min(hw - 1);
            let tx = TENT[x % 2];
            let mut colour = [0.0f32; GUIDE_CHANNELS];
            for (v, s) in colour.iter_mut().zip(px.iter().take(channels)) {
                *v = s.to_unit();
            }
            let (mut sum_w, mut sum_d, mut sum_wc, mut sum_c) = (0.0f32, 0.0f32, 0.0f32, 0.0f32);
            for &(wy, hd_row, hc_row, means) in near.iter().flatten() {
                for (kx, &wx) in tx.iter().enumerate() {
                    let Some(i) = (ix + kx).checked_sub(1).filter(|&i| i < hw) else {
                        continue;
                    };
                    let (Some(&[m0, m1, m2]), Some(&hd), Some(&hc)) = (
                        means.get(i * GUIDE_CHANNELS..(i + 1) * GUIDE_CHANNELS),
                        hd_row.get(i),
                        hc_row.get(i),
                    ) else {
                        continue;
                    };
                    let diff2 = ((m0 - colour[0]) * (m0 - colour[0])
                        + (m1 - colour[1]) * (m1 - colour[1]))
                        + (m2 - colour[2]) * (m2 - colour[2]);
                    let range = sigma2 / (sigma2 + diff2);
                    let w = wx * wy * range * range;
                    let wc = w * (hc + CONFIDENCE_FLOOR);
                    sum_w += w;
                    sum_c += w * hc;
                    sum_wc += wc;
                    sum_d += wc * hd;
                }
            }
            *d = if sum_wc > 0.0 { sum_d / sum_wc } else { 0.0 };
            *c = if sum_w > 0.0 { sum_c / sum_w } else { 0.0 };
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{Grid, Layout};
    use crate::setup::TestSetup;

    fn setup(width: usize, height: usize) -> TestSetup<EpiParams> {
        let layout = Layout::packed(Grid { rows: 3, cols: 3 }, width, height, 3);
        TestSetup::new(
            layout,
            EpiParams {
                half_resolution: true,
                ..EpiParams::default()
            },
        )
    }

    #[test]
    fn a_step_on_a_colour_edge_lands_on_it() {
        // Left of x = 19 dark at disparity 1, right bright at disparity −1: the edge falls
        // inside half-resolution pixel 9, whose estimate is wrong for one of its halves.
        let (w, h) = (40, 20);
        let test = setup(w, h);
        let mut view = vec![0u8; w * h * 3];
        for y in 0..h {
            for x in 0..w {
                let v = if x < 19 { 40 } else { 200 };
                view[(y * w + x) * 3..][..3].fill(v);
            }
        }
        let centre = View::new(&view, w, h, 3, w * 3).unwrap();
        let (hw, hh) = (w / 2, h / 2);
        let half_d: Vec<f32> = (0..hw * hh)
            .map(|p| if p % hw < 9 { 1.0 } else { -1.0 })
            .collect();
        let half_c = vec![0.5f32; hw * hh];
        let mut d = vec![0.0f32; w * h];
        let mut c = vec![0.0f32; w * h];
        let mut scratch = vec![0.0f32; upsample_scratch_len(test.setup(), h)];
        upsample_rows(
            test.setup(),
            &centre,
            &half_d,
            &half_c,
            0..h,
            DisparityOut {
                disparity: &mut d,
                confidence: &mut c,
            },
            &mut scratch,
        )
        .unwrap();
        for y in 0..h {
            for x in 0..w {
                let truth = if x < 19 { 1.0 } else { -1.0 };
                let got = d[y * w + x];
                // Pixel 18 (dark) sees the dark half-pixel 8 and the mixed pixel 9, whose
                // mean colour is between: it stays on the dark side.
                assert!(
                    (got - truth).abs() < 0.2,
                    "pixel ({x}, {y}): {got}, truth {truth}"
                );
            }
        }
        assert!(c.iter().all(|&v| (v - 0.5).abs() < 1e-6));
    }

    #[test]
    fn bands_agree_with_the_whole_map_and_bad_sizes_are_errors() {
        let (w, h) = (33, 21);
        let test = setup(w, h);
        let view: Vec<u8> = (0..w * h * 3).map(|i| (i * 37 % 251) as u8).collect();
        let centre = View::new(&view, w, h, 3, w * 3).unwrap();
        let (hw, hh) = (w / 2, h / 2);
        let half_d: Vec<f32> = (0..hw * hh).map(|p| (p % 7) as f32 * 0.3 - 1.0).collect();
        let half_c: Vec<f32> = (0..hw * hh).map(|p| (p % 5) as f32 * 0.2).collect();
        let run = |rows: Range<usize>| {
            let n = rows.len() * w;
            let (mut d, mut c) = (vec![0.0f32; n], vec![0.0f32; n]);
            let mut scratch = vec![0.0f32; upsample_scratch_len(test.setup(), rows.len())];
            upsample_rows(
                test.setup(),
                &centre,
                &half_d,
                &half_c,
                rows,
                DisparityOut {
                    disparity: &mut d,
                    confidence: &mut c,
                },
                &mut scratch,
            )
            .map(|()| (d, c))
        };
        let (whole_d, whole_c) = run(0..h).unwrap();
        let mut banded = (Vec::new(), Vec::new());
        for rows in [0..3, 3..4, 4..21] {
            let (d, c) = run(rows).unwrap();
            banded.0.extend(d);
            banded.1.extend(c);
        }
        assert_eq!(banded, (whole_d, whole_c));
        assert!(matches!(run(5..22), Err(Error::OutOfRange { .. })));
        let mut small = [0.0f32; 1];
        let (mut d, mut c) = (vec![0.0f32; w], vec![0.0f32; w]);
        assert!(matches!(
            upsample_rows(
                test.setup(),
                &centre,
                &half_d,
                &half_c,
                0..1,
                DisparityOut {
                    disparity: &mut d,
                    confidence: &mut c,
                },
                &mut small,
            ),
            Err(Error::ScratchTooSmall { .. })
        ));
    }
}
