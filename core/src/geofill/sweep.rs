//! The geodesic distance transform: raster sweeps that carry each band pixel's
//! cheapest path to a seed.

use crate::error::{Error, Result};
use crate::lightfield::{Sample, View};

use super::access::{at, put};

/// Marks a pixel that neither takes part nor changes (non-finite outside the band).
pub(super) const BLOCKED: f32 = -1.0;

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
pub(super) struct Field<'a, 'g, S: Sample> {
    pub(super) guide: &'a View<'g, S>,
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) channels: usize,
    /// 0 at seeds, [`BLOCKED`] where nothing passes, the best path cost so far (`+∞`
    /// before any) in the band.
    pub(super) dist: &'a mut [f32],
    /// Offset from the pixel to its seed.
    pub(super) off_x: &'a mut [f32],
    pub(super) off_y: &'a mut [f32],
    pub(super) reach: f32,
    pub(super) spatial: f32,
}

impl<'g, S: Sample> Field<'_, 'g, S> {
    /// One raster sweep, forward (top-left to bottom-right) or backward: every band
    /// pixel relaxes from the four neighbours the sweep has already visited.
    pub(super) fn sweep<const BACKWARD: bool>(&mut self) -> Result<()> {
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
