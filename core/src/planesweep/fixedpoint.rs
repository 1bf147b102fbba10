//! The pixel costs in fixed point and their window sums along x: integer sums are
//! exact, so the map does not depend on the order of the taps.

use super::copy;

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
pub(super) fn fixed_scale(taps: usize, terms: usize, tau: f32) -> f32 {
    let per_pixel = (WINDOW_LIMIT / taps.max(1) as f32).min(PIXEL_LIMIT);
    per_pixel / (terms.max(1) as f32 * tau)
}

/// A pixel's summed cost in fixed point, rounded to the nearest unit (ties to even):
/// `cost · scale` lies in `[0, 2²³)` ([`fixed_scale`]; the differences are truncated,
/// so `cost` is finite and ≥ 0), where adding `2²³` leaves the rounded integer in the
/// mantissa. Three vector instructions per eight lanes, where `as i32` (saturating) is
/// not vectorised.
#[inline(always)]
pub(super) fn fixed(cost: f32, scale: f32) -> i32 {
    ((cost * scale + ROUNDING).to_bits() as i32).wrapping_sub(ROUNDING.to_bits() as i32)
}

/// Per pixel, the sum of the first `used` of its `channels` interleaved samples, in
/// channel order (the common layouts unrolled), in fixed point at `scale`.
pub(super) fn channel_sums(
    sum: &mut [i32],
    costs: &[f32],
    channels: usize,
    used: usize,
    scale: f32,
) {
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
pub(super) fn window_sum(a: &[i32], n: usize, out: &mut [i32], p0: &mut [i32], p1: &mut [i32]) {
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
