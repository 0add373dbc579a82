//! Alarms and the operator's tags: a tag's `alarm:` and `operator:` keys, and the `alarms:`
//! section.
//!
//! ```yaml
//! tags:
//!   - { name: door_jam, point: mm1.X4, alarm: { text: Door jammed, priority: high } }
//!   - { name: air_ok, point: mm1.X5, alarm: { text: No air pressure, when: false } }
//!   - { name: level, type: f32, alarm: { text: Tank overflow, when: "> 95", priority: 900 } }
//!   - { name: setpoint, type: u16, operator: true }   # on the operator's page (/operator)
//! alarms: { history: 1000 }   # events kept in PROJECT.alarms.jsonl (default 1000, 10..=100000)
//! ```
//!
//! - `text`: what the operator reads (one line, at most 256 characters), required.
//! - `priority`: `low`, `medium` (the default), `high`, `urgent`, or a number 1..=1000 (the
//!   OPC UA severity scale). The names stand for 250, 500, 750 and 1000; a number is shown
//!   with the name of its band (1..=250 low, 251..=500 medium, 501..=750 high, 751..=1000
//!   urgent).
//! - `when`: the condition that makes it active. A bool tag: `true` (the default) or
//!   `false`; a number: a comparison with a literal, `"> 95"`, `"<= 0.5"`, `"== 3"`, `"!= 0"`
//!   (required).
//!
//! Every module has one more alarm, `lost.MODULE` ("module lost: MODULE", priority high):
//! while it is raised its tags' alarms are held as they were, so a dead line shows one alarm
//! per module rather than one per signal.

use schemars::JsonSchema;
use serde::Deserialize;
use softplc_io::point::{Value, ValueType};

use super::error::ErrorKind;
use super::raw::{Int, RawProject, ScalarText};
use super::span::YPath;
use super::trace::CompareOp;
use super::{DocKind, DocText, TagConfig};

/// Default number of events the history keeps.
pub(crate) const DEFAULT_HISTORY: usize = 1_000;
/// Bounds of `alarms.history`.
const HISTORY_RANGE: std::ops::RangeInclusive<usize> = 10..=100_000;

/// A tag's alarm: what the operator reads, how urgent it is, and when it is active.
#[derive(Debug, Clone, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "an alarm: a mapping with text, priority and when"
)]
pub(crate) struct RawAlarm {
    /// What the operator reads (one line, at most 256 characters).
    pub text: String,
    /// `low`, `medium` (default), `high`, `urgent`, or a severity 1..=1000.
    #[serde(default)]
    pub priority: Option<ScalarText>,
    /// When it is active: `true` (default) or `false` for a bool tag; `"> 95"` (`>`, `>=`,
    /// `<`, `<=`, `==`, `!=` and a number) for a number.
    #[serde(default)]
    pub when: Option<ScalarText>,
}

/// The `alarms:` settings.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "alarm settings: a mapping with history"
)]
pub(crate) struct RawAlarms {
    /// Events kept in the history file (default 1000, 10..=100000).
    #[serde(default)]
    pub history: Option<Int>,
}

/// An alarm's priority: a severity 1..=1000, as OPC UA counts it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Priority(u16);

impl Priority {
    /// The named levels and the severity each stands for.
    pub const LEVELS: [(&'static str, u16); 4] = [
        ("low", 250),
        ("medium", 500),
        ("high", 750),
        ("urgent", 1000),
    ];
    /// `medium`.
    pub const MEDIUM: Priority = Priority(500);
    /// `high`: a lost module's.
    pub const HIGH: Priority = Priority(750);

    /// A severity 1..=1000.
    pub fn new(severity: u16) -> Option<Self> {
        (1..=1000).contains(&severity).then_some(Self(severity))
    }

    /// Reads a level's name or a severity.
    pub fn parse(text: &str) -> Option<Self> {
        let t = text.trim();
        match Self::LEVELS.iter().find(|(n, _)| n.eq_ignore_ascii_case(t)) {
            Some((_, s)) => Some(Self(*s)),
            None => t.parse().ok().and_then(Self::new),
        }
    }

    /// The severity, 1..=1000.
    pub fn severity(self) -> u16 {
        self.0
    }

    /// The name of its band: `low` (1..=250), `medium`, `high`, `urgent` (751..=1000).
    pub fn level(self) -> &'static str {
        Self::LEVELS
            .iter()
            .find(|(_, top)| self.0 <= *top)
            .map_or("urgent", |(n, _)| n)
    }
}

impl std::fmt::Display for Priority {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.level())
    }
}

/// When an alarm is active.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum AlarmWhen {
    /// A bool tag has this value.
    Is(bool),
    /// A number compares so with a literal.
    Compare(CompareOp, f64),
}

impl AlarmWhen {
    /// Whether `value` makes the alarm active.
    pub fn holds(self, value: Value) -> bool {
        match (self, value) {
            (AlarmWhen::Is(b), Value::Bool(v)) => v == b,
            (AlarmWhen::Compare(op, lit), v) => op.holds(number(v), lit),
            (AlarmWhen::Is(_), _) => false,
        }
    }
}

/// A value as a number, for a comparison.
fn number(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    }
}

/// A tag's alarm.
#[derive(Debug, Clone, PartialEq)]
pub struct AlarmConfig {
    /// The tag (its index in [`super::Project::tags`]); its name is the alarm's.
    pub tag: usize,
    /// What the operator reads.
    pub text: DocText,
    /// Its priority.
    pub priority: Priority,
    /// When it is active.
    pub when: AlarmWhen,
}

/// The project's alarms and the operator's tags.
#[derive(Debug, Clone, PartialEq)]
pub struct AlarmsConfig {
    /// The tags' alarms, in tag order.
    pub alarms: Vec<AlarmConfig>,
    /// The tags on the operator's page, in tag order.
    pub operator: Vec<usize>,
    /// Events the history keeps.
    pub history: usize,
}

impl Default for AlarmsConfig {
    fn default() -> Self {
        Self {
            alarms: Vec::new(),
            operator: Vec::new(),
            history: DEFAULT_HISTORY,
        }
    }
}

/// What is wrong with an alarm or the `alarms:` section.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum AlarmError {
    /// `priority` is neither a level nor a severity.
    #[error(
        "alarm of tag {tag}: priority {text:?} is not low, medium, high, urgent or a number \
         1..=1000"
    )]
    Priority {
        /// The tag.
        tag: String,
        /// As written.
        text: String,
    },
    /// `when` on a bool tag is not true or false.
    #[error("alarm of bool tag {tag}: when {text:?} must be true or false")]
    BoolWhen {
        /// The tag.
        tag: String,
        /// As written.
        text: String,
    },
    /// `when` on a number tag is not a comparison.
    #[error(
        "alarm of {ty} tag {tag}: when {text:?} is not a comparison with a number, like \"> 95\" \
         (>, >=, <, <=, ==, !=)"
    )]
    Compare {
        /// The tag.
        tag: String,
        /// Its type.
        ty: ValueType,
        /// As written.
        text: String,
    },
    /// A number tag's alarm without `when`.
    #[error("alarm of {ty} tag {tag}: say when it is active, like when: \"> 95\"")]
    NoWhen {
        /// The tag.
        tag: String,
        /// Its type.
        ty: ValueType,
    },
    /// `text` is empty.
    #[error("alarm of tag {tag}: its text is empty; say what the operator should read")]
    EmptyText {
        /// The tag.
        tag: String,
    },
    /// `text` is too long or more than one line.
    #[error("alarm of tag {tag}: text {error}")]
    Text {
        /// The tag.
        tag: String,
        /// Why.
        error: super::DocTextError,
    },
    /// `alarms.history` out of range.
    #[error("alarms.history is {value}; it must be between 10 and 100000")]
    History {
        /// As written.
        value: i64,
    },
}

/// The project's alarms, operator tags and history bound from `raw`; every error is given to
/// `report` with its place. `tags` are the validated tags (`None` where refused).
pub(crate) fn validate_all(
    raw: &RawProject,
    tags: &[Option<TagConfig>],
    mut report: impl FnMut(YPath, ErrorKind),
) -> AlarmsConfig {
    let mut out = AlarmsConfig::default();
    if let Some(Int(n)) = raw.alarms.as_ref().and_then(|a| a.history) {
        match usize::try_from(n) {
            Ok(n) if HISTORY_RANGE.contains(&n) => out.history = n,
            _ => report(
                YPath::root().key("alarms").key("history"),
                AlarmError::History { value: n }.into(),
            ),
        }
    }
    for (i, t) in raw.tags.iter().enumerate() {
        let path = YPath::root().key("tags").index(i);
        if t.operator == Some(true) {
            out.operator.push(i);
        }
        let (Some(a), Some(Some(tag))) = (&t.alarm, tags.get(i)) else {
            continue;
        };
        match alarm(i, tag, a) {
            Ok(c) => out.alarms.push(c),
            Err((key, e)) => report(path.key("alarm").key(key), e.into()),
        }
    }
    out
}

/// One tag's alarm, or the key at fault and why.
fn alarm(
    i: usize,
    tag: &TagConfig,
    raw: &RawAlarm,
) -> Result<AlarmConfig, (&'static str, AlarmError)> {
    let name = || tag.name.clone();
    let text = match DocText::new(DocKind::Description, &raw.text) {
        Ok(Some(t)) => t,
        Ok(None) => return Err(("text", AlarmError::EmptyText { tag: name() })),
        Err(error) => return Err(("text", AlarmError::Text { tag: name(), error })),
    };
    let priority = match &raw.priority {
        None => Priority::MEDIUM,
        Some(ScalarText(p)) => Priority::parse(p).ok_or_else(|| {
            (
                "priority",
                AlarmError::Priority {
                    tag: name(),
                    text: p.clone(),
                },
            )
        })?,
    };
    let when = match (tag.ty, raw.when.as_ref().map(|w| w.0.trim())) {
        (ValueType::Bool, None) => AlarmWhen::Is(true),
        (ValueType::Bool, Some(w)) => match w {
            "true" | "1" => AlarmWhen::Is(true),
            "false" | "0" => AlarmWhen::Is(false),
            _ => {
                return Err((
                    "when",
                    AlarmError::BoolWhen {
                        tag: name(),
                        text: w.into(),
                    },
                ))
            }
        },
        (ty, None) => return Err(("when", AlarmError::NoWhen { tag: name(), ty })),
        (ty, Some(w)) => parse_compare(w).ok_or_else(|| {
            (
                "when",
                AlarmError::Compare {
                    tag: name(),
                    ty,
                    text: w.into(),
                },
            )
        })?,
    };
    Ok(AlarmConfig {
        tag: i,
        text,
        priority,
        when,
    })
}

/// `OP NUMBER`.
fn parse_compare(text: &str) -> Option<AlarmWhen> {
    let (op, literal) = CompareOp::ALL
        .iter()
        .find_map(|(s, op)| text.strip_prefix(s).map(|lit| (*op, lit.trim())))?;
    let v: f64 = literal.parse().ok().filter(|v: &f64| v.is_finite())?;
    Some(AlarmWhen::Compare(op, v))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn priorities_read_as_levels_or_severities_and_show_their_band() {
        assert_eq!(Priority::parse("high").map(Priority::severity), Some(750));
        assert_eq!(
            Priority::parse("Urgent").map(Priority::severity),
            Some(1000)
        );
        assert_eq!(Priority::parse("900").map(Priority::level), Some("urgent"));
        assert_eq!(Priority::parse("251").map(Priority::level), Some("medium"));
        assert_eq!(Priority::parse("1").map(Priority::level), Some("low"));
        assert_eq!(Priority::parse("0"), None);
        assert_eq!(Priority::parse("1001"), None);
        assert_eq!(Priority::parse("severe"), None);
    }

    #[test]
    fn conditions() {
        let c = parse_compare("> 95").unwrap();
        assert!(c.holds(Value::F32(95.5)));
        assert!(!c.holds(Value::F32(95.0)));
        assert!(parse_compare(">= 3").unwrap().holds(Value::U16(3)));
        assert!(parse_compare("!= 0").unwrap().holds(Value::I32(-1)));
        assert_eq!(parse_compare("> x"), None);
        assert_eq!(parse_compare("95"), None);
        assert!(AlarmWhen::Is(false).holds(Value::Bool(false)));
    }

    #[test]
    fn bad_alarms_are_refused_at_their_key() {
        let text = "project: t\nscan: { period: 10ms }\nalarms: { history: 5 }\n\
                    tags:\n\
                    \x20 - { name: a, type: bool, alarm: { text: A, priority: severe } }\n\
                    \x20 - { name: n, type: u16, alarm: { text: N } }\n\
                    \x20 - { name: m, type: u16, alarm: { text: M, when: about 3 } }\n\
                    \x20 - { name: b, type: bool, alarm: { text: '', when: maybe } }\n\
                    program: { file: conveyor.expr, kind: expr }\n";
        let file = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR"))
            .join("tests/fixtures/projects/inline.yaml");
        let errors = super::super::parse_str(text, &file)
            .unwrap_err()
            .to_string();
        for want in [
            "inline.yaml:3:20: error: alarms.history is 5; it must be between 10 and 100000",
            "inline.yaml:5:56: error: alarm of tag a: priority \"severe\" is not low, medium",
            "inline.yaml:6:34: error",
            "alarm of u16 tag n: say when it is active, like when: \"> 95\"",
            "inline.yaml:7:51: error: alarm of u16 tag m: when \"about 3\" is not a comparison",
            "alarm of tag b: its text is empty",
        ] {
            assert!(errors.contains(want), "{want}\n{errors}");
        }
    }
}
