//! Reading a record: its segments in order, each up to its last good block.
//!
//! A segment whose tail is torn (a `kill -9` or a power cut in the middle of a write) is read
//! up to the last block whose length and CRC are whole, and the rest is reported, not an
//! error: that is what a crash leaves, and what comes before it is the interesting part. A
//! file that is not a segment at all, or of a newer format, is an error naming the file.

use std::fmt;
use std::path::{Path, PathBuf};

use crate::recorder::format::{
    self, BlockKind, CycleRecord, Dec, DecodeError, End, Framed, Gap, Header, Keyframe,
};
use crate::recorder::writer::{segments_in, SEGMENT_EXT};

/// Where a segment stops before its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Torn {
    /// The offset of the first byte not read.
    pub offset: usize,
    /// Bytes after it, ignored.
    pub ignored: usize,
}

/// One segment file, read.
#[derive(Debug, Clone, PartialEq)]
pub struct Segment {
    /// Its file.
    pub path: PathBuf,
    /// What it is a record of.
    pub header: Header,
    /// The state at its start.
    pub keyframe: Keyframe,
    /// The cycles missing just before it (the recorder could not write them).
    pub gap: Option<Gap>,
    /// Its cycles, in order.
    pub cycles: Vec<CycleRecord>,
    /// The run's clean end, when the run ended in this segment.
    pub end: Option<End>,
    /// Where its good blocks stop, when they stop before the file's end.
    pub torn: Option<Torn>,
}

/// Why a file is not a readable segment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SegmentError {
    /// It cannot be read.
    #[error("cannot read it ({0})")]
    Io(std::io::ErrorKind),
    /// It does not start as a segment does.
    #[error("not a softplc record segment")]
    NotASegment,
    /// It is of another format version.
    #[error("a record of format version {0}; this softplc reads versions {from} and {v}", from = format::VERSION_FROM_ZERO, v = format::VERSION)]
    Version(u16),
    /// Its header or keyframe is missing or damaged (a file cut right after its creation).
    #[error("its header or keyframe is incomplete or damaged")]
    NoStart,
    /// Its header or keyframe does not decode.
    #[error("its start does not decode: {0}")]
    BadStart(DecodeError),
}

/// A file that could not be read, and why.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FileError {
    /// The file.
    pub path: PathBuf,
    /// Why.
    pub error: SegmentError,
}

impl fmt::Display for FileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.path.display(), self.error)
    }
}

impl std::error::Error for FileError {}

/// Reads one segment, up to its last good block.
pub(crate) fn read_segment(path: &Path) -> Result<Segment, FileError> {
    let fail = |error| FileError {
        path: path.to_path_buf(),
        error,
    };
    let bytes = std::fs::read(path).map_err(|e| fail(SegmentError::Io(e.kind())))?;
    parse_segment(path, &bytes).map_err(fail)
}

fn parse_segment(path: &Path, bytes: &[u8]) -> Result<Segment, SegmentError> {
    if bytes.len() < format::PREAMBLE || &bytes[..format::MAGIC.len()] != format::MAGIC {
        return Err(SegmentError::NotASegment);
    }
    let version = u16::from_le_bytes([bytes[8], bytes[9]]);
    if version != format::VERSION && version != format::VERSION_FROM_ZERO {
        return Err(SegmentError::Version(version));
    }
    let mut at = format::PREAMBLE;
    let Framed::Block(BlockKind::Header, h, next) = format::next_block(bytes, at) else {
        return Err(SegmentError::NoStart);
    };
    let header = Dec::new(h).header().map_err(SegmentError::BadStart)?;
    at = next;
    let Framed::Block(BlockKind::Keyframe, k, next) = format::next_block(bytes, at) else {
        return Err(SegmentError::NoStart);
    };
    let keyframe = Dec::new(k)
        .keyframe(header.tags.len())
        .map_err(SegmentError::BadStart)?;
    at = next;
    let mut gap = None;
    if let Framed::Block(BlockKind::Gap, g, next) = format::next_block(bytes, at) {
        gap = Some(Dec::new(g).gap().map_err(SegmentError::BadStart)?);
        at = next;
    }
    let mut segment = Segment {
        path: path.to_path_buf(),
        header,
        keyframe,
        gap,
        cycles: Vec::new(),
        end: None,
        torn: None,
    };
    let tags = segment.header.tags.len();
    loop {
        let decoded = match format::next_block(bytes, at) {
            Framed::Eof => break,
            Framed::Torn => None,
            Framed::Block(BlockKind::Cycles, payload, next) => {
                Dec::new(payload).cycles(tags).ok().map(|mut c| {
                    segment.cycles.append(&mut c);
                    next
                })
            }
            Framed::Block(BlockKind::End, payload, next) => Dec::new(payload).end().ok().map(|e| {
                segment.end = Some(e);
                next
            }),
            // A second header or keyframe is not something this version writes.
            Framed::Block(_, _, _) => None,
        };
        match decoded {
            Some(next) => at = next,
            None => {
                segment.torn = Some(Torn {
                    offset: at,
                    ignored: bytes.len() - at,
                });
                break;
            }
        }
    }
    if version == format::VERSION_FROM_ZERO {
        // Version 1 numbered a run's first cycle 0; cycle N is the N-th scan now.
        segment.keyframe.next_cycle += 1;
        for c in &mut segment.cycles {
            c.cycle += 1;
        }
    }
    Ok(segment)
}

/// A record: the segments of a folder (or one segment file), oldest first.
#[derive(Debug, Clone, PartialEq)]
pub struct Record {
    /// The segments read.
    pub segments: Vec<Segment>,
}

/// Why a record cannot be read at all.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RecordError {
    /// The path does not exist or cannot be listed.
    #[error("{}: no record there ({kind})", path.display())]
    Missing {
        /// The path.
        path: PathBuf,
        /// The OS error.
        kind: std::io::ErrorKind,
    },
    /// A folder without segments.
    #[error("{}: no record segments (*.{SEGMENT_EXT}) in this folder", path.display())]
    Empty {
        /// The folder.
        path: PathBuf,
    },
    /// A segment cannot be read.
    #[error("{0}")]
    Segment(#[from] FileError),
}

/// Reads the record at `path`: a record folder, or a single segment file.
pub fn read_record(path: &Path) -> Result<Record, RecordError> {
    let meta = std::fs::metadata(path).map_err(|e| RecordError::Missing {
        path: path.to_path_buf(),
        kind: e.kind(),
    })?;
    if !meta.is_dir() {
        return Ok(Record {
            segments: vec![read_segment(path)?],
        });
    }
    let files = segments_in(path);
    if files.is_empty() {
        return Err(RecordError::Empty {
            path: path.to_path_buf(),
        });
    }
    let mut segments = Vec::with_capacity(files.len());
    for (i, f) in files.iter().enumerate() {
        match read_segment(&f.path) {
            Ok(s) => segments.push(s),
            // The newest segment may be cut right after its creation by a crash: it holds
            // no cycle yet, so nothing is lost by leaving it out.
            Err(e) if i + 1 == files.len() && e.error == SegmentError::NoStart => {}
            Err(e) => return Err(e.into()),
        }
    }
    Ok(Record { segments })
}

impl Record {
    /// The record cut where replay must start afresh: a new run (the PLC restarted), a
    /// segment missing, a gap (cycles the recorder could not write), or a torn segment before
    /// the next one. Each part is consecutive
    /// segments of one run, the first of them starting from its keyframe.
    pub fn parts(&self) -> Vec<&[Segment]> {
        let mut parts = Vec::new();
        let mut start = 0;
        for i in 1..=self.segments.len() {
            let cut = i == self.segments.len() || {
                let (a, b) = (&self.segments[i - 1], &self.segments[i]);
                a.header.run_id != b.header.run_id
                    || b.header.segment != a.header.segment + 1
                    || b.gap.is_some()
                    || a.torn.is_some()
            };
            if cut {
                parts.push(&self.segments[start..i]);
                start = i;
            }
        }
        parts
    }

    /// Every cycle record, in order.
    pub fn cycles(&self) -> impl Iterator<Item = &CycleRecord> {
        self.segments.iter().flat_map(|s| s.cycles.iter())
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;
    use std::time::Duration;

    use super::parse_segment;
    use crate::recorder::format::{
        frame, preamble, BlockKind, CycleRecord, Enc, Header, Keyframe, VERSION_FROM_ZERO,
    };
    use softplc_io::time::ScanInstant;

    /// A segment whose one cycle is numbered 5, its keyframe's next cycle 5.
    fn segment() -> Vec<u8> {
        let header = Header {
            project: "p".into(),
            project_hash: crate::recorder::format::digest(b"project"),
            program_hash: crate::recorder::format::digest(b"program"),
            program_file: "p.expr".into(),
            period: Duration::from_millis(10),
            virtual_clock: true,
            run_id: 1,
            wall_origin: 0,
            segment: 0,
            tags: vec![],
            task: None,
        };
        let keyframe = Keyframe {
            next_cycle: 5,
            now: ScanInstant::after_origin(Duration::from_millis(40)),
            slots: vec![],
            forces: vec![],
        };
        let record = CycleRecord {
            cycle: 5,
            now: ScanInstant::after_origin(Duration::from_millis(40)),
            ..CycleRecord::default()
        };
        let mut block = Enc::cycles_block(5, record.now);
        block.cycle(&record, (5, record.now));
        let mut bytes = preamble();
        bytes.extend(frame(BlockKind::Header, &Enc::header(&header)));
        bytes.extend(frame(BlockKind::Keyframe, &Enc::keyframe(&keyframe)));
        bytes.extend(frame(BlockKind::Cycles, &block.0));
        bytes
    }

    #[test]
    fn a_version_1_record_numbered_from_0_is_read_numbered_from_1() {
        let now = parse_segment(Path::new("s"), &segment()).unwrap();
        assert_eq!(now.keyframe.next_cycle, 5);
        assert_eq!(now.cycles[0].cycle, 5);
        let mut old = segment();
        old[8..10].copy_from_slice(&VERSION_FROM_ZERO.to_le_bytes());
        let old = parse_segment(Path::new("s"), &old).unwrap();
        assert_eq!(old.keyframe.next_cycle, 6);
        assert_eq!(old.cycles[0].cycle, 6, "its first cycle 0 is cycle 1 now");
    }
}
