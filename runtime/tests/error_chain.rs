//! Each cause once, in one chain, from every command family: an error names what failed, then
//! why, and a cause that an outer error already says is not said again (`cli/error_line.rs`).
//! The commands fail at once here (no instance, no port, a program that does not compile),
//! so each runs the binary to its end.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::Arc;

use crate::common::host::repo as root;
use softplc_io::line::{pty_pair, LineSettings, SerialTransport};
use softplc_io::time::{Clock, MonotonicClock};

/// Runs `softplc args`, which must fail; what it printed (standard output, then error).
fn printed(args: &[&str]) -> String {
    let Output {
        status,
        stdout,
        stderr,
    } = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .output()
        .expect("the binary runs");
    let text = String::from_utf8_lossy(&stdout).into_owned() + &*String::from_utf8_lossy(&stderr);
    assert!(!status.success(), "softplc {args:?} failed: {text}");
    text
}

/// `text` holds `cause` exactly once.
fn once(text: &str, cause: &str) {
    assert_eq!(text.matches(cause).count(), 1, "{cause:?} once in:\n{text}");
}

/// A copy of the quick start in a folder of its own, its program `program` (Rhai) and its bus
/// on `port`.
fn project(name: &str, program: &str, port: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-chain-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    let quickstart = std::fs::read_to_string(root().join("examples/quickstart/project.yaml"))
        .expect("the quick start");
    let mut text = String::new();
    for line in quickstart.lines() {
        // Keep the project, its lines and tags; the program and port are this test's.
        if line.starts_with("program:") || line.starts_with("plant:") {
            break;
        }
        text += &line.replace("port: sim ", &format!("port: {port} "));
        text.push('\n');
    }
    text += "program: { file: clock.rhai, kind: rhai }\n";
    std::fs::write(dir.join("clock.rhai"), program).expect("the program");
    let file = dir.join("project.yaml");
    std::fs::write(&file, text).expect("the project");
    file
}

const UNKNOWN_FUNCTION: &str = "unknown function `timestamp`";

#[test]
fn run_and_check_say_a_program_error_once() {
    let file = project("program", "let t = timestamp();\nmotor = start;\n", "sim");
    let file = file.to_str().expect("a UTF-8 path");
    let run = printed(&["run", file, "--virtual", "--for", "1s"]);
    once(&run, UNKNOWN_FUNCTION);
    assert!(run.contains("cannot start the PLC: "), "{run}");
    once(&run, "clock.rhai:1:9");
    once(&printed(&["check", file]), UNKNOWN_FUNCTION);
}

#[test]
fn run_says_a_locked_port_once_and_runs_with_the_line_lost() {
    let (_master, _slave, path) = pty_pair().expect("a pty pair");
    // Another program holds the port, as `softplc run` holds its own.
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let _held = SerialTransport::open(Path::new(&path), LineSettings::DEFAULT, clock)
        .expect("the first opener gets the port");
    let file = project("locked", "motor = start;\n", &path);
    // A port that cannot be opened at start is a lost line (it may be freed, or appear):
    // the PLC runs with the line's modules lost, and says why once.
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["run", file.to_str().expect("a UTF-8 path"), "--for", "1s"])
        .output()
        .expect("the binary runs");
    let run =
        String::from_utf8_lossy(&out.stdout).into_owned() + &*String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{run}");
    assert!(
        run.contains(&format!("line line1: cannot open {path}")),
        "{run}"
    );
    once(&run, "exclusive lock");
    assert!(run.contains("stopped after its run time"), "{run}");
}

#[test]
fn the_serial_tools_say_a_missing_port_once() {
    let missing = "/dev/softplc-no-such-port";
    for args in [
        vec!["sim", "--port", missing, "minimod@1"],
        vec!["monitor", missing],
        vec!["discover", "--bauds", "19200", missing],
    ] {
        let stderr = printed(&args);
        once(&stderr, "No such file or directory");
        once(&stderr, &format!("cannot open {missing}"));
    }
}

#[test]
fn the_control_commands_say_a_missing_instance_once() {
    let socket = std::env::temp_dir().join(format!("softplc-chain-{}.sock", std::process::id()));
    let socket = socket.to_str().expect("a UTF-8 path");
    for command in [
        vec!["status", "--socket", socket],
        vec!["force", "--socket", socket, "motor", "1"],
        vec!["trace", "status", "--socket", socket],
    ] {
        let stderr = printed(&command);
        once(&stderr, "No such file or directory");
    }
}

#[test]
fn test_says_a_scenarios_program_error_once() {
    let file = project("scenario", "let t = timestamp();\nmotor = start;\n", "sim");
    let dir = file.parent().expect("the project's folder");
    let scenario = dir.join("start.scenario.yaml");
    std::fs::write(
        &scenario,
        "name: start runs the motor\nproject: project.yaml\nsteps:\n  - { at: 0s, set: { start: 1 } }\n  - { at: 1s, expect: { motor: 1 } }\n",
    )
    .expect("the scenario");
    let test = printed(&["test", scenario.to_str().expect("a UTF-8 path")]);
    once(&test, UNKNOWN_FUNCTION);
}

const GOOD: &str = "motor = start;\n";
const BAD: &str = "let t = timestamp();\nmotor = start;\n";

#[test]
fn replay_says_a_program_error_once() {
    let file = project("replay", GOOD, "sim");
    let project_file = file.to_str().expect("a UTF-8 path");
    let (recorded, text) = crate::common::host::softplc(&[
        "run",
        project_file,
        "--virtual",
        "--for",
        "1s",
        "--record",
        "1m",
    ]);
    assert!(recorded, "{text}");
    let record = file.with_extension("yaml.record");
    assert!(record.exists(), "{text}");
    // The program changed since the record was made, and no longer compiles.
    std::fs::write(file.with_file_name("clock.rhai"), BAD).expect("the program");
    let replay = printed(&[
        "replay",
        record.to_str().expect("a UTF-8 path"),
        project_file,
    ]);
    once(&replay, UNKNOWN_FUNCTION);
    once(&replay, "clock.rhai:1:9");
    assert!(replay.contains("cannot be replayed with"), "{replay}");
}

#[test]
fn a_running_instances_reload_and_a_second_run_on_its_socket_say_their_cause_once() {
    let file = project("reload", GOOD, "sim");
    let socket = file.with_file_name("ctl.sock");
    let _running = crate::common::host::run_virtual(&file, &socket);
    let socket = socket.to_str().expect("a UTF-8 path");
    std::fs::write(file.with_file_name("clock.rhai"), BAD).expect("the program");
    let reload = printed(&["reload", "--socket", socket]);
    once(&reload, UNKNOWN_FUNCTION);
    once(&reload, "refused");
    // A second instance on the same socket: the socket named once, its cause once.
    std::fs::write(file.with_file_name("clock.rhai"), GOOD).expect("the program");
    let second = printed(&[
        "run",
        file.to_str().expect("a UTF-8 path"),
        "--virtual",
        "--for",
        "1s",
        "--socket",
        socket,
    ]);
    once(&second, socket);
    once(&second, "another instance is running");
}
