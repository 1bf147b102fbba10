//! Geodesic refill of the band around depth steps, guided by the centre view.
//!
//! Next to a depth edge whose background is weakly textured, the refined disparity
//! carries the foreground's value several pixels into the background ("fattening"):
//! the structure tensor sees the foreground's edge, and a flat background is
//! photo-consistent at either disparity. A window filter (the weighted median) cannot
//! undo a fattened band as wide as its radius. This stage replaces the whole band with
//! values from outside it, choosing for each pixel the source it is connected to by
//! the most uniform colour:
//!
//! 1. The *band*: pixels within a city-block distance [`GeoFillParams::band`] of a step
//!    larger than [`GeoFillParams::step`] between 4-neighbours. Every other finite pixel
//!    is a *seed* and keeps its value.
//! 2. A multi-source geodesic distance transform from the seeds, through the band only:
//!    a step between 8-neighbours costs the largest channel difference of their colours
//!    (unit intensity) plus [`GeoFillParams::spatial`] per pixel of length. Each band
//!    pixel inherits the offset to its geodesically nearest seed. The transform runs as
//!    raster sweeps (forward, then backward; [`GeoFillParams::sweeps`] pairs): each
//!    pixel relaxes from its four already-visited neighbours, strict improvements only,
//!    so the result is a fixed function of the inputs.
//! 3. Each band pixel takes its seed's disparity, extrapolated along the seed's local
//!    slope ([`GeoFillParams::planar`]) so slanted surfaces are not terraced.
//!
//! A fattened pixel reaches the background's seeds through uniform background colour,
//! while the path to the foreground crosses the colour edge, so the depth step moves
//! back onto the colour edge. (A prototype with the weighted median of all seeds within
//! 14 px, weighted by the exponential of the straight-line colour path, measured the
//! same effect; docs/stages/refill.md.)
//!
//! The sweeps run over the whole map in one order, so the stage is not banded: it is
//! one serial call, bit-identical however the caller schedules the other stages.

use crate::error::{check_map_lengths, check_scratch, checked_product, Error, Result};
use crate::lightfield::{Sample, View};
use crate::plan::Plan;

/// Progress and timing stage name.
pub const STAGE: &str = "geofill";
/// Widest band (px).
pub const MAX_BAND: usize = 32;
/// Most sweep pairs.
pub const MAX_SWEEPS: usize = 8;

/// Parameters of the geodesic band refill.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct GeoFillParams {
    /// Run the stage (after the refinement, before the median and TV).
    pub enabled: bool,
    /// A disparity difference between 4-neighbours larger than this (px) is a depth
    /// step whose band is refilled.
    pub step: f32,
    /// A depth step with a colour step (largest channel difference, unit intensity) of
    /// at least this within 2 px of it, on the line across it, sits on a colour edge and
    /// gets no band, 0.001…1.
    pub edge: f32,
    /// Pixels within this city-block distance (px) of a step are refilled, 1…[`MAX_BAND`].
    pub band: usize,
    /// Largest horizontal or vertical offset (px) between a pixel and the seed it takes
    /// its value from, `band`…`4·MAX_BAND`.
    pub reach: usize,
    /// Cost of one pixel of path length, in unit intensity: breaks ties in flat colour
    /// towards the nearer seed, 0.0001…1 (positive, so that every band pixel's path
    /// cost is above a seed's 0).
    pub spatial: f32,
    /// A band pixel whose cheapest path to a seed costs more than this (unit intensity)
    /// keeps its value, 0.001…16: a fattened pixel reaches the background through
    /// uniform colour, while a thin structure inside a band (no seed of its own) would
    /// have to cross its own colour edge, 0.15 ≈ two edges of 20 levels.
    pub max_cost: f32,
    /// Forward + backward sweep pairs of the distance transform, 1…[`MAX_SWEEPS`]: one
    /// pair finds paths that turn at most once between the sweep directions.
    pub sweeps: usize,
    /// Extrapolate the seed's disparity to the pixel along the seed's slope (measured
    /// over up to two seeds on each side) instead of copying it.
    pub planar: bool,
}

impl Default for GeoFillParams {
    /// Chosen by measurement on HCI cotton and backgammon (docs/stages/refill.md): steps
    /// above 0.8 px (smaller ones are slants and noise that the median and TV handle),
    /// colour edges of 8 levels, a 5 px band (wider bands reach across thin structures),
    /// and copied values (the slopes of seeds next to a band are too noisy to
    /// extrapolate over several pixels).
    fn default() -> Self {
        GeoFillParams {
            enabled: true,
            step: 0.8,
            edge: 0.03,
            band: 5,
            reach: 16,
            spatial: 0.004,
            max_cost: 0.15,
            sweeps: 2,
            planar: false,
        }
    }
}

impl GeoFillParams {
    /// The stage switched off (the paper's pipeline has no such step).
    pub fn off() -> Self {
        GeoFillParams {
            enabled: false,
            ..Self::default()
        }
    }

    /// Checks every parameter.
    pub fn validate(&self) -> Result<()> {
        let bad = |name, reason| Err(Error::InvalidParameter { name, reason });
        if !(self.step.is_finite() && (0.01..=16.0).contains(&self.step)) {
            return bad("geofill.step", "must be in [0.01, 16] pixels");
        }
        if !(self.edge.is_finite() && (0.001..=1.0).contains(&self.edge)) {
            return bad("geofill.edge", "must be in [0.001, 1] (unit intensity)");
        }
        if !(1..=MAX_BAND).contains(&self.band) {
            return bad("geofill.band", "must be in 1..=32 pixels");
        }
        if !(self.band..=4 * MAX_BAND).contains(&self.reach) {
            return bad("geofill.reach", "must be in band..=128 pixels");
        }
        if !(self.spatial.is_finite() && (0.0001..=1.0).contains(&self.spatial)) {
            return bad(
                "geofill.spatial",
                "must be in [0.0001, 1] (unit intensity per pixel)",
            );
        }
        if !(self.max_cost.is_finite() && (0.001..=16.0).contains(&self.max_cost)) {
            return bad(
                "geofill.max_cost",
                "must be in [0.001, 16] (unit intensity)",
            );
        }
        if !(1..=MAX_SWEEPS).contains(&self.sweeps) {
            return bad("geofill.sweeps", "must be in 1..=8");
        }
        Ok(())
    }
}

/// Scratch (`f32` elements) of [`fill`]: the geodesic distance and the offset (x, y) to
/// the nearest seed of every pixel, `3 · pixels`.
pub fn scratch_len(plan: &Plan) -> usize {
    plan.pixels().saturating_mul(3)
}

/// `s[i]`, NaN past the end: the indices are in range (every map holds `width · height`
/// values, checked on entry); the checked form keeps panics out of the image.
#[inline]
fn at(s: &[f32], i: usize) -> f32 {
    s.get(i).copied().unwrap_or(f32::NAN)
}

/// `s[i] = v`, nothing past the end (see [`at`]).
#[inline]
fn put(s: &mut [f32], i: usize, v: f32) {
    if let Some(x) = s.get_mut(i) {
        *x = v;
    }
}

/// Marks a pixel that neither takes part nor changes (non-finite outside the band).
const BLOCKED: f32 = -1.0;

/// Refills the band around the depth steps of `input` (row-major, `plan.pixels()`) into
/// `out` (same size), guided by `guide` (the centre view). `scratch` needs
/// [`scratch_len`] elements. Pixels outside the band and non-finite values are copied
/// unchanged; non-finite values never seed a neighbour.
pub fn fill<S: Sample>(
    plan: &Plan,
    guide: &View<'_, S>,
    input: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let layout = plan.layout();
    let (width, height) = (layout.width, layout.height);
    let pixels = plan.pixels();
    if guide.width() != width || guide.height() != height {
        return Err(Error::OutputSize {
            what: "the fill's guide view",
            needed: pixels,
            got: checked_product(&[guide.width(), guide.height()], "the guide view")?,
        });
    }
    check_map_lengths(
        pixels,
        &[
            ("the fill input", input.len()),
            ("the fill output", out.len()),
        ],
    )?;
    let needed = scratch_len(plan);
    check_scratch(needed, scratch.len())?;
    let p = plan.params().geofill;
    let short = Error::ScratchTooSmall {
        needed,
        got: scratch.len(),
    };
    let (dist, rest) = scratch.split_at_mut_checked(pixels).ok_or(short)?;
    let (off_x, rest) = rest.split_at_mut_checked(pixels).ok_or(short)?;
    let off_y = rest.get_mut(..pixels).ok_or(short)?;
    for (o, &v) in out.iter_mut().zip(input) {
        *o = v;
    }
    // `off_x` is free until the sweeps: one row of it serves the band's row pass.
    band_distance(
        guide,
        input,
        (width, height),
        (p.step, p.edge, p.band),
        dist,
        off_x,
    );
    let band = p.band as f32;
    let mut any = false;
    for (d, &v) in dist.iter_mut().zip(input) {
        *d = if *d <= band {
            any = true;
            f32::INFINITY
        } else if v.is_finite() {
            0.0
        } else {
            BLOCKED
        };
    }
    if !any {
        return Ok(());
    }
    off_x.fill(0.0);
    off_y.fill(0.0);
    let mut field = Field {
        guide,
        width,
        height,
        channels: guide.channels().min(3),
        dist,
        off_x,
        off_y,
        reach: p.reach as f32,
        spatial: p.spatial,
    };
    for _ in 0..p.sweeps {
        field.sweep::<false>()?;
        field.sweep::<true>()?;
    }
    let Field {
        dist, off_x, off_y, ..
    } = field;
    let max_cost = p.max_cost;
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let di = at(dist, i);
            if !(di > 0.0 && di <= max_cost && at(input, i).is_finite()) {
                continue;
            }
            let (ox, oy) = (at(off_x, i), at(off_y, i));
            // Offsets are small integers held exactly in f32.
            let sx = x as i64 + ox as i64;
            let sy = y as i64 + oy as i64;
            let (Ok(sx), Ok(sy)) = (usize::try_from(sx), usize::try_from(sy)) else {
                continue;
            };
            if sx >= width || sy >= height {
                continue;
            }
            let s = sy * width + sx;
            let mut v = at(input, s);
            if p.planar {
                let seed = |xx: usize, yy: usize| {
                    let j = yy * width + xx;
                    (at(dist, j) == 0.0).then(|| at(input, j))
                };
                let gx = seed_slope(|k| {
                    let xx = sx as i64 + k;
                    usize::try_from(xx)
                        .ok()
                        .filter(|&xx| xx < width)
                        .and_then(|xx| seed(xx, sy))
                });
                let gy = seed_slope(|k| {
                    let yy = sy as i64 + k;
                    usize::try_from(yy)
                        .ok()
                        .filter(|&yy| yy < height)
                        .and_then(|yy| seed(sx, yy))
                });
                v -= gx * ox + gy * oy;
            }
            put(out, i, v);
        }
    }
    Ok(())
}

/// The slope at a seed from `at(k)`, the seed value `k` pixels away (`None` where there
/// is no seed): the difference across the longest run of seeds within ±2 that contains
/// the seed itself, 0 where it has no seed neighbour on the line.
fn seed_slope(at: impl Fn(i64) -> Option<f32>) -> f32 {
    let Some(centre) = at(0) else {
        return 0.0;
    };
    let mut hi = (0i64, centre);
    for k in 1..=2 {
        match at(k) {
            Some(v) => hi = (k, v),
            None => break,
        }
    }
    let mut lo = (0i64, centre);
    for k in 1..=2 {
        match at(-k) {
            Some(v) => lo = (-k, v),
            None => break,
        }
    }
    let span = hi.0 - lo.0;
    if span == 0 {
        0.0
    } else {
        (hi.1 - lo.1) / span as f32
    }
}

/// City-block distance (px, as `f32`) of every pixel to the nearest pixel of an
/// *unsupported* step where it is at most `band`, a value above `band` elsewhere (see
/// [`within_band`]; `row_scratch` holds one row). A step is a difference above `step` between finite
/// 4-neighbours; it is unsupported when no colour step of `edge` or more lies on the
/// line through the pair within 2 px of it: depth edges of real scenes sit on colour
/// edges, so a step inside uniform colour is a misplaced (fattened) one, while a
/// step on a colour edge is where it belongs and is left alone.
fn band_distance<S: Sample>(
    guide: &View<'_, S>,
    input: &[f32],
    (width, height): (usize, usize),
    (step, edge, band): (f32, f32, usize),
    dist: &mut [f32],
    row_scratch: &mut [f32],
) {
    // False next to a NaN; a finite value next to ±∞ is a step.
    let jump = |a: f32, b: f32| (a - b).abs() > step;
    // Whether the colour steps between consecutive pixels along the line through
    // (x, y) and (x + dx, y + dy), from 2 px before to 2 px after the pair, all stay
    // below `edge`.
    let flat = |x: usize, y: usize, dx: usize, dy: usize| {
        (-2i64..=2).all(|k| {
            let at = |t: i64| {
                let xx = usize::try_from(x as i64 + t * dx as i64).ok()?;
                let yy = usize::try_from(y as i64 + t * dy as i64).ok()?;
                (xx < width && yy < height).then_some((xx, yy))
            };
            match (at(k), at(k + 1)) {
                (Some(a), Some(b)) => colour_step(guide, a, b) < edge,
                _ => true,
            }
        })
    };
    dist.fill(f32::INFINITY);
    for y in 0..height {
        for x in 0..width {
            let i = y * width + x;
            let v = at(input, i);
            if !v.is_finite() {
                continue;
            }
            if x + 1 < width && jump(v, at(input, i + 1)) && flat(x, y, 1, 0) {
                put(dist, i, 0.0);
                put(dist, i + 1, 0.0);
            }
            if y + 1 < height && jump(v, at(input, i + width)) && flat(x, y, 0, 1) {
                put(dist, i, 0.0);
                put(dist, i + width, 0.0);
            }
        }
    }
    within_band(dist, width, band, row_scratch);
}

/// Turns `dist` (0 on the step pixels, `+∞` elsewhere) into the city-block distance to
/// the nearest step pixel where it is at most `band`, and a value above `band` elsewhere
/// (the caller only asks which pixels lie within the band). The L1 distance is separable:
/// the vertical distance by a downward and an upward pass over whole rows, then the
/// horizontal step as a minimum over a window of `±band` columns. Every loop walks whole
/// rows with no dependence between neighbouring columns, so it vectorises (a raster
/// two-pass transform chains every pixel on its left neighbour). `row` is room for one
/// row (`width` long). Compare-and-select, not `f32::min`, which wasm lowers slowly.
fn within_band(dist: &mut [f32], width: usize, band: usize, row: &mut [f32]) {
    let width = width.max(1);
    let near = |a: f32, b: f32| if b < a { b } else { a };
    let pixels = dist.len() - dist.len() % width;
    // Checked splits and copies: the firmware links with no panic path (a plain
    // `split_at_mut` or `copy_from_slice` keeps one the compiler cannot rule out).
    for y in 1..pixels / width {
        let Some((done, rest)) = dist.split_at_mut_checked(y * width) else {
            break;
        };
        let above = done.get((y - 1) * width..).unwrap_or_default();
        for (d, &a) in rest.iter_mut().zip(above) {
            *d = near(*d, a + 1.0);
        }
    }
    for y in (1..pixels / width).rev() {
        let Some((done, rest)) = dist.split_at_mut_checked(y * width) else {
            continue;
        };
        let above = done.get_mut((y - 1) * width..).unwrap_or_default();
        for (a, &d) in above.iter_mut().zip(rest.iter()) {
            *a = near(*a, d + 1.0);
        }
    }
    let Some(row) = row.get_mut(..width) else {
        return;
    };
    for line in dist.chunks_exact_mut(width) {
        for (r, &l) in row.iter_mut().zip(line.iter()) {
            *r = l;
        }
        for k in 1..=band.min(width - 1) {
            let step = k as f32;
            let (Some(right), Some(later)) = (row.get(k..), line.get_mut(k..)) else {
                break;
            };
            // Pixel x sees column x − k on its left, then x + k on its right.
            for (d, &l) in later.iter_mut().zip(row.iter()) {
                *d = near(*d, l + step);
            }
            for (d, &r) in line.iter_mut().zip(right) {
                *d = near(*d, r + step);
            }
        }
    }
}

/// Largest channel difference (unit intensity) between the guide's pixels `a` and `b`
/// (0 where either is outside the view).
fn colour_step<S: Sample>(guide: &View<'_, S>, a: (usize, usize), b: (usize, usize)) -> f32 {
    let stride = guide.channels();
    let used = stride.min(3);
    let pixel = |(x, y): (usize, usize)| {
        guide
            .row(y)
            .and_then(|r| r.get(x * stride..x * stride + used))
            .unwrap_or(&[])
    };
    let mut most = 0u8;
    for (sa, sb) in pixel(a).iter().zip(pixel(b)) {
        most = most.max(sa.level().abs_diff(sb.level()));
    }
    f32::from(most) * (1.0 / 255.0)
}

/// [`Field::colour_step`] for pixels of `CH` samples, the first `USED` compared.
#[inline(always)]
fn fixed_colour_step<S: Sample, const CH: usize, const USED: usize>(
    ra: &[S],
    a: usize,
    rb: &[S],
    b: usize,
) -> f32 {
    let (Some(pa), Some(pb)) = (ra.get(a * CH..a * CH + USED), rb.get(b * CH..b * CH + USED))
    else {
        return 0.0;
    };
    let mut most = 0u8;
    for (sa, sb) in pa.iter().zip(pb) {
        most = most.max(sa.level().abs_diff(sb.level()));
    }
    f32::from(most) * (1.0 / 255.0)
}

/// The geodesic distance field being relaxed.
struct Field<'a, 'g, S: Sample> {
    guide: &'a View<'g, S>,
    width: usize,
    height: usize,
    channels: usize,
    /// 0 at seeds, [`BLOCKED`] where nothing passes, the best path cost so far (`+∞`
    /// before any) in the band.
    dist: &'a mut [f32],
    /// Offset from the pixel to its seed.
    off_x: &'a mut [f32],
    off_y: &'a mut [f32],
    reach: f32,
    spatial: f32,
}

impl<'g, S: Sample> Field<'_, 'g, S> {
    /// One raster sweep, forward (top-left to bottom-right) or backward: every band
    /// pixel relaxes from the four neighbours the sweep has already visited.
    fn sweep<const BACKWARD: bool>(&mut self) -> Result<()> {
        // The common pixel layouts get a colour step of fixed length (the neighbour
        // loop is most of the stage on cotton).
        match (self.guide.channels(), self.channels) {
            (3, 3) => self.sweep_with::<BACKWARD, 3, 3>(),
            (4, 3) => self.sweep_with::<BACKWARD, 4, 3>(),
            (1, 1) => self.sweep_with::<BACKWARD, 1, 1>(),
            _ => self.sweep_with::<BACKWARD, 0, 0>(),
        }
    }

    /// [`Self::sweep`] for `CH` samples per pixel of which `USED` are compared (`CH` 0:
    /// the view's own layout, looked up per step).
    fn sweep_with<const BACKWARD: bool, const CH: usize, const USED: usize>(
        &mut self,
    ) -> Result<()> {
        let backward = BACKWARD;
        let (width, height) = (self.width, self.height);
        // (dx, dy) of the visited neighbours in a forward sweep; negated backward.
        const VISITED: [(i64, i64); 4] = [(-1, 0), (-1, -1), (0, -1), (1, -1)];
        for yi in 0..height {
            let y = if backward { height - 1 - yi } else { yi };
            let row = self.guide_row(y)?;
            let ny = if backward { y + 1 } else { y.wrapping_sub(1) };
            let above = if ny < height {
                Some(self.guide_row(ny)?)
            } else {
                None
            };
            for xi in 0..width {
                let x = if backward { width - 1 - xi } else { xi };
                let i = y * width + x;
                // Seeds (0) and blocked pixels (< 0) keep their state; costs are never NaN.
                if at(self.dist, i) <= 0.0 {
                    continue;
                }
                for &(dx, dy) in &VISITED {
                    let (dx, dy) = if backward { (-dx, -dy) } else { (dx, dy) };
                    let Ok(nx) = usize::try_from(x as i64 + dx) else {
                        continue;
                    };
                    if nx >= width {
                        continue;
                    }
                    let (n, colours) = if dy == 0 {
                        (y * width + nx, row)
                    } else {
                        match above {
                            Some(r) => (ny * width + nx, r),
                            None => continue,
                        }
                    };
                    let dn = at(self.dist, n);
                    if !(dn >= 0.0 && dn.is_finite()) {
                        continue;
                    }
                    let ox = at(self.off_x, n) + dx as f32;
                    let oy = at(self.off_y, n) + dy as f32;
                    if ox.abs() > self.reach || oy.abs() > self.reach {
                        continue;
                    }
                    let length = if dx != 0 && dy != 0 {
                        core::f32::consts::SQRT_2
                    } else {
                        1.0
                    };
                    let step = if CH == 0 {
                        self.colour_step(row, x, colours, nx)
                    } else {
                        fixed_colour_step::<S, CH, USED>(row, x, colours, nx)
                    };
                    let cost = dn + step + self.spatial * length;
                    if cost < at(self.dist, i) {
                        put(self.dist, i, cost);
                        put(self.off_x, i, ox);
                        put(self.off_y, i, oy);
                    }
                }
            }
        }
        Ok(())
    }

    fn guide_row(&self, y: usize) -> Result<&'g [S]> {
        self.guide.row(y).ok_or(Error::OutOfRange {
            what: "guide row",
            index: y,
            len: self.guide.height(),
        })
    }

    /// Largest channel difference (unit intensity) between pixel `a` of row `ra` and
    /// pixel `b` of row `rb`.
    fn colour_step(&self, ra: &[S], a: usize, rb: &[S], b: usize) -> f32 {
        let stride = self.guide.channels();
        let pa = ra
            .get(a * stride..a * stride + self.channels)
            .unwrap_or(&[]);
        let pb = rb
            .get(b * stride..b * stride + self.channels)
            .unwrap_or(&[]);
        let mut most = 0u8;
        for (sa, sb) in pa.iter().zip(pb) {
            most = most.max(sa.level().abs_diff(sb.level()));
        }
        f32::from(most) * (1.0 / 255.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::lightfield::{Grid, Layout, LightField};
    use crate::plan::Params;

    const W: usize = 48;
    const H: usize = 24;

    fn plan() -> Plan {
        let params = Params {
            geofill: GeoFillParams {
                enabled: true,
                ..GeoFillParams::default()
            },
            ..Params::default()
        };
        Plan::new(Layout::packed(Grid::new(3, 3), W, H, 3), params).unwrap()
    }

    /// A 3×3 grid whose every view is the centre image (only the centre is read).
    fn light_field(image: &[u8]) -> Vec<u8> {
        image.repeat(9)
    }

    #[test]
    fn band_distance_is_the_city_block_distance_up_to_the_band() {
        let (w, h, band) = (23usize, 17usize, 4usize);
        let steps = [(0usize, 0usize), (11, 8), (22, 3), (5, 16), (6, 16)];
        let mut dist = vec![f32::INFINITY; w * h];
        for &(x, y) in &steps {
            dist[y * w + x] = 0.0;
        }
        let mut row = vec![0.0; w];
        within_band(&mut dist, w, band, &mut row);
        for y in 0..h {
            for x in 0..w {
                let exact = steps
                    .iter()
                    .map(|&(sx, sy)| (sx.abs_diff(x) + sy.abs_diff(y)) as f32)
                    .fold(f32::INFINITY, f32::min);
                let got = dist[y * w + x];
                if exact <= band as f32 {
                    assert_eq!(got, exact, "({x}, {y})");
                } else {
                    assert!(got > band as f32, "({x}, {y}): {got}");
                }
            }
        }
    }

    #[test]
    fn fattened_step_moves_to_the_colour_edge() {
        let plan = plan();
        // Bright foreground x < 20, dark background beyond; the disparity's step sits
        // 5 px into the background.
        let mut image = vec![0u8; W * H * 3];
        for y in 0..H {
            for x in 0..W {
                let level = if x < 20 { 200 } else { 30 };
                image[(y * W + x) * 3..(y * W + x) * 3 + 3].fill(level);
            }
        }
        let data = light_field(&image);
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        let input: Vec<f32> = (0..W * H)
            .map(|i| if i % W < 25 { 2.0 } else { 0.5 })
            .collect();
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch).unwrap();
        for y in 0..H {
            for x in 0..W {
                let want = if x < 20 { 2.0 } else { 0.5 };
                assert_eq!(out[y * W + x], want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn slanted_band_is_extrapolated_along_the_seed_slope() {
        let mut params = *plan().params();
        params.geofill.planar = true;
        params.geofill.band = 8;
        let plan = Plan::new(*plan().layout(), params).unwrap();
        let mut image = vec![0u8; W * H * 3];
        for (i, px) in image.chunks_exact_mut(3).enumerate() {
            px.fill(if i % W < 20 { 200 } else { 30 });
        }
        let data = light_field(&image);
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        // Background slants by 0.01 px per column; the foreground (2.0) is fattened to
        // x < 24.
        let bg = |x: usize| 0.5 + 0.01 * x as f32;
        let input: Vec<f32> = (0..W * H)
            .map(|i| if i % W < 24 { 2.0 } else { bg(i % W) })
            .collect();
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch).unwrap();
        for x in 20..W {
            assert!(
                (out[5 * W + x] - bg(x)).abs() < 1e-4,
                "x {x}: {}",
                out[5 * W + x]
            );
        }
    }

    #[test]
    fn thin_structure_inside_a_band_keeps_its_value() {
        let plan = plan();
        let bar = |x: usize, y: usize| (18..20).contains(&x) && (8..13).contains(&y);
        let mut image = vec![0u8; W * H * 3];
        for (i, px) in image.chunks_exact_mut(3).enumerate() {
            let (x, y) = (i % W, i / W);
            px.fill(if x < 10 || bar(x, y) { 200 } else { 30 });
        }
        let data = light_field(&image);
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        // The foreground (x < 10) is fattened to x < 15, within a band's reach of a
        // short bright bar at disparity 3 whose own steps sit on colour edges.
        let input: Vec<f32> = (0..W * H)
            .map(|i| match (i % W, i / W) {
                (x, y) if bar(x, y) => 3.0,
                (x, _) if x < 15 => 2.0,
                _ => 0.5,
            })
            .collect();
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch).unwrap();
        for y in 0..H {
            for x in 0..W {
                let want = if bar(x, y) {
                    3.0
                } else if x < 10 {
                    2.0
                } else {
                    0.5
                };
                assert_eq!(out[y * W + x], want, "({x}, {y})");
            }
        }
    }

    #[test]
    fn step_on_a_colour_edge_is_left_alone() {
        let plan = plan();
        let mut image = vec![0u8; W * H * 3];
        for (i, px) in image.chunks_exact_mut(3).enumerate() {
            px.fill(if i % W < 20 { 200 } else { 30 });
        }
        let data = light_field(&image);
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        // The step sits on the colour edge: nothing to move.
        let input: Vec<f32> = (0..W * H)
            .map(|i| if i % W < 20 { 2.0 } else { 0.5 })
            .collect();
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch).unwrap();
        assert_eq!(out, input);
    }

    #[test]
    fn map_without_steps_is_unchanged() {
        let plan = plan();
        let image: Vec<u8> = (0..W * H * 3).map(|i| (i * 37 % 251) as u8).collect();
        let data = light_field(&image);
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        // Smooth slant: every neighbour step is below 0.3 px.
        let mut input: Vec<f32> = (0..W * H)
            .map(|i| 0.1 * (i % W) as f32 + 0.05 * (i / W) as f32)
            .collect();
        input[7] = f32::NAN;
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch).unwrap();
        for (a, b) in out.iter().zip(&input) {
            assert_eq!(a.to_bits(), b.to_bits());
        }
    }

    #[test]
    fn short_scratch_and_wrong_sizes_are_errors() {
        let plan = plan();
        let data = vec![0u8; W * H * 3 * 9];
        let lf = LightField::new(&data, *plan.layout()).unwrap();
        let input = vec![0.0f32; W * H];
        let mut out = vec![0.0f32; W * H];
        let mut scratch = vec![0.0f32; scratch_len(&plan) - 1];
        assert!(matches!(
            fill(&plan, &lf.center_view(), &input, &mut out, &mut scratch),
            Err(Error::ScratchTooSmall { .. })
        ));
        let mut scratch = vec![0.0f32; scratch_len(&plan)];
        assert!(matches!(
            fill(
                &plan,
                &lf.center_view(),
                &input[1..],
                &mut out,
                &mut scratch
            ),
            Err(Error::OutputSize { .. })
        ));
    }

    #[test]
    fn a_stream_refuses_the_refill() {
        let params = *plan().params();
        let params = Params {
            refine: crate::refine::RefineParams::off(),
            median: crate::median::MedianParams::off(),
            tv: crate::tv::TvParams {
                sweeps: 0,
                ..params.tv
            },
            epi: crate::epi::EpiParams {
                range: crate::epi::DisparityRange::Fixed {
                    min: -1.0,
                    max: 1.0,
                },
                ..params.epi
            },
            ..params
        };
        let layout = *plan().layout();
        assert!(matches!(
            crate::stream::StreamPlan::new(layout, params),
            Err(Error::InvalidParameter {
                name: "geofill.enabled",
                ..
            })
        ));
        let off = Params {
            geofill: GeoFillParams::off(),
            ..params
        };
        assert!(crate::stream::StreamPlan::new(layout, off).is_ok());
    }

    #[test]
    fn parameters_are_checked() {
        let ok = GeoFillParams::default();
        assert!(ok.validate().is_ok());
        for bad in [
            GeoFillParams { band: 0, ..ok },
            GeoFillParams { reach: 4, ..ok },
            GeoFillParams {
                step: f32::NAN,
                ..ok
            },
            GeoFillParams {
                spatial: -1.0,
                ..ok
            },
            GeoFillParams { sweeps: 0, ..ok },
            GeoFillParams {
                max_cost: 0.0,
                ..ok
            },
        ] {
            assert!(matches!(
                bad.validate(),
                Err(Error::InvalidParameter { .. })
            ));
        }
    }
}
