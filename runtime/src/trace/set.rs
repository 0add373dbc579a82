//! The traces of a running PLC: armed, stepped and read at the cycle boundary, on the scan
//! thread.
//!
//! With no trace armed, [`TraceSet::sample`] is one branch on an empty list: no allocation,
//! nothing read. Arming allocates the trace's whole ring; sampling and re-arming never do.

use softplc_io::point::{Value, ValueType};

use super::capture::{Capture, Moment, TraceState};
use super::data::TraceData;
use super::export::Signal;
use super::ledger::TraceLedger;
use crate::image::TagId;
use crate::plc::Plc;
use crate::project::trace::{
    self, Counter, Phase, Probe, RawTrace, SignalNames, TraceConfig, TraceError,
};
use crate::project::{Bytes, Project};
use crate::scan::ScanStats;

/// Why a trace request was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TraceRefusal {
    /// No trace of that name is defined or armed.
    #[error("no trace {name}{}", known(defined))]
    Unknown {
        /// The name asked for.
        name: String,
        /// The traces there are.
        defined: Vec<String>,
    },
    /// A trace of the project that is not armed (`arm: manual`, or disarmed).
    #[error("trace {name} is not armed: arm it with `softplc trace arm {name}`")]
    NotArmed {
        /// Its name.
        name: String,
    },
    /// A run-time trace named like one of the project's.
    #[error(
        "trace {name} is defined in the project: arm it by name, or give yours another --name"
    )]
    NameTaken {
        /// The name.
        name: String,
    },
    /// A run-time trace that does not pass the project's rules.
    #[error("{}", .0.iter().map(|e| e.to_string()).collect::<Vec<_>>().join("; "))]
    Invalid(Vec<TraceError>),
    /// A trace of that name is armed in another task (a trace's name is the PLC's).
    #[error(
        "trace {name} is armed in task {task}: disarm it first (`softplc trace disarm {name}`), \
         or arm it in task {task}"
    )]
    ArmedElsewhere {
        /// The trace.
        name: String,
        /// The task it is armed in.
        task: String,
    },
    /// Neither a name nor a definition.
    #[error("arm a trace by name, or give its tags (and trigger)")]
    Nothing,
    /// As many traces armed as the project's budget allows.
    #[error(
        "{armed} traces are armed, as many as the project allows (trace_budget.armed); \
         disarm one first"
    )]
    TooMany {
        /// The budget's count.
        armed: usize,
    },
    /// The trace's samples do not fit what is left of the project's memory budget.
    #[error(
        "trace {name} needs {} for its samples; {} of the {} trace budget is left: disarm a \
         trace, record fewer signals or samples, or raise trace_budget.memory",
        Bytes(*needs), Bytes(*left), Bytes(*memory)
    )]
    OverBudget {
        /// The trace.
        name: String,
        /// Bytes its ring takes.
        needs: u64,
        /// Bytes left by the traces armed.
        left: u64,
        /// The budget.
        memory: u64,
    },
}

fn known(defined: &[String]) -> String {
    if defined.is_empty() {
        " (the project defines none; arm one with --tags)".to_owned()
    } else {
        format!(" (traces: {})", defined.join(", "))
    }
}

/// What `trace status` shows of one trace.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct TraceStatus {
    /// Its name.
    pub name: String,
    /// Where it is; `None`: defined in the project, not armed.
    pub state: Option<TraceState>,
    /// Samples held.
    pub samples: usize,
    /// Samples it holds at most.
    pub depth: usize,
    /// Samples before the trigger.
    pub pre: u32,
    /// Samples after it.
    pub post: u32,
    /// The cycle it triggered on.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub triggered_at: Option<u64>,
    /// Its signals.
    pub signals: Vec<String>,
    /// With several tasks: the task whose cycles it samples (absent with one task, and for
    /// a trace of the project not armed).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub task: Option<String>,
}

impl std::fmt::Display for TraceStatus {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let state = self
            .state
            .map_or_else(|| "not armed".to_owned(), |s| s.to_string());
        write!(f, "{}", self.name)?;
        if let Some(t) = &self.task {
            write!(f, " (task {t})")?;
        }
        write!(
            f,
            ": {state}, {}/{} samples (pre {}, post {})",
            self.samples, self.depth, self.pre, self.post
        )?;
        if let Some(c) = self.triggered_at {
            write!(f, ", triggered at cycle {c}")?;
        }
        write!(f, "; {}", self.signals.join(", "))
    }
}

/// The traces of one PLC, or of one task of several.
#[derive(Debug, Default)]
pub struct TraceSet {
    armed: Vec<Armed>,
    /// Every trace armed in the PLC, against its one budget.
    ledger: TraceLedger,
    /// With several tasks: this set's task.
    task: Option<String>,
    /// With several tasks: the project's traces this task arms at start (each is armed in
    /// one task); `None`: every one marked `arm: start`.
    at_start: Option<Vec<String>>,
}

#[derive(Debug)]
struct Armed {
    capture: Capture,
    signals: Vec<Signal>,
}

impl TraceSet {
    /// No trace armed.
    pub fn new() -> Self {
        Self::default()
    }

    /// The traces of task `task`, one of several whose traces are held in `ledger`; of the
    /// project's traces, it arms those named in `at_start` when it starts.
    pub fn of_task(task: String, ledger: TraceLedger, at_start: Vec<String>) -> Self {
        Self {
            armed: Vec::new(),
            ledger,
            task: Some(task),
            at_start: Some(at_start),
        }
    }

    /// At a cycle boundary: steps every armed trace with the cycle just completed.
    pub fn sample(&mut self, plc: &Plc, stats: &ScanStats) {
        if self.armed.is_empty() {
            return;
        }
        let at = Moment {
            time: stats.last.start,
            cycle: stats.cycles,
        };
        for a in &mut self.armed {
            a.capture.step(at, |p| read(p, plc, stats));
        }
    }

    /// Arms the project's trace `name`, or `spec` (a run-time trace); arming a trace already
    /// armed starts it again. Returns what was armed.
    pub fn arm(
        &mut self,
        project: &Project,
        name: Option<&str>,
        spec: Option<&RawTrace>,
    ) -> Result<TraceStatus, TraceRefusal> {
        let config = match (spec, name) {
            (Some(raw), _) => spec_config(project, raw)?,
            (None, Some(name)) => project
                .traces
                .iter()
                .find(|t| t.name == name)
                .cloned()
                .ok_or_else(|| self.unknown(project, name))?,
            (None, None) => return Err(TraceRefusal::Nothing),
        };
        self.ledger.reserve(
            self.task.as_deref(),
            &config.name,
            config.ring_bytes(),
            project.trace_budget,
        )?;
        let signals = signals(project, &config);
        self.armed
            .retain(|a| a.capture.config().name != config.name);
        let armed = Armed {
            capture: Capture::arm(config),
            signals,
        };
        let armed_status = status(&armed, self.task.as_ref());
        self.armed.push(armed);
        Ok(armed_status)
    }

    /// Arms every trace of the project marked `arm: start` (the default), before the first
    /// cycle; the number armed.
    pub fn arm_at_start(&mut self, project: &Project) -> usize {
        let mut n = 0;
        let here = |name: &str| {
            self.at_start
                .as_ref()
                .is_none_or(|names| names.iter().any(|n| n == name))
        };
        let start: Vec<String> = project
            .traces
            .iter()
            .filter(|t| t.at_start && here(&t.name))
            .map(|t| t.name.clone())
            .collect();
        for t in project.traces.iter().filter(|t| start.contains(&t.name)) {
            if self.arm(project, Some(&t.name), None).is_ok() {
                n += 1;
            }
        }
        n
    }

    /// Stops and forgets the armed trace `name`.
    pub fn disarm(&mut self, project: &Project, name: &str) -> Result<(), TraceRefusal> {
        let before = self.armed.len();
        self.armed.retain(|a| a.capture.config().name != name);
        if self.armed.len() == before {
            return Err(self.unknown(project, name));
        }
        self.ledger.release(name);
        Ok(())
    }

    /// The status of `name`, or of every trace (armed, then defined but not armed).
    pub fn status(
        &self,
        project: &Project,
        name: Option<&str>,
    ) -> Result<Vec<TraceStatus>, TraceRefusal> {
        let mut out: Vec<TraceStatus> = self
            .armed
            .iter()
            .map(|a| status(a, self.task.as_ref()))
            .collect();
        for t in &project.traces {
            if !out.iter().any(|s| s.name == t.name) {
                out.push(TraceStatus {
                    name: t.name.clone(),
                    state: None,
                    samples: 0,
                    depth: t.depth(),
                    pre: t.pre,
                    post: t.post,
                    triggered_at: None,
                    signals: signals(project, t).into_iter().map(|s| s.name).collect(),
                    task: None,
                });
            }
        }
        match name {
            None => Ok(out),
            Some(n) => match out.into_iter().find(|s| s.name == n) {
                Some(s) => Ok(vec![s]),
                None => Err(self.unknown(project, n)),
            },
        }
    }

    /// A copy of the samples of `name`. `save`: the user keeps them, so a complete repeating
    /// trace arms itself again (in the buffers it has).
    pub fn read(
        &mut self,
        project: &Project,
        name: &str,
        save: bool,
    ) -> Result<TraceData, TraceRefusal> {
        let Some(a) = self
            .armed
            .iter_mut()
            .find(|a| a.capture.config().name == name)
        else {
            return Err(self.unknown(project, name));
        };
        let mut data = TraceData::of(&project.name, &a.capture, &a.signals);
        data.task = self.task.clone();
        if save && a.capture.repeats() && a.capture.state() == TraceState::Complete {
            a.capture.rearm();
        }
        Ok(data)
    }

    fn unknown(&self, project: &Project, name: &str) -> TraceRefusal {
        if project.traces.iter().any(|t| t.name == name) {
            return TraceRefusal::NotArmed {
                name: name.to_owned(),
            };
        }
        let mut defined: Vec<String> = project.traces.iter().map(|t| t.name.clone()).collect();
        for a in &self.armed {
            if !defined.contains(&a.capture.config().name) {
                defined.push(a.capture.config().name.clone());
            }
        }
        TraceRefusal::Unknown {
            name: name.to_owned(),
            defined,
        }
    }
}

/// A trace given at run time, checked against `project` as the project's are.
pub(crate) fn spec_config(project: &Project, raw: &RawTrace) -> Result<TraceConfig, TraceRefusal> {
    if project.traces.iter().any(|t| t.name == raw.name) {
        return Err(TraceRefusal::NameTaken {
            name: raw.name.clone(),
        });
    }
    let (tags, modules) = names(project);
    let names = SignalNames {
        tags: &tags,
        modules: &modules,
    };
    trace::build(raw, &names)
        .map_err(|errors| TraceRefusal::Invalid(errors.into_iter().map(|(_, e)| e).collect()))
}

fn status(a: &Armed, task: Option<&String>) -> TraceStatus {
    let c = &a.capture;
    TraceStatus {
        name: c.config().name.clone(),
        state: Some(c.state()),
        samples: c.len(),
        depth: c.depth(),
        pre: c.config().pre,
        post: c.config().post,
        triggered_at: c.trigger().map(|(_, cycle)| cycle),
        signals: a.signals.iter().map(|s| s.name.clone()).collect(),
        task: task.cloned(),
    }
}

/// The project's names, as the trace rules take them.
fn names(project: &Project) -> (Vec<(&str, Option<ValueType>)>, Vec<&str>) {
    (
        project
            .tags
            .iter()
            .map(|t| (t.name.as_str(), Some(t.ty)))
            .collect(),
        project.modules.iter().map(|m| m.name.as_str()).collect(),
    )
}

/// The export signals of `config`'s probes.
pub(crate) fn signals(project: &Project, config: &TraceConfig) -> Vec<Signal> {
    let (tags, modules) = names(project);
    let names = SignalNames {
        tags: &tags,
        modules: &modules,
    };
    config
        .probes
        .iter()
        .map(|p| {
            let s = Signal::new(
                names.name(*p),
                names.value_type(*p).unwrap_or(ValueType::I32),
            );
            match trace::unit(*p) {
                Some(u) => s.with_unit(u),
                None => s,
            }
        })
        .collect()
}

/// A signal's value at this boundary.
fn read(probe: Probe, plc: &Plc, stats: &ScanStats) -> Value {
    match probe {
        Probe::Tag(i) => plc.image().get(TagId(i as u32)),
        Probe::Counter { module, counter } => {
            let Some(m) = plc.module_status().get(module) else {
                return Value::I32(0);
            };
            let c = &m.counters;
            let n = match counter {
                Counter::Requests => c.requests,
                Counter::Timeouts => c.timeouts,
                Counter::CrcErrors => c.crc_errors,
                Counter::BadReplies => c.bad_replies,
                Counter::Exceptions => c.exceptions,
                Counter::RoundTrip => c.last_round_trip.as_micros() as u64,
            };
            Value::I32(i32::try_from(n).unwrap_or(i32::MAX))
        }
        Probe::Phase(p) => {
            let d = match p {
                Phase::Read => stats.last.read,
                Phase::Logic => stats.last.logic,
                Phase::Write => stats.last.write,
                Phase::Cycle => stats.last.cycle,
            };
            Value::I32(i32::try_from(d.as_micros()).unwrap_or(i32::MAX))
        }
    }
}
