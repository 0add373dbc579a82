//! The flight recorder: a bounded, rotating, crash-safe record of what the scan saw, and its
//! replay.
//!
//! Every cycle the scan hands the recorder its number and timestamp, the changes of the image
//! at the start of the logic (the inputs, as the logic saw them), the changes after the output
//! phase (what the program wrote) and the control requests applied at the boundary before it
//! (force, unforce, write, reload with the new program's identity). The scan's side
//! (`tap`) only diffs and `try_send`s into a bounded channel; the writer (`writer`) runs
//! on its own thread and cuts the record into checksummed blocks and bounded segments
//! ([`format`](mod@format)), deleting the oldest beyond `keep` and the size bound. `reader` reads a
//! record back, up to the last good block of a torn tail; [`replay`] re-runs a program on it.
//!
//! A project of several tasks has a record per task (one PLC per task, each its own recorder):
//! the header names the task, and the tags the task copies in from the others are inputs of
//! its record, so [`replay`] of one task needs no other ([`ReplaySubject`]).
//!
//! The recorder sits beside the PLC it records, below it: [`crate::plc::Plc::record`] wires
//! it in, and nothing here knows of the scan loop or the service.

pub mod format;
pub(crate) mod reader;
pub(crate) mod replay;
pub(crate) mod tap;
pub(crate) mod writer;

pub use reader::{read_record, FileError, Record, RecordError, Segment, SegmentError, Torn};
pub use replay::{
    replay, replay_subject, CycleOutputs, Difference, ReplayError, ReplayOptions, ReplayReport,
    ReplaySubject, TagDifference,
};
pub use tap::Tap;
pub use writer::{
    segments_in, Disk, FaultDisk, FileDisk, RecorderHandle, SegmentFile, Settings, WriterOutcome,
    WriterState, MAX_BACKOFF,
};
