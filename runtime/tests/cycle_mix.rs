//! `check` predicts the overruns `run --virtual` then shows, at several periods.
//!
//! The project: two factory-default MiniMods on one simulated line at 19200 8E1 in event mode
//! (the default), one output each driven by the program and never changed, inputs idle. Its
//! cycles differ only by the refreshes the bus owner runs (each module's output rewrite, its
//! full reads) and by what the line's work does to the next cycle, which is what `check`'s
//! cycle mix plays forward and what the virtual clock must cost like the wire. Both are the
//! `softplc` binary as a user runs it; the virtual clock makes the run deterministic.
//!
//! A project of several tasks is held to `check`'s prediction per task, one task driving two
//! lines (a cycle waits for the slower read, and overruns when either line's work runs past
//! the period) and one a MiniMod polled at 9600 Bd, whose answer comes just after the scan
//! stops waiting.

use crate::common::host;

use std::path::{Path, PathBuf};

use host::softplc;

/// A project folder with the test's project at `period_ms`.
fn project(period_ms: u64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "softplc-cycle-mix-{}-{period_ms}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("hold.expr"), "y1 = x1\ny2 = x2\n").unwrap();
    let text = format!(
        "project: cycle-mix
scan:
  period: {period_ms}ms
  watchdog: {{ time: 2s, sensitivity: 3 }}
buses:
  - {{ name: line1, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}
modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}
tags:
  - {{ name: x1, point: mm1.X1 }}
  - {{ name: x2, point: mm2.X1 }}
  - {{ name: y1, point: mm1.Y1, safe: false }}
  - {{ name: y2, point: mm2.Y1, safe: false }}
program: {{ file: hold.expr, kind: expr }}
"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The number after `key` in `text`, up to the next space.
fn number_after(text: &str, key: &str) -> f64 {
    let rest = &text[text
        .find(key)
        .unwrap_or_else(|| panic!("no `{key}` in:\n{text}"))
        + key.len()..];
    rest.split_whitespace()
        .next()
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no number after `{key}` in:\n{text}"))
}

/// `check`'s predicted overruns a minute at the project's period.
fn predicted(path: &Path, period_ms: u64) -> f64 {
    let (ok, text) = softplc(&["check", path.to_str().unwrap()]);
    assert!(ok, "{text}");
    number_after(
        &text,
        &format!("predicted at {period_ms}.00ms with idle inputs and unchanged outputs:"),
    )
}

/// What `softplc run --virtual --for 60s` prints of the project at `path`.
fn run_a_minute(path: &Path) -> String {
    let (ok, text) = softplc(&[
        "run",
        path.to_str().unwrap(),
        "--virtual",
        "--for",
        "60s",
        "--no-socket",
    ]);
    assert!(ok, "{text}");
    text
}

/// Overruns of a minute on the virtual clock, the first cycle (the start-up's full reads and
/// writes, which `check` prints apart) set aside.
fn measured(path: &Path) -> f64 {
    number_after(&run_a_minute(path), "overruns")
}

#[test]
fn the_virtual_clock_overruns_as_check_predicts() {
    let mut seen = Vec::new();
    for period in [10u64, 20, 25, 30, 40, 50, 100] {
        let path = project(period);
        let predicted = predicted(&path, period);
        let measured = measured(&path);
        seen.push((period, predicted, measured));
        // The first cycle and the lines it delays are in the run, not in the prediction's
        // rate; a refresh's period falls on the grid a cycle either way.
        let tolerance = (predicted * 0.05).max(4.0);
        assert!(
            (measured - predicted).abs() <= tolerance,
            "at {period} ms: check predicts {predicted} overruns a minute, the run shows \
             {measured} (all: {seen:?})"
        );
    }
    // The picture a user gets: hopeless at 10 ms, refresh cycles only at 20-50 ms, none at
    // 100 ms.
    assert!(seen[0].2 > 2500.0, "{seen:?}");
    assert!(seen[1].2 > 100.0 && seen[1].2 < 1000.0, "{seen:?}");
    assert_eq!(seen[6].2, 0.0, "{seen:?}");
}

#[test]
fn check_warns_of_the_overruns_it_predicts_and_not_otherwise() {
    let (_, at_20) = softplc(&["check", project(20).to_str().unwrap()]);
    assert!(
        at_20.contains("warning: bus line1: ") && at_20.contains("% of cycles will overrun"),
        "{at_20}"
    );
    assert!(
        at_20.contains("cycle mix: ordinary 13.59ms"),
        "the ordinary cycle is the idle Collect round: {at_20}"
    );
    let (_, at_100) = softplc(&["check", project(100).to_str().unwrap()]);
    assert!(!at_100.contains("will overrun"), "{at_100}");
    assert!(
        at_100.contains("0 overrun(s) a minute (0.0% of cycles)"),
        "{at_100}"
    );
}

/// A project of two tasks: `press` drives two lines (two MiniMods in event mode at 19200,
/// one polled MiniMod at 9600) at `period_ms`, `panel` one polled MiniMod at 9600 at 30 ms.
fn two_tasks(period_ms: u64) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "softplc-cycle-mix-tasks-{}-{period_ms}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("press.expr"), "y1 = x1\ny2 = x2\ny3 = x3\n").unwrap();
    std::fs::write(dir.join("panel.expr"), "y4 = x4\n").unwrap();
    let text = format!(
        "project: cycle-mix-tasks
tasks:
  - {{ name: press, period: {period_ms}ms, program: {{ file: press.expr, kind: expr }}, buses: [fast, slow] }}
  - {{ name: panel, period: 30ms, program: {{ file: panel.expr, kind: expr }}, buses: [panel] }}
buses:
  - {{ name: fast, port: sim, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}
  - {{ name: slow, port: sim, baud: 9600, format: 8E1, response_timeout: 50ms, retries: 1 }}
  - {{ name: panel, port: sim, baud: 9600, format: 8E1, response_timeout: 50ms, retries: 1 }}
modules:
  - {{ name: mm1, bus: fast, model: minimod, address: 1 }}
  - {{ name: mm2, bus: fast, model: minimod, address: 2 }}
  - {{ name: mm3, bus: slow, model: minimod, address: 1 }}
  - {{ name: mm4, bus: panel, model: minimod, address: 1 }}
tags:
  - {{ name: x1, point: mm1.X1 }}
  - {{ name: x2, point: mm2.X1 }}
  - {{ name: x3, point: mm3.X1 }}
  - {{ name: x4, point: mm4.X1 }}
  - {{ name: y1, point: mm1.Y1, safe: false }}
  - {{ name: y2, point: mm2.Y1, safe: false }}
  - {{ name: y3, point: mm3.Y1, safe: false }}
  - {{ name: y4, point: mm4.Y1, safe: false }}
"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The overruns `run --virtual` counts for task `task` in its report `text`.
fn task_overruns(text: &str, task: &str) -> f64 {
    let section = &text[text
        .find(&format!("task {task}:\n"))
        .unwrap_or_else(|| panic!("no task {task} in:\n{text}"))..];
    number_after(section, "overruns")
}

#[test]
fn each_task_overruns_as_check_predicts_for_its_lines_together() {
    let mut seen = Vec::new();
    for period in [20u64, 30, 40, 50] {
        let path = two_tasks(period);
        let (ok, check) = softplc(&["check", path.to_str().unwrap()]);
        assert!(ok, "{check}");
        let predicted = |task: &str, lines: &str, at: u64| {
            number_after(
                &check,
                &format!(
                    "task {task} {lines}: predicted at {at}.00ms with idle inputs and \
                     unchanged outputs:"
                ),
            )
        };
        let press = predicted(
            "press",
            "on lines fast, slow together (a cycle waits for the slowest read and overruns \
             when any line's work runs past its period)",
            period,
        );
        let panel = predicted("panel", "on line panel", 30);
        let run = run_a_minute(&path);
        let (press_run, panel_run) = (task_overruns(&run, "press"), task_overruns(&run, "panel"));
        seen.push((period, press, press_run, panel, panel_run));
        for (task, predicted, measured) in
            [("press", press, press_run), ("panel", panel, panel_run)]
        {
            let tolerance = (predicted * 0.05).max(4.0);
            assert!(
                (measured - predicted).abs() <= tolerance,
                "task {task} at press {period} ms: check predicts {predicted} overruns a \
                 minute, the run shows {measured} (all: {seen:?})"
            );
        }
    }
    // Together the press's lines overrun more than its 19200 line alone at 40 ms (132 a
    // minute), and the panel's polled read, in by 27.19 ms, just misses its 27 ms wait.
    assert!(seen[2].1 > 200.0, "{seen:?}");
    assert!(seen[0].3 > 500.0, "{seen:?}");
}
