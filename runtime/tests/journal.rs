//! Logging under systemd: with `$JOURNAL_STREAM` naming its stderr, `softplc run` sends its
//! events to the journal's native socket with PROJECT, BUS and MODULE fields; with no journal
//! to reach it logs to stderr and says so once.
//!
//! `tracing-journald` sends to the fixed path `/run/systemd/journal/socket`, so the binary
//! runs in a mount namespace of its own (`unshare -Urm`) where `/run` is a scratch directory
//! holding this test's socket. Where user namespaces are refused, the test says so and passes.

use std::collections::HashMap;
use std::os::unix::fs::MetadataExt;
use std::os::unix::net::UnixDatagram;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use crate::common::sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

fn scratch(name: &str) -> PathBuf {
    crate::common::host::scratch_dir("journal", name)
}

fn namespaces_allowed() -> bool {
    let ok = Command::new("unshare")
        .args(["-Urm", "true"])
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    if !ok {
        eprintln!("skipped: `unshare -Urm` is refused here (no user namespaces)");
    }
    ok
}

/// A project whose module mm2 (address 2) is absent: the simulator serves only address 1.
fn project(dir: &Path, pty: &str) -> PathBuf {
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    let text = format!(
        "project: press\n\
         scan: {{ period: 100ms }}\n\
         buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 0 }}\n\
         modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2 }}\n\
         tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm1.Y1, safe: false }}\n\
         program: {{ file: follow.expr, kind: expr }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// Runs `softplc run` with `run_dir` as its `/run` and stderr a file that `$JOURNAL_STREAM`
/// names; returns what it wrote to stderr.
fn run_under_journal(dir: &Path, run_dir: &Path, project: &Path) -> String {
    let stderr_path = dir.join("stderr.log");
    let stderr = std::fs::File::create(&stderr_path).unwrap();
    let meta = stderr.metadata().unwrap();
    let status = Command::new("unshare")
        .args([
            "-Urm",
            "sh",
            "-c",
            "mount --bind \"$0\" /run && exec \"$@\"",
        ])
        .arg(run_dir)
        .args([BIN, "run", "--quiet", "--no-socket", "--for", "2s"])
        .arg(project)
        .env("JOURNAL_STREAM", format!("{}:{}", meta.dev(), meta.ino()))
        .env("SOFTPLC_LOG", "info")
        .stdout(Stdio::null())
        .stderr(stderr)
        .status()
        .unwrap();
    let text = std::fs::read_to_string(&stderr_path).unwrap();
    assert!(status.success(), "softplc run failed: {status}\n{text}");
    text
}

/// One journal entry in the native protocol: `KEY=value\n`, or `KEY\n` + u64 LE length +
/// bytes + `\n`; a field may repeat.
fn parse_entry(mut data: &[u8]) -> HashMap<String, Vec<String>> {
    let mut fields: HashMap<String, Vec<String>> = HashMap::new();
    while !data.is_empty() {
        let nl = data.iter().position(|&b| b == b'\n').expect("a field ends");
        let line = &data[..nl];
        let (key, value, rest) = match line.iter().position(|&b| b == b'=') {
            Some(eq) => (&line[..eq], &line[eq + 1..], &data[nl + 1..]),
            None => {
                let after = &data[nl + 1..];
                let len = u64::from_le_bytes(after[..8].try_into().unwrap()) as usize;
                (line, &after[8..8 + len], &after[8 + len + 1..])
            }
        };
        fields
            .entry(String::from_utf8_lossy(key).into_owned())
            .or_default()
            .push(String::from_utf8_lossy(value).into_owned());
        data = rest;
    }
    fields
}

fn one(entry: &HashMap<String, Vec<String>>, key: &str) -> Option<String> {
    entry.get(key).and_then(|v| v.first().cloned())
}

#[test]
fn under_systemd_events_go_to_the_journal_with_project_bus_and_module() {
    if !namespaces_allowed() {
        return;
    }
    let dir = scratch("native");
    let run_dir = dir.join("run");
    std::fs::create_dir_all(run_dir.join("systemd/journal")).unwrap();
    let journal = UnixDatagram::bind(run_dir.join("systemd/journal/socket")).unwrap();
    journal
        .set_read_timeout(Some(Duration::from_millis(300)))
        .unwrap();
    let (_sim, pty) = sim::Sim::start(BIN, &["minimod@1"]);
    let project = project(&dir, &pty);

    let stderr = run_under_journal(&dir, &run_dir, &project);

    let mut entries = Vec::new();
    let mut buf = vec![0u8; 1 << 16];
    while let Ok(n) = journal.recv(&mut buf) {
        if n > 0 {
            entries.push(parse_entry(&buf[..n]));
        }
    }
    let messages: Vec<String> = entries.iter().filter_map(|e| one(e, "MESSAGE")).collect();
    let absent = entries
        .iter()
        .find(|e| one(e, "MESSAGE").is_some_and(|m| m.contains("module mm2 did not answer")))
        .unwrap_or_else(|| panic!("no entry for the absent module; entries: {messages:#?}"));
    assert_eq!(one(absent, "PROJECT").as_deref(), Some("press"));
    assert_eq!(one(absent, "BUS").as_deref(), Some("line1"));
    assert_eq!(one(absent, "MODULE").as_deref(), Some("mm2"));
    assert_eq!(one(absent, "PRIORITY").as_deref(), Some("4"), "a warning");
    assert_eq!(one(absent, "SYSLOG_IDENTIFIER").as_deref(), Some("softplc"));
    let scanning = entries
        .iter()
        .find(|e| one(e, "MESSAGE").is_some_and(|m| m.contains("scanning every")))
        .unwrap_or_else(|| panic!("no start entry; entries: {messages:#?}"));
    assert_eq!(one(scanning, "PROJECT").as_deref(), Some("press"));
    assert_eq!(one(scanning, "MODULE"), None);
    // Nothing logged twice: the events went to the journal, not to stderr.
    assert!(
        !stderr.contains("did not answer") && !stderr.contains("scanning every"),
        "stderr: {stderr}"
    );
}

#[test]
fn a_journal_that_cannot_be_reached_leaves_the_log_on_stderr_with_one_line_saying_so() {
    if !namespaces_allowed() {
        return;
    }
    let dir = scratch("fallback");
    let run_dir = dir.join("run");
    std::fs::create_dir_all(&run_dir).unwrap();
    let (_sim, pty) = sim::Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let project = project(&dir, &pty);

    let stderr = run_under_journal(&dir, &run_dir, &project);

    assert_eq!(
        stderr.matches("the journal cannot be reached").count(),
        1,
        "stderr: {stderr}"
    );
    assert!(stderr.contains("press: scanning every"), "stderr: {stderr}");
    assert!(
        !stderr.contains('\x1b'),
        "no colour codes in a file: {stderr}"
    );
}
