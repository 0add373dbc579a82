//! The write phase: which outputs are written, by which request (FC 6 / FC 5 / FC 22, or text
//! `>YWORD` / `>Yn`), commands to read-write registers, and the echoes taken as the module's
//! output state.

use super::super::map::{self, Space, POINTS};
use super::super::text::{self, TextId, TextReply, WriteValue};
use super::{MiniModDriver, Tag, IDX_Y};
use crate::devices::Protocol;
use crate::driver::{DecodeError, Transaction};
use crate::modbus::{ExceptionCode, Request, Response, UnitId};
use crate::point::Value;

impl MiniModDriver {
    /// This cycle's writes towards `desired`.
    pub(super) fn plan_writes(
        &mut self,
        unit: UnitId,
        desired: &[Option<Value>],
        refresh: bool,
        out: &mut Vec<Transaction>,
    ) {
        // Read-write holding registers (pulsers YPULSEn, blinkers, conditions, ...): a `Some`
        // is a command, written once with FC 6 whatever the protocol (the manual allows Modbus
        // beside the text protocol), before the outputs. The scan sets it for one cycle (a
        // pulser started by a push-down trigger, tables cleared at stop). A blinker mask
        // (YLAMPn) is a state the scan asks for every cycle: written when it differs from the
        // last one written, and again after a restart (whose start-up clears the blinkers) or
        // a failed write, so a pushed-down lamp costs one write per change of its enable and
        // none per toggle. The periodic rewrite of the outputs leaves it, as it leaves the
        // logic tables: a module that comes back (lost, or in event mode found with its event
        // recording off) gets its start-up again, and the mask after it.
        for (i, spec) in POINTS.iter().enumerate() {
            let Some(Some(v)) = desired.get(i) else {
                continue;
            };
            let Some(e) = map::entry(spec.name).filter(|e| {
                e.space == Space::HoldingRegister && spec.access == crate::point::Access::ReadWrite
            }) else {
                continue;
            };
            let value = match *v {
                Value::U16(n) => n,
                Value::I32(n) => u16::try_from(n).unwrap_or(0),
                other => u16::from(other.as_bool()),
            };
            if let map::Item::Lamp(y) = e.item {
                let Some(last) = self.lamp.get_mut(usize::from(y)) else {
                    continue;
                };
                if !self.rewrite && *last == Some(value) {
                    continue;
                }
                *last = Some(value);
            }
            // WDTTIME and WDTYMASK by name, as at start-up (see `watchdog`).
            if let Some((line, tag)) = super::watchdog::command_by_name(unit, e.item, value) {
                out.push(Self::text_tx(line, tag));
                continue;
            }
            let request = Request::WriteSingleRegister {
                addr: e.addr,
                value,
            };
            out.push(self.modbus(unit, request, Tag::WriteRegister(e.addr)));
        }
        let all = refresh || self.rewrite;
        let (mut owned, mut write, mut word) = (0u16, 0u16, 0u16);
        for (y, &i) in IDX_Y.iter().enumerate() {
            if let Some(Some(v)) = desired.get(i) {
                let on = v.as_bool();
                owned |= 1 << y;
                word |= u16::from(on) << y;
                if all || self.y.get(y).copied().flatten() != Some(on) {
                    write |= 1 << y;
                }
            }
        }
        // Every owned output is in this plan (a YWORD write covers all four): the bus owner
        // counts it as the module's output refresh.
        self.full_write = write != 0 && (write == owned || owned == 0x0F);
        if write == 0 {
            return;
        }
        if self.protocol == Protocol::Text {
            if owned == 0x0F {
                let value = WriteValue::Number(word);
                if let Ok(line) = text::write_command(unit.get(), TextId::Yword, value) {
                    out.push(Self::text_tx(line, Tag::WriteYword(word)));
                }
                return;
            }
            for y in (0..4u8).filter(|y| write & (1 << y) != 0) {
                let on = word & (1 << y) != 0;
                let value = WriteValue::Number(u16::from(on));
                if let Ok(line) = text::write_command(unit.get(), TextId::Y(y), value) {
                    let index = (u16::from(y) << 1) | u16::from(on);
                    out.push(Self::text_tx(line, Tag::WriteY(index)));
                }
            }
            return;
        }
        let request = if owned == 0x0F {
            Request::WriteSingleRegister {
                addr: map::HR_YWORD,
                value: word,
            }
        } else if write.count_ones() == 1 {
            let y = write.trailing_zeros() as u16;
            Request::WriteSingleCoil {
                addr: map::COIL_Y1 + y,
                value: word & write != 0,
            }
        } else {
            Request::MaskWriteRegister {
                addr: map::HR_YWORD,
                and_mask: !write,
                or_mask: word & write,
            }
        };
        out.push(self.modbus(unit, request, Tag::WriteOutputs));
    }

    /// A Modbus echo of a write.
    pub(super) fn on_write_modbus(
        &mut self,
        tag: u32,
        write: Tag,
        response: &Response,
    ) -> Result<(), DecodeError> {
        match (write, response) {
            (Tag::WriteRegister(a), Response::WriteSingleRegister { addr, value })
                if *addr == a =>
            {
                if let Some(e) = map::MAP
                    .iter()
                    .find(|e| e.space == Space::HoldingRegister && e.addr == a)
                {
                    self.set_named(e.name, Value::U16(*value));
                }
                Ok(())
            }
            (Tag::WriteOutputs, Response::WriteSingleRegister { addr, value })
                if *addr == map::HR_YWORD =>
            {
                self.set_yword(*value);
                self.rewrite = false;
                Ok(())
            }
            (Tag::WriteOutputs, Response::WriteSingleCoil { addr, value })
                if (map::COIL_Y1..map::COIL_Y1 + 4).contains(addr) =>
            {
                self.set_y(usize::from(addr - map::COIL_Y1), *value);
                self.rewrite = false;
                Ok(())
            }
            (
                Tag::WriteOutputs,
                Response::MaskWriteRegister {
                    addr,
                    and_mask,
                    or_mask,
                },
            ) if *addr == map::HR_YWORD => {
                for y in 0..4 {
                    if and_mask & (1 << y) == 0 {
                        self.set_y(y, or_mask & (1 << y) != 0);
                    }
                }
                self.rewrite = false;
                Ok(())
            }
            _ => Err(DecodeError::Unexpected { tag }),
        }
    }

    /// A text answer to a write.
    pub(super) fn on_write_text(
        &mut self,
        tag: u32,
        write: Tag,
        reply: TextReply,
    ) -> Result<(), DecodeError> {
        match (write, reply) {
            (Tag::WriteY(i), TextReply::Ok) => {
                self.set_y(usize::from(i >> 1), i & 1 != 0);
                self.rewrite = false;
                Ok(())
            }
            (Tag::WriteYword(w), TextReply::Ok) => {
                self.set_yword(w);
                self.rewrite = false;
                Ok(())
            }
            (Tag::WdtTimeByName(v), TextReply::Ok) => {
                self.set_named("WDTTIME", Value::U16(v));
                Ok(())
            }
            (Tag::WdtMaskByName(v), TextReply::Ok) => {
                self.set_named("WDTYMASK", Value::U16(v));
                Ok(())
            }
            // The text protocol's "no" to an output write: what Modbus says with exception 04
            // (a fired watchdog, see `restart`).
            (t, TextReply::Error) if t.is_write() => {
                Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
            }
            _ => Err(DecodeError::Unexpected { tag }),
        }
    }
}
