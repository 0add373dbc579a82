//! Alarms in a scenario of several tasks, fed as `softplc run` feeds them: each task's share
//! at its own cycles. A pulse of a fast task that a slow first task never sees is raised and
//! cleared at the fast task's times; a module of the second task silenced raises its `lost.`
//! alarm, which is acknowledged and clears once it answers; two runs give one trace; and a
//! scenario's alarm events are those `softplc run --virtual` writes in its history.

use crate::common::host::softplc_in;
use crate::common::scratch::{Scratch, TWO_LINES};

/// The slow task first (100 ms), the fast one second (20 ms). The fast task makes `pulse`
/// true for one of its cycles at each rising edge of `start`.
const PROJECT: &str = "\
project: tsa
tasks:
  - name: slow
    period: 100ms
    buses: [slow_line]
    program: { file: slow.ladder.yaml, kind: ladder }
  - name: fast
    period: 20ms
    buses: [fast_line]
    program: { file: fast.ladder.yaml, kind: ladder }
{lines}tags:
  - { name: start,   point: f1.X1 }
  - { name: valve,   point: f1.Y1, safe: false }
  - { name: key,     point: s1.X1 }
  - { name: enabled, type: bool }
  - { name: pulse,   type: bool, alarm: { text: Start pulse, priority: high } }
";

/// The pulse's alarm between two of the slow task's cycles (expected as the fast task's cycles
/// at 1.06s and 1.08s leave it), then the fast line's module silenced, acknowledged, and
/// answering again.
const SCENARIO: &str = "\
project: project.yaml
watch: [valve, pulse]
until: 9s
steps:
  - { at: 1.05s, set: { start: 1 } }
  - { at: 1.07s, expect: { alarm.pulse: raised } }
  - { at: 1.08s, expect: { alarm.pulse: \"cleared, unacknowledged\" } }
  - { at: 1.5s,  expect: { alarm.pulse: \"cleared, unacknowledged\", alarm.lost.f1: inactive } }
  - { at: 1.6s,  ack: pulse }
  - { at: 1.7s,  expect: { alarm.pulse: \"cleared, acknowledged\" } }
  - { at: 2s,    module: { f1: silent } }
  - { at: 4.5s,  expect: { alarm.lost.f1: raised, alarm.lost.s1: inactive } }
  - { at: 5s,    ack: lost.f1 }
  - { at: 5.1s,  expect: { alarm.lost.f1: \"active, acknowledged\" } }
  - { at: 5.5s,  module: { f1: answers } }
  - { at: 8s,    expect: { alarm.lost.f1: \"cleared, acknowledged\" } }
";

fn folder(case: &str) -> Scratch {
    let s = Scratch::new("task-scenario-alarms", case);
    s.write("project.yaml", &PROJECT.replace("{lines}", TWO_LINES));
    s.write(
        "fast.ladder.yaml",
        "rungs:\n  - start -> valve\n  - rising(start) -> pulse\n",
    );
    s.write("slow.ladder.yaml", "rungs:\n  - key -> enabled\n");
    s
}

/// The trace lines of a verbose run (those after its `ok`/`FAIL` line).
fn trace(text: &str) -> Vec<&str> {
    text.lines()
        .filter(|l| l.starts_with("           "))
        .map(str::trim)
        .collect()
}

/// The time of a trace line `1.060s  alarm.pulse = raised`, in seconds.
fn time_of(line: &str) -> f64 {
    line.split('s')
        .next()
        .and_then(|t| t.parse().ok())
        .unwrap_or_else(|| panic!("a trace line starts with its time: {line}"))
}

/// The trace line of `what`, the only one.
fn line_of<'a>(trace: &[&'a str], what: &str, text: &str) -> &'a str {
    let lines: Vec<&str> = trace
        .iter()
        .copied()
        .filter(|l| l.ends_with(what))
        .collect();
    assert_eq!(lines.len(), 1, "one `{what}`:\n{text}");
    lines[0]
}

#[test]
fn a_fast_tasks_pulse_and_a_second_tasks_lost_module_are_alarms_at_its_own_cycles() {
    let s = folder("pass");
    s.write("s.scenario.yaml", SCENARIO);
    let (ok, text) = softplc_in(&s.dir, &["test", "--verbose", "s.scenario.yaml"]);
    assert!(ok, "{text}");
    assert!(text.contains("1 passed, 0 failed"), "{text}");
    let trace = trace(&text);

    // The pulse lives one fast cycle (20 ms) between two slow cycles (100 ms apart): the
    // alarm is raised and cleared at the fast task's cycles, as the pulse itself.
    let raised = time_of(line_of(&trace, "alarm.pulse = raised", &text));
    let cleared = time_of(line_of(&trace, "alarm.pulse = cleared", &text));
    let at = |t: f64, what: &str| trace.contains(&format!("{t:.3}s  {what}").as_str());
    assert!(
        at(raised, "pulse = 1") && at(cleared, "pulse = 0"),
        "{text}"
    );
    assert!(
        (cleared - raised - 0.02).abs() < 1e-9,
        "one fast cycle:\n{text}"
    );
    assert!(
        (1.05..1.1).contains(&raised),
        "before the slow task's 1.1s:\n{text}"
    );
    // Acknowledged at the boundary of the last cycle at or before 1.6s.
    assert!(
        trace.contains(&"1.600s  alarm.pulse = acknowledged"),
        "{text}"
    );

    // The second task's module: lost while silent, acknowledged, cleared once it answers,
    // each at a cycle of the fast task owning its line.
    let lost = time_of(line_of(&trace, "alarm.lost.f1 = raised", &text));
    let back = time_of(line_of(&trace, "alarm.lost.f1 = cleared", &text));
    assert!((2.0..4.5).contains(&lost), "{text}");
    assert!((5.5..8.0).contains(&back), "{text}");
    assert!(
        trace.contains(&"5.000s  alarm.lost.f1 = acknowledged"),
        "{text}"
    );
    assert!(!text.contains("alarm.lost.s1"), "{text}");

    // Deterministic: a second run gives the same trace.
    let (ok, again) = softplc_in(&s.dir, &["test", "--verbose", "s.scenario.yaml"]);
    assert!(ok, "{again}");
    assert_eq!(trace, self::trace(&again));
}

#[test]
fn a_step_before_the_slow_tasks_first_cycle_sees_the_fast_tasks_cycles_up_to_its_time() {
    let s = folder("early");
    // The slow line starts later than the fast one: its task's first cycle comes after the
    // fast task's pulse (0.06s to 0.08s), and every step below is taken at its own time.
    s.write(
        "e.scenario.yaml",
        "project: project.yaml\nwatch: [pulse]\nuntil: 1s\nsteps:\n  - { at: 0.05s, set: { start: 1 } }\n  - { at: 0.07s, expect: { alarm.pulse: raised } }\n  - { at: 0.1s, expect: { alarm.pulse: \"cleared, unacknowledged\" } }\n  - { at: 0.12s, ack: pulse }\n  - { at: 0.5s, expect: { alarm.pulse: \"cleared, acknowledged\" } }\n",
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "--verbose", "e.scenario.yaml"]);
    assert!(ok, "{text}");
    let trace = trace(&text);
    for line in [
        "0.060s  alarm.pulse = raised",
        "0.080s  alarm.pulse = cleared",
        "0.120s  alarm.pulse = acknowledged",
    ] {
        assert!(trace.contains(&line), "{line}:\n{text}");
    }
}

#[test]
fn a_failed_alarm_expectation_of_a_fast_task_says_when_it_was_raised_and_cleared() {
    let s = folder("fail");
    // At 1.2s the pulse's alarm is waiting, not active: raised and cleared before the slow
    // task's next cycle.
    s.write(
        "f.scenario.yaml",
        "project: project.yaml\nuntil: 2s\nsteps:\n  - { at: 1.05s, set: { start: 1 } }\n  - { at: 1.2s, expect: { alarm.pulse: active } }\n",
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "f.scenario.yaml"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("at 1.2s (line 5): alarm.pulse expected active, got cleared, unacknowledged (raised at 1.0"),
        "{text}"
    );
    assert!(text.contains(", cleared at 1.0"), "{text}");
}

#[test]
fn an_alarm_the_project_does_not_have_is_refused_with_every_tasks_alarms() {
    let s = folder("refused");
    s.write(
        "a.scenario.yaml",
        "project: project.yaml\nsteps:\n  - { at: 1s, expect: { alarm.lost.s1: inactive } }\n  - { at: 2s, ack: lost.f2 }\n",
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "a.scenario.yaml"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("a.scenario.yaml:4:")
            && text.contains(
                "the project has no alarm `lost.f2` (its alarms: pulse, lost.f1, lost.s1)"
            ),
        "{text}"
    );
    assert!(!text.contains("a.scenario.yaml:3:"), "{text}");
}

/// The same two tasks with a program of their own: the fast task's `pulse` holds one cycle in
/// seven, an alarm the slow first task never sees.
const SELF_PULSING: &str = "\
project: tsa
tasks:
  - { name: slow, period: 100ms, buses: [slow_line], program: { file: slow.rhai, kind: rhai } }
  - { name: fast, period: 20ms, buses: [fast_line], program: { file: fast.rhai, kind: rhai } }
{lines}tags:
  - { name: n,     type: u16 }
  - { name: pulse, type: bool, alarm: { text: Every seventh cycle } }
  - { name: lamp,  point: s1.Y1, safe: false }
";

#[test]
fn a_scenario_shows_the_alarm_events_softplc_run_records() {
    let s = Scratch::new("task-scenario-alarms", "as-run");
    s.write("project.yaml", &SELF_PULSING.replace("{lines}", TWO_LINES));
    s.write("fast.rhai", "n += 1;\npulse = n % 7 == 0;\n");
    s.write("slow.rhai", "lamp = !lamp;\n");
    s.write(
        "s.scenario.yaml",
        "project: project.yaml\nuntil: 1s\nsteps:\n  - { at: 0.5s, expect: { n: 26 } }\n",
    );
    // The run's history: each event with the fast task's cycle.
    let (ok, text) = softplc_in(
        &s.dir,
        &["run", "--virtual", "--quiet", "--for", "1s", "project.yaml"],
    );
    assert!(ok, "{text}");
    let history = std::fs::read_to_string(s.dir.join("project.yaml.alarms.jsonl"))
        .expect("the run's alarm history");
    let run: Vec<(String, String, u64)> = history
        .lines()
        .map(|l| {
            let e: serde_json::Value = serde_json::from_str(l).expect("a history line");
            (
                e["alarm"].as_str().unwrap_or_default().to_owned(),
                e["event"].as_str().unwrap_or_default().to_owned(),
                e["cycle"].as_u64().unwrap_or_default(),
            )
        })
        .collect();
    assert_eq!(run.len(), 14, "{history}");
    // The scenario's trace: each event at the fast task's cycle time (cycle N at (N-1)×20ms,
    // the fast task's first scan being time 0).
    let (ok, text) = softplc_in(&s.dir, &["test", "--verbose", "s.scenario.yaml"]);
    assert!(ok, "{text}");
    let scenario: Vec<(String, String, u64)> = trace(&text)
        .into_iter()
        .filter_map(|l| {
            let (alarm, event) = l.split_once("  alarm.")?.1.split_once(" = ")?;
            let cycle = (time_of(l) / 0.02).round() as u64 + 1;
            Some((alarm.to_owned(), event.to_owned(), cycle))
        })
        .collect();
    assert_eq!(scenario, run, "{text}");
}
