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

pub(crate) mod boundary;
pub(crate) mod engine;
mod overrun;
pub(crate) mod rt;
pub(crate) mod stats;
pub(crate) mod tasks;
pub(crate) mod watchdog;

pub use boundary::CycleBoundary;
pub use engine::{CycleHook, Run, RunOutcome, ScanEngine, StatusSnapshot, StopReason, TaskHalt};
pub use rt::{apply as apply_realtime, RealtimeNote, RealtimeOutcome};
pub use stats::{
    fmt_duration, DurationHistogram, LastCycle, LineInstant, Percentiles, ScanInstant, ScanStats,
};
pub use tasks::{Task, TaskControl, TaskOutcome, TaskSet};
pub use watchdog::WatchdogTrip;
