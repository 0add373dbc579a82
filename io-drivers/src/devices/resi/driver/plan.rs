//! Reading points in the fewest exchanges the tables allow.
//!
//! - Modbus: the points' map entries, sorted by address, are joined into runs read with one
//!   FC 1/2 (bits; FC 1 when a run holds a coil the host may write, FC 2 otherwise) or FC 3
//!   (registers). Two entries join when the addresses between them are all documented (an
//!   undocumented one may answer exception 02) and the gap is small; runs stay within the
//!   manual's limits (2000 bits, 125 registers, L1991).
//! - ASCII: a bit point is read with the word command of its group when there is one (`GDIS`
//!   for DI1..DI16, `GROS` for RO1..RO8), otherwise with the command of the fewest values
//!   that holds it (`RDI3`, then `GTS` if nothing smaller).

use super::super::ascii::command::{Action, Command, Fmt, COMMON};
use super::super::item::Item;
use super::super::map::{Acc, Table};
use super::super::model::Model;
use super::super::value::Enc;

/// Largest gap of unread documented addresses inside one Modbus read.
const MAX_GAP_BITS: u16 = 64;
const MAX_GAP_REGS: u16 = 16;

/// Where a point's value is in a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Target {
    /// The point's index.
    pub point: usize,
    /// Modbus: the address offset in the read; ASCII: the index of the value.
    pub at: usize,
    /// The value is this part (first bit, width) of a bigger one.
    pub part: Option<(u8, u8)>,
    /// How the value is encoded (Modbus registers).
    pub enc: Enc,
}

/// One read exchange.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) enum Read {
    /// FC 1 (coils) or FC 2.
    Bits {
        /// First protocol address.
        addr: u16,
        /// Number of bits.
        count: u16,
        /// FC 1 rather than FC 2.
        coils: bool,
        /// The points.
        targets: Vec<Target>,
    },
    /// FC 3.
    Regs {
        /// First protocol address.
        addr: u16,
        /// Number of registers.
        count: u16,
        /// The points.
        targets: Vec<Target>,
    },
    /// An ASCII get command.
    Ascii {
        /// The command.
        command: &'static Command,
        /// Its channel number.
        x: u8,
        /// The points.
        targets: Vec<Target>,
    },
}

/// The Modbus reads of `points`.
pub(crate) fn modbus(model: &'static Model, points: &[usize]) -> Vec<Read> {
    let mut entries: Vec<_> = points
        .iter()
        .filter_map(|&p| {
            let spec = model.points.get(p)?;
            model.map.by_name(spec.name).map(|e| (e, p))
        })
        .collect();
    entries.sort_by_key(|(e, _)| (e.table == Table::Registers, e.addr()));
    let mut out: Vec<Read> = Vec::new();
    // (table, start, end, coils, targets) of the run being built.
    let mut run: Option<(Table, u16, u32, bool, Vec<Target>)> = None;
    for (e, p) in entries {
        let (addr, end) = (e.addr(), u32::from(e.addr()) + u32::from(e.words()));
        let (max, gap) = match e.table {
            Table::Bits => (2000u32, MAX_GAP_BITS),
            Table::Registers => (125, MAX_GAP_REGS),
        };
        let joins = run.as_ref().is_some_and(|(t, start, run_end, ..)| {
            *t == e.table
                && end - u32::from(*start) <= max
                && (u32::from(addr) <= *run_end
                    || (u32::from(addr) - run_end <= u32::from(gap)
                        && (*run_end..u32::from(addr)).all(|a| {
                            u16::try_from(a).is_ok_and(|a| model.map.lookup(e.table, a).is_some())
                        })))
        });
        if !joins {
            if let Some(r) = run.take() {
                out.push(finish(r));
            }
            run = Some((e.table, addr, end, false, Vec::new()));
        }
        if let Some((_, start, run_end, coils, targets)) = run.as_mut() {
            *run_end = (*run_end).max(end);
            *coils |= e.access != Acc::ReadOnly;
            targets.push(Target {
                point: p,
                at: usize::from(addr - *start),
                part: None,
                enc: e.enc,
            });
        }
    }
    if let Some(r) = run {
        out.push(finish(r));
    }
    out
}

fn finish((table, addr, end, coils, targets): (Table, u16, u32, bool, Vec<Target>)) -> Read {
    let count = u16::try_from(end - u32::from(addr)).unwrap_or(u16::MAX);
    match table {
        Table::Bits => Read::Bits {
            addr,
            count,
            coils,
            targets,
        },
        Table::Registers => Read::Regs {
            addr,
            count,
            targets,
        },
    }
}

/// Every get command of a model, with its channel numbers.
fn gets(model: &'static Model) -> impl Iterator<Item = (&'static Command, u8)> {
    model
        .commands
        .iter()
        .chain(COMMON.iter())
        // A sensor configuration is names, not a number the driver could decode.
        .filter(|c| matches!(c.action, Action::Get { fmt, .. } if fmt != Fmt::SensorConfig))
        .flat_map(|c| {
            let (first, last) = c.x.unwrap_or((1, 1));
            (first..=last).map(move |x| (c, x))
        })
}

/// The position of value `k` in a get answer.
pub(crate) fn position(fmt: Fmt, k: usize) -> usize {
    match fmt {
        Fmt::Pairs => 2 * k,
        Fmt::DecsThenHexes | Fmt::Reals => k,
        // `S1,<4 names>,S2,...`: never planned (see `gets`); where value `k`'s first name is.
        Fmt::SensorConfig => 5 * k + 1,
    }
}

/// The get command that reads `item`: (command, x, index of the value).
pub(crate) fn ascii_get(
    model: &'static Model,
    item: Item,
) -> Option<(&'static Command, u8, usize)> {
    gets(model)
        .filter_map(|(c, x)| {
            let Action::Get { fields, .. } = c.action else {
                return None;
            };
            let k = fields
                .iter()
                .position(|f| Item::new(f.kind, f.index(x)) == item)?;
            Some((c, x, k, fields.len()))
        })
        .min_by_key(|(.., n)| *n)
        .map(|(c, x, k, _)| (c, x, k))
}

/// The ASCII reads of `points`; the points no command reads are left out (and returned).
pub(crate) fn ascii(model: &'static Model, points: &[usize]) -> (Vec<Read>, Vec<usize>) {
    let mut out: Vec<Read> = Vec::new();
    let mut unreadable = Vec::new();
    for &p in points {
        let Some(entry) = model
            .points
            .get(p)
            .and_then(|spec| model.map.by_name(spec.name))
        else {
            unreadable.push(p);
            continue;
        };
        let via_word = entry.item.part_of().and_then(|(whole, shift, width)| {
            let (c, x, k) = ascii_get(model, whole)?;
            Some((c, x, k, Some((shift, width))))
        });
        let found = via_word.or_else(|| {
            let (c, x, k) = ascii_get(model, entry.item)?;
            Some((c, x, k, None))
        });
        let Some((command, x, k, part)) = found else {
            unreadable.push(p);
            continue;
        };
        let Action::Get { fmt, .. } = command.action else {
            unreadable.push(p);
            continue;
        };
        let target = Target {
            point: p,
            at: position(fmt, k),
            part,
            enc: entry.enc,
        };
        let existing = out.iter_mut().find_map(|r| match r {
            Read::Ascii {
                command: c,
                x: cx,
                targets,
            } if std::ptr::eq(*c, command) && *cx == x => Some(targets),
            _ => None,
        });
        match existing {
            Some(targets) => targets.push(target),
            None => out.push(Read::Ascii {
                command,
                x,
                targets: vec![target],
            }),
        }
    }
    (out, unreadable)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::driver::settings::select;
    use crate::devices::resi::models::{m16di8ro, m2rtd};

    #[test]
    fn modbus_joins_documented_runs() {
        let m = &m16di8ro::MODEL;
        let reads = modbus(m, &select(m, &["DI*", "RO*"]).unwrap());
        assert_eq!(reads.len(), 1);
        let Read::Bits {
            addr,
            count,
            coils,
            targets,
        } = &reads[0]
        else {
            panic!()
        };
        assert_eq!((*addr, *count, *coils, targets.len()), (0, 24, true, 24));
        let reads = modbus(m, &select(m, &["DI*"]).unwrap());
        assert!(matches!(
            reads[0],
            Read::Bits {
                coils: false,
                count: 16,
                ..
            }
        ));
        // Counters 0..31, then 4x00101..103, then the relay counters at 200: three reads.
        let reads = modbus(
            m,
            &select(m, &["RISE_DI*", "FALL_DI*", "DIS", "ROS", "COUNTER_RO*"]).unwrap(),
        );
        let spans: Vec<(u16, u16)> = reads
            .iter()
            .map(|r| match r {
                Read::Regs { addr, count, .. } => (*addr, *count),
                _ => (0, 0),
            })
            .collect();
        assert_eq!(spans, [(0, 32), (100, 2), (200, 16)]);
    }

    #[test]
    fn ascii_prefers_word_commands() {
        let m = &m16di8ro::MODEL;
        let (reads, none) = ascii(m, &select(m, &["DI*", "RO*", "RISE_DI3", "DIP1"]).unwrap());
        assert!(none.is_empty());
        let names: Vec<String> = reads
            .iter()
            .map(|r| match r {
                Read::Ascii { command, x, .. } => command.reply_keyword(*x),
                _ => String::new(),
            })
            .collect();
        assert_eq!(names, ["GDIS", "GROS", "RDI3", "GDIP"]);
        let m = &m2rtd::MODEL;
        let (reads, none) = ascii(m, &select(m, &["CH1_REAL_TEMP", "CH2_STATUS"]).unwrap());
        assert!(none.is_empty());
        assert_eq!(reads.len(), 2);
    }
}
