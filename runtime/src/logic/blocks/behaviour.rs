//! What a block does with one call's inputs: each block's state reads its pins, by their index
//! in its [`BlockDef`](super::BlockDef), and calls its own state machine.

use std::time::Duration;

use super::{
    Blink, Ctd, Ctu, Ctud, FTrig, Lamp, Member, OutputValue, Pattern, RTrig, Rs, Sr, Stair, Tof,
    Toggle, Ton, Tp,
};

/// Most pins a block has (CTUD and BLINK have five).
pub(crate) const MAX_PINS: usize = 5;

/// One pin's value in one call.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) enum Arg {
    /// Not given: `false`, zero, no pattern.
    #[default]
    Absent,
    /// A bool pin's value.
    Bool(bool),
    /// A time pin's value.
    Time(Duration),
    /// A count pin's value.
    Count(i32),
    /// A pattern pin's value.
    Pattern(Pattern),
}

/// One call's inputs, by pin index.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Args(pub [Arg; MAX_PINS]);

/// A call's inputs by pin index, as a block reads them: each engine hands them over its own
/// way ([`Args`] built by the Rhai interpreter, [`TimerPins`] and the VM's call sites read in
/// place), and the block's code is compiled for each, with no copy in between.
pub(crate) trait Pins {
    /// The bool at pin `i` (`false` when absent).
    fn bool(&self, i: usize) -> bool;
    /// The time at pin `i` (zero when absent).
    fn time(&self, i: usize) -> Duration;
    /// The count at pin `i` (zero when absent).
    fn count(&self, i: usize) -> i32;
    /// The pattern at pin `i`, if given.
    fn pattern(&self, i: usize) -> Option<Pattern>;
}

impl Pins for Args {
    fn bool(&self, i: usize) -> bool {
        matches!(self.0.get(i), Some(Arg::Bool(true)))
    }

    fn time(&self, i: usize) -> Duration {
        match self.0.get(i) {
            Some(Arg::Time(d)) => *d,
            _ => Duration::ZERO,
        }
    }

    fn count(&self, i: usize) -> i32 {
        match self.0.get(i) {
            Some(Arg::Count(c)) => *c,
            _ => 0,
        }
    }

    fn pattern(&self, i: usize) -> Option<Pattern> {
        match self.0.get(i) {
            Some(Arg::Pattern(p)) => Some(*p),
            _ => None,
        }
    }
}

/// A plain timer's call (a power flow and a time, pins 0 and 1), as the VM's
/// `Instr::Timer` makes it.
#[derive(Debug, Clone, Copy)]
pub(crate) struct TimerPins {
    /// The power flow.
    pub input: bool,
    /// The preset.
    pub pt: Duration,
}

impl Pins for TimerPins {
    fn bool(&self, i: usize) -> bool {
        i == 0 && self.input
    }

    fn time(&self, i: usize) -> Duration {
        if i == 1 {
            self.pt
        } else {
            Duration::ZERO
        }
    }

    fn count(&self, _: usize) -> i32 {
        0
    }

    fn pattern(&self, _: usize) -> Option<Pattern> {
        None
    }
}

/// A block's behaviour.
pub(crate) trait Block {
    /// One call; returns the main output.
    fn call(&mut self, args: &impl Pins, now: Duration) -> bool;

    /// An output it has, `None` for a member it does not have.
    fn output(&self, member: Member) -> Option<OutputValue>;
}

/// `Q`, `ET`.
fn timed(member: Member, q: bool, et: Duration) -> Option<OutputValue> {
    match member {
        Member::Q => Some(OutputValue::Bool(q)),
        Member::Et => Some(OutputValue::Time(et)),
        _ => None,
    }
}

/// `Q`, `CV`.
fn counted(member: Member, q: bool, cv: i32) -> Option<OutputValue> {
    match member {
        Member::Q => Some(OutputValue::Bool(q)),
        Member::Cv => Some(OutputValue::Count(cv)),
        _ => None,
    }
}

/// `Q` only.
fn q_only(member: Member, q: bool) -> Option<OutputValue> {
    (member == Member::Q).then_some(OutputValue::Bool(q))
}

// Pins: IN, PT.
macro_rules! plain_timer {
    ($($t:ty),*) => {$(
        impl Block for $t {
            fn call(&mut self, a: &impl Pins, now: Duration) -> bool {
                <$t>::call(self, a.bool(0), a.time(1), now)
            }
            fn output(&self, m: Member) -> Option<OutputValue> {
                timed(m, self.q(), self.et())
            }
        }
    )*};
}
plain_timer!(Ton, Tof, Tp);

// Pins: IN, PT, R.
impl Block for Stair {
    fn call(&mut self, a: &impl Pins, now: Duration) -> bool {
        Stair::call(self, a.bool(0), a.bool(2), a.time(1), now)
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        timed(m, self.q(), self.et())
    }
}

// Pins: CU, PV, R.
impl Block for Ctu {
    fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
        Ctu::call(self, a.bool(0), a.bool(2), a.count(1))
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        counted(m, self.q(), self.cv())
    }
}

// Pins: CD, PV, LD.
impl Block for Ctd {
    fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
        Ctd::call(self, a.bool(0), a.bool(2), a.count(1))
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        counted(m, self.q(), self.cv())
    }
}

// Pins: CU, PV, CD, R, LD.
impl Block for Ctud {
    fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
        Ctud::call(self, a.bool(0), a.bool(2), a.bool(3), a.bool(4), a.count(1))
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        match m {
            Member::Qu => Some(OutputValue::Bool(self.qu())),
            Member::Qd => Some(OutputValue::Bool(self.qd())),
            Member::Cv => Some(OutputValue::Count(self.cv())),
            _ => None,
        }
    }
}

// Pins: CLK.
impl Block for RTrig {
    fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
        self.0.rising(a.bool(0))
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        q_only(m, self.0.q())
    }
}

// Pins: CLK.
impl Block for FTrig {
    fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
        self.0.falling(a.bool(0))
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        q_only(m, self.0.q())
    }
}

// Pins: the set input, R (the latches and the impulse relay alike).
macro_rules! latch {
    ($($t:ty),*) => {$(
        impl Block for $t {
            fn call(&mut self, a: &impl Pins, _: Duration) -> bool {
                <$t>::call(self, a.bool(0), a.bool(1))
            }
            fn output(&self, m: Member) -> Option<OutputValue> {
                q_only(m, self.q())
            }
        }
    )*};
}
latch!(Sr, Rs, Toggle);

// Pins: EN, ON, OFF, PATTERN, STEP; a pattern given plays it.
impl Block for Blink {
    fn call(&mut self, a: &impl Pins, now: Duration) -> bool {
        match a.pattern(3) {
            Some(pattern) => self.call_pattern(a.bool(0), pattern, a.time(4), now),
            None => Blink::call(self, a.bool(0), a.time(1), a.time(2), now),
        }
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        q_only(m, self.q())
    }
}

// Pins: EN, MASK.
impl Block for Lamp {
    fn call(&mut self, a: &impl Pins, now: Duration) -> bool {
        Lamp::call(self, a.bool(0), a.count(1), now)
    }
    fn output(&self, m: Member) -> Option<OutputValue> {
        q_only(m, self.q())
    }
}
