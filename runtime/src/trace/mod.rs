//! Trace, as CODESYS has it: chosen signals (tags, module counters, phase times) sampled at
//! every cycle boundary into a ring buffer around a trigger, then saved as CSV or VCD.
//!
//! - definitions: the project's `traces:` (`crate::project::trace`), or given at run time;
//! - `capture`: one armed trace, its ring and its trigger's state machine;
//! - `set`: the traces of a running PLC (of one task of several), stepped by the service's
//!   cycle boundary; `ledger`: the traces armed in every task, against the PLC's one budget;
//! - `data`: a trace's samples taken out of the scan;
//! - `export`: the CSV and VCD writers (also used by the replay).
//!
//! Samples are taken on the scan thread from the process image, with the cycle's timestamp
//! (the time its logic saw) on the PLC's clock, so a trace on the virtual clock is the same at
//! every run.

pub(crate) mod capture;
pub(crate) mod data;
pub(crate) mod export;
pub(crate) mod ledger;
pub(crate) mod set;

pub use capture::{Capture, Moment, TraceState};
pub use data::{SignalInfo, TraceData};
pub use export::{CsvWriter, ExportError, Sample, Signal, Timescale, VcdWriter};
pub use ledger::TraceLedger;
pub use set::{TraceRefusal, TraceSet, TraceStatus};
