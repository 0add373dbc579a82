//! Modbus RTU, our own sans-IO codec (DESIGN.md principle 4).
//!
//! - [`pdu`]: typed requests, responses and exception codes; [`UnitId`].
//! - [`crc`]: the CRC-16/MODBUS checksum.
//! - [`master`]: encodes request frames and reassembles and verifies reply frames, with a
//!   length table per function code, so a fragmented reply is joined and a corrupted or foreign
//!   one is refused.
//! - [`server`]: the device side used by the simulators: splits a byte stream into request
//!   frames and answers them from a [`server::RegisterBank`].
//!
//! Addresses in this module are protocol addresses: 0-based. Manual references such as 40001
//! are 1-based; the register maps in `devices/` give both.

pub mod crc;
pub mod master;
pub mod pdu;
pub mod server;

pub use pdu::{ExceptionCode, FunctionCode, Request, Response, UnitId};
