//! The device side, used by the simulators: split a byte stream into request frames, decode
//! them, answer them from a [`RegisterBank`], encode the reply.
//!
//! A simulated device typically does:
//!
//! ```
//! use softplc_io::modbus::{
//!     decode_request, encode_response, request_frame_len, serve, FrameLen, RegisterBank,
//! };
//!
//! struct Empty;
//! impl RegisterBank for Empty {}
//!
//! let me = 1;
//! let stream = [0x01, 0x03, 0x00, 0x00, 0x00, 0x0A, 0xC5, 0xCD];
//! let mut out = Vec::new();
//! if let FrameLen::Complete(n) = request_frame_len(&stream) {
//!     match decode_request(stream.get(..n).unwrap_or_default()) {
//!         Ok((unit, req)) if unit == me => encode_response(me, &serve(&mut Empty, &req), &mut out),
//!         Ok((0, req)) => {
//!             serve(&mut Empty, &req); // broadcast: act, never reply
//!         }
//!         Ok(_) => {} // for another device
//!         Err(e) => {
//!             // CRC errors and short frames get no reply; malformed requests an exception.
//!             if let Some((unit, resp)) = e.exception_reply() {
//!                 if unit == me {
//!                     encode_response(me, &resp, &mut out);
//!                 }
//!             }
//!         }
//!     }
//! }
//! // Empty has no registers: exception 02.
//! assert_eq!(out, [0x01, 0x83, 0x02, 0xC0, 0xF1]);
//! ```
//!
//! References: Modbus Application Protocol v1.1b3 §6 (functions, and the order of checks:
//! quantity → exception 03, address range → 02, execution → 04), Modbus over Serial Line
//! v1.02 (a device stays silent on a CRC error and never answers a broadcast).

mod decode;

pub use decode::{decode_request, request_frame_len, FrameLen, RequestError};

use super::crc::append_crc;
use super::master::{
    check_pdu, pack_bits, push_u16, span, EncodeError, COIL_OFF, COIL_ON, MAX_DATA_BYTES,
};
use super::pdu::{ExceptionCode, FunctionCode, Request, Response};

/// The data a simulated device exposes, by 0-based protocol address. Every method defaults to
/// "no such address" ([`ExceptionCode::IllegalDataAddress`]); a device implements what it has.
/// A method may return any exception code (e.g. `IllegalDataValue` for a value out of range);
/// [`serve`] passes it on to the master.
pub trait RegisterBank {
    /// The coil (0x reference) at `addr`.
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        let _ = addr;
        Err(ExceptionCode::IllegalDataAddress)
    }

    /// The discrete input (1x reference) at `addr`.
    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        let _ = addr;
        Err(ExceptionCode::IllegalDataAddress)
    }

    /// The holding register (4x reference) at `addr`.
    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        let _ = addr;
        Err(ExceptionCode::IllegalDataAddress)
    }

    /// The input register (3x reference) at `addr`.
    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        let _ = addr;
        Err(ExceptionCode::IllegalDataAddress)
    }

    /// Writes the coil at `addr`.
    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        let _ = (addr, value);
        Err(ExceptionCode::IllegalDataAddress)
    }

    /// Writes the holding register at `addr`.
    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        let _ = (addr, value);
        Err(ExceptionCode::IllegalDataAddress)
    }
}

/// The `count` consecutive addresses from `addr` (stops at 65535; [`check_pdu`] has made sure
/// the range fits).
fn addrs(addr: u16, count: usize) -> impl Iterator<Item = u16> {
    (addr..=u16::MAX).take(count)
}

/// Executes `req` against `bank` and returns the response, an exception when the device says
/// no:
/// - a quantity outside the function's range (FC 3 count 0 or > 125, ...) → IllegalDataValue;
///   a range running past address 65535 → IllegalDataAddress (checked in that order, as the
///   spec's state diagrams do);
/// - an address of the range the bank refuses → the bank's code (IllegalDataAddress by default);
/// - FC 70 Collect → IllegalFunction (the MiniMod simulator handles it itself).
///
/// Writes of several values (FC 15, 16) first read every address of the range, so a range
/// with a missing address changes nothing. A bank that accepts the read but refuses a write
/// (a value out of range) stops the write there: the values before it stay written. FC 22
/// writes `(current AND and_mask) OR (or_mask AND NOT and_mask)`.
///
/// A broadcast request is executed the same way; the caller must not send the response.
pub fn serve(bank: &mut dyn RegisterBank, req: &Request) -> Response {
    match execute(bank, req) {
        Ok(resp) => resp,
        Err(code) => Response::Exception {
            function: req.function().code(),
            code,
        },
    }
}

fn execute(bank: &mut dyn RegisterBank, req: &Request) -> Result<Response, ExceptionCode> {
    if matches!(req, Request::Collect { .. }) {
        return Err(ExceptionCode::IllegalFunction);
    }
    check_pdu(req).map_err(|e| match e {
        EncodeError::AddressOverflow { .. } => ExceptionCode::IllegalDataAddress,
        _ => ExceptionCode::IllegalDataValue,
    })?;
    let (addr, count) = span(req).ok_or(ExceptionCode::IllegalFunction)?;
    Ok(match req {
        Request::ReadCoils { .. } => Response::ReadCoils(
            addrs(addr, count)
                .map(|a| bank.read_coil(a))
                .collect::<Result<_, _>>()?,
        ),
        Request::ReadDiscreteInputs { .. } => Response::ReadDiscreteInputs(
            addrs(addr, count)
                .map(|a| bank.read_discrete_input(a))
                .collect::<Result<_, _>>()?,
        ),
        Request::ReadHoldingRegisters { .. } => Response::ReadHoldingRegisters(
            addrs(addr, count)
                .map(|a| bank.read_holding_register(a))
                .collect::<Result<_, _>>()?,
        ),
        Request::ReadInputRegisters { .. } => Response::ReadInputRegisters(
            addrs(addr, count)
                .map(|a| bank.read_input_register(a))
                .collect::<Result<_, _>>()?,
        ),
        Request::WriteSingleCoil { addr, value } => {
            bank.write_coil(*addr, *value)?;
            Response::WriteSingleCoil {
                addr: *addr,
                value: *value,
            }
        }
        Request::WriteSingleRegister { addr, value } => {
            bank.write_holding_register(*addr, *value)?;
            Response::WriteSingleRegister {
                addr: *addr,
                value: *value,
            }
        }
        Request::WriteMultipleCoils { addr, values } => {
            for a in addrs(*addr, count) {
                bank.read_coil(a)?;
            }
            for (a, v) in addrs(*addr, count).zip(values) {
                bank.write_coil(a, *v)?;
            }
            Response::WriteMultipleCoils {
                addr: *addr,
                count: u16::try_from(count).map_err(|_| ExceptionCode::IllegalDataValue)?,
            }
        }
        Request::WriteMultipleRegisters { addr, values } => {
            for a in addrs(*addr, count) {
                bank.read_holding_register(a)?;
            }
            for (a, v) in addrs(*addr, count).zip(values) {
                bank.write_holding_register(a, *v)?;
            }
            Response::WriteMultipleRegisters {
                addr: *addr,
                count: u16::try_from(count).map_err(|_| ExceptionCode::IllegalDataValue)?,
            }
        }
        Request::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => {
            let current = bank.read_holding_register(*addr)?;
            bank.write_holding_register(*addr, (current & and_mask) | (or_mask & !and_mask))?;
            Response::MaskWriteRegister {
                addr: *addr,
                and_mask: *and_mask,
                or_mask: *or_mask,
            }
        }
        Request::Collect { .. } => return Err(ExceptionCode::IllegalFunction),
    })
}

/// The exception ADU a conforming device sends for the bad request `e`, with the unit it is
/// addressed to: `None` when it must stay silent (see [`RequestError::exception_reply`]). A
/// simulator sends it only when the unit is its own address.
pub(crate) fn exception_frame(e: &RequestError) -> Option<(u8, Vec<u8>)> {
    let (unit, resp) = e.exception_reply()?;
    let mut out = Vec::new();
    encode_response(unit, &resp, &mut out);
    Some((unit, out))
}

/// Appends the whole reply ADU for `resp` from `unit` to `out`: address, PDU, CRC. An
/// exception is sent as `unit, function | 0x80, code`. For a Collect reply the address byte
/// is `unit` (set `slave` to the same). A read response longer than one frame can carry (2000
/// bits, 125 registers) is cut at that size; [`serve`] never makes one.
pub fn encode_response(unit: u8, resp: &Response, out: &mut Vec<u8>) {
    let mut frame = Vec::with_capacity(MAX_DATA_BYTES + 5);
    frame.push(unit);
    match resp {
        Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits) => {
            let fc = if matches!(resp, Response::ReadCoils(_)) {
                FunctionCode::ReadCoils
            } else {
                FunctionCode::ReadDiscreteInputs
            };
            let bits = bits.get(..MAX_DATA_BYTES * 8).unwrap_or(bits);
            frame.push(fc.code());
            frame.push(u8::try_from(bits.len().div_ceil(8)).unwrap_or(u8::MAX));
            pack_bits(bits, &mut frame);
        }
        Response::ReadHoldingRegisters(regs) | Response::ReadInputRegisters(regs) => {
            let fc = if matches!(resp, Response::ReadHoldingRegisters(_)) {
                FunctionCode::ReadHoldingRegisters
            } else {
                FunctionCode::ReadInputRegisters
            };
            let regs = regs.get(..MAX_DATA_BYTES / 2).unwrap_or(regs);
            frame.push(fc.code());
            frame.push(u8::try_from(regs.len() * 2).unwrap_or(u8::MAX));
            for r in regs {
                push_u16(&mut frame, *r);
            }
        }
        Response::WriteSingleCoil { addr, value } => {
            frame.push(FunctionCode::WriteSingleCoil.code());
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, if *value { COIL_ON } else { COIL_OFF });
        }
        Response::WriteSingleRegister { addr, value } => {
            frame.push(FunctionCode::WriteSingleRegister.code());
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *value);
        }
        Response::WriteMultipleCoils { addr, count } => {
            frame.push(FunctionCode::WriteMultipleCoils.code());
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *count);
        }
        Response::WriteMultipleRegisters { addr, count } => {
            frame.push(FunctionCode::WriteMultipleRegisters.code());
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *count);
        }
        Response::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => {
            frame.push(FunctionCode::MaskWriteRegister.code());
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *and_mask);
            push_u16(&mut frame, *or_mask);
        }
        Response::Collect {
            seq, kind, data, ..
        } => {
            frame.push(FunctionCode::Collect.code());
            frame.push(*seq);
            frame.push(*kind);
            push_u16(&mut frame, *data);
            frame.push(0);
        }
        Response::Exception { function, code } => {
            frame.push(function | 0x80);
            frame.push(code.code());
        }
    }
    append_crc(&mut frame);
    out.extend_from_slice(&frame);
}

#[cfg(test)]
mod tests;
