//! Write exchanges: start-up settings and the outputs of each cycle (see [`super`]).

use super::super::ascii::command::Action;
use super::super::item::{Item, Kind};
use super::super::map::{Entry, Table};
use super::super::value::Num;
use super::{ascii, Check, ResiDriver, Step};
use crate::devices::Protocol;
use crate::modbus::{Request, Response};
use crate::point::{Access, Value};

/// The manual allows 125 registers per FC 16 (L1991); the standard, 123.
const MAX_WRITE_REGS: usize = 123;

/// The request that writes one value.
pub(super) fn single(e: &Entry, v: Num) -> Request {
    match (e.table, e.enc.words()) {
        (Table::Bits, _) => Request::WriteSingleCoil {
            addr: e.addr(),
            value: v.int() != 0,
        },
        (Table::Registers, 1) => Request::WriteSingleRegister {
            addr: e.addr(),
            value: e.enc.word(v, 0),
        },
        (Table::Registers, _) => Request::WriteMultipleRegisters {
            addr: e.addr(),
            values: e.enc.encode(v),
        },
    }
}

/// Whether `resp` is the echo of the write `req`.
pub(super) fn echoes(req: &Request, resp: &Response) -> bool {
    match (req, resp) {
        (
            Request::WriteSingleCoil { addr, value },
            Response::WriteSingleCoil { addr: a, value: v },
        ) => addr == a && value == v,
        (
            Request::WriteSingleRegister { addr, value },
            Response::WriteSingleRegister { addr: a, value: v },
        ) => addr == a && value == v,
        (
            Request::WriteMultipleCoils { addr, values },
            Response::WriteMultipleCoils { addr: a, count },
        ) => addr == a && values.len() == usize::from(*count),
        (
            Request::WriteMultipleRegisters { addr, values },
            Response::WriteMultipleRegisters { addr: a, count },
        ) => addr == a && values.len() == usize::from(*count),
        _ => false,
    }
}

/// Start-up settings (sorted by address) as write requests, each with its read-back and
/// check: contiguous registers joined into one FC 16 and one FC 3, coils one by one.
pub(super) fn setting_runs(settings: &[(Entry, Num)]) -> Vec<(Request, (Request, Check))> {
    let mut out = Vec::new();
    let mut run: Vec<(Entry, Num)> = Vec::new();
    let flush = |run: &mut Vec<(Entry, Num)>, out: &mut Vec<(Request, (Request, Check))>| {
        let Some((first, _)) = run.first() else {
            return;
        };
        let addr = first.addr();
        let mut values = Vec::new();
        let mut expected = Vec::new();
        for (e, v) in run.iter() {
            expected.push((values.len(), *e, *v));
            values.extend(e.enc.encode(*v));
        }
        let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
        out.push((
            Request::WriteMultipleRegisters { addr, values },
            (
                Request::ReadHoldingRegisters { addr, count },
                Check::Registers(expected),
            ),
        ));
        run.clear();
    };
    for (e, v) in settings {
        if e.table == Table::Bits {
            flush(&mut run, &mut out);
            out.push((
                single(e, *v),
                (
                    Request::ReadCoils {
                        addr: e.addr(),
                        count: 1,
                    },
                    Check::Bit(*e, v.int() != 0),
                ),
            ));
            continue;
        }
        let joins = run.last().is_some_and(|(last, _)| {
            usize::from(last.addr()) + usize::from(last.words()) == usize::from(e.addr())
        }) && run
            .iter()
            .map(|(e, _)| usize::from(e.words()))
            .sum::<usize>()
            + usize::from(e.words())
            <= MAX_WRITE_REGS;
        if !joins {
            flush(&mut run, &mut out);
        }
        run.push((*e, *v));
    }
    flush(&mut run, &mut out);
    out
}

/// An output to write this cycle.
#[derive(Debug, Clone, Copy)]
struct Todo {
    point: usize,
    entry: Entry,
    value: Value,
}

/// The write exchanges of one cycle.
pub(super) fn plan(d: &ResiDriver, desired: &[Option<Value>], refresh: bool) -> Vec<Step> {
    let model = d.model;
    let mut todo = Vec::new();
    let mut steps = Vec::new();
    for (p, spec) in model.points.iter().enumerate() {
        // A read-write point (a logic table, PULSE TIME, ENABLE LOGIC FUNCTIONS) is a command:
        // the scan sets it for one cycle (push-down clears its tables at stop), written then.
        let command = spec.access == Access::ReadWrite;
        if spec.access != Access::Output && !command {
            continue;
        }
        let (Some(Some(value)), Some(entry)) = (desired.get(p), model.map.by_name(spec.name))
        else {
            continue;
        };
        if command {
            todo.push(Todo {
                point: p,
                entry,
                value: *value,
            });
            continue;
        }
        let one_shot = model.one_shot.contains(&spec.name);
        let changed = d.written.get(p).copied().flatten() != Some(*value);
        if let (Some(ms), Kind::Do) = (d.watchdog, entry.item.kind) {
            watchdog(
                d,
                p,
                entry,
                value.as_bool(),
                ms,
                changed || refresh,
                &mut steps,
            );
            continue;
        }
        if changed || (refresh && !one_shot) {
            todo.push(Todo {
                point: p,
                entry,
                value: *value,
            });
        }
    }
    match d.protocol {
        Protocol::Modbus => modbus(d, &todo, &mut steps),
        Protocol::Text => text(d, &todo, &mut steps),
    }
    steps
}

fn modbus(d: &ResiDriver, todo: &[Todo], steps: &mut Vec<Step>) {
    let mut sorted: Vec<Todo> = todo.to_vec();
    sorted.sort_by_key(|t| (t.entry.table == Table::Registers, t.entry.addr()));
    let mut i = 0;
    while let Some(first) = sorted.get(i) {
        let mut end = usize::from(first.entry.addr()) + usize::from(first.entry.words());
        let mut j = i + 1;
        while let Some(next) = sorted.get(j) {
            if next.entry.table != first.entry.table || usize::from(next.entry.addr()) != end {
                break;
            }
            end += usize::from(next.entry.words());
            j += 1;
        }
        let run = sorted.get(i..j).unwrap_or_default();
        let request = match (run, first.entry.table) {
            ([one], _) => single(&one.entry, Num::from_value(one.value)),
            (_, Table::Bits) => Request::WriteMultipleCoils {
                addr: first.entry.addr(),
                values: run.iter().map(|t| t.value.as_bool()).collect(),
            },
            (_, Table::Registers) => Request::WriteMultipleRegisters {
                addr: first.entry.addr(),
                values: run
                    .iter()
                    .flat_map(|t| t.entry.enc.encode(Num::from_value(t.value)))
                    .collect(),
            },
        };
        if let Some(frame) = d.modbus(request.clone()) {
            steps.push(Step {
                frame,
                check: Check::Echo(request),
                sets: run.iter().map(|t| (t.point, t.value)).collect(),
            });
        }
        i = j;
    }
}

/// The word an item is one bit of (`RO3` → `ROS`).
fn bit_of(item: Item) -> Option<Item> {
    match item.part_of() {
        Some((word, _, 1)) => Some(word),
        _ => None,
    }
}

fn text(d: &ResiDriver, todo: &[Todo], steps: &mut Vec<Step>) {
    let model = d.model;
    let mut done = vec![false; todo.len()];
    // A word command (`SROS`) when every bit of the word is written now.
    for (i, t) in todo.iter().enumerate() {
        let Some((word, _, 1)) = t.entry.item.part_of() else {
            continue;
        };
        if done.get(i).copied().unwrap_or(true) {
            continue;
        }
        let members: Vec<usize> = todo
            .iter()
            .enumerate()
            .filter(|(_, o)| bit_of(o.entry.item) == Some(word))
            .map(|(k, _)| k)
            .collect();
        let all = model
            .points
            .iter()
            .filter_map(|p| model.map.by_name(p.name))
            .filter(|e| bit_of(e.item) == Some(word))
            .count();
        let Some((command, x)) = ascii::ascii_set(model, word) else {
            continue;
        };
        if members.len() != all || all < 2 {
            continue;
        }
        let bits = members
            .iter()
            .filter_map(|&k| todo.get(k))
            .fold(0i64, |acc, o| {
                let bit = o.entry.item.part_of().map_or(0, |(_, b, _)| b);
                acc | (i64::from(o.value.as_bool()) << bit)
            });
        steps.push(Step {
            frame: ascii::request(d.address, command, x, &[Num::Int(bits)]),
            check: Check::Ok,
            sets: members
                .iter()
                .filter_map(|&k| todo.get(k).map(|o| (o.point, o.value)))
                .collect(),
        });
        for k in members {
            if let Some(flag) = done.get_mut(k) {
                *flag = true;
            }
        }
    }
    for (i, t) in todo.iter().enumerate() {
        if done.get(i).copied().unwrap_or(true) {
            continue;
        }
        let Some((command, x)) = ascii::ascii_set(model, t.entry.item) else {
            tracing::error!(
                model = model.name,
                point = t.entry.name,
                "no ASCII command writes this output"
            );
            continue;
        };
        debug_assert!(matches!(command.action, Action::Set { .. }));
        steps.push(Step {
            frame: ascii::request(d.address, command, x, &[Num::from_value(t.value)]),
            check: Check::Ok,
            sets: vec![(t.point, t.value)],
        });
    }
}

/// 1RO DO1 driven through the off-delay (setting `SOFFDLY`): on = retrigger the off-delay
/// every cycle with DO1 itself off (cleared once at the start), off = end the off-delay and
/// clear DO1.
fn watchdog(
    d: &ResiDriver,
    point: usize,
    do1: Entry,
    on: bool,
    ms: u16,
    again: bool,
    steps: &mut Vec<Step>,
) {
    let Some(delay) = d
        .model
        .map
        .entries()
        .find(|e| e.item.kind == Kind::OffDelay)
    else {
        return;
    };
    let mut writes: Vec<(Entry, Num)> = Vec::new();
    if on {
        if d.written.get(point).copied().flatten().is_none() {
            writes.push((do1, Num::Int(0)));
        }
        writes.push((delay, Num::Int(ms.into())));
    } else if again {
        writes.push((delay, Num::Int(0)));
        writes.push((do1, Num::Int(0)));
    }
    let last = writes.len().saturating_sub(1);
    for (k, (e, v)) in writes.into_iter().enumerate() {
        let sets = if k == last {
            vec![(point, Value::Bool(on))]
        } else {
            Vec::new()
        };
        match d.protocol {
            Protocol::Modbus => {
                let request = single(&e, v);
                if let Some(frame) = d.modbus(request.clone()) {
                    steps.push(Step {
                        frame,
                        check: Check::Echo(request),
                        sets,
                    });
                }
            }
            Protocol::Text => {
                if let Some((command, x)) = ascii::ascii_set(d.model, e.item) {
                    steps.push(Step {
                        frame: ascii::request(d.address, command, x, &[v]),
                        check: Check::Ok,
                        sets,
                    });
                }
            }
        }
    }
}
