//! The function-block library shared by every logic engine: timers, counters, edges,
//! bistables, blinkers, an impulse relay and a staircase timer.
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

mod behaviour;
mod bistable;
mod blink;
mod counter;
mod edge;
mod registry;
mod timer;

use std::fmt;
use std::time::Duration;

pub(crate) use behaviour::{Arg, Args, Block, Pins, TimerPins, MAX_PINS};
pub(crate) use bistable::{Rs, Sr, Toggle};
pub(crate) use blink::{Blink, Lamp};
pub use blink::{Pattern, PatternError};
pub(crate) use counter::{Ctd, Ctu, Ctud};
pub(crate) use edge::{Edge, FTrig, RTrig};
pub use registry::{BlockDef, Form, Pin, PinType};
pub(crate) use timer::{Stair, Tof, Ton, Tp};

/// The block library, once: each line is a kind, the type of its state (its behaviour, a
/// [`Block`]) and its definition ([`BlockDef`]). It makes [`Kind`] and [`Instance`]; the
/// order is the documentation's.
macro_rules! blocks {
    ($($(#[$doc:meta])* $kind:ident($state:ty) = $def:path;)*) => {
        /// The block types, as programs name them.
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
        pub enum Kind {
            $($(#[$doc])* $kind,)*
        }

        impl Kind {
            /// Every kind, in documentation order.
            pub const ALL: [Kind; [$(stringify!($kind)),*].len()] = [$(Kind::$kind),*];

            /// Its definition.
            pub fn def(self) -> &'static BlockDef {
                match self {
                    $(Kind::$kind => &$def,)*
                }
            }
        }

        /// One instance of any block, for engines that keep instances of mixed kinds in one
        /// table.
        #[derive(Debug, Clone, PartialEq)]
        pub(crate) enum Instance {
            $($(#[$doc])* $kind($state),)*
        }

        impl Instance {
            /// A fresh instance of `kind`.
            pub(crate) fn new(kind: Kind) -> Self {
                match kind {
                    $(Kind::$kind => Instance::$kind(<$state>::default()),)*
                }
            }

            /// Its kind.
            pub(crate) fn kind(&self) -> Kind {
                match self {
                    $(Instance::$kind(_) => Kind::$kind,)*
                }
            }

            /// One call with its inputs, by pin ([`BlockDef::pins`]); returns the main output.
            pub(crate) fn call(&mut self, args: &impl Pins, now: Duration) -> bool {
                match self {
                    $(Instance::$kind(b) => Block::call(b, args, now),)*
                }
            }

            /// An output, typed: `ET` a duration, `CV` a count, the others booleans (`false`,
            /// zero for a member the kind does not have).
            pub(crate) fn output(&self, member: Member) -> OutputValue {
                let value = match self {
                    $(Instance::$kind(b) => Block::output(b, member),)*
                };
                value.unwrap_or(OutputValue::none(member))
            }
        }
    };
}

blocks! {
    /// On-delay timer.
    Ton(Ton) = registry::TON;
    /// Off-delay timer.
    Tof(Tof) = registry::TOF;
    /// Pulse timer.
    Tp(Tp) = registry::TP;
    /// Staircase timer: a retriggerable pulse.
    Stair(Stair) = registry::STAIR;
    /// Up counter.
    Ctu(Ctu) = registry::CTU;
    /// Down counter.
    Ctd(Ctd) = registry::CTD;
    /// Up-down counter.
    Ctud(Ctud) = registry::CTUD;
    /// Rising-edge detector.
    RTrig(RTrig) = registry::R_TRIG;
    /// Falling-edge detector.
    FTrig(FTrig) = registry::F_TRIG;
    /// Set-dominant bistable.
    Sr(Sr) = registry::SR;
    /// Reset-dominant bistable.
    Rs(Rs) = registry::RS;
    /// Impulse relay: toggles on each rising edge.
    Toggle(Toggle) = registry::TOGGLE;
    /// Blinker (on/off times or a bit pattern).
    Blink(Blink) = registry::BLINK;
    /// The MiniMod's blinker: a 16-step mask on free-running 100 ms steps.
    Lamp(Lamp) = registry::LAMP;
}

impl Kind {
    /// The name programs use: `TON`, `R_TRIG`, ...
    pub fn name(self) -> &'static str {
        self.def().name
    }

    /// The kind named `name` (exact, upper case).
    pub fn parse(name: &str) -> Option<Kind> {
        Kind::ALL.into_iter().find(|k| k.name() == name)
    }

    /// The outputs an instance of this kind exposes.
    pub fn outputs(self) -> &'static [Member] {
        self.def().outputs
    }

    /// The input the rung's power flow feeds, by its IEC name as docs/programming.md's table
    /// gives it: `IN` (timers, STAIR, TOGGLE), `CU` (CTU, CTUD), `CD`, `CLK` (edges), `S1`
    /// (SR), `S` (RS), `EN` (BLINK, LAMP).
    pub fn main_input(self) -> &'static str {
        self.def().main_input().name
    }

    /// The output that a block passes on along its rung (`Q`; `QU` for CTUD).
    pub fn main_output(self) -> Member {
        self.def().main_output()
    }
}

/// The block names, in documentation order: `TON, TOF, ...` (for messages).
pub(crate) fn names() -> String {
    let names: Vec<&str> = Kind::ALL.iter().map(|k| k.name()).collect();
    names.join(", ")
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

impl Instance {
    /// A boolean output (`false` for a member the kind does not have).
    pub(crate) fn bool_output(&self, member: Member) -> bool {
        matches!(self.output(member), OutputValue::Bool(true))
    }

    /// An output as a number: booleans as 0/1, `ET` in milliseconds, `CV` as is.
    pub(crate) fn number_output(&self, member: Member) -> f64 {
        match self.output(member) {
            OutputValue::Bool(b) => f64::from(u8::from(b)),
            OutputValue::Time(d) => millis(d),
            OutputValue::Count(c) => f64::from(c),
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

impl OutputValue {
    /// What a member the kind does not have reads: `false`, zero.
    fn none(member: Member) -> Self {
        match member {
            Member::Et => OutputValue::Time(Duration::ZERO),
            Member::Cv => OutputValue::Count(0),
            Member::Q | Member::Qu | Member::Qd => OutputValue::Bool(false),
        }
    }
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
