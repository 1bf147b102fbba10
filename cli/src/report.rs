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

/// The warning for an estimate with NaN or infinite pixels in the evaluated window, or
/// `None`. The benchmark's protocol counts such a pixel as good (NaN compares false), so
/// the BadPix scores of a map with holes look better than they are.
pub fn invalid_warning(scores: &Scores) -> Option<String> {
    (scores.invalid_pct > 0.0).then(|| {
        format!(
            "{:.3} % of the evaluated pixels of the estimate are NaN or infinite: the benchmark's protocol counts them as good pixels, so BadPix is lower than the map deserves",
            scores.invalid_pct
        )
    })
}

fn scores_value(scores: &Scores) -> Value {
    let mut map: serde_json::Map<String, Value> = METRICS
        .iter()
        .map(|(_, key, get)| ((*key).to_string(), finite_json(get(scores))))
        .collect();
    if let Some(warning) = invalid_warning(scores) {
        map.insert("warning".into(), json!(warning));
    }
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
/// (`badpix007`, `badpix003`, `badpix001`, `mse100`, `q25`, `invalid_pct`), and
/// `warning` when [`invalid_warning`] has one.
pub fn scores_json(scores: &Scores) -> String {
    scores_value(scores).to_string()
}

/// One scene of a dataset evaluation.
#[derive(Clone, Debug)]
pub struct SceneRow {
    /// The scene folder relative to the dataset root.
    pub scene: String,
    /// Its scores, or why it could not be scored.
    pub result: Result<Scores, String>,
    /// Wall time to load and estimate it.
    pub seconds: f64,
}

/// The mean of every metric and of the time over the scenes that were scored.
fn mean(rows: &[SceneRow]) -> (Vec<f64>, f64) {
    let scored: Vec<(&Scores, f64)> = rows
        .iter()
        .filter_map(|r| r.result.as_ref().ok().map(|s| (s, r.seconds)))
        .collect();
    if scored.is_empty() {
        return (vec![f64::NAN; 5], f64::NAN);
    }
    let n = scored.len() as f64;
    let metrics = METRICS[..5]
        .iter()
        .map(|(_, _, get)| scored.iter().map(|(s, _)| get(s)).sum::<f64>() / n)
        .collect();
    (metrics, scored.iter().map(|(_, t)| t).sum::<f64>() / n)
}

/// Rows that failed, `(scene, why)`.
fn failures(rows: &[SceneRow]) -> Vec<(&str, &str)> {
    rows.iter()
        .filter_map(|r| {
            r.result
                .as_ref()
                .err()
                .map(|e| (r.scene.as_str(), e.as_str()))
        })
        .collect()
}

/// A Markdown table: one row per scene (`failed` for a scene that could not be scored),
/// then the mean over the scored scenes; below it a `warning:` line per scene whose
/// estimate has invalid pixels and an `error:` line per failed scene.
pub fn dataset_markdown(rows: &[SceneRow]) -> String {
    let mut out = String::from(
        "| scene | BadPix0.07 | BadPix0.03 | BadPix0.01 | MSE×100 | Q25 | seconds |\n",
    );
    out.push_str("|---|---:|---:|---:|---:|---:|---:|\n");
    let line = |name: &str, values: &[f64], seconds: f64| {
        let cells: String = values.iter().map(|v| format!(" {v:.3} |")).collect();
        format!("| {name} |{cells} {seconds:.2} |\n")
    };
    let mut notes = String::new();
    for row in rows {
        match &row.result {
            Ok(scores) => {
                let values: Vec<f64> = METRICS[..5].iter().map(|(_, _, get)| get(scores)).collect();
                let name = match invalid_warning(scores) {
                    Some(warning) => {
                        notes.push_str(&format!("warning: {}: {warning}\n", row.scene));
                        format!("{} (invalid pixels!)", row.scene)
                    }
                    None => row.scene.clone(),
                };
                out.push_str(&line(&name, &values, row.seconds));
            }
            Err(why) => {
                notes.push_str(&format!("error: {}: {why}\n", row.scene));
                out.push_str(&format!(
                    "| {} | failed | – | – | – | – | {:.2} |\n",
                    row.scene, row.seconds
                ));
            }
        }
    }
    let (values, seconds) = mean(rows);
    let failed = failures(rows).len();
    let label = if failed == 0 {
        "**mean**".to_string()
    } else {
        format!("**mean** of {} scored", rows.len() - failed)
    };
    out.push_str(&line(&label, &values, seconds));
    if !notes.is_empty() {
        out.push('\n');
        out.push_str(&notes);
    }
    out
}

/// The same table as JSON: `{"scenes": [{"scene", metrics…, "seconds"}], "mean": {…}}`;
/// a failed scene has `"error"` instead of metrics, a scene with invalid pixels a
/// `"warning"`, and `"failed"` counts the failed scenes.
pub fn dataset_json(rows: &[SceneRow]) -> String {
    let scenes: Vec<Value> = rows
        .iter()
        .map(|r| {
            let mut v = match &r.result {
                Ok(scores) => scores_value(scores),
                Err(why) => json!({ "error": why }),
            };
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
    json!({
        "scenes": scenes,
        "mean": Value::Object(mean_map),
        "failed": failures(rows).len(),
    })
    .to_string()
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
                result: Ok(scores(1.0)),
                seconds: 1.0,
            },
            SceneRow {
                scene: "b".into(),
                result: Ok(scores(3.0)),
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
        assert!(!scores_json(&nan).contains("warning"));
    }

    #[test]
    fn failed_scenes_and_invalid_pixels_are_reported() {
        let mut holes = scores(1.0);
        holes.invalid_pct = 25.0;
        let rows = [
            SceneRow {
                scene: "a".into(),
                result: Ok(holes),
                seconds: 1.0,
            },
            SceneRow {
                scene: "b".into(),
                result: Err("b/input_Cam003.png: damaged".into()),
                seconds: 0.5,
            },
        ];
        let md = dataset_markdown(&rows);
        assert!(md.contains("| a (invalid pixels!) | 1.000 |"), "{md}");
        assert!(md.contains("| b | failed |"), "{md}");
        assert!(md.contains("| **mean** of 1 scored | 1.000 |"), "{md}");
        assert!(md.contains("warning: a: 25.000 %"), "{md}");
        assert!(md.contains("error: b: b/input_Cam003.png: damaged"), "{md}");
        let json: Value = serde_json::from_str(&dataset_json(&rows)).unwrap();
        assert_eq!(json["failed"], json!(1));
        assert!(json["scenes"][0]["warning"]
            .as_str()
            .unwrap()
            .contains("25.000 %"));
        assert_eq!(
            json["scenes"][1]["error"],
            json!("b/input_Cam003.png: damaged")
        );
        assert_eq!(json["mean"]["badpix007"], json!(1.0));
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
