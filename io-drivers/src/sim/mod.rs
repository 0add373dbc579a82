//! The simulated world: module simulators on a virtual multidrop line, plant models that close
//! the loop from outputs to inputs, and a host that serves simulators on a real serial device.
//!
//! A simulator runs its module's internal behaviour on its own tick (MiniMod: 1 ms) and is
//! advanced lazily to the time of each interaction, so it gives the same answers on a virtual
//! clock as in real time.

pub(crate) mod device;
pub(crate) mod fault;
pub(crate) mod framing;
pub(crate) mod line;
pub mod plant;
pub(crate) mod serve;
pub(crate) mod serve_tcp;

pub use device::{SimDevice, SimError, SimReply};
pub use fault::{Fault, FaultRule, Frequency, LineFaults, Wire};
pub use line::{SharedWorld, SimEcho, SimWorld, VirtualPort};
pub use serve::{complete_frame, serve, serve_following, tty_settings, ServeStats, SERVED_LINE};
pub use serve_tcp::serve_tcp;
