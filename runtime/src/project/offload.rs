//! Push-down switches of a project: the `offload:` section and the tag options that belong to
//! it (see [`crate::offload`] for what the planner does with them).
//!
//! ```yaml
//! offload: auto                  # auto | never | require; default never
//! # or, with what happens to the module tables when the PLC stops:
//! offload: { mode: auto, on_stop: clear }   # on_stop: clear (default) | keep
//! tags:
//!   - { name: lamp,   point: mm2.Y1, offload: require }   # per rung: the rung writing lamp
//!   - { name: horn,   point: mm2.Y2, offload: never }
//!   - { name: button, point: mm1.X1, debounce: 20ms }      # XLATUP1 = XLATDN1 = 20
//!   - { name: eye,    point: mm1.X2, stretch: 500ms }      # XLATDN2 = 500
//!   - { name: beacon, point: mm2.Y3, blink_phase: free }   # its BLINK may go down as YLAMP3
//! ```
//!
//! - `mode` is the default of every rung; a tag's `offload` overrides it for the rung that
//!   writes the tag (only tags bound to a module output have a rung to push). `never` keeps
//!   the rung central, `auto` pushes it down when the module gives the same behaviour,
//!   `require` makes `softplc check` (and the start) fail when it cannot be pushed down.
//! - The default is `never`: push-down changes who owns an output (the module, not the scan),
//!   what a force can do and what the bus carries (read-back of the outputs), so a project
//!   asks for it; `softplc check` shows what `auto` would push down.
//! - `on_stop: clear` writes zero to every table the planner wrote, then the safe values of
//!   the pushed-down outputs; `keep` leaves the tables running in the modules (a machine whose
//!   fast interlocks must survive the PLC) and does not write those outputs.
//! - `debounce` and `stretch` condition a MiniMod input X1..X3 in the module ("Input
//!   conditioning"): `debounce: T` sets the rising and falling latencies XLATUPn and XLATDNn
//!   to T (noise and bounces shorter than T vanish), `stretch: T` sets XLATDNn to T (a pulse
//!   shorter than the scan is held long enough for the scan to see it). Whole milliseconds,
//!   0..=65535. The same registers may not also be set in the module's `settings`.
//! - `blink_phase: free` on an output says that the BLINK writing it may start anywhere in
//!   its period when its enable rises (default `enable`: on at once, as BLINK does). Only
//!   then may a BLINK go down as a MiniMod blinker (YLAMPn), whose steps run freely from the
//!   module's power-on; a LAMP block needs no such word, its phase is free by definition.

use std::fmt;
use std::time::Duration;

use serde::de::{self, value::MapAccessDeserializer, Deserializer, MapAccess, Visitor};
use serde::Deserialize;

use super::error::ErrorKind;
use super::model::{Binding, ModuleConfig, TagConfig};
use super::raw::{RawProject, RawTag};
use super::span::YPath;
use softplc_io::point::Access;

/// Whether rungs may be pushed down into modules.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OffloadMode {
    /// Keep every rung central.
    #[default]
    Never,
    /// Push a rung down when the module gives the same behaviour.
    Auto,
    /// Push down, or fail `check` and the start.
    Require,
}

impl OffloadMode {
    /// The project-file word.
    pub fn name(self) -> &'static str {
        match self {
            OffloadMode::Never => "never",
            OffloadMode::Auto => "auto",
            OffloadMode::Require => "require",
        }
    }

    fn parse(text: &str) -> Option<Self> {
        match text.trim() {
            "never" => Some(OffloadMode::Never),
            "auto" => Some(OffloadMode::Auto),
            "require" => Some(OffloadMode::Require),
            _ => None,
        }
    }
}

impl fmt::Display for OffloadMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What happens to the module tables when the PLC stops.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum OnStop {
    /// Write zero to every table, then the safe values of the pushed-down outputs.
    #[default]
    Clear,
    /// Leave the tables running; the pushed-down outputs stay the modules'.
    Keep,
}

/// A tag's push-down options.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TagOffload {
    /// The rung writing this tag: overrides the project's mode.
    pub mode: Option<OffloadMode>,
    /// Input debounce (XLATUPn and XLATDNn), whole ms.
    pub debounce: Option<u16>,
    /// Input pulse stretching (XLATDNn), whole ms.
    pub stretch: Option<u16>,
    /// `blink_phase: free`: a BLINK writing this output may start anywhere in its period.
    pub blink_phase_free: bool,
}

/// The validated push-down settings.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct OffloadConfig {
    /// Every rung's default.
    pub mode: OffloadMode,
    /// At stop.
    pub on_stop: OnStop,
    /// Per tag, indexed like [`super::Project::tags`].
    pub tags: Vec<TagOffload>,
}

impl OffloadConfig {
    /// The mode of the rung writing tag `tag`: the tag's own, else the project's.
    pub fn mode_of(&self, tag: usize) -> OffloadMode {
        self.tags.get(tag).and_then(|t| t.mode).unwrap_or(self.mode)
    }
}

/// `offload:` as written: a word, or a mapping.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct RawOffload {
    /// `auto`, `never`, `require`.
    pub mode: Option<String>,
    /// `clear` or `keep`.
    pub on_stop: Option<String>,
    /// Written as a mapping (errors then point into it).
    pub mapping: bool,
}

#[derive(Deserialize)]
#[serde(
    deny_unknown_fields,
    expecting = "offload settings: a mapping with mode and on_stop"
)]
struct RawOffloadMap {
    #[serde(default)]
    mode: Option<String>,
    #[serde(default)]
    on_stop: Option<String>,
}

impl<'de> Deserialize<'de> for RawOffload {
    fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> Visitor<'de> for V {
            type Value = RawOffload;

            fn expecting(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str("auto, never, require, or a mapping with mode and on_stop")
            }

            fn visit_str<E: de::Error>(self, v: &str) -> Result<RawOffload, E> {
                Ok(RawOffload {
                    mode: Some(v.to_owned()),
                    on_stop: None,
                    mapping: false,
                })
            }

            fn visit_map<A: MapAccess<'de>>(self, map: A) -> Result<RawOffload, A::Error> {
                let m = RawOffloadMap::deserialize(MapAccessDeserializer::new(map))?;
                Ok(RawOffload {
                    mode: m.mode,
                    on_stop: m.on_stop,
                    mapping: true,
                })
            }
        }
        d.deserialize_any(V)
    }
}

/// What is wrong with the push-down settings.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum OffloadError {
    /// Not a mode.
    #[error("offload mode \"{text}\" is not one of auto, never, require")]
    BadMode {
        /// As written.
        text: String,
    },
    /// Not a `blink_phase` choice.
    #[error("tag {tag}: blink_phase \"{text}\" is not one of enable, free")]
    BadBlinkPhase {
        /// The tag.
        tag: String,
        /// As written.
        text: String,
    },
    /// `blink_phase` on a tag no rung can push down.
    #[error(
        "tag {tag}: blink_phase applies to tags bound to a module output (the BLINK writing \
         the output); this is {what}"
    )]
    BlinkPhaseNotOnOutput {
        /// The tag.
        tag: String,
        /// What the tag is instead.
        what: &'static str,
    },
    /// Not an `on_stop` choice.
    #[error("offload.on_stop \"{text}\" is not one of clear, keep")]
    BadOnStop {
        /// As written.
        text: String,
    },
    /// `offload` on a tag that no rung can push down.
    #[error(
        "tag {tag}: offload applies to tags bound to a module output (the rung writing the \
         output is pushed down or not); this is {what}"
    )]
    ModeNotOnOutput {
        /// The tag.
        tag: String,
        /// What the tag is instead.
        what: &'static str,
    },
    /// `debounce`/`stretch` on a tag that is not a MiniMod input.
    #[error(
        "tag {tag}: {key} is done by the module's input conditioning, which only MiniMod \
         inputs X1..X3 have; this is {what}"
    )]
    ConditioningNotOnInput {
        /// The tag.
        tag: String,
        /// `debounce` or `stretch`.
        key: &'static str,
        /// What the tag is instead.
        what: String,
    },
    /// A conditioning time the module cannot hold.
    #[error(
        "tag {tag}: {key} {ms} is not a whole number of milliseconds from 0ms to 65535ms (the \
         module's latency registers count ms)"
    )]
    BadLatency {
        /// The tag.
        tag: String,
        /// `debounce` or `stretch`.
        key: &'static str,
        /// The value, as shown.
        ms: String,
    },
    /// The latency register is also set another way.
    #[error("tag {tag}: {key} sets {register} of module {module}, which {other} also sets")]
    LatencyTwice {
        /// The tag.
        tag: String,
        /// `debounce` or `stretch`.
        key: &'static str,
        /// The register.
        register: String,
        /// The module.
        module: String,
        /// The other place (`its settings`, `tag x`).
        other: String,
    },
}

/// Whole milliseconds in 0..=65535.
fn whole_ms(d: Duration) -> Option<u16> {
    (d.subsec_nanos() % 1_000_000 == 0)
        .then(|| u16::try_from(d.as_millis()).ok())
        .flatten()
}

/// The push-down settings of `raw`, with the errors found (and where). `tags` are the
/// validated tags (`None` where refused) and `module(i)` the validated module `i`.
pub(crate) fn validate<'m>(
    raw: &RawProject,
    tags: &[Option<TagConfig>],
    module: impl Fn(usize) -> Option<&'m ModuleConfig>,
) -> (Option<OffloadConfig>, Vec<(YPath, ErrorKind)>) {
    let root = YPath::root().key("offload");
    let mut errors: Vec<(YPath, ErrorKind)> = Vec::new();
    let given = raw.offload.clone().unwrap_or_default();
    let at = |key: &str| {
        if given.mapping {
            root.key(key)
        } else {
            root.clone()
        }
    };
    let mode = match given.mode.as_deref() {
        None => Some(OffloadMode::default()),
        Some(text) => OffloadMode::parse(text).or_else(|| {
            errors.push((
                at("mode"),
                OffloadError::BadMode { text: text.into() }.into(),
            ));
            None
        }),
    };
    let on_stop = match given.on_stop.as_deref().map(str::trim) {
        None | Some("clear") => Some(OnStop::Clear),
        Some("keep") => Some(OnStop::Keep),
        Some(text) => {
            errors.push((
                at("on_stop"),
                OffloadError::BadOnStop { text: text.into() }.into(),
            ));
            None
        }
    };
    // (module, register) → who sets it, for the "set twice" check.
    let mut latency_owner: Vec<(usize, String, String)> = Vec::new();
    let mut per_tag = Vec::with_capacity(raw.tags.len());
    let mut ok = true;
    for (i, (rt, tc)) in raw.tags.iter().zip(tags).enumerate() {
        let path = YPath::root().key("tags").index(i);
        let (t, e) = tag(rt, tc.as_ref(), &module, &path, &mut latency_owner);
        ok &= e.is_empty();
        errors.extend(e);
        per_tag.push(t);
    }
    let config = match (mode, on_stop, ok) {
        (Some(mode), Some(on_stop), true) => Some(OffloadConfig {
            mode,
            on_stop,
            tags: per_tag,
        }),
        _ => None,
    };
    (config, errors)
}

/// One tag's options.
fn tag<'m>(
    rt: &RawTag,
    tc: Option<&TagConfig>,
    module: &impl Fn(usize) -> Option<&'m ModuleConfig>,
    path: &YPath,
    latency_owner: &mut Vec<(usize, String, String)>,
) -> (TagOffload, Vec<(YPath, ErrorKind)>) {
    let mut errors: Vec<(YPath, ErrorKind)> = Vec::new();
    let mut out = TagOffload::default();
    // The tag's point, when it is bound and its module is valid.
    let point = tc.and_then(|t| match t.binding {
        Binding::Point { module: m, point } => {
            let cfg = module(m)?;
            Some((m, cfg, cfg.model.points.get(point)?))
        }
        Binding::Memory => None,
    });
    let what = |p: Option<(usize, &ModuleConfig, &softplc_io::point::PointSpec)>| match p {
        Some((_, cfg, spec)) => format!(
            "{}.{} ({} of a {})",
            cfg.name,
            spec.name,
            match spec.access {
                Access::Input => "an input",
                Access::Output => "an output",
                Access::ReadWrite => "a read-write setting",
            },
            cfg.model.name
        ),
        None => "a memory tag".to_owned(),
    };
    // What a valid tag is when it is no module output (no rung of it can be pushed down).
    let not_output = match point {
        _ if tc.is_none() => None,
        Some((_, _, spec)) if spec.access == Access::Output => None,
        Some(_) => Some("not an output"),
        None => Some("a memory tag"),
    };
    if let Some(text) = &rt.offload {
        match OffloadMode::parse(&text.0) {
            None => errors.push((
                path.key("offload"),
                OffloadError::BadMode {
                    text: text.0.clone(),
                }
                .into(),
            )),
            Some(m) => {
                if let Some(what) = not_output {
                    errors.push((
                        path.key("offload"),
                        OffloadError::ModeNotOnOutput {
                            tag: rt.name.clone(),
                            what,
                        }
                        .into(),
                    ));
                }
                out.mode = Some(m);
            }
        }
    }
    if let Some(text) = &rt.blink_phase {
        match text.0.trim() {
            "enable" => {}
            "free" => out.blink_phase_free = true,
            other => errors.push((
                path.key("blink_phase"),
                OffloadError::BadBlinkPhase {
                    tag: rt.name.clone(),
                    text: other.into(),
                }
                .into(),
            )),
        }
        if let Some(what) = not_output {
            errors.push((
                path.key("blink_phase"),
                OffloadError::BlinkPhaseNotOnOutput {
                    tag: rt.name.clone(),
                    what,
                }
                .into(),
            ));
        }
    }
    for (key, given) in [("debounce", &rt.debounce), ("stretch", &rt.stretch)] {
        let Some(d) = given else { continue };
        let Some(ms) = whole_ms(d.0) else {
            errors.push((
                path.key(key),
                OffloadError::BadLatency {
                    tag: rt.name.clone(),
                    key,
                    ms: crate::scan::fmt_duration(d.0),
                }
                .into(),
            ));
            continue;
        };
        if tc.is_none() {
            // The tag itself was refused (and reported); nothing to check against.
            continue;
        }
        let regs = point.and_then(|(m, cfg, spec)| {
            cfg.model
                .family
                .input_latency_registers(spec.name)
                .map(|r| (m, cfg, r))
        });
        let Some((m, cfg, (up, dn))) = regs else {
            errors.push((
                path.key(key),
                OffloadError::ConditioningNotOnInput {
                    tag: rt.name.clone(),
                    key,
                    what: what(point),
                }
                .into(),
            ));
            continue;
        };
        let registers = if key == "debounce" {
            out.debounce = Some(ms);
            vec![up, dn]
        } else {
            out.stretch = Some(ms);
            vec![dn]
        };
        for register in registers {
            // Parsed settings: the text spellings X1LATUP.. are the same registers there.
            let in_settings = cfg
                .model
                .family
                .sets_register(&cfg.device.settings, &register);
            let other = if in_settings {
                Some("its settings".to_owned())
            } else {
                latency_owner
                    .iter()
                    .find(|(om, r, _)| *om == m && *r == register)
                    .map(|(_, _, who)| who.clone())
            };
            match other {
                // debounce + stretch on the same tag: stretch's XLATDN wins, by design.
                Some(who) if who == format!("tag {}", rt.name) => {}
                Some(other) => errors.push((
                    path.key(key),
                    OffloadError::LatencyTwice {
                        tag: rt.name.clone(),
                        key,
                        register: register.clone(),
                        module: cfg.name.clone(),
                        other,
                    }
                    .into(),
                )),
                None => latency_owner.push((m, register, format!("tag {}", rt.name))),
            }
        }
    }
    (out, errors)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_milliseconds() {
        assert_eq!(whole_ms(Duration::from_millis(20)), Some(20));
        assert_eq!(whole_ms(Duration::from_micros(1500)), None);
        assert_eq!(whole_ms(Duration::from_millis(65535)), Some(65535));
        assert_eq!(whole_ms(Duration::from_millis(65536)), None);
    }
}
