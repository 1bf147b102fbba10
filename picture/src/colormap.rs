//! Colour-mapped disparity images with a legend bar.
//!
//! The colour map is Turbo (Mikhailov, Google AI blog 2019), evaluated from its
//! published degree-5 polynomial fit per channel. Larger disparity (nearer) is warmer.

use crate::font;
pub use crate::rgb::Rgb;

/// Per-channel polynomial coefficients of Turbo, constant term first.
const TURBO: [[f64; 6]; 3] = [
    [
        0.135_721_38,
        4.615_392_6,
        -42.660_322_58,
        132.131_082_34,
        -152.942_393_96,
        59.286_379_43,
    ],
    [
        0.091_402_61,
        2.194_188_39,
        4.842_966_58,
        -14.185_033_33,
        4.277_298_57,
        2.829_566_04,
    ],
    [
        0.106_673_3,
        12.641_946_08,
        -60.582_048_36,
        110.362_767_71,
        -89.903_109_12,
        27.348_249_73,
    ],
];

/// Colour of NaN and infinite disparities.
pub const INVALID: [u8; 3] = [128, 128, 128];

/// Turbo at `t` in `[0, 1]` (clamped) as 8-bit RGB.
pub fn turbo(t: f32) -> [u8; 3] {
    let t = if t.is_finite() {
        f64::from(t.clamp(0.0, 1.0))
    } else {
        0.0
    };
    TURBO.map(|c| {
        let v = c.iter().rev().fold(0.0f64, |acc, &k| acc * t + k);
        (v.clamp(0.0, 1.0) * 255.0).round() as u8
    })
}

/// The finite minimum and maximum of `values`, or `None` when none is finite.
pub fn finite_range(values: &[f32]) -> Option<(f32, f32)> {
    values
        .iter()
        .filter(|v| v.is_finite())
        .fold(None, |acc, &v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// Maps each value to RGB over `[min, max]`.
pub fn colorize(values: &[f32], min: f32, max: f32) -> Vec<u8> {
    let span = if max > min { max - min } else { 1.0 };
    values
        .iter()
        .flat_map(|&v| {
            if v.is_finite() {
                turbo((v - min) / span)
            } else {
                INVALID
            }
        })
        .collect()
}

/// A tick label: two decimals, or scientific notation for very large values.
pub fn tick_label(v: f32) -> String {
    if v.abs() >= 1e5 {
        format!("{v:.2e}")
    } else {
        format!("{v:.2}")
    }
}

const MARGIN: usize = 10;
const BAR_WIDTH: usize = 20;
const TICK: usize = 5;
const BACKGROUND: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [0, 0, 0];

/// The disparity map colour-mapped over `[min, max]`, with a vertical legend bar to
/// its right (max at the top, min at the bottom) labelled with both values.
pub fn with_legend(width: usize, height: usize, values: &[f32], min: f32, max: f32) -> Rgb {
    let scale = (height / 256).clamp(1, 4);
    let glyph_h = font::HEIGHT * scale;
    let labels = [tick_label(max), tick_label(min)];
    let label_w = labels
        .iter()
        .map(|l| font::text_width(l, scale))
        .max()
        .unwrap_or(0);
    let canvas_h = height.max(2 * glyph_h + 2 * MARGIN + 8);
    let bar_x = width + MARGIN;
    let label_x = bar_x + BAR_WIDTH + TICK + 3;
    let canvas_w = label_x + label_w + MARGIN;
    let mut out = Rgb::new(canvas_w, canvas_h, BACKGROUND);
    let colours = colorize(values, min, max);
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) * 3;
            if let Some(c) = colours.get(i..i + 3) {
                out.put(x, y, [c[0], c[1], c[2]]);
            }
        }
    }
    // The bar spans from the middle of the top label to the middle of the bottom one.
    let top = MARGIN + glyph_h / 2;
    let bottom = canvas_h - MARGIN - glyph_h / 2;
    let span = (bottom - top).max(1);
    for y in top..=bottom {
        let colour = turbo(1.0 - (y - top) as f32 / span as f32);
        for x in bar_x..bar_x + BAR_WIDTH {
            out.put(x, y, colour);
        }
    }
    for (label, y) in labels.iter().zip([top, bottom]) {
        for x in bar_x + BAR_WIDTH..bar_x + BAR_WIDTH + TICK {
            out.put(x, y, INK);
        }
        font::draw(&mut out, label, label_x, y - glyph_h / 2, scale, INK);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn turbo_runs_from_dark_blue_through_green_to_red() {
        let lo = turbo(0.0);
        let mid = turbo(0.5);
        let hi = turbo(1.0);
        assert!(lo.iter().all(|&c| c < 70), "{lo:?}");
        assert!(
            mid[1] > 200 && mid[1] > mid[0] && mid[1] > mid[2],
            "{mid:?}"
        );
        assert!(hi[0] > 100 && hi[1] < 30 && hi[2] < 30, "{hi:?}");
        // Blue peaks early, red late.
        let blue_peak = (0..=100)
            .max_by_key(|&i| turbo(i as f32 / 100.0)[2])
            .unwrap();
        let red_peak = (0..=100)
            .max_by_key(|&i| turbo(i as f32 / 100.0)[0])
            .unwrap();
        assert!(blue_peak < 30 && red_peak > 60, "{blue_peak} {red_peak}");
    }

    #[test]
    fn legend_labels_and_bar() {
        let values: Vec<f32> = (0..64 * 48)
            .map(|i| (i % 64) as f32 / 63.0 * 2.0 - 1.0)
            .collect();
        let img = with_legend(64, 48, &values, -1.0, 1.0);
        assert_eq!(img.get(0, 0), Some(turbo(0.0)));
        assert_eq!(img.get(63, 0), Some(turbo(1.0)));
        let bar_x = 64 + MARGIN + BAR_WIDTH / 2;
        let top = (0..img.height)
            .find(|&y| img.get(bar_x, y) != Some(BACKGROUND))
            .unwrap();
        assert_eq!(img.get(bar_x, top), Some(turbo(1.0)));
        // Some ink in the label column.
        let label_x = 64 + MARGIN + BAR_WIDTH + TICK + 3;
        let ink = (label_x..img.width)
            .flat_map(|x| (0..img.height).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get(x, y) == Some(INK))
            .count();
        assert!(ink > 20, "{ink}");
        assert_eq!(
            img.get(1, 1).map(|_| colorize(&[f32::NAN], 0.0, 1.0)),
            Some(INVALID.to_vec())
        );
    }

    #[test]
    fn range_skips_non_finite() {
        assert_eq!(
            finite_range(&[f32::NAN, 2.0, -1.0, f32::INFINITY]),
            Some((-1.0, 2.0))
        );
        assert_eq!(finite_range(&[f32::NAN]), None);
    }
}
