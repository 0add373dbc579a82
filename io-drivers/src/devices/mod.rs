//! Module families: one folder each, with register map, driver and simulator, and the catalog
//! that names them for project files and `softplc sim`.

mod config;
pub mod ex9053;
mod family;
pub mod minimod;
pub mod profile;
pub mod resi;

use std::time::Duration;

use crate::driver::Driver;
use crate::point::PointSpec;
use crate::sim::SimDevice;

pub use config::{
    Accepted, AddressError, ConfigError, DeviceConfig, KeyError, ModuleAddress, ModuleSettings,
    ParseSettings, PushDown, Range, SettingError,
};
pub use family::{
    Armed, Derivation, Family, InputModes, OffProtocol, Origin, ReplyDelayTuning, WatchdogAsk,
    WatchdogConflict, WatchdogPolicy,
};
pub use family::{
    Check, CommissionError, CommissionRequest, Conversation, Expect, LineFailed, Plan, Step,
};

/// How a driver talks to its module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Protocol {
    /// Modbus RTU.
    Modbus,
    /// The module's own text protocol (MiniMod text, RESI ASCII, DCON).
    Text,
}

impl Protocol {
    /// The project-file name.
    pub fn name(self) -> &'static str {
        match self {
            Protocol::Modbus => "modbus",
            Protocol::Text => "text",
        }
    }
}

/// A module model in the catalog.
#[derive(Debug)]
pub struct ModelSpec {
    /// The name in project files and `softplc sim` (`minimod`).
    pub name: &'static str,
    /// One-line description.
    pub summary: &'static str,
    /// Every point, by the manual's names.
    pub points: &'static [PointSpec],
    /// Protocols the model speaks; the first is the default.
    pub protocols: &'static [Protocol],
    /// Valid unit addresses.
    pub addresses: std::ops::RangeInclusive<u8>,
    /// Highest baud rate the module accepts.
    pub max_baud: u32,
    /// The module's power-on reply delay.
    pub default_reply_delay: Duration,
    /// Builds a driver.
    pub driver: fn(&DeviceConfig) -> Box<dyn Driver>,
    /// Builds a simulator at a unit address.
    pub simulator: fn(u8) -> Box<dyn SimDevice>,
    /// Parses a module entry's `settings` (key, value as written, in file order) into the
    /// model's typed settings, once; every refused setting comes back with its index.
    pub parse_settings: ParseSettings,
    /// Every setting key the model accepts, in the manual's spelling (for "did you mean").
    pub setting_keys: fn() -> Vec<&'static str>,
    /// The profile a model read from a profile file is built from (`None` for the built-in
    /// models). Its simulator is made by [`ModelSpec::simulate`], which can reach it.
    pub profile: Option<&'static profile::Profile>,
    /// The family's capabilities: its watchdog plan and input modes.
    pub family: &'static dyn Family,
}

impl ModelSpec {
    /// Index of a point by name (case-sensitive, the manual's spelling).
    pub fn point_index(&self, name: &str) -> Option<usize> {
        self.points.iter().position(|p| p.name == name)
    }

    /// A simulator of the model at `address` (a profile model's from its profile).
    pub fn simulate(&'static self, address: u8) -> Box<dyn SimDevice> {
        match self.profile {
            Some(_) => Box::new(profile::sim::ProfileSim::new(self, address)),
            None => (self.simulator)(address),
        }
    }

    /// A module entry's `settings:` parsed by the model, once (a profile model takes none).
    pub fn parse(&self, pairs: &[(String, String)]) -> Result<ModuleSettings, Vec<KeyError>> {
        match self.profile {
            Some(p) => profile::catalog::parse(p, pairs),
            None => (self.parse_settings)(pairs),
        }
    }
}

/// Every model softplc knows.
pub fn catalog() -> &'static [&'static ModelSpec] {
    static CATALOG: [&ModelSpec; 12] = [
        &minimod::MODEL,
        &ex9053::MODEL_D,
        &ex9053::MODEL_M,
        &resi::models::m16di8ro::SPEC,
        &resi::models::m32di::SPEC,
        &resi::models::m14ri::SPEC,
        &resi::models::m8co::SPEC,
        &resi::models::m2ri::SPEC,
        &resi::models::m1ro::SPEC,
        &resi::models::m2rtd::SPEC,
        &resi::models::m1led::SPEC,
        &resi::models::m4led::SPEC,
    ];
    &CATALOG
}

/// Every family softplc knows, in the order `softplc discover` and `softplc commission` ask
/// a module who it is.
pub fn families() -> &'static [&'static dyn Family] {
    static FAMILIES: [&dyn Family; 4] = [
        &minimod::MiniModFamily,
        &resi::ResiFamily,
        &ex9053::Ex9053Family,
        &profile::ProfileFamily,
    ];
    &FAMILIES
}

/// A model by its project-file name.
pub fn model(name: &str) -> Option<&'static ModelSpec> {
    catalog().iter().copied().find(|m| m.name == name)
}
