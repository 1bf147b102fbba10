//! Step outcomes and the end-of-run summary that CI reads.

/// How one step ended.
#[derive(Clone, Debug, PartialEq)]
pub enum Outcome {
    Passed,
    /// Why it failed.
    Failed(String),
    /// Why it did not run.
    Skipped(String),
}

/// One row of the summary.
#[derive(Clone, Debug, PartialEq)]
pub struct StepResult {
    pub name: String,
    pub outcome: Outcome,
    pub seconds: f64,
}

/// Counts of passed, failed and skipped steps.
pub fn counts(results: &[StepResult]) -> (usize, usize, usize) {
    let mut counts = (0, 0, 0);
    for r in results {
        match r.outcome {
            Outcome::Passed => counts.0 += 1,
            Outcome::Failed(_) => counts.1 += 1,
            Outcome::Skipped(_) => counts.2 += 1,
        }
    }
    counts
}

/// The summary table, ending with the line `N passed, M failed, K skipped`.
pub fn summary(results: &[StepResult]) -> String {
    let width = results
        .iter()
        .map(|r| r.name.len())
        .chain(["step".len()])
        .max()
        .unwrap_or(4);
    let mut out = format!(
        "{:<width$}  {:<7}  {:>8}  note\n",
        "step", "result", "seconds"
    );
    for r in results {
        let (result, note) = match &r.outcome {
            Outcome::Passed => ("passed", ""),
            Outcome::Failed(why) => ("FAILED", why.as_str()),
            Outcome::Skipped(why) => ("skipped", why.as_str()),
        };
        // A failure's note can be a whole command output; its first line says enough here.
        let note = note.lines().next().unwrap_or("");
        let line = format!(
            "{:<width$}  {result:<7}  {:>8.1}  {note}",
            r.name, r.seconds
        );
        out.push_str(line.trim_end());
        out.push('\n');
    }
    let (passed, failed, skipped) = counts(results);
    out.push_str(&format!(
        "{passed} passed, {failed} failed, {skipped} skipped"
    ));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn step(name: &str, outcome: Outcome, seconds: f64) -> StepResult {
        StepResult {
            name: name.into(),
            outcome,
            seconds,
        }
    }

    #[test]
    fn summary_lists_every_step_and_ends_with_the_counts() {
        let results = [
            step("fmt", Outcome::Passed, 0.44),
            step(
                "clippy",
                Outcome::Failed("`cargo clippy` exited with 1\nmore".into()),
                12.0,
            ),
            step(
                "node-tests",
                Outcome::Skipped("no tests/node/*.test.mjs".into()),
                0.0,
            ),
        ];
        let text = summary(&results);
        let lines: Vec<&str> = text.lines().collect();
        assert_eq!(lines.len(), 5, "{text}");
        assert_eq!(lines[0], "step        result    seconds  note");
        assert_eq!(lines[1], "fmt         passed        0.4");
        assert_eq!(
            lines[2],
            "clippy      FAILED       12.0  `cargo clippy` exited with 1"
        );
        assert_eq!(
            lines[3],
            "node-tests  skipped       0.0  no tests/node/*.test.mjs"
        );
        assert_eq!(lines[4], "1 passed, 1 failed, 1 skipped");
    }

    #[test]
    fn an_empty_run_still_prints_the_count_line() {
        assert!(summary(&[]).ends_with("\n0 passed, 0 failed, 0 skipped"));
    }
}
