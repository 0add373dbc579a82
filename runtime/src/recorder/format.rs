//! The record's binary format, version 1.
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
//! ```
//!
//! A segment opens with a header and a keyframe, written together; cycle blocks follow. A
//! block is written whole or not at all as far as a reader can tell: a block whose length runs
//! past the end of the file or whose CRC does not match is a torn tail (a `kill -9`, a power
//! cut in the middle of a write), and the reader stops there, keeping every block before it.
//!
//! Numbers are LEB128 varints unless said otherwise (signed ones zig-zag encoded); strings
//! are a varint length and UTF-8. A value is one byte of type, quality and (for a bool) the
//! bit, then the value: u16 as 2 bytes LE, i32 as a zig-zag varint, f32 as its 4 bytes LE.
//!
//! A cycle record holds what the scan saw and did in one cycle:
//! `cycle delta, time delta (ns), dropped records before it, events, seen, wrote`: the control
//! requests applied at the boundary before it (force, unforce, write, reload), the tags whose
//! value or quality at the start of the logic differ from the state before (`seen`: the input
//! image, and the quality marks the scan put on other tags), and the tags whose value or
//! quality after the output phase differ from that (`wrote`: the program's outputs). A cycles
//! block starts with the absolute cycle number and time its first record's deltas count from.

use std::time::Duration;

use softplc_io::point::{Quality, Value, ValueType};

/// The first bytes of every segment.
pub const MAGIC: &[u8; 8] = b"SPLCREC\n";
/// The format version this code writes and reads.
pub const VERSION: u16 = 1;
/// Bytes before the first block: magic and version.
pub const PREAMBLE: usize = MAGIC.len() + 2;
/// Bytes of a block's frame before its kind byte: length and CRC.
pub const FRAME: usize = 8;
/// The largest block a reader accepts: anything longer is damage, not data.
pub const MAX_BLOCK: usize = 16 << 20;

const CASTAGNOLI: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);

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
}

impl BlockKind {
    fn from_u8(b: u8) -> Option<Self> {
        Some(match b {
            1 => Self::Header,
            2 => Self::Keyframe,
            3 => Self::Cycles,
            4 => Self::End,
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
}

/// The whole state at a segment's start.
#[derive(Debug, Clone, PartialEq)]
pub struct Keyframe {
    /// The cycle number of the next cycle.
    pub next_cycle: u64,
    /// The scan time of the state.
    pub now: Duration,
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
    /// The cycle number (0 = the run's first).
    pub cycle: u64,
    /// The cycle's timestamp: what the logic saw as `now`.
    pub now: Duration,
    /// Records dropped just before this one (the writer fell behind): a gap. After a gap
    /// `seen` lists every tag.
    pub dropped_before: u64,
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

/// A growing encoded block.
#[derive(Debug, Default, Clone)]
pub struct Enc(pub Vec<u8>);

impl Enc {
    fn u8(&mut self, b: u8) {
        self.0.push(b);
    }

    fn varint(&mut self, mut v: u64) {
        loop {
            let byte = (v & 0x7f) as u8;
            v >>= 7;
            if v == 0 {
                self.0.push(byte);
                return;
            }
            self.0.push(byte | 0x80);
        }
    }

    fn nanos(&mut self, d: Duration) {
        self.varint(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
    }

    fn str(&mut self, s: &str) {
        self.varint(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
    }

    fn value(&mut self, v: Value, q: Quality) {
        let q = match q {
            Quality::Good => 0u8,
            Quality::Stale => 1,
            Quality::Bad => 2,
        } << 2;
        match v {
            Value::Bool(b) => self.u8(q | u8::from(b) << 4),
            Value::U16(x) => {
                self.u8(q | 1);
                self.0.extend_from_slice(&x.to_le_bytes());
            }
            Value::I32(x) => {
                self.u8(q | 2);
                self.varint(u64::from((x << 1 ^ x >> 31) as u32));
            }
            Value::F32(x) => {
                self.u8(q | 3);
                self.0.extend_from_slice(&x.to_le_bytes());
            }
        }
    }

    fn changes(&mut self, changes: &[Change]) {
        self.varint(changes.len() as u64);
        for c in changes {
            self.varint(u64::from(c.tag));
            self.value(c.value, c.quality);
        }
    }

    /// The header's payload.
    pub fn header(h: &Header) -> Vec<u8> {
        let mut e = Enc::default();
        e.str(&h.project);
        e.0.extend_from_slice(&h.project_hash);
        e.0.extend_from_slice(&h.program_hash);
        e.str(&h.program_file);
        e.nanos(h.period);
        e.u8(u8::from(h.virtual_clock));
        e.varint(h.run_id);
        e.varint(h.wall_origin);
        e.varint(u64::from(h.segment));
        e.varint(h.tags.len() as u64);
        for t in &h.tags {
            e.str(&t.name);
            e.u8(type_code(t.ty));
            e.u8(t.role as u8);
        }
        e.0
    }

    /// The keyframe's payload.
    pub fn keyframe(k: &Keyframe) -> Vec<u8> {
        let mut e = Enc::default();
        e.varint(k.next_cycle);
        e.nanos(k.now);
        e.varint(k.slots.len() as u64);
        for &(v, q) in &k.slots {
            e.value(v, q);
        }
        e.varint(k.forces.len() as u64);
        for &(tag, v) in &k.forces {
            e.varint(u64::from(tag));
            e.value(v, Quality::Good);
        }
        e.0
    }

    /// The end block's payload.
    pub fn end(end: &End) -> Vec<u8> {
        let mut e = Enc::default();
        e.varint(end.cycles);
        e.varint(end.dropped);
        e.0
    }

    /// Starts a cycles block whose first record counts from `cycle` and `now`.
    pub fn cycles_block(cycle: u64, now: Duration) -> Self {
        let mut e = Enc::default();
        e.varint(cycle);
        e.nanos(now);
        e
    }

    /// Appends a cycle record whose predecessor in the block was at `prev` (cycle, time).
    pub fn cycle(&mut self, r: &CycleRecord, prev: (u64, Duration)) {
        self.varint(r.cycle.saturating_sub(prev.0));
        self.nanos(r.now.saturating_sub(prev.1));
        self.varint(r.dropped_before);
        self.varint(r.events.len() as u64);
        for ev in &r.events {
            match ev {
                Event::Force { tag, value } => {
                    self.u8(1);
                    self.varint(u64::from(*tag));
                    self.value(*value, Quality::Good);
                }
                Event::Unforce { tag } => {
                    self.u8(2);
                    self.varint(u64::from(*tag));
                }
                Event::UnforceAll => self.u8(3),
                Event::Write { values } => {
                    self.u8(4);
                    self.varint(values.len() as u64);
                    for &(tag, v) in values {
                        self.varint(u64::from(tag));
                        self.value(v, Quality::Good);
                    }
                }
                Event::Reload { program_hash } => {
                    self.u8(5);
                    self.0.extend_from_slice(program_hash);
                }
            }
        }
        self.changes(&r.seen);
        self.changes(&r.wrote);
    }
}

/// A framed block: length, CRC-32C, kind, payload.
pub fn frame(kind: BlockKind, payload: &[u8]) -> Vec<u8> {
    let mut body = Vec::with_capacity(payload.len() + 1);
    body.push(kind as u8);
    body.extend_from_slice(payload);
    let mut out = Vec::with_capacity(body.len() + FRAME);
    out.extend_from_slice(&(body.len() as u32).to_le_bytes());
    out.extend_from_slice(&CASTAGNOLI.checksum(&body).to_le_bytes());
    out.extend_from_slice(&body);
    out
}

/// The preamble of a segment.
pub fn preamble() -> Vec<u8> {
    let mut out = MAGIC.to_vec();
    out.extend_from_slice(&VERSION.to_le_bytes());
    out
}

/// What [`next_block`] found at an offset.
#[derive(Debug, PartialEq, Eq)]
pub enum Framed<'a> {
    /// A whole block with a good CRC, and the offset after it.
    Block(BlockKind, &'a [u8], usize),
    /// The end of the bytes, exactly at a block boundary.
    Eof,
    /// A block cut short or damaged: the torn tail.
    Torn,
}

/// The block at `at` in `bytes`.
pub fn next_block(bytes: &[u8], at: usize) -> Framed<'_> {
    if at == bytes.len() {
        return Framed::Eof;
    }
    let Some(head) = bytes.get(at..at + FRAME) else {
        return Framed::Torn;
    };
    let len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
    let crc = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
    if len == 0 || len > MAX_BLOCK {
        return Framed::Torn;
    }
    let Some(body) = bytes.get(at + FRAME..at + FRAME + len) else {
        return Framed::Torn;
    };
    if CASTAGNOLI.checksum(body) != crc {
        return Framed::Torn;
    }
    match BlockKind::from_u8(body[0]) {
        Some(kind) => Framed::Block(kind, &body[1..], at + FRAME + len),
        None => Framed::Torn,
    }
}

/// Reads items from a block's payload.
#[derive(Debug)]
pub struct Dec<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Dec<'a> {
    /// A reader of `bytes`.
    pub fn new(bytes: &'a [u8]) -> Self {
        Self { bytes, at: 0 }
    }

    /// Whether every byte was read.
    pub fn done(&self) -> bool {
        self.at == self.bytes.len()
    }

    fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let s = self
            .bytes
            .get(self.at..self.at.saturating_add(n))
            .ok_or(DecodeError::Truncated)?;
        self.at += n;
        Ok(s)
    }

    fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }

    fn varint(&mut self) -> Result<u64, DecodeError> {
        let mut v = 0u64;
        for shift in (0..64).step_by(7) {
            let b = self.u8()?;
            v |= u64::from(b & 0x7f) << shift;
            if b & 0x80 == 0 {
                return Ok(v);
            }
        }
        Err(DecodeError::Overlong)
    }

    fn len(&mut self) -> Result<usize, DecodeError> {
        let n = self.varint()?;
        // A count can never exceed the bytes left: refuse before allocating for it.
        usize::try_from(n)
            .ok()
            .filter(|&n| n <= self.bytes.len() - self.at)
            .ok_or(DecodeError::Truncated)
    }

    fn nanos(&mut self) -> Result<Duration, DecodeError> {
        Ok(Duration::from_nanos(self.varint()?))
    }

    fn str(&mut self) -> Result<String, DecodeError> {
        let n = self.len()?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| DecodeError::Utf8)
    }

    fn digest(&mut self) -> Result<Digest, DecodeError> {
        let mut d = [0u8; 32];
        d.copy_from_slice(self.take(32)?);
        Ok(d)
    }

    fn tag(&mut self, tags: usize) -> Result<u32, DecodeError> {
        let t = self.varint()?;
        let tag = u32::try_from(t).unwrap_or(u32::MAX);
        if (tag as usize) < tags {
            Ok(tag)
        } else {
            Err(DecodeError::TagRange { tag })
        }
    }

    fn value(&mut self) -> Result<(Value, Quality), DecodeError> {
        let b = self.u8()?;
        let q = match b >> 2 & 3 {
            0 => Quality::Good,
            1 => Quality::Stale,
            2 => Quality::Bad,
            _ => {
                return Err(DecodeError::Unknown {
                    what: "quality",
                    byte: b,
                })
            }
        };
        let v = match b & 3 {
            0 => Value::Bool(b & 0x10 != 0),
            1 => {
                let s = self.take(2)?;
                Value::U16(u16::from_le_bytes([s[0], s[1]]))
            }
            2 => {
                let z = self.varint()? as u32;
                Value::I32((z >> 1) as i32 ^ -((z & 1) as i32))
            }
            _ => {
                let s = self.take(4)?;
                Value::F32(f32::from_le_bytes([s[0], s[1], s[2], s[3]]))
            }
        };
        Ok((v, q))
    }

    fn changes(&mut self, tags: usize) -> Result<Vec<Change>, DecodeError> {
        let n = self.len()?;
        let mut out = Vec::with_capacity(n);
        for _ in 0..n {
            let tag = self.tag(tags)?;
            let (value, quality) = self.value()?;
            out.push(Change {
                tag,
                value,
                quality,
            });
        }
        Ok(out)
    }

    /// A header payload.
    pub fn header(mut self) -> Result<Header, DecodeError> {
        let project = self.str()?;
        let project_hash = self.digest()?;
        let program_hash = self.digest()?;
        let program_file = self.str()?;
        let period = self.nanos()?;
        let virtual_clock = self.u8()? != 0;
        let run_id = self.varint()?;
        let wall_origin = self.varint()?;
        let segment = u32::try_from(self.varint()?).unwrap_or(u32::MAX);
        let n = self.len()?;
        let mut tags = Vec::with_capacity(n);
        for _ in 0..n {
            let name = self.str()?;
            let t = self.u8()?;
            let ty = type_from(t).ok_or(DecodeError::Unknown {
                what: "type",
                byte: t,
            })?;
            let r = self.u8()?;
            let role = TagRole::from_u8(r).ok_or(DecodeError::Unknown {
                what: "tag role",
                byte: r,
            })?;
            tags.push(TagInfo { name, ty, role });
        }
        Ok(Header {
            project,
            project_hash,
            program_hash,
            program_file,
            period,
            virtual_clock,
            run_id,
            wall_origin,
            segment,
            tags,
        })
    }

    /// A keyframe payload for a table of `tags` tags.
    pub fn keyframe(mut self, tags: usize) -> Result<Keyframe, DecodeError> {
        let next_cycle = self.varint()?;
        let now = self.nanos()?;
        let n = self.len()?;
        if n != tags {
            return Err(DecodeError::TagRange { tag: n as u32 });
        }
        let slots = (0..n).map(|_| self.value()).collect::<Result<_, _>>()?;
        let f = self.len()?;
        let mut forces = Vec::with_capacity(f);
        for _ in 0..f {
            let tag = self.tag(tags)?;
            forces.push((tag, self.value()?.0));
        }
        Ok(Keyframe {
            next_cycle,
            now,
            slots,
            forces,
        })
    }

    /// An end payload.
    pub fn end(mut self) -> Result<End, DecodeError> {
        Ok(End {
            cycles: self.varint()?,
            dropped: self.varint()?,
        })
    }

    /// Every cycle record of a cycles block, for a table of `tags` tags.
    pub fn cycles(mut self, tags: usize) -> Result<Vec<CycleRecord>, DecodeError> {
        let mut prev = (self.varint()?, self.nanos()?);
        let mut out = Vec::new();
        while !self.done() {
            let cycle = prev.0.saturating_add(self.varint()?);
            let now = prev.1.saturating_add(self.nanos()?);
            let dropped_before = self.varint()?;
            let n = self.len()?;
            let mut events = Vec::with_capacity(n);
            for _ in 0..n {
                events.push(match self.u8()? {
                    1 => {
                        let tag = self.tag(tags)?;
                        Event::Force {
                            tag,
                            value: self.value()?.0,
                        }
                    }
                    2 => Event::Unforce {
                        tag: self.tag(tags)?,
                    },
                    3 => Event::UnforceAll,
                    4 => {
                        let k = self.len()?;
                        let mut values = Vec::with_capacity(k);
                        for _ in 0..k {
                            let tag = self.tag(tags)?;
                            values.push((tag, self.value()?.0));
                        }
                        Event::Write { values }
                    }
                    5 => Event::Reload {
                        program_hash: self.digest()?,
                    },
                    byte => {
                        return Err(DecodeError::Unknown {
                            what: "event",
                            byte,
                        })
                    }
                });
            }
            let seen = self.changes(tags)?;
            let wrote = self.changes(tags)?;
            out.push(CycleRecord {
                cycle,
                now,
                dropped_before,
                events,
                seen,
                wrote,
            });
            prev = (cycle, now);
        }
        Ok(out)
    }
}

fn type_code(ty: ValueType) -> u8 {
    match ty {
        ValueType::Bool => 0,
        ValueType::U16 => 1,
        ValueType::I32 => 2,
        ValueType::F32 => 3,
    }
}

fn type_from(b: u8) -> Option<ValueType> {
    Some(match b {
        0 => ValueType::Bool,
        1 => ValueType::U16,
        2 => ValueType::I32,
        3 => ValueType::F32,
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> Header {
        Header {
            project: "quickstart".into(),
            project_hash: digest(b"project"),
            program_hash: digest(b"program"),
            program_file: "conveyor.expr".into(),
            period: Duration::from_millis(100),
            virtual_clock: true,
            run_id: 1_764_000_000_000_000_000,
            wall_origin: 1_763_999_999_000_000_000,
            segment: 3,
            tags: vec![
                TagInfo {
                    name: "start".into(),
                    ty: ValueType::Bool,
                    role: TagRole::Input,
                },
                TagInfo {
                    name: "level".into(),
                    ty: ValueType::I32,
                    role: TagRole::Memory,
                },
            ],
        }
    }

    #[test]
    fn the_checksum_is_crc_32c() {
        // The check value of CRC-32C (Castagnoli).
        assert_eq!(CASTAGNOLI.checksum(b"123456789"), 0xE306_9283);
    }

    #[test]
    fn a_block_is_framed_byte_for_byte() {
        let block = frame(
            BlockKind::End,
            &Enc::end(&End {
                cycles: 300,
                dropped: 0,
            }),
        );
        // length 4 (kind + 3 bytes), CRC-32C of the body, kind 4, varint 300 = ac 02, 0.
        let body = [4u8, 0xac, 0x02, 0x00];
        let crc = CASTAGNOLI.checksum(&body).to_le_bytes();
        let mut expected = vec![4, 0, 0, 0];
        expected.extend_from_slice(&crc);
        expected.extend_from_slice(&body);
        assert_eq!(block, expected);
        assert_eq!(
            next_block(&block, 0),
            Framed::Block(BlockKind::End, &body[1..], block.len())
        );
    }

    #[test]
    fn values_encode_compactly_and_round_trip() {
        let mut e = Enc::default();
        e.value(Value::Bool(true), Quality::Good);
        e.value(Value::U16(0x1234), Quality::Stale);
        e.value(Value::I32(-3), Quality::Bad);
        e.value(Value::F32(1.5), Quality::Good);
        assert_eq!(
            e.0,
            [0x10, 0x05, 0x34, 0x12, 0x0a, 0x05, 0x03, 0x00, 0x00, 0xc0, 0x3f]
        );
        let mut d = Dec::new(&e.0);
        assert_eq!(d.value(), Ok((Value::Bool(true), Quality::Good)));
        assert_eq!(d.value(), Ok((Value::U16(0x1234), Quality::Stale)));
        assert_eq!(d.value(), Ok((Value::I32(-3), Quality::Bad)));
        assert_eq!(d.value(), Ok((Value::F32(1.5), Quality::Good)));
        assert!(d.done());
    }

    #[test]
    fn header_keyframe_and_cycles_round_trip() {
        let h = header();
        assert_eq!(Dec::new(&Enc::header(&h)).header(), Ok(h.clone()));
        let k = Keyframe {
            next_cycle: 40,
            now: Duration::from_millis(4000),
            slots: vec![
                (Value::Bool(false), Quality::Bad),
                (Value::I32(i32::MIN), Quality::Good),
            ],
            forces: vec![(0, Value::Bool(true))],
        };
        assert_eq!(Dec::new(&Enc::keyframe(&k)).keyframe(2), Ok(k));
        let records = vec![
            CycleRecord {
                cycle: 40,
                now: Duration::from_millis(4000),
                dropped_before: 0,
                events: vec![
                    Event::Force {
                        tag: 0,
                        value: Value::Bool(true),
                    },
                    Event::Unforce { tag: 1 },
                    Event::UnforceAll,
                    Event::Write {
                        values: vec![(1, Value::I32(7))],
                    },
                    Event::Reload {
                        program_hash: digest(b"new"),
                    },
                ],
                seen: vec![Change {
                    tag: 0,
                    value: Value::Bool(true),
                    quality: Quality::Good,
                }],
                wrote: vec![],
            },
            CycleRecord {
                cycle: 43,
                now: Duration::from_millis(4300),
                dropped_before: 2,
                ..CycleRecord::default()
            },
        ];
        let mut block = Enc::cycles_block(40, Duration::from_millis(4000));
        let mut prev = (40, Duration::from_millis(4000));
        for r in &records {
            block.cycle(r, prev);
            prev = (r.cycle, r.now);
        }
        assert_eq!(Dec::new(&block.0).cycles(2), Ok(records));
    }

    #[test]
    fn damage_is_a_torn_tail_never_a_panic() {
        let block = frame(
            BlockKind::End,
            &Enc::end(&End {
                cycles: 1,
                dropped: 0,
            }),
        );
        for cut in 1..block.len() {
            assert_eq!(next_block(&block[..cut], 0), Framed::Torn, "cut at {cut}");
        }
        let mut flipped = block.clone();
        *flipped.last_mut().unwrap() ^= 1;
        assert_eq!(next_block(&flipped, 0), Framed::Torn);
        assert_eq!(next_block(&block, block.len()), Framed::Eof);
        // A payload that lies about its counts is refused, not allocated for.
        assert_eq!(
            Dec::new(&[0xff, 0xff, 0xff, 0xff, 0x0f]).changes(2),
            Err(DecodeError::Truncated)
        );
        assert_eq!(
            Dec::new(&[1, 9, 0]).changes(2),
            Err(DecodeError::TagRange { tag: 9 })
        );
    }
}
