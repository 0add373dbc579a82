//! Relay outputs RO1..ROn: their state, the 16DI8RO switching-cycle counters ("Remanent
//! counter for each output counting the switching cycles", L15768; "You cannot reset or delete
//! this counter!", L18869) and the 8CO timed pulses (`PULSE ROn` in 100 ms units, L31538;
//! remaining time in ms, L31635).
//!
//! A switching cycle is counted at every actual change of a relay, on or off; writing the
//! state a relay already has does not count (the manual does not define a cycle; resi-spec
//! §4.5).

/// The relays of a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Relays {
    count: u8,
    state: u8,
    counters: [u32; 8],
    /// End of the running 8CO pulse, ms of module time.
    pulse_until: [Option<u64>; 8],
}

impl Relays {
    /// `count` relays (at most 8), all off.
    pub(crate) fn new(count: u8) -> Self {
        Self {
            count: count.min(8),
            state: 0,
            counters: [0; 8],
            pulse_until: [None; 8],
        }
    }

    /// How many relays.
    pub(crate) fn count(&self) -> u8 {
        self.count
    }

    fn mask(&self) -> u8 {
        if self.count >= 8 {
            0xFF
        } else {
            (1u8 << self.count) - 1
        }
    }

    /// Every relay, bit n = RO(n+1).
    pub(crate) fn bits(&self) -> u8 {
        self.state
    }

    /// Whether RO(n+1) is on.
    pub(crate) fn is_on(&self, n: u8) -> bool {
        n < self.count && self.state & (1 << n) != 0
    }

    /// Switches RO(n+1); counts a cycle if it changed.
    pub(crate) fn set(&mut self, n: u8, on: bool) {
        if n >= self.count || self.is_on(n) == on {
            return;
        }
        self.state ^= 1 << n;
        if let Some(c) = self.counters.get_mut(usize::from(n)) {
            *c = c.wrapping_add(1);
        }
    }

    /// Sets every relay from a bit pattern (bits above the relay count are ignored).
    pub(crate) fn set_bits(&mut self, bits: u8) {
        for n in 0..self.count {
            self.set(n, bits & (1 << n) != 0);
        }
        self.state &= self.mask();
    }

    /// Switching cycles of RO(n+1).
    pub(crate) fn counter(&self, n: u8) -> Option<u32> {
        (n < self.count)
            .then(|| self.counters.get(usize::from(n)).copied())
            .flatten()
    }

    /// Starts an 8CO pulse: RO(n+1) on until `until` (ms); `None` cancels and switches off.
    pub(crate) fn pulse(&mut self, n: u8, until: Option<u64>) {
        if n >= self.count {
            return;
        }
        self.set(n, until.is_some());
        if let Some(slot) = self.pulse_until.get_mut(usize::from(n)) {
            *slot = until;
        }
    }

    /// Forgets a running pulse of RO(n+1) without switching (a host write took over).
    pub(crate) fn cancel_pulse(&mut self, n: u8) {
        if let Some(slot) = self.pulse_until.get_mut(usize::from(n)) {
            *slot = None;
        }
    }

    /// Remaining pulse time of RO(n+1) at `now`, ms.
    pub(crate) fn pulse_left(&self, n: u8, now: u64) -> u64 {
        self.pulse_until
            .get(usize::from(n))
            .copied()
            .flatten()
            .map_or(0, |until| until.saturating_sub(now))
    }

    /// Ends the pulses due by `now`.
    pub(crate) fn expire(&mut self, now: u64) {
        for n in 0..self.count {
            let due = self
                .pulse_until
                .get(usize::from(n))
                .copied()
                .flatten()
                .is_some_and(|until| until <= now);
            if due {
                self.pulse(n, None);
            }
        }
    }

    /// Power loss of monostable relays: all off, pulses gone. Not a switching cycle of the
    /// module's doing, but the contacts do open, so it counts like any other change.
    pub(crate) fn drop_all(&mut self) {
        self.pulse_until = [None; 8];
        self.set_bits(0);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_real_changes_only() {
        let mut r = Relays::new(8);
        r.set(0, true);
        r.set(0, true);
        r.set(0, false);
        r.set_bits(0b1000_0001);
        assert_eq!(r.counter(0), Some(3));
        assert_eq!(r.counter(7), Some(1));
        assert_eq!(r.bits(), 0x81);
        r.set(9, true);
        assert_eq!(r.counter(9), None);
    }

    #[test]
    fn pulses_end_on_time() {
        let mut r = Relays::new(8);
        r.pulse(2, Some(1500));
        assert!(r.is_on(2));
        assert_eq!(r.pulse_left(2, 1000), 500);
        r.expire(1499);
        assert!(r.is_on(2));
        r.expire(1500);
        assert!(!r.is_on(2));
        assert_eq!(r.pulse_left(2, 1500), 0);
    }
}
