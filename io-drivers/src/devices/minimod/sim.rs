//! The MiniMod simulator: the module's state on its 1 ms tick, answering on the line.
//!
//! - Frames are told apart first ([`FrameKind`]): the manual ("RS-485 serial interface") allows
//!   Modbus RTU and the text protocol on the same line. Modbus frames are served from the
//!   register map through [`RegisterBank`]; text lines are the text protocol's (a later issue:
//!   until then the simulator stays silent on them, as a module that does not understand).
//! - Modbus ("Process control and data acquisition by a PC/PLC", Modbus over Serial Line): a
//!   frame with a bad CRC gets no reply; a frame for another address is ignored; a broadcast
//!   (address 0) is executed and never answered; a request the module refuses gets an
//!   exception. FC 70 Collect gets no reply: this cut keeps no event queue, and a MiniMod with
//!   no events stays silent.
//! - Addresses: see [`super::map::Space::extent`]: holes inside the implemented range read 0
//!   and ignore writes, addresses beyond it answer `IllegalDataAddress`; a pulser value above
//!   65000 answers `IllegalDataValue`.
//! - Every reply waits the module's reply delay, RDELAYT × 10 ms (power-on 10 ms).

use std::time::Duration;

use super::map::{lookup, point_item, Item, Slot, Space, POINTS};
use super::state::{Fault, MiniModState, WriteError};
use crate::modbus::crc::check_crc;
use crate::modbus::server::{decode_request, encode_response, serve, RegisterBank};
use crate::modbus::{ExceptionCode, Request, Response};
use crate::point::{PointSpec, Value, ValueType};
use crate::sim::{SimDevice, SimError, SimReply};

/// The model name.
const MODEL: &str = "minimod";

/// Builds a simulator at a unit address (the catalog's constructor).
pub fn build(address: u8) -> Box<dyn SimDevice> {
    Box::new(MiniModSim::new(address))
}

/// How a frame seen on the line is read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameKind {
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
    pub fn of(frame: &[u8]) -> Self {
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
}

impl MiniModSim {
    /// A module just powered on, answering at `address` (see [`MiniModState::new`] for the
    /// selector position it gets).
    pub fn new(address: u8) -> Self {
        Self {
            state: MiniModState::new(address),
        }
    }

    /// The module's state.
    pub fn state(&self) -> &MiniModState {
        &self.state
    }

    /// The module's state, to change it directly (tests, plant models).
    pub fn state_mut(&mut self) -> &mut MiniModState {
        &mut self.state
    }

    /// The reply delay now: RDELAYT hundredths of a second ("Setting the reply delay").
    pub fn reply_delay(&self) -> Duration {
        Duration::from_millis(10 * u64::from(self.state.rdelayt()))
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
                return (unit == me).then(|| self.reply(unit, &resp));
            }
        };
        if unit != 0 && unit != me {
            return None;
        }
        if matches!(req, Request::Collect { .. }) {
            // No event queue yet: a module with no events does not answer a Collect.
            return None;
        }
        let resp = serve(&mut self.state, &req);
        (unit != 0).then(|| self.reply(unit, &resp))
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

    fn status(&self) -> String {
        let s = &self.state;
        let bits = |w: u8, n: usize| (0..n).map(move |i| if w & (1 << i) != 0 { '1' } else { '0' });
        let terminals: u8 = (0..3).fold(0, |acc, i| acc | (u8::from(s.terminal(i)) << i));
        let fb = u8::from(s.feedback(0)) | (u8::from(s.feedback(1)) << 1);
        format!(
            "t={} ms address={} terminals X1..X3={} cooked X1..X3={} Y1..Y4={} YWORD={:#06x} \
             FB1,FB2={}",
            s.time_ms(),
            s.address(),
            bits(terminals, 3).collect::<String>(),
            bits(s.inputs(), 3).collect::<String>(),
            bits(s.outputs(), 4).collect::<String>(),
            s.read(Item::Yword),
            bits(fb, 2).collect::<String>(),
        )
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
    }
}

/// Reads through the map: holes read 0, beyond the extent is `IllegalDataAddress`.
fn read(state: &MiniModState, space: Space, addr: u16) -> Result<u16, ExceptionCode> {
    match lookup(space, addr) {
        Slot::Mapped(item) => Ok(state.read(item)),
        Slot::Hole => Ok(0),
        Slot::Outside => Err(ExceptionCode::IllegalDataAddress),
    }
}

/// Writes through the map: holes ignore writes, beyond the extent is `IllegalDataAddress`.
fn write(
    state: &mut MiniModState,
    space: Space,
    addr: u16,
    value: u16,
) -> Result<(), ExceptionCode> {
    match lookup(space, addr) {
        Slot::Mapped(item) => state.write(item, value).map_err(exception),
        Slot::Hole => Ok(()),
        Slot::Outside => Err(ExceptionCode::IllegalDataAddress),
    }
}

/// The Modbus view of the state, by 0-based protocol address ([`super::map`]).
impl RegisterBank for MiniModState {
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        read(self, Space::Coil, addr).map(|v| v != 0)
    }

    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        read(self, Space::DiscreteInput, addr).map(|v| v != 0)
    }

    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        read(self, Space::HoldingRegister, addr)
    }

    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        read(self, Space::InputRegister, addr)
    }

    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        write(self, Space::Coil, addr, u16::from(value))
    }

    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        write(self, Space::HoldingRegister, addr, value)
    }
}

const HELP: &str = "\
minimod commands:
  fault Yn open|overload|none   inject a load fault on output Yn (n = 1..4): an open load is
                                seen while the output is off, an overload while it is on;
                                FB1 (Y1/Y2) and FB2 (Y3/Y4) follow, mirrored as X9/X10
  power-cycle                   switch the module off and on (power-on values; terminals,
                                faults, switches and address stay)
  status                        terminals, cooked inputs, outputs, YWORD, feedbacks
points: `set X1 1` sets the level at a terminal (cooked after XLATUP/XLATDN); `set SW3 1`
flips dip switch 3; `set ROTSW n` turns the address selector (0..15; 0 counts as 16);
`get Y1` is the level at the output terminal (pulser, blinker, watchdog included); other
points read and write as through Modbus.";

impl SimDevice for MiniModSim {
    fn model(&self) -> &'static str {
        MODEL
    }

    fn address(&self) -> u8 {
        self.state.address()
    }

    fn advance_to(&mut self, t: Duration) {
        let ms = u64::try_from(t.as_millis()).unwrap_or(u64::MAX);
        self.state.advance_to_ms(ms);
    }

    fn on_frame(&mut self, frame: &[u8], t: Duration) -> Option<SimReply> {
        self.advance_to(t);
        match FrameKind::of(frame) {
            FrameKind::Modbus => self.on_modbus(frame),
            // The text protocol ("Text commands protocol") comes in a later issue.
            FrameKind::Text | FrameKind::Noise => None,
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
                Ok("power cycled".to_string())
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modbus::crc::append_crc;
    use crate::modbus::master::encode_request;

    const UNIT: u8 = 5;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
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
        sim.on_frame(&request(UNIT, req), t).map(|r| r.bytes)
    }

    #[test]
    fn reads_inputs_byte_exact_after_the_rising_latency() {
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X1", Value::Bool(true)).unwrap();
        let req = frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]);
        let before = sim.on_frame(&req, ms(19)).unwrap();
        assert_eq!(before.bytes, frame(&[0x05, 0x02, 0x02, 0x00, 0x00]));
        let reply = sim.on_frame(&req, ms(20)).unwrap();
        assert_eq!(reply.bytes, frame(&[0x05, 0x02, 0x02, 0x01, 0x00]));
        assert_eq!(reply.delay, ms(10), "RDELAYT power-on: 1/100 s");
    }

    #[test]
    fn x9_x10_and_input_register_0() {
        let mut sim = MiniModSim::new(UNIT);
        sim.command(&["fault", "Y3", "open"]).unwrap();
        sim.set("X2", Value::Bool(true)).unwrap();
        sim.advance_to(ms(20));
        let reply = sim
            .on_frame(&frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]), ms(20))
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
        let reply = sim.on_frame(&req, ms(0)).unwrap();
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
            sim.on_frame(&req, ms(0)).map(|r| r.bytes),
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
        assert!(sim.on_frame(&req, ms(100)).is_some());
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        let left = ask(
            &mut sim,
            &Request::ReadHoldingRegisters { addr: 83, count: 1 },
            ms(130),
        );
        assert_eq!(left, Some(frame(&[0x05, 0x03, 0x02, 0x00, 20])));
        sim.advance_to(ms(149));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
        sim.advance_to(ms(150));
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
        assert!(sim.on_frame(&on, ms(0)).is_some());
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.advance_to(ms(19));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(false)));
        sim.advance_to(ms(20));
        assert_eq!(sim.get("Y1"), Ok(Value::Bool(true)));
    }

    #[test]
    fn unimplemented_inputs_read_zero_and_unmapped_ranges_are_refused() {
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X3", Value::Bool(true)).unwrap();
        sim.advance_to(ms(20));
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
        assert_eq!(sim.on_frame(&req, ms(0)), None);
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0x0F)));
        let read = frame(&[0x00, 0x03, 0x00, 0x00, 0x00, 0x01]);
        assert_eq!(sim.on_frame(&read, ms(1)), None);
    }

    #[test]
    fn bad_crc_gets_no_reply_and_changes_nothing() {
        let mut sim = MiniModSim::new(UNIT);
        let mut req = frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x0F]);
        if let Some(last) = req.last_mut() {
            *last ^= 0x01;
        }
        assert_eq!(sim.on_frame(&req, ms(0)), None);
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0)));
        assert_eq!(sim.on_frame(&[0x05], ms(1)), None);
        assert_eq!(sim.on_frame(&[], ms(1)), None);
    }

    #[test]
    fn other_units_are_ignored_and_unknown_functions_refused() {
        let mut sim = MiniModSim::new(UNIT);
        assert_eq!(
            sim.on_frame(&frame(&[0x06, 0x03, 0x00, 0x00, 0x00, 0x01]), ms(0)),
            None
        );
        let reply = sim.on_frame(&frame(&[0x05, 0x2B, 0x0E, 0x01, 0x00]), ms(0));
        assert_eq!(reply.map(|r| r.bytes), Some(frame(&[0x05, 0xAB, 0x01])));
    }

    #[test]
    fn collect_without_events_is_silent() {
        let mut sim = MiniModSim::new(UNIT);
        let collect = frame(&[0x00, 70, 1, 16, 0, 0]);
        assert_eq!(sim.on_frame(&collect, ms(0)), None);
        let direct = frame(&[0x05, 70, 1, 16, 0, 0]);
        assert_eq!(sim.on_frame(&direct, ms(0)), None);
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
        assert_eq!(sim.on_frame(b"?X1\r", ms(0)), None);
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
        assert!(sim.command(&["status"]).unwrap().contains("address=5"));
        assert!(sim.command_help().contains("fault Yn"));
    }

    #[test]
    fn a_long_idle_advance_is_fast() {
        let mut sim = MiniModSim::new(UNIT);
        let start = std::time::Instant::now();
        sim.advance_to(Duration::from_secs(365 * 24 * 3600));
        assert!(start.elapsed() < Duration::from_millis(50));
    }
}
