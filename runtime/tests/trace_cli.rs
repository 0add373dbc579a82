//! `softplc trace` against a running `softplc run` on the virtual clock, through its control
//! socket, as a user types it: the project's trace listed, armed, waited for and saved as CSV
//! and VCD; a trace armed with --tags; the refusals, with their words. Also the `traces:`
//! errors `check` reports, at their line and column.

use crate::common::host;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

use host::{run_virtual, Running};

fn folder(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-trace-cli-{}-{name}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `n` counts the cycles, `pulse` is true on every fourth; the project defines `boot`, armed
/// when the PLC starts (the default), and `pulses`, armed by hand.
const PROJECT: &str = "project: tracecli
scan: { period: 10ms }
tags:
  - { name: n, type: i32 }
  - { name: pulse, type: bool }
  - { name: level, type: f32 }
program: { file: count.rhai, kind: rhai }
traces:
  - name: boot
    tags: [n]
    trigger: pulse rising
    pre: 1
    post: 1
  - name: pulses
    tags: [n, pulse, phase.logic]
    trigger: pulse rising
    pre: 2
    post: 3
    arm: manual
";

fn softplc(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .stdin(Stdio::null())
        .output()
        .unwrap()
}

fn text(o: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&o.stdout).into_owned(),
        String::from_utf8_lossy(&o.stderr).into_owned(),
    )
}

fn start(dir: &Path) -> (Running, PathBuf) {
    start_with(dir, PROJECT)
}

fn start_with(dir: &Path, project: &str) -> (Running, PathBuf) {
    std::fs::write(
        dir.join("count.rhai"),
        "n = n + 1;\npulse = n % 4 == 0;\nlevel = level + 0.5;\nif level > 4.0 { level = 0.0; }\n",
    )
    .unwrap();
    std::fs::write(dir.join("project.yaml"), project).unwrap();
    let socket = dir.join("ctl.sock");
    let running = run_virtual(&dir.join("project.yaml"), &socket);
    (running, socket)
}

#[test]
fn a_project_trace_is_armed_waited_for_and_saved_as_csv_and_vcd() {
    let dir = folder("save");
    let (_run, socket) = start(&dir);
    let s = socket.to_str().unwrap();

    let o = softplc(&["trace", "status", "--socket", s]);
    assert!(o.status.success(), "{o:?}");
    assert_eq!(
        text(&o).0,
        "boot: complete, 3/3 samples (pre 1, post 1), triggered at cycle 4; n\n\
         pulses: not armed, 0/6 samples (pre 2, post 3); n, pulse, phase.logic\n",
        "boot armed itself at start and caught the first pulse; pulses waits to be armed"
    );

    let o = softplc(&["trace", "arm", "pulses", "--socket", s]);
    assert!(o.status.success(), "{o:?}");
    assert!(text(&o).0.starts_with("pulses: "), "{o:?}");

    let csv = dir.join("pulses.csv");
    let vcd = dir.join("pulses.vcd");
    let o = softplc(&[
        "trace",
        "save",
        "pulses",
        "--wait",
        "30s",
        "--csv",
        csv.to_str().unwrap(),
        "--vcd",
        vcd.to_str().unwrap(),
        "--socket",
        s,
    ]);
    assert!(o.status.success(), "{o:?}");
    assert!(
        text(&o).1.contains(" sample(s) of pulses written to"),
        "{o:?}"
    );
    let csv = std::fs::read_to_string(&csv).unwrap();
    // Which cycle it was armed at depends on when the request came; what it holds around
    // that cycle does not: up to two samples before the rise (fewer when it rose sooner after
    // arming), the rise, three after, on the 10 ms grid of the virtual clock, n being the
    // cycle. The first sample cannot be the rise: an edge needs the value before it.
    let first: u64 = csv
        .lines()
        .nth(1)
        .unwrap()
        .split(',')
        .nth(1)
        .unwrap()
        .parse()
        .unwrap();
    let rise = (first / 4 + 1) * 4;
    let mut expected = String::from("time_s,cycle,n [i32],pulse [bool],phase.logic [i32 us]\n");
    for c in first..=rise + 3 {
        let t = (c - 1) * 10;
        expected.push_str(&format!(
            "{}.{:09},{c},{c},{},0\n",
            t / 1000,
            (t % 1000) * 1_000_000,
            u8::from(c % 4 == 0)
        ));
    }
    assert_eq!(csv, expected);
    let held = rise + 4 - first;
    assert!((4..=6).contains(&held), "{csv}");

    let vcd = std::fs::read_to_string(&vcd).unwrap();
    assert!(vcd.contains("$var wire 1 # pulse $end\n"), "{vcd}");
    let at_rise = format!("#{}\nr{rise} !\nr{rise} \"\n1#\n", (rise - 1) * 10_000);
    assert!(vcd.contains(&at_rise), "{at_rise}\nin\n{vcd}");

    // Saved: a single trace stays complete, and says so.
    let o = softplc(&["trace", "status", "pulses", "--socket", s]);
    let line = text(&o).0;
    assert_eq!(
        line,
        format!(
            "pulses: complete, {held}/6 samples (pre 2, post 3), triggered at cycle {rise}; \
             n, pulse, phase.logic\n"
        )
    );
}

#[test]
fn a_trace_given_with_tags_is_checked_like_the_project_and_refusals_name_the_fault() {
    let dir = folder("adhoc");
    let (_run, socket) = start(&dir);
    let s = socket.to_str().unwrap();

    let o = softplc(&[
        "trace",
        "arm",
        "climb",
        "--tags",
        "n,level",
        "--trigger",
        "level == 2.5",
        "--pre",
        "1",
        "--post",
        "1",
        "--socket",
        s,
    ]);
    assert!(o.status.success(), "{o:?}");
    let o = softplc(&[
        "trace", "save", "climb", "--wait", "30s", "--csv", "-", "--socket", s,
    ]);
    assert!(o.status.success(), "{o:?}");
    let (out, _) = text(&o);
    let rows: Vec<&str> = out.lines().skip(1).collect();
    // level climbs 0.5 a cycle and starts again after 4: the trigger row is where it is 2.5
    // (with the row before it unless it came first), then one after.
    assert!((2..=3).contains(&rows.len()), "{out}");
    assert!(rows[rows.len() - 2].ends_with(",2.5"), "{out}");
    assert!(rows[rows.len() - 1].ends_with(",3"), "{out}");

    let cases: [(&[&str], &str); 5] = [
        (
            &["trace", "arm", "--tags", "nn,pulse"],
            "error: trace signal \"nn\" is no tag, module counter or phase time; did you mean n?\n",
        ),
        (
            &["trace", "arm", "--tags", "n", "--trigger", "n rising"],
            "error: trigger \"n rising\": n is i32, and an edge or level needs a bool; compare \
             it instead (`n > 0`)\n",
        ),
        (
            &["trace", "arm", "pulses", "--tags", "n"],
            "error: trace pulses is defined in the project: arm it by name, or give yours \
             another --name\n",
        ),
        (
            &["trace", "arm", "jam"],
            "error: no trace jam (traces: boot, pulses, climb)\n",
        ),
        (
            &["trace", "save", "pulses", "--csv", "-"],
            "error: trace pulses is not armed: arm it with `softplc trace arm pulses`\n",
        ),
    ];
    for (args, expected) in cases {
        let mut args = args.to_vec();
        args.extend(["--socket", s]);
        let o = softplc(&args);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {o:?}");
        assert_eq!(text(&o).1, expected, "{args:?}");
    }
}

/// Arms `name` with `tags` and `pre`/`post` samples around `n > 0`; the command's output.
fn arm(s: &str, name: &str, tags: &str, around: u32) -> Output {
    let around = around.to_string();
    softplc(&[
        "trace",
        "arm",
        name,
        "--tags",
        tags,
        "--trigger",
        "n > 0",
        "--pre",
        &around,
        "--post",
        &around,
        "--socket",
        s,
    ])
}

#[test]
fn arming_past_the_projects_trace_budget_is_refused_with_what_is_left() {
    let dir = folder("budget");
    let project = format!("{PROJECT}trace_budget: {{ armed: 3, memory: 1MiB }}\n");
    let (_run, socket) = start_with(&dir, &project);
    let s = socket.to_str().unwrap();

    // One signal: 8 bytes a value, 16 the time, 8 the cycle. boot (3 samples) is armed at
    // start: 96 bytes. big takes 20,001 samples: 640,032 bytes.
    let o = arm(s, "big", "n", 10_000);
    assert!(o.status.success(), "{o:?}");
    let o = arm(s, "big2", "n", 10_000);
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert_eq!(
        text(&o).1,
        "error: trace big2 needs 625 KiB for its samples; 398.8 KiB of the 1 MiB trace budget \
         is left: disarm a trace, record fewer signals or samples, or raise \
         trace_budget.memory\n"
    );
    // Armed again, big replaces itself: its own memory counts as free.
    let o = arm(s, "big", "n", 10_000);
    assert!(o.status.success(), "{o:?}");

    let o = arm(s, "small", "n", 1);
    assert!(o.status.success(), "{o:?}");
    let o = arm(s, "small2", "n", 1);
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    assert_eq!(
        text(&o).1,
        "error: 3 traces are armed, as many as the project allows (trace_budget.armed); \
         disarm one first\n"
    );
    let o = softplc(&["trace", "disarm", "small", "--socket", s]);
    assert!(o.status.success(), "{o:?}");
    let o = arm(s, "small2", "n", 1);
    assert!(o.status.success(), "disarming gave its place back: {o:?}");
    let o = softplc(&["trace", "status", "--socket", s]);
    let listed: Vec<String> = text(&o)
        .0
        .lines()
        .map(|l| l.split(':').next().unwrap().to_owned())
        .collect();
    assert_eq!(listed, ["boot", "big", "small2", "pulses"]);
}

/// Resident memory of a process, from /proc.
fn rss_bytes(pid: u32) -> u64 {
    let status = std::fs::read_to_string(format!("/proc/{pid}/status")).unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    let kib: u64 = line.split_whitespace().nth(1).unwrap().parse().unwrap();
    kib * 1024
}

#[test]
fn forty_of_the_largest_traces_armed_leave_the_plc_within_the_default_budget() {
    let dir = folder("flood");
    let (run, socket) = start(&dir);
    let s = socket.to_str().unwrap();
    let before = rss_bytes(run.0.id());
    // 5 signals × 99,999 samples, 64 bytes each: 6.4 MB a trace, so 10 fit the default 64 MiB.
    let tags = "n,pulse,level,phase.logic,phase.read";
    let mut accepted = 0;
    for i in 0..40 {
        let o = arm(s, &format!("t{i}"), tags, 49_999);
        match o.status.code() {
            Some(0) => accepted += 1,
            _ => assert!(
                text(&o).1.contains("of the 64 MiB trace budget is left"),
                "{o:?}"
            ),
        }
    }
    assert_eq!(accepted, 10);
    let grown = rss_bytes(run.0.id()).saturating_sub(before);
    // Unbounded, the 40 rings would be 256 MB; the budget holds them to 64 MiB.
    assert!(grown < 80 << 20, "resident memory grew by {grown} bytes");
}

#[test]
fn check_reports_every_trace_error_at_its_line_and_column() {
    let dir = folder("check");
    std::fs::write(dir.join("count.rhai"), "n = n + 1;\n").unwrap();
    let project = "project: bad
scan: { period: 10ms }
tags:
  - { name: n, type: i32 }
  - { name: pulse, type: bool }
program: { file: count.rhai, kind: rhai }
traces:
  - name: a
    tags: [n, pulze, phase.logik]
    trigger: n rising
    pre: -1
  - name: a
    tags: [pulse]
    trigger: pulse > 1
    mode: again
    every: 0
";
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    let o = softplc(&["check", path.to_str().unwrap()]);
    assert_eq!(o.status.code(), Some(1), "{o:?}");
    let p = path.display();
    let (_, err) = text(&o);
    for line in [
        format!("{p}:9:15: error: trace signal \"pulze\" is no tag, module counter or phase time; did you mean pulse?"),
        format!("{p}:9:22: error: \"phase.logik\" is no phase time; the phases are phase.read, phase.logic, phase.write, phase.cycle"),
        format!("{p}:10:14: error: trigger \"n rising\": n is i32, and an edge or level needs a bool; compare it instead (`n > 0`)"),
        format!("{p}:11:10: error: pre is -1; it must be between 0 and 100000"),
        format!("{p}:12:11: error: trace a is already defined"),
        format!("{p}:14:14: error: trigger \"pulse > 1\": pulse is a bool; use `pulse rising`, `falling`, `high` or `low`"),
        format!("{p}:15:11: error: mode \"again\": a trace's mode is single or repeat"),
        format!("{p}:16:12: error: every is 0; it must be between 1 and 1000000 cycles"),
    ] {
        assert!(err.contains(&line), "missing\n{line}\nin\n{err}");
    }
}

#[test]
fn a_trace_armed_with_tags_and_no_name_is_adhoc_as_from_the_page() {
    let dir = folder("unnamed");
    let (_run, socket) = start(&dir);
    let s = socket.to_str().unwrap();
    let o = softplc(&[
        "trace",
        "arm",
        "--tags",
        "n",
        "--trigger",
        "pulse rising",
        "--socket",
        s,
    ]);
    assert!(o.status.success(), "{o:?}");
    assert!(text(&o).0.contains("adhoc"), "{o:?}");
    // The page's unnamed trace has the same name (service/web/trace.rs): one default.
    let o = softplc(&[
        "trace", "save", "adhoc", "--wait", "30s", "--csv", "-", "--socket", s,
    ]);
    assert!(o.status.success(), "{o:?}");
    assert!(
        text(&o).0.starts_with("time_s,cycle,n [i32]\n"),
        "{:?}",
        text(&o).1
    );
}
