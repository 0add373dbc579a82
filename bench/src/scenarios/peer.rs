//! Scenario 10: a peer in the same run. Four MiniMods (units 1–4, reply delay 10 ms) served by
//! one `softplc sim --pty` at 19200 8E1; each master runs the same workload back to back: every
//! cycle reads the inputs of the four modules and writes the one output that changed (Y1 of
//! one module, the modules in turn). The masters, one after the other on the same simulators:
//!
//! - the runtime's bus owner polling (one FC 2 per module), writes on change (FC 5);
//! - the runtime's bus owner in event mode (`events: true`: one FC 70 Collect round for the
//!   line), writes on change;
//! - pymodbus's synchronous serial client in a Python loop, as OpenPLC v4's Modbus master
//!   plugin polls a serial device: FC 2 per module, then the changed output; and the same
//!   loop writing every module's output each cycle, changed or not, as a master that copies
//!   its output image every cycle does;
//! - minimalmodbus, one instrument per module on the shared port, FC 2 per module and the
//!   changed output.
//!
//! A pty has no baud rate: every master is paced by the simulator's reply delay and the reply's
//! wire time, so the ratios show each master's own overhead and what Collect and writing on
//! change save, not wire time (scenario 3 has that).

use std::sync::Arc;
use std::time::{Duration, Instant};

use anyhow::Context;
use softplc::scan::DurationHistogram;
use softplc_io::devices::minimod;
use softplc_io::line::{BusOwner, Discipline, LineSettings, Module, OutputFrame, SerialTransport};
use softplc_io::point::Value;
use softplc_io::time::{Clock, MonotonicClock};

use super::{Ctx, Scenario};
use crate::python::{Library, Masters, Writes};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_line;
use crate::softplc_sim::{softplc_binary, ServedSim};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 10,
    name: "peer",
    title: "A peer in the same run: the runtime's bus owner vs Python masters (pymodbus, \
            minimalmodbus) on a pty",
    summary: "Four MiniMods (units 1–4, reply delay 10 ms) served by one `softplc sim --pty` at \
              19200 8E1. Full cycle: the inputs of every module, then the one output that \
              changed (Y1 of one module, in turn); cycles back to back, each master on the same \
              simulators in the same run. pymodbus is its synchronous serial client in a Python \
              loop, as OpenPLC v4's Modbus master plugin polls a serial device. A pty has no \
              baud rate: every master is paced by the reply delay and the reply's characters \
              (\"pty pacing\" of the polling cycle: 4 × FC 2 + 1 × FC 5), so the ratios are \
              the masters' own overheads and what Collect and writes on change save, not wire \
              time.",
    run,
};

const UNITS: [u8; 4] = [1, 2, 3, 4];
/// Event mode with Collect rounds only: the periodic full reads (`event_refresh`,
/// `event_resync`) out of the way of the cycles measured.
const EVENT_MODE: [(&str, &str); 3] = [
    ("events", "true"),
    ("event_refresh", "60s"),
    ("event_resync", "60s"),
];

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let line = LineSettings::DEFAULT;
    let (_, read_rt) = sim_line::single_read_floor(line, &[]);
    let pacing = read_rt * UNITS.len() as u32 + sim_line::write_round_trip(line, &[], "Y1");
    let binary = softplc_binary()?;
    let devices: Vec<String> = UNITS.iter().map(|u| format!("minimod@{u}")).collect();
    let devices: Vec<&str> = devices.iter().map(String::as_str).collect();
    let sim = ServedSim::start(&binary, &devices)?;

    let run_for = ctx.pick(Duration::from_secs(6), Duration::from_millis(1200));
    let cycles = if ctx.quick { 15 } else { 80 };
    let polling = bus_owner(&sim, line, &[], run_for).context("softplc, polling")?;
    let events = bus_owner(&sim, line, &EVENT_MODE, run_for).context("softplc, event mode")?;
    let peers: Vec<(String, anyhow::Result<DurationHistogram>)> = match Masters::find() {
        Ok(m) => [
            (
                Library::Pymodbus,
                Writes::Changed,
                "OpenPLC-style poll loop",
            ),
            (Library::Pymodbus, Writes::All, "every output each cycle"),
            (Library::Minimalmodbus, Writes::Changed, "poll loop"),
        ]
        .into_iter()
        .map(|(lib, writes, how)| {
            let label = format!("{} (Python), {how}", m.version(lib));
            (label, m.cycles(lib, writes, &sim.path, &UNITS, cycles))
        })
        .collect(),
        Err(e) => vec![("Python masters".to_string(), Err(e))],
    };
    drop(sim);

    let mut out = Outcome::default();
    let pymodbus = peers
        .first()
        .and_then(|(l, r)| Some((l.clone(), r.as_ref().ok()?.percentiles())));
    let poll_p = polling.hist.percentiles();
    let mut series = Vec::new();
    for (case, ours) in [
        ("softplc bus owner, polling, writes on change", polling),
        ("softplc bus owner, Collect, writes on change", events),
    ] {
        let mut row = Row::measured(case, "full I/O cycle", ours.hist.percentiles());
        if let Some((label, p)) = &pymodbus {
            row = row.bound(Bound::baseline(short(label), p));
        }
        if case.contains("Collect") {
            row = row.bound(Bound::baseline("softplc polling", &poll_p));
        }
        out.rows.push(
            row.bound(Bound::fixed("pty pacing", pacing))
                .value("errors", ours.errors as f64)
                .note(format!("{} errors", ours.errors)),
        );
        series.push(Series {
            label: case.to_string(),
            hist: ours.hist,
        });
    }
    for (label, result) in peers {
        match result {
            Ok(hist) => {
                out.rows.push(
                    Row::measured(label.clone(), "full I/O cycle", hist.percentiles())
                        .bound(Bound::baseline("softplc polling", &poll_p))
                        .bound(Bound::fixed("pty pacing", pacing)),
                );
                series.push(Series { label, hist });
            }
            Err(e) => out
                .rows
                .push(Row::unavailable(label, "full I/O cycle", e.to_string())),
        }
    }
    out.plots.push(Plot {
        file: "peer-cycle.svg".into(),
        title: "Full I/O cycle on a pty, 4 MiniMods, 19200 8E1, reply delay 10 ms".into(),
        x_label: "full I/O cycle".into(),
        kind: PlotKind::Cdf { log_x: false },
        series,
    });
    Ok(out)
}

/// "pymodbus 3.16.1" out of a peer's row label.
fn short(label: &str) -> String {
    label.split(" (").next().unwrap_or(label).to_string()
}

/// What the runtime's bus owner measured.
struct Ours {
    hist: DurationHistogram,
    errors: u64,
}

/// The runtime's bus owner on the pty with `settings` on every module, its start-up run, then
/// full cycles back to back for `run_for`.
fn bus_owner(
    sim: &ServedSim,
    line: LineSettings,
    settings: &[(&str, &str)],
    run_for: Duration,
) -> anyhow::Result<Ours> {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let transport = SerialTransport::open(&sim.path, line, clock)?;
    let modules = UNITS
        .iter()
        .map(|&u| Module::new(format!("mm{u}"), sim_line::driver(u, settings)))
        .collect();
    let mut owner = BusOwner::new("pty", Box::new(transport), Discipline::default(), modules);
    owner
        .startup()
        .map_err(|e| anyhow::anyhow!("module start-up on the pty: {e}"))?;
    let y1 = minimod::point_index("Y1").context("MiniMod has no Y1")?;
    let mut outputs = OutputFrame {
        modules: vec![vec![None; minimod::POINTS.len()]; UNITS.len()],
    };
    for m in &mut outputs.modules {
        m[y1] = Some(Value::Bool(false));
    }
    let (mut hist, mut errors) = (DurationHistogram::new(), 0u64);
    let begin = Instant::now();
    // Cycle 0 (the first read and the first full write) is not recorded.
    let mut k = 0usize;
    while k < 3 || begin.elapsed() < run_for {
        let changed = &mut outputs.modules[k % UNITS.len()][y1];
        *changed = Some(Value::Bool(!changed.is_some_and(|v| v.as_bool())));
        let t0 = Instant::now();
        let frame = owner.read_inputs();
        let report = owner.write_outputs(&outputs);
        let took = t0.elapsed();
        errors += frame
            .modules
            .iter()
            .filter(|m| m.last_error.is_some())
            .count() as u64
            + u64::from(report.failures);
        if k > 0 {
            hist.record(took);
        }
        k += 1;
    }
    Ok(Ours { hist, errors })
}
