//! `softplc monitor`: a passive listener decoding what it hears. For each protocol a session
//! is captured first (the bus owner's start-up exchanges with the simulated modules of an
//! example project, recorded with their timing through the frame trace), then written into
//! one end of a pty pair with pauses of 150 ms between frames, with the monitor listening on
//! the other end. It must find every frame's boundaries (t3.5 of silence for RTU, CR for text
//! lines), and decode each one as the bus owner did, without being told which way it went.
//!
//! Real time and a real pty: the pauses are far above t3.5 at 9600 Bd (4 ms), so scheduling
//! delays cannot merge or split frames; no assertion depends on how long anything took.

use std::io::{BufRead, BufReader, Read, Write};
use std::os::fd::AsRawFd;
use std::path::{Path, PathBuf};
use std::process::{ChildStderr, Command, Stdio};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use softplc::clock::{Clock, VirtualClock};
use softplc::plc::Plc;
use softplc_io::line::{pty_pair, TTYPort};
use softplc_io::time::LineInstant;
use softplc_io::wire::{format_event, Hex, Verdict, WireEvent, WireTap};

/// Frames replayed per session: every family's start-up has at least this many exchanges.
const FRAMES: usize = 14;
/// The note on a frame the monitor found glued to the next.
const GLUED: &str = " (no silence after it: split from the next by their CRCs)";
/// Silence between replayed frames: long beside the frame gap (a few ms), and long enough that
/// a monitor starved of CPU on a loaded machine still reads each frame on its own.
const PAUSE: Duration = Duration::from_millis(150);

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("the workspace root")
        .join("examples")
}

/// One frame of a captured session: its bytes and how the bus owner decoded it.
#[derive(Debug, Clone)]
struct Captured {
    bytes: Vec<u8>,
    decoded: String,
}

/// A tap that records one bus's frames (requests, and the replies it took as good).
#[derive(Debug)]
struct Capture {
    bus: String,
    frames: Mutex<Vec<Captured>>,
}

impl WireTap for Capture {
    fn record(&self, bus: &str, at: LineInstant, event: &WireEvent<'_>) {
        let bytes = match event {
            WireEvent::Sent(bytes) => bytes,
            WireEvent::Received {
                bytes,
                verdict: Verdict::Good,
                ..
            } => bytes,
            _ => return,
        };
        if bus != self.bus {
            return;
        }
        let line = format_event(bus, at, event);
        let decoded = line.split_once("  | ").map(|(_, d)| d.to_string());
        self.frames.lock().unwrap().push(Captured {
            bytes: bytes.to_vec(),
            decoded: decoded.unwrap_or_default(),
        });
    }
}

/// The first frames `bus` of the example project `dir/project.yaml` (edited by `edit`)
/// exchanges with its simulated modules.
fn capture(dir: &str, bus: &str, edit: impl Fn(String) -> String) -> Vec<Captured> {
    let path = examples().join(dir).join("project.yaml");
    let text = edit(std::fs::read_to_string(&path).unwrap());
    let project = softplc::project::parse_str(&text, &path).unwrap_or_else(|e| panic!("{e}"));
    let tap = Arc::new(Capture {
        bus: bus.to_string(),
        frames: Mutex::new(Vec::new()),
    });
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let plc = Plc::build_traced(project, clock, None, Some(tap.clone() as _)).expect("builds");
    drop(plc);
    let mut frames = tap.frames.lock().unwrap().clone();
    assert!(frames.len() >= FRAMES, "{frames:?}");
    frames.truncate(FRAMES);
    frames
}

/// `softplc monitor PATH ARGS --for 30s`, once it listens: the child and its stderr after the
/// banner. The caller then lets go of the pty's slave, so only the monitor reads the line.
fn listening(path: &str, args: &[&str]) -> (std::process::Child, BufReader<ChildStderr>) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("monitor")
        .arg(path)
        .args(args)
        .args(["--for", "30s"])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("softplc monitor starts");
    let mut stderr = BufReader::new(child.stderr.take().unwrap());
    let mut banner = String::new();
    stderr.read_line(&mut banner).unwrap();
    assert!(banner.starts_with("monitoring "), "{banner}");
    (child, stderr)
}

/// Everything a monitor that is ending prints: its stdout, and its stderr after the banner.
fn ended(child: &mut std::process::Child, mut stderr: BufReader<ChildStderr>) -> (String, String) {
    let mut stdout = String::new();
    if let Some(mut out) = child.stdout.take() {
        out.read_to_string(&mut stdout).unwrap();
    }
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    (stdout, rest)
}

/// One line of the monitor's output, in parts.
#[derive(Debug)]
struct Heard {
    gap: String,
    hex: String,
    decoded: String,
}

/// Replays `frames` into a pty with the monitor (`args`) on its other end; its lines.
fn monitor(frames: &[Captured], args: &[&str]) -> Vec<Heard> {
    let (mut master, slave, path) = private_pty();
    let (mut child, stderr) = listening(&path, args);
    // From here only the monitor reads the line.
    drop(slave);
    for frame in frames {
        std::thread::sleep(PAUSE);
        master.write_all(&frame.bytes).unwrap();
        master.flush().unwrap();
    }
    std::thread::sleep(PAUSE);
    // The line hangs up: the monitor prints what it holds and ends.
    drop(master);
    let (stdout, rest) = ended(&mut child, stderr);
    assert!(child.wait().unwrap().success(), "{stdout}\n{rest}");
    assert!(
        rest.contains(&format!("{} frame(s) in ", frames.len())) && rest.contains("hung up"),
        "{rest}"
    );
    stdout
        .lines()
        .map(|line| {
            let (head, decoded) = line.split_once("  | ").unwrap_or_else(|| panic!("{line}"));
            let gap = head
                .split("gap ")
                .nth(1)
                .and_then(|g| g.split_whitespace().next())
                .unwrap_or_else(|| panic!("{line}"))
                .to_string();
            // The hex follows the gap; a text line's text follows it in quotes.
            let hex = head
                .split_once(&gap)
                .map(|(_, h)| {
                    h.split("  \"")
                        .next()
                        .unwrap_or_default()
                        .trim()
                        .to_string()
                })
                .unwrap_or_default();
            // On a loaded machine the monitor may read two frames at once; it splits them by
            // their CRCs and says so.
            let decoded = decoded.strip_suffix(GLUED).unwrap_or(decoded);
            Heard {
                gap,
                hex,
                decoded: decoded.to_string(),
            }
        })
        .collect()
}

/// Every frame heard whole and decoded as the bus owner decoded it, each after a silence.
fn assert_heard_as_sent(frames: &[Captured], heard: &[Heard]) {
    let sent: Vec<String> = frames.iter().map(|f| Hex(&f.bytes).to_string()).collect();
    let got: Vec<&str> = heard.iter().map(|h| h.hex.as_str()).collect();
    assert_eq!(got, sent, "frame boundaries");
    for (frame, h) in frames.iter().zip(heard) {
        assert_eq!(h.decoded, frame.decoded, "{}", h.hex);
    }
    assert_eq!(heard[0].gap, "-", "nothing before the first frame");
    // Each gap is the silence the monitor measured between reads: the 150 ms pause less
    // however late it read the frame before (a loaded machine), so only "longer than the
    // frame gap that split them" is certain.
    // A frame split from the one before it by their CRCs has no gap of its own.
    for h in heard[1..].iter().filter(|h| h.gap != "-") {
        let ms: f64 = h
            .gap
            .strip_suffix("ms")
            .and_then(|v| v.parse().ok())
            .unwrap_or_else(|| panic!("gap {:?} of {}", h.gap, h.hex));
        assert!(ms > 4.0, "gap {ms} ms before {}", h.hex);
    }
}

/// Captures the session of `bus` in the example `dir` (edited by `edit`), replays it to the
/// monitor run with `args`, checks it heard every frame as sent; its decodings.
fn heard(dir: &str, bus: &str, edit: impl Fn(String) -> String, args: &[&str]) -> Vec<String> {
    let frames = capture(dir, bus, edit);
    let heard = monitor(&frames, args);
    assert_heard_as_sent(&frames, &heard);
    heard.into_iter().map(|h| h.decoded).collect()
}

#[test]
fn modbus_rtu_frames_are_cut_at_silence_and_paired_with_their_replies() {
    let args = ["--baud", "19200", "--format", "8E1"];
    let decoded = heard("quickstart", "line1", |t| t, &args);
    assert_eq!(
        decoded[..2],
        [
            "rtu request unit 1: read coils (FC 1) 160 (1 bit), CRC ok",
            "rtu reply unit 1: read coils (FC 1) 160 (1 bit) = 0, CRC ok"
        ]
    );
    // --protocol rtu: the same frames.
    let rtu = heard("quickstart", "line1", |t| t, &["--protocol", "rtu"]);
    assert_eq!(rtu, decoded);
}

#[test]
fn minimod_text_lines_are_told_from_rtu_frames_on_the_same_line() {
    // A MiniMod speaks both protocols on one line; with `protocol: text` its driver still
    // uses Modbus where the text protocol has no command.
    let text = |t: String| {
        t.replace(
            "model: minimod, address: 1 }",
            "model: minimod, address: 1, protocol: text }",
        )
    };
    let decoded = heard("quickstart", "line1", text, &["--baud", "19200"]);
    assert!(
        decoded
            .iter()
            .any(|d| d == "minimod command to module 1: read WFLAGS")
            && decoded.iter().any(|d| d == "minimod reply: WFLAGS = 0")
            && decoded.iter().any(|d| d.starts_with("rtu request")),
        "{decoded:#?}"
    );
}

#[test]
fn resi_ascii_frames_keep_their_address_and_parts() {
    let text = |t: String| t.replace("# protocol: text ", "protocol: text");
    let decoded = heard("resi", "house", text, &["--protocol", "text"]);
    assert!(
        decoded
            .iter()
            .any(|d| d == "resi command address 1: GSMODE")
            && decoded
                .iter()
                .any(|d| d == "resi answer address 1: GSMODE [0, 0x0]"),
        "{decoded:#?}"
    );
}

#[test]
fn dcon_commands_and_answers_are_paired() {
    let args = ["--baud", "9600", "--format", "8N1"];
    let decoded = heard("mixed-lines", "dcon_line", |t| t, &args);
    assert!(
        decoded
            .iter()
            .any(|d| d == "dcon command to 01: §2.9 read module name")
            && decoded.iter().any(|d| d == "dcon answer from 01: \"9053\""),
        "{decoded:#?}"
    );
}

/// A pty pair whose ends the monitor does not inherit (the line hangs up when the test closes
/// the master), and the slave's path. The test holds the slave until the monitor has opened
/// it, then lets go so that only the monitor reads the line.
fn private_pty() -> (TTYPort, TTYPort, String) {
    let (master, slave, path) = pty_pair().expect("a pty pair");
    for fd in [master.as_raw_fd(), slave.as_raw_fd()] {
        #[allow(unsafe_code)]
        // SAFETY: F_SETFD on a descriptor the ports own, for as long as they are alive.
        unsafe {
            libc::fcntl(fd, libc::F_SETFD, libc::FD_CLOEXEC)
        };
    }
    (master, slave, path)
}

fn softplc(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_softplc"))
        .args(args)
        .output()
        .expect("softplc runs")
}

#[test]
fn bad_arguments_and_a_missing_port_are_named() {
    for (args, says) in [
        (
            &["/dev/no-such-tty", "--for", "1s"][..],
            "error: cannot listen on /dev/no-such-tty",
        ),
        (
            &["/dev/null", "--format", "9X1"],
            "\"9X1\": serial format must look like 8E1",
        ),
        (&["/dev/null", "--baud", "0"], "--baud"),
    ] {
        let out = softplc(&[&["monitor"][..], args].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        assert!(stderr.contains(says), "{args:?}: {stderr}");
    }
}

#[test]
fn a_silent_line_ends_at_for_and_a_closed_pipe_ends_it_quietly() {
    let (_master, _slave, path) = private_pty();
    let out = softplc(&["monitor", &path, "--for", "300ms"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(out.stdout.is_empty());
    assert!(stderr.contains("0 frame(s) in "), "{stderr}");

    // `softplc monitor ... | head -0`: the reader of its output goes away.
    let (mut master, slave, path) = private_pty();
    let (mut child, mut stderr) = listening(&path, &[]);
    drop(slave);
    drop(child.stdout.take());
    master.write_all(b"@1?X1\r").unwrap();
    let status = child.wait().unwrap();
    let mut rest = String::new();
    stderr.read_to_string(&mut rest).unwrap();
    assert_eq!(status.code(), Some(141), "{rest}");
    assert_eq!(rest, "", "nothing said about the closed pipe");
}

#[test]
fn ctrl_c_ends_it_with_the_frame_it_held() {
    let (mut master, slave, path) = private_pty();
    // A text line ends at its CR, or cut short by the frame gap (here 10 s): the line below
    // is still being heard when Ctrl-C comes.
    let (mut child, stderr) = listening(&path, &["--protocol", "text", "--gap", "10s"]);
    drop(slave);
    master.write_all(b"@1?X").unwrap();
    std::thread::sleep(PAUSE);
    let pid = libc::pid_t::try_from(child.id()).unwrap();
    #[allow(unsafe_code)]
    // SAFETY: a signal to the child this test started and has not reaped.
    unsafe {
        libc::kill(pid, libc::SIGINT)
    };
    let (stdout, rest) = ended(&mut child, stderr);
    assert!(child.wait().unwrap().success(), "{rest}");
    assert!(
        stdout.trim_end().ends_with(
            "40 31 3F 58  \"@1?X\"  | unrecognised: text without its CR (cut: the capture ended)"
        ),
        "{stdout}"
    );
    assert!(rest.contains("1 frame(s) in "), "{rest}");
}
