//! Scenario 1: wake-up lateness of the scan thread against a tokio-interval loop.
//!
//! For each period (1, 10, 20 ms), three loops run side by side for the same time, their
//! phases staggered by a third of a period so they do not wake at the same instant:
//! - the runtime's scan thread (`ScanEngine` on a project with no bus and a one-line program),
//!   normal scheduling: lateness as the scan itself records it (start − deadline);
//! - the same with SCHED_FIFO priority 50 (the project's `realtime.priority`), when the OS
//!   grants it;
//! - a tokio `interval` loop (current-thread runtime, missed ticks skipped like the scan):
//!   lateness = wake-up − the tick's scheduled instant.
//!
//! Then again with a competing CPU load: one busy thread per CPU in this process.

use std::sync::Arc;
use std::time::Duration;

use softplc::clock::MonotonicClock;
use softplc::plc::Plc;
use softplc::project::RealtimeConfig;
use softplc::scan::{apply_realtime, DurationHistogram, ScanEngine};

use super::{Ctx, Scenario};
use crate::cpu_load::CpuLoad;
use crate::project_file;
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 1,
    name: "scheduler",
    title: "Scheduler: wake-up lateness of the scan thread vs a tokio interval loop",
    summary: "Lateness = actual wake-up − deadline. The three loops of a period run at the same \
              time; ratios are scan thread / tokio loop at the same percentile.",
    run,
};

const PERIODS_MS: [u64; 3] = [1, 10, 20];
const FIFO_PRIORITY: u8 = 50;

/// What one loop measured.
struct Measured {
    hist: DurationHistogram,
    /// Why the loop could not run as asked (SCHED_FIFO refused).
    refused: Option<String>,
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let run_for = ctx.pick(Duration::from_secs(6), Duration::from_secs(1));
    let mut out = Outcome::default();
    for load in [false, true] {
        let mut series = Vec::new();
        for period_ms in PERIODS_MS {
            let period = Duration::from_millis(period_ms);
            let (plain, fifo, tokio) = measure(ctx, period, run_for, load)?;
            let case = |what: &str| {
                format!(
                    "{period_ms} ms, {what}{}",
                    if load { ", CPU load" } else { "" }
                )
            };
            let tokio_p = tokio.hist.percentiles();
            let period_bound = Bound::fixed("period", period);
            out.rows.push(
                Row::measured(
                    case("scan thread"),
                    "wake-up lateness",
                    plain.hist.percentiles(),
                )
                .bound(Bound::baseline("tokio loop", &tokio_p))
                .bound(period_bound.clone()),
            );
            match &fifo.refused {
                None => out.rows.push(
                    Row::measured(
                        case(&format!("scan thread, SCHED_FIFO {FIFO_PRIORITY}")),
                        "wake-up lateness",
                        fifo.hist.percentiles(),
                    )
                    .bound(Bound::baseline("tokio loop", &tokio_p))
                    .bound(period_bound.clone()),
                ),
                Some(why) => out.rows.push(Row::unavailable(
                    case(&format!("scan thread, SCHED_FIFO {FIFO_PRIORITY}")),
                    "wake-up lateness",
                    why.clone(),
                )),
            }
            out.rows.push(
                Row::measured(case("tokio interval"), "wake-up lateness", tokio_p)
                    .bound(period_bound)
                    .note("baseline"),
            );
            series.push(Series {
                label: format!("scan thread {period_ms} ms"),
                hist: plain.hist,
            });
            if fifo.refused.is_none() {
                series.push(Series {
                    label: format!("scan FIFO {period_ms} ms"),
                    hist: fifo.hist,
                });
            }
            series.push(Series {
                label: format!("tokio {period_ms} ms"),
                hist: tokio.hist,
            });
        }
        let which = if load { "load" } else { "no-load" };
        out.plots.push(Plot {
            file: format!("scheduler-lateness-{which}.svg"),
            title: format!(
                "Wake-up lateness, {}",
                if load {
                    "with a busy thread per CPU"
                } else {
                    "no added load"
                }
            ),
            x_label: "lateness".into(),
            kind: PlotKind::Cdf { log_x: true },
            series,
        });
    }
    Ok(out)
}

/// Runs the three loops of one period side by side.
fn measure(
    ctx: &Ctx,
    period: Duration,
    run_for: Duration,
    load: bool,
) -> anyhow::Result<(Measured, Measured, Measured)> {
    let ms = period.as_millis();
    let plain = scan_engine(ctx, &format!("sched_{ms}ms_a"), period, run_for, None)?;
    let fifo = scan_engine(
        ctx,
        &format!("sched_{ms}ms_b"),
        period,
        run_for,
        Some(FIFO_PRIORITY),
    )?;
    let _load = load.then(|| CpuLoad::per_cpu(run_for + period * 2 + Duration::from_secs(2)));
    let stagger = period / 3;
    std::thread::scope(|s| {
        let a = s.spawn(plain);
        let b = s.spawn(move || {
            std::thread::sleep(stagger);
            fifo()
        });
        let c = s.spawn(move || {
            std::thread::sleep(stagger * 2);
            tokio_loop(period, run_for)
        });
        let join = |h: std::thread::ScopedJoinHandle<'_, anyhow::Result<Measured>>| {
            h.join()
                .map_err(|_| anyhow::anyhow!("a measuring thread panicked"))?
        };
        Ok((join(a)?, join(b)?, join(c)?))
    })
}

/// Prepares a scan engine on a bus-less project; the returned closure runs it on the calling
/// thread (after applying SCHED_FIFO `priority`, if given) and returns its lateness.
fn scan_engine(
    ctx: &Ctx,
    name: &str,
    period: Duration,
    run_for: Duration,
    priority: Option<u8>,
) -> anyhow::Result<impl FnOnce() -> anyhow::Result<Measured> + Send> {
    let period_text = format!("{}us", period.as_micros());
    let tags = ["{ name: beat, type: bool }".to_string()];
    let project = project_file::load(
        &ctx.scratch,
        name,
        &period_text,
        &[],
        &tags,
        "beat = !beat\n",
    )?;
    let plc = Plc::build(project, Arc::new(MonotonicClock::new()))?;
    Ok(move || {
        let mut refused = None;
        if let Some(p) = priority {
            let cfg = RealtimeConfig {
                priority: Some(p),
                ..RealtimeConfig::default()
            };
            for note in apply_realtime(&cfg).notes {
                if !note.applied {
                    refused = Some(note.text);
                }
            }
        }
        let outcome = ScanEngine::new(plc).run_for(run_for).run();
        Ok(Measured {
            hist: outcome.stats.lateness,
            refused,
        })
    })
}

/// A tokio interval loop on a current-thread runtime: the naive async heartbeat.
fn tokio_loop(period: Duration, run_for: Duration) -> anyhow::Result<Measured> {
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_time()
        .build()?;
    let hist = runtime.block_on(async move {
        let mut hist = DurationHistogram::new();
        let start = tokio::time::Instant::now();
        let mut ticks = tokio::time::interval_at(start, period);
        ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
        while start.elapsed() < run_for {
            let due = ticks.tick().await;
            hist.record(tokio::time::Instant::now().saturating_duration_since(due));
        }
        hist
    });
    Ok(Measured {
        hist,
        refused: None,
    })
}
