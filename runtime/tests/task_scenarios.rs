//! Scenarios (`softplc test`) on a project of several tasks: program variants named by task
//! (a task of two programs, ladder then Rhai, against one Rhai program: one trace), alarms
//! expected and acknowledged (see `task_scenario_alarms`), retained values read
//! from each owning task's file; an unknown task and a bare file refused at their line.

use crate::common::host::softplc_in;
use crate::common::scratch::{Scratch, TWO_LINES};

/// Two tasks on two simulated lines. The fast task (two programs) drives the valve and counts
/// strokes (retained); the slow one enables it from the key switch, counts shifts (retained)
/// and raises `warn` while the key is off.
const PROJECT: &str = "\
project: ts
tasks:
  - name: fast
    period: 20ms
    buses: [fast_line]
    programs:
      - { file: fast.ladder.yaml, kind: ladder }
      - { file: fast_count.rhai, kind: rhai }
  - name: slow
    period: 200ms
    buses: [slow_line]
    program: { file: slow.ladder.yaml, kind: ladder }
{lines}tags:
  - { name: start,   point: f1.X1 }
  - { name: valve,   point: f1.Y1, safe: false }
  - { name: key,     point: s1.X1 }
  - { name: enabled, type: bool }
  - { name: warn,    type: bool, alarm: { text: Key switch off } }
  - { name: count,   type: u16, retain: true }
  - { name: shifts,  type: u16, retain: true }
";

/// The scenario; `{retained}` is filled in.
const SCENARIO: &str = "\
project: project.yaml
programs:
  - { fast: [fast.ladder.yaml, fast_count.rhai] }
  - { fast: fast.rhai }
watch: [valve, count, enabled]
until: 8s
steps:
  - { at: 1s,   expect: { alarm.warn: raised } }
  - { at: 1.5s, ack: warn }
  - { at: 2s,   expect: { alarm.warn: \"active, acknowledged\" } }
  - { at: 3s,   set: { key: 1 } }
  - { at: 4s,   set: { start: 1 }, expect: { alarm.warn: \"cleared, acknowledged\" } }
  - { at: 4.5s, set: { start: 0 } }
  - { at: 5s,   set: { start: 1 } }
  - { at: 5.5s, set: { start: 0 } }
  - { at: 7s,   expect: { count: 2, valve: 0 } }
expect_retained: {retained}
";

fn folder(case: &str) -> Scratch {
    let s = Scratch::new("task-scenarios", case);
    s.write("project.yaml", &PROJECT.replace("{lines}", TWO_LINES));
    s.write("fast.ladder.yaml", "rungs:\n  - start enabled -> valve\n");
    s.write(
        "fast_count.rhai",
        "if r_trig(\"stroke\", valve) {\n    count += 1;\n}\n",
    );
    s.write(
        "fast.rhai",
        "valve = start && enabled;\nif r_trig(\"stroke\", valve) {\n    count += 1;\n}\n",
    );
    s.write(
        "slow.ladder.yaml",
        "rungs:\n  - key -> enabled\n  - /key -> warn\n  - rising(key) -> ADD(shifts, 1) => shifts\n",
    );
    s
}

/// Each variant's trace: the lines after its `ok`/`FAIL` line, up to the next.
fn traces(text: &str) -> Vec<Vec<&str>> {
    let mut traces: Vec<Vec<&str>> = Vec::new();
    for line in text.lines() {
        if line.starts_with("ok ") || line.starts_with("FAIL ") {
            traces.push(Vec::new());
        } else if let Some(t) = traces.last_mut() {
            if line.starts_with("           ") {
                t.push(line.trim());
            }
        }
    }
    traces
}

#[test]
fn variants_by_task_alarms_and_retained_values_of_a_two_task_project() {
    let s = folder("pass");
    s.write(
        "s.scenario.yaml",
        &SCENARIO.replace("{retained}", "{ count: 2, shifts: 1 }"),
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "--verbose", "s.scenario.yaml"]);
    assert!(ok, "{text}");
    assert!(text.contains("2 passed, 0 failed"), "{text}");
    assert!(
        text.contains("[fast: fast.ladder.yaml + fast_count.rhai]")
            && text.contains("[fast: fast.rhai]"),
        "each variant named by its task's programs:\n{text}"
    );
    assert!(
        text.contains(
            "fast: fast.ladder.yaml + fast_count.rhai and fast: fast.rhai give the same trace"
        ),
        "{text}"
    );
    let traces = traces(&text);
    assert_eq!(traces.len(), 2, "{text}");
    assert_eq!(traces[0], traces[1], "{text}");
    // The alarm of a tag the slow task owns, evaluated at the slow task's cycles: raised
    // when it published it, acknowledged by the step, cleared after the key.
    let alarm: Vec<&str> = traces[0]
        .iter()
        .copied()
        .filter(|l| l.contains("alarm.warn"))
        .collect();
    assert_eq!(alarm.len(), 3, "{text}");
    assert!(alarm[0].ends_with("alarm.warn = raised"), "{text}");
    assert_eq!(alarm[1], "1.500s  alarm.warn = acknowledged", "{text}");
    assert!(alarm[2].ends_with("alarm.warn = cleared"), "{text}");
    // The two strokes counted by the fast task's second program, in the first variant.
    assert!(traces[0].contains(&"5.000s  count = 2"), "{text}");
}

#[test]
fn a_retained_value_is_read_from_the_file_of_the_task_owning_it() {
    let s = folder("retained");
    // `shifts` is the slow task's: its file holds 1, not 2.
    s.write(
        "s.scenario.yaml",
        &SCENARIO.replace("{retained}", "{ count: 2, shifts: 2 }"),
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "s.scenario.yaml"]);
    assert!(!ok, "{text}");
    assert_eq!(
        text.matches("retained shifts: expected 2, the file holds 1")
            .count(),
        2,
        "once per variant:\n{text}"
    );
    assert!(!text.contains("retained count"), "{text}");
}

#[test]
fn a_variant_naming_an_unknown_task_or_no_task_is_refused_at_its_line() {
    let s = folder("refused");
    s.write(
        "e.scenario.yaml",
        "project: project.yaml\nprograms:\n  - { fast: fast.rhai, fsat: fast.rhai }\n  - fast.rhai\n  - { slow: nothing.rhai }\nsteps:\n  - { at: 1s, expect: { count: 0 } }\n",
    );
    let (ok, text) = softplc_in(&s.dir, &["test", "e.scenario.yaml"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains("e.scenario.yaml:3:24: error: unknown task `fsat` (the project's tasks: fast, slow); did you mean `fast`?"),
        "{text}"
    );
    assert!(
        text.contains("e.scenario.yaml:4:5: error: this project has several tasks (fast, slow): name the task each program is for"),
        "{text}"
    );
    assert!(
        text.contains("e.scenario.yaml:5:13: error: no program file"),
        "{text}"
    );
}
