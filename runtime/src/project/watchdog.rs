//! The modules' own watchdogs: armed by default, so a host that dies (`kill -9`, a crash, a
//! pulled cable) still leaves the outputs in their safe state (DESIGN, principle 7).
//!
//! A module entry may say `watchdog: off` (or `auto`, the default); see [`super::raw`]. What a
//! module's watchdog is, and what arming it writes, is its family's to say
//! ([`softplc_io::devices::Family::plan_watchdog`]; the MiniMod's WDTTIME and WDTYMASK, the
//! EX-9053's host watchdog, the RESI-1RO's off-delay are documented there). The runtime
//! gives every family the same facts: the entry's policy, the tags' safe values, whether the
//! bus carries text commands, and the line's worst time between two exchanges with the
//! module ([`Derivation`]), the sum of
//! - 3 × the scan period: a cycle that overruns and is skipped to the next deadline, and the
//!   scan's own jitter;
//! - the cycle floor: every module's reads and a full output write ([`line_budget_on`]);
//! - the line's whole start-up traffic: modules are configured one after another before the
//!   first scan, and a module that comes back is configured again in the middle of a cycle;
//! - for every other module of the line, a read and a write that time out with all retries
//!   (what a failing module costs each cycle until it is declared lost; once lost it costs
//!   one probe at a time), each attempt costing the request, the response timeout and the
//!   guard after it ([`failed_attempt`]), and one retry of an exchange of the module's own;
//! - in event mode, one refresh period of the module ([`softplc_io::devices::InputModes`]).
//!
//! So a healthy line, or one with failing neighbours, never fires a watchdog armed from it,
//! while a dead host (or a dead line) gets the outputs safe within that time.

use std::time::Duration;

use softplc_io::devices::WatchdogAsk;
use softplc_io::line::{failed_attempt, line_budget_on, transaction_time, SysfsRoot};
use softplc_io::point::{Access, Value};

pub use softplc_io::devices::{Armed, Derivation, Origin, WatchdogPolicy};

use super::model::{Binding, Project};

/// The module entry's key.
pub(crate) const KEY: &str = "watchdog";

/// Parses the module entry's `watchdog:` value.
pub(crate) fn parse_policy(text: &str) -> Result<WatchdogPolicy, String> {
    match text.trim().to_ascii_lowercase().as_str() {
        "auto" | "on" | "true" | "yes" => Ok(WatchdogPolicy::Auto),
        "off" | "false" | "no" => Ok(WatchdogPolicy::Off),
        _ => Err(
            "takes auto (the default: the module's own watchdog armed with a time derived from \
             the scan and the line) or off"
                .into(),
        ),
    }
}

/// A module's watchdog: what the entry asked for, what it is.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct ModuleWatchdog {
    /// The entry's `watchdog:`.
    pub policy: WatchdogPolicy,
    /// What it is (filled in by `arm`); its family adds what arming it writes to the
    /// module's settings ([`super::model::ModuleConfig::device_with_watchdog`]).
    pub armed: Armed,
}

impl super::model::ModuleConfig {
    /// What the module's driver is built from: its settings as written, then what arming its
    /// watchdog adds (see `arm`).
    pub fn device_with_watchdog(&self) -> softplc_io::devices::DeviceConfig {
        let mut device = self.device.clone();
        self.model
            .family
            .apply_watchdog(&mut device.settings, &self.watchdog.armed);
        device
    }
}

/// Works out every module's watchdog (the module's own settings stay as written; what arming
/// adds comes with [`super::model::ModuleConfig::device_with_watchdog`]): at the end of
/// validation, once the project is whole.
pub(crate) fn arm(project: &mut Project) {
    let derivations = derive_all(project);
    for (m, derivation) in derivations.into_iter().enumerate() {
        let safe = safe_values(project, m);
        let carries_text = !project
            .modules
            .get(m)
            .and_then(|module| project.buses.get(module.bus))
            .is_some_and(|bus| bus.port.is_modbus_tcp());
        let Some(module) = project.modules.get_mut(m) else {
            continue;
        };
        let ask = WatchdogAsk {
            model: module.model,
            policy: module.watchdog.policy,
            derivation,
            safe: &safe,
            carries_text,
        };
        module.watchdog.armed = module
            .model
            .family
            .plan_watchdog(&module.device.settings, &ask);
    }
}

/// The safe values of the tags bound to module `m`'s points, in tag order: (point, value).
fn safe_values(project: &Project, m: usize) -> Vec<(usize, Value)> {
    project
        .tags
        .iter()
        .filter_map(|tag| match (tag.binding, tag.safe) {
            (Binding::Point { module, point }, Some(v)) if module == m => Some((point, v)),
            _ => None,
        })
        .collect()
}

/// The derived time's parts for every module (index = module).
fn derive_all(project: &Project) -> Vec<Derivation> {
    // A module's host is the task owning its bus: three of that task's periods.
    let mut out: Vec<Derivation> = project
        .modules
        .iter()
        .map(|m| Derivation {
            periods: project.bus_period(m.bus) * 3,
            floor: Duration::ZERO,
            startup: Duration::ZERO,
            failures: Duration::ZERO,
            event_refresh: None,
        })
        .collect();
    for (b, bus) in project.buses.iter().enumerate() {
        // A USB adapter's latency timer stretches every exchange, so the module's timeout
        // must too, or the watchdog fires on a healthy line.
        let (_, adapter) = bus.adapter(&SysfsRoot::default());
        let members: Vec<usize> = (0..project.modules.len())
            .filter(|&m| project.modules[m].bus == b)
            .collect();
        let mut drivers: Vec<_> = members
            .iter()
            .map(|&m| {
                let module = &project.modules[m];
                let access: Vec<Access> = module.model.points.iter().map(|p| p.access).collect();
                // As it will run: its start-up with what arming its watchdog adds (whose
                // values do not change its traffic).
                let mut device = module.device.clone();
                module.model.family.watchdog_traffic(&mut device.settings);
                (module.name.clone(), (module.model.driver)(&device), access)
            })
            .collect();
        let mut startup = Duration::ZERO;
        let mut plan = Vec::new();
        for (_, driver, _) in drivers.iter_mut() {
            plan.clear();
            driver.plan_startup(&mut plan);
            let delay = driver.reply_delay();
            startup += plan
                .iter()
                .map(|tx| transaction_time(bus.settings, tx, delay) + adapter.latency)
                .sum::<Duration>();
        }
        let floor = line_budget_on(bus.settings, adapter, &mut drivers).cycle_floor();
        // One attempt that gets no answer: the request, the response timeout, the guard.
        let attempt = failed_attempt(bus.settings, bus.response_timeout);
        let attempts = u32::from(bus.retries) + 1;
        let others = u32::try_from(members.len().saturating_sub(1)).unwrap_or(u32::MAX);
        let failures = attempt * attempts * 2 * others + attempt * u32::from(bus.retries);
        for &m in &members {
            let module = &project.modules[m];
            let event_refresh = module
                .model
                .family
                .input_modes(&module.device.settings, module.device.protocol)
                .refresh;
            if let Some(d) = out.get_mut(m) {
                d.floor = floor;
                d.startup = startup;
                d.failures = failures;
                d.event_refresh = event_refresh;
            }
        }
    }
    out
}

/// The line `check` prints for a module's watchdog, and a warning when it is off.
pub(crate) fn report(module: &super::model::ModuleConfig) -> (String, Option<String>) {
    module.watchdog.armed.report(&module.name)
}
