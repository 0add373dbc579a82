//! What the push-down planner hands a RESI-16DI8RO's driver, typed: one logic-table row per
//! relay (SWITCH, TOGGLE, SWITCH ON / SWITCH OFF, PULSE with its PULSE TIME; manual 10.1.1,
//! `resi-spec.md` §4.5) and the relays' start values.
//!
//! The driver writes them at start-up with the module's own settings (masks and PULSE TIMEs
//! before ENABLE LOGIC FUNCTIONS, which the rows set to 1 unless the project sets it, in
//! address order), after its logic was disarmed and the start values written (see the
//! driver's `startup.rs`), and reads them back.

use std::fmt;

use super::driver::settings::{Setting, Settings};
use super::item::{Func, Item, Kind};
use super::map::Acc;
use super::model::Model;
use super::value::Num;
use crate::devices::config::numbered_point;

numbered_point!(
    /// A relay RO1..RO8.
    Relay,
    "RO",
    1..=8
);

impl Relay {
    fn index(self) -> u8 {
        self.0 - 1
    }
}

/// A set of inputs DI1..DI16 as the logic masks hold it: bit n = DI(n+1).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Inputs(pub u16);

impl fmt::Display for Inputs {
    /// `DI1 DI4`; `unused` for none.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.0 == 0 {
            return f.write_str("unused");
        }
        let mut first = true;
        for i in (0..16).filter(|i| self.0 & (1 << i) != 0) {
            if !first {
                f.write_str(" ")?;
            }
            first = false;
            write!(f, "DI{}", i + 1)?;
        }
        Ok(())
    }
}

/// PULSE TIME in tenths of a second, 1..=2^31-1 (4x20065, L21469: a 32-bit register; 0 starts
/// no pulse).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PulseTime(u32);

impl PulseTime {
    /// `tenths` of a second if the register takes it.
    pub fn from_tenths(tenths: u32) -> Option<Self> {
        (1..=i32::MAX as u32)
            .contains(&tenths)
            .then_some(Self(tenths))
    }

    /// The register value.
    pub fn tenths(self) -> u32 {
        self.0
    }
}

/// What a relay's row of the logic table does.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RelayFunction {
    /// SWITCH: the relay takes the level of its input.
    Switch(Inputs),
    /// TOGGLE: a rising edge of a mapped input inverts it.
    Toggle(Inputs),
    /// SWITCH ON sets it on a rising edge of `on`, SWITCH OFF resets it on one of `off`
    /// (after SWITCH ON, so reset wins).
    SwitchOnOff {
        /// SWITCH ON's inputs.
        on: Inputs,
        /// SWITCH OFF's inputs.
        off: Inputs,
    },
    /// PULSE: a rising edge sets it and (re)starts a timer of `time`, at whose end it drops.
    Pulse {
        /// The inputs.
        inputs: Inputs,
        /// PULSE TIME.
        time: PulseTime,
    },
}

impl RelayFunction {
    /// The five masks, in register order (SWITCH, TOGGLE, SWITCH ON, SWITCH OFF, PULSE).
    fn masks(self) -> [(Func, Inputs); 5] {
        let mut m = Func::ALL.map(|f| (f, Inputs(0)));
        let mut set = |func: Func, inputs: Inputs| {
            if let Some(slot) = m.iter_mut().find(|(f, _)| *f == func) {
                slot.1 = inputs;
            }
        };
        match self {
            RelayFunction::Switch(i) => set(Func::Switch, i),
            RelayFunction::Toggle(i) => set(Func::Toggle, i),
            RelayFunction::SwitchOnOff { on, off } => {
                set(Func::SwitchOn, on);
                set(Func::SwitchOff, off);
            }
            RelayFunction::Pulse { inputs, .. } => set(Func::Pulse, inputs),
        }
        m
    }
}

/// One relay's row: its five masks (the functions it does not use at 0) and, for PULSE, its
/// PULSE TIME.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct LogicRow {
    /// The relay.
    pub relay: Relay,
    /// What it does.
    pub function: RelayFunction,
}

/// A register a row writes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RowRegister {
    /// The register's name in the model's map (`SWITCH_RO3`).
    pub name: &'static str,
    /// Its value.
    pub value: u32,
    /// What it holds: the inputs of a mask, else `None` (PULSE TIME).
    pub inputs: Option<Inputs>,
}

impl LogicRow {
    /// The registers it writes, by the map's names: the five masks, then PULSE TIME for a
    /// PULSE.
    pub fn registers(&self, model: &'static Model) -> Vec<RowRegister> {
        let index = self.relay.index();
        let entry = |kind| model.map.by_item(Item { kind, index });
        let mut out: Vec<RowRegister> = self
            .function
            .masks()
            .into_iter()
            .filter_map(|(f, inputs)| {
                Some(RowRegister {
                    name: entry(Kind::Mask(f))?.name,
                    value: u32::from(inputs.0),
                    inputs: Some(inputs),
                })
            })
            .collect();
        if let RelayFunction::Pulse { time, .. } = self.function {
            out.extend(entry(Kind::PulseTime).map(|e| RowRegister {
                name: e.name,
                value: time.tenths(),
                inputs: None,
            }));
        }
        out
    }
}

/// Everything the planner pushes into one RESI-16DI8RO.
#[derive(Debug, Clone, PartialEq, Eq, Hash, Default)]
pub struct LogicTable {
    /// One row per relay at most.
    pub rows: Vec<LogicRow>,
    /// Start values of relays whose row keeps a state (TOGGLE, SWITCH ON / OFF, PULSE),
    /// written after the logic is disarmed and before the rows are armed.
    pub initial: Vec<(Relay, bool)>,
}

impl LogicTable {
    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.rows.is_empty() && self.initial.is_empty()
    }

    /// The start-up settings it adds to the module's own: the rows' registers, the start
    /// values, ENABLE LOGIC FUNCTIONS = 1 unless the project sets it, and the rows' relays in
    /// the poll list when the project gives its own (the default list reads every relay), so
    /// the image shows what the logic did.
    pub fn settings(&self, model: &'static Model, own: &Settings) -> Vec<Setting> {
        let mut out = Vec::new();
        let map = model.map;
        for row in &self.rows {
            for r in row.registers(model) {
                if let Some(entry) = map.by_name(r.name) {
                    let value = Num::Int(i64::from(r.value));
                    out.push(Setting::Write { entry, value });
                }
            }
        }
        for &(relay, on) in &self.initial {
            let item = Item {
                kind: Kind::Ro,
                index: relay.index(),
            };
            if let Some(entry) = map.by_item(item) {
                out.push(Setting::Initial { entry, on });
            }
        }
        if self.rows.is_empty() {
            return out;
        }
        let enable = map
            .entries()
            .find(|e| e.item.kind == Kind::EnableLogic && e.access == Acc::ReadWrite);
        if let Some(entry) = enable.filter(|e| !own.sets(e.name)) {
            out.push(Setting::Write {
                entry,
                value: Num::Int(1),
            });
        }
        if let Some(poll) = own.poll() {
            let mut poll = poll.to_vec();
            for row in &self.rows {
                let name = row.relay.to_string();
                if let Some(i) = model.points.iter().position(|p| p.name == name) {
                    if !poll.contains(&i) {
                        poll.push(i);
                    }
                }
            }
            out.push(Setting::Poll(poll));
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::models::m16di8ro::MODEL;

    #[test]
    fn a_pulse_row_writes_its_masks_and_its_pulse_time() {
        let row = LogicRow {
            relay: Relay::named("RO2").unwrap(),
            function: RelayFunction::Pulse {
                inputs: Inputs(0b1001),
                time: PulseTime::from_tenths(300).unwrap(),
            },
        };
        let regs: Vec<(&str, u32)> = row
            .registers(&MODEL)
            .iter()
            .map(|r| (r.name, r.value))
            .collect();
        assert_eq!(
            regs,
            vec![
                ("SWITCH_RO2", 0),
                ("TOGGLE_RO2", 0),
                ("SWITCH_ON_RO2", 0),
                ("SWITCH_OFF_RO2", 0),
                ("PULSE_RO2", 9),
                ("PULSE_TIME_RO2", 300),
            ]
        );
        assert_eq!(Inputs(0b1001).to_string(), "DI1 DI4");
        assert_eq!(PulseTime::from_tenths(0), None);
    }

    #[test]
    fn rows_enable_the_logic_and_join_a_projects_poll_list() {
        let table = LogicTable {
            rows: vec![LogicRow {
                relay: Relay::new(1).unwrap(),
                function: RelayFunction::Toggle(Inputs(1)),
            }],
            initial: vec![(Relay::new(1).unwrap(), false)],
        };
        let own = Settings::parse(&MODEL, &[("poll".into(), "DI*".into())]).unwrap();
        let s = table.settings(&MODEL, &own);
        let writes: Vec<(&str, Num)> = s
            .iter()
            .filter_map(|x| match x {
                Setting::Write { entry, value } => Some((entry.name, *value)),
                _ => None,
            })
            .collect();
        assert!(writes.contains(&("TOGGLE_RO1", Num::Int(1))));
        assert!(writes.contains(&("ENABLE_LOGIC_FUNCTIONS", Num::Int(1))));
        let Some(Setting::Poll(poll)) = s.iter().find(|x| matches!(x, Setting::Poll(_))) else {
            panic!("{s:?}")
        };
        assert_eq!(poll.len(), 17, "DI1..DI16 and RO1");
        assert!(s
            .iter()
            .any(|x| matches!(x, Setting::Initial { entry, on: false } if entry.name == "RO1")));
        // The project's own ENABLE_LOGIC_FUNCTIONS stays the only one.
        let own =
            Settings::parse(&MODEL, &[("ENABLE_LOGIC_FUNCTIONS".into(), "1".into())]).unwrap();
        let s = table.settings(&MODEL, &own);
        assert!(!s.iter().any(
            |x| matches!(x, Setting::Write { entry, .. } if entry.name == "ENABLE_LOGIC_FUNCTIONS")
        ));
        assert!(
            !s.iter().any(|x| matches!(x, Setting::Poll(_))),
            "the default list reads RO*"
        );
    }
}
