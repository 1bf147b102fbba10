//! Streaming estimation for firmware: rows of the cross views arrive band by band as from
//! a sensor, and the disparity of each band leaves before the next arrives, from scratch
//! whose size does not depend on the frame size.
//!
//! The stream is one more executor of the plan's [`Schedule`]: [`StreamPlan::new`] walks
//! its steps and runs each on regions of the frame, refusing the steps it cannot run
//! band by band (see there). The frame is cut into the TV tiles of the plan
//! (`params.tv.tile`, `params.tv.halo`, see [`crate::tv::tile_rects`]); a *band* is one
//! row of tiles. For each tile the stream computes on the tile's TV region (core + TV
//! halo) grown by the weighted median's halo ([`crate::median::halo`], `passes ·
//! (radius + 1)`, when the plan runs the median before TV):
//!
//! 1. the EPI stage on the region, over EPI lines cropped to the region plus a margin that
//!    covers the shear and the filters (the columns a region shares with the previous
//!    tile of the band are moved rather than estimated again);
//! 2. the weighted median over the region as a frame of its own: a pixel's value after
//!    every pass depends only on the input within the median's halo, so the TV region's
//!    rows are the whole frame's;
//! 3. TV on the TV region, writing the core.
//!
//! The crop margin makes every region sample bit-identical to the whole-frame EPI stage,
//! the median's halo makes the median's TV region bit-identical, and the TV regions are
//! the pipeline's own, so a stream gives exactly what [`crate::pipeline::run`] gives with
//! the same parameters: the tests `stream_equals_the_whole_frame_pipeline` and
//! `stream_with_the_median_equals_the_whole_frame_pipeline` check it.
//!
//! Memory: the input band ([`CrossBand`], the 17 cross views of a 9×9 grid, rows
//! [`StreamPlan::input_rows`]), the output rows, and two scratch slices sized by
//! [`StreamPlan::scratch_len`] (kernel scalars) and [`StreamPlan::map_scratch_len`]
//! (`f32` maps of one region: the EPI disparity and confidence, and with the median its
//! input, its scratch and its output). Both depend on the tile, halos, margin and grid,
//! never on the frame width or height (for frames larger than one region).
//!
//! The disparity range must be given ([`DisparityRange::Fixed`]): the automatic range
//! probes the whole frame. The photometric refinement, the geodesic refill, a median
//! after TV, TV's outer sweeps and the alignment are not streamed (the views must be
//! rectified).

use core::ops::Range;

use crate::align::AlignMode;
use crate::epi::{ColorMode, DisparityRange, Hypotheses, LineEstimator};
use crate::error::{checked_product, Error, Result};
use crate::lightfield::{Grid, Layout, Sample};
use crate::median;
use crate::plan::{Params, Plan};
use crate::schedule::{Schedule, Stages, Step};
use crate::setup::Setup;
use crate::tv::{self, Rect};

/// Largest kernel radius of the EPI filters (`MAX_RADIUS` of the EPI kernels).
const MAX_KERNEL_RADIUS: usize = 16;

/// Radius of a Gaussian truncated at 3σ, as the EPI kernels build it.
fn gaussian_radius(sigma: f32) -> usize {
    if sigma > 0.0 {
        (libm::ceilf(3.0 * sigma) as usize).min(MAX_KERNEL_RADIUS - 1)
    } else {
        0
    }
}

/// The rows of one band of the cross views, held by the caller.
///
/// Slots: view `(r0, c)` of the centre row is slot `c`; view `(r, c0)` of the centre
/// column, `r ≠ r0`, is slot `cols + r` for `r < r0` and `cols + r − 1` above (see
/// [`CrossBand::slot`]): `rows + cols − 1` views. Slot `s` holds image row `y` of
/// `rows` at `data[s · view_stride + (y − rows.start) · row_stride + x · channels]`.
#[derive(Clone, Debug)]
pub struct CrossBand<'a, S: Sample> {
    data: &'a [S],
    grid: Grid,
    width: usize,
    channels: usize,
    rows: Range<usize>,
    row_stride: usize,
    view_stride: usize,
}

impl<'a, S: Sample> CrossBand<'a, S> {
    /// Number of views a band holds for `grid`.
    pub fn slots(grid: Grid) -> usize {
        (grid.rows + grid.cols).saturating_sub(1)
    }

    /// The slot of view `(row, col)`, or `None` when it is not on the cross.
    pub fn slot(grid: Grid, row: usize, col: usize) -> Option<usize> {
        let (r0, c0) = grid.center();
        if row == r0 && col < grid.cols {
            Some(col)
        } else if col == c0 && row < grid.rows {
            Some(grid.cols + if row < r0 { row } else { row - 1 })
        } else {
            None
        }
    }

    /// A band of image rows `rows` of every cross view of `layout`'s grid, the views of
    /// `layout.width` pixels of `layout.channels` samples. Checks that `data` holds them.
    pub fn new(
        data: &'a [S],
        layout: &Layout,
        rows: Range<usize>,
        row_stride: usize,
        view_stride: usize,
    ) -> Result<Self> {
        layout.validate()?;
        if rows.start >= rows.end || rows.end > layout.height {
            return Err(Error::OutOfRange {
                what: "band end row",
                index: rows.end,
                len: layout.height,
            });
        }
        let row_len = checked_product(&[layout.width, layout.channels], "a band row")?;
        if row_stride < row_len {
            return Err(Error::Stride {
                which: "band row stride",
                stride: row_stride,
                needed: row_len,
            });
        }
        let view_len = checked_product(&[rows.len() - 1, row_stride], "a band view")?
            .checked_add(row_len)
            .ok_or(Error::SizeOverflow {
                what: "a band view",
            })?;
        if view_stride < view_len {
            return Err(Error::Stride {
                which: "band view stride",
                stride: view_stride,
                needed: view_len,
            });
        }
        let needed = checked_product(&[Self::slots(layout.grid) - 1, view_stride], "a band")?
            .checked_add(view_len)
            .ok_or(Error::SizeOverflow { what: "a band" })?;
        if data.len() < needed {
            return Err(Error::BufferTooSmall {
                what: "the band buffer",
                needed,
                got: data.len(),
            });
        }
        Ok(CrossBand {
            data,
            grid: layout.grid,
            width: layout.width,
            channels: layout.channels,
            rows,
            row_stride,
            view_stride,
        })
    }

    /// A packed band: rows `width · channels` apart, views `rows.len()` rows apart.
    pub fn packed(data: &'a [S], layout: &Layout, rows: Range<usize>) -> Result<Self> {
        let row_stride = checked_product(&[layout.width, layout.channels], "a band row")?;
        let view_stride = checked_product(&[rows.len(), row_stride], "a band view")?;
        Self::new(data, layout, rows, row_stride, view_stride)
    }

    /// The image rows the band holds.
    pub fn rows(&self) -> Range<usize> {
        self.rows.clone()
    }

    /// Where pixel `x` of row `y` of slot `slot` starts in the buffer.
    fn offset(&self, slot: usize, x: usize, y: usize) -> usize {
        slot * self.view_stride + (y - self.rows.start) * self.row_stride + x * self.channels
    }
}

/// A validated streaming plan: the frame plan, the resolved hypotheses and the crop
/// margins of the EPI lines.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StreamPlan {
    plan: Plan,
    hypotheses: Hypotheses,
    /// Samples beyond a region the horizontal / vertical EPI lines need.
    margin_h: usize,
    margin_v: usize,
    /// Pixels the weighted median reads beyond a TV region (0: no median).
    median_halo: usize,
}

/// Samples a line needs beyond the outputs it must reproduce exactly: the outer smoothing,
/// the shear (`views_out` views from the centre at the largest shear, plus one sample of
/// linear interpolation) and the inner filters (a Gaussian widened by one sample by the
/// derivative and the Scharr smoothing). The radii follow the EPI kernels; the test
/// `stream_equals_the_whole_frame_pipeline` fails if the margin falls 2 samples short.
fn line_margin(params: &Params, hypotheses: &Hypotheses, views_out: usize) -> usize {
    let count = hypotheses.count();
    let shear = libm::fabsf(hypotheses.shear(0))
        .max(libm::fabsf(hypotheses.shear(count.saturating_sub(1))));
    let shift = libm::ceilf(shear * views_out as f32) as usize + 1;
    gaussian_radius(params.epi.outer_sigma) + shift + gaussian_radius(params.epi.inner_sigma) + 1
}

impl StreamPlan {
    /// Validates `layout` and `params` for streaming. The stages come from the plan's
    /// [`Schedule`]: the stream runs each step of it on the regions of a band (the
    /// range is the fixed one, the EPI directions on each region with the lines cropped,
    /// the weighted median before TV on the region grown by its halo, TV's first sweep on
    /// the region), and refuses a step it cannot run band by band, naming the parameter
    /// that switches it off: the photometric refinement, the geodesic refill, the median
    /// after TV, TV's outer sweeps, the plane sweep and the half-resolution EPI's
    /// upsampling. The disparity
    /// range must be fixed (or the shear off), the alignment off and the grid two-dimensional.
    pub fn new(layout: Layout, params: Params) -> Result<Self> {
        let plan = Plan::new(layout, params)?;
        if layout.grid.is_linear() {
            return Err(Error::InvalidParameter {
                name: "grid",
                reason: "is one row or column of views: a stream fuses both EPI directions of a grid; run the whole-frame pipeline for a linear array",
            });
        }
        if params.fused {
            return Err(Error::InvalidParameter {
                name: "fused",
                reason: "must be off for a stream: the fused start refines and sweeps whole frames",
            });
        }
        let schedule = Schedule::new(&plan, Stages::Full, 1)?;
        let mut median_halo = 0;
        let mut after_tv = false;
        for &step in schedule.steps() {
            match step {
                // The range is fixed (below); the EPI runs on each region.
                Step::Range | Step::Epi(_) => {}
                Step::Upsample => {
                    return Err(Error::InvalidParameter {
                        name: "half_resolution",
                        reason: "must be off for a stream: the half-resolution EPI is not streamed",
                    })
                }
                Step::PlaneSweep => {
                    return Err(Error::InvalidParameter {
                        name: "sweep.enabled",
                        reason: "must be off for a stream: the plane sweep is not streamed",
                    })
                }
                Step::Fuse => {
                    return Err(Error::InvalidParameter {
                        name: "fused",
                        reason: "must be off for a stream: the fused start refines and sweeps whole frames",
                    })
                }
                Step::Refine => {
                    return Err(Error::InvalidParameter {
                        name: "refine.enabled",
                        reason: "must be off for a stream: the photometric refinement is not streamed",
                    })
                }
                Step::Refill => {
                    return Err(Error::InvalidParameter {
                        name: "geofill.enabled",
                        reason: "must be off for a stream: the geodesic refill is a whole-frame stage",
                    })
                }
                Step::Median if !after_tv => median_halo = median::halo(plan.median()),
                Step::Median => {
                    return Err(Error::InvalidParameter {
                        name: "median.before_tv",
                        reason: "must be true for a stream: a median after TV would read TV's output beyond the tile",
                    })
                }
                Step::Tv { sweep: 0 } => after_tv = true,
                Step::Tv { .. } => {
                    return Err(Error::InvalidParameter {
                        name: "tv.sweeps",
                        reason: "must be 0 for a stream: outer sweeps need the dual of the whole frame",
                    })
                }
            }
        }
        if params.align.mode != AlignMode::Off {
            return Err(Error::InvalidParameter {
                name: "align.mode",
                reason: "must be Off for a stream: it takes rectified views (alignment is a whole-frame stage)",
            });
        }
        let epi = &params.epi;
        let hypotheses = match epi.range {
            DisparityRange::Fixed { min, max } => Hypotheses::new(epi, min, max)?,
            DisparityRange::Auto if !epi.shear => Hypotheses::new(
                epi,
                -crate::epi::MAX_DISPARITY,
                crate::epi::MAX_DISPARITY,
            )?,
            DisparityRange::Auto => {
                return Err(Error::InvalidParameter {
                    name: "epi.range",
                    reason: "must be Fixed for a stream (the automatic range probes the whole frame): give the camera's range",
                })
            }
        };
        let (r0, c0) = layout.grid.center();
        let out_h = c0.max(layout.grid.cols - 1 - c0);
        let out_v = r0.max(layout.grid.rows - 1 - r0);
        Ok(StreamPlan {
            plan,
            hypotheses,
            margin_h: line_margin(&params, &hypotheses, out_h),
            margin_v: line_margin(&params, &hypotheses, out_v),
            median_halo,
        })
    }

    /// The frame plan.
    pub fn plan(&self) -> &Plan {
        &self.plan
    }

    /// The shear hypotheses and output range.
    pub fn hypotheses(&self) -> &Hypotheses {
        &self.hypotheses
    }

    /// Samples the horizontal and vertical EPI lines reach beyond a region.
    pub fn margins(&self) -> (usize, usize) {
        (self.margin_h, self.margin_v)
    }

    /// Number of bands (rows of tiles).
    pub fn bands(&self) -> usize {
        tv::tile_count(self.plan.tv()).1
    }

    /// Image rows of the disparity band `band` writes.
    pub fn output_rows(&self, band: usize) -> Result<Range<usize>> {
        let bands = self.bands();
        if band >= bands {
            return Err(Error::OutOfRange {
                what: "band",
                index: band,
                len: bands,
            });
        }
        let tile = self.plan.params().tv.tile;
        let height = self.plan.layout().height;
        Ok(band * tile..((band + 1) * tile).min(height))
    }

    /// Image rows of the cross views band `band` reads.
    pub fn input_rows(&self, band: usize) -> Result<Range<usize>> {
        let out = self.output_rows(band)?;
        let reach = self.plan.params().tv.halo + self.median_halo + self.margin_v;
        let height = self.plan.layout().height;
        // Vertical lines start on a multiple of `LINE_ALIGN` (see there).
        Ok(align_down(out.start.saturating_sub(reach))..(out.end + reach).min(height))
    }

    /// Most input rows any band reads.
    pub fn max_input_rows(&self) -> usize {
        let tv = &self.plan.params().tv;
        (tv.tile + 2 * (tv.halo + self.median_halo + self.margin_v) + LINE_ALIGN - 1)
            .min(self.plan.layout().height)
    }

    /// Elements of a packed [`CrossBand`] of [`StreamPlan::max_input_rows`] rows.
    pub fn band_len(&self) -> usize {
        let layout = self.plan.layout();
        CrossBand::<u8>::slots(layout.grid)
            .saturating_mul(self.max_input_rows())
            .saturating_mul(layout.width)
            .saturating_mul(layout.channels)
    }

    /// Pixels the weighted median reads beyond a TV region: its passes times its radius
    /// plus one, 0 when the stream runs no median.
    pub fn median_halo(&self) -> usize {
        self.median_halo
    }

    /// Largest TV region (core + halo) side: `(width, height)`.
    fn tv_region_size(&self) -> (usize, usize) {
        let tv = &self.plan.params().tv;
        let layout = self.plan.layout();
        let side = tv.tile + 2 * tv.halo;
        (side.min(layout.width), side.min(layout.height))
    }

    /// Largest region the EPI stage and the median compute on (a TV region grown by the
    /// median's halo) side: `(width, height)`.
    fn region_size(&self) -> (usize, usize) {
        let tv = &self.plan.params().tv;
        let layout = self.plan.layout();
        let side = tv.tile + 2 * (tv.halo + self.median_halo);
        (side.min(layout.width), side.min(layout.height))
    }

    /// The region the EPI stage and the median compute on for the TV region `tv`: grown
    /// by the median's halo, clipped to the frame.
    fn grow(&self, tv: Rect) -> Rect {
        let layout = self.plan.layout();
        let h = self.median_halo;
        let (x0, y0) = (tv.x.saturating_sub(h), tv.y.saturating_sub(h));
        let x1 = (tv.x + tv.width + h).min(layout.width);
        let y1 = (tv.y + tv.height + h).min(layout.height);
        Rect {
            x: x0,
            y: y0,
            width: x1 - x0,
            height: y1 - y0,
        }
    }

    /// The layout of a region `width × height` of the frame: what the median's setup
    /// measures (its data is the band's, addressed through a view).
    fn region_layout(&self, width: usize, height: usize) -> Layout {
        let layout = self.plan.layout();
        Layout::packed(layout.grid, width, height, layout.channels)
    }

    /// Map scratch of the median over the largest region.
    fn median_scratch_len(&self) -> usize {
        if self.median_halo == 0 {
            return 0;
        }
        let (rw, rh) = self.region_size();
        let layout = self.region_layout(rw, rh);
        Setup::new(&layout, &self.plan.params().median).map_or(usize::MAX, median::band_scratch_len)
    }

    /// Kernel scratch (elements of `T`): one EPI line of a region with its margins, or
    /// one TV solve of a TV region, whichever is larger.
    pub fn scratch_len(&self) -> usize {
        let layout = self.plan.layout();
        let (rw, rh) = self.region_size();
        let (tw, th) = self.tv_region_size();
        let channels = match self.plan.params().epi.color {
            ColorMode::Gray => 1,
            ColorMode::Tensor => layout.channels.min(3),
        };
        let line = |views: usize, centre: usize, n: usize| {
            LineEstimator::<f32>::work_len(&self.plan.params().epi, views, centre, channels, n)
                + 2 * n
        };
        let n_h = (rw + 2 * self.margin_h + LINE_ALIGN - 1).min(layout.width);
        let n_v = (rh + 2 * self.margin_v + LINE_ALIGN - 1).min(layout.height);
        let (r0, c0) = layout.grid.center();
        line(layout.grid.cols, c0, n_h)
            .max(line(layout.grid.rows, r0, n_v))
            .max(tv::scratch_len_for(tw, th))
    }

    /// Map scratch (`f32` elements): the EPI disparity and confidence of one region; with
    /// the median also its input, its own scratch ([`median::band_scratch_len`] of the
    /// region) and its output on the TV region's rows.
    pub fn map_scratch_len(&self) -> usize {
        let (rw, rh) = self.region_size();
        let plane = rw.saturating_mul(rh);
        if self.median_halo == 0 {
            return plane.saturating_mul(2);
        }
        let (_, th) = self.tv_region_size();
        plane
            .saturating_mul(3)
            .saturating_add(self.median_scratch_len())
            .saturating_add(th.saturating_mul(rw))
    }

    /// Bytes of both scratch slices with kernel scalars of `bytes_per_scalar` bytes
    /// (4 for `f32` and `Q16`).
    pub fn scratch_bytes(&self, bytes_per_scalar: usize) -> usize {
        self.scratch_len()
            .saturating_mul(bytes_per_scalar)
            .saturating_add(self.map_scratch_len().saturating_mul(4))
    }
}

/// Cropped lines start on multiples of this: the EPI stage scores its coarse pass on
/// every second sample and sums its tensor in blocks of 16, counted from the line's
/// start, so a crop starting elsewhere would round differently from the whole frame.
const LINE_ALIGN: usize = 16;

fn align_down(x: usize) -> usize {
    x / LINE_ALIGN * LINE_ALIGN
}

mod tile;

#[cfg(test)]
mod tests;
