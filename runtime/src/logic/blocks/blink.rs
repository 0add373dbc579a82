//! BLINK: a blinker by on/off times or by a bit pattern, starting on when enabled; LAMP: the
//! MiniMod's own blinker, a 16-step mask on steps that run freely from the PLC's start.

use std::fmt;
use std::time::Duration;

use super::elapsed;

/// Longest bit pattern.
pub(crate) const MAX_PATTERN_BITS: usize = 64;

/// A blink pattern: bits played one per `step`, first bit first, repeated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Pattern {
    bits: u64,
    len: u8,
}

/// Why a pattern text was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum PatternError {
    /// Empty.
    #[error("a blink pattern needs at least one bit")]
    Empty,
    /// A character other than 0 or 1.
    #[error("a blink pattern is written with 0 and 1 only")]
    NotBinary,
    /// More than `MAX_PATTERN_BITS` bits.
    #[error("a blink pattern has at most {MAX_PATTERN_BITS} bits")]
    TooLong,
}

impl Pattern {
    /// Parses `1100101`: the output is on for each `1`, one `step` each, left to right.
    pub fn parse(text: &str) -> Result<Pattern, PatternError> {
        if text.is_empty() {
            return Err(PatternError::Empty);
        }
        let mut bits = 0u64;
        let mut len = 0usize;
        for c in text.chars() {
            if len == MAX_PATTERN_BITS {
                return Err(PatternError::TooLong);
            }
            match c {
                '1' => bits |= 1 << len,
                '0' => {}
                _ => return Err(PatternError::NotBinary),
            }
            len += 1;
        }
        Ok(Pattern {
            bits,
            len: len as u8,
        })
    }

    /// Its number of bits.
    pub fn len(&self) -> u64 {
        u64::from(self.len)
    }

    /// Whether it has no bits (never: a parsed pattern has one at least).
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bit `i` (0 = first), repeating.
    pub fn bit(&self, i: u64) -> bool {
        let n = u64::from(self.len.max(1));
        self.bits >> (i % n) & 1 == 1
    }
}

impl fmt::Display for Pattern {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for i in 0..u64::from(self.len) {
            f.write_str(if self.bit(i) { "1" } else { "0" })?;
        }
        Ok(())
    }
}

/// A blinker. While enabled it starts with the output on at the scan that enabled it; while
/// disabled the output is off and the phase restarts on the next enable.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Blink {
    start: Option<Duration>,
    q: bool,
}

impl Blink {
    /// One call with on/off times; returns `Q`. A zero period keeps the output on.
    pub(crate) fn call(
        &mut self,
        enable: bool,
        on: Duration,
        off: Duration,
        now: Duration,
    ) -> bool {
        let Some(t) = self.phase(enable, now) else {
            return self.q;
        };
        let period = on.as_nanos() + off.as_nanos();
        self.q = period == 0 || t.as_nanos() % period < on.as_nanos();
        self.q
    }

    /// One call playing `pattern`, one bit per `step`; returns `Q`. A zero step holds the
    /// first bit.
    pub(crate) fn call_pattern(
        &mut self,
        enable: bool,
        pattern: Pattern,
        step: Duration,
        now: Duration,
    ) -> bool {
        let Some(t) = self.phase(enable, now) else {
            return self.q;
        };
        let index = t.as_nanos().checked_div(step.as_nanos()).unwrap_or(0);
        self.q = pattern.bit((index % u128::from(u64::MAX)) as u64);
        self.q
    }

    /// Time since the enable, or `None` (and `Q` off) when disabled.
    fn phase(&mut self, enable: bool, now: Duration) -> Option<Duration> {
        if !enable {
            self.start = None;
            self.q = false;
            return None;
        }
        let start = self.start.get_or_insert(now);
        Some(elapsed(start, now))
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

/// One LAMP step: the MiniMod's blinker step, "with speed of about a tenth of a second"
/// (manual, "Automatic continuous blinking").
pub(crate) const LAMP_STEP: Duration = Duration::from_millis(100);
/// Steps in a LAMP mask ("a 16 bit rotating mask").
const LAMP_STEPS: u128 = 16;

/// The MiniMod's blinker as a block: while enabled, Q is bit k of the 16-bit mask during step
/// k = (scan time / 100 ms) mod 16, the scan time counted from the PLC's start. The phase is
/// the clock's, not the enable's, as the module's own steps run from its power-on: a program
/// means the same in the scan and in the module (`offload`: pushed down as YLAMPn), up to
/// where the 16 steps start. A mask outside 0..=65535 (read from a tag) is held to that range.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub(crate) struct Lamp {
    q: bool,
}

impl Lamp {
    /// One call; returns `Q`.
    pub(crate) fn call(&mut self, enable: bool, mask: i32, now: Duration) -> bool {
        let mask = u16::try_from(mask.clamp(0, i32::from(u16::MAX))).unwrap_or(u16::MAX);
        self.q = enable && mask & (1 << Self::step(now)) != 0;
        self.q
    }

    /// The step shown at `now`, 0..=15.
    pub(crate) fn step(now: Duration) -> u32 {
        // The remainder is below 16.
        ((now.as_nanos() / LAMP_STEP.as_nanos()) % LAMP_STEPS) as u32
    }

    /// The output.
    pub(crate) fn q(&self) -> bool {
        self.q
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn on_off_times() {
        let mut b = Blink::default();
        let out: String = (0..10)
            .map(|i| {
                let q = b.call(i >= 2, ms(40), ms(20), ms(20 * i));
                if q {
                    '1'
                } else {
                    '0'
                }
            })
            .collect();
        assert_eq!(out, "0011011011");
        assert!(Blink::default().call(true, ms(0), ms(0), ms(5)));
    }

    #[test]
    fn patterns() {
        let p = Pattern::parse("1101").unwrap();
        assert_eq!(p.to_string(), "1101");
        let mut b = Blink::default();
        let out: Vec<bool> = (0..6)
            .map(|i| b.call_pattern(true, p, ms(10), ms(10 * i)))
            .collect();
        assert_eq!(out, [true, true, false, true, true, true]);
        assert_eq!(Pattern::parse(""), Err(PatternError::Empty));
        assert_eq!(Pattern::parse("12"), Err(PatternError::NotBinary));
        assert_eq!(Pattern::parse(&"1".repeat(65)), Err(PatternError::TooLong));
        assert!(Pattern::parse(&"1".repeat(64)).is_ok());
        assert!(Blink::default().call_pattern(true, p, Duration::ZERO, ms(50)));
    }

    #[test]
    fn lamp_steps_run_from_the_plcs_start_not_from_the_enable() {
        // 0x0F0F: 400 ms on, 400 ms off; enabled at 250 ms, it shows step 2's bit (on) at
        // once and goes off at 400 ms, where a BLINK would still be on.
        let mut lamp = Lamp::default();
        let out: String = (0..12)
            .map(|i| {
                let q = lamp.call(i >= 5, 0x0F0F, ms(50 * i));
                if q {
                    '1'
                } else {
                    '0'
                }
            })
            .collect();
        assert_eq!(out, "000001110000");
        // Bit 15 during the 16th step, then bit 0 again.
        assert!(Lamp::default().call(true, 0x8000, ms(1550)));
        assert!(!Lamp::default().call(true, 0x8000, ms(1600)));
        assert!(Lamp::default().call(true, 1, ms(1600)));
        assert!(!Lamp::default().call(true, -5, ms(0)), "held to 0");
        assert!(Lamp::default().call(true, 70000, ms(0)), "held to 0xFFFF");
    }
}
