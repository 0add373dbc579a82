//! Several tasks running (virtual clocks, the two-tasks example): the fast task keeps its
//! period beside a slow task on its own slow line, a value one task publishes is seen by the
//! other from its next cycle's start on and never before, a watchdog trip in one task drives
//! every task's outputs safe, and two runs give the same trace.

use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::plc::Plc;
use softplc::project::load;
use softplc::scan::{ScanInstant, StopReason, TaskOutcome, TaskSet};
use softplc_io::point::Value;
use softplc_io::sim::SharedWorld;

use crate::common::host::repo;
use crate::common::scratch::Scratch;

/// How long the tests run: the press starts at about 1 s, the panel (its slow line's start-up
/// longer) at about 5.5 s; the operator turns the key at 7 s.
const RUN: Duration = Duration::from_secs(10);

/// One line of a run's trace: the task, its cycle, the cycle's start, and tag values.
type Line = (String, u64, ScanInstant, Vec<Value>);

const WATCHED: [&str; 5] = [
    "enabled",
    "press_down",
    "strokes",
    "running_lamp",
    "guard_lamp",
];

/// The simulated worlds of the tasks' lines (one per task on virtual clocks).
type Worlds = Vec<SharedWorld>;

fn set(worlds: &Worlds, module: &str, point: &str, on: bool) {
    for world in worlds {
        let mut w = world.lock().expect("the world");
        if let Some(d) = w.find(module) {
            w.set(d, point, Value::Bool(on)).expect("an input");
            return;
        }
    }
    panic!("no simulator {module}");
}

fn output(worlds: &Worlds, module: &str, point: &str) -> Value {
    for world in worlds {
        let w = world.lock().expect("the world");
        if let Some(d) = w.find(module) {
            return w.get(d, point).expect("an output");
        }
    }
    panic!("no simulator {module}");
}

/// Runs the two-tasks example for `run_for` on virtual clocks. The operator holds both palm
/// buttons with the guard closed from the start and turns the key at 7 s (the panel line's
/// start-up takes about 5.5 s); `hang` makes the
/// panel task's cycle starting at or after that time take 10 s (a stuck program). Returns
/// every task's outcome, the trace, and the world.
fn run(run_for: Duration, hang: Option<Duration>) -> (Vec<TaskOutcome>, Vec<Line>, Worlds) {
    run_project(
        &repo().join("examples/two-tasks/project.yaml"),
        run_for,
        hang,
    )
}

/// The example's press task alone: its line, its modules, its tags, the press enabled from
/// the start.
const PRESS_ALONE: &str = "\
project: press-alone
tasks:
  - name: press
    period: 30ms
    watchdog: { time: 50ms, sensitivity: 3 }
    program: { file: press.ladder.yaml, kind: ladder }
    buses: [press_line]
buses:
  - { name: press_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }
modules:
  - { name: hands,  bus: press_line, model: minimod, address: 1 }
  - { name: guard,  bus: press_line, model: minimod, address: 2 }
  - { name: valves, bus: press_line, model: minimod, address: 3 }
  - { name: ram,    bus: press_line, model: minimod, address: 4 }
tags:
  - { name: hand_left,    point: hands.X1 }
  - { name: hand_right,   point: hands.X2 }
  - { name: guard_closed, point: guard.X1 }
  - { name: ram_top,      point: ram.X1 }
  - { name: press_down,   point: valves.Y1, safe: false }
  - { name: strokes,      type: u16 }
  - { name: enabled,      type: bool, initial: true }
  - { name: running_lamp, type: bool }
  - { name: guard_lamp,   type: bool }
";

fn run_project(
    path: &std::path::Path,
    run_for: Duration,
    hang: Option<Duration>,
) -> (Vec<TaskOutcome>, Vec<Line>, Worlds) {
    let project = load(path).expect("the project");
    let plcs = Plc::build_tasks(&project, None, None).expect("builds");
    let world: Worlds = plcs.iter().filter_map(|t| t.plc.world().cloned()).collect();
    for (module, point) in [("hands", "X1"), ("hands", "X2"), ("guard", "X1")] {
        set(&world, module, point, true);
    }
    let trace: Arc<Mutex<Vec<Line>>> = Arc::default();
    let hung = Arc::new(Mutex::new(false));
    let set_world = world.clone();
    let tasks = TaskSet::new(plcs).configure(|i, engine| {
        let trace = trace.clone();
        let world = set_world.clone();
        let hung = hung.clone();
        engine.run_for(run_for).on_cycle(Box::new(move |plc, ctx| {
            let name = plc.project().tasks[0].name.clone();
            let values = WATCHED
                .iter()
                .map(|t| plc.image().get(plc.image().id(t).expect("a tag")))
                .collect();
            trace
                .lock()
                .expect("trace")
                .push((name, ctx.cycle, ctx.now, values));
            if i == 1 && ctx.now.since_origin() >= Duration::from_secs(7) {
                set(&world, "keys", "X1", true);
            }
            let mut h = hung.lock().expect("hung");
            if i == 1 && !*h && hang.is_some_and(|at| ctx.now.since_origin() >= at) {
                *h = true;
                plc.clock()
                    .sleep_until(plc.clock().now() + Duration::from_secs(10));
            }
        }))
    });
    let outcomes = tasks.run_virtual();
    let trace = trace.lock().expect("trace").clone();
    (outcomes, trace, world)
}

fn of<'t>(outcomes: &'t [TaskOutcome], name: &str) -> &'t TaskOutcome {
    outcomes
        .iter()
        .find(|o| o.name == name)
        .expect("the task's outcome")
}

#[test]
fn the_fast_task_keeps_its_period_beside_a_slow_task_on_its_own_line() {
    let s = Scratch::new("task_runtime", "alone");
    std::fs::copy(
        repo().join("examples/two-tasks/press.ladder.yaml"),
        s.dir.join("press.ladder.yaml"),
    )
    .expect("copy the press program");
    let (alone, _, _) = run_project(&s.write("project.yaml", PRESS_ALONE), RUN, None);
    let (outcomes, _, _) = run(RUN, None);
    let press = &of(&outcomes, "press").outcome;
    let panel = &of(&outcomes, "panel").outcome;
    let alone = &of(&alone, "press").outcome;
    assert_eq!(press.reason, StopReason::TimeUp);
    assert_eq!(panel.reason, StopReason::TimeUp);
    // 10 s at 30 ms and at 500 ms, each from the end of its own line's start-up.
    assert_eq!(press.stats.cycles, 334, "{:?}", press.stats);
    assert_eq!(panel.stats.cycles, 20);
    // The panel line needs hundreds of milliseconds for its I/O; the press never waits for
    // it: its cycles and overruns are those of the press alone (its first cycle, which reads
    // and writes every module in full, is its one overrun).
    assert!(panel.stats.cycle.percentiles().max > Duration::from_millis(100));
    assert_eq!(panel.stats.overruns, 0);
    assert_eq!(press.stats.overruns, alone.stats.overruns);
    assert!(press.stats.overruns <= 1, "{}", press.stats.overruns);
    assert_eq!(
        press.stats.cycle.percentiles().p99,
        alone.stats.cycle.percentiles().p99
    );
    assert!(press.stats.cycle.percentiles().p99 < Duration::from_millis(30));
}

#[test]
fn a_published_value_is_seen_from_the_readers_next_cycle_on_never_before() {
    let (_, trace, _) = run(RUN, None);
    // The panel task publishes `enabled` at the end of the cycle that read the key.
    let panel: Vec<&Line> = trace.iter().filter(|l| l.0 == "panel").collect();
    let first = panel
        .iter()
        .position(|l| l.3[0] == Value::Bool(true))
        .expect("the panel enables the press");
    // It started at or after 1 s; it ends within its period.
    let published_from = panel[first].2;
    assert!(published_from.since_origin() >= Duration::from_secs(7));
    let press: Vec<&Line> = trace.iter().filter(|l| l.0 == "press").collect();
    for l in &press {
        let enabled = l.3[0] == Value::Bool(true);
        if l.2 + Duration::from_millis(30) <= published_from {
            // This whole press cycle ran before the panel's cycle even started.
            assert!(!enabled, "press cycle {} saw it early", l.1);
        }
        if l.2 >= published_from + Duration::from_millis(500) {
            assert!(enabled, "press cycle {} missed it", l.1);
            // Both palm buttons, the guard and the enable: the ram goes down.
            assert_eq!(l.3[1], Value::Bool(true));
        }
    }
    // Once seen it stays: the press saw one change, at one cycle boundary.
    let changes = press.windows(2).filter(|w| w[0].3[0] != w[1].3[0]).count();
    assert_eq!(changes, 1);
    // The panel shows the ram going down from its next cycle after the press published it.
    assert!(panel.iter().any(|l| l.3[3] == Value::Bool(true)));
}

#[test]
fn a_watchdog_trip_in_one_task_drives_every_output_safe() {
    let (outcomes, trace, world) = run(Duration::from_secs(12), Some(Duration::from_secs(9)));
    assert!(
        matches!(
            of(&outcomes, "panel").outcome.reason,
            StopReason::Watchdog(_)
        ),
        "{:?}",
        of(&outcomes, "panel").outcome.reason
    );
    assert_eq!(
        of(&outcomes, "press").outcome.reason,
        StopReason::TaskFault {
            task: "panel".into()
        }
    );
    // The ram was going down and the running lamp on before the trip.
    assert!(trace
        .iter()
        .any(|l| l.0 == "press" && l.3[1] == Value::Bool(true)));
    assert!(trace
        .iter()
        .any(|l| l.0 == "panel" && l.3[3] == Value::Bool(true)));
    // The press stopped at its next cycle boundary, well before its run time (12 s).
    let press = &of(&outcomes, "press").outcome;
    assert!(press.stats.last.start.since_origin() < Duration::from_secs(10));
    // Every output of both lines at its safe value in the modules.
    assert_eq!(output(&world, "valves", "Y1"), Value::Bool(false));
    assert_eq!(output(&world, "lamps", "Y1"), Value::Bool(false));
    assert_eq!(output(&world, "lamps", "Y2"), Value::Bool(false));
}

#[test]
fn two_runs_of_several_tasks_give_the_same_trace() {
    let (a_outcomes, a, _) = run(RUN, None);
    let (b_outcomes, b, _) = run(RUN, None);
    assert!(a.len() > 100);
    assert_eq!(a, b);
    for (x, y) in a_outcomes.iter().zip(&b_outcomes) {
        assert_eq!(x.outcome.stats.cycles, y.outcome.stats.cycles);
        assert_eq!(
            x.outcome.stats.cycle.percentiles(),
            y.outcome.stats.cycle.percentiles()
        );
    }
}

/// The example copied into a scratch folder (a run writes its audit file beside it).
fn example_copy(case: &str) -> Scratch {
    let s = Scratch::new("task_runtime", case);
    for f in ["project.yaml", "press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(repo().join("examples/two-tasks").join(f), s.dir.join(f))
            .expect("copy the example");
    }
    s
}

fn ctl(socket: &std::path::Path, args: &[&str]) -> (bool, String) {
    let mut all = args.to_vec();
    all.extend(["--socket", socket.to_str().expect("UTF-8")]);
    crate::common::host::softplc(&all)
}

#[test]
fn run_on_the_real_clock_reports_each_task_and_hands_requests_to_the_owner() {
    let s = example_copy("real");
    let socket = s.dir.join("s.sock");
    let child = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("run")
        .arg(s.dir.join("project.yaml"))
        .args(["--for", "8s", "--quiet", "--socket"])
        .arg(&socket)
        // SIGHUP's answer is an info line of each task.
        .env("SOFTPLC_LOG", "info")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("softplc runs");
    // The press starts once its fast line is up, the panel's slow line takes seconds more:
    // until then the press runs alone.
    let status = crate::common::host::status_once_scanned(&socket, &[10, 1]);
    assert_eq!(status["tasks"][0]["name"], "press");
    assert_eq!(status["tasks"][0]["period_us"], 30_000);
    assert_eq!(status["tasks"][1]["name"], "panel");
    assert_eq!(status["tasks"][1]["period_us"], 500_000);
    // Every task's modules are listed.
    let modules = status["modules"].as_array().expect("modules");
    assert_eq!(modules.len(), 12, "{status}");
    // A force goes to the task owning the tag, whose scan logs it.
    let (ok, text) = ctl(&socket, &["force", "key_on", "1"]);
    assert!(ok, "{text}");
    assert!(text.contains("key_on forced to 1"), "{text}");
    // A reload with no program changed: each task says so and runs on.
    let (ok, text) = ctl(&socket, &["reload"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("press.ladder.yaml unchanged; task panel: program "),
        "{text}"
    );
    let (_, text) = ctl(&socket, &["status"]);
    assert!(
        text.starts_with("two-tasks: 2 tasks\n  task press: "),
        "{text}"
    );
    // `systemctl reload` (SIGHUP) reloads every task, each logging what became of it; the
    // PLC runs on.
    #[allow(unsafe_code)]
    // SAFETY: kill has no memory preconditions; the pid is our own child's.
    unsafe {
        libc::kill(child.id() as i32, libc::SIGHUP)
    };
    let out = child.wait_with_output().expect("the run ends");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(stdout.contains("\ntask press:\n  scans "), "{stdout}");
    assert!(stdout.contains("\ntask panel:\n  scans "), "{stdout}");
    assert!(
        stderr.contains("task{name=panel}: tag key_on forced to 1"),
        "{stderr}"
    );
    for task in ["press", "panel"] {
        assert!(
            stderr.contains(&format!("task{{name={task}}}: program "))
                && stderr.contains(&format!("{task}.ladder.yaml unchanged")),
            "{stderr}"
        );
    }
}

#[test]
fn the_examples_scenarios_pass_in_ladder_and_rhai_with_one_trace() {
    let (ok, text) = crate::common::host::softplc(&["test", "examples/two-tasks", "--verbose"]);
    assert!(ok, "{text}");
    assert!(text.contains("2 passed, 0 failed"), "{text}");
    // Each task's scans, counted on its own: 20 s of the press's 30 ms cycles (from its first
    // scan) and of the panel's 500 ms ones, fewer where its slow line overran.
    assert!(
        text.contains("(14 expectations, press 667 scans, panel 32 scans)"),
        "{text}"
    );
    // Each run's trace: the lines after its `ok` line, up to the next.
    let mut traces: Vec<Vec<&str>> = Vec::new();
    for line in text.lines() {
        if line.starts_with("ok ") {
            traces.push(Vec::new());
        } else if let Some(t) = traces.last_mut() {
            if line.starts_with("   ") {
                t.push(line.trim());
            }
        }
    }
    assert_eq!(traces.len(), 2, "{text}");
    assert!(traces[0].contains(&"6.420s  press_down = 1"), "{text}");
    // The panel's key switch module lost: its alarm raised and cleared at the panel task's
    // cycles (500 ms apart from 4.376 s), acknowledged at the press's last cycle before 15.5 s.
    for line in [
        "13.876s  alarm.lost.keys = raised",
        "15.480s  alarm.lost.keys = acknowledged",
        "18.376s  alarm.lost.keys = cleared",
    ] {
        assert!(traces[0].contains(&line), "{line}:\n{text}");
    }
    assert_eq!(traces[0], traces[1], "ladder and Rhai differ:\n{text}");
}
