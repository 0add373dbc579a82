//! Scenario 5: reaction latency, input edge → output edge at the simulated module's terminals,
//! over many edges at pseudo-random times: central logic against the module's own logic.
//!
//! Each case runs twice on the runtime's scan in real time, 19200 8E1, scan period 50 ms, with
//! the same input edges: central (`offload: never`), where the edge waits for the next input
//! phase, then the output phase's write; and pushed down (`offload: auto`), where the planner
//! moves the rung into the module, the driver writes and verifies its tables at start-up, and
//! the scan reads the output back.
//!
//! - MiniMod AON/AOFF: `y = x` (X1 → Y1), reply delay 10 ms; pushed down as Y1AON1 = X1,
//!   Y1AOFF1 = -X1 ("Automatic output management"). Both include the module's power-on input
//!   filter (XLATUP/XLATDN = 20 ms). The same with X1's latencies set to 1 ms (XLATUP1 =
//!   XLATDN1 = 1), against the 2 ms goal: the filter, the module's 1 ms tick and the 1 ms
//!   sampling of the terminal are what is left.
//! - RESI-16DI8RO SWITCH: `y = x` (DI1 → RO1), reply delay 2 ms; pushed down as SWITCH RO1 =
//!   DI1. The module samples its inputs every 10 ms.
//! - RESI-16DI8RO TOGGLE: `y = y ^ rising(x)` (an impulse relay); pushed down as TOGGLE RO1 =
//!   DI1. Only rising edges are timed (a falling edge leaves the relay alone).

use std::time::Duration;

use anyhow::Context;
use softplc::scan::DurationHistogram;
use softplc_io::line::LineSettings;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};
use crate::sim_line;
use crate::sim_scan::Scanning;
use crate::terminal::{Follow, ReactionProbe};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 5,
    name: "reaction",
    title: "Reaction latency: input edge → output edge, central vs in the module",
    summary: "An input flipped at the simulated module's terminal at pseudo-random times, the \
              output sampled every 1 ms. 19200 8E1, scan period 50 ms. MiniMod (X1 → Y1): \
              reply delay 10 ms; both cases include the module's 20 ms power-on input filter \
              (XLATUP/XLATDN), and again with X1's filter set to 1 ms (goal 2 ms). RESI-16DI8RO (DI1 → RO1): reply delay 2 ms, inputs sampled \
              every 10 ms; TOGGLE rows time rising edges only. Bus cycle floor = one read \
              cycle + one write of the output (MiniMod FC 2 + FC 5, RESI FC 1 + FC 5).",
    run,
};

const PERIOD: Duration = Duration::from_millis(50);

/// One program on one module, run central and pushed down.
struct Case {
    /// Scratch file and thread names.
    file: &'static str,
    /// Catalog model of the module.
    model: &'static str,
    /// The module's `settings:` mapping in the project, empty for its power-on settings.
    settings: &'static str,
    /// Input and output terminals, bound to tags `x` and `y`.
    input: &'static str,
    output: &'static str,
    /// The `expr` program (`beat` keeps a rung in the scan when `y`'s goes to the module).
    program: &'static str,
    follow: Follow,
    /// Row names, central and pushed down; the metric.
    central: &'static str,
    module: &'static str,
    metric: &'static str,
    /// The pushed-down row's note.
    note: &'static str,
    /// A figure of the module itself that the pushed-down row is also held against.
    module_bound: Option<(&'static str, Duration)>,
    /// Plot labels, central and pushed down.
    labels: [&'static str; 2],
}

const RESI_SAMPLE: (&str, Duration) = ("RESI input sample", Duration::from_millis(10));

const CASES: [Case; 4] = [
    Case {
        file: "reaction_minimod",
        model: "minimod",
        settings: "",
        input: "X1",
        output: "Y1",
        program: "beat = !beat\ny = x\n",
        follow: Follow::Level,
        central: "central: y = x, scan 50 ms",
        module: "MiniMod Y1AON1 = X1, Y1AOFF1 = -X1",
        metric: "X1 edge → Y1 edge",
        note: "pushed down by the planner (offload: auto)",
        module_bound: None,
        labels: ["central, scan 50 ms", "MiniMod AON/AOFF"],
    },
    Case {
        file: "reaction_minimod_fast",
        model: "minimod",
        settings: "{ XLATUP1: 1, XLATDN1: 1 }",
        input: "X1",
        output: "Y1",
        program: "beat = !beat\ny = x\n",
        follow: Follow::Level,
        central: "central: y = x, scan 50 ms, X1 latency 1 ms",
        module: "MiniMod Y1AON1 = X1, Y1AOFF1 = -X1, X1 latency 1 ms",
        metric: "X1 edge → Y1 edge",
        note: "pushed down by the planner (offload: auto); XLATUP1 = XLATDN1 = 1 ms set at start-up; goal 2 ms",
        module_bound: Some(("goal", Duration::from_millis(2))),
        labels: ["central, X1 latency 1 ms", "MiniMod AON/AOFF, X1 latency 1 ms"],
    },
    Case {
        file: "reaction_resi_switch",
        model: "resi-16di8ro",
        settings: "",
        input: "DI1",
        output: "RO1",
        program: "beat = !beat\ny = x\n",
        follow: Follow::Level,
        central: "RESI central: y = x, scan 50 ms",
        module: "RESI-16DI8RO SWITCH",
        metric: "DI1 edge → RO1 edge",
        note: "SWITCH RO1 = DI1, pushed down by the planner (offload: auto)",
        module_bound: Some(RESI_SAMPLE),
        labels: ["RESI central y = x", "RESI-16DI8RO SWITCH"],
    },
    Case {
        file: "reaction_resi_toggle",
        model: "resi-16di8ro",
        settings: "",
        input: "DI1",
        output: "RO1",
        program: "beat = !beat\ny = y ^ rising(x)\n",
        follow: Follow::Toggle,
        central: "RESI central: y = y ^ rising(x), scan 50 ms",
        module: "RESI-16DI8RO TOGGLE",
        metric: "DI1 rising edge → RO1 flip",
        note: "TOGGLE RO1 = DI1, pushed down by the planner (offload: auto)",
        module_bound: Some(RESI_SAMPLE),
        labels: ["RESI central toggle", "RESI-16DI8RO TOGGLE"],
    },
];

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let mut out = Outcome::default();
    let mut series = Vec::new();
    for case in &CASES {
        let model = softplc_io::devices::model(case.model)
            .with_context(|| format!("model {} is not in the catalog", case.model))?;
        let (read_floor, _) = sim_line::read_floor(model, LineSettings::DEFAULT, &[]);
        let write_floor = sim_line::write_floor(model, LineSettings::DEFAULT, &[], case.output);
        let central = probe(ctx, case, false)?;
        let module = probe(ctx, case, true)?;
        let central_p = central.latencies.percentiles();
        out.rows.push(
            Row::measured(case.central, case.metric, central_p)
                .bound(Bound::fixed("scan period", PERIOD))
                .bound(Bound::fixed("bus cycle floor", read_floor + write_floor))
                .value("missed_edges", central.missed as f64),
        );
        let mut row = Row::measured(case.module, case.metric, module.latencies.percentiles())
            .bound(Bound::baseline("central", &central_p))
            .bound(Bound::fixed("scan period", PERIOD));
        if let Some((name, value)) = case.module_bound {
            row = row.bound(Bound::fixed(name, value));
        }
        out.rows.push(
            row.value("missed_edges", module.missed as f64)
                .note(case.note),
        );
        for (label, probed) in case.labels.into_iter().zip([central, module]) {
            series.push(Series {
                label: label.into(),
                hist: probed.latencies,
            });
        }
    }
    out.plots.push(Plot {
        file: "reaction-latency.svg".into(),
        title: "Reaction latency, input edge → output edge at the terminals".into(),
        x_label: "latency".into(),
        kind: PlotKind::Cdf { log_x: false },
        series,
    });
    Ok(out)
}

/// What one case measured.
struct Probed {
    latencies: DurationHistogram,
    missed: u64,
}

/// Runs `case`'s project, central or pushed down (`offload: auto`), and flips its input.
fn probe(ctx: &Ctx, case: &Case, in_module: bool) -> anyhow::Result<Probed> {
    let run_for = ctx.pick(Duration::from_secs(12), Duration::from_millis(2500));
    let mut bus = SimBus::new("line1", 19200, [1]);
    bus.model = case.model;
    bus.settings = case.settings.to_string();
    let tags = [
        format!("{{ name: x, point: line1_m1.{} }}", case.input),
        "{ name: beat, type: bool }".to_string(),
        format!(
            "{{ name: y, point: line1_m1.{}, safe: false }}",
            case.output
        ),
    ];
    let (offload, name) = if in_module {
        ("auto", format!("{}_module", case.file))
    } else {
        ("never", format!("{}_central", case.file))
    };
    let project = project_file::load_offload(
        &ctx.scratch,
        &name,
        "50ms",
        &[bus],
        &tags,
        case.program,
        offload,
    )?;
    let scan = Scanning::start(project, format!("scan-{name}"), run_for)?;
    let clock = scan.clock.clone();
    let begin = scan.begin;
    let mut probe = ReactionProbe::new(
        scan.world.clone(),
        scan.device,
        case.input,
        case.output,
        case.follow,
    );
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
    scan.join()?;
    Ok(Probed {
        latencies: probe.latencies,
        missed: probe.missed,
    })
}
