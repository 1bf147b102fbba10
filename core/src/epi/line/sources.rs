//! Where a shear hypothesis reads every view: an offset into the stored planes, or a
//! fallback plane interpolated for it.

use super::estimator::{LineEstimator, COARSE_VIEWS};
use crate::epi::planes::{shift, Planes, Sources};
use crate::lightfield::GRID_MAX;
use crate::scalar::Scalar;
use core::ops::Range;

impl<T: Scalar> LineEstimator<T> {
    /// Where hypothesis `shear` reads every view: the stored planes at a whole-sample
    /// offset (the half-shifted ones for half-sample offsets), or, for any other fraction
    /// and for shifts beyond the stored padding, a fallback plane interpolated here.
    pub(super) fn sources(
        &self,
        planes: &Planes,
        bank: &mut [T],
        shear: f32,
        slots: Range<usize>,
    ) -> Sources {
        let mut sources = Sources {
            d: [[0; GRID_MAX]; 3],
            s: [[0; GRID_MAX]; 3],
            slots: slots.len().min(3),
            active: self.band.active,
        };
        if slots.start >= self.channels {
            for (k, a) in sources.active.iter_mut().enumerate() {
                *a &= k.abs_diff(self.centre) <= COARSE_VIEWS;
            }
        }
        let stored_len = planes.stored_len();
        let half_ready = match &self.coarse {
            Some(coarse) if slots.start >= self.channels => coarse.half_shifts,
            _ => self.half_shifts,
        };
        for k in 0..self.views.min(GRID_MAX) {
            let offset = (k as f32 - self.centre as f32) * shear;
            let floor = libm::floorf(offset);
            let frac = offset - floor;
            let whole = floor as isize;
            let stored_kind = if frac == 0.0 {
                Some(0)
            } else if frac == 0.5 && half_ready {
                Some(2)
            } else {
                None
            };
            for (slot, c) in slots.clone().enumerate().take(3) {
                match stored_kind {
                    Some(kind) if whole.unsigned_abs() <= planes.reach => {
                        // Sample t of the sheared view is stored sample t − whole.
                        let start = |kind| {
                            let at = (planes.plane(kind, k, c) + planes.lead) as isize - whole;
                            at as usize
                        };
                        sources.d[slot][k] = start(kind);
                        sources.s[slot][k] = start(kind + 1);
                    }
                    _ => {
                        let Some((stored, spare)) = bank.split_at_mut_checked(stored_len) else {
                            continue;
                        };
                        for kind in 0..2 {
                            let from = planes.plane(kind, k, c) + planes.lead;
                            let to = planes.fallback(kind, k, c);
                            let at = to.wrapping_sub(stored_len);
                            let (Some(out), Some(input)) = (
                                spare.get_mut(at..at.wrapping_add(planes.n_blocks)),
                                stored.get(from..from + planes.n),
                            ) else {
                                continue;
                            };
                            let Some((line, tail)) = out.split_at_mut_checked(planes.n) else {
                                continue;
                            };
                            shift(input, line, offset);
                            if let Some(&last) = line.last() {
                                tail.fill(last);
                            }
                            if kind == 0 {
                                sources.d[slot][k] = to;
                            } else {
                                sources.s[slot][k] = to;
                            }
                        }
                    }
                }
            }
        }
        sources
    }
}
