//! The scenarios, one file each. Adding one: write `NAME.rs` with a `pub fn run(&Ctx) ->
//! anyhow::Result<Outcome>` and list it in [`all`].

pub(crate) mod blink;
pub(crate) mod bus_cycle;
pub(crate) mod collect;
pub(crate) mod footprint;
pub(crate) mod full_cycle;
pub(crate) mod logic_cost;
pub(crate) mod peer;
pub(crate) mod plant_kit;
pub(crate) mod plant_load;
pub(crate) mod plant_services;
pub(crate) mod pulse;
pub(crate) mod reaction;
pub(crate) mod scale;
pub(crate) mod scheduler;
pub(crate) mod serial_path;
pub(crate) mod tasks;
pub(crate) mod trace_cost;
pub(crate) mod virtual_truth;

use std::path::PathBuf;
use std::time::Duration;

use crate::report::{Outcome, Row};

/// What every scenario gets.
#[derive(Debug, Clone)]
pub(crate) struct Ctx {
    /// Short runs (`--quick`): the whole harness under a minute.
    pub quick: bool,
    /// A scratch folder for generated project and program files.
    pub scratch: PathBuf,
}

impl Ctx {
    /// `full` normally, `quick` with `--quick`.
    pub(crate) fn pick(&self, full: Duration, quick: Duration) -> Duration {
        if self.quick {
            quick
        } else {
            full
        }
    }
}

/// A scenario of issue #8.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Scenario {
    /// Its number in the issue.
    pub number: u8,
    /// Name for `--only`.
    pub name: &'static str,
    /// Title in the table.
    pub title: &'static str,
    /// What it answers, printed under the title.
    pub summary: &'static str,
    /// Runs it.
    pub run: fn(&Ctx) -> anyhow::Result<Outcome>,
}

/// A scenario's results.
#[derive(Debug)]
pub(crate) struct ScenarioResult {
    /// Its number.
    pub number: u8,
    /// Its name.
    pub name: &'static str,
    /// Its title.
    pub title: &'static str,
    /// Its summary.
    pub summary: &'static str,
    /// Rows.
    pub rows: Vec<Row>,
    /// Wall time it took.
    pub took: Duration,
}

/// Every scenario, in the order.
pub(crate) fn all() -> Vec<Scenario> {
    vec![
        scheduler::SCENARIO,
        logic_cost::SCENARIO,
        bus_cycle::SCENARIO,
        collect::SCENARIO,
        reaction::SCENARIO,
        pulse::SCENARIO,
        serial_path::SCENARIO,
        scale::SCENARIO,
        trace_cost::SCENARIO,
        peer::SCENARIO,
        plant_services::SCENARIO,
        full_cycle::SCENARIO,
        virtual_truth::SCENARIO,
        plant_load::SCENARIO,
        blink::SCENARIO,
        footprint::SCENARIO,
        tasks::SCENARIO,
    ]
}
