//! Running a machine: the control interface of a running instance, systemd integration.
//!
//! - [`control`]: the local control interface (a Unix socket, one JSON request per line):
//!   status, force, unforce, reload. Requests are applied by the scan thread at a cycle
//!   boundary, so they never race a scan.
//! - [`notify`]: `sd_notify` (READY after the first complete scan, WATCHDOG after each
//!   completed scan, STATUS, STOPPING).
//! - [`status`]: the status a running instance reports.

pub mod control;
pub mod notify;
pub mod status;
