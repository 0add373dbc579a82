//! Identifying and commissioning a MiniMod by its text protocol (manual, "Text commands
//! protocol", "Configuration of Minimod"):
//! - who it is: `@N?DEVICE`, answered `DEVICE=MINIMOD 1.1` ("Slave addressing", "Read commands
//!   table (text mode)"); bauds 4800..57600 ("SERLINE"), @N 1..=255;
//! - `>RDELAYT=n` ("Setting the reply delay": hundredths of a second, 0..=200);
//! - `>SERLINE=19200E` ("Setting the communication parameters": 4800..57600, E/O/N/X); the
//!   module answers `OK` at the old settings and switches after it;
//! - `>ADDRESS=N` ("Setting the slave address": 1..=247 for Modbus);
//! - `>WCONF=1` ("Saving setting permanently"), at the new address; without it the module
//!   powers up with what its flash held before.
//!
//! Read back: `@N?DEVICE` at the new address and settings (SERLINE and RDELAYT are
//! write-only, "Read commands table").

use super::{read_command, write_command, LineMode, TextId, Unwritable, WriteValue};
use super::{BAUD_RATES, MAX_RDELAY};
use crate::devices::family::{CommissionError, CommissionRequest, Expect, Plan, Step};
use crate::line::{LineSettings, SerialFormat};

/// What the MiniMod's manual does not allow a host to set.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum MiniModRefusal {
    /// A reply delay RDELAYT cannot count.
    #[error("refused: --set-reply-delay {ms}ms: the MiniMod's RDELAYT counts hundredths of a second, 0..=200 (manual, \"Setting the reply delay\"): give 0ms..2s in steps of 10ms")]
    ReplyDelay {
        /// The delay asked, ms.
        ms: u128,
    },
    /// A baud rate SERLINE does not take.
    #[error("refused: --set-baud {baud}: the MiniMod runs at 4800, 9600, 19200, 38400 or 57600 Bd (manual, \"Setting the communication parameters\")")]
    Baud {
        /// The rate asked.
        baud: u32,
    },
    /// A character format SERLINE does not take.
    #[error("refused: --set-format {format}: the MiniMod has 8E1, 8O1, 8N2 and 8N1 only (SERLINE E, O, N, X; manual, \"Setting the communication parameters\")")]
    Format {
        /// The format asked.
        format: SerialFormat,
    },
    /// An address outside Modbus units.
    #[error("refused: --set-address {address}: Modbus accepts only 1..=247 (MiniMod manual, \"Setting the slave address\")")]
    Address {
        /// The address asked.
        address: u8,
    },
    /// A value the text command cannot carry.
    #[error("cannot encode {id}: {error:?}")]
    Encode {
        /// The command.
        id: TextId,
        /// Why.
        error: Unwritable,
    },
}

/// Whether a MiniMod can run at these settings and answer at this address.
pub(crate) fn supports(s: LineSettings, address: u8) -> bool {
    BAUD_RATES.contains(&s.baud) && s.format.data_bits == 8 && address >= 1
}

/// `@N?DEVICE`.
pub(crate) fn who_are_you(address: u8) -> Vec<u8> {
    read_command(address, TextId::Device)
}

/// The model a `DEVICE=` answer names, if it is a MiniMod's.
pub(crate) fn identify(reply: &str) -> Option<Result<&'static str, String>> {
    let reply = reply.trim_matches(|c: char| c == '\r' || c == '\n' || c == ' ');
    reply
        .strip_prefix("DEVICE=")
        .filter(|r| r.starts_with("MINIMOD"))
        .map(|_| Ok(super::MODEL.name))
}

/// The answer of every MiniMod write.
fn ok() -> Expect {
    Expect::Answer(Box::new(|r: &str| {
        if r.trim() == "OK" {
            Ok(())
        } else {
            Err(format!("the module answered {r:?}, not OK"))
        }
    }))
}

fn frame(to: u8, id: TextId, v: WriteValue) -> Result<Vec<u8>, CommissionError> {
    write_command(to, id, v)
        .map_err(|error| CommissionError::refused(MiniModRefusal::Encode { id, error }))
}

/// The plan for `req` to the MiniMod `model` answering at `req.now`.
pub(crate) fn plan(req: &CommissionRequest, model: &'static str) -> Result<Plan, CommissionError> {
    let now = req.now;
    let a = req.address;
    let mut steps = Vec::new();
    if let Some(d) = req.set_reply_delay {
        // "Setting the reply delay": RDELAYT=nnn, hundredths of a second, 0..=200.
        let ms = d.as_millis();
        if ms % 10 != 0 || ms / 10 > u128::from(MAX_RDELAY) {
            return Err(CommissionError::refused(MiniModRefusal::ReplyDelay { ms }));
        }
        let n = u16::try_from(ms / 10).unwrap_or(0);
        steps.push(Step::Send {
            what: format!("RDELAYT={n} (reply delay {ms}ms)"),
            frame: frame(a, TextId::RdelayT, WriteValue::Number(n))?,
            expect: ok(),
        });
    }
    let mut new_settings = now;
    if req.set_baud.is_some() || req.set_format.is_some() {
        let baud = req.set_baud.unwrap_or(now.baud);
        if !BAUD_RATES.contains(&baud) {
            return Err(CommissionError::refused(MiniModRefusal::Baud { baud }));
        }
        let format = req.set_format.unwrap_or(now.format);
        let Some(mode) = [
            LineMode::Even,
            LineMode::Odd,
            LineMode::NoneTwoStops,
            LineMode::NoneOneStop,
        ]
        .into_iter()
        .find(|m| m.format() == format) else {
            return Err(CommissionError::refused(MiniModRefusal::Format { format }));
        };
        new_settings = LineSettings { baud, format };
        steps.push(Step::Send {
            what: format!("SERLINE={baud}{} ({new_settings})", mode.letter()),
            frame: frame(
                a,
                TextId::Serline,
                WriteValue::Serline {
                    baud,
                    mode: Some(mode),
                },
            )?,
            expect: ok(),
        });
        // "The module replies with the old settings; the new ones apply after the OK".
        if new_settings != now {
            steps.push(Step::Switch(new_settings));
        }
    }
    let mut new_address = a;
    if let Some(n) = req.set_address {
        if !(1..=247).contains(&n) {
            return Err(CommissionError::refused(MiniModRefusal::Address {
                address: n,
            }));
        }
        new_address = n;
        steps.push(Step::Send {
            what: format!("ADDRESS={n}"),
            frame: frame(a, TextId::Address, WriteValue::Number(u16::from(n)))?,
            expect: ok(),
        });
    }
    steps.push(Step::Send {
        what: "WCONF=1 (save to flash)".into(),
        frame: frame(new_address, TextId::Wconf, WriteValue::Number(1))?,
        expect: ok(),
    });
    steps.push(Step::Send {
        what: format!("read back at {new_settings}"),
        frame: who_are_you(new_address),
        expect: Expect::Answer(Box::new(move |r: &str| match identify(r) {
            Some(Ok(_)) => Ok(()),
            _ => Err(format!("{r:?} is not a MiniMod's DEVICE answer")),
        })),
    });
    Ok(Plan {
        steps,
        done: format!("{model} answers at address {new_address}, {new_settings}; saved (WCONF)"),
    })
}
