//! Start-up exchanges: command registers first, then the read-write settings in address
//! order, each written and read back (see [`super`]).

use super::super::ascii::command::{Action, Op};
use super::super::item::Kind;
use super::super::map::{Acc, Entry, Table};
use super::super::value::Num;
use super::{ascii, plan, write, Check, ResiDriver, Step};
use crate::devices::Protocol;

/// The start-up exchanges for `writes` (see [`super`]).
pub(super) fn steps(d: &ResiDriver, writes: &[(Entry, Num)]) -> Vec<Step> {
    let (commands, mut settings): (Vec<_>, Vec<_>) = writes
        .iter()
        .copied()
        .partition(|(e, _)| e.access == Acc::WriteOnly);
    settings.sort_by_key(|(e, _)| (e.table == Table::Registers, e.addr()));
    let mut steps = Vec::new();
    match d.protocol {
        Protocol::Modbus => {
            for (e, v) in commands {
                let req = write::single(&e, v);
                if let Some(frame) = d.modbus(req.clone()) {
                    steps.push(Step {
                        frame,
                        check: Check::Echo(req),
                        sets: Vec::new(),
                    });
                }
            }
            for (req, check) in write::setting_runs(&settings) {
                if let Some(frame) = d.modbus(req.clone()) {
                    steps.push(Step {
                        frame,
                        check: Check::Echo(req),
                        sets: Vec::new(),
                    });
                }
                if let Some(frame) = d.modbus(check.0) {
                    steps.push(Step {
                        frame,
                        check: check.1,
                        sets: Vec::new(),
                    });
                }
            }
        }
        Protocol::Text => {
            for (e, _) in commands {
                let op = match e.item.kind {
                    Kind::ClearLogic => Op::ClearLogic,
                    _ => Op::ResetCounters,
                };
                if let Some(c) = ascii::ascii_op(d.model, op) {
                    steps.push(Step {
                        frame: ascii::request(d.address, c, 1, &[]),
                        check: Check::Ok,
                        sets: Vec::new(),
                    });
                }
            }
            for (e, v) in settings {
                let set = ascii::ascii_set(d.model, e.item);
                let get = plan::ascii_get(d.model, e.item);
                let (Some((sc, sx)), Some((gc, gx, k))) = (set, get) else {
                    tracing::error!(
                        model = d.model.name,
                        setting = e.name,
                        "no ASCII command writes this setting"
                    );
                    continue;
                };
                let at = match gc.action {
                    Action::Get { fmt, .. } => plan::position(fmt, k),
                    _ => k,
                };
                steps.push(Step {
                    frame: ascii::request(d.address, sc, sx, &[v]),
                    check: Check::Ok,
                    sets: Vec::new(),
                });
                steps.push(Step {
                    frame: ascii::request(d.address, gc, gx, &[]),
                    check: Check::Answer {
                        command: gc,
                        x: gx,
                        at,
                        entry: e,
                        expected: v,
                    },
                    sets: Vec::new(),
                });
            }
        }
    }
    steps
}
