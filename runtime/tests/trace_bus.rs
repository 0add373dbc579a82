//! `softplc run --trace-bus`: every frame a bus owner sends and receives, on the line's clock.
//! On the virtual clock the trace of the quick start is the same on every run and is the
//! golden file `fixtures/trace_bus/quickstart.txt`; a timeout, a late reply and a corrupted
//! one appear in it as what they are.
//!
//! Regenerate the golden file after an intended change with
//! `UPDATE_GOLDEN=1 cargo test -p softplc --test integration trace_bus::`, and review its diff.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Arc, Mutex};
use std::time::Duration;

use crate::common::host::repo as root;
use softplc::clock::{Clock, VirtualClock};
use softplc::plc::Plc;
use softplc::scan::ScanEngine;
use softplc_io::sim::{Fault, FaultRule, Frequency};
use softplc_io::time::LineInstant;
use softplc_io::wire::{format_event, WireEvent, WireTap};

fn quickstart() -> PathBuf {
    root().join("examples/quickstart/project.yaml")
}

/// `softplc run QUICKSTART --virtual --for 300ms --trace-bus`: its trace lines.
fn traced_run() -> Vec<String> {
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("run")
        .arg(quickstart())
        .args(["--virtual", "--for", "300ms", "--trace-bus", "--no-control"])
        .args(["--quiet"])
        .output()
        .expect("softplc runs");
    let stdout = String::from_utf8(out.stdout).expect("utf-8");
    assert!(
        out.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<String> = stdout
        .lines()
        .take_while(|l| l.starts_with("t=") || l.starts_with('#'))
        .map(str::to_string)
        .collect();
    // The summary follows the whole trace, the safe state written included.
    let rest = &stdout.lines().nth(lines.len());
    assert!(
        rest.is_some_and(|l| l.starts_with("stopped")),
        "summary after the trace: {rest:?}"
    );
    lines
}

#[test]
fn the_quick_start_trace_is_deterministic_and_the_golden_one() {
    let first = traced_run();
    assert_eq!(first, traced_run(), "two virtual runs, two traces");
    assert_eq!(
        first[0],
        "# bus trace: t = the line's clock (virtual time since the start of the run); TX = sent \
         (t: start), RX = received (t: last byte)"
    );
    // The start-up's first exchange, byte for byte: mm1's Y1..Y4 read (coils 160, MiniMod
    // register map) and its reply.
    assert_eq!(
        first[1],
        "t=0.000000s  line1  TX  01 01 00 A0 00 01 FD E8  | rtu request unit 1: read coils \
         (FC 1) 160 (1 bit), CRC ok"
    );
    assert!(first[2].starts_with("t=0.018020s  line1  RX  01 01 01 00 51 88  | rtu reply unit 1"));
    let text = first.join("\n") + "\n";
    let golden =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/trace_bus/quickstart.txt");
    if std::env::var_os("UPDATE_GOLDEN").is_some() {
        std::fs::write(&golden, &text).unwrap();
    }
    let want = std::fs::read_to_string(&golden).expect("the golden trace");
    assert!(
        text == want,
        "trace differs from {}:\n{text}",
        golden.display()
    );
}

/// A tap that keeps the trace lines.
#[derive(Debug, Default)]
struct Recorder(Mutex<Vec<String>>);

impl WireTap for Recorder {
    fn record(&self, bus: &str, at: LineInstant, event: &WireEvent<'_>) {
        self.0.lock().unwrap().push(format_event(bus, at, event));
    }
}

#[test]
fn timeouts_late_replies_and_crc_errors_are_in_the_trace() {
    let mut project = softplc::project::load(&quickstart()).expect("the quick start");
    // Polled, pinned: the faults below are those of polls (the quick start's modules run
    // Collect by default, where a silent module is only seen at its refresh).
    for module in &mut project.modules {
        if let softplc_io::devices::ModuleSettings::MiniMod(s) = &mut module.device.settings {
            s.push(softplc_io::devices::minimod::Setting::Events(false));
        }
    }
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let probe = Plc::build(project.clone(), clock).expect("builds");
    let world = probe.world().unwrap().clone();
    drop(probe);
    {
        let mut w = world.lock().unwrap();
        let faults = w.faults_mut();
        // mm1 (device 0): its next reply 45 ms late (the timeout is 50 ms, the reply delay 10),
        // then one with a flipped bit; mm2 (device 1) is silent.
        // Rules apply together: the late reply is flipped too (and discarded), the retry's
        // reply only flipped.
        for (fault, n) in [
            (
                Fault::Late {
                    by: Duration::from_millis(45),
                },
                1,
            ),
            (Fault::FlipBit, 2),
        ] {
            faults.add(FaultRule {
                device: Some(0),
                fault,
                frequency: Frequency::Next(n),
            });
        }
        faults.add(FaultRule {
            device: Some(1),
            fault: Fault::Silent,
            frequency: Frequency::Always,
        });
    }
    let clock = Arc::new(VirtualClock::new());
    clock.advance_to(world.lock().unwrap().now().on_scan_clock());
    let tap = Arc::new(Recorder::default());
    let plc = Plc::build_traced(project, clock, Some(world), Some(tap.clone() as _))
        .expect("a silent module does not stop the start");
    let mut engine = ScanEngine::new(plc).run_for(Duration::from_millis(500));
    engine.run();
    let trace = tap.0.lock().unwrap().clone();
    let all = trace.join("\n");
    let position = |needle: &str| {
        trace
            .iter()
            .position(|l| l.contains(needle))
            .unwrap_or_else(|| panic!("no {needle:?} in\n{all}"))
    };
    // The late reply: a timeout, then its bytes flushed after the guard time.
    let timeout = position("--  timeout: no reply within 0.050000s");
    assert!(trace[timeout - 1].contains("TX  01 "), "{all}");
    assert!(
        trace[timeout + 1].contains("--  discarded ")
            && trace[timeout + 1].contains("came late, flushed after the guard time"),
        "{all}"
    );
    // The corrupted reply: its flipped bit made the byte count 9, so the bus owner waited for
    // more and gave up on silence; the trace shows the bytes and their bad CRC.
    let crc = position("CRC bad (computed");
    assert_eq!(
        trace[crc],
        "t=0.776744s  line1  RX  01 01 09 00 51 88  | rtu unit 1 FC 1: CRC bad (computed \
         0x4856, frame carries 0x8851) (cut: then silence)",
        "{all}"
    );
    // mm2 never answers: its requests time out.
    let mm2 = trace
        .iter()
        .enumerate()
        .filter(|(_, l)| l.contains("TX  02 "))
        .filter(|(i, _)| trace.get(i + 1).is_some_and(|n| n.contains("timeout")))
        .count();
    assert!(mm2 >= 2, "{all}");
}

#[test]
fn on_the_real_clock_the_trace_comes_from_the_bus_threads_before_the_summary() {
    let out = Command::new(env!("CARGO_BIN_EXE_softplc"))
        .arg("run")
        .arg(quickstart())
        .args(["--for", "500ms", "--trace-bus", "--no-control", "--quiet"])
        .output()
        .expect("softplc runs");
    let stdout = String::from_utf8(out.stdout).expect("utf-8");
    assert!(out.status.success(), "{stdout}");
    let lines: Vec<&str> = stdout.lines().collect();
    assert!(
        lines[0].contains("monotonic time since softplc started"),
        "{stdout}"
    );
    let summary = lines
        .iter()
        .position(|l| l.starts_with("stopped"))
        .unwrap_or_else(|| panic!("{stdout}"));
    let trace = &lines[1..summary];
    // The scan's cycles, and the safe state written at the end, on both modules.
    assert!(trace.iter().all(|l| l.starts_with("t=")), "{stdout}");
    let writes = |unit: &str| {
        trace
            .iter()
            .filter(|l| {
                l.contains(&format!("TX  {unit} 05 ")) || l.contains(&format!("TX  {unit} 0F "))
            })
            .count()
    };
    assert!(writes("01") >= 1 && writes("02") >= 1, "{stdout}");
    assert!(trace.iter().any(|l| l.contains("RX  02 02 ")), "{stdout}");
}

#[test]
fn a_wrong_echo_is_in_the_trace_after_its_request() {
    // The quick start on an adapter that hears itself (`echo: discard`), one echo corrupted.
    let path = quickstart();
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("    retries: 1\n", "    retries: 1\n    echo: discard\n");
    let project = softplc::project::parse_str(&text, &path).unwrap_or_else(|e| panic!("{e}"));
    let clock: Arc<dyn Clock> = Arc::new(VirtualClock::new());
    let probe = Plc::build(project.clone(), clock).expect("builds");
    let world = probe.world().unwrap().clone();
    drop(probe);
    world.lock().unwrap().corrupt_next_echoes(0, 1);
    let clock = Arc::new(VirtualClock::new());
    clock.advance_to(world.lock().unwrap().now().on_scan_clock());
    let tap = Arc::new(Recorder::default());
    let plc = Plc::build_traced(project, clock, Some(world), Some(tap.clone() as _))
        .expect("a bad echo does not stop the start");
    drop(plc);
    let trace = tap.0.lock().unwrap().clone();
    let all = trace.join("\n");
    let echo = trace
        .iter()
        .position(|l| l.contains("--  echo differs from the request at byte"))
        .unwrap_or_else(|| panic!("{all}"));
    assert!(
        trace[echo - 1].contains("  TX  01 01 00 A0 00 01 FD E8  "),
        "{all}"
    );
    // Retried, and answered.
    assert!(
        trace[echo + 1..]
            .iter()
            .take(3)
            .any(|l| l.contains("  RX  01 01 ")),
        "{all}"
    );
}
