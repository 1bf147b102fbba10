//! A pixel's statistics and cost over raw views sampled through their homographies.

use crate::geometry::Homography;
use crate::lightfield::Sample;
use crate::scalar::Scalar;

use super::sampling::lanes;
use super::taps::Tap;
use super::{Views, STATS};

impl<T: Scalar> Views<T> {
    /// The sample of the raw view at `start` at rectified position `(px, py)` mapped by
    /// `map` (rectified → view pixels, as the warp), bilinear or (`cubic`) Catmull–Rom:
    /// one interpolation of the input. `None` outside the view.
    #[inline(always)]
    fn mapped<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        start: usize,
        map: &Homography,
        cubic: bool,
        (px, py): (T, T),
    ) -> Option<[T; L]> {
        let (u, v) = map.apply(px.to_f32(), py.to_f32())?;
        let (xm, ym) = (self.x_max.to_f32(), self.y_max.to_f32());
        if !(u >= 0.0 && u <= xm && v >= 0.0 && v <= ym) {
            return None;
        }
        if cubic {
            return self.catmull_rom_at::<S, CH, L>(data, start, u, v);
        }
        self.bilinear_at::<S, CH, L>(data, start, (T::from_f32(u), T::from_f32(v)))
    }

    /// Catmull–Rom sample of the `L` lanes at `(u, v)` inside the view; taps past the
    /// border repeat the border pixel.
    #[inline(always)]
    fn catmull_rom_at<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        start: usize,
        u: f32,
        v: f32,
    ) -> Option<[T; L]> {
        let weights = |t: f32| {
            let (t2, t3) = (t * t, t * t * t);
            [
                0.5 * (-t3 + 2.0 * t2 - t),
                0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
                0.5 * (-3.0 * t3 + 4.0 * t2 + t),
                0.5 * (t3 - t2),
            ]
        };
        let (x0, y0) = ((u as i32).max(0), (v as i32).max(0));
        let (wx, wy) = (weights(u - x0 as f32), weights(v - y0 as f32));
        let xl = self.x_last as i32 + 1;
        let yl = self.y_last as i32 + 1;
        let mut out = [T::ZERO; L];
        for (j, &wyj) in wy.iter().enumerate() {
            let yy = (y0 + j as i32 - 1).clamp(0, yl) as usize;
            let mut row = [T::ZERO; L];
            for (i, &wxi) in wx.iter().enumerate() {
                let xx = (x0 + i as i32 - 1).clamp(0, xl) as usize;
                let at = lanes::<T, S, CH, L>(
                    data,
                    start + yy * self.row_stride + xx * CH,
                    &self.levels,
                )?;
                let w = T::from_f32(wxi);
                for c in 0..L {
                    row[c] += w * at[c];
                }
            }
            let w = T::from_f32(wyj);
            for c in 0..L {
                out[c] += w * row[c];
            }
        }
        Some(out)
    }

    /// The homography of the view whose first sample is `start`.
    #[inline(always)]
    fn map_of<'m>(&self, maps: &'m [Homography], start: usize) -> Option<&'m Homography> {
        maps.get(start.checked_div(self.view_stride)?)
    }

    /// The centre view's samples at `(x, y)` through its homography.
    #[inline(always)]
    fn mapped_centre<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (maps, cubic): (&[Homography], bool),
        (xf, yf): (T, T),
    ) -> Option<[T; L]> {
        let map = self.map_of(maps, self.centre)?;
        self.mapped::<S, CH, L>(data, self.centre, map, cubic, (xf, yf))
    }

    /// The samples of a view through its homography at `d + h`, `d − h` and `d`.
    #[inline(always)]
    fn mapped_three<S: Sample, const CH: usize, const L: usize>(
        &self,
        data: &[S],
        (maps, cubic): (&[Homography], bool),
        tap: &Tap<T>,
        (xf, yf): (T, T),
        d: T,
    ) -> Option<[[T; L]; 3]> {
        let map = self.map_of(maps, tap.start)?;
        let sample = |dd: T| {
            let at = (xf - dd * tap.du, yf - dd * tap.dv);
            self.mapped::<S, CH, L>(data, tap.start, map, cubic, at)
        };
        Some([sample(d + tap.h)?, sample(d - tap.h)?, sample(d)?])
    }

    pub(super) fn pixel_mapped_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
    >(
        &self,
        data: &[S],
        maps: (&[Homography], bool),
        (x, y): (usize, usize),
        d: T,
        (robust, scaled): (T, T),
        out: &mut [T; STATS],
    ) {
        *out = [T::ZERO; STATS];
        let (xf, yf) = (T::from_i32(x as i32), T::from_i32(y as i32));
        let Some(centre) = self.mapped_centre::<S, CH, L>(data, maps, (xf, yf)) else {
            return;
        };
        for tap in self.all_taps() {
            let Some([first, second, at]) =
                self.mapped_three::<S, CH, L>(data, maps, &tap, (xf, yf), d)
            else {
                continue;
            };
            let (mut a, mut b, mut e) = (T::ZERO, T::ZERO, T::ZERO);
            for c in 0..N.min(L) {
                let g = (first[c] - second[c]) * tap.inv;
                let r = at[c] - centre[c];
                a += g * g;
                b += g * (g * d - r);
                e += r * r;
            }
            tap.add_weighted(out, (a, b, e), (robust, scaled));
        }
    }

    pub(super) fn cost_mapped_channels<
        S: Sample,
        const CH: usize,
        const N: usize,
        const L: usize,
    >(
        &self,
        data: &[S],
        maps: (&[Homography], bool),
        (x, y): (usize, usize),
        d: T,
        (robust, scaled): (T, T),
        bar: Option<T>,
    ) -> Option<T> {
        let below = |c: T| bar.is_none_or(|bar| c < bar);
        let (xf, yf) = (T::from_i32(x as i32), T::from_i32(y as i32));
        let Some(centre) = self.mapped_centre::<S, CH, L>(data, maps, (xf, yf)) else {
            return below(T::ZERO).then_some(T::ZERO);
        };
        let mut cost = T::ZERO;
        for tap in self.all_taps() {
            // The same views as the statistics: those whose three samples lie inside.
            let Some([_, _, at]) = self.mapped_three::<S, CH, L>(data, maps, &tap, (xf, yf), d)
            else {
                continue;
            };
            // Counted once per group the view belongs to (two separate sums, so the
            // rounding matches summing each group on its own).
            let e = tap.weighted_cost(&at, &centre, N, (robust, scaled), None);
            cost += e;
            if tap.second_group.is_some() {
                cost += e;
            }
            if !below(cost) {
                return None;
            }
        }
        below(cost).then_some(cost)
    }
}
