//! Decoding a block's payload; every count is checked against the bytes left, so damage is
//! an error, never a panic or a huge allocation.

use std::time::Duration;

use softplc_io::point::{Quality, Value};
use softplc_io::time::ScanInstant;

use super::{
    type_from, Change, CycleRecord, DecodeError, Digest, End, Event, Gap, Header, Keyframe,
    TagInfo, TagRole,
};

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

    pub(super) fn take(&mut self, n: usize) -> Result<&'a [u8], DecodeError> {
        let s = self
            .bytes
            .get(self.at..self.at.saturating_add(n))
            .ok_or(DecodeError::Truncated)?;
        self.at += n;
        Ok(s)
    }

    pub(super) fn u8(&mut self) -> Result<u8, DecodeError> {
        Ok(self.take(1)?[0])
    }

    pub(super) fn varint(&mut self) -> Result<u64, DecodeError> {
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

    pub(super) fn len(&mut self) -> Result<usize, DecodeError> {
        let n = self.varint()?;
        // A count can never exceed the bytes left: refuse before allocating for it.
        usize::try_from(n)
            .ok()
            .filter(|&n| n <= self.bytes.len() - self.at)
            .ok_or(DecodeError::Truncated)
    }

    pub(super) fn nanos(&mut self) -> Result<Duration, DecodeError> {
        Ok(Duration::from_nanos(self.varint()?))
    }

    /// A scan time: nanoseconds since the PLC's start.
    pub(super) fn instant(&mut self) -> Result<ScanInstant, DecodeError> {
        Ok(ScanInstant::after_origin(self.nanos()?))
    }

    pub(super) fn str(&mut self) -> Result<String, DecodeError> {
        let n = self.len()?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| DecodeError::Utf8)
    }

    pub(super) fn digest(&mut self) -> Result<Digest, DecodeError> {
        let mut d = [0u8; 32];
        d.copy_from_slice(self.take(32)?);
        Ok(d)
    }

    pub(super) fn tag(&mut self, tags: usize) -> Result<u32, DecodeError> {
        let t = self.varint()?;
        let tag = u32::try_from(t).unwrap_or(u32::MAX);
        if (tag as usize) < tags {
            Ok(tag)
        } else {
            Err(DecodeError::TagRange { tag })
        }
    }

    pub(super) fn value(&mut self) -> Result<(Value, Quality), DecodeError> {
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

    pub(super) fn changes(&mut self, tags: usize) -> Result<Vec<Change>, DecodeError> {
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
        // A record of one task (and every record written before tasks) ends here.
        let task = if self.done() { None } else { Some(self.str()?) };
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
            task,
        })
    }

    /// A keyframe payload for a table of `tags` tags.
    pub fn keyframe(mut self, tags: usize) -> Result<Keyframe, DecodeError> {
        let next_cycle = self.varint()?;
        let now = self.instant()?;
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

    /// A gap payload.
    pub fn gap(mut self) -> Result<Gap, DecodeError> {
        Ok(Gap {
            first: self.varint()?,
            last: self.varint()?,
        })
    }

    /// Every cycle record of a cycles block, for a table of `tags` tags.
    pub fn cycles(mut self, tags: usize) -> Result<Vec<CycleRecord>, DecodeError> {
        let mut prev = (self.varint()?, self.instant()?);
        let mut out = Vec::new();
        while !self.done() {
            let cycle = prev.0.saturating_add(self.varint()?);
            let now = prev.1 + self.nanos()?;
            let dropped_before = self.varint()?;
            let faulted = self.u8()? != 0;
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
                faulted,
                events,
                seen,
                wrote,
            });
            prev = (cycle, now);
        }
        Ok(out)
    }
}
