//! Profile modules as a device family: polled, with no watchdog softplc arms (a profiled
//! device's watchdog, if it has one, is not in its profile).

use crate::devices::family::{Armed, Family, WatchdogAsk, WatchdogConflict};
use crate::devices::ModuleSettings;

/// The family of every module described by a profile file.
#[derive(Debug)]
pub struct ProfileFamily;

impl Family for ProfileFamily {
    fn name(&self) -> &'static str {
        "profile"
    }

    fn watchdog_conflict(&self, _settings: &ModuleSettings) -> Option<WatchdogConflict> {
        None
    }

    fn plan_watchdog(&self, _settings: &ModuleSettings, _ask: &WatchdogAsk<'_>) -> Armed {
        Armed::NotArmed(
            "a device profile arms no watchdog (configure the device's own, if it has one)",
        )
    }
}
