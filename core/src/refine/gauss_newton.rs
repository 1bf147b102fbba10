//! Gauss–Newton: per-pixel normal equations summed over a gated window, the damped
//! step, the choice of groups (occlusion, axis agreement) and the confidence (see [the
//! module](super)).

use core::ops::Range;

use crate::scalar::Scalar;

use super::params::RefineParams;
use super::photo::{Photometric, GROUPS, STATS};
use super::state::{OwnCost, Planes, Region};
use super::{Constants, Measure, Slant, MEMORY};

/// Term counts of the groups over one window, as the window sums are scaled: the
/// divisors of the mean residuals and the damping's term counts.
struct Counts<T> {
    /// Per group, its terms over one window times the scale (exact).
    terms: [T; GROUPS],
    /// The same, at least one term's worth: the divisor of the group's mean residual.
    means: [T; GROUPS],
    /// The factor of the window sums.
    scale: T,
}

impl<T: Scalar> Counts<T> {
    fn new(terms: &[f32; GROUPS], area: f32, shift: i32) -> Self {
        let scale = libm::ldexpf(1.0, -shift);
        Counts {
            terms: terms.map(|t| T::from_f32(t * area * scale)),
            means: terms.map(|t| T::from_f32((t * area).max(1.0) * scale)),
            scale: T::from_f32(scale),
        }
    }
}

/// Window sums whose total curvature `A` exceeds `T::MAX · 2^-WIDE_LIMIT_SHIFT` are
/// summed again with every term scaled by `2^-WIDE_SHIFT` (see the module's "Numbers").
const WIDE_LIMIT_SHIFT: i32 = 5;
/// See [`WIDE_LIMIT_SHIFT`]: `2^8` covers the terms of any window on a 9×9 grid.
const WIDE_SHIFT: i32 = 8;

/// The region's disparities at which the statistics were last measured, and those
/// statistics ([`STATS`] per pixel), row-major, `width` pixels a row.
struct Evaluated<'a, T> {
    disparity: &'a [T],
    stats: &'a [T],
    width: usize,
}

/// The window sum of the statistics of the pixels within `gate` of `d`, over
/// `ys × xs` of the region, in a fixed order so that every band sums alike. Each term is
/// multiplied by `scale` when one is given. With a `plane` (the slanted window), each
/// neighbour is gated by and transferred along the plane instead (see [`Plane`]). (A
/// row's interior pixels at radius 1 take [`update_row`]'s [`window_rows`] instead.)
#[inline]
fn window_sum<T: Scalar>(
    evaluated: &Evaluated<'_, T>,
    (ys, xs): (Range<usize>, Range<usize>),
    d: T,
    gate: T,
    plane: Option<&Plane<T>>,
    scale: Option<T>,
) -> [T; STATS] {
    let (stats, previous, width) = (evaluated.stats, evaluated.disparity, evaluated.width);
    let mut sum = [T::ZERO; STATS];
    if let Some(plane) = plane {
        return window_sum_each(evaluated, (ys, xs), d, gate, plane, scale);
    }
    if xs.len() == 3 {
        // Radius 1 away from the image's sides (fewer than three rows at the region's
        // ends): each window row as one array of three disparities and one of their
        // statistics. A neighbour outside the gate adds zero instead of being skipped
        // (the sum starts at +0 and never becomes −0, so adding +0 leaves it
        // unchanged): the same sums, without branches.
        for yy in ys.clone() {
            let at = yy * width + xs.start;
            let (Some(ds), Some(ss)) = (
                previous.get(at..).and_then(|s| s.first_chunk::<3>()),
                stats
                    .get(at * STATS..)
                    .and_then(|s| s.first_chunk::<{ 3 * STATS }>()),
            ) else {
                return window_sum_each(evaluated, (ys, xs), d, gate, &Flat, scale);
            };
            for (&p, s) in ds.iter().zip(ss.chunks_exact(STATS)) {
                let outside = (p - d).abs() > gate;
                let terms = sum.iter_mut().zip(s);
                match scale {
                    None => terms.for_each(|(s, &v)| *s += if outside { T::ZERO } else { v }),
                    Some(f) => {
                        terms.for_each(|(s, &v)| *s += if outside { T::ZERO } else { v * f })
                    }
                }
            }
        }
        return sum;
    }
    window_sum_each(evaluated, (ys, xs), d, gate, &Flat, scale)
}

/// The local plane of a slanted window ([`RefineParams::slanted`]): the pixel's
/// position and the disparity's slope there (px per px).
pub(super) struct Plane<T> {
    x: usize,
    y: usize,
    slope: (T, T),
}

impl<T: Scalar> Plane<T> {
    /// The plane through a pixel at `(x, y)` with disparity `d` whose disparities at
    /// `(x + dx, y + dy)` are `at(dx, dy)` (`None` outside the region): per axis, the
    /// mean central difference across the window (`±radius`) of the window's rows
    /// (columns) whose ends lie within `reach` of their centre, which lies within it
    /// of the pixel, bending by at most the window gate; 0 where none does.
    #[inline(always)]
    fn at(
        (x, y): (usize, usize),
        d: T,
        at: impl Fn(isize, isize) -> Option<T>,
        gate: T,
        slant: &Slant<T>,
    ) -> Self {
        let line = |a: Option<T>, c: Option<T>, b: Option<T>| -> Option<T> {
            let (a, c, b) = (a?, c?, b?);
            let smooth = (c - d).abs() <= slant.reach
                && (a - c).abs() <= slant.reach
                && (b - c).abs() <= slant.reach
                && (a + b - c - c).abs() <= gate;
            smooth.then(|| b - a)
        };
        let r = slant.radius as isize;
        let average = |diff: &dyn Fn(isize) -> Option<T>| {
            let (mut sum, mut n) = (T::ZERO, 0);
            for diff in (-r..=r).filter_map(diff) {
                sum += diff;
                n += 1;
            }
            sum * slant.mean.get(n).copied().unwrap_or(T::ZERO)
        };
        let gx = average(&|dy| line(at(-r, dy), at(0, dy), at(r, dy)));
        let gy = average(&|dx| line(at(dx, -r), at(dx, 0), at(dx, r)));
        Plane {
            x,
            y,
            slope: (gx, gy),
        }
    }
}

/// The plane a window's neighbours are gated around and their statistics transferred
/// along: the fronto-parallel [`Flat`] or a slanted window's [`Plane`]. Each is its own
/// monomorphised loop, so the fronto-parallel window pays nothing for the other.
trait WindowPlane<T: Scalar> {
    /// The plane's disparity at `(xx, yy)` relative to the pixel's.
    fn offset(&self, xx: usize, yy: usize) -> T;

    /// Adds a neighbour's statistics to a window's sum, the plane lying `offset` px
    /// above it at the pixel, scaled by `scale` when given.
    fn add(sum: &mut [T; STATS], stat: &[T], offset: T, scale: Option<T>);
}

/// The fronto-parallel window: the plane of the pixel's disparity, along which the
/// statistics are added as they are.
struct Flat;

impl<T: Scalar> WindowPlane<T> for Flat {
    /// Zero: `p − d − 0` is `p − d`, bit for bit (also for [`Q16`](crate::Q16)'s
    /// saturating subtraction), and the compiler drops it.
    #[inline(always)]
    fn offset(&self, _: usize, _: usize) -> T {
        T::ZERO
    }

    #[inline(always)]
    fn add(sum: &mut [T; STATS], stat: &[T], _: T, scale: Option<T>) {
        add_stats(sum, stat, scale);
    }
}

impl<T: Scalar> WindowPlane<T> for Plane<T> {
    #[inline(always)]
    fn offset(&self, xx: usize, yy: usize) -> T {
        let steps = |to: usize, from: usize| T::from_f32(to as f32 - from as f32);
        self.slope.0 * steps(xx, self.x) + self.slope.1 * steps(yy, self.y)
    }

    #[inline(always)]
    fn add(sum: &mut [T; STATS], stat: &[T], offset: T, scale: Option<T>) {
        add_stats_slanted(sum, stat, offset, scale);
    }
}

/// Adds one pixel's statistics to a window's sum transferred along a plane that lies
/// `offset` px above it at the pixel: `B − offset · A` per group (the pixel's own
/// Gauss–Newton target moved by the plane's step), scaled by `scale` when given.
#[inline(always)]
fn add_stats_slanted<T: Scalar>(sum: &mut [T; STATS], stat: &[T], offset: T, scale: Option<T>) {
    for (sum, stat) in sum.chunks_exact_mut(3).zip(stat.chunks_exact(3)) {
        if let ([sa, sb, se], [a, b, e]) = (sum, stat) {
            let b = *b - offset * *a;
            match scale {
                None => {
                    *sa += *a;
                    *sb += b;
                    *se += *e;
                }
                Some(f) => {
                    *sa += *a * f;
                    *sb += b * f;
                    *se += *e * f;
                }
            }
        }
    }
}

/// The total curvature `A` of a window sum (all groups).
#[inline(always)]
fn curvature<T: Scalar>(sum: &[T; STATS]) -> T {
    (0..GROUPS).fold(T::ZERO, |a, g| a + sum[3 * g])
}

/// Rows `y − 1`, `y` and `y + 1` of a plane whose rows are `row_len` long (`None` for
/// `y` = 0 or rows past the plane).
#[inline(always)]
fn rows_around<T>(plane: &[T], row_len: usize, y: usize) -> Option<[&[T]; 3]> {
    let rows = plane
        .get(y.checked_sub(1)? * row_len..)?
        .get(..3 * row_len)?;
    let (r0, rest) = rows.split_at_checked(row_len)?;
    let (r1, r2) = rest.split_at_checked(row_len)?;
    Some([r0, r1, r2])
}

/// Rows `y − 1`, `y` and `y + 1` of the region's disparities and statistics (`width`
/// wide; `None` for `y` = 0 or rows past the region).
#[allow(clippy::type_complexity)]
#[inline(always)]
fn three_rows<'a, T>(
    previous: &'a [T],
    stats: &'a [T],
    width: usize,
    y: usize,
) -> Option<([&'a [T]; 3], [&'a [T]; 3])> {
    Some((
        rows_around(previous, width, y)?,
        rows_around(stats, width * STATS, y)?,
    ))
}

/// [`window_sum_each`] of a whole 3 × 3 window given as its three rows of disparities
/// and statistics, around the pixel at (1, 1) of the three rows: the same terms in the
/// same order. A neighbour outside the gate is skipped, which is adding +0 (the sum
/// starts at +0 and never becomes −0; adding 0 to a Q16 integer is exact): the same
/// bits as [`window_sum`]'s branchless rows. Not inlined: inlined into the row's loop,
/// its sums were kept in vector lanes by group (for the curvature), which cost more
/// than the call.
#[allow(clippy::type_complexity)]
#[inline(never)]
fn window_rows<T: Scalar, W: WindowPlane<T>>(
    (ds, ss): &([&[T; 3]; 3], [&[T; 3 * STATS]; 3]),
    d: T,
    gate: T,
    plane: &W,
    scale: Option<T>,
) -> [T; STATS] {
    let mut sum = [T::ZERO; STATS];
    for (yy, (ds, ss)) in ds.iter().zip(ss).enumerate() {
        for (xx, (&p, s)) in ds.iter().zip(ss.chunks_exact(STATS)).enumerate() {
            let offset = plane.offset(xx, yy);
            if (p - d - offset).abs() > gate {
                continue;
            }
            W::add(&mut sum, s, offset, scale);
        }
    }
    sum
}

/// Adds one pixel's statistics to a window's sum, scaled by `scale` when given (the
/// wide windows' re-sum).
#[inline(always)]
fn add_stats<T: Scalar>(sum: &mut [T; STATS], stat: &[T], scale: Option<T>) {
    let terms = sum.iter_mut().zip(stat);
    match scale {
        None => terms.for_each(|(s, &v)| *s += v),
        Some(f) => terms.for_each(|(s, &v)| *s += v * f),
    }
}

/// What one pixel's Gauss–Newton update needs besides its window sum.
struct Step<'a, T> {
    k: &'a Constants<T>,
    narrow: &'a Counts<T>,
    wide: &'a Counts<T>,
    /// Window sums whose total curvature exceeds this are summed again scaled.
    wide_limit: T,
    occlusion: bool,
    range: (f32, f32),
}

impl<T: Scalar> Step<'_, T> {
    /// The next disparity of a pixel at `d` (with the `E` and `A` + damping of its
    /// confidence) from its plain window sum `sum`, or, when the sum's total curvature
    /// exceeds `wide_limit`, from `scaled(wide scale)`, the window summed again scaled.
    #[inline(always)]
    fn update(&self, d: T, sum: [T; STATS], scaled: impl FnOnce(T) -> [T; STATS]) -> (T, T, T) {
        let wide = curvature(&sum) > self.wide_limit;
        let sum = if wide { scaled(self.wide.scale) } else { sum };
        self.next(&sum, wide, d)
    }

    /// The next disparity of a pixel at `d` whose window sum is `sum` (summed scaled,
    /// with the wide counts, when `wide`), with the `E` and `A` + damping of its
    /// confidence.
    #[inline(always)]
    fn next(&self, sum: &[T; STATS], wide: bool, d: T) -> (T, T, T) {
        let k = self.k;
        let counts = if wide { self.wide } else { self.narrow };
        let (a, b, e, terms) = select(sum, counts, k, self.occlusion, d);
        let damping = k.damping * terms;
        let target = (b + damping * d) / (a + damping);
        // `Scalar::clamp` (`max`, then `min`; a NaN gives the lower bound) as compares
        // that the compiler keeps as one `max` / `min` instruction each, with the same
        // bits: for the step they differ from `Scalar::max` / `min` only where the
        // value equals a bound (the same bits: `±max_step` is not zero), or on a NaN
        // bound (never); for the range they are `Scalar::max` / `min` of a value that
        // is not NaN (`d` is finite and the step is clamped).
        let (raw, max_step) = (target - d, k.max_step);
        let step = if raw > -max_step { raw } else { -max_step };
        let step = if step < max_step { step } else { max_step };
        let next = d + step;
        let next = if k.lo > next { k.lo } else { next };
        let next = if k.hi < next { k.hi } else { next };
        let next = if next.is_finite() { next } else { d };
        (next, e, a + damping)
    }

    /// The band's output for disparity `next`, its `E` and `A` + damping.
    #[inline(always)]
    fn output(&self, next: T, e: T, damped: T, out: &mut f32, confidence: &mut f32) {
        // Fixed-point rounding of the range ends must not step outside it.
        *out = crate::float::clamp_f32(next.to_f32(), self.range.0, self.range.1);
        let err2 = e / damped;
        let c = T::ONE / (T::ONE + err2 / self.k.confidence2);
        *confidence = if c.is_finite() {
            c.to_f32().clamp(0.0, 1.0)
        } else {
            0.0
        };
    }
}

/// Elements `x`, `x + 1` and `x + 2` of `row`.
#[inline(always)]
fn three_at<X>(row: &[X], x: usize) -> Option<&[X; 3]> {
    row.get(x..).and_then(|r| r.first_chunk::<3>())
}

/// The statistics of elements `x`, `x + 1` and `x + 2` of a row of statistics.
#[inline(always)]
fn three_stats_at<T>(row: &[T], x: usize) -> Option<&[T; 3 * STATS]> {
    row.get(x * STATS..)
        .and_then(|r| r.first_chunk::<{ 3 * STATS }>())
}

/// With [`RefineParams::skip_settled`], what a row's update keeps of the iteration
/// before: after the first iteration the rows `moved` above, at and below it (from
/// x = 0: how far each pixel moved in the iteration before; a pixel that moved by less
/// than `settled` kept its statistics, and its window settled when the other pixels
/// moved by less than `loose`), and the `E` and `A` + damping of the row's pixels (from
/// x = 1 in [`update_row`], as `next`), which a skipped pixel's confidence reuses and
/// an updated pixel's overwrites when `store`.
struct Reuse<'a, T> {
    moved: Option<[&'a [T]; 3]>,
    e: &'a mut [T],
    damped: &'a mut [T],
    settled: T,
    /// The largest move of the window's other pixels (at least `settled`).
    loose: T,
    store: bool,
}

/// The update of a row's interior pixels (x = 1 … width − 2) from the region's rows
/// `ds` / `ss` above, at and below it (see [`three_rows`]) into `next` (the row of the
/// next disparities from x = 1) and, in the last iteration, `outputs` (the band's
/// disparity and confidence rows from x = 1); with `reuse`, a pixel whose window settled
/// keeps its disparity (`next` holds it already) and its confidence.
#[inline(never)]
fn update_row<T: Scalar>(
    step: &Step<'_, T>,
    ds: [&[T]; 3],
    ss: [&[T]; 3],
    next: &mut [T],
    outputs: Option<(&mut [f32], &mut [f32])>,
    reuse: Option<Reuse<'_, T>>,
) {
    let n = next.len();
    // Every row holds the n + 2 pixels of the row's windows: the window lookups below
    // stay inside these (their `else` never happens).
    let ([d0, d1, d2], [s0, s1, s2]) = (ds, ss);
    let (Some(d0), Some(d1), Some(d2), Some(s0), Some(s1), Some(s2)) = (
        d0.get(..n + 2),
        d1.get(..n + 2),
        d2.get(..n + 2),
        s0.get(..(n + 2) * STATS),
        s1.get(..(n + 2) * STATS),
        s2.get(..(n + 2) * STATS),
    ) else {
        return;
    };
    let gate = step.k.gate;
    let mut outputs =
        outputs.and_then(|(out, confidence)| Some((out.get_mut(..n)?, confidence.get_mut(..n)?)));
    let mut reuse = reuse.and_then(|r| {
        let moved = match r.moved {
            Some([m0, m1, m2]) => Some([m0.get(..n + 2)?, m1.get(..n + 2)?, m2.get(..n + 2)?]),
            None => None,
        };
        Some((
            moved,
            r.e.get_mut(..n)?,
            r.damped.get_mut(..n)?,
            (r.settled, r.loose),
            r.store,
        ))
    });
    // Whether a pixel of column `x` (of the rows' n + 2) in the three rows moved by
    // `limit` or more (moves are never NaN); the window of pixel x spans columns
    // x … x + 2.
    let column = |m: &[&[T]; 3], limit: T, x: usize| {
        m.iter().any(|row| row.get(x).is_none_or(|&v| v >= limit))
    };
    let mut moved = match &reuse {
        Some((Some(m), _, _, (_, loose), _)) => [column(m, *loose, 0), column(m, *loose, 1)],
        _ => [true; 2],
    };
    for (x, next) in next.iter_mut().enumerate() {
        if let Some((Some(m), e, damped, (settled, loose), _)) = &reuse {
            let right = column(m, *loose, x + 2);
            let centre = m[1].get(x + 1).is_none_or(|&v| v >= *settled);
            let window = moved[0] | moved[1] | right | centre;
            moved = [moved[1], right];
            // `next` holds the pixel's disparity already.
            if !window {
                if let (Some((out, confidence)), Some(&d), Some(&e), Some(&damped)) =
                    (&mut outputs, d1.get(x + 1), e.get(x), damped.get(x))
                {
                    if let (Some(out), Some(confidence)) = (out.get_mut(x), confidence.get_mut(x)) {
                        step.output(d, e, damped, out, confidence);
                    }
                }
                continue;
            }
        }
        let (Some(d0), Some(d1), Some(d2), Some(s0), Some(s1), Some(s2)) = (
            three_at(d0, x),
            three_at(d1, x),
            three_at(d2, x),
            three_stats_at(s0, x),
            three_stats_at(s1, x),
            three_stats_at(s2, x),
        ) else {
            continue;
        };
        let d = d1[1];
        let rows = ([d0, d1, d2], [s0, s1, s2]);
        let (n, e, damped) = match &step.k.slant {
            None => {
                let sum = window_rows(&rows, d, gate, &Flat, None);
                step.update(d, sum, |f| window_rows(&rows, d, gate, &Flat, Some(f)))
            }
            Some(slant) => {
                let ds = [d0, d1, d2];
                let at = |dx: isize, dy: isize| {
                    let row = ds.get(usize::try_from(dy + 1).ok()?)?;
                    row.get(usize::try_from(dx + 1).ok()?).copied()
                };
                let plane = Plane::at((1, 1), d, at, gate, slant);
                let sum = window_rows(&rows, d, gate, &plane, None);
                step.update(d, sum, |f| window_rows(&rows, d, gate, &plane, Some(f)))
            }
        };
        *next = n;
        if let Some((_, ke, kd, _, true)) = &mut reuse {
            if let (Some(ke), Some(kd)) = (ke.get_mut(x), kd.get_mut(x)) {
                (*ke, *kd) = (e, damped);
            }
        }
        if let Some((out, confidence)) = &mut outputs {
            if let (Some(out), Some(confidence)) = (out.get_mut(x), confidence.get_mut(x)) {
                step.output(n, e, damped, out, confidence);
            }
        }
    }
}

/// [`window_sum`] pixel by pixel: each neighbour within `gate` of the window's `plane`
/// through the pixel, its statistics transferred along the plane ([`Flat`]: gated
/// around `d`, added as they are).
#[inline]
fn window_sum_each<T: Scalar, W: WindowPlane<T>>(
    evaluated: &Evaluated<'_, T>,
    (ys, xs): (Range<usize>, Range<usize>),
    d: T,
    gate: T,
    plane: &W,
    scale: Option<T>,
) -> [T; STATS] {
    let (stats, previous, width) = (evaluated.stats, evaluated.disparity, evaluated.width);
    let mut sum = [T::ZERO; STATS];
    for yy in ys {
        for xx in xs.clone() {
            let j = yy * width + xx;
            // The window lies within the region, which `previous` covers.
            let Some(&p) = previous.get(j) else { continue };
            let offset = plane.offset(xx, yy);
            if (p - d - offset).abs() > gate {
                continue;
            }
            let Some(stat) = stats.get(j * STATS..(j + 1) * STATS) else {
                continue;
            };
            W::add(&mut sum, stat, offset, scale);
        }
    }
    sum
}

/// The Gauss–Newton iterations of a band (see [the module](super)): per iteration,
/// each pixel's statistics at its disparity (unless it settled), then each pixel's
/// update from the window sum of its neighbours' statistics, written to `out` and
/// `confidence` (the band's rows) in the last iteration. `propagated`: whether the
/// propagation ran (and left its [`OwnCost`] states in `planes.memory`).
pub(super) fn iterate<T: Scalar, P: Photometric<T>>(
    measure: &Measure<'_, T, P>,
    p: &RefineParams,
    region: &Region,
    planes: &mut Planes<'_, T>,
    propagated: bool,
    (out, confidence): (&mut [f32], &mut [f32]),
) {
    let (photo, k, range) = (measure.photo, &measure.k, measure.range);
    let stat_robust = measure.stat_robust;
    let (width, first, region_rows) = (region.width, region.first, region.len());
    let band_start = region.rows.start;
    let pixels = region_rows * width;
    let Planes {
        current,
        previous,
        stats,
        memory,
    } = planes;
    let r = p.radius;
    let area = ((2 * r + 1) * (2 * r + 1)) as f32;
    let terms = &photo.views().terms;
    let (narrow, wide) = (
        Counts::<T>::new(terms, area, 0),
        Counts::<T>::new(terms, area, WIDE_SHIFT),
    );
    let wide_limit = T::MAX * T::from_f32(libm::ldexpf(1.0, -WIDE_LIMIT_SHIFT));
    // See `RefineParams::skip_settled` (nothing settles before the second iteration).
    let skip = p.skip_settled > 0.0 && p.iterations > 1;
    let skip_moved = T::from_f32(p.skip_settled);
    for iteration in 0..p.iterations {
        // Rows whose statistics the remaining iterations can still reach the band from.
        let measured = region.near((p.iterations - iteration) * r);
        let updated = region.near((p.iterations - iteration - 1) * r);
        let last_iteration = iteration + 1 == p.iterations;
        let settled = if last_iteration {
            k.settled
        } else {
            k.settled_early
        };
        // Per-pixel normal equations at each pixel's own disparity.
        for y in measured.clone() {
            for x in 0..width {
                let i = y * width + x;
                // A pixel that moved by less than `SETTLED` (`SETTLED_EARLY` before
                // the last iteration) since its statistics were measured keeps them
                // (every row measured now was measured and updated by the iteration
                // before): to first order `B` does not change with
                // `d` (`r` grows by `g·Δd`), and the step from the stale `A`, `B` is
                // that from the fresh ones within a few `SETTLED`.
                // `measured` rows lie within the region, which the tables cover.
                let (Some(&now), Some(&before), Some(stat)) = (
                    current.get(i),
                    previous.get(i),
                    stats
                        .get_mut(i * STATS..)
                        .and_then(|s| s.first_chunk_mut::<STATS>()),
                ) else {
                    continue;
                };
                if iteration > 0 {
                    let moved = (now - before).abs();
                    // How far the pixel moved, for the windows of `skip_settled` (the
                    // first plane of `memory`: the propagation's state is no longer read).
                    if skip {
                        if let Some(m) = memory.get_mut(i) {
                            *m = moved;
                        }
                    }
                    if moved < settled {
                        continue;
                    }
                }
                // The propagation measured them at this disparity (the same bits as now):
                // `memory` covers these rows when there was a propagation.
                if iteration == 0
                    && propagated
                    && memory
                        .get(i * MEMORY)
                        .is_some_and(|&m| OwnCost::read(m) == OwnCost::Fresh)
                {
                    continue;
                }
                photo.pixel(x, first + y, now, stat_robust, stat);
            }
        }
        let span = measured.start * width..measured.end * width;
        if let (Some(to), Some(from)) = (previous.get_mut(span.clone()), current.get(span)) {
            to.copy_from_slice(from);
        }
        // With `skip_settled`, `memory` holds three planes from here: how far each pixel
        // moved in the iteration before (written by the statistics pass after the first
        // iteration), and each pixel's last `E` and `A` + damping, which a pixel whose
        // window settled keeps for its confidence.
        let (moved, rest) = memory.split_at_mut_checked(pixels).unwrap_or_default();
        let (kept_e, kept_damped) = rest.split_at_mut_checked(pixels).unwrap_or_default();
        let (check, store) = (skip && iteration > 0, skip && !last_iteration);
        let loose = if skip_moved > settled {
            skip_moved
        } else {
            settled
        };
        let step = Step {
            k,
            narrow: &narrow,
            wide: &wide,
            wide_limit,
            occlusion: p.occlusion,
            range,
        };
        for y in updated {
            // A row whose pixels have whole 3 × 3 windows (radius 1, not at the
            // region's ends): its interior pixels go to `update_row`, which walks the
            // three rows' slices side by side (no per-window offsets or bounds checks);
            // only the first and the last pixel take `window_sum` here.
            let interior = if r == 1 && y + 1 < region_rows && width >= 3 {
                three_rows(previous, stats, width, y)
            } else {
                None
            };
            let stride = if interior.is_some() { width - 1 } else { 1 };
            for x in (0..width).step_by(stride.max(1)) {
                // Window sum over the neighbours whose disparity is within
                // `WINDOW_GATE` of this pixel's: the window does not reach across depth
                // edges.
                let j = y * width + x;
                let Some(&d) = previous.get(j) else {
                    continue;
                };
                let (ys, xs) = (
                    y.saturating_sub(r)..(y + r + 1).min(region_rows),
                    x.saturating_sub(r)..(x + r + 1).min(width),
                );
                if check {
                    let mut window = ys.clone().flat_map(|yy| {
                        let row = moved.get(yy * width..(yy + 1) * width).unwrap_or_default();
                        row.get(xs.clone()).unwrap_or_default().iter()
                    });
                    // `current` holds `d` already (copied above).
                    let centre = moved.get(j).is_some_and(|&m| m < settled);
                    if centre && window.all(|&m| m < loose) {
                        if last_iteration {
                            let o = (first + y - band_start) * width + x;
                            if let (Some(out), Some(confidence), Some(&e), Some(&damped)) = (
                                out.get_mut(o),
                                confidence.get_mut(o),
                                kept_e.get(j),
                                kept_damped.get(j),
                            ) {
                                step.output(d, e, damped, out, confidence);
                            }
                        }
                        continue;
                    }
                }
                let evaluated = Evaluated {
                    disparity: previous,
                    stats,
                    width,
                };
                // The slanted window's plane, from the window's disparities within the
                // region.
                let plane = k.slant.as_ref().map(|slant| {
                    let at = |dx: isize, dy: isize| {
                        let xx = x.checked_add_signed(dx).filter(|&xx| xx < width)?;
                        let yy = y.checked_add_signed(dy).filter(|&yy| yy < region_rows)?;
                        previous.get(yy * width + xx).copied()
                    };
                    Plane::at((x, y), d, at, k.gate, slant)
                });
                let window = (ys, xs);
                let sum = window_sum(&evaluated, window.clone(), d, k.gate, plane.as_ref(), None);
                let (next, e, damped) = step.update(d, sum, |f| {
                    window_sum(&evaluated, window, d, k.gate, plane.as_ref(), Some(f))
                });
                if let Some(current) = current.get_mut(j) {
                    *current = next;
                }
                if let (true, Some(ke), Some(kd)) =
                    (store, kept_e.get_mut(j), kept_damped.get_mut(j))
                {
                    (*ke, *kd) = (e, damped);
                }
                if last_iteration {
                    let o = (first + y - band_start) * width + x;
                    if let (Some(out), Some(confidence)) = (out.get_mut(o), confidence.get_mut(o)) {
                        step.output(next, e, damped, out, confidence);
                    }
                }
            }
            let Some((ds, ss)) = interior else {
                continue;
            };
            let inner = |at: usize| at + 1..at + width - 1;
            let next = current.get_mut(inner(y * width)).unwrap_or_default();
            let outputs = if last_iteration {
                let o = (first + y - band_start) * width;
                match (out.get_mut(inner(o)), confidence.get_mut(inner(o))) {
                    (Some(out), Some(confidence)) => Some((out, confidence)),
                    _ => None,
                }
            } else {
                None
            };
            let reuse = if skip {
                let moved = check.then(|| rows_around(moved, width, y)).flatten();
                match (
                    kept_e.get_mut(inner(y * width)),
                    kept_damped.get_mut(inner(y * width)),
                ) {
                    (Some(e), Some(damped)) => Some(Reuse {
                        moved,
                        e,
                        damped,
                        settled,
                        loose,
                        store,
                    }),
                    _ => None,
                }
            } else {
                None
            };
            update_row(&step, ds, ss, next, outputs, reuse);
        }
    }
}

/// Sums the groups that see the pixel: all of them, or without the worse half of the
/// left/right and up/down pairs when it fits much worse (an occluder). When the
/// horizontal and vertical views then disagree on the disparity by more than
/// [`AXIS_AGREEMENT`](super::AXIS_AGREEMENT), only the axis with the smaller error `E / A` is kept: along
/// edges parallel to an axis, that axis' views only see aliasing and noise.
/// Returns `(A, B, E, terms)` (the terms scaled like the statistics).
#[inline]
fn select<T: Scalar>(
    sum: &[T; STATS],
    counts: &Counts<T>,
    k: &Constants<T>,
    occlusion: bool,
    d: T,
) -> (T, T, T, T) {
    let mut keep = [true; GROUPS];
    if occlusion {
        for pair in [[0, 1], [2, 3]] {
            // Groups are 0…GROUPS − 1: the defaults never happen.
            let mean = |g: usize| match (sum.get(3 * g + 2), counts.means.get(g)) {
                (Some(&e), Some(&m)) => e / m,
                _ => T::ZERO,
            };
            let (m0, m1) = (mean(pair[0]), mean(pair[1]));
            let drop = if m0 > k.occlusion_ratio * m1 + k.occlusion_floor {
                keep.get_mut(pair[0])
            } else if m1 > k.occlusion_ratio * m0 + k.occlusion_floor {
                keep.get_mut(pair[1])
            } else {
                None
            };
            if let Some(keep) = drop {
                *keep = false;
            }
        }
    }
    let axis = |groups: [usize; 2]| {
        let (mut a, mut b, mut e, mut n) = (T::ZERO, T::ZERO, T::ZERO, T::ZERO);
        for g in groups {
            let (Some(true), Some(group), Some(&terms)) = (
                keep.get(g).copied(),
                sum.get(3 * g..3 * g + 3),
                counts.terms.get(g),
            ) else {
                continue;
            };
            if let [ga, gb, ge] = *group {
                a += ga;
                b += gb;
                e += ge;
                n += terms;
            }
        }
        (a, b, e, n)
    };
    let h = axis([0, 1]);
    let v = axis([2, 3]);
    let damping = k.damping;
    let solve = |s: (T, T, T, T)| (s.1 + damping * s.3 * d) / (s.0 + damping * s.3);
    let error = |s: (T, T, T, T)| s.2 / (s.0 + damping * s.3);
    if h.3 > T::ZERO && v.3 > T::ZERO && (solve(h) - solve(v)).abs() > k.axis_agreement {
        return if error(h) <= error(v) { h } else { v };
    }
    (h.0 + v.0, h.1 + v.1, h.2 + v.2, h.3 + v.3)
}
