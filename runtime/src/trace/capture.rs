//! One armed trace: a ring of samples in memory allocated when it is armed, and the trigger's
//! state machine, stepped once per cycle on the scan thread.
//!
//! States, in order: **filling** (armed, fewer than `pre` samples held yet), **armed** (`pre`
//! held, the oldest dropped as new ones come, waiting for the trigger), **triggered** (taking
//! the `post` samples after the trigger), **complete** (kept until saved). The trigger is
//! accepted while filling too (the trace then has fewer samples before it), as CODESYS does.
//! A trace without a trigger is **filling** until it holds `pre + post` samples, then
//! **recording**: it keeps the newest ones for as long as it runs.
//!
//! The trigger is watched every cycle, whatever `every` is, so a one-cycle pulse is never
//! missed: the cycle it fires is sampled, and `post` samples follow every `every` cycles from
//! it. An edge needs two cycles: the first cycle after arming only gives the trigger its
//! previous value.

use serde::{Deserialize, Serialize};
use softplc_io::point::Value;

use crate::project::trace::{Condition, Probe, TraceConfig, TraceMode};
use softplc_io::time::ScanInstant;

/// Where a trace is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum TraceState {
    /// Armed, collecting its pre-trigger samples.
    Filling,
    /// Armed with its pre-trigger samples, waiting for the trigger.
    Armed,
    /// Triggered, taking its post-trigger samples.
    Triggered,
    /// Done: its samples are kept until saved.
    Complete,
    /// No trigger: keeping the newest samples, continuously.
    Recording,
}

impl std::fmt::Display for TraceState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            TraceState::Filling => "filling",
            TraceState::Armed => "armed",
            TraceState::Triggered => "triggered",
            TraceState::Complete => "complete",
            TraceState::Recording => "recording",
        })
    }
}

/// When a sample is taken: the scan's timestamp and cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Moment {
    /// The cycle's timestamp (the time its logic saw).
    pub time: ScanInstant,
    /// The cycle (1 = the first).
    pub cycle: u64,
}

/// An armed trace.
#[derive(Debug)]
pub struct Capture {
    config: TraceConfig,
    width: usize,
    depth: usize,
    /// `depth × width` values, one row per slot.
    values: Vec<Value>,
    times: Vec<ScanInstant>,
    cycles: Vec<u64>,
    /// The oldest slot, and how many are held.
    head: usize,
    len: usize,
    state: TraceState,
    /// Post-trigger samples still to take.
    post_left: u32,
    /// Cycles since the last sample.
    since: u32,
    /// The trigger signal's truth at the previous cycle (edges).
    previous: Option<bool>,
    /// The trigger sample's position from the oldest held, and its cycle.
    trigger: Option<(usize, u64)>,
}

impl Capture {
    /// Arms `config`: its whole ring is allocated here, never while sampling.
    pub fn arm(config: TraceConfig) -> Self {
        let width = config.probes.len();
        let depth = config.depth();
        let mut c = Self {
            values: vec![Value::Bool(false); depth * width],
            times: vec![ScanInstant::ZERO; depth],
            cycles: vec![0; depth],
            width,
            depth,
            config,
            head: 0,
            len: 0,
            state: TraceState::Filling,
            post_left: 0,
            since: 0,
            previous: None,
            trigger: None,
        };
        c.rearm();
        c
    }

    /// Starts again from nothing, in the buffers it has.
    pub fn rearm(&mut self) {
        self.head = 0;
        self.len = 0;
        self.state = if self.config.trigger.is_some() && self.config.pre == 0 {
            TraceState::Armed
        } else {
            TraceState::Filling
        };
        self.post_left = 0;
        // The first cycle after arming is sampled.
        self.since = self.config.every.saturating_sub(1);
        self.previous = None;
        self.trigger = None;
    }

    /// Its definition.
    pub fn config(&self) -> &TraceConfig {
        &self.config
    }

    /// Where it is.
    pub fn state(&self) -> TraceState {
        self.state
    }

    /// Samples held.
    pub fn len(&self) -> usize {
        self.len
    }

    /// True when it holds no sample.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Samples it holds at most.
    pub fn depth(&self) -> usize {
        self.depth
    }

    /// The trigger sample's position among the held samples (0 = oldest) and its cycle.
    pub fn trigger(&self) -> Option<(usize, u64)> {
        self.trigger
    }

    /// Whether it re-arms once saved.
    pub fn repeats(&self) -> bool {
        self.config.mode == TraceMode::Repeat
    }

    /// One cycle boundary: watches the trigger and takes a sample when one is due. `read`
    /// gives a signal's value at this boundary.
    pub fn step(&mut self, at: Moment, read: impl Fn(Probe) -> Value) {
        match self.state {
            TraceState::Complete => {}
            TraceState::Triggered => {
                self.since += 1;
                if self.since >= self.config.every {
                    self.since = 0;
                    self.push(at, &read);
                    self.post_left -= 1;
                    if self.post_left == 0 {
                        self.state = TraceState::Complete;
                    }
                }
            }
            TraceState::Filling | TraceState::Armed | TraceState::Recording => {
                if self.fired(&read) {
                    self.since = 0;
                    self.push(at, &read);
                    self.trigger = Some((self.len - 1, at.cycle));
                    self.post_left = self.config.post;
                    self.state = if self.post_left == 0 {
                        TraceState::Complete
                    } else {
                        TraceState::Triggered
                    };
                    return;
                }
                self.since += 1;
                if self.since < self.config.every {
                    return;
                }
                self.since = 0;
                let keep = match self.config.trigger {
                    Some(_) => self.config.pre as usize,
                    None => self.depth,
                };
                if keep == 0 {
                    return;
                }
                if self.len == keep {
                    self.head = (self.head + 1) % self.depth;
                    self.len -= 1;
                }
                self.push(at, &read);
                self.state = match (self.config.trigger.is_some(), self.len == keep) {
                    (_, false) => TraceState::Filling,
                    (true, true) => TraceState::Armed,
                    (false, true) => TraceState::Recording,
                };
            }
        }
    }

    /// Whether the trigger fires at this boundary (and remembers its value for edges).
    fn fired(&mut self, read: &impl Fn(Probe) -> Value) -> bool {
        let Some(t) = self.config.trigger else {
            return false;
        };
        let v = read(t.probe);
        let now = v.as_bool();
        let previous = self.previous.replace(now);
        match t.condition {
            Condition::Rising => previous == Some(false) && now,
            Condition::Falling => previous == Some(true) && !now,
            Condition::High => now,
            Condition::Low => !now,
            Condition::Compare(op, literal) => op.holds(as_f64(v), literal),
        }
    }

    /// Writes a sample into the next slot (the caller has made room).
    fn push(&mut self, at: Moment, read: &impl Fn(Probe) -> Value) {
        let slot = (self.head + self.len) % self.depth;
        let row = &mut self.values[slot * self.width..(slot + 1) * self.width];
        for (v, p) in row.iter_mut().zip(&self.config.probes) {
            *v = read(*p);
        }
        self.times[slot] = at.time;
        self.cycles[slot] = at.cycle;
        self.len += 1;
    }

    /// The held samples, oldest first: (time, cycle, one value per signal).
    pub fn samples(&self) -> impl Iterator<Item = (ScanInstant, u64, &[Value])> + '_ {
        (0..self.len).map(move |k| {
            let slot = (self.head + k) % self.depth;
            (
                self.times[slot],
                self.cycles[slot],
                &self.values[slot * self.width..(slot + 1) * self.width],
            )
        })
    }
}

/// A value as a number (bools as 0 and 1).
pub(crate) fn as_f64(v: Value) -> f64 {
    match v {
        Value::Bool(b) => f64::from(u8::from(b)),
        Value::U16(x) => f64::from(x),
        Value::I32(x) => f64::from(x),
        Value::F32(x) => f64::from(x),
    }
}
