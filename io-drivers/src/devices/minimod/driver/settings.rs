//! From the module's settings to its start-up steps: which registers and coils are written,
//! in which runs, by which protocol (the order and why: [`super`]'s "Start-up settings").

use super::super::map::{self, Item, Space};
use super::super::settings::Setting;
use super::super::text::{self, TextId, WriteValue};
use super::logic;
use crate::devices::Protocol;

/// One start-up step: a write and, where possible, its read-back.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum SetupStep {
    /// Contiguous holding registers: FC 16, then FC 3.
    Registers {
        addr: u16,
        values: Vec<u16>,
        names: Vec<&'static str>,
    },
    /// Contiguous coils: FC 15, then FC 1.
    Coils {
        addr: u16,
        values: Vec<bool>,
        names: Vec<&'static str>,
    },
    /// A text write; read back with `?ID` when `verify`.
    Text {
        id: TextId,
        /// The register table's name (for errors and point values).
        name: &'static str,
        value: WriteValue,
        number: u16,
        verify: bool,
    },
}

/// The text identifier a start-up register has, if the text write table has one.
fn text_id(item: Item) -> Option<TextId> {
    Some(match item {
        Item::XlatUp(i) => TextId::XlatUp(i),
        Item::XlatDn(i) => TextId::XlatDn(i),
        Item::Xcount(i) => TextId::Xcount(i),
        Item::Lamp(i) => TextId::Lamp(i),
        Item::AutoOn(y, c) => TextId::AutoOn(y, c),
        Item::AutoOff(y, c) => TextId::AutoOff(y, c),
        Item::WdtTime => TextId::WdtTime,
        Item::WdtYMask => TextId::WdtMask,
        _ => return None,
    })
}

/// `(addr, value, name)` by address, the last of duplicates winning.
fn dedup<T: Copy>(items: Vec<(u16, T, &'static str)>) -> Vec<(u16, T, &'static str)> {
    let mut unique: Vec<(u16, T, &'static str)> = Vec::with_capacity(items.len());
    for item in items {
        unique.retain(|u| u.0 != item.0);
        unique.push(item);
    }
    unique.sort_by_key(|u| u.0);
    unique
}

/// Groups `(addr, value, name)` by address (the last of duplicates wins) into runs of
/// consecutive addresses.
pub(super) fn runs<T: Copy>(
    items: Vec<(u16, T, &'static str)>,
) -> Vec<(u16, Vec<T>, Vec<&'static str>)> {
    let mut out: Vec<(u16, Vec<T>, Vec<&'static str>)> = Vec::new();
    for (addr, value, name) in dedup(items) {
        match out.last_mut() {
            Some((start, values, names))
                if usize::from(*start) + values.len() == usize::from(addr) =>
            {
                values.push(value);
                names.push(name);
            }
            _ => out.push((addr, vec![value], vec![name])),
        }
    }
    out
}

/// The name of a coil in the map.
fn coil_name(addr: u16) -> &'static str {
    map::MAP
        .iter()
        .find(|e| e.space == Space::Coil && e.addr == addr)
        .map_or("coil", |e| e.name)
}

/// Builds the start-up steps from the settings.
pub(super) fn setup_steps(
    settings: &[Setting],
    protocol: Protocol,
    events: bool,
) -> Vec<SetupStep> {
    let mut registers: Vec<(u16, u16, &'static str)> = Vec::new();
    let mut coils: Vec<(u16, bool, &'static str)> = Vec::new();
    let mut delays: Vec<(TextId, u8)> = Vec::new();
    for s in settings {
        match *s {
            Setting::Register { name, addr, value } => registers.push((addr, value, name)),
            Setting::Coils {
                addr, count, bits, ..
            } => {
                for i in 0..u16::from(count) {
                    let a = addr + i;
                    coils.push((a, bits & (1 << i) != 0, coil_name(a)));
                }
            }
            Setting::ReplyDelay(n) => delays.push((TextId::RdelayT, n)),
            Setting::FrameTimeout(n) => delays.push((TextId::RdelayM, n)),
            _ => {}
        }
    }
    let watchdog = registers
        .iter()
        .any(|r| matches!(r.2, "WDTTIME" | "WDTYMASK"))
        || coils
            .iter()
            .any(|c| (map::WDTFB1.addr..=map::WDTFB2.addr).contains(&c.0));
    if watchdog {
        // The project owns the watchdog: a fired one left by the last run is reset once the
        // new settings are in, so the timeout starts from this start-up.
        coils.push((map::WDTFIRED.addr, false, map::WDTFIRED.name));
    }
    if events {
        // Event mode needs the module to record input variations: X1..X3 and FB1/FB2.
        if !registers.iter().any(|r| r.0 == map::XEVMASK.addr) {
            registers.insert(0, (map::XEVMASK.addr, 0b111, map::XEVMASK.name));
        }
        for a in [map::EVFB1.addr, map::EVFB1.addr + 1] {
            if !coils.iter().any(|c| c.0 == a) {
                coils.insert(0, (a, true, coil_name(a)));
            }
        }
    }
    // Logic tables and the pushed-down outputs' initial values: a sequence of their own, after
    // the watchdog reset (see `logic`).
    let logic = logic::split(&mut registers, &mut coils);
    // WDTTIME and WDTYMASK by name, whatever the protocol (see `watchdog`).
    let watchdog_by_name = super::watchdog::arm_by_name(&mut registers);
    let mut steps = Vec::new();
    if protocol == Protocol::Text {
        let mut modbus_registers = Vec::new();
        for (addr, value, name) in dedup(registers) {
            let id = map::entry(name).and_then(|e| text_id(e.item));
            let wv = match id {
                Some(TextId::AutoOn(..) | TextId::AutoOff(..)) => WriteValue::Condition(value),
                _ => WriteValue::Number(value),
            };
            match id {
                Some(id) if text::write_command(1, id, wv).is_ok() => steps.push(SetupStep::Text {
                    id,
                    name,
                    value: wv,
                    number: value,
                    verify: id.readable() && !matches!(id, TextId::Xcount(_)),
                }),
                _ => modbus_registers.push((addr, value, name)),
            }
        }
        registers = modbus_registers;
        let wdtfb = |a: u16| coils.iter().rev().find(|c| c.0 == a).map(|c| c.1);
        let (fb1, fb2) = (map::WDTFB1.addr, map::WDTFB2.addr);
        if let (Some(on1), Some(on2)) = (wdtfb(fb1), wdtfb(fb2)) {
            coils.retain(|c| c.0 != fb1 && c.0 != fb2);
            let bits = u16::from(on1) | (u16::from(on2) << 1);
            steps.push(SetupStep::Text {
                id: TextId::FbEnable,
                name: "FBENABLE",
                value: WriteValue::Number(bits),
                number: bits,
                verify: true,
            });
        }
    }
    for (addr, values, names) in runs(registers) {
        steps.push(SetupStep::Registers {
            addr,
            values,
            names,
        });
    }
    steps.extend(watchdog_by_name);
    for (addr, values, names) in runs(coils) {
        steps.push(SetupStep::Coils {
            addr,
            values,
            names,
        });
    }
    steps.extend(logic);
    for (id, n) in delays {
        let name = if id == TextId::RdelayT {
            "RDELAYT"
        } else {
            "RDELAYM"
        };
        steps.push(SetupStep::Text {
            id,
            name,
            value: WriteValue::Number(u16::from(n)),
            number: u16::from(n),
            verify: false,
        });
    }
    steps
}
