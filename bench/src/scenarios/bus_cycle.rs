//! Scenario 3: the I/O cycle of one line against its wire-time floor and the manual's figures.
//!
//! N MiniMods (1, 4, 8, 16) on the virtual line in real time, at 19200 and 57600 8E1, with the
//! power-on reply delay (RDELAYT = 1: 10 ms) and the shortest the module accepts (RDELAYT = 0,
//! "Setting the reply delay": 0 to 200 hundredths of a second). The runtime's bus owner runs on
//! its own thread and is driven over its channels as the scan drives it; cycles run back to
//! back. Two plans: inputs only (one FC 2 per module), and inputs + outputs written on change
//! with Y1 of every module toggled each cycle (one FC 5 per module: the most a change costs).
//!
//! The floor is DESIGN.md's timing model applied to the plan the drivers make
//! (`softplc_io::line::budget`): request + reply delay + reply + t3.5 per transaction.

use std::sync::Arc;
use std::time::Duration;

use softplc::scan::DurationHistogram;
use softplc_io::line::{BusCommand, BusEvent, BusThread, LineSettings};
use softplc_io::time::{Clock, MonotonicClock};

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_line;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 3,
    name: "bus-cycle",
    title: "Bus cycle: one line of MiniMods against the wire-time floor and the manual",
    summary: "Virtual line in real time, the runtime's bus owner on its thread, cycles back to \
              back. Floor = Σ (request + reply delay + reply + t3.5) over the cycle's \
              transactions. Manual (\"Modbus interface\"): \"three or four slaves … about 50 \
              milliseconds\"; many more: \"hundreds of milliseconds\".",
    run,
};

const COUNTS: [u8; 4] = [1, 4, 8, 16];
const BAUDS: [u32; 2] = [19200, 57600];
/// RDELAYT values: power-on (10 ms) and the shortest accepted (0).
const RDELAYTS: [u8; 2] = [1, 0];

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    let mut plotted = Vec::new();
    for baud in BAUDS {
        for rdelayt in RDELAYTS {
            for n in COUNTS {
                for write in [false, true] {
                    let (row, excess) = measure(ctx, n, baud, rdelayt, write)?;
                    out.rows.push(row);
                    if baud == 19200 && rdelayt == 1 {
                        let what = if write { "in + out" } else { "inputs" };
                        let label = format!("N={n}, {what}");
                        plotted.push(Series {
                            label,
                            hist: excess,
                        });
                    }
                }
            }
        }
    }
    out.plots.push(Plot {
        file: "bus-cycle-19200.svg".into(),
        title: "I/O cycle above its wire-time floor, 19200 8E1, reply delay 10 ms".into(),
        x_label: "cycle time − floor".into(),
        kind: PlotKind::Cdf { log_x: true },
        series: plotted,
    });
    Ok(out)
}

/// Runs one configuration; returns its row and each cycle's time above the floor.
fn measure(
    ctx: &Ctx,
    n: u8,
    baud: u32,
    rdelayt: u8,
    write: bool,
) -> anyhow::Result<(Row, DurationHistogram)> {
    let settings = LineSettings {
        baud,
        ..LineSettings::DEFAULT
    };
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let rdelayt_text = rdelayt.to_string();
    let line = sim_line::minimods(n, settings, &[("RDELAYT", &rdelayt_text)], clock.clone())?;
    let floor = line.budget.read_floor
        + if write {
            line.toggle_write_floor
        } else {
            Duration::ZERO
        };
    let mut bus = BusThread::spawn(line.owner)?;

    let (min_time, min_cycles) = if ctx.quick {
        (Duration::from_millis(200), 1)
    } else {
        (Duration::from_millis(2500), 5)
    };
    let wait = Duration::from_secs(5);
    let mut hist = DurationHistogram::new();
    let mut excess = DurationHistogram::new();
    let begin = clock.now();
    let mut cycles: u64 = 0;
    let mut failures = 0u64;
    // Cycle 0 is not recorded: it does not start with the t3.5 that every later cycle waits
    // out after the previous one's last reply.
    let mut k: u64 = 0;
    loop {
        if k > 0 && cycles >= min_cycles && clock.now() - begin >= min_time {
            break;
        }
        let start = clock.now();
        failures += sim_line::read_failures(&mut bus, wait)?;
        if write {
            bus.send(BusCommand::Write(sim_line::all_y1(
                usize::from(n),
                k % 2 == 0,
            )));
            match bus.recv(wait) {
                Some(BusEvent::Written(report)) => failures += u64::from(report.failures),
                _ => anyhow::bail!("the bus thread did not answer a write within {wait:?}"),
            }
        }
        let took = clock.now() - start;
        if k > 0 {
            hist.record(took);
            excess.record(took.saturating_sub(floor));
            cycles += 1;
        }
        k += 1;
    }
    // The owner handed back is not reused: the line is torn down with the scenario.
    drop(bus.stop(None, wait));

    let delay_ms = u64::from(rdelayt) * 10;
    let case = format!(
        "N={n}, {baud} 8E1, delay {delay_ms} ms, {}",
        if write { "in + out" } else { "inputs" }
    );
    let mut row = Row::measured(case, "I/O cycle", hist.percentiles())
        .bound(Bound::fixed("floor", floor))
        .value("floor_ms", floor.as_secs_f64() * 1e3)
        .value("failed_transactions", failures as f64);
    if n == 4 {
        row = row.bound(Bound::fixed(
            "manual (3–4 slaves)",
            Duration::from_millis(50),
        ));
    }
    if n == 16 {
        row = row.bound(Bound::fixed(
            "manual (many: hundreds of ms)",
            Duration::from_millis(100),
        ));
    }
    if failures > 0 {
        row = row.note(format!("{failures} failed transactions"));
    }
    Ok((row, excess))
}
