//! The function-block library shared by every logic engine: timers, counters, edges,
//! bistables, a blinker, an impulse relay and a staircase timer.
//!
//! Each block is a small state machine called once per scan with its inputs and the scan's time
//! ([`ScanContext::now`](crate::logic::ScanContext::now)); none reads a clock. The ladder engine
//! keeps its instances in a table indexed at compile time, the Rhai engine keys them by name;
//! both call the same code, so a program gives the same trace in either language.
//!
//! # Conventions
//!
//! - **Edges.** Every edge-triggered input (R_TRIG, F_TRIG, TP, counters, TOGGLE, STAIR) sees an
//!   edge when its input differs from the previous *call*. The first call has no previous value
//!   and sees no edge: an input already true at start-up is not a press (unlike IEC R_TRIG,
//!   which fires on the first scan; a machine must not restart by itself after a power cut).
//! - **Time** is measured from the scan that saw the triggering condition (`now - start`),
//!   so with a 20 ms period a 100 ms TON is true from the 6th consecutive scan with its input.
//!   If the clock goes back (a replayed virtual clock), a running timer restarts from `now`.
//! - **Counters** hold an `i32` and saturate at its limits instead of wrapping.

mod bistable;
mod blink;
mod counter;
mod edge;
mod timer;

use std::fmt;
use std::time::Duration;

pub(crate) use bistable::{Rs, Sr, Toggle};
pub(crate) use blink::Blink;
pub use blink::{Pattern, PatternError};
pub(crate) use counter::{Ctd, Ctu, Ctud};
pub(crate) use edge::Edge;
pub(crate) use timer::{Stair, Tof, Ton, Tp};

/// The block types, as programs name them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kind {
    /// On-delay timer.
    Ton,
    /// Off-delay timer.
    Tof,
    /// Pulse timer.
    Tp,
    /// Up counter.
    Ctu,
    /// Down counter.
    Ctd,
    /// Up-down counter.
    Ctud,
    /// Rising-edge detector.
    RTrig,
    /// Falling-edge detector.
    FTrig,
    /// Set-dominant bistable.
    Sr,
    /// Reset-dominant bistable.
    Rs,
    /// Blinker (on/off times or a bit pattern).
    Blink,
    /// Impulse relay: toggles on each rising edge.
    Toggle,
    /// Staircase timer: a retriggerable pulse.
    Stair,
}

impl Kind {
    /// Every kind, in documentation order.
    pub const ALL: [Kind; 13] = [
        Kind::Ton,
        Kind::Tof,
        Kind::Tp,
        Kind::Ctu,
        Kind::Ctd,
        Kind::Ctud,
        Kind::RTrig,
        Kind::FTrig,
        Kind::Sr,
        Kind::Rs,
        Kind::Blink,
        Kind::Toggle,
        Kind::Stair,
    ];

    /// The name programs use: `TON`, `R_TRIG`, ...
    pub fn name(self) -> &'static str {
        match self {
            Kind::Ton => "TON",
            Kind::Tof => "TOF",
            Kind::Tp => "TP",
            Kind::Ctu => "CTU",
            Kind::Ctd => "CTD",
            Kind::Ctud => "CTUD",
            Kind::RTrig => "R_TRIG",
            Kind::FTrig => "F_TRIG",
            Kind::Sr => "SR",
            Kind::Rs => "RS",
            Kind::Blink => "BLINK",
            Kind::Toggle => "TOGGLE",
            Kind::Stair => "STAIR",
        }
    }

    /// The kind named `name` (exact, upper case).
    pub fn parse(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The outputs an instance of this kind exposes.
    pub fn outputs(self) -> &'static [Member] {
        match self {
            Kind::Ton | Kind::Tof | Kind::Tp | Kind::Stair => &[Member::Q, Member::Et],
            Kind::Ctu | Kind::Ctd => &[Member::Q, Member::Cv],
            Kind::Ctud => &[Member::Qu, Member::Qd, Member::Cv],
            Kind::RTrig | Kind::FTrig | Kind::Sr | Kind::Rs | Kind::Blink | Kind::Toggle => {
                &[Member::Q]
            }
        }
    }

    /// The input the rung's power flow feeds, by its IEC name as docs/programming.md's table
    /// gives it: `IN` (timers, STAIR, TOGGLE), `CU` (CTU, CTUD), `CD`, `CLK` (edges), `S1`
    /// (SR), `S` (RS), `EN` (BLINK).
    pub fn main_input(self) -> &'static str {
        match self {
            Kind::Ton | Kind::Tof | Kind::Tp | Kind::Stair | Kind::Toggle => "IN",
            Kind::Ctu | Kind::Ctud => "CU",
            Kind::Ctd => "CD",
            Kind::RTrig | Kind::FTrig => "CLK",
            Kind::Sr => "S1",
            Kind::Rs => "S",
            Kind::Blink => "EN",
        }
    }

    /// The output that a block passes on along its rung (`Q`; `QU` for CTUD).
    pub fn main_output(self) -> Member {
        match self {
            Kind::Ctud => Member::Qu,
            _ => Member::Q,
        }
    }
}

impl fmt::Display for Kind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// An output of an instance: `.Q`, `.ET`, `.CV`, `.QU`, `.QD`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Member {
    /// The boolean output.
    Q,
    /// Elapsed time, in milliseconds when read as a number.
    Et,
    /// Counter value.
    Cv,
    /// CTUD: counted up to the preset.
    Qu,
    /// CTUD: counted down to zero.
    Qd,
}

impl Member {
    /// The name programs use.
    pub fn name(self) -> &'static str {
        match self {
            Member::Q => "Q",
            Member::Et => "ET",
            Member::Cv => "CV",
            Member::Qu => "QU",
            Member::Qd => "QD",
        }
    }

    /// The member named `name` (exact, upper case).
    pub fn parse(name: &str) -> Option<Member> {
        [Member::Q, Member::Et, Member::Cv, Member::Qu, Member::Qd]
            .into_iter()
            .find(|m| m.name() == name)
    }

    /// True for the boolean outputs.
    pub fn is_bool(self) -> bool {
        matches!(self, Member::Q | Member::Qu | Member::Qd)
    }
}

impl fmt::Display for Member {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// One instance of any block, for engines that keep instances of mixed kinds in one table.
#[derive(Debug, Clone, PartialEq)]
pub(crate) enum Instance {
    /// See [`Ton`].
    Ton(Ton),
    /// See [`Tof`].
    Tof(Tof),
    /// See [`Tp`].
    Tp(Tp),
    /// See [`Ctu`].
    Ctu(Ctu),
    /// See [`Ctd`].
    Ctd(Ctd),
    /// See [`Ctud`].
    Ctud(Ctud),
    /// R_TRIG, see [`Edge`].
    RTrig(Edge),
    /// F_TRIG, see [`Edge`].
    FTrig(Edge),
    /// See [`Sr`].
    Sr(Sr),
    /// See [`Rs`].
    Rs(Rs),
    /// See [`Blink`].
    Blink(Blink),
    /// See [`Toggle`].
    Toggle(Toggle),
    /// See [`Stair`].
    Stair(Stair),
}

impl Instance {
    /// A fresh instance of `kind`.
    pub(crate) fn new(kind: Kind) -> Self {
        match kind {
            Kind::Ton => Instance::Ton(Ton::default()),
            Kind::Tof => Instance::Tof(Tof::default()),
            Kind::Tp => Instance::Tp(Tp::default()),
            Kind::Ctu => Instance::Ctu(Ctu::default()),
            Kind::Ctd => Instance::Ctd(Ctd::default()),
            Kind::Ctud => Instance::Ctud(Ctud::default()),
            Kind::RTrig => Instance::RTrig(Edge::default()),
            Kind::FTrig => Instance::FTrig(Edge::default()),
            Kind::Sr => Instance::Sr(Sr::default()),
            Kind::Rs => Instance::Rs(Rs::default()),
            Kind::Blink => Instance::Blink(Blink::default()),
            Kind::Toggle => Instance::Toggle(Toggle::default()),
            Kind::Stair => Instance::Stair(Stair::default()),
        }
    }

    /// Its kind.
    pub(crate) fn kind(&self) -> Kind {
        match self {
            Instance::Ton(_) => Kind::Ton,
            Instance::Tof(_) => Kind::Tof,
            Instance::Tp(_) => Kind::Tp,
            Instance::Ctu(_) => Kind::Ctu,
            Instance::Ctd(_) => Kind::Ctd,
            Instance::Ctud(_) => Kind::Ctud,
            Instance::RTrig(_) => Kind::RTrig,
            Instance::FTrig(_) => Kind::FTrig,
            Instance::Sr(_) => Kind::Sr,
            Instance::Rs(_) => Kind::Rs,
            Instance::Blink(_) => Kind::Blink,
            Instance::Toggle(_) => Kind::Toggle,
            Instance::Stair(_) => Kind::Stair,
        }
    }

    /// A boolean output (`false` for a member the kind does not have).
    pub(crate) fn bool_output(&self, member: Member) -> bool {
        match (self, member) {
            (Instance::Ton(t), Member::Q) => t.q(),
            (Instance::Tof(t), Member::Q) => t.q(),
            (Instance::Tp(t), Member::Q) => t.q(),
            (Instance::Stair(t), Member::Q) => t.q(),
            (Instance::Ctu(c), Member::Q) => c.q(),
            (Instance::Ctd(c), Member::Q) => c.q(),
            (Instance::Ctud(c), Member::Qu) => c.qu(),
            (Instance::Ctud(c), Member::Qd) => c.qd(),
            (Instance::RTrig(e) | Instance::FTrig(e), Member::Q) => e.q(),
            (Instance::Sr(b), Member::Q) => b.q(),
            (Instance::Rs(b), Member::Q) => b.q(),
            (Instance::Blink(b), Member::Q) => b.q(),
            (Instance::Toggle(b), Member::Q) => b.q(),
            _ => false,
        }
    }

    /// An output as a number: booleans as 0/1, `ET` in milliseconds, `CV` as is.
    pub(crate) fn number_output(&self, member: Member) -> f64 {
        match self.output(member) {
            OutputValue::Bool(b) => f64::from(u8::from(b)),
            OutputValue::Time(d) => millis(d),
            OutputValue::Count(c) => f64::from(c),
        }
    }

    /// An output, typed: `ET` a duration, `CV` a count, the others booleans (`false`, zero
    /// for a member the kind does not have).
    pub(crate) fn output(&self, member: Member) -> OutputValue {
        match (self, member) {
            (Instance::Ton(t), Member::Et) => OutputValue::Time(t.et()),
            (Instance::Tof(t), Member::Et) => OutputValue::Time(t.et()),
            (Instance::Tp(t), Member::Et) => OutputValue::Time(t.et()),
            (Instance::Stair(t), Member::Et) => OutputValue::Time(t.et()),
            (_, Member::Et) => OutputValue::Time(Duration::ZERO),
            (Instance::Ctu(c), Member::Cv) => OutputValue::Count(c.cv()),
            (Instance::Ctd(c), Member::Cv) => OutputValue::Count(c.cv()),
            (Instance::Ctud(c), Member::Cv) => OutputValue::Count(c.cv()),
            (_, Member::Cv) => OutputValue::Count(0),
            (_, m) => OutputValue::Bool(self.bool_output(m)),
        }
    }
}

/// The value of one output of an instance (`Instance::output`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum OutputValue {
    /// `Q`, `QU`, `QD`.
    Bool(bool),
    /// `ET`.
    Time(Duration),
    /// `CV`.
    Count(i32),
}

/// A duration in (fractional) milliseconds.
pub(crate) fn millis(d: Duration) -> f64 {
    d.as_secs_f64() * 1000.0
}

/// A number of milliseconds as a duration: negative and NaN give zero, huge values saturate.
pub(crate) fn from_millis(ms: f64) -> Duration {
    if ms.is_nan() || ms <= 0.0 {
        return Duration::ZERO;
    }
    let nanos = (ms * 1e6).round();
    if nanos >= u64::MAX as f64 {
        Duration::from_nanos(u64::MAX)
    } else {
        Duration::from_nanos(nanos as u64)
    }
}

/// Time since `start`; should the clock go back, timing restarts from `now`.
fn elapsed(start: &mut Duration, now: Duration) -> Duration {
    if now < *start {
        *start = now;
    }
    now - *start
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for k in Kind::ALL {
            assert_eq!(Kind::parse(k.name()), Some(k));
            assert_eq!(Instance::new(k).kind(), k);
            assert!(k.outputs().contains(&k.main_output()));
        }
        assert_eq!(Kind::parse("ton"), None);
        assert_eq!(Member::parse("CV"), Some(Member::Cv));
    }

    #[test]
    fn millisecond_conversions_are_total() {
        assert_eq!(from_millis(1.5), Duration::from_micros(1500));
        assert_eq!(from_millis(-3.0), Duration::ZERO);
        assert_eq!(from_millis(f64::NAN), Duration::ZERO);
        assert_eq!(from_millis(f64::INFINITY), Duration::from_nanos(u64::MAX));
        assert_eq!(millis(Duration::from_millis(250)), 250.0);
    }
}
