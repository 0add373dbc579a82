//! Control of a PLC of several tasks through its control socket, as a client sees it (the
//! two-tasks example run on virtual clocks, `softplc run --virtual`): a write naming tags of
//! both tasks is split between them and each part's answer comes back, a refused part says
//! which and why; `unforce --all` reaches every task.

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
    assert!(
        text.contains("task panel: refused: reload refused:"),
        "{text}"
    );
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
