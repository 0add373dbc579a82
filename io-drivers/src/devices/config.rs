//! What crosses the seam from a project file to a driver, typed: the module's address, its
//! settings parsed once by its model, and the push-down tables the planner built.
//!
//! A project file's `settings:` are text; each model parses them **once**, when the project is
//! validated ([`ModelSpec::parse_settings`]), into its own typed value, and every later reader
//! (the driver's `build`, the runtime's watchdog arming and push-down planner, the reload
//! check) works on that value. So a setting cannot be read two ways, a driver cannot meet a
//! setting it refuses (its `build` has no error path), and a refusal is a typed
//! [`SettingError`] carrying the key and numbers, which the runtime turns into its
//! file:line:col diagnostic.
//!
//! [`ModuleSettings`] is an enum of the families rather than a trait object: each family looks
//! inside its own value (a MiniMod's `WDTTIME`, a RESI module's poll list) without
//! downcasting, where the runtime asks it through [`super::Family`], and an enum is
//! `Clone + PartialEq` for free, which a reload needs to tell whether a module's configuration
//! changed.

use std::fmt;

use super::{ex9053, minimod, resi, ModelSpec, Protocol};
use crate::modbus::UnitId;

/// A module's address on its line, checked against its model's range
/// ([`ModelSpec::addresses`]).
///
/// Not [`UnitId`]: the EX-9053D's DCON address may be 0 (`%AANNTTCCFF`, §2.1), which is the
/// Modbus broadcast address, never a unit. [`ModuleAddress::unit`] gives the Modbus unit where
/// the address is one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ModuleAddress(u8);

/// An address outside the model's range.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("address {given} is outside {model}'s {min}..={max}")]
pub struct AddressError {
    /// The model.
    pub model: &'static str,
    /// The address given.
    pub given: u8,
    /// Lowest valid address.
    pub min: u8,
    /// Highest valid address.
    pub max: u8,
}

impl ModuleAddress {
    /// `address` if `model` accepts it.
    pub fn new(model: &ModelSpec, address: u8) -> Result<Self, AddressError> {
        if model.addresses.contains(&address) {
            Ok(Self(address))
        } else {
            Err(AddressError {
                model: model.name,
                given: address,
                min: *model.addresses.start(),
                max: *model.addresses.end(),
            })
        }
    }

    /// The address byte.
    pub fn get(self) -> u8 {
        self.0
    }

    /// The Modbus unit at this address (`None` for 0, 248..=255).
    pub fn unit(self) -> Option<UnitId> {
        UnitId::new(self.0)
    }
}

impl fmt::Display for ModuleAddress {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0)
    }
}

/// A numbered point of a module family (`Y1`..`Y4`, `X1`..`X3`, `RO1`..`RO8`) as a value:
/// its number checked against the range, its point name parsed by its prefix.
macro_rules! numbered_point {
    ($(#[$doc:meta])* $name:ident, $prefix:literal, $range:expr) => {
        $(#[$doc])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        pub struct $name(u8);

        impl $name {
            #[doc = concat!("`", $prefix, "n` for n in its range.")]
            pub fn new(n: u8) -> Option<Self> {
                ($range).contains(&n).then_some(Self(n))
            }

            #[doc = concat!("The point by its name (`", $prefix, "2`).")]
            pub fn named(name: &str) -> Option<Self> {
                name.strip_prefix($prefix)
                    .and_then(|n| n.parse().ok())
                    .and_then(Self::new)
            }

            #[doc = concat!("n of `", $prefix, "n`.")]
            pub fn number(self) -> u8 {
                self.0
            }
        }

        impl std::fmt::Display for $name {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                write!(f, "{}{}", $prefix, self.0)
            }
        }
    };
}
pub(crate) use numbered_point;

/// A module's settings, parsed by its model.
#[derive(Debug, Clone, PartialEq)]
pub enum ModuleSettings {
    /// A MiniMod's.
    MiniMod(minimod::Settings),
    /// A RESI module's (every model of the series).
    Resi(resi::driver::settings::Settings),
    /// An EX-9053D's or EX-9053D-M's.
    Ex9053(ex9053::settings::Settings),
    /// A profile module's: its profile.
    Profile(super::profile::catalog::ProfileSettings),
}

impl ModuleSettings {
    /// Whether the entry set nothing (every setting at the model's default).
    pub fn is_empty(&self) -> bool {
        match self {
            ModuleSettings::MiniMod(s) => s.items().is_empty(),
            ModuleSettings::Resi(s) => s.items().is_empty(),
            ModuleSettings::Ex9053(s) => *s == ex9053::settings::Settings::default(),
            ModuleSettings::Profile(_) => true,
        }
    }
}

/// The numbers a setting takes, for its error (`0..=200 (1/100 s)`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Range {
    /// Lowest value.
    pub min: i64,
    /// Highest value.
    pub max: i64,
    /// What the number counts, with its leading space (` (ms)`), or empty.
    pub unit: &'static str,
}

impl fmt::Display for Range {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}..={}{}", self.min, self.max, self.unit)
    }
}

/// Which settings a family accepts, for an unknown key's error.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Accepted {
    /// The MiniMod's list.
    MiniMod,
    /// A RESI model's list; `example` is one of its read-write points.
    Resi {
        /// One of the model's read-write points (`SWITCH_RO1`), `none` without any.
        example: &'static str,
    },
    /// The EX-9053D's list.
    Ex9053,
    /// A profile module's: none.
    Profile,
}

impl fmt::Display for Accepted {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Accepted::MiniMod => f.write_str(
                "readback, counters, status, events, event_refresh, event_resync, RDELAYT, RDELAYM, \
                 XLATUP1..3, XLATDN1..3, XCOUNT1..3, Y1AON1..Y4AON3, Y1AOFF1..Y4AOFF3, \
                 YLAMP1..4, WDTTIME, WDTYMASK, FBENABLE, WDTFB1..2, EVFB1..2, XEVMASK, YEVMASK",
            ),
            Accepted::Resi { example } => write!(
                f,
                "poll, reply_delay, its read-write points ({example}, ...), the command \
                 registers it has (CLEAR_ALL_LOGIC_FUNCTIONS, RESET_COUNTER), on resi-1ro \
                 SOFFDLY, on resi-16di8ro initial_RO1..8"
            ),
            Accepted::Ex9053 => {
                f.write_str("checksum, latch, counters, count_edge, watchdog, sync")
            }
            Accepted::Profile => {
                f.write_str("nothing: a profile module is described by its profile file")
            }
        }
    }
}

/// Why a model refused one setting. The key is the manual's spelling of the setting, the
/// numbers are the range it takes; the value's text stays with the caller, which has it
/// (positions point into it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    /// Not a setting of the model.
    #[error("not {} {model} setting; accepted: {accepted}", article(model))]
    UnknownKey {
        /// The model's name.
        model: &'static str,
        /// What it accepts.
        accepted: Accepted,
    },
    /// A number outside the setting's range, or no number where one is needed.
    #[error("{key} takes {range}")]
    OutOfRange {
        /// The setting.
        key: &'static str,
        /// What it takes.
        range: Range,
    },
    /// A value of another form than the setting's (`expected` says which).
    #[error("{key} takes {expected}")]
    BadValue {
        /// The setting.
        key: &'static str,
        /// What it takes, in words.
        expected: &'static str,
    },
    /// A value whose text stops making sense at a character.
    #[error("{key} takes {expected}; the value goes wrong at character {}", at + 1)]
    BadSyntax {
        /// The setting.
        key: &'static str,
        /// Byte offset in the value's text (0-based) of the first character that does not
        /// fit.
        at: usize,
        /// What it takes, in words.
        expected: &'static str,
    },
    /// A `poll` pattern that names no point of the model.
    #[error("poll: the pattern at character {} names no point of {model}", at + 1)]
    NoSuchPoint {
        /// The model.
        model: &'static str,
        /// Byte offset of the pattern in the value's text (0-based, after its spaces).
        at: usize,
        /// Its length in bytes.
        len: usize,
    },
}

impl SettingError {
    /// The error in words, quoting the part of `value` it is about (a poll pattern), so a
    /// diagnostic reads `poll: "DI17" names no point of resi-16di8ro`.
    pub fn describe(&self, value: &str) -> String {
        match *self {
            SettingError::NoSuchPoint { model, at, len } => {
                let pattern = value.get(at..at + len).unwrap_or(value);
                format!("poll: {pattern:?} names no point of {model}")
            }
            ref other => other.to_string(),
        }
    }
}

/// A model's settings parser: a module entry's `key: value` pairs as written, in file order,
/// to its typed settings, or every refusal with its index.
pub type ParseSettings = fn(&[(String, String)]) -> Result<ModuleSettings, Vec<KeyError>>;

/// A refused setting: which one (its index in the entry's `settings`, in file order) and why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct KeyError {
    /// Index of the `key: value` pair.
    pub index: usize,
    /// Why.
    pub error: SettingError,
}

/// Why a module entry cannot become a driver configuration (for callers outside project
/// validation: tests, the bench, `softplc sim` tools). The setting's reason stays text here:
/// it is the message for a person, made with the value's text ([`SettingError::describe`]),
/// which the typed error does not carry.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ConfigError {
    /// The address.
    #[error(transparent)]
    Address(#[from] AddressError),
    /// A setting.
    #[error("setting {key}: {message}")]
    Setting {
        /// The key as given.
        key: String,
        /// The model's reason.
        message: String,
    },
}

/// What a driver is built from: the validated module entry of a project file.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceConfig {
    /// The module's name in the project (`mm1`).
    pub name: String,
    /// Unit / text address.
    pub address: ModuleAddress,
    /// Protocol chosen for this module.
    pub protocol: Protocol,
    /// Model-specific settings, parsed by the model.
    pub settings: ModuleSettings,
    /// What the push-down planner moved into the module's own logic (nothing by default).
    pub push_down: PushDown,
}

impl DeviceConfig {
    /// How long the module holds a change of its input point `point` (by the manual's name)
    /// before it takes it, as configured: the MiniMod's input latency on X1..X3; nothing for
    /// the models whose inputs have no programmable latency. A reaction to the input, in the
    /// module or in the scan, starts only after it.
    pub fn input_latency(&self, point: &str) -> Option<std::time::Duration> {
        match (&self.settings, &self.push_down) {
            (ModuleSettings::MiniMod(own), push_down) => {
                let input = minimod::push_down::Input::named(point)?;
                let none = minimod::PushDown::default();
                let planned = match push_down {
                    PushDown::MiniMod(p) => p,
                    _ => &none,
                };
                Some(minimod::push_down::input_latency(own, planned, input))
            }
            _ => None,
        }
    }
}

/// The tables the push-down planner hands a module's driver, which writes them at start-up
/// after the module's own settings and reads them back.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum PushDown {
    /// Nothing pushed down.
    #[default]
    None,
    /// A MiniMod's automatic outputs, start values and input latencies.
    MiniMod(minimod::PushDown),
    /// A RESI-16DI8RO's logic table.
    Resi(resi::LogicTable),
}

impl ModelSpec {
    /// A driver configuration from text, as a project entry gives it: the address checked,
    /// every setting parsed (the first refusal is the error).
    pub fn device_config(
        &self,
        name: &str,
        address: u8,
        protocol: Protocol,
        settings: &[(&str, &str)],
    ) -> Result<DeviceConfig, ConfigError> {
        let address = ModuleAddress::new(self, address)?;
        let owned: Vec<(String, String)> = settings
            .iter()
            .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
            .collect();
        let settings = self.parse(&owned).map_err(|errors| {
            let first = errors
                .first()
                .and_then(|e| Some((owned.get(e.index)?, e.error)));
            match first {
                Some(((key, value), error)) => ConfigError::Setting {
                    key: key.clone(),
                    message: error.describe(value),
                },
                None => ConfigError::Setting {
                    key: String::new(),
                    message: "refused".into(),
                },
            }
        })?;
        Ok(DeviceConfig {
            name: name.to_owned(),
            address,
            protocol,
            settings,
            push_down: PushDown::None,
        })
    }
}

/// `an` before a vowel (`an ex9053d setting`), else `a`.
fn article(word: &str) -> &'static str {
    match word.bytes().next() {
        Some(b'a' | b'e' | b'i' | b'o' | b'u') => "an",
        _ => "a",
    }
}

/// Parses every pair with `one`, collecting every refusal with its index (the shape every
/// family's `parse_settings` shares).
pub(crate) fn parse_each<T>(
    pairs: &[(String, String)],
    mut one: impl FnMut(&str, &str) -> Result<T, SettingError>,
) -> Result<Vec<T>, Vec<KeyError>> {
    let mut items = Vec::with_capacity(pairs.len());
    let mut errors = Vec::new();
    for (index, (key, value)) in pairs.iter().enumerate() {
        match one(key, value) {
            Ok(item) => items.push(item),
            Err(error) => errors.push(KeyError { index, error }),
        }
    }
    if errors.is_empty() {
        Ok(items)
    } else {
        Err(errors)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::{ex9053, minimod};

    fn copy_eq<T: Copy + Eq>() {}

    #[test]
    fn a_minimods_input_latency_is_the_plans_else_its_settings_else_20ms() {
        use std::time::Duration;
        let ms = |n| Some(Duration::from_millis(n));
        let plain = minimod::MODEL
            .device_config("mm1", 1, Protocol::Modbus, &[])
            .unwrap();
        assert_eq!(plain.input_latency("X1"), ms(20), "power-on");
        assert_eq!(plain.input_latency("Y1"), None, "an output has none");
        let mut set = minimod::MODEL
            .device_config(
                "mm1",
                1,
                Protocol::Modbus,
                &[("XLATUP2", "5"), ("XLATDN2", "50")],
            )
            .unwrap();
        assert_eq!(set.input_latency("X2"), ms(50), "the longer edge");
        assert_eq!(set.input_latency("X3"), ms(20));
        set.push_down = PushDown::MiniMod(minimod::PushDown {
            latencies: vec![minimod::push_down::Latency {
                input: minimod::push_down::Input::named("X2").unwrap(),
                rising: Some(2),
                falling: Some(3),
            }],
            ..Default::default()
        });
        assert_eq!(
            set.input_latency("X2"),
            ms(3),
            "the plan's conditioning wins"
        );
        let dcon = ex9053::MODEL_D
            .device_config("di", 2, Protocol::Text, &[])
            .unwrap();
        assert_eq!(dcon.input_latency("DI0"), None, "no programmable latency");
    }

    #[test]
    fn errors_across_the_seam_are_copy_and_comparable() {
        copy_eq::<SettingError>();
        copy_eq::<KeyError>();
        copy_eq::<AddressError>();
        copy_eq::<crate::driver::DecodeError>();
        copy_eq::<crate::line::bus::TxError>();
    }

    #[test]
    fn an_address_is_checked_against_its_models_range() {
        assert_eq!(
            ModuleAddress::new(&minimod::MODEL, 0),
            Err(AddressError {
                model: "minimod",
                given: 0,
                min: 1,
                max: 247
            })
        );
        // DCON address 0 is an EX-9053D's, but no Modbus unit.
        let dcon = ModuleAddress::new(&ex9053::MODEL_D, 0).unwrap();
        assert_eq!((dcon.get(), dcon.unit()), (0, None));
        let unit = ModuleAddress::new(&minimod::MODEL, 5).unwrap().unit();
        assert_eq!(unit.map(UnitId::get), Some(5));
    }

    #[test]
    fn a_config_from_text_names_the_refused_setting() {
        let e = minimod::MODEL
            .device_config("mm1", 1, Protocol::Modbus, &[("RDELAYT", "300")])
            .unwrap_err();
        assert_eq!(
            e,
            ConfigError::Setting {
                key: "RDELAYT".into(),
                message: "RDELAYT takes 0..=200 (1/100 s)".into()
            }
        );
        let c = minimod::MODEL
            .device_config("mm1", 1, Protocol::Modbus, &[])
            .unwrap();
        assert!(c.settings.is_empty() && c.push_down == PushDown::None);
    }
}
