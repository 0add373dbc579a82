//! The RESI-1RO output (chapter 6): the commanded output DO1 and the off-delay timer OFFDLY.
//!
//! The true relay state TDO1 is "the current state of the relay including offdelay timers"
//! (L3965): on while DO1 is on or the off-delay runs. `SOFFDLY:<ms>` (or a write of 4x00005)
//! "activates the output relay for" that time, and a new write within it restarts it; "If no
//! command is received within 5 seconds, the module switches off the relay" (L4102–L4110):
//! the module's only communication watchdog. Writing 0 ends the timer.

/// DO1 and its off-delay.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub(crate) struct OneRelay {
    do1: bool,
    /// End of the off-delay, ms of module time.
    until: Option<u64>,
}

impl OneRelay {
    /// DO1, the commanded output.
    pub(crate) fn output(&self) -> bool {
        self.do1
    }

    /// Commands DO1 (`SDO1`: "!=0: Digital output 1 is ON", L4092).
    pub(crate) fn set_output(&mut self, on: bool) {
        self.do1 = on;
    }

    /// Starts (or restarts, or with 0 ends) the off-delay at `now`.
    pub(crate) fn set_off_delay(&mut self, ms: u16, now: u64) {
        self.until = (ms > 0).then(|| now.saturating_add(u64::from(ms)));
    }

    /// Remaining off-delay at `now`, ms.
    pub(crate) fn off_delay(&self, now: u64) -> u16 {
        self.until.map_or(0, |u| {
            u16::try_from(u.saturating_sub(now)).unwrap_or(u16::MAX)
        })
    }

    /// Whether the off-delay runs at `now`.
    pub(crate) fn delaying(&self, now: u64) -> bool {
        self.off_delay(now) > 0
    }

    /// The true relay state at `now`.
    pub(crate) fn relay(&self, now: u64) -> bool {
        self.do1 || self.delaying(now)
    }

    /// Forgets a timer that has run out by `now`.
    pub(crate) fn expire(&mut self, now: u64) {
        if !self.delaying(now) {
            self.until = None;
        }
    }

    /// Power-on: the relay is monostable and nothing is remembered.
    pub(crate) fn boot(&mut self) {
        *self = Self::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn off_delay_is_a_watchdog() {
        let mut o = OneRelay::default();
        o.set_off_delay(5000, 1000);
        assert!(o.relay(5999));
        o.set_off_delay(5000, 5999);
        assert!(o.relay(10_998));
        assert!(!o.relay(10_999));
        assert_eq!(o.off_delay(8000), 2999);
        o.set_output(true);
        o.set_off_delay(0, 8000);
        assert!(o.relay(20_000) && !o.delaying(8000));
    }
}
