//! RS-485 lines: serial settings and the wire-time model, transports, and the bus owner.
//!
//! - [`settings`]: baud and character format, and DESIGN.md's timing model.
//! - [`transport`]: the byte pipe a bus owner drives: a real serial port or the virtual line.
//! - [`bus`]: the bus owner: runs drivers' transactions on one line with its discipline
//!   (response timeout, t3.5 gap, guard + flush after a timeout, retries, counters).
//! - [`link`]: how the scan drives a line on either clock, against one deadline per phase.
//! - [`collect`]: FC 70 Collect rounds for the modules in event mode (MiniMod).
//! - [`echo`]: adapters that hear their own transmission (`echo: discard`).
//! - [`latency`]: USB adapters' latency timer: read, lowered, and counted in the budget.
//! - [`tcp`]: buses over TCP: Modbus TCP (`tcp://`) and RTU over TCP (`rtu+tcp://`).

pub mod budget;
pub mod bus;
pub mod collect;
pub mod echo;
pub mod health;
pub mod latency;
pub mod link;
pub mod settings;
pub mod tcp;
pub mod transport;

pub use settings::{LineSettings, Parity, SerialFormat};
