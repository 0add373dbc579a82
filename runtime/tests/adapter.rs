//! The serial line's adapter, end to end on ptys: `echo: discard` against `softplc sim --echo`
//! (an adapter that hears its own transmission), the echo named when the project does not say
//! so, a corrupted echo, and what `check` says of a pty's adapter latency.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::time::Duration;

use crate::common::sim;

use sim::Sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");

/// The follow-the-button project on `port`, `bus_extra` added to its bus (`fixtures/adapter`).
fn project(port: &str, bus_extra: &str) -> String {
    include_str!("fixtures/adapter/project.yaml")
        .replace("{port}", port)
        .replace("{bus_extra}", bus_extra)
}

/// A tempdir with [`project`] in it.
struct Project(PathBuf);

impl Project {
    fn new(tag: &str, port: &str, bus_extra: &str) -> Self {
        let dir =
            std::env::temp_dir().join(format!("softplc-adapter-{tag}-{}", std::process::id()));
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&dir));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
        std::fs::write(dir.join("project.yaml"), project(port, bus_extra)).unwrap();
        Self(dir)
    }

    fn path(&self) -> PathBuf {
        self.0.join("project.yaml")
    }

    fn run(&self, run_for: &str) -> std::process::Child {
        Command::new(BIN)
            .args(["run", "--no-control", "--for", run_for])
            .arg(self.path())
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::piped())
            .spawn()
            .unwrap()
    }

    fn check(&self) -> Output {
        Command::new(BIN)
            .arg("check")
            .arg(self.path())
            .output()
            .unwrap()
    }
}

impl Drop for Project {
    fn drop(&mut self) {
        // Best effort: the test's scratch folder (it may not exist).
        drop(std::fs::remove_dir_all(&self.0));
    }
}

fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn echo_discard_runs_against_an_adapter_that_echoes() {
    let (mut sim, pty) = Sim::start(BIN, &["--echo", "minimod@1"]);
    let project = Project::new("discard", &pty, ", echo: discard");
    let run = project.run("6s");
    // The program follows the button through the echoing line, both ways.
    sim.send("set minimod@1.X1 1");
    let on = sim.wait_for("minimod@1.Y1", "1", Duration::from_secs(5));
    sim.send("set minimod@1.X1 0");
    let off = sim.wait_for("minimod@1.Y1", "0", Duration::from_secs(5));
    let out = run.wait_with_output().unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        on.is_some() && off.is_some(),
        "lamp did not follow:\n{stdout}\n{stderr}"
    );
    assert!(out.status.success(), "{stdout}\n{stderr}");
    assert!(
        stdout.contains("module mm1 (line1): good  requests ")
            && stdout.contains(" timeouts 0 crc 0 bad replies 0 exceptions 0 "),
        "{stdout}\n{stderr}"
    );
    assert!(!stderr.contains("echo"), "{stderr}");
}

#[test]
fn an_echoing_adapter_without_echo_discard_is_named_with_the_fix() {
    let (_sim, pty) = Sim::start(BIN, &["--echo", "minimod@1"]);
    let project = Project::new("none", &pty, "");
    let out = project.run("1s").wait_with_output().unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        stderr.contains(
            "line line1: module mm1 did not answer at start-up (line error: the reply began with \
             the request's own bytes: the adapter hears its own transmission (set echo: discard \
             on this bus))"
        ),
        "{stderr}"
    );
    assert!(stdout.contains("module mm1 (line1): bad"), "{stdout}");
}

#[test]
fn a_corrupted_echo_is_a_line_error_and_the_line_recovers() {
    let (mut sim, pty) = Sim::start(BIN, &["--echo", "minimod@1"]);
    // No retry: the start-up's first exchange fails on its echo, the module is probed again.
    let project = Project::new("corrupt", &pty, ", echo: discard, retries: 0");
    sim.send("echo corrupt 1");
    // The command is answered once taken; a `get` after it is answered after it.
    assert_eq!(sim.get("minimod@1.Y1"), "minimod@1.Y1=0");
    // The start-up is retried every second; a loaded machine may time one more out (a pty's
    // simulator starved of CPU), so the run leaves room for several retries.
    let out = project.run("6s").wait_with_output().unwrap();
    let (stdout, stderr) = text(&out);
    assert!(
        stderr.contains(
            "module mm1 did not answer at start-up (line error: echo differs from the request at \
             byte 4 (a collision or noise on the line))"
        ),
        "{stderr}"
    );
    assert!(
        stderr.contains("line line1: module mm1 is back after"),
        "{stderr}"
    );
    assert!(stdout.contains("module mm1 (line1): good"), "{stdout}");
}

#[test]
fn check_says_a_pty_has_no_adapter_latency() {
    let (_master, _slave, pty) = softplc_io::line::pty_pair().unwrap();
    let project = Project::new("check", &pty, ", echo: discard");
    let out = project.check();
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}{stderr}");
    assert!(
        stdout.contains("\n  adapter latency: none: pty\n"),
        "{stdout}"
    );
    assert!(
        stdout.contains(
            "\n  echo: discard (every request is read back and verified; it comes back while it \
             is sent, so the budget counts nothing for it)\n"
        ),
        "{stdout}"
    );
    assert!(
        stdout.contains("\n  budget: inputs 20.60ms (1 transactions), full output write"),
        "{stdout}"
    );
}

#[test]
fn bad_echo_and_adapter_latency_are_refused_with_their_place() {
    let project = Project::new(
        "bad",
        "/dev/ttyUSB0",
        ", echo: maybe, adapter_latency: 300ms",
    );
    let sim = Project::new("badsim", "sim", ", adapter_latency: 2ms");
    let out = project.check();
    let (stdout, stderr) = text(&out);
    assert!(!out.status.success(), "{stdout}");
    let at = |p: &Path, line_col: &str| format!("{}:{line_col}", p.display());
    assert!(
        stderr.contains(&format!(
            "{}: error: echo must be none (the adapter does not hear itself) or discard",
            at(&project.path(), "4:46")
        )),
        "{stderr}"
    );
    assert!(
        stderr.contains(&format!(
            "{}: error: adapter_latency must be auto or whole milliseconds from 0ms to 255ms",
            at(&project.path(), "4:70")
        )),
        "{stderr}"
    );
    let out = sim.check();
    let (_, stderr) = text(&out);
    assert!(!out.status.success());
    assert!(
        stderr.contains(&format!(
            "{}: error: adapter_latency is for a device port (a USB adapter), not port: sim",
            at(&sim.path(), "4:48")
        )),
        "{stderr}"
    );
}
