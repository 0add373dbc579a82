//! The MiniMod simulator: the module's state on its 1 ms tick, answering on the line.
//!
//! - Frames are told apart first: the manual ("RS-485 serial interface") allows Modbus RTU
//!   and the text protocol on the same line. A frame with a good Modbus CRC is Modbus and is
//!   served from the register map through [`RegisterBank`]; every other byte goes to the text
//!   receiver ([`PacketReceiver`]), which collects packets up to their CR as the module does
//!   (so a terminal typing one character at a time works), and each packet is executed by
//!   [`super::sim_text`].
//! - Modbus ("Process control and data acquisition by a PC/PLC", Modbus over Serial Line): a
//!   frame with a bad CRC gets no reply; a frame for another address is ignored; a broadcast
//!   (address 0) is executed and never answered; a request the module refuses gets an
//!   exception (04 for an output write while the watchdog fires).
//! - FC 70 Collect ([`super::events`]): a Collect for this module (broadcast or its address)
//!   applies its acknowledgement; if the module is in the window and has an event, it replies
//!   `SLAVE 70 SLVSEQ TYPE DATH DATL 0` in its 3 ms slot. On this virtual line a module cannot
//!   hear another slave's reply, so the "blocked" rule of the manual (only the first slave with
//!   events replies) is up to the line: two modules with events in one window both answer, in
//!   their own slots.
//! - Addresses: see [`super::map::Space::extent`]: holes inside the implemented range read 0
//!   and ignore writes, addresses beyond it answer `IllegalDataAddress`; a pulser value above
//!   65000 answers `IllegalDataValue`.
//! - Where WDTTIME and WDTYMASK are (the manual gives them two ways, see [`super::map`]):
//!   option `watchdog-registers table` (the default: holding registers 128/144, 40129/40145)
//!   or `aliased` (holding registers 8/9 by the coil/register aliasing rule; 128 and 144 then
//!   answer `IllegalDataAddress`), set with [`MiniModSim::with_watchdog_registers`], the
//!   console's `option watchdog-registers aliased`, or `softplc sim --option
//!   minimod@5:watchdog-registers=aliased`. The text protocol (`?WDTTIME`, `>WDTMASK=`) and
//!   the coils WDTY1..4 work the same under both; a power cycle keeps it (it is the firmware).
//! - Every reply but Collect's waits the module's reply delay, RDELAYT × 10 ms (power-on
//!   10 ms) + RDELAYM × 0.1 ms; `>WCONF=1` takes 100 ms more.
//! - Every frame the module acts on (Modbus for its address or broadcast, a well-formed text
//!   packet for it) is a valid command for the watchdog.
//! - While the module's serial settings (SERLINE, dip-switch 3) differ from the master's
//!   ([`MiniModState::line`], changed with the `line` command), it hears only garbage: no
//!   action, no reply. Installed for a line's settings ([`SimDevice::set_uart`], `softplc sim
//!   --pty minimod@5:9600:8N1`), they are its SERLINE, in use and in flash.

use std::time::Duration;

use super::map::{lookup_in, point_item, Item, Slot, Space, WatchdogRegisters, POINTS};
use super::serial_config::{LineMode, SerialParams};
use super::sim_text;
use super::state::{Fault, MiniModState, WriteError};
use super::text::{PacketReceiver, TERMINATOR};
use crate::modbus::crc::check_crc;
use crate::modbus::server::{decode_request, encode_response, serve, RegisterBank};
use crate::modbus::{ExceptionCode, Request, Response};
use crate::point::{PointSpec, Value, ValueType};
use crate::sim::{SimDevice, SimError, SimReply};
use crate::time::LineInstant;

/// The model name.
const MODEL: &str = "minimod";

/// Builds a simulator at a unit address (the catalog's constructor).
pub(crate) fn build(address: u8) -> Box<dyn SimDevice> {
    Box::new(MiniModSim::new(address))
}

/// How a frame seen on the line is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum FrameKind {
    /// A Modbus RTU frame with an intact CRC.
    Modbus,
    /// A line of the text protocol: starts with `?`, `>` or `@`, printable ASCII, ends with CR
    /// (an LF after it is allowed).
    Text,
    /// Neither (a corrupted Modbus frame, noise): no reply.
    Noise,
}

impl FrameKind {
    /// Classifies a frame. The CRC decides first: a text line is taken for Modbus only if its
    /// last two bytes happen to be its CRC.
    pub(crate) fn of(frame: &[u8]) -> Self {
        if check_crc(frame) {
            return FrameKind::Modbus;
        }
        let body = frame.strip_suffix(b"\n").unwrap_or(frame);
        let text = matches!(frame.first(), Some(b'?' | b'>' | b'@'))
            && body.ends_with(b"\r")
            && body
                .iter()
                .all(|&b| b == b'\r' || (0x20..0x7F).contains(&b));
        if text {
            FrameKind::Text
        } else {
            FrameKind::Noise
        }
    }
}

/// A simulated MiniMod.
#[derive(Debug, Clone)]
pub struct MiniModSim {
    state: MiniModState,
    text: PacketReceiver,
    registers: WatchdogRegisters,
}

impl MiniModSim {
    /// A module just powered on, answering at `address` (see [`MiniModState::new`] for the
    /// selector position it gets).
    pub fn new(address: u8) -> Self {
        Self::with_watchdog_registers(address, WatchdogRegisters::Table)
    }

    /// A module just powered on whose WDTTIME and WDTYMASK are where `registers` says.
    pub fn with_watchdog_registers(address: u8, registers: WatchdogRegisters) -> Self {
        Self {
            state: MiniModState::new(address),
            text: PacketReceiver::new(),
            registers,
        }
    }

    /// Where this module keeps WDTTIME and WDTYMASK.
    pub fn watchdog_registers(&self) -> WatchdogRegisters {
        self.registers
    }

    /// The module's state.
    pub fn state(&self) -> &MiniModState {
        &self.state
    }

    /// The module's state, to change it directly (tests, plant models).
    pub fn state_mut(&mut self) -> &mut MiniModState {
        &mut self.state
    }

    /// The reply delay now: RDELAYT hundredths of a second ("Setting the reply delay") plus
    /// RDELAYM tenths of a millisecond.
    pub fn reply_delay(&self) -> Duration {
        self.state.reply_delay()
    }

    fn reply(&self, unit: u8, resp: &Response) -> SimReply {
        let mut bytes = Vec::with_capacity(16);
        encode_response(unit, resp, &mut bytes);
        SimReply {
            bytes,
            delay: self.reply_delay(),
        }
    }

    /// A Modbus frame with a good CRC.
    fn on_modbus(&mut self, frame: &[u8]) -> Option<SimReply> {
        let me = self.state.address();
        let (unit, req) = match decode_request(frame) {
            Ok(decoded) => decoded,
            Err(e) => {
                // Malformed requests to this unit get their exception; the rest, silence.
                let (unit, resp) = e.exception_reply()?;
                if unit != me {
                    return None;
                }
                self.state.on_valid_command();
                return Some(self.reply(unit, &resp));
            }
        };
        if unit != 0 && unit != me {
            return None;
        }
        self.state.on_valid_command();
        if let Request::Collect {
            first,
            last,
            slave_ack,
            slave_seq,
        } = req
        {
            let (event, delay_ms) = self.state.collect(first, last, slave_ack, slave_seq)?;
            let resp = Response::Collect {
                slave: me,
                seq: event.seq,
                kind: event.kind,
                data: event.data,
            };
            let mut bytes = Vec::with_capacity(9);
            encode_response(me, &resp, &mut bytes);
            // Its slot starts once it has taken the Collect as ended: RDELAYM later than a
            // module at 0 ("Setting the Modbus communication timeout").
            return Some(SimReply {
                bytes,
                delay: Duration::from_millis(delay_ms) + self.state.frame_timeout(),
            });
        }
        let mut bank = Bank {
            state: &mut self.state,
            registers: self.registers,
        };
        let resp = serve(&mut bank, &req);
        (unit != 0).then(|| self.reply(unit, &resp))
    }

    /// Bytes that are not a Modbus frame: the text receiver's. Every packet they complete is
    /// executed; the replies of several go out back to back.
    fn on_text(&mut self, frame: &[u8]) -> Option<SimReply> {
        let mut reply: Option<SimReply> = None;
        for &b in frame {
            let Some(packet) = self.text.push(b) else {
                continue;
            };
            let Some(answer) = sim_text::execute(&mut self.state, &packet) else {
                continue;
            };
            let r = reply.get_or_insert_with(|| SimReply {
                bytes: Vec::new(),
                delay: self.state.reply_delay() + answer.extra_delay,
            });
            r.bytes.extend_from_slice(answer.text.as_bytes());
            r.bytes.push(TERMINATOR);
        }
        reply
    }

    fn spec(point: &str) -> Result<&'static PointSpec, SimError> {
        POINTS
            .iter()
            .find(|p| p.name == point)
            .ok_or_else(|| SimError::UnknownPoint {
                model: MODEL,
                point: point.to_string(),
            })
    }

    fn options(&self) -> String {
        format!(
            "watchdog-registers {}: {}",
            self.registers.name(),
            self.registers.describe()
        )
    }

    fn status(&self) -> String {
        let s = &self.state;
        let bits = |w: u8, n: usize| (0..n).map(move |i| if w & (1 << i) != 0 { '1' } else { '0' });
        let terminals: u8 = (0..3).fold(0, |acc, i| acc | (u8::from(s.terminal(i)) << i));
        let wd = s.watchdog();
        let prefs = s.serial().active();
        let watchdog = if wd.fired() {
            let why = if wd.fired_by_comm() {
                "WDTCOMM"
            } else if wd.fired_by_feedback() {
                "WDTFB"
            } else {
                "by hand"
            };
            format!("FIRED ({why})")
        } else {
            "armed".to_string()
        };
        format!(
            "t={} ms address={} terminals X1..X3={} cooked X1..X3={} Y1..Y4={} YWORD={:#06x} \
             FB1,FB2={}\nwatchdog {watchdog}: WDTTIME={} FBENABLE={} WDTYMASK={:#06x}\n\
             events: {} queued, {} dropped, XEVMASK={:#06x} EVFB={} YEVMASK={:#06x}\n\
             serial: module {} (flash {}), master {}{}; RDELAYT={} RDELAYM={} MBADD={} \
             SW3={} SW4={} flash {}",
            s.time_ms(),
            s.address(),
            bits(terminals, 3).collect::<String>(),
            bits(s.inputs(), 3).collect::<String>(),
            bits(s.outputs(), 4).collect::<String>(),
            s.read(Item::Yword),
            bits(s.feedbacks(), 2).collect::<String>(),
            wd.time(),
            wd.fb_enable(),
            wd.mask(),
            s.events().queued().count(),
            s.events().dropped(),
            s.events().xevmask(),
            s.events().evfb(),
            s.events().yevmask(),
            prefs.serial,
            s.serial().stored().serial,
            s.line(),
            if s.listening() {
                ""
            } else {
                " (mismatch: deaf)"
            },
            prefs.rdelayt,
            prefs.rdelaym,
            prefs.mbadd,
            s.read(Item::Sw3),
            s.read(Item::Sw4),
            if s.serial().flash_broken() {
                "broken"
            } else {
                "ok"
            },
        )
    }
}

fn on_off(word: &str) -> Option<bool> {
    match word {
        "on" | "1" => Some(true),
        "off" | "0" => Some(false),
        _ => None,
    }
}

/// A value as a word for a point of type `ty`; `None` if it does not fit.
fn to_word(ty: ValueType, value: Value) -> Option<u16> {
    match (ty, value) {
        (ValueType::Bool, Value::Bool(b)) => Some(u16::from(b)),
        (ValueType::Bool, Value::U16(v @ 0..=1)) => Some(v),
        (ValueType::Bool, Value::I32(v @ 0..=1)) => u16::try_from(v).ok(),
        (ValueType::U16, Value::U16(v)) => Some(v),
        (ValueType::U16, Value::I32(v)) => u16::try_from(v).ok(),
        (ValueType::U16, Value::Bool(b)) => Some(u16::from(b)),
        _ => None,
    }
}

fn exception(e: WriteError) -> ExceptionCode {
    match e {
        WriteError::ReadOnly => ExceptionCode::IllegalDataAddress,
        WriteError::OutOfRange(_) => ExceptionCode::IllegalDataValue,
        WriteError::WatchdogFired => ExceptionCode::ServerDeviceFailure,
    }
}

/// The Modbus view of the state, by 0-based protocol address ([`super::map`]), with WDTTIME
/// and WDTYMASK where the module's reading puts them.
struct Bank<'a> {
    state: &'a mut MiniModState,
    registers: WatchdogRegisters,
}

impl Bank<'_> {
    /// Reads through the map: holes read 0, beyond the extent is `IllegalDataAddress`.
    fn read(&self, space: Space, addr: u16) -> Result<u16, ExceptionCode> {
        match lookup_in(space, addr, self.registers) {
            Slot::Mapped(item) => Ok(self.state.read(item)),
            Slot::Hole => Ok(0),
            Slot::Outside => Err(ExceptionCode::IllegalDataAddress),
        }
    }

    /// Writes through the map: holes ignore writes, beyond the extent is `IllegalDataAddress`.
    fn write(&mut self, space: Space, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        match lookup_in(space, addr, self.registers) {
            Slot::Mapped(item) => self.state.write(item, value).map_err(exception),
            Slot::Hole => Ok(()),
            Slot::Outside => Err(ExceptionCode::IllegalDataAddress),
        }
    }
}

impl RegisterBank for Bank<'_> {
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(Space::Coil, addr).map(|v| v != 0)
    }

    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(Space::DiscreteInput, addr).map(|v| v != 0)
    }

    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(Space::HoldingRegister, addr)
    }

    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(Space::InputRegister, addr)
    }

    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        self.write(Space::Coil, addr, u16::from(value))
    }

    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        self.write(Space::HoldingRegister, addr, value)
    }
}

const HELP: &str = "\
minimod commands:
  fault Yn open|overload|none   inject a load fault on output Yn (n = 1..4): an open load is
                                seen while the output is off, an overload while it is on;
                                FB1 (Y1/Y2) and FB2 (Y3/Y4) follow, mirrored as X9/X10, and
                                fire the watchdog where FBENABLE says
  power-cycle                   switch the module off and on: power-on values, preferences
                                from flash (what >WCONF=1 saved); terminals, faults, switches,
                                selector stay
  switch 3|4 on|off             flip a dip switch; 3 going on restores 19200 8E1 until the
                                next power-up
  line BAUD[E|O|N|X]            the master now talks at these settings (e.g. `line 9600N`);
                                the module hears it only while its SERLINE matches; in
                                `softplc sim` it holds for every module of the line until
                                the served port's own settings change
  flash ok|broken               break the flash: >WCONF=1 answers \"Error 1\", FLASHFAIL = 1
  events                        the Collect event queue
  options                       the simulator's choices where the manual gives two readings
  option watchdog-registers table|aliased
                                WDTTIME/WDTYMASK at holding registers 128/144 (the register
                                table, the default) or 8/9 (the coil/register aliasing rule)
  status                        terminals, inputs, outputs, feedbacks, watchdog, events, serial
points: `set X1 1` sets the level at a terminal (cooked after XLATUP/XLATDN); `set SW3 1`
flips dip switch 3; `set ROTSW n` turns the address selector (0..15; 0 counts as 16);
`set WDTFIRED 0` resets the watchdog; `get Y1` is the level at the output terminal (pulser,
blinker, watchdog included); other points read and write as through Modbus.";

impl SimDevice for MiniModSim {
    fn model(&self) -> &'static str {
        MODEL
    }

    fn address(&self) -> u8 {
        self.state.address()
    }

    fn advance_to(&mut self, t: LineInstant) {
        // The module ticks in milliseconds since the line's origin.
        let ms = u64::try_from(t.since_origin().as_millis()).unwrap_or(u64::MAX);
        self.state.advance_to_ms(ms);
    }

    /// Collect slots are taken in ascending address order, and a slave that hears an earlier
    /// slave's reply stays silent: the master goes on with a narrower window (manual, "The
    /// Modbus function Collect").
    fn yields_to_earlier_reply(&self, frame: &[u8]) -> bool {
        frame.len() == 8 && frame.get(1) == Some(&70)
    }

    /// 28 bit times and RDELAYM ("Setting the Modbus communication timeout"): a master's
    /// pause inside a request shorter than that is part of it; a longer one ends it.
    fn frame_silence(&self, settings: crate::line::settings::LineSettings) -> Option<Duration> {
        Some(self.state.frame_silence(settings.baud))
    }

    /// The master's baud (and format, when known) on a served line: the module listens only
    /// when they are its own ("Setting the communication parameters"). A format the module
    /// cannot have is never its own.
    fn master_settings(&self) -> Option<crate::line::settings::LineSettings> {
        Some(self.state.line().line_settings())
    }

    fn master_line(&mut self, baud: u32, format: Option<crate::line::settings::SerialFormat>) {
        let own = self.state.serial().active().serial;
        let (baud, mode) = match format.map(LineMode::of_format) {
            None => (baud, own.mode),
            Some(Some(mode)) => (baud, mode),
            // No SERLINE gives this format: baud 0, which none gives either, keeps it deaf.
            Some(None) => (0, own.mode),
        };
        self.state.set_line(SerialParams { baud, mode });
    }

    /// The module's own UART is its SERLINE: installed for `settings` (`softplc sim --pty
    /// minimod@5:9600:8N1`), it runs at them from then on, changed by `>SERLINE=`, kept over
    /// a power cycle once `>WCONF=1` saved them, and it hears only a master at them. Settings
    /// no SERLINE can take (another baud, 7 data bits, 8O2) are refused.
    fn set_uart(&mut self, settings: crate::line::settings::LineSettings) -> bool {
        match SerialParams::of_line_settings(settings) {
            Some(params) => {
                self.state.install_serial(params);
                true
            }
            None => false,
        }
    }

    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        self.advance_to(t);
        if !self.state.listening() {
            // Wrong baud or parity: framing errors, nothing the module can act on.
            self.text.clear();
            return None;
        }
        match FrameKind::of(frame) {
            FrameKind::Modbus => {
                self.text.clear();
                self.on_modbus(frame)
            }
            FrameKind::Text | FrameKind::Noise => self.on_text(frame),
        }
    }

    fn points(&self) -> &'static [PointSpec] {
        POINTS
    }

    fn get(&self, point: &str) -> Result<Value, SimError> {
        let spec = Self::spec(point)?;
        let item = point_item(point).ok_or_else(|| SimError::UnknownPoint {
            model: MODEL,
            point: point.to_string(),
        })?;
        let word = match item {
            Item::Output(y) => u16::from(self.state.output_level(usize::from(y))),
            other => self.state.read(other),
        };
        Ok(match spec.ty {
            ValueType::Bool => Value::Bool(word != 0),
            _ => Value::U16(word),
        })
    }

    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
        let spec = Self::spec(point)?;
        let bad = || SimError::BadValue {
            point: point.to_string(),
            value: value.to_string(),
        };
        let word = to_word(spec.ty, value).ok_or_else(bad)?;
        let item = point_item(point).ok_or_else(bad)?;
        match item {
            Item::Input(x) => self.state.set_terminal(usize::from(x), word != 0),
            Item::Sw3 => self.state.set_switch(3, word != 0),
            Item::Sw4 => self.state.set_switch(4, word != 0),
            Item::RotSw => {
                let position = u8::try_from(word)
                    .ok()
                    .filter(|p| *p < 16)
                    .ok_or_else(bad)?;
                self.state.set_rotary(position);
            }
            other => self.state.write(other, word).map_err(|_| bad())?,
        }
        Ok(())
    }

    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        match words {
            ["fault", output, kind] => {
                let y = match *output {
                    "Y1" => 0,
                    "Y2" => 1,
                    "Y3" => 2,
                    "Y4" => 3,
                    other => {
                        return Err(SimError::UnknownPoint {
                            model: MODEL,
                            point: other.into(),
                        })
                    }
                };
                let fault = match *kind {
                    "open" => Fault::OpenLoad,
                    "overload" => Fault::Overload,
                    "none" => Fault::None,
                    other => {
                        return Err(SimError::BadValue {
                            point: (*output).to_string(),
                            value: other.to_string(),
                        })
                    }
                };
                self.state.set_fault(y, fault);
                Ok(format!("{output}: fault {kind}"))
            }
            ["power-cycle"] => {
                self.state.power_cycle();
                self.text.clear();
                Ok(format!(
                    "power cycled: address {}, serial {}",
                    self.state.address(),
                    self.state.serial().active().serial
                ))
            }
            ["switch", n @ ("3" | "4"), position] => {
                let on = on_off(position).ok_or_else(|| SimError::BadValue {
                    point: format!("SW{n}"),
                    value: (*position).to_string(),
                })?;
                let n: u8 = if *n == "3" { 3 } else { 4 };
                self.state.set_switch(n, on);
                Ok(format!(
                    "SW{n} {}; serial {}",
                    if on { "on" } else { "off" },
                    self.state.serial().active().serial
                ))
            }
            ["line", settings] => {
                let params = SerialParams::parse(settings, LineMode::Even).map_err(|e| {
                    SimError::BadValue {
                        point: "line".into(),
                        value: format!("{settings} ({e})"),
                    }
                })?;
                self.state.set_line(params);
                Ok(format!(
                    "master at {params}; module at {}{}",
                    self.state.serial().active().serial,
                    if self.state.listening() {
                        ""
                    } else {
                        " (mismatch: the module hears garbage)"
                    }
                ))
            }
            ["flash", state @ ("ok" | "broken")] => {
                self.state.set_flash_broken(*state == "broken");
                Ok(format!("flash {state}"))
            }
            ["events"] => {
                let lines: Vec<String> = self
                    .state
                    .events()
                    .queued()
                    .map(|e| {
                        let kind = if e.kind == super::events::KIND_INPUTS {
                            "inputs"
                        } else {
                            "outputs"
                        };
                        format!("SLVSEQ {} {kind} {:#06x}", e.seq, e.data)
                    })
                    .collect();
                Ok(if lines.is_empty() {
                    "no events".to_string()
                } else {
                    lines.join("\n")
                })
            }
            ["status"] => Ok(self.status()),
            ["options"] => Ok(self.options()),
            ["option", "watchdog-registers", value] => {
                self.registers =
                    WatchdogRegisters::parse(value).ok_or_else(|| SimError::BadValue {
                        point: "watchdog-registers".into(),
                        value: format!("{value} (takes table or aliased)"),
                    })?;
                Ok(self.options())
            }
            ["help"] => Ok(HELP.to_string()),
            _ => Err(SimError::UnknownCommand(words.join(" "))),
        }
    }

    fn command_help(&self) -> &'static str {
        HELP
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modbus::crc::append_crc;
    use crate::modbus::master::encode_request;

    const UNIT: u8 = 5;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// `n` ms after the line's origin.
    fn at(n: u64) -> LineInstant {
        LineInstant::after_origin(ms(n))
    }

    fn frame(bytes: &[u8]) -> Vec<u8> {
        let mut f = bytes.to_vec();
        append_crc(&mut f);
        f
    }

    fn request(unit: u8, req: &Request) -> Vec<u8> {
        let mut out = Vec::new();
        encode_request(unit, req, &mut out).unwrap();
        out
    }

    /// Sends `req` at time `t` and returns the reply bytes.
    fn ask(sim: &mut MiniModSim, req: &Request, t: Duration) -> Option<Vec<u8>> {
        sim.on_frame(&request(UNIT, req), LineInstant::after_origin(t))
            .map(|r| r.bytes)
    }

    #[test]
    fn reads_inputs_byte_exact_after_the_rising_latency() {
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X1", Value::Bool(true)).unwrap();
        let req = frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]);
        let before = sim.on_frame(&req, at(19)).unwrap();
        assert_eq!(before.bytes, frame(&[0x05, 0x02, 0x02, 0x00, 0x00]));
        let reply = sim.on_frame(&req, at(20)).unwrap();
        assert_eq!(reply.bytes, frame(&[0x05, 0x02, 0x02, 0x01, 0x00]));
        assert_eq!(reply.delay, ms(10), "RDELAYT power-on: 1/100 s");
    }

    #[test]
    fn x9_x10_and_input_register_0() {
        let mut sim = MiniModSim::new(UNIT);
        sim.command(&["fault", "Y3", "open"]).unwrap();
        sim.set("X2", Value::Bool(true)).unwrap();
        sim.advance_to(at(20));
        let reply = sim
            .on_frame(&frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]), at(20))
            .unwrap();
        assert_eq!(
            reply.bytes,
            frame(&[0x05, 0x02, 0x02, 0x02, 0x02]),
            "X2 and X10"
        );
        let ir0 = ask(
            &mut sim,
            &Request::ReadInputRegisters { addr: 0, count: 1 },
            ms(21),
        );
        assert_eq!(ir0, Some(frame(&[0x05, 0x04, 0x02, 0x02, 0x02])));
        // Feedback mirrors at discrete inputs 48/49.
        let fb = ask(
            &mut sim,
            &Request::ReadDiscreteInputs { addr: 48, count: 2 },
            ms(22),
        );
        assert_eq!(fb, Some(frame(&[0x05, 0x02, 0x01, 0x02])));
        assert_eq!(sim.get("X10"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("FB2"), Ok(Value::Bool(true)));
        sim.command(&["fault", "Y3", "none"]).unwrap();
        assert_eq!(sim.get("X10"), Ok(Value::Bool(false)));
    }

    #[test]
    fn rotary_selector_at_input_register_9() {
        let mut sim = MiniModSim::new(UNIT);
        let reply = ask(
            &mut sim,
            &Request::ReadInputRegisters { addr: 9, count: 1 },
            ms(0),
        );
        assert_eq!(reply, Some(frame(&[0x05, 0x04, 0x02, 0x00, 0x05])));
    }

    #[test]
    fn fc6_yword_write_is_echoed_and_drives_the_outputs() {
        let mut sim = MiniModSim::new(UNIT);
        let req = frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x05]);
        let reply = sim.on_frame(&req, at(0)).unwrap();
        assert_eq!(reply.bytes, req, "FC 6 echoes the request");
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(false)));
        assert_eq!(sim.get("Y3"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(5)));
    }

    #[test]
    fn fc5_coil_0_then_fc1_shows_y1() {
        let mut sim = MiniModSim::new(UNIT);
        let req = frame(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]);
        assert_eq!(
            sim.on_frame(&req, at(0)).map(|r| r.bytes),
            Some(req.clone())
        );
        let coils = ask(&mut sim, &Request::ReadCoils { addr: 0, count: 4 }, ms(1));
        assert_eq!(coils, Some(frame(&[0x05, 0x01, 0x01, 0x01])));
        let yword = ask(
            &mut sim,
            &Request::ReadHoldingRegisters { addr: 0, count: 1 },
            ms(2),
        );
        assert_eq!(yword, Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x01])));
    }

    #[test]
    fn holding_registers_power_on_values() {
        let mut sim = MiniModSim::new(UNIT);
        // XCOUNT1..3 (11..13) are 0; XLATUP1..3 (19..21) and XLATDN1..3 (35..37) are 20.
        let regs = ask(
            &mut sim,
            &Request::ReadHoldingRegisters {
                addr: 11,
                count: 27,
            },
            ms(0),
        );
        let mut expected = vec![0x05, 0x03, 54];
        for addr in 11..38u16 {
            let v: u16 = if (19..=21).contains(&addr) || (35..=37).contains(&addr) {
                20
            } else {
                0
            };
            expected.extend_from_slice(&v.to_be_bytes());
        }
        assert_eq!(regs, Some(frame(&expected)));
        let xlatup1 = ask(
            &mut sim,
            &Request::ReadHoldingRegisters { addr: 19, count: 1 },
            ms(0),
        );
        assert_eq!(xlatup1, Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x14])));
    }

    #[test]
    fn pulser_written_over_modbus_reads_back_the_remaining_count() {
        let mut sim = MiniModSim::new(UNIT);
        // YPULSE1 = 50 at holding register 83 (40084).
        let req = frame(&[0x05, 0x06, 0x00, 0x53, 0x00, 0x32]);
        assert!(sim.on_frame(&req, at(100)).is_some());
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        let left = ask(
            &mut sim,
            &Request::ReadHoldingRegisters { addr: 83, count: 1 },
            ms(130),
        );
        assert_eq!(left, Some(frame(&[0x05, 0x03, 0x02, 0x00, 20])));
        sim.advance_to(at(149));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        sim.advance_to(at(150));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        // Above the manual's range: exception 03.
        let too_long = ask(
            &mut sim,
            &Request::WriteSingleRegister {
                addr: 83,
                value: 65001,
            },
            ms(200),
        );
        assert_eq!(too_long, Some(frame(&[0x05, 0x86, 0x03])));
    }

    #[test]
    fn automatic_condition_written_over_modbus() {
        let mut sim = MiniModSim::new(UNIT);
        // Y1AON1 (40052, HR 51) = 0x0203: X1 on and X2 off.
        let on = request(
            UNIT,
            &Request::WriteSingleRegister {
                addr: 51,
                value: 0x0203,
            },
        );
        assert!(sim.on_frame(&on, at(0)).is_some());
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(at(19));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        sim.advance_to(at(20));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
    }

    #[test]
    fn unimplemented_inputs_read_zero_and_unmapped_ranges_are_refused() {
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X3", Value::Bool(true)).unwrap();
        sim.advance_to(at(20));
        let di = ask(
            &mut sim,
            &Request::ReadDiscreteInputs { addr: 0, count: 16 },
            ms(20),
        );
        assert_eq!(di, Some(frame(&[0x05, 0x02, 0x02, 0x04, 0x00])));
        let beyond = ask(
            &mut sim,
            &Request::ReadHoldingRegisters {
                addr: 140,
                count: 10,
            },
            ms(20),
        );
        assert_eq!(beyond, Some(frame(&[0x05, 0x83, 0x02])));
        let ir = ask(
            &mut sim,
            &Request::ReadInputRegisters { addr: 10, count: 1 },
            ms(20),
        );
        assert_eq!(ir, Some(frame(&[0x05, 0x84, 0x02])));
    }

    #[test]
    fn broadcast_acts_but_never_replies() {
        let mut sim = MiniModSim::new(UNIT);
        let req = frame(&[0x00, 0x06, 0x00, 0x00, 0x00, 0x0F]);
        assert_eq!(sim.on_frame(&req, at(0)), None);
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0x0F)));
        let read = frame(&[0x00, 0x03, 0x00, 0x00, 0x00, 0x01]);
        assert_eq!(sim.on_frame(&read, at(1)), None);
    }

    #[test]
    fn bad_crc_gets_no_reply_and_changes_nothing() {
        let mut sim = MiniModSim::new(UNIT);
        let mut req = frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x0F]);
        if let Some(last) = req.last_mut() {
            *last ^= 0x01;
        }
        assert_eq!(sim.on_frame(&req, at(0)), None);
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0)));
        assert_eq!(sim.on_frame(&[0x05], at(1)), None);
        assert_eq!(sim.on_frame(&[], at(1)), None);
    }

    #[test]
    fn other_units_are_ignored_and_unknown_functions_refused() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(
            sim.on_frame(&frame(&[0x06, 0x03, 0x00, 0x00, 0x00, 0x01]), at(0)),
            None
        );
        let reply = sim.on_frame(&frame(&[0x05, 0x2B, 0x0E, 0x01, 0x00]), at(0));
        assert_eq!(reply.map(|r| r.bytes), Some(frame(&[0x05, 0xAB, 0x01])));
    }

    #[test]
    fn collect_without_events_is_silent() {
        let mut sim = MiniModSim::new(UNIT);
        let collect = frame(&[0x00, 70, 1, 16, 0, 0]);
        assert_eq!(sim.on_frame(&collect, at(0)), None);
        let direct = frame(&[0x05, 70, 1, 16, 0, 0]);
        assert_eq!(sim.on_frame(&direct, at(0)), None);
    }

    #[test]
    fn text_lines_are_told_apart_from_modbus() {
        assert_eq!(FrameKind::of(b"?X1\r"), FrameKind::Text);
        assert_eq!(FrameKind::of(b"@25?DEVICE\r\n"), FrameKind::Text);
        assert_eq!(
            FrameKind::of(&frame(&[0x3F, 0x03, 0x00, 0x00, 0x00, 0x01])),
            FrameKind::Modbus
        );
        assert_eq!(FrameKind::of(&[0x3F, 0x03, 0x00]), FrameKind::Noise);
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, "?X1\r", 0).as_deref(), Some("X1=0\r"));
    }

    /// Sends a text packet at `t` ms and returns the reply as text.
    fn text(sim: &mut MiniModSim, packet: &str, t: u64) -> Option<String> {
        sim.on_frame(packet.as_bytes(), at(t))
            .map(|r| String::from_utf8(r.bytes).unwrap())
    }

    #[test]
    fn manual_text_examples() {
        let mut sim = MiniModSim::new(UNIT);
        // "?X1<CR>(<LF>)" → "X1=0<CR>"; ">Y1=1" → "OK".
        assert_eq!(text(&mut sim, "?X1\r\n", 0).as_deref(), Some("X1=0\r"));
        assert_eq!(text(&mut sim, ">Y1=1\r", 1).as_deref(), Some("OK\r"));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        assert_eq!(text(&mut sim, "?Y1\r", 2).as_deref(), Some("Y1=1\r"));
        // ">YWORD=1" activates Y1 and turns off all the others.
        text(&mut sim, ">Y3=1\r", 3);
        assert_eq!(text(&mut sim, ">YWORD=1\r", 4).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, "?YWORD\r", 5).as_deref(),
            Some("YWORD=00001\r")
        );
        // "XWORD=00003" means X1 and X2 on.
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.set("X2", Value::Bool(true)).unwrap();
        assert_eq!(
            text(&mut sim, "?XWORD\r", 30).as_deref(),
            Some("XWORD=00003\r")
        );
        // "FBACKS=00003": both feedbacks on.
        sim.command(&["fault", "Y2", "open"]).unwrap();
        sim.command(&["fault", "Y4", "open"]).unwrap();
        assert_eq!(
            text(&mut sim, "?FBACKS\r", 31).as_deref(),
            Some("FBACKS=00003\r")
        );
        assert_eq!(text(&mut sim, "?X9\r", 31).as_deref(), Some("X9=1\r"));
        assert_eq!(text(&mut sim, "?X10\r", 31).as_deref(), Some("X10=1\r"));
        // "FBENABLE=3".
        assert_eq!(text(&mut sim, ">FBENABLE=3\r", 32).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, "?FBENABLE\r", 33).as_deref(),
            Some("FBENABLE=3\r")
        );
        // The feedbacks now fire the watchdog at the next millisecond.
        assert_eq!(
            text(&mut sim, "?WFLAGS\r", 35).as_deref(),
            Some("WFLAGS=006\r")
        );
        assert_eq!(text(&mut sim, ">WFLAGS=0\r", 36).as_deref(), Some("OK\r"));
        assert_eq!(text(&mut sim, ">FBENABLE=0\r", 36).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, "?WFLAGS\r", 40).as_deref(),
            Some("WFLAGS=000\r")
        );
        // ">XCOUNT1=0" presets; "?SW3".
        assert_eq!(
            text(&mut sim, "?XCOUNT1\r", 41).as_deref(),
            Some("XCOUNT1=00001\r")
        );
        assert_eq!(text(&mut sim, ">XCOUNT1=0\r", 42).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, "?XCOUNT1\r", 43).as_deref(),
            Some("XCOUNT1=00000\r")
        );
        assert_eq!(text(&mut sim, "?SW3\r", 44).as_deref(), Some("SW3=0\r"));
        assert_eq!(text(&mut sim, "?SW4\r", 44).as_deref(), Some("SW4=0\r"));
        assert_eq!(
            text(&mut sim, "?X1LATUP\r", 44).as_deref(),
            Some("X1LATUP=00020\r")
        );
        // ">WDTMASK=0": all off when it fires.
        assert_eq!(text(&mut sim, ">WDTMASK=0\r", 45).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, "?WDTMASK\r", 45).as_deref(),
            Some("WDTMASK=00000\r")
        );
        assert_eq!(
            text(&mut sim, ">WDTTIME=65535\r", 46).as_deref(),
            Some("OK\r")
        );
        assert_eq!(
            text(&mut sim, "?WDTTIME\r", 46).as_deref(),
            Some("WDTTIME=65535\r")
        );
    }

    #[test]
    fn more_manual_text_examples() {
        // "ADDRESS=034".
        let mut sim = MiniModSim::new(34);
        assert_eq!(
            text(&mut sim, "?ADDRESS\r", 0).as_deref(),
            Some("ADDRESS=034\r")
        );
        // ">Y2=1" turns on Y2, ">Y2=0" turns it off.
        assert_eq!(text(&mut sim, ">Y2=1\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(true)));
        assert_eq!(text(&mut sim, ">Y2=0\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(false)));
        // ">FBENABLE=0|1|2|3".
        for n in 0..=3u16 {
            assert_eq!(
                text(&mut sim, &format!(">FBENABLE={n}\r"), 1).as_deref(),
                Some("OK\r")
            );
            assert_eq!(sim.get("WDTFB1"), Ok(Value::Bool(n & 1 != 0)));
            assert_eq!(sim.get("WDTFB2"), Ok(Value::Bool(n & 2 != 0)));
        }
        text(&mut sim, ">FBENABLE=0\r", 1);
        // ">Y1PULSE=100": Y1 on, off after 100 ms.
        assert_eq!(
            text(&mut sim, ">Y1PULSE=100\r", 10).as_deref(),
            Some("OK\r")
        );
        sim.advance_to(at(109));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        sim.advance_to(at(110));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        // ">Y1LAMP=1": a brief flash (one step of 100 ms) every 1.6 s.
        assert_eq!(text(&mut sim, ">Y1LAMP=1\r", 1600).as_deref(), Some("OK\r"));
        let on: Vec<u64> = (1600..4800)
            .step_by(50)
            .filter(|&t| {
                sim.advance_to(at(t));
                sim.get("Y1") == Ok(Value::Bool(true))
            })
            .collect();
        assert_eq!(on, [1600, 1650, 3200, 3250]);
        // "Y1AON1=X1X2" and "Y1AON2=X1-X3": on when X1 is high and (X2 high or X3 low).
        let mut sim = MiniModSim::new(UNIT);
        for x in 1..=3 {
            text(&mut sim, &format!(">X{x}LATUP=0\r"), 0);
            text(&mut sim, &format!(">X{x}LATDN=0\r"), 0);
        }
        text(&mut sim, ">Y1AON1=X1X2\r", 0);
        text(&mut sim, ">Y1AON2=X1-X3\r", 0);
        text(&mut sim, ">Y1AOFF1=-X1\r", 0);
        let mut t = 1;
        for inputs in 0u8..8 {
            for x in 0..3 {
                let point = ["X1", "X2", "X3"][x];
                sim.set(point, Value::Bool(inputs & (1 << x) != 0)).unwrap();
            }
            t += 1;
            sim.advance_to(at(t));
            let (x1, x2, x3) = (inputs & 1 != 0, inputs & 2 != 0, inputs & 4 != 0);
            let expected = x1 && (x2 || !x3);
            if expected || !x1 {
                assert_eq!(
                    sim.get("Y1"),
                    Ok(Value::Bool(expected)),
                    "inputs {inputs:03b}"
                );
            }
        }
    }

    #[test]
    fn slave_addressing_and_device() {
        let mut sim = MiniModSim::new(25);
        assert_eq!(
            text(&mut sim, "@25?DEVICE\r", 0).as_deref(),
            Some("DEVICE=MINIMOD 1.1\r")
        );
        assert_eq!(text(&mut sim, "@24?DEVICE\r", 0), None, "another slave");
        assert_eq!(text(&mut sim, "@0?DEVICE\r", 0), None, "@0 is malformed");
        assert_eq!(
            text(&mut sim, "?ADDRESS\r", 0).as_deref(),
            Some("ADDRESS=025\r")
        );
        assert_eq!(
            text(&mut sim, "@25 ? device \r", 0).as_deref(),
            Some("DEVICE=MINIMOD 1.1\r")
        );
    }

    #[test]
    fn malformed_packets_get_no_reply_and_errors_get_error() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, "X1\r", 0), None);
        assert_eq!(text(&mut sim, "\r", 0), None);
        assert_eq!(text(&mut sim, "?X4\r", 0).as_deref(), Some("Error\r"));
        assert_eq!(text(&mut sim, ">X1=1\r", 0).as_deref(), Some("Error\r"));
        assert_eq!(text(&mut sim, ">Y1=2\r", 0).as_deref(), Some("Error\r"));
        assert_eq!(text(&mut sim, ">Y2=\r", 0).as_deref(), Some("Error\r"));
        assert_eq!(
            text(&mut sim, ">Y1PULSE=65001\r", 0).as_deref(),
            Some("Error\r")
        );
        assert_eq!(text(&mut sim, "?Y1AON1\r", 0).as_deref(), Some("Error\r"));
        assert_eq!(
            text(&mut sim, "@6?X4\r", 0),
            None,
            "an error for another slave"
        );
    }

    #[test]
    fn a_terminal_typing_one_character_at_a_time() {
        let mut sim = MiniModSim::new(UNIT);
        for (i, c) in "?x".chars().enumerate() {
            assert_eq!(text(&mut sim, &c.to_string(), i as u64), None);
        }
        assert_eq!(text(&mut sim, "1", 2), None);
        assert_eq!(text(&mut sim, "\r", 3).as_deref(), Some("X1=0\r"));
        // Two packets in one frame: both answered, back to back.
        assert_eq!(
            text(&mut sim, "?X1\r?X2\r", 4).as_deref(),
            Some("X1=0\rX2=0\r")
        );
    }

    #[test]
    fn modbus_and_text_concurrently() {
        let mut sim = MiniModSim::new(UNIT);
        text(&mut sim, "?X", 0);
        // A Modbus frame in between throws the partial text packet away.
        let req = frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x05]);
        assert_eq!(
            sim.on_frame(&req, at(1)).map(|r| r.bytes),
            Some(req.clone())
        );
        assert_eq!(text(&mut sim, "1\r", 2), None, "\"1\" alone is malformed");
        assert_eq!(
            text(&mut sim, "?YWORD\r", 3).as_deref(),
            Some("YWORD=00005\r")
        );
        assert_eq!(text(&mut sim, ">YWORD=2\r", 4).as_deref(), Some("OK\r"));
        let yword = ask(
            &mut sim,
            &Request::ReadHoldingRegisters { addr: 0, count: 1 },
            ms(5),
        );
        assert_eq!(yword, Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x02])));
    }

    #[test]
    fn automatic_conditions_by_text() {
        let mut sim = MiniModSim::new(UNIT);
        for x in 1..=3 {
            text(&mut sim, &format!(">X{x}LATUP=0\r"), 0);
            text(&mut sim, &format!(">X{x}LATDN=0\r"), 0);
        }
        // "Y1AON1=X1X2": Y1 on when X1 and X2 are both high.
        assert_eq!(text(&mut sim, ">Y1AON1=X1X2\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(sim.get("Y1AON1"), Ok(Value::U16(0x0003)));
        // "Y3AON2=X2-X3": Y3 on when X2 is on and X3 is off.
        assert_eq!(
            text(&mut sim, ">Y3AON2=X2-X3\r", 0).as_deref(),
            Some("OK\r")
        );
        assert_eq!(sim.get("Y3AON2"), Ok(Value::U16(0x0406)));
        // "Y1AOFF1=-X1": Y1 off when X1 goes down.
        assert_eq!(text(&mut sim, ">Y1AOFF1=-X1\r", 0).as_deref(), Some("OK\r"));
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(at(2));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        sim.set("X2", Value::Bool(true)).unwrap();
        sim.advance_to(at(3));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("Y3"), Ok(Value::Bool(true)));
        sim.set("X1", Value::Bool(false)).unwrap();
        sim.advance_to(at(4));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)), "OFF has precedence");
        // An empty value clears a condition.
        assert_eq!(text(&mut sim, ">Y3AON2=\r", 5).as_deref(), Some("OK\r"));
        assert_eq!(sim.get("Y3AON2"), Ok(Value::U16(0)));
    }

    #[test]
    fn y1pulse_50_by_text_is_a_50_ms_pulse() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(
            text(&mut sim, ">Y1PULSE=50\r", 100).as_deref(),
            Some("OK\r")
        );
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        assert_eq!(
            text(&mut sim, "?Y1PULSE\r", 120).as_deref(),
            Some("Y1PULSE=00030\r")
        );
        sim.advance_to(at(149));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        sim.advance_to(at(150));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
    }

    #[test]
    fn a_pulse_shows_in_the_status_over_modbus_and_turns_the_output_off() {
        let mut sim = MiniModSim::new(UNIT);
        // Y1 on (FC 5 coil 0), then YPULSE1 = 100 (FC 6 holding register 83, 40084).
        let on = frame(&[0x05, 0x05, 0x00, 0x00, 0xFF, 0x00]);
        assert_eq!(sim.on_frame(&on, at(0)).map(|r| r.bytes), Some(on.clone()));
        let pulse = frame(&[0x05, 0x06, 0x00, 0x53, 0x00, 0x64]);
        assert_eq!(sim.on_frame(&pulse, at(10)).map(|r| r.bytes), Some(pulse));
        let coils = Request::ReadCoils { addr: 0, count: 4 };
        let yword = Request::ReadHoldingRegisters { addr: 0, count: 1 };
        // During the pulse: coil 0 and YWORD read on.
        assert_eq!(
            ask(&mut sim, &coils, ms(60)),
            Some(frame(&[0x05, 0x01, 0x01, 0x01]))
        );
        assert_eq!(
            ask(&mut sim, &yword, ms(61)),
            Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x01]))
        );
        // After 100 ms: off, although it was on before the pulse.
        assert_eq!(
            ask(&mut sim, &coils, ms(110)),
            Some(frame(&[0x05, 0x01, 0x01, 0x00]))
        );
        assert_eq!(
            ask(&mut sim, &yword, ms(111)),
            Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x00]))
        );
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
    }

    #[test]
    fn y1pulse_by_text_reads_on_while_it_runs() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, ">Y3=1\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(
            text(&mut sim, ">Y1PULSE=100\r", 10).as_deref(),
            Some("OK\r")
        );
        assert_eq!(text(&mut sim, "?Y1\r", 50).as_deref(), Some("Y1=1\r"));
        assert_eq!(
            text(&mut sim, "?YWORD\r", 51).as_deref(),
            Some("YWORD=00005\r")
        );
        assert_eq!(text(&mut sim, "?Y1\r", 110).as_deref(), Some("Y1=0\r"));
        assert_eq!(
            text(&mut sim, "?YWORD\r", 111).as_deref(),
            Some("YWORD=00004\r")
        );
        // Already on before the pulse: off after it all the same.
        assert_eq!(
            text(&mut sim, ">Y3PULSE=50\r", 200).as_deref(),
            Some("OK\r")
        );
        assert_eq!(text(&mut sim, "?Y3\r", 249).as_deref(), Some("Y3=1\r"));
        assert_eq!(text(&mut sim, "?Y3\r", 250).as_deref(), Some("Y3=0\r"));
    }

    #[test]
    fn ylamp_255_blinks_with_a_1600_ms_period() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, ">Y2LAMP=255\r", 0).as_deref(), Some("OK\r"));
        let level = |sim: &mut MiniModSim, t: u64| {
            sim.advance_to(at(t));
            sim.get("Y2") == Ok(Value::Bool(true))
        };
        for period in 0..3 {
            let base = 1600 * period;
            assert!(level(&mut sim, base + 1), "on for 8 steps");
            assert!(level(&mut sim, base + 799));
            assert!(!level(&mut sim, base + 800), "off for 8 steps");
            assert!(!level(&mut sim, base + 1599));
        }
        assert_eq!(
            text(&mut sim, "?Y2LAMP\r", 5000).as_deref(),
            Some("Y2LAMP=00255\r")
        );
    }

    #[test]
    fn collect_exchange_of_the_manual() {
        // Window 1–16: slave 4 has an event and replies in its slot; then window 5–16
        // acknowledges it.
        let mut sim = MiniModSim::new(4);
        sim.set("XLATUP1", Value::U16(0)).unwrap();
        sim.set("XEVMASK", Value::U16(0b111)).unwrap();
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(at(1));
        assert_eq!(sim.get("EVENTSPRS"), Ok(Value::Bool(true)));
        let collect = frame(&[0x00, 0x46, 0x01, 0x10, 0x00, 0x00]);
        let reply = sim.on_frame(&collect, at(10)).unwrap();
        assert_eq!(
            reply.bytes,
            frame(&[0x04, 0x46, 0x01, 0x02, 0x00, 0x01, 0x00])
        );
        assert_eq!(reply.delay, ms(3 * 3 + 1), "the fourth 3 ms slot");
        // Not acknowledged: the same event again.
        let again = sim.on_frame(&collect, at(40)).unwrap();
        assert_eq!(again.bytes, reply.bytes);
        let ack = frame(&[0x00, 0x46, 0x05, 0x10, 0x04, 0x01]);
        assert_eq!(sim.on_frame(&ack, at(60)), None, "4 is outside 5–16");
        assert_eq!(sim.get("EVENTSPRS"), Ok(Value::Bool(false)));
        assert_eq!(sim.on_frame(&collect, at(80)), None, "nothing queued");
        // Directed to another slave: ignored, acknowledgement included.
        sim.set("X1", Value::Bool(false)).unwrap();
        sim.advance_to(at(120));
        let other = frame(&[0x07, 0x46, 0x01, 0x10, 0x04, 0x02]);
        assert_eq!(sim.on_frame(&other, at(121)), None);
        assert_eq!(sim.get("EVENTSPRS"), Ok(Value::Bool(true)));
        let mine = frame(&[0x04, 0x46, 0x04, 0x04, 0x00, 0x00]);
        let reply = sim.on_frame(&mine, at(122)).unwrap();
        assert_eq!(
            reply.bytes,
            frame(&[0x04, 0x46, 0x02, 0x02, 0x00, 0x00, 0x00])
        );
        assert_eq!(reply.delay, ms(1), "first slot");
    }

    #[test]
    fn watchdog_over_the_line() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, ">WDTMASK=8\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(text(&mut sim, ">YWORD=3\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(text(&mut sim, ">WDTTIME=10\r", 0).as_deref(), Some("OK\r"));
        // Polls for another slave do not feed it; polls for this one (any protocol) do.
        let poll = frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]);
        let other = frame(&[0x06, 0x02, 0x00, 0x00, 0x00, 0x0A]);
        assert!(sim.on_frame(&poll, at(90)).is_some());
        assert!(sim.on_frame(&other, at(150)).is_none());
        sim.advance_to(at(189));
        assert_eq!(sim.get("WDTFIRED"), Ok(Value::Bool(false)));
        sim.advance_to(at(190));
        assert_eq!(
            sim.get("WDTFIRED"),
            Ok(Value::Bool(true)),
            "100 ms after 90 ms"
        );
        assert_eq!(sim.get("WDTCOMM"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("Y4"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        // Outputs are locked: exception 04 on Modbus, Error in text.
        let write = frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x01]);
        let refused = sim.on_frame(&write, at(200)).map(|r| r.bytes);
        assert_eq!(refused, Some(frame(&[0x05, 0x86, 0x04])));
        assert_eq!(text(&mut sim, ">Y1=1\r", 201).as_deref(), Some("Error\r"));
        // WDTCOMM and WDTFB at discrete inputs 24/25.
        let why = ask(
            &mut sim,
            &Request::ReadDiscreteInputs { addr: 24, count: 2 },
            ms(202),
        );
        assert_eq!(why, Some(frame(&[0x05, 0x02, 0x01, 0x02])));
        // Reset through the coil WDTFIRED (00161).
        let reset = frame(&[0x05, 0x05, 0x00, 0xA0, 0x00, 0x00]);
        assert!(sim.on_frame(&reset, at(203)).is_some());
        assert_eq!(sim.get("WDTFIRED"), Ok(Value::Bool(false)));
        assert_eq!(
            sim.on_frame(&write, at(204)).map(|r| r.bytes),
            Some(write.clone())
        );
    }

    #[test]
    fn wdttime_and_wdtymask_under_both_readings_of_the_manual() {
        let read = |addr| Request::ReadHoldingRegisters { addr, count: 2 };
        // The register table (default): WDTTIME at 128 (40129), WDTYMASK at 144 (40145).
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(text(&mut sim, ">WDTTIME=50\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(text(&mut sim, ">WDTMASK=2\r", 1).as_deref(), Some("OK\r"));
        let write = Request::WriteSingleRegister {
            addr: 128,
            value: 51,
        };
        assert_eq!(ask(&mut sim, &write, ms(2)), Some(request(UNIT, &write)));
        assert_eq!(
            text(&mut sim, "?WDTTIME\r", 3).as_deref(),
            Some("WDTTIME=00051\r")
        );
        let hr144 = Request::ReadHoldingRegisters {
            addr: 144,
            count: 1,
        };
        assert_eq!(
            ask(&mut sim, &hr144, ms(4)),
            Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x02]))
        );
        // Holding registers 8/9 are holes: they read 0 and keep nothing.
        assert_eq!(
            ask(&mut sim, &read(8), ms(5)),
            Some(frame(&[0x05, 0x03, 0x04, 0x00, 0x00, 0x00, 0x00]))
        );

        // The coil/register aliasing rule: the same two at 8 and 9; 128 and 144 are refused.
        let mut sim = MiniModSim::with_watchdog_registers(UNIT, WatchdogRegisters::Aliased);
        assert_eq!(text(&mut sim, ">WDTTIME=50\r", 0).as_deref(), Some("OK\r"));
        assert_eq!(text(&mut sim, ">WDTMASK=2\r", 1).as_deref(), Some("OK\r"));
        assert_eq!(
            ask(&mut sim, &read(8), ms(2)),
            Some(frame(&[0x05, 0x03, 0x04, 0x00, 0x32, 0x00, 0x02]))
        );
        let write = Request::WriteSingleRegister { addr: 8, value: 51 };
        assert_eq!(ask(&mut sim, &write, ms(3)), Some(request(UNIT, &write)));
        assert_eq!(
            text(&mut sim, "?WDTTIME\r", 4).as_deref(),
            Some("WDTTIME=00051\r")
        );
        assert_eq!(
            ask(&mut sim, &hr144, ms(5)),
            Some(frame(&[0x05, 0x83, 0x02])),
            "IllegalDataAddress"
        );
        let old = Request::WriteMultipleRegisters {
            addr: 128,
            values: vec![0],
        };
        assert_eq!(ask(&mut sim, &old, ms(6)), Some(frame(&[0x05, 0x90, 0x02])));
        assert_eq!(sim.get("WDTTIME"), Ok(Value::U16(51)), "unchanged");
        // The coils WDTY1..4 are WDTYMASK's bits under both.
        let coils = Request::ReadCoils {
            addr: 144,
            count: 4,
        };
        assert_eq!(
            ask(&mut sim, &coils, ms(7)),
            Some(frame(&[0x05, 0x01, 0x01, 0x02]))
        );
        // YPULSE4 (40087) is still the last holding register.
        let pulse = Request::ReadHoldingRegisters { addr: 86, count: 1 };
        assert_eq!(
            ask(&mut sim, &pulse, ms(8)),
            Some(frame(&[0x05, 0x03, 0x02, 0x00, 0x00]))
        );
    }

    #[test]
    fn the_watchdog_registers_option_on_the_console() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(
            sim.command(&["options"]).unwrap(),
            "watchdog-registers table: the register table: WDTTIME holding register 128 \
             (40129), WDTYMASK 144 (40145)"
        );
        assert!(sim
            .command(&["option", "watchdog-registers", "aliased"])
            .unwrap()
            .starts_with("watchdog-registers aliased: the coil/register aliasing rule"));
        assert_eq!(sim.watchdog_registers(), WatchdogRegisters::Aliased);
        sim.command(&["power-cycle"]).unwrap();
        assert_eq!(
            sim.watchdog_registers(),
            WatchdogRegisters::Aliased,
            "the firmware's, kept across a power cycle"
        );
        assert!(matches!(
            sim.command(&["option", "watchdog-registers", "both"]),
            Err(SimError::BadValue { .. })
        ));
        assert!(matches!(
            sim.command(&["option", "colour", "red"]),
            Err(SimError::UnknownCommand(_))
        ));
        assert!(sim
            .command_help()
            .contains("option watchdog-registers table|aliased"));
    }

    #[test]
    fn serial_configuration() {
        let mut sim = MiniModSim::new(UNIT);
        // The OK goes out with the old settings, then the module is at 9600 8N2.
        assert_eq!(
            text(&mut sim, ">SERLINE=9600N\r", 0).as_deref(),
            Some("OK\r")
        );
        assert_eq!(
            text(&mut sim, "?X1\r", 1),
            None,
            "the master still talks 19200E"
        );
        sim.command(&["line", "9600N"]).unwrap();
        assert_eq!(text(&mut sim, "?X1\r", 2).as_deref(), Some("X1=0\r"));
        // No letter: parity and stop bits stay.
        assert_eq!(
            text(&mut sim, ">SERLINE=57600\r", 3).as_deref(),
            Some("OK\r")
        );
        assert_eq!(sim.state().serial().active().serial.to_string(), "57600N");
        assert_eq!(text(&mut sim, ">SERLINE=1200E\r", 4), None, "deaf at 9600");
        // Dip-switch 3 to on: 19200 8E1 until the next power-up.
        sim.command(&["line", "19200E"]).unwrap();
        sim.command(&["switch", "3", "on"]).unwrap();
        assert_eq!(
            text(&mut sim, ">SERLINE=1200E\r", 5).as_deref(),
            Some("Error\r")
        );
        // Never saved: the power cycle brings the flash's 19200E back.
        sim.command(&["power-cycle"]).unwrap();
        assert_eq!(text(&mut sim, "?SW3\r", 6).as_deref(), Some("SW3=1\r"));
        // Saved with WCONF: slow OK, and kept across a power cycle.
        assert_eq!(text(&mut sim, ">RDELAYT=3\r", 7).as_deref(), Some("OK\r"));
        let wconf = sim.on_frame(b">WCONF=1\r", at(8)).unwrap();
        assert_eq!(wconf.bytes, b"OK\r");
        assert_eq!(wconf.delay, ms(30 + 100));
        sim.command(&["power-cycle"]).unwrap();
        let reply = sim.on_frame(b"?X1\r", at(9)).unwrap();
        assert_eq!(reply.delay, ms(30), "RDELAYT 3 survived");
        assert_eq!(text(&mut sim, ">RDELAYM=25\r", 10).as_deref(), Some("OK\r"));
        assert_eq!(
            sim.on_frame(b"?X1\r", at(11)).unwrap().delay,
            Duration::from_micros(32_500)
        );
        sim.command(&["flash", "broken"]).unwrap();
        assert_eq!(
            text(&mut sim, ">WCONF=1\r", 12).as_deref(),
            Some("Error 1\r")
        );
        assert_eq!(sim.get("FLASHFAIL"), Ok(Value::Bool(true)));
        assert_eq!(text(&mut sim, ">WCONF=0\r", 13).as_deref(), Some("Error\r"));
    }

    #[test]
    fn address_through_mbadd() {
        let mut sim = MiniModSim::new(UNIT);
        sim.set("ROTSW", Value::U16(0)).unwrap();
        assert_eq!(sim.address(), 16);
        assert_eq!(
            text(&mut sim, "@16>ADDRESS=180\r", 0).as_deref(),
            Some("OK\r")
        );
        assert_eq!(sim.address(), 180);
        assert_eq!(
            text(&mut sim, "@180?ADDRESS\r", 1).as_deref(),
            Some("ADDRESS=180\r")
        );
        assert_eq!(text(&mut sim, "@16?ADDRESS\r", 1), None);
        let poll = frame(&[180, 0x04, 0x00, 0x09, 0x00, 0x01]);
        assert_eq!(
            sim.on_frame(&poll, at(2)).map(|r| r.bytes),
            Some(frame(&[180, 0x04, 0x02, 0x00, 0x00])),
            "ROTSW is still 0"
        );
        sim.set("ROTSW", Value::U16(1)).unwrap();
        assert_eq!(sim.address(), 165, "the selector still moves it");
        assert_eq!(
            text(&mut sim, ">ADDRESS=248\r", 3).as_deref(),
            Some("Error\r")
        );
    }

    #[test]
    fn get_and_set_by_point_name() {
        let mut sim = MiniModSim::new(UNIT);
        for p in POINTS {
            assert!(sim.get(p.name).is_ok(), "{}", p.name);
        }
        assert!(matches!(sim.get("X4"), Err(SimError::UnknownPoint { .. })));
        sim.set("XLATUP2", Value::U16(5)).unwrap();
        assert_eq!(sim.get("XLATUP2"), Ok(Value::U16(5)));
        sim.set("SW3", Value::Bool(true)).unwrap();
        let sw = ask(
            &mut sim,
            &Request::ReadDiscreteInputs {
                addr: 128,
                count: 2,
            },
            ms(0),
        );
        assert_eq!(sw, Some(frame(&[0x05, 0x02, 0x01, 0x01])));
        assert!(matches!(
            sim.set("X9", Value::Bool(true)),
            Err(SimError::BadValue { .. })
        ));
        assert!(matches!(
            sim.set("Y1", Value::U16(2)),
            Err(SimError::BadValue { .. })
        ));
        assert!(matches!(
            sim.set("YPULSE1", Value::I32(-1)),
            Err(SimError::BadValue { .. })
        ));
        sim.set("ROTSW", Value::U16(0)).unwrap();
        assert_eq!(sim.address(), 16);
        assert!(sim.set("ROTSW", Value::U16(16)).is_err());
    }

    #[test]
    fn commands() {
        let mut sim = MiniModSim::new(UNIT);
        assert!(sim.command(&["fault", "Y1", "overload"]).is_ok());
        assert_eq!(
            sim.get("FB1"),
            Ok(Value::Bool(false)),
            "overload seen only while on"
        );
        sim.set("Y1", Value::Bool(true)).unwrap();
        assert_eq!(sim.get("FB1"), Ok(Value::Bool(true)));
        assert!(matches!(
            sim.command(&["fault", "Y5", "open"]),
            Err(SimError::UnknownPoint { .. })
        ));
        assert!(matches!(
            sim.command(&["fault", "Y1", "melted"]),
            Err(SimError::BadValue { .. })
        ));
        assert!(matches!(
            sim.command(&["dance"]),
            Err(SimError::UnknownCommand(_))
        ));
        sim.set("XLATUP1", Value::U16(3)).unwrap();
        sim.command(&["power-cycle"]).unwrap();
        assert_eq!(sim.get("XLATUP1"), Ok(Value::U16(20)));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        let status = sim.command(&["status"]).unwrap();
        assert!(status.contains("address=5"), "{status}");
        assert!(status.contains("watchdog armed"), "{status}");
        assert!(status.contains("module 19200E"), "{status}");
        assert!(sim.command_help().contains("fault Yn"));
        assert!(sim
            .command(&["switch", "3", "on"])
            .unwrap()
            .contains("SW3 on"));
        assert_eq!(sim.get("SW3"), Ok(Value::Bool(true)));
        assert!(sim.command(&["switch", "3", "sideways"]).is_err());
        assert!(sim.command(&["line", "9600Q"]).is_err());
        assert!(sim
            .command(&["line", "9600N"])
            .unwrap()
            .contains("mismatch"));
        assert!(sim.command(&["flash", "broken"]).is_ok());
        assert_eq!(sim.command(&["events"]).unwrap(), "no events");
        sim.set("XEVMASK", Value::U16(1)).unwrap();
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(at(100));
        assert_eq!(sim.command(&["events"]).unwrap(), "SLVSEQ 1 inputs 0x0001");
    }

    /// A terminal held on across a power cycle, in a world on the virtual clock: the cooked
    /// input starts again at 0 and follows the terminal after the power-on XLATUP (20 ms,
    /// "Digital inputs, latencies and counters"), whether the world jumps from poll to poll
    /// (idle stretches skipped) or runs tick by tick (as with a plant attached).
    #[test]
    fn a_terminal_held_on_reads_on_again_after_a_power_cycle() {
        use crate::line::settings::LineSettings;
        use crate::sim::line::SimWorld;

        let fc2 = request(UNIT, &Request::ReadDiscreteInputs { addr: 0, count: 1 });
        let x1 = |level: u8| frame(&[UNIT, 0x02, 0x01, level]);
        // The master reads X1 with FC 2 at `t`; the reply it hears.
        let poll = |w: &mut SimWorld, t: Duration| {
            let t = LineInstant::after_origin(t);
            w.deliver(0, &fc2, t);
            let mut reply = Vec::new();
            w.take_arrived(0, t + ms(50), &mut reply);
            reply
        };
        let mut w = SimWorld::new(vec![LineSettings::DEFAULT]);
        let d = w.add_device(0, "mm", build(UNIT));
        w.set(d, "X1", Value::Bool(true)).unwrap();
        assert_eq!(poll(&mut w, ms(100)), x1(1));
        assert_eq!(poll(&mut w, ms(5_000)), x1(1), "after a long idle stretch");

        w.device_mut(d).unwrap().command(&["power-cycle"]).unwrap();
        assert_eq!(w.get(d, "X1"), Ok(Value::Bool(false)), "latency running");
        assert_eq!(poll(&mut w, ms(5_010)), x1(0), "10 ms after power-up");
        assert_eq!(poll(&mut w, ms(5_030)), x1(1), "30 ms after power-up");
        assert_eq!(w.get(d, "X1"), Ok(Value::Bool(true)));
        for k in 1..=50 {
            let t = ms(5_030 + 100 * k);
            assert_eq!(poll(&mut w, t), x1(1), "at {t:?}");
        }

        // Tick by tick, with no traffic.
        w.device_mut(d).unwrap().command(&["power-cycle"]).unwrap();
        let start = w.now();
        for n in 1..=30 {
            w.advance_to(start + ms(n));
            let expected = n >= 20;
            assert_eq!(w.get(d, "X1"), Ok(Value::Bool(expected)), "{n} ms after");
        }
        assert_eq!(
            w.get(d, "XCOUNT1"),
            Ok(Value::U16(1)),
            "counters restart at 0"
        );
    }

    #[test]
    fn a_long_idle_advance_is_fast() {
        let mut sim = MiniModSim::new(UNIT);
        let start = std::time::Instant::now();
        sim.advance_to(LineInstant::after_origin(Duration::from_secs(
            365 * 24 * 3600,
        )));
        assert!(start.elapsed() < Duration::from_millis(50));
    }

    /// Installed at 9600 8N1 (`softplc sim --pty minimod@5:9600:8N1`), the module's SERLINE is
    /// 9600X: a master at the factory 19200 8E1, or at 9600 with another format, gets nothing;
    /// one at 9600 8N1, or at 9600 on a pty (format unknown), reads X1; the installed setting
    /// survives a power cycle, and `>SERLINE=` moves the module away from it.
    #[test]
    fn a_module_installed_at_its_own_settings_hears_only_a_master_at_them() {
        use crate::line::settings::{LineSettings, SerialFormat};
        use crate::sim::line::SimWorld;
        let own = LineSettings {
            baud: 9600,
            format: "8N1".parse().unwrap(),
        };
        let mut world = SimWorld::new(vec![LineSettings::DEFAULT]);
        let d = world.add_device(0, "mm5", build(UNIT));
        world.set_device_settings(d, own);
        let read_x1 = request(UNIT, &Request::ReadDiscreteInputs { addr: 0, count: 1 });
        // Each frame a second after the last; what comes back within 900 ms.
        let mut at = 0;
        let mut send = |world: &mut SimWorld, frame: &[u8]| {
            at += 1000;
            world.deliver(0, frame, LineInstant::after_origin(ms(at)));
            let mut reply = Vec::new();
            world.take_arrived(0, LineInstant::after_origin(ms(at + 900)), &mut reply);
            reply
        };
        assert_eq!(send(&mut world, &read_x1), b"", "master at 19200 8E1");
        world.set_master_settings(
            0,
            LineSettings {
                baud: 9600,
                format: SerialFormat::EVEN_8E1,
            },
        );
        assert_eq!(send(&mut world, &read_x1), b"", "master at 9600 8E1");
        world.set_master_settings(0, own);
        assert_eq!(send(&mut world, &read_x1), frame(&[UNIT, 2, 1, 0]));
        world.follow_master_baud(0, 19200);
        assert_eq!(send(&mut world, &read_x1), b"", "pty at 19200");
        world.follow_master_baud(0, 9600);
        assert_eq!(
            send(&mut world, &read_x1),
            frame(&[UNIT, 2, 1, 0]),
            "pty at 9600"
        );
        let sim = world.device_mut(d).unwrap();
        sim.command(&["power-cycle"]).unwrap();
        assert_eq!(send(&mut world, &read_x1), frame(&[UNIT, 2, 1, 0]), "kept");
        world.set_master_settings(0, own);
        assert_eq!(send(&mut world, &read_x1), frame(&[UNIT, 2, 1, 0]));
        assert_eq!(send(&mut world, b">SERLINE=19200E\r"), b"OK\r");
        assert_eq!(send(&mut world, &read_x1), b"", "now at 19200E");
        world.set_master_settings(0, LineSettings::DEFAULT);
        assert_eq!(send(&mut world, &read_x1), frame(&[UNIT, 2, 1, 0]));
    }

    /// Settings no `>SERLINE=` gives are refused at install (the world then keeps them fixed).
    #[test]
    fn settings_a_minimod_cannot_have_are_refused_at_install() {
        let mut sim = MiniModSim::new(UNIT);
        for bad in ["8O2", "7E1"] {
            let settings = crate::line::settings::LineSettings {
                baud: 9600,
                format: bad.parse().unwrap(),
            };
            assert!(!sim.set_uart(settings), "{bad}");
        }
        let fast = crate::line::settings::LineSettings {
            baud: 115_200,
            format: "8N1".parse().unwrap(),
        };
        assert!(!sim.set_uart(fast));
        assert_eq!(sim.state().serial().active().serial, SerialParams::FACTORY);
    }
}
