//! Splitting a byte stream into request frames and decoding them.

use crate::modbus::crc::split_crc;
use crate::modbus::master::{unpack_bits, word_at, COIL_OFF, COIL_ON};
use crate::modbus::pdu::{ExceptionCode, FunctionCode, Request, Response};

/// The length of the request frame at the start of a byte stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameLen {
    /// Not enough bytes yet to know the length (or to hold the whole frame).
    Incomplete,
    /// A whole frame of this many bytes (CRC included) is at the start of the buffer.
    Complete(usize),
    /// The function code is not in the request length table: the stream cannot be split here
    /// (resynchronise on the next silence, t3.5).
    Unknown,
}

/// The length of the request frame at the start of `buf`, from the request length table:
/// FC 1–6: 8; FC 15/16: 9 + byte count (byte 6); FC 22: 10; FC 70 Collect
/// `DST 70 FIRST LAST SLVACK SLVSEQ` + CRC: 8. The CRC is not checked here.
pub fn request_frame_len(buf: &[u8]) -> FrameLen {
    let Some(&fc) = buf.get(1) else {
        return FrameLen::Incomplete;
    };
    let len = match request_len(fc, buf.get(6).copied()) {
        Some(Some(len)) => len,
        Some(None) => return FrameLen::Incomplete,
        None => return FrameLen::Unknown,
    };
    if buf.len() >= len {
        FrameLen::Complete(len)
    } else {
        FrameLen::Incomplete
    }
}

/// The request length table. `None`: unknown function; `Some(None)`: the byte count (byte 6)
/// is needed and missing.
fn request_len(fc: u8, byte_count: Option<u8>) -> Option<Option<usize>> {
    Some(match FunctionCode::from_u8(fc)? {
        FunctionCode::ReadCoils
        | FunctionCode::ReadDiscreteInputs
        | FunctionCode::ReadHoldingRegisters
        | FunctionCode::ReadInputRegisters
        | FunctionCode::WriteSingleCoil
        | FunctionCode::WriteSingleRegister
        | FunctionCode::Collect => Some(8),
        FunctionCode::WriteMultipleCoils | FunctionCode::WriteMultipleRegisters => {
            byte_count.map(|n| 9 + usize::from(n))
        }
        FunctionCode::MaskWriteRegister => Some(10),
    })
}

/// Why a request frame was not decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RequestError {
    /// Fewer than 4 bytes (address, function, CRC): not a frame. Stay silent.
    #[error("request frame of {len} bytes is too short")]
    TooShort {
        /// The frame length.
        len: usize,
    },
    /// The CRC does not match. A device must stay silent (Modbus over Serial Line §2.4.1).
    #[error("request CRC error: computed {expected:#06x}, frame carries {found:#06x}")]
    Crc {
        /// The CRC computed over the frame.
        expected: u16,
        /// The CRC the frame carries.
        found: u16,
    },
    /// The function code is not one softplc serves. Reply: exception 01.
    #[error("unit {unit}: unknown function {function}")]
    UnknownFunction {
        /// The address byte.
        unit: u8,
        /// The function byte.
        function: u8,
    },
    /// The frame length does not fit the function (with its byte count). Reply: exception 03.
    #[error("unit {unit}: function {function} frame of {found} bytes, expected {expected}")]
    WrongLength {
        /// The address byte.
        unit: u8,
        /// The function byte.
        function: u8,
        /// The length the function implies.
        expected: usize,
        /// The length received.
        found: usize,
    },
    /// FC 15/16: the byte count does not match the quantity. Reply: exception 03.
    #[error("unit {unit}: function {function} byte count {found}, quantity implies {expected}")]
    BadByteCount {
        /// The address byte.
        unit: u8,
        /// The function byte.
        function: u8,
        /// The byte count the quantity implies.
        expected: usize,
        /// The byte count received.
        found: u8,
    },
    /// FC 5 with a value other than 0xFF00 (ON) or 0x0000 (OFF). Reply: exception 03.
    #[error("unit {unit}: coil value {value:#06x} is neither 0xFF00 nor 0x0000")]
    BadCoilValue {
        /// The address byte.
        unit: u8,
        /// The value received.
        value: u16,
    },
}

impl RequestError {
    /// Whether this is a CRC error.
    pub fn is_crc(&self) -> bool {
        matches!(self, Self::Crc { .. })
    }

    /// The reply a conforming device gives to this bad request, as `(unit, exception)`: `None`
    /// when it must stay silent (CRC error, short frame, broadcast). The device answers only
    /// if `unit` is its own address.
    pub fn exception_reply(&self) -> Option<(u8, Response)> {
        let (unit, function, code) = match *self {
            Self::TooShort { .. } | Self::Crc { .. } => return None,
            Self::UnknownFunction { unit, function } => {
                (unit, function, ExceptionCode::IllegalFunction)
            }
            Self::WrongLength { unit, function, .. }
            | Self::BadByteCount { unit, function, .. } => {
                (unit, function, ExceptionCode::IllegalDataValue)
            }
            Self::BadCoilValue { unit, .. } => (
                unit,
                FunctionCode::WriteSingleCoil.code(),
                ExceptionCode::IllegalDataValue,
            ),
        };
        (unit != 0).then_some((unit, Response::Exception { function, code }))
    }
}

/// Decodes one whole request frame (address, PDU, CRC) into its address byte and request.
/// The CRC is checked first. The address is returned as it came (0 = broadcast, or another
/// device's address): filtering is the caller's. Quantities are not checked here (an
/// out-of-range quantity is an exception [`super::serve`] returns), except where the frame cannot be
/// decoded without them (FC 15/16 byte count).
pub fn decode_request(adu: &[u8]) -> Result<(u8, Request), RequestError> {
    let len = adu.len();
    let (&unit, &fc) = match adu {
        [unit, fc, _, _, ..] => (unit, fc),
        _ => return Err(RequestError::TooShort { len }),
    };
    let (computed, carried) = split_crc(adu).ok_or(RequestError::TooShort { len })?;
    if computed != carried {
        return Err(RequestError::Crc {
            expected: computed,
            found: carried,
        });
    }
    let unknown = RequestError::UnknownFunction { unit, function: fc };
    let wrong_length = |expected| RequestError::WrongLength {
        unit,
        function: fc,
        expected,
        found: len,
    };
    let Some(function) = FunctionCode::from_u8(fc) else {
        return Err(unknown);
    };
    let expected = match request_len(fc, adu.get(6).copied()) {
        Some(Some(n)) => n,
        Some(None) => return Err(wrong_length(9)),
        None => return Err(unknown),
    };
    if len != expected {
        return Err(wrong_length(expected));
    }
    // From here the frame has its table length: every field below is present.
    let w = |at: usize| word_at(adu, at).ok_or(wrong_length(expected));
    let b = |at: usize| adu.get(at).copied().ok_or(wrong_length(expected));
    let req = match function {
        FunctionCode::ReadCoils => Request::ReadCoils {
            addr: w(2)?,
            count: w(4)?,
        },
        FunctionCode::ReadDiscreteInputs => Request::ReadDiscreteInputs {
            addr: w(2)?,
            count: w(4)?,
        },
        FunctionCode::ReadHoldingRegisters => Request::ReadHoldingRegisters {
            addr: w(2)?,
            count: w(4)?,
        },
        FunctionCode::ReadInputRegisters => Request::ReadInputRegisters {
            addr: w(2)?,
            count: w(4)?,
        },
        FunctionCode::WriteSingleCoil => {
            let value = match w(4)? {
                COIL_ON => true,
                COIL_OFF => false,
                value => return Err(RequestError::BadCoilValue { unit, value }),
            };
            Request::WriteSingleCoil { addr: w(2)?, value }
        }
        FunctionCode::WriteSingleRegister => Request::WriteSingleRegister {
            addr: w(2)?,
            value: w(4)?,
        },
        FunctionCode::WriteMultipleCoils | FunctionCode::WriteMultipleRegisters => {
            let count = usize::from(w(4)?);
            let found = b(6)?;
            let coils = function == FunctionCode::WriteMultipleCoils;
            let bytes_needed = if coils { count.div_ceil(8) } else { count * 2 };
            if usize::from(found) != bytes_needed {
                return Err(RequestError::BadByteCount {
                    unit,
                    function: fc,
                    expected: bytes_needed,
                    found,
                });
            }
            let data = adu.get(7..7 + bytes_needed).ok_or(wrong_length(expected))?;
            let addr = w(2)?;
            if coils {
                Request::WriteMultipleCoils {
                    addr,
                    values: unpack_bits(data, count),
                }
            } else {
                Request::WriteMultipleRegisters {
                    addr,
                    values: data.chunks_exact(2).filter_map(|c| word_at(c, 0)).collect(),
                }
            }
        }
        FunctionCode::MaskWriteRegister => Request::MaskWriteRegister {
            addr: w(2)?,
            and_mask: w(4)?,
            or_mask: w(6)?,
        },
        FunctionCode::Collect => Request::Collect {
            first: b(2)?,
            last: b(3)?,
            slave_ack: b(4)?,
            slave_seq: b(5)?,
        },
    };
    Ok((unit, req))
}
