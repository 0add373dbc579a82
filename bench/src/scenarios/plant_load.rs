//! Scenario 14: every change at every plant client, under load (issue 25's goal). 1,000 i32
//! counter tags at a 10 ms scan, 100 of them stepped by one each cycle (each tag every tenth
//! cycle: 10,000 changes/s), for 60 s (8 s with `--quick`), run by `softplc run`:
//!
//! - without services: the baseline of CPU and of the scan's timing;
//! - with the OPC UA server and async-opcua's own client (compiled into the harness: not the
//!   bottleneck) subscribed to all 1,000 tags, sampling interval 0, queue 100;
//! - with the Sparkplug B edge node on a mosquitto started here, and the harness's compiled
//!   host (`plant_load/spb_counter.rs`) counting every metric change;
//! - with both services and both clients at once;
//! - with the OPC UA server and asyncua (`bench/py/opcua_count.py`), a peer: what it received
//!   at the rate it can take.
//!
//! A counter that steps by one makes a missed change a gap in its sequence
//! ([`crate::sequence`]). The program steps only while the memory tag `stepping` is forced true:
//! the harness forces it once the clients are subscribed, forces it false after the run, waits
//! for the last changes to arrive, then reads every tag's final value (what the PLC made) and
//! the services' `lost_changes` from the control socket. CPU is the softplc process's
//! utime + stime (`/proc/PID/stat`) over the stepping, per second and per 1,000 changes/s; the
//! scan's wake-up lateness and cycle come from `softplc status` at the end (every cycle of the
//! run, the clients' connection included), each as a ratio to the run without services.

mod spb_counter;
mod ua_counter;

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use anyhow::{bail, Context};
use softplc::scan::{DurationHistogram, Percentiles};
use softplc::service::control::{request, Request};
use softplc::service::StatusReport;

use super::plant_kit::{
    clock_tick, cpu_ticks, free_port, from_micros, scratch, Broker, Running, WINDOW_S,
};
use super::plant_services::{asyncua_client, stop_client};
use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Row};
use crate::sequence::Tally;
use crate::softplc_sim::softplc_binary;
use spb_counter::{SpbCounter, SpbFigures};
use ua_counter::{UaCounter, UaFigures, UaRequest};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 14,
    name: "plant-load",
    title: "Plant services under load: every change of 1,000 tags at 10,000 changes/s, counted at each client",
    summary: "1,000 i32 counter tags, 100 stepped by one each 10 ms cycle (10,000 changes/s) for \
              60 s by `softplc run`: without services; OPC UA with async-opcua's own client \
              (sampling interval 0, queue 100, publishing 50 ms); Sparkplug B through a local \
              mosquitto with the harness's compiled host; both; OPC UA with asyncua (a peer, at \
              the rate it can take). Each client's changes counted against the counters' final \
              values (a gap in a tag's sequence is a miss), the Overflow InfoBit, the PLC's \
              lost_changes per service. CPU: the softplc process's utime + stime over the 60 s, \
              per second and per 1,000 changes/s. Lateness and cycle: the scan's own figures \
              over the whole run (`softplc status`), as a ratio to the run without services.",
    run,
};

const TAGS: usize = 1000;
/// Tags stepped each cycle: each tag once every `TAGS / STEPPED` cycles.
const STEPPED: usize = 100;
const PERIOD: &str = "10ms";
const PROJECT: &str = "plant_load";
const GROUP: &str = "bench";
const NODE: &str = "n1";
/// The OPC UA clients' subscription.
const UA: UaRequest = UaRequest {
    publishing: Duration::from_millis(50),
    queue: 100,
    tags: TAGS,
};
/// After `stepping` falls: time for the last changes to reach every client.
const GRACE: Duration = Duration::from_secs(3);

/// Who is connected in a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Case {
    NoServices,
    OpcUa,
    Sparkplug,
    Both,
    Asyncua,
}

impl Case {
    const ALL: [Self; 5] = [
        Self::NoServices,
        Self::OpcUa,
        Self::Sparkplug,
        Self::Both,
        Self::Asyncua,
    ];

    fn label(self) -> &'static str {
        match self {
            Self::NoServices => "no services",
            Self::OpcUa => "OPC UA, async-opcua client",
            Self::Sparkplug => "Sparkplug B, compiled host via mosquitto",
            Self::Both => "OPC UA + Sparkplug B, both clients",
            Self::Asyncua => "OPC UA, asyncua client (peer)",
        }
    }

    fn opcua(self) -> bool {
        matches!(self, Self::OpcUa | Self::Both | Self::Asyncua)
    }

    fn mqtt(self) -> bool {
        matches!(self, Self::Sparkplug | Self::Both)
    }
}

/// What one run measured.
struct RunFigures {
    /// CPU time per second, every [`WINDOW_S`] of the stepping.
    cpu: DurationHistogram,
    /// CPU time per second over the whole stepping.
    cpu_mean_ms: f64,
    /// Changes the PLC made (every counter's final value).
    made: u64,
    /// How long `stepping` was held.
    stepping: Duration,
    /// The scan's figures at the end.
    status: StatusReport,
    ua: Option<UaFigures>,
    spb: Option<SpbFigures>,
    /// asyncua's count, or why it could not run.
    asyncua: Option<Result<PeerFigures, String>>,
}

impl RunFigures {
    fn changes_per_s(&self) -> f64 {
        self.made as f64 / self.stepping.as_secs_f64()
    }

    /// CPU, ms per second of run, per 1,000 changes/s made.
    fn cpu_per_thousand(&self) -> f64 {
        self.cpu_mean_ms / (self.changes_per_s() / 1e3)
    }

    fn lost(&self, service: &str) -> Option<u64> {
        self.status
            .lost_changes
            .iter()
            .find(|l| l.service == service)
            .map(|l| l.lost)
    }
}

/// asyncua's own count.
#[derive(Debug, Clone, Copy)]
struct PeerFigures {
    tally: Tally,
    overflow: u64,
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    let binary = softplc_binary()?;
    let stepping = ctx.pick(Duration::from_secs(60), Duration::from_secs(8));
    let dir = scratch(ctx, "plant-load")?;
    let mosquitto = Command::new("mosquitto").arg("-h").output().is_ok();
    let mut baseline: Option<RunFigures> = None;
    for case in Case::ALL {
        if case.mqtt() && !mosquitto {
            out.rows.push(Row::unavailable(
                case.label(),
                "CPU per second",
                "mosquitto is not installed (bench/setup installs it)",
            ));
            continue;
        }
        match one_run(&binary, &dir, case, stepping) {
            Ok(f) => {
                rows(&mut out, case, &f, baseline.as_ref(), ctx.quick);
                if case == Case::NoServices {
                    baseline = Some(f);
                }
            }
            Err(e) => out.rows.push(Row::unavailable(
                case.label(),
                "CPU per second",
                format!("{e:#}"),
            )),
        }
    }
    Ok(out)
}

/// One run of the project with `case`'s services and clients.
fn one_run(
    binary: &Path,
    dir: &Path,
    case: Case,
    stepping: Duration,
) -> anyhow::Result<RunFigures> {
    let dir = dir.join(format!("{case:?}").to_lowercase());
    std::fs::create_dir_all(&dir)?;
    // mosquitto says how many messages it dropped every second.
    let broker = if case.mqtt() {
        Some(Broker::start_with(&dir, "sys_interval 1\n")?)
    } else {
        None
    };
    let opcua_port = free_port()?;
    let project = write_project(&dir, case, opcua_port, broker.as_ref().map(|b| b.port))?;
    // The host is there before the node, so it sees the NBIRTH.
    let host = match &broker {
        Some(b) => Some(SpbCounter::start(b.port, GROUP, NODE, TAGS)?),
        None => None,
    };
    let socket = dir.join("control.sock");
    let mut plc = Running::start_with(
        binary,
        &project,
        stepping + Duration::from_secs(180),
        Some(&socket),
    )?;
    wait_for_socket(&mut plc, &socket).with_context(|| format!("softplc said: {}", plc.said()))?;
    let ua = if matches!(case, Case::OpcUa | Case::Both) {
        Some(
            UaCounter::start(opcua_port, PROJECT, &dir.join("ua-client-pki"), UA)
                .with_context(|| format!("softplc said: {}", plc.said()))?,
        )
    } else {
        None
    };
    let peer = if case == Case::Asyncua {
        let (n, publishing, queue) = (
            TAGS.to_string(),
            UA.publishing.as_millis().to_string(),
            UA.queue.to_string(),
        );
        Some(asyncua_client(
            "opcua_count.py",
            opcua_port,
            PROJECT,
            &["c", &n, &publishing, &queue],
        ))
    } else {
        None
    };

    let pid = plc.child.id();
    let tick = clock_tick();
    let start_ticks = cpu_ticks(pid)?;
    force_stepping(&socket, true)?;
    let started = Instant::now();
    let mut cpu = DurationHistogram::new();
    let mut last = start_ticks;
    let mut at = started;
    for _ in 0..(stepping.as_secs() / u64::from(WINDOW_S)).max(1) {
        std::thread::sleep(Duration::from_secs(u64::from(WINDOW_S)));
        let now = cpu_ticks(pid)?;
        let wall = at.elapsed().as_secs_f64();
        at = Instant::now();
        cpu.record(
            (tick * u32::try_from(now.saturating_sub(last)).unwrap_or(u32::MAX)).div_f64(wall),
        );
        last = now;
    }
    let end_ticks = cpu_ticks(pid)?;
    force_stepping(&socket, false)?;
    let stepped = started.elapsed();
    std::thread::sleep(GRACE);
    let status = status(&socket)?;
    let finals = finals(&status)?;
    let made = finals.iter().map(|&v| u64::try_from(v).unwrap_or(0)).sum();
    let ua = ua.map(|c| c.finish(&finals));
    let spb = match host {
        Some(h) => Some(h.finish(&finals)?),
        None => None,
    };
    let asyncua = peer.map(|p| p.map(|(child, lines)| peer_done(child, lines, &finals)));
    drop(plc);
    drop(broker);
    let cpu_s = (tick * u32::try_from(end_ticks.saturating_sub(start_ticks)).unwrap_or(u32::MAX))
        .as_secs_f64();
    Ok(RunFigures {
        cpu,
        cpu_mean_ms: cpu_s * 1e3 / stepped.as_secs_f64(),
        made,
        stepping: stepped,
        status,
        ua,
        spb,
        asyncua: asyncua.map(|r| r.and_then(|x| x)),
    })
}

/// Stops asyncua's client and reads its count.
fn peer_done(
    mut child: std::process::Child,
    lines: std::sync::mpsc::Receiver<(Instant, String)>,
    finals: &[i64],
) -> Result<PeerFigures, String> {
    drop(child.stdin.take());
    let mut done = None;
    while let Ok((_, line)) = lines.recv_timeout(Duration::from_secs(20)) {
        if let Some(rest) = line.strip_prefix("DONE ") {
            done = Some(rest.to_string());
            break;
        }
    }
    stop_client(&mut child);
    let rest = done.ok_or("the asyncua client said nothing at its end")?;
    let n: Vec<u64> = rest.split(' ').filter_map(|t| t.parse().ok()).collect();
    let [received, repeated, out_of_order, overflow, unknown] = n[..] else {
        return Err(format!(
            "the asyncua client's last line is unreadable: {rest:?}"
        ));
    };
    let made: u64 = finals.iter().map(|&v| u64::try_from(v).unwrap_or(0)).sum();
    Ok(PeerFigures {
        tally: Tally {
            made,
            received,
            missed: made.saturating_sub(received),
            repeated,
            out_of_order,
            unknown,
        },
        overflow,
    })
}

/// The project: the counter tags, `stepping` and `phase` (not served), the program, `case`'s
/// services.
fn write_project(
    dir: &Path,
    case: Case,
    opcua_port: u16,
    mqtt_port: Option<u16>,
) -> anyhow::Result<PathBuf> {
    std::fs::write(dir.join("count.rhai"), program())?;
    let mut text = format!(
        "project: {PROJECT}\nscan: {{ period: {PERIOD} }}\ntags:\n  - {{ name: stepping, type: bool, \
         scada: none }}\n  - {{ name: phase, type: i32, scada: none }}\n"
    );
    for i in 0..TAGS {
        text.push_str(&format!("  - {{ name: c{i}, type: i32 }}\n"));
    }
    text.push_str("program: { file: count.rhai, kind: rhai }\n");
    if case != Case::NoServices {
        text.push_str("service:\n");
    }
    if case.opcua() {
        text.push_str(&format!("  opcua: {{ port: {opcua_port} }}\n"));
    }
    if let (true, Some(port)) = (case.mqtt(), mqtt_port) {
        text.push_str(&format!(
            "  mqtt: {{ host: 127.0.0.1, port: {port}, group: {GROUP}, node: {NODE} }}\n"
        ));
    }
    let path = dir.join("project.yaml");
    std::fs::write(&path, text)?;
    Ok(path)
}

/// While `stepping` holds, each cycle steps the tags `c{phase}`, `c{phase + 10}`, ... by one, then
/// `phase` moves on: every tag once every ten cycles, [`STEPPED`] a cycle.
fn program() -> String {
    let stride = TAGS / STEPPED;
    let mut s = String::from("if stepping {\n");
    for phase in 0..stride {
        let keyword = if phase == 0 { "    if" } else { " else if" };
        s.push_str(&format!("{keyword} phase == {phase} {{\n"));
        for tag in (phase..TAGS).step_by(stride) {
            s.push_str(&format!("        c{tag} += 1;\n"));
        }
        s.push_str("    }");
    }
    s.push_str(&format!(
        "\n    phase += 1;\n    if phase >= {stride} {{ phase = 0; }}\n}}\n"
    ));
    s
}

/// Until `plc` answers on `socket`; why not if it stopped or stayed silent for 60 s.
fn wait_for_socket(plc: &mut Running, socket: &Path) -> anyhow::Result<()> {
    let deadline = Instant::now() + Duration::from_secs(60);
    loop {
        match request(socket, &Request::Status) {
            Ok(r) if r.ok => return Ok(()),
            _ if Instant::now() > deadline => {
                bail!("softplc's control socket did not answer within 60 s")
            }
            _ => {}
        }
        if let Ok(Some(exit)) = plc.child.try_wait() {
            bail!("softplc stopped ({exit})");
        }
        std::thread::sleep(Duration::from_millis(100));
    }
}

/// Forces the memory tag `stepping`, which the program's counting waits for.
fn force_stepping(socket: &Path, on: bool) -> anyhow::Result<()> {
    let r = request(
        socket,
        &Request::Force {
            tag: "stepping".into(),
            value: on.to_string(),
        },
    )
    .context("cannot force stepping")?;
    if !r.ok {
        bail!(
            "softplc refused to force stepping: {}",
            r.error.unwrap_or_default()
        );
    }
    Ok(())
}

fn status(socket: &Path) -> anyhow::Result<StatusReport> {
    let r = request(socket, &Request::Status).context("cannot ask softplc for its status")?;
    r.status
        .with_context(|| format!("no status from softplc: {}", r.error.unwrap_or_default()))
}

/// Every counter's final value, in tag order.
fn finals(status: &StatusReport) -> anyhow::Result<Vec<i64>> {
    (0..TAGS)
        .map(|i| {
            let name = format!("c{i}");
            let tag = status
                .tags
                .iter()
                .find(|t| t.name == name)
                .with_context(|| format!("no tag {name} in softplc's status"))?;
            tag.value
                .parse()
                .with_context(|| format!("tag {name}: not a number: {:?}", tag.value))
        })
        .collect()
}

/// The run's rows: CPU with what each client counted, and the scan's lateness and cycle.
fn rows(out: &mut Outcome, case: Case, f: &RunFigures, base: Option<&RunFigures>, quick: bool) {
    let rate = f.changes_per_s();
    let mut note = format!(
        "{} changes made in {:.1} s ({rate:.0}/s); CPU {:.1} ms/s over the run, {:.2} ms/s per \
         1,000 changes/s",
        f.made,
        f.stepping.as_secs_f64(),
        f.cpu_mean_ms,
        f.cpu_per_thousand()
    );
    if quick {
        note.push_str(" (--quick: 8 s instead of 60)");
    }
    let mut row = Row::measured(case.label(), "CPU per second", f.cpu.percentiles())
        .value("changes_made", f.made as f64)
        .value("changes_per_s", rate)
        .value("cpu_ms_per_s", f.cpu_mean_ms)
        .value("cpu_ms_per_s_per_1000_changes_per_s", f.cpu_per_thousand());
    if let Some(b) = base {
        let extra = (f.cpu_mean_ms - b.cpu_mean_ms) / (rate / 1e3);
        note.push_str(&format!(" ({extra:+.2} over the run without services)"));
        row = row
            .bound(Bound::baseline("no services", &b.cpu.percentiles()))
            .value("extra_cpu_ms_per_s_per_1000_changes_per_s", extra);
    }
    if let Some(ua) = &f.ua {
        note.push_str(&format!(
            "; async-opcua: {} in {} data values (queue {} granted), Overflow bit on {} values, \
             {} subscription status changes",
            tally_text(&ua.tally),
            ua.values,
            ua.queue,
            ua.overflow,
            ua.status_changes
        ));
        if ua.without_value > 0 {
            note.push_str(&format!(", {} values without an Int32", ua.without_value));
        }
        row = tally_values(row, "opcua", &ua.tally).value("opcua_overflow", ua.overflow as f64);
    }
    if let Some(s) = &f.spb {
        let dropped = s
            .broker_dropped
            .map_or("not published".to_string(), |n| n.to_string());
        note.push_str(&format!(
            "; Sparkplug host: {} in {} messages; its queue: high-water {} of {}, {} refused; \
             mosquitto's dropped count: {dropped}",
            tally_text(&s.tally),
            s.messages,
            s.high_water,
            spb_counter::QUEUE,
            s.refused
        ));
        row = tally_values(row, "sparkplug", &s.tally)
            .value("sparkplug_queue_high_water", s.high_water as f64)
            .value("sparkplug_queue_capacity", spb_counter::QUEUE as f64)
            .value("sparkplug_queue_refused", s.refused as f64);
        if let Some(n) = s.broker_dropped {
            row = row.value("mosquitto_dropped", n as f64);
        }
    }
    match &f.asyncua {
        Some(Ok(p)) => {
            note.push_str(&format!(
                "; asyncua (peer): {}, Overflow bit on {} values",
                tally_text(&p.tally),
                p.overflow
            ));
            row =
                tally_values(row, "asyncua", &p.tally).value("asyncua_overflow", p.overflow as f64);
        }
        Some(Err(why)) => note.push_str(&format!("; asyncua could not run: {why}")),
        None => {}
    }
    for service in ["opcua", "mqtt"] {
        if let Some(lost) = f.lost(service) {
            note.push_str(&format!("; PLC lost_changes {service}: {lost}"));
            row = row.value(&format!("plc_lost_changes_{service}"), lost as f64);
        }
    }
    out.rows.push(row.note(note));

    let timing = |metric: &str, p: Percentiles, b: Option<Percentiles>| {
        let mut row = Row::measured(case.label(), metric, p).note(format!(
            "the scan's own figure over every cycle of the run ({} scans, {} overruns; the \
             clients' connection included)",
            f.status.scans, f.status.overruns
        ));
        if let Some(b) = b {
            row = row.bound(Bound::baseline("no services", &b));
        }
        row.value("overruns", f.status.overruns as f64)
    };
    out.rows.push(timing(
        "wake-up lateness",
        from_micros(&f.status.lateness),
        base.map(|b| from_micros(&b.status.lateness)),
    ));
    out.rows.push(timing(
        "cycle",
        from_micros(&f.status.cycle),
        base.map(|b| from_micros(&b.status.cycle)),
    ));
}

fn tally_text(t: &Tally) -> String {
    let mut s = format!(
        "received {} of {} changes, {} missed",
        t.received, t.made, t.missed
    );
    if t.repeated > 0 {
        s.push_str(&format!(", {} values repeated", t.repeated));
    }
    if t.out_of_order > 0 {
        s.push_str(&format!(", {} out of order", t.out_of_order));
    }
    if t.unknown > 0 {
        s.push_str(&format!(", {} values of unknown tags", t.unknown));
    }
    s
}

fn tally_values(row: Row, client: &str, t: &Tally) -> Row {
    row.value(&format!("{client}_received"), t.received as f64)
        .value(&format!("{client}_missed"), t.missed as f64)
        .value(&format!("{client}_repeated"), t.repeated as f64)
        .value(&format!("{client}_out_of_order"), t.out_of_order as f64)
}
