//! Progress reports of long work, and the callback's answer that cancels it.

use core::ops::ControlFlow;

use crate::error::{Error, Result};

/// A progress report: `done` of `total` units of `stage` are finished.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Progress {
    /// Name of the running stage (each stage module's `STAGE` constants: `"epi
    /// horizontal"`, `"refine"`, `"tv"`, …).
    pub stage: &'static str,
    /// Units finished.
    pub done: u64,
    /// Units in the stage.
    pub total: u64,
}

/// Tells `progress` that `done` of `total` units of `stage` are finished;
/// [`Error::Cancelled`] when it answers `ControlFlow::Break(())`.
pub fn report(
    progress: &mut dyn FnMut(Progress) -> ControlFlow<()>,
    stage: &'static str,
    done: usize,
    total: usize,
) -> Result<()> {
    match progress(Progress {
        stage,
        done: done as u64,
        total: total as u64,
    }) {
        ControlFlow::Continue(()) => Ok(()),
        ControlFlow::Break(()) => Err(Error::Cancelled),
    }
}
