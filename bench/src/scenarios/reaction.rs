//! Scenario 5: reaction latency, input edge → output edge at the simulated module's terminals,
//! over many edges at pseudo-random times: central logic against the module's own logic.
//!
//! - Central: `y = x` (X1 → Y1 of one MiniMod) on the runtime's scan in real time, 19200 8E1,
//!   reply delay 10 ms, scan period 50 ms: the edge waits for the next input phase, then the
//!   output phase's write.
//! - MiniMod AON/AOFF: the same program with `offload: auto`: the push-down planner moves the
//!   rung into the module (Y1AON1 = X1, Y1AOFF1 = -X1, "Automatic output management"), the
//!   driver writes and verifies the tables at start-up, and the scan reads Y1 back.
//! - RESI-16DI8RO SWITCH and TOGGLE: not yet available (no RESI model yet).
//!
//! Both MiniMod cases include the module's power-on input filter (XLATUP/XLATDN = 20 ms).

use std::sync::Arc;
use std::time::Duration;

use anyhow::Context;
use softplc::clock::MonotonicClock;
use softplc::plc::Plc;
use softplc::scan::{DurationHistogram, ScanEngine};
use softplc_io::line::LineSettings;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_line;
use crate::terminal::ReactionProbe;

/// The scenario.
pub const SCENARIO: Scenario = Scenario {
    number: 5,
    name: "reaction",
    title: "Reaction latency: input edge → output edge, central vs in the module",
    summary: "X1 flipped at the simulated MiniMod's terminal at pseudo-random times, Y1 sampled \
              every 1 ms. 19200 8E1, reply delay 10 ms, scan period 50 ms; both cases include \
              the module's 20 ms power-on input filter (XLATUP/XLATDN). Bus cycle floor = one \
              FC 2 read + one FC 5 write.",
    run,
};

const PERIOD: Duration = Duration::from_millis(50);
const RESI: &str = "the RESI-16DI8RO driver, simulator and push-down planner";
const RESI_ISSUE: &str = "RESI and push-down issues";

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let (read_floor, _) = sim_line::single_read_floor(LineSettings::DEFAULT, &[]);
    let write_floor = {
        let clock = Arc::new(MonotonicClock::new());
        sim_line::minimods(1, LineSettings::DEFAULT, &[], clock)?.toggle_write_floor
    };
    let central = probe(ctx, false)?;
    let module = probe(ctx, true)?;
    let central_p = central.latencies.percentiles();
    let mut out = Outcome::default();
    out.rows.push(
        Row::measured("central: y = x, scan 50 ms", "X1 edge → Y1 edge", central_p)
            .bound(Bound::fixed("scan period", PERIOD))
            .bound(Bound::fixed("bus cycle floor", read_floor + write_floor))
            .value("missed_edges", central.missed as f64),
    );
    out.rows.push(
        Row::measured(
            "MiniMod Y1AON1 = X1, Y1AOFF1 = -X1",
            "X1 edge → Y1 edge",
            module.latencies.percentiles(),
        )
        .bound(Bound::baseline("central", &central_p))
        .bound(Bound::fixed("scan period", PERIOD))
        .value("missed_edges", module.missed as f64)
        .note("pushed down by the planner (offload: auto)"),
    );
    out.rows
        .push(Row::not_yet("RESI-16DI8RO SWITCH", RESI, RESI_ISSUE));
    out.rows
        .push(Row::not_yet("RESI-16DI8RO TOGGLE", RESI, RESI_ISSUE));
    out.plots.push(Plot {
        file: "reaction-latency.svg".into(),
        title: "Reaction latency, X1 edge → Y1 edge at the terminals".into(),
        x_label: "latency".into(),
        kind: PlotKind::Cdf { log_x: false },
        series: vec![
            Series {
                label: "central, scan 50 ms".into(),
                hist: central.latencies,
            },
            Series {
                label: "MiniMod AON/AOFF".into(),
                hist: module.latencies,
            },
        ],
    });
    Ok(out)
}

/// What one case measured.
struct Probed {
    latencies: DurationHistogram,
    missed: u64,
}

/// Runs the project (central: `y = x`; in the module: AON/AOFF settings) and flips X1.
fn probe(ctx: &Ctx, in_module: bool) -> anyhow::Result<Probed> {
    let run_for = ctx.pick(Duration::from_secs(12), Duration::from_millis(2500));
    let bus = SimBus::new("line1", 19200, [1]);
    let mut tags = vec![
        "{ name: x, point: line1_m1.X1 }".to_string(),
        "{ name: beat, type: bool }".to_string(),
    ];
    tags.push("{ name: y, point: line1_m1.Y1, safe: false }".into());
    let program = "beat = !beat\ny = x\n";
    let offload = if in_module { "auto" } else { "never" };
    let name = if in_module {
        "reaction_module"
    } else {
        "reaction_central"
    };
    let project =
        project_file::load_offload(&ctx.scratch, name, "50ms", &[bus], &tags, program, offload)?;
    let plc = Plc::build(project, Arc::new(MonotonicClock::new()))?;
    let clock = plc.clock().clone();
    let world = plc
        .world()
        .cloned()
        .context("the project has no simulated world")?;
    let device = world
        .lock()
        .unwrap_or_else(|e| e.into_inner())
        .find("line1_m1")
        .context("module line1_m1 is not in the world")?;
    let begin = clock.now();
    let scan = std::thread::Builder::new()
        .name(format!("scan-{name}"))
        .spawn(move || ScanEngine::new(plc).run_for(run_for).run())?;
    let mut probe = ReactionProbe::new(world, device, "X1", "Y1");
    let timeout = Duration::from_millis(500);
    // Gaps of 120..320 ms from a fixed LCG: edges fall anywhere in the scan's period.
    let mut seed: u32 = 0x2545_F491;
    let stop = begin + run_for.saturating_sub(timeout + PERIOD * 2);
    while clock.now() < stop {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let gap = Duration::from_millis(120 + u64::from(seed >> 24) * 200 / 256);
        clock.sleep_until(clock.now() + gap);
        probe.edge(clock.as_ref(), timeout);
    }
    scan.join()
        .map_err(|_| anyhow::anyhow!("the scan thread panicked"))?;
    Ok(Probed {
        latencies: probe.latencies,
        missed: probe.missed,
    })
}
