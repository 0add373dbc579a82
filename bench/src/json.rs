//! The machine-readable results (`latest.json`): every row with its percentiles in
//! microseconds, its bounds and ratios (or its one value in its unit, its goal and ratio), and
//! the run's machine, date and command.

use std::time::Duration;

use serde_json::{json, Map, Value};

use crate::machine::Machine;
use crate::report::{Figure, Row};
use crate::scenarios::ScenarioResult;

/// Version of this file's layout.
pub(crate) const SCHEMA: u64 = 1;

/// Microseconds with nanosecond digits.
fn us(d: Duration) -> f64 {
    d.as_nanos() as f64 / 1e3
}

fn round(x: f64, digits: i32) -> f64 {
    let k = 10f64.powi(digits);
    (x * k).round() / k
}

fn row_json(row: &Row) -> Value {
    let mut m = Map::new();
    m.insert("case".into(), json!(row.case));
    m.insert("metric".into(), json!(row.metric));
    match &row.figure {
        Figure::Measured(p) => {
            m.insert("status".into(), json!("measured"));
            m.insert("count".into(), json!(p.count));
            m.insert("p50_us".into(), json!(us(p.p50)));
            m.insert("p99_us".into(), json!(us(p.p99)));
            m.insert("p999_us".into(), json!(us(p.p999)));
            m.insert("max_us".into(), json!(us(p.max)));
            let bounds: Vec<Value> = row
                .bounds
                .iter()
                .map(|b| {
                    let (r50, r99) = b.ratios(p);
                    json!({
                        "name": b.name,
                        "p50_us": us(b.p50),
                        "p99_us": us(b.p99),
                        "ratio_p50": r50.map(|r| round(r, 4)),
                        "ratio_p99": r99.map(|r| round(r, 4)),
                    })
                })
                .collect();
            m.insert("bounds".into(), Value::Array(bounds));
        }
        Figure::Scalar { value, goal } => {
            m.insert("status".into(), json!("measured"));
            m.insert("unit".into(), json!(value.unit()));
            m.insert("value".into(), json!(round(value.number(), 4)));
            if let Some(g) = goal {
                m.insert(
                    "goal".into(),
                    json!({
                        "name": g.name,
                        "value": round(g.limit.number(), 4),
                        "unit": g.limit.unit(),
                        "ratio": value.ratio_to(&g.limit).map(|r| round(r, 4)),
                    }),
                );
            }
        }
        Figure::NotYet { feature, issue } => {
            m.insert("status".into(), json!("not_yet_available"));
            m.insert("feature".into(), json!(feature));
            m.insert("issue".into(), json!(issue));
        }
        Figure::Unavailable(why) => {
            m.insert("status".into(), json!("not_measured"));
            m.insert("reason".into(), json!(why));
        }
    }
    let values: Map<String, Value> = row
        .values
        .iter()
        .map(|(k, v)| (k.clone(), json!(round(*v, 4))))
        .collect();
    m.insert("values".into(), Value::Object(values));
    m.insert("note".into(), json!(row.note));
    Value::Object(m)
}

/// The whole results document.
pub(crate) fn document(
    machine: &Machine,
    load_at_end: f64,
    command: &str,
    quick: bool,
    results: &[ScenarioResult],
) -> Value {
    let scenarios: Vec<Value> = results
        .iter()
        .map(|r| {
            json!({
                "number": r.number,
                "name": r.name,
                "title": r.title,
                "took_s": round(r.took.as_secs_f64(), 1),
                "rows": r.rows.iter().map(row_json).collect::<Vec<_>>(),
            })
        })
        .collect();
    json!({
        "harness": "softplc-bench",
        "schema": SCHEMA,
        "date": machine.date,
        "command": command,
        "quick": quick,
        "revision": machine.revision,
        "machine": {
            "cpus": machine.cpus,
            "cpu_model": machine.cpu_model,
            "kernel": machine.kernel,
            "load_average_1m_start": machine.load_at_start,
            "load_average_1m_end": load_at_end,
            "load_average_1m_start": machine.load_at_start,
            "load_average_1m_end": load_at_end,
        },
        "scenarios": scenarios,
    })
}

/// `committed` with the scenarios of the partial run `run` in place of its entries of the same
/// name (new ones added), in scenario order; the other entries stay as they were. Each merged
/// entry keeps its own run (date, revision, command, load), since the document's header
/// describes the full run the others come from.
pub(crate) fn merge(committed: &Value, run: &Value) -> anyhow::Result<Value> {
    let mut doc = committed.clone();
    let Some(entries) = doc["scenarios"].as_array_mut() else {
        anyhow::bail!("the committed results have no scenarios array");
    };
    for s in run["scenarios"].as_array().into_iter().flatten() {
        let mut entry = s.clone();
        entry["run"] = json!({
            "date": run["date"],
            "revision": run["revision"],
            "command": run["command"],
            "quick": run["quick"],
            "load_average_1m_start": run["machine"]["load_average_1m_start"],
            "load_average_1m_end": run["machine"]["load_average_1m_end"],
        });
        match entries.iter_mut().find(|e| e["name"] == s["name"]) {
            Some(old) => *old = entry,
            None => entries.push(entry),
        }
    }
    entries.sort_by_key(|e| e["number"].as_u64().unwrap_or(u64::MAX));
    Ok(doc)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_merge_replaces_its_scenarios_and_keeps_the_others() {
        let committed = json!({"date": "full", "scenarios": [
            {"number": 1, "name": "a", "rows": [1]},
            {"number": 3, "name": "c", "rows": [3]},
        ]});
        let run = json!({"date": "partial", "revision": "r", "command": "x", "quick": false,
        "machine": {"load_average_1m_start": 1.0, "load_average_1m_end": 2.0},
        "scenarios": [
            {"number": 3, "name": "c", "rows": [33]},
            {"number": 2, "name": "b", "rows": [22]},
        ]});
        let merged = merge(&committed, &run).expect("a scenarios array");
        assert_eq!(merged["date"], "full");
        let names: Vec<_> = merged["scenarios"]
            .as_array()
            .into_iter()
            .flatten()
            .map(|s| (s["name"].clone(), s["rows"][0].clone()))
            .collect();
        assert_eq!(
            names,
            [
                (json!("a"), json!(1)),
                (json!("b"), json!(22)),
                (json!("c"), json!(33))
            ]
        );
        assert_eq!(merged["scenarios"][2]["run"]["date"], "partial");
        assert!(merged["scenarios"][0].get("run").is_none());
    }
}
