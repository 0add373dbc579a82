//! What softplc plans for a line beyond what its entry says, once the project is whole: the
//! modules' reply delays when the bus asks for `tune: reply_delay` ([`tune`]), then their
//! input mode where the project leaves it open ([`event_mode`]: Collect where its floor is
//! lower than polling's). What a module can do is its family's to say
//! ([`softplc_io::devices::Family`]: its input modes, its reply-delay tuning). Both add typed settings to the modules' own, before the watchdogs
//! are armed (whose WDTTIME counts the line's floor), and keep what they chose and why on the
//! bus for `check` ([`LinePlan`]).

use std::time::Duration;

use softplc_io::devices::{InputModes, ModuleSettings};
use softplc_io::driver::Driver;
use softplc_io::line::SysfsRoot;
use softplc_io::line::{input_floor, AdapterTiming};

use super::model::{ModuleConfig, Project};

pub(crate) mod direction;
pub(crate) mod event_mode;
pub(crate) mod tune;

pub use direction::{Direction, FastTurn, SlowTurn};
pub use event_mode::{Choice, InputPlan};
pub use tune::Tuned;

/// What was planned for one bus.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LinePlan {
    /// How its MiniMods read their inputs, and why.
    pub inputs: event_mode::InputPlan,
    /// What `tune: reply_delay` set, when the bus asks for it.
    pub tuned: Option<tune::Tuned>,
}

/// Plans every bus: tuning first (it changes the polls' floor), then the input mode.
pub(crate) fn apply(project: &mut Project) {
    for b in 0..project.buses.len() {
        let mut tuned = tune::apply(project, b);
        let inputs = event_mode::apply(project, b);
        if let Some(t) = tuned.as_mut() {
            tune::floors(project, b, t);
        }
        if let Some(bus) = project.buses.get_mut(b) {
            bus.plan = LinePlan { inputs, tuned };
        }
    }
}

/// How a module reads its inputs with its settings as they are, as its family says.
pub(crate) fn input_modes(module: &ModuleConfig) -> InputModes {
    module
        .model
        .family
        .input_modes(&module.device.settings, module.device.protocol)
}

/// The indexes of bus `b`'s modules.
pub(crate) fn on_bus(project: &Project, b: usize) -> Vec<usize> {
    (0..project.modules.len())
        .filter(|&m| project.modules[m].bus == b)
        .collect()
}

/// The adapter timing every floor of bus `b` counts (as `check` and the watchdog do).
pub(crate) fn adapter(project: &Project, b: usize) -> AdapterTiming {
    project
        .buses
        .get(b)
        .map(|bus| bus.adapter(&SysfsRoot::default()).1)
        .unwrap_or_default()
}

/// Settings as a floor is to count them: a copy of module `m`'s, edited.
pub(crate) type Edit<'a> = &'a dyn Fn(usize, &mut ModuleSettings);

/// Module `m`'s driver, its settings as `edit` leaves a copy of them.
fn driver_with(project: &Project, m: usize, edit: Edit<'_>) -> Box<dyn Driver> {
    let module = &project.modules[m];
    let mut device = module.device.clone();
    edit(m, &mut device.settings);
    (module.model.driver)(&device)
}

/// The input floor of bus `b` (`softplc_io::line::input_floor`) with each module's
/// settings as `edit` leaves a copy of them.
pub(crate) fn floor_with(project: &Project, b: usize, edit: Edit<'_>) -> Duration {
    let Some(bus) = project.buses.get(b) else {
        return Duration::ZERO;
    };
    let mut drivers: Vec<Box<dyn Driver>> = on_bus(project, b)
        .into_iter()
        .map(|m| driver_with(project, m, edit))
        .collect();
    input_floor(bus.settings, adapter(project, b), &mut drivers)
}

/// What writing one changed output of module `m` costs on its line (its first output point
/// turned on: one transaction, with the module's reply delay and the adapter's latency).
pub(crate) fn change_write_with(project: &Project, m: usize, edit: Edit<'_>) -> Duration {
    let (Some(module), Some(bus)) = (
        project.modules.get(m),
        project
            .modules
            .get(m)
            .and_then(|x| project.buses.get(x.bus)),
    ) else {
        return Duration::ZERO;
    };
    let first_output = module
        .model
        .points
        .iter()
        .position(|p| p.access == softplc_io::point::Access::Output);
    let desired: Vec<_> = (0..module.model.points.len())
        .map(|i| (Some(i) == first_output).then_some(softplc_io::point::Value::Bool(true)))
        .collect();
    let mut driver = driver_with(project, m, edit);
    let mut plan = Vec::new();
    driver.plan_write(&desired, false, &mut plan);
    let delay = driver.reply_delay();
    let timing = adapter(project, module.bus);
    plan.iter()
        .map(|tx| softplc_io::line::transaction_time_on(bus.settings, timing, tx, delay))
        .sum()
}
