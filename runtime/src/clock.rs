//! Time for the PLC. The [`Clock`] trait lives in `softplc-io` because lines and simulators
//! need it too; the runtime re-exports it so programs and tests name it from here.

pub use softplc_io::time::{Clock, MonotonicClock, VirtualClock};
