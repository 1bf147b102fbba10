//! The tile executor of a [`StreamPlan`]: a band's tiles, each through the EPI stage on
//! its region (rows and columns over cropped lines), the weighted median when the plan
//! runs one, and TV on its TV region.

use core::ops::Range;

use super::{align_down, CrossBand, StreamPlan};
use crate::epi::{fuse, load_line, mix_chroma, Chroma, LineEstimator, LineSpan};
use crate::error::{check_scratch, Error, Result};
use crate::float::clamp_f32;
use crate::lightfield::{Sample, View};
use crate::median;
use crate::scalar::Scalar;
use crate::setup::Setup;
use crate::tv::{self, Guide, Maps, Rect, SolveOutput};

impl StreamPlan {
    /// Estimates band `band` from `input` (which must hold [`StreamPlan::input_rows`]) into
    /// `disparity` and `confidence` (exactly `output_rows(band).len() · width` each,
    /// row-major): for each tile, EPI on its region, the weighted median when the plan
    /// runs one, then TV on the tile's TV region. `scratch` needs
    /// [`StreamPlan::scratch_len`] elements, `maps` [`StreamPlan::map_scratch_len`].
    pub fn process_band<T: Scalar, S: Sample>(
        &self,
        band: usize,
        input: &CrossBand<'_, S>,
        disparity: &mut [f32],
        confidence: &mut [f32],
        scratch: &mut [T],
        maps: &mut [f32],
    ) -> Result<tv::RefineReport> {
        let layout = *self.plan.layout();
        if input.grid != layout.grid
            || input.width != layout.width
            || input.channels != layout.channels
        {
            return Err(Error::InvalidParameter {
                name: "band",
                reason: "must have the grid, width and channels of the stream plan's layout",
            });
        }
        let out_rows = self.output_rows(band)?;
        let need = self.input_rows(band)?;
        if input.rows.start > need.start || input.rows.end < need.end {
            return Err(Error::OutOfRange {
                what: "band row (the band must hold input_rows(band))",
                index: if input.rows.start > need.start {
                    need.start
                } else {
                    need.end - 1
                },
                len: input.rows.end,
            });
        }
        let width = layout.width;
        let out_len = out_rows.len() * width;
        if disparity.len() != out_len || confidence.len() != out_len {
            return Err(Error::OutputSize {
                what: "the band disparity/confidence",
                needed: out_len,
                got: disparity.len().min(confidence.len()),
            });
        }
        for (needed, got) in [
            (self.scratch_len(), scratch.len()),
            (self.map_scratch_len(), maps.len()),
        ] {
            if got < needed {
                return Err(Error::ScratchTooSmall { needed, got });
            }
        }
        let (cols, _) = tv::tile_count(self.plan.tv());
        // The region maps keep the stride of the widest region, so that the columns a
        // tile shares with the previous one of the band move left instead of being
        // estimated again; TV reads them through maps of that width.
        let (stride, max_height) = self.region_size();
        let plane = stride * max_height;
        let short = Error::ScratchTooSmall {
            needed: self.map_scratch_len(),
            got: maps.len(),
        };
        let (map_d, rest) = maps.split_at_mut_checked(plane).ok_or(short)?;
        let (map_c, median_maps) = rest.split_at_mut_checked(plane).ok_or(short)?;
        // Columns past a region's width are never used, but the maps must be finite.
        map_d.fill(0.0);
        map_c.fill(0.0);
        let (r0, c0) = layout.grid.center();
        let centre = CrossBand::<S>::slot(layout.grid, r0, c0).unwrap_or(0);
        let mut report = tv::RefineReport::default();
        let mut previous: Option<Rect> = None;
        let mut local = RegionMaps {
            disparity: map_d,
            confidence: map_c,
            stride,
        };
        for tx in 0..cols {
            let (core, tv_region) = tv::tile_rects(self.plan.tv(), band * cols + tx)?;
            let region = self.grow(tv_region);
            let shared = match previous {
                Some(p) => shift_left(p, region, &mut local),
                None => 0,
            };
            previous = Some(region);
            let fresh = shared..region.width;
            self.epi_rows(input, region, fresh.clone(), &mut local, scratch)?;
            self.epi_columns(input, region, fresh, &mut local, scratch)?;

            let out_start = (core.y - out_rows.start) * width + core.x;
            let out = SolveOutput {
                disparity: disparity.get_mut(out_start..).unwrap_or_default(),
                stride: width,
                history: &mut [],
                dual: None,
            };
            let guide = CentreView {
                input,
                slot: centre,
            };
            let tile = Tile {
                region,
                tv_region,
                core,
            };
            let tile = if self.median_halo == 0 {
                let used = stride * region.height;
                let (Some(used_d), Some(used_c)) =
                    (local.disparity.get(..used), local.confidence.get(..used))
                else {
                    return Err(short);
                };
                let maps = Maps::new(stride, region.height, used_d, used_c)?;
                self.tv_tile(guide, region, &maps, tile, out, scratch)?
            } else {
                self.median_tv_tile(guide, tile, &local, median_maps, out, scratch)?
            };
            report.add(&tile);
            let local_core = (core.x - region.x, core.y - region.y);
            for y in 0..core.height {
                let from = (local_core.1 + y) * stride + local_core.0;
                let to = out_start + y * width;
                let src = local.confidence.get(from..from + core.width);
                let dst = confidence.get_mut(to..to + core.width);
                if let (Some(src), Some(dst)) = (src, dst) {
                    dst.copy_from_slice(src);
                }
            }
        }
        Ok(report)
    }

    /// TV on the tile's TV region of the maps, which cover `maps_rect` of the frame (and,
    /// as the guide, of the centre view), into `out` at the tile's core.
    fn tv_tile<T: Scalar, S: Sample>(
        &self,
        guide: CentreView<'_, '_, S>,
        maps_rect: Rect,
        maps: &Maps<'_>,
        tile: Tile,
        out: SolveOutput<'_>,
        scratch: &mut [T],
    ) -> Result<tv::SolveReport> {
        let layout = self.plan.layout();
        let input = guide.input;
        let start = input.offset(guide.slot, maps_rect.x, maps_rect.y);
        let guide_data = input.data.get(start..).unwrap_or(&[]);
        let guide = Guide::View(View::new(
            guide_data,
            maps.width(),
            maps.height(),
            layout.channels,
            input.row_stride,
        )?);
        let local = |r: Rect| Rect {
            x: r.x - maps_rect.x,
            y: r.y - maps_rect.y,
            width: r.width,
            height: r.height,
        };
        tv::solve(
            maps,
            &guide,
            &self.plan.params().tv,
            local(tile.tv_region),
            local(tile.core),
            out,
            scratch,
        )
    }

    /// The weighted median over the tile's region (all its passes,
    /// [`median::filter_band`] on the region as a frame of its own: the median's halo
    /// makes the TV region's rows of it the whole frame's), then TV on the TV region of
    /// its output. `epi` holds the region's EPI disparity and confidence.
    #[inline(never)]
    fn median_tv_tile<T: Scalar, S: Sample>(
        &self,
        centre_view: CentreView<'_, '_, S>,
        tile: Tile,
        epi: &RegionMaps<'_>,
        maps: &mut [f32],
        out: SolveOutput<'_>,
        scratch: &mut [T],
    ) -> Result<tv::SolveReport> {
        let layout = self.plan.layout();
        let (input, centre) = (centre_view.input, centre_view.slot);
        let Tile {
            region, tv_region, ..
        } = tile;
        let (stride, map_d, map_c) = (epi.stride, &*epi.disparity, &*epi.confidence);
        let pixels = region.width * region.height;
        let (rw, rh) = self.region_size();
        let short = Error::ScratchTooSmall {
            needed: self.map_scratch_len(),
            got: maps.len(),
        };
        let (packed, rest) = maps.split_at_mut_checked(rw * rh).ok_or(short)?;
        let (median_scratch, rest) = rest
            .split_at_mut_checked(self.median_scratch_len())
            .ok_or(short)?;
        let tv_len = tv_region.height * region.width;
        let (packed, filtered) = (
            packed.get_mut(..pixels).ok_or(short)?,
            rest.get_mut(..tv_len).ok_or(short)?,
        );
        // The median reads the region row-major, `region.width` apart.
        let rows = map_d.chunks(stride.max(1)).take(region.height);
        for (to, from) in packed.chunks_mut(region.width.max(1)).zip(rows) {
            for (t, f) in to.iter_mut().zip(from) {
                *t = *f;
            }
        }
        let region_layout = self.region_layout(region.width, region.height);
        let setup = Setup::new(&region_layout, &self.plan.params().median)?;
        let start = input.offset(centre, region.x, region.y);
        let guide = View::new(
            input.data.get(start..).unwrap_or(&[]),
            region.width,
            region.height,
            layout.channels,
            input.row_stride,
        )?;
        let first = tv_region.y - region.y;
        median::filter_band(
            setup,
            &guide,
            packed,
            first..first + tv_region.height,
            filtered,
            median_scratch,
            &mut [],
        )?;
        // TV reads the EPI confidence of the TV region's rows, packed as the median's
        // output; the median's scratch is free again.
        let confidence = median_scratch.get_mut(..tv_len).ok_or(short)?;
        let rows = map_c
            .chunks(stride.max(1))
            .skip(first)
            .take(tv_region.height);
        for (to, from) in confidence.chunks_mut(region.width.max(1)).zip(rows) {
            for (t, f) in to.iter_mut().zip(from) {
                *t = *f;
            }
        }
        let maps = Maps::new(region.width, tv_region.height, filtered, confidence)?;
        let maps_rect = Rect {
            x: region.x,
            y: tv_region.y,
            width: region.width,
            height: tv_region.height,
        };
        self.tv_tile(centre_view, maps_rect, &maps, tile, out, scratch)
    }

    /// Horizontal lines: image rows of the region, cropped to its columns ± margin.
    /// Writes the local columns `fresh` of every region row into `out`.
    fn epi_rows<T: Scalar, S: Sample>(
        &self,
        input: &CrossBand<'_, S>,
        region: Rect,
        fresh: Range<usize>,
        out: &mut RegionMaps<'_>,
        scratch: &mut [T],
    ) -> Result<()> {
        if fresh.is_empty() {
            return Ok(());
        }
        let x0 = align_down((region.x + fresh.start).saturating_sub(self.margin_h));
        let x1 = (region.x + fresh.end + self.margin_h).min(self.plan.layout().width);
        let n = x1 - x0;
        let lines = Lines {
            axis: Axis::Rows,
            indices: 0..region.height,
            origin: (x0, region.y),
            n,
            // To the line's end: placing stops after the `fresh` columns.
            keep: region.x + fresh.start - x0..n,
        };
        let (map_d, map_c, stride) = (&mut *out.disparity, &mut *out.confidence, out.stride);
        self.epi_lines(input, lines, scratch, |ly, estimates| {
            let row = ly * stride + fresh.start..ly * stride + fresh.end;
            let (Some(out_d), Some(out_c)) = (map_d.get_mut(row.clone()), map_c.get_mut(row))
            else {
                return;
            };
            for ((o, oc), (d, c)) in out_d.iter_mut().zip(out_c).zip(estimates) {
                (*o, *oc) = (d, c);
            }
        })
    }

    /// Vertical lines: image columns `fresh` of the region, cropped to its rows ±
    /// margin, fused into the horizontal estimate.
    fn epi_columns<T: Scalar, S: Sample>(
        &self,
        input: &CrossBand<'_, S>,
        region: Rect,
        fresh: Range<usize>,
        out: &mut RegionMaps<'_>,
        scratch: &mut [T],
    ) -> Result<()> {
        if fresh.is_empty() {
            return Ok(());
        }
        let y0 = align_down(region.y.saturating_sub(self.margin_v));
        let y1 = (region.y + region.height + self.margin_v).min(self.plan.layout().height);
        let first = region.y - y0;
        let lines = Lines {
            axis: Axis::Columns,
            indices: fresh,
            origin: (region.x, y0),
            n: y1 - y0,
            keep: first..first + region.height,
        };
        let fusion = self.plan.params().epi.fusion;
        let (map_d, map_c, stride) = (&mut *out.disparity, &mut *out.confidence, out.stride);
        self.epi_lines(input, lines, scratch, |lx, estimates| {
            // Column `lx` of the region maps: every `stride`-th element from `lx`.
            let column_d = map_d.iter_mut().skip(lx).step_by(stride.max(1));
            let column_c = map_c.iter_mut().skip(lx).step_by(stride.max(1));
            for ((od, oc), (dv, cv)) in column_d.zip(column_c).zip(estimates) {
                (*od, *oc) = fuse(fusion, *od, *oc, dv, cv);
            }
        })
    }

    /// Estimates the EPI lines `lines` of the centre row's views (horizontal) or the
    /// centre column's (vertical) and hands `place` each line's index and its estimates
    /// on the samples that land in the region. Not inlined, so that only one line
    /// estimator (a few KiB) is on the stack at a time.
    #[inline(never)]
    fn epi_lines<T: Scalar, S: Sample>(
        &self,
        input: &CrossBand<'_, S>,
        lines: Lines,
        scratch: &mut [T],
        mut place: impl FnMut(usize, Estimates<'_, T>),
    ) -> Result<()> {
        let layout = self.plan.layout();
        let params = &self.plan.params().epi;
        let grid = layout.grid;
        let (r0, c0) = grid.center();
        let h = &self.hypotheses;
        let (lo, hi) = (h.min(), h.max());
        let ch_n = layout.channels;
        let color = params.color;
        let chroma = Chroma::of(params);
        // The views a line crosses, the centre one among them, and the step between a
        // line's samples.
        let (views, centre, step) = match lines.axis {
            Axis::Rows => (grid.cols, c0, ch_n),
            Axis::Columns => (grid.rows, r0, input.row_stride),
        };
        let n = lines.n;
        let estimator = LineEstimator::<T>::new(params, *h, views, centre, ch_n);
        let (d_line, c_line, work) = split_line(scratch, &estimator, n)?;
        // The band slot of the line's view `k`.
        let slot = |k: usize| match lines.axis {
            Axis::Rows => CrossBand::<S>::slot(grid, r0, k),
            Axis::Columns => CrossBand::<S>::slot(grid, k, c0),
        };
        let (ox, oy) = lines.origin;
        for line in lines.indices {
            let (x, y) = match lines.axis {
                Axis::Rows => (ox, oy + line),
                Axis::Columns => (ox + line, oy),
            };
            let load = |k: usize, out: &mut [T]| {
                let start = input.offset(slot(k).unwrap_or(0), x, y);
                load_line(
                    input.data,
                    BAND_BUFFER,
                    LineSpan {
                        start,
                        step,
                        channels: ch_n,
                        n,
                    },
                    color,
                    out,
                )?;
                mix_chroma(color, ch_n, chroma, n, out);
                Ok(())
            };
            estimator.estimate(n, load, work, d_line, c_line)?;
            let keep = lines.keep.clone();
            let (Some(d), Some(c)) = (d_line.get(keep.clone()), c_line.get(keep)) else {
                continue;
            };
            place(
                line,
                Estimates {
                    disparity: d.iter(),
                    confidence: c.iter(),
                    lo,
                    hi,
                },
            );
        }
        Ok(())
    }
}

/// The direction of a set of EPI lines.
#[derive(Clone, Copy)]
enum Axis {
    /// Image rows through the centre row's views.
    Rows,
    /// Image columns through the centre column's views.
    Columns,
}

/// Where the EPI lines of one direction run through a region: line `i` of `indices`
/// (local rows or columns of the region) starts at the frame pixel `origin` moved by
/// `i` across the lines, and has `n` samples, of which those at `keep` land in the
/// region.
struct Lines {
    axis: Axis,
    indices: Range<usize>,
    origin: (usize, usize),
    n: usize,
    keep: Range<usize>,
}

/// One line's estimates as the region maps take them: (disparity clamped to the
/// hypotheses' range, confidence clamped to [0, 1]) per sample.
struct Estimates<'l, T> {
    disparity: core::slice::Iter<'l, T>,
    confidence: core::slice::Iter<'l, T>,
    lo: f32,
    hi: f32,
}

impl<T: Scalar> Iterator for Estimates<'_, T> {
    type Item = (f32, f32);

    #[inline(always)]
    fn next(&mut self) -> Option<(f32, f32)> {
        let (d, c) = (self.disparity.next()?, self.confidence.next()?);
        Some((
            clamp_f32(d.to_f32(), self.lo, self.hi),
            c.to_f32().clamp(0.0, 1.0),
        ))
    }
}

/// The EPI maps of a tile's region: row `y` of the region starts at `y · stride`.
struct RegionMaps<'a> {
    disparity: &'a mut [f32],
    confidence: &'a mut [f32],
    /// The row stride (the widest region's width).
    stride: usize,
}

/// The centre view's samples in a band: the median's and TV's guide.
struct CentreView<'b, 'd, S: Sample> {
    input: &'b CrossBand<'d, S>,
    /// The centre view's slot in the band.
    slot: usize,
}

impl<S: Sample> Clone for CentreView<'_, '_, S> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<S: Sample> Copy for CentreView<'_, '_, S> {}

/// The rectangles of one tile in the frame: the region whose EPI maps are estimated
/// (the TV region grown by the median's halo), the TV region, and the core it writes.
#[derive(Clone, Copy)]
struct Tile {
    region: Rect,
    tv_region: Rect,
    core: Rect,
}

/// Moves the columns that `region` shares with `previous` (the tile to its left in the
/// same band) to the left edge of the maps; returns how many there are.
fn shift_left(previous: Rect, region: Rect, maps: &mut RegionMaps<'_>) -> usize {
    let (map_d, map_c, stride) = (&mut *maps.disparity, &mut *maps.confidence, maps.stride);
    if region.y != previous.y || region.height != previous.height || region.x < previous.x {
        return 0;
    }
    let shared = (previous.x + previous.width)
        .saturating_sub(region.x)
        .min(region.width);
    let dx = region.x - previous.x;
    if shared == 0 || dx + shared > stride {
        return 0;
    }
    for ly in 0..region.height {
        let from = ly * stride + dx;
        if from + shared > map_d.len().min(map_c.len()) {
            return 0;
        }
        // Row `ly` from its start to the shared columns' end: `dx` then `shared` samples.
        let row = ly * stride..from + shared;
        if let (Some(d), Some(c)) = (map_d.get_mut(row.clone()), map_c.get_mut(row)) {
            if dx <= d.len() && dx <= c.len() {
                d.copy_within(dx.., 0);
                c.copy_within(dx.., 0);
            }
        }
    }
    shared
}

/// Splits scratch into one line's disparity, confidence and work.
#[allow(clippy::type_complexity)]
fn split_line<'s, T: Scalar>(
    scratch: &'s mut [T],
    estimator: &LineEstimator<T>,
    n: usize,
) -> Result<(&'s mut [T], &'s mut [T], &'s mut [T])> {
    let needed = estimator.line_work_len(n) + 2 * n;
    check_scratch(needed, scratch.len())?;
    let short = Error::ScratchTooSmall {
        needed,
        got: scratch.len(),
    };
    let (d, rest) = scratch.split_at_mut_checked(n).ok_or(short)?;
    let (c, work) = rest.split_at_mut_checked(n).ok_or(short)?;
    Ok((d, c, work))
}

/// Names the band buffer in the loader's error.
const BAND_BUFFER: &str = "the band buffer";
