//! Retained tags survive a `kill -9` between two scans; a corrupt file is reported and the
//! initial values used; the project file refuses retain settings it cannot honour.

use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use softplc::project::{parse_str, ErrorKind};

/// A project counting scans into a retained tag, in its own folder.
/// The project is named after its folder: a running instance is found by its name.
fn project(dir: &Path, kind: &str) -> PathBuf {
    std::fs::create_dir_all(dir).unwrap();
    let (file, program) = match kind {
        "rhai" => ("count.rhai", "count += 1;\n"),
        _ => ("count.yaml", "rungs:\n  - -> ADD(count, 1) => count\n"),
    };
    std::fs::write(dir.join(file), program).unwrap();
    let text = format!(
        "project: {name}\nscan:\n  period: 50ms\nbuses:\n  - {{ name: line1, port: sim }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n\
         tags:\n  - {{ name: lamp, point: mm1.Y1 }}\n  - {{ name: count, type: i32, retain: true }}\n\
         program: {{ file: {file}, kind: {kind} }}\nretain: {{ file: state/count.json, period: 100ms }}\n",
        name = dir.file_name().unwrap().to_string_lossy().replace('-', "_"),
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

fn temp(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("softplc-retain-it-{}-{name}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&d));
    d
}

/// The saved count, if the file exists; panics on a torn file.
fn saved(file: &Path) -> Option<i64> {
    let text = std::fs::read_to_string(file).ok()?;
    let doc: serde_json::Value = serde_json::from_str(&text)
        .unwrap_or_else(|e| panic!("the retain file is always whole: {e}: {text:?}"));
    doc["values"]["count"].as_i64()
}

fn softplc(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_softplc"));
    c.args(args).env("SOFTPLC_LOG", "info");
    c
}

fn kill_nine_then_restart(kind: &str) {
    let dir = temp(kind);
    let project = project(&dir, kind);
    let file = dir.join("state/count.json");
    let mut child = softplc(&["run", project.to_str().unwrap(), "--quiet", "--no-socket"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let start = Instant::now();
    let mut before_kill = 0;
    while start.elapsed() < Duration::from_secs(20) {
        // Every read in the middle of the saves finds a whole file.
        if let Some(v) = saved(&file) {
            before_kill = v;
            if v >= 20 {
                break;
            }
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.kill().unwrap(); // SIGKILL: no shutdown, no final save
    child.wait().unwrap();
    assert!(
        before_kill >= 20,
        "the count was saved while running: {before_kill}"
    );
    let at_kill = saved(&file).unwrap();
    assert!(at_kill >= before_kill);

    let out = softplc(&[
        "run",
        project.to_str().unwrap(),
        "--quiet",
        "--no-socket",
        "--for",
        "1s",
    ])
    .output()
    .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("retain: 1 value(s) restored"), "{log}");
    let after = saved(&file).unwrap();
    // Restored, then about 20 more scans (never back to ~20 from zero).
    assert!(
        after >= at_kill + 10 && after <= at_kill + 40,
        "{at_kill} → {after}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn ladder_counts_survive_kill_9() {
    kill_nine_then_restart("ladder");
}

#[test]
fn rhai_counts_survive_kill_9() {
    kill_nine_then_restart("rhai");
}

#[test]
fn a_corrupt_file_is_reported_kept_aside_and_the_defaults_used() {
    let dir = temp("corrupt");
    let project = project(&dir, "ladder");
    let file = dir.join("state/count.json");
    std::fs::create_dir_all(file.parent().unwrap()).unwrap();
    std::fs::write(&file, b"{\"softplc_retain\": 1, \"values\": {\"count\": 12").unwrap();
    let out = softplc(&[
        "run",
        project.to_str().unwrap(),
        "--quiet",
        "--no-socket",
        "--virtual",
        "--for",
        "1s",
    ])
    .output()
    .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{log}");
    assert!(log.contains("is unreadable"), "{log}");
    assert!(dir.join("state/count.json.corrupt").exists());
    // Started from 0: 20 scans of 50 ms.
    assert_eq!(saved(&file), Some(20), "{log}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn project_errors_for_retain_settings() {
    let dir = temp("errors");
    let project_path = project(&dir, "ladder");
    let good = std::fs::read_to_string(&project_path).unwrap();
    let p = parse_str(&good, &project_path).unwrap();
    assert!(p.tags[1].retain && !p.tags[0].retain);
    assert_eq!(p.retain.file, dir.join("state/count.json"));
    assert_eq!(p.retain.period, Duration::from_millis(100));

    let bad = good
        .replace(
            "{ name: lamp, point: mm1.Y1 }",
            "{ name: lamp, point: mm1.Y1, retain: true }",
        )
        .replace("period: 100ms", "period: 0s")
        .replace("file: state/count.json", "file: \"\"");
    let errors = parse_str(&bad, &project_path).unwrap_err().errors;
    let shown: Vec<String> = errors
        .iter()
        .map(|e| format!("{}:{}: {}", e.line, e.column, e.kind))
        .collect();
    assert_eq!(errors.len(), 3, "{shown:#?}");
    assert!(
        matches!(errors[0].kind, ErrorKind::RetainOnPoint { .. }),
        "{shown:#?}"
    );
    assert_eq!((errors[0].line, errors[0].column), (9, 42), "{shown:#?}");
    assert!(
        matches!(errors[1].kind, ErrorKind::EmptyRetainFile),
        "{shown:#?}"
    );
    assert!(
        matches!(
            errors[2].kind,
            ErrorKind::ZeroDuration {
                key: "retain.period"
            }
        ),
        "{shown:#?}"
    );

    let default_file = good.replace("retain: { file: state/count.json, period: 100ms }\n", "");
    let p = parse_str(&default_file, &project_path).unwrap();
    assert_eq!(p.retain.file, dir.join("project.retain.json"));
    assert_eq!(p.retain.period, Duration::from_secs(10));
    let unknown = good.replace("period: 100ms", "period: 100ms, every: 1s");
    assert!(parse_str(&unknown, &project_path).is_err());
    let kind = good.replace("kind: ladder", "kind: ladr");
    let e = parse_str(&kind, &project_path).unwrap_err().errors;
    assert!(e[0].to_string().contains("ladder"), "{}", e[0]);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn under_systemd_retained_values_go_to_the_state_directory() {
    // The unit's dynamic user cannot write beside the project in /etc/softplc/NAME/: with
    // `StateDirectory=` systemd sets $STATE_DIRECTORY, and the default retain file goes there.
    let dir = temp("state-directory");
    let project = project(&dir, "ladder");
    let text = std::fs::read_to_string(&project).unwrap();
    let text = text.replace("retain: { file: state/count.json, period: 100ms }\n", "");
    std::fs::write(&project, text).unwrap();
    let state = dir.join("var-lib-softplc");
    let out = softplc(&[
        "run",
        project.to_str().unwrap(),
        "--virtual",
        "--for",
        "2s",
        "--quiet",
        "--no-socket",
    ])
    .env("STATE_DIRECTORY", &state)
    .output()
    .unwrap();
    assert!(out.status.success(), "{out:?}");
    let instance = dir.file_name().unwrap();
    let file = state.join(instance).join("project.retain.json");
    assert!(
        saved(&file).is_some_and(|n| n > 0),
        "{} holds the count; beside the project: {:?}",
        file.display(),
        std::fs::read_dir(&dir)
            .unwrap()
            .flatten()
            .map(|e| e.file_name())
            .collect::<Vec<_>>()
    );
    assert!(
        !dir.join("project.retain.json").exists(),
        "nothing beside the project"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn saves_that_fail_every_100_ms_log_a_few_lines_and_a_count_and_status_says_so() {
    let dir = temp("flood");
    let project = project(&dir, "rhai");
    // The retain folder is a file: every save fails (as on a full disk), every 100 ms.
    std::fs::write(dir.join("state"), "in the way").unwrap();
    let socket = dir.join("ctl.sock");
    let log = dir.join("log");
    let mut child = softplc(&["run", project.to_str().unwrap(), "--for", "14s", "--socket"])
        .arg(&socket)
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let status = |socket: &Path| crate::common::host::service_state(socket, "retain");
    std::thread::sleep(Duration::from_secs(3));
    let failing = status(&socket);
    assert_eq!(failing["state"], "degraded", "{failing}");
    assert!(
        failing["reason"]
            .as_str()
            .unwrap()
            .starts_with("cannot save: "),
        "{failing}"
    );
    // Room again: the saves go through, and say so.
    std::fs::remove_file(dir.join("state")).unwrap();
    std::fs::create_dir_all(dir.join("state")).unwrap();
    let begin = Instant::now();
    while status(&socket)["state"] != "running" {
        assert!(
            begin.elapsed() < Duration::from_secs(5),
            "retain never recovered"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    assert!(child.wait().unwrap().success());
    let text = std::fs::read_to_string(&log).unwrap();
    let lines = text
        .lines()
        .filter(|l| l.contains("retain: cannot save"))
        .count();
    // About 30 failed saves in 3 s: 5 written, the rest counted in one summary.
    assert_eq!(lines, 5, "{text}");
    let summary = text
        .lines()
        .find(|l| l.contains("retain: failed saves: … "))
        .unwrap_or_else(|| panic!("no summary:\n{text}"));
    let held_back = crate::common::host::held_back(summary);
    assert!((10..40).contains(&held_back), "{summary}");
    assert!(text.contains("retain: saving to "), "{text}");
    assert!(saved(&dir.join("state/count.json")).is_some_and(|n| n > 0));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
