//! Reads coalesced into as few requests as the device allows: the points of the due poll
//! groups, by table and address, are joined into one read while the request stays within the
//! device's maximum and, unless the profile allows reading gaps, only where no address between
//! them is left out.

use super::{Profile, Table};
use crate::modbus::Request;

/// One read request and the points its reply holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Read {
    /// The table.
    pub table: Table,
    /// First protocol address.
    pub addr: u16,
    /// Registers or bits.
    pub count: u16,
    /// The profile points it reads (indexes into [`Profile::points`]).
    pub points: Vec<usize>,
}

impl Read {
    /// The request on the wire.
    pub(crate) fn request(&self) -> Request {
        let (addr, count) = (self.addr, self.count);
        match self.table {
            Table::Coil => Request::ReadCoils { addr, count },
            Table::Discrete => Request::ReadDiscreteInputs { addr, count },
            Table::Input => Request::ReadInputRegisters { addr, count },
            Table::Holding => Request::ReadHoldingRegisters { addr, count },
        }
    }
}

/// The reads of every readable point whose group `due` says is due, in table then address
/// order.
pub(crate) fn reads(profile: &Profile, due: impl Fn(usize) -> bool) -> Vec<Read> {
    let mut points: Vec<usize> = (0..profile.points.len())
        .filter(|&i| {
            let p = &profile.points[i];
            p.access.reads() && due(p.group)
        })
        .collect();
    points.sort_by_key(|&i| (profile.points[i].table, profile.points[i].address));
    let limits = profile.limits;
    let mut out: Vec<Read> = Vec::new();
    for i in points {
        let p = &profile.points[i];
        let max = u32::from(if p.table.is_bits() {
            limits.max_bits
        } else {
            limits.max_registers
        });
        let joins = out.last().is_some_and(|r| {
            let end = u32::from(r.addr) + u32::from(r.count);
            r.table == p.table
                && p.end() - u32::from(r.addr) <= max
                && (u32::from(p.address) <= end || limits.read_gaps)
        });
        match out.last_mut() {
            Some(r) if joins => {
                let end = (u32::from(r.addr) + u32::from(r.count)).max(p.end());
                r.count = (end - u32::from(r.addr)) as u16;
                r.points.push(i);
            }
            _ => out.push(Read {
                table: p.table,
                addr: p.address,
                count: p.width(),
                points: vec![i],
            }),
        }
    }
    out
}
