//! The `traces:` section: what a trace records, when it triggers and how much it keeps.
//!
//! ```yaml
//! traces:
//!   - name: jam                # how `softplc trace arm jam` names it
//!     tags: [x1, motor, mm1.timeouts, phase.logic]
//!     trigger: x1 rising       # or falling, high, low; or `speed >= 12.5` (> >= < <= == !=)
//!     pre: 100                 # samples kept before the trigger (default 100)
//!     post: 400                # samples taken after it (default 400)
//!     mode: single             # or repeat: re-armed once saved
//!     every: 1                 # one sample every N cycles (default 1)
//! ```
//!
//! A signal is a tag, a module's counter (`MODULE.requests`, `.timeouts`, `.crc_errors`,
//! `.bad_replies`, `.exceptions`, `.round_trip` in µs: what `softplc status` shows per module)
//! or a phase time of the cycle in µs (`phase.read`, `phase.logic`, `phase.write`,
//! `phase.cycle`). The trigger is a signal too: an edge or a level of a bool, a comparison of a
//! number with a literal. Without a trigger the trace records continuously and keeps the last
//! `pre + post` samples.
//!
//! The same rules check a trace armed at run time (`softplc trace arm --tags ...`): both go
//! through [`build`].

use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use softplc_io::point::ValueType;

use super::model::TagConfig;
use super::raw::RawProject;
use super::span::YPath;

/// Most samples one trace keeps (`pre + 1 + post`).
pub(crate) const MAX_SAMPLES: u64 = 100_000;
/// Most values one trace keeps (samples × signals): 8 MB.
pub(crate) const MAX_VALUES: u64 = 1_000_000;
/// Largest `every`.
pub(crate) const MAX_EVERY: u64 = 1_000_000;
/// Default `pre`.
pub(crate) const DEFAULT_PRE: u32 = 100;
/// Default `post`.
pub(crate) const DEFAULT_POST: u32 = 400;

/// The name of a trace armed at run time without one, from the command line (`softplc trace
/// arm --tags ...`) or the web page alike.
pub(crate) const UNNAMED: &str = "adhoc";

/// `name` as given, or [`UNNAMED`] when none (or only blanks) was.
pub(crate) fn name_or_default(name: Option<String>) -> String {
    name.map(|n| n.trim().to_owned())
        .filter(|n| !n.is_empty())
        .unwrap_or_else(|| UNNAMED.to_owned())
}

/// One `traces:` entry as written (also the body of a run-time `trace arm`).
#[derive(Debug, Clone, Default, PartialEq, Eq, Serialize, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a trace: a mapping with name, tags, trigger, pre, post, mode, every and arm"
)]
pub struct RawTrace {
    /// Its name.
    pub name: String,
    /// What it records.
    pub tags: Vec<String>,
    /// When it triggers (`x1 rising`, `speed > 10`); absent: it records continuously.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub trigger: Option<String>,
    /// Samples kept before the trigger.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub pre: Option<i64>,
    /// Samples taken after the trigger.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub post: Option<i64>,
    /// `single` or `repeat`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(schema_with = "super::raw_schema::field::trace_mode")]
    pub mode: Option<String>,
    /// One sample every this many cycles.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub every: Option<i64>,
    /// `start` (the default for a trace of the project): armed when the PLC starts, so a
    /// restart never leaves the event it waits for unwatched; `manual`: armed by `softplc
    /// trace arm NAME` or the web page. A trace armed at run time is armed at once.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    #[schemars(schema_with = "super::raw_schema::field::trace_arm")]
    pub arm: Option<String>,
}

/// A validated trace definition.
#[derive(Debug, Clone, PartialEq)]
pub struct TraceConfig {
    /// Its name.
    pub name: String,
    /// What it records, in the order given.
    pub probes: Vec<Probe>,
    /// When it triggers; `None`: continuously.
    pub trigger: Option<Trigger>,
    /// Samples kept before the trigger.
    pub pre: u32,
    /// Samples taken after the trigger sample.
    pub post: u32,
    /// What happens once it is complete.
    pub mode: TraceMode,
    /// One sample every this many cycles (≥ 1).
    pub every: u32,
    /// Armed when the PLC starts (`arm: start`, a project trace's default).
    pub at_start: bool,
}

impl TraceConfig {
    /// How many samples it holds at most: the trigger sample with `pre` before and `post`
    /// after it, or the last `pre + post` for a continuous trace.
    pub fn depth(&self) -> usize {
        let around = self.pre as usize + self.post as usize;
        if self.trigger.is_some() {
            around + 1
        } else {
            around
        }
    }

    /// The bytes its ring takes once armed: per sample, a value of each signal, the time
    /// and the cycle (what `trace::Capture` allocates).
    pub fn ring_bytes(&self) -> u64 {
        let per_sample = self.probes.len() * std::mem::size_of::<softplc_io::point::Value>()
            + std::mem::size_of::<std::time::Duration>()
            + std::mem::size_of::<u64>();
        (self.depth() * per_sample) as u64
    }
}

/// What one signal of a trace reads.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Probe {
    /// A tag, by its index in the project's tags (its `TagId`).
    Tag(usize),
    /// A module's bus counter, by the module's index.
    Counter {
        /// The module.
        module: usize,
        /// Which counter.
        counter: Counter,
    },
    /// A phase time of the cycle just ended, in µs.
    Phase(Phase),
}

/// A module's bus counters, as `softplc status` shows them.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Counter {
    /// Requests sent.
    Requests,
    /// Requests without a reply in time.
    Timeouts,
    /// Replies with a bad CRC.
    CrcErrors,
    /// Replies that were not the answer.
    BadReplies,
    /// Exception replies.
    Exceptions,
    /// The last good round trip, µs.
    RoundTrip,
}

impl Counter {
    /// Every counter, by its name in a trace.
    pub const ALL: [(&'static str, Counter); 6] = [
        ("requests", Counter::Requests),
        ("timeouts", Counter::Timeouts),
        ("crc_errors", Counter::CrcErrors),
        ("bad_replies", Counter::BadReplies),
        ("exceptions", Counter::Exceptions),
        ("round_trip", Counter::RoundTrip),
    ];

    fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, c)| *c == self)
            .map_or("", |(n, _)| n)
    }
}

/// The phases of a cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Reading the inputs.
    Read,
    /// Running the program.
    Logic,
    /// Writing the outputs.
    Write,
    /// The whole cycle.
    Cycle,
}

impl Phase {
    /// Every phase, by its name after `phase.`.
    pub const ALL: [(&'static str, Phase); 4] = [
        ("read", Phase::Read),
        ("logic", Phase::Logic),
        ("write", Phase::Write),
        ("cycle", Phase::Cycle),
    ];

    fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(_, p)| *p == self)
            .map_or("", |(n, _)| n)
    }
}

/// When a trace triggers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trigger {
    /// The signal watched (every cycle, whatever `every` is).
    pub probe: Probe,
    /// What it must do.
    pub condition: Condition,
}

/// A trigger's condition.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Condition {
    /// A bool goes from false to true between two cycles.
    Rising,
    /// A bool goes from true to false.
    Falling,
    /// A bool is true.
    High,
    /// A bool is false.
    Low,
    /// A number compares so with a literal.
    Compare(CompareOp, f64),
}

/// A comparison.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CompareOp {
    /// `>`
    Gt,
    /// `>=`
    Ge,
    /// `<`
    Lt,
    /// `<=`
    Le,
    /// `==`
    Eq,
    /// `!=`
    Ne,
}

impl CompareOp {
    /// Longest first, so `>=` is not read as `>`.
    pub(crate) const ALL: [(&'static str, CompareOp); 6] = [
        (">=", CompareOp::Ge),
        ("<=", CompareOp::Le),
        ("==", CompareOp::Eq),
        ("!=", CompareOp::Ne),
        (">", CompareOp::Gt),
        ("<", CompareOp::Lt),
    ];

    /// Whether `a OP b` holds.
    pub fn holds(self, a: f64, b: f64) -> bool {
        match self {
            CompareOp::Gt => a > b,
            CompareOp::Ge => a >= b,
            CompareOp::Lt => a < b,
            CompareOp::Le => a <= b,
            CompareOp::Eq => a == b,
            CompareOp::Ne => a != b,
        }
    }
}

/// What a trace does once complete.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TraceMode {
    /// Keeps its samples until armed again.
    #[default]
    Single,
    /// Arms itself again once its samples have been saved (or read).
    Repeat,
}

/// The names a trace can use: the project's tags (with their types, when valid) and modules.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SignalNames<'a> {
    /// Tag names and types, in project order (a tag whose type is invalid has `None`).
    pub tags: &'a [(&'a str, Option<ValueType>)],
    /// Module names, in project order.
    pub modules: &'a [&'a str],
}

impl SignalNames<'_> {
    /// The signal called `name`.
    pub(crate) fn resolve(&self, name: &str) -> Result<Probe, TraceError> {
        if let Some(i) = self.tags.iter().position(|(t, _)| *t == name) {
            return Ok(Probe::Tag(i));
        }
        if let Some((head, tail)) = name.split_once('.') {
            if head == "phase" {
                return Phase::ALL
                    .iter()
                    .find(|(n, _)| *n == tail)
                    .map(|(_, p)| Probe::Phase(*p))
                    .ok_or_else(|| TraceError::UnknownPhase {
                        name: name.to_owned(),
                    });
            }
            if let Some(module) = self.modules.iter().position(|m| *m == head) {
                return Counter::ALL
                    .iter()
                    .find(|(n, _)| *n == tail)
                    .map(|(_, counter)| Probe::Counter {
                        module,
                        counter: *counter,
                    })
                    .ok_or_else(|| TraceError::UnknownCounter {
                        name: name.to_owned(),
                        hint: super::web::closest(tail, Counter::ALL.iter().map(|(n, _)| *n))
                            .map(|c| format!("{head}.{c}")),
                    });
            }
        }
        let all = self.all_names();
        Err(TraceError::UnknownSignal {
            name: name.to_owned(),
            hint: super::web::closest(name, all.iter().map(String::as_str)),
        })
    }

    /// Every signal name, for hints.
    fn all_names(&self) -> Vec<String> {
        let mut all: Vec<String> = self.tags.iter().map(|(t, _)| (*t).to_owned()).collect();
        for m in self.modules {
            all.extend(Counter::ALL.iter().map(|(c, _)| format!("{m}.{c}")));
        }
        all.extend(Phase::ALL.iter().map(|(p, _)| format!("phase.{p}")));
        all
    }

    /// A signal's name.
    pub(crate) fn name(&self, probe: Probe) -> String {
        match probe {
            Probe::Tag(i) => self.tags.get(i).map_or("?", |(t, _)| *t).to_owned(),
            Probe::Counter { module, counter } => format!(
                "{}.{}",
                self.modules.get(module).copied().unwrap_or("?"),
                counter.name()
            ),
            Probe::Phase(p) => format!("phase.{}", p.name()),
        }
    }

    /// The type of a signal's values: a tag's own, `i32` for counters and phase times.
    pub(crate) fn value_type(&self, probe: Probe) -> Option<ValueType> {
        match probe {
            Probe::Tag(i) => self.tags.get(i).and_then(|(_, t)| *t),
            Probe::Counter { .. } | Probe::Phase(_) => Some(ValueType::I32),
        }
    }
}

/// The unit of a signal's values, when it has one.
pub(crate) fn unit(probe: Probe) -> Option<&'static str> {
    match probe {
        Probe::Tag(_) => None,
        Probe::Counter {
            counter: Counter::RoundTrip,
            ..
        }
        | Probe::Phase(_) => Some("us"),
        Probe::Counter { .. } => None,
    }
}

/// Which part of a trace an error is about.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Field {
    /// `name`.
    Name,
    /// `tags`.
    Tags,
    /// `tags[k]`.
    Tag(usize),
    /// `trigger`.
    Trigger,
    /// `pre`.
    Pre,
    /// `post`.
    Post,
    /// `mode`.
    Mode,
    /// `every`.
    Every,
    /// `arm`.
    Arm,
}

/// What is wrong with a trace.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TraceError {
    /// A name that is no tag, counter or phase.
    #[error(
        "trace signal {name:?} is no tag, module counter or phase time{}",
        hint_text(hint)
    )]
    UnknownSignal {
        /// The name.
        name: String,
        /// The closest signal name.
        hint: Option<String>,
    },
    /// `MODULE.something` that is no counter.
    #[error(
        "{name:?} is no module counter{}; the counters are requests, timeouts, crc_errors, \
         bad_replies, exceptions, round_trip",
        hint_text(hint)
    )]
    UnknownCounter {
        /// The name.
        name: String,
        /// The closest counter.
        hint: Option<String>,
    },
    /// `phase.something` that is no phase.
    #[error("{name:?} is no phase time; the phases are phase.read, phase.logic, phase.write, phase.cycle")]
    UnknownPhase {
        /// The name.
        name: String,
    },
    /// One signal listed twice.
    #[error("signal {name} is listed twice in this trace")]
    SignalTwice {
        /// The signal.
        name: String,
    },
    /// No signal at all.
    #[error("a trace records at least one signal: list tags, counters or phase times")]
    NoSignals,
    /// An empty name.
    #[error("a trace needs a name")]
    EmptyName,
    /// Two traces with one name.
    #[error("trace {name} is already defined")]
    DuplicateTrace {
        /// The name.
        name: String,
    },
    /// A trigger that does not read.
    #[error(
        "trigger {text:?}: expected `SIGNAL rising|falling|high|low` or `SIGNAL OP NUMBER` \
         with OP one of > >= < <= == !="
    )]
    TriggerSyntax {
        /// The trigger as written.
        text: String,
    },
    /// A comparison with something that is no number.
    #[error("trigger {text:?}: {literal:?} is not a number")]
    TriggerLiteral {
        /// The trigger as written.
        text: String,
        /// The literal.
        literal: String,
    },
    /// An edge or level on a number.
    #[error(
        "trigger {text:?}: {signal} is {ty}, and an edge or level needs a bool; compare it \
         instead (`{signal} > 0`)"
    )]
    EdgeOnNumber {
        /// The trigger as written.
        text: String,
        /// The signal.
        signal: String,
        /// Its type.
        ty: ValueType,
    },
    /// A comparison on a bool.
    #[error(
        "trigger {text:?}: {signal} is a bool; use `{signal} rising`, `falling`, `high` or `low`"
    )]
    CompareOnBool {
        /// The trigger as written.
        text: String,
        /// The signal.
        signal: String,
    },
    /// A negative or oversized count.
    #[error("{key} is {value}; it must be between 0 and {max}")]
    Count {
        /// `pre` or `post`.
        key: &'static str,
        /// As written.
        value: i64,
        /// The largest.
        max: u64,
    },
    /// Too many samples.
    #[error("pre + 1 + post is {samples} samples; a trace keeps at most {MAX_SAMPLES}")]
    TooManySamples {
        /// Asked for.
        samples: u64,
    },
    /// Too many values.
    #[error(
        "{samples} samples of {signals} signals are {} values; a trace keeps at most \
         {MAX_VALUES}: record fewer signals or fewer samples",
        samples * signals
    )]
    TooManyValues {
        /// Samples.
        samples: u64,
        /// Signals.
        signals: u64,
    },
    /// A continuous trace that keeps nothing.
    #[error("a trace without a trigger keeps the last pre + post samples; give pre or post")]
    NothingKept,
    /// `every` out of range.
    #[error("every is {value}; it must be between 1 and {MAX_EVERY} cycles")]
    Every {
        /// As written.
        value: i64,
    },
    /// An unknown `arm`.
    #[error("arm {arm:?}: a trace is armed at start or manual")]
    UnknownArm {
        /// As written.
        arm: String,
    },
    /// An unknown mode.
    #[error("mode {mode:?}: a trace's mode is single or repeat")]
    UnknownMode {
        /// As written.
        mode: String,
    },
    /// `repeat` without a trigger.
    #[error(
        "mode repeat re-arms a trace after its trigger; a trace without one records continuously"
    )]
    RepeatWithoutTrigger,
}

fn hint_text(hint: &Option<String>) -> String {
    hint.as_ref()
        .map(|h| format!("; did you mean {h}?"))
        .unwrap_or_default()
}

/// Validates one trace against the project's `names`; every error found, with its field.
pub(crate) fn build(
    raw: &RawTrace,
    names: &SignalNames<'_>,
) -> Result<TraceConfig, Vec<(Field, TraceError)>> {
    let mut errors = Vec::new();
    if raw.name.trim().is_empty() {
        errors.push((Field::Name, TraceError::EmptyName));
    }
    if raw.tags.is_empty() {
        errors.push((Field::Tags, TraceError::NoSignals));
    }
    let mut probes = Vec::with_capacity(raw.tags.len());
    for (k, name) in raw.tags.iter().enumerate() {
        match names.resolve(name) {
            Ok(p) if probes.contains(&p) => errors.push((
                Field::Tag(k),
                TraceError::SignalTwice { name: name.clone() },
            )),
            Ok(p) => probes.push(p),
            Err(e) => errors.push((Field::Tag(k), e)),
        }
    }
    let trigger = match raw.trigger.as_deref() {
        None => None,
        Some(text) => match parse_trigger(text, names) {
            Ok(t) => Some(t),
            Err(e) => {
                errors.push((Field::Trigger, e));
                None
            }
        },
    };
    let count = |key: &'static str,
                 field: Field,
                 v: Option<i64>,
                 default: u32,
                 errors: &mut Vec<_>| {
        match v {
            None => default,
            Some(n) if (0..=MAX_SAMPLES as i64).contains(&n) => n as u32,
            Some(n) => {
                errors.push((
                    field,
                    TraceError::Count {
                        key,
                        value: n,
                        max: MAX_SAMPLES,
                    },
                ));
                default
            }
        }
    };
    let pre = count("pre", Field::Pre, raw.pre, DEFAULT_PRE, &mut errors);
    let post = count("post", Field::Post, raw.post, DEFAULT_POST, &mut errors);
    let mode = match raw.mode.as_deref() {
        None | Some("single") => TraceMode::Single,
        Some("repeat") => TraceMode::Repeat,
        Some(m) => {
            errors.push((Field::Mode, TraceError::UnknownMode { mode: m.to_owned() }));
            TraceMode::Single
        }
    };
    if mode == TraceMode::Repeat && raw.trigger.is_none() {
        errors.push((Field::Mode, TraceError::RepeatWithoutTrigger));
    }
    let every = match raw.every {
        None => 1,
        Some(n) if (1..=MAX_EVERY as i64).contains(&n) => n as u32,
        Some(n) => {
            errors.push((Field::Every, TraceError::Every { value: n }));
            1
        }
    };
    let at_start = match raw.arm.as_deref() {
        None | Some("start") => true,
        Some("manual") => false,
        Some(a) => {
            errors.push((Field::Arm, TraceError::UnknownArm { arm: a.to_owned() }));
            false
        }
    };
    let config = TraceConfig {
        name: raw.name.clone(),
        probes,
        trigger,
        pre,
        post,
        mode,
        every,
        at_start,
    };
    let samples = config.depth() as u64;
    if raw.trigger.is_none() && samples == 0 {
        errors.push((Field::Pre, TraceError::NothingKept));
    } else if samples > MAX_SAMPLES {
        errors.push((Field::Post, TraceError::TooManySamples { samples }));
    } else if samples * raw.tags.len() as u64 > MAX_VALUES {
        errors.push((
            Field::Tags,
            TraceError::TooManyValues {
                samples,
                signals: raw.tags.len() as u64,
            },
        ));
    }
    if errors.is_empty() {
        Ok(config)
    } else {
        Err(errors)
    }
}

/// Validates every `traces:` entry of `raw` against its tags (as validated: a tag whose entry
/// is wrong keeps its name but has no type) and modules; errors go to `error` with their path.
pub(crate) fn validate_all(
    raw: &RawProject,
    tags: &[Option<TagConfig>],
    mut error: impl FnMut(YPath, TraceError),
) -> Vec<TraceConfig> {
    // The project's own tags by their written names (a refused one too), then the tags of
    // the instances of blocks of one's own (`s1.done`).
    let tag_names: Vec<(&str, Option<ValueType>)> = raw
        .tags
        .iter()
        .zip(tags)
        .map(|(r, t)| (r.name.as_str(), t.as_ref().map(|t| t.ty)))
        .chain(
            tags.iter()
                .skip(raw.tags.len())
                .flatten()
                .map(|t| (t.name.as_str(), Some(t.ty))),
        )
        .collect();
    let modules: Vec<&str> = raw.modules.iter().map(|m| m.name.as_str()).collect();
    let names = SignalNames {
        tags: &tag_names,
        modules: &modules,
    };
    let mut out: Vec<TraceConfig> = Vec::with_capacity(raw.traces.len());
    for (i, t) in raw.traces.iter().enumerate() {
        let at = YPath::root().key("traces").index(i);
        if raw.traces[..i].iter().any(|o| o.name == t.name) {
            error(
                at.key("name"),
                TraceError::DuplicateTrace {
                    name: t.name.clone(),
                },
            );
        }
        match build(t, &names) {
            Ok(c) => out.push(c),
            Err(errors) => {
                for (field, e) in errors {
                    error(field.path(&at), e);
                }
            }
        }
    }
    out
}

impl Field {
    fn path(self, entry: &YPath) -> YPath {
        match self {
            Field::Name => entry.key("name"),
            Field::Tags => entry.key("tags"),
            Field::Tag(k) => entry.key("tags").index(k),
            Field::Trigger => entry.key("trigger"),
            Field::Pre => entry.key("pre"),
            Field::Post => entry.key("post"),
            Field::Mode => entry.key("mode"),
            Field::Arm => entry.key("arm"),
            Field::Every => entry.key("every"),
        }
    }
}

/// Reads `SIGNAL rising|falling|high|low` or `SIGNAL OP NUMBER` and checks it against the
/// signal's type.
pub(crate) fn parse_trigger(text: &str, names: &SignalNames<'_>) -> Result<Trigger, TraceError> {
    let syntax = || TraceError::TriggerSyntax {
        text: text.to_owned(),
    };
    let t = text.trim();
    let op_at = t.find(['<', '>', '=', '!']);
    let (signal, condition) = match op_at {
        Some(at) => {
            let (signal, rest) = t.split_at(at);
            let (op, literal) = CompareOp::ALL
                .iter()
                .find_map(|(s, op)| rest.strip_prefix(s).map(|lit| (*op, lit.trim())))
                .ok_or_else(syntax)?;
            let value: f64 = literal
                .parse()
                .ok()
                .filter(|v: &f64| v.is_finite())
                .ok_or_else(|| TraceError::TriggerLiteral {
                    text: text.to_owned(),
                    literal: literal.to_owned(),
                })?;
            (signal.trim(), Condition::Compare(op, value))
        }
        None => {
            let mut words = t.split_whitespace();
            let (Some(signal), Some(word), None) = (words.next(), words.next(), words.next())
            else {
                return Err(syntax());
            };
            let condition = match word {
                "rising" => Condition::Rising,
                "falling" => Condition::Falling,
                "high" => Condition::High,
                "low" => Condition::Low,
                _ => return Err(syntax()),
            };
            (signal, condition)
        }
    };
    if signal.is_empty() || signal.contains(char::is_whitespace) {
        return Err(syntax());
    }
    let probe = names.resolve(signal)?;
    match (names.value_type(probe), condition) {
        (Some(ValueType::Bool), Condition::Compare(..)) => Err(TraceError::CompareOnBool {
            text: text.to_owned(),
            signal: signal.to_owned(),
        }),
        (Some(ty), Condition::Rising | Condition::Falling | Condition::High | Condition::Low)
            if ty != ValueType::Bool =>
        {
            Err(TraceError::EdgeOnNumber {
                text: text.to_owned(),
                signal: signal.to_owned(),
                ty,
            })
        }
        _ => Ok(Trigger { probe, condition }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const TAGS: [(&str, Option<ValueType>); 3] = [
        ("x1", Some(ValueType::Bool)),
        ("speed", Some(ValueType::F32)),
        ("parts", Some(ValueType::U16)),
    ];
    const MODULES: [&str; 1] = ["mm1"];

    fn names() -> SignalNames<'static> {
        SignalNames {
            tags: &TAGS,
            modules: &MODULES,
        }
    }

    fn raw(tags: &[&str], trigger: Option<&str>) -> RawTrace {
        RawTrace {
            name: "t".into(),
            tags: tags.iter().map(|t| t.to_string()).collect(),
            trigger: trigger.map(str::to_owned),
            ..RawTrace::default()
        }
    }

    #[test]
    fn triggers_read_as_written() {
        let n = names();
        let t = |s| parse_trigger(s, &n);
        assert_eq!(
            t("x1 rising"),
            Ok(Trigger {
                probe: Probe::Tag(0),
                condition: Condition::Rising
            })
        );
        assert_eq!(t(" x1  low ").unwrap().condition, Condition::Low);
        assert_eq!(
            t("speed>=12.5").unwrap().condition,
            Condition::Compare(CompareOp::Ge, 12.5)
        );
        assert_eq!(
            t("parts != 3").unwrap().condition,
            Condition::Compare(CompareOp::Ne, 3.0)
        );
        assert_eq!(
            t("phase.logic > 500").unwrap().probe,
            Probe::Phase(Phase::Logic)
        );
        assert_eq!(
            t("mm1.timeouts > 0").unwrap().probe,
            Probe::Counter {
                module: 0,
                counter: Counter::Timeouts
            }
        );
    }

    #[test]
    fn triggers_that_cannot_work_say_why() {
        let n = names();
        let t = |s| parse_trigger(s, &n).unwrap_err().to_string();
        assert!(
            t("x1 up").contains("expected `SIGNAL rising"),
            "{}",
            t("x1 up")
        );
        assert!(t("x1").contains("expected"));
        assert!(t("speed > fast").contains("\"fast\" is not a number"));
        assert!(t("speed => 1").contains("expected"));
        assert_eq!(
            t("speed rising"),
            "trigger \"speed rising\": speed is f32, and an edge or level needs a bool; \
             compare it instead (`speed > 0`)"
        );
        assert_eq!(
            t("x1 == 1"),
            "trigger \"x1 == 1\": x1 is a bool; use `x1 rising`, `falling`, `high` or `low`"
        );
        assert_eq!(
            t("x2 rising"),
            "trace signal \"x2\" is no tag, module counter or phase time; did you mean x1?"
        );
    }

    #[test]
    fn signals_resolve_with_hints() {
        let n = names();
        assert_eq!(
            n.resolve("mm1.timeout").unwrap_err().to_string(),
            "\"mm1.timeout\" is no module counter; did you mean mm1.timeouts?; the counters are \
             requests, timeouts, crc_errors, bad_replies, exceptions, round_trip"
        );
        assert!(matches!(
            n.resolve("phase.scan"),
            Err(TraceError::UnknownPhase { .. })
        ));
        assert_eq!(
            n.resolve("phase.logik").unwrap_err(),
            TraceError::UnknownPhase {
                name: "phase.logik".into()
            }
        );
        assert_eq!(
            n.name(n.resolve("mm1.round_trip").unwrap()),
            "mm1.round_trip"
        );
    }

    #[test]
    fn bounds_and_modes_are_checked() {
        let n = names();
        let mut r = raw(&["x1", "x1"], None);
        r.mode = Some("repeat".into());
        r.pre = Some(-1);
        r.every = Some(0);
        let errors = build(&r, &n).unwrap_err();
        let fields: Vec<Field> = errors.iter().map(|(f, _)| *f).collect();
        assert_eq!(
            fields,
            [Field::Tag(1), Field::Pre, Field::Mode, Field::Every],
            "{errors:?}"
        );

        let mut r = raw(&["x1"], Some("x1 rising"));
        r.pre = Some(60_000);
        r.post = Some(60_000);
        assert_eq!(
            build(&r, &n).unwrap_err(),
            [(Field::Post, TraceError::TooManySamples { samples: 120_001 })]
        );

        let mut r = raw(&["x1"], None);
        r.pre = Some(0);
        r.post = Some(0);
        assert_eq!(
            build(&r, &n).unwrap_err(),
            [(Field::Pre, TraceError::NothingKept)]
        );

        let ok = build(&raw(&["x1", "phase.cycle"], Some("x1 falling")), &n).unwrap();
        assert_eq!(ok.depth(), 501);
        assert_eq!(ok.every, 1);
    }
}
