//! Scenario 4: FC 70 Collect against its floor and against polling, 4, 10 and 16 MiniMods on
//! the virtual line in real time (19200 8E1, reply delay 10 ms), with no input changes and
//! with a few (X1 of two modules flipped at their terminals before every round). Time per
//! round = one read cycle of the runtime's bus owner on its thread; against the wire-time
//! floor of that round (`CollectFloor`, the function `softplc check` prints), the polling
//! cycle of the same modules in the same run, and the manual's "down to 5% of the original
//! time when no variations have happened" ("Modbus function Collect").
//!
//! Event mode is the driver's `events: true`; its periodic full reads (`event_refresh`,
//! `event_resync`) are set to 60 s so that the rounds measured are Collect rounds (the first cycle, which always
//! refreshes, is not recorded), and X1's input latency (`XLATUP1`, `XLATDN1`) to 0 so that a
//! flip made before a round is in that round, which makes every changing round one of two
//! events and its floor known. The flipped modules are never the window's last address
//! (whose event ends a round early, a different floor): every changing round has the same
//! floor. Polling does not depend on changes: it is measured once.

use std::sync::Arc;
use std::time::Duration;

use softplc::scan::DurationHistogram;
use softplc_io::line::{AdapterTiming, BusThread, CollectFloor, CollectStats, LineSettings};
use softplc_io::point::Value;
use softplc_io::sim::SharedWorld;
use softplc_io::time::{Clock, MonotonicClock};

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_line;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 4,
    name: "collect",
    title: "Collect vs its floor and vs polling: time per round",
    summary: "One read cycle of the bus owner, 19200 8E1, reply delay 10 ms. Event mode: \
              `events: true`, `event_refresh` and `event_resync` 60s, X1's input latency 0. \"a few \
              changes\": X1 of two modules (never the last address) flipped before every \
              round, two events per round. Floor: the Collect requests (8 characters each), \
              the window's 3 ms slots before each reply and 1 ms after the last, each reply's \
              9 characters from the start of its slot, t3.5 after each; no reply delay. The \
              manual's claim is a ratio of ×0.05 to polling with no changes.",
    run,
};

const COUNTS: [u8; 3] = [4, 10, 16];
const EVENT_MODE: [(&str, &str); 5] = [
    ("events", "true"),
    ("event_refresh", "60s"),
    ("event_resync", "60s"),
    ("XLATUP1", "0"),
    ("XLATDN1", "0"),
];

/// What one configuration measured.
struct Rounds {
    hist: DurationHistogram,
    /// Events delivered per Collect round (the warm-up round included).
    per_round: f64,
    /// Failed transactions and failed Collect rounds.
    failures: u64,
    /// The wire-time floor of the rounds measured (the largest, should they differ).
    floor: Duration,
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    let mut series = Vec::new();
    for n in COUNTS {
        let polling = rounds(ctx, n, &[], false)?;
        let poll_p = polling.hist.percentiles();
        out.rows.push(
            Row::measured(format!("N={n}, polling"), "time per round", poll_p)
                .value("failures", polling.failures as f64)
                .note("baseline"),
        );
        for changes in [false, true] {
            let collect = rounds(ctx, n, &EVENT_MODE, changes)?;
            let p = collect.hist.percentiles();
            let what = if changes {
                "a few changes"
            } else {
                "no changes"
            };
            let per_round = collect.per_round;
            out.rows.push(
                Row::measured(format!("N={n}, Collect, {what}"), "time per round", p)
                    .bound(Bound::fixed("floor", collect.floor))
                    .bound(Bound::baseline("polling", &poll_p))
                    .bound(Bound::fixed(
                        "manual: 5 % of polling",
                        poll_p.p50.mul_f64(0.05),
                    ))
                    .value("floor_ms", collect.floor.as_secs_f64() * 1e3)
                    .value("events_per_round", per_round)
                    .value("failures", collect.failures as f64)
                    .note(format!("{per_round:.1} events per round")),
            );
            if n == 16 {
                series.push(Series {
                    label: format!("Collect, {what}"),
                    hist: collect.hist,
                });
            }
        }
        if n == 16 {
            series.push(Series {
                label: "polling".into(),
                hist: polling.hist,
            });
        }
    }
    out.plots.push(Plot {
        file: "collect-16.svg".into(),
        title: "Time per round, 16 MiniMods, 19200 8E1".into(),
        x_label: "time per round".into(),
        kind: PlotKind::Cdf { log_x: true },
        series,
    });
    Ok(out)
}

/// Read cycles back to back on `n` modules with `settings`; with `changes`, X1 of two modules
/// is flipped before each.
fn rounds(ctx: &Ctx, n: u8, settings: &[(&str, &str)], changes: bool) -> anyhow::Result<Rounds> {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let line = sim_line::minimods(n, LineSettings::DEFAULT, settings, clock.clone())?;
    let world = line.world.clone();
    let mut bus = BusThread::spawn(line.owner)?;
    let (min_time, min_rounds) = if ctx.quick {
        (Duration::from_millis(200), 1)
    } else {
        (Duration::from_millis(2500), 10)
    };
    let wait = Duration::from_secs(5);
    let members: Vec<u8> = (1..=n).collect();
    let floor_of = CollectFloor::over(LineSettings::DEFAULT, AdapterTiming::default(), &members)
        .ok_or_else(|| anyhow::anyhow!("no Collect window over {n} modules"))?;
    let mut floor = Duration::ZERO;
    let mut hist = DurationHistogram::new();
    let mut failures = 0u64;
    let begin = clock.now();
    let mut levels = vec![false; usize::from(n)];
    let mut k: u64 = 0;
    loop {
        if k > 0 && hist.percentiles().count >= min_rounds && clock.now() - begin >= min_time {
            break;
        }
        let mut flipped = Vec::new();
        if changes {
            // Modules 1..n−1: the last address's event would end the round early.
            for j in [2 * k, 2 * k + 1] {
                let i = (j % u64::from(n - 1)) as usize;
                levels[i] = !levels[i];
                set_x1(&world, clock.as_ref(), i, levels[i]);
                flipped.push(i as u8 + 1);
            }
        }
        let start = clock.now();
        failures += sim_line::read_failures(&mut bus, wait)?;
        // The first cycle of event mode is a full refresh of every module.
        if k > 0 {
            hist.record(clock.now() - start);
            floor = floor.max(floor_of.round(&flipped));
        }
        k += 1;
    }
    let (stats, per_round) = stop(bus, wait)?;
    Ok(Rounds {
        hist,
        per_round,
        failures: failures + stats.failures,
        floor,
    })
}

/// Stops `bus` within `wait`; its Collect counters and the events a round.
pub(super) fn stop(bus: BusThread, wait: Duration) -> anyhow::Result<(CollectStats, f64)> {
    let owner = bus
        .stop(None, wait)
        .ok_or_else(|| anyhow::anyhow!("the bus thread was lost"))?;
    let stats = owner.collect_stats();
    Ok((stats, stats.events as f64 / stats.rounds.max(1) as f64))
}

/// Sets X1 of device `index` at its terminal.
pub(super) fn set_x1(world: &SharedWorld, clock: &dyn Clock, index: usize, level: bool) {
    let mut w = world.lock().unwrap_or_else(|e| e.into_inner());
    w.advance_to(clock.line_now());
    // A stimulus that never reached the terminal would make the measurement meaningless.
    if let Err(e) = w.set(index, "X1", Value::Bool(level)) {
        panic!("setting X1 of simulated device {index}: {e}");
    }
}
