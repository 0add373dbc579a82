//! Scenario 8: several lines polled in parallel. 1, 2 and 4 lines of 8 MiniMods each (19200
//! 8E1, reply delay 10 ms), a project run by the runtime's scan engine in real time, every
//! line on its own bus thread. The scan's input phase must grow with the slowest line, not
//! with the sum of the lines.

use std::sync::Arc;
use std::time::Duration;

use softplc::clock::MonotonicClock;
use softplc::plc::Plc;
use softplc::project::Project;
use softplc::scan::ScanEngine;
use softplc_io::driver::Driver;
use softplc_io::line::line_budget;
use softplc_io::point::Access;

use super::{Ctx, Scenario};
use crate::project_file::{self, SimBus};
use crate::report::{Bound, Outcome, Plot, PlotKind, Row, Series};

/// The scenario.
pub(crate) const SCENARIO: Scenario = Scenario {
    number: 8,
    name: "scale",
    title: "Scale: lines polled in parallel",
    summary: "8 MiniMods per line, polled (events: false), 19200 8E1, reply delay 10 ms, scan \
              period 250 ms, the runtime's scan engine with one bus thread per line. Input phase against the \
              slowest line's floor and against the sum of every line's floor. A line's phase \
              floor is the sum of its transactions less the t3.5 after the last reply, which \
              falls outside the phase.",
    run,
};

const LINES: [usize; 3] = [1, 2, 4];
const PER_LINE: u8 = 8;

fn run(ctx: &Ctx) -> anyhow::Result<Outcome> {
    let run_for = ctx.pick(Duration::from_secs(8), Duration::from_millis(1500));
    let mut out = Outcome::default();
    let mut series = Vec::new();
    for lines in LINES {
        // Polled (`events: false`): this scenario is about lines in parallel against the
        // polling floor; a line of MiniMods would otherwise get Collect by default (scenario
        // 12 measures that plan).
        let buses: Vec<SimBus> = (1..=lines)
            .map(|l| SimBus {
                settings: "{ events: false }".into(),
                ..SimBus::new(&format!("line{l}"), 19200, 1..=PER_LINE)
            })
            .collect();
        let tags = ["{ name: beat, type: bool }".to_string()];
        let name = format!("scale_{lines}");
        let project = project_file::load(
            &ctx.scratch,
            &name,
            "250ms",
            &buses,
            &tags,
            "beat = !beat\n",
        )?;
        let floors = read_floors(&project);
        let slowest = floors.iter().copied().max().unwrap_or_default();
        let sum: Duration = floors.iter().sum();
        let plc = Plc::build(project, Arc::new(MonotonicClock::new()))?;
        let outcome = std::thread::Builder::new()
            .name(format!("scan-{name}"))
            .spawn(move || ScanEngine::new(plc).run_for(run_for).run())?
            .join()
            .map_err(|_| anyhow::anyhow!("the scan thread panicked"))?;
        let read = outcome.stats.read.percentiles();
        let errors = outcome.stats.bus_errors;
        let mut row = Row::measured(
            format!("{lines} line(s) × {PER_LINE} MiniMods"),
            "input phase",
            read,
        )
        .bound(Bound::fixed("slowest line floor", slowest))
        .bound(Bound::fixed("sum of line floors", sum))
        .value("overruns", outcome.stats.overruns as f64)
        .value("bus_errors", errors as f64);
        if errors > 0 || outcome.stats.overruns > 0 {
            row = row.note(format!(
                "{errors} bus errors, {} overruns",
                outcome.stats.overruns
            ));
        }
        out.rows.push(row);
        series.push(Series {
            label: format!("{lines} line(s)"),
            hist: outcome.stats.read,
        });
    }
    out.plots.push(Plot {
        file: "scale-input-phase.svg".into(),
        title: "Scan input phase, 8 MiniMods per line, lines in parallel".into(),
        x_label: "input phase".into(),
        kind: PlotKind::Cdf { log_x: false },
        series,
    });
    Ok(out)
}

/// The floor of every bus's input phase, from the drivers its modules get: the line's read
/// floor less the t3.5 after its last reply.
fn read_floors(project: &Project) -> Vec<Duration> {
    project
        .buses
        .iter()
        .enumerate()
        .map(|(b, bus)| {
            let mut drivers: Vec<(String, Box<dyn Driver>, Vec<Access>)> = project
                .modules
                .iter()
                .filter(|m| m.bus == b)
                .map(|m| {
                    let access = m.model.points.iter().map(|p| p.access).collect();
                    (m.name.clone(), (m.model.driver)(&m.device), access)
                })
                .collect();
            line_budget(bus.settings, &mut drivers)
                .read_floor
                .saturating_sub(bus.settings.t3_5())
        })
        .collect()
}
