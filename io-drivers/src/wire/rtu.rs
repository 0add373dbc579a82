//! Modbus RTU frames decoded with the codec the bus owner and the simulators use
//! ([`crate::modbus`]): requests by the device-side decoder (length table, CRC), replies by the
//! master's [`ReplyAssembler`] against the request they answer. Nothing here re-implements a
//! frame layout; a reply seen without its request is checked against the request its own
//! header implies (FC 1/2 and 3/4 by the byte count, writes by their echo).
//!
//! FC 70 "Collect" follows the MiniMod manual, "The Modbus function Collect": the request is
//! `DST 70 FIRST LAST SLVACK SLVSEQ`, the reply `SLAVE 70 SLVSEQ TYPE DATH DATL 0` with TYPE
//! 2 = inputs, 1 = outputs.

use std::fmt;

use crate::modbus::crc::{check_crc, split_crc};
use crate::modbus::master::{Progress, ReplyAssembler, ReplyError};
use crate::modbus::server::{decode_request, RequestError};
use crate::modbus::{ExceptionCode, FunctionCode, Request, Response};

/// Length of an exception reply: `unit, fc|0x80, code, crc lo, crc hi`.
const EXCEPTION_LEN: usize = 5;

/// One RTU frame, decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Rtu {
    /// A request with a good CRC.
    Request {
        /// The address byte (0: broadcast).
        unit: u8,
        /// What it asks.
        request: Request,
    },
    /// A reply with a good CRC (an exception included: the device said no).
    Reply {
        /// The address byte.
        unit: u8,
        /// What it says.
        response: Response,
        /// The request it answers: the one seen before it, or the one its own header implies
        /// when none was seen (a read's start address is then unknown).
        to: Request,
        /// Whether `to` was seen on the line.
        seen: bool,
    },
    /// An exception to a function softplc does not speak (its CRC is good).
    ForeignException {
        /// The address byte.
        unit: u8,
        /// The function byte without its 0x80 bit.
        function: u8,
        /// The exception code.
        code: ExceptionCode,
    },
    /// A frame whose length fits a Modbus function but whose CRC does not match.
    BadCrc {
        /// The address byte.
        unit: u8,
        /// The function byte.
        function: u8,
        /// The CRC computed over the frame.
        computed: u16,
        /// The CRC it carries.
        carried: u16,
    },
    /// A reply with a good CRC that does not answer the request before it (another unit,
    /// another function, a wrong byte count or echo).
    Mismatch {
        /// The address byte.
        unit: u8,
        /// The function byte.
        function: u8,
        /// Why it is not the answer.
        error: ReplyError,
    },
}

/// A request frame, if `frame` is one with a good CRC; a bad CRC is [`Rtu::BadCrc`].
pub(crate) fn request(frame: &[u8]) -> Option<Rtu> {
    match decode_request(frame) {
        Ok((unit, request)) => Some(Rtu::Request { unit, request }),
        Err(RequestError::Crc { expected, found }) => bad_crc(frame, expected, found),
        Err(_) => None,
    }
}

/// `frame` as the reply to `request` sent to `unit`: `None` when it is not a whole frame of
/// that reply's length (another frame, or a cut one).
pub(crate) fn reply_to(frame: &[u8], unit: u8, request: &Request) -> Option<Rtu> {
    let mut assembler = ReplyAssembler::new(unit, request);
    let header = (frame.first().copied(), frame.get(1).copied());
    match assembler.push(frame) {
        Progress::Complete { response, extra: 0 } => Some(Rtu::Reply {
            unit: header.0.unwrap_or(unit),
            response,
            to: request.clone(),
            seen: true,
        }),
        Progress::Failed(ReplyError::Crc { expected, found })
            if assembler.expected_len() == Some(frame.len()) =>
        {
            bad_crc(frame, expected, found)
        }
        Progress::Failed(error) if check_crc(frame) => match header {
            (Some(unit), Some(function)) => Some(Rtu::Mismatch {
                unit,
                function,
                error,
            }),
            _ => None,
        },
        _ => None,
    }
}

/// `frame` as a reply whose request was not seen: the request is the one its header implies.
pub(crate) fn reply_alone(frame: &[u8]) -> Option<Rtu> {
    let (&unit, &function) = match frame {
        [unit, function, ..] => (unit, function),
        _ => return None,
    };
    if function & 0x80 != 0 && FunctionCode::from_u8(function & 0x7F).is_none() {
        return foreign_exception(frame, unit, function);
    }
    let implied = implied_request(frame, unit, function)?;
    match reply_to(frame, unit, &implied)? {
        Rtu::Reply {
            unit, response, to, ..
        } => Some(Rtu::Reply {
            unit,
            response,
            to,
            seen: false,
        }),
        other => Some(other),
    }
}

/// The request whose reply has `frame`'s header: reads by their byte count (a register read
/// with an odd one is no reply), writes by their echo, Collect by the replying slave.
fn implied_request(frame: &[u8], unit: u8, function: u8) -> Option<Request> {
    let word = |at: usize| Some(u16::from_be_bytes([*frame.get(at)?, *frame.get(at + 1)?]));
    let byte_count = || frame.get(2).copied().map(u16::from);
    let code = FunctionCode::from_u8(function & 0x7F)?;
    let exception = function & 0x80 != 0;
    // An exception carries no fields: any request of its function checks it.
    let (addr, second) = if exception {
        (0, 1)
    } else {
        (word(2).unwrap_or(0), word(4).unwrap_or(0))
    };
    Some(match code {
        FunctionCode::ReadCoils | FunctionCode::ReadDiscreteInputs => {
            let count = if exception { 1 } else { byte_count()? * 8 };
            if code == FunctionCode::ReadCoils {
                Request::ReadCoils { addr: 0, count }
            } else {
                Request::ReadDiscreteInputs { addr: 0, count }
            }
        }
        FunctionCode::ReadHoldingRegisters | FunctionCode::ReadInputRegisters => {
            let bytes = if exception { 2 } else { byte_count()? };
            if bytes % 2 != 0 {
                return None;
            }
            let count = bytes / 2;
            if code == FunctionCode::ReadHoldingRegisters {
                Request::ReadHoldingRegisters { addr: 0, count }
            } else {
                Request::ReadInputRegisters { addr: 0, count }
            }
        }
        FunctionCode::WriteSingleCoil => Request::WriteSingleCoil {
            addr,
            value: second == crate::modbus::master::COIL_ON,
        },
        FunctionCode::WriteSingleRegister => Request::WriteSingleRegister {
            addr,
            value: second,
        },
        FunctionCode::WriteMultipleCoils => Request::WriteMultipleCoils {
            addr,
            values: vec![false; usize::from(second)],
        },
        FunctionCode::WriteMultipleRegisters => Request::WriteMultipleRegisters {
            addr,
            values: vec![0; usize::from(second)],
        },
        FunctionCode::MaskWriteRegister => Request::MaskWriteRegister {
            addr,
            and_mask: second,
            or_mask: word(6).unwrap_or(0),
        },
        FunctionCode::Collect => Request::Collect {
            first: unit,
            last: unit,
            slave_ack: 0,
            slave_seq: 0,
        },
    })
}

fn foreign_exception(frame: &[u8], unit: u8, function: u8) -> Option<Rtu> {
    if frame.len() != EXCEPTION_LEN {
        return None;
    }
    if let Some((computed, carried)) = split_crc(frame).filter(|(c, k)| c != k) {
        return bad_crc(frame, computed, carried);
    }
    Some(Rtu::ForeignException {
        unit,
        function: function & 0x7F,
        code: ExceptionCode::from_u8(*frame.get(2)?),
    })
}

fn bad_crc(frame: &[u8], computed: u16, carried: u16) -> Option<Rtu> {
    match frame {
        [unit, function, ..] => Some(Rtu::BadCrc {
            unit: *unit,
            function: *function,
            computed,
            carried,
        }),
        _ => None,
    }
}

impl Rtu {
    /// Whether a device answers this frame (a unicast request, or a Collect).
    pub fn expects_reply(&self) -> bool {
        match self {
            Rtu::Request { unit, request } => crate::modbus::master::expects_reply(*unit, request),
            _ => false,
        }
    }
}

/// The manual's name of a function (Modbus Application Protocol v1.1b3 §6; FC 70 from the
/// MiniMod manual).
fn function_name(code: u8) -> &'static str {
    match FunctionCode::from_u8(code) {
        Some(FunctionCode::ReadCoils) => "read coils",
        Some(FunctionCode::ReadDiscreteInputs) => "read discrete inputs",
        Some(FunctionCode::ReadHoldingRegisters) => "read holding registers",
        Some(FunctionCode::ReadInputRegisters) => "read input registers",
        Some(FunctionCode::WriteSingleCoil) => "write single coil",
        Some(FunctionCode::WriteSingleRegister) => "write single register",
        Some(FunctionCode::WriteMultipleCoils) => "write multiple coils",
        Some(FunctionCode::WriteMultipleRegisters) => "write multiple registers",
        Some(FunctionCode::MaskWriteRegister) => "mask write register",
        Some(FunctionCode::Collect) => "Collect",
        None => "function",
    }
}

struct Address(u8);

impl fmt::Display for Address {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            0 => f.write_str("broadcast"),
            n => write!(f, "unit {n}"),
        }
    }
}

struct Bits<'a>(&'a [bool]);

impl fmt::Display for Bits<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for b in self.0 {
            f.write_str(if *b { "1" } else { "0" })?;
        }
        Ok(())
    }
}

struct Words<'a>(&'a [u16]);

impl fmt::Display for Words<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("[")?;
        for (i, w) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(", ")?;
            }
            write!(f, "{w}")?;
        }
        f.write_str("]")
    }
}

fn on_off(v: bool) -> &'static str {
    if v {
        "ON"
    } else {
        "OFF"
    }
}

/// The addresses a request or reply spans: `160 (1 bit)`, `51..=78 (28 registers)`.
/// Addresses are protocol addresses (0-based).
fn span(f: &mut fmt::Formatter<'_>, addr: u16, count: usize, what: Unit) -> fmt::Result {
    let last = usize::from(addr) + count.saturating_sub(1);
    let (one, many) = match what {
        Unit::Bits => ("bit", "bits"),
        Unit::Registers => ("register", "registers"),
    };
    if count == 1 {
        write!(f, "{addr} (1 {one})")
    } else {
        write!(f, "{addr}..={last} ({count} {many})")
    }
}

/// What a span counts.
#[derive(Clone, Copy)]
enum Unit {
    Bits,
    Registers,
}

fn fmt_request(f: &mut fmt::Formatter<'_>, request: &Request) -> fmt::Result {
    let code = request.function().code();
    write!(f, "{} (FC {code}) ", function_name(code))?;
    match request {
        Request::ReadCoils { addr, count } | Request::ReadDiscreteInputs { addr, count } => {
            span(f, *addr, usize::from(*count), Unit::Bits)
        }
        Request::ReadHoldingRegisters { addr, count }
        | Request::ReadInputRegisters { addr, count } => {
            span(f, *addr, usize::from(*count), Unit::Registers)
        }
        Request::WriteSingleCoil { addr, value } => write!(f, "{addr} = {}", on_off(*value)),
        Request::WriteSingleRegister { addr, value } => write!(f, "{addr} = {value}"),
        Request::WriteMultipleCoils { addr, values } => {
            span(f, *addr, values.len(), Unit::Bits)?;
            write!(f, " = {}", Bits(values))
        }
        Request::WriteMultipleRegisters { addr, values } => {
            span(f, *addr, values.len(), Unit::Registers)?;
            write!(f, " = {}", Words(values))
        }
        Request::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => write!(f, "{addr} AND {and_mask:#06X} OR {or_mask:#06X}"),
        Request::Collect {
            first,
            last,
            slave_ack,
            slave_seq,
        } => write!(
            f,
            "window {first}..={last}, SLVACK {slave_ack} SLVSEQ {slave_seq}"
        ),
    }
}

/// The first address a read reply's values start at, from its request.
fn read_start(to: Option<&Request>) -> Option<u16> {
    match to? {
        Request::ReadCoils { addr, .. }
        | Request::ReadDiscreteInputs { addr, .. }
        | Request::ReadHoldingRegisters { addr, .. }
        | Request::ReadInputRegisters { addr, .. } => Some(*addr),
        _ => None,
    }
}

fn fmt_response(
    f: &mut fmt::Formatter<'_>,
    response: &Response,
    to: Option<&Request>,
) -> fmt::Result {
    let from = |f: &mut fmt::Formatter<'_>, n: usize, what: Unit| match read_start(to) {
        Some(addr) => span(f, addr, n, what),
        None => {
            let what = match what {
                Unit::Bits => "bits",
                Unit::Registers => "registers",
            };
            write!(f, "{n} {what}, request not seen")
        }
    };
    match response {
        Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits) => {
            from(f, bits.len(), Unit::Bits)?;
            write!(f, " = {}", Bits(bits))
        }
        Response::ReadHoldingRegisters(words) | Response::ReadInputRegisters(words) => {
            from(f, words.len(), Unit::Registers)?;
            write!(f, " = {}", Words(words))
        }
        Response::WriteSingleCoil { addr, value } => write!(f, "{addr} = {} done", on_off(*value)),
        Response::WriteSingleRegister { addr, value } => write!(f, "{addr} = {value} done"),
        Response::WriteMultipleCoils { addr, count } => {
            span(f, *addr, usize::from(*count), Unit::Bits)?;
            f.write_str(" written")
        }
        Response::WriteMultipleRegisters { addr, count } => {
            span(f, *addr, usize::from(*count), Unit::Registers)?;
            f.write_str(" written")
        }
        Response::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => write!(f, "{addr} AND {and_mask:#06X} OR {or_mask:#06X} done"),
        Response::Collect {
            slave,
            seq,
            kind,
            data,
        } => {
            let kind = match kind {
                2 => "inputs",
                1 => "outputs",
                _ => "TYPE unknown",
            };
            write!(
                f,
                "event of slave {slave}: SLVSEQ {seq}, {kind} {data:#06X}"
            )
        }
        Response::Exception { code, .. } => write!(f, "exception {code}"),
    }
}

impl fmt::Display for Rtu {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Rtu::Request { unit, request } => {
                write!(f, "request {}: ", Address(*unit))?;
                fmt_request(f, request)?;
                f.write_str(", CRC ok")
            }
            Rtu::Reply {
                unit,
                response,
                to,
                seen,
            } => {
                let code = to.function().code();
                write!(
                    f,
                    "reply {}: {} (FC {code}) ",
                    Address(*unit),
                    function_name(code)
                )?;
                fmt_response(f, response, seen.then_some(to))?;
                f.write_str(", CRC ok")
            }
            Rtu::ForeignException {
                unit,
                function,
                code,
            } => write!(
                f,
                "reply {}: FC {function} exception {code}, CRC ok",
                Address(*unit)
            ),
            Rtu::BadCrc {
                unit,
                function,
                computed,
                carried,
            } => write!(
                f,
                "{} FC {}: CRC bad (computed {computed:#06X}, frame carries {carried:#06X})",
                Address(*unit),
                function & 0x7F
            ),
            Rtu::Mismatch {
                unit,
                function,
                error,
            } => write!(
                f,
                "reply {} FC {function}, not the answer to the request: {error}, CRC ok",
                Address(*unit)
            ),
        }
    }
}
