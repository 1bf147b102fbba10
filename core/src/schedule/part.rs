//! What one part of a step writes and needs: its output buffers, its scratch, and where
//! its output goes in the maps of the run.

use crate::error::{Error, Result};
use crate::tv::Rect;

/// Lengths (`f32` elements) of one part's outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PartLen {
    /// Disparity (or, for [`Step::Range`](super::Step::Range), the range's two ends).
    pub disparity: usize,
    /// Confidence.
    pub confidence: usize,
    /// TV residual history (first sweep only).
    pub history: usize,
    /// TV dual for the next sweep (every sweep but the last).
    pub dual: usize,
    /// The plane sweep's per-pixel candidate (with `PlaneSweepParams::candidate`).
    pub candidate: usize,
}

impl PartLen {
    /// All of them together.
    pub fn total(&self) -> usize {
        self.disparity
            .saturating_add(self.confidence)
            .saturating_add(self.history)
            .saturating_add(self.dual)
            .saturating_add(self.candidate)
    }
    pub(super) fn max(self, other: PartLen) -> PartLen {
        PartLen {
            disparity: self.disparity.max(other.disparity),
            confidence: self.confidence.max(other.confidence),
            history: self.history.max(other.history),
            dual: self.dual.max(other.dual),
            candidate: self.candidate.max(other.candidate),
        }
    }
}

/// Scratch one part of a step needs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct ScratchLen {
    /// Elements of the kernel scalar `T`.
    pub kernel: usize,
    /// `f32` elements.
    pub maps: usize,
    /// Bytes of flags (optional: a part given none computes the same result, slower).
    pub flags: usize,
}

impl ScratchLen {
    pub(super) fn max(self, other: ScratchLen) -> ScratchLen {
        ScratchLen {
            kernel: self.kernel.max(other.kernel),
            maps: self.maps.max(other.maps),
            flags: self.flags.max(other.flags),
        }
    }
}

/// Where one part's output goes in the maps of the run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Region {
    /// Lines `start..end` of a map (image rows, or for vertical EPI lines, columns
    /// stored line after line).
    Lines(usize, usize),
    /// A rectangle of the image (a TV tile's core).
    Rect(Rect),
    /// Not a map region: the EPI range.
    Range,
}

/// One part's outputs, `PartLen` elements each.
pub struct PartOutput<'a> {
    /// Disparity of the part's region, row-major (for [`Step::Range`](super::Step::Range): `[min, max]`).
    pub disparity: &'a mut [f32],
    /// Confidence of the part's region.
    pub confidence: &'a mut [f32],
    /// TV residual history (squared dual updates per iteration, added to).
    pub history: &'a mut [f32],
    /// TV dual of the region for the next sweep.
    pub dual: &'a mut [f32],
    /// The plane sweep's per-pixel candidate of the region.
    pub candidate: &'a mut [f32],
}

impl<'a> PartOutput<'a> {
    /// Cuts a part's outputs of `len` from the front of `buffer`.
    pub fn split(buffer: &'a mut [f32], len: PartLen) -> Result<Self> {
        let short = Error::ScratchTooSmall {
            needed: len.total(),
            got: buffer.len(),
        };
        let (disparity, rest) = buffer.split_at_mut_checked(len.disparity).ok_or(short)?;
        let (confidence, rest) = rest.split_at_mut_checked(len.confidence).ok_or(short)?;
        let (history, rest) = rest.split_at_mut_checked(len.history).ok_or(short)?;
        let (dual, rest) = rest.split_at_mut_checked(len.dual).ok_or(short)?;
        let (candidate, _) = rest.split_at_mut_checked(len.candidate).ok_or(short)?;
        Ok(PartOutput {
            disparity,
            confidence,
            history,
            dual,
            candidate,
        })
    }
}

/// One part's scratch ([`ScratchLen`]).
pub struct PartScratch<'a, T> {
    /// Kernel scalars.
    pub kernel: &'a mut [T],
    /// `f32` maps.
    pub maps: &'a mut [f32],
    /// Flag bytes (may be empty).
    pub flags: &'a mut [u8],
}

pub(super) fn write_range(out: &mut [f32], (min, max): (f32, f32)) -> Result<()> {
    match out {
        [lo, hi, ..] => {
            (*lo, *hi) = (min, max);
            Ok(())
        }
        _ => Err(Error::OutputSize {
            what: "the range part",
            needed: 2,
            got: out.len(),
        }),
    }
}

pub(super) fn put(map: &mut [f32], at: usize, values: &[f32]) -> Result<()> {
    let got = map.len();
    let short = Error::OutputSize {
        what: "a map of the run",
        needed: at.saturating_add(values.len()),
        got,
    };
    let to = map.get_mut(at..).ok_or(short)?;
    if to.len() < values.len() {
        return Err(short);
    }
    for (t, v) in to.iter_mut().zip(values) {
        *t = *v;
    }
    Ok(())
}
