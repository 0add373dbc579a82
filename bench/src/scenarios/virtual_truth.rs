//! Scenario 13: does the virtual clock tell the truth? The same project, two factory-default
//! MiniMods on one simulated line at 19200 8E1 in event mode (the default), one output each
//! held by the program, inputs idle, run by the runtime's scan engine on the virtual clock and
//! on the real one (every line on its own bus thread) for the same time, at periods where
//! `check` predicts no overrun, some, and most. A test cannot compare the two (the real clock
//! on a busy machine is not deterministic); the bench can, and reports the ratio of overrun
//! counts and of cycle p99, real against virtual, beside `check`'s prediction.

use std::sync::Arc;
use std::time::Duration;

use softplc::clock::{MonotonicClock, VirtualClock};
use softplc::plc::Plc;
use softplc::scan::{RunOutcome, ScanEngine};
use softplc_io::line::AdapterTiming;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Row};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 13,
    name: "virtual-truth",
    title: "The virtual clock against the real one",
    summary: "2 MiniMods in event mode, 19200 8E1, factory reply delay, outputs held, inputs \
              idle; the runtime's scan engine on the virtual clock and on the real one for the \
              same time at 10, 20 and 50 ms. Cycle p99 on the real clock against the virtual \
              clock's (the bound); overruns of both and their ratio, beside check's prediction.",
    run,
};

const PERIODS_MS: [u64; 3] = [10, 20, 50];

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let run_for = ctx.pick(Duration::from_secs(30), Duration::from_secs(3));
    let mut out = Outcome::default();
    for period_ms in PERIODS_MS {
        let buses = [SimBus::new("line1", 19200, 1..=2)];
        let tags = [
            "{ name: x1, point: line1_m1.X1 }".to_string(),
            "{ name: x2, point: line1_m2.X1 }".to_string(),
            "{ name: y1, point: line1_m1.Y1 }".to_string(),
            "{ name: y2, point: line1_m2.Y1 }".to_string(),
        ];
        let name = format!("virtual_truth_{period_ms}");
        let period = format!("{period_ms}ms");
        let load = || {
            project_file::load(
                &ctx.scratch,
                &name,
                &period,
                &buses,
                &tags,
                "y1 = x1\ny2 = x2\n",
            )
        };
        let project = load()?;
        let predicted = prediction(&project, Duration::from_millis(period_ms));
        let virtual_run = scan(Plc::build(load()?, Arc::new(VirtualClock::new()))?, run_for)?;
        let real_run = scan(
            Plc::build(project, Arc::new(MonotonicClock::new()))?,
            run_for,
        )?;
        let (v, r) = (virtual_run.stats.overruns, real_run.stats.overruns);
        let virtual_cycle = virtual_run.stats.cycle.percentiles();
        let ratio = if v == 0 {
            f64::NAN
        } else {
            r as f64 / v as f64
        };
        out.rows.push(
            Row::measured(
                format!("{period_ms} ms, real clock"),
                "cycle",
                real_run.stats.cycle.percentiles(),
            )
            .bound(Bound::baseline("virtual clock", &virtual_cycle))
            .value("overruns_real", r as f64)
            .value("overruns_virtual", v as f64)
            .value("overrun_ratio", ratio)
            .value("predicted_per_minute", predicted)
            .note(format!(
                "overruns: real {r}, virtual {v} (×{ratio:.2}); check predicts {:.0} in {:.0} s",
                predicted * run_for.as_secs_f64() / 60.0,
                run_for.as_secs_f64()
            )),
        );
    }
    Ok(out)
}

/// Runs `plc` for `run_for` on its own thread (the scan's, as `softplc run` has it).
fn scan(plc: Plc, run_for: Duration) -> anyhow::Result<RunOutcome> {
    std::thread::Builder::new()
        .name("scan-virtual-truth".into())
        .spawn(move || ScanEngine::new(plc).run_for(run_for).run())?
        .join()
        .map_err(|_| anyhow::anyhow!("the scan thread panicked"))
}

/// `check`'s prediction for the project's one line: overruns a minute with idle inputs.
fn prediction(project: &softplc::project::Project, period: Duration) -> f64 {
    project
        .cycle_mix(0, AdapterTiming::default())
        .predict(period)
        .per_minute
}
