//! The EX-9053D / EX-9053D-M as a device family: its host watchdog.
//!
//! Not armed by default: its host watchdog's only effect is on outputs ("Host Watchdog
//! Timeout will let all output goto Safe Value", §1.5; §1.8), and the EX-9053D has none, so
//! there is no safe value to give it; arming it would cost a host OK broadcast and a status
//! read every cycle for a diagnostic the PLC has anyway (the module is lost). Its `watchdog`
//! setting (100ms..=25.5s) still arms it (see the driver); `check` prints it. Polled only:
//! FC 70 Collect is not in its manual.
//!
//! # A neighbour's text commands
//!
//! In DCON mode it reads the `@` of another family's text command line and the next two
//! characters as its own command and address (`@AA`, "Read Digital Input Status", §2.13), and
//! answers a command it does not know with `?AA` ("Invalid Command"): both replies are
//! garbled. With its checksum on (data format bit 6, §1.10) it takes the line's last two
//! characters for one, and they do not add up. Which lines it takes is decided by its own
//! DCON parser ([`address_hearing`]).

use super::{Command, ParseError};
use crate::devices::family::{
    Armed, CommissionError, CommissionRequest, Conversation, Family, OffProtocol, Plan,
    WatchdogAsk, WatchdogConflict, WatchdogPolicy,
};
use crate::devices::{DeviceConfig, ModuleSettings, Protocol};
use crate::line::LineSettings;

/// The EX-9053 family.
#[derive(Debug)]
pub struct Ex9053Family;

/// The DCON address (as a project writes an EX-9053's address: the number) that takes a text
/// command `line` (with or without its CR) for its own; `None` when none does.
pub fn address_hearing(line: &[u8]) -> Option<u8> {
    let body = line.strip_suffix(b"\r").unwrap_or(line);
    match Command::parse(body) {
        Ok(command) => command.address(),
        Err(ParseError::Invalid { address }) => Some(address),
        Err(ParseError::NoAddress) => None,
    }
}

/// The `watchdog` setting, 0.1 s, when given.
fn watchdog(settings: &ModuleSettings) -> Option<u8> {
    match settings {
        ModuleSettings::Ex9053(s) => s.watchdog,
        _ => None,
    }
}

impl Family for Ex9053Family {
    fn name(&self) -> &'static str {
        "EX-9053 (DCON)"
    }

    fn supports(&self, settings: LineSettings, _address: u8) -> bool {
        super::commission::supports(settings)
    }

    fn who_are_you(&self, address: u8, checksum: bool) -> Option<Vec<u8>> {
        Some(super::commission::name_request(address, checksum))
    }

    fn answer_body(&self, reply: &str, checksum: bool) -> Option<String> {
        super::commission::body(reply, checksum)
    }

    fn identify(&self, address: u8, reply: &str) -> Option<Result<&'static str, String>> {
        super::commission::identify(address, reply)
    }

    fn has_checksum(&self) -> bool {
        true
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
        let tenths = watchdog(settings)?;
        Some(WatchdogConflict {
            key: "watchdog",
            value: format!("{}s", f64::from(tenths) / 10.0),
        })
    }

    fn off_protocol(&self, settings: &ModuleSettings, protocol: Protocol) -> Option<OffProtocol> {
        let ModuleSettings::Ex9053(s) = settings else {
            return None;
        };
        let key = s.dcon_only().filter(|_| protocol == Protocol::Modbus)?;
        Some(OffProtocol {
            key,
            belongs_to: "DCON",
            needs: Protocol::Text,
            speaks: protocol,
        })
    }

    fn takes_for_own(&self, device: &DeviceConfig, line: &[u8]) -> bool {
        let dcon_without_checksum = device.protocol == Protocol::Text
            && matches!(&device.settings, ModuleSettings::Ex9053(s) if !s.checksum);
        dcon_without_checksum && address_hearing(line) == Some(device.address.get())
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
