//! A family's watchdog plan: what the runtime knows (the entry's policy, the line's worst gap
//! between two exchanges, the tags' safe values) in, what the module's own watchdog does out
//! ([`Armed`]), and the line `check` prints for it.

use std::time::Duration;

use crate::devices::ModelSpec;
use crate::point::Value;

/// What the module entry asks for (`watchdog:`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum WatchdogPolicy {
    /// Armed by default where the model has a watchdog that makes outputs safe.
    #[default]
    Auto,
    /// `watchdog: off`.
    Off,
}

/// Where a value comes from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Origin {
    /// The module's settings.
    Project,
    /// Worked out by softplc.
    Derived,
}

/// The longest a healthy line may leave a module without a message, in parts (for `check`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Derivation {
    /// 3 × the scan period.
    pub periods: Duration,
    /// The line's cycle floor.
    pub floor: Duration,
    /// The line's start-up traffic.
    pub startup: Duration,
    /// Failing exchanges of the other modules, and one retry of the module's own.
    pub failures: Duration,
    /// Event mode: one refresh period ([`super::InputModes::refresh`]).
    pub event_refresh: Option<Duration>,
}

impl Derivation {
    /// The sum.
    pub fn total(&self) -> Duration {
        self.periods
            + self.floor
            + self.startup
            + self.failures
            + self.event_refresh.unwrap_or_default()
    }
}

/// What a module's own watchdog does in a project.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum Armed {
    /// Not worked out yet (during validation).
    #[default]
    Pending,
    /// MiniMod: WDTTIME and WDTYMASK written at start-up.
    MiniMod {
        /// WDTTIME, 1/100 s (non-zero).
        time: u16,
        /// Where it comes from.
        time_from: Origin,
        /// The derivation, when derived.
        derivation: Option<Derivation>,
        /// WDTYMASK (bits 0..3 = Y1..Y4).
        mask: u16,
        /// Where it comes from.
        mask_from: Origin,
        /// Outputs that go off without a safe value saying so (derived mask only).
        no_safe: Vec<&'static str>,
    },
    /// The EX-9053D's host watchdog, by its `watchdog` setting.
    HostWatchdog {
        /// The timeout, 0.1 s.
        tenths: u8,
    },
    /// The RESI-1RO's off-delay, by its `SOFFDLY` setting.
    OffDelay {
        /// ms.
        ms: u16,
    },
    /// Turned off by the project (`watchdog: off`, or `WDTTIME: 0`): `check` warns.
    Off,
    /// Not armed: why.
    NotArmed(&'static str),
    /// Not armed, and `check` warns: why, and the warning's text after the module's name.
    NotArmedWarned {
        /// Why (after `not armed: `).
        why: &'static str,
        /// The warning (after `warning: module NAME: `).
        warning: &'static str,
    },
}

/// What a family is told to plan its watchdog from.
#[derive(Debug, Clone, Copy)]
pub struct WatchdogAsk<'a> {
    /// The module's model.
    pub model: &'static ModelSpec,
    /// The entry's `watchdog:`.
    pub policy: WatchdogPolicy,
    /// The line's worst time between two exchanges with the module, in parts.
    pub derivation: Derivation,
    /// The safe values of the tags bound to the module's points, in the project's tag order:
    /// (index into the model's points, value).
    pub safe: &'a [(usize, Value)],
    /// Whether the bus carries the module's text commands (a Modbus TCP bus carries PDUs
    /// only).
    pub carries_text: bool,
}

/// Why `watchdog: off` cannot go with a module's settings: the setting that arms it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WatchdogConflict {
    /// The setting's key (`WDTTIME`).
    pub key: &'static str,
    /// Its value as the message shows it.
    pub value: String,
}

impl std::fmt::Display for WatchdogConflict {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "off contradicts the setting {}: {}; remove one of them",
            self.key, self.value
        )
    }
}

/// `0b0010 (Y1 off, Y2 on; no safe value, so off: Y3, Y4)`.
fn fmt_mask(mask: u16, no_safe: &[&str]) -> String {
    let outputs: Vec<String> = ["Y1", "Y2", "Y3", "Y4"]
        .iter()
        .enumerate()
        .filter(|(_, name)| !no_safe.contains(name))
        .map(|(y, name)| {
            let on = if mask & (1 << y) != 0 { "on" } else { "off" };
            format!("{name} {on}")
        })
        .collect();
    let mut text = outputs.join(", ");
    if !no_safe.is_empty() {
        if !text.is_empty() {
            text.push_str("; ");
        }
        text.push_str("no safe value, so off: ");
        text.push_str(&no_safe.join(", "));
    }
    format!("{:#06b} ({text})", mask & 0x0F)
}

/// `1.18s`.
fn fmt_secs(d: Duration) -> String {
    format!("{:.2}s", d.as_secs_f64())
}

impl Armed {
    /// The line `check` prints for module `name`'s watchdog, and a warning when it is off.
    pub fn report(&self, name: &str) -> (String, Option<String>) {
        match self {
            Armed::MiniMod {
                time,
                time_from,
                derivation,
                mask,
                mask_from,
                no_safe,
            } => {
                let t = fmt_secs(Duration::from_millis(u64::from(*time) * 10));
                let how = match (time_from, derivation) {
                    (Origin::Derived, Some(d)) => {
                        let mut parts = vec![
                            format!("3 × period {}", fmt_secs(d.periods / 3)),
                            format!("line floor {}", fmt_secs(d.floor)),
                            format!("start-up {}", fmt_secs(d.startup)),
                            format!("failing neighbours {}", fmt_secs(d.failures)),
                        ];
                        if let Some(r) = d.event_refresh {
                            parts.push(format!("event_refresh {}", fmt_secs(r)));
                        }
                        format!("{t} ≥ {}", parts.join(" + "))
                    }
                    _ => format!("{t}, from the settings"),
                };
                let mask = match mask_from {
                    Origin::Derived => fmt_mask(*mask, no_safe),
                    Origin::Project => format!("{:#06b}, from the settings", mask & 0x0F),
                };
                (
                    format!(
                        "    module watchdog: WDTTIME {time} ({how}); WDTYMASK {mask}: outputs the \
                         module sets by itself after that long without a command"
                    ),
                    None,
                )
            }
            Armed::HostWatchdog { tenths } => (
                format!(
                    "    module watchdog: host watchdog armed, {} (the module has no outputs: its \
                     timeout shows as WDT_TIMEOUT)",
                    fmt_secs(Duration::from_millis(u64::from(*tenths) * 100))
                ),
                None,
            ),
            Armed::OffDelay { ms } => (
                format!(
                    "    module watchdog: off-delay SOFFDLY {}: DO1 drops when no command \
                     retriggers it",
                    fmt_secs(Duration::from_millis(u64::from(*ms)))
                ),
                None,
            ),
            Armed::Off => (
                "    module watchdog: OFF".into(),
                Some(format!(
                    "warning: module {name}: its watchdog is off: if this process dies or the \
                     line breaks, its outputs keep their last state"
                )),
            ),
            Armed::NotArmedWarned { why, warning } => (
                format!("    module watchdog: not armed: {why}"),
                Some(format!("warning: module {name}: {warning}")),
            ),
            Armed::NotArmed(why) => (format!("    module watchdog: not armed: {why}"), None),
            Armed::Pending => ("    module watchdog: not worked out".into(), None),
        }
    }
}
