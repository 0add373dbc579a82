//! Our typed requests to tokio-modbus's, and its responses back to ours, verified against the
//! request as the RTU codec verifies a reply (byte count, echoed address, value and quantity):
//! drivers see the same [`Response`] whichever bus carried it.

use std::borrow::Cow;

use tokio_modbus::{Request as TmRequest, Response as TmResponse};

use crate::modbus::master::{EchoField, ReplyError};
use crate::modbus::{ExceptionCode, Request, Response};

/// The request in tokio-modbus's terms; `None` for FC 70 Collect, which only exists on an
/// RS-485 line (its replies come in time slots of a broadcast).
pub(crate) fn request(req: &Request) -> Option<TmRequest<'_>> {
    Some(match req {
        Request::ReadCoils { addr, count } => TmRequest::ReadCoils(*addr, *count),
        Request::ReadDiscreteInputs { addr, count } => TmRequest::ReadDiscreteInputs(*addr, *count),
        Request::ReadHoldingRegisters { addr, count } => {
            TmRequest::ReadHoldingRegisters(*addr, *count)
        }
        Request::ReadInputRegisters { addr, count } => TmRequest::ReadInputRegisters(*addr, *count),
        Request::WriteSingleCoil { addr, value } => TmRequest::WriteSingleCoil(*addr, *value),
        Request::WriteSingleRegister { addr, value } => {
            TmRequest::WriteSingleRegister(*addr, *value)
        }
        Request::WriteMultipleCoils { addr, values } => {
            TmRequest::WriteMultipleCoils(*addr, Cow::Borrowed(values))
        }
        Request::WriteMultipleRegisters { addr, values } => {
            TmRequest::WriteMultipleRegisters(*addr, Cow::Borrowed(values))
        }
        Request::MaskWriteRegister {
            addr,
            and_mask,
            or_mask,
        } => TmRequest::MaskWriteRegister(*addr, *and_mask, *or_mask),
        Request::Collect { .. } => return None,
    })
}

/// The exception a device (or a gateway for it) answered `req` with.
pub(crate) fn exception(req: &Request, code: tokio_modbus::ExceptionCode) -> Response {
    Response::Exception {
        function: req.function() as u8,
        code: ExceptionCode::from_u8(u8::from(code)),
    }
}

fn echo(field: EchoField, expected: u16, found: u16) -> Result<(), ReplyError> {
    if expected == found {
        Ok(())
    } else {
        Err(ReplyError::EchoMismatch {
            field,
            expected,
            found,
        })
    }
}

fn byte_count(expected: usize, found: usize) -> ReplyError {
    ReplyError::WrongByteCount {
        expected,
        found: u8::try_from(found).unwrap_or(u8::MAX),
    }
}

fn bits(mut got: Vec<bool>, count: u16) -> Result<Vec<bool>, ReplyError> {
    // tokio-modbus unpacks whole bytes: the padding bits of the last one come along.
    let count = usize::from(count);
    let bytes = count.div_ceil(8);
    if got.len().div_ceil(8) != bytes || got.len() < count {
        return Err(byte_count(bytes, got.len().div_ceil(8)));
    }
    got.truncate(count);
    Ok(got)
}

fn words(got: Vec<u16>, count: u16) -> Result<Vec<u16>, ReplyError> {
    if got.len() != usize::from(count) {
        return Err(byte_count(usize::from(count) * 2, got.len() * 2));
    }
    Ok(got)
}

/// `res` as our [`Response`] when it answers `req`; why not otherwise.
pub(crate) fn response(req: &Request, res: TmResponse) -> Result<Response, ReplyError> {
    let wrong = |res: &TmResponse| ReplyError::WrongFunction {
        expected: req.function() as u8,
        found: res.function_code().value(),
    };
    Ok(match (req, res) {
        (Request::ReadCoils { count, .. }, TmResponse::ReadCoils(v)) => {
            Response::ReadCoils(bits(v, *count)?)
        }
        (Request::ReadDiscreteInputs { count, .. }, TmResponse::ReadDiscreteInputs(v)) => {
            Response::ReadDiscreteInputs(bits(v, *count)?)
        }
        (Request::ReadHoldingRegisters { count, .. }, TmResponse::ReadHoldingRegisters(v)) => {
            Response::ReadHoldingRegisters(words(v, *count)?)
        }
        (Request::ReadInputRegisters { count, .. }, TmResponse::ReadInputRegisters(v)) => {
            Response::ReadInputRegisters(words(v, *count)?)
        }
        (Request::WriteSingleCoil { addr, value }, TmResponse::WriteSingleCoil(a, v)) => {
            echo(EchoField::Address, *addr, a)?;
            echo(EchoField::Value, u16::from(*value), u16::from(v))?;
            Response::WriteSingleCoil { addr: a, value: v }
        }
        (Request::WriteSingleRegister { addr, value }, TmResponse::WriteSingleRegister(a, v)) => {
            echo(EchoField::Address, *addr, a)?;
            echo(EchoField::Value, *value, v)?;
            Response::WriteSingleRegister { addr: a, value: v }
        }
        (Request::WriteMultipleCoils { addr, values }, TmResponse::WriteMultipleCoils(a, n)) => {
            echo(EchoField::Address, *addr, a)?;
            echo(EchoField::Quantity, values.len() as u16, n)?;
            Response::WriteMultipleCoils { addr: a, count: n }
        }
        (
            Request::WriteMultipleRegisters { addr, values },
            TmResponse::WriteMultipleRegisters(a, n),
        ) => {
            echo(EchoField::Address, *addr, a)?;
            echo(EchoField::Quantity, values.len() as u16, n)?;
            Response::WriteMultipleRegisters { addr: a, count: n }
        }
        (
            Request::MaskWriteRegister {
                addr,
                and_mask,
                or_mask,
            },
            TmResponse::MaskWriteRegister(a, and, or),
        ) => {
            echo(EchoField::Address, *addr, a)?;
            echo(EchoField::AndMask, *and_mask, and)?;
            echo(EchoField::OrMask, *or_mask, or)?;
            Response::MaskWriteRegister {
                addr: a,
                and_mask: and,
                or_mask: or,
            }
        }
        (_, res) => return Err(wrong(&res)),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coils_lose_their_padding_and_a_short_reply_is_refused() {
        let req = Request::ReadCoils { addr: 0, count: 3 };
        let padded = vec![true, false, true, false, false, false, false, false];
        assert_eq!(
            response(&req, TmResponse::ReadCoils(padded)),
            Ok(Response::ReadCoils(vec![true, false, true]))
        );
        let req = Request::ReadCoils { addr: 0, count: 9 };
        assert_eq!(
            response(&req, TmResponse::ReadCoils(vec![false; 8])),
            Err(ReplyError::WrongByteCount {
                expected: 2,
                found: 1
            })
        );
    }

    #[test]
    fn registers_echoes_and_functions_are_checked() {
        let req = Request::ReadHoldingRegisters { addr: 4, count: 2 };
        assert_eq!(
            response(&req, TmResponse::ReadHoldingRegisters(vec![1, 2])),
            Ok(Response::ReadHoldingRegisters(vec![1, 2]))
        );
        assert_eq!(
            response(&req, TmResponse::ReadHoldingRegisters(vec![1])),
            Err(ReplyError::WrongByteCount {
                expected: 4,
                found: 2
            })
        );
        assert_eq!(
            response(&req, TmResponse::ReadInputRegisters(vec![1, 2])),
            Err(ReplyError::WrongFunction {
                expected: 3,
                found: 4
            })
        );
        let req = Request::WriteSingleRegister { addr: 7, value: 9 };
        assert_eq!(
            response(&req, TmResponse::WriteSingleRegister(7, 8)),
            Err(ReplyError::EchoMismatch {
                field: EchoField::Value,
                expected: 9,
                found: 8
            })
        );
        assert!(request(&Request::Collect {
            first: 1,
            last: 2,
            slave_ack: 0,
            slave_seq: 0
        })
        .is_none());
    }
}
