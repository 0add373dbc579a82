//! The scan: the PLC's heartbeat (DESIGN.md principle 1).
//!
//! One dedicated OS thread runs cycles on absolute deadlines (`next += period`, never
//! sleep-after-work): read inputs → run logic → write outputs, each phase timed into an HDR
//! histogram. A cycle that runs past its successor's deadline skips to the next deadline still
//! ahead and counts the skipped ones as overruns. The task watchdog (time + sensitivity, as
//! CODESYS defines it) faults the PLC to its safe state.
//!
//! The scan depends on the PLC it drives and on nothing above it: whatever else touches the
//! PLC (the service's control requests, reloads, systemd, the snapshot for the network
//! services) does so through a [`CycleBoundary`], called between cycles on the scan thread.

pub mod boundary;
pub mod engine;
mod overrun;
pub mod rt;
pub mod stats;
pub mod watchdog;

pub use boundary::CycleBoundary;
pub use engine::{RunOutcome, ScanEngine, StatusSnapshot, StopReason};
pub use stats::{fmt_duration, DurationHistogram, LastCycle, Percentiles, ScanStats};
