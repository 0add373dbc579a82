//! Scenario 9: what a trace costs the scan. A memory-only project of 100 bool tags, each
//! toggled by its own `expr` line, run cycle by cycle on the virtual clock (read, logic,
//! write, then the trace's boundary step, as the service's boundary does it). The same loop
//! without any trace set is the baseline; then with the trace set idle (nothing armed), and
//! with one continuous trace of 10 and of 100 tags (a 1000-sample ring, so it wraps and every
//! cycle writes a sample). The cases take turns, 2000 cycles each, so a slow spell of the
//! machine falls on all of them.

use std::sync::Arc;
use std::time::{Duration, Instant};

use softplc::clock::VirtualClock;
use softplc::logic::ScanContext;
use softplc::plc::Plc;
use softplc::project::RawTrace;
use softplc::scan::{DurationHistogram, ScanStats};
use softplc::trace::TraceSet;

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use softplc_io::time::ScanInstant;

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 9,
    name: "trace-cost",
    title: "Trace: cost per traced tag",
    summary: "One cycle (read, logic, write, the trace's step at the boundary) of a project of \
              100 bool memory tags toggled by 100 `expr` lines, on the virtual clock. Baseline: \
              the same loop with no trace at all. \"per tag\" in the note is (p50 − baseline \
              p50) / tags.",
    run,
};

const TAGS: usize = 100;
const TURN: u64 = 2000;

/// The cases: a label and how many tags the armed trace records (`None`: no trace set).
const CASES: [(&str, Option<usize>); 4] = [
    ("no trace set", None),
    ("idle: nothing armed", Some(0)),
    ("10 traced tags", Some(10)),
    ("100 traced tags", Some(100)),
];

fn project(ctx: &Ctx) -> anyhow::Result<softplc::project::Project> {
    let dir = ctx.scratch.join("trace-cost");
    std::fs::create_dir_all(&dir)?;
    let program: String = (0..TAGS).map(|i| format!("b{i} = !b{i}\n")).collect();
    std::fs::write(dir.join("toggle.expr"), program)?;
    let tags: String = (0..TAGS)
        .map(|i| format!("  - {{ name: b{i}, type: bool }}\n"))
        .collect();
    let yaml = format!(
        "project: tracecost\nscan: {{ period: 10ms }}\ntags:\n{tags}program: {{ file: toggle.expr, kind: expr }}\n"
    );
    let path = dir.join("project.yaml");
    std::fs::write(&path, yaml)?;
    softplc::project::load(&path).map_err(|e| anyhow::anyhow!("{e}"))
}

/// One case's loop state.
struct Case {
    plc: Plc,
    traces: Option<TraceSet>,
    stats: ScanStats,
    hist: DurationHistogram,
}

impl Case {
    fn new(ctx: &Ctx, traced: Option<usize>) -> anyhow::Result<Self> {
        let plc = Plc::build(project(ctx)?, Arc::new(VirtualClock::new()))?;
        let traces = match traced {
            None => None,
            Some(0) => Some(TraceSet::new()),
            Some(n) => {
                let mut set = TraceSet::new();
                let raw = RawTrace {
                    name: "cost".into(),
                    tags: (0..n).map(|i| format!("b{i}")).collect(),
                    pre: Some(1000),
                    post: Some(0),
                    ..RawTrace::default()
                };
                set.arm(plc.project(), None, Some(&raw))
                    .map_err(|e| anyhow::anyhow!("{e}"))?;
                Some(set)
            }
        };
        Ok(Self {
            plc,
            traces,
            stats: ScanStats::default(),
            hist: DurationHistogram::new(),
        })
    }

    /// `cycles` more cycles, each timed alone.
    fn turn(&mut self, cycles: u64) -> anyhow::Result<()> {
        let period = Duration::from_millis(10);
        for _ in 0..cycles {
            let now = ScanInstant::after_origin(
                period * u32::try_from(self.stats.cycles).unwrap_or(u32::MAX),
            );
            let ctx = ScanContext {
                now,
                delta: period,
                cycle: self.stats.cycles,
            };
            let t0 = Instant::now();
            self.plc.read_inputs();
            self.plc
                .run_logic(&ctx)
                .map_err(|e| anyhow::anyhow!("{e}"))?;
            self.plc.write_outputs();
            self.stats.cycles += 1;
            self.stats.last.start = now;
            if let Some(t) = &mut self.traces {
                t.sample(&self.plc, &self.stats);
            }
            let took = t0.elapsed();
            // The first cycles warm the caches.
            if self.stats.cycles > 100 {
                self.hist.record(took);
            }
        }
        Ok(())
    }
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let turns = if ctx.quick { 20 } else { 200 };
    let mut cases = CASES
        .iter()
        .map(|(_, traced)| Case::new(ctx, *traced))
        .collect::<anyhow::Result<Vec<_>>>()?;
    for _ in 0..turns {
        for c in &mut cases {
            c.turn(TURN)?;
        }
    }
    let base = cases[0].hist.percentiles();
    let mut out = Outcome::default();
    let mut series = Vec::new();
    for ((label, traced), case) in CASES.iter().zip(cases) {
        let p = case.hist.percentiles();
        let mut row = Row::measured(*label, "cycle", p);
        match traced {
            None => row = row.note("baseline"),
            Some(n) => {
                let extra_ns = p.p50.as_secs_f64() * 1e9 - base.p50.as_secs_f64() * 1e9;
                row = row.bound(Bound::baseline("no trace set", &base));
                if *n > 0 {
                    let per_tag = extra_ns / *n as f64;
                    row = row
                        .value("ns_per_tag_p50", per_tag)
                        .note(format!("{per_tag:.1} ns per tag"));
                } else {
                    row = row.note(format!("{extra_ns:+.0} ns"));
                }
            }
        }
        out.rows.push(row);
        series.push(Series {
            label: label.to_string(),
            hist: case.hist,
        });
    }
    out.plots.push(Plot {
        file: "trace-cost.svg".into(),
        title: "Cycle time with a trace of 0, 10, 100 tags".into(),
        x_label: "cycle time".into(),
        kind: PlotKind::Cdf { log_x: true },
        series,
    });
    Ok(out)
}
