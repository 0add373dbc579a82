//! The DCON side of the simulator (manual chapter 2): a command line in, the module's answer
//! out, or silence.
//!
//! - A line ends at CR (a terminal's LF is taken too); leading CR/LF left over from a previous
//!   line are skipped; a line with no terminator yet is not a command.
//! - With the checksum enabled (running, §1.10 bit 6) a command without a correct checksum is
//!   ignored: the module cannot trust the address of a damaged line (the manual is silent).
//!   Answers carry the checksum when it is enabled.
//! - A line whose delimiter and address cannot be read gets no answer; a command to this
//!   module that it does not have gets `?AA` (§2 "Invalid Command"), as do refused changes
//!   (a baud or checksum change outside INIT*, a bad CC, `$AAPN` outside INIT*, `$AAP`/`$AAPN`
//!   on the EX-9053D, `~AA3` enabling with VV = 00).
//! - Broadcasts (`#**`, `~**`) act and never answer (§2.2, §2.17).
//! - `%AANNTTCCFF` answers from the new address NN (§2.1 example `!02`). In INIT*, `$AA2`
//!   answers with the stored address, so that `$002` recovers a forgotten address (§1.4).
//! - `#AAN` reads channels 0..F: the EX-9053D has 16 counters. (The §2.3 example `#025` →
//!   `?02` comes from a module with fewer channels; here channel 5 exists.)

use super::dcon::{check_line, encode_line, Answer, Command, ParseError};
use super::state::{Ex9053State, Variant, WireProtocol};
use super::tables::FIRMWARE;

/// The module's answer to one line as it came off the wire, or `None` for silence.
pub(crate) fn answer(state: &mut Ex9053State, frame: &[u8]) -> Option<Vec<u8>> {
    let start = frame.iter().position(|b| *b != b'\r' && *b != b'\n')?;
    let rest = frame.get(start..)?;
    let end = rest.iter().position(|b| *b == b'\r' || *b == b'\n')?;
    let checksum = state.running().checksum;
    let body = check_line(rest.get(..end)?, checksum).ok()?;
    let (address, answer) = match Command::parse(body) {
        Ok(cmd) => execute(state, &cmd)?,
        Err(ParseError::NoAddress) => return None,
        Err(ParseError::Invalid { address }) => {
            if !state.dcon_addressed(address) {
                return None;
            }
            (address, Answer::Invalid)
        }
    };
    Some(encode_line(&answer.body(address), checksum))
}

/// Executes a parsed command; returns the answer and the address it carries, or `None` when
/// the command is not for this module or is a broadcast.
pub(crate) fn execute(state: &mut Ex9053State, cmd: &Command) -> Option<(u8, Answer)> {
    let address = match cmd.address() {
        None => {
            match cmd {
                Command::SyncSample => state.sync_sample(),
                Command::HostOk => state.host_ok(),
                _ => {}
            }
            return None;
        }
        Some(a) if state.dcon_addressed(a) => a,
        Some(_) => return None,
    };
    let done = |ok: bool| if ok { Answer::Ack } else { Answer::Invalid };
    let answer = match cmd {
        Command::SyncSample | Command::HostOk => return None,
        Command::SetConfig {
            new_address,
            baud_code,
            format,
            ..
        } => {
            return Some(match state.configure(*new_address, *baud_code, *format) {
                Ok(()) => (*new_address, Answer::Ack),
                Err(_) => (address, Answer::Invalid),
            });
        }
        Command::ReadCounter { channel, .. } => {
            Answer::Counter(state.counter(usize::from(*channel)))
        }
        Command::ReadConfig { .. } => {
            let (type_code, baud_code, format) = state.config();
            let from = if state.running().init {
                state.eeprom().address
            } else {
                address
            };
            let config = Answer::Config {
                type_code,
                baud_code,
                format,
            };
            return Some((from, config));
        }
        Command::ReadSync { .. } => {
            let (first, inputs) = state.read_sync();
            Answer::Sync { first, inputs }
        }
        Command::ReadResetStatus { .. } => Answer::ResetStatus(state.take_reset_status()),
        Command::ReadInputStatus { .. } => Answer::InputStatus(state.inputs()),
        Command::ReadFirmware { .. } => Answer::Text(FIRMWARE.to_string()),
        Command::ReadName { .. } => Answer::Text(state.name().to_string()),
        Command::ClearLatches { .. } => {
            state.clear_latches();
            Answer::Ack
        }
        Command::ClearCounter { channel, .. } => {
            state.clear_counter(usize::from(*channel));
            Answer::Ack
        }
        Command::ReadLatches { high, .. } => Answer::Latches(if *high {
            state.latch_high()
        } else {
            state.latch_low()
        }),
        Command::ReadInputs { .. } => Answer::Inputs(state.inputs()),
        Command::SetName { name, .. } => done(state.set_name(name).is_ok()),
        Command::ReadProtocol { .. } => match state.variant() {
            Variant::M => Answer::Protocol {
                modbus: state.eeprom().protocol == WireProtocol::Modbus,
            },
            Variant::D => Answer::Invalid,
        },
        Command::SetProtocol { modbus, .. } => {
            let p = if *modbus {
                WireProtocol::Modbus
            } else {
                WireProtocol::Dcon
            };
            done(state.set_stored_protocol(p, true).is_ok())
        }
        Command::ReadModuleStatus { .. } => Answer::ModuleStatus(state.module_status()),
        Command::ResetModuleStatus { .. } => {
            state.reset_module_status();
            Answer::Ack
        }
        Command::ReadWatchdog { .. } => {
            let (enabled, value) = state.watchdog();
            Answer::Watchdog { enabled, value }
        }
        Command::SetWatchdog { enabled, value, .. } => {
            // "VV timeout value, from 01 to FF": 00 only to disable.
            let ok = !*enabled || *value > 0;
            if ok {
                state.set_watchdog(*enabled, *value);
            }
            done(ok)
        }
    };
    Some((address, answer))
}
