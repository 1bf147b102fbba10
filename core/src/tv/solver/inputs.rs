//! What a solve reads: the maps, where the edge weights come from, and the rectangles.

use crate::error::{checked_product, Error, Result};
use crate::lightfield::{Sample, View};

#[cfg(doc)]
use super::super::params::TvParams;

/// The per-pixel inputs of the stage: EPI disparity and confidence, row-major, top row
/// first, `width × height` each.
#[derive(Clone, Copy, Debug)]
pub struct Maps<'a> {
    pub(super) width: usize,
    pub(super) height: usize,
    pub(super) disparity: &'a [f32],
    pub(super) confidence: &'a [f32],
    /// The dual `(F_h, F_v)` per pixel of a previous sweep over the whole map (see
    /// [`Maps::with_dual`]).
    pub(super) dual: Option<&'a [f32]>,
}

impl<'a> Maps<'a> {
    /// Checks sizes and that every value is finite (confidence is clamped to [0, 1] when used).
    pub fn new(
        width: usize,
        height: usize,
        disparity: &'a [f32],
        confidence: &'a [f32],
    ) -> Result<Self> {
        let all = Rect {
            x: 0,
            y: 0,
            width,
            height,
        };
        Self::checked_in(width, height, disparity, confidence, all)
    }

    /// [`Maps::new`] that checks the values only inside `region` (clipped to the map):
    /// what one tile reads. Every pixel lies in some tile's region, so a run over all
    /// tiles refuses a non-finite value as [`Maps::new`] does, without every tile
    /// reading the whole map.
    pub fn checked_in(
        width: usize,
        height: usize,
        disparity: &'a [f32],
        confidence: &'a [f32],
        region: Rect,
    ) -> Result<Self> {
        let pixels = checked_product(&[width, height], "the disparity map")?;
        if width == 0 || height == 0 {
            return Err(Error::ViewTooSmall { width, height });
        }
        for (what, map) in [("disparity", disparity), ("confidence", confidence)] {
            if map.len() != pixels {
                return Err(Error::OutputSize {
                    what,
                    needed: pixels,
                    got: map.len(),
                });
            }
            if !all_finite(map, width, height, region, 1) {
                return Err(Error::NonFinite { what });
            }
        }
        Ok(Maps {
            width,
            height,
            disparity,
            confidence,
            dual: None,
        })
    }

    /// Adds the dual `(F_h, F_v)` per pixel (`2 × width × height`, row-major, as
    /// [`SolveOutput::dual`](crate::tv::SolveOutput::dual) writes it) of a previous sweep
    /// over the whole map. A solve then starts from it and holds the flows on the edges
    /// that cross its region's border fixed at its values (an outer sweep that exchanges
    /// halos, see [`TvParams::sweeps`]): a tile no longer sees a free border, so tiled
    /// results approach the untiled one.
    pub fn with_dual(self, dual: &'a [f32]) -> Result<Self> {
        let all = Rect {
            x: 0,
            y: 0,
            width: self.width,
            height: self.height,
        };
        self.with_dual_checked_in(dual, all)
    }

    /// [`Maps::with_dual`] that checks the dual only where a solve of `region` reads it:
    /// the region and one pixel beyond its left and top edges (the flows of the edges
    /// that enter it there are stored at the pixel outside).
    pub fn with_dual_checked_in(self, dual: &'a [f32], region: Rect) -> Result<Self> {
        let needed = 2 * self.width * self.height;
        if dual.len() != needed {
            return Err(Error::OutputSize {
                what: "the previous sweep's dual",
                needed,
                got: dual.len(),
            });
        }
        let grown = Rect {
            x: region.x.saturating_sub(1),
            y: region.y.saturating_sub(1),
            width: region.width + usize::from(region.x > 0),
            height: region.height + usize::from(region.y > 0),
        };
        if !all_finite(dual, self.width, self.height, grown, 2) {
            return Err(Error::NonFinite {
                what: "the previous sweep's dual",
            });
        }
        Ok(Maps {
            dual: Some(dual),
            ..self
        })
    }
    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }
    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }
}

/// Whether every value of `map` (`per_pixel` values per pixel of a `width × height` map,
/// row-major) inside `region` (clipped to the map) is finite.
fn all_finite(map: &[f32], width: usize, height: usize, region: Rect, per_pixel: usize) -> bool {
    let columns = region.x.min(width)..(region.x + region.width).min(width);
    (region.y.min(height)..(region.y + region.height).min(height)).all(|y| {
        let row = (y * width + columns.start) * per_pixel..(y * width + columns.end) * per_pixel;
        map.get(row)
            .is_some_and(|row| row.iter().all(|v| v.is_finite()))
    })
}

/// Where the edge weights come from.
#[derive(Clone, Copy, Debug)]
pub enum Guide<'a, P: Sample> {
    /// The centre view (same size as the maps), through [`TvParams::edge_sigma`].
    View(View<'a, P>),
    /// Given weights (≥ 0, finite): `horizontal[i]` for the edge `i → i+1`, `vertical[i]`
    /// for `i → i+width`, row-major like the maps (entries of edges leaving the image
    /// are ignored).
    Weights {
        /// Right-neighbour edge weights.
        horizontal: &'a [f32],
        /// Down-neighbour edge weights.
        vertical: &'a [f32],
    },
}

/// A rectangle of pixels.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct Rect {
    /// Left column.
    pub x: usize,
    /// Top row.
    pub y: usize,
    /// Columns.
    pub width: usize,
    /// Rows.
    pub height: usize,
}

impl Rect {
    pub(super) fn pixels(&self) -> usize {
        self.width.saturating_mul(self.height)
    }
    pub(super) fn contains(&self, other: &Rect) -> bool {
        let end = |start: usize, len: usize| start.checked_add(len);
        match (
            end(self.x, self.width),
            end(self.y, self.height),
            end(other.x, other.width),
            end(other.y, other.height),
        ) {
            (Some(sx), Some(sy), Some(ox), Some(oy)) => {
                other.x >= self.x && other.y >= self.y && ox <= sx && oy <= sy
            }
            _ => false,
        }
    }
}

pub(super) fn check_guide<P: Sample>(
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    region: Rect,
) -> Result<()> {
    match guide {
        Guide::View(view) => {
            if view.width() != maps.width || view.height() != maps.height {
                return Err(Error::InvalidParameter {
                    name: "guide view",
                    reason: "must have the size of the disparity map",
                });
            }
            // Only the region (one row and column beyond it for the edges) is read.
            let ch = view.channels();
            let x0 = region.x * ch;
            let x1 = ((region.x + region.width + 1).min(view.width())) * ch;
            let mut finite = true;
            for y in region.y..(region.y + region.height + 1).min(view.height()) {
                if let Some(row) = view.row(y).and_then(|r| r.get(x0..x1)) {
                    finite &= row.iter().all(|s| s.is_finite());
                }
            }
            if !finite {
                return Err(Error::NonFinite {
                    what: "the guide view",
                });
            }
        }
        Guide::Weights {
            horizontal,
            vertical,
        } => {
            let pixels = maps.width * maps.height;
            for (what, w) in [
                ("horizontal edge weights", horizontal),
                ("vertical edge weights", vertical),
            ] {
                if w.len() != pixels {
                    return Err(Error::OutputSize {
                        what,
                        needed: pixels,
                        got: w.len(),
                    });
                }
                if w.iter().any(|v| !v.is_finite() || *v < 0.0) {
                    return Err(Error::InvalidParameter {
                        name: "edge weights",
                        reason: "must be finite and non-negative",
                    });
                }
            }
        }
    }
    Ok(())
}
