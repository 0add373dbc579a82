//! The Modbus RTU side of the EX-9053D-M simulator ("9053-M Modbus mapping").
//!
//! Two requests are taken apart before the generic server ([`crate::modbus::server::serve`]
//! over [`super::map`]):
//! - **FC 0x46** to this unit: sub-function 00 reads the name (`AA 46 00` →
//!   `AA 46 00 00 90 53 00`), sub-function 04 stores a new address for the next reboot
//!   (`AA 46 04 NN 00 00 00`, echoed: the manual gives no reply, the echo is the usual form).
//!   Only frames addressed to this unit are read this way; FC 0x46 to another unit or to the
//!   broadcast address is ignored, so MiniMod's Collect (also function 70 = 0x46, broadcast
//!   with its window) on the same line is left alone. Other sub-functions get exception 01,
//!   a wrong length 03, an address outside 1..=247 03.
//! - **Host OK**: FC 3 or FC 4 at 0x3038 with quantity 0 (312345 / 412345), to this unit or
//!   broadcast: the watchdog restarts, nothing is answered.
//!
//! Everything else follows Modbus over Serial Line: a bad CRC is silence, another unit is
//! silence, a broadcast acts without an answer, a refused request gets its exception.

use crate::modbus::crc::{append_crc, check_crc};
use crate::modbus::server::{decode_request, encode_response, exception_frame, serve};
use crate::modbus::{ExceptionCode, Response};

use super::map::{FC_MODULE, NAME_WORDS, REG_HOST_OK, SUB_READ_NAME, SUB_SET_ADDRESS};
use super::state::Ex9053State;

/// The module's answer to one frame, or `None` for silence.
pub(crate) fn answer(state: &mut Ex9053State, frame: &[u8]) -> Option<Vec<u8>> {
    if !check_crc(frame) {
        return None;
    }
    let me = state.running().address;
    let for_me = |unit: u8| unit != 0 && unit == me;
    let (&unit, rest) = frame.split_first()?;
    let pdu = rest.get(..rest.len().checked_sub(2)?)?;
    let [host_hi, host_lo] = REG_HOST_OK.to_be_bytes();
    match pdu {
        [FC_MODULE, sub @ ..] => return for_me(unit).then(|| module_function(state, me, sub)),
        [3 | 4, hi, lo, 0, 0] if (*hi, *lo) == (host_hi, host_lo) => {
            if unit == 0 || for_me(unit) {
                state.host_ok();
            }
            return None;
        }
        _ => {}
    }
    let mut out = Vec::with_capacity(16);
    match decode_request(frame) {
        Ok((0, req)) => {
            serve(state, &req);
            None
        }
        Ok((unit, req)) if for_me(unit) => {
            encode_response(unit, &serve(state, &req), &mut out);
            Some(out)
        }
        Ok(_) => None,
        Err(e) => {
            let (unit, out) = exception_frame(&e)?;
            for_me(unit).then_some(out)
        }
    }
}

/// FC 0x46 after the function byte.
fn module_function(state: &mut Ex9053State, me: u8, sub: &[u8]) -> Vec<u8> {
    let mut out = Vec::with_capacity(10);
    let exception = |code: ExceptionCode, out: &mut Vec<u8>| {
        let resp = Response::Exception {
            function: FC_MODULE,
            code,
        };
        encode_response(me, &resp, out);
    };
    match sub {
        [SUB_READ_NAME] => {
            out.extend_from_slice(&[me, FC_MODULE, SUB_READ_NAME]);
            for w in NAME_WORDS {
                out.extend_from_slice(&w.to_be_bytes());
            }
            append_crc(&mut out);
        }
        [SUB_SET_ADDRESS, nn, 0, 0, 0] => match state.set_stored_address(u16::from(*nn)) {
            Ok(()) => {
                out.extend_from_slice(&[me, FC_MODULE, SUB_SET_ADDRESS, *nn, 0, 0, 0]);
                append_crc(&mut out);
            }
            Err(_) => exception(ExceptionCode::IllegalDataValue, &mut out),
        },
        [SUB_READ_NAME | SUB_SET_ADDRESS, ..] => {
            exception(ExceptionCode::IllegalDataValue, &mut out)
        }
        _ => exception(ExceptionCode::IllegalFunction, &mut out),
    }
    out
}
