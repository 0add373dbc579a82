//! The MiniMod's project-file `settings`: what the driver reads besides the inputs, event mode,
//! and the registers it configures at start-up.
//!
//! Keys are case-insensitive; numbers are decimal, `0x` hex or `0b` binary (`.`, `_` and `-`
//! may group binary digits, as the manual writes masks: `0b0000.0010-0000.0011`).
//!
//! | key | value | meaning |
//! |---|---|---|
//! | `readback` | `off` \| `every` \| N | read Y1..Y4 back every Nth cycle (default off) |
//! | `counters` | `off` \| `every` \| N | read XCOUNT1..3 every Nth cycle (default off) |
//! | `status` | `off` \| `every` \| N | read the module status (WDTFIRED, WDTFB, WDTCOMM, EVENTSPRS, GENERICFAIL, FLASHFAIL, SW3, SW4) every Nth cycle (default off) |
//! | `events` | `true` \| `false` | event mode: inputs from FC 70 Collect (not given: false for the driver; a project's validation chooses per line, Collect where its floor is lower) |
//! | `event_refresh` | `500ms`, `2s`, or ms | event mode: a full input read when nothing addressed to the module was answered for this long (default 1 s; a write's echo counts) |
//! | `event_resync` | `500ms`, `30s`, or ms | event mode: a full input read at least this often, whatever answered (default 30 s) |
//! | `RDELAYT` | 0..=200 | reply delay in 1/100 s, set at start-up with `>RDELAYT=` |
//! | `RDELAYM` | 0..=200 | extra end-of-frame silence in 1/10 ms, set with `>RDELAYM=` |
//! | `XLATUP1..3` / `X1LATUP..X3LATUP` | ms | rising-edge latency |
//! | `XLATDN1..3` / `X1LATDN..X3LATDN` | ms | falling-edge latency |
//! | `XCOUNT1..3` | 0..=65535 | counter preset |
//! | `Y1AON1..Y4AON3`, `Y1AOFF1..Y4AOFF3` | mask or `X1-X2` | automatic output conditions |
//! | `YLAMP1..4` / `Y1LAMP..Y4LAMP` | mask | blinkers |
//! | `WDTTIME` | 1/100 s | watchdog communication timeout |
//! | `WDTYMASK` / `WDTMASK` | mask | outputs while the watchdog fires |
//! | `FBENABLE` | 0..=3 | feedbacks that fire the watchdog (= `WDTFB1`, `WDTFB2`) |
//! | `WDTFB1`, `WDTFB2`, `EVFB1`, `EVFB2` | 0/1 | the coils |
//! | `XEVMASK`, `YEVMASK` | mask | event recording masks |
//!
//! Every register setting is written at start-up and read back; a difference stops the start
//! with the module's and the register's names (counters are not compared: they count while
//! being read back). Reply delays have no register: they are verified by the module's `OK`.

use std::time::Duration;

use super::map::{self, parse_condition, ConditionError, Item, Space};
pub use crate::devices::config::SettingError;
use crate::devices::config::{parse_each, Accepted, KeyError, Range};

/// How often an optional read runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Readback {
    /// Never.
    #[default]
    Off,
    /// Every Nth cycle (1 = every cycle).
    Every(u16),
}

impl Readback {
    /// Whether the read runs in cycle `cycle` (counted from 0).
    pub fn due(self, cycle: u64) -> bool {
        match self {
            Readback::Off => false,
            Readback::Every(n) => cycle % u64::from(n.max(1)) == 0,
        }
    }
}

/// Default longest time in event mode without an answered exchange addressed to the module.
pub(crate) const DEFAULT_EVENT_REFRESH: Duration = Duration::from_secs(1);
/// Default longest time in event mode without a full read. It bounds one case only: events
/// lost with no gap in SLVSEQ to show it (event recording switched off by a power cycle shorter
/// than `event_refresh`, the rarest failure of the round); a lost event with a gap, a failed
/// round and a silent module are each handled at once or within `event_refresh`. A full read
/// costs a cycle a whole exchange with the reply delay (20 ms on a factory-default MiniMod at
/// 19200, 40 % of the manual's 50 ms cycle), so a period of seconds is what keeps it out of a
/// line's p99.
pub(crate) const DEFAULT_EVENT_RESYNC: Duration = Duration::from_secs(30);

/// One validated setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `readback`.
    Readback(Readback),
    /// `counters`.
    Counters(Readback),
    /// `status`.
    Status(Readback),
    /// `events`.
    Events(bool),
    /// `event_refresh`.
    EventRefresh(Duration),
    /// `event_resync`.
    EventResync(Duration),
    /// `RDELAYT`, hundredths of a second.
    ReplyDelay(u8),
    /// `RDELAYM`, tenths of a millisecond.
    FrameTimeout(u8),
    /// A holding register written at start-up.
    Register {
        /// The register table's name.
        name: &'static str,
        /// Protocol address (0-based).
        addr: u16,
        /// The value.
        value: u16,
    },
    /// Consecutive coils written at start-up (`FBENABLE` is WDTFB1..2).
    Coils {
        /// The name as given (`FBENABLE`, `WDTFB1`).
        name: &'static str,
        /// Protocol address of the first coil (0-based).
        addr: u16,
        /// How many coils (1 or 2).
        count: u8,
        /// Their values, bit 0 first.
        bits: u8,
    },
}

/// Parses a number: decimal, `0x` hex, `0b` binary.
pub(crate) fn parse_number(text: &str) -> Option<u64> {
    let t = text.trim();
    if let Some(hex) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u64::from_str_radix(hex, 16).ok()
    } else if let Some(bin) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        u64::from_str_radix(&bin.replace(['.', '_', '-'], ""), 2).ok()
    } else {
        t.parse().ok()
    }
}

fn parse_every(key: &'static str, value: &str) -> Result<Readback, SettingError> {
    let bad = SettingError::BadValue {
        key,
        expected: "off, every or 1..=65535",
    };
    match value.trim() {
        "off" | "false" => Ok(Readback::Off),
        "every" | "true" => Ok(Readback::Every(1)),
        n => parse_number(n)
            .and_then(|n| u16::try_from(n).ok())
            .filter(|&n| n > 0)
            .map(Readback::Every)
            .ok_or(bad),
    }
}

/// `500ms`, `2s`, `1.5s`, or a bare number of milliseconds; 10 ms..=1 h.
fn parse_duration(text: &str) -> Option<Duration> {
    let t = text.trim();
    let d = if let Some(ms) = t.strip_suffix("ms") {
        Duration::from_millis(ms.trim().parse().ok()?)
    } else if let Some(s) = t.strip_suffix('s') {
        let secs: f64 = s.trim().parse().ok()?;
        if !secs.is_finite() || secs < 0.0 {
            return None;
        }
        Duration::try_from_secs_f64(secs).ok()?
    } else {
        Duration::from_millis(t.parse().ok()?)
    };
    (Duration::from_millis(10)..=Duration::from_secs(3600))
        .contains(&d)
        .then_some(d)
}

/// The register-table name of a text-protocol spelling (`X1LATUP` → `XLATUP1`, `Y2LAMP` →
/// `YLAMP2`, `WDTMASK` → `WDTYMASK`); other names unchanged.
fn canonical(upper: &str) -> String {
    if upper == "WDTMASK" {
        return "WDTYMASK".into();
    }
    let b = upper.as_bytes();
    match b {
        [b'X', d @ b'1'..=b'3', rest @ ..] if rest == b"LATUP" || rest == b"LATDN" => {
            format!("X{}{}", upper.get(2..).unwrap_or_default(), char::from(*d))
        }
        [b'Y', d @ b'1'..=b'4', rest @ ..] if rest == b"LAMP" => format!("YLAMP{}", char::from(*d)),
        _ => upper.to_string(),
    }
}

impl Setting {
    /// The start-up write of the holding register named `name` in the register table
    /// (`WDTTIME`), `None` for a name that is not one.
    pub fn holding(name: &str, value: u16) -> Option<Self> {
        let e = map::entry(name).filter(|e| e.space == Space::HoldingRegister)?;
        Some(Setting::Register {
            name: e.name,
            addr: e.addr,
            value,
        })
    }

    /// Parses a `key: value` pair of the project file.
    pub fn parse(key: &str, value: &str) -> Result<Self, SettingError> {
        let lower = key.to_ascii_lowercase();
        match lower.as_str() {
            "readback" => return parse_every("readback", value).map(Setting::Readback),
            "counters" => return parse_every("counters", value).map(Setting::Counters),
            "status" => return parse_every("status", value).map(Setting::Status),
            "events" => {
                return match value.trim() {
                    "true" | "on" | "yes" => Ok(Setting::Events(true)),
                    "false" | "off" | "no" => Ok(Setting::Events(false)),
                    _ => Err(SettingError::BadValue {
                        key: "events",
                        expected: "true or false",
                    }),
                }
            }
            "event_refresh" => {
                return parse_duration(value).map(Setting::EventRefresh).ok_or(
                    SettingError::BadValue {
                        key: "event_refresh",
                        expected: "a duration from 10ms to 3600s (500ms, 2s, or ms)",
                    },
                )
            }
            "event_resync" => {
                return parse_duration(value).map(Setting::EventResync).ok_or(
                    SettingError::BadValue {
                        key: "event_resync",
                        expected: "a duration from 10ms to 3600s (500ms, 30s, or ms)",
                    },
                )
            }
            "rdelayt" | "rdelaym" => {
                let (key, unit) = if lower == "rdelayt" {
                    ("RDELAYT", " (1/100 s)")
                } else {
                    ("RDELAYM", " (1/10 ms)")
                };
                let n = number_in(
                    value,
                    key,
                    Range {
                        min: 0,
                        max: 200,
                        unit,
                    },
                )? as u8;
                return Ok(if lower == "rdelayt" {
                    Setting::ReplyDelay(n)
                } else {
                    Setting::FrameTimeout(n)
                });
            }
            "fbenable" => {
                let range = Range {
                    min: 0,
                    max: 3,
                    unit: " (bit 0 = FB1, bit 1 = FB2)",
                };
                return Ok(Setting::Coils {
                    name: "FBENABLE",
                    addr: WDTFB1_COIL,
                    count: 2,
                    bits: number_in(value, "FBENABLE", range)? as u8,
                });
            }
            _ => {}
        }
        let name = canonical(&key.to_ascii_uppercase());
        let entry = map::entry(&name).ok_or(UNKNOWN)?;
        match (entry.space, entry.item) {
            (Space::Coil, Item::WdtFbEnable(_) | Item::EvFb(_)) => {
                let bit =
                    parse_number(value)
                        .filter(|&n| n <= 1)
                        .ok_or(SettingError::BadValue {
                            key: entry.name,
                            expected: "0 or 1",
                        })?;
                return Ok(Setting::Coils {
                    name: entry.name,
                    addr: entry.addr,
                    count: 1,
                    bits: bit as u8,
                });
            }
            (Space::HoldingRegister, _) => {}
            _ => return Err(UNKNOWN),
        }
        let word = |unit| {
            let range = Range {
                min: 0,
                max: 65535,
                unit,
            };
            number_in(value, entry.name, range).map(|n| n as u16)
        };
        let mask = || {
            parse_number(value)
                .and_then(|n| u16::try_from(n).ok())
                .ok_or(SettingError::BadValue {
                    key: entry.name,
                    expected: "a 16-bit mask",
                })
        };
        let value = match entry.item {
            Item::XlatUp(_) | Item::XlatDn(_) => word(" (ms)")?,
            Item::Xcount(_) => word("")?,
            Item::Lamp(_) => mask()?,
            Item::WdtTime => word(" (1/100 s; 0 = off)")?,
            Item::WdtYMask | Item::XevMask | Item::YevMask => mask()?,
            Item::AutoOn(..) | Item::AutoOff(..) => {
                const EXPECTED: &str = "a 16-bit mask or a condition such as X1-X2";
                match parse_number(value) {
                    Some(n) => u16::try_from(n).map_err(|_| SettingError::BadValue {
                        key: entry.name,
                        expected: EXPECTED,
                    })?,
                    None => parse_condition(value).map_err(|ConditionError::Syntax { at }| {
                        SettingError::BadSyntax {
                            key: entry.name,
                            at,
                            expected: EXPECTED,
                        }
                    })?,
                }
            }
            _ => return Err(UNKNOWN),
        };
        Ok(Setting::Register {
            name: entry.name,
            addr: entry.addr,
            value,
        })
    }
}

/// Coil of WDTFB1 (00113).
pub(crate) const WDTFB1_COIL: u16 = 112;

/// Every key (the catalog's `setting_keys`): the named ones, then each register and coil of
/// the map that a setting writes.
pub(crate) fn keys() -> Vec<&'static str> {
    let named = [
        "readback",
        "counters",
        "status",
        "events",
        "event_refresh",
        "event_resync",
        "RDELAYT",
        "RDELAYM",
        "FBENABLE",
    ];
    let registers = map::MAP.iter().map(|e| e.name).filter(|name| {
        !matches!(
            Setting::parse(name, "0"),
            Err(SettingError::UnknownKey { .. })
        )
    });
    named.into_iter().chain(registers).collect()
}

/// The error of a key that is no MiniMod setting.
const UNKNOWN: SettingError = SettingError::UnknownKey {
    model: "minimod",
    accepted: Accepted::MiniMod,
};

/// A number of `range`; a number outside it, or no number, is [`SettingError::OutOfRange`].
fn number_in(value: &str, key: &'static str, range: Range) -> Result<i64, SettingError> {
    parse_number(value)
        .and_then(|n| i64::try_from(n).ok())
        .filter(|n| (range.min..=range.max).contains(n))
        .ok_or(SettingError::OutOfRange { key, range })
}

/// A MiniMod's settings, parsed once from its project entry, in file order (a later setting
/// of the same register wins, as it would on the module).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Settings {
    items: Vec<Setting>,
}

impl Settings {
    /// Parses every `key: value` of the entry; every refusal comes back with its index.
    pub fn parse(pairs: &[(String, String)]) -> Result<Self, Vec<KeyError>> {
        parse_each(pairs, Setting::parse).map(|items| Self { items })
    }

    /// The catalog's `parse_settings`.
    pub fn parse_module(
        pairs: &[(String, String)],
    ) -> Result<crate::devices::ModuleSettings, Vec<KeyError>> {
        Self::parse(pairs).map(crate::devices::ModuleSettings::MiniMod)
    }

    /// Settings from already typed items.
    pub fn from_items(items: Vec<Setting>) -> Self {
        Self { items }
    }

    /// Every setting, in file order.
    pub fn items(&self) -> &[Setting] {
        &self.items
    }

    /// Adds a setting after the entry's own (the runtime's watchdog arming).
    pub fn push(&mut self, setting: Setting) {
        self.items.push(setting);
    }

    /// Adds settings after the entry's own.
    pub fn extend(&mut self, settings: impl IntoIterator<Item = Setting>) {
        self.items.extend(settings);
    }

    /// The value the settings give the holding register named `name` (the register table's
    /// name: `WDTTIME`, `WDTYMASK`), the last one winning.
    pub fn register(&self, name: &str) -> Option<u16> {
        self.items.iter().rev().find_map(|s| match *s {
            Setting::Register { name: n, value, .. } if n == name => Some(value),
            _ => None,
        })
    }

    /// Whether a setting writes the register or coil named `name` (the register table's
    /// name; `FBENABLE` writes WDTFB1 and WDTFB2).
    pub fn sets(&self, name: &str) -> bool {
        self.items.iter().any(|s| match *s {
            Setting::Register { name: n, .. } => n == name,
            Setting::Coils {
                name: n,
                addr,
                count,
                ..
            } => {
                n == name
                    || map::entry(name).is_some_and(|e| {
                        e.space == Space::Coil && (addr..addr + u16::from(count)).contains(&e.addr)
                    })
            }
            _ => false,
        })
    }

    /// The `readback` setting, if given.
    pub fn readback(&self) -> Option<Readback> {
        self.items.iter().rev().find_map(|s| match *s {
            Setting::Readback(r) => Some(r),
            _ => None,
        })
    }

    /// Event mode (`events: true`).
    pub fn events(&self) -> bool {
        self.events_given().unwrap_or(false)
    }

    /// `events:` as given (`None`: the project leaves the mode to softplc).
    pub fn events_given(&self) -> Option<bool> {
        self.items.iter().rev().find_map(|s| match *s {
            Setting::Events(on) => Some(on),
            _ => None,
        })
    }

    /// `RDELAYT` as given, hundredths of a second.
    pub fn reply_delay_given(&self) -> Option<u8> {
        self.items.iter().rev().find_map(|s| match *s {
            Setting::ReplyDelay(n) => Some(n),
            _ => None,
        })
    }

    /// `RDELAYM` as the project sets it (0 when it does not): how much longer than 28 bit
    /// times the module waits for the end of a request.
    pub fn frame_timeout(&self) -> Duration {
        let tenths = self
            .items
            .iter()
            .rev()
            .find_map(|s| match *s {
                Setting::FrameTimeout(n) => Some(n),
                _ => None,
            })
            .unwrap_or(0);
        Duration::from_micros(100 * u64::from(tenths))
    }

    /// Event mode: the longest without an answered exchange addressed to the module.
    pub fn event_refresh(&self) -> Duration {
        self.items
            .iter()
            .rev()
            .find_map(|s| match *s {
                Setting::EventRefresh(d) => Some(d),
                _ => None,
            })
            .unwrap_or(DEFAULT_EVENT_REFRESH)
    }

    /// Event mode: the longest without a full read.
    pub fn event_resync(&self) -> Duration {
        self.items
            .iter()
            .rev()
            .find_map(|s| match *s {
                Setting::EventResync(d) => Some(d),
                _ => None,
            })
            .unwrap_or(DEFAULT_EVENT_RESYNC)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(key: &str, value: &str) -> Result<(), SettingError> {
        Setting::parse(key, value).map(|_| ())
    }

    #[test]
    fn settings_are_checked() {
        assert_eq!(check("readback", "every"), Ok(()));
        assert_eq!(check("xlatup3", "65535"), Ok(()));
        assert_eq!(check("Y4AOFF3", "-X3"), Ok(()));
        assert_eq!(check("YLAMP2", "0b0000.0000.1111.1111"), Ok(()));
        assert_eq!(check("RDELAYT", "200"), Ok(()));
        assert!(check("readback", "0").is_err());
        assert!(check("YWORD", "1")
            .unwrap_err()
            .to_string()
            .contains("not a minimod setting"));
        assert_eq!(check("YPULSE1", "1"), Err(UNKNOWN));
        assert_eq!(check("baud", "1"), Err(UNKNOWN));
        assert_eq!(check("EVX1", "1"), Err(UNKNOWN), "use XEVMASK");
    }

    #[test]
    fn the_keys_are_what_parses() {
        let k = keys();
        for key in [
            "readback", "RDELAYT", "Y1AON1", "XLATUP3", "WDTTIME", "EVFB2",
        ] {
            assert!(k.contains(&key), "{key}");
        }
        for key in ["YWORD", "YPULSE1", "X1", "Y1"] {
            assert!(!k.contains(&key), "{key}");
        }
    }

    #[test]
    fn refusals_carry_the_key_and_the_range() {
        for (key, value, name, max, unit) in [
            ("RDELAYT", "201", "RDELAYT", 200, " (1/100 s)"),
            ("rdelaym", "x", "RDELAYM", 200, " (1/10 ms)"),
            ("X1LATUP", "65536", "XLATUP1", 65535, " (ms)"),
            (
                "FBENABLE",
                "4",
                "FBENABLE",
                3,
                " (bit 0 = FB1, bit 1 = FB2)",
            ),
        ] {
            let range = Range { min: 0, max, unit };
            assert_eq!(
                check(key, value),
                Err(SettingError::OutOfRange { key: name, range }),
                "{key}: {value}"
            );
        }
        assert_eq!(
            check("RDELAYT", "201").unwrap_err().to_string(),
            "RDELAYT takes 0..=200 (1/100 s)"
        );
        // A condition that goes wrong at X7: its position in the value.
        assert_eq!(
            check("Y1AON1", "X1 X7"),
            Err(SettingError::BadSyntax {
                key: "Y1AON1",
                at: 3,
                expected: "a 16-bit mask or a condition such as X1-X2"
            })
        );
        assert_eq!(
            check("YLAMP1", "0x10000"),
            Err(SettingError::BadValue {
                key: "YLAMP1",
                expected: "a 16-bit mask"
            })
        );
    }

    #[test]
    fn a_module_entry_is_parsed_whole_with_every_refusal_indexed() {
        let pairs: Vec<(String, String)> = [
            ("WDTTIME", "50"),
            ("nope", "1"),
            ("events", "true"),
            ("RDELAYT", "300"),
        ]
        .iter()
        .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
        .collect();
        let errors = Settings::parse(&pairs).unwrap_err();
        assert_eq!(
            errors.iter().map(|e| e.index).collect::<Vec<_>>(),
            vec![1, 3]
        );
        assert_eq!(errors[0].error, UNKNOWN);
        let ok: Vec<(String, String)> = pairs
            .into_iter()
            .enumerate()
            .filter(|(i, _)| i % 2 == 0)
            .map(|(_, p)| p)
            .collect();
        let s = Settings::parse(&ok).unwrap();
        assert_eq!(s.register("WDTTIME"), Some(50));
        assert!(s.events() && s.sets("WDTTIME") && !s.sets("WDTYMASK"));
        assert_eq!(s.event_refresh(), DEFAULT_EVENT_REFRESH);
        assert_eq!(s.event_resync(), DEFAULT_EVENT_RESYNC);
    }

    #[test]
    fn every_key_of_the_table() {
        let reg = |k: &str, v: &str| match Setting::parse(k, v) {
            Ok(Setting::Register { name, addr, value }) => (name, addr, value),
            other => panic!("{k}: {other:?}"),
        };
        assert_eq!(reg("X2LATUP", "5"), ("XLATUP2", 20, 5));
        assert_eq!(reg("x3latdn", "500"), ("XLATDN3", 37, 500));
        assert_eq!(reg("Y4LAMP", "255"), ("YLAMP4", 78, 255));
        assert_eq!(reg("WDTMASK", "0b1000"), ("WDTYMASK", 144, 8));
        assert_eq!(reg("WDTTIME", "50"), ("WDTTIME", 128, 50));
        assert_eq!(reg("XEVMASK", "7"), ("XEVMASK", 5, 7));
        assert_eq!(reg("YEVMASK", "0xF"), ("YEVMASK", 6, 15));
        assert_eq!(reg("XCOUNT2", "100"), ("XCOUNT2", 12, 100));
        assert_eq!(
            reg("Y1AON1", "0b0000.0010-0000.0011"),
            ("Y1AON1", 51, 0x0203)
        );
        assert_eq!(
            Setting::parse("FBENABLE", "3"),
            Ok(Setting::Coils {
                name: "FBENABLE",
                addr: 112,
                count: 2,
                bits: 3
            })
        );
        assert_eq!(
            Setting::parse("EVFB2", "1"),
            Ok(Setting::Coils {
                name: "EVFB2",
                addr: 89,
                count: 1,
                bits: 1
            })
        );
        assert!(Setting::parse("FBENABLE", "4").is_err());
        assert_eq!(Setting::parse("events", "true"), Ok(Setting::Events(true)));
        assert_eq!(
            Setting::parse("event_refresh", "500ms"),
            Ok(Setting::EventRefresh(Duration::from_millis(500)))
        );
        assert_eq!(
            Setting::parse("event_refresh", "2s"),
            Ok(Setting::EventRefresh(Duration::from_secs(2)))
        );
        assert_eq!(
            Setting::parse("event_refresh", "1.5s"),
            Ok(Setting::EventRefresh(Duration::from_millis(1500)))
        );
        for bad in ["0", "5ms", "-1s", "NaNs", "infs", "2h", "99999s"] {
            assert!(Setting::parse("event_refresh", bad).is_err(), "{bad}");
            assert!(Setting::parse("event_resync", bad).is_err(), "{bad}");
        }
        assert_eq!(
            Setting::parse("event_resync", "10s"),
            Ok(Setting::EventResync(Duration::from_secs(10)))
        );
        assert_eq!(
            Setting::parse("counters", "10"),
            Ok(Setting::Counters(Readback::Every(10)))
        );
        assert_eq!(
            Setting::parse("status", "every"),
            Ok(Setting::Status(Readback::Every(1)))
        );
        assert_eq!(
            Setting::parse("RDELAYM", "20"),
            Ok(Setting::FrameTimeout(20))
        );
    }
}
