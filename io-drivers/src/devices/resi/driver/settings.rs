//! The project-file `settings` of a RESI module, checked before the first scan.
//!
//! - `poll`: the points read every cycle, as a comma-separated list of point names; `NAME*`
//!   stands for a numbered run (`RISE_DI*` = RISE_DI1..RISE_DI16; `DI*` does not match `DIS`).
//!   Default: the model's inputs and outputs (16DI8RO: `DI*, RO*`).
//! - `reply_delay`: the module's answer delay for the line budget, ms (`5` or `5ms`; default
//!   2 ms — the manual gives no figure).
//! - every **read-write point** of the model (16DI8RO: `SWITCH_RO1`, `TOGGLE_RO4`,
//!   `PULSE_TIME_RO1`, `ENABLE_LOGIC_FUNCTIONS`, ...): written at start-up and verified by
//!   reading it back; a difference stops the start. Names are case-insensitive and may be
//!   written with spaces as in the manual (`SWITCH ON RO1`). Values: decimal, `0x` hex, `0b`
//!   binary (`.`/`_` separators allowed), reals for 2RTD offsets.
//! - the **command registers** `CLEAR_ALL_LOGIC_FUNCTIONS` (16DI8RO) and `RESET_COUNTER`:
//!   written first at start-up, not read back (they read 0).
//! - 1RO `SOFFDLY` (1..=65535 ms): drive DO1 through the off-delay, which the manual offers as
//!   a watchdog (L4102–L4110): while the program wants DO1 on, every cycle retriggers the
//!   off-delay instead of setting DO1, so the relay drops within that time when the host stops.
//! - 16DI8RO `initial_RO1..8` (0 or 1): the relay's value written at start-up after the logic
//!   is disarmed and before its tables are armed (the push-down planner sets it for a relay
//!   whose pushed-down rung keeps a state: TOGGLE, SWITCH ON / OFF, PULSE; see
//!   `startup.rs`).

use std::time::Duration;

use crate::devices::config::{parse_each, Accepted, KeyError, Range};
use crate::devices::resi::item::Kind;
use crate::devices::resi::map::{Acc, Entry};
use crate::devices::resi::model::Model;
use crate::devices::resi::value::Num;
use crate::point::Access;

pub(crate) use crate::devices::config::SettingError;

/// One validated setting.
#[derive(Debug, Clone, PartialEq)]
pub enum Setting {
    /// Points read every cycle (indexes into the model's points).
    Poll(Vec<usize>),
    /// The answer delay for the budget.
    ReplyDelay(Duration),
    /// A value written at start-up (verified unless it is a command register).
    Write {
        /// The map entry.
        entry: Entry,
        /// The value.
        value: Num,
    },
    /// 1RO `SOFFDLY`, ms.
    Watchdog(u16),
    /// 16DI8RO `initial_ROn`: the relay's value before the logic is armed.
    Initial {
        /// The relay's coil.
        entry: Entry,
        /// Its value.
        on: bool,
    },
}

/// The key prefix of a relay's initial value (`initial_RO4: 0`).
pub(crate) const INITIAL_PREFIX: &str = "initial_";

/// Whether `name` matches `pattern` (`NAME` or `NAME*`, `*` = one or more digits).
pub(crate) fn matches(pattern: &str, name: &str) -> bool {
    match pattern.strip_suffix('*') {
        Some(prefix) => name
            .strip_prefix(prefix)
            .is_some_and(|rest| !rest.is_empty() && rest.bytes().all(|b| b.is_ascii_digit())),
        None => pattern == name,
    }
}

/// Indexes of the points `patterns` name.
pub(crate) fn select(model: &'static Model, patterns: &[&str]) -> Result<Vec<usize>, SettingError> {
    let mut out = Vec::new();
    for pattern in patterns {
        let p = pattern.trim().to_ascii_uppercase().replace(' ', "_");
        let before = out.len();
        for (i, spec) in model.points.iter().enumerate() {
            if matches(&p, spec.name) && !out.contains(&i) {
                out.push(i);
            }
        }
        if out.len() == before && !model.points.iter().any(|s| matches(&p, s.name)) {
            let trimmed = pattern.trim();
            return Err(SettingError::NoSuchPoint {
                model: model.name,
                at: 0,
                len: trimmed.len(),
            });
        }
    }
    Ok(out)
}

fn number(text: &str) -> Option<Num> {
    let t = text.trim();
    if let Some(h) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        return i64::from_str_radix(h, 16).ok().map(Num::Int);
    }
    if let Some(b) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        return i64::from_str_radix(&b.replace(['.', '_'], ""), 2)
            .ok()
            .map(Num::Int);
    }
    if let Ok(v) = t.parse::<i64>() {
        return Some(Num::Int(v));
    }
    t.parse::<f64>()
        .ok()
        .filter(|f| f.is_finite())
        .map(Num::Real)
}

/// The entry a start-up write of `key` reaches: a read-write point, or a command register.
fn writable(model: &'static Model, key: &str) -> Option<Entry> {
    let name = key.trim().to_ascii_uppercase().replace(' ', "_");
    let entry = model.map.by_name(&name)?;
    let is_rw_point = model
        .points
        .iter()
        .any(|p| p.name == entry.name && p.access == Access::ReadWrite);
    let is_command = entry.access == Acc::WriteOnly
        && matches!(entry.item.kind, Kind::ClearLogic | Kind::ResetCounter);
    (is_rw_point && entry.access == Acc::ReadWrite || is_command).then_some(entry)
}

/// Parses one `key: value` of a module's `settings`.
pub(crate) fn parse(
    model: &'static Model,
    key: &str,
    value: &str,
) -> Result<Setting, SettingError> {
    if key.eq_ignore_ascii_case("poll") {
        // Each pattern with its byte offset in the value, for the error.
        let mut patterns: Vec<(usize, &str)> = Vec::new();
        let mut at = 0;
        for piece in value.split(',') {
            let lead = piece.len() - piece.trim_start().len();
            if !piece.trim().is_empty() {
                patterns.push((at + lead, piece.trim()));
            }
            at += piece.len() + 1;
        }
        if patterns.is_empty() {
            return Err(SettingError::BadValue {
                key: "poll",
                expected: "a comma-separated list of point names (NAME or NAME*)",
            });
        }
        for &(at, pattern) in &patterns {
            if let Err(SettingError::NoSuchPoint { model, len, .. }) = select(model, &[pattern]) {
                return Err(SettingError::NoSuchPoint { model, at, len });
            }
        }
        let names: Vec<&str> = patterns.iter().map(|(_, p)| *p).collect();
        return select(model, &names).map(Setting::Poll);
    }
    if key.eq_ignore_ascii_case("reply_delay") {
        return value
            .trim()
            .trim_end_matches("ms")
            .trim()
            .parse::<u64>()
            .ok()
            .filter(|ms| *ms <= 10_000)
            .map(|ms| Setting::ReplyDelay(Duration::from_millis(ms)))
            .ok_or(SettingError::OutOfRange {
                key: "reply_delay",
                range: Range {
                    min: 0,
                    max: 10_000,
                    unit: " ms",
                },
            });
    }
    if key.eq_ignore_ascii_case("SOFFDLY") && model.hw.one_relay {
        return match number(value) {
            Some(Num::Int(ms @ 1..=65535)) => Ok(Setting::Watchdog(ms as u16)),
            _ => Err(SettingError::OutOfRange {
                key: "SOFFDLY",
                range: Range {
                    min: 1,
                    max: 65535,
                    unit: " (ms)",
                },
            }),
        };
    }
    if let Some(relay) = key
        .get(..INITIAL_PREFIX.len())
        .filter(|p| p.eq_ignore_ascii_case(INITIAL_PREFIX))
        .and_then(|_| key.get(INITIAL_PREFIX.len()..))
        .filter(|_| model.hw.logic)
    {
        let name = relay.trim().to_ascii_uppercase();
        let entry = model
            .map
            .by_name(&name)
            .filter(|e| e.item.kind == Kind::Ro)
            .ok_or(SettingError::BadValue {
                key: "initial_ROn",
                expected: "a relay RO1..RO8",
            })?;
        return match number(value) {
            Some(Num::Int(v @ 0..=1)) => Ok(Setting::Initial { entry, on: v == 1 }),
            _ => Err(SettingError::BadValue {
                key: "initial_ROn",
                expected: "0 or 1",
            }),
        };
    }
    let entry = writable(model, key).ok_or(SettingError::UnknownKey {
        model: model.name,
        accepted: Accepted::Resi {
            example: model
                .points
                .iter()
                .find(|p| p.access == Access::ReadWrite)
                .map_or("none", |p| p.name),
        },
    })?;
    let expected = if entry.item.kind.is_real() {
        "a number"
    } else {
        match entry.enc.words() {
            1 => "an integer 0..=65535",
            _ => "an integer 0..=4294967295",
        }
    };
    let bad = SettingError::BadValue {
        key: entry.name,
        expected,
    };
    let v = number(value).ok_or(bad)?;
    let v = if entry.item.kind.is_real() {
        Num::Real(v.real())
    } else {
        v
    };
    if matches!(v, Num::Real(_)) && !entry.item.kind.is_real() || !entry.enc.fits(v) {
        return Err(bad);
    }
    Ok(Setting::Write { entry, value: v })
}

/// Every key of `model` (the catalog's `setting_keys`): `poll`, `reply_delay`, 1RO `SOFFDLY`,
/// then each register a setting writes.
pub(crate) fn keys(model: &'static Model) -> Vec<&'static str> {
    let mut out = vec!["poll", "reply_delay"];
    if model.hw.one_relay {
        out.push("SOFFDLY");
    }
    out.extend(
        model
            .map
            .entries()
            .filter(|e| writable(model, e.name).is_some())
            .map(|e| e.name),
    );
    out.dedup();
    out
}

/// A RESI module's settings, parsed once from its project entry, in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Settings {
    items: Vec<Setting>,
}

impl Settings {
    /// Parses every `key: value` of the entry for `model`; every refusal comes back with its
    /// index.
    pub fn parse(model: &'static Model, pairs: &[(String, String)]) -> Result<Self, Vec<KeyError>> {
        parse_each(pairs, |k, v| parse(model, k, v)).map(|items| Self { items })
    }

    /// Every setting, in file order.
    pub fn items(&self) -> &[Setting] {
        &self.items
    }

    /// The value the settings write to the map entry `name` (`ENABLE_LOGIC_FUNCTIONS`), the
    /// last one winning.
    pub fn write_value(&self, name: &str) -> Option<Num> {
        self.items.iter().rev().find_map(|s| match s {
            Setting::Write { entry, value } if entry.name == name => Some(*value),
            _ => None,
        })
    }

    /// Whether a setting writes the map entry `name` (`SWITCH_RO1`; `RO1` for its start
    /// value).
    pub fn sets(&self, name: &str) -> bool {
        self.items.iter().any(|s| match s {
            Setting::Write { entry, .. } | Setting::Initial { entry, .. } => entry.name == name,
            _ => false,
        })
    }

    /// The `poll` list (indexes into the model's points), if the entry gives one.
    pub fn poll(&self) -> Option<&[usize]> {
        self.items.iter().rev().find_map(|s| match s {
            Setting::Poll(points) => Some(points.as_slice()),
            _ => None,
        })
    }

    /// 1RO `SOFFDLY`, ms.
    pub fn off_delay(&self) -> Option<u16> {
        self.items.iter().rev().find_map(|s| match s {
            Setting::Watchdog(ms) => Some(*ms),
            _ => None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::resi::models::{m16di8ro, m1ro, m2rtd};

    #[test]
    fn patterns() {
        assert!(matches("DI*", "DI16"));
        assert!(!matches("DI*", "DIS"));
        assert!(!matches("DI*", "DIP1") && !matches("DI*", "DI"));
        assert!(matches("DIS", "DIS"));
        let m = &m16di8ro::MODEL;
        assert_eq!(select(m, &["DI*", "RO*"]).unwrap().len(), 24);
        assert_eq!(select(m, &["rise di*"]).unwrap().len(), 16);
        assert!(select(m, &["DI17"]).is_err());
    }

    #[test]
    fn the_keys_are_what_parses() {
        let k = keys(&m16di8ro::MODEL);
        for key in [
            "poll",
            "SWITCH_RO1",
            "PULSE_TIME_RO8",
            "ENABLE_LOGIC_FUNCTIONS",
        ] {
            assert!(k.contains(&key), "{key}");
        }
        assert!(!k.contains(&"RO1") && !k.contains(&"SOFFDLY"));
        assert!(keys(&m1ro::MODEL).contains(&"SOFFDLY"));
    }

    #[test]
    fn keys_and_values() {
        let m = &m16di8ro::MODEL;
        let Setting::Write { entry, value } = parse(m, "SWITCH_RO1", "0x0001").unwrap() else {
            panic!()
        };
        assert_eq!((entry.reference, value), (20001, Num::Int(1)));
        let Setting::Write { entry, .. } = parse(m, "switch on ro1", "15").unwrap() else {
            panic!()
        };
        assert_eq!(entry.name, "SWITCH_ON_RO1");
        assert!(parse(m, "PULSE_TIME_RO4", "300").is_ok());
        assert!(parse(m, "PULSE_TIME_RO4", "4294967296").is_err());
        assert!(parse(m, "SWITCH_RO1", "65536").is_err());
        assert!(parse(m, "SWITCH_RO1", "1.5").is_err());
        assert!(parse(m, "TOGGLE_RO4", "0b0000_0011").is_ok());
        assert!(parse(m, "CLEAR_ALL_LOGIC_FUNCTIONS", "1").is_ok());
        assert!(
            parse(m, "RO1", "1").is_err(),
            "outputs belong to the program"
        );
        assert!(parse(m, "DIS", "1").is_err(), "read-only");
        assert!(parse(m, "SOFFDLY", "5000").is_err(), "1RO only");
        let e = parse(m, "nope", "1").unwrap_err();
        assert_eq!(
            e,
            SettingError::UnknownKey {
                model: "resi-16di8ro",
                accepted: Accepted::Resi {
                    example: "SWITCH_RO1"
                }
            }
        );
        assert!(e
            .to_string()
            .starts_with("not a resi-16di8ro setting; accepted: poll"));
        assert_eq!(
            parse(m, "reply_delay", "5ms"),
            Ok(Setting::ReplyDelay(Duration::from_millis(5)))
        );
        assert!(parse(m, "poll", "DI*, RISE_DI1").is_ok());
        assert!(parse(m, "poll", "").is_err());
        let e = parse(m, "poll", "DI*,  DI17").unwrap_err();
        assert_eq!(
            e,
            SettingError::NoSuchPoint {
                model: "resi-16di8ro",
                at: 6,
                len: 4
            }
        );
        assert_eq!(
            e.describe("DI*,  DI17"),
            "poll: \"DI17\" names no point of resi-16di8ro"
        );
        assert_eq!(
            parse(&m1ro::MODEL, "SOFFDLY", "0"),
            Err(SettingError::OutOfRange {
                key: "SOFFDLY",
                range: Range {
                    min: 1,
                    max: 65535,
                    unit: " (ms)"
                }
            })
        );
        assert_eq!(
            parse(&m1ro::MODEL, "SOFFDLY", "5000"),
            Ok(Setting::Watchdog(5000))
        );
        assert!(parse(&m1ro::MODEL, "SOFFDLY", "0").is_err());
        assert!(parse(&m2rtd::MODEL, "CH1_ZERO_OFFSET", "-0.25").is_ok());
        let Setting::Initial { entry, on } = parse(m, "initial_RO4", "1").unwrap() else {
            panic!()
        };
        assert_eq!((entry.name, entry.addr(), on), ("RO4", 19, true));
        assert!(parse(m, "initial_RO9", "0").is_err());
        assert!(parse(m, "initial_DI1", "0").is_err());
        assert!(parse(m, "initial_RO1", "2").is_err());
        assert!(
            parse(&m1ro::MODEL, "initial_DO1", "0").is_err(),
            "no internal logic"
        );
    }
}
