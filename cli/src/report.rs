//! Human- and machine-readable reports: stage timings, scores, dataset tables.

use std::time::Duration;

/// Stage timings, one per line, then the total: `epi 1.234 s`.
pub fn timings(stages: &[(&'static str, Duration)]) -> String {
    let width = stages
        .iter()
        .map(|(n, _)| n.len())
        .max()
        .unwrap_or(0)
        .max(5);
    let mut out = String::new();
    for (name, time) in stages {
        out.push_str(&format!("{name:<width$} {:>8.3} s\n", time.as_secs_f64()));
    }
    let total: Duration = stages.iter().map(|(_, t)| *t).sum();
    out.push_str(&format!(
        "{:<width$} {:>8.3} s\n",
        "total",
        total.as_secs_f64()
    ));
    out
}
