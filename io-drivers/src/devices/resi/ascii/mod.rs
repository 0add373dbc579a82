//! The RESI ASCII protocol, one implementation for every model (manual 5.12–5.13, 10.12–10.13
//! and the same sections of each chapter; resi-spec §2).
//!
//! - [`frame`]: `#[addr,]CMD[:p1,p2]` + CR, numbers, the address echo.
//! - `command`: the command table type, the commands common to every model, name matching
//!   (short and long forms, channel numbers).
//! - `serve`: the module side, dispatching a request to the state through the table.
//!
//! The driver side builds its requests and reads its answers with the same table
//! (`super::driver`).

pub(crate) mod command;
pub(crate) mod frame;
pub(crate) mod sensor_config;
pub(crate) mod serve;

pub use super::driver::ascii::{answer_values, is_ok, request};
pub use command::{find, Action, Command, Field, Fmt, Op, Text, COMMON};
pub use frame::{frame, parse_number};
