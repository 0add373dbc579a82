//! The simulated world: module simulators on a virtual multidrop line, plant models that close
//! the loop from outputs to inputs, and a host that serves simulators on a real serial device.
//!
//! A simulator runs its module's internal behaviour on its own tick (MiniMod: 1 ms) and is
//! advanced lazily to the time of each interaction, so it gives the same answers on a virtual
//! clock as in real time.

pub mod device;
pub mod fault;
pub mod line;
pub mod plant;
pub mod serve;
pub mod serve_tcp;

pub use device::{SimDevice, SimError, SimReply};
