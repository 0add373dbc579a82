//! `tasks:` in the project file and what `check` says of it: each task's period, program
//! and buses; a bus belongs to exactly one task; every tag has one writing task; `scan:` and
//! `program:` alone stay one task, `main`. Each refusal is asserted at its file:line:col.

use softplc::image::{ProcessImage, TagId};
use softplc::logic::{load_tasks, ProgramError};
use softplc::project::{parse_str, ErrorKind, Project, MAIN_TASK};

use crate::common::host::repo;
use crate::common::scratch::{Scratch, TWO_LINES};

/// Two buses, a module on each (`TWO_LINES`), tags on both and a memory tag; `{tasks}` is
/// filled in by [`with_tasks`].
const PROJECT: &str = "\
project: t
{tasks}
{lines}tags:
  - { name: go,      point: f1.X1 }
  - { name: valve,   point: f1.Y1, safe: false }
  - { name: key,     point: s1.X1 }
  - { name: lamp,    point: s1.Y1, safe: false }
  - { name: enabled, type: bool }
  - { name: busy,    type: bool }
";

/// Lines 2..=12: the two tasks, `{fast}` and `{slow}` their `buses:` lists.
const TASKS: &str = "\
tasks:
  - name: fast
    period: 20ms
    realtime: { priority: 60 }
    program: { file: fast.expr, kind: expr }
    buses: {fast}
  - name: slow
    period: 500ms
    watchdog: { time: 2s, sensitivity: 2 }
    program: { file: slow.expr, kind: expr }
    buses: {slow}";

/// `softplc check PROJECT`: whether it passed, stdout, stderr.
fn check(project: &std::path::Path) -> (bool, String, String) {
    crate::common::host::check_in(&crate::common::host::repo(), project)
}

/// The project with `tasks` in its `{tasks}` place.
fn with_tasks(tasks: &str) -> String {
    PROJECT
        .replace("{lines}", TWO_LINES)
        .replace("{tasks}", tasks)
}

fn project_text(fast: &str, slow: &str) -> String {
    with_tasks(&TASKS.replace("{fast}", fast).replace("{slow}", slow))
}

/// A scratch folder with `fast.expr` and `slow.expr` holding the given programs.
fn folder(case: &str, fast: &str, slow: &str) -> Scratch {
    let s = Scratch::new("tasks", case);
    s.write("fast.expr", fast);
    s.write("slow.expr", slow);
    s
}

fn parse(s: &Scratch, text: &str) -> Result<Project, Vec<softplc::project::ProjectError>> {
    let file = s.write("project.yaml", text);
    parse_str(text, &file).map_err(|e| e.errors)
}

/// The programs of a project the tests share: the fast task drives the valve from `go` and
/// `enabled`, the slow one the lamp and `enabled` from the key.
const FAST: &str = "valve = go & enabled\nbusy = valve\n";
const SLOW: &str = "enabled = key\nlamp = busy\n";

#[test]
fn tasks_parse_with_their_timing_programs_and_buses() {
    let s = folder("parse", FAST, SLOW);
    let p = parse(&s, &project_text("[fast_line]", "[slow_line]")).expect("valid");
    assert_eq!(p.tasks.len(), 2);
    let (fast, slow) = (&p.tasks[0], &p.tasks[1]);
    assert_eq!(fast.name, "fast");
    assert_eq!(fast.scan.period, std::time::Duration::from_millis(20));
    assert_eq!(fast.scan.realtime.priority, Some(60));
    assert_eq!(fast.buses, vec![0]);
    assert_eq!(slow.name, "slow");
    assert_eq!(slow.scan.watchdog.time, std::time::Duration::from_secs(2));
    assert_eq!(slow.scan.watchdog.sensitivity, 2);
    // The default watchdog is 5 periods, as for `scan:`.
    assert_eq!(
        fast.scan.watchdog.time,
        std::time::Duration::from_millis(100)
    );
    assert_eq!(slow.buses, vec![1]);
    assert!(slow.programs[0].path.ends_with("slow.expr"));
    assert!(p.multitask());
    assert_eq!(p.bus_period(1), std::time::Duration::from_millis(500));
}

#[test]
fn scan_and_program_alone_are_one_task_named_main_owning_every_bus() {
    let s = folder("main", FAST, SLOW);
    let text = with_tasks("scan: { period: 20ms }\nprogram: { file: fast.expr, kind: expr }");
    let p = parse(&s, &text).expect("valid");
    assert_eq!(p.tasks.len(), 1);
    assert_eq!(p.tasks[0].name, MAIN_TASK);
    assert_eq!(p.tasks[0].buses, vec![0, 1]);
    assert_eq!(p.tasks[0].scan, p.scan);
    assert!(!p.multitask());
}

#[test]
fn a_bus_named_by_two_tasks_is_refused_at_the_second_naming() {
    let s = folder("twice", FAST, SLOW);
    let errors = parse(&s, &project_text("[fast_line]", "[slow_line, fast_line]")).unwrap_err();
    assert_eq!(errors.len(), 1, "{errors:#?}");
    let e = &errors[0];
    assert_eq!((e.line, e.column), (12, 24), "{e}");
    assert_eq!(
        e.kind.to_string(),
        "bus `fast_line` is already owned by task `fast` (line 7); a bus belongs to one task, \
         whose thread does all of its I/O"
    );
}

#[test]
fn a_bus_named_by_no_task_is_refused_at_the_bus() {
    let s = folder("none", FAST, SLOW);
    let errors = parse(&s, &project_text("[fast_line]", "[]")).unwrap_err();
    assert_eq!(errors.len(), 1, "{errors:#?}");
    assert_eq!((errors[0].line, errors[0].column), (15, 13));
    assert_eq!(
        errors[0].kind,
        ErrorKind::BusWithoutTask {
            bus: "slow_line".into()
        }
    );
}

#[test]
fn an_unknown_bus_and_a_duplicate_task_name_are_refused_where_written() {
    let s = folder("unknown", FAST, SLOW);
    let text =
        project_text("[fast_lin]", "[slow_line]").replace("- name: slow\n", "- name: fast\n");
    let errors = parse(&s, &text).unwrap_err();
    let lines: Vec<String> = errors
        .iter()
        .map(|e| format!("{}:{}: {}", e.line, e.column, e.kind))
        .collect();
    assert!(
        lines
            .iter()
            .any(|l| l.starts_with("7:13: unknown bus \"fast_lin\" (known: fast_line, slow_line)")),
        "{lines:#?}"
    );
    assert!(
        lines.iter().any(
            |l| l.starts_with("8:11: task name \"fast\" is already used by the task at line 3")
        ),
        "{lines:#?}"
    );
}

#[test]
fn tasks_beside_scan_or_no_task_at_all_are_refused() {
    let s = folder("beside", FAST, SLOW);
    let text = format!(
        "{}scan: {{ period: 10ms }}\n",
        project_text("[fast_line]", "[slow_line]")
    );
    let errors = parse(&s, &text).unwrap_err();
    assert_eq!(errors.len(), 1, "{errors:#?}");
    assert_eq!(errors[0].kind, ErrorKind::TasksBesideScan { key: "scan" });
    assert_eq!(errors[0].line, 26);

    let errors = parse(&s, &with_tasks("")).unwrap_err();
    assert_eq!(errors[0].kind, ErrorKind::NoTask);

    let errors = parse(&s, &with_tasks("tasks: []")).unwrap_err();
    assert_eq!(errors[0].kind, ErrorKind::NoTasks);
    assert_eq!((errors[0].line, errors[0].column), (2, 8));
}

fn ownership_errors(fast: &str, slow: &str) -> Vec<String> {
    let s = folder("owners", fast, slow);
    let p = parse(&s, &project_text("[fast_line]", "[slow_line]")).expect("valid");
    let image = ProcessImage::new(p.tags.iter().map(|t| (t.name.clone(), t.initial)));
    match load_tasks(&p, &image) {
        Ok(_) => Vec::new(),
        Err(ProgramError::Ownership(errors)) => errors
            .iter()
            .map(|e| e.to_string().replace(&s.dir.display().to_string(), "DIR"))
            .collect(),
        Err(e) => panic!("expected ownership errors, got {e}"),
    }
}

#[test]
fn every_tag_has_one_writing_task() {
    assert!(ownership_errors(FAST, SLOW).is_empty());
    assert_eq!(
        ownership_errors(FAST, "enabled = key\nbusy = key\n"),
        [
            "DIR/slow.expr:2:1: error: tag `busy` is written by task `slow` here and by task \
          `fast` at DIR/fast.expr:2:1; every tag has one writing task: write it in one and read \
          it in the other"
        ]
    );
    assert_eq!(
        ownership_errors(FAST, "enabled = key\nvalve = key\n"),
        [
            "DIR/slow.expr:2:1: error: tag `valve` is an output of bus `fast_line`, which task \
          `fast` owns; task `slow` writes it here: only the task owning a bus writes its outputs \
          (compute the value in `slow` into a memory tag and copy it in `fast`)"
        ]
    );
}

#[test]
fn ownership_follows_buses_and_writers() {
    let s = folder("owned", FAST, SLOW);
    let p = parse(&s, &project_text("[fast_line]", "[slow_line]")).expect("valid");
    let image = ProcessImage::new(p.tags.iter().map(|t| (t.name.clone(), t.initial)));
    let (_, owners) = load_tasks(&p, &image).expect("loads");
    // go, valve (fast_line), busy (written by fast).
    assert_eq!(owners.owned_by(0), [TagId(0), TagId(1), TagId(5)]);
    // key, lamp (slow_line), enabled (written by slow).
    assert_eq!(owners.owned_by(1), [TagId(2), TagId(3), TagId(4)]);
    assert_eq!(owners.foreign_to(0), [TagId(2), TagId(3), TagId(4)]);
}

#[test]
fn check_lists_each_task_with_its_buses_and_the_tags_it_owns() {
    let s = folder("check", FAST, SLOW);
    let project = s.write("project.yaml", &project_text("[fast_line]", "[slow_line]"));
    let (passed, text, _) = check(&project);
    assert!(passed, "{text}");
    assert!(text.starts_with("project t: 2 tasks"), "{text}");
    assert!(text.contains("bus fast_line: sim (simulated modules), 57600 8E1, response timeout 100.00ms, retries 1, task fast"), "{text}");
    for line in [
        "  task fast: period 20.00ms, watchdog 100.00ms × 3, SCHED_FIFO priority 60",
        "    buses: fast_line",
        "    owns: go, valve, busy",
        "  task slow: period 500.00ms, watchdog 2.00s × 2",
        "    buses: slow_line",
        "    owns: key, lamp, enabled",
    ] {
        assert!(text.lines().any(|l| l == line), "{line:?} in\n{text}");
    }
    // The slow line's budget counts against its own task's period.
    assert!(text.contains("predicted at 500.00ms"), "{text}");

    s.write("slow.expr", "enabled = key\nbusy = key\n");
    let (passed, _, err) = check(&project);
    assert!(!passed);
    assert!(
        err.contains("slow.expr:2:1: error: tag `busy` is written by task `slow` here"),
        "{err}"
    );
}

#[test]
fn the_two_tasks_example_passes_check() {
    let project = repo().join("examples/two-tasks/project.yaml");
    let (passed, text, _) = check(&project);
    assert!(passed, "{text}");
    assert!(!text.contains("warning:"), "{text}");
}
