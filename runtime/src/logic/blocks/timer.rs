//! Timers: TON, TOF, TP (IEC 61131-3) and STAIR, a retriggerable pulse.

use std::time::Duration;

use super::{elapsed, Edge};

/// On-delay: `Q` once the input has been true for `PT`; false as soon as it is false.
/// `ET` counts while the input is true, up to `PT`; zero when the input is false.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Ton {
    running: bool,
    start: Duration,
    q: bool,
    et: Duration,
}

impl Ton {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, input: bool, pt: Duration, now: Duration) -> bool {
        if input {
            if !self.running {
                self.running = true;
                self.start = now;
            }
            let e = elapsed(&mut self.start, now);
            self.q = e >= pt;
            self.et = e.min(pt);
        } else {
            self.running = false;
            self.q = false;
            self.et = Duration::ZERO;
        }
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// Elapsed time.
    pub(crate) fn et(&self) -> Duration {
        self.et
    }
}

/// Off-delay: `Q` while the input is true and until it has been false for `PT`; false before
/// the input was ever true. `ET` counts from the falling input up to `PT`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Tof {
    running: bool,
    start: Duration,
    q: bool,
    et: Duration,
}

impl Tof {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, input: bool, pt: Duration, now: Duration) -> bool {
        if input {
            self.running = false;
            self.q = true;
            self.et = Duration::ZERO;
        } else if self.q {
            if !self.running {
                self.running = true;
                self.start = now;
            }
            let e = elapsed(&mut self.start, now);
            self.et = e.min(pt);
            if e >= pt {
                self.running = false;
                self.q = false;
            }
        }
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// Elapsed time.
    pub(crate) fn et(&self) -> Duration {
        self.et
    }
}

/// Pulse: a rising edge of the input starts a pulse of `PT`, true on the scans with
/// `now - start < PT` whatever the input does; edges during a pulse are ignored.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Tp {
    edge: Edge,
    running: bool,
    start: Duration,
    q: bool,
    et: Duration,
}

impl Tp {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, input: bool, pt: Duration, now: Duration) -> bool {
        let edge = self.edge.rising(input);
        if self.running && elapsed(&mut self.start, now) >= pt {
            self.running = false;
            self.et = pt;
        }
        if !self.running && edge {
            self.running = true;
            self.start = now;
        }
        if self.running {
            self.et = elapsed(&mut self.start, now);
        } else if !input {
            self.et = Duration::ZERO;
        }
        self.q = self.running;
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// Elapsed time.
    pub(crate) fn et(&self) -> Duration {
        self.et
    }
}

/// Staircase timer: every rising edge of the input (re)starts a pulse of `PT`, so a press during
/// the pulse extends it; the reset input ends it at once.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Stair {
    edge: Edge,
    running: bool,
    start: Duration,
    q: bool,
    et: Duration,
}

impl Stair {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, input: bool, reset: bool, pt: Duration, now: Duration) -> bool {
        let edge = self.edge.rising(input);
        if reset {
            self.running = false;
        } else if edge {
            self.running = true;
            self.start = now;
        }
        if self.running {
            let e = elapsed(&mut self.start, now);
            if e >= pt {
                self.running = false;
            }
            self.et = e.min(pt);
        } else {
            self.et = Duration::ZERO;
        }
        self.q = self.running;
        self.q
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }

    /// Elapsed time of the running pulse.
    pub(crate) fn et(&self) -> Duration {
        self.et
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    /// Runs `f` every 20 ms with the inputs given, from t = 0.
    fn trace(inputs: &[bool], mut f: impl FnMut(bool, Duration) -> bool) -> String {
        inputs
            .iter()
            .enumerate()
            .map(|(i, &x)| if f(x, ms(20 * i as u64)) { '1' } else { '0' })
            .collect()
    }

    fn bits(s: &str) -> Vec<bool> {
        s.chars().map(|c| c == '1').collect()
    }

    #[test]
    fn ton_counts_from_the_first_scan_with_the_input() {
        let mut t = Ton::default();
        let out = trace(&bits("0111111101"), |x, now| t.call(x, ms(100), now));
        assert_eq!(out, "0000001100");
        let mut t = Ton::default();
        t.call(true, ms(100), ms(0));
        t.call(true, ms(100), ms(40));
        assert_eq!(t.et(), ms(40));
        t.call(true, ms(100), ms(400));
        assert_eq!(t.et(), ms(100));
        t.call(false, ms(100), ms(420));
        assert_eq!(t.et(), ms(0));
    }

    #[test]
    fn tof_holds_after_the_input_falls() {
        let mut t = Tof::default();
        let out = trace(&bits("0011000000100"), |x, now| t.call(x, ms(60), now));
        assert_eq!(out, "0011111000111");
    }

    #[test]
    fn tp_ignores_edges_during_the_pulse() {
        let mut t = Tp::default();
        let out = trace(&bits("1010101000001"), |x, now| t.call(x, ms(50), now));
        assert_eq!(out, "0011101110001");
    }

    #[test]
    fn stair_retriggers_and_resets() {
        let mut s = Stair::default();
        let out = trace(&bits("01000100000000"), |x, now| {
            s.call(x, false, ms(100), now)
        });
        // Pressed at 20 ms (until 120), again at 100 ms: lit until 200 ms.
        assert_eq!(out, "01111111110000");
        let mut s = Stair::default();
        s.call(false, false, ms(100), ms(0));
        assert!(s.call(true, false, ms(100), ms(20)));
        assert!(!s.call(true, true, ms(100), ms(40)));
        assert!(!s.call(true, false, ms(100), ms(60)), "held: no new edge");
    }

    #[test]
    fn a_clock_going_back_restarts_timing() {
        let mut t = Ton::default();
        t.call(true, ms(100), ms(500));
        assert!(!t.call(true, ms(100), ms(100)));
        assert!(t.call(true, ms(100), ms(200)));
    }
}
