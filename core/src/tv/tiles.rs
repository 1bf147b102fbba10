//! Tiles: cores of `tile × tile` pixels solved on the core plus a halo, so tiles are
//! independent (any order, any thread) and the result is bit-identical however they run.

use core::ops::ControlFlow;

use crate::error::{check_scratch, checked_product, Error, Result};
use crate::lightfield::Sample;
use crate::progress::Progress;
use crate::scalar::Scalar;
use crate::setup::Setup;

use super::solver::{scratch_len_for, solve, Guide, Maps, Rect, SolveOutput, SolveReport};
use super::TvParams;

/// What a whole refinement did.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct RefineReport {
    /// Tile solves (tiles × passes, with the outer sweeps).
    pub tiles: usize,
    /// Most iterations any tile ran.
    pub max_iterations: usize,
    /// Iterations summed over tiles.
    pub total_iterations: usize,
    /// Tiles that met the stopping rule.
    pub converged_tiles: usize,
}

impl RefineReport {
    /// Adds one tile's report.
    pub fn add(&mut self, tile: &SolveReport) {
        self.tiles += 1;
        self.max_iterations = self.max_iterations.max(tile.iterations);
        self.total_iterations += tile.iterations;
        self.converged_tiles += usize::from(tile.converged);
    }
}

fn region_side(tile: usize, halo: usize, len: usize) -> usize {
    tile.saturating_add(halo.saturating_mul(2)).min(len)
}

/// Scratch elements (of the scalar type) one tile needs: the same for every tile and
/// independent of the image size beyond one tile plus halo.
pub fn scratch_len(setup: Setup<'_, TvParams>) -> usize {
    let tv = setup.params();
    let layout = setup.layout();
    scratch_len_for(
        region_side(tv.tile, tv.halo, layout.width),
        region_side(tv.tile, tv.halo, layout.height),
    )
}

/// Number of tiles `(columns, rows)`.
pub fn tile_count(setup: Setup<'_, TvParams>) -> (usize, usize) {
    let tile = setup.params().tile.max(1);
    let layout = setup.layout();
    (layout.width.div_ceil(tile), layout.height.div_ceil(tile))
}

/// The core and the region (core + halo, clipped to the image) of tile `index`
/// (row-major over [`tile_count`]).
pub fn tile_rects(setup: Setup<'_, TvParams>, index: usize) -> Result<(Rect, Rect)> {
    let (cols, rows) = tile_count(setup);
    if index >= cols * rows {
        return Err(Error::OutOfRange {
            what: "tile",
            index,
            len: cols * rows,
        });
    }
    let tv = setup.params();
    let (w, h) = (setup.layout().width, setup.layout().height);
    // `cols > 0` (checked above); the checked forms keep the division's panic out.
    let (tx, ty) = (
        index.checked_rem(cols).unwrap_or_default(),
        index.checked_div(cols).unwrap_or_default(),
    );
    let x0 = tx * tv.tile;
    let y0 = ty * tv.tile;
    let core = Rect {
        x: x0,
        y: y0,
        width: tv.tile.min(w - x0),
        height: tv.tile.min(h - y0),
    };
    let rx0 = x0.saturating_sub(tv.halo);
    let ry0 = y0.saturating_sub(tv.halo);
    let rx1 = (x0 + core.width + tv.halo).min(w);
    let ry1 = (y0 + core.height + tv.halo).min(h);
    let region = Rect {
        x: rx0,
        y: ry0,
        width: rx1 - rx0,
        height: ry1 - ry0,
    };
    Ok((core, region))
}

fn check_maps(setup: Setup<'_, TvParams>, maps: &Maps<'_>) -> Result<()> {
    let layout = setup.layout();
    if maps.width() != layout.width || maps.height() != layout.height {
        return Err(Error::InvalidParameter {
            name: "maps",
            reason: "must have the size of the plan's views",
        });
    }
    Ok(())
}

/// Solves tile `index` and writes its core into `out` (core pixel `(x, y)` at
/// `out.disparity[y · out.stride + x]`), adding its residual history to `out.history`.
pub fn refine_tile<S: Scalar, P: Sample>(
    setup: Setup<'_, TvParams>,
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    index: usize,
    out: SolveOutput<'_>,
    scratch: &mut [S],
) -> Result<SolveReport> {
    check_maps(setup, maps)?;
    let (core, region) = tile_rects(setup, index)?;
    solve(maps, guide, setup.params(), region, core, out, scratch)
}

/// Turns a history accumulated over every tile (squared dual updates) into the RMS dual
/// update per node and iteration — the residual norm curve.
pub fn normalise_history(setup: Setup<'_, TvParams>, history: &mut [f32]) {
    let (cols, rows) = tile_count(setup);
    let mut nodes = 0usize;
    for index in 0..cols * rows {
        if let Ok((_, region)) = tile_rects(setup, index) {
            nodes += region.width * region.height;
        }
    }
    let nodes = nodes.max(1) as f32;
    for h in history.iter_mut() {
        *h = crate::float::sqrtf(*h / nodes);
    }
}

/// Floats of caller memory [`refine`] needs for the outer sweeps
/// ([`super::TvParams::sweeps`]): two duals of the whole map, or nothing without sweeps.
pub fn dual_len(setup: Setup<'_, TvParams>) -> usize {
    if setup.params().sweeps == 0 {
        0
    } else {
        setup.pixels().saturating_mul(4)
    }
}

/// The caller-owned memory of [`refine`].
#[derive(Debug)]
pub struct TvScratch<'a, S> {
    /// Kernel scalars: [`scratch_len`] elements.
    pub kernel: &'a mut [S],
    /// [`dual_len`] floats: carries the dual from one outer sweep to the next.
    pub duals: &'a mut [f32],
}

/// Refines the whole map, tile after tile: `out` (`width × height`) gets the refined
/// disparity, `history[n]` the RMS dual update at iteration `n` of the first pass (see
/// [`normalise_history`]; pass an empty slice to skip it).
pub fn refine<S: Scalar, P: Sample>(
    setup: Setup<'_, TvParams>,
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    out: &mut [f32],
    history: &mut [f32],
    scratch: TvScratch<'_, S>,
) -> Result<RefineReport> {
    refine_with_progress(setup, maps, guide, out, history, scratch, &mut |_| {
        ControlFlow::Continue(())
    })
}

/// [`refine`], reporting each tile solve to `progress` (stage [`super::STAGE`]; done out
/// of tiles × passes); `ControlFlow::Break(())` stops with [`Error::Cancelled`].
pub fn refine_with_progress<S: Scalar, P: Sample>(
    setup: Setup<'_, TvParams>,
    maps: &Maps<'_>,
    guide: &Guide<'_, P>,
    out: &mut [f32],
    history: &mut [f32],
    scratch: TvScratch<'_, S>,
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
) -> Result<RefineReport> {
    let TvScratch {
        kernel: scratch,
        duals,
    } = scratch;
    check_maps(setup, maps)?;
    if out.len() != setup.pixels() {
        return Err(Error::OutputSize {
            what: "the refined disparity",
            needed: setup.pixels(),
            got: out.len(),
        });
    }
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    let needed = dual_len(setup);
    let short = Error::BufferTooSmall {
        what: "the outer sweeps' duals",
        needed,
        got: duals.len(),
    };
    let duals = duals.get_mut(..needed).ok_or(short)?;
    let (mut previous, mut next) = duals.split_at_mut_checked(needed / 2).ok_or(short)?;
    history.fill(0.0);
    let width = setup.layout().width;
    let sweeps = setup.params().sweeps;
    let (cols, rows) = tile_count(setup);
    let tiles = checked_product(&[cols, rows], "the TV tiles")?;
    let solves = checked_product(&[tiles, sweeps + 1], "the TV tile solves")?;
    let mut report = RefineReport::default();
    for sweep in 0..=sweeps {
        let maps = if sweep == 0 {
            *maps
        } else {
            maps.with_dual(previous)?
        };
        for index in 0..tiles {
            tell(progress, sweep * tiles + index, solves)?;
            let (core, _) = tile_rects(setup, index)?;
            let start = core.y * width + core.x;
            let got = out.len();
            let disparity = out.get_mut(start..).ok_or(Error::OutputSize {
                what: "the refined disparity",
                needed: start,
                got,
            })?;
            let tile = refine_tile(
                setup,
                &maps,
                guide,
                index,
                SolveOutput {
                    disparity,
                    stride: width,
                    history: if sweep == 0 { &mut *history } else { &mut [] },
                    dual: if sweep < sweeps {
                        next.get_mut(2 * start..)
                    } else {
                        None
                    },
                },
                scratch,
            )?;
            report.add(&tile);
        }
        core::mem::swap(&mut previous, &mut next);
    }
    normalise_history(setup, history);
    tell(progress, solves, solves)?;
    Ok(report)
}

fn tell(
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
    done: usize,
    total: usize,
) -> Result<()> {
    match progress(Progress {
        stage: super::STAGE,
        done: done as u64,
        total: total as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}
