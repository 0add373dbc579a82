//! Control of a PLC of several tasks through its control socket, as a client sees it (the
//! two-tasks example run on virtual clocks, `softplc run --virtual`): a write naming tags of
//! both tasks is split between them and each part's answer comes back, a refused part says
//! which and why; `unforce --all` reaches every task; `--keep-forces` keeps each task's
//! forces; a reload swaps the changed task's program while the other runs on, and refuses a
//! bad program at its place; a trace samples the cycles of the task owning its trigger, all
//! traces against one budget.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use softplc::service::control::{request, Request, Response, TagValue};

use crate::common::host::{repo, Running};
use crate::common::scratch::Scratch;

/// The two-tasks example (ladder) copied into a scratch folder of its own.
fn example(case: &str) -> Scratch {
    let s = Scratch::new("task_control", case);
    for f in ["project.yaml", "press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(repo().join("examples/two-tasks").join(f), s.dir.join(f))
            .expect("copy the example");
    }
    s
}

/// The example running on virtual clocks, and its control socket.
fn start(s: &Scratch, extra: &[&str]) -> (Running, PathBuf) {
    let socket = s.dir.join("ctl.sock");
    let running =
        crate::common::host::run_virtual_with(&s.dir.join("project.yaml"), &socket, extra);
    (running, socket)
}

fn ask(socket: &Path, r: &Request) -> Response {
    request(socket, r).expect("an answer")
}

/// Waits (a bounded real time) until both tasks have completed `cycles` cycles each.
fn wait_cycles(socket: &Path, cycles: u64) {
    let begin = Instant::now();
    loop {
        let r = ask(socket, &Request::Status);
        let v = serde_json::to_value(&r.status).expect("JSON");
        let scans = |t: usize| v["tasks"][t]["scans"].as_u64().unwrap_or(0);
        if scans(0) >= cycles && scans(1) >= cycles {
            return;
        }
        assert!(
            begin.elapsed() < Duration::from_secs(60),
            "tasks not running: {v}"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
}

fn write(socket: &Path, values: &[(&str, &str)]) -> Response {
    ask(
        socket,
        &Request::Write {
            values: values
                .iter()
                .map(|(t, v)| TagValue {
                    tag: (*t).into(),
                    value: (*v).into(),
                })
                .collect(),
        },
    )
}

fn force(socket: &Path, tag: &str, value: &str) {
    let r = ask(
        socket,
        &Request::Force {
            tag: tag.into(),
            value: value.into(),
        },
    );
    assert!(r.ok, "{r:?}");
}

fn unforce_all(socket: &Path) -> String {
    let (ok, text) = crate::common::host::softplc(&[
        "unforce",
        "--all",
        "--socket",
        socket.to_str().expect("UTF-8"),
    ]);
    assert!(ok, "{text}");
    text
}

#[test]
fn a_write_naming_tags_of_both_tasks_is_split_and_each_part_answers() {
    let s = example("write");
    let (_run, socket) = start(&s, &[]);
    wait_cycles(&socket, 2);
    // `strokes` is the press task's, `enabled` the panel's: each part lands at its own task's
    // next boundary, and the reply gives each task's cycle.
    let r = write(&socket, &[("enabled", "1"), ("strokes", "7")]);
    assert!(r.ok, "{r:?}");
    let parts = r.parts.clone().expect("each task's part");
    assert_eq!(parts.len(), 2, "{r:?}");
    assert_eq!(
        (parts[0].task.as_str(), parts[1].task.as_str()),
        ("press", "panel")
    );
    assert!(
        parts
            .iter()
            .all(|p| p.answer.ok && p.answer.applied_at.is_some()),
        "{r:?}"
    );
    let message = r.message.clone().unwrap_or_default();
    assert!(
        message.starts_with("task press: strokes written: 7 (at cycle "),
        "{message}"
    );
    assert!(
        message.contains("; task panel: enabled written: 1 (at cycle "),
        "{message}"
    );

    // A forced tag refuses its task's part; the other part is applied all the same, and the
    // reply says which was which.
    force(&socket, "running_lamp", "1");
    let r = write(&socket, &[("strokes", "9"), ("running_lamp", "0")]);
    assert!(!r.ok, "{r:?}");
    assert!(r.locked, "a forced tag's refusal is a lock: {r:?}");
    let error = r.error.clone().unwrap_or_default();
    assert!(
        error.starts_with("task press: strokes written: 9"),
        "{error}"
    );
    assert!(
        error.contains("; task panel: refused: ") && error.contains("running_lamp"),
        "{error}"
    );
    let parts = r.parts.expect("parts");
    assert!(
        parts[0].answer.ok && !parts[1].answer.ok && parts[1].answer.locked,
        "{parts:?}"
    );

    // An unknown tag refuses the whole write before any part is applied.
    let r = write(&socket, &[("strokes", "11"), ("no_such_tag", "1")]);
    assert!(!r.ok, "{r:?}");
    assert!(r.parts.is_none(), "{r:?}");
    assert!(r.error.unwrap_or_default().contains("no_such_tag"));
}

#[test]
fn unforce_all_reaches_every_task_and_merges_their_answers() {
    let s = example("unforce");
    let (_run, socket) = start(&s, &[]);
    wait_cycles(&socket, 1);
    force(&socket, "hand_left", "1");
    force(&socket, "guard_closed", "1");
    force(&socket, "key_on", "1");
    let text = unforce_all(&socket);
    assert!(
        text.contains("task press: 2 force(s) removed; task panel: 1 force(s) removed"),
        "{text}"
    );
    // Every task's forces are gone: a second time finds none in either.
    let text = unforce_all(&socket);
    assert!(
        text.contains("task press: 0 force(s) removed; task panel: 0 force(s) removed"),
        "{text}"
    );
}

#[test]
fn kept_forces_are_kept_per_task_and_restored_in_each_at_restart() {
    let s = example("keep");
    let keep = ["--keep-forces"];
    {
        let (_run, socket) = start(&s, &keep);
        wait_cycles(&socket, 1);
        force(&socket, "hand_left", "1");
        force(&socket, "key_on", "1");
        // Each task writes its own file, off its scan, soon after the force.
        let files = [
            s.dir.join("project.yaml.forces.press.json"),
            s.dir.join("project.yaml.forces.panel.json"),
        ];
        let begin = Instant::now();
        let kept = |f: &PathBuf, tag: &str| {
            std::fs::read_to_string(f).is_ok_and(|t| t.contains(&format!("\"{tag}\": \"1\"")))
        };
        while !(kept(&files[0], "hand_left") && kept(&files[1], "key_on")) {
            assert!(
                begin.elapsed() < Duration::from_secs(30),
                "forces not kept: {:?}",
                files
                    .iter()
                    .map(std::fs::read_to_string)
                    .collect::<Vec<_>>()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
        let press = std::fs::read_to_string(&files[0]).expect("the press's forces");
        assert!(!press.contains("key_on"), "{press}");
    }
    // Restarted: each task applies its own forces before its first scan.
    let (_run, socket) = start(&s, &keep);
    wait_cycles(&socket, 1);
    let text = unforce_all(&socket);
    assert!(
        text.contains("task press: 1 force(s) removed; task panel: 1 force(s) removed"),
        "{text}"
    );
}

/// A tag's value in the status (the first task's image, which copies in every other tag).
fn value(socket: &Path, tag: &str) -> String {
    let r = ask(socket, &Request::Status);
    let status = r.status.expect("a status");
    status
        .tags
        .iter()
        .find(|t| t.name == tag)
        .map(|t| t.value.clone())
        .expect("the tag")
}

/// Each task's completed cycles.
fn scans(socket: &Path) -> (u64, u64) {
    let r = ask(socket, &Request::Status);
    let status = r.status.expect("a status");
    (status.tasks[0].scans, status.tasks[1].scans)
}

/// Waits (a bounded real time) until `tag` shows `want`.
fn wait_value(socket: &Path, tag: &str, want: &str) {
    let begin = Instant::now();
    loop {
        let v = value(socket, tag);
        if v == want {
            return;
        }
        assert!(
            begin.elapsed() < Duration::from_secs(60),
            "{tag} is {v}, not {want}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

fn ctl(socket: &Path, args: &[&str]) -> (bool, String) {
    let mut all = args.to_vec();
    all.extend(["--socket", socket.to_str().expect("UTF-8")]);
    crate::common::host::softplc(&all)
}

const PANEL_INVERTED: &str = "\
rungs:
  - key_on -> enabled
  - /press_down -> running_lamp
  - rung: /guard_closed -> BLINK guard_blink(1s, 1s) -> guard_lamp
";

#[test]
fn a_reload_swaps_the_changed_task_s_program_while_the_other_runs_on() {
    let s = example("reload");
    let (_run, socket) = start(&s, &[]);
    wait_cycles(&socket, 1);
    // The press runs: both hands, the guard closed, the key on.
    for tag in ["hand_left", "hand_right", "guard_closed", "key_on"] {
        force(&socket, tag, "1");
    }
    wait_value(&socket, "running_lamp", "1");
    assert_eq!(value(&socket, "press_down"), "1");
    let strokes = value(&socket, "strokes");

    // The panel's program changes on disk: its lamp now shows the ram NOT going down.
    s.write("panel.ladder.yaml", PANEL_INVERTED);
    let before = scans(&socket);
    let (ok, text) = ctl(&socket, &["reload"]);
    assert!(ok, "{text}");
    assert!(
        text.contains("task press: program ")
            && text.contains("press.ladder.yaml unchanged; task panel: program ")
            && text.contains("panel.ladder.yaml reloaded"),
        "{text}"
    );
    wait_value(&socket, "running_lamp", "0");
    // The press never stopped: its cycles went on counting, its valve stayed driven, its
    // stroke counter kept its value.
    let after = scans(&socket);
    assert!(
        after.0 > before.0 && after.1 > before.1,
        "{before:?} {after:?}"
    );
    assert_eq!(value(&socket, "press_down"), "1");
    assert_eq!(value(&socket, "strokes"), strokes);

    // A program that does not compile is refused at its place; both tasks run on, the
    // panel with the program it had.
    s.write(
        "panel.ladder.yaml",
        "rungs:\n  - key_on -> enabled\n  - press_down -> \n",
    );
    let (ok, text) = ctl(&socket, &["reload", "--task", "panel"]);
    assert!(!ok, "{text}");
    // Each cause once: the refusal is said by the task's part, not again around it.
    assert!(text.contains("task panel: reload refused:"), "{text}");
    assert_eq!(text.matches("refused").count(), 1, "{text}");
    assert!(text.contains("panel.ladder.yaml:3:"), "{text}");
    // A program writing a tag the other task owns is refused naming both tasks.
    s.write(
        "panel.ladder.yaml",
        &format!("{PANEL_INVERTED}  - key_on -> press_down\n"),
    );
    let (ok, text) = ctl(&socket, &["reload"]);
    assert!(!ok, "{text}");
    assert!(
        text.contains(
            "panel.ladder.yaml:5:5: error: tag `press_down` is written by task `press`; task \
             `panel`'s new program writes it here"
        ),
        "{text}"
    );
    assert!(text.contains("task press: program "), "{text}");
    let refused = scans(&socket);
    wait_cycles(&socket, refused.1 + 2);
    assert!(scans(&socket).0 > refused.0);
    assert_eq!(value(&socket, "running_lamp"), "0");
    assert_eq!(value(&socket, "press_down"), "1");

    // An unknown task is refused, naming the tasks.
    let (ok, text) = ctl(&socket, &["reload", "--task", "oven"]);
    assert!(!ok);
    assert!(
        text.contains("no task oven: the tasks are press, panel"),
        "{text}"
    );
}

/// `softplc trace ...` against the socket.
fn trace(socket: &Path, args: &[&str]) -> (bool, String) {
    let mut all = vec!["trace"];
    all.extend_from_slice(args);
    ctl(socket, &all)
}

/// The rows of a trace's CSV: (time in ns, cycle, values).
fn rows(csv: &str) -> Vec<(u64, u64, Vec<String>)> {
    csv.lines()
        .skip(1)
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            let (s, ns) = f[0].split_once('.').expect("time_s");
            let t = s.parse::<u64>().expect("s") * 1_000_000_000 + ns.parse::<u64>().expect("ns");
            (
                t,
                f[1].parse().expect("cycle"),
                f[2..].iter().map(|v| (*v).to_owned()).collect(),
            )
        })
        .collect()
}

/// Trace `name` saved as CSV once complete: its text and rows, checked to be task `task`'s
/// own cycles, one after the other, `period_ns` apart on its grid.
fn saved(
    s: &Scratch,
    socket: &Path,
    name: &str,
    task: &str,
    period_ns: u64,
) -> (String, Vec<(u64, u64, Vec<String>)>) {
    let file = s.dir.join(format!("{name}.csv"));
    let path = file.to_str().expect("UTF-8");
    let (ok, text) = trace(socket, &["save", name, "--wait", "60s", "--csv", path]);
    assert!(ok, "{text}");
    let csv = std::fs::read_to_string(&file).expect("the CSV");
    assert!(
        csv.starts_with(&format!("time_s,cycle [task {task}],")),
        "{csv}"
    );
    let rows = rows(&csv);
    for w in rows.windows(2) {
        assert_eq!(w[1].1, w[0].1 + 1, "{csv}");
        assert_eq!(w[1].0 - w[0].0, period_ns, "{csv}");
    }
    (csv, rows)
}

#[test]
fn a_trace_samples_the_cycles_of_the_task_owning_its_trigger() {
    let s = example("trace");
    // One budget of three traces for the whole PLC, whichever tasks arm them; the project's
    // own trace, armed at start, in the task owning its trigger (the panel).
    let text = std::fs::read_to_string(s.dir.join("project.yaml")).expect("the project");
    s.write(
        "project.yaml",
        &format!(
            "{text}\ntrace_budget: {{ armed: 3 }}\ntraces:\n  - {{ name: key, tags: [key_on, \
             strokes], trigger: key_on rising, pre: 1, post: 1 }}\n"
        ),
    );
    let (_run, socket) = start(&s, &[]);
    wait_cycles(&socket, 1);
    let (ok, text) = trace(&socket, &["status"]);
    assert!(ok, "{text}");
    assert!(text.starts_with("key (task panel): armed, "), "{text}");
    assert_eq!(text.lines().count(), 1, "armed in one task only: {text}");
    // press_down is the press task's: the trace samples the press's cycles.
    let (ok, text) = trace(
        &socket,
        &[
            "arm",
            "stroke",
            "--tags",
            "press_down,enabled",
            "--trigger",
            "press_down rising",
            "--pre",
            "3",
            "--post",
            "4",
        ],
    );
    assert!(ok, "{text}");
    assert!(text.contains("stroke (task press): "), "{text}");
    // running_lamp is the panel's: that trace samples the panel's cycles.
    let (ok, text) = trace(
        &socket,
        &[
            "arm",
            "lamp",
            "--tags",
            "running_lamp",
            "--pre",
            "0",
            "--post",
            "4",
        ],
    );
    assert!(ok, "{text}");
    assert!(text.contains("lamp (task panel): "), "{text}");
    // The budget is the PLC's: a third trace is refused, in whichever task.
    let (ok, text) = trace(
        &socket,
        &[
            "arm", "third", "--tags", "strokes", "--pre", "0", "--post", "2",
        ],
    );
    assert!(!ok, "{text}");
    assert!(
        text.contains("3 traces are armed, as many as the project allows"),
        "{text}"
    );
    // An unknown task is refused, naming the tasks.
    let (ok, text) = trace(
        &socket,
        &["arm", "x", "--tags", "strokes", "--task", "oven"],
    );
    assert!(!ok);
    assert!(
        text.contains("no task oven: the tasks are press, panel"),
        "{text}"
    );
    // A module's counters are the task's polling it.
    let (ok, text) = trace(
        &socket,
        &[
            "arm",
            "y",
            "--tags",
            "strokes,keys.requests",
            "--task",
            "press",
        ],
    );
    assert!(!ok);
    assert!(
        text.contains(
            "trace y: module keys is polled by task panel, and the trace samples task press's \
             cycles"
        ),
        "{text}"
    );

    for tag in ["hand_left", "hand_right", "guard_closed", "key_on"] {
        force(&socket, tag, "1");
    }
    let (csv, stroke) = saved(&s, &socket, "stroke", "press", 30_000_000);
    assert!(
        csv.starts_with("time_s,cycle [task press],press_down [bool],enabled [bool]\n"),
        "{csv}"
    );
    assert_eq!(stroke.len(), 8, "{csv}");
    // The rise, at the fourth sample, with the panel's `enabled` copied in before it.
    let values: Vec<&str> = stroke.iter().map(|r| r.2[0].as_str()).collect();
    assert_eq!(values, ["0", "0", "0", "1", "1", "1", "1", "1"], "{csv}");
    assert_eq!(stroke[3].2[1], "1", "{csv}");
    let (_, lamp) = saved(&s, &socket, "lamp", "panel", 500_000_000);
    // The panel counts fewer cycles than the press in the same time.
    assert!(lamp[0].1 < stroke[0].1, "{lamp:?} {stroke:?}");

    // Status lists both, each with its task; disarming frees the budget for a third.
    let (ok, text) = trace(&socket, &["status"]);
    assert!(ok, "{text}");
    assert!(text.contains("stroke (task press): complete"), "{text}");
    assert!(text.contains("lamp (task panel): "), "{text}");
    let (ok, text) = ctl(&socket, &["trace", "disarm", "lamp"]);
    assert!(ok, "{text}");
    let (ok, text) = trace(
        &socket,
        &[
            "arm", "third", "--tags", "strokes", "--pre", "0", "--post", "2",
        ],
    );
    assert!(ok, "{text}");
    assert!(text.contains("third (task press): "), "{text}");
}

#[test]
fn a_project_of_one_task_answers_to_its_task_s_name_main() {
    let s = Scratch::new("task_control", "main");
    s.write("count.rhai", "n = n + 1;\n");
    s.write(
        "project.yaml",
        "project: one\nscan: { period: 10ms }\ntags:\n  - { name: n, type: i32 }\nprogram: { file: count.rhai, kind: rhai }\n",
    );
    let socket = s.dir.join("ctl.sock");
    let _run = crate::common::host::run_virtual(&s.dir.join("project.yaml"), &socket);
    let (ok, text) = ctl(&socket, &["reload", "--task", "main"]);
    assert!(ok, "{text}");
    assert!(text.contains("count.rhai reloaded"), "{text}");
    let (ok, text) = ctl(&socket, &["reload", "--task", "oven"]);
    assert!(!ok);
    assert!(
        text.contains("no task oven: this PLC runs task main"),
        "{text}"
    );
    let (ok, text) = trace(&socket, &["arm", "x", "--tags", "n", "--task", "oven"]);
    assert!(!ok);
    assert!(
        text.contains("no task oven: this PLC runs task main"),
        "{text}"
    );
    // Its own name is accepted; a trace of a project of one task is shown as before, naming
    // no task.
    let (ok, text) = trace(&socket, &["arm", "x", "--tags", "n", "--task", "main"]);
    assert!(ok, "{text}");
    assert!(text.starts_with("x: "), "{text}");
}
