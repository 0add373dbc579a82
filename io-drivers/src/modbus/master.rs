//! The RTU master side: request frames out, reply frames reassembled and verified.
//!
//! [`encode_request`] validates a request against the Modbus limits and appends its whole
//! ADU (address, PDU, CRC). [`ReplyAssembler`] joins the reply from fragments using a length
//! table per function code and verifies it against the request it answers (address or
//! Collect window, function, byte count, echo fields, CRC) — so a late reply to an earlier
//! request, a corrupted frame or a babbling device is refused instead of being taken as the
//! answer (DESIGN.md principle 4).
//!
//! References: Modbus Application Protocol v1.1b3 (function layouts and limits), Modbus over
//! Serial Line v1.02 (RTU framing, CRC), MiniMod manual "The Modbus function Collect" (FC 70).

mod error;
mod reply;

pub use error::{EchoField, ReplyError};
pub use reply::{Progress, ReplyAssembler};

use super::crc::append_crc;
use super::pdu::{FunctionCode, Request};

/// Largest data field of a read reply, in bytes: 2000 bits or 125 registers (a 256-byte ADU).
pub(crate) const MAX_DATA_BYTES: usize = 250;

/// The largest unit address a device may have; 248..=255 are reserved.
const MAX_UNIT: u8 = 247;

/// The coil value FC 5 uses for ON.
pub(crate) const COIL_ON: u16 = 0xFF00;

/// The coil value FC 5 uses for OFF.
pub(crate) const COIL_OFF: u16 = 0x0000;

/// Why a request cannot be encoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EncodeError {
    /// The unit address is reserved (248..=255).
    #[error("unit address {unit} is reserved (valid: 0 for broadcast, 1..=247)")]
    ReservedUnit {
        /// The address asked for.
        unit: u8,
    },
    /// A read was addressed to broadcast (0): no device would answer it.
    #[error("function {function} is a read and cannot be broadcast")]
    BroadcastRead {
        /// The function code.
        function: u8,
    },
    /// The quantity is outside `1..=max` for this function.
    #[error("function {function}: quantity {count} outside 1..={max}")]
    Quantity {
        /// The function code.
        function: u8,
        /// The quantity asked for (number of bits or registers).
        count: usize,
        /// The largest quantity the function allows.
        max: u16,
    },
    /// `addr + count` runs past the last protocol address (65535).
    #[error("function {function}: address {addr} + quantity {count} exceeds 65536")]
    AddressOverflow {
        /// The function code.
        function: u8,
        /// The first (0-based) address.
        addr: u16,
        /// The quantity.
        count: usize,
    },
    /// A Collect window with `first > last` would authorise no device.
    #[error("Collect window {first}..={last} is empty")]
    CollectWindow {
        /// FIRST.
        first: u8,
        /// LAST.
        last: u8,
    },
}

/// Whether a device answers `req` sent to `unit`: every unicast does; a broadcast (0) does
/// not, except FC 70 Collect, which the devices in its window answer.
pub(crate) fn expects_reply(unit: u8, req: &Request) -> bool {
    unit != 0 || matches!(req, Request::Collect { .. })
}

/// Checks `req` sent to `unit` against the Modbus limits: unit 0..=247, no broadcast read,
/// quantity within the function's range (FC 1/2: 1..=2000, FC 3/4: 1..=125, FC 15: 1..=1968,
/// FC 16: 1..=123), `addr + count <= 65536`, a non-empty Collect window.
pub(crate) fn validate_request(unit: u8, req: &Request) -> Result<(), EncodeError> {
    if unit > MAX_UNIT {
        return Err(EncodeError::ReservedUnit { unit });
    }
    let function = req.function();
    if unit == 0
        && matches!(
            function,
            FunctionCode::ReadCoils
                | FunctionCode::ReadDiscreteInputs
                | FunctionCode::ReadHoldingRegisters
                | FunctionCode::ReadInputRegisters
        )
    {
        return Err(EncodeError::BroadcastRead {
            function: function.code(),
        });
    }
    check_pdu(req)
}

/// The unit-independent part of [`validate_request`]: quantities, address range, Collect
/// window. Shared with the server, which maps the errors to exception codes.
pub(crate) fn check_pdu(req: &Request) -> Result<(), EncodeError> {
    if let Request::Collect { first, last, .. } = *req {
        return if first <= last {
            Ok(())
        } else {
            Err(EncodeError::CollectWindow { first, last })
        };
    }
    let Some((addr, count)) = span(req) else {
        return Ok(());
    };
    let function = req.function();
    if let Some(max) = function.max_quantity() {
        if count == 0 || count > usize::from(max) {
            return Err(EncodeError::Quantity {
                function: function.code(),
                count,
                max,
            });
        }
    }
    if usize::from(addr) + count > 0x1_0000 {
        return Err(EncodeError::AddressOverflow {
            function: function.code(),
            addr,
            count,
        });
    }
    Ok(())
}

/// The first address and the number of bits or registers a request touches; `None` for
/// Collect.
pub(crate) fn span(req: &Request) -> Option<(u16, usize)> {
    Some(match req {
        Request::ReadCoils { addr, count }
        | Request::ReadDiscreteInputs { addr, count }
        | Request::ReadHoldingRegisters { addr, count }
        | Request::ReadInputRegisters { addr, count } => (*addr, usize::from(*count)),
        Request::WriteSingleCoil { addr, .. }
        | Request::WriteSingleRegister { addr, .. }
        | Request::MaskWriteRegister { addr, .. } => (*addr, 1),
        Request::WriteMultipleCoils { addr, values } => (*addr, values.len()),
        Request::WriteMultipleRegisters { addr, values } => (*addr, values.len()),
        Request::Collect { .. } => return None,
    })
}

/// Appends the whole request ADU for `req` to `unit` (0 = broadcast) to `out`: address, PDU,
/// CRC (low byte first). Nothing is appended when the request is refused.
pub fn encode_request(unit: u8, req: &Request, out: &mut Vec<u8>) -> Result<(), EncodeError> {
    validate_request(unit, req)?;
    let mut frame = Vec::with_capacity(16);
    frame.push(unit);
    frame.push(req.function().code());
    match req {
        Request::ReadCoils { addr, count }
        | Request::ReadDiscreteInputs { addr, count }
        | Request::ReadHoldingRegisters { addr, count }
        | Request::ReadInputRegisters { addr, count } => {
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *count);
        }
        Request::WriteSingleCoil { addr, value } => {
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, if *value { COIL_ON } else { COIL_OFF });
        }
        Request::WriteSingleRegister { addr, value } => {
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *value);
        }
        Request::WriteMultipleCoils { addr, values } => {
            // Validated: 1..=1968 values, so the count fits u16 and the byte count u8.
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, u16::try_from(values.len()).unwrap_or(u16::MAX));
            frame.push(u8::try_from(values.len().div_ceil(8)).unwrap_or(u8::MAX));
            pack_bits(values, &mut frame);
        }
        Request::WriteMultipleRegisters { addr, values } => {
            // Validated: 1..=123 values.
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, u16::try_from(values.len()).unwrap_or(u16::MAX));
            frame.push(u8::try_from(values.len() * 2).unwrap_or(u8::MAX));
            for v in values {
                push_u16(&mut frame, *v);
            }
        }
        Request::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => {
            push_u16(&mut frame, *addr);
            push_u16(&mut frame, *and_mask);
            push_u16(&mut frame, *or_mask);
        }
        Request::Collect {
            first,
            last,
            slave_ack,
            slave_seq,
        } => frame.extend_from_slice(&[*first, *last, *slave_ack, *slave_seq]),
    }
    append_crc(&mut frame);
    out.extend_from_slice(&frame);
    Ok(())
}

/// Appends `v` big-endian, as Modbus carries 16-bit fields.
pub(crate) fn push_u16(out: &mut Vec<u8>, v: u16) {
    out.extend_from_slice(&v.to_be_bytes());
}

/// The big-endian word at `at` in `bytes`, if both bytes are there.
pub(crate) fn word_at(bytes: &[u8], at: usize) -> Option<u16> {
    match bytes.get(at..at.checked_add(2)?)? {
        [hi, lo] => Some(u16::from_be_bytes([*hi, *lo])),
        _ => None,
    }
}

/// Packs bits LSB first, 8 per byte, the last byte padded with zeros.
pub(crate) fn pack_bits(bits: &[bool], out: &mut Vec<u8>) {
    for chunk in bits.chunks(8) {
        let byte = chunk
            .iter()
            .enumerate()
            .fold(0u8, |acc, (i, &b)| if b { acc | (1 << i) } else { acc });
        out.push(byte);
    }
}

/// Unpacks the first `count` bits (LSB first) of `bytes`; padding bits are dropped. Returns
/// fewer than `count` bits only if `bytes` is too short.
pub(crate) fn unpack_bits(bytes: &[u8], count: usize) -> Vec<bool> {
    bytes
        .iter()
        .flat_map(|&byte| (0..8).map(move |i| byte & (1 << i) != 0))
        .take(count)
        .collect()
}

#[cfg(test)]
mod tests;
