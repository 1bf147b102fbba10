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

mod access;
mod band;
mod params;
mod seeds;
mod sweep;
#[cfg(test)]
mod tests;

use crate::error::{check_map_lengths, check_scratch, checked_product, Error, Result};
use crate::lightfield::{Sample, View};
use crate::setup::Setup;
use band::band_distance;
use seeds::refill_from_seeds;
use sweep::{Field, BLOCKED};

pub use params::{GeoFillParams, MAX_BAND, MAX_SWEEPS};

/// Progress and timing stage name.
pub const STAGE: &str = "geofill";

/// Scratch (`f32` elements) of [`fill`]: the geodesic distance and the offset (x, y) to
/// the nearest seed of every pixel, `3 · pixels`.
pub fn scratch_len(setup: Setup<'_, GeoFillParams>) -> usize {
    setup.pixels().saturating_mul(3)
}

/// Refills the band around the depth steps of `input` (row-major, `setup.pixels()`) into
/// `out` (same size), guided by `guide` (the centre view). `scratch` needs
/// [`scratch_len`] elements. Pixels outside the band and non-finite values are copied
/// unchanged; non-finite values never seed a neighbour.
pub fn fill<S: Sample>(
    setup: Setup<'_, GeoFillParams>,
    guide: &View<'_, S>,
    input: &[f32],
    out: &mut [f32],
    scratch: &mut [f32],
) -> Result<()> {
    let layout = setup.layout();
    let (width, height) = (layout.width, layout.height);
    let pixels = setup.pixels();
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
    let needed = scratch_len(setup);
    check_scratch(needed, scratch.len())?;
    let p = *setup.params();
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
    refill_from_seeds(
        input,
        (dist, off_x, off_y),
        (width, height),
        (p.max_cost, p.planar),
        out,
    );
    Ok(())
}
