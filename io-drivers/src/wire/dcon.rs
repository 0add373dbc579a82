//! DCON commands and answers in the words of the EX-9053D manual, chapter 2 "Command Sets":
//! each command by its section and its "Description" line, its fields in hexadecimal as the
//! manual writes them (addresses 00..FF, TT, CC, FF), inputs as the 16-bit DI mask of §1.10.

use std::fmt;

use crate::devices::ex9053::dcon::{Answer, Command};

/// A command as the manual names it: `§2.9 $AAM read module name`.
pub(super) struct Described<'a>(pub(super) &'a Command);

impl fmt::Display for Described<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use Command::*;
        match self.0 {
            SetConfig {
                new_address,
                type_code,
                baud_code,
                format,
                ..
            } => write!(
                f,
                "§2.1 set module configuration: new address {new_address:02X}, type \
                 {type_code:02X}, baud code {baud_code:02X}, format {format:02X}"
            ),
            SyncSample => f.write_str("§2.2 synchronized sampling"),
            ReadCounter { channel, .. } => {
                write!(f, "§2.3 read digital input counter of DI{channel}")
            }
            ReadConfig { .. } => f.write_str("§2.4 read configuration"),
            ReadSync { .. } => f.write_str("§2.5 read the synchronized data"),
            ReadResetStatus { .. } => f.write_str("§2.6 read reset status"),
            ReadInputStatus { .. } => f.write_str("§2.7 read digital I/O status"),
            ReadFirmware { .. } => f.write_str("§2.8 read firmware version"),
            ReadName { .. } => f.write_str("§2.9 read module name"),
            ClearLatches { .. } => f.write_str("§2.10 clear latched digital input"),
            ClearCounter { channel, .. } => {
                write!(f, "§2.11 clear digital input counter of DI{channel}")
            }
            ReadLatches { high, .. } => write!(
                f,
                "§2.12 read latched digital input ({})",
                if *high { "high" } else { "low" }
            ),
            ReadInputs { .. } => f.write_str("§2.13 read digital I/O status"),
            SetName { name, .. } => write!(f, "§2.14 set module name to {name:?}"),
            ReadProtocol { .. } => f.write_str("§2.15 read protocol"),
            SetProtocol { modbus, .. } => write!(
                f,
                "§2.16 set protocol to {}",
                if *modbus { "Modbus RTU" } else { "DCON" }
            ),
            HostOk => f.write_str("§2.17 host OK"),
            ReadModuleStatus { .. } => f.write_str("§2.18 read module status"),
            ResetModuleStatus { .. } => f.write_str("§2.19 reset module status"),
            ReadWatchdog { .. } => f.write_str("§2.20 read host watchdog timeout"),
            SetWatchdog { enabled, value, .. } => write!(
                f,
                "§2.21 set host watchdog timeout: {}, {value} × 0.1 s",
                if *enabled { "enabled" } else { "disabled" }
            ),
        }
    }
}

/// An answer with its fields named.
pub(super) struct Told<'a>(pub(super) &'a Answer);

impl fmt::Display for Told<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Answer::Ack => f.write_str("done"),
            Answer::Invalid => f.write_str("invalid command"),
            Answer::Config {
                type_code,
                baud_code,
                format,
            } => write!(
                f,
                "type {type_code:02X}, baud code {baud_code:02X}, format {format:02X}"
            ),
            Answer::Sync { first, inputs } => write!(
                f,
                "inputs {inputs:04X}, {} read of this sample",
                if *first { "first" } else { "a repeated" }
            ),
            Answer::ResetStatus(set) => write!(
                f,
                "{}",
                if *set {
                    "reset since the last read"
                } else {
                    "no reset since the last read"
                }
            ),
            Answer::InputStatus(v) | Answer::Inputs(v) => write!(f, "inputs {v:04X}"),
            Answer::Text(text) => write!(f, "{text:?}"),
            Answer::Counter(n) => write!(f, "count {n}"),
            Answer::Latches(v) => write!(f, "latched {v:04X}"),
            Answer::Protocol { modbus } => write!(
                f,
                "protocol {}",
                if *modbus { "Modbus RTU" } else { "DCON" }
            ),
            Answer::ModuleStatus(s) => write!(f, "module status {s:02X}"),
            Answer::Watchdog { enabled, value } => write!(
                f,
                "host watchdog {}, {value} × 0.1 s",
                if *enabled { "enabled" } else { "disabled" }
            ),
        }
    }
}
