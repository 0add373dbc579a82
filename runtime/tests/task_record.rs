//! The flight recorder and replay with several tasks (virtual clocks): `softplc run --record`
//! writes a record per task in the record's folder, each task's record names its task and
//! holds what the task copied in from the other, so `softplc replay` replays each task alone
//! with the cycles the run had and no difference; a program changed in one task differs in
//! that task only, naming it; a task whose disk fails is named in the recorder's state while
//! the other task records on, and the gap it leaves is named with its task by replay; a
//! real-clock run's task threads record alike.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use softplc::plc::{Plc, TaskPlc};
use softplc::project::load;
use softplc::recorder::format::TagRole;
use softplc::recorder::{
    read_record, replay, Disk, FaultDisk, FileDisk, Record, RecorderHandle, ReplayError,
    ReplayOptions, Settings,
};
use softplc::scan::TaskSet;
use softplc::service::{Health, PerTask, Service, ServiceState};
use softplc_io::point::Value;

use crate::common::host::softplc_in;
use crate::common::scratch::Scratch;

/// Two tasks on two lines: the slow one counts its cycles into `ticks`, the fast one copies
/// `ticks` in at its cycles' starts and computes `scaled` from it, which the slow one copies
/// in to drive its lamp. Each task's outputs depend on what it copied in from the other.
/// The task watchdogs are generous: the real-clock test runs beside the whole suite on shared
/// cores, and it is about the record, not the watchdog.
pub(crate) const PROJECT: &str = "\
project: counted
tasks:
  - name: fast
    period: 20ms
    watchdog: { time: 2s, sensitivity: 3 }
    program: { file: fast.rhai, kind: rhai }
    buses: [fast_line]
  - name: slow
    period: 100ms
    watchdog: { time: 2s, sensitivity: 3 }
    program: { file: slow.rhai, kind: rhai }
    buses: [slow_line]
buses:
  - { name: fast_line, port: sim, baud: 57600, response_timeout: 20ms }
  - { name: slow_line, port: sim, baud: 57600, response_timeout: 20ms }
modules:
  - { name: a, bus: fast_line, model: minimod, address: 1 }
  - { name: b, bus: slow_line, model: minimod, address: 1 }
tags:
  - { name: beat, point: a.Y1, safe: false }
  - { name: scaled, type: i32 }
  - { name: ticks, type: i32 }
  - { name: lamp, point: b.Y1, safe: false }
";

pub(crate) const FAST: &str = "scaled = ticks * 10;\nbeat = ticks % 2 == 0;\n";
pub(crate) const SLOW: &str = "ticks += 1;\nlamp = scaled % 20 == 10;\n";

fn project(case: &str) -> (Scratch, PathBuf) {
    let scratch = Scratch::new("task-record", case);
    scratch.write("fast.rhai", FAST);
    scratch.write("slow.rhai", SLOW);
    let path = scratch.write("project.yaml", PROJECT);
    (scratch, path)
}

/// `softplc run --virtual --for RUN_FOR --record 1m` of the project in `dir`.
fn run_recorded(dir: &Path, run_for: &str) -> (bool, String) {
    softplc_in(
        dir,
        &[
            "run",
            "project.yaml",
            "--virtual",
            "--for",
            run_for,
            "--record",
            "1m",
            "--no-socket",
            "--quiet",
        ],
    )
}

/// A run of 5 s, recorded; its output.
fn run_5s(dir: &Path) -> String {
    let (ok, out) = run_recorded(dir, "5s");
    assert!(ok, "the run succeeds: {out}");
    out
}

/// `softplc replay project.yaml.record project.yaml MORE` in `dir`.
fn replay_cli(dir: &Path, more: &[&str]) -> (bool, String) {
    let args = [&["replay", "project.yaml.record", "project.yaml"][..], more].concat();
    softplc_in(dir, &args)
}

/// The cycles the run's summary gives task `task`.
pub(crate) fn scans(out: &str, task: &str) -> u64 {
    let section = out
        .split_once(&format!("task {task}:\n"))
        .unwrap_or_else(|| panic!("task {task} in the summary: {out}"))
        .1;
    section
        .split_whitespace()
        .skip_while(|w| *w != "scans")
        .nth(1)
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("task {task}'s scans: {out}"))
}

/// The number of tag `name` in `record`'s tag table.
fn tag_number(record: &Record, name: &str) -> u32 {
    let tags = &record.segments[0].header.tags;
    tags.iter().position(|t| t.name == name).expect("the tag") as u32
}

#[test]
fn each_task_records_its_own_cycles_and_replays_alone_with_no_difference() {
    let (scratch, path) = project("replay");
    let out = run_5s(&scratch.dir);
    let folder = scratch.dir.join("project.yaml.record");
    let whole = load(&path).expect("the project");
    for task in ["fast", "slow"] {
        let record = read_record(&folder.join(task)).expect("the task's record");
        let header = &record.segments[0].header;
        assert_eq!(header.task.as_deref(), Some(task));
        // What a task copies in is an input of its record; what it writes, compared.
        let role = |tag: &str| {
            header
                .tags
                .iter()
                .find(|t| t.name == tag)
                .map(|t| t.role)
                .expect("the tag")
        };
        let (own, copied) = match task {
            "fast" => ("scaled", "ticks"),
            _ => ("ticks", "scaled"),
        };
        assert_eq!(role(copied), TagRole::Input, "{task} copies {copied} in");
        assert_eq!(role(own), TagRole::Memory, "{task} computes {own}");
        // Cycle N is the task's N-th scan, every one recorded.
        let cycles: Vec<u64> = record.cycles().map(|c| c.cycle).collect();
        let ran = scans(&out, task);
        assert!(ran > 10, "{task} ran: {out}");
        assert_eq!(cycles, (1..=ran).collect::<Vec<_>>(), "{task}");
        // The library's replay takes the task from the record.
        let report = replay(&record, &whole, ReplayOptions::default(), |_| {}).expect("replays");
        assert_eq!(report.task.as_deref(), Some(task));
        assert!(report.identical(), "{task}: {report:?}");
        assert_eq!(report.cycles, ran);
    }
    // The copied-in values changed during the run: replay had something to get right.
    let fast = read_record(&folder.join("fast")).expect("fast's record");
    let ticks = tag_number(&fast, "ticks");
    let seen: Vec<Value> = fast
        .cycles()
        .flat_map(|c| c.seen.iter().filter(|s| s.tag == ticks).map(|s| s.value))
        .collect();
    assert!(seen.len() > 10, "fast saw ticks change: {seen:?}");

    let (ok, text) = replay_cli(&scratch.dir, &[]);
    assert!(ok, "{text}");
    for task in ["fast", "slow"] {
        let line = format!(
            "task {task}: {} cycles, 5.00s of plant time, outputs identical",
            scans(&out, task)
        );
        assert!(text.contains(&line), "{line}\nin\n{text}");
    }
    assert!(text.contains("2 tasks replayed: fast "), "{text}");

    // One task, asked for by name, into a CSV that names it.
    let (ok, text) = replay_cli(&scratch.dir, &["--task", "slow", "--csv", "slow.csv"]);
    assert!(ok, "{text}");
    assert!(!text.contains("task fast"), "{text}");
    let csv = std::fs::read_to_string(scratch.dir.join("slow.csv")).expect("the CSV");
    assert!(
        csv.starts_with("time_s,cycle,rec.ticks [i32],rec.lamp [bool],new.ticks"),
        "{csv}"
    );
    assert_eq!(csv.lines().count() as u64, scans(&out, "slow") + 1);
    // Every task, a CSV each.
    let (ok, text) = replay_cli(&scratch.dir, &["--csv", "out.csv"]);
    assert!(ok, "{text}");
    for task in ["fast", "slow"] {
        let csv = std::fs::read_to_string(scratch.dir.join(format!("out.{task}.csv")))
            .expect("a CSV per task");
        assert_eq!(csv.lines().count() as u64, scans(&out, task) + 1);
    }

    // An unknown task is refused, listing the tasks.
    let (ok, text) = replay_cli(&scratch.dir, &["--task", "medium"]);
    assert!(!ok);
    assert!(
        text.contains("--task medium: project.yaml has no task \"medium\"; its tasks: fast, slow"),
        "{text}"
    );
    // The record of several tasks given with a project of one task: said, not a bare "no
    // segments".
    let one = PROJECT.replace(
        &PROJECT[PROJECT.find("tasks:").expect("tasks")..=PROJECT.find("\nbuses:").expect("buses")],
        "scan: { period: 20ms }\nprogram: { file: fast.rhai, kind: rhai }\n",
    );
    scratch.write("one.yaml", &one);
    let (ok, text) = softplc_in(&scratch.dir, &["replay", "project.yaml.record", "one.yaml"]);
    assert!(!ok);
    assert!(
        text.contains("it holds the records of the tasks fast, slow of a project of several tasks"),
        "{text}"
    );
    let (ok, text) = softplc_in(
        &scratch.dir,
        &["replay", "project.yaml.record/fast", "one.yaml"],
    );
    assert!(!ok);
    assert!(
        text.contains(
            "the record is of task fast of a project of several tasks, the project has one task"
        ),
        "{text}"
    );
}

#[test]
fn a_program_changed_in_one_task_differs_in_that_task_only() {
    let (scratch, path) = project("changed");
    let out = run_5s(&scratch.dir);
    scratch.write(
        "fast.rhai",
        "scaled = ticks * 11;\nbeat = ticks % 2 == 0;\n",
    );
    let folder = scratch.dir.join("project.yaml.record");
    // The first cycle of fast in which it copied in a count other than 0: there its new
    // program computes another `scaled`.
    let fast = read_record(&folder.join("fast")).expect("fast's record");
    let ticks = tag_number(&fast, "ticks");
    let (cycle, count) = fast
        .cycles()
        .find_map(|c| {
            c.seen
                .iter()
                .find(|s| s.tag == ticks && s.value != Value::I32(0))
                .map(|s| (c.cycle, s.value))
        })
        .expect("fast copied a count in");
    let Value::I32(count) = count else {
        panic!("ticks is an i32: {count:?}")
    };

    let (ok, text) = replay_cli(&scratch.dir, &[]);
    assert!(!ok, "the outputs differ: {text}");
    let first = format!("task fast: first difference at cycle {cycle} (t=");
    assert!(text.contains(&first), "{first}\nin\n{text}");
    let tag = format!("  scaled  recorded {}  replayed {}", count * 10, count * 11);
    assert!(text.contains(&tag), "{tag}\nin\n{text}");
    assert!(
        text.contains(&format!(
            "task slow: {} cycles, 5.00s of plant time, outputs identical",
            scans(&out, "slow")
        )),
        "the slow task's record holds what it copied in: {text}"
    );
    assert!(!text.contains("task slow: first difference"), "{text}");

    // A task's record replayed as another task is refused, naming both.
    let whole = load(&path).expect("the project");
    let slow = read_record(&folder.join("slow")).expect("slow's record");
    let subject = softplc::recorder::ReplaySubject::task(&whole, "fast").expect("fast");
    let err = softplc::recorder::replay_subject(&slow, &subject, ReplayOptions::default(), |_| {})
        .expect_err("another task's record");
    assert_eq!(
        err,
        ReplayError::OtherTask {
            record: "slow".into(),
            asked: "fast".into()
        }
    );
}

/// Polls `health`'s recorder state until `done` says so, for at most 20 s (the writer runs
/// on a thread of its own).
fn wait_for(health: &Health, done: impl Fn(&ServiceState) -> bool) -> ServiceState {
    let start = Instant::now();
    loop {
        let state = health.state(Service::Recorder);
        if done(&state) || start.elapsed() > Duration::from_secs(20) {
            return state;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Every task of `whole` recording into `dir/project.yaml.record`, the slow task through a
/// disk that fills when asked (its switch in the returned `FaultDisk`), each task's settings
/// changed by `tune`: the tasks, their recorders' handles, and the recorder's state.
fn record_tasks(
    whole: &softplc::project::Project,
    dir: &Path,
    tune: impl Fn(&mut Settings),
) -> (
    Vec<TaskPlc>,
    Vec<(String, RecorderHandle)>,
    Health,
    FaultDisk,
) {
    let mut tasks = Plc::build_tasks(whole, None, None).expect("builds");
    let settings = Settings::new(
        dir.join("project.yaml.record"),
        Duration::from_secs(60),
        8 << 20,
    );
    let health = Health::new();
    let recorders = PerTask::new();
    let mut handles = Vec::new();
    let mut slow_disk = None;
    for task in &mut tasks {
        let mut s = settings.for_task(&task.name, 2);
        tune(&mut s);
        let disk: Box<dyn Disk> = if task.name == "slow" {
            let disk = FaultDisk::new(&s.folder, 1 << 30);
            slow_disk = Some(disk.clone());
            Box::new(disk)
        } else {
            Box::new(FileDisk)
        };
        let handle = task.plc.record_on(s, disk).expect("the recorder starts");
        recorders.add_recorder(&task.name, handle.state_cell());
        handles.push((task.name.clone(), handle));
    }
    health.watch_tasks(Service::Recorder, recorders);
    (tasks, handles, health, slow_disk.expect("a slow task"))
}

/// Asserts the fast task's record holds its `cycles` cycles and replays identically.
fn fast_recorded_whole(dir: &Path, whole: &softplc::project::Project, cycles: u64) {
    let record = read_record(&dir.join("project.yaml.record/fast")).expect("fast's record");
    assert_eq!(record.cycles().count() as u64, cycles);
    let report = replay(&record, whole, ReplayOptions::default(), |_| {}).expect("replays");
    assert!(report.identical(), "{report:?}");
}

#[test]
fn a_task_whose_disk_fails_is_named_while_the_other_task_records_on() {
    let (scratch, path) = project("disk");
    let whole = load(&path).expect("the project");
    let (tasks, handles, health, disk) = record_tasks(&whole, &scratch.dir, |_| {});
    disk.full_switch()
        .store(true, std::sync::atomic::Ordering::SeqCst);
    let cycles: Arc<Mutex<Vec<u64>>> = Arc::new(Mutex::new(vec![0, 0]));
    let outcomes = TaskSet::new(tasks)
        .configure(|i, engine| {
            let cycles = cycles.clone();
            engine
                .run_for(Duration::from_secs(5))
                .on_cycle(Box::new(move |_, ctx| {
                    cycles.lock().expect("cycles")[i] = ctx.cycle;
                }))
        })
        .run_virtual();
    assert_eq!(outcomes.len(), 2);
    let state = wait_for(&health, |s| *s != ServiceState::Running);
    let reason = state.reason().unwrap_or_default().to_string();
    assert_eq!(state.word(), "degraded", "{state:?}");
    assert!(
        reason.starts_with("task slow: cannot write (No space left on device"),
        "{reason}"
    );
    assert!(!reason.contains("task fast"), "{reason}");
    assert!(disk.refused() > 0);

    let ran = cycles.lock().expect("cycles").clone();
    for (name, handle) in handles {
        let outcome = handle.finish();
        if name == "slow" {
            let error = outcome.error.expect("slow's record ends short");
            assert!(error.contains("project.yaml.record/slow"), "{error}");
        } else {
            assert_eq!(outcome.error, None);
        }
    }
    fast_recorded_whole(&scratch.dir, &whole, ran[0]);
}

#[test]
pub(crate) fn a_gap_in_a_tasks_record_is_named_with_its_task_by_replay() {
    let (scratch, path) = project("gap");
    let whole = load(&path).expect("the project");
    // Small blocks and a small hold: a full disk loses cycles quickly.
    let (tasks, handles, health, disk) = record_tasks(&whole, &scratch.dir, |s| {
        s.block_bytes = 64;
        s.hold_bytes = 128;
    });
    let full = disk.full_switch();
    let cycles: Arc<Mutex<Vec<u64>>> = Arc::new(Mutex::new(vec![0, 0]));
    let seen: Arc<Mutex<Option<ServiceState>>> = Arc::default();
    let outcomes = TaskSet::new(tasks)
        .configure(|i, engine| {
            let (cycles, full, health, seen) =
                (cycles.clone(), full.clone(), health.clone(), seen.clone());
            engine
                .run_for(Duration::from_secs(10))
                .on_cycle(Box::new(move |_, ctx| {
                    use std::sync::atomic::Ordering;
                    cycles.lock().expect("cycles")[i] = ctx.cycle;
                    // The slow task's disk fills at its cycle 5; at its cycle 60, once cycles
                    // are being lost, it comes back.
                    match (i, ctx.cycle) {
                        (1, 5) => full.store(true, Ordering::SeqCst),
                        (1, 60) => {
                            let losing = wait_for(&health, |s| {
                                s.reason().is_some_and(|r| r.contains("more lost"))
                            });
                            *seen.lock().expect("seen") = Some(losing);
                            full.store(false, Ordering::SeqCst);
                            wait_for(&health, |s| *s == ServiceState::Running);
                        }
                        _ => {}
                    }
                }))
        })
        .run_virtual();
    assert_eq!(outcomes.len(), 2);
    let losing = seen
        .lock()
        .expect("seen")
        .clone()
        .expect("the slow task's cycle 60");
    let reason = losing.reason().unwrap_or_default().to_string();
    assert!(
        reason.starts_with("task slow: cannot write (No space left on device")
            && reason.ends_with("more lost: the record will have a gap"),
        "{reason}"
    );
    let ran = cycles.lock().expect("cycles").clone();
    for (name, handle) in handles {
        let outcome = handle.finish();
        assert_eq!(outcome.error, None, "{name}");
        assert_eq!(
            outcome.gaps,
            u32::from(name == "slow"),
            "{name}: {outcome:?}"
        );
    }
    fast_recorded_whole(&scratch.dir, &whole, ran[0]);
    let slow = read_record(&scratch.dir.join("project.yaml.record/slow")).expect("slow's record");
    let gap = slow
        .segments
        .iter()
        .find_map(|s| s.gap)
        .expect("a gap block");
    // The disk is back after the slow task's cycle 60.
    assert!(gap.first <= gap.last && gap.last <= 60, "{gap:?}");
    let (_, text) = replay_cli(&scratch.dir, &[]);
    let note = format!(
        "task slow: note: no record from cycle {} to {}: the recorder could not write them",
        gap.first, gap.last
    );
    assert!(text.contains(&note), "{note}\nin\n{text}");
    assert!(
        text.contains(&format!(
            "task fast: {} cycles, 10.00s of plant time, outputs identical",
            ran[0]
        )),
        "{text}"
    );
}

#[test]
fn a_task_record_folder_that_cannot_be_made_stops_the_run_naming_the_task() {
    let (scratch, _) = project("folder");
    std::fs::create_dir_all(scratch.dir.join("project.yaml.record")).expect("the record folder");
    // A file where the slow task's folder would go.
    scratch.write("project.yaml.record/slow", "not a folder");
    let (ok, out) = run_recorded(&scratch.dir, "1s");
    assert!(!ok, "{out}");
    assert!(
        out.contains("flight recorder: task slow: cannot create"),
        "{out}"
    );
}

#[test]
fn on_the_real_clock_each_task_thread_records_and_the_status_shows_the_recorder() {
    let (scratch, _) = project("real");
    let socket = scratch.dir.join("s.sock");
    let run = ["project.yaml", "--for", "3s", "--record", "1m"];
    let child = crate::common::host::spawn_run(&scratch.dir, &run, &socket);
    let status = crate::common::host::status_once_scanned(&socket, &[1, 1]);
    let services = status["services"].as_array().expect("services");
    let recorder = services
        .iter()
        .find(|s| s["service"] == "recorder")
        .expect("the recorder's state");
    assert_eq!(recorder["state"], "running", "{recorder}");
    let out = child.wait_with_output().expect("the run ends");
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    // The threads copied in what the other task published whenever it did: the record holds
    // it, so each task replays as it ran.
    let (ok, text) = replay_cli(&scratch.dir, &[]);
    assert!(ok, "{text}");
    for task in ["fast", "slow"] {
        let line = format!("task {task}: {} cycles, ", scans(&stdout, task));
        assert!(text.contains(&line), "{line}\nin\n{text}");
    }
    assert!(!text.contains("differ"), "{text}");
}
