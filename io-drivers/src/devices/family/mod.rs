//! The one interface through which a device family states its capabilities to the runtime:
//! its module watchdog's plan, its input modes and reply-delay tuning, and what validation
//! needs to know of its settings (those only its text commands carry, those that do nothing on
//! a protocol, the text its start-up sends that a neighbour may take for its own). Every model in the [catalog](super::catalog)
//! names its family ([`ModelSpec::family`](super::ModelSpec::family)); the runtime asks the
//! family and never matches on a family's settings or a model's name, so a new family is one
//! folder under `devices/` (its settings, driver, simulator and this trait's implementation)
//! and one catalog line.
//!
//! # Stable API
//!
//! The [`Family`] trait's methods and the types they take and return ([`WatchdogAsk`],
//! [`WatchdogPolicy`], [`Derivation`], [`Armed`], [`Origin`], [`WatchdogConflict`],
//! [`InputModes`], [`ReplyDelayTuning`], [`OffProtocol`]) are the stable seam: a family outside this crate
//! implements them. Every method with a default keeps it for a family without the
//! capability (no watchdog settings to add, no event mode, no reply delay to tune). The
//! variants of [`Armed`] that name a family (`MiniMod`, `HostWatchdog`, `OffDelay`) are what
//! `check` prints; a new family's watchdog reuses the neutral ones or adds its own.

mod watchdog;

use std::fmt;
use std::time::Duration;

use super::{DeviceConfig, ModuleAddress, ModuleSettings, Protocol};

pub use watchdog::{Armed, Derivation, Origin, WatchdogAsk, WatchdogConflict, WatchdogPolicy};

/// A setting that does nothing on the protocol the module speaks: refused, not ignored.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct OffProtocol {
    /// The setting's key, in the manual's spelling (`checksum`).
    pub key: &'static str,
    /// The protocol it belongs to, in words (`DCON`).
    pub belongs_to: &'static str,
    /// The protocol that carries it.
    pub needs: Protocol,
    /// The protocol the module speaks.
    pub speaks: Protocol,
}

impl fmt::Display for OffProtocol {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let speaks = match self.speaks {
            Protocol::Modbus => "Modbus",
            Protocol::Text => "its text protocol",
        };
        write!(
            f,
            "{} is a {} setting and the module speaks {speaks} (protocol: {}); remove it, or \
             use protocol: {}",
            self.key,
            self.belongs_to,
            self.speaks.name(),
            self.needs.name()
        )
    }
}

/// How a module reads its inputs, as its family states it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputModes {
    /// Whether the module may be a member of a Collect round (FC 70, event mode): it answers
    /// a Collect broadcast in its own slot. A line where one module is not stays polled by
    /// default, since every slave hears the broadcast.
    pub collect: bool,
    /// Whether it runs in event mode with its settings as they are.
    pub events: bool,
    /// Whether the project left the mode for softplc to choose (a Collect-capable module
    /// on Modbus RTU whose settings do not say).
    pub open: bool,
    /// In event mode: the longest without an answered exchange addressed to the module.
    pub refresh: Option<Duration>,
    /// How much longer than the line's t3.5 the module waits for the end of a request (it
    /// starts each Collect slot later).
    pub frame_timeout: Duration,
}

/// What `tune: reply_delay` did to one module's settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ReplyDelayTuning {
    /// The family's reply delay is not the master's to set at run time.
    NotTunable,
    /// The settings set the module's own delay; they are left as written.
    Own,
    /// The module answers without a delay for this run (not saved in the module).
    Tuned,
}

/// A device family's capabilities, asked by the runtime with the module's parsed settings.
///
/// A method that gets settings of another family (which the catalog never pairs with it)
/// answers as for a module without the capability.
pub trait Family: Sync + fmt::Debug {
    /// Why `watchdog: off` cannot go with these settings, if it cannot: the setting that arms
    /// the module's watchdog.
    fn watchdog_conflict(&self, settings: &ModuleSettings) -> Option<WatchdogConflict>;

    /// The module's watchdog in this project, planned from the scan period, the line's worst
    /// gap and the safe outputs.
    fn plan_watchdog(&self, settings: &ModuleSettings, ask: &WatchdogAsk<'_>) -> Armed;

    /// Adds to `settings` what arming `armed` writes at start-up (the module's own settings
    /// win and stay as written).
    fn apply_watchdog(&self, _settings: &mut ModuleSettings, _armed: &Armed) {}

    /// `settings` as the start-up will run with an armed watchdog, for counting its traffic
    /// before the watchdog is planned (values that do not change the traffic).
    fn watchdog_traffic(&self, _settings: &mut ModuleSettings) {}

    /// Settings that only the family's text commands can carry, set in `settings`, so a
    /// Modbus TCP bus refuses them (keys in the manual's spelling).
    fn text_only_settings(&self, _settings: &ModuleSettings) -> Vec<&'static str> {
        Vec::new()
    }

    /// A setting that does nothing on `protocol`, if the settings have one.
    fn off_protocol(&self, _settings: &ModuleSettings, _protocol: Protocol) -> Option<OffProtocol> {
        None
    }

    /// The text command line (with its CR) the module's start-up sends at `address` whatever
    /// protocol it speaks, which every module of the line hears (`None`: it sends none).
    fn startup_text(&self, _address: ModuleAddress) -> Option<Vec<u8>> {
        None
    }

    /// Whether the module, as configured, takes `line` (a neighbour's text command line) for
    /// a command of its own, and answers it.
    fn takes_for_own(&self, _device: &DeviceConfig, _line: &[u8]) -> bool {
        false
    }

    /// How the module reads its inputs with `settings`, on `protocol`.
    fn input_modes(&self, _settings: &ModuleSettings, _protocol: Protocol) -> InputModes {
        InputModes::default()
    }

    /// Puts the module in event mode (softplc chose Collect for its line).
    fn choose_events(&self, _settings: &mut ModuleSettings) {}

    /// `tune: reply_delay` on the module's bus: sets the module to answer without a delay,
    /// unless the settings set their own.
    fn tune_reply_delay(&self, _settings: &mut ModuleSettings) -> ReplyDelayTuning {
        ReplyDelayTuning::NotTunable
    }

    /// Sets the module's reply delay back to its factory value (a floor without the tuning).
    fn factory_reply_delay(&self, _settings: &mut ModuleSettings) {}
}
