//! A profile's entry among the models: the [`ModelSpec`] validation, `check`, the bus owner
//! and `softplc sim` know every model by.
//!
//! A [`ModelSpec`] is `'static` (the built-in models are statics, and everything downstream
//! keeps `&'static` references to them). A profile read at run time is therefore interned: the
//! first time a profile's content is seen its spec is allocated for the life of the process,
//! and every later load of the same content (a reload, a second module of the same device)
//! gets that one back, so memory grows only with the number of distinct profiles.

use std::sync::{Mutex, OnceLock};
use std::time::Duration;

use super::{driver, sim, Profile};
use crate::devices::{Accepted, KeyError, ModelSpec, ModuleSettings, Protocol, SettingError};
use crate::point::{Access, PointSpec};

/// A profile module's settings: its profile (the file says everything; a project entry's
/// `settings:` are refused).
#[derive(Debug, Clone, PartialEq)]
pub struct ProfileSettings {
    /// The profile.
    pub profile: &'static Profile,
}

static INTERNED: Mutex<Vec<&'static ModelSpec>> = Mutex::new(Vec::new());

/// The model of `profile`, interned by content.
pub fn model_of(profile: Profile) -> &'static ModelSpec {
    let mut interned = INTERNED.lock().unwrap_or_else(|e| e.into_inner());
    if let Some(m) = interned
        .iter()
        .find(|m| m.profile.is_some_and(|p| *p == profile))
    {
        return m;
    }
    let profile: &'static Profile = Box::leak(Box::new(profile));
    let spec: &'static ModelSpec = Box::leak(Box::new(spec(profile)));
    interned.push(spec);
    spec
}

/// The profile with no points, for a driver or simulator asked for without one.
pub(crate) fn empty() -> &'static Profile {
    static EMPTY: OnceLock<Profile> = OnceLock::new();
    EMPTY.get_or_init(|| Profile {
        model: String::new(),
        summary: String::new(),
        source: String::new(),
        addresses: 1..=247,
        max_baud: 115_200,
        points: Vec::new(),
        groups: Vec::new(),
        limits: Default::default(),
        timing: super::DeviceTiming {
            reply_timeout: None,
            frame_gap: None,
            reply_delay: Duration::ZERO,
        },
        behaviours: Vec::new(),
    })
}

fn leak(s: String) -> &'static str {
    Box::leak(s.into_boxed_str())
}

/// One line per point for `check` and `softplc models`: table, address, type, scaling,
/// access, group, the manual's name.
pub fn describe(profile: &Profile, entry: super::Entry) -> String {
    let p = &profile.points[entry.point];
    let group = profile
        .groups
        .get(p.group)
        .map(|g| match g.period {
            Some(t) => format!("{} every {t:?}", g.name),
            None => format!("{} every cycle", g.name),
        })
        .unwrap_or_default();
    if let Some(b) = entry.bits {
        let f = &p.bits[b];
        let bits = if f.width == 1 {
            format!("bit {}", f.bit)
        } else {
            format!("bits {}..={}", f.bit, f.bit + f.width - 1)
        };
        let manual = f
            .manual
            .as_deref()
            .map(|m| format!(" — {m}"))
            .unwrap_or_default();
        return format!("{bits} of {} ({group}){manual}", p.name);
    }
    let mut s = format!("{} {}", p.table.name(), p.address);
    s.push_str(&format!(" {}", p.data.name()));
    if p.data.words() == 2 {
        s.push_str(&format!(" {}", p.order.name()));
    }
    if let Some(k) = p.scaling {
        s.push_str(&format!(" ×{}", k.scale));
        if k.offset != 0.0 {
            s.push_str(&format!(" {:+}", k.offset));
        }
    }
    if let Some(u) = &p.unit {
        s.push_str(&format!(" {u}"));
    }
    s.push_str(&format!(", {}", p.access.name()));
    if p.access.reads() {
        s.push_str(&format!(", {group}"));
    }
    if p.access.writes() && p.write == super::WriteMode::Cyclic {
        s.push_str(", written every cycle");
    }
    if let Some(m) = &p.manual {
        s.push_str(&format!(" — {m}"));
    }
    s
}

fn spec(profile: &'static Profile) -> ModelSpec {
    let points: Vec<PointSpec> = profile
        .entries()
        .into_iter()
        .map(|e| {
            let p = &profile.points[e.point];
            let (name, ty, access) = match e.bits {
                Some(b) => (
                    p.bits[b].name.clone(),
                    p.bits[b].value_type(),
                    Access::Input,
                ),
                None => (
                    p.name.clone(),
                    p.value_type(),
                    if p.access.writes() {
                        Access::Output
                    } else {
                        Access::Input
                    },
                ),
            };
            PointSpec {
                name: leak(name),
                ty,
                access,
                doc: leak(describe(profile, e)),
            }
        })
        .collect();
    ModelSpec {
        name: leak(profile.model.clone()),
        summary: leak(format!("{} (profile; {})", profile.summary, profile.source)),
        points: Box::leak(points.into_boxed_slice()),
        protocols: &[Protocol::Modbus],
        addresses: profile.addresses.clone(),
        max_baud: profile.max_baud,
        default_reply_delay: profile.timing.reply_delay,
        driver: driver::build,
        simulator: sim::unbound,
        parse_settings: no_settings,
        setting_keys: Vec::new,
        profile: Some(profile),
        family: &super::ProfileFamily,
    }
}

/// A profile module takes no `settings:` (its profile file says everything).
fn no_settings(pairs: &[(String, String)]) -> Result<ModuleSettings, Vec<KeyError>> {
    if pairs.is_empty() {
        return Ok(ModuleSettings::Profile(ProfileSettings {
            profile: empty(),
        }));
    }
    Err((0..pairs.len())
        .map(|index| KeyError {
            index,
            error: SettingError::UnknownKey {
                model: "profile",
                accepted: Accepted::Profile,
            },
        })
        .collect())
}

/// A profile model's settings: none, with its profile.
pub(crate) fn parse(
    profile: &'static Profile,
    pairs: &[(String, String)],
) -> Result<ModuleSettings, Vec<KeyError>> {
    no_settings(pairs).map(|_| ModuleSettings::Profile(ProfileSettings { profile }))
}
