//! Running a machine: the control interface of a running instance, systemd integration.
//!
//! The service sits above the scan: the scan calls it between cycles through
//! [`crate::scan::CycleBoundary`], which [`boundary::ServiceBoundary`] implements, and knows
//! nothing of what it does there.
//!
//! - `boundary`: what runs at each cycle boundary: control requests, reloads, sd_notify, the
//!   snapshot.
//! - [`control`]: the local control interface (a Unix socket, one JSON request per line):
//!   status, force, unforce, reload. Requests are applied by the scan thread at a cycle
//!   boundary, so they never race a scan.
//! - `notify`: `sd_notify` (READY after the first complete scan, WATCHDOG after each
//!   completed scan, STATUS, STOPPING).
//! - [`alarms`]: the tags' and modules' alarms, evaluated from every cycle's changes on a
//!   thread of their own, acknowledged through the scan's requests, with their history file.
//! - `status`: the status a running instance reports; `health`: the state of every service
//!   (running, degraded, stopped, with the reason) it includes, as do the metrics and the page.
//! - `trace`: the control socket's trace requests (arm, status, save).
//! - `snapshot`: what the scan publishes, without blocking, for the two network services:
//!   `metrics` (a Prometheus text endpoint) and `modbus_tcp` (a Modbus TCP server for
//!   SCADA/HMI, with its address map in `modbus_map` and its input checks in
//!   `modbus_guard`) and [`web`] (the web page: live I/O, forcing, the program with live
//!   values, timing plots); `network` starts them. [`mqtt`] (a Sparkplug B edge node) and
//!   `opcua` (an OPC UA server) read the same snapshot for births and diagnostics, and take
//!   every cycle's tag changes, in order, from `changes` (a bounded queue each, fed at the
//!   cycle boundary; a consumer that falls behind loses changes visibly).

pub(crate) mod accepting;
pub mod alarms;
pub mod audit;
pub(crate) mod boundary;
pub(crate) mod changes;
pub mod control;
pub(crate) mod health;
pub(crate) mod json_lines;
pub(crate) mod metrics;
pub(crate) mod modbus_guard;
pub(crate) mod modbus_map;
pub(crate) mod modbus_tcp;
#[cfg(feature = "mqtt")]
pub mod mqtt;
pub(crate) mod network;
pub(crate) mod notify;
#[cfg(feature = "opcua")]
pub(crate) mod opcua;
pub(crate) mod slots;
pub(crate) mod snapshot;
pub(crate) mod socket;
pub(crate) mod status;
pub(crate) mod task_router;
pub(crate) mod task_share;
pub(crate) mod trace;
pub mod web;

pub use boundary::ServiceBoundary;
pub use health::{Health, PerTask, Service, ServiceReport, ServiceState};
pub use metrics::parse_head as parse_metrics_head;
pub use modbus_guard::{check_pdu, whole_frames, Malformed};
pub use notify::Notifier;
pub use snapshot::{
    HistogramView, ModuleSnapshot, PhaseSummary, Publisher, ServiceSnapshot, SnapshotCell,
};
pub use status::{
    LostChanges, MicrosPercentiles, ModuleReport, PlantReport, StatusReport, TagReport, TaskReport,
    TaskStatus,
};
pub use trace::TraceRequest;
