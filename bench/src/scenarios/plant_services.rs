//! Scenario 11: the plant services. What a SCADA or a historian behind an MQTT broker sees of
//! the machine, and what the edge node costs the PLC.
//!
//! - **Latency**: `softplc sim --pty minimod@1` serves a MiniMod on a pty (reply delay 0, input
//!   filter X1 1 ms, both set by the driver at start-up); `softplc run` scans it every 10 ms
//!   and is a Sparkplug B edge node on a mosquitto started here on 127.0.0.1. The harness
//!   flips X1 at the simulator's terminal (its console) at pseudo-random times and a
//!   subscriber of its own (rumqttc, the DDATA decoded with the same `sparkplug_b.proto`)
//!   timestamps the DDATA that carries the new value: terminal → broker → consumer.
//! - **CPU**: a memory-only project of 1,000 bool tags, each toggled every 100 ms cycle (10,000
//!   metric changes per second), run with and without the edge node; the softplc process's
//!   CPU time per second of run (`/proc/PID/stat` utime + stime) in both, side by side; and
//!   once more with the OPC UA server instead, an asyncua client subscribed to every tag.
//! - **Lateness**: 100 bool tags toggled every 10 ms cycle, run without services and with OPC
//!   UA + MQTT under a client load (asyncua subscribed to every tag and reading them all in a
//!   loop, the harness's MQTT subscriber); the scan's wake-up lateness as the scan records it,
//!   from `softplc status --json` on the run's control socket, the second as a ratio to the
//!   first.
//!
//! Without `mosquitto` on the machine (`bench/setup` installs it) the rows say so.

use std::collections::HashMap;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use prost::Message;
use softplc::scan::{DurationHistogram, Percentiles};
use softplc::service::mqtt::spb;
use softplc::service::StatusReport;

use super::plant_kit::{
    clock_tick, cpu_ticks, free_port, from_micros, scratch, Broker, Running, WINDOW_S,
};
use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::softplc_sim::{softplc_binary, ServedSim};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 11,
    name: "plant-services",
    title: "Plant services: terminal → MQTT consumer and OPC UA client, their CPU cost, the scan's lateness",
    summary: "Latency: one MiniMod served by `softplc sim --pty` (reply delay 0, X1 input filter \
              1 ms), scanned every 10 ms at 19200 8E1 by `softplc run`, a Sparkplug B edge node on \
              a local mosquitto, and an OPC UA server; X1 flipped at the simulator's console at random \
              times, the harness's own MQTT subscriber timestamps the DDATA with the new value, \
              and an asyncua client (bench/py/opcua_watch.py) its data-change notification \
              (includes the filter, the wait for the next input phase, the scan, the publish, \
              the broker or the server's publishing interval of 10 ms, and the client). CPU: 1,000 bool memory tags toggled every 100 ms cycle, \
              the softplc process's CPU time per second of run, without services, with the edge node, and \
              with the OPC UA server and an asyncua client subscribed to every tag. Lateness: 100 \
              bool tags toggled every 10 ms cycle, the scan's wake-up lateness (`softplc status \
              --json`) without services and with both under a client load (asyncua subscribed to \
              every tag and reading them all in a loop, an MQTT subscriber).",
    run,
};

const PERIOD: Duration = Duration::from_millis(10);
/// One read of the MiniMod's inputs on the pty: FC 2 request and reply at 19200 8E1 (8 + 6
/// characters of 11 bits) with reply delay 0, as the simulator paces it.
const BUS_CYCLE: Duration = Duration::from_micros(8_021);
const GROUP: &str = "bench";
/// Tags of the CPU case, each toggled every cycle.
const TAGS: usize = 1000;
const NODE: &str = "n1";

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    if Command::new("mosquitto").arg("-h").output().is_err() {
        let why = "mosquitto is not installed (bench/setup installs it)";
        out.rows
            .push(Row::unavailable("terminal → MQTT consumer", "latency", why));
        out.rows.push(Row::unavailable(
            "1,000 tags via MQTT",
            "CPU per second",
            why,
        ));
        return Ok(out);
    }
    let binary = softplc_binary()?;
    match latency(ctx, &binary) {
        Ok(l) => {
            let mut series = Vec::new();
            for (case, hist, label) in [
                (
                    "terminal → MQTT consumer",
                    Ok(l.mqtt),
                    "MQTT: DDATA at a subscriber (mosquitto)",
                ),
                (
                    "terminal → OPC UA client",
                    l.opcua,
                    "OPC UA: data-change notification at asyncua",
                ),
            ] {
                match hist {
                    Ok(hist) => {
                        let p = hist.percentiles();
                        out.rows.push(
                            Row::measured(case, "latency", p)
                                .bound(Bound::fixed("scan period", PERIOD))
                                .bound(Bound::fixed("scan period + bus cycle", PERIOD + BUS_CYCLE))
                                .note(format!(
                                    "{} flips; a change waits up to one scan period for the next \
                                     input phase",
                                    p.count
                                )),
                        );
                        series.push(Series {
                            label: label.into(),
                            hist,
                        });
                    }
                    Err(why) => out.rows.push(Row::unavailable(case, "latency", why)),
                }
            }
            out.plots.push(Plot {
                file: "plant-latency.svg".into(),
                title: "Input change at the terminal → plant client (10 ms scan)".into(),
                x_label: "latency".into(),
                kind: PlotKind::Cdf { log_x: false },
                series,
            });
        }
        Err(e) => out.rows.push(Row::unavailable(
            "terminal → MQTT consumer",
            "latency",
            format!("{e:#}"),
        )),
    }
    match cpu(ctx, &binary) {
        Ok(f) => {
            let (w, wo) = (f.with.percentiles(), f.without.percentiles());
            let extra_ms = (w.p50.as_secs_f64() - wo.p50.as_secs_f64()) * 1e3;
            let rate = f64::from(u32::try_from(TAGS).unwrap_or(u32::MAX)) * 10.0;
            let delivered = median(&f.delivered);
            let bytes = median(&f.bytes);
            out.rows.push(
                Row::measured("1,000 tags, no edge node", "CPU per second", wo)
                    .note("baseline: the same scan without the MQTT service"),
            );
            out.rows.push(
                Row::measured("1,000 tags via MQTT", "CPU per second", w)
                    .bound(Bound::baseline("no edge node", &wo))
                    .value("extra_cpu_ms_per_s", extra_ms)
                    .value("changes_per_s", rate)
                    .note(format!(
                        "the edge node: {extra_ms:.1} ms of CPU per second at p50 for {rate:.0} \
                         metric changes/s ({:.2} µs per change)",
                        extra_ms * 1e3 / rate
                    )),
            );
            match &f.opcua {
                Ok(hist) => {
                    let ua = hist.percentiles();
                    let extra_ms = (ua.p50.as_secs_f64() - wo.p50.as_secs_f64()) * 1e3;
                    out.rows.push(
                        Row::measured("1,000 tags via OPC UA", "CPU per second", ua)
                            .bound(Bound::baseline("no services", &wo))
                            .value("extra_cpu_ms_per_s", extra_ms)
                            .note(format!(
                                "the OPC UA server with one asyncua client subscribed to every \
                                 tag (publishing interval 10 ms): {extra_ms:.1} ms of CPU per \
                                 second at p50 for {rate:.0} value changes/s"
                            )),
                    );
                }
                Err(why) => out.rows.push(Row::unavailable(
                    "1,000 tags via OPC UA",
                    "CPU per second",
                    why.clone(),
                )),
            }
            out.rows.push(
                Row::measured(
                    "mosquitto, same run",
                    "CPU per second",
                    f.broker.percentiles(),
                )
                .value("delivered_changes_per_s", delivered)
                .value("ndata_bytes_per_s", bytes)
                .note(format!(
                    "one local broker forwarding to one subscriber; the subscriber got \
                     {delivered:.0} metric changes/s at the median (of {rate:.0} published), \
                     {:.0} kB/s of NDATA payload ({:.1} B per change)",
                    bytes / 1e3,
                    if delivered > 0.0 {
                        bytes / delivered
                    } else {
                        0.0
                    }
                )),
            );
        }
        Err(e) => out.rows.push(Row::unavailable(
            "1,000 tags via MQTT",
            "CPU per second",
            format!("{e:#}"),
        )),
    }
    match lateness(ctx, &binary) {
        Ok(l) => {
            out.rows.push(
                Row::measured("no services", "wake-up lateness", l.without).note(format!(
                    "baseline: {LOAD_TAGS} bool tags toggled every 10 ms cycle"
                )),
            );
            out.rows.push(
                Row::measured(
                    "OPC UA + MQTT under a client load",
                    "wake-up lateness",
                    l.with,
                )
                .bound(Bound::baseline("no services", &l.without))
                .note(format!(
                    "same project with both services; an asyncua client subscribed to every \
                         tag and reading them all in a loop ({} reads), the harness's MQTT \
                         subscriber ({} DDATA/NDATA messages)",
                    l.reads, l.messages
                )),
            );
        }
        Err(e) => out.rows.push(Row::unavailable(
            "OPC UA + MQTT under a client load",
            "wake-up lateness",
            format!("{e:#}"),
        )),
    }
    Ok(out)
}

/// Tags of the lateness case, each toggled every 10 ms cycle.
const LOAD_TAGS: usize = 100;

/// The lateness case's figures.
struct LatenessFigures {
    without: Percentiles,
    with: Percentiles,
    /// Read passes the asyncua client made over every tag.
    reads: u64,
    /// DATA messages the MQTT subscriber received.
    messages: usize,
}

/// The scan's wake-up lateness of a 10 ms project of [`LOAD_TAGS`] toggled tags, as the scan
/// records it (`softplc status --json` on its control socket at the end of the run), without
/// services and with OPC UA + MQTT under a client load.
fn lateness(ctx: &Ctx, binary: &Path) -> anyhow::Result<LatenessFigures> {
    let dir = scratch(ctx, "plant-lateness")?;
    let broker = Broker::start(&dir)?;
    let base = toggle_project(&dir, "plant_load", "10ms", LOAD_TAGS)?;
    let without = dir.join("without.yaml");
    std::fs::write(&without, &base)?;
    let opcua_port = free_port()?;
    let with = dir.join("with.yaml");
    std::fs::write(
        &with,
        format!(
            "{base}{}  opcua: {{ port: {opcua_port} }}\n",
            mqtt_section(broker.port)
        ),
    )?;
    let rx = subscribe(broker.port)?;
    let seconds = if ctx.quick { 5 } else { 30 };
    let socket = dir.join("control.sock");
    let (without, _) = scan_lateness(binary, &without, &socket, seconds, || Ok(None))?;
    let (with, reads) = scan_lateness(binary, &with, &socket, seconds, || {
        OpcUaLoad::start(opcua_port, "plant_load", LOAD_TAGS, true).map(Some)
    })?;
    let messages = rx
        .try_iter()
        .filter(|(_, topic, _, _)| topic.contains("DATA/"))
        .count();
    drop(broker);
    Ok(LatenessFigures {
        without,
        with,
        reads,
        messages,
    })
}

/// Runs `project` with its control socket at `socket`, `client` started once it is up, for
/// `seconds`; the scan's lateness from `softplc status --json` just before the end, and the
/// read passes the client made.
fn scan_lateness(
    binary: &Path,
    project: &Path,
    socket: &Path,
    seconds: u32,
    client: impl FnOnce() -> Result<Option<OpcUaLoad>, String>,
) -> anyhow::Result<(Percentiles, u64)> {
    let run_for = Duration::from_secs(u64::from(seconds) + 50);
    let plc = Running::start_with(binary, project, run_for, Some(socket))?;
    std::thread::sleep(Duration::from_secs(1));
    let client = client()
        .map_err(anyhow::Error::msg)
        .with_context(|| format!("softplc said: {}", plc.said()))?;
    std::thread::sleep(Duration::from_secs(u64::from(seconds)));
    let out = Command::new(binary)
        .args(["status", "--json", "--socket"])
        .arg(socket)
        .output()
        .context("cannot run softplc status")?;
    if !out.status.success() {
        bail!(
            "softplc status failed: {}; softplc said: {}",
            String::from_utf8_lossy(&out.stderr).trim(),
            plc.said()
        );
    }
    let report: StatusReport =
        serde_json::from_slice(&out.stdout).context("unreadable softplc status --json")?;
    let p = from_micros(&report.lateness);
    // The client stops while the server still runs, so it can say what it did.
    Ok((p, client.map_or(0, OpcUaLoad::finish)))
}

/// A memory-only project `name` of `tags` bool tags `b0..`, each toggled every cycle of
/// `period` by `toggle.expr` (written into `dir`); its text, without a service section.
fn toggle_project(dir: &Path, name: &str, period: &str, tags: usize) -> anyhow::Result<String> {
    let program: String = (0..tags).map(|i| format!("b{i} = !b{i}\n")).collect();
    std::fs::write(dir.join("toggle.expr"), program)?;
    let tags: String = (0..tags)
        .map(|i| format!("  - {{ name: b{i}, type: bool }}\n"))
        .collect();
    Ok(format!(
        "project: {name}\nscan: {{ period: {period} }}\ntags:\n{tags}program: {{ file: toggle.expr, kind: expr }}\n"
    ))
}

fn opcua_section(port: u16) -> String {
    format!("service:\n  opcua: {{ port: {port} }}\n")
}

fn mqtt_section(port: u16) -> String {
    format!("service:\n  mqtt: {{ host: 127.0.0.1, port: {port}, group: {GROUP}, node: {NODE} }}\n")
}

/// What the harness's subscriber got: arrival, topic, booleans by metric name, payload bytes.
type Received = (Instant, String, Vec<(String, bool)>, usize);

/// A subscriber of the harness on `GROUP`/`NODE`: every DATA message, with metric names taken
/// from the BIRTH aliases (Sparkplug aliases are unique within an edge node).
fn subscribe(port: u16) -> anyhow::Result<mpsc::Receiver<Received>> {
    let mut opts = rumqttc::MqttOptions::new("softplc-bench", "127.0.0.1", port);
    opts.set_keep_alive(Duration::from_secs(30));
    opts.set_max_packet_size(1 << 20, 1 << 20);
    let (client, mut connection) = rumqttc::Client::new(opts, 64);
    client.subscribe(
        format!("spBv1.0/{GROUP}/+/{NODE}"),
        rumqttc::QoS::AtMostOnce,
    )?;
    client.subscribe(
        format!("spBv1.0/{GROUP}/+/{NODE}/+"),
        rumqttc::QoS::AtMostOnce,
    )?;
    let (tx, rx) = mpsc::channel();
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::spawn(move || {
        // The client lives as long as the connection is read.
        let _client = client;
        let mut names: HashMap<u64, String> = HashMap::new();
        let mut acked = 0;
        for event in connection.iter() {
            let packet = match event {
                Ok(rumqttc::Event::Incoming(packet)) => packet,
                Ok(_) => continue,
                Err(_) => break,
            };
            match packet {
                rumqttc::Packet::SubAck(_) => {
                    acked += 1;
                    if acked == 2 {
                        // The harness may have given up waiting; nobody to tell then.
                        ready_tx.send(()).ok();
                    }
                }
                rumqttc::Packet::Publish(p) => {
                    let at = Instant::now();
                    let Ok(payload) = spb::Payload::decode(p.payload.as_ref()) else {
                        continue;
                    };
                    let birth = p.topic.contains("BIRTH/");
                    let mut values = Vec::new();
                    for m in &payload.metrics {
                        if birth {
                            if let (Some(name), Some(alias)) = (&m.name, m.alias) {
                                names.insert(alias, name.clone());
                            }
                        }
                        let name = m
                            .name
                            .clone()
                            .or_else(|| m.alias.and_then(|a| names.get(&a).cloned()));
                        if let (Some(name), Some(spb::payload::metric::Value::BooleanValue(b))) =
                            (name, &m.value)
                        {
                            values.push((name, *b));
                        }
                    }
                    if tx
                        .send((at, p.topic.clone(), values, p.payload.len()))
                        .is_err()
                    {
                        break;
                    }
                }
                _ => {}
            }
        }
    });
    ready_rx
        .recv_timeout(Duration::from_secs(10))
        .context("the harness's MQTT subscriber got no SUBACK within 10 s")?;
    Ok(rx)
}

/// The latency case's figures: MQTT, and OPC UA when its client could run.
struct Latencies {
    mqtt: DurationHistogram,
    opcua: Result<DurationHistogram, String>,
}

fn latency(ctx: &Ctx, binary: &Path) -> anyhow::Result<Latencies> {
    let dir = scratch(ctx, "plant-latency")?;
    let broker = Broker::start(&dir)?;
    let mut sim = ServedSim::start(binary, &["minimod@1"])?;
    let opcua_port = free_port()?;
    let project = dir.join("project.yaml");
    // A project needs a program; this one has nothing to do, so the tags are only the input.
    std::fs::write(dir.join("idle.expr"), "")?;
    std::fs::write(
        &project,
        format!(
            "project: plant_latency\nscan: {{ period: 10ms }}\nbuses:\n  - {{ name: line1, port: {}, \
             baud: 19200, format: 8E1 }}\nmodules:\n  - {{ name: mm1, bus: line1, model: minimod, \
             address: 1, settings: {{ RDELAYT: 0, XLATUP1: 1, XLATDN1: 1 }} }}\ntags:\n  - {{ \
             name: x1, point: mm1.X1 }}\nprogram: {{ file: idle.expr, kind: expr }}\n{}  opcua: {{ \
             port: {opcua_port} }}\n",
            sim.path.display(),
            mqtt_section(broker.port)
        ),
    )?;
    let rx = subscribe(broker.port)?;
    let flips = if ctx.quick { 30 } else { 300 };
    let plc = Running::start(binary, &project, Duration::from_secs(600))?;
    // The DBIRTH (X1 false) says the node is up and the module is read.
    wait_for(&rx, "x1", false, Duration::from_secs(20))
        .with_context(|| format!("no DDATA/DBIRTH baseline; softplc said: {}", plc.said()))?;
    let mut opcua = OpcUaWatch::start(opcua_port, "plant_latency", "x1");
    let mut mqtt = DurationHistogram::new();
    let mut ua = DurationHistogram::new();
    let mut seed = 0x2545_f491_u32;
    let mut value = false;
    for _ in 0..flips {
        // A pseudo-random pause, so the flips fall at every phase of the scan.
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        std::thread::sleep(Duration::from_micros(u64::from(seed % 20_000)));
        while rx.try_recv().is_ok() {}
        if let Ok(w) = &opcua {
            while w.changes.try_recv().is_ok() {}
        }
        value = !value;
        let t0 = Instant::now();
        sim.command(&format!("set minimod@1.X1 {}", u8::from(value)))?;
        let at = wait_for(&rx, "x1", value, Duration::from_secs(5))
            .with_context(|| format!("no DDATA with x1 = {value} within 5 s"))?;
        mqtt.record(at.saturating_duration_since(t0));
        if let Ok(w) = &opcua {
            match w.wait_for(value, Duration::from_secs(5)) {
                Ok(at) => ua.record(at.saturating_duration_since(t0)),
                Err(e) => opcua = Err(format!("{e:#}")),
            }
        }
    }
    drop(broker);
    Ok(Latencies {
        mqtt,
        opcua: opcua.map(|_| ua),
    })
}

/// `bench/py/opcua_watch.py` (asyncua, from the harness's virtual environment) subscribed to
/// one bool tag: a line per data-change notification, timestamped here when it is read.
struct OpcUaWatch {
    child: Child,
    changes: mpsc::Receiver<(Instant, bool)>,
}

impl OpcUaWatch {
    /// The client, subscribed; why not when the environment is missing or it cannot connect.
    fn start(port: u16, project: &str, tag: &str) -> Result<Self, String> {
        let period = PERIOD.as_millis().to_string();
        let (child, lines) = asyncua_client("opcua_watch.py", port, project, &[tag, &period])?;
        let (tx, rx) = mpsc::channel();
        std::thread::spawn(move || {
            for (at, line) in lines {
                if let Some(v) = line.strip_prefix("CHANGE ") {
                    if tx.send((at, v == "True")).is_err() {
                        break;
                    }
                }
            }
        });
        Ok(Self { child, changes: rx })
    }

    /// The arrival of the notification with `value`.
    fn wait_for(&self, value: bool, within: Duration) -> anyhow::Result<Instant> {
        let deadline = Instant::now() + within;
        loop {
            let left = deadline.saturating_duration_since(Instant::now());
            let (at, v) = self.changes.recv_timeout(left).with_context(|| {
                format!("no OPC UA notification x1 = {value} within {within:?}")
            })?;
            if v == value {
                return Ok(at);
            }
        }
    }
}

impl Drop for OpcUaWatch {
    fn drop(&mut self) {
        stop_client(&mut self.child);
    }
}

/// `bench/py/opcua_load.py`: an asyncua client subscribed to tags `b0..b{n-1}` (publishing
/// interval 10 ms), reading them all in a loop when asked; stopped when dropped.
struct OpcUaLoad {
    child: Child,
    lines: mpsc::Receiver<(Instant, String)>,
}

impl OpcUaLoad {
    /// Stops the client; the read passes it made (0 if it did not say).
    fn finish(mut self) -> u64 {
        drop(self.child.stdin.take());
        // A client that died says nothing: 0 then.
        while let Ok((_, line)) = self.lines.recv_timeout(Duration::from_secs(10)) {
            if let Some(rest) = line.strip_prefix("DONE ") {
                return rest
                    .split(' ')
                    .nth(1)
                    .and_then(|n| n.parse().ok())
                    .unwrap_or(0);
            }
        }
        0
    }

    fn start(port: u16, project: &str, tags: usize, read: bool) -> Result<Self, String> {
        let (n, period) = (tags.to_string(), PERIOD.as_millis().to_string());
        let mode = if read { "read" } else { "subscribe" };
        let (child, lines) =
            asyncua_client("opcua_load.py", port, project, &["b", &n, &period, mode])?;
        Ok(Self { child, lines })
    }
}

impl Drop for OpcUaLoad {
    fn drop(&mut self) {
        stop_client(&mut self.child);
    }
}

/// Closing its standard input ends an asyncua client; killed if it lingers.
pub(super) fn stop_client(child: &mut Child) {
    drop(child.stdin.take());
    std::thread::sleep(Duration::from_millis(200));
    drop(child.kill());
    drop(child.wait());
}

/// Starts `bench/py/SCRIPT URL NAMESPACE_URI ARGS...` with the harness's asyncua and waits
/// for its "READY"; the child and its later lines, each timestamped when read. Why not when
/// the environment is missing or the client cannot connect.
pub(super) fn asyncua_client(
    script: &str,
    port: u16,
    project: &str,
    args: &[&str],
) -> Result<(Child, mpsc::Receiver<(Instant, String)>), String> {
    let bench = Path::new(env!("CARGO_MANIFEST_DIR"));
    let python = bench.join("../target/bench-venv/bin/python");
    if !python.exists() {
        return Err("no target/bench-venv with asyncua: run bench/setup".into());
    }
    let mut child = Command::new(python)
        .arg(bench.join("py").join(script))
        // Its import of opcua_connect.py would leave a __pycache__ in the source tree.
        .env("PYTHONDONTWRITEBYTECODE", "1")
        .arg(format!("opc.tcp://127.0.0.1:{port}/"))
        .arg(format!("urn:softplc:{project}"))
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .map_err(|e| format!("cannot start the asyncua client: {e}"))?;
    let stdout = child
        .stdout
        .take()
        .ok_or("no stdout from the asyncua client")?;
    let (tx, rx) = mpsc::channel();
    let (ready_tx, ready_rx) = mpsc::channel();
    std::thread::spawn(move || {
        use std::io::BufRead;
        for line in std::io::BufReader::new(stdout).lines() {
            let Ok(line) = line else { break };
            let at = Instant::now();
            if line == "READY" || line.starts_with("FAIL") {
                // Nobody waits any more once the harness gave up.
                ready_tx.send(line).ok();
            } else if tx.send((at, line)).is_err() {
                break;
            }
        }
    });
    let ready = ready_rx.recv_timeout(Duration::from_secs(40));
    let why = match ready {
        Ok(line) if line == "READY" => return Ok((child, rx)),
        Ok(line) => format!("the asyncua client: {line}"),
        Err(_) => "the asyncua client did not subscribe within 40 s".into(),
    };
    drop(child.kill());
    drop(child.wait());
    Err(why)
}

/// Waits for a DDATA that carries `tag = value`; its arrival time.
fn wait_for(
    rx: &mpsc::Receiver<Received>,
    tag: &str,
    value: bool,
    within: Duration,
) -> anyhow::Result<Instant> {
    let deadline = Instant::now() + within;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let (at, _, values, _) = rx.recv_timeout(left).context("timed out")?;
        if values.iter().any(|(n, v)| n == tag && *v == value) {
            return Ok(at);
        }
    }
}

/// What the CPU case measured.
struct CpuFigures {
    /// softplc's CPU time per second, with the edge node.
    with: DurationHistogram,
    /// softplc's CPU time per second, without it.
    without: DurationHistogram,
    /// softplc's CPU time per second with the OPC UA server (no edge node) and an asyncua
    /// client subscribed to every tag; `Err` when the client could not run.
    opcua: Result<DurationHistogram, String>,
    /// mosquitto's CPU time per second while the edge node published.
    broker: DurationHistogram,
    /// Metric changes the harness's subscriber received per second (every window).
    delivered: Vec<f64>,
    /// NDATA payload bytes it received per second.
    bytes: Vec<f64>,
}

/// CPU time per second of run of the 1,000-tag project, with and without the edge node.
fn cpu(ctx: &Ctx, binary: &Path) -> anyhow::Result<CpuFigures> {
    let dir = scratch(ctx, "plant-cpu")?;
    let broker = Broker::start(&dir)?;
    let base = toggle_project(&dir, "plant_cpu", "100ms", TAGS)?;
    let without = dir.join("without.yaml");
    std::fs::write(&without, &base)?;
    let with = dir.join("with.yaml");
    std::fs::write(&with, format!("{base}{}", mqtt_section(broker.port)))?;
    let opcua_port = free_port()?;
    let with_opcua = dir.join("with_opcua.yaml");
    std::fs::write(&with_opcua, format!("{base}{}", opcua_section(opcua_port)))?;
    // The subscriber makes the broker forward every NDATA, as a SCADA would have it.
    let rx = subscribe(broker.port)?;
    let seconds = if ctx.quick { 8 } else { 24 };
    let mut figures = CpuFigures {
        with: DurationHistogram::new(),
        without: DurationHistogram::new(),
        opcua: Ok(DurationHistogram::new()),
        broker: DurationHistogram::new(),
        delivered: Vec::new(),
        bytes: Vec::new(),
    };
    let broker_pid = broker.child.id();
    // Turns, so a slow spell of the machine falls on both.
    for _ in 0..2 {
        let mut on_window = |_: u32| {
            let (mut changes, mut bytes) = (0usize, 0usize);
            while let Ok((_, topic, values, len)) = rx.try_recv() {
                if topic.contains("/NDATA/") {
                    changes += values.len();
                    bytes += len;
                }
            }
            (changes, bytes)
        };
        let delivered = sample_cpu(
            binary,
            &with,
            seconds,
            &mut figures.with,
            Some((broker_pid, &mut figures.broker)),
            &mut on_window,
        )?;
        if let Ok(hist) = &mut figures.opcua {
            // The client's start-up falls in the 2 s sample_cpu does not count.
            let mut client = None;
            let started = sample_cpu_then(binary, &with_opcua, seconds, hist, || {
                client = Some(OpcUaLoad::start(opcua_port, "plant_cpu", TAGS, false)?);
                Ok(())
            });
            if let Err(e) = started {
                figures.opcua = Err(format!("{e:#}"));
            }
            drop(client);
        }
        // The first window holds the births' backlog; the rest are steady state.
        for &(changes, bytes) in delivered.iter().skip(1) {
            figures.delivered.push(changes as f64 / f64::from(WINDOW_S));
            figures.bytes.push(bytes as f64 / f64::from(WINDOW_S));
        }
        sample_cpu(
            binary,
            &without,
            seconds,
            &mut figures.without,
            None,
            &mut |_| (0, 0),
        )?;
    }
    drop(broker);
    Ok(figures)
}

/// Runs `project` for `seconds` (+ 2 s of start-up not counted), recording its CPU time per
/// second of every [`WINDOW_S`] (and `also`'s, another process); `each` runs at the end of
/// every window and its results are returned.
fn sample_cpu(
    binary: &Path,
    project: &Path,
    seconds: u32,
    into: &mut DurationHistogram,
    also: Option<(u32, &mut DurationHistogram)>,
    each: &mut dyn FnMut(u32) -> (usize, usize),
) -> anyhow::Result<Vec<(usize, usize)>> {
    sample_cpu_with(binary, project, seconds, into, also, each, &mut || Ok(()))
}

/// [`sample_cpu`] of `project` alone, `start` run once softplc is up (a client connecting).
fn sample_cpu_then(
    binary: &Path,
    project: &Path,
    seconds: u32,
    into: &mut DurationHistogram,
    mut start: impl FnMut() -> Result<(), String>,
) -> anyhow::Result<()> {
    let mut start = || start().map_err(anyhow::Error::msg);
    sample_cpu_with(
        binary,
        project,
        seconds,
        into,
        None,
        &mut |_| (0, 0),
        &mut start,
    )?;
    Ok(())
}

/// [`sample_cpu`], with `start` run after softplc started and before the samples.
fn sample_cpu_with(
    binary: &Path,
    project: &Path,
    seconds: u32,
    into: &mut DurationHistogram,
    mut also: Option<(u32, &mut DurationHistogram)>,
    each: &mut dyn FnMut(u32) -> (usize, usize),
    start: &mut dyn FnMut() -> anyhow::Result<()>,
) -> anyhow::Result<Vec<(usize, usize)>> {
    // Time for a client to connect (up to 40 s) comes on top of the run.
    let plc = Running::start(
        binary,
        project,
        Duration::from_secs(u64::from(seconds) + 50),
    )?;
    let pid = plc.child.id();
    std::thread::sleep(Duration::from_secs(1));
    start().with_context(|| format!("softplc said: {}", plc.said()))?;
    std::thread::sleep(Duration::from_secs(1));
    each(0);
    let tick = clock_tick();
    let mut last = cpu_ticks(pid)?;
    let mut last_also = match &also {
        Some((p, _)) => cpu_ticks(*p)?,
        None => 0,
    };
    let mut at = Instant::now();
    let mut results = Vec::new();
    for second in 0..seconds / WINDOW_S {
        std::thread::sleep(Duration::from_secs(u64::from(WINDOW_S)));
        let now = cpu_ticks(pid)?;
        let wall = at.elapsed().as_secs_f64();
        at = Instant::now();
        let per_second =
            |ticks: u64| (tick * u32::try_from(ticks).unwrap_or(u32::MAX)).div_f64(wall);
        // Per second of wall time, whatever the sleep really took.
        into.record(per_second(now.saturating_sub(last)));
        last = now;
        if let Some((p, hist)) = &mut also {
            let n = cpu_ticks(*p)?;
            hist.record(per_second(n.saturating_sub(last_also)));
            last_also = n;
        }
        results.push(each(second));
    }
    Ok(results)
}

/// The median of `v` (0 when empty).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}
