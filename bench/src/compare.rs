//! Comparison with the committed results of an earlier run: rows whose p50 or p99 moved by more
//! than a threshold are listed, so a regression shows up in the terminal.

use std::fmt::Write;

use serde_json::Value;

/// A change worth printing: ±25 %.
pub(crate) const THRESHOLD: f64 = 0.25;

/// Key and (p50, p99) of every measured row of a results document.
fn measured(doc: &Value) -> Vec<(String, f64, f64)> {
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
            if let (Some(p50), Some(p99)) = (r["p50_us"].as_f64(), r["p99_us"].as_f64()) {
                out.push((key, p50, p99));
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
    for (key, p50, p99) in measured(after) {
        let Some((_, o50, o99)) = old.iter().find(|(k, _, _)| *k == key) else {
            continue;
        };
        compared += 1;
        let rel = |new: f64, old: f64| if old > 0.0 { new / old - 1.0 } else { 0.0 };
        let (d50, d99) = (rel(p50, *o50), rel(p99, *o99));
        if d50.abs() > THRESHOLD || d99.abs() > THRESHOLD {
            let _ = writeln!(
                out,
                "  {key}: p50 {:.0}µs → {:.0}µs ({:+.0}%), p99 {:.0}µs → {:.0}µs ({:+.0}%)",
                o50,
                p50,
                d50 * 100.0,
                o99,
                p99,
                d99 * 100.0
            );
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
