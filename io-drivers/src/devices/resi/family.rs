//! The RESI series as a device family: its watchdog.
//!
//! resi-spec.md §5.4 and its summary: the RESI modules have no communication watchdog and no
//! module-side safe state, except the RESI-1RO, whose off-delay (`SOFFDLY`, the point
//! `OFFDLY`) drops the relay when no command retriggers it. That off-delay is a way of driving
//! DO1 (through a timer, retriggered every cycle), not a safe state to reset: nothing locks
//! when it expires, and the relay follows the program again with the next cycle. It stays
//! opt-in (`SOFFDLY` in the settings); `check` says it is not armed. Polled only: FC 70
//! Collect is not in the series' manual, and its reply delay is not the master's to set.

use super::{m16di8ro, Num, Setting};
use crate::devices::family::{
    Armed, CommissionError, CommissionRequest, Conversation, Family, Plan, WatchdogAsk,
    WatchdogConflict, WatchdogPolicy,
};
use crate::devices::{ModelSpec, ModuleSettings, PushDown};
use crate::line::LineSettings;
use crate::push_down::{ModulePlacement, Pushed, Reason, Site};
use crate::rung::RungShape;

/// The RESI family (every model of the series).
#[derive(Debug)]
pub struct ResiFamily;

/// The `SOFFDLY` setting, ms, when given.
fn off_delay(settings: &ModuleSettings) -> Option<u16> {
    match settings {
        ModuleSettings::Resi(s) => s.off_delay(),
        _ => None,
    }
}

impl Family for ResiFamily {
    fn name(&self) -> &'static str {
        "RESI"
    }

    fn push_down(&self, shape: &RungShape, site: &dyn Site) -> Result<ModulePlacement, Reason> {
        // Of the RESI family, only the RESI-16DI8RO has logic functions (manual 10.1.1).
        if site.model().name != super::placement::MODEL {
            return Err(Reason::NoTables {
                module: site.module_name().to_string(),
                model: site.model().name,
            });
        }
        super::placement::map(shape, site)
    }

    fn add_pushed(&self, push: &mut PushDown, pushed: Pushed) {
        let Pushed::Resi(row) = pushed else {
            return;
        };
        if *push == PushDown::None {
            *push = PushDown::Resi(super::LogicTable::default());
        }
        if let PushDown::Resi(table) = push {
            table.rows.push(row);
        }
    }

    fn supports(&self, settings: LineSettings, address: u8) -> bool {
        super::commission::supports(settings, address)
    }

    fn who_are_you(&self, address: u8, _checksum: bool) -> Option<Vec<u8>> {
        Some(super::commission::who_are_you(address))
    }

    fn identify(&self, address: u8, reply: &str) -> Option<Result<&'static str, String>> {
        super::commission::identify(address, reply)
    }

    fn plan_commissioning(
        &self,
        conversation: &mut dyn Conversation,
        request: &CommissionRequest,
        model: &'static str,
    ) -> Result<Plan, CommissionError> {
        super::commission::plan(conversation, request, model)
    }

    fn watchdog_conflict(&self, settings: &ModuleSettings) -> Option<WatchdogConflict> {
        let ms = off_delay(settings)?;
        Some(WatchdogConflict {
            key: "SOFFDLY",
            value: ms.to_string(),
        })
    }

    /// The RESI-16DI8RO alone of the series has logic tables.
    fn logic_cleared_at_startup(&self, model: &ModelSpec) -> Option<&'static str> {
        (model.name == m16di8ro::MODEL.name).then_some(super::LOGIC_CLEARED_AT_STARTUP)
    }

    fn startup_values(&self, settings: &ModuleSettings) -> Vec<String> {
        let ModuleSettings::Resi(s) = settings else {
            return Vec::new();
        };
        s.items()
            .iter()
            .filter_map(|s| match s {
                Setting::Initial { entry, on } => {
                    Some(format!("{} = {}", entry.name, u8::from(*on)))
                }
                _ => None,
            })
            .collect()
    }

    fn push_down_settings(
        &self,
        model: &ModelSpec,
        settings: &ModuleSettings,
        push: &PushDown,
    ) -> Vec<String> {
        let (PushDown::Resi(table), ModuleSettings::Resi(own)) = (push, settings) else {
            return Vec::new();
        };
        table
            .settings(&m16di8ro::MODEL, own)
            .iter()
            .map(|s| match s {
                Setting::Write { entry, value } => match value {
                    Num::Int(v) => format!("{}: {v}", entry.name),
                    Num::Real(v) => format!("{}: {v}", entry.name),
                },
                Setting::Initial { entry, on } => {
                    format!("initial {}: {}", entry.name, u8::from(*on))
                }
                Setting::Poll(points) => {
                    let names: Vec<&str> = points
                        .iter()
                        .filter_map(|&i| model.points.get(i).map(|p| p.name))
                        .collect();
                    format!("poll: {}", names.join(", "))
                }
                other => format!("{other:?}"),
            })
            .collect()
    }

    fn push_initial(&self, push: &mut PushDown, point: &str, on: bool) {
        if *push == PushDown::None {
            *push = PushDown::Resi(super::LogicTable::default());
        }
        if let (PushDown::Resi(table), Some(relay)) = (push, super::Relay::named(point)) {
            table.initial.push((relay, on));
        }
    }

    fn sets_register(&self, settings: &ModuleSettings, name: &str) -> bool {
        matches!(settings, ModuleSettings::Resi(s) if s.sets(name))
    }

    fn plan_watchdog(&self, settings: &ModuleSettings, ask: &WatchdogAsk<'_>) -> Armed {
        if ask.model.point_index("OFFDLY").is_none() {
            return Armed::NotArmed("the model has no communication watchdog (resi-spec §5.4)");
        }
        match (ask.policy, off_delay(settings)) {
            (WatchdogPolicy::Off, _) => Armed::NotArmed("watchdog: off"),
            (_, Some(ms)) => Armed::OffDelay { ms },
            (_, None) => Armed::NotArmed(
                "the off-delay SOFFDLY is opt-in (it drives DO1 through a timer); setting \
                 SOFFDLY: <ms> arms it",
            ),
        }
    }
}
