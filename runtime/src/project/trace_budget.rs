//! The `trace_budget:` section: how many traces may be armed at once and how much memory
//! their samples may take in all.
//!
//! ```yaml
//! trace_budget:
//!   armed: 16        # traces armed at once (default 16, 1..=256)
//!   memory: 64MiB    # samples of every armed trace together (default 64MiB, 1MiB..=4GiB)
//! ```
//!
//! Why a budget: a trace allocates its whole ring when it is armed, and anyone with the
//! control socket or the web page's token can arm one. Without a bound, a few hundred large
//! traces take gigabytes and the kernel kills the PLC. An arm past the budget is refused with
//! what is left; the project's own `arm: start` traces must fit it (checked with the file).

use schemars::JsonSchema;
use serde::Deserialize;

use super::error::ErrorKind;
use super::raw::Int;
use super::recorder::parse_size;
use super::span::YPath;
use super::trace::TraceConfig;

/// Default number of traces armed at once.
pub(crate) const DEFAULT_ARMED: usize = 16;
/// Largest `armed`.
pub(crate) const MAX_ARMED: usize = 256;
/// Default memory for the samples of every armed trace.
pub(crate) const DEFAULT_MEMORY: u64 = 64 << 20;
/// Smallest `memory`.
pub(crate) const MIN_MEMORY: u64 = 1 << 20;
/// Largest `memory`.
pub(crate) const MAX_MEMORY: u64 = 4 << 30;

/// `trace_budget:` as written.
#[derive(Debug, Clone, Default, PartialEq, Deserialize, JsonSchema)]
#[serde(
    deny_unknown_fields,
    expecting = "a trace budget: a mapping with armed and memory"
)]
pub(crate) struct RawTraceBudget {
    /// Traces armed at once.
    #[serde(default)]
    pub armed: Option<Int>,
    /// Memory of every armed trace's samples together (`64MiB`).
    #[serde(default)]
    pub memory: Option<String>,
}

/// The bound on armed traces.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct TraceBudget {
    /// Traces armed at once.
    pub armed: usize,
    /// Bytes the samples of every armed trace may take together.
    pub memory: u64,
}

impl Default for TraceBudget {
    fn default() -> Self {
        Self {
            armed: DEFAULT_ARMED,
            memory: DEFAULT_MEMORY,
        }
    }
}

/// A byte count as a person reads it: `64 MiB`, `3.5 MiB`, `512 KiB`, `100 B`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Bytes(pub u64);

impl std::fmt::Display for Bytes {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let b = self.0;
        let (unit, scale) = if b >= 1 << 30 {
            ("GiB", 1u64 << 30)
        } else if b >= 1 << 20 {
            ("MiB", 1 << 20)
        } else if b >= 1 << 10 {
            ("KiB", 1 << 10)
        } else {
            return write!(f, "{b} B");
        };
        // One decimal, rounded down, so what is said to be left is never more than is.
        let tenths = b * 10 / scale;
        if tenths % 10 == 0 {
            write!(f, "{} {unit}", tenths / 10)
        } else {
            write!(f, "{}.{} {unit}", tenths / 10, tenths % 10)
        }
    }
}

/// What is wrong with a `trace_budget:` section.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TraceBudgetError {
    /// `armed` out of range.
    #[error("trace_budget.armed is {value}; it must be between 1 and {MAX_ARMED}")]
    Armed {
        /// As written.
        value: i64,
    },
    /// `memory` does not read as a size.
    #[error(
        "trace_budget.memory {text:?} is not a size: write it with a unit, like 64MiB or 1GiB"
    )]
    BadMemory {
        /// As written.
        text: String,
    },
    /// `memory` out of range.
    #[error("trace_budget.memory is {}; it must be between 1 MiB and 4 GiB", Bytes(*bytes))]
    MemoryRange {
        /// As given.
        bytes: u64,
    },
    /// The traces armed at start do not fit the budget.
    #[error(
        "trace {name} is armed at start and needs {} of samples; the traces armed at start \
         before it leave {} of the {} trace_budget.memory: make it smaller, `arm: manual`, or \
         raise the budget",
        Bytes(*needs), Bytes(*left), Bytes(*memory)
    )]
    StartOverMemory {
        /// The trace.
        name: String,
        /// Bytes it needs.
        needs: u64,
        /// Bytes left by the ones before it.
        left: u64,
        /// The budget.
        memory: u64,
    },
    /// More traces armed at start than the budget allows.
    #[error(
        "trace {name} is armed at start, past the {armed} traces trace_budget.armed allows: \
         make it `arm: manual`, or raise the budget"
    )]
    StartOverCount {
        /// The trace.
        name: String,
        /// The budget.
        armed: usize,
    },
}

/// The trace budget of a project, with the errors found (and where).
pub(crate) fn validate(raw: Option<&RawTraceBudget>) -> (TraceBudget, Vec<(YPath, ErrorKind)>) {
    let mut budget = TraceBudget::default();
    let mut errors = Vec::new();
    let Some(raw) = raw else {
        return (budget, errors);
    };
    let path = YPath::root().key("trace_budget");
    if let Some(Int(n)) = raw.armed {
        match usize::try_from(n) {
            Ok(n) if (1..=MAX_ARMED).contains(&n) => budget.armed = n,
            _ => errors.push((
                path.key("armed"),
                TraceBudgetError::Armed { value: n }.into(),
            )),
        }
    }
    if let Some(text) = raw.memory.as_deref() {
        match parse_size(text) {
            None => errors.push((
                path.key("memory"),
                TraceBudgetError::BadMemory { text: text.into() }.into(),
            )),
            Some(bytes) if !(MIN_MEMORY..=MAX_MEMORY).contains(&bytes) => errors.push((
                path.key("memory"),
                TraceBudgetError::MemoryRange { bytes }.into(),
            )),
            Some(bytes) => budget.memory = bytes,
        }
    }
    (budget, errors)
}

/// Checks that the traces armed at start fit `budget`, in file order; an error names the
/// first one past it (at its entry in `raw_names`, the `traces:` names as written).
pub(crate) fn check_start_traces(
    budget: TraceBudget,
    traces: &[TraceConfig],
    raw_names: &[&str],
) -> Vec<(YPath, ErrorKind)> {
    let mut errors = Vec::new();
    let mut armed = 0;
    let mut used = 0u64;
    for t in traces.iter().filter(|t| t.at_start) {
        let at = raw_names.iter().position(|n| *n == t.name).map_or_else(
            || YPath::root().key("traces"),
            |i| YPath::root().key("traces").index(i).key("name"),
        );
        let needs = t.ring_bytes();
        if armed == budget.armed {
            errors.push((
                at,
                TraceBudgetError::StartOverCount {
                    name: t.name.clone(),
                    armed: budget.armed,
                }
                .into(),
            ));
        } else if needs > budget.memory - used {
            errors.push((
                at,
                TraceBudgetError::StartOverMemory {
                    name: t.name.clone(),
                    needs,
                    left: budget.memory - used,
                    memory: budget.memory,
                }
                .into(),
            ));
        } else {
            armed += 1;
            used += needs;
        }
    }
    errors
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_read_as_a_person_says_them_rounded_down() {
        let said = [
            0,
            100,
            2048,
            64 << 20,
            (7 << 20) / 2,
            (1 << 20) - 1,
            5 << 30,
        ]
        .map(|b| Bytes(b).to_string());
        assert_eq!(
            said,
            [
                "0 B",
                "100 B",
                "2 KiB",
                "64 MiB",
                "3.5 MiB",
                "1023.9 KiB",
                "5 GiB"
            ]
        );
    }

    fn trace(name: &str, around: u32, at_start: bool) -> TraceConfig {
        TraceConfig {
            name: name.into(),
            probes: vec![super::super::trace::Probe::Tag(0)],
            trigger: None,
            pre: around,
            post: around,
            mode: super::super::trace::TraceMode::Single,
            every: 1,
            at_start,
        }
    }

    #[test]
    fn start_traces_past_the_budget_are_named_at_their_entry() {
        let budget = TraceBudget {
            armed: 2,
            memory: 1 << 20,
        };
        // 20,000 samples of one signal: 640,000 bytes each.
        let traces = [
            trace("a", 10_000, true),
            trace("manual", 10_000, false),
            trace("b", 10_000, true),
            trace("c", 1, true),
            trace("d", 1, true),
        ];
        let names = ["a", "manual", "b", "c", "d"];
        let errors = check_start_traces(budget, &traces, &names);
        let at = |i| YPath::root().key("traces").index(i).key("name");
        let said: Vec<(YPath, String)> = errors
            .iter()
            .map(|(p, e)| (p.clone(), e.to_string()))
            .collect();
        assert_eq!(
            said,
            [
                (
                    at(2),
                    "trace b is armed at start and needs 625 KiB of samples; the traces armed \
                     at start before it leave 399 KiB of the 1 MiB trace_budget.memory: make it \
                     smaller, `arm: manual`, or raise the budget"
                        .to_owned()
                ),
                (
                    at(4),
                    "trace d is armed at start, past the 2 traces trace_budget.armed allows: \
                     make it `arm: manual`, or raise the budget"
                        .to_owned()
                ),
            ]
        );
    }

    #[test]
    fn defaults_without_the_section_and_each_key_checked() {
        assert_eq!(validate(None), (TraceBudget::default(), Vec::new()));
        let raw = RawTraceBudget {
            armed: Some(Int(4)),
            memory: Some("8MiB".into()),
        };
        let (budget, errors) = validate(Some(&raw));
        assert!(errors.is_empty());
        assert_eq!(
            budget,
            TraceBudget {
                armed: 4,
                memory: 8 << 20
            }
        );
        for (raw, said) in [
            (
                RawTraceBudget {
                    armed: Some(Int(0)),
                    memory: None,
                },
                "trace_budget.armed is 0; it must be between 1 and 256",
            ),
            (
                RawTraceBudget {
                    armed: None,
                    memory: Some("lots".into()),
                },
                "trace_budget.memory \"lots\" is not a size: write it with a unit, like 64MiB \
                 or 1GiB",
            ),
            (
                RawTraceBudget {
                    armed: None,
                    memory: Some("8GiB".into()),
                },
                "trace_budget.memory is 8 GiB; it must be between 1 MiB and 4 GiB",
            ),
        ] {
            let (_, errors) = validate(Some(&raw));
            let text: Vec<String> = errors.iter().map(|(_, e)| e.to_string()).collect();
            assert_eq!(text, [said]);
        }
    }
}
