//! The MiniMod as a device family: its watchdog (WDTTIME, WDTYMASK), its input modes (polled
//! or Collect) and its run-time reply delay.
//!
//! # Watchdog
//!
//! Manual, "Internal watch-dog (security and coherency check)" and the register table: with
//! WDTTIME (40129, 1/100 s, 1..=65535) non-zero "Minimod expects messages from the master at
//! least every WDTTIME time; if no messages are received in that time, the watch-dog fires",
//! and the outputs take WDTYMASK (40145: "Bitmask for the outputs Y1..Y4 when the watch-dog is
//! firing"). The driver sets and reads back both by name through the text protocol (see the
//! driver's docs, "Registers the manual gives two ways"). Unless the project sets them:
//! - **WDTYMASK** is built from the tags' safe values: bit n−1 is 1 when the tag bound to Yn
//!   has `safe: true` (or a tag bound to YWORD has it in its safe value), else 0. The mask has
//!   no "leave as is": an output without a safe value goes off, which `check` says.
//! - **WDTTIME** is the line's worst gap ([`Derivation::total`]: 3 × the scan period, the
//!   line's floor, its start-up traffic, its failing neighbours and, in event mode, one
//!   `event_refresh`, since the manual does not say a broadcast Collect counts as a message),
//!   rounded up to 1/100 s, at most 65535 (655.35 s).
//! - `watchdog: off` writes WDTTIME = 0 at start-up (a watchdog armed by an earlier run is
//!   disarmed). An explicit `WDTTIME` (or `WDTYMASK`) in the settings wins; `WDTTIME: 0` is the
//!   same as `watchdog: off`.
//! - On a Modbus TCP bus it is not armed: the text commands that arm it cannot cross it.
//!
//! # Input modes
//!
//! Modbus function 70 "Collect" (event management) is the MiniMod's own; a Modbus-protocol
//! MiniMod whose settings do not say `events:` leaves the mode to softplc.
//!
//! # Reply delay
//!
//! RDELAYT (1/100 s, the factory's [`super::FACTORY_RDELAYT`]) is set to 0 for the run by
//! `tune: reply_delay` unless the settings set it; never saved to flash.

use std::time::Duration;

use super::{Setting, Settings};
use crate::devices::family::{
    Armed, CommissionError, CommissionRequest, Conversation, Derivation, Family, InputModes,
    Origin, Plan, ReplyDelayTuning, WatchdogAsk, WatchdogConflict, WatchdogPolicy,
};
use crate::devices::{ModelSpec, ModuleAddress, ModuleSettings, Protocol, PushDown};
use crate::line::LineSettings;
use crate::point::Value;
use crate::push_down::{ModulePlacement, Pushed, Reason, Site};
use crate::rung::RungShape;

/// The MiniMod family.
#[derive(Debug)]
pub struct MiniModFamily;

/// Why a MiniMod on a Modbus TCP bus has no watchdog armed by softplc.
const ON_MODBUS_TCP: &str = "a MiniMod's watchdog is armed by name with text commands \
     (>WDTTIME=), which a Modbus TCP bus cannot carry; arm it in the module's flash (WCONF) on \
     a line of its own, or put it on an rtu+tcp:// bus";

/// The warning `check` gives for it.
const ON_MODBUS_TCP_WARNING: &str = "no watchdog armed on a Modbus TCP bus: if this process \
     dies or the connection breaks, its outputs keep their last state";

/// The registers the watchdog is armed with, set by name through text commands.
const WATCHDOG_REGISTERS: [&str; 2] = ["WDTTIME", "WDTYMASK"];

/// The outputs WDTYMASK covers, bit 0 first.
const OUTPUTS: [&str; 4] = ["Y1", "Y2", "Y3", "Y4"];

fn own(settings: &ModuleSettings) -> Option<&Settings> {
    match settings {
        ModuleSettings::MiniMod(s) => Some(s),
        _ => None,
    }
}

fn own_mut(settings: &mut ModuleSettings) -> Option<&mut Settings> {
    match settings {
        ModuleSettings::MiniMod(s) => Some(s),
        _ => None,
    }
}

/// Rounds `d` up to whole hundredths of a second, within WDTTIME's range.
fn hundredths(d: Duration) -> u16 {
    let h = d.as_nanos().div_ceil(10_000_000);
    u16::try_from(h).unwrap_or(u16::MAX).max(1)
}

/// WDTYMASK from the tags' safe values, and the outputs that have none.
fn safe_mask(ask: &WatchdogAsk<'_>) -> (u16, Vec<&'static str>) {
    let mut known = [None::<bool>; 4];
    for (point, v) in ask.safe {
        let Some(spec) = ask.model.points.get(*point) else {
            continue;
        };
        if spec.name == "YWORD" {
            let word = match *v {
                Value::U16(w) => w,
                other => u16::from(other.as_bool()),
            };
            for (y, k) in known.iter_mut().enumerate() {
                if k.is_none() {
                    *k = Some(word & (1 << y) != 0);
                }
            }
        } else if let Some(y) = OUTPUTS.iter().position(|n| *n == spec.name) {
            known[y] = Some(v.as_bool());
        }
    }
    let mask = known
        .iter()
        .enumerate()
        .fold(0u16, |acc, (y, k)| acc | (u16::from(*k == Some(true)) << y));
    let no_safe = OUTPUTS
        .into_iter()
        .zip(known)
        .filter(|(_, k)| k.is_none())
        .map(|(n, _)| n)
        .collect();
    (mask, no_safe)
}

/// The armed watchdog for `Auto`: the settings' own time and mask, else derived.
fn auto(
    time: Option<u16>,
    mask: Option<u16>,
    derivation: Derivation,
    ask: &WatchdogAsk<'_>,
) -> Armed {
    let (time, time_from, derivation) = match time {
        Some(t) => (t, Origin::Project, None),
        None => (
            hundredths(derivation.total()),
            Origin::Derived,
            Some(derivation),
        ),
    };
    let (mask, mask_from, no_safe) = match mask {
        Some(v) => (v, Origin::Project, Vec::new()),
        None => {
            let (mask, no_safe) = safe_mask(ask);
            (mask, Origin::Derived, no_safe)
        }
    };
    Armed::MiniMod {
        time,
        time_from,
        derivation,
        mask,
        mask_from,
        no_safe,
    }
}

impl Family for MiniModFamily {
    fn name(&self) -> &'static str {
        "MiniMod"
    }

    fn push_down(&self, shape: &RungShape, site: &dyn Site) -> Result<ModulePlacement, Reason> {
        super::placement::map(shape, site)
    }

    fn add_pushed(&self, push: &mut PushDown, pushed: Pushed) {
        if let (Some(mine), Pushed::MiniMod(auto)) = (minimod_push(push), pushed) {
            mine.auto.push(auto);
        }
    }

    fn condition_input(
        &self,
        push: &mut PushDown,
        point: &str,
        rising: Option<u16>,
        falling: Option<u16>,
    ) -> Option<Vec<(&'static str, u16)>> {
        let input = super::Input::named(point)?;
        let latency = super::Latency {
            input,
            rising,
            falling,
        };
        minimod_push(push)?.latencies.push(latency);
        Some(latency.registers())
    }

    fn supports(&self, settings: LineSettings, address: u8) -> bool {
        super::commission::supports(settings, address)
    }

    fn who_are_you(&self, address: u8, _checksum: bool) -> Option<Vec<u8>> {
        Some(super::commission::who_are_you(address))
    }

    fn identify(&self, _address: u8, reply: &str) -> Option<Result<&'static str, String>> {
        super::commission::identify(reply)
    }

    fn plan_commissioning(
        &self,
        _conversation: &mut dyn Conversation,
        request: &CommissionRequest,
        model: &'static str,
    ) -> Result<Plan, CommissionError> {
        super::commission::plan(request, model)
    }

    fn watchdog_conflict(&self, settings: &ModuleSettings) -> Option<WatchdogConflict> {
        let time = own(settings)?.register("WDTTIME").filter(|&t| t != 0)?;
        Some(WatchdogConflict {
            key: "WDTTIME",
            value: time.to_string(),
        })
    }

    fn plan_watchdog(&self, settings: &ModuleSettings, ask: &WatchdogAsk<'_>) -> Armed {
        // The driver arms it by name (`>WDTTIME=`, read back with `?WDTTIME`; `?WFLAGS`
        // after a restart): text commands, which Modbus TCP cannot carry.
        if !ask.carries_text {
            return Armed::NotArmedWarned {
                why: ON_MODBUS_TCP,
                warning: ON_MODBUS_TCP_WARNING,
            };
        }
        let s = own(settings);
        let time = s.and_then(|s| s.register("WDTTIME"));
        let mask = s.and_then(|s| s.register("WDTYMASK"));
        match (ask.policy, time) {
            (_, Some(0)) | (WatchdogPolicy::Off, _) => Armed::Off,
            (WatchdogPolicy::Auto, time) => auto(time, mask, ask.derivation, ask),
        }
    }

    fn apply_watchdog(&self, settings: &mut ModuleSettings, armed: &Armed) {
        let Some(s) = own_mut(settings) else {
            return;
        };
        match *armed {
            // `watchdog: off` disarms what an earlier run armed, unless WDTTIME: 0 does.
            Armed::Off if s.register("WDTTIME") != Some(0) => {
                s.extend(Setting::holding("WDTTIME", 0));
            }
            Armed::MiniMod {
                time,
                time_from,
                mask,
                mask_from,
                ..
            } => {
                if time_from == Origin::Derived {
                    s.extend(Setting::holding("WDTTIME", time));
                }
                if mask_from == Origin::Derived {
                    s.extend(Setting::holding("WDTYMASK", mask));
                }
            }
            _ => {}
        }
    }

    fn watchdog_traffic(&self, settings: &mut ModuleSettings) {
        if let Some(s) = own_mut(settings) {
            for key in WATCHDOG_REGISTERS {
                if s.register(key).is_none() {
                    s.extend(Setting::holding(key, 1));
                }
            }
        }
    }

    fn text_only_settings(&self, settings: &ModuleSettings) -> Vec<&'static str> {
        own(settings).map_or_else(Vec::new, |s| {
            WATCHDOG_REGISTERS
                .into_iter()
                .filter(|key| s.register(key).is_some())
                .collect()
        })
    }

    /// Every MiniMod gets text commands at start-up, whatever its protocol: its watchdog is
    /// armed by name (`@18>WDTTIME=148`; see the driver's `watchdog`).
    fn startup_text(&self, address: ModuleAddress) -> Option<Vec<u8>> {
        super::write_command(
            address.get(),
            super::TextId::WdtTime,
            super::WriteValue::Number(0),
        )
        .ok()
    }

    fn sets_register(&self, settings: &ModuleSettings, name: &str) -> bool {
        own(settings).is_some_and(|s| s.sets(name))
    }

    /// Inputs X1..X3: XLATUPn and XLATDNn.
    fn input_latency_registers(&self, point: &str) -> Option<(String, String)> {
        let n = point.strip_prefix('X')?;
        matches!(n, "1" | "2" | "3").then(|| (format!("XLATUP{n}"), format!("XLATDN{n}")))
    }

    fn logic_cleared_at_startup(&self, _model: &ModelSpec) -> Option<&'static str> {
        Some(super::LOGIC_CLEARED_AT_STARTUP)
    }

    fn push_down_settings(
        &self,
        _model: &ModelSpec,
        settings: &ModuleSettings,
        push: &PushDown,
    ) -> Vec<String> {
        let (PushDown::MiniMod(push), Some(own)) = (push, own(settings)) else {
            return Vec::new();
        };
        push.settings(own)
            .iter()
            .filter_map(|s| match *s {
                Setting::Register { name, value, .. } => Some(format!("{name}: {value}")),
                Setting::Coils { name, bits, .. } => Some(format!("initial {name}: {bits}")),
                Setting::Readback(_) => Some("readback: every".into()),
                _ => None,
            })
            .collect()
    }

    fn push_initial(&self, push: &mut PushDown, point: &str, on: bool) {
        if *push == PushDown::None {
            *push = PushDown::MiniMod(super::PushDown::default());
        }
        if let (PushDown::MiniMod(push), Some(y)) = (push, super::Output::named(point)) {
            push.initial.push((y, on));
        }
    }

    fn input_modes(&self, settings: &ModuleSettings, protocol: Protocol) -> InputModes {
        let Some(s) = own(settings) else {
            return InputModes::default();
        };
        InputModes {
            collect: true,
            events: s.events(),
            open: protocol == Protocol::Modbus && s.events_given().is_none(),
            refresh: s.events().then(|| s.event_refresh()),
            frame_timeout: s.frame_timeout(),
        }
    }

    fn choose_events(&self, settings: &mut ModuleSettings) {
        if let Some(s) = own_mut(settings) {
            s.push(Setting::Events(true));
        }
    }

    fn tune_reply_delay(&self, settings: &mut ModuleSettings) -> ReplyDelayTuning {
        match own_mut(settings) {
            None => ReplyDelayTuning::NotTunable,
            Some(s) if s.reply_delay_given().is_some() => ReplyDelayTuning::Own,
            Some(s) => {
                s.push(Setting::ReplyDelay(0));
                ReplyDelayTuning::Tuned
            }
        }
    }

    fn factory_reply_delay(&self, settings: &mut ModuleSettings) {
        if let Some(s) = own_mut(settings) {
            s.push(Setting::ReplyDelay(super::FACTORY_RDELAYT));
        }
    }
}

/// The MiniMod push-down in `push`, made one when it is none yet.
fn minimod_push(push: &mut PushDown) -> Option<&mut super::PushDown> {
    if *push == PushDown::None {
        *push = PushDown::MiniMod(super::PushDown::default());
    }
    match push {
        PushDown::MiniMod(mine) => Some(mine),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn registers_of_points() {
        let latency = |point| MiniModFamily.input_latency_registers(point);
        assert_eq!(latency("X2"), Some(("XLATUP2".into(), "XLATDN2".into())));
        assert_eq!(latency("X9"), None);
        assert_eq!(latency("Y1"), None);
    }
}
