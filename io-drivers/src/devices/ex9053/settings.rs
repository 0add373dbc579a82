//! The project file's `settings` of an EX-9053D / EX-9053D-M module. Keys are
//! case-insensitive.
//!
//! | key          | values                                   | default | protocol |
//! |--------------|------------------------------------------|---------|----------|
//! | `checksum`   | `on` / `off`: the module's FF bit 6      | `off`   | DCON     |
//! | `latch`      | `off`, `high`, `low`, `both`             | `off`   | both     |
//! | `counters`   | `none`, `all`, or channels: `DI0, DI4-DI7` | `none` | both     |
//! | `count_edge` | `rising` / `falling`                     | —       | both     |
//! | `watchdog`   | `off`, or 100ms..=25.5s in 0.1 s steps   | `off`   | both     |
//! | `sync`       | `off`, `lead`, `follow` (see [`super::sync`]) | `off` | DCON   |
//!
//! - `checksum` must match the module (set it with `%AANNTTCCFF` in INIT*, §2.1): the driver
//!   then checksums every command and checks every answer.
//! - `count_edge` is written and read back over Modbus (coil 02251). Over DCON it is only
//!   checked (`$AA2`, FF bit 7): writing it needs `%AANNTTCCFF` with the module's baud code,
//!   which the driver does not know; a difference stops the start and says so.
//! - `watchdog` arms the host watchdog at start-up and keeps it fed (see [`super::driver`]);
//!   `off` or absent leaves the module's watchdog setting as it is.

use super::points::channel_of;
use super::sync::SyncRole;
use super::tables::{CHANNELS, WDT_TICK_MS};
use crate::devices::config::{parse_each, Accepted, KeyError};
use crate::devices::ModuleSettings;

pub(crate) use crate::devices::config::SettingError;

/// Which latches are read each cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LatchMode {
    /// None.
    #[default]
    Off,
    /// Latch high (`$AAL1`, coils 00065..00080).
    High,
    /// Latch low (`$AAL0`, coils 00097..00112).
    Low,
    /// Both.
    Both,
}

impl LatchMode {
    /// Reads latch high.
    pub fn high(self) -> bool {
        matches!(self, LatchMode::High | LatchMode::Both)
    }

    /// Reads latch low.
    pub fn low(self) -> bool {
        matches!(self, LatchMode::Low | LatchMode::Both)
    }
}

/// Validated settings.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Settings {
    /// DCON checksum (FF bit 6).
    pub checksum: bool,
    /// Latches read each cycle.
    pub latch: LatchMode,
    /// Counters read each cycle, bit n = DIn.
    pub counters: u16,
    /// Counted edge to configure: `Some(true)` rising.
    pub count_edge: Option<bool>,
    /// Host watchdog value to arm, in 0.1 s (1..=255).
    pub watchdog: Option<u8>,
    /// Part in synchronized sampling.
    pub sync: SyncRole,
}

fn on_off(text: &str) -> Option<bool> {
    match text.trim().to_ascii_lowercase().as_str() {
        "on" | "true" | "1" | "yes" => Some(true),
        "off" | "false" | "0" | "no" => Some(false),
        _ => None,
    }
}

/// `DI0, DI4-DI7` → mask; `all`, `none`.
fn parse_channels(text: &str) -> Option<u16> {
    let t = text.trim();
    match t.to_ascii_lowercase().as_str() {
        "all" => return Some(u16::MAX),
        "none" | "off" | "" => return Some(0),
        _ => {}
    }
    let mut mask = 0u16;
    for item in t.split([',', ' ']).filter(|s| !s.is_empty()) {
        let (a, b) = match item.split_once('-') {
            Some((a, b)) => (channel_of(a.trim())?, channel_of(b.trim())?),
            None => {
                let ch = channel_of(item)?;
                (ch, ch)
            }
        };
        if a > b || b >= CHANNELS {
            return None;
        }
        for ch in a..=b {
            mask |= 1 << ch;
        }
    }
    Some(mask)
}

/// `100ms`..`25.5s` in 0.1 s steps → counts of 0.1 s.
fn parse_watchdog(text: &str) -> Option<Option<u8>> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("off") || t.eq_ignore_ascii_case("false") {
        return Some(None);
    }
    let (number, unit_ms) = if let Some(n) = t.strip_suffix("ms") {
        (n, 1.0)
    } else if let Some(n) = t.strip_suffix('s') {
        (n, 1000.0)
    } else {
        return None;
    };
    let value: f64 = number.trim().parse().ok()?;
    let ms = value * unit_ms;
    let ticks = (ms / WDT_TICK_MS as f64).round();
    if !ms.is_finite() || (ticks * WDT_TICK_MS as f64 - ms).abs() > 1e-6 {
        return None;
    }
    if !(1.0..=255.0).contains(&ticks) {
        return None;
    }
    // In 1..=255 and whole: the conversion is exact.
    Some(Some(ticks as u8))
}

impl Settings {
    /// Applies one `key: value` pair.
    pub fn apply(&mut self, key: &str, value: &str) -> Result<(), SettingError> {
        let bad = |key, expected| SettingError::BadValue { key, expected };
        match key.to_ascii_lowercase().as_str() {
            "checksum" => self.checksum = on_off(value).ok_or(bad("checksum", "on or off"))?,
            "latch" | "latches" => {
                self.latch = match value.trim().to_ascii_lowercase().as_str() {
                    "off" | "false" | "none" => LatchMode::Off,
                    "high" => LatchMode::High,
                    "low" => LatchMode::Low,
                    "both" | "on" | "true" => LatchMode::Both,
                    _ => return Err(bad("latch", "off, high, low or both")),
                }
            }
            "counters" => {
                self.counters = parse_channels(value).ok_or(bad(
                    "counters",
                    "none, all, or channels such as DI0, DI4-DI7",
                ))?
            }
            "count_edge" => {
                self.count_edge = match value.trim().to_ascii_lowercase().as_str() {
                    "rising" => Some(true),
                    "falling" => Some(false),
                    _ => return Err(bad("count_edge", "rising or falling")),
                }
            }
            "watchdog" => {
                self.watchdog = parse_watchdog(value).ok_or(bad(
                    "watchdog",
                    "off, or a duration from 100ms to 25.5s in steps of 100ms (e.g. 2s)",
                ))?
            }
            "sync" => {
                self.sync = SyncRole::parse(value).ok_or(bad("sync", "off, lead or follow"))?
            }
            _ => return Err(UNKNOWN),
        }
        Ok(())
    }

    /// The first DCON-only setting given (`checksum`, `sync`): the module's Modbus side has
    /// neither, so on `protocol: modbus` it is refused before the first scan.
    pub fn dcon_only(&self) -> Option<&'static str> {
        if self.checksum {
            Some("checksum")
        } else if self.sync != SyncRole::Off {
            Some("sync")
        } else {
            None
        }
    }

    /// Parses every `key: value` of the entry, later keys winning; every refusal comes back
    /// with its index.
    pub fn parse(pairs: &[(String, String)]) -> Result<Self, Vec<KeyError>> {
        let mut settings = Settings::default();
        parse_each(pairs, |k, v| settings.apply(k, v))?;
        Ok(settings)
    }
}

/// The error of a key that is no EX-9053D setting.
const UNKNOWN: SettingError = SettingError::UnknownKey {
    model: "ex9053d",
    accepted: Accepted::Ex9053,
};

/// Every key (the catalog's `setting_keys`).
pub(crate) fn keys() -> Vec<&'static str> {
    vec![
        "checksum",
        "latch",
        "counters",
        "count_edge",
        "watchdog",
        "sync",
    ]
}

/// The catalog's `parse_settings`.
pub(crate) fn parse_module(pairs: &[(String, String)]) -> Result<ModuleSettings, Vec<KeyError>> {
    Settings::parse(pairs).map(ModuleSettings::Ex9053)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_every_key() {
        let mut s = Settings::default();
        s.apply("Checksum", "on").unwrap();
        s.apply("latch", "both").unwrap();
        s.apply("counters", "DI0, DI4-DI7 DI15").unwrap();
        s.apply("count_edge", "rising").unwrap();
        s.apply("watchdog", "2.5s").unwrap();
        s.apply("sync", "lead").unwrap();
        assert_eq!(
            s,
            Settings {
                checksum: true,
                latch: LatchMode::Both,
                counters: 0x80F1,
                count_edge: Some(true),
                watchdog: Some(25),
                sync: SyncRole::Lead,
            }
        );
        s.apply("watchdog", "100ms").unwrap();
        assert_eq!(s.watchdog, Some(1));
        s.apply("watchdog", "25.5s").unwrap();
        assert_eq!(s.watchdog, Some(255));
        s.apply("watchdog", "off").unwrap();
        assert_eq!(s.watchdog, None);
        s.apply("counters", "all").unwrap();
        assert_eq!(s.counters, 0xFFFF);
    }

    #[test]
    fn refuses_what_does_not_fit() {
        let mut s = Settings::default();
        for (k, v) in [
            ("watchdog", "2"),
            ("watchdog", "150ms"),
            ("watchdog", "0s"),
            ("watchdog", "26s"),
            ("watchdog", "NaNs"),
            ("counters", "DI16"),
            ("counters", "DI5-DI2"),
            ("counters", "X1"),
            ("latch", "sometimes"),
            ("sync", "yes"),
            ("checksum", "maybe"),
            ("count_edge", "both"),
        ] {
            assert!(
                matches!(s.apply(k, v), Err(SettingError::BadValue { .. })),
                "{k}: {v}"
            );
        }
        assert_eq!(s.apply("RDELAYT", "1"), Err(UNKNOWN));
        assert_eq!(
            UNKNOWN.to_string(),
            "not an ex9053d setting; accepted: checksum, latch, counters, count_edge, watchdog, sync"
        );
        let pairs = |list: &[(&str, &str)]| -> Vec<(String, String)> {
            list.iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect()
        };
        assert_eq!(
            Settings::parse(&pairs(&[("latch", "high"), ("watchdog", "2s")])),
            Ok(Settings {
                latch: LatchMode::High,
                watchdog: Some(20),
                ..Settings::default()
            })
        );
        assert_eq!(
            Settings::parse(&pairs(&[("latch", "x"), ("sync", "lead"), ("nope", "1")])),
            Err(vec![
                KeyError {
                    index: 0,
                    error: SettingError::BadValue {
                        key: "latch",
                        expected: "off, high, low or both"
                    }
                },
                KeyError {
                    index: 2,
                    error: UNKNOWN
                },
            ])
        );
    }
}
