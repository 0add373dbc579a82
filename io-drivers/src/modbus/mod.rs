//! Modbus RTU, our own sans-IO codec (DESIGN.md principle 4).
//!
//! - [`Request`], [`Response`], [`ExceptionCode`]: typed requests, responses and exception
//!   codes; [`UnitId`].
//! - [`append_crc`], [`check_crc`]: the CRC-16/MODBUS checksum.
//! - [`encode_request`], [`ReplyAssembler`]: encodes request frames and reassembles and
//!   verifies reply frames, with a length table per function code, so a fragmented reply is
//!   joined and a corrupted or foreign one is refused ([`ReplyError`]).
//! - [`decode_request`], [`request_frame_len`]: the device side used by the simulators: splits
//!   a byte stream into request frames, answered ([`serve`], [`encode_response`]) from a
//!   [`RegisterBank`].
//!
//! Addresses in this module are protocol addresses: 0-based. Manual references such as 40001
//! are 1-based; the register maps in `devices/` give both.

pub(crate) mod crc;
pub(crate) mod master;
pub(crate) mod pdu;
pub(crate) mod server;

pub use crc::{append_crc, check_crc};
pub use master::{encode_request, EchoField, EncodeError, Progress, ReplyAssembler, ReplyError};
pub use pdu::{ExceptionCode, FunctionCode, Request, Response, UnitId};
pub use server::{
    decode_request, encode_response, request_frame_len, serve, FrameLen, RegisterBank, RequestError,
};
