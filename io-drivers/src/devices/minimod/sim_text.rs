//! The simulator's side of the text protocol: a packet in, the module's state changed, the
//! reply out ([`super::text`] parses and formats; this file decides).
//!
//! Manual, "Text commands protocol", the read and write tables and "Configuration of Minimod".
//! The choices the manual leaves open are listed in [`super::text`], [`super::watchdog`] and
//! [`super::serial_config`]; the ones made here:
//! - Text identifiers reach the same items as Modbus (`?Y1` is coil 0, the commanded output;
//!   `?XWORD` is input register 0).
//! - `>SERLINE=` answers `OK` with the old settings, then switches ("only after having replied
//!   with OK, the new parameters take effect"); `>ADDRESS=` likewise.
//! - `>WCONF=1` is slow: its reply comes [`WCONF_EXTRA_DELAY`] after the usual reply delay
//!   ("can take up to some tenth of a second").

use std::time::Duration;

use super::map::Item;
use super::serial_config::SerialParams;
use super::state::MiniModState;
use super::text::{
    device_reply, format_value, parse_command, Op, TextId, WriteValue, ERROR, FLASH_ERROR, OK,
};

/// Extra time a `>WCONF=1` takes before its reply (the flash write).
pub(crate) const WCONF_EXTRA_DELAY: Duration = Duration::from_millis(100);

/// What the module answers to a packet.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct TextAnswer {
    /// The reply, without its CR.
    pub text: String,
    /// Extra delay before it (the flash write of WCONF).
    pub extra_delay: Duration,
}

impl TextAnswer {
    fn now(text: impl Into<String>) -> Self {
        Self {
            text: text.into(),
            extra_delay: Duration::ZERO,
        }
    }
}

/// Executes one packet (CR stripped or not) on `state`; `None` when the module stays silent
/// (malformed, or addressed to another slave).
pub(crate) fn execute(state: &mut MiniModState, packet: &[u8]) -> Option<TextAnswer> {
    let command = parse_command(packet).ok()?;
    if command.to.is_some_and(|to| to != state.address()) {
        return None;
    }
    state.on_valid_command();
    let answer = match command.op {
        Err(_) => TextAnswer::now(ERROR),
        Ok(Op::Read(id)) => read(state, id),
        Ok(Op::Write(id, value)) => write(state, id, value),
    };
    Some(answer)
}

fn read(state: &MiniModState, id: TextId) -> TextAnswer {
    let value = match id {
        TextId::Device => return TextAnswer::now(device_reply()),
        TextId::Address => u16::from(state.address()),
        TextId::Fbacks => u16::from(state.feedbacks()),
        TextId::FbEnable => u16::from(state.fb_enable()),
        TextId::Wflags => state.wflags(),
        other => match item(other) {
            Some(item) => state.read(item),
            // Write-only identifiers are refused by the parser; nothing else is left.
            None => return TextAnswer::now(ERROR),
        },
    };
    TextAnswer::now(format_value(id, value))
}

fn write(state: &mut MiniModState, id: TextId, value: WriteValue) -> TextAnswer {
    let number = match value {
        WriteValue::Number(n) => n,
        WriteValue::Condition(mask) => mask,
        WriteValue::Serline { baud, mode } => {
            let current = state.serial().active().serial.mode;
            state.set_serial(SerialParams::from_write(baud, mode, current));
            return TextAnswer::now(OK);
        }
    };
    // The parser has checked each identifier's range, so the narrowing below cannot fail.
    let byte = u8::try_from(number).unwrap_or(u8::MAX);
    match id {
        TextId::Address => state.set_address(byte),
        TextId::RdelayT => state.set_rdelayt(byte),
        TextId::RdelayM => state.set_rdelaym(byte),
        TextId::FbEnable => state.set_fb_enable(byte),
        TextId::Wflags => state.write_wflags(number),
        TextId::Wconf => {
            return match state.save_preferences() {
                Ok(()) => TextAnswer {
                    text: OK.into(),
                    extra_delay: WCONF_EXTRA_DELAY,
                },
                Err(_) => TextAnswer {
                    text: FLASH_ERROR.into(),
                    extra_delay: WCONF_EXTRA_DELAY,
                },
            };
        }
        other => {
            let Some(item) = item(other) else {
                return TextAnswer::now(ERROR);
            };
            if state.write(item, number).is_err() {
                return TextAnswer::now(ERROR);
            }
        }
    }
    TextAnswer::now(OK)
}

/// The register-map item a text identifier reaches, where there is one.
fn item(id: TextId) -> Option<Item> {
    Some(match id {
        TextId::Xword => Item::InputWord,
        TextId::X(i) => Item::Input(i),
        TextId::X9 => Item::Feedback(0),
        TextId::X10 => Item::Feedback(1),
        TextId::Sw3 => Item::Sw3,
        TextId::Sw4 => Item::Sw4,
        TextId::Yword => Item::Yword,
        TextId::Y(i) => Item::Output(i),
        TextId::WdtTime => Item::WdtTime,
        TextId::WdtMask => Item::WdtYMask,
        TextId::Xcount(i) => Item::Xcount(i),
        TextId::XlatUp(i) => Item::XlatUp(i),
        TextId::XlatDn(i) => Item::XlatDn(i),
        TextId::Lamp(i) => Item::Lamp(i),
        TextId::Pulse(i) => Item::Pulse(i),
        TextId::AutoOn(y, c) => Item::AutoOn(y, c),
        TextId::AutoOff(y, c) => Item::AutoOff(y, c),
        TextId::Address
        | TextId::Device
        | TextId::Fbacks
        | TextId::FbEnable
        | TextId::Wflags
        | TextId::Serline
        | TextId::RdelayT
        | TextId::RdelayM
        | TextId::Wconf => return None,
    })
}
