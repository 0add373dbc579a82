//! The EX-9053D / EX-9053D-M driver (sans-IO), DCON or Modbus RTU as the project file says.
//!
//! The project file's numeric `address` is the module address as a number: `address: 1` is
//! DCON `01`, `address: 18` is DCON `12` (hexadecimal on the wire) and Modbus unit 18.
//!
//! ## Start-up (verified; a [`DecodeError`] stops the start)
//!
//! | step                         | DCON                  | Modbus                                  |
//! |------------------------------|-----------------------|-----------------------------------------|
//! | identity                     | `$AAM` (name, logged) | FC 3 40483..40484 = 0x0090 0x5300       |
//! | configuration                | `$AA2`: TT = 40, FF bit 6 = `checksum`, bit 7 = `count_edge` | — |
//! | reset status                 | `$AA5` (logged)       | —                                       |
//! | `count_edge`                 | (checked above)       | FC 5 02251, read back FC 1              |
//! | `watchdog`                   | `~AA0` (a past timeout is logged), `~AA1`, `~AA31VV`, `~AA2` read back | FC 1 00270 (logged), FC 5 00270 ← ON, FC 6 40489 ← VV, FC 5 00261 ← ON, FC 3 40489 and FC 1 00261 read back |
//! | latches (if read)            | `$AAC`                | FC 5 00264 ← ON                         |
//!
//! ## Per cycle (the inputs of one module, in this order)
//!
//! | step                         | DCON                         | Modbus                        |
//! |------------------------------|------------------------------|-------------------------------|
//! | recovery after a timeout     | `~AA1`, `~AA31VV`            | FC 5 00270, FC 6 40489, FC 5 00261 |
//! | sync lead                    | `#**` (no reply)             | —                             |
//! | host OK (`watchdog`)         | `~**` (no reply)             | FC 4 0x3038 qty 0 (no reply)  |
//! | inputs DI0..DI15             | `@AA`, or `$AA4` with `sync` | FC 2 10001..10016             |
//! | latch high / low             | `$AAL1` / `$AAL0`            | FC 1 00065.. / 00097.. (16)   |
//! | clear latches                | `$AAC`                       | FC 5 00264 ← ON               |
//! | counters                     | `#AAN` per channel           | FC 4, one read over the span  |
//! | watchdog status              | `~AA0`                       | FC 1 00270                    |
//!
//! Latches are read and then cleared every cycle, so `DIn_LATCH_HIGH` means "high at some
//! moment since the previous poll": a pulse shorter than the scan is caught. A pulse that starts
//! and ends between the latch read and the clear (one transaction) is not: neither protocol can
//! read and clear at once.
//!
//! The host watchdog is fed every cycle. When `~AA0` / 00270 shows the timeout status (the host
//! was silent too long: a stopped scan, a broken line), `WDT_TIMEOUT` turns true, a warning is
//! logged, and the next cycle clears the status and re-arms the watchdog (the module disables
//! it on timeout, §2.21 example); `WDT_TIMEOUT` turns false with the next clean status read.
//!
//! A module that comes back after it was lost (a broken line, a power cycle) gets its start-up
//! again from the bus owner ([`Driver::on_restart`]): the start-up's `~AA0` / 00270 read finds
//! the timeout status the outage left (§1.8: "set and store into EEPROM while the host watchdog
//! timeout interval expired and only can be cleared by command ~AA1"), logs it once with the
//! module's address, clears it and arms the watchdog again. "Host Watchdog Timeout will let all
//! output goto Safe Value ... and the output command will be ignored" (§1.5): the EX-9053D has
//! no outputs, so there is no Safe Value to leave and nothing to write again; the driver never
//! asks for a restart ([`Driver::wants_restart`] stays false).
//!
//! The module name is not read through FC 0x46: the master codec's FC 0x46 is MiniMod's
//! Collect; the name registers 40483..40484 give the same identity with FC 3.
//!
//! There are no outputs: [`Driver::plan_write`] plans nothing.
//!
//! ## Registers the manual gives two ways
//!
//! What the driver writes where the manual says two things, the reading chosen, and how it is
//! confirmed:
//!
//! | what | reading 1 | reading 2 | chosen | confirmed |
//! |---|---|---|---|---|
//! | host watchdog status after a timeout | `~AA0` "84 = host watchdog is enabled & host watchdog timeout status is set" (§2.18 table) | "The module's status ... will be 04" (§1.5), and the §2.21 example reads `!0104` then "host watchdog is disabled" | bit 2 (0x04) alone means a timeout, whatever bit 7 says; the watchdog is always armed again after the clear (`~AA1`, `~AA31VV`), so a module that disabled it is armed too | `~AA2` / FC 3 40489 + FC 1 00261 read back enabled with the value; the status is read again every cycle |
//! | WDT timeout status, Modbus | 00270 reads "0x01: WDT timeout" | "(write 0xFF00 to clear WDT timeout status)": writing ON clears it | FC 5 00270 ← ON (0xFF00), as the FC 05 section says too (0x010D, "0xFF00 for Clear WDT timeout status") | FC 1 00270 every cycle: a timeout still set is logged and cleared again |
//! | WDT timeout value | DCON `VV` "from 01 to FF" (§2.21) | Modbus 40489 "0x0000~0x00FF" | 1..=255 (`watchdog` 100ms..=25.5s), valid in both | read back (`~AA2`, FC 3 40489) |
//! | `#AAN`, `$AA4` answers | the "Response" lines | the examples (§2.3, §2.2) | the examples (see [`super::dcon`]) | parsed strictly: another form is an error |
//!
//! The rest (enable 00261 = 0x0104, clear 00270 = 0x010D, host OK 0x3038 = 312345/412345,
//! count edge FF bit 7 and 02251) is given the same way wherever the manual gives it.

use std::time::Duration;

use super::dcon::{check_line, Answer, Command};

/// The counter edge as `$AA2` reports it: a mismatch names it, and the driver then says how
/// to set it.
const COUNT_EDGE_DCON: &str = "$AA2 FF bit 7 (counter edge, 1 = rising)";
use super::map::{
    host_ok_frame, COIL_CLEAR_LATCHES, COIL_COUNT_EDGE, COIL_LATCH_HIGH, COIL_LATCH_LOW,
    COIL_WDT_ENABLE, COIL_WDT_STATUS, DI_INPUTS, HR_NAME, HR_WDT_VALUE, NAME_WORDS, REG_COUNTERS,
};
use super::points::{Point, POINTS};
use super::settings::Settings;
use super::sync::SyncRole;
use super::tables::{
    CHANNELS, FF_CHECKSUM, FF_RISING_EDGE, REPLY_DELAY, STATUS_WDT_TIMEOUT, TYPE_DIO,
};
use crate::devices::{DeviceConfig, ModuleSettings, Protocol};
use crate::driver::{DecodeError, Driver, Integrity, Outgoing, Reply, Transaction};
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

/// Builds a driver from a validated module entry (the catalog's constructor). A configuration
/// of another family (never built by project validation, which parses the settings with this
/// model) gives the defaults. Project validation refuses a DCON-only setting on a module
/// running Modbus; [`Ex9053Driver::new`] still drops one, with a warning, for callers that
/// build a driver by hand.
pub(crate) fn build(config: &DeviceConfig) -> Box<dyn Driver> {
    let settings = match &config.settings {
        ModuleSettings::Ex9053(s) => *s,
        _ => Settings::default(),
    };
    Box::new(Ex9053Driver::new(
        &config.name,
        config.address.get(),
        config.protocol,
        settings,
    ))
}

/// One step of a plan; carried in the transaction's tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Step {
    Name,
    Config,
    ResetStatus,
    EdgeWrite,
    EdgeVerify,
    WdtPastStatus,
    WdtClear,
    WdtArm,
    WdtValue,
    WdtEnable,
    WdtVerify,
    WdtVerifyEnable,
    SyncSample,
    HostOk,
    Inputs,
    LatchHigh,
    LatchLow,
    ClearLatches,
    Counter(u8),
    Counters,
    WdtStatus,
}

impl Step {
    const KINDS: [Step; 21] = [
        Step::Name,
        Step::Config,
        Step::ResetStatus,
        Step::EdgeWrite,
        Step::EdgeVerify,
        Step::WdtPastStatus,
        Step::WdtClear,
        Step::WdtArm,
        Step::WdtValue,
        Step::WdtEnable,
        Step::WdtVerify,
        Step::WdtVerifyEnable,
        Step::SyncSample,
        Step::HostOk,
        Step::Inputs,
        Step::LatchHigh,
        Step::LatchLow,
        Step::ClearLatches,
        Step::Counter(0),
        Step::Counters,
        Step::WdtStatus,
    ];

    fn tag(self) -> u32 {
        let kind = Self::KINDS
            .iter()
            .position(|k| std::mem::discriminant(k) == std::mem::discriminant(&self))
            .unwrap_or(0);
        let channel = match self {
            Step::Counter(ch) => u32::from(ch),
            _ => 0,
        };
        ((kind as u32) << 8) | channel
    }

    fn from_tag(tag: u32) -> Option<Self> {
        let kind = *Self::KINDS.get(usize::try_from(tag >> 8).ok()?)?;
        Some(match kind {
            Step::Counter(_) => Step::Counter(u8::try_from(tag & 0xFF).ok()?),
            other => other,
        })
    }
}

/// The EX-9053D / EX-9053D-M driver.
#[derive(Debug, Clone)]
pub struct Ex9053Driver {
    name: String,
    address: u8,
    protocol: Protocol,
    unit: Option<UnitId>,
    settings: Settings,
    values: Vec<Option<Value>>,
    /// A watchdog timeout was seen: clear the status and re-arm at the next cycle.
    recover: bool,
    /// The bus owner restarted the module (it was lost and answers again).
    restarted: bool,
    /// The timeout status has been logged; cleared by a clean status read.
    logged: bool,
}

impl Ex9053Driver {
    /// A driver for the module `name` at `address` speaking `protocol` (Text = DCON).
    pub fn new(name: &str, address: u8, protocol: Protocol, mut settings: Settings) -> Self {
        let unit = UnitId::new(address);
        if protocol == Protocol::Modbus {
            if unit.is_none() {
                tracing::error!(module = %name, address, "not a Modbus unit address");
            }
            if settings.sync != SyncRole::Off || settings.checksum {
                tracing::warn!(module = %name, "sync and checksum are DCON settings: ignored");
                settings.sync = SyncRole::Off;
                settings.checksum = false;
            }
        }
        Self {
            name: name.to_string(),
            address,
            protocol,
            unit,
            settings,
            values: vec![None; POINTS.len()],
            recover: false,
            restarted: false,
            logged: false,
        }
    }

    fn dcon(&self) -> bool {
        self.protocol == Protocol::Text
    }

    /// The DCON command of a step.
    fn command(&self, step: Step) -> Option<Command> {
        let address = self.address;
        let vv = self.settings.watchdog.unwrap_or(0);
        Some(match step {
            Step::Name => Command::ReadName { address },
            Step::Config => Command::ReadConfig { address },
            Step::ResetStatus => Command::ReadResetStatus { address },
            Step::WdtPastStatus | Step::WdtStatus => Command::ReadModuleStatus { address },
            Step::WdtClear => Command::ResetModuleStatus { address },
            Step::WdtArm => Command::SetWatchdog {
                address,
                enabled: true,
                value: vv,
            },
            Step::WdtVerify => Command::ReadWatchdog { address },
            Step::SyncSample => Command::SyncSample,
            Step::HostOk => Command::HostOk,
            Step::Inputs if self.settings.sync.reads_sample() => Command::ReadSync { address },
            Step::Inputs => Command::ReadInputs { address },
            Step::LatchHigh => Command::ReadLatches {
                address,
                high: true,
            },
            Step::LatchLow => Command::ReadLatches {
                address,
                high: false,
            },
            Step::ClearLatches => Command::ClearLatches { address },
            Step::Counter(channel) => Command::ReadCounter { address, channel },
            Step::EdgeWrite
            | Step::EdgeVerify
            | Step::WdtValue
            | Step::WdtEnable
            | Step::WdtVerifyEnable
            | Step::Counters => return None,
        })
    }

    /// The channels whose counters are read, lowest and highest.
    fn counter_span(&self) -> Option<(u16, u16)> {
        let mask = self.settings.counters;
        (mask != 0).then(|| {
            let first = mask.trailing_zeros() as u16;
            let last = 15 - mask.leading_zeros() as u16;
            (first, last)
        })
    }

    /// Whether `response` is the echo of the write `step` sends: an FC 5 or FC 6 answer at the
    /// address its request wrote.
    fn echoes(&self, step: Step, response: &Response) -> bool {
        matches!(
            (self.request(step), response),
            (
                Some(Request::WriteSingleCoil { addr: sent, .. }),
                Response::WriteSingleCoil { addr, .. },
            ) | (
                Some(Request::WriteSingleRegister { addr: sent, .. }),
                Response::WriteSingleRegister { addr, .. },
            ) if sent == *addr
        )
    }

    /// The Modbus request of a step (`None`: a DCON-only step, or the host OK frame).
    fn request(&self, step: Step) -> Option<Request> {
        let vv = u16::from(self.settings.watchdog.unwrap_or(0));
        Some(match step {
            Step::Name => Request::ReadHoldingRegisters {
                addr: HR_NAME,
                count: 2,
            },
            Step::EdgeWrite => Request::WriteSingleCoil {
                addr: COIL_COUNT_EDGE,
                value: self.settings.count_edge.unwrap_or(false),
            },
            Step::EdgeVerify => Request::ReadCoils {
                addr: COIL_COUNT_EDGE,
                count: 1,
            },
            Step::WdtPastStatus | Step::WdtStatus => Request::ReadCoils {
                addr: COIL_WDT_STATUS,
                count: 1,
            },
            Step::WdtClear => Request::WriteSingleCoil {
                addr: COIL_WDT_STATUS,
                value: true,
            },
            Step::WdtValue => Request::WriteSingleRegister {
                addr: HR_WDT_VALUE,
                value: vv,
            },
            Step::WdtEnable => Request::WriteSingleCoil {
                addr: COIL_WDT_ENABLE,
                value: true,
            },
            Step::WdtVerify => Request::ReadHoldingRegisters {
                addr: HR_WDT_VALUE,
                count: 1,
            },
            Step::WdtVerifyEnable => Request::ReadCoils {
                addr: COIL_WDT_ENABLE,
                count: 1,
            },
            Step::Inputs => Request::ReadDiscreteInputs {
                addr: DI_INPUTS,
                count: CHANNELS as u16,
            },
            Step::LatchHigh => Request::ReadCoils {
                addr: COIL_LATCH_HIGH,
                count: CHANNELS as u16,
            },
            Step::LatchLow => Request::ReadCoils {
                addr: COIL_LATCH_LOW,
                count: CHANNELS as u16,
            },
            Step::ClearLatches => Request::WriteSingleCoil {
                addr: COIL_CLEAR_LATCHES,
                value: true,
            },
            Step::Counters => {
                let (first, last) = self.counter_span()?;
                Request::ReadInputRegisters {
                    addr: REG_COUNTERS + first,
                    count: last - first + 1,
                }
            }
            Step::Config
            | Step::ResetStatus
            | Step::WdtArm
            | Step::SyncSample
            | Step::HostOk
            | Step::Counter(_) => return None,
        })
    }

    /// Appends the transaction of `step`, if it has one in this protocol.
    fn push(&self, step: Step, out: &mut Vec<Transaction>) {
        let tag = step.tag();
        let frame = if self.dcon() {
            let Some(cmd) = self.command(step) else {
                return;
            };
            let line = cmd.encode(self.settings.checksum);
            if cmd.address().is_none() {
                Outgoing::NoReply { bytes: line }
            } else {
                Outgoing::Text {
                    line,
                    terminator: super::dcon::CR,
                    integrity: if self.settings.checksum {
                        Integrity::Checked
                    } else {
                        Integrity::Unchecked
                    },
                }
            }
        } else {
            let Some(unit) = self.unit else { return };
            if step == Step::HostOk {
                Outgoing::NoReply {
                    bytes: host_ok_frame(unit.get()),
                }
            } else {
                let Some(request) = self.request(step) else {
                    return;
                };
                Outgoing::Modbus { unit, request }
            }
        };
        out.push(Transaction { frame, tag });
    }

    fn set(&mut self, point: Point, value: Value) {
        if let Some(slot) = self.values.get_mut(point.index()) {
            *slot = Some(value);
        }
    }

    fn set_word(&mut self, point: fn(usize) -> Point, word: u16) {
        for ch in 0..CHANNELS {
            self.set(point(ch), Value::Bool(word & (1 << ch) != 0));
        }
    }

    fn set_watchdog_status(&mut self, timeout: bool) {
        if timeout && !self.recover && !self.logged {
            self.logged = true;
            tracing::warn!(
                module = %self.name,
                address = self.address,
                "host watchdog timeout status set: the module saw no host OK in time; \
                 clearing and re-arming"
            );
        }
        if !timeout {
            self.logged = false;
        }
        self.recover = timeout;
        self.set(Point::WdtTimeout, Value::Bool(timeout));
    }

    fn on_dcon(&mut self, step: Step, tag: u32, text: &[u8]) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let cmd = self.command(step).ok_or(unexpected)?;
        let body = check_line(text, self.settings.checksum).map_err(|_| unexpected)?;
        let answer = Answer::parse(&cmd, body).map_err(|_| unexpected)?;
        match (step, answer) {
            (_, Answer::Invalid) => {
                tracing::debug!(module = %self.name, command = %cmd, "module answered ?AA");
                Err(unexpected)
            }
            (Step::Name, Answer::Text(name)) => {
                tracing::info!(module = %self.name, name = %name, "EX-9053D answers");
                Ok(())
            }
            (
                Step::Config,
                Answer::Config {
                    type_code, format, ..
                },
            ) => self.check_config(type_code, format),
            (Step::ResetStatus, Answer::ResetStatus(reset)) => {
                if reset {
                    tracing::info!(module = %self.name, "module was reset (power-on or module watchdog)");
                }
                Ok(())
            }
            (Step::WdtPastStatus, Answer::ModuleStatus(ss)) => {
                self.log_past_timeout(ss & STATUS_WDT_TIMEOUT != 0);
                Ok(())
            }
            (Step::WdtClear, Answer::Ack) | (Step::ClearLatches, Answer::Ack) => Ok(()),
            (Step::WdtArm, Answer::Ack) => {
                self.recover = false;
                Ok(())
            }
            (Step::WdtVerify, Answer::Watchdog { enabled, value }) => {
                let vv = self.settings.watchdog.unwrap_or(0);
                let found = (u32::from(enabled) << 8) | u32::from(value);
                let expected = 0x100 | u32::from(vv);
                (found == expected)
                    .then_some(())
                    .ok_or(DecodeError::Mismatch {
                        register: "~AA2 host watchdog (E << 8 | VV)",
                        expected,
                        found,
                    })
            }
            (Step::Inputs, Answer::Inputs(word)) => {
                self.set_word(Point::Input, word);
                Ok(())
            }
            (Step::Inputs, Answer::Sync { first, inputs }) => {
                self.set(Point::SyncFirst, Value::Bool(first));
                if !first {
                    // No sample since the last read: the broadcast was lost or nobody leads.
                    tracing::debug!(module = %self.name, "$AA4: no new synchronized sample");
                    return Err(unexpected);
                }
                self.set_word(Point::Input, inputs);
                Ok(())
            }
            (Step::LatchHigh, Answer::Latches(word)) => {
                self.set_word(Point::LatchHigh, word);
                Ok(())
            }
            (Step::LatchLow, Answer::Latches(word)) => {
                self.set_word(Point::LatchLow, word);
                Ok(())
            }
            (Step::Counter(ch), Answer::Counter(n)) => {
                let n = i32::try_from(n).map_err(|_| unexpected)?;
                self.set(Point::Counter(usize::from(ch)), Value::I32(n));
                Ok(())
            }
            (Step::WdtStatus, Answer::ModuleStatus(ss)) => {
                self.set_watchdog_status(ss & STATUS_WDT_TIMEOUT != 0);
                Ok(())
            }
            _ => Err(unexpected),
        }
    }

    fn check_config(&self, type_code: u8, format: u8) -> Result<(), DecodeError> {
        if type_code != TYPE_DIO {
            return Err(DecodeError::Mismatch {
                register: "$AA2 TT (type)",
                expected: u32::from(TYPE_DIO),
                found: u32::from(type_code),
            });
        }
        let checksum = format & FF_CHECKSUM != 0;
        if checksum != self.settings.checksum {
            return Err(DecodeError::Mismatch {
                register: "$AA2 FF bit 6 (checksum)",
                expected: u32::from(self.settings.checksum),
                found: u32::from(checksum),
            });
        }
        if let Some(rising) = self.settings.count_edge {
            let found = format & FF_RISING_EDGE != 0;
            if found != rising {
                // Explained once it is believed (`on_confirmed_mismatch`).
                return Err(DecodeError::Mismatch {
                    register: COUNT_EDGE_DCON,
                    expected: u32::from(rising),
                    found: u32::from(found),
                });
            }
        }
        Ok(())
    }

    fn log_past_timeout(&mut self, timeout: bool) {
        if !timeout {
            self.logged = false;
            return;
        }
        if self.logged {
            return;
        }
        self.logged = true;
        if self.restarted {
            tracing::warn!(
                module = %self.name,
                address = self.address,
                "EX-9053D {} at address {} is back with its host watchdog timeout status set: \
                 it saw no host OK within the host watchdog timeout while it was away (the \
                 output command is ignored until ~AA1, §1.5); clearing it and arming the host \
                 watchdog again",
                self.name,
                self.address
            );
        } else {
            tracing::warn!(
                module = %self.name,
                address = self.address,
                "EX-9053D {} at address {}: host watchdog timeout status set at start-up (the \
                 host was away); clearing it and arming the host watchdog again",
                self.name,
                self.address
            );
        }
    }

    fn on_modbus(&mut self, step: Step, tag: u32, response: &Response) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        if let Response::Exception { code, .. } = response {
            return Err(DecodeError::Exception(*code));
        }
        let single = |bits: &[bool]| match bits {
            [b] => Ok(*b),
            _ => Err(unexpected),
        };
        let word = |bits: &[bool]| {
            if bits.len() == CHANNELS {
                Ok(bits
                    .iter()
                    .enumerate()
                    .fold(0u16, |w, (i, b)| w | (u16::from(*b) << i)))
            } else {
                Err(unexpected)
            }
        };
        match (step, response) {
            (Step::Name, Response::ReadHoldingRegisters(regs)) => {
                if regs.as_slice() == NAME_WORDS {
                    Ok(())
                } else {
                    let join = |r: &[u16]| {
                        r.iter()
                            .take(2)
                            .fold(0u32, |acc, w| (acc << 16) | u32::from(*w))
                    };
                    Err(DecodeError::Mismatch {
                        register: "40483..40484 module name",
                        expected: join(&NAME_WORDS),
                        found: join(regs),
                    })
                }
            }
            (Step::EdgeVerify, Response::ReadCoils(bits)) => {
                let rising = self.settings.count_edge.unwrap_or(false);
                let found = single(bits)?;
                (found == rising)
                    .then_some(())
                    .ok_or(DecodeError::Mismatch {
                        register: "02251 count edge (1 = rising)",
                        expected: u32::from(rising),
                        found: u32::from(found),
                    })
            }
            (Step::WdtPastStatus, Response::ReadCoils(bits)) => {
                self.log_past_timeout(single(bits)?);
                Ok(())
            }
            (Step::WdtStatus, Response::ReadCoils(bits)) => {
                let timeout = single(bits)?;
                self.set_watchdog_status(timeout);
                Ok(())
            }
            (_, Response::WriteSingleCoil { .. } | Response::WriteSingleRegister { .. })
                if self.echoes(step, response) =>
            {
                if step == Step::WdtEnable {
                    self.recover = false;
                }
                Ok(())
            }
            (Step::WdtVerify, Response::ReadHoldingRegisters(regs)) => {
                let expected = u32::from(self.settings.watchdog.unwrap_or(0));
                match regs.as_slice() {
                    [v] if u32::from(*v) == expected => Ok(()),
                    [v] => Err(DecodeError::Mismatch {
                        register: "40489 WDT timeout value",
                        expected,
                        found: u32::from(*v),
                    }),
                    _ => Err(unexpected),
                }
            }
            (Step::WdtVerifyEnable, Response::ReadCoils(bits)) => {
                let on = single(bits)?;
                on.then_some(()).ok_or(DecodeError::Mismatch {
                    register: "00261 WDT enable",
                    expected: 1,
                    found: 0,
                })
            }
            (Step::Inputs, Response::ReadDiscreteInputs(bits)) => {
                let w = word(bits)?;
                self.set_word(Point::Input, w);
                Ok(())
            }
            (Step::LatchHigh, Response::ReadCoils(bits)) => {
                let w = word(bits)?;
                self.set_word(Point::LatchHigh, w);
                Ok(())
            }
            (Step::LatchLow, Response::ReadCoils(bits)) => {
                let w = word(bits)?;
                self.set_word(Point::LatchLow, w);
                Ok(())
            }
            (Step::Counters, Response::ReadInputRegisters(regs)) => {
                let (first, last) = self.counter_span().ok_or(unexpected)?;
                if regs.len() != usize::from(last - first + 1) {
                    return Err(unexpected);
                }
                for (ch, v) in (usize::from(first)..).zip(regs) {
                    if self.settings.counters & (1 << ch) != 0 {
                        self.set(Point::Counter(ch), Value::I32(i32::from(*v)));
                    }
                }
                Ok(())
            }
            _ => Err(unexpected),
        }
    }
}

impl Driver for Ex9053Driver {
    fn address(&self) -> u8 {
        self.address
    }

    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        let s = self.settings;
        self.push(Step::Name, out);
        if self.dcon() {
            self.push(Step::Config, out);
            self.push(Step::ResetStatus, out);
        } else if s.count_edge.is_some() {
            self.push(Step::EdgeWrite, out);
            self.push(Step::EdgeVerify, out);
        }
        if s.watchdog.is_some() {
            for step in [
                Step::WdtPastStatus,
                Step::WdtClear,
                Step::WdtArm,
                Step::WdtValue,
                Step::WdtEnable,
                Step::WdtVerify,
                Step::WdtVerifyEnable,
            ] {
                self.push(step, out);
            }
        }
        if s.latch != super::settings::LatchMode::Off {
            self.push(Step::ClearLatches, out);
        }
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        let s = self.settings;
        if self.recover && s.watchdog.is_some() {
            for step in [
                Step::WdtClear,
                Step::WdtArm,
                Step::WdtValue,
                Step::WdtEnable,
            ] {
                self.push(step, out);
            }
        }
        if s.sync.sends_broadcast() {
            self.push(Step::SyncSample, out);
        }
        if s.watchdog.is_some() {
            self.push(Step::HostOk, out);
        }
        self.push(Step::Inputs, out);
        if s.latch.high() {
            self.push(Step::LatchHigh, out);
        }
        if s.latch.low() {
            self.push(Step::LatchLow, out);
        }
        if s.latch != super::settings::LatchMode::Off {
            self.push(Step::ClearLatches, out);
        }
        if self.dcon() {
            for ch in 0..CHANNELS as u8 {
                if s.counters & (1 << ch) != 0 {
                    self.push(Step::Counter(ch), out);
                }
            }
        } else {
            self.push(Step::Counters, out);
        }
        if s.watchdog.is_some() {
            self.push(Step::WdtStatus, out);
        }
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        // Inputs only: nothing to write.
        let _ = (desired, refresh, out);
    }

    fn on_restart(&mut self) {
        // The start-up reads the timeout status again, clears it and re-arms (see the docs).
        self.recover = false;
        self.restarted = true;
        if let Some(slot) = self.values.get_mut(Point::WdtTimeout.index()) {
            *slot = None;
        }
    }

    fn on_confirmed_mismatch(&mut self, _tag: u32, mismatch: DecodeError) {
        if let DecodeError::Mismatch {
            register: COUNT_EDGE_DCON,
            ..
        } = mismatch
        {
            tracing::error!(
                module = %self.name,
                "counter edge differs: set FF bit 7 with %AANNTTCCFF (7 = rising)"
            );
        }
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let step = Step::from_tag(tag).ok_or(unexpected)?;
        match reply {
            Reply::Text(text) if self.dcon() => self.on_dcon(step, tag, text),
            Reply::Modbus(response) if !self.dcon() => self.on_modbus(step, tag, response),
            _ => Err(unexpected),
        }
    }

    fn values(&self) -> &[Option<Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        REPLY_DELAY
    }
}
