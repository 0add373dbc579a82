//! The read plan of each cycle (status, counters, inputs, read-back; in event mode the inputs
//! and read-back are the refresh) and the decoding of its answers, Modbus, text and Collect
//! events.

use super::super::map;
use super::super::text::{TextId, TextReply};
use super::{MiniModDriver, Tag, IDX_FB1, IDX_FB2, IDX_X, IDX_X10, IDX_X9, IDX_Y};
use crate::devices::Protocol;
use crate::driver::{DecodeError, Transaction};
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

/// Discrete inputs of the status read: EVENTSPRS (10018) ..= SW4 (10130), one FC 2.
const DI_STATUS_FIRST: u16 = map::EVENTSPRS.addr;
const DI_STATUS_COUNT: u16 = map::SW4.addr - map::EVENTSPRS.addr + 1;

/// The counters' names, XCOUNT1..3 (holding registers 11..=13).
const XCOUNT: [&str; 3] = ["XCOUNT1", "XCOUNT2", "XCOUNT3"];

/// The bits of the input word that XWORD holds and events report (X1..X3, X9/X10 = FB1/FB2).
pub(super) const XWORD_BITS: u16 = 0x0307;

impl MiniModDriver {
    /// This cycle's reads.
    pub(super) fn plan_reads(&mut self, unit: UnitId, out: &mut Vec<Transaction>) {
        self.plan_event_watch(unit, out);
        let cycle = self.cycle;
        self.cycle = self.cycle.wrapping_add(1);
        let text = self.protocol == Protocol::Text;
        if self.status.due(cycle) {
            if text {
                out.push(self.read_tx(unit, TextId::Wflags, Tag::Status));
            } else {
                let request = Request::ReadDiscreteInputs {
                    addr: DI_STATUS_FIRST,
                    count: DI_STATUS_COUNT,
                };
                out.push(self.modbus(unit, request, Tag::Status));
                let request = Request::ReadCoils {
                    addr: map::WDTFIRED.addr,
                    count: 1,
                };
                out.push(self.modbus(unit, request, Tag::StatusFired));
            }
        }
        if self.counters.due(cycle) {
            if text {
                for c in 0..3u8 {
                    out.push(self.read_tx(unit, TextId::Xcount(c), Tag::Counter(u16::from(c))));
                }
            } else {
                let request = Request::ReadHoldingRegisters {
                    addr: map::XCOUNT1.addr,
                    count: 3,
                };
                out.push(self.modbus(unit, request, Tag::Counters));
            }
        }
        self.refresh_readback = self.readback.due(cycle);
        // Event mode: the inputs come from the line's Collect round; the full read is the
        // refresh the bus owner asks for when it is due.
        if !self.events {
            self.plan_full_read(unit, out);
        }
    }

    /// The inputs and, when due this cycle, the read-back: every cycle when polled, the
    /// refresh in event mode.
    pub(super) fn plan_full_read(&self, unit: UnitId, out: &mut Vec<Transaction>) {
        if self.protocol == Protocol::Text {
            out.push(self.read_tx(unit, TextId::Xword, Tag::Inputs));
        } else {
            let request = Request::ReadDiscreteInputs {
                addr: map::DI_X1,
                count: map::DI_READ_COUNT,
            };
            out.push(self.modbus(unit, request, Tag::Inputs));
        }
        if self.refresh_readback {
            if self.protocol == Protocol::Text {
                out.push(self.read_tx(unit, TextId::Yword, Tag::Readback));
            } else {
                let request = Request::ReadCoils {
                    addr: map::COIL_Y1,
                    count: 4,
                };
                out.push(self.modbus(unit, request, Tag::Readback));
            }
        }
    }

    /// The inputs as input register 0 / XWORD / a TYPE 2 event carry them.
    fn apply_input_word(&mut self, word: u16) {
        for (x, &i) in IDX_X.iter().enumerate() {
            self.set_value(i, Value::Bool(word & (1 << x) != 0));
        }
        let (x9, x10) = (word & (1 << 8) != 0, word & (1 << 9) != 0);
        self.set_value(IDX_X9, Value::Bool(x9));
        self.set_value(IDX_FB1, Value::Bool(x9));
        self.set_value(IDX_X10, Value::Bool(x10));
        self.set_value(IDX_FB2, Value::Bool(x10));
        self.set_named("XWORD", Value::U16(word & XWORD_BITS));
    }

    fn apply_inputs(&mut self, tag: u32, bits: &[bool]) -> Result<(), DecodeError> {
        if bits.len() != usize::from(map::DI_READ_COUNT) {
            return Err(DecodeError::Unexpected { tag });
        }
        let word = bits
            .iter()
            .enumerate()
            .fold(0u16, |acc, (i, &b)| acc | (u16::from(b) << i));
        self.watch_full_read(word);
        self.apply_input_word(word);
        Ok(())
    }

    fn apply_status(&mut self, tag: u32, bits: &[bool]) -> Result<(), DecodeError> {
        if bits.len() != usize::from(DI_STATUS_COUNT) {
            return Err(DecodeError::Unexpected { tag });
        }
        for name in [
            "EVENTSPRS",
            "GENERICFAIL",
            "FLASHFAIL",
            "WDTFB",
            "WDTCOMM",
            "SW3",
            "SW4",
        ] {
            let bit = map::entry(name)
                .and_then(|e| e.addr.checked_sub(DI_STATUS_FIRST))
                .and_then(|i| bits.get(usize::from(i)))
                .copied()
                .unwrap_or(false);
            self.set_named(name, Value::Bool(bit));
        }
        Ok(())
    }

    /// An event from the Collect round.
    pub(super) fn apply_event(&mut self, tag: u32, kind: u8, data: u16) -> Result<(), DecodeError> {
        match kind {
            super::super::events::KIND_INPUTS => {
                self.watch_event();
                self.apply_input_word(data);
            }
            super::super::events::KIND_OUTPUTS => {
                for (y, &i) in IDX_Y.iter().enumerate() {
                    self.set_value(i, Value::Bool(data & (1 << y) != 0));
                }
            }
            _ => return Err(DecodeError::Unexpected { tag }),
        }
        Ok(())
    }

    /// A Modbus answer to a read.
    pub(super) fn on_read_modbus(
        &mut self,
        tag: u32,
        read: Tag,
        response: &Response,
    ) -> Result<(), DecodeError> {
        match (read, response) {
            (Tag::Inputs, Response::ReadDiscreteInputs(bits)) => self.apply_inputs(tag, bits),
            (Tag::Readback, Response::ReadCoils(bits)) if bits.len() == 4 => {
                for (y, &on) in bits.iter().enumerate() {
                    self.set_y(y, on);
                }
                Ok(())
            }
            (Tag::Counters, Response::ReadHoldingRegisters(regs)) if regs.len() == 3 => {
                for (i, &v) in regs.iter().enumerate() {
                    self.set_named(XCOUNT[i], Value::U16(v));
                }
                Ok(())
            }
            (Tag::Status, Response::ReadDiscreteInputs(bits)) => self.apply_status(tag, bits),
            (Tag::EventMaskProbe, Response::ReadHoldingRegisters(regs)) if regs.len() == 1 => {
                self.on_event_mask(regs[0]);
                Ok(())
            }
            (Tag::StatusFired, Response::ReadCoils(bits)) if bits.len() == 1 => {
                self.set_named("WDTFIRED", Value::Bool(bits[0]));
                Ok(())
            }
            _ => Err(DecodeError::Unexpected { tag }),
        }
    }

    /// A text answer to a read.
    pub(super) fn on_read_text(
        &mut self,
        tag: u32,
        read: Tag,
        reply: TextReply,
    ) -> Result<(), DecodeError> {
        match (read, reply) {
            (Tag::Inputs, TextReply::Value(TextId::Xword, w)) => {
                self.watch_full_read(w);
                self.apply_input_word(w);
                Ok(())
            }
            (Tag::Readback, TextReply::Value(TextId::Yword, w)) => {
                self.set_yword(w);
                Ok(())
            }
            (Tag::Counter(i), TextReply::Value(TextId::Xcount(c), v)) if u16::from(c) == i => {
                self.set_named(XCOUNT[usize::from(c.min(2))], Value::U16(v));
                Ok(())
            }
            (Tag::Status, TextReply::Value(TextId::Wflags, v)) => {
                self.set_named(
                    "WDTFIRED",
                    Value::Bool(v & super::super::watchdog::WFLAGS_FIRED != 0),
                );
                Ok(())
            }
            _ => Err(DecodeError::Unexpected { tag }),
        }
    }
}
