//! Running the start-up steps: each write, its read-back, and what a read-back that differs
//! says (the steps themselves: [`super::settings`]).

use super::super::map::{self, POINTS};
use super::super::text::{self, TextReply};
use super::settings::SetupStep;
use super::{MiniModDriver, Tag};
use crate::driver::{DecodeError, Transaction};
use crate::modbus::{ExceptionCode, Request, Response, UnitId};
use crate::point::Value;

/// Compares a start-up read-back with what was written, register by register (or coil by
/// coil): `None` when the reply has another length, else the first mismatch as an error.
/// `skip` names the items whose value moves on its own and is not compared.
fn read_back<T: Copy + PartialEq + Into<u32>>(
    written: &[T],
    found: &[T],
    names: &[&'static str],
    skip: impl Fn(&str) -> bool,
) -> Option<Result<(), DecodeError>> {
    if found.len() != written.len() {
        return None;
    }
    let mismatch = written
        .iter()
        .zip(found)
        .zip(names)
        .filter(|(_, name)| !skip(name))
        .find(|((want, got), _)| want != got);
    Some(match mismatch {
        Some(((&expected, &found), &register)) => Err(DecodeError::Mismatch {
            register,
            expected: expected.into(),
            found: found.into(),
        }),
        None => Ok(()),
    })
}

impl MiniModDriver {
    /// The whole start-up: the watchdog's status first, then every step.
    pub(super) fn plan_startup_steps(&self, unit: UnitId, out: &mut Vec<Transaction>) {
        // Why the watchdog fired, before the settings reset it (see `restart`).
        self.plan_watchdog_status(unit, out);
        for (i, step) in self.setup.iter().enumerate() {
            let Ok(i) = u16::try_from(i) else { break };
            self.plan_startup_step(unit, i, step, out);
        }
    }

    /// Values of start-up registers once verified.
    fn record_setup(&mut self, step: usize) {
        let Some(step) = self.setup.get(step).cloned() else {
            return;
        };
        match step {
            SetupStep::Registers { values, names, .. } => {
                for (v, n) in values.into_iter().zip(names) {
                    self.set_named(n, Value::U16(v));
                }
            }
            SetupStep::Coils { values, names, .. } => {
                for (v, n) in values.into_iter().zip(names) {
                    self.set_named(n, Value::Bool(v));
                }
            }
            SetupStep::Text { name, number, .. } => {
                if let Some(i) = map::point_index(name) {
                    let value = match POINTS[i].ty {
                        crate::point::ValueType::Bool => Value::Bool(number != 0),
                        _ => Value::U16(number),
                    };
                    self.set_value(i, value);
                } else if name == "FBENABLE" {
                    self.set_named("WDTFB1", Value::Bool(number & 1 != 0));
                    self.set_named("WDTFB2", Value::Bool(number & 2 != 0));
                }
            }
        }
    }

    fn plan_startup_step(
        &self,
        unit: UnitId,
        i: u16,
        step: &SetupStep,
        out: &mut Vec<Transaction>,
    ) {
        match step {
            SetupStep::Registers { addr, values, .. } => {
                let request = Request::WriteMultipleRegisters {
                    addr: *addr,
                    values: values.clone(),
                };
                out.push(self.modbus(unit, request, Tag::SetupWrite(i)));
                let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
                let request = Request::ReadHoldingRegisters { addr: *addr, count };
                out.push(self.modbus(unit, request, Tag::SetupVerify(i)));
            }
            SetupStep::Coils { addr, values, .. } => {
                let request = Request::WriteMultipleCoils {
                    addr: *addr,
                    values: values.clone(),
                };
                out.push(self.modbus(unit, request, Tag::SetupWrite(i)));
                let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
                let request = Request::ReadCoils { addr: *addr, count };
                out.push(self.modbus(unit, request, Tag::SetupVerify(i)));
            }
            SetupStep::Text {
                id, value, verify, ..
            } => {
                // Steps are built only from values the text protocol can carry.
                if let Ok(line) = text::write_command(unit.get(), *id, *value) {
                    out.push(Self::text_tx(line, Tag::SetupWrite(i)));
                }
                if *verify {
                    out.push(self.read_tx(unit, *id, Tag::SetupVerify(i)));
                }
            }
        }
    }

    /// A Modbus answer to a start-up write or read-back.
    pub(super) fn on_setup_modbus(
        &mut self,
        tag: u32,
        step: Tag,
        response: &Response,
    ) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        match (step, response) {
            (Tag::SetupWrite(i), Response::WriteMultipleRegisters { addr, count }) => {
                match self.setup.get(usize::from(i)) {
                    Some(SetupStep::Registers {
                        addr: a, values, ..
                    }) if a == addr && usize::from(*count) == values.len() => Ok(()),
                    _ => Err(unexpected),
                }
            }
            (Tag::SetupWrite(i), Response::WriteMultipleCoils { addr, count }) => {
                match self.setup.get(usize::from(i)) {
                    Some(SetupStep::Coils {
                        addr: a, values, ..
                    }) if a == addr && usize::from(*count) == values.len() => Ok(()),
                    _ => Err(unexpected),
                }
            }
            (Tag::SetupVerify(i), Response::ReadHoldingRegisters(found)) => {
                let Some(SetupStep::Registers { values, names, .. }) =
                    self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                // A counter counts while it is read back: its write echo is its check.
                read_back(values, found, names, |name| name.starts_with("XCOUNT"))
                    .ok_or(unexpected)??;
                self.record_setup(usize::from(i));
                Ok(())
            }
            (Tag::SetupVerify(i), Response::ReadCoils(found)) => {
                let Some(SetupStep::Coils { values, names, .. }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                read_back(values, found, names, |_| false).ok_or(unexpected)??;
                self.record_setup(usize::from(i));
                Ok(())
            }
            _ => Err(unexpected),
        }
    }

    /// A text answer to a start-up write or read-back.
    pub(super) fn on_setup_text(
        &mut self,
        tag: u32,
        step: Tag,
        reply: TextReply,
    ) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        match (step, reply) {
            (Tag::SetupWrite(i), answer) => {
                let Some(SetupStep::Text { name, verify, .. }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                match answer {
                    TextReply::Ok => {
                        if !verify {
                            self.record_setup(usize::from(i));
                        }
                        Ok(())
                    }
                    // A refused write that is read back shows as a mismatch there, by name.
                    TextReply::Error if *verify => Ok(()),
                    TextReply::Error => {
                        tracing::error!(register = *name, "the module refused the setting");
                        Err(DecodeError::Exception(ExceptionCode::IllegalDataValue))
                    }
                    _ => Err(unexpected),
                }
            }
            (Tag::SetupVerify(i), TextReply::Value(id, found)) => {
                let Some(SetupStep::Text {
                    id: want_id,
                    name,
                    number,
                    ..
                }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                if id != *want_id {
                    return Err(unexpected);
                }
                if found != *number {
                    // A text reply has no check: the bus owner asks again before it believes
                    // this, and only then is it explained (`on_confirmed_mismatch`).
                    return Err(DecodeError::Mismatch {
                        register: name,
                        expected: u32::from(*number),
                        found: u32::from(found),
                    });
                }
                self.record_setup(usize::from(i));
                Ok(())
            }
            _ => Err(unexpected),
        }
    }
}
