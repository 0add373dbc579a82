//! Scenario 6: a 50 ms pulse requested by a program that scans every 80 ms (the MiniMod
//! manual's own example, "Pulse generation"), measured at the simulated module's terminal.
//!
//! - Central: an `expr` program on the virtual line in real time, `pulse = tp(req, 50ms)` with
//!   `pulse` bound to Y1; `req` is a one-scan request every 7 scans from an on-delay timer. The
//!   scan can only switch Y1 at its write phases, 80 ms apart.
//! - YPULSE: the same program with `offload: auto`: the push-down planner keeps the trigger in
//!   the scan and turns the pulse into a write of YPULSE1 = 50 (holding register 83, 40084) on
//!   each trigger edge; the module's own pulser times the output.
//!
//! Y1 is sampled at the terminal every millisecond (so widths are good to about ±1 ms).

use std::time::Duration;

use softplc::scan::DurationHistogram;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_scan::Scanning;
use crate::terminal::PulseWatch;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 6,
    name: "pulse",
    title: "Pulse accuracy: 50 ms requested by a program scanning every 80 ms",
    summary: "On-time of Y1 at the simulated MiniMod's terminal (sampled every 1 ms), 19200 8E1, \
              reply delay 10 ms. Ratio = measured width / requested 50 ms.",
    run,
};

const WIDTH: Duration = Duration::from_millis(50);
const PERIOD: Duration = Duration::from_millis(80);

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let central = program(ctx, "never")?;
    let pushed = program(ctx, "auto")?;
    let mut out = Outcome::default();
    let row = |case: &str, h: &DurationHistogram| {
        let p = h.percentiles();
        Row::measured(case, "on-time at terminal", p)
            .bound(Bound::fixed("requested", WIDTH))
            .value(
                "error_p50_ms",
                (p.p50.as_secs_f64() - WIDTH.as_secs_f64()) * 1e3,
            )
            .value(
                "error_max_ms",
                (p.max.as_secs_f64() - WIDTH.as_secs_f64()) * 1e3,
            )
    };
    out.rows.push(
        row("central: tp(req, 50ms), scan 80 ms", &central)
            .bound(Bound::fixed("scan period", PERIOD))
            .note("the scan switches Y1 only at its write phases"),
    );
    out.rows.push(
        row("pushed down: YPULSE1 = 50 (HR 83)", &pushed).note(
            "the planner's push-down (offload: auto): trigger in the scan, width in the module",
        ),
    );
    out.plots.push(Plot {
        file: "pulse-width.svg".into(),
        title: "On-time of a 50 ms pulse at the terminal".into(),
        x_label: "on-time".into(),
        kind: PlotKind::Histogram,
        series: vec![
            Series {
                label: "central tp, scan 80 ms".into(),
                hist: central,
            },
            Series {
                label: "YPULSE1 = 50".into(),
                hist: pushed,
            },
        ],
    });
    Ok(out)
}

/// The program, central (`offload: never`) or pushed down (`auto`); widths of Y1's pulses at
/// the terminal.
fn program(ctx: &Ctx, offload: &str) -> anyhow::Result<DurationHistogram> {
    let run_for = ctx.pick(Duration::from_secs(12), Duration::from_millis(2500));
    let bus = SimBus::new("line1", 19200, [1]);
    let tags = [
        "{ name: req, type: bool }".to_string(),
        "{ name: pulse, point: line1_m1.Y1, safe: false }".to_string(),
    ];
    let program = "req = ton(!req, 400ms)\npulse = tp(req, 50ms)\n";
    let project = project_file::load_offload(
        &ctx.scratch,
        &format!("pulse_{offload}"),
        "80ms",
        &[bus],
        &tags,
        program,
        offload,
    )?;
    let scan = Scanning::start(project, "scan-pulse".to_string(), run_for)?;
    let clock = scan.clock.clone();
    let begin = scan.begin;
    let mut watch = PulseWatch::new(scan.world.clone(), scan.device, "Y1");
    // Stop before the end so the shutdown's safe state does not cut a pulse short.
    watch.run_until(clock.as_ref(), begin + run_for.saturating_sub(PERIOD * 2));
    scan.join()?;
    Ok(watch.widths)
}
