//! Several programs in one task (`programs:`): they run in the listed order within the task's
//! cycle on its image, each in its own language; `program:` beside `programs:` and an empty
//! list are refused where written; `check` lists every program, names the file of an error in
//! any of them, and warns (naming both places) when two programs of one task write one tag,
//! while two tasks writing one tag stay refused.

use std::sync::Arc;
use std::time::Duration;

use softplc::clock::VirtualClock;
use softplc::logic::ScanContext;
use softplc::plc::Plc;
use softplc::project::{parse_str, ErrorKind, ProgramKind, Project};
use softplc::scan::ScanInstant;
use softplc_io::point::Value;

use crate::common::scratch::{Scratch, TWO_LINES};

/// A project of one task without lines: `go` is on from the start; `{programs}` is filled in.
const ONE_TASK: &str = "\
project: p
scan: { period: 10ms }
buses: []
modules: []
tags:
  - { name: go,    type: bool, initial: true }
  - { name: busy,  type: bool }
  - { name: valve, type: bool }
{programs}
";

/// The ladder program: `busy` follows `go`.
const LADDER: &str = "rungs:\n  - go -> busy\n";
/// The Rhai program: `valve` follows `busy`, as the ladder program left it this cycle.
const RHAI: &str = "// the valve follows busy\nvalve = busy;\n";

fn folder(case: &str) -> Scratch {
    let s = Scratch::new("task-programs", case);
    s.write("a.ladder.yaml", LADDER);
    s.write("b.rhai", RHAI);
    s
}

fn parse(s: &Scratch, text: &str) -> Result<Project, Vec<softplc::project::ProjectError>> {
    let file = s.write("project.yaml", text);
    parse_str(text, &file).map_err(|e| e.errors)
}

/// The values of `busy` and `valve` after the first cycle's logic.
fn after_one_cycle(project: Project) -> (Value, Value) {
    let mut plc = Plc::build(project, Arc::new(VirtualClock::new())).expect("builds");
    let ctx = ScanContext {
        now: ScanInstant::ZERO,
        delta: Duration::from_millis(10),
        cycle: 1,
    };
    plc.run_logic(&ctx).expect("no fault");
    let value = |name: &str| {
        let id = plc.image().id(name).expect("a tag");
        plc.image().get(id)
    };
    (value("busy"), value("valve"))
}

#[test]
fn a_tasks_programs_run_in_their_order_each_in_its_language_on_one_image() {
    let s = folder("order");
    let text = ONE_TASK.replace(
        "{programs}",
        "programs:\n  - { file: a.ladder.yaml, kind: ladder }\n  - { file: b.rhai, kind: rhai }",
    );
    let p = parse(&s, &text).expect("valid");
    let kinds: Vec<ProgramKind> = p.programs.iter().map(|p| p.kind).collect();
    assert_eq!(kinds, [ProgramKind::Ladder, ProgramKind::Rhai]);
    assert_eq!(p.tasks[0].programs, p.programs);
    // The Rhai program, second, sees what the ladder program wrote in the same cycle.
    assert_eq!(
        after_one_cycle(p),
        (Value::Bool(true), Value::Bool(true)),
        "the second program reads the first one's output of the same cycle"
    );

    // The other order: the Rhai program reads `busy` before the ladder program sets it.
    let text = ONE_TASK.replace(
        "{programs}",
        "programs:\n  - { file: b.rhai, kind: rhai }\n  - { file: a.ladder.yaml, kind: ladder }",
    );
    let p = parse(&s, &text).expect("valid");
    assert_eq!(after_one_cycle(p), (Value::Bool(true), Value::Bool(false)));
}

#[test]
fn program_beside_programs_and_an_empty_list_are_refused_where_written() {
    let s = folder("refused");
    let text = ONE_TASK.replace(
        "{programs}",
        "program: { file: a.ladder.yaml, kind: ladder }\nprograms:\n  - { file: b.rhai, kind: rhai }",
    );
    let errors = parse(&s, &text).unwrap_err();
    assert_eq!(errors.len(), 1, "{errors:#?}");
    assert_eq!(
        errors[0].kind,
        ErrorKind::ProgramBesidePrograms { program_line: 9 }
    );
    assert_eq!((errors[0].line, errors[0].column), (11, 3), "{}", errors[0]);

    let errors = parse(&s, &ONE_TASK.replace("{programs}", "programs: []")).unwrap_err();
    assert_eq!(errors[0].kind, ErrorKind::NoPrograms);
    assert_eq!((errors[0].line, errors[0].column), (9, 11));

    // In a task, each missing file is said at its entry.
    let text = TWO_TASKS
        .replace("{lines}", TWO_LINES)
        .replace("{fast}", "programs:\n      - { file: a.ladder.yaml, kind: ladder }\n      - { file: gone.rhai, kind: rhai }")
        .replace("{slow}", "program: { file: slow.expr, kind: expr }");
    s.write("slow.expr", "lamp = key\n");
    let errors = parse(&s, &text).unwrap_err();
    assert_eq!(errors.len(), 1, "{errors:#?}");
    assert!(
        matches!(errors[0].kind, ErrorKind::ProgramNotFound { .. }),
        "{}",
        errors[0]
    );
    assert_eq!(errors[0].line, 8, "{}", errors[0]);
}

/// Two tasks on two lines; `{fast}` and `{slow}` are the tasks' program keys.
const TWO_TASKS: &str = "\
project: t
tasks:
  - name: fast
    period: 20ms
    buses: [fast_line]
    {fast}
  - name: slow
    period: 500ms
    buses: [slow_line]
    {slow}
{lines}tags:
  - { name: go,    point: f1.X1 }
  - { name: valve, point: f1.Y1, safe: false }
  - { name: key,   point: s1.X1 }
  - { name: lamp,  point: s1.Y1, safe: false }
  - { name: busy,  type: bool }
";

/// `softplc check PROJECT`: whether it passed, stdout, stderr.
fn check(project: &std::path::Path) -> (bool, String, String) {
    crate::common::host::check_in(&crate::common::host::repo(), project)
}

fn two_task_project(s: &Scratch, fast_rhai: &str) -> std::path::PathBuf {
    s.write("fast.ladder.yaml", "rungs:\n  - go -> busy\n");
    s.write("fast.rhai", fast_rhai);
    s.write("slow.expr", "lamp = busy & key\n");
    s.write(
        "project.yaml",
        &TWO_TASKS
            .replace("{lines}", TWO_LINES)
            .replace(
                "{fast}",
                "programs:\n      - { file: fast.ladder.yaml, kind: ladder }\n      - { file: fast.rhai, kind: rhai }",
            )
            .replace("{slow}", "program: { file: slow.expr, kind: expr }"),
    )
}

#[test]
fn check_lists_every_program_of_a_task_and_names_the_file_of_an_error() {
    let s = Scratch::new("task-programs", "check");
    let project = two_task_project(&s, "valve = busy;\n");
    let (ok, out, err) = check(&project);
    assert!(ok, "{out}\n{err}");
    let ladder = format!(
        "    program {} (Ladder)",
        s.dir.join("fast.ladder.yaml").display()
    );
    let rhai = format!("    program {} (Rhai)", s.dir.join("fast.rhai").display());
    let at = |needle: &str| {
        out.find(needle)
            .unwrap_or_else(|| panic!("{needle}:\n{out}"))
    };
    assert!(at(&ladder) < at(&rhai), "in running order:\n{out}");
    assert!(!out.contains("warning: tag"), "{out}");

    // An error in the second program names its file, line and column.
    let project = two_task_project(&s, "valve = busy;\nvalve = nosuch;\n");
    let (ok, out, err) = check(&project);
    assert!(!ok, "{out}");
    let place = format!("{}:2:", s.dir.join("fast.rhai").display());
    assert!(err.contains(&place), "{err}");
    assert!(err.contains("nosuch"), "{err}");
}

#[test]
fn two_programs_of_one_task_writing_a_tag_is_a_warning_naming_both_places() {
    let s = Scratch::new("task-programs", "shared");
    // The Rhai program writes `busy` too, on its line 2.
    let project = two_task_project(&s, "valve = busy;\nbusy = false;\n");
    let (ok, out, err) = check(&project);
    assert!(ok, "a warning, not a refusal:\n{out}\n{err}");
    let warning = format!(
        "{}:2:1: warning: tag `busy` is also written by an earlier program of task `fast` at {}:2:",
        s.dir.join("fast.rhai").display(),
        s.dir.join("fast.ladder.yaml").display()
    );
    assert!(out.contains(&warning), "{warning}\n{out}");

    // The same tag written by the other task is refused, as between any two tasks.
    s.write("slow.expr", "lamp = key\nbusy = key\n");
    let (ok, _, err) = check(&project);
    assert!(!ok);
    assert!(
        err.contains("tag `busy` is written by task `slow` here and by task `fast`"),
        "{err}"
    );
}

#[test]
fn the_page_draws_each_ladder_program_of_a_task_with_its_own_blocks_live_values() {
    use softplc::logic::{Member, OutputValue};
    use softplc::project::WebConfig;
    use softplc::service::web::WebInfo;

    let s = Scratch::new("task-programs", "page");
    s.write("a.ladder.yaml", "rungs:\n  - go -> TON t1(20ms) -> busy\n");
    s.write("b.ladder.yaml", "rungs:\n  - go -> TON t2(50ms) -> valve\n");
    let text = ONE_TASK.replace(
        "{programs}",
        "programs:\n  - { file: a.ladder.yaml, kind: ladder }\n  - { file: b.ladder.yaml, kind: ladder }",
    );
    let p = parse(&s, &text).expect("valid");
    let mut plc = Plc::build(p, Arc::new(VirtualClock::new())).expect("builds");
    let web = WebConfig {
        bind: "127.0.0.1:0".parse().expect("an address"),
        writes: false,
        token: None,
        operator_token: None,
        trend: Vec::new(),
    };
    let info = WebInfo::new(&plc, plc.project(), &web);
    let files: Vec<(&str, u32, bool)> = info
        .programs
        .iter()
        .map(|v| (v.file.as_str(), v.inst_base, v.diagram.is_some()))
        .collect();
    // Each program drawn as a ladder; the second's instances after the first's one.
    assert_eq!(
        files,
        [("a.ladder.yaml", 0, true), ("b.ladder.yaml", 1, true)]
    );
    for cycle in 1..=4u64 {
        let ctx = ScanContext {
            now: ScanInstant::after_origin(Duration::from_millis(10 * (cycle - 1))),
            delta: Duration::from_millis(10),
            cycle,
        };
        plc.run_logic(&ctx).expect("no fault");
    }
    let mut outputs = Vec::new();
    plc.instance_outputs(&mut outputs);
    let q = |inst: u32| {
        outputs
            .iter()
            .find(|o| o.inst == inst && o.member == Member::Q)
            .map(|o| o.value)
    };
    // After 30 ms the first program's 20 ms timer is done, the second's 50 ms one is not:
    // the page reads each at its program's base.
    assert_eq!(q(info.programs[0].inst_base), Some(OutputValue::Bool(true)));
    assert_eq!(
        q(info.programs[1].inst_base),
        Some(OutputValue::Bool(false))
    );
}

/// The project of one task running `a.ladder.yaml` then `b.rhai`, in `s`.
fn two_programs(s: &Scratch) -> std::path::PathBuf {
    s.write(
        "project.yaml",
        &ONE_TASK.replace(
            "{programs}",
            "programs:\n  - { file: a.ladder.yaml, kind: ladder }\n  - { file: b.rhai, kind: rhai }",
        ),
    )
}

fn logic(plc: &mut Plc, cycle: u64) -> Value {
    let ctx = ScanContext {
        now: ScanInstant::after_origin(Duration::from_millis(10 * cycle)),
        delta: Duration::from_millis(10),
        cycle,
    };
    plc.run_logic(&ctx).expect("no fault");
    let id = plc.image().id("valve").expect("a tag");
    plc.image().get(id)
}

#[test]
fn a_reload_compiles_every_program_of_the_task_again() {
    let s = folder("reload");
    let project = softplc::project::load(&two_programs(&s)).expect("valid");
    let mut plc = Plc::build(project, Arc::new(VirtualClock::new())).expect("builds");
    assert_eq!(logic(&mut plc, 1), Value::Bool(true));
    // The second program changed: the reload takes it, the first program still runs first.
    s.write("b.rhai", "valve = !busy;\n");
    plc.reload_program().expect("reloads");
    assert_eq!(logic(&mut plc, 2), Value::Bool(false));
    // An error in the second program refuses the reload, naming its file and line.
    s.write("b.rhai", "valve = nosuch;\n");
    let e = plc.reload_program().expect_err("refused").to_string();
    assert!(e.contains("b.rhai:1:"), "{e}");
    assert_eq!(
        logic(&mut plc, 3),
        Value::Bool(false),
        "the running one stays"
    );
}

#[test]
fn the_records_program_identity_covers_every_program_of_the_task() {
    use softplc::recorder::{read_record, replay, ReplayOptions, Settings};
    use softplc::scan::ScanEngine;

    let s = folder("record");
    let file = two_programs(&s);
    let project = softplc::project::load(&file).expect("valid");
    let mut plc = Plc::build(project.clone(), Arc::new(VirtualClock::new())).expect("builds");
    let folder = s.dir.join("rec");
    let settings = Settings::new(folder.clone(), Duration::from_secs(600), 16 << 20);
    let handle = plc.record(settings).expect("records");
    let mut engine = ScanEngine::new(plc).run_for(Duration::from_millis(500));
    engine.run();
    drop(engine);
    assert_eq!(handle.finish().error, None);
    let record = read_record(&folder).expect("a record");
    let header = &record.segments[0].header;
    assert!(
        header.program_file.contains("a.ladder.yaml") && header.program_file.contains("b.rhai"),
        "{}",
        header.program_file
    );
    let options = ReplayOptions { differences: 10 };
    let same = replay(&record, &project, options, |_| {}).expect("replays");
    assert_eq!(same.recorded_program, same.replayed_program);
    assert!(same.identical());
    // Only the second program changed: another identity, and its output differs.
    s.write("b.rhai", "valve = !busy;\n");
    let changed = softplc::project::load(&file).expect("valid");
    let options = ReplayOptions { differences: 10 };
    let other = replay(&record, &changed, options, |_| {}).expect("replays");
    assert_ne!(other.recorded_program, other.replayed_program);
    assert!(!other.identical());
    assert_eq!(other.differences[0].tags[0].tag, "valve");
}

#[test]
fn the_status_lists_the_programs_in_running_order() {
    use softplc::scan::ScanStats;
    use softplc::service::{StatusReport, TaskStatus};

    let s = folder("status");
    let project = softplc::project::load(&two_programs(&s)).expect("valid");
    let plc = Plc::build(project, Arc::new(VirtualClock::new())).expect("builds");
    let report = StatusReport::of(&plc, &ScanStats::default());
    assert_eq!(report.programs, ["a.ladder.yaml", "b.rhai"]);
    let text = report.to_string();
    assert!(
        text.contains("\n  programs, in running order: a.ladder.yaml, b.rhai\n"),
        "{text}"
    );
    // With several tasks, under each task's line.
    let task = TaskStatus {
        name: "press".into(),
        period: Duration::from_millis(30),
        programs: vec!["press.ladder.yaml".into(), "count.rhai".into()],
        live: Arc::default(),
        modules: Vec::new(),
    };
    let text = report.with_tasks(&[task]).to_string();
    assert!(
        text.contains("\n    programs: press.ladder.yaml, count.rhai\n"),
        "{text}"
    );
}

#[test]
fn check_lists_the_top_level_programs_in_running_order() {
    let s = folder("check-top");
    let project = two_programs(&s);
    let (ok, out, err) = check(&project);
    assert!(ok, "{out}\n{err}");
    let lines = format!(
        "\nprogram {} (Ladder)\nprogram {} (Rhai)\n",
        s.dir.join("a.ladder.yaml").display(),
        s.dir.join("b.rhai").display()
    );
    assert!(out.contains(&lines), "{lines}\n{out}");
}
