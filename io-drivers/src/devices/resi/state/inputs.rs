//! Digital inputs: terminal levels, the 10 ms sampling ("Sampling rate Every 10ms", L16833,
//! L23241, L26072) and the edge counters `RISE DIn` / `FALL DIn`, which are "set always to 0"
//! after power on or a soft reset (L20311–L20314). No debounce is documented, so none is
//! simulated: a level held across one sampling instant is seen.

/// What one sampling instant saw.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct Sample {
    /// The levels now, bit n = DI(n+1).
    pub now: u32,
    /// The levels at the previous sample.
    pub before: u32,
    /// Inputs that went high.
    pub rise: u32,
    /// Inputs that went low.
    pub fall: u32,
}

/// The inputs of a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Inputs {
    count: u8,
    terminals: u32,
    sampled: u32,
    rise: [u16; 32],
    fall: [u16; 32],
}

impl Inputs {
    /// `count` inputs (at most 32), all low.
    pub(crate) fn new(count: u8) -> Self {
        Self {
            count: count.min(32),
            terminals: 0,
            sampled: 0,
            rise: [0; 32],
            fall: [0; 32],
        }
    }

    /// How many inputs.
    pub(crate) fn count(&self) -> u8 {
        self.count
    }

    fn mask(&self) -> u32 {
        if self.count >= 32 {
            u32::MAX
        } else {
            (1u32 << self.count) - 1
        }
    }

    /// Sets the level at terminal DI(n+1); seen at the next sampling instant.
    pub(crate) fn set_terminal(&mut self, n: u8, high: bool) {
        if n < self.count {
            let bit = 1u32 << n;
            self.terminals = if high {
                self.terminals | bit
            } else {
                self.terminals & !bit
            };
        }
    }

    /// One sampling instant: new levels, edges counted.
    pub(crate) fn sample(&mut self) -> Sample {
        let now = self.terminals & self.mask();
        let before = self.sampled;
        let rise = now & !before;
        let fall = !now & before;
        for n in 0..usize::from(self.count) {
            if rise & (1 << n) != 0 {
                if let Some(c) = self.rise.get_mut(n) {
                    *c = c.wrapping_add(1);
                }
            }
            if fall & (1 << n) != 0 {
                if let Some(c) = self.fall.get_mut(n) {
                    *c = c.wrapping_add(1);
                }
            }
        }
        self.sampled = now;
        Sample {
            now,
            before,
            rise,
            fall,
        }
    }

    /// Power-on or soft reset: counters at 0, and the levels taken as they are, so an input
    /// already high is not counted as a rising edge (resi-spec §4.5).
    pub(crate) fn boot(&mut self) {
        self.sampled = self.terminals & self.mask();
        self.reset_counters();
    }

    /// RESET COUNTER / `RC`.
    pub(crate) fn reset_counters(&mut self) {
        self.rise = [0; 32];
        self.fall = [0; 32];
    }

    /// The sampled levels, bit n = DI(n+1).
    pub(crate) fn levels(&self) -> u32 {
        self.sampled
    }

    /// Rising edges of DI(n+1).
    pub(crate) fn rises(&self, n: u8) -> Option<u16> {
        (n < self.count)
            .then(|| self.rise.get(usize::from(n)).copied())
            .flatten()
    }

    /// Falling edges of DI(n+1).
    pub(crate) fn falls(&self, n: u8) -> Option<u16> {
        (n < self.count)
            .then(|| self.fall.get(usize::from(n)).copied())
            .flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn edges_are_counted_at_sampling() {
        let mut i = Inputs::new(16);
        i.set_terminal(0, true);
        assert_eq!(i.levels(), 0, "not sampled yet");
        let s = i.sample();
        assert_eq!((s.now, s.rise, s.fall), (1, 1, 0));
        i.set_terminal(0, false);
        i.set_terminal(15, true);
        let s = i.sample();
        assert_eq!((s.rise, s.fall), (1 << 15, 1));
        assert_eq!(
            (i.rises(0), i.falls(0), i.rises(15)),
            (Some(1), Some(1), Some(1))
        );
        i.set_terminal(20, true);
        assert_eq!(i.sample().now, 1 << 15, "no DI21 on 16 inputs");
        assert_eq!(i.rises(16), None);
    }

    #[test]
    fn boot_takes_levels_without_edges() {
        let mut i = Inputs::new(32);
        i.set_terminal(31, true);
        i.sample();
        i.boot();
        assert_eq!(i.rises(31), Some(0));
        assert_eq!(i.sample().rise, 0);
        assert_eq!(i.levels(), 1 << 31);
    }
}
