//! The driver of a profiled device: reads its due poll groups in the coalesced requests of
//! [`super::plan`], decodes each point (and its bit fields) by the profile, and writes the
//! program's values on change or every cycle, as each point says.

use std::collections::HashMap;
use std::time::Duration;

use crate::line::LineSettings;
use crate::time::LineInstant;

use super::plan::{self, Read};
use super::{value, Entry, Profile, Table, WriteMode};
use crate::devices::{DeviceConfig, ModuleSettings};
use crate::driver::{DecodeError, Driver, Outgoing, Reply, Transaction};
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

/// Tags at and above this are writes (the point's index added); below, the index of a read in
/// the cycle's plan.
const WRITE_TAG: u32 = 1 << 24;

/// Builds the driver of a profile module (the catalog's `driver` of every profile model). A
/// configuration that is not a profile's (which validation never hands over) gives a driver
/// with no points.
pub(crate) fn build(config: &DeviceConfig) -> Box<dyn Driver> {
    match &config.settings {
        ModuleSettings::Profile(p) => Box::new(ProfileDriver::new(p.profile, config.address.get())),
        _ => Box::new(ProfileDriver::new(
            super::catalog::empty(),
            config.address.get(),
        )),
    }
}

/// A profiled device's driver.
#[derive(Debug)]
pub(crate) struct ProfileDriver {
    profile: &'static Profile,
    address: u8,
    entries: Vec<Entry>,
    /// Index into `entries` of each profile point.
    entry_of: Vec<usize>,
    values: Vec<Option<Value>>,
    /// This cycle's reads, and whether each was answered.
    reads: Vec<(Read, bool)>,
    /// When each poll group was last planned.
    last_read: Vec<Option<LineInstant>>,
    now: LineInstant,
    /// What each point was last written with, as the device acknowledged it.
    written: Vec<Option<Value>>,
    /// Writes in flight: tag → value.
    pending: HashMap<u32, Value>,
}

impl ProfileDriver {
    /// The driver of `profile` at unit `address`.
    pub(crate) fn new(profile: &'static Profile, address: u8) -> Self {
        let entries = profile.entries();
        let mut entry_of = vec![0; profile.points.len()];
        for (i, e) in entries.iter().enumerate() {
            if e.bits.is_none() {
                entry_of[e.point] = i;
            }
        }
        Self {
            profile,
            address,
            values: vec![None; entries.len()],
            entries,
            entry_of,
            reads: Vec::new(),
            last_read: vec![None; profile.groups.len()],
            now: LineInstant::ZERO,
            written: vec![None; profile.points.len()],
            pending: HashMap::new(),
        }
    }

    fn unit(&self) -> Option<UnitId> {
        UnitId::new(self.address)
    }

    fn due(&self, group: usize) -> bool {
        match (
            self.profile.groups.get(group).and_then(|g| g.period),
            self.last_read.get(group),
        ) {
            (None, _) | (_, None | Some(None)) => true,
            (Some(period), Some(Some(t))) => self.now - *t >= period,
        }
    }

    /// Stores the registers (or bits as 0/1) `words` read from `read`.
    fn store(&mut self, read: &Read, words: &[u16]) -> Result<(), DecodeError> {
        for &i in &read.points {
            let p = &self.profile.points[i];
            let at = usize::from(p.address - read.addr);
            let Some(part) = words.get(at..at + usize::from(p.width())) else {
                return Err(DecodeError::Unexpected { tag: 0 });
            };
            let Some((raw, bits)) = value::raw(p, part) else {
                return Err(DecodeError::Unexpected { tag: 0 });
            };
            let e = self.entry_of[i];
            self.values[e] = Some(value::to_value(p, value::engineering(p, raw)));
            for (b, field) in p.bits.iter().enumerate() {
                let n = f64::from(field.extract(bits));
                self.values[e + 1 + b] = Some(value::typed(field.value_type(), n));
            }
        }
        Ok(())
    }
}

impl Driver for ProfileDriver {
    fn address(&self) -> u8 {
        self.address
    }

    fn advance_to(&mut self, now: LineInstant) {
        self.now = self.now.max(now);
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        // A read of the last cycle that got no answer: its groups are read again now.
        for (read, answered) in std::mem::take(&mut self.reads) {
            if !answered {
                for i in read.points {
                    if let Some(g) = self.last_read.get_mut(self.profile.points[i].group) {
                        *g = None;
                    }
                }
            }
        }
        let Some(unit) = self.unit() else { return };
        let reads = plan::reads(self.profile, |g| self.due(g));
        for read in &reads {
            for &i in &read.points {
                let g = self.profile.points[i].group;
                self.last_read[g] = Some(self.now);
            }
        }
        for (tag, read) in reads.into_iter().enumerate() {
            out.push(Transaction {
                frame: Outgoing::Modbus {
                    unit,
                    request: read.request(),
                },
                tag: tag as u32,
            });
            self.reads.push((read, false));
        }
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit() else { return };
        let multiple = self.profile.limits.write_multiple;
        for (e, want) in desired.iter().enumerate() {
            let (Some(entry), Some(want)) = (self.entries.get(e), want) else {
                continue;
            };
            let p = &self.profile.points[entry.point];
            if entry.bits.is_some() || !p.access.writes() {
                continue;
            }
            let want = value::to_value(p, value::number(*want));
            let changed = self.written[entry.point] != Some(want);
            if !(changed || refresh || p.write == WriteMode::Cyclic) {
                continue;
            }
            let n = value::number(want);
            let addr = p.address;
            let request = match (p.table, multiple) {
                (Table::Coil, false) => Request::WriteSingleCoil {
                    addr,
                    value: n != 0.0,
                },
                (Table::Coil, true) => Request::WriteMultipleCoils {
                    addr,
                    values: vec![n != 0.0],
                },
                _ => {
                    let words = value::encode(p, n);
                    match words.as_slice() {
                        [one] if !multiple => Request::WriteSingleRegister { addr, value: *one },
                        _ => Request::WriteMultipleRegisters {
                            addr,
                            values: words,
                        },
                    }
                }
            };
            let tag = WRITE_TAG + entry.point as u32;
            self.pending.insert(tag, want);
            out.push(Transaction {
                frame: Outgoing::Modbus { unit, request },
                tag,
            });
        }
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        let Reply::Modbus(response) = reply else {
            return Err(DecodeError::Unexpected { tag });
        };
        if let Response::Exception { code, .. } = response {
            if tag >= WRITE_TAG {
                self.pending.remove(&tag);
            }
            return Err(DecodeError::Exception(*code));
        }
        if tag >= WRITE_TAG {
            let point = (tag - WRITE_TAG) as usize;
            let Some(v) = self.pending.remove(&tag) else {
                return Err(DecodeError::Unexpected { tag });
            };
            let fits = matches!(
                response,
                Response::WriteSingleCoil { .. }
                    | Response::WriteSingleRegister { .. }
                    | Response::WriteMultipleCoils { .. }
                    | Response::WriteMultipleRegisters { .. }
            );
            if !fits {
                return Err(DecodeError::Unexpected { tag });
            }
            self.written[point] = Some(v);
            if !self.profile.points[point].access.reads() {
                self.values[self.entry_of[point]] = Some(v);
            }
            return Ok(());
        }
        let Some((read, answered)) = self.reads.get_mut(tag as usize) else {
            return Err(DecodeError::Unexpected { tag });
        };
        let read = read.clone();
        *answered = true;
        let count = usize::from(read.count);
        let words: Vec<u16> = match (read.table, response) {
            (Table::Coil, Response::ReadCoils(bits))
            | (Table::Discrete, Response::ReadDiscreteInputs(bits)) => {
                bits.iter().take(count).map(|b| u16::from(*b)).collect()
            }
            (Table::Holding, Response::ReadHoldingRegisters(regs))
            | (Table::Input, Response::ReadInputRegisters(regs)) => regs.clone(),
            _ => return Err(DecodeError::Unexpected { tag }),
        };
        if words.len() < count {
            return Err(DecodeError::Unexpected { tag });
        }
        self.store(&read, &words)
            .map_err(|_| DecodeError::Unexpected { tag })
    }

    fn on_failure(&mut self, tag: u32) {
        if tag >= WRITE_TAG {
            self.pending.remove(&tag);
            if let Some(w) = self.written.get_mut((tag - WRITE_TAG) as usize) {
                *w = None;
            }
        }
    }

    fn on_restart(&mut self) {
        self.written.iter_mut().for_each(|w| *w = None);
        self.last_read.iter_mut().for_each(|t| *t = None);
        self.pending.clear();
        self.reads.clear();
    }

    fn values(&self) -> &[Option<Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        self.profile.timing.reply_delay
    }

    fn response_timeout(&self) -> Option<Duration> {
        self.profile.timing.reply_timeout
    }

    fn frame_gap(&self, settings: LineSettings) -> Option<Duration> {
        let _ = settings;
        self.profile.timing.frame_gap
    }
}
