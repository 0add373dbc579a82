//! Start-up exchanges (see [`super`]), in this order:
//!
//! 1. the command registers the settings name (CLEAR ALL LOGIC FUNCTIONS, RESET COUNTER);
//! 2. on a module with internal logic (16DI8RO), **disarm**: ENABLE LOGIC FUNCTIONS = 0, then
//!    every logic table (SWITCH, TOGGLE, SWITCH ON, SWITCH OFF, PULSE of RO1..RO8) and every
//!    PULSE TIME 0, all read back. Modbus: ENABLE with FC 16 + FC 3, the 40 masks (4x20001..
//!    4x20040) in one FC 16 + FC 3, the PULSE TIMEs (4x20065..4x20080) in another. ASCII
//!    (one value per command): RESET SPECIAL MODE ("Switches logic off and sets all mapping
//!    registers to 0", 10.13.5), then GSMODE and every mask's get to check it, and SPTIMEx:0
//!    with GPTIMEx (the reset names only the mappings);
//! 3. the relays' **initial values** (`initial_ROn`), each read back;
//! 4. the read-write settings in address order, so the tables are **armed** last, ENABLE LOGIC
//!    FUNCTIONS (4x21001) after the masks it enables.
//!
//! Why every start-up clears: the tables live in FRAM ("All parameters for this logic functions
//! are stored in the internal permanent memory FRAM. After a power loss all this configuration
//! is not deleted and the module executes the logic functions again", L16434–L16436; "Writing
//! on this register saves the mapping in the non-volatile internal FRAM memory", L20990), so a
//! run that ended without its clean stop (a crash, `kill -9`) leaves them driving the relays
//! under the next program, across power cycles too. Over Modbus each table is cleared
//! explicitly rather than with CLEAR ALL LOGIC FUNCTIONS (whose reach over PULSE TIME the manual
//! leaves open, resi-spec §4.1), so the read-back checks exactly what was written.
//!
//! Why in this order: the logic "can operate side by side with control commands via
//! MODBUS/RTU or ASCII" (L16437), and it never resets a relay when a table is written: TOGGLE
//! "inverts the current state of the relay output" (L16685), SWITCH ON / SWITCH OFF / PULSE act
//! only on a rising edge (10.1.1.4–10.1.1.7). A relay left on by the crashed run therefore stays
//! on under freshly written tables, and a TOGGLE starts from it. So the relay gets the central
//! rung's start value first; and the logic is disarmed before that write ("Only if this
//! register contains 1, the internal logic functions are executed", L22516), or a stale table
//! could switch the relay again between the write and the arming.

use super::super::ascii::command::{Action, Op};
use super::super::item::Kind;
use super::super::map::{Acc, Entry, Table};
use super::super::model::Model;
use super::super::value::Num;
use super::{ascii, plan, write, Check, ResiDriver, Step};
use crate::devices::Protocol;

/// What start-up clears on a model with internal logic (the manual's names), for reports.
pub const CLEARED: &str =
    "ENABLE LOGIC FUNCTIONS, SWITCH / TOGGLE / SWITCH ON / SWITCH OFF / PULSE RO1..8, PULSE TIME RO1..8";

/// The logic registers cleared at start-up (every mask and PULSE TIME, each once, in address
/// order), or nothing for a model without internal logic.
pub(super) fn logic_tables(model: &'static Model) -> Vec<Entry> {
    if !model.hw.logic {
        return Vec::new();
    }
    let mut out: Vec<Entry> = Vec::new();
    for e in model.map.entries() {
        let table = matches!(e.item.kind, Kind::Mask(_) | Kind::PulseTime);
        if table && e.access == Acc::ReadWrite && !out.iter().any(|o| o.name == e.name) {
            out.push(e);
        }
    }
    out.sort_by_key(Entry::addr);
    out
}

/// The start-up exchanges for `writes` and the relays' `initial` values (see the module docs).
pub(super) fn steps(
    d: &ResiDriver,
    writes: &[(Entry, Num)],
    initial: &[(Entry, Num)],
) -> Vec<Step> {
    let (commands, mut settings): (Vec<_>, Vec<_>) = writes
        .iter()
        .copied()
        .partition(|(e, _)| e.access == Acc::WriteOnly);
    settings.sort_by_key(|(e, _)| (e.table == Table::Registers, e.addr()));
    let mut steps = Vec::new();
    command_steps(d, &commands, &mut steps);
    let enable = d
        .model
        .map
        .entries()
        .find(|e| e.item.kind == Kind::EnableLogic && e.access == Acc::ReadWrite);
    if let (Some(enable), true) = (enable, d.model.hw.logic) {
        let zero = |e: Entry| (e, Num::Int(0));
        let (masks, times): (Vec<Entry>, Vec<Entry>) = logic_tables(d.model)
            .into_iter()
            .partition(|e| matches!(e.item.kind, Kind::Mask(_)));
        let reset = ascii::ascii_op(d.model, Op::ClearLogic);
        match (d.protocol, reset) {
            (Protocol::Text, Some(reset)) => {
                steps.push(Step {
                    frame: ascii::request(d.address, reset, 1, &[]),
                    check: Check::Ok,
                    sets: Vec::new(),
                });
                for e in std::iter::once(enable).chain(masks) {
                    steps.extend(ascii_get(d, e, Num::Int(0)));
                }
            }
            _ => {
                setting_steps(d, &[zero(enable)], &mut steps);
                let masks: Vec<_> = masks.into_iter().map(zero).collect();
                setting_steps(d, &masks, &mut steps);
            }
        }
        let times: Vec<_> = times.into_iter().map(zero).collect();
        setting_steps(d, &times, &mut steps);
    }
    let mut initial = initial.to_vec();
    initial.sort_by_key(|(e, _)| e.addr());
    setting_steps(d, &initial, &mut steps);
    setting_steps(d, &settings, &mut steps);
    steps
}

/// Command registers: written, not read back (they read 0).
fn command_steps(d: &ResiDriver, commands: &[(Entry, Num)], steps: &mut Vec<Step>) {
    match d.protocol {
        Protocol::Modbus => {
            for (e, v) in commands {
                let req = write::single(e, *v);
                if let Some(frame) = d.modbus(req.clone()) {
                    steps.push(Step {
                        frame,
                        check: Check::Echo(req),
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
        }
    }
}

/// Values written and read back; `settings` sorted by table and address.
fn setting_steps(d: &ResiDriver, settings: &[(Entry, Num)], steps: &mut Vec<Step>) {
    match d.protocol {
        Protocol::Modbus => {
            for (req, check) in write::setting_runs(settings) {
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
            for &(e, v) in settings {
                let set = ascii::ascii_set(d.model, e.item);
                let (Some((sc, sx)), Some(get)) = (set, ascii_get(d, e, v)) else {
                    tracing::error!(
                        model = d.model.name,
                        setting = e.name,
                        "no ASCII command writes this setting"
                    );
                    continue;
                };
                steps.push(Step {
                    frame: ascii::request(d.address, sc, sx, &[v]),
                    check: Check::Ok,
                    sets: Vec::new(),
                });
                steps.push(get);
            }
        }
    }
}

/// The ASCII get that checks `e` holds `v`.
fn ascii_get(d: &ResiDriver, e: Entry, v: Num) -> Option<Step> {
    let (gc, gx, k) = plan::ascii_get(d.model, e.item)?;
    let at = match gc.action {
        Action::Get { fmt, .. } => plan::position(fmt, k),
        _ => k,
    };
    Some(Step {
        frame: ascii::request(d.address, gc, gx, &[]),
        check: Check::Answer {
            command: gc,
            x: gx,
            at,
            entry: e,
            expected: v,
        },
        sets: Vec::new(),
    })
}
