//! A stage-aware progress bar on stderr, hidden when stderr is not a terminal.

use std::io::IsTerminal;

use indicatif::{ProgressBar, ProgressStyle};

/// Turns the engine's `(stage, done, total)` reports into one progress bar.
pub struct StageProgress {
    bar: ProgressBar,
    stage: String,
}

impl StageProgress {
    /// A bar on stderr; hidden unless stderr is a terminal (or `quiet` is set).
    pub fn new(quiet: bool) -> Self {
        let bar = if quiet || !std::io::stderr().is_terminal() {
            ProgressBar::hidden()
        } else {
            ProgressBar::new(0)
        };
        if let Ok(style) = ProgressStyle::with_template("{msg:>6} [{bar:40}] {pos}/{len} {elapsed}")
        {
            bar.set_style(style.progress_chars("=> "));
        }
        StageProgress {
            bar,
            stage: String::new(),
        }
    }

    /// Records progress of `stage`.
    pub fn update(&mut self, stage: &str, done: u64, total: u64) {
        if stage != self.stage {
            self.stage = stage.to_string();
            self.bar.set_message(self.stage.clone());
            self.bar.reset();
        }
        self.bar.set_length(total);
        self.bar.set_position(done);
    }

    /// Removes the bar.
    pub fn finish(&self) {
        self.bar.finish_and_clear();
    }
}
