//! Encoding a block's payload (the layout is in the parent module's docs).

use std::time::Duration;

use softplc_io::point::{Quality, Value};
use softplc_io::time::ScanInstant;

use super::{type_code, Change, CycleRecord, End, Event, Gap, Header, Keyframe};

/// A growing encoded block.
#[derive(Debug, Default, Clone)]
pub struct Enc(pub Vec<u8>);

impl Enc {
    pub(super) fn u8(&mut self, b: u8) {
        self.0.push(b);
    }

    pub(super) fn varint(&mut self, mut v: u64) {
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

    pub(super) fn nanos(&mut self, d: Duration) {
        self.varint(u64::try_from(d.as_nanos()).unwrap_or(u64::MAX));
    }

    /// A scan time: nanoseconds since the PLC's start.
    pub(super) fn instant(&mut self, t: ScanInstant) {
        self.nanos(t.since_origin());
    }

    pub(super) fn str(&mut self, s: &str) {
        self.varint(s.len() as u64);
        self.0.extend_from_slice(s.as_bytes());
    }

    pub(super) fn value(&mut self, v: Value, q: Quality) {
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

    pub(super) fn changes(&mut self, changes: &[Change]) {
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
        if let Some(task) = &h.task {
            e.str(task);
        }
        e.0
    }

    /// The keyframe's payload.
    pub fn keyframe(k: &Keyframe) -> Vec<u8> {
        let mut e = Enc::default();
        e.varint(k.next_cycle);
        e.instant(k.now);
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

    /// The gap block's payload.
    pub fn gap(gap: &Gap) -> Vec<u8> {
        let mut e = Enc::default();
        e.varint(gap.first);
        e.varint(gap.last);
        e.0
    }

    /// Starts a cycles block whose first record counts from `cycle` and `now`.
    pub fn cycles_block(cycle: u64, now: ScanInstant) -> Self {
        let mut e = Enc::default();
        e.varint(cycle);
        e.instant(now);
        e
    }

    /// Appends a cycle record whose predecessor in the block was at `prev` (cycle, time).
    pub fn cycle(&mut self, r: &CycleRecord, prev: (u64, ScanInstant)) {
        self.varint(r.cycle.saturating_sub(prev.0));
        self.nanos(r.now - prev.1);
        self.varint(r.dropped_before);
        self.u8(u8::from(r.faulted));
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
