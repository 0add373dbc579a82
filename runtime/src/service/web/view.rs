//! The live JSON the page draws: the state (every cycle), the statistics (every refresh of
//! the snapshot's statistics) and the trend's history. Arrays are in tag (or module, or
//! phase) order, so the page joins them with [`super::info::WebInfo`] by index. Times are
//! milliseconds as numbers, values are JSON booleans and numbers (`null` for a float that is
//! not finite), qualities 0 good, 1 stale, 2 bad.

use crate::service::health::Health;
use serde_json::{json, Value as Json};
use softplc_io::point::{Quality, Value};

use super::trend::Trend;
use crate::logic::blocks::OutputValue;
use crate::logic::InstanceOutput;
use crate::service::snapshot::{Phase, ServiceSnapshot};

fn ms(d: std::time::Duration) -> f64 {
    // Microsecond resolution is all a person reads; it also keeps the JSON short.
    (d.as_micros() as f64) / 1000.0
}

fn value(v: Value) -> Json {
    match v {
        Value::Bool(b) => Json::Bool(b),
        Value::U16(x) => json!(x),
        Value::I32(x) => json!(x),
        Value::F32(x) => {
            serde_json::Number::from_f64(f64::from(x)).map_or(Json::Null, Json::Number)
        }
    }
}

fn quality(q: Quality) -> u8 {
    match q {
        Quality::Good => 0,
        Quality::Stale => 1,
        Quality::Bad => 2,
    }
}

fn output(v: OutputValue) -> Json {
    match v {
        OutputValue::Bool(b) => Json::Bool(b),
        OutputValue::Time(d) => json!(ms(d)),
        OutputValue::Count(c) => json!(c),
    }
}

/// The block instances' outputs as the ladder view reads them: an array by instance index of
/// objects by member name, `[{"Q": true, "ET": 120.0}, {"Q": false, "CV": 3}]` (`ET` in
/// milliseconds, like every time here).
fn blocks(outputs: &[InstanceOutput]) -> Json {
    let mut all: Vec<Json> = Vec::new();
    for o in outputs {
        let at = o.inst as usize;
        if all.len() <= at {
            all.resize_with(at + 1, || Json::Object(serde_json::Map::new()));
        }
        if let Some(Json::Object(members)) = all.get_mut(at) {
            members.insert(o.member.name().to_string(), output(o.value));
        }
    }
    Json::Array(all)
}

/// The state: cycle figures and every tag's value, quality, age and force, and the block
/// outputs (`b`) when the program has blocks (ladder; expr and Rhai programs publish none,
/// and their state stays as small as it was).
pub(crate) fn state(s: &ServiceSnapshot) -> Json {
    // Several tasks: a fast task's tags are stamped after the first task's last publication,
    // so ages count from the latest task's.
    let latest = s.task_now.iter().copied().max();
    let now = latest.map_or(s.now, |l| l.max(s.now));
    let age: Vec<f64> = s
        .timestamps
        .iter()
        .map(|t| ms(now.saturating_duration_since(*t)))
        .collect();
    let forced: Vec<usize> = s
        .forced
        .iter()
        .enumerate()
        .filter_map(|(i, f)| f.then_some(i))
        .collect();
    let mut state = json!({
        "published": s.published,
        "stopped": s.stopped,
        "stop_reason": s.stop_reason,
        "cycles": s.cycles,
        "overruns": s.overruns,
        "now": ms(s.now.since_origin()),
        "v": s.values.iter().map(|v| value(*v)).collect::<Vec<_>>(),
        "q": s.qualities.iter().map(|q| quality(*q)).collect::<Vec<_>>(),
        "age": age,
        "forced": forced,
    });
    if !s.blocks.is_empty() {
        state["b"] = blocks(&s.blocks);
    }
    if !s.task_blocks.is_empty() {
        // Several tasks: each task's ladders read the blocks of their own task.
        state["tb"] = Json::Array(s.task_blocks.iter().map(|b| blocks(b)).collect());
    }
    if !s.task_now.is_empty() {
        // Several tasks: each task's cycles and time at its last publication, so the trend
        // samples a tag at its own task's cycles.
        state["task_cycles"] = json!(s.task_cycles);
        state["task_now"] = json!(s
            .task_now
            .iter()
            .map(|t| ms(t.since_origin()))
            .collect::<Vec<_>>());
    }
    if let Some(p) = &s.plant {
        // The plant panel: the model, whether it runs, its states by name as text.
        state["plant"] = json!({
            "model": p.model,
            "state": p.state,
            "error": p.error,
            "states": p.states,
        });
    }
    state
}

/// The statistics: each phase's percentiles and histogram, each module's counters, each
/// task's figures (a PLC of several tasks).
pub(crate) fn stats(s: &ServiceSnapshot, health: &Health) -> Json {
    let phases: Vec<Json> = Phase::ALL
        .iter()
        .zip(&s.phases)
        .enumerate()
        .map(|(i, (phase, p))| {
            let h = s.histograms.get(i);
            json!({
                "name": phase.name(),
                "count": p.count,
                "p50": ms(p.p50),
                "p99": ms(p.p99),
                "p999": ms(p.p999),
                "max": ms(p.max),
                "mean": if p.count > 0 { ms(p.sum) / p.count as f64 } else { 0.0 },
                "hist": h.map(|h| json!({
                    "lo": ms(h.lo),
                    "hi": ms(h.hi),
                    "log": h.log,
                    "counts": h.counts,
                })),
            })
        })
        .collect();
    let modules: Vec<Json> = s
        .modules
        .iter()
        .enumerate()
        .map(|(i, m)| {
            let c = &m.counters;
            json!({
                "q": quality(m.quality),
                "requests": c.requests,
                "collect": c.collect_requests,
                "timeouts": c.timeouts,
                "crc": c.crc_errors,
                "bad": c.bad_replies,
                "exceptions": c.exceptions,
                "rtt": ms(c.last_round_trip),
                "error": s.module_errors.get(i).cloned().flatten(),
            })
        })
        .collect();
    json!({
        "seq": s.stats_seq,
        "phases": phases,
        "modules": modules,
        "services": health.report(),
        // With several tasks, each task's figures (µs, as `status --json` gives them).
        "tasks": s.tasks,
    })
}

/// The trend's history, column by column: times (ms of scan time) and one series per tag.
pub(crate) fn trend(t: &Trend) -> Json {
    let times: Vec<f64> = t.samples.iter().map(|(at, _)| ms(*at)).collect();
    let series: Vec<Vec<Option<f64>>> = (0..t.tags.len())
        .map(|k| {
            t.samples
                .iter()
                .map(|(_, row)| row.get(k).copied().flatten())
                .collect()
        })
        .collect();
    json!({ "tags": t.tags, "t": times, "series": series })
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;
    use crate::logic::blocks::Member;
    use crate::service::snapshot::HistogramView;
    use softplc_io::time::ScanInstant;

    #[test]
    fn state_and_stats_json() {
        let s = ServiceSnapshot {
            published: true,
            cycles: 7,
            now: ScanInstant::after_origin(Duration::from_millis(700)),
            values: vec![Value::Bool(true), Value::F32(f32::NAN), Value::I32(-3)],
            qualities: vec![Quality::Good, Quality::Stale, Quality::Bad],
            timestamps: vec![
                ScanInstant::after_origin(Duration::from_millis(650)),
                ScanInstant::ZERO,
                ScanInstant::ZERO,
            ],
            forced: vec![false, false, true],
            histograms: vec![HistogramView {
                lo: Duration::from_micros(1500),
                hi: Duration::from_millis(3),
                log: false,
                counts: vec![1, 2],
            }],
            module_errors: vec![Some("timeout".into())],
            modules: vec![Default::default()],
            ..ServiceSnapshot::default()
        };
        let j = state(&s);
        assert_eq!(j["v"], json!([true, null, -3]));
        assert_eq!(j["q"], json!([0, 1, 2]));
        assert_eq!(j["age"], json!([50.0, 700.0, 700.0]));
        assert_eq!(j["forced"], json!([2]));
        assert!(j.get("b").is_none(), "no blocks, no `b`: {j}");
        let j = stats(&s, &Health::new());
        assert_eq!(j["phases"][0]["name"], "cycle");
        assert_eq!(j["phases"][0]["hist"]["lo"], json!(1.5));
        assert_eq!(j["phases"][1]["hist"], Json::Null);
        assert_eq!(j["modules"][0]["error"], "timeout");
        let with_blocks = ServiceSnapshot {
            blocks: vec![
                InstanceOutput {
                    inst: 0,
                    member: Member::Q,
                    value: OutputValue::Bool(true),
                },
                InstanceOutput {
                    inst: 0,
                    member: Member::Et,
                    value: OutputValue::Time(Duration::from_micros(120_500)),
                },
                InstanceOutput {
                    inst: 1,
                    member: Member::Cv,
                    value: OutputValue::Count(-3),
                },
            ],
            ..ServiceSnapshot::default()
        };
        assert_eq!(
            state(&with_blocks)["b"],
            json!([{"Q": true, "ET": 120.5}, {"CV": -3}])
        );
        let mut t = Trend::new(vec![0]);
        let at = |ms| ScanInstant::after_origin(Duration::from_millis(ms));
        t.sample_snapshot(&ServiceSnapshot {
            now: at(100),
            ..s.clone()
        });
        assert_eq!(
            trend(&t),
            json!({"tags": [0], "t": [100.0], "series": [[1.0]]})
        );
        let tasks = ServiceSnapshot {
            task_blocks: vec![vec![], with_blocks.blocks.clone()],
            task_now: vec![at(700), at(730)],
            ..s
        };
        let j = state(&tasks);
        assert_eq!(j["tb"], json!([[], [{"Q": true, "ET": 120.5}, {"CV": -3}]]));
        assert_eq!(j["task_now"], json!([700.0, 730.0]));
        assert_eq!(j["task_cycles"], json!([]));
        assert_eq!(
            j["age"][0],
            json!(80.0),
            "from the latest task's publication"
        );
    }

    #[test]
    fn with_several_tasks_the_trend_samples_each_tag_at_its_owners_cycles() {
        let at = |ms| ScanInstant::after_origin(Duration::from_millis(ms));
        // Tag 0 is the slow first task's, tag 1 the fast second task's.
        let mut t = Trend::new(vec![1]).sampled_by(vec![1]);
        let mut s = ServiceSnapshot {
            published: true,
            values: vec![Value::Bool(false), Value::I32(1)],
            task_cycles: vec![1, 10],
            task_now: vec![at(500), at(100)],
            ..ServiceSnapshot::default()
        };
        t.sample_snapshot(&s);
        // The slow task's next cycle adds nothing to the fast task's tag...
        s.task_cycles[0] = 2;
        s.task_now[0] = at(1000);
        t.sample_snapshot(&s);
        // ...each of the fast task's cycles adds a sample at its time.
        (s.task_cycles[1], s.task_now[1], s.values[1]) = (11, at(110), Value::I32(2));
        t.sample_snapshot(&s);
        assert_eq!(
            trend(&t),
            json!({"tags": [1], "t": [100.0, 110.0], "series": [[1.0, 2.0]]})
        );
    }
}
