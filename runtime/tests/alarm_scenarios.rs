//! Alarms in scenarios: a plant fault found by the program's own alarm in the examples (raised,
//! acknowledged by an `ack:` step, cleared after the repair, in the trace), a wrong state
//! named with the alarm, both states and the line, an unknown alarm refused at its line.

use crate::common::host::softplc;
use crate::common::scratch::Scratch;

/// The lines of `text` that are alarm events of the trace, trimmed.
fn alarm_lines(text: &str) -> Vec<&str> {
    text.lines()
        .map(str::trim)
        .filter(|l| l.contains("  alarm."))
        .collect()
}

#[test]
fn the_examples_jams_are_found_by_the_programs_own_alarm_acknowledged_and_cleared() {
    for (scenario, alarm, raised, acked, cleared) in [
        (
            "examples/garage_door/jam.scenario.yaml",
            "door_fault",
            "16.100s",
            "18.000s",
            "24.000s",
        ),
        (
            "examples/conveyor/jam.scenario.yaml",
            "jammed",
            "21.100s",
            "22.000s",
            "25.000s",
        ),
    ] {
        let (ok, text) = softplc(&["test", "--verbose", scenario]);
        assert!(ok, "{scenario}:\n{text}");
        assert!(!text.contains("FAIL"), "{text}");
        // The alarm events are in the trace the second run must repeat.
        assert!(text.contains("two runs give the same trace"), "{text}");
        let want = [
            format!("{raised}  alarm.{alarm} = raised"),
            format!("{acked}  alarm.{alarm} = acknowledged"),
            format!("{cleared}  alarm.{alarm} = cleared"),
        ];
        // Per program run: the three events, in order, and nothing else of the alarms.
        let lines = alarm_lines(&text);
        assert!(!lines.is_empty(), "{text}");
        for run in lines.chunks(3) {
            assert_eq!(run, want, "{scenario}:\n{text}");
        }
    }
}

/// A project on one simulated MiniMod: `y` follows `x`, and is an alarm.
fn project(scratch: &Scratch) {
    scratch.write("follow.expr", "y = x\n");
    scratch.write(
        "project.yaml",
        "project: alarm-scenarios
scan: { period: 100ms }
buses:
  - { name: line1, port: sim }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
tags:
  - { name: x, point: mm1.X1 }
  - { name: y, point: mm1.Y1, safe: false, alarm: { text: Y is on, priority: urgent } }
program: { file: follow.expr, kind: expr }
",
    );
}

#[test]
fn a_wrong_alarm_state_fails_with_the_alarm_both_states_and_the_line() {
    let scratch = Scratch::new("alarm-scenarios", "wrong-state");
    project(&scratch);
    let scenario = scratch.write(
        "wrong.scenario.yaml",
        "project: project.yaml
steps:
  - { at: 1s,   set: { x: 1 } }
  - { at: 1.5s, expect: { y: 1, alarm.y: cleared } }
  - { at: 2s,   ack: y }
  - { at: 2s,   expect: { alarm.y: raised } }
  - { at: 2.5s, expect: { alarm.y: \"active, unacknowledged\" } }
  - { at: 3s,   set: { x: 0 } }
  - { at: 3.5s, expect: { alarm.y: \"cleared, acknowledged\", alarm.lost.mm1: inactive } }
  - { at: 4s,   ack: all }
  - { at: 4s,   ack: y }
  - { at: 5s,   set: { x: 1 } }
  - { at: 5.1s, set: { x: 0 } }
  - { at: 6s,   expect: { alarm.y: \"cleared, unacknowledged\" } }
  - { at: 9s,   expect: { alarm.y: acknowledged } }
",
    );
    let (ok, text) = softplc(&["test", "--verbose", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let failures = [
        "at 1.5s (line 4): alarm.y expected cleared, got active, unacknowledged (raised at 1s)",
        // The step's expectation is checked before its acknowledgement.
        "at 2.5s (line 7): alarm.y expected active, unacknowledged, got active, acknowledged (raised at 1s, acknowledged at 2s)",
        "at 4s (line 11): cannot acknowledge y: alarm y is not waiting for an acknowledgement",
        "at 9s (line 15): alarm.y expected acknowledged, got cleared, unacknowledged (raised at 5s, cleared at 5.1s)",
    ];
    assert_has_all(&text, &failures);
    // Lines 6, 9 and 14 hold; a one-cycle alarm is raised and cleared in the trace.
    assert_eq!(text.matches("): alarm.").count(), 3, "{text}");
    assert_has_all(
        &text,
        &["5.000s  alarm.y = raised", "5.100s  alarm.y = cleared"],
    );
}

#[test]
fn a_silent_module_raises_its_lost_alarm_which_holds_its_tags_alarms_until_it_is_back() {
    let scratch = Scratch::new("alarm-scenarios", "lost");
    project(&scratch);
    let scenario = scratch.write(
        "lost.scenario.yaml",
        "project: project.yaml
steps:
  - { at: 1s,   set: { x: 1 } }
  - { at: 1.5s, expect: { alarm.y: raised, alarm.lost.mm1: inactive } }
  - { at: 2s,   module: { mm1: silent } }
  - { at: 2s,   set: { x: 0 } }
  - { at: 4s,   expect: { alarm.lost.mm1: raised, alarm.y: raised } }
  - { at: 4s,   ack: all }
  - { at: 5s,   module: { mm1: answers } }
  - { at: 8s,   expect: { alarm.lost.mm1: \"cleared, acknowledged\", alarm.y: \"cleared, acknowledged\" } }
",
    );
    let (ok, text) = softplc(&["test", "--verbose", scenario.to_str().unwrap()]);
    assert!(ok, "{text}");
    // One lost alarm for the dead module; y's alarm held while it is lost, cleared after.
    let lines = alarm_lines(&text);
    let events: Vec<&str> = lines
        .iter()
        .filter_map(|l| l.split_once("  ").map(|(_, e)| e))
        .collect();
    assert_eq!(
        events[..6],
        [
            "alarm.y = raised",
            "alarm.lost.mm1 = raised",
            "alarm.y = acknowledged",
            "alarm.lost.mm1 = acknowledged",
            "alarm.lost.mm1 = cleared",
            "alarm.y = cleared",
        ],
        "{text}"
    );
}

/// Fails unless `text` holds every one of `wants`, naming the first missing.
fn assert_has_all(text: &str, wants: &[impl AsRef<str>]) {
    for want in wants {
        let want = want.as_ref();
        assert!(text.contains(want), "{want}\nnot in:\n{text}");
    }
}

#[test]
fn an_unknown_alarm_or_state_is_refused_at_its_line_with_the_closest_name() {
    let scratch = Scratch::new("alarm-scenarios", "unknown");
    project(&scratch);
    let scenario = scratch.write(
        "unknown.scenario.yaml",
        "project: project.yaml
steps:
  - { at: 1s, expect: { alarm.yy: raised } }
  - { at: 1s, ack: [y, lost.mm2] }
  - { at: 2s, expect: { alarm.y: up } }
  - { at: 2s, ack: x }
  - { at: 3s, module: { mm9: silent } }
  - { at: 3s, module: { mm1: dead } }
",
    );
    let (ok, text) = softplc(&["test", scenario.to_str().unwrap()]);
    assert!(!ok, "{text}");
    let file = scenario.display();
    let errors = [
        format!("{file}:3:25: error: the project has no alarm `yy` (its alarms: y, lost.mm1); did you mean `y`?"),
        format!("{file}:4:24: error: the project has no alarm `lost.mm2` (its alarms: y, lost.mm1); did you mean `lost.mm1`?"),
        format!("{file}:5:34: error: `up` is not an alarm's state (raised, active, cleared, inactive, acknowledged, unacknowledged, or several joined by commas)"),
        format!("{file}:6:20: error: the project has no alarm `x` (its alarms: y, lost.mm1); did you mean `y`?"),
        format!("{file}:7:25: error: no module `mm9`; did you mean `mm1`?"),
        format!("{file}:8:30: error: `dead` is not `silent` or `answers`"),
    ];
    assert_has_all(&text, &errors);
}
