//! Human- and machine-readable reports: stage timings, scores, dataset tables.

use std::time::Duration;

use lfdepth::metrics::Scores;
use serde_json::{json, Value};

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

/// A metric: printed name, JSON key (the reference evaluator's), and its value.
type Metric = (&'static str, &'static str, fn(&Scores) -> f64);

/// The metrics in print order.
const METRICS: [Metric; 6] = [
    ("BadPix0.07", "badpix007", |s| s.badpix_007),
    ("BadPix0.03", "badpix003", |s| s.badpix_003),
    ("BadPix0.01", "badpix001", |s| s.badpix_001),
    ("MSE×100", "mse100", |s| s.mse100),
    ("Q25", "q25", |s| s.q25),
    ("invalid%", "invalid_pct", |s| s.invalid_pct),
];

/// One `name value` line per metric, three decimals (e.g. `BadPix0.07 2.594`).
pub fn scores_text(scores: &Scores) -> String {
    METRICS
        .iter()
        .map(|(name, _, get)| format!("{name} {:.3}\n", get(scores)))
        .collect()
}

fn scores_value(scores: &Scores) -> Value {
    let map: serde_json::Map<String, Value> = METRICS
        .iter()
        .map(|(_, key, get)| ((*key).to_string(), finite_json(get(scores))))
        .collect();
    Value::Object(map)
}

/// NaN and infinity are not JSON: they become `null`.
fn finite_json(v: f64) -> Value {
    if v.is_finite() {
        json!(v)
    } else {
        Value::Null
    }
}

/// The scores as a JSON object with the reference evaluator's keys
/// (`badpix007`, `badpix003`, `badpix001`, `mse100`, `q25`, `invalid_pct`).
pub fn scores_json(scores: &Scores) -> String {
    scores_value(scores).to_string()
}

/// One scene of a dataset evaluation.
#[derive(Clone, Debug)]
pub struct SceneRow {
    /// The scene folder relative to the dataset root.
    pub scene: String,
    /// Its scores.
    pub scores: Scores,
    /// Wall time to load and estimate it.
    pub seconds: f64,
}

/// The mean of every metric and of the time over the rows.
fn mean(rows: &[SceneRow]) -> (Vec<f64>, f64) {
    let n = rows.len().max(1) as f64;
    let metrics = METRICS[..5]
        .iter()
        .map(|(_, _, get)| rows.iter().map(|r| get(&r.scores)).sum::<f64>() / n)
        .collect();
    (metrics, rows.iter().map(|r| r.seconds).sum::<f64>() / n)
}

/// A Markdown table: one row per scene, then the mean.
pub fn dataset_markdown(rows: &[SceneRow]) -> String {
    let mut out = String::from(
        "| scene | BadPix0.07 | BadPix0.03 | BadPix0.01 | MSE×100 | Q25 | seconds |\n",
    );
    out.push_str("|---|---:|---:|---:|---:|---:|---:|\n");
    let line = |name: &str, values: &[f64], seconds: f64| {
        let cells: String = values.iter().map(|v| format!(" {v:.3} |")).collect();
        format!("| {name} |{cells} {seconds:.2} |\n")
    };
    for row in rows {
        let values: Vec<f64> = METRICS[..5]
            .iter()
            .map(|(_, _, get)| get(&row.scores))
            .collect();
        out.push_str(&line(&row.scene, &values, row.seconds));
    }
    let (values, seconds) = mean(rows);
    out.push_str(&line("**mean**", &values, seconds));
    out
}

/// The same table as JSON: `{"scenes": [{"scene", metrics…, "seconds"}], "mean": {…}}`.
pub fn dataset_json(rows: &[SceneRow]) -> String {
    let scenes: Vec<Value> = rows
        .iter()
        .map(|r| {
            let mut v = scores_value(&r.scores);
            if let Value::Object(map) = &mut v {
                map.insert("scene".into(), json!(r.scene));
                map.insert("seconds".into(), finite_json(r.seconds));
            }
            v
        })
        .collect();
    let (values, seconds) = mean(rows);
    let mut mean_map: serde_json::Map<String, Value> = METRICS[..5]
        .iter()
        .zip(&values)
        .map(|((_, key, _), v)| ((*key).to_string(), finite_json(*v)))
        .collect();
    mean_map.insert("seconds".into(), finite_json(seconds));
    json!({ "scenes": scenes, "mean": Value::Object(mean_map) }).to_string()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scores(b: f64) -> Scores {
        Scores {
            badpix_007: b,
            badpix_003: 2.0 * b,
            badpix_001: 3.0 * b,
            mse100: 1.3129,
            q25: 0.25,
            invalid_pct: 0.0,
        }
    }

    #[test]
    fn text_lines_are_name_space_value() {
        let text = scores_text(&scores(2.5942));
        assert!(text.starts_with("BadPix0.07 2.594\n"), "{text}");
        assert!(text.contains("\nMSE×100 1.313\n"), "{text}");
    }

    #[test]
    fn tables_end_with_the_mean() {
        let rows = [
            SceneRow {
                scene: "a".into(),
                scores: scores(1.0),
                seconds: 1.0,
            },
            SceneRow {
                scene: "b".into(),
                scores: scores(3.0),
                seconds: 3.0,
            },
        ];
        let md = dataset_markdown(&rows);
        let last = md.lines().last().unwrap();
        assert_eq!(
            last,
            "| **mean** | 2.000 | 4.000 | 6.000 | 1.313 | 0.250 | 2.00 |"
        );
        let json: Value = serde_json::from_str(&dataset_json(&rows)).unwrap();
        assert_eq!(json["mean"]["badpix001"], json!(6.0));
        assert_eq!(json["scenes"][1]["scene"], json!("b"));
        let mut nan = scores(1.0);
        nan.q25 = f64::NAN;
        assert!(scores_json(&nan).contains("\"q25\":null"));
    }

    #[test]
    fn timings_end_with_the_total() {
        let t = timings(&[
            ("epi", Duration::from_millis(1500)),
            ("tv", Duration::from_millis(500)),
        ]);
        assert!(t.lines().last().unwrap().contains("2.000 s"), "{t}");
    }
}
