//! The `softplc` binary as a user runs it: `check`, `run`, and `sim` with a third-party Modbus
//! master (mbpoll) on the other end of its pty.
//!
//! mbpoll is a Debian package that `scripts/test` installs; without it the master tests fail
//! (they do not skip) and say so. Processes run in real time here: every wait is generous and
//! no test asserts how long something took, except that the virtual clock does not wait.

use crate::common::host::repo as root;
use crate::common::scratch::Scratch;
use std::io::{BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, ExitStatus, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::time::{Duration, Instant};

/// Far longer than any of these commands takes, even on a loaded machine.
const PATIENCE: Duration = Duration::from_secs(60);

fn quickstart() -> PathBuf {
    root().join("examples/quickstart/project.yaml")
}

/// What a finished command left.
#[derive(Debug)]
struct Finished {
    status: ExitStatus,
    stdout: String,
    stderr: String,
}

impl Finished {
    fn code(&self) -> Option<i32> {
        self.status.code()
    }
}

/// Reads a child's pipe to the end on a thread.
fn drain(mut pipe: impl Read + Send + 'static) -> Receiver<String> {
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        let mut text = String::new();
        // A read ending in an error (timeout, reset) still leaves what arrived in the buffer.
        drop(pipe.read_to_string(&mut text));
        // The receiver is gone once the test has what it needs.
        drop(tx.send(text));
    });
    rx
}

/// Runs `program args`, killing it after [`PATIENCE`].
fn run(program: &str, args: &[&str]) -> Finished {
    let mut child = Command::new(program)
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {program}: {e}"));
    let stdout = drain(child.stdout.take().expect("piped stdout"));
    let stderr = drain(child.stderr.take().expect("piped stderr"));
    let deadline = Instant::now() + PATIENCE;
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for the child") {
            break status;
        }
        if Instant::now() > deadline {
            // The child may have exited already; then there is nothing to stop.
            drop(child.kill());
            drop(child.wait());
            panic!("{program} {args:?} did not finish within {PATIENCE:?}");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Finished {
        status,
        stdout: stdout.recv().unwrap_or_default(),
        stderr: stderr.recv().unwrap_or_default(),
    }
}

fn softplc(args: &[&str]) -> Finished {
    run(env!("CARGO_BIN_EXE_softplc"), args)
}

fn path_str(p: &Path) -> &str {
    p.to_str().expect("a UTF-8 path")
}

// --- the catalog ---

#[test]
fn points_lists_a_models_points_and_models_names_them_all() {
    let out = softplc(&["points", "minimod", "--only", "input"]);
    assert_eq!(out.code(), Some(0), "{out:?}");
    let x1 = out.stdout.lines().find(|l| l.starts_with("X1 "));
    assert_eq!(
        x1.map(|l| l.split_whitespace().take(3).collect::<Vec<_>>()),
        Some(vec!["X1", "input", "bool"]),
        "{}",
        out.stdout
    );
    let out = softplc(&["points", "resi16di8ro"]);
    assert_eq!(out.code(), Some(1), "{out:?}");
    assert!(
        out.stderr
            .starts_with("error: unknown model `resi16di8ro`; did you mean `resi-16di8ro`?"),
        "{}",
        out.stderr
    );
    let out = softplc(&["models"]);
    assert_eq!(out.code(), Some(0), "{out:?}");
    for model in ["minimod", "ex9053d", "resi-16di8ro", "resi-2rtd"] {
        assert!(
            out.stdout
                .lines()
                .any(|l| l.starts_with(&format!("{model} "))),
            "{model} missing:\n{}",
            out.stdout
        );
    }
}

// --- check ---

#[test]
fn check_accepts_the_quick_start_and_prints_its_budget() {
    let out = softplc(&["check", path_str(&quickstart())]);
    assert_eq!(out.code(), Some(0), "{out:?}");
    let text = &out.stdout;
    assert!(text.contains("module mm1 = minimod @1 (modbus)"), "{text}");
    assert!(
        text.contains("out Y1       bool → tag #3 motor safe=0"),
        "{text}"
    );
    // Event mode by default (the round, 13.59 ms, is cheaper than two polls, 41.20 ms); its
    // longest input phase is a refresh: the round, then two FC 2 reads of 8 + 7 bytes at
    // 19200 8E1, each with the MiniMod's 10 ms reply delay and t3.5: 2 × (8.594 + 10 + 2.005)
    // ms.
    assert!(
        text.contains("input plan: event mode (Collect) for mm1, mm2, chosen"),
        "{text}"
    );
    assert!(
        text.contains(
            "budget: inputs 54.79ms (2 transactions after an idle Collect round of 13.59ms, a \
             refresh cycle), full output write 42.34ms, cycle floor 97.13ms"
        ),
        "{text}"
    );
    assert!(
        text.contains("an ordinary cycle's input phase can be no shorter than 13.59ms"),
        "{text}"
    );
    assert!(!text.contains("warning"), "{text}");
}

/// A broken project's folder, with the quick start's program beside it.
fn scratch(case: &str) -> Scratch {
    let s = Scratch::new("cli", case);
    let program = std::fs::read_to_string(root().join("programs/conveyor.expr"))
        .expect("programs/conveyor.expr");
    s.write("conveyor.expr", &program);
    s
}

/// A valid project; the cases below break one line of it. Line numbers matter.
const PROJECT: &str = "\
project: broken
scan:
  period: 100ms
buses:
  - name: line1
    port: sim
    baud: 19200
modules:
  - { name: mm1, bus: line1, model: minimod, address: 1 }
  - { name: mm2, bus: line1, model: minimod, address: 2 }
tags:
  - { name: start, point: mm1.X2 }
  - { name: stop, point: mm1.X3 }
  - { name: box_at_entry, point: mm1.X1 }
  - { name: motor, point: mm1.Y1, safe: false }
  - { name: box_at_exit, point: mm2.X1 }
  - { name: lamp, point: mm2.Y1 }
program:
  file: conveyor.expr
  kind: expr
";

/// Runs `check` on `PROJECT` with `from` replaced by `to`; it must fail with exactly
/// `expected` errors (`line:col: error: message`) on stderr, in order, naming the file.
fn check_fails<S: AsRef<str>>(case: &str, from: &str, to: &str, expected: &[S]) {
    let scratch = scratch(case);
    assert!(
        PROJECT.contains(from),
        "{case}: {from:?} is not in the project"
    );
    let path = scratch.write("project.yaml", &PROJECT.replacen(from, to, 1));
    let out = softplc(&["check", path_str(&path)]);
    assert_eq!(out.code(), Some(1), "{case}: {out:?}");
    let lines: Vec<&str> = out.stderr.lines().collect();
    let want: Vec<String> = expected
        .iter()
        .map(|e| format!("{}:{}", path.display(), e.as_ref()))
        .collect();
    assert_eq!(lines, want, "{case}");
    assert!(!out.stdout.contains("budget"), "{case}: {}", out.stdout);
}

#[test]
fn check_names_file_line_column_and_fault() {
    let base = scratch("valid");
    let valid = base.write("project.yaml", PROJECT);
    let out = softplc(&["check", path_str(&valid)]);
    assert_eq!(
        out.code(),
        Some(0),
        "the unbroken project is valid: {out:?}"
    );

    check_fails(
        "unknown-model",
        "model: minimod, address: 2",
        "model: minimodd, address: 2",
        &[format!(
            "10:37: error: unknown model \"minimodd\" (known: {})",
            softplc_io::devices::catalog()
                .iter()
                .map(|m| m.name)
                .collect::<Vec<_>>()
                .join(", ")
        )],
    );
    check_fails(
        "duplicate-address",
        "address: 2",
        "address: 1",
        &["10:55: error: address 1 is already used by module mm1 on bus line1 (line 9)"],
    );
    check_fails(
        "bad-point",
        "mm2.Y1",
        "mm2.Y9",
        &[
            "17:26: error: module mm2 (minimod) has no point \"Y9\"; did you mean X9, Y1, Y2, \
           Y3, Y4?",
        ],
    );
    check_fails(
        "zero-period",
        "period: 100ms",
        "period: 0ms",
        &["3:11: error: scan.period must be greater than zero"],
    );
    check_fails(
        "unknown-key",
        "    baud: 19200",
        "    baudrate: 19200",
        &[
            "7:5: error: unknown key `baudrate` in buses[0]; expected one of `name`, `port`, \
           `baud`, `format`, `response_timeout`, `retries`, `output_refresh`, `rs485`, `echo`, \
           `adapter_latency`, `direction`, `tune`",
        ],
    );
    check_fails(
        "wrong-type",
        "baud: 19200",
        "baud: fast",
        &["7:11: error: buses[0].baud: invalid type: string \"fast\", expected a whole number"],
    );
    // Semantic errors are all reported at once, in file order.
    check_fails(
        "several",
        "  - { name: mm2, bus: line1, model: minimod, address: 2 }\n",
        "  - { name: mm2, bus: line2, model: minimod, address: 300 }\n",
        &[
            "10:23: error: unknown bus \"line2\" (known: line1)",
            "10:55: error: address 300 is outside the range 1..=247 of model minimod",
        ],
    );
}

#[test]
fn check_names_the_program_line_and_fault() {
    let scratch = scratch("program");
    // Line 11 of conveyor.expr is the motor rung; `stop` misspelt.
    let program = std::fs::read_to_string(scratch.dir.join("conveyor.expr")).unwrap();
    let rung = "motor = (rising(start) | motor) & !stop & !box_at_exit";
    assert_eq!(program.lines().nth(10), Some(rung));
    let typo = scratch.write("typo.expr", &program.replace("!stop", "!stpo"));
    let cut = scratch.write(
        "cut.expr",
        "motor = (rising(start) | motor) & \nlamp = box_at_exit\n",
    );
    for (program, expected) in [
        (
            &typo,
            "11:36: error: unknown tag `stpo`; did you mean `stop`?",
        ),
        (
            &cut,
            "1:35: error: expected a tag, 0, 1, true, false, `!`, `(` or a function call, \
             found end of line",
        ),
    ] {
        let name = program.file_name().unwrap().to_str().unwrap();
        let project = scratch.write(
            "project.yaml",
            &PROJECT.replace("file: conveyor.expr", &format!("file: {name}")),
        );
        let out = softplc(&["check", path_str(&project)]);
        assert_eq!(out.code(), Some(1), "{name}: {out:?}");
        assert_eq!(
            out.stderr.trim_end(),
            format!("{}:{expected}", program.display()),
            "{name}"
        );
    }
}

// --- run ---

/// `softplc run` opens a control socket named after the project; two runs of the quick start
/// at once would refuse each other ("another instance is running"), so these tests take
/// turns.
static ONE_RUN_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `softplc run QUICKSTART extra...`, and how long it took once its turn came.
fn run_quickstart(extra: &[&str]) -> (Finished, Duration) {
    let _turn = ONE_RUN_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let project = quickstart();
    // No control socket: the default one is named after the project, and a quick start
    // running on this machine would hold it.
    let mut args = vec!["run", path_str(&project), "--no-socket"];
    args.extend_from_slice(extra);
    let begin = Instant::now();
    let out = softplc(&args);
    (out, begin.elapsed())
}

/// The summary line `scans N  overruns N  period 100.00ms` and the cycle line.
fn summary_lines(stdout: &str) -> (String, String) {
    let scans = stdout
        .lines()
        .find(|l| l.starts_with("scans "))
        .unwrap_or_else(|| panic!("no `scans` line in:\n{stdout}"));
    let cycle = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("cycle "))
        .unwrap_or_else(|| panic!("no `cycle` line in:\n{stdout}"));
    (scans.to_string(), cycle.trim().to_string())
}

#[test]
fn the_service_default_priority_is_applied_or_its_refusal_logged() {
    let (out, _) = run_quickstart(&["--for", "300ms", "--quiet", "--realtime-priority", "50"]);
    assert_eq!(out.code(), Some(0), "{out:?}");
    // Whether the kernel grants it depends on the machine; either way the log says which.
    let applied = out
        .stderr
        .contains("scan thread runs SCHED_FIFO priority 50");
    let refused = out.stderr.contains("WARN")
        && out.stderr.contains("SCHED_FIFO priority 50 refused (")
        && out.stderr.contains("running with normal scheduling");
    assert!(applied ^ refused, "{}", out.stderr);
    let (out, _) = run_quickstart(&["--for", "300ms", "--realtime-priority", "0"]);
    assert_eq!(out.code(), Some(2), "{out:?}");
    assert!(
        out.stderr
            .contains("invalid value '0' for '--realtime-priority <PRIORITY>'"),
        "{}",
        out.stderr
    );
}

#[test]
fn run_for_two_seconds_reports_cycle_statistics() {
    let (out, _) = run_quickstart(&["--for", "2s", "--quiet"]);
    assert_eq!(out.code(), Some(0), "{out:?}");
    let text = &out.stdout;
    assert!(
        text.starts_with(
            "stopped after its run time (--for 2.00s); outputs set to their safe values\n"
        ),
        "{text}"
    );
    let (scans, cycle) = summary_lines(text);
    let count: u64 = scans
        .split_whitespace()
        .nth(1)
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("{scans}"));
    assert!((1..=20).contains(&count), "2 s at 100 ms: {scans}");
    assert!(scans.ends_with("period 100.00ms"), "{scans}");
    for p in ["p50 ", " p99 ", " p99.9 ", " max "] {
        assert!(cycle.contains(p), "{cycle}");
    }
    for phase in ["inputs ", "logic ", "outputs ", "lateness "] {
        assert!(
            text.lines().any(|l| l.trim_start().starts_with(phase)),
            "no {phase} line:\n{text}"
        );
    }
    // Logs piped into a file or a journal carry no colour codes.
    assert!(out.stderr.contains("INFO"), "{}", out.stderr);
    assert!(!out.stderr.contains('\x1b'), "{:?}", out.stderr);
    for m in ["module mm1 (line1): good", "module mm2 (line1): good"] {
        assert!(text.contains(m), "{text}");
    }
}

#[test]
fn run_on_the_virtual_clock_is_fast_and_deterministic() {
    let args = ["--virtual", "--for", "30s"];
    let (first, elapsed) = run_quickstart(&args);
    let (second, _) = run_quickstart(&args);
    assert_eq!(first.code(), Some(0), "{first:?}");
    assert_eq!(second.code(), Some(0), "{second:?}");
    // 30 s of scan time; the virtual clock jumps instead of waiting.
    assert!(
        elapsed < Duration::from_secs(20),
        "30 s virtual took {elapsed:?}"
    );
    let (scans, cycle) = summary_lines(&first.stdout);
    assert_eq!(scans, "scans 300  overruns 0  period 100.00ms");
    // The longest cycle runs the Collect round, refreshes both modules' inputs and both
    // outputs: the cycle floor of `check` (97.13 ms) without the last t3.5 and with the
    // character the owner listens past the round's window (0.57 ms), to the histogram's 3
    // significant digits.
    assert!(cycle.ends_with("max 95.75ms"), "{cycle}");
    // Everything, the statistics included, is the same twice.
    assert_eq!(first.stdout, second.stdout);
}

// --- sim + a third-party master ---

pub(crate) fn require_mbpoll() {
    match Command::new("mbpoll").arg("-V").output() {
        Ok(_) => {}
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => panic!(
            "mbpoll is not installed: run scripts/test, which installs it (Debian package \
             mbpoll) and then runs the tests"
        ),
        Err(e) => panic!("cannot run mbpoll: {e}"),
    }
}

/// `softplc sim --pty minimod@5`, its standard input and its standard output by lines.
pub(crate) struct Sim {
    child: Child,
    stdin: Option<ChildStdin>,
    lines: Receiver<String>,
    /// The pty's slave path for the master.
    path: String,
}

impl Sim {
    fn start() -> Self {
        Self::start_with(&["sim", "--pty", "minimod@5"])
    }

    /// `softplc ARGS` (a `sim --pty` serving unit 5 at 19200 8E1).
    pub(crate) fn start_with(args: &[&str]) -> Self {
        let mut child = Command::new(env!("CARGO_BIN_EXE_softplc"))
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("softplc sim starts");
        let stdin = child.stdin.take();
        let stdout = child.stdout.take().expect("piped stdout");
        let (tx, lines) = mpsc::channel();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines() {
                let Ok(line) = line else { break };
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        let mut sim = Self {
            child,
            stdin,
            lines,
            path: String::new(),
        };
        let first = sim.line();
        let path = first
            .strip_prefix("serving ")
            .and_then(|rest| rest.split_once(" on "))
            .and_then(|(_, rest)| rest.strip_suffix(" at 19200 8E1"))
            .unwrap_or_else(|| panic!("unexpected first line {first:?}"));
        assert!(path.starts_with("/dev/pts/"), "{first}");
        sim.path = path.to_string();
        sim
    }

    /// The next line on its standard output.
    fn line(&self) -> String {
        self.lines
            .recv_timeout(PATIENCE)
            .expect("softplc sim printed a line")
    }

    /// Types `command` on its standard input; returns the line it prints in answer.
    pub(crate) fn command(&mut self, command: &str) -> String {
        let stdin = self.stdin.as_mut().expect("stdin open");
        writeln!(stdin, "{command}").expect("write to softplc sim");
        stdin.flush().expect("flush");
        self.line()
    }

    /// Runs mbpoll once on the pty as unit 5's master at 19200 8E1, with `args` (`-t 0` coils,
    /// `-t 1` discrete inputs, `-t 3` input registers, `-t 4` holding registers; `-r` is a
    /// 1-based reference as in the manual unless `-0` is given) and `values` to write; returns
    /// the `[reference]: value` lines it printed.
    pub(crate) fn mbpoll(&self, args: &[&str], values: &[&str]) -> Vec<(u32, String)> {
        let mut all = vec![
            "-m", "rtu", "-a", "5", "-b", "19200", "-P", "even", "-o", "5", "-1",
        ];
        all.extend_from_slice(args);
        all.push(&self.path);
        all.extend_from_slice(values);
        let out = run("mbpoll", &all);
        assert_eq!(out.code(), Some(0), "mbpoll {all:?}: {out:?}");
        out.stdout
            .lines()
            .filter_map(|l| {
                let (reference, value) = l.strip_prefix('[')?.split_once("]:")?;
                Some((reference.parse().ok()?, value.trim().to_string()))
            })
            .collect()
    }
}

impl Drop for Sim {
    fn drop(&mut self) {
        if let Some(mut stdin) = self.stdin.take() {
            // The simulator may have exited already.
            drop(writeln!(stdin, "quit"));
        }
        let deadline = Instant::now() + Duration::from_secs(10);
        while Instant::now() < deadline {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

fn values(refs: std::ops::RangeInclusive<u32>, v: &[&str]) -> Vec<(u32, String)> {
    refs.zip(v).map(|(r, v)| (r, v.to_string())).collect()
}

#[test]
fn a_third_party_master_reads_the_manuals_addresses_and_sees_stdin_inputs() {
    require_mbpoll();
    let mut sim = Sim::start();

    // Discrete inputs 10001..10010: X1..X3, holes, FB1, FB2 (10009, 10010).
    let zeros = ["0"; 10];
    assert_eq!(
        sim.mbpoll(&["-t", "1", "-r", "1", "-c", "10"], &[]),
        values(1..=10, &zeros)
    );
    // Coils 00001..00004: Y1..Y4.
    assert_eq!(
        sim.mbpoll(&["-t", "0", "-r", "1", "-c", "4"], &[]),
        values(1..=4, &zeros)
    );
    // Holding registers 40020..40022 (protocol 19..21): XLATUP1..3, 20 ms at power-on.
    assert_eq!(
        sim.mbpoll(&["-t", "4", "-0", "-r", "19", "-c", "3"], &[]),
        values(19..=21, &["20", "20", "20"])
    );
    // 40036..40038: XLATDN1..3, 20 ms too; 40001: YWORD.
    assert_eq!(
        sim.mbpoll(&["-t", "4", "-r", "36", "-c", "3"], &[]),
        values(36..=38, &["20", "20", "20"])
    );
    assert_eq!(
        sim.mbpoll(&["-t", "4", "-r", "1"], &[]),
        values(1..=1, &["0"])
    );
    // Input register 30010: ROTSW, the selector at 5 for unit 5.
    assert_eq!(
        sim.mbpoll(&["-t", "3", "-r", "10"], &[]),
        values(10..=10, &["5"])
    );

    // An input set on the simulator's standard input shows in the next reads, once the
    // module's 20 ms input latency has passed.
    assert_eq!(sim.command("set minimod@5.X1 1"), "minimod@5.X1=1");
    std::thread::sleep(Duration::from_millis(100));
    assert_eq!(
        sim.mbpoll(&["-t", "1", "-r", "1", "-c", "3"], &[]),
        values(1..=3, &["1", "0", "0"])
    );
    // The same with 0-based references, and as input register 30001 (XWORD, bit 0 = X1).
    assert_eq!(
        sim.mbpoll(&["-t", "1", "-0", "-r", "0", "-c", "3"], &[]),
        values(0..=2, &["1", "0", "0"])
    );
    assert_eq!(
        sim.mbpoll(&["-t", "3", "-r", "1"], &[]),
        values(1..=1, &["1"])
    );
}

#[test]
fn a_coil_written_by_a_third_party_master_shows_on_stdin_get() {
    require_mbpoll();
    let mut sim = Sim::start();
    assert_eq!(sim.command("get minimod@5.Y1"), "minimod@5.Y1=0");
    // Write coil 00001 (Y1) to 1.
    let written = sim.mbpoll(&["-t", "0", "-r", "1"], &["1"]);
    assert!(written.is_empty(), "a write prints no values: {written:?}");
    assert_eq!(sim.command("get minimod@5.Y1"), "minimod@5.Y1=1");
    assert_eq!(sim.command("get minimod@5.YWORD"), "minimod@5.YWORD=1");
    assert_eq!(
        sim.mbpoll(&["-t", "0", "-r", "1", "-c", "4"], &[]),
        values(1..=4, &["1", "0", "0", "0"])
    );
}

// --- closed pipes and pathological input ---

/// A scratch folder for `name` holding the quick start with `n` more memory tags (so `check`
/// and `status` print far more than a pipe holds) and the project name `name`.
fn big_quickstart(name: &str, n: usize) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("softplc-cli-{name}-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::copy(
        root().join("programs/conveyor.expr"),
        dir.join("conveyor.expr"),
    )
    .unwrap();
    crate::common::host::copy_quickstart_plant(&dir);
    let text = std::fs::read_to_string(quickstart()).unwrap();
    let text = text
        .split("\nservice:\n")
        .next()
        .unwrap_or_default()
        .replace("../../programs/conveyor.expr", "conveyor.expr")
        .replace("project: quickstart", &format!("project: {name}"));
    let tags: String = (0..n)
        .map(|i| format!("  - {{ name: memory_tag_{i}, type: u16, initial: {i} }}\n"))
        .collect();
    let text = text.replacen("tags:\n", &format!("tags:\n{tags}"), 1);
    std::fs::write(dir.join("project.yaml"), text).unwrap();
    dir
}

/// Runs `softplc args` with stdout a pipe that the test closes after reading the first bytes,
/// so the command's later writes find no reader: what it printed to stderr, and its status.
fn with_stdout_closed_early(args: &[&str]) -> Finished {
    let mut child = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("softplc runs");
    let stderr = drain(child.stderr.take().expect("piped stderr"));
    let mut stdout = child.stdout.take().expect("piped stdout");
    let mut first = [0u8; 16];
    stdout.read_exact(&mut first).expect("the command prints");
    drop(stdout);
    let deadline = Instant::now() + PATIENCE;
    let status = loop {
        if let Some(status) = child.try_wait().expect("wait for the child") {
            break status;
        }
        if Instant::now() > deadline {
            // The child may have exited already; then there is nothing to stop.
            drop(child.kill());
            panic!("softplc {args:?} did not end after its stdout closed");
        }
        std::thread::sleep(Duration::from_millis(10));
    };
    Finished {
        status,
        stdout: String::from_utf8_lossy(&first).into_owned(),
        stderr: stderr.recv().unwrap_or_default(),
    }
}

/// What a command whose stdout closed under it must look like: no panic, nothing on stderr,
/// the status of a program a closed pipe ended (128 + SIGPIPE).
fn ended_quietly(out: &Finished) {
    assert!(
        !out.stderr.contains("panicked") && out.stderr.trim().is_empty(),
        "stderr: {}",
        out.stderr
    );
    assert_eq!(out.code(), Some(141), "{out:?}");
}

#[test]
fn check_into_a_closed_pipe_ends_quietly() {
    let dir = big_quickstart("pipecheck", 8000);
    let project = dir.join("project.yaml");
    // The whole report is far more than a pipe buffers (64 KiB).
    let full = softplc(&["check", path_str(&project)]);
    assert_eq!(full.code(), Some(0), "{}", full.stderr);
    assert!(full.stdout.len() > 128 * 1024, "{}", full.stdout.len());
    let out = with_stdout_closed_early(&["check", path_str(&project)]);
    assert!(out.stdout.starts_with("project pipe"), "{out:?}");
    ended_quietly(&out);
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn status_into_a_closed_pipe_ends_quietly() {
    let dir = big_quickstart("pipestatus", 8000);
    let socket = dir.join("ctl.sock");
    let mut plc = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["run", "--quiet", "--for", "30s", "--socket"])
        .arg(&socket)
        .arg(dir.join("project.yaml"))
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("softplc run starts");
    let status = ["status", "--json", "--socket", path_str(&socket)];
    let begin = Instant::now();
    let full = loop {
        let out = softplc(&status);
        if out.code() == Some(0) {
            break out;
        }
        assert!(
            plc.try_wait().unwrap().is_none(),
            "softplc run stopped: {out:?}"
        );
        assert!(begin.elapsed() < PATIENCE, "no status: {out:?}");
        std::thread::sleep(Duration::from_millis(200));
    };
    assert!(full.stdout.len() > 128 * 1024, "{}", full.stdout.len());
    let out = with_stdout_closed_early(&status);
    assert!(out.stdout.starts_with('{'), "{out:?}");
    ended_quietly(&out);
    // The instance is unharmed and answers the next client.
    assert_eq!(softplc(&status).code(), Some(0));
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn check_answers_a_deeply_nested_project_at_once() {
    let dir = std::env::temp_dir().join(format!("softplc-cli-nested-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, text) in [
        // 100 000 brackets inside one another, then as many closing: 200 KB.
        (
            "brackets.yaml",
            format!(
                "project: nested\nplant: {}{}\n",
                "[".repeat(100_000),
                "]".repeat(100_000)
            ),
        ),
        // Mappings inside one another, never closed.
        (
            "braces.yaml",
            format!("project: nested\nplant: {}\n", "{a: ".repeat(50_000)),
        ),
    ] {
        assert!(text.len() >= 200_000);
        let file = dir.join(name);
        std::fs::write(&file, text).unwrap();
        let begin = Instant::now();
        let out = softplc(&["check", path_str(&file)]);
        let took = begin.elapsed();
        assert_eq!(out.code(), Some(1), "{out:?}");
        // The top-level mapping is one level: the 64th collection of line 2 goes past the
        // limit, at column 8 (after `plant: `) + 63 brackets or 63 × 4 for `{a: `.
        let column = if name == "brackets.yaml" { 71 } else { 260 };
        let expected = format!(
            "{}:2:{column}: error: lists and mappings nested more than 64 deep (a project needs \
             a handful); this one goes past it",
            file.display()
        );
        assert_eq!(out.stderr.trim(), expected, "{name}");
        assert!(took < Duration::from_secs(10), "{name}: {took:?}");
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

/// `softplc run project.yaml --socket ctl.sock` in `dir` (a bare name): the socket opens in
/// `dir`, and `status` through the same bare name answers for project `name`.
fn a_bare_socket_name_answers_in(dir: &Path, name: &str) -> serde_json::Value {
    let mut plc = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args([
            "run",
            "project.yaml",
            "--virtual",
            "--for",
            "10000h",
            "--quiet",
        ])
        .args(["--socket", "ctl.sock"])
        .current_dir(dir)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .expect("softplc run starts");
    let begin = Instant::now();
    while !dir.join("ctl.sock").exists() {
        if let Some(exit) = plc.try_wait().unwrap() {
            let mut err = String::new();
            drop(plc.stderr.take().map(|mut e| e.read_to_string(&mut err)));
            panic!("softplc run --socket ctl.sock stopped ({exit}): {err}");
        }
        assert!(begin.elapsed() < PATIENCE, "no control socket");
        std::thread::sleep(Duration::from_millis(20));
    }
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(["status", "--json", "--socket", "ctl.sock"])
        .current_dir(dir)
        .output()
        .unwrap();
    assert!(out.status.success(), "{out:?}");
    let status: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(status["project"], name, "{status}");
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    status
}

#[test]
fn a_control_socket_named_without_a_folder_opens_in_the_working_folder() {
    let dir = big_quickstart("relsocket", 0);
    a_bare_socket_name_answers_in(&dir, "relsocket");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}

#[test]
fn a_project_of_two_tasks_opens_a_bare_socket_name_in_the_working_folder() {
    let s = Scratch::new("cli", "relsocket-tasks");
    for f in ["project.yaml", "press.ladder.yaml", "panel.ladder.yaml"] {
        std::fs::copy(root().join("examples/two-tasks").join(f), s.dir.join(f)).unwrap();
    }
    let status = a_bare_socket_name_answers_in(&s.dir, "two-tasks");
    let tasks: Vec<&str> = status["tasks"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| t["name"].as_str().unwrap())
        .collect();
    assert_eq!(tasks, ["press", "panel"], "{status}");
}
