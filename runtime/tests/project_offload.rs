//! The push-down switches of a project file (`offload:`, a tag's `offload`, `debounce`,
//! `stretch`): valid forms parse to the expected configuration, each mistake is reported at its
//! `line:column`; and `softplc check` fails, naming the rung's `file:line:col`, when a rung
//! with `offload: require` cannot be pushed down.

use std::path::{Path, PathBuf};
use std::process::Command;

use softplc::project::{
    parse_str, ErrorKind, OffloadError, OffloadMode, OnStop, ProjectError, TagOffload,
};

fn fixtures() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/projects")
}

fn file() -> PathBuf {
    fixtures().join("inline.yaml")
}

/// Lines 1..=12: a MiniMod on a simulated line, a program (`conveyor.expr` of the fixtures).
const HEAD: &str = "\
project: t
scan:
  period: 20ms
program:
  file: conveyor.expr
  kind: expr
buses:
  - name: line1
    port: sim
modules:
  - name: mm1
    bus: line1
";

/// Lines 13..: the module's model and address, then `tags:` opening at line 15.
const MODEL: &str = "    model: minimod\n    address: 1\ntags:\n";

fn project(offload: &str, tags: &str) -> String {
    format!("{HEAD}{MODEL}{tags}{offload}")
}

fn one(text: &str) -> ProjectError {
    match parse_str(text, &file()) {
        Ok(p) => panic!("expected an error, got {p:#?}"),
        Err(mut e) => {
            assert_eq!(e.errors.len(), 1, "{:#?}", e.errors);
            e.errors.remove(0)
        }
    }
}

fn offload_error(e: &ProjectError) -> &OffloadError {
    match &e.kind {
        ErrorKind::Offload(o) => o,
        other => panic!("not an offload error: {other:?}"),
    }
}

/// Lines 16..=18.
const TAGS: &str = concat!(
    "  - { name: start, point: mm1.X1 }\n",
    "  - { name: stop, point: mm1.X2 }\n",
    "  - { name: motor, point: mm1.Y1, offload: require }\n",
);

#[test]
fn valid_forms() {
    let p = parse_str(&project("", TAGS), &file()).unwrap();
    assert_eq!(p.offload.mode, OffloadMode::Never, "the default");
    assert_eq!(p.offload.on_stop, OnStop::Clear);
    assert_eq!(p.offload.mode_of(2), OffloadMode::Require, "the tag's own");
    assert_eq!(p.offload.mode_of(0), OffloadMode::Never);

    let p = parse_str(&project("offload: auto\n", TAGS), &file()).unwrap();
    assert_eq!(p.offload.mode, OffloadMode::Auto);

    let text = project(
        "offload: { mode: require, on_stop: keep }\n",
        "  - { name: b, point: mm1.X2, debounce: 20ms, stretch: 500ms }\n",
    );
    let p = parse_str(&text, &file()).unwrap();
    assert_eq!(p.offload.mode, OffloadMode::Require);
    assert_eq!(p.offload.on_stop, OnStop::Keep);
    assert_eq!(
        p.offload.tags[0],
        TagOffload {
            mode: None,
            debounce: Some(20),
            stretch: Some(500),
            blink_phase_free: false,
        }
    );
}

#[test]
fn bad_modes_are_placed() {
    // `offload: sometimes` on line 19 (after the three tag lines), column 10.
    let e = one(&project("offload: sometimes\n", TAGS));
    assert_eq!((e.line, e.column), (19, 10));
    assert!(matches!(offload_error(&e), OffloadError::BadMode { text } if text == "sometimes"));
    assert_eq!(
        e.kind.to_string(),
        "offload mode \"sometimes\" is not one of auto, never, require"
    );

    let e = one(&project("offload: { mode: auto, on_stop: later }\n", TAGS));
    assert_eq!((e.line, e.column), (19, 33));
    assert!(matches!(offload_error(&e), OffloadError::BadOnStop { .. }));

    let e = one(&project(
        "",
        "  - { name: motor, point: mm1.Y1, offload: maybe }\n",
    ));
    assert_eq!((e.line, e.column), (16, 44));
    assert!(matches!(offload_error(&e), OffloadError::BadMode { .. }));

    // An unknown key of the mapping form is the YAML reader's error.
    let e = one(&project("offload: { mode: auto, when: now }\n", TAGS));
    assert!(matches!(e.kind, ErrorKind::UnknownKey { .. }), "{e}");
}

#[test]
fn tag_options_only_where_they_mean_something() {
    let e = one(&project(
        "",
        "  - { name: start, point: mm1.X1, offload: auto }\n",
    ));
    assert_eq!((e.line, e.column), (16, 44));
    assert!(matches!(
        offload_error(&e),
        OffloadError::ModeNotOnOutput {
            what: "not an output",
            ..
        }
    ));

    let e = one(&project("", "  - { name: m, type: bool, offload: auto }\n"));
    assert!(matches!(
        offload_error(&e),
        OffloadError::ModeNotOnOutput {
            what: "a memory tag",
            ..
        }
    ));

    let e = one(&project(
        "",
        "  - { name: motor, point: mm1.Y1, debounce: 20ms }\n",
    ));
    assert_eq!((e.line, e.column), (16, 45));
    assert_eq!(
        e.kind.to_string(),
        "tag motor: debounce is done by the module's input conditioning, which only MiniMod \
         inputs X1..X3 have; this is mm1.Y1 (an output of a minimod)"
    );

    let e = one(&project(
        "",
        "  - { name: fb, point: mm1.X9, stretch: 100ms }\n",
    ));
    assert!(matches!(
        offload_error(&e),
        OffloadError::ConditioningNotOnInput { key: "stretch", .. }
    ));

    let e = one(&project("", "  - { name: m, type: bool, debounce: 5ms }\n"));
    assert!(e.kind.to_string().ends_with("this is a memory tag"), "{e}");
}

#[test]
fn latencies_are_whole_milliseconds_set_once() {
    let e = one(&project(
        "",
        "  - { name: a, point: mm1.X1, debounce: 1500us }\n",
    ));
    assert!(matches!(offload_error(&e), OffloadError::BadLatency { .. }));
    assert!(e.kind.to_string().contains("1.50ms"), "{e}");

    let e = one(&project(
        "",
        "  - { name: a, point: mm1.X1, stretch: 66s }\n",
    ));
    assert!(matches!(offload_error(&e), OffloadError::BadLatency { .. }));

    // XLATUP1 in the module's settings too.
    let text = format!(
        "{HEAD}    model: minimod\n    address: 1\n    settings: {{ X1LATUP: 5 }}\ntags:\n  - {{ name: a, point: mm1.X1, debounce: 20ms }}\n"
    );
    let e = one(&text);
    assert_eq!(
        e.kind.to_string(),
        "tag a: debounce sets XLATUP1 of module mm1, which its settings also sets"
    );

    // Two tags on one input.
    let e = one(&project(
        "",
        "  - { name: a, point: mm1.X1, stretch: 200ms }\n  - { name: b, point: mm1.X1, debounce: 20ms }\n",
    ));
    assert_eq!(e.line, 17);
    assert_eq!(
        e.kind.to_string(),
        "tag b: debounce sets XLATDN1 of module mm1, which tag a also sets"
    );
}

/// A scratch folder with a project and its program.
fn scratch(name: &str, project: &str, program: &str) -> PathBuf {
    let dir = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join(format!("offload-{name}"));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("p.expr"), program).unwrap();
    let path = dir.join("project.yaml");
    std::fs::write(&path, project).unwrap();
    path
}

const CHECKED: &str = "\
project: t
scan: { period: 50ms }
offload: auto
buses: [ { name: line1, port: sim } ]
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
  - { name: mm2, bus: line1, model: minimod, address: 2 }
tags:
  - { name: a, point: mm1.X1 }
  - { name: b, point: mm2.X1 }
  - { name: lamp, point: mm1.Y1, offload: require }
  - { name: horn, point: mm1.Y2 }
program: { file: p.expr, kind: expr }
";

#[test]
fn check_fails_when_a_required_rung_stays_central() {
    let path = scratch(
        "require",
        CHECKED,
        "horn = a\n\n# Lamp: both boxes in\nlamp = a & b\n",
    );
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    let program = path.with_file_name("p.expr");
    assert_eq!(
        stderr.trim(),
        format!(
            "{}:4:1: error: offload: require: the rung writing lamp (\"Lamp: both boxes in\") \
             stays central: an input from another module: b is on mm2",
            program.display()
        )
    );
    // The report still shows every rung: horn is pushed down.
    assert!(
        stdout.contains("horn (combinational): module mm1 Y2"),
        "{stdout}"
    );
    assert!(stdout.contains("Y2AON1         = 0x0001 X1"), "{stdout}");

    // Pushable: check passes.
    let path = scratch("require-ok", CHECKED, "horn = a\nlamp = a\n");
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["check", path.to_str().unwrap()])
        .output()
        .unwrap();
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

/// `softplc check` on the push-down example, its line on `port` with `extra` bus keys.
fn check_pushdown(port: &str, extra: &str) -> String {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    let dir = std::env::temp_dir().join(format!(
        "softplc-offload-adapter-{}-{}",
        std::process::id(),
        extra.len()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let text = std::fs::read_to_string(root.join("examples/pushdown/project.yaml")).unwrap();
    let text = text.replace(
        "    port: sim ",
        &format!("    port: {port}\n{extra}    # was: sim "),
    );
    // Polled, pinned: with a 16 ms adapter Collect would be the cheaper default, and these
    // are the figures of polls.
    let text = text.replace("RDELAYT: 0 }", "RDELAYT: 0, events: false }");
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    for f in std::fs::read_dir(root.join("examples/pushdown")).unwrap() {
        let f = f.unwrap().path();
        if f.file_name().is_some_and(|n| n != "project.yaml") {
            std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
        }
    }
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["check", dir.join("project.yaml").to_str().unwrap()])
        .output()
        .unwrap();
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    String::from_utf8(out.stdout).unwrap()
}

#[test]
fn reaction_times_count_the_input_latency_and_the_adapters() {
    let line = |report: &str| {
        report
            .lines()
            .find(|l| l.trim_start().starts_with("reaction: module"))
            .map(str::trim)
            .map(str::to_owned)
            .unwrap_or_else(|| panic!("no reaction line in:\n{report}"))
    };
    let sim = check_pushdown("sim", "");
    let usb = check_pushdown("/dev/ttyUSB9", "    adapter_latency: 16ms\n");
    // The module's own watchdog waits for the slower line too, or it fires on a healthy one.
    assert!(sim.contains("module watchdog: WDTTIME 132 (1.32s ≥ 3 × period 0.10s + line floor 0.03s + start-up 0.28s"), "{sim}");
    assert!(usb.contains("module watchdog: WDTTIME 204 (2.04s ≥ 3 × period 0.10s + line floor 0.12s + start-up 0.90s"), "{usb}");
    assert_eq!(
        line(&sim),
        "reaction: module ≤ 21.00ms (input latency 20.00ms (X3 of mm1) + its tick 1.00ms) vs central ≤ 157.11ms (input latency 20.00ms (X3 of mm1) + period 100.00ms + inputs 22.69ms + write 14.42ms)"
    );
    // A USB adapter holding each reply 16 ms: 5 reads and 3 writes each wait that much more.
    assert_eq!(
        line(&usb),
        "reaction: module ≤ 21.00ms (input latency 20.00ms (X3 of mm1) + its tick 1.00ms) vs central ≤ 285.11ms (input latency 20.00ms (X3 of mm1) + period 100.00ms + inputs 102.69ms + write 62.42ms)"
    );
}

#[test]
fn the_report_names_a_rung_by_its_title_or_its_comment() {
    let path = scratch(
        "titled",
        &CHECKED.replace(", offload: require", ""),
        "# Horn follows a\nhorn = a\nlamp = a & b  # Lamp: both boxes in\n",
    );
    let ladder = "rungs:\n  - { rung: a -> horn, title: Horn follows a }\n  - a b -> lamp\n";
    std::fs::write(path.with_file_name("p.yaml"), ladder).unwrap();
    let ladder_project = path.with_file_name("ladder.yaml");
    let text = CHECKED
        .replace(", offload: require", "")
        .replace("file: p.expr, kind: expr", "file: p.yaml, kind: ladder");
    std::fs::write(&ladder_project, text).unwrap();
    for (project, program, horn, lamp) in [
        (
            &path,
            "p.expr",
            "2:1 \"Horn follows a\"",
            "3:1 \"Lamp: both boxes in\"",
        ),
        (&ladder_project, "p.yaml", "2:13 \"Horn follows a\"", "3:5"),
    ] {
        let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
            .args(["check", project.to_str().unwrap()])
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        assert!(out.status.success(), "{stdout}");
        let at = path.with_file_name(program).display().to_string();
        let horn = format!("  {at}:{horn} horn (combinational): module mm1 Y2,");
        let lamp = format!("  {at}:{lamp} lamp (combinational): central: ");
        for want in [horn, lamp] {
            assert!(
                stdout.lines().any(|l| l.starts_with(&want)),
                "{want}\n{stdout}"
            );
        }
    }
}
