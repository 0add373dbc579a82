//! The EX-9053D / EX-9053D-M simulator: the module's state ([`super::state`]) answering on the
//! line in the protocol it runs since its last power-on — DCON lines ([`super::sim_dcon`]) or
//! Modbus RTU frames ([`super::sim_modbus`], -M only). A module never answers the other
//! protocol, as on a real line where each module runs one.
//!
//! Every answer comes [`REPLY_DELAY`] (1 ms) after the request: the manual gives none.
//!
//! The module's UART runs at the baud it took at its last power-on (§1.4: from EEPROM, or
//! 9600 Bd in INIT*), 8N1 (a DCON line has no parity); on a served line ([`SimDevice::master_line`])
//! a master at another baud or a known other format is not heard. `%AANNTTCCFF` stores a new
//! baud or checksum only with INIT* on GND and it takes effect at the next power-on (§2.1), so
//! commissioning can be tried on a pty: `init on`, `power-cycle`, the command, `init off`,
//! `power-cycle`.
//!
//! Points: `DI0`..`DI15` are the terminals' levels (set them); the latches, counters,
//! `WDT_TIMEOUT` and `SYNC_FIRST` read the module's inside. Commands (`softplc sim`'s standard
//! input, `MODEL@ADDR COMMAND`): see [`HELP`].

use super::points::{Point, POINTS};
use super::sim_dcon;
use super::sim_modbus;
use super::state::{Ex9053State, Variant, WireProtocol};
use super::tables::{baud_of_code, code_of_baud, CHANNELS, LINE_FORMAT, REPLY_DELAY};
use crate::line::settings::{LineSettings, SerialFormat};
use crate::point::{PointSpec, Value};
use crate::sim::{SimDevice, SimError, SimReply};
use crate::time::LineInstant;

/// Builds an EX-9053D at `address` (the catalog's constructor).
pub(crate) fn build_d(address: u8) -> Box<dyn SimDevice> {
    Box::new(Ex9053Sim::new(Variant::D, address))
}

/// Builds an EX-9053D-M at `address`, running Modbus RTU (the catalog's constructor).
pub(crate) fn build_m(address: u8) -> Box<dyn SimDevice> {
    Box::new(Ex9053Sim::new(Variant::M, address))
}

/// Help for the model's own commands.
pub(crate) const HELP: &str = "\
ex9053d / ex9053d-m commands:
  init on|off            slide the INIT* switch (§1.4); read at the next power-cycle: INIT*
                         runs DCON at address 00, 9600 Bd, no checksum
  power-cycle            switch off and on: the EEPROM (address, baud, checksum, protocol,
                         name, watchdog) is kept and takes effect, RAM (counters, latches,
                         synchronized sample) restarts, reset status set
  protocol dcon|modbus   (-M) store the protocol for the next power-cycle, as $AAPN or coil
                         00257 would
  inputs HHHH            set all 16 terminals at once, hexadecimal, bit n = DIn (0F00: DI8..DI11)
  pulse DIn [high|low]   a pulse shorter than any poll: high then low (or low then high)
  status                 address, protocol, INIT*, inputs, latches, counters, watchdog
points: `set DI3 1` sets a terminal's level; DIn_LATCH_HIGH, DIn_LATCH_LOW, DIn_COUNTER,
WDT_TIMEOUT and SYNC_FIRST read the module (not settable).";

/// A simulated EX-9053D or EX-9053D-M.
#[derive(Debug, Clone)]
pub struct Ex9053Sim {
    state: Ex9053State,
    /// The master's baud and format on a served line, when known ([`SimDevice::master_line`]).
    master: crate::sim::device::MasterLine,
}

impl Ex9053Sim {
    /// A module just powered on with factory settings, answering at `address`.
    pub fn new(variant: Variant, address: u8) -> Self {
        Self {
            state: Ex9053State::new(variant, address),
            master: None,
        }
    }

    /// The baud and format the module's UART runs at now: the baud code of its last power-on,
    /// 8N1.
    pub fn uart(&self) -> LineSettings {
        LineSettings {
            baud: baud_of_code(self.state.running().baud_code).unwrap_or(9600),
            format: LINE_FORMAT,
        }
    }

    /// Whether the module's UART can read what the master sends.
    fn hears_master(&self) -> bool {
        crate::sim::device::hears(self.uart(), self.master)
    }

    /// The module's state.
    pub fn state(&self) -> &Ex9053State {
        &self.state
    }

    /// The module's state, to change it directly (tests).
    pub fn state_mut(&mut self) -> &mut Ex9053State {
        &mut self.state
    }

    fn unknown(&self, point: &str) -> SimError {
        SimError::UnknownPoint {
            model: self.state.variant().model(),
            point: point.to_string(),
        }
    }

    fn status(&self) -> String {
        let s = &self.state;
        let r = s.running();
        let e = s.eeprom();
        let protocol = |p: WireProtocol| match p {
            WireProtocol::Dcon => "dcon",
            WireProtocol::Modbus => "modbus",
        };
        let on = |b: bool| if b { "on" } else { "off" };
        let counters: Vec<String> = (0..CHANNELS)
            .filter(|ch| s.counter(*ch) != 0)
            .map(|ch| format!("DI{ch}={}", s.counter(ch)))
            .collect();
        let (wdt_on, wdt_value) = s.watchdog();
        format!(
            "t={} ms {} running: address={:02X}h ({}) protocol={} baud={} checksum={} INIT*={} \
             | stored: address={:02X}h baud={} format={:02X}h protocol={} name={:?} | INIT* \
             switch={} | inputs={:04X}h latch-high={:04X}h latch-low={:04X}h counters: {} | \
             host watchdog: enabled={} value={} x0.1s timeout={} status={:02X} | reset status={}",
            s.now().as_millis(),
            s.variant().model(),
            r.address,
            r.address,
            protocol(r.protocol),
            baud_of_code(r.baud_code).unwrap_or(0),
            on(r.checksum),
            on(r.init),
            e.address,
            baud_of_code(e.baud_code).unwrap_or(0),
            e.format,
            protocol(e.protocol),
            e.name,
            on(s.init_switch()),
            s.inputs(),
            s.latch_high(),
            s.latch_low(),
            if counters.is_empty() {
                "all 0".to_string()
            } else {
                counters.join(" ")
            },
            on(wdt_on),
            wdt_value,
            on(s.watchdog_timeout()),
            s.module_status(),
            u8::from(s.reset_status()),
        )
    }

    fn channel(&self, word: &str) -> Result<usize, SimError> {
        match Point::from_name(word) {
            Some(Point::Input(ch)) => Ok(ch),
            _ => Err(self.unknown(word)),
        }
    }
}

fn as_level(value: Value) -> Option<bool> {
    match value {
        Value::Bool(b) => Some(b),
        Value::U16(v @ 0..=1) => Some(v == 1),
        Value::I32(v @ 0..=1) => Some(v == 1),
        _ => None,
    }
}

fn parse_on_off(word: &str) -> Option<bool> {
    match word {
        "on" | "1" | "true" => Some(true),
        "off" | "0" | "false" => Some(false),
        _ => None,
    }
}

impl SimDevice for Ex9053Sim {
    fn set_protocol(&mut self, protocol: crate::devices::Protocol) -> Result<(), SimError> {
        let wire = match protocol {
            crate::devices::Protocol::Text => WireProtocol::Dcon,
            crate::devices::Protocol::Modbus => WireProtocol::Modbus,
        };
        self.state
            .set_stored_protocol(wire, false)
            .map_err(|_| SimError::UnknownCommand(format!("protocol {}", protocol.name())))?;
        // The -M reads its protocol selection at power-on (§1.4).
        self.state.power_cycle();
        Ok(())
    }

    fn model(&self) -> &'static str {
        self.state.variant().model()
    }

    fn address(&self) -> u8 {
        self.state.running().address
    }

    fn advance_to(&mut self, t: LineInstant) {
        // The module's state keeps its time as a duration since the line's origin.
        self.state.advance_to(t.since_origin());
    }

    fn set_uart(&mut self, settings: LineSettings) -> bool {
        code_of_baud(settings.baud).is_some_and(|c| self.state.install_baud_code(c))
    }

    fn master_line(&mut self, baud: u32, format: Option<SerialFormat>) {
        self.master = Some((baud, format));
    }

    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        self.advance_to(t);
        if !self.hears_master() {
            return None;
        }
        let bytes = match self.state.running().protocol {
            WireProtocol::Dcon => sim_dcon::answer(&mut self.state, frame),
            WireProtocol::Modbus => sim_modbus::answer(&mut self.state, frame),
        }?;
        Some(SimReply {
            bytes,
            delay: REPLY_DELAY,
        })
    }

    fn points(&self) -> &'static [PointSpec] {
        POINTS
    }

    fn get(&self, point: &str) -> Result<Value, SimError> {
        let s = &self.state;
        let bit = |word: u16, ch: usize| Value::Bool(word & (1 << ch) != 0);
        Ok(
            match Point::from_name(point).ok_or_else(|| self.unknown(point))? {
                Point::Input(ch) => bit(s.inputs(), ch),
                Point::LatchHigh(ch) => bit(s.latch_high(), ch),
                Point::LatchLow(ch) => bit(s.latch_low(), ch),
                Point::Counter(ch) => Value::I32(i32::try_from(s.counter(ch)).unwrap_or(i32::MAX)),
                Point::WdtTimeout => Value::Bool(s.watchdog_timeout()),
                Point::SyncFirst => Value::Bool(s.sync_first()),
            },
        )
    }

    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
        let bad = || SimError::BadValue {
            point: point.to_string(),
            value: value.to_string(),
        };
        match Point::from_name(point).ok_or_else(|| self.unknown(point))? {
            Point::Input(ch) => {
                let level = as_level(value).ok_or_else(bad)?;
                self.state.set_input(ch, level);
                Ok(())
            }
            // The module's inside: only its protocol or a command changes it.
            _ => Err(bad()),
        }
    }

    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        let bad = |point: &str, value: &str| SimError::BadValue {
            point: point.to_string(),
            value: value.to_string(),
        };
        match words {
            ["init", v] => {
                let on = parse_on_off(v).ok_or_else(|| bad("INIT*", v))?;
                self.state.set_init_switch(on);
                Ok(format!(
                    "INIT* switch {}; takes effect at the next power-cycle",
                    if on { "on" } else { "off" }
                ))
            }
            ["power-cycle"] => {
                self.state.power_cycle();
                Ok(self.status())
            }
            ["protocol", p] => {
                let protocol = match *p {
                    "dcon" | "ascii" => WireProtocol::Dcon,
                    "modbus" => WireProtocol::Modbus,
                    other => return Err(bad("protocol", other)),
                };
                self.state
                    .set_stored_protocol(protocol, false)
                    .map_err(|_| bad("protocol", p))?;
                Ok(format!(
                    "protocol {p} stored; takes effect at the next power-cycle"
                ))
            }
            ["inputs", hex] => {
                let digits = hex.trim_start_matches("0x").trim_start_matches("0X");
                let levels = u16::from_str_radix(digits, 16).map_err(|_| bad("inputs", hex))?;
                self.state.set_inputs(levels);
                Ok(format!("inputs={levels:04X}h"))
            }
            ["pulse", di] | ["pulse", di, "high"] => {
                let ch = self.channel(di)?;
                self.state.set_input(ch, true);
                self.state.set_input(ch, false);
                Ok(format!("{di}: high pulse"))
            }
            ["pulse", di, "low"] => {
                let ch = self.channel(di)?;
                self.state.set_input(ch, false);
                self.state.set_input(ch, true);
                Ok(format!("{di}: low pulse"))
            }
            ["status"] => Ok(self.status()),
            ["help"] => Ok(HELP.to_string()),
            _ => Err(SimError::UnknownCommand(words.join(" "))),
        }
    }

    fn command_help(&self) -> &'static str {
        HELP
    }
}
