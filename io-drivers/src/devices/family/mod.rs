//! The one interface through which a device family states its capabilities to the runtime:
//! its module watchdog's plan, its input modes and reply-delay tuning, what validation
//! needs to know of its settings (those only its text commands carry, those that do nothing on
//! a protocol, the text its start-up sends that a neighbour may take for its own), how a
//! module of it says who it is, and its commissioning protocol (a [`Plan`] of steps for a
//! [`CommissionRequest`], sans-IO: the runner that talks on a port is the caller's). Every model in the [catalog](super::catalog)
//! names its family ([`ModelSpec::family`](super::ModelSpec::family)); the runtime asks the
//! family and never matches on a family's settings or a model's name, so a new family is one
//! folder under `devices/` (its settings, driver, simulator and this trait's implementation),
//! one catalog line per model and one line in [`families`](super::families). A family's own
//! refusal types (`MiniModRefusal`, ...) are its own API, not the seam's.
//!
//! # Stable API
//!
//! The [`Family`] trait's methods and the types they take and return ([`WatchdogAsk`],
//! [`WatchdogPolicy`], [`Derivation`], [`Armed`], [`Origin`], [`WatchdogConflict`],
//! [`InputModes`], [`ReplyDelayTuning`], [`OffProtocol`], [`CommissionRequest`],
//! [`Conversation`], [`Plan`], [`Step`], [`Expect`], [`CommissionError`]) are the stable seam: a family outside this crate
//! implements them. Every method with a default keeps it for a family without the
//! capability (no watchdog settings to add, no event mode, no reply delay to tune). The
//! variants of [`Armed`] that name a family (`MiniMod`, `HostWatchdog`, `OffDelay`) are what
//! `check` prints; a new family's watchdog reuses the neutral ones or adds its own.

mod commission;
mod watchdog;

use std::fmt;
use std::time::Duration;

use super::{DeviceConfig, ModelSpec, ModuleAddress, ModuleSettings, Protocol, PushDown};
use crate::line::LineSettings;
use crate::push_down::{ModulePlacement, Pushed, Reason, Site};
use crate::rung::RungShape;

pub use commission::{
    Check, CommissionError, CommissionRequest, Conversation, Expect, LineFailed, Plan, Step,
};

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
    /// The family's name for a person (`MiniMod`, `RESI`).
    fn name(&self) -> &'static str;

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

    /// Whether a module of the family can run at `settings` and answer at `address` (what
    /// `softplc discover` and `softplc commission` ask it at).
    fn supports(&self, _settings: LineSettings, _address: u8) -> bool {
        false
    }

    /// The question that makes a module of the family say who it is, in its own protocol
    /// (with a DCON checksum when `checksum`); `None`: the family cannot be asked.
    fn who_are_you(&self, _address: u8, _checksum: bool) -> Option<Vec<u8>> {
        None
    }

    /// The body of an answer line, its checksum checked and removed when `checksum`.
    fn answer_body(&self, reply: &str, _checksum: bool) -> Option<String> {
        Some(reply.to_owned())
    }

    /// The model (project-file name) an answer from `address` names, if it is this family's
    /// answer; an error when it is the family's but names no model softplc knows.
    fn identify(&self, _address: u8, _reply: &str) -> Option<Result<&'static str, String>> {
        None
    }

    /// Whether the family has a checksum a host can switch (`--set-checksum`).
    fn has_checksum(&self) -> bool {
        false
    }

    /// The commissioning of the module `model` as `request` asks, planned after reading what
    /// the family needs through `conversation`; a refusal says what its manual forbids.
    fn plan_commissioning(
        &self,
        _conversation: &mut dyn Conversation,
        _request: &CommissionRequest,
        _model: &'static str,
    ) -> Result<Plan, CommissionError> {
        Err(CommissionError::NotCommissioned {
            family: self.name(),
        })
    }

    /// Whether `settings` write the register or coil named `name` (the model's map's name),
    /// which the push-down planner then leaves to them.
    fn sets_register(&self, _settings: &ModuleSettings, _name: &str) -> bool {
        false
    }

    /// The module's own conditioning registers of input `point` (its rising and falling
    /// latency: a MiniMod's `XLATUP2`, `XLATDN2` for `X2`), where it has them: what a tag's
    /// `debounce` and `stretch` are written to.
    fn input_latency_registers(&self, _point: &str) -> Option<(String, String)> {
        None
    }

    /// The logic registers the start-up of a `model` module clears and reads back before the
    /// first scan, whatever the push-down plan, in words; `None` for a model without logic
    /// tables.
    fn logic_cleared_at_startup(&self, _model: &ModelSpec) -> Option<&'static str> {
        None
    }

    /// The pushed-down outputs' start values `settings` hold, as `NAME = 0|1`.
    fn startup_values(&self, _settings: &ModuleSettings) -> Vec<String> {
        Vec::new()
    }

    /// The start-up settings the driver adds to `settings` for the push-down `push`, as
    /// `NAME: value` (the tables, the start values and what they need besides).
    fn push_down_settings(
        &self,
        _model: &ModelSpec,
        _settings: &ModuleSettings,
        _push: &PushDown,
    ) -> Vec<String> {
        Vec::new()
    }

    /// Adds the start value `on` of the pushed-down output `point` to the module's push-down
    /// `push` (made the family's when it is none yet).
    fn push_initial(&self, _push: &mut PushDown, _point: &str, _on: bool) {}

    /// The push-down target: runs the rung of shape `shape` in the module's own logic (the
    /// feature, its tables, a command the scan sends instead of the output), or says why it
    /// stays in the scan. The family answers only when its logic gives the rung's behaviour
    /// (each mapping's module docs hold the proof). Default: no logic tables.
    fn push_down(&self, _shape: &RungShape, site: &dyn Site) -> Result<ModulePlacement, Reason> {
        Err(Reason::NoTables {
            module: site.module_name().to_string(),
            model: site.model().name,
        })
    }

    /// Adds a placement's tables `pushed` to the module's push-down `push` (made the
    /// family's when it is none yet), what its driver writes and verifies at start-up.
    fn add_pushed(&self, _push: &mut PushDown, _pushed: Pushed) {}

    /// The module's own conditioning of input `point`: a rising edge counted once the input
    /// was high `rising` ms, a falling one after `falling` ms, added to the module's push-down
    /// `push`; the registers that hold it, with their values (ms). `None` when the module
    /// conditions no such input (`check` refuses `debounce:`/`stretch:` there first).
    fn condition_input(
        &self,
        _push: &mut PushDown,
        _point: &str,
        _rising: Option<u16>,
        _falling: Option<u16>,
    ) -> Option<Vec<(&'static str, u16)>> {
        None
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

#[cfg(test)]
mod tests {
    use crate::devices::{catalog, families, model};

    #[test]
    fn every_model_s_family_is_asked_by_discover_and_commission() {
        for m in catalog() {
            assert!(
                families().iter().any(|f| f.name() == m.family.name()),
                "{}'s family {} is not in families()",
                m.name,
                m.family.name()
            );
        }
    }

    #[test]
    fn the_resi_1ro_alone_of_its_series_has_an_off_delay_to_arm() {
        use crate::devices::{Armed, Derivation, WatchdogAsk, WatchdogPolicy};
        let plan = |name: &str, pairs: &[(&str, &str)]| {
            let spec = model(name).expect("in the catalog");
            let pairs: Vec<(String, String)> = pairs
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect();
            let settings = spec.parse(&pairs).expect("valid settings");
            let ask = WatchdogAsk {
                model: spec,
                policy: WatchdogPolicy::Auto,
                derivation: Derivation {
                    periods: std::time::Duration::from_millis(30),
                    floor: std::time::Duration::ZERO,
                    startup: std::time::Duration::ZERO,
                    failures: std::time::Duration::ZERO,
                    event_refresh: None,
                },
                safe: &[],
                carries_text: true,
            };
            spec.family.plan_watchdog(&settings, &ask)
        };
        assert_eq!(
            plan("resi-1ro", &[("SOFFDLY", "5000")]),
            Armed::OffDelay { ms: 5000 }
        );
        assert!(matches!(plan("resi-1ro", &[]), Armed::NotArmed(why) if why.contains("opt-in")));
        assert!(
            matches!(plan("resi-16di8ro", &[]), Armed::NotArmed(why) if why.contains("no communication watchdog"))
        );
    }
}
