//! What the plant's clients see of the scan (issue #25), against third-party clients: Python
//! asyncua for OPC UA, and a Sparkplug host (paho-mqtt with Eclipse Tahu's
//! `sparkplug_b.proto`) through a real mosquitto, both in `runtime/tests/plant_view/client.py`.
//!
//! - An output no program writes, on a healthy module, is good: in `softplc status`, at the OPC
//!   UA client and in the Sparkplug host's view (its DBIRTH, and every DDATA after it); a
//!   profile point's `unit:` is its metric's `engUnit` in the DBIRTH.
//! - A memory tag the program steps every scan, at a 20 ms scan: the OPC UA client (sampling
//!   interval 0, queue 100, publishing every scan period) and the Sparkplug host each get
//!   every value, in order, none missing, and the PLC counts no change lost for either.
//! - A read straight after a `Good` OPC UA write returns the written value, every time.
//! - With `max_sessions: 3`, a fourth and fifth session are refused `BadTooManySessions`, and
//!   the log says so once.
//! - 50 starts of the node, one after the other, each on a broker started for it: every
//!   NDEATH a host sees comes after an NBIRTH (none from a connection dropped before its
//!   birth).
//! - With `primary_host:`, the node births only once the host's STATE says online, publishes
//!   NDEATH when it goes offline, births again (next bdSeq) when it is back, and ignores an
//!   offline STATE older than the last online one.
//! - A module lost behind a Modbus TCP gateway (the simulator killed): a subscription without a
//!   DataChangeFilter reports the tag's status change (OPC 10000-4 §7.22.2: STATUS_VALUE_1 is
//!   the default), and so does one asking for StatusValueTimestamp.
//!
//! `scripts/test` installs mosquitto and the Python environment (`target/py-venv`).

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::common::broker;
use crate::common::host;
use broker::{sparkplug_pb2, Broker};
use host::{free_port, lines_of, repo as workspace};

const BIN: &str = env!("CARGO_BIN_EXE_softplc");
const NAMESPACE: &str = "urn:softplc:plant_view";

fn python() -> PathBuf {
    let py = workspace().join("target/py-venv/bin/python");
    assert!(
        py.exists(),
        "{} is missing: run scripts/test, which creates it (asyncua, paho-mqtt, protobuf, \
         grpcio-tools)",
        py.display()
    );
    py
}

/// A fresh folder of this test.
fn scratch(name: &str) -> PathBuf {
    crate::common::host::scratch_dir("plant-view", name)
}

/// The ports of a run's services.
#[derive(Debug, Clone, Copy)]
struct Ports {
    opcua: u16,
    mqtt: u16,
}

/// The issue's project: `y1` bound to `mm1.Y1` and never written, `y2` written by the
/// program, and `counter`, a memory tag the program steps every scan.
fn project(dir: &Path, period_ms: u64, ports: Ports) -> PathBuf {
    project_with(dir, period_ms, ports, "", false)
}

/// [`project`] with `opcua_keys` added to its `opcua:` section, and with `meter` an SDM120
/// energy meter (`examples/profiles/sdm120.yaml`) on a 9600 Bd line of its own, its voltage
/// the tag `voltage`.
fn project_with(
    dir: &Path,
    period_ms: u64,
    ports: Ports,
    opcua_keys: &str,
    meter: bool,
) -> PathBuf {
    let (meter_bus, meter_module, meter_tag) = if meter {
        (
            "  - { name: line2, port: sim, baud: 9600, response_timeout: 100ms, retries: 1 }\n"
                .to_string(),
            format!(
                "  - {{ name: meter, bus: line2, model: \"profile:{}\", address: 3 }}\n",
                workspace().join("examples/profiles/sdm120.yaml").display()
            ),
            "  - { name: voltage, point: meter.voltage }\n",
        )
    } else {
        (String::new(), String::new(), "")
    };
    let program = dir.join("program.rhai");
    std::fs::write(&program, "y2 = true;\ncounter += 1;\n").unwrap();
    let text = format!(
        r#"project: plant_view
scan:
  period: {period_ms}ms
buses:
  - {{ name: line1, port: sim, baud: 57600, format: 8E1, response_timeout: 30ms, retries: 1 }}
{meter_bus}modules:
  - {{ name: mm1, bus: line1, model: minimod, address: 1 }}
{meter_module}tags:
  - {{ name: y1, point: mm1.Y1, safe: false }}
  - {{ name: y2, point: mm1.Y2, safe: false }}
{meter_tag}  - {{ name: counter, type: i32 }}
  - {{ name: setpoint, type: u16, scada: write }}
program: {{ file: {}, kind: rhai }}
service:
  opcua:
    port: {opcua}
    writes: true
{opcua_keys}  mqtt:
    host: 127.0.0.1
    port: {mqtt}
    group: plant1
    node: edge1
"#,
        program.display(),
        opcua = ports.opcua,
        mqtt = ports.mqtt,
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, text).unwrap();
    path
}

/// A running softplc, killed when dropped.
struct Plc {
    child: Child,
    socket: PathBuf,
    log: PathBuf,
}

impl Plc {
    fn start(dir: &Path, project: &Path) -> Self {
        let socket = dir.join("control.sock");
        let log = dir.join("softplc.log");
        let child = Command::new(BIN)
            .args(["run", "--quiet", "--for", "120s", "--socket"])
            .arg(&socket)
            .arg(project)
            .env("RUST_LOG", "info")
            .stdout(Stdio::null())
            .stderr(std::fs::File::create(&log).unwrap())
            .spawn()
            .unwrap();
        Self { child, socket, log }
    }

    fn log(&self) -> String {
        std::fs::read_to_string(&self.log).unwrap_or_default()
    }

    /// `softplc status --json`, once the control socket answers.
    fn status(&self) -> serde_json::Value {
        let deadline = Instant::now() + Duration::from_secs(20);
        loop {
            let out = Command::new(BIN)
                .args(["status", "--json", "--socket"])
                .arg(&self.socket)
                .output()
                .unwrap();
            if out.status.success() {
                return serde_json::from_slice(&out.stdout).unwrap();
            }
            assert!(
                Instant::now() < deadline,
                "status: {out:?}; log:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(100));
        }
    }

    /// A tag's quality in `softplc status`.
    fn tag_quality(&self, tag: &str) -> String {
        let status = self.status();
        status["tags"]
            .as_array()
            .unwrap()
            .iter()
            .find(|t| t["name"] == tag)
            .unwrap_or_else(|| panic!("{tag} in {status}"))["quality"]
            .as_str()
            .unwrap()
            .to_string()
    }

    /// Waits until the scan has run `n` cycles.
    fn wait_scans(&self, n: u64) {
        let deadline = Instant::now() + Duration::from_secs(30);
        while self.status()["scans"].as_u64().unwrap() < n {
            assert!(
                Instant::now() < deadline,
                "no {n} scans; log:\n{}",
                self.log()
            );
            std::thread::sleep(Duration::from_millis(50));
        }
    }
}

impl Drop for Plc {
    fn drop(&mut self) {
        // The child may have exited already; then there is nothing to stop.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

/// Runs the client in `mode` with `args`; the lines it printed before DONE (a FAIL panics with
/// softplc's log, at `log`).
fn client(log: &Path, mode: &str, args: &[String], within: Duration) -> Vec<String> {
    client_doing(log, mode, args, within, |need| {
        panic!("client asks for {need}")
    })
}

/// [`client`], doing what the client asks for (`NEED action`) with `act`, then telling it.
fn client_doing(
    log: &Path,
    mode: &str,
    args: &[String],
    within: Duration,
    mut act: impl FnMut(&str),
) -> Vec<String> {
    let log = || std::fs::read_to_string(log).unwrap_or_default();
    let mut child = Command::new(python())
        .arg(workspace().join("runtime/tests/plant_view/client.py"))
        .arg(mode)
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit())
        .spawn()
        .unwrap();
    let mut to_client = child.stdin.take().unwrap();
    let lines = lines_of(child.stdout.take().unwrap());
    let deadline = Instant::now() + within;
    let mut out = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let Ok(line) = lines.recv_timeout(left) else {
            // The child may have exited already; then there is nothing to stop.
            drop(child.kill());
            panic!("client {mode}: no DONE after {out:?}; log:\n{}", log());
        };
        eprintln!("client {mode}: {line}");
        if line == "DONE" {
            break;
        }
        assert!(
            !line.starts_with("FAIL"),
            "client {mode}: {line}; log:\n{}",
            log()
        );
        if let Some(need) = line.strip_prefix("NEED ") {
            act(need);
            writeln!(to_client, "done").unwrap();
            continue;
        }
        out.push(line);
    }
    assert!(child.wait().unwrap().success());
    out
}

/// The value of `KEY tag value` lines.
fn keyed<'a>(lines: &'a [String], key: &str, tag: &str) -> Option<&'a str> {
    let prefix = format!("{key} {tag} ");
    lines.iter().find_map(|l| l.strip_prefix(&prefix))
}

#[test]
fn an_output_no_program_writes_is_good_in_status_at_an_opcua_client_and_at_a_sparkplug_host() {
    let dir = scratch("quality");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let _broker = Broker::start(&dir, ports.mqtt);
    let pb2 = sparkplug_pb2(&python(), &dir);
    let project = project_with(&dir, 50, ports, "", true);
    let plc = Plc::start(&dir, &project);
    // Before the module has acknowledged its outputs nobody can say they hold: the birth may
    // show that, so the host is listening from the start and its view is taken at the end.
    let host_args: Vec<String> = [
        ports.mqtt.to_string(),
        "plant1".into(),
        "edge1".into(),
        pb2.display().to_string(),
        "y1".into(),
        "y2".into(),
        "voltage".into(),
    ]
    .into();
    let host = {
        let log = plc.log.clone();
        std::thread::spawn(move || {
            client(
                &log,
                "sparkplug-quality",
                &host_args,
                Duration::from_secs(40),
            )
        })
    };
    plc.wait_scans(20);
    assert_eq!(plc.tag_quality("y1"), "good", "y1 in softplc status");
    assert_eq!(plc.tag_quality("y2"), "good", "y2 in softplc status");
    let module = &plc.status()["modules"][0];
    assert_eq!(module["quality"], "good", "{module}");
    assert_eq!(module["outputs"], "good", "{module}");

    let seen = client(
        &plc.log,
        "opcua-quality",
        &[
            format!("opc.tcp://127.0.0.1:{}/", ports.opcua),
            NAMESPACE.into(),
            "y1".into(),
            "y2".into(),
        ],
        Duration::from_secs(40),
    );
    assert_eq!(keyed(&seen, "QUALITY", "y1"), Some("Good"), "{seen:?}");
    assert_eq!(keyed(&seen, "QUALITY", "y2"), Some("Good"), "{seen:?}");

    let seen = host.join().unwrap();
    assert_eq!(
        keyed(&seen, "QUALITY", "y1"),
        Some("192"),
        "y1 as the Sparkplug host holds it: {seen:?}"
    );
    assert_eq!(keyed(&seen, "QUALITY", "y2"), Some("192"), "{seen:?}");
    // A profile point's unit is the metric's engUnit in its DBIRTH.
    assert_eq!(keyed(&seen, "ENGUNIT", "voltage"), Some("V"), "{seen:?}");
    assert_eq!(keyed(&seen, "ENGUNIT", "y1"), None, "{seen:?}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

/// `COUNT received first last missing extra` of a counting client, as numbers.
fn counted(lines: &[String]) -> [i64; 5] {
    let line = lines
        .iter()
        .find_map(|l| l.strip_prefix("COUNT "))
        .unwrap_or_else(|| panic!("no COUNT in {lines:?}"));
    let n: Vec<i64> = line.split(' ').map(|x| x.parse().unwrap()).collect();
    [n[0], n[1], n[2], n[3], n[4]]
}

#[test]
fn every_step_of_a_counter_at_a_20_ms_scan_reaches_an_opcua_client_and_a_sparkplug_host() {
    let dir = scratch("every-change");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let _broker = Broker::start(&dir, ports.mqtt);
    let pb2 = sparkplug_pb2(&python(), &dir);
    let project = project(&dir, 20, ports);
    let plc = Plc::start(&dir, &project);
    plc.wait_scans(10);
    let seconds = "6";
    let host = {
        let log = plc.log.clone();
        let args: Vec<String> = [
            ports.mqtt.to_string(),
            "plant1".into(),
            "edge1".into(),
            pb2.display().to_string(),
            "counter".into(),
            seconds.into(),
        ]
        .into();
        std::thread::spawn(move || client(&log, "sparkplug-count", &args, Duration::from_secs(60)))
    };
    let opcua = client(
        &plc.log,
        "opcua-count",
        &[
            format!("opc.tcp://127.0.0.1:{}/", ports.opcua),
            NAMESPACE.into(),
            "counter".into(),
            "20".into(),
            seconds.into(),
        ],
        Duration::from_secs(60),
    );
    let sparkplug = host.join().unwrap();
    // Each client saw a run of the counter: every value from its first to its last, once.
    let [received, first, last, missing, overflowed] = counted(&opcua);
    assert_eq!(missing, 0, "OPC UA: {opcua:?}");
    assert_eq!(overflowed, 0, "OPC UA: {opcua:?}");
    assert_eq!(received, last - first + 1, "OPC UA: {opcua:?}");
    // Six seconds at 20 ms is 300 scans; a loaded machine runs fewer, never none.
    assert!(received >= 50, "OPC UA: {opcua:?}");
    let [received, first, last, missing, out_of_order] = counted(&sparkplug);
    assert_eq!((missing, out_of_order), (0, 0), "Sparkplug: {sparkplug:?}");
    assert_eq!(received, last - first + 1, "Sparkplug: {sparkplug:?}");
    assert!(received >= 50, "Sparkplug: {sparkplug:?}");
    // The PLC lost none for either service, and says so.
    let status = plc.status();
    let lost = status["lost_changes"].as_array().unwrap();
    let services: Vec<&str> = lost
        .iter()
        .map(|l| l["service"].as_str().unwrap())
        .collect();
    // In the order they took the feed: the alarms (which OPC UA publishes) and OPC UA start
    // before the modules' start-up, MQTT after.
    assert_eq!(services, ["alarms", "opcua", "mqtt"], "{status}");
    assert!(lost.iter().all(|l| l["lost"] == 0), "{status}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_subscription_without_a_filter_reports_a_module_lost_behind_a_gateway() {
    let dir = scratch("status");
    let mut sim = Command::new(BIN)
        .args(["sim", "--tcp", "127.0.0.1:0", "minimod@1"])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let _sim_stdin = sim.stdin.take().unwrap();
    let said = lines_of(sim.stdout.take().unwrap());
    let first = said.recv_timeout(Duration::from_secs(10)).unwrap();
    let url = first
        .split_whitespace()
        .find(|w| w.starts_with("tcp://127.0.0.1:"))
        .unwrap_or_else(|| panic!("{first}"))
        .to_string();
    let opcua = free_port();
    let program = dir.join("program.expr");
    std::fs::write(&program, "y1 = x1\n").unwrap();
    let project = dir.join("project.yaml");
    std::fs::write(
        &project,
        format!(
            "project: plant_view\nscan: {{ period: 50ms }}\nbuses:\n  - {{ name: gw, port: \"{url}\", \
             response_timeout: 100ms, retries: 0 }}\nmodules:\n  - {{ name: mm1, bus: gw, model: \
             minimod, address: 1 }}\ntags:\n  - {{ name: x1, point: mm1.X1 }}\n  - {{ name: y1, \
             point: mm1.Y1, safe: false }}\nprogram: {{ file: {}, kind: expr }}\nservice:\n  \
             opcua:\n    port: {opcua}\n",
            program.display()
        ),
    )
    .unwrap();
    let plc = Plc::start(&dir, &project);
    let seen = client_doing(
        &plc.log,
        "opcua-status",
        &[
            format!("opc.tcp://127.0.0.1:{opcua}/"),
            NAMESPACE.into(),
            "x1".into(),
        ],
        Duration::from_secs(90),
        |need| {
            assert_eq!(need, "kill");
            // The simulator may have exited already; then there is nothing to stop.
            drop(sim.kill());
            drop(sim.wait());
        },
    );
    let lost = ["UncertainLastUsableValue", "BadCommunicationError"];
    for subscription in ["filterless", "timestamp"] {
        let status = keyed(&seen, "STATUS", subscription).unwrap_or("none");
        assert!(
            lost.contains(&status),
            "{subscription}: {status} after the module was lost: {seen:?}"
        );
    }
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn a_read_after_a_good_opcua_write_returns_the_written_value() {
    let dir = scratch("read-after-write");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let _broker = Broker::start(&dir, ports.mqtt);
    let project = project(&dir, 50, ports);
    let plc = Plc::start(&dir, &project);
    plc.wait_scans(5);
    let seen = client(
        &plc.log,
        "opcua-write-read",
        &[
            format!("opc.tcp://127.0.0.1:{}/", ports.opcua),
            NAMESPACE.into(),
            "setpoint".into(),
            "30".into(),
        ],
        Duration::from_secs(60),
    );
    assert!(seen.contains(&"WRITES 30 old 0".to_string()), "{seen:?}");
    assert_eq!(plc.tag_quality("setpoint"), "good");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn sessions_beyond_max_sessions_are_refused_and_logged_once() {
    let dir = scratch("sessions");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let _broker = Broker::start(&dir, ports.mqtt);
    let project = project_with(&dir, 50, ports, "    max_sessions: 3\n", false);
    let plc = Plc::start(&dir, &project);
    plc.wait_scans(5);
    let seen = client(
        &plc.log,
        "opcua-sessions",
        &[format!("opc.tcp://127.0.0.1:{}/", ports.opcua), "5".into()],
        Duration::from_secs(60),
    );
    assert!(
        seen.contains(&"SESSIONS ok 3 refused 2".to_string()),
        "{seen:?}"
    );
    let log = plc.log();
    let lines: Vec<&str> = log
        .lines()
        .filter(|l| l.contains("OPC UA: session refused (BadTooManySessions)"))
        .collect();
    assert_eq!(lines.len(), 1, "{log}");
    assert!(lines[0].contains("the limit is 3 (max_sessions)"), "{log}");
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn fifty_starts_on_a_fresh_broker_never_show_a_death_before_the_birth() {
    const RUNS: usize = 50;
    let dir = scratch("starts");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let pb2 = sparkplug_pb2(&python(), &dir);
    let project = project(&dir, 50, ports);
    // Without the OPC UA server: only the edge node's start is under test.
    let text = std::fs::read_to_string(&project).unwrap();
    let start = text.find("  opcua:").unwrap();
    let end = text.find("  mqtt:").unwrap();
    std::fs::write(&project, format!("{}{}", &text[..start], &text[end..])).unwrap();
    let log = dir.join("softplc.log");
    let mut broker = Broker::start(&dir, ports.mqtt);
    let seen = client_doing(
        &log,
        "sparkplug-order",
        &[
            ports.mqtt.to_string(),
            "plant1".into(),
            "edge1".into(),
            pb2.display().to_string(),
            RUNS.to_string(),
        ],
        Duration::from_secs(300),
        |need| {
            // One start a time: the client asks for the next once it saw this one's NDEATH.
            assert_eq!(need, "run");
            // A fresh broker for each start (the host reconnects within 200 ms and subscribes
            // again).
            broker.restart_after(|| {});
            std::thread::sleep(Duration::from_millis(800));
            let out = Command::new(BIN)
                .args(["run", "--quiet", "--no-socket", "--for", "300ms"])
                .arg(&project)
                .env("RUST_LOG", "info")
                .stdout(Stdio::null())
                .stderr(std::fs::File::create(&log).unwrap())
                .status()
                .unwrap();
            assert!(out.success(), "{}", std::fs::read_to_string(&log).unwrap());
        },
    );
    assert!(
        seen.contains(&format!("ORDER births {RUNS} deaths {RUNS} early 0")),
        "{seen:?}"
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}

#[test]
fn with_a_primary_host_the_node_births_only_while_the_host_is_online() {
    let dir = scratch("primary-host");
    let ports = Ports {
        opcua: free_port(),
        mqtt: free_port(),
    };
    let _broker = Broker::start(&dir, ports.mqtt);
    let pb2 = sparkplug_pb2(&python(), &dir);
    let project = project(&dir, 50, ports);
    let text = std::fs::read_to_string(&project).unwrap();
    std::fs::write(
        &project,
        text.replace(
            "    node: edge1\n",
            "    node: edge1\n    primary_host: scada1\n",
        ),
    )
    .unwrap();
    let mut plc = None;
    let log = dir.join("softplc.log");
    let seen = client_doing(
        &log,
        "sparkplug-state",
        &[
            ports.mqtt.to_string(),
            "plant1".into(),
            "edge1".into(),
            pb2.display().to_string(),
            "scada1".into(),
        ],
        Duration::from_secs(90),
        |need| {
            assert_eq!(need, "start");
            plc = Some(Plc::start(&dir, &project));
        },
    );
    let plc = plc.expect("started");
    let said = |key: &str| {
        seen.iter()
            .find_map(|l| l.strip_prefix(key))
            .unwrap_or_else(|| panic!("no {key} in {seen:?}"))
            .trim()
            .to_string()
    };
    assert_eq!(said("BEFORE births"), "0", "{seen:?}");
    let first: u64 = said("ONLINE birth").parse().unwrap();
    assert_eq!(said("OFFLINE death"), first.to_string(), "{seen:?}");
    let back: u64 = said("BACK birth").parse().unwrap();
    assert_eq!(back, first + 1, "a new session, the next bdSeq: {seen:?}");
    assert_eq!(said("STALE deaths"), "0", "{seen:?}");
    assert!(
        plc.log().contains("MQTT: primary host offline"),
        "{}",
        plc.log()
    );
    // Best effort: the test's scratch folder (it may not exist).
    drop(std::fs::remove_dir_all(&dir));
}
