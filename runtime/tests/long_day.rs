//! A long day, on the real binary and the real clock, for a project of two tasks: two MiniMods
//! served by `softplc sim` on a pty (2 % of replies with a flipped bit, the line dead for 3 s
//! every minute from 20 s on, so the one minute CI runs has a death too), the fast task's
//! program copying mm1.X1 to mm2.Y1 every 50 ms, a slow task of 200 ms on a simulated line of
//! its own beside it, while the services are under attack the whole time: 16 clients
//! hold every Modbus TCP slot and another reconnects without pause, 24 slow clients sit on
//! the metrics port, 16 event streams on the page are never read. Every second X1 is flipped;
//! once the line has been alive for 5 s, Y1 must follow within 1.5 s (a wrong value is one
//! that does not). Every 5 s a scrape and the page must answer within 3 s. At the end the
//! cycles of each task are counted against the time.
//!
//! Ten minutes by default: `cargo test -p softplc --test integration long_day:: -- --ignored` (it is left
//! out of the ordinary run for its length; `SOFTPLC_LONG_DAY_SECS` shortens or lengthens it).
//! The last result is in docs/robustness.md.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::Path;
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::common::host::http_get;
use crate::common::sim;

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
/// The fast task's period (it owns the line under test) and the slow task's.
const PERIOD_MS: u64 = 50;
const PANEL_PERIOD_MS: u64 = 200;

fn log_value(log: &Path, prefix: &str) -> String {
    let begin = Instant::now();
    loop {
        let text = std::fs::read_to_string(log).unwrap_or_default();
        if let Some(v) = text.lines().find_map(|l| l.split(prefix).nth(1)).map(|r| {
            r.split(['/', ' ', ','])
                .next()
                .unwrap_or_default()
                .to_owned()
        }) {
            return v;
        }
        assert!(
            begin.elapsed() < Duration::from_secs(30),
            "no {prefix:?}:\n{text}"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
}

/// Sleeps `d`, or less once `stop` is set.
fn pause(stop: &AtomicBool, d: Duration) {
    let end = Instant::now() + d;
    while Instant::now() < end && !stop.load(Ordering::Relaxed) {
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Runs `attack` on a thread until `stop`.
fn attacker(
    stop: &Arc<AtomicBool>,
    attack: impl Fn() + Send + 'static,
) -> std::thread::JoinHandle<()> {
    let stop = stop.clone();
    std::thread::spawn(move || {
        while !stop.load(Ordering::Relaxed) {
            attack();
        }
    })
}

#[test]
#[ignore = "ten minutes of real time: run it with --ignored; CI runs one minute of it"]
fn a_long_day_under_attack_and_line_faults_keeps_the_scan_and_the_outputs_right() {
    let secs: u64 = std::env::var("SOFTPLC_LONG_DAY_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(600);
    let (mut sim, pty) = sim::Sim::start(BIN, &["minimod@1", "minimod@2"]);
    let dir = std::env::temp_dir().join(format!("softplc-long-day-{}", std::process::id()));
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
    std::fs::create_dir_all(&dir).unwrap();
    std::fs::write(dir.join("follow.expr"), "lamp = button\n").unwrap();
    std::fs::write(dir.join("panel.expr"), "key_lamp = key\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(
        &project,
        format!(
            "project: longday\n\
             tasks:\n  - {{ name: line, period: {PERIOD_MS}ms, program: {{ file: follow.expr, kind: expr }}, buses: [line1] }}\n  \
             - {{ name: panel, period: {PANEL_PERIOD_MS}ms, program: {{ file: panel.expr, kind: expr }}, buses: [panel_line] }}\n\
             buses:\n  - {{ name: line1, port: {pty}, baud: 19200, format: 8E1, response_timeout: 50ms, retries: 1 }}\n  \
             - {{ name: panel_line, port: sim, baud: 19200, response_timeout: 50ms }}\n\
             modules:\n  - {{ name: mm1, bus: line1, model: minimod, address: 1, settings: {{ events: false }} }}\n  - {{ name: mm2, bus: line1, model: minimod, address: 2, settings: {{ events: false }} }}\n  \
             - {{ name: keys, bus: panel_line, model: minimod, address: 1 }}\n\
             tags:\n  - {{ name: button, point: mm1.X1 }}\n  - {{ name: lamp, point: mm2.Y1, safe: false }}\n  \
             - {{ name: key, point: keys.X1 }}\n  - {{ name: key_lamp, point: keys.Y1, safe: false }}\n\
             service:\n  metrics: 127.0.0.1:0\n  modbus_tcp: {{ bind: 127.0.0.1:0 }}\n  web: {{ bind: 127.0.0.1:0 }}\n"
        ),
    )
    .unwrap();
    let log = dir.join("log");
    let socket = dir.join("ctl.sock");
    let mut plc = Command::new(BIN)
        // As the shipped unit runs it: the scan at real-time priority where the machine grants
        // it (best effort; the log says when refused).
        .args([
            "run",
            "--quiet",
            "--record",
            "10m",
            "--realtime-priority",
            "50",
            "--for",
        ])
        .arg(format!("{}s", secs + 30))
        .arg("--socket")
        .arg(&socket)
        .arg(&project)
        .env("RUST_LOG", "info")
        .stdout(Stdio::null())
        .stderr(std::fs::File::create(&log).unwrap())
        .spawn()
        .unwrap();
    let web = log_value(&log, "web page: http://");
    let metrics = log_value(&log, "metrics at http://");
    let modbus = log_value(&log, "Modbus TCP server on ");
    let begin = Instant::now();
    sim.send("fault all crc rate 0.02");

    let stop = Arc::new(AtomicBool::new(false));
    let refused = Arc::new(AtomicU64::new(0));
    let mut attackers = Vec::new();
    // Modbus TCP: every slot held, and a peer reconnecting without pause.
    let held: Vec<TcpStream> = (0..16)
        .filter_map(|_| TcpStream::connect(&modbus).ok())
        .collect();
    {
        let (addr, refused) = (modbus.clone(), refused.clone());
        attackers.push(attacker(&stop, move || {
            if let Ok(mut s) = TcpStream::connect(&addr) {
                drop(s.set_read_timeout(Some(Duration::from_secs(1))));
                let mut b = [0u8; 1];
                if matches!(s.read(&mut b), Ok(0) | Err(_)) {
                    refused.fetch_add(1, Ordering::Relaxed);
                }
            }
        }));
    }
    // Metrics: 24 slow clients, coming back as they are dropped.
    {
        let addr = metrics.clone();
        let stop_slow = stop.clone();
        attackers.push(attacker(&stop, move || {
            let slow: Vec<TcpStream> = (0..24)
                .filter_map(|_| {
                    let mut s = TcpStream::connect(&addr).ok()?;
                    s.write_all(b"GET /met").ok()?;
                    Some(s)
                })
                .collect();
            pause(&stop_slow, Duration::from_secs(4));
            drop(slow);
        }));
    }
    // The page: 16 event streams never read, opened again every 30 s.
    {
        let addr = web.clone();
        let stop_streams = stop.clone();
        attackers.push(attacker(&stop, move || {
            let streams: Vec<TcpStream> = (0..16)
                .filter_map(|_| {
                    let mut s = TcpStream::connect(&addr).ok()?;
                    write!(s, "GET /api/events HTTP/1.1\r\nHost: {addr}\r\n\r\n").ok()?;
                    Some(s)
                })
                .collect();
            pause(&stop_streams, Duration::from_secs(30));
            drop(streams);
        }));
    }

    let mut x1 = false;
    let mut checked = 0u64;
    let mut wrong = 0u64;
    let mut answers = 0u64;
    let mut slowest = Duration::ZERO;
    let mut line_alive_since = Instant::now();
    let mut next_death = Duration::from_secs(20);
    let mut deaths = 0u64;
    let mut last_probe = Instant::now();
    while begin.elapsed() < Duration::from_secs(secs) {
        if begin.elapsed() >= next_death {
            sim.send("line dead");
            std::thread::sleep(Duration::from_secs(3));
            sim.send("line alive");
            line_alive_since = Instant::now();
            next_death += Duration::from_secs(60);
            deaths += 1;
        }
        x1 = !x1;
        sim.send(&format!("set minimod@1.X1 {}", u8::from(x1)));
        let want = u8::from(x1).to_string();
        let followed = sim.wait_for("minimod@2.Y1", &want, Duration::from_millis(1500));
        if line_alive_since.elapsed() >= Duration::from_secs(5) {
            checked += 1;
            if followed.is_none() {
                wrong += 1;
                eprintln!("t={:?}: Y1 did not follow X1={want}", begin.elapsed());
            }
        }
        if last_probe.elapsed() >= Duration::from_secs(5) {
            last_probe = Instant::now();
            for (addr, path) in [(&metrics, "/metrics"), (&web, "/")] {
                let (status, took) = http_get(addr, path);
                assert_eq!(status, 200, "{path} at t={:?}", begin.elapsed());
                assert!(took < Duration::from_secs(3), "{path} took {took:?}");
                slowest = slowest.max(took);
                answers += 1;
            }
        }
        std::thread::sleep(Duration::from_millis(500));
    }
    let ran = begin.elapsed();
    let status = Command::new(BIN)
        .args(["status", "--json", "--socket"])
        .arg(&socket)
        .output()
        .unwrap();
    stop.store(true, Ordering::Relaxed);
    drop(held);
    let status: serde_json::Value = serde_json::from_slice(&status.stdout).unwrap();
    // The child may have exited already; then there is nothing to stop.
    drop(plc.kill());
    drop(plc.wait());
    let task = |i: usize, key: &str| status["tasks"][i][key].as_u64().unwrap();
    let (scans, overruns) = (task(0, "scans"), task(0, "overruns"));
    let (panel_scans, panel_overruns) = (task(1, "scans"), task(1, "overruns"));
    let expected = ran.as_millis() as u64 / PERIOD_MS;
    let panel_expected = ran.as_millis() as u64 / PANEL_PERIOD_MS;
    let text = std::fs::read_to_string(&log).unwrap();
    let refusal_lines = text
        .lines()
        .filter(|l| l.contains("clients connected"))
        .count();
    eprintln!(
        "long day: {ran:?}, task line {scans} scans (about {expected} due), {overruns} \
         overruns; task panel {panel_scans} scans (about {panel_expected} due), \
         {panel_overruns} overruns; \
         {deaths} line deaths; {checked} output checks, {wrong} wrong; {answers} page and scrape answers, slowest \
         {slowest:?}; {} refused Modbus TCP connections, {refusal_lines} log lines of them; \
         {} log lines in all",
        refused.load(Ordering::Relaxed),
        text.lines().count()
    );
    assert_eq!(
        wrong, 0,
        "outputs that did not follow once the line was back"
    );
    assert!(checked >= secs / 2, "{checked} checks");
    assert!(deaths >= secs / 60, "{deaths} line deaths in {secs} s");
    // Counted, and bounded generously: on a shared machine without real-time priority the
    // flood competes with the scan for the cores (the count and the overruns are reported).
    assert!(
        scans * 2 >= expected,
        "{scans} scans where {expected} were due"
    );
    assert!(
        panel_scans * 2 >= panel_expected,
        "{panel_scans} panel scans where {panel_expected} were due"
    );
    assert!(
        (refusal_lines as u64) <= 5 * (secs / 10 + 2),
        "{refusal_lines} refusal lines"
    );
    assert_eq!(
        status["services"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|s| s["state"] == "stopped")
            .count(),
        0,
        "{status}"
    );
    for a in attackers {
        drop(a.join());
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(dir));
}
