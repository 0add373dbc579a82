//! `softplc check` refuses what `run` would fault on (the service's `ExecStartPre` relies on
//! it): Rhai calls of unknown functions, wrong arities and bad literal arguments in any branch,
//! undeclared names, values a tag's type cannot hold (Rhai, ladder, expr), and `offload:
//! require` on an output a Rhai script writes. Each case runs the binary on a project in its
//! own folder and asserts the exact error lines and the exit code; every example and program
//! of the repository still passes.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use crate::common::host::repo as root;
use crate::common::scratch::Scratch;
use softplc::clock::{Clock, VirtualClock};
use softplc::plc::Plc;

/// What `softplc ARGS` left: exit code, stdout, stderr.
fn softplc(args: &[&str]) -> (Option<i32>, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .env("SOFTPLC_LOG", "warn")
        .output()
        .expect("softplc runs");
    (
        out.status.code(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

/// A pump on one simulated MiniMod; `{program}` and `{kind}` are filled in.
const PROJECT: &str = "\
project: pumps
scan:
  period: 100ms
buses:
  - { name: line1, port: sim }
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
tags:
  - { name: x1, point: mm1.X1 }
  - { name: pump1, point: mm1.Y1 }
  - { name: y2, point: mm1.Y2 }
  - { name: demand, type: bool }
  - { name: n, type: i32 }
  - { name: level, type: u16 }
program: { file: {program}, kind: {kind} }
";

/// Writes `program` as `name` beside a project running it; the project's path.
fn project(scratch: &Scratch, name: &str, kind: &str, program: &str) -> PathBuf {
    scratch.write(name, program);
    let text = PROJECT.replace("{program}", name).replace("{kind}", kind);
    scratch.write("project.yaml", &text)
}

/// `check` on `program` fails with exactly `expected` (each `line:col: error: …`, after the
/// program's path) and prints no report.
fn check_fails(case: &str, name: &str, kind: &str, program: &str, expected: &[&str]) {
    let scratch = Scratch::new("check-catches", case);
    let path = project(&scratch, name, kind, program);
    let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
    assert_eq!(code, Some(1), "{case}: {stdout}{stderr}");
    let file = scratch.dir.join(name);
    let want: Vec<String> = expected
        .iter()
        .map(|e| format!("{}:{e}", file.display()))
        .collect();
    assert_eq!(stderr.lines().collect::<Vec<_>>(), want, "{case}");
    assert!(!stdout.contains("push-down"), "{case}: {stdout}");
}

#[test]
fn rhai_calls_in_every_branch_are_checked_by_name_arity_and_literal_arguments() {
    // Scan 101 would have faulted with `Function not found: tonn`.
    check_fails(
        "issue",
        "pump.rhai",
        "rhai",
        "n += 1;\nif n > 50 { y2 = tonn(\"t\", x1, \"1s\"); }\n",
        &["2:18: error: unknown function `tonn`; did you mean `ton(name, in, pt)`?"],
    );
    // The script of docs/programming.md, "What `check` catches".
    check_fails(
        "docs",
        "pump.rhai",
        "rhai",
        "n += 1;\n\
         if n > 50 { y2 = tonn(\"t\", x1, \"1s\"); }\n\
         pump1 = ton(\"t2\", x1);\n\
         y2 = tof(\"t3\", x1, \"1 sec\");\n\
         pump1 = 2;\n\
         demand = ton(\"t4\", level, \"1s\");\n\
         if level { n = 0; }\n",
        &[
            "2:18: error: unknown function `tonn`; did you mean `ton(name, in, pt)`?",
            "3:9: error: ton() takes 3 arguments: ton(name, in, pt); this call has 2",
            "4:20: error: bad duration \"1 sec\" for `pt` of tof(): unknown unit \"sec\" (ns, \
             us, ms, s, m or h); write e.g. \"500ms\", \"2s\" or a number of ms",
            "5:9: error: type error: `pump1` is bool, the value assigned is an integer; a bool \
             tag takes a condition, e.g. `x > 0`",
            "6:20: error: argument `in` of ton() is a bool, not an integer",
            "7:4: error: type error: a condition is a bool, not an integer; compare it, e.g. \
             `x > 0`",
        ],
    );
    // Inside a script function, which no scan may ever call.
    check_fails(
        "function",
        "pump.rhai",
        "rhai",
        "fn later(x) {\n    blink_pattern(\"b\", x, \"10x1\", 100)\n}\npump1 = x1;\n",
        &[
            "2:27: error: bad pattern \"10x1\" for blink_pattern(): a blink pattern is written \
             with 0 and 1 only",
        ],
    );
    check_fails(
        "undeclared",
        "pump.rhai",
        "rhai",
        "pump1 = levle > 2;\n",
        &["1:9: error: unknown tag or variable `levle`; did you mean `level`?"],
    );
}

#[test]
fn a_number_into_a_bool_is_a_type_error_in_every_language() {
    check_fails(
        "ladder",
        "pump.ladder.yaml",
        "ladder",
        "rungs:\n  - x1 -> MOVE(0.5) => demand\n  - x1 -> MOVE(0.5) => level\n",
        &[
            "2:24: error: type error: `demand` is bool and MOVE(…) computes a number; drive a \
             bool tag with a coil, e.g. `… -> demand`",
            "3:16: error: type error: `0.5` is not a u16 value (a whole number from 0 to \
             65535); `level` is u16",
        ],
    );
    check_fails(
        "expr",
        "pump.expr",
        "expr",
        "pump1 = level == 0.5\n",
        &[
            "1:18: error: type error: `0.5` is not a u16 value (a whole number from 0 to \
             65535); `level` is u16",
        ],
    );
}

#[test]
fn a_wrong_value_check_cannot_see_faults_naming_the_tag() {
    let scratch = Scratch::new("check-catches", "run");
    let path = project(&scratch, "pump.rhai", "rhai", "let v = 2;\npump1 = v;\n");
    let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
    assert_eq!(code, Some(0), "{stdout}{stderr}");
    let (_, stdout, stderr) = softplc(&[
        "run",
        path_str(&path),
        "--virtual",
        "--for",
        "1s",
        "--quiet",
        "--no-control",
    ]);
    let file = scratch.dir.join("pump.rhai");
    let fault = format!(
        "FAULT: program error: script error: tag `pump1` is bool, the script assigned it an \
         integer (2) at {}:2:1; outputs set to their safe values",
        file.display()
    );
    assert!(
        stdout.contains(&fault) || stderr.contains(&fault),
        "{stdout}{stderr}"
    );
}

#[test]
fn require_on_rhai_outputs_pushes_the_plain_forms_and_fails_the_others_with_the_reason() {
    let scratch = Scratch::new("check-catches", "require");
    let path = project(
        &scratch,
        "pump.rhai",
        "rhai",
        "n += 1;\ny2 = x1 && !demand;\nif n > 5 { pump1 = !x1; }\n",
    );
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("point: mm1.Y1 }", "point: mm1.Y1, offload: require }")
        .replace("point: mm1.Y2 }", "point: mm1.Y2, offload: require }");
    std::fs::write(&path, text).unwrap();
    let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
    let file = scratch.dir.join("pump.rhai");
    let reason = softplc::logic::rhai::NOT_PLAIN;
    let failure = format!(
        "{}:3:12: error: offload: require: the rung writing pump1 stays central: {reason}",
        file.display()
    );
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    // `demand` is a memory tag the module cannot read: y2 stays central too, with the reason.
    let memory = format!(
        "{}:2:1: error: offload: require: the rung writing y2 stays central: memory or a timer \
         in the condition: demand is a memory tag, which the module cannot see",
        file.display()
    );
    assert_eq!(
        stderr.lines().collect::<Vec<_>>(),
        [memory.as_str(), failure.as_str()]
    );
    assert!(
        stdout.contains(&format!(
            "{}:3:12 pump1 (other): central: {reason}",
            file.display()
        )),
        "{stdout}"
    );
    assert!(
        stdout.contains(&format!(
            "{}:2:1 y2 (combinational): central: ",
            file.display()
        )),
        "{stdout}"
    );

    // A plain condition of the module's inputs runs in the module; a project-wide `require`
    // is about the outputs, so the memory tag `n` does not fail it.
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace(", offload: require }", " }")
        .replace("program:", "offload: require\nprogram:");
    std::fs::write(&path, text).unwrap();
    scratch.write(
        "pump.rhai",
        "n += 1;\ny2 = x1 || y2;\nif n > 5 { pump1 = !x1; }\n",
    );
    let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
    assert_eq!(code, Some(1), "{stdout}{stderr}");
    assert!(
        stdout.contains(&format!(
            "{}:2:1 y2 (set/reset latch): module mm1 Y2",
            file.display()
        )),
        "{stdout}"
    );
    assert_eq!(stderr.lines().collect::<Vec<_>>(), [failure.as_str()]);
}

#[test]
fn check_says_whether_a_rhai_program_runs_on_the_logic_vm() {
    for (case, program, line) in [
        (
            "rhai-vm",
            "pump1 = ton(\"t\", (x1 || pump1) && !demand, \"2s\");\n",
            "  rhai: plain rungs, runs on the logic VM",
        ),
        (
            "rhai-interpreted",
            "pump1 = x1;\nif demand { n += 1; }\n",
            "  rhai: runs in the Rhai interpreter (line 2: `if`)",
        ),
    ] {
        let scratch = Scratch::new("check-catches", case);
        let path = project(&scratch, "pump.rhai", "rhai", program);
        let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
        assert_eq!(code, Some(0), "{case}: {stdout}{stderr}");
        let lines: Vec<&str> = stdout.lines().collect();
        let at = lines
            .iter()
            .position(|l| l.starts_with("program "))
            .expect("the program line");
        assert_eq!(lines.get(at + 1).copied(), Some(line), "{case}: {stdout}");
    }
}

#[test]
fn every_example_and_program_passes_check() {
    let mut checked = 0;
    for entry in std::fs::read_dir(root().join("examples")).expect("examples/") {
        let project = entry.expect("an entry").path().join("project.yaml");
        if !project.exists() {
            continue;
        }
        let (code, stdout, stderr) = softplc(&["check", path_str(&project)]);
        assert_eq!(code, Some(0), "{}: {stdout}{stderr}", project.display());
        checked += 1;
        // The same project with each other program of its folder under programs/ (the ladder
        // and the Rhai version of one machine).
        let text = std::fs::read_to_string(&project).expect("the project");
        let Some(line) = text
            .lines()
            .find(|l| l.trim_start().starts_with("file: ../../programs/"))
        else {
            continue;
        };
        let file = line.trim_start().trim_start_matches("file: ");
        let program = project.parent().unwrap().join(file);
        let folder = program.parent().unwrap().to_path_buf();
        for sibling in std::fs::read_dir(&folder).expect("the program folder") {
            let sibling = sibling.expect("an entry").path();
            let name = sibling.file_name().unwrap().to_str().unwrap().to_string();
            let kind = if name.ends_with(".rhai") {
                "rhai"
            } else if name.ends_with(".ladder.yaml") {
                "ladder"
            } else {
                continue;
            };
            let scratch = Scratch::new("check-catches", &format!("example-{name}"));
            let kind_line = text
                .lines()
                .find(|l| l.trim_start().starts_with("kind: "))
                .expect("a program kind");
            let copy = text
                .replace(line, &format!("  file: {}", sibling.display()))
                .replace(kind_line, &format!("  kind: {kind}"));
            // A plant model file beside the project stays the project's.
            let copy = copy
                .lines()
                .map(|l| match l.trim_start().strip_prefix("file: ") {
                    Some(f) if f.ends_with(".plant.rhai") => {
                        let model = project.parent().unwrap().join(f);
                        format!("  file: {}", model.display())
                    }
                    _ => l.to_owned(),
                })
                .collect::<Vec<_>>()
                .join("\n");
            let path = scratch.write("project.yaml", &copy);
            let (code, stdout, stderr) = softplc(&["check", path_str(&path)]);
            assert_eq!(code, Some(0), "{}: {stdout}{stderr}", sibling.display());
            checked += 1;
        }
    }
    assert!(checked >= 16, "{checked} checked");
}

#[test]
fn a_reload_with_a_type_error_is_refused_and_the_running_program_kept() {
    let scratch = Scratch::new("check-catches", "reload");
    let path = project(&scratch, "pump.rhai", "rhai", "pump1 = x1;\n");
    let project = softplc::project::load(&path).expect("the project loads");
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let mut plc = Plc::build(project, clock).expect("the PLC builds");
    let program = scratch.write("pump.rhai", "pump1 = 2;\n");
    let refused = plc.reload_program().expect_err("the reload is refused");
    assert_eq!(
        refused.to_string(),
        format!(
            "reload refused:\n{}:1:9: error: type error: `pump1` is bool, the value assigned is \
             an integer; a bool tag takes a condition, e.g. `x > 0`",
            program.display()
        )
    );
    scratch.write("pump.rhai", "pump1 = !x1;\n");
    plc.reload_program().expect("a mended program reloads");
}

#[test]
fn a_module_whose_reply_delay_outlasts_the_response_timeout_is_a_warning() {
    // RDELAYM=200 on mm1: it waits 20 ms more for a request's end, so it turns round 10 ms
    // (RDELAYT, factory) + 20 ms after each request; the line waits 25 ms for a first byte.
    let scratch = Scratch::new("check-catches", "turnaround");
    scratch.write("p.expr", "pump1 = x1\n");
    let text = PROJECT
        .replace("{program}", "p.expr")
        .replace("{kind}", "expr")
        .replace("port: sim }", "port: sim, response_timeout: 25ms }");
    let late = text.replace("address: 1 }", "address: 1, settings: { RDELAYM: 200 } }");
    let (code, out, err) = softplc(&["check", path_str(&scratch.write("late.yaml", &late))]);
    assert_eq!(code, Some(0), "a warning, not an error: {out}{err}");
    assert!(
        out.contains(
            "warning: module mm1: its reply delay 30.00ms puts its reply's first byte at \
             30.57ms or later, not within the response timeout 25.00ms of bus line1: none of \
             its replies would be heard"
        ),
        "{out}"
    );
    // Without RDELAYM its reply comes at 10.57 ms: nothing to say.
    let (_, out, _) = softplc(&["check", path_str(&scratch.write("ok.yaml", &text))]);
    assert!(!out.contains("none of its replies"), "{out}");
}
