//! Reply reassembly and verification with a length table per function code.
//!
//! The length of a reply is known from its first bytes:
//!
//! | reply                          | total ADU length        |
//! |--------------------------------|-------------------------|
//! | FC 1, 2, 3, 4                  | 5 + byte count (byte 2) |
//! | FC 5, 6, 15, 16 (echo)         | 8                       |
//! | FC 22 (echo)                   | 10                      |
//! | FC 70 `SLAVE 70 SLVSEQ TYPE DATH DATL 0` | 9             |
//! | exception `unit, fc\|0x80, code` | 5                     |
//!
//! Order of checks: the address byte as soon as it arrives (fail fast: the bus owner flushes);
//! the function byte when it arrives, only to know the length (an unknown function fails
//! fast, a known one is read to its end); then, on the whole frame, the CRC first, and only on
//! an intact frame the content (function, byte count, echo fields). So a corrupted frame is a
//! [`ReplyError::Crc`], whichever byte the noise hit, unless it hit the address, made the
//! function byte unknown, or made the byte count impossible (> 250).

use super::error::{EchoField, ReplyError};
use super::{unpack_bits, word_at, COIL_OFF, COIL_ON, MAX_DATA_BYTES};
use crate::modbus::crc::split_crc;
use crate::modbus::pdu::{ExceptionCode, FunctionCode, Request, Response};

/// Length of an exception reply: `unit, fc|0x80, code, crc lo, crc hi`.
const EXCEPTION_LEN: usize = 5;

/// What [`ReplyAssembler::push`] made of the bytes so far.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Progress {
    /// The frame is not complete yet.
    NeedMore,
    /// A complete, verified reply.
    Complete {
        /// The decoded reply (possibly an exception: the device answered).
        response: Response,
        /// Bytes received beyond the frame (a babbling device, a late reply glued on); the
        /// caller decides what that means. Keeps growing if more bytes are pushed.
        extra: usize,
    },
    /// The reply is refused; pushing more bytes changes nothing.
    Failed(ReplyError),
}

/// What the reply to a request must contain.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Expect {
    /// FC 1/2: `count` bits.
    Bits { count: u16 },
    /// FC 3/4: `count` registers.
    Registers { count: u16 },
    /// FC 5, 6, 15, 16 (three words, the last unused) and 22: the echo, from byte 2 on.
    Echo {
        words: [(EchoField, u16); 3],
        len: usize,
    },
    /// FC 70: a slave in the window.
    Collect { first: u8, last: u8 },
}

impl Expect {
    fn of(req: &Request) -> Self {
        let sat = |n: usize| u16::try_from(n).unwrap_or(u16::MAX);
        let echo2 = |addr: u16, second: (EchoField, u16)| Expect::Echo {
            words: [(EchoField::Address, addr), second, (EchoField::Value, 0)],
            len: 2,
        };
        match req {
            Request::ReadCoils { count, .. } | Request::ReadDiscreteInputs { count, .. } => {
                Expect::Bits { count: *count }
            }
            Request::ReadHoldingRegisters { count, .. }
            | Request::ReadInputRegisters { count, .. } => Expect::Registers { count: *count },
            Request::WriteSingleCoil { addr, value } => echo2(
                *addr,
                (EchoField::Value, if *value { COIL_ON } else { COIL_OFF }),
            ),
            Request::WriteSingleRegister { addr, value } => {
                echo2(*addr, (EchoField::Value, *value))
            }
            Request::WriteMultipleCoils { addr, values } => {
                echo2(*addr, (EchoField::Quantity, sat(values.len())))
            }
            Request::WriteMultipleRegisters { addr, values } => {
                echo2(*addr, (EchoField::Quantity, sat(values.len())))
            }
            Request::MaskWriteRegister {
                addr,
                and_mask,
                or_mask,
            } => Expect::Echo {
                words: [
                    (EchoField::Address, *addr),
                    (EchoField::AndMask, *and_mask),
                    (EchoField::OrMask, *or_mask),
                ],
                len: 3,
            },
            Request::Collect { first, last, .. } => Expect::Collect {
                first: *first,
                last: *last,
            },
        }
    }

    /// The byte count a read reply must carry.
    fn byte_count(self) -> Option<usize> {
        match self {
            Expect::Bits { count } => Some(usize::from(count).div_ceil(8)),
            Expect::Registers { count } => Some(usize::from(count) * 2),
            Expect::Echo { .. } | Expect::Collect { .. } => None,
        }
    }
}

/// The length of a reply from its first bytes, or why it cannot be one.
enum Header {
    NeedMore,
    Len(usize),
    Fail(ReplyError),
}

/// Reassembles and verifies the reply to one request, from fragments of any size.
///
/// ```
/// use softplc_io::modbus::{Progress, ReplyAssembler};
/// use softplc_io::modbus::{Request, Response};
///
/// let req = Request::ReadHoldingRegisters { addr: 0x6B, count: 3 };
/// let mut asm = ReplyAssembler::new(0x11, &req);
/// assert_eq!(asm.push(&[0x11, 0x03, 0x06, 0x02, 0x2B]), Progress::NeedMore);
/// assert_eq!(asm.expected_len(), Some(11));
/// let done = asm.push(&[0x00, 0x00, 0x00, 0x64, 0xC8, 0xBA]);
/// assert_eq!(
///     done,
///     Progress::Complete {
///         response: Response::ReadHoldingRegisters(vec![0x022B, 0x0000, 0x0064]),
///         extra: 0
///     }
/// );
/// ```
#[derive(Debug, Clone)]
pub struct ReplyAssembler {
    unit: u8,
    function: FunctionCode,
    expect: Expect,
    buf: Vec<u8>,
    expected_len: Option<usize>,
    outcome: Option<Progress>,
}

impl ReplyAssembler {
    /// An assembler for the reply to `req` sent to `unit`. For a Collect the address of the
    /// reply is checked against the window `first..=last` instead of `unit` (a broadcast
    /// Collect is answered by a device in the window). A broadcast of anything else gets no
    /// reply (`super::expects_reply`); any byte then fails as [`ReplyError::WrongUnit`].
    pub fn new(unit: u8, req: &Request) -> Self {
        Self {
            unit,
            function: req.function(),
            expect: Expect::of(req),
            buf: Vec::with_capacity(MAX_DATA_BYTES + 5),
            expected_len: None,
            outcome: None,
        }
    }

    /// The total length of the reply frame (CRC included), once its header told it.
    pub fn expected_len(&self) -> Option<usize> {
        self.expected_len
    }

    /// The number of bytes taken into the frame so far (not counting extra bytes); useful to
    /// report a timeout on a partial frame.
    pub fn received(&self) -> usize {
        self.buf.len()
    }

    /// Feeds the next bytes received. Once the result is `Complete` or `Failed` it stays so;
    /// further bytes only grow `extra` of a `Complete`.
    pub fn push(&mut self, mut bytes: &[u8]) -> Progress {
        loop {
            if let Some(outcome) = &mut self.outcome {
                if let Progress::Complete { extra, .. } = outcome {
                    *extra = extra.saturating_add(bytes.len());
                }
                return outcome.clone();
            }
            if bytes.is_empty() {
                return Progress::NeedMore;
            }
            // Before the length is known, take one byte at a time (at most 3 header bytes).
            let want = match self.expected_len {
                Some(len) => len.saturating_sub(self.buf.len()),
                None => 1,
            };
            let (now, rest) = bytes.split_at(want.min(bytes.len()));
            self.buf.extend_from_slice(now);
            bytes = rest;
            if self.expected_len.is_none() {
                match self.header() {
                    Header::NeedMore => {}
                    Header::Len(len) => self.expected_len = Some(len),
                    Header::Fail(e) => self.outcome = Some(Progress::Failed(e)),
                }
            }
            if self.outcome.is_none() && self.expected_len == Some(self.buf.len()) {
                self.outcome = Some(match self.decode() {
                    Ok(response) => Progress::Complete { response, extra: 0 },
                    Err(e) => Progress::Failed(e),
                });
            }
        }
    }

    /// The reply length from the header bytes received so far (the length table).
    fn header(&self) -> Header {
        let Some(&addr) = self.buf.first() else {
            return Header::NeedMore;
        };
        match self.expect {
            Expect::Collect { first, last } if !(first..=last).contains(&addr) => {
                return Header::Fail(ReplyError::OutsideWindow {
                    first,
                    last,
                    found: addr,
                });
            }
            Expect::Collect { .. } => {}
            _ if addr != self.unit => {
                return Header::Fail(ReplyError::WrongUnit {
                    expected: self.unit,
                    found: addr,
                });
            }
            _ => {}
        }
        let Some(&fc) = self.buf.get(1) else {
            return Header::NeedMore;
        };
        if fc & 0x80 != 0 {
            return Header::Len(EXCEPTION_LEN);
        }
        let wrong_function = ReplyError::WrongFunction {
            expected: self.function.code(),
            found: fc,
        };
        match FunctionCode::from_u8(fc) {
            None => Header::Fail(wrong_function),
            Some(
                FunctionCode::ReadCoils
                | FunctionCode::ReadDiscreteInputs
                | FunctionCode::ReadHoldingRegisters
                | FunctionCode::ReadInputRegisters,
            ) => {
                let Some(&count) = self.buf.get(2) else {
                    return Header::NeedMore;
                };
                if usize::from(count) <= MAX_DATA_BYTES {
                    Header::Len(5 + usize::from(count))
                } else if fc == self.function.code() {
                    Header::Fail(ReplyError::WrongByteCount {
                        expected: self.expect.byte_count().unwrap_or(0),
                        found: count,
                    })
                } else {
                    Header::Fail(wrong_function)
                }
            }
            Some(
                FunctionCode::WriteSingleCoil
                | FunctionCode::WriteSingleRegister
                | FunctionCode::WriteMultipleCoils
                | FunctionCode::WriteMultipleRegisters,
            ) => Header::Len(8),
            Some(FunctionCode::MaskWriteRegister) => Header::Len(10),
            Some(FunctionCode::Collect) => Header::Len(9),
        }
    }

    /// Verifies and decodes the complete frame in `buf`.
    fn decode(&self) -> Result<Response, ReplyError> {
        let frame = self.buf.as_slice();
        let malformed = |offset| ReplyError::Malformed { offset };
        let byte = |at: usize| frame.get(at).copied().ok_or(malformed(at));
        let word = |at: usize| word_at(frame, at).ok_or(malformed(at));

        let (computed, carried) = split_crc(frame).ok_or(malformed(0))?;
        if computed != carried {
            return Err(ReplyError::Crc {
                expected: computed,
                found: carried,
            });
        }
        let addr = byte(0)?;
        let fc = byte(1)?;
        let function = self.function.code();
        if fc == function | 0x80 {
            return Ok(Response::Exception {
                function,
                code: ExceptionCode::from_u8(byte(2)?),
            });
        }
        if fc != function {
            return Err(ReplyError::WrongFunction {
                expected: function,
                found: fc,
            });
        }
        match self.expect {
            Expect::Bits { .. } | Expect::Registers { .. } => {
                let found = byte(2)?;
                let expected = self.expect.byte_count().unwrap_or(0);
                if usize::from(found) != expected {
                    return Err(ReplyError::WrongByteCount { expected, found });
                }
                let data = frame.get(3..3 + expected).ok_or(malformed(3))?;
                Ok(self.read_response(data))
            }
            Expect::Echo { words, len } => {
                for (i, (field, expected)) in words.iter().take(len).enumerate() {
                    let found = word(2 + 2 * i)?;
                    if found != *expected {
                        return Err(ReplyError::EchoMismatch {
                            field: *field,
                            expected: *expected,
                            found,
                        });
                    }
                }
                self.echo_response(&words)
            }
            Expect::Collect { .. } => {
                if byte(6)? != 0 {
                    return Err(malformed(6));
                }
                Ok(Response::Collect {
                    slave: addr,
                    seq: byte(2)?,
                    kind: byte(3)?,
                    data: word(4)?,
                })
            }
        }
    }

    /// The response of a read whose data field (byte count checked) is `data`.
    fn read_response(&self, data: &[u8]) -> Response {
        match self.expect {
            Expect::Bits { count } => {
                let bits = unpack_bits(data, usize::from(count));
                if self.function == FunctionCode::ReadCoils {
                    Response::ReadCoils(bits)
                } else {
                    Response::ReadDiscreteInputs(bits)
                }
            }
            _ => {
                let regs = data.chunks_exact(2).filter_map(|w| word_at(w, 0)).collect();
                if self.function == FunctionCode::ReadHoldingRegisters {
                    Response::ReadHoldingRegisters(regs)
                } else {
                    Response::ReadInputRegisters(regs)
                }
            }
        }
    }

    /// The response of a write whose echo (checked) equals the request's `words`.
    fn echo_response(&self, words: &[(EchoField, u16); 3]) -> Result<Response, ReplyError> {
        let [(_, addr), (_, second), (_, third)] = *words;
        Ok(match self.function {
            FunctionCode::WriteSingleCoil => Response::WriteSingleCoil {
                addr,
                value: second == COIL_ON,
            },
            FunctionCode::WriteSingleRegister => Response::WriteSingleRegister {
                addr,
                value: second,
            },
            FunctionCode::WriteMultipleCoils => Response::WriteMultipleCoils {
                addr,
                count: second,
            },
            FunctionCode::WriteMultipleRegisters => Response::WriteMultipleRegisters {
                addr,
                count: second,
            },
            FunctionCode::MaskWriteRegister => Response::MaskWriteRegister {
                addr,
                and_mask: second,
                or_mask: third,
            },
            // Expect::Echo is only built for the five functions above.
            _ => return Err(ReplyError::Malformed { offset: 1 }),
        })
    }
}

#[cfg(test)]
mod tests;
