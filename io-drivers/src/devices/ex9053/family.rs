//! The EX-9053D / EX-9053D-M as a device family: its host watchdog.
//!
//! Not armed by default: its host watchdog's only effect is on outputs ("Host Watchdog
//! Timeout will let all output goto Safe Value", §1.5; §1.8), and the EX-9053D has none, so
//! there is no safe value to give it; arming it would cost a host OK broadcast and a status
//! read every cycle for a diagnostic the PLC has anyway (the module is lost). Its `watchdog`
//! setting (100ms..=25.5s) still arms it (see the driver); `check` prints it. Polled only:
//! FC 70 Collect is not in its manual.

use crate::devices::family::{Armed, Family, WatchdogAsk, WatchdogConflict, WatchdogPolicy};
use crate::devices::ModuleSettings;

/// The EX-9053 family.
#[derive(Debug)]
pub struct Ex9053Family;

/// The `watchdog` setting, 0.1 s, when given.
fn watchdog(settings: &ModuleSettings) -> Option<u8> {
    match settings {
        ModuleSettings::Ex9053(s) => s.watchdog,
        _ => None,
    }
}

impl Family for Ex9053Family {
    fn watchdog_conflict(&self, settings: &ModuleSettings) -> Option<WatchdogConflict> {
        let tenths = watchdog(settings)?;
        Some(WatchdogConflict {
            key: "watchdog",
            value: format!("{}s", f64::from(tenths) / 10.0),
        })
    }

    fn plan_watchdog(&self, settings: &ModuleSettings, ask: &WatchdogAsk<'_>) -> Armed {
        match (ask.policy, watchdog(settings)) {
            (WatchdogPolicy::Off, _) => Armed::NotArmed("watchdog: off"),
            (_, Some(tenths)) => Armed::HostWatchdog { tenths },
            (_, None) => Armed::NotArmed(
                "the EX-9053D has no outputs for its host watchdog to make safe (§1.5, §1.8); \
                 setting watchdog: 2s arms it",
            ),
        }
    }
}
