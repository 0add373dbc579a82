//! softplc-io: everything that talks to I/O modules.
//!
//! Layers, bottom up (see DESIGN.md):
//! - [`time`]: the [`time::Clock`] trait (monotonic or virtual) every timed part shares.
//! - [`line`]: serial settings and the wire-time model, transports (a real serial port or the
//!   virtual multidrop line) and the bus owner that runs transactions on one line.
//! - [`modbus`]: the sans-IO Modbus RTU codec, master side (requests out, replies verified and
//!   reassembled) and server side (what the simulators answer).
//! - [`devices`]: one folder per module family: register map, driver (sans-IO), simulator.
//! - [`sim`]: the simulated world: devices on a virtual line, plant models, serving on a pty.
//! - [`wire`]: seeing the wire: one frame decoder (every protocol), the bus owner's frame
//!   trace and the framing of a passively heard line.
//!
//! This crate never depends on the runtime: drivers never see logic.

pub mod devices;
pub mod driver;
pub mod line;
pub mod modbus;
pub mod point;
pub mod sim;
pub mod time;
pub mod wire;
