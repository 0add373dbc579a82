//! What the end-to-end tests that run servers and third-party clients share: the workspace's
//! folder, a free loopback port, a child's output as lines.

use std::io::{BufRead, BufReader};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{channel, Receiver};

/// The workspace's root folder.
pub(crate) fn repo() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

/// Runs the `softplc` binary with `args` from the workspace's folder (log level warn) and
/// returns whether it succeeded and what it printed (standard output, then standard error).
pub(crate) fn softplc(args: &[&str]) -> (bool, String) {
    softplc_in(&repo(), args)
}

/// [`softplc`] from folder `dir`.
pub(crate) fn softplc_in(dir: &Path, args: &[&str]) -> (bool, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .current_dir(dir)
        .env("SOFTPLC_LOG", "warn")
        .output()
        .expect("softplc runs");
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    (out.status.success(), text)
}

/// `softplc check PROJECT` run in `dir` (warnings only in the log): whether it passed, its
/// standard output and its standard error, apart.
pub(crate) fn check_in(dir: &Path, project: &Path) -> (bool, String, String) {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("check")
        .arg(project)
        .current_dir(dir)
        .env("SOFTPLC_LOG", "warn")
        .output()
        .expect("softplc runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// A folder of its own for test `name` of `subject`, empty (removed first if an earlier run
/// left it), named after the process so that runs side by side never share one.
pub(crate) fn scratch_dir(subject: &str, name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-{subject}-{name}-{}", std::process::id()));
    // Best effort: a folder left by an earlier run (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).expect("a scratch folder");
    dir
}

/// [`scratch_dir`] with the quick start's program (`conveyor.expr`) and plant model
/// (`conveyor.plant.rhai`) in it.
pub(crate) fn conveyor_scratch(subject: &str, name: &str) -> PathBuf {
    let dir = scratch_dir(subject, name);
    std::fs::copy(
        repo().join("programs/conveyor.expr"),
        dir.join("conveyor.expr"),
    )
    .expect("the quick start's program");
    copy_quickstart_plant(&dir);
    dir
}

/// Copies the quick start's plant model (`conveyor.plant.rhai`, named relative to its
/// project) into `dir`, beside a copy of its project.
pub(crate) fn copy_quickstart_plant(dir: &Path) {
    std::fs::copy(
        repo().join("examples/quickstart/conveyor.plant.rhai"),
        dir.join("conveyor.plant.rhai"),
    )
    .expect("the quick start's plant model");
}

/// The quick start's plant model line, with the model named by absolute path (for a copy of
/// the project elsewhere): `file: /…/examples/quickstart/conveyor.plant.rhai`.
pub(crate) fn quickstart_plant_absolute(text: &str) -> String {
    let model = repo().join("examples/quickstart/conveyor.plant.rhai");
    text.replace(
        "file: conveyor.plant.rhai",
        &format!("file: {}", model.display()),
    )
}

/// One HTTP GET of `path` at `addr`: its status (0 when the connection or the answer failed)
/// and how long it took.
pub(crate) fn http_get(addr: &str, path: &str) -> (u16, std::time::Duration) {
    use std::io::{Read, Write};
    let begin = std::time::Instant::now();
    let Ok(mut s) = std::net::TcpStream::connect(addr) else {
        return (0, begin.elapsed());
    };
    drop(s.set_read_timeout(Some(std::time::Duration::from_secs(10))));
    drop(write!(s, "GET {path} HTTP/1.1\r\nHost: {addr}\r\n\r\n"));
    let mut text = String::new();
    drop(s.read_to_string(&mut text));
    let status = text
        .split(' ')
        .nth(1)
        .and_then(|c| c.parse().ok())
        .unwrap_or(0);
    (status, begin.elapsed())
}

/// A port nobody listens on now (bound, then released).
pub(crate) fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .unwrap()
        .local_addr()
        .unwrap()
        .port()
}

/// The lines `r` gives, read on a thread of their own (so a test waits with a deadline).
pub(crate) fn lines_of(r: impl std::io::Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = channel();
    std::thread::spawn(move || {
        for line in BufReader::new(r).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    rx
}

/// `command` spawned with its stdin and stdout piped (stderr dropped): the child, its stdin,
/// and its stdout's lines as they come ([`lines_of`]).
pub(crate) fn spawn_piped(
    command: &mut std::process::Command,
) -> (
    std::process::Child,
    std::process::ChildStdin,
    Receiver<String>,
) {
    use std::process::Stdio;
    let mut child = command
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap_or_else(|e| panic!("{command:?} does not start: {e}"));
    let stdin = child.stdin.take().expect("its stdin, piped");
    let lines = lines_of(child.stdout.take().expect("its stdout, piped"));
    (child, stdin, lines)
}

/// A running `softplc run`, stopped (SIGTERM) when dropped.
pub(crate) struct Running(pub(crate) std::process::Child);

impl Drop for Running {
    fn drop(&mut self) {
        #[allow(unsafe_code)]
        // SAFETY: kill has no memory preconditions; the pid is our own child's.
        unsafe {
            libc::kill(self.0.id() as i32, libc::SIGTERM)
        };
        // Only reaps the child: its exit status is not what this test checks.
        drop(self.0.wait());
    }
}

/// Waits (bounded) for a line of `log` containing `what`; that line.
pub(crate) fn wait_in_log(
    log: &std::path::Path,
    what: &str,
    within: std::time::Duration,
) -> String {
    let begin = std::time::Instant::now();
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some(line) = text.lines().find(|l| l.contains(what)) {
            return line.to_owned();
        }
        assert!(begin.elapsed() < within, "no {what:?} in the log:\n{text}");
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// `softplc run PROJECT --virtual` without end, its control socket at `socket`, once that
/// socket is there (within a minute); stopped when the result is dropped.
pub(crate) fn run_virtual(project: &std::path::Path, socket: &std::path::Path) -> Running {
    run_virtual_with(project, socket, &[])
}

/// [`run_virtual`] with more options of `softplc run` (`--keep-forces`).
pub(crate) fn run_virtual_with(
    project: &std::path::Path,
    socket: &std::path::Path,
    extra: &[&str],
) -> Running {
    use std::process::{Command, Stdio};
    let child = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("run")
        .arg(project)
        .args(["--virtual", "--for", "10000h", "--quiet", "--socket"])
        .arg(socket)
        .args(extra)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let running = Running(child);
    let begin = std::time::Instant::now();
    while !socket.exists() {
        assert!(
            begin.elapsed() < std::time::Duration::from_secs(60),
            "no control socket"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    running
}

/// The address a child logs after `prefix` in its log file `log` (e.g. `web page: http://`),
/// once it has (within 30 s).
pub(crate) fn log_value(log: &Path, prefix: &str) -> String {
    let begin = std::time::Instant::now();
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some(v) = text
            .lines()
            .find_map(|l| l.split(prefix).nth(1))
            .map(|r| r.split(['/', ' ']).next().unwrap_or_default().to_owned())
        {
            return v;
        }
        assert!(
            begin.elapsed() < std::time::Duration::from_secs(30),
            "no {prefix:?}:\n{text}"
        );
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
}

/// `softplc run ARGS --quiet --socket SOCKET` started from folder `dir` (log level warn), its
/// output piped.
pub(crate) fn spawn_run(dir: &Path, args: &[&str], socket: &Path) -> std::process::Child {
    std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .current_dir(dir)
        .arg("run")
        .args(args)
        .args(["--quiet", "--socket"])
        .arg(socket)
        .env("SOFTPLC_LOG", "warn")
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("softplc runs")
}

/// `softplc status --json` of the PLC of several tasks on `socket` once task `i` has made
/// `scans[i]` scans, polled every 100 ms for at most 20 s (a run's start-up: its lines, its
/// tasks' first cycles).
pub(crate) fn status_once_scanned(socket: &Path, scans: &[u64]) -> serde_json::Value {
    let begin = std::time::Instant::now();
    loop {
        let (ok, text) = softplc(&[
            "status",
            "--json",
            "--socket",
            socket.to_str().expect("a UTF-8 socket path"),
        ]);
        if ok {
            let v: serde_json::Value = serde_json::from_str(&text).expect("JSON");
            let made = |t: usize| v["tasks"][t]["scans"].as_u64().unwrap_or(0);
            if scans.iter().enumerate().all(|(t, &n)| made(t) >= n) {
                return v;
            }
        }
        assert!(
            begin.elapsed() < std::time::Duration::from_secs(20),
            "no status: {text}"
        );
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// The count a log summary (`… 12,345 more in the last 10 s …`) says was held back.
pub(crate) fn held_back(summary: &str) -> u64 {
    summary
        .split("… ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|n| n.replace(',', "").parse().ok())
        .unwrap_or_else(|| panic!("not a summary: {summary}"))
}

/// Whether this machine lets an unprivileged test mount a tmpfs in a mount namespace of its
/// own (`unshare -rm`).
pub(crate) fn tmpfs_allowed() -> bool {
    std::process::Command::new("unshare")
        .args(["-rm", "sh", "-c", "mount -t tmpfs -o size=64k tmpfs /mnt"])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok_and(|s| s.success())
}

/// What `softplc status --json` on `socket` says of `service` (`{"service", "state",
/// "reason"}`); null when there is no answer yet.
pub(crate) fn service_state(socket: &Path, service: &str) -> serde_json::Value {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["status", "--json", "--socket"])
        .arg(socket)
        .output()
        .expect("softplc runs");
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap_or_default();
    status["services"]
        .as_array()
        .and_then(|s| s.iter().find(|s| s["service"] == service).cloned())
        .unwrap_or_default()
}
