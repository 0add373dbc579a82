//! Simulator options for the points where the manual is silent and a real module might differ
//! from our choice (resi-spec §2.4, §3.3, §4.4, §7). Each default is the choice documented in
//! [`super`]; `softplc sim`'s standard input changes them with `DEVICE option NAME VALUE`.

use std::time::Duration;

/// How SWITCH drives a relay (resi-spec §4.4, point 2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum SwitchMode {
    /// The relay follows the input at every 10 ms sample: a host write to a relay held by
    /// SWITCH lasts until the next sample.
    Level,
    /// The relay follows the input only when a mapped input changes: host writes stick
    /// until then.
    Change,
}

/// How several inputs in one SWITCH mask combine (resi-spec §4.4, point 3).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Combine {
    /// Each mapped input writes its level in turn, DI1 first: the highest mapped input wins.
    Last,
    /// The relay is on while any mapped input is high.
    Any,
}

/// What happens at power-on to a relay whose PULSE was running at the power loss (resi-spec
/// §3.5).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum PulseAtBoot {
    /// The bistable relay keeps its contact; the timer is lost, so it stays on.
    Keep,
    /// The module switches it off at boot, as if the pulse had ended.
    Off,
}

/// The options.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Options {
    /// SWITCH drive.
    pub switch: SwitchMode,
    /// SWITCH with several inputs.
    pub combine: Combine,
    /// ENABLE LOGIC FUNCTIONS must be exactly 1 (L22516, `true`) or any non-zero value
    /// (erratum 3: the central-light example writes 0x8000).
    pub enable_exactly_one: bool,
    /// A host write of 0 to a relay ends its running PULSE (resi-spec §4.4, point 4).
    pub host_off_ends_pulse: bool,
    /// CLEAR ALL LOGIC FUNCTIONS also sets every PULSE TIME to 0 ("clears all mapping and
    /// configuration tables", L22531).
    pub clear_pulse_times: bool,
    /// PULSE across a power loss.
    pub pulse_at_boot: PulseAtBoot,
    /// Undocumented Modbus addresses answer exception 02 (`true`) or read 0 and ignore
    /// writes.
    pub strict_addresses: bool,
    /// The `-ASCII` variant, which also speaks ASCII on the same port (L744–L746); `false`
    /// is the `-MODBUS` variant.
    pub ascii: bool,
    /// Answer ASCII requests to address 0 and without address, as the manual's samples do
    /// (L2073); `false` keeps silent on them, like a Modbus broadcast.
    pub ascii_broadcast_answer: bool,
    /// Accept lower-case ASCII commands and long names without their spaces.
    pub lenient: bool,
    /// Serve RESET SYSTEM (4x06001) and MODBUS UNIT ADDRESS (4x65222) on models whose
    /// chapter does not list them (resi-spec §1.4).
    pub system_registers: bool,
    /// Time from the end of a request to the first byte of the answer (undocumented;
    /// resi-spec §6 proposes 2 ms).
    pub reply_delay: Duration,
}

impl Default for Options {
    fn default() -> Self {
        Self {
            switch: SwitchMode::Level,
            combine: Combine::Last,
            enable_exactly_one: true,
            host_off_ends_pulse: true,
            clear_pulse_times: true,
            pulse_at_boot: PulseAtBoot::Keep,
            strict_addresses: true,
            ascii: true,
            ascii_broadcast_answer: true,
            lenient: false,
            system_registers: false,
            reply_delay: Duration::from_millis(2),
        }
    }
}

/// Why an option was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub(crate) enum OptionError {
    /// No such option.
    #[error("unknown option; options: {}", NAMES.join(", "))]
    Unknown,
    /// The value does not fit.
    #[error("{name} takes {expected}")]
    BadValue {
        /// The option.
        name: &'static str,
        /// What it takes.
        expected: &'static str,
    },
}

/// Every option name.
pub(crate) const NAMES: [&str; 12] = [
    "switch",
    "switch-combine",
    "enable",
    "host-off-ends-pulse",
    "clear-pulse-times",
    "pulse-at-boot",
    "undocumented",
    "ascii",
    "ascii-broadcast",
    "lenient",
    "system-registers",
    "reply-delay",
];

fn on_off(name: &'static str, value: &str) -> Result<bool, OptionError> {
    match value {
        "on" | "1" | "true" => Ok(true),
        "off" | "0" | "false" => Ok(false),
        _ => Err(OptionError::BadValue {
            name,
            expected: "on or off",
        }),
    }
}

fn word(b: bool) -> &'static str {
    if b {
        "on"
    } else {
        "off"
    }
}

impl Options {
    /// Sets option `name` from its text.
    pub(crate) fn set(&mut self, name: &str, value: &str) -> Result<(), OptionError> {
        let bad =
            |name: &'static str, expected: &'static str| OptionError::BadValue { name, expected };
        match name {
            "switch" => {
                self.switch = match value {
                    "level" => SwitchMode::Level,
                    "change" => SwitchMode::Change,
                    _ => return Err(bad("switch", "level or change")),
                }
            }
            "switch-combine" => {
                self.combine = match value {
                    "last" => Combine::Last,
                    "any" => Combine::Any,
                    _ => return Err(bad("switch-combine", "last or any")),
                }
            }
            "enable" => {
                self.enable_exactly_one = match value {
                    "one" => true,
                    "nonzero" => false,
                    _ => return Err(bad("enable", "one or nonzero")),
                }
            }
            "host-off-ends-pulse" => {
                self.host_off_ends_pulse = on_off("host-off-ends-pulse", value)?
            }
            "clear-pulse-times" => self.clear_pulse_times = on_off("clear-pulse-times", value)?,
            "pulse-at-boot" => {
                self.pulse_at_boot = match value {
                    "keep" => PulseAtBoot::Keep,
                    "off" => PulseAtBoot::Off,
                    _ => return Err(bad("pulse-at-boot", "keep or off")),
                }
            }
            "undocumented" => {
                self.strict_addresses = match value {
                    "exception" => true,
                    "zero" => false,
                    _ => return Err(bad("undocumented", "exception or zero")),
                }
            }
            "ascii" => self.ascii = on_off("ascii", value)?,
            "ascii-broadcast" => {
                self.ascii_broadcast_answer = match value {
                    "answer" => true,
                    "silent" => false,
                    _ => return Err(bad("ascii-broadcast", "answer or silent")),
                }
            }
            "lenient" => self.lenient = on_off("lenient", value)?,
            "system-registers" => self.system_registers = on_off("system-registers", value)?,
            "reply-delay" => {
                let ms = value
                    .trim_end_matches("ms")
                    .parse::<u64>()
                    .ok()
                    .filter(|ms| *ms <= 10_000)
                    .ok_or(bad("reply-delay", "0..=10000 (ms)"))?;
                self.reply_delay = Duration::from_millis(ms);
            }
            _ => return Err(OptionError::Unknown),
        }
        Ok(())
    }

    /// Every option and its value, one per line.
    pub(crate) fn describe(&self) -> String {
        let lines = [
            (
                "switch",
                match self.switch {
                    SwitchMode::Level => "level",
                    SwitchMode::Change => "change",
                }
                .to_string(),
                "level | change: SWITCH follows the input every sample or on its changes",
            ),
            (
                "switch-combine",
                match self.combine {
                    Combine::Last => "last",
                    Combine::Any => "any",
                }
                .to_string(),
                "last | any: several inputs in one SWITCH mask",
            ),
            (
                "enable",
                if self.enable_exactly_one {
                    "one"
                } else {
                    "nonzero"
                }
                .to_string(),
                "one | nonzero: ENABLE LOGIC FUNCTIONS values that run the logic",
            ),
            (
                "host-off-ends-pulse",
                word(self.host_off_ends_pulse).to_string(),
                "on | off: a host write of 0 ends a running PULSE",
            ),
            (
                "clear-pulse-times",
                word(self.clear_pulse_times).to_string(),
                "on | off: CLEAR ALL also zeroes PULSE TIME",
            ),
            (
                "pulse-at-boot",
                match self.pulse_at_boot {
                    PulseAtBoot::Keep => "keep",
                    PulseAtBoot::Off => "off",
                }
                .to_string(),
                "keep | off: a relay whose PULSE ran at power loss",
            ),
            (
                "undocumented",
                if self.strict_addresses {
                    "exception"
                } else {
                    "zero"
                }
                .to_string(),
                "exception | zero: undocumented Modbus addresses",
            ),
            (
                "ascii",
                word(self.ascii).to_string(),
                "on | off: the -ASCII variant (off: -MODBUS)",
            ),
            (
                "ascii-broadcast",
                if self.ascii_broadcast_answer {
                    "answer"
                } else {
                    "silent"
                }
                .to_string(),
                "answer | silent: ASCII requests to address 0 or without address",
            ),
            (
                "lenient",
                word(self.lenient).to_string(),
                "on | off: lower case and long names without spaces",
            ),
            (
                "system-registers",
                word(self.system_registers).to_string(),
                "on | off: 4x06001 and 4x65222 where the chapter does not list them",
            ),
            (
                "reply-delay",
                format!("{}ms", self.reply_delay.as_millis()),
                "0..10000 ms before an answer",
            ),
        ];
        lines
            .iter()
            .map(|(n, v, d)| format!("  {n:<20} {v:<10} {d}"))
            .collect::<Vec<_>>()
            .join("\n")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sets_and_refuses() {
        let mut o = Options::default();
        o.set("switch", "change").unwrap();
        o.set("reply-delay", "5ms").unwrap();
        o.set("enable", "nonzero").unwrap();
        assert_eq!(o.switch, SwitchMode::Change);
        assert_eq!(o.reply_delay, Duration::from_millis(5));
        assert!(!o.enable_exactly_one);
        assert_eq!(o.set("nope", "1"), Err(OptionError::Unknown));
        assert!(o.set("lenient", "maybe").is_err());
        assert!(o.set("reply-delay", "99999").is_err());
        assert_eq!(o.describe().lines().count(), NAMES.len());
    }
}
