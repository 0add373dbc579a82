//! Scenario 2: logic cost per scan, ladder and Rhai, 10 / 100 / 1000 rungs.
//!
//! The programs are the synthetic ones of [`synthetic`]: rung `i` is a latch through an
//! on-delay timer, `(x{i} | y{i}) /x{i+1} -> TON t{i}(100ms) -> y{i}`, the same in every
//! engine. The `expr` engine runs the same rungs as the baseline
//! (`y{i} = ton((x{i} | y{i}) & !x{i+1}, 100ms)`). Each scan is timed alone (the engine's
//! `scan` on the process image, 10 ms of scan time per cycle, a few inputs changing every
//! cycle as `synthetic::drive_inputs` moves them), on this thread.

mod synthetic;

use std::time::{Duration, Instant};

use softplc::logic::{LogicEngine, ScanContext};
use softplc::scan::DurationHistogram;

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use softplc_io::time::ScanInstant;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 2,
    name: "logic-cost",
    title: "Logic cost per scan: ladder and Rhai, 10 / 100 / 1000 rungs",
    summary: "Time of one logic scan (the engine alone, no I/O) on the synthetic latch + TON \
              rungs; baseline: the same rungs in the `expr` engine. \"per rung\" in the note is \
              p50 / rungs.",
    run,
};

const RUNGS: [usize; 3] = [10, 100, 1000];

fn compile(engine: &str, n: usize) -> anyhow::Result<Box<dyn LogicEngine>> {
    let language = match engine {
        "ladder" => synthetic::Language::Ladder,
        "Rhai" => synthetic::Language::Rhai,
        _ => synthetic::Language::Expr,
    };
    synthetic::compile(language, n)
}

/// Scans `engine`'s `n`-rung program for `run_for` (at least 50 scans); one sample per scan.
fn measure(engine: &str, n: usize, run_for: Duration) -> anyhow::Result<DurationHistogram> {
    let mut program = compile(engine, n)?;
    let mut image = synthetic::image(n);
    let mut hist = DurationHistogram::new();
    let began = Instant::now();
    let mut cycle: u64 = 0;
    while cycle < 50 || began.elapsed() < run_for {
        synthetic::drive_inputs(&mut image, n, cycle);
        let ctx = ScanContext {
            now: ScanInstant::after_origin(Duration::from_millis(10 * cycle)),
            delta: Duration::from_millis(10),
            cycle,
        };
        let t0 = Instant::now();
        program
            .scan(&mut image, &ctx)
            .map_err(|e| anyhow::anyhow!("{e}"))?;
        let took = t0.elapsed();
        // The first scans warm caches and allocate the engines' state.
        if cycle >= 10 {
            hist.record(took);
        }
        cycle += 1;
    }
    Ok(hist)
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let run_for = ctx.pick(Duration::from_millis(1500), Duration::from_millis(250));
    let mut out = Outcome::default();
    let mut series = Vec::new();
    for n in RUNGS {
        let baseline = measure("expr", n, run_for)?;
        let base_p = baseline.percentiles();
        for engine in ["ladder", "Rhai", "expr"] {
            let hist = if engine == "expr" {
                baseline.clone()
            } else {
                measure(engine, n, run_for)?
            };
            let p = hist.percentiles();
            let per_rung = p.p50.as_secs_f64() * 1e9 / n as f64;
            let mut row = Row::measured(format!("{engine}, {n} rungs"), "logic scan", p)
                .value("ns_per_rung_p50", per_rung)
                .note(format!("{per_rung:.0} ns per rung"));
            if engine != "expr" {
                row = row.bound(Bound::baseline("expr engine", &base_p));
            }
            out.rows.push(row);
            if n == 100 {
                series.push(Series {
                    label: format!("{engine}, 100 rungs"),
                    hist,
                });
            }
        }
    }
    out.plots.push(Plot {
        file: "logic-cost-100-rungs.svg".into(),
        title: "Logic scan time, 100 synthetic rungs".into(),
        x_label: "scan time".into(),
        kind: PlotKind::Cdf { log_x: true },
        series,
    });
    Ok(out)
}
