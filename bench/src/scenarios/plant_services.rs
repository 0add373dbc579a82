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
//!   CPU time per second of run (`/proc/PID/stat` utime + stime) in both, side by side.
//!
//! Without `mosquitto` on the machine (`bench/setup` installs it) the rows say so.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use prost::Message;
use softplc::scan::DurationHistogram;
use softplc::service::mqtt::spb;

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::softplc_sim::{softplc_binary, ServedSim};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 11,
    name: "plant-services",
    title: "Plant services: terminal → MQTT consumer and OPC UA client, the edge node's CPU cost",
    summary: "Latency: one MiniMod served by `softplc sim --pty` (reply delay 0, X1 input filter \
              1 ms), scanned every 10 ms at 19200 8E1 by `softplc run`, a Sparkplug B edge node on \
              a local mosquitto, and an OPC UA server; X1 flipped at the simulator's console at random \
              times, the harness's own MQTT subscriber timestamps the DDATA with the new value, \
              and an asyncua client (bench/py/opcua_watch.py) its data-change notification \
              (includes the filter, the wait for the next input phase, the scan, the publish, \
              the broker or the server's publishing interval of 10 ms, and the client). CPU: 1,000 bool memory tags toggled every 100 ms cycle, \
              the softplc process's CPU time per second of run, with and without the edge node.",
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
    Ok(out)
}

/// A mosquitto of the harness: loopback only, anonymous, no persistence.
struct Broker {
    child: Child,
    port: u16,
}

impl Broker {
    fn start(dir: &Path) -> anyhow::Result<Self> {
        let port = free_port()?;
        let conf = dir.join("mosquitto.conf");
        std::fs::write(
            &conf,
            format!("listener {port} 127.0.0.1\nallow_anonymous true\npersistence false\n"),
        )?;
        let child = Command::new("mosquitto")
            .arg("-c")
            .arg(&conf)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("cannot start mosquitto")?;
        let broker = Self { child, port };
        let deadline = Instant::now() + Duration::from_secs(10);
        while std::net::TcpStream::connect(("127.0.0.1", port)).is_err() {
            if Instant::now() > deadline {
                bail!("mosquitto did not listen on 127.0.0.1:{port} within 10 s");
            }
            std::thread::sleep(Duration::from_millis(20));
        }
        Ok(broker)
    }
}

impl Drop for Broker {
    fn drop(&mut self) {
        // The broker may have exited already; the wait reaps it either way.
        drop(self.child.kill());
        drop(self.child.wait());
    }
}

fn free_port() -> anyhow::Result<u16> {
    let l = std::net::TcpListener::bind("127.0.0.1:0")?;
    Ok(l.local_addr()?.port())
}

/// `softplc run` of `project` for `run_for`, killed when dropped.
struct Running(Child);

impl Running {
    fn start(binary: &Path, project: &Path, run_for: Duration) -> anyhow::Result<Self> {
        let child = Command::new(binary)
            .args(["run", "--quiet", "--no-socket", "--for"])
            .arg(format!("{}ms", run_for.as_millis()))
            .arg(project)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .context("cannot start softplc run")?;
        Ok(Self(child))
    }
}

impl Drop for Running {
    fn drop(&mut self) {
        // It may have stopped at the end of its run time; the wait reaps it either way.
        drop(self.0.kill());
        drop(self.0.wait());
    }
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
    std::fs::write(
        &project,
        format!(
            "project: plant_latency\nscan: {{ period: 10ms }}\nbuses:\n  - {{ name: line1, port: {}, \
             baud: 19200, format: 8E1 }}\nmodules:\n  - {{ name: mm1, bus: line1, model: minimod, \
             address: 1, settings: {{ RDELAYT: 0, XLATUP1: 1, XLATDN1: 1 }} }}\ntags:\n  - {{ \
             name: x1, point: mm1.X1 }}\n{}  opcua: {{ port: {opcua_port} }}\n",
            sim.path.display(),
            mqtt_section(broker.port)
        ),
    )?;
    let rx = subscribe(broker.port)?;
    let flips = if ctx.quick { 30 } else { 300 };
    let _plc = Running::start(binary, &project, Duration::from_secs(600))?;
    // The DBIRTH (X1 false) says the node is up and the module is read.
    wait_for(&rx, "x1", false, Duration::from_secs(20)).context("no DDATA/DBIRTH baseline")?;
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
        let bench = Path::new(env!("CARGO_MANIFEST_DIR"));
        let python = bench.join("../target/bench-venv/bin/python");
        if !python.exists() {
            return Err("no target/bench-venv with asyncua: run bench/setup".into());
        }
        let mut child = Command::new(python)
            .arg(bench.join("py/opcua_watch.py"))
            .arg(format!("opc.tcp://127.0.0.1:{port}/"))
            .arg(format!("urn:softplc:{project}"))
            .arg(tag)
            .arg(PERIOD.as_millis().to_string())
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
                } else if let Some(v) = line.strip_prefix("CHANGE ") {
                    if tx.send((at, v == "True")).is_err() {
                        break;
                    }
                }
            }
        });
        let watch = Self { child, changes: rx };
        match ready_rx.recv_timeout(Duration::from_secs(40)) {
            Ok(line) if line == "READY" => Ok(watch),
            Ok(line) => Err(format!("the asyncua client: {line}")),
            Err(_) => Err("the asyncua client did not subscribe within 40 s".into()),
        }
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
        // Closing its standard input ends the client; kill it if it lingers.
        drop(self.child.stdin.take());
        std::thread::sleep(Duration::from_millis(200));
        drop(self.child.kill());
        drop(self.child.wait());
    }
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
    let program: String = (0..TAGS).map(|i| format!("b{i} = !b{i}\n")).collect();
    std::fs::write(dir.join("toggle.expr"), program)?;
    let tags: String = (0..TAGS)
        .map(|i| format!("  - {{ name: b{i}, type: bool }}\n"))
        .collect();
    let base = format!(
        "project: plant_cpu\nscan: {{ period: 100ms }}\ntags:\n{tags}program: {{ file: toggle.expr, kind: expr }}\n"
    );
    let without = dir.join("without.yaml");
    std::fs::write(&without, &base)?;
    let with = dir.join("with.yaml");
    std::fs::write(&with, format!("{base}{}", mqtt_section(broker.port)))?;
    // The subscriber makes the broker forward every NDATA, as a SCADA would have it.
    let rx = subscribe(broker.port)?;
    let seconds = if ctx.quick { 4 } else { 20 };
    let mut figures = CpuFigures {
        with: DurationHistogram::new(),
        without: DurationHistogram::new(),
        broker: DurationHistogram::new(),
        delivered: Vec::new(),
        bytes: Vec::new(),
    };
    let broker_pid = broker.child.id();
    // Turns, so a slow spell of the machine falls on both.
    for _ in 0..2 {
        let mut on_second = |_: u32| {
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
            &mut on_second,
        )?;
        // The first window holds the births' backlog; the rest are steady state.
        for &(changes, bytes) in delivered.iter().skip(1) {
            figures.delivered.push(changes as f64);
            figures.bytes.push(bytes as f64);
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

/// Runs `project` for `seconds` (+ 2 s of start-up not counted), recording its CPU time of
/// every whole second (and `also`'s, another process); `each` runs at the end of every second
/// and its results are returned.
fn sample_cpu(
    binary: &Path,
    project: &Path,
    seconds: u32,
    into: &mut DurationHistogram,
    mut also: Option<(u32, &mut DurationHistogram)>,
    each: &mut dyn FnMut(u32) -> (usize, usize),
) -> anyhow::Result<Vec<(usize, usize)>> {
    let plc = Running::start(binary, project, Duration::from_secs(u64::from(seconds) + 4))?;
    let pid = plc.0.id();
    std::thread::sleep(Duration::from_secs(2));
    each(0);
    let tick = clock_tick();
    let mut last = cpu_ticks(pid)?;
    let mut last_also = match &also {
        Some((p, _)) => cpu_ticks(*p)?,
        None => 0,
    };
    let mut at = Instant::now();
    let mut results = Vec::new();
    for second in 0..seconds {
        std::thread::sleep(Duration::from_secs(1));
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

/// utime + stime of process `pid`, in clock ticks.
fn cpu_ticks(pid: u32) -> anyhow::Result<u64> {
    let stat = std::fs::read_to_string(format!("/proc/{pid}/stat"))
        .with_context(|| format!("softplc (pid {pid}) stopped early"))?;
    // Fields after the command name in parentheses, which may hold spaces.
    let rest = stat.rsplit_once(')').map(|(_, r)| r).unwrap_or("");
    let fields: Vec<&str> = rest.split_whitespace().collect();
    let num = |i: usize| -> anyhow::Result<u64> {
        fields
            .get(i)
            .and_then(|f| f.parse().ok())
            .context("unreadable /proc/PID/stat")
    };
    // utime and stime are fields 14 and 15 of stat(5); 12 and 13 after the state.
    Ok(num(11)? + num(12)?)
}

/// The length of one clock tick of `/proc/PID/stat` (`getconf CLK_TCK`, 100 Hz on Linux).
fn clock_tick() -> Duration {
    let hz = Command::new("getconf")
        .arg("CLK_TCK")
        .output()
        .ok()
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .and_then(|s| s.trim().parse::<u32>().ok())
        .filter(|hz| *hz > 0)
        .unwrap_or(100);
    Duration::from_secs(1) / hz
}

/// The median of `v` (0 when empty).
fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

fn scratch(ctx: &Ctx, name: &str) -> anyhow::Result<PathBuf> {
    let dir = ctx.scratch.join(name);
    std::fs::create_dir_all(&dir)?;
    Ok(dir)
}
