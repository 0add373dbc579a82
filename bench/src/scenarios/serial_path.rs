//! Scenario 7: the real serial path. `softplc sim --pty minimod@5` serves a simulated MiniMod
//! on a pty; the runtime's bus owner (on a `SerialTransport`, as for a USB adapter) and then
//! mbpoll read the same inputs of it (FC 2, discrete inputs 0..10), one after the other in the
//! same run.
//!
//! A pty does not enforce the baud rate. The runtime's bus owner keeps the wire timing of a
//! real line anyway (it waits out the request's characters and t3.5); the simulator replies
//! after the module's reply delay and stays quiet for the reply's wire time.

use std::sync::Arc;
use std::time::Duration;

use softplc::scan::DurationHistogram;
use softplc_io::line::{BusOwner, Discipline, LineSettings, Module, SerialTransport};
use softplc_io::time::{Clock, MonotonicClock};

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::softplc_sim::{softplc_binary, ServedSim};
use crate::{mbpoll, sim_line};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 7,
    name: "serial-path",
    title: "Real serial path: a pty, `softplc sim`, the runtime's bus owner vs mbpoll",
    summary: "One MiniMod (unit 5, reply delay 10 ms) served by `softplc sim --pty` at 19200 8E1; \
              each master reads discrete inputs 0..10 back to back. mbpoll's figure is per run: \
              (K polls − 1 poll) / (K − 1), since it prints no timings. A pty has no baud \
              rate: the request lands at once and the simulator answers after the reply delay, \
              then keeps quiet for the reply's wire time, so both masters are paced at reply \
              delay + reply characters (\"pty pacing\"), below the floor of a real wire.",
    run,
};

const UNIT: u8 = 5;

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let settings = LineSettings::DEFAULT;
    let (floor, pacing) = sim_line::single_read_floor(settings, &[]);
    let binary = softplc_binary()?;
    let sim = ServedSim::start(&binary, &[&format!("minimod@{UNIT}")])?;

    let run_for = ctx.pick(Duration::from_secs(8), Duration::from_millis(1500));
    let ours = bus_owner(&sim, settings, run_for)?;
    let theirs = third_party(ctx, &sim);
    drop(sim);

    let mut out = Outcome::default();
    let ours_p = ours.per_tx.percentiles();
    let ours_tps = ours.count as f64 / ours.elapsed.as_secs_f64();
    let mut row = Row::measured("softplc bus owner", "time per transaction", ours_p);
    if let Ok((_, theirs_hist)) = &theirs {
        row = row.bound(Bound::baseline("mbpoll", &theirs_hist.percentiles()));
    }
    out.rows.push(
        row.bound(Bound::fixed("pty pacing", pacing))
            .bound(Bound::fixed("wire floor", floor))
            .value("tx_per_s", ours_tps)
            .value("errors", ours.errors as f64)
            .note(format!("{ours_tps:.1} tx/s, {} errors", ours.errors)),
    );
    out.rows.push(
        Row::measured("softplc bus owner", "round trip", ours.rtt.percentiles()).note(
            "end of the request's wire time → reply read; the simulator had the request at once",
        ),
    );
    let tps = |p: Duration| {
        if p.is_zero() {
            0.0
        } else {
            1.0 / p.as_secs_f64()
        }
    };
    match theirs {
        Ok((version, hist)) => {
            let p = hist.percentiles();
            out.rows.push(
                Row::measured(version, "time per transaction", p)
                    .bound(Bound::fixed("pty pacing", pacing))
                    .bound(Bound::fixed("wire floor", floor))
                    .value("tx_per_s", tps(p.p50))
                    .note(format!("{:.1} tx/s", tps(p.p50))),
            );
            out.plots.push(Plot {
                file: "serial-path.svg".into(),
                title: "Time per transaction on a pty, 19200 8E1, reply delay 10 ms".into(),
                x_label: "time per transaction".into(),
                kind: PlotKind::Cdf { log_x: false },
                series: vec![
                    Series {
                        label: "softplc bus owner".into(),
                        hist: ours.per_tx,
                    },
                    Series {
                        label: "mbpoll (per run)".into(),
                        hist,
                    },
                ],
            });
        }
        Err(e) => out.rows.push(Row::unavailable(
            "mbpoll",
            "time per transaction",
            e.to_string(),
        )),
    }
    Ok(out)
}

/// What the runtime's bus owner measured.
struct Ours {
    per_tx: DurationHistogram,
    rtt: DurationHistogram,
    count: u64,
    errors: u64,
    elapsed: Duration,
}

/// The runtime's bus owner on the pty, one read cycle (one transaction) after another.
fn bus_owner(sim: &ServedSim, settings: LineSettings, run_for: Duration) -> anyhow::Result<Ours> {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let transport = SerialTransport::open(&sim.path, settings, clock.clone())?;
    let module = Module::new("mm", sim_line::driver(UNIT, &[]));
    let mut owner = BusOwner::new(
        "pty",
        Box::new(transport),
        Discipline::default(),
        vec![module],
    );
    // Warm-up: the first exchange opens the simulator's side of the conversation.
    let mut last = owner.read_inputs().finished;
    let (mut per_tx, mut rtt) = (DurationHistogram::new(), DurationHistogram::new());
    let (mut count, mut errors) = (0u64, 0u64);
    let begin = last;
    while last - begin < run_for {
        let frame = owner.read_inputs();
        let Some(m) = frame.modules.first() else {
            anyhow::bail!("no module on the line")
        };
        if m.last_error.is_some() {
            errors += 1;
        } else {
            rtt.record(m.counters.last_round_trip);
        }
        per_tx.record(frame.finished - last);
        last = frame.finished;
        count += 1;
    }
    Ok(Ours {
        per_tx,
        rtt,
        count,
        errors,
        elapsed: last - begin,
    })
}

/// mbpoll against the same simulator: several runs of K polls.
fn third_party(ctx: &Ctx, sim: &ServedSim) -> anyhow::Result<(String, DurationHistogram)> {
    let Some(version) = mbpoll::version() else {
        anyhow::bail!("mbpoll is not installed (bench/setup installs it)");
    };
    let (runs, polls) = if ctx.quick { (2, 30) } else { (6, 100) };
    let mut hist = DurationHistogram::new();
    for _ in 0..runs {
        hist.record(mbpoll::per_transaction(&sim.path, UNIT, polls)?);
    }
    Ok((format!("{version} (libmodbus)"), hist))
}
