//! The record's binary format, version 2 (version 1, which numbered a run's first cycle 0,
//! is read too, its numbers moved up by one).
//!
//! A record is a folder of segment files. Every segment stands on its own:
//!
//! ```text
//! segment  = MAGIC (8 bytes "SPLCREC\n") VERSION (u16 LE) block*
//! block    = length (u32 LE: kind byte + payload) crc (u32 LE: CRC-32C of kind + payload)
//!            kind (u8) payload
//! kinds    = 1 header    the project, the program's identity, the tag table, the run
//!            2 keyframe  the whole image (value and quality of every tag) and the forces
//!            3 cycles    cycle records, each relative to the one before it
//!            4 end       the run ended cleanly (its cycle count and dropped records)
//!            5 gap       cycles the recorder could not write (a full disk): the first and
//!                        the last missing; only right after a segment's keyframe
//! ```
//!
//! The header ends with the task's name when the project has several tasks (each task records
//! its own cycles in a record of its own); a header without it is a record of one task, as
//! every record written before tasks is. A reader that does not know the field ignores it.
//!
//! A segment opens with a header and a keyframe, written together (with a gap block when the
//! cycles before it could not be written); cycle blocks follow. A reader of a version without
//! the gap block stops at it as at a torn tail, which loses nothing before it. A
//! block is written whole or not at all as far as a reader can tell: a block whose length runs
//! past the end of the file or whose CRC does not match is a torn tail (a `kill -9`, a power
//! cut in the middle of a write), and the reader stops there, keeping every block before it.
//!
//! Numbers are LEB128 varints unless said otherwise (signed ones zig-zag encoded); strings
//! are a varint length and UTF-8. A value is one byte of type, quality and (for a bool) the
//! bit, then the value: u16 as 2 bytes LE, i32 as a zig-zag varint, f32 as its 4 bytes LE.
//!
//! A cycle record holds what the scan saw and did in one cycle:
//! `cycle delta, time delta (ns), dropped records before it, faulted (u8), events, seen,
//! wrote`: the control
//! requests applied at the boundary before it (force, unforce, write, reload), the tags whose
//! value or quality at the start of the logic differ from the state before (`seen`: the input
//! image, and the quality marks the scan put on other tags), and the tags whose value or
//! quality after the output phase differ from that (`wrote`: the program's outputs). A cycles
//! block starts with the absolute cycle number and time its first record's deltas count from.

mod dec;
mod enc;
mod frame;
#[cfg(test)]
mod tests;

use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};
use softplc_io::time::ScanInstant;

pub use dec::Dec;
pub use enc::Enc;
pub use frame::{frame, next_block, preamble, Framed};

/// The first bytes of every segment.
pub const MAGIC: &[u8; 8] = b"SPLCREC\n";
/// The format version this code writes and reads.
pub const VERSION: u16 = 2;
/// The format version before cycles were numbered from 1 (the reader shifts its numbers).
pub const VERSION_FROM_ZERO: u16 = 1;
/// Bytes before the first block: magic and version.
pub const PREAMBLE: usize = MAGIC.len() + 2;
/// Bytes of a block's frame before its kind byte: length and CRC.
pub const FRAME: usize = 8;
/// The largest block a reader accepts: anything longer is damage, not data.
pub const MAX_BLOCK: usize = 16 << 20;

/// A SHA-256 digest (the program's identity, the project file's).
pub type Digest = [u8; 32];

/// SHA-256 of `bytes`.
pub fn digest(bytes: &[u8]) -> Digest {
    use sha2::Digest as _;
    sha2::Sha256::digest(bytes).into()
}

/// A digest as people compare it: the first 12 hex digits (`sha256sum` prints them first).
pub fn short_hex(d: &Digest) -> String {
    d.iter().take(6).map(|b| format!("{b:02x}")).collect()
}

/// What a block holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BlockKind {
    /// [`Header`].
    Header = 1,
    /// [`Keyframe`].
    Keyframe = 2,
    /// Cycle records.
    Cycles = 3,
    /// [`End`].
    End = 4,
    /// [`Gap`].
    Gap = 5,
}

impl BlockKind {
    fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            1 => Self::Header,
            2 => Self::Keyframe,
            3 => Self::Cycles,
            4 => Self::End,
            5 => Self::Gap,
            _ => return None,
        })
    }
}

/// What a tag is to the scan, which decides what replay does with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TagRole {
    /// Read from a module: an input to replay.
    Input,
    /// A module output the program drives: compared by replay.
    Output,
    /// A memory tag: the program's own state, compared by replay.
    Memory,
    /// A module output whose rung runs in the module (push-down): its value is read back
    /// from the module, so to replay it is an input.
    Pushed,
}

impl TagRole {
    /// Whether the program computes it in the scan (what replay recomputes and compares).
    pub fn program_owned(self) -> bool {
        matches!(self, Self::Output | Self::Memory)
    }

    /// The word the summary and errors use.
    pub fn word(self) -> &'static str {
        match self {
            Self::Input => "input",
            Self::Output => "output",
            Self::Memory => "memory",
            Self::Pushed => "pushed-down output",
        }
    }

    fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            0 => Self::Input,
            1 => Self::Output,
            2 => Self::Memory,
            3 => Self::Pushed,
            _ => return None,
        })
    }
}

/// One tag of the header's tag table.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TagInfo {
    /// Its name.
    pub name: String,
    /// Its type.
    pub ty: ValueType,
    /// What it is to the scan.
    pub role: TagRole,
}

/// What a segment is a record of.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Header {
    /// The project's name.
    pub project: String,
    /// SHA-256 of the project file.
    pub project_hash: Digest,
    /// SHA-256 of the program's source (the program running when the segment began).
    pub program_hash: Digest,
    /// The program file, as the project names it.
    pub program_file: String,
    /// The scan period.
    pub period: Duration,
    /// Whether the run was on the virtual clock.
    pub virtual_clock: bool,
    /// The run: the wall-clock time it started (ns since the Unix epoch); every segment of a
    /// run has the same.
    pub run_id: u64,
    /// Wall-clock time (ns since the Unix epoch) of the PLC clock's zero: a cycle's wall time
    /// is this plus its scan time.
    pub wall_origin: u64,
    /// The segment's place in its run (0 = the run's first, whose keyframe is the state the
    /// first cycle started from: retained values, initial values, kept forces).
    pub segment: u32,
    /// Every tag, in project order.
    pub tags: Vec<TagInfo>,
    /// The task recorded, for a project of several tasks (each task records its own cycles);
    /// `None` for a project of one task. Written after the tag table only when present, so a
    /// record of one task is as before and a record written before tasks still reads.
    pub task: Option<String>,
}

/// The whole state at a segment's start.
#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    /// The cycle number of the next cycle.
    pub next_cycle: u64,
    /// The scan time of the state.
    pub now: ScanInstant,
    /// Every tag's value and quality, in tag order.
    pub slots: Vec<(Value, Quality)>,
    /// The forced tags and their values.
    pub forces: Vec<(u32, Value)>,
}

/// A control request applied at a cycle boundary.
#[derive(Debug, Clone, PartialEq)]
pub enum Event {
    /// A tag forced.
    Force {
        /// The tag.
        tag: u32,
        /// Its forced value.
        value: Value,
    },
    /// A tag's force removed.
    Unforce {
        /// The tag.
        tag: u32,
    },
    /// Every force removed.
    UnforceAll,
    /// Tags written (all at once).
    Write {
        /// Tags and values.
        values: Vec<(u32, Value)>,
    },
    /// A new program swapped in.
    Reload {
        /// Its identity.
        program_hash: Digest,
    },
}

/// A tag whose value or quality changed.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Change {
    /// The tag.
    pub tag: u32,
    /// Its value.
    pub value: Value,
    /// Its quality.
    pub quality: Quality,
}

/// What one cycle saw and did.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CycleRecord {
    /// The cycle number (1 = the run's first, as the scan numbers it).
    pub cycle: u64,
    /// The cycle's timestamp: what the logic saw as `now`.
    pub now: ScanInstant,
    /// Records dropped just before this one (the writer fell behind): a gap. After a gap
    /// `seen` lists every tag.
    pub dropped_before: u64,
    /// The program faulted in this cycle: the run stopped here, `wrote` holds nothing.
    pub faulted: bool,
    /// Control requests applied at the boundary before the cycle.
    pub events: Vec<Event>,
    /// Changes at the start of the logic.
    pub seen: Vec<Change>,
    /// Changes after the output phase.
    pub wrote: Vec<Change>,
}

/// The clean end of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct End {
    /// Cycles the run completed.
    pub cycles: u64,
    /// Records dropped over the run.
    pub dropped: u64,
}

/// Cycles missing from the record before a segment: the recorder could not write them (a
/// full disk) and resumed with this segment's keyframe.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Gap {
    /// The first cycle missing.
    pub first: u64,
    /// The last cycle missing.
    pub last: u64,
}

/// Why bytes did not decode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The bytes end inside an item.
    #[error("truncated")]
    Truncated,
    /// A varint longer than 64 bits.
    #[error("a number longer than 64 bits")]
    Overlong,
    /// An unknown item tag.
    #[error("unknown {what} {byte}")]
    Unknown {
        /// What was read.
        what: &'static str,
        /// Its byte.
        byte: u8,
    },
    /// A string that is not UTF-8.
    #[error("a name that is not UTF-8")]
    Utf8,
    /// A tag number beyond the tag table.
    #[error("tag number {tag} beyond the tag table")]
    TagRange {
        /// The number.
        tag: u32,
    },
}

pub(super) fn type_code(ty: ValueType) -> u8 {
    match ty {
        ValueType::Bool => 0,
        ValueType::U16 => 1,
        ValueType::I32 => 2,
        ValueType::F32 => 3,
    }
}

pub(super) fn type_from(b: u8) -> Option<ValueType> {
    Some(match b {
        0 => ValueType::Bool,
        1 => ValueType::U16,
        2 => ValueType::I32,
        3 => ValueType::F32,
        _ => return None,
    })
}
