//! Comparison with the committed results of an earlier run: rows whose p50 or p99 (or, for a
//! one-number row, its value) moved by more than a threshold are listed, so a regression shows
//! up in the terminal.

use std::fmt::Write;

use serde_json::Value;

/// A change worth printing: ±25 %.
pub(crate) const THRESHOLD: f64 = 0.25;

/// One compared number of a row: its label, value and unit as printed.
struct Number {
    label: &'static str,
    value: f64,
    unit: String,
}

/// Key and numbers of every measured row of a results document: p50 and p99 of a
/// distribution, the value of a one-number row (a size, a CPU share).
fn measured(doc: &Value) -> Vec<(String, Vec<Number>)> {
    let mut out = Vec::new();
    for s in doc["scenarios"].as_array().into_iter().flatten() {
        let name = s["name"].as_str().unwrap_or("?");
        for r in s["rows"].as_array().into_iter().flatten() {
            if r["status"] != "measured" {
                continue;
            }
            let key = format!(
                "{name} / {} / {}",
                r["case"].as_str().unwrap_or("?"),
                r["metric"].as_str().unwrap_or("?")
            );
            let number = |label, field: &str, unit: &str| {
                r[field].as_f64().map(|value| Number {
                    label,
                    value,
                    unit: unit.to_string(),
                })
            };
            let numbers: Vec<Number> = match r["unit"].as_str() {
                Some(unit) => number("", "value", &format!(" {unit}"))
                    .into_iter()
                    .collect(),
                None => [
                    number("p50 ", "p50_us", "µs"),
                    number("p99 ", "p99_us", "µs"),
                ]
                .into_iter()
                .flatten()
                .collect(),
            };
            if !numbers.is_empty() {
                out.push((key, numbers));
            }
        }
    }
    out
}

/// A report of what moved between `before` and `after` (empty when nothing did).
pub(crate) fn changes(before: &Value, after: &Value) -> String {
    let old = measured(before);
    let mut out = String::new();
    let mut compared = 0;
    for (key, numbers) in measured(after) {
        let Some((_, was)) = old.iter().find(|(k, _)| *k == key) else {
            continue;
        };
        if was.len() != numbers.len() {
            continue;
        }
        compared += 1;
        let rel = |new: f64, old: f64| if old > 0.0 { new / old - 1.0 } else { 0.0 };
        let moved = numbers
            .iter()
            .zip(was)
            .any(|(n, o)| rel(n.value, o.value).abs() > THRESHOLD);
        if moved {
            let parts: Vec<String> = numbers
                .iter()
                .zip(was)
                .map(|(n, o)| {
                    format!(
                        "{}{:.0}{} → {:.0}{} ({:+.0}%)",
                        n.label,
                        o.value,
                        o.unit,
                        n.value,
                        n.unit,
                        rel(n.value, o.value) * 100.0
                    )
                })
                .collect();
            let _ = writeln!(out, "  {key}: {}", parts.join(", "));
        }
    }
    if compared == 0 {
        return String::new();
    }
    let header = format!(
        "compared with the run of {} ({}): {compared} rows, {} moved by more than {:.0}%\n",
        before["date"].as_str().unwrap_or("?"),
        before["revision"].as_str().unwrap_or("?"),
        out.lines().count(),
        THRESHOLD * 100.0
    );
    header + out.as_str()
}

#[cfg(test)]
mod tests {
    use serde_json::json;

    use super::*;

    fn doc(p50: f64) -> Value {
        json!({"date": "d", "revision": "r", "scenarios": [{"name": "s", "rows": [
            {"status": "measured", "case": "c", "metric": "m", "p50_us": p50, "p99_us": 10.0},
            {"status": "not_yet_available", "case": "x", "metric": "—"}
        ]}]})
    }

    fn size(bytes: f64) -> Value {
        json!({"date": "d", "revision": "r", "scenarios": [{"name": "footprint", "rows": [
            {"status": "measured", "case": "c", "metric": "size", "unit": "bytes", "value": bytes}
        ]}]})
    }

    #[test]
    fn a_one_number_row_is_compared_by_its_value() {
        assert!(changes(&size(100.0), &size(110.0)).contains("1 rows, 0 moved"));
        let moved = changes(&size(200.0), &size(100.0));
        assert!(
            moved.contains("footprint / c / size: 200 bytes → 100 bytes (-50%)"),
            "{moved}"
        );
    }

    #[test]
    fn lists_only_rows_that_moved() {
        assert!(changes(&doc(5.0), &doc(5.5)).contains("0 moved"));
        let moved = changes(&doc(5.0), &doc(10.0));
        assert!(
            moved.contains("s / c / m: p50 5µs → 10µs (+100%)"),
            "{moved}"
        );
    }
}
