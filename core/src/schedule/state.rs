//! The maps a run carries from step to step, in one caller-owned buffer.

use crate::epi::{self, Fusion, Hypotheses};
use crate::error::{Error, Result};
use crate::plan::Plan;

use super::Schedule;

/// Which map plays which part, and the EPI range: everything of a [`State`] that is
/// not in its buffer. A driver that keeps the buffer between calls keeps this beside it
/// ([`State::cursor`], [`State::resume`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cursor {
    /// The buffer's map (0…3) holding the current disparity, the current confidence,
    /// the other disparity and the other confidence.
    slots: [usize; 4],
    /// The first of the two duals is the previous sweep's (the second receives the
    /// next).
    dual_first: bool,
    hypotheses: Option<Hypotheses>,
}

impl Default for Cursor {
    fn default() -> Self {
        Cursor {
            slots: [0, 1, 2, 3],
            dual_first: true,
            hypotheses: None,
        }
    }
}

pub(super) const CURRENT_D: usize = 0;
pub(super) const CURRENT_C: usize = 1;
pub(super) const OTHER_D: usize = 2;
pub(super) const OTHER_C: usize = 3;

/// The state of a run over a buffer of [`Schedule::state_len`] floats: four maps of
/// `plan.pixels()` (the current disparity and confidence, and the other pair), the two
/// TV duals when TV sweeps, and the residual history.
pub struct State<'a> {
    buffer: &'a mut [f32],
    pixels: usize,
    duals: usize,
    cursor: Cursor,
}

/// Maps handed to a [`State`] by [`State::set`] (`None`: leave as it is).
#[derive(Clone, Copy, Debug, Default)]
pub struct StateMaps<'a> {
    /// The current disparity.
    pub disparity: Option<&'a [f32]>,
    /// The current confidence.
    pub confidence: Option<&'a [f32]>,
    /// The other disparity.
    pub other_disparity: Option<&'a [f32]>,
    /// The other confidence.
    pub other_confidence: Option<&'a [f32]>,
    /// The previous sweep's TV dual.
    pub dual: Option<&'a [f32]>,
}

impl<'a> State<'a> {
    /// A new run's state in `buffer` ([`Schedule::state_len`] floats; the history is
    /// cleared, the maps are left as they are).
    pub fn new(schedule: &Schedule, buffer: &'a mut [f32]) -> Result<Self> {
        Self::resume(schedule, buffer, Cursor::default())
    }

    /// The state of a run that left `buffer` at `cursor` (from [`State::cursor`]).
    pub fn resume(schedule: &Schedule, buffer: &'a mut [f32], cursor: Cursor) -> Result<Self> {
        let needed = schedule.state_len();
        let got = buffer.len();
        let buffer = buffer
            .get_mut(..needed)
            .ok_or(Error::ScratchTooSmall { needed, got })?;
        let mut state = State {
            buffer,
            pixels: schedule.plan().pixels(),
            duals: schedule.dual_len(),
            cursor,
        };
        if cursor == Cursor::default() {
            state.history_mut().fill(0.0);
        }
        Ok(state)
    }

    /// What to keep beside the buffer to [`State::resume`] the run.
    pub fn cursor(&self) -> Cursor {
        self.cursor
    }

    // The buffer holds `Schedule::state_len` floats (checked when the state is made), so
    // every range below lies in it; the checked forms keep panics out of the firmware.
    fn map_range(&self, which: usize) -> core::ops::Range<usize> {
        let start = self.cursor.slots.get(which).copied().unwrap_or(which) * self.pixels;
        start..start + self.pixels
    }

    pub(super) fn map(&self, which: usize) -> &[f32] {
        self.buffer.get(self.map_range(which)).unwrap_or(&[])
    }

    pub(super) fn map_mut(&mut self, which: usize) -> &mut [f32] {
        let range = self.map_range(which);
        self.buffer.get_mut(range).unwrap_or(&mut [])
    }

    fn dual_range(&self, previous: bool) -> core::ops::Range<usize> {
        let first = previous == self.cursor.dual_first;
        let start = 4 * self.pixels + if first { 0 } else { self.duals };
        start..start + self.duals
    }

    /// The current disparity (row-major, `plan.pixels()`): the result after the last
    /// step.
    pub fn disparity(&self) -> &[f32] {
        self.map(CURRENT_D)
    }

    /// The current confidence.
    pub fn confidence(&self) -> &[f32] {
        self.map(CURRENT_C)
    }

    /// The other disparity and confidence (after the vertical EPI step: its estimates,
    /// transposed; in the fused start, after the plane sweep: its maps).
    pub fn other(&self) -> (&[f32], &[f32]) {
        (self.map(OTHER_D), self.map(OTHER_C))
    }

    /// The previous sweep's TV dual (empty without sweeps).
    pub fn dual(&self) -> &[f32] {
        self.buffer.get(self.dual_range(true)).unwrap_or(&[])
    }

    pub(super) fn next_dual_mut(&mut self) -> &mut [f32] {
        let range = self.dual_range(false);
        self.buffer.get_mut(range).unwrap_or(&mut [])
    }

    pub(super) fn swap_duals(&mut self) {
        self.cursor.dual_first = !self.cursor.dual_first;
    }

    pub(super) fn swap_maps(&mut self, a: usize, b: usize) {
        self.cursor.slots.swap(a, b);
    }

    /// The TV residual curve: after the TV steps, the RMS dual update per node and
    /// iteration of the first sweep (zero past the iterations no tile ran).
    pub fn history(&self) -> &[f32] {
        self.buffer
            .get(4 * self.pixels + 2 * self.duals..)
            .unwrap_or(&[])
    }

    pub(super) fn history_mut(&mut self) -> &mut [f32] {
        let start = 4 * self.pixels + 2 * self.duals;
        self.buffer.get_mut(start..).unwrap_or(&mut [])
    }

    /// The EPI hypotheses, once the range step ran.
    pub fn hypotheses(&self) -> Option<Hypotheses> {
        self.cursor.hypotheses
    }

    pub(super) fn set_hypotheses(&mut self, hypotheses: Hypotheses) {
        self.cursor.hypotheses = Some(hypotheses);
    }

    /// Fuses the horizontal estimates (the current maps, row-major) with the vertical
    /// ones (the other maps, transposed) into the current maps, pixel by pixel; with no
    /// `fusion` (a column of cameras has no horizontal estimates) the vertical ones are
    /// taken as they are.
    pub(super) fn fuse(&mut self, fusion: Option<Fusion>, width: usize, height: usize) {
        let (d, c) = (self.map_range(CURRENT_D), self.map_range(CURRENT_C));
        let (dv, cv) = (self.map_range(OTHER_D), self.map_range(OTHER_C));
        for y in 0..height {
            for x in 0..width {
                let (p, t) = (y * width + x, x * height + y);
                let at = |range: &core::ops::Range<usize>, i: usize| range.start + i;
                let get = |i: usize| self.buffer.get(i).copied().unwrap_or(f32::NAN);
                let vertical = (get(at(&dv, t)), get(at(&cv, t)));
                let (fd, fc) = match fusion {
                    Some(fusion) => epi::fuse(
                        fusion,
                        get(at(&d, p)),
                        get(at(&c, p)),
                        vertical.0,
                        vertical.1,
                    ),
                    None => vertical,
                };
                if let Some(v) = self.buffer.get_mut(at(&d, p)) {
                    *v = fd;
                }
                if let Some(v) = self.buffer.get_mut(at(&c, p)) {
                    *v = fc;
                }
            }
        }
    }

    /// The range the EPI stage tests, once the range step ran.
    pub fn range(&self) -> Option<(f32, f32)> {
        self.cursor.hypotheses.map(|h| (h.min(), h.max()))
    }

    /// Sets what the parts of a step read, as a worker holding a copy of the state does:
    /// the maps given and the EPI range (when given).
    pub fn set(
        &mut self,
        plan: &Plan,
        maps: StateMaps<'_>,
        range: Option<(f32, f32)>,
    ) -> Result<()> {
        let pairs = [
            (CURRENT_D, maps.disparity),
            (CURRENT_C, maps.confidence),
            (OTHER_D, maps.other_disparity),
            (OTHER_C, maps.other_confidence),
        ];
        for (which, map) in pairs {
            if let Some(map) = map {
                copy_into(self.map_mut(which), map, "a map of the run")?;
            }
        }
        if let Some(dual) = maps.dual {
            let range = self.dual_range(true);
            let to = self.buffer.get_mut(range).unwrap_or(&mut []);
            copy_into(to, dual, "the TV dual")?;
        }
        if let Some((min, max)) = range {
            self.set_hypotheses(Hypotheses::new(&plan.params().epi, min, max)?);
        }
        Ok(())
    }
}

fn copy_into(to: &mut [f32], from: &[f32], what: &'static str) -> Result<()> {
    if to.len() != from.len() {
        return Err(Error::OutputSize {
            what,
            needed: to.len(),
            got: from.len(),
        });
    }
    for (t, f) in to.iter_mut().zip(from) {
        *t = *f;
    }
    Ok(())
}
