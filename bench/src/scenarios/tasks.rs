//! Scenario 17: does a slow task hold a fast one back? The two-tasks example on the real
//! clock: the press task (4 MiniMods at 57600 8E1, `tune: reply_delay`, 30 ms) alone, then
//! beside the panel task (8 MiniMods at 9600 8E1, 500 ms) on its own line, each task on its
//! own scan thread as `softplc run` has them. The press's cycle p99 beside the panel against
//! the same task alone (goal ≤ ×1.1), the overruns of both, and the scheduling overhead of a
//! second task: the press's wake-up lateness and cycle p50 with and without it.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Duration;

use softplc::clock::{Clock, MonotonicClock};
use softplc::plc::TaskBuilder;
use softplc::project::Project;
use softplc::scan::{RunOutcome, TaskControl};

use super::{Ctx, Scenario};
use crate::report::{Bound, Outcome, Row};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 17,
    name: "tasks",
    title: "A fast task beside a slow one",
    summary: "The two-tasks example on the real clock: the press task (4 MiniMods, 57600 8E1, \
              reply delay tuned, 30 ms) alone, then beside the panel task (8 MiniMods, 9600 \
              8E1, 500 ms) on its own line and thread. The press's cycle beside the panel \
              against the press alone (goal p99 ≤ ×1.1, no overrun more); the panel's cycle; \
              the press's wake-up lateness with and without the second task (the scheduling \
              overhead of a task).",
    run,
};

/// The example's press task alone: its line, its modules, its tags.
const PRESS_ALONE: &str = "\
project: press-alone
tasks:
  - name: press
    period: 30ms
    watchdog: { time: 50ms, sensitivity: 3 }
    realtime: { priority: 60 }
    program: { file: press.ladder.yaml, kind: ladder }
    buses: [press_line]
buses:
  - { name: press_line, port: sim, baud: 57600, response_timeout: 20ms, tune: reply_delay }
modules:
  - { name: hands,  bus: press_line, model: minimod, address: 1 }
  - { name: guard,  bus: press_line, model: minimod, address: 2 }
  - { name: valves, bus: press_line, model: minimod, address: 3 }
  - { name: ram,    bus: press_line, model: minimod, address: 4 }
tags:
  - { name: hand_left,    point: hands.X1 }
  - { name: hand_right,   point: hands.X2 }
  - { name: guard_closed, point: guard.X1 }
  - { name: ram_top,      point: ram.X1 }
  - { name: press_down,   point: valves.Y1, safe: false }
  - { name: strokes,      type: u16 }
  - { name: enabled,      type: bool }
";

fn example() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/two-tasks")
}

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let run_for = ctx.pick(Duration::from_secs(40), Duration::from_secs(10));
    std::fs::create_dir_all(&ctx.scratch)?;
    std::fs::copy(
        example().join("press.ladder.yaml"),
        ctx.scratch.join("press.ladder.yaml"),
    )?;
    let alone_file = ctx.scratch.join("tasks_press_alone.yaml");
    std::fs::write(&alone_file, PRESS_ALONE)?;
    let alone = softplc::project::load(&alone_file).map_err(|e| anyhow::anyhow!("{e}"))?;
    let both = softplc::project::load(&example().join("project.yaml"))
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let alone = run_tasks(&alone, run_for)?;
    let both = run_tasks(&both, run_for)?;
    let press_alone = &alone[0];
    let (press, panel) = (&both[0], &both[1]);
    let alone_cycle = press_alone.stats.cycle.percentiles();
    let cycle = press.stats.cycle.percentiles();
    let ratio = cycle.p99.as_secs_f64() / alone_cycle.p99.as_secs_f64().max(1e-9);
    let mut out = Outcome::default();
    out.rows.push(
        Row::measured("press alone, 30 ms", "cycle", alone_cycle)
            .bound(Bound::fixed("period", Duration::from_millis(30)))
            .value("overruns", press_alone.stats.overruns as f64)
            .value("cycles", press_alone.stats.cycles as f64)
            .note(format!(
                "{} cycles, {} overruns",
                press_alone.stats.cycles, press_alone.stats.overruns
            )),
    );
    out.rows.push(
        Row::measured("press beside the panel task", "cycle", cycle)
            .bound(Bound::baseline("press alone", &alone_cycle))
            .value("p99_ratio", ratio)
            .value("overruns", press.stats.overruns as f64)
            .value("overruns_alone", press_alone.stats.overruns as f64)
            .note(format!(
                "p99 ×{ratio:.2} of the press alone (goal ≤ ×1.1); overruns {} (alone {})",
                press.stats.overruns, press_alone.stats.overruns
            )),
    );
    out.rows.push(
        Row::measured(
            "panel task, 500 ms",
            "cycle",
            panel.stats.cycle.percentiles(),
        )
        .bound(Bound::fixed("period", Duration::from_millis(500)))
        .value("overruns", panel.stats.overruns as f64)
        .note(format!(
            "{} cycles, {} overruns",
            panel.stats.cycles, panel.stats.overruns
        )),
    );
    let alone_lateness = press_alone.stats.lateness.percentiles();
    out.rows.push(
        Row::measured(
            "press beside the panel task",
            "wake-up lateness",
            press.stats.lateness.percentiles(),
        )
        .bound(Bound::baseline("press alone", &alone_lateness))
        .note(format!(
            "a second task's cost to the first: cycle p50 {} against {} alone",
            softplc::scan::fmt_duration(cycle.p50),
            softplc::scan::fmt_duration(alone_cycle.p50)
        )),
    );
    Ok(out)
}

/// Runs every task of `project` on the real clock for `run_for` each, each built and scanned
/// on a thread of its own at its real-time options (as `softplc run` does); the outcomes in
/// task order.
fn run_tasks(project: &Project, run_for: Duration) -> anyhow::Result<Vec<RunOutcome>> {
    let clock: Arc<dyn Clock> = Arc::new(MonotonicClock::new());
    let builder = Arc::new(TaskBuilder::new(project, Some(clock), None)?);
    let control = TaskControl::new();
    let mut handles = Vec::new();
    for i in 0..project.tasks.len() {
        let (builder, control) = (builder.clone(), control.clone());
        let realtime = builder.realtime(i);
        handles.push(
            std::thread::Builder::new()
                .name(format!("scan-bench-{i}"))
                .spawn(move || -> anyhow::Result<RunOutcome> {
                    // Best effort, as the runtime: refused without CAP_SYS_NICE.
                    drop(softplc::scan::apply_realtime(&realtime));
                    let plc = builder.build(i)?;
                    Ok(control.engine(plc).run_for(run_for).run())
                })?,
        );
    }
    handles
        .into_iter()
        .map(|h| {
            h.join()
                .map_err(|_| anyhow::anyhow!("a task's thread panicked"))?
        })
        .collect()
}
