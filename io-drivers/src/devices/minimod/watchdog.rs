//! The MiniMod's internal watchdog: what makes it fire, what it does, how it is reset.
//!
//! Manual, "Internal watch-dog (security and coherency check)", "Outputs feedback", the
//! register tables (WDTFB1..2 coils 112/113, WDTY1..4 / WDTYMASK, WDTFIRED coil 160, WDTTIME
//! holding register 128, WDTFB / WDTCOMM discrete inputs 24/25) and the text identifiers
//! FBENABLE, WDTTIME, WDTMASK, WFLAGS:
//! - communication: with WDTTIME > 0 the module expects a valid command at least every
//!   WDTTIME hundredths of a second; when none came for that long, it fires (WDTCOMM);
//! - feedbacks: a feedback bit (FB1, FB2) that is 1 while its WDTFBn / FBENABLE bit is set
//!   fires it (WDTFB);
//! - when fired, the outputs take WDTYMASK and cannot be changed until the master resets it
//!   (WDTFIRED = 0, or `>WFLAGS=0`);
//! - at power-up it is completely disabled (WDTTIME = 0, FBENABLE = 0).
//!
//! Choices where the manual is silent (the simulator's model of the real module):
//! - A valid command is any frame the module acts on: a Modbus frame with a good CRC for its
//!   address or broadcast (a Collect included), or a well-formed text command for it.
//! - On firing, YWORD takes WDTYMASK and running pulsers stop, so the outputs stay safe after a
//!   reset until the master writes them; the automatic ON/OFF conditions are suspended while
//!   fired. Writes that would change an output (Y1..Y4, YWORD, YPULSE) are refused (Modbus
//!   exception 04, text `Error`); configuration (YLAMP, conditions, masks) may still be written.
//! - Writing WDTFIRED = 1 (or a WFLAGS value with bit 1 set) fires it by hand, with neither
//!   cause flag set.
//! - WFLAGS: bit 1 (weight 2) is WDTFIRED as the manual says; bit 2 (4) is WDTFB and bit 3 (8)
//!   is WDTCOMM, in the order of their discrete inputs; the other bits read 0.
//! - A reset counts as a valid command, so the communication timeout starts again from it; a
//!   feedback that still holds fires again at the next millisecond.

/// WFLAGS bit: the watchdog has fired (manual, "Wflags").
pub(crate) const WFLAGS_FIRED: u16 = 1 << 1;
/// WFLAGS bit: fired because of a feedback (simulator's choice).
pub(crate) const WFLAGS_FB: u16 = 1 << 2;
/// WFLAGS bit: fired because of a communication loss (simulator's choice).
pub(crate) const WFLAGS_COMM: u16 = 1 << 3;

/// Why the watchdog fired.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Cause {
    /// No valid command for WDTTIME (WDTCOMM).
    Comm,
    /// An enabled feedback went to 1 (WDTFB).
    Feedback,
    /// Fired by hand: WDTFIRED = 1 written.
    Manual,
}

/// The watchdog's settings and state.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Watchdog {
    /// WDTTIME, hundredths of a second; 0 disables the communication check.
    time: u16,
    /// WDTFB1..2 (FBENABLE), bits 0..1.
    fb_enable: u8,
    /// WDTYMASK.
    mask: u16,
    fired: bool,
    cause_fb: bool,
    cause_comm: bool,
    /// Module time of the last valid command, ms.
    last_valid_ms: u64,
}

impl Watchdog {
    /// Power-up at module time `now_ms`: disabled.
    pub fn new(now_ms: u64) -> Self {
        Self {
            time: 0,
            fb_enable: 0,
            mask: 0,
            fired: false,
            cause_fb: false,
            cause_comm: false,
            last_valid_ms: now_ms,
        }
    }

    /// A valid command arrived at `now_ms`.
    pub fn feed(&mut self, now_ms: u64) {
        self.last_valid_ms = now_ms;
    }

    /// WDTTIME.
    pub fn time(&self) -> u16 {
        self.time
    }

    /// Sets WDTTIME (hundredths of a second).
    pub fn set_time(&mut self, hundredths: u16) {
        self.time = hundredths;
    }

    /// FBENABLE: bit 0 = WDTFB1, bit 1 = WDTFB2.
    pub fn fb_enable(&self) -> u8 {
        self.fb_enable
    }

    /// Sets FBENABLE (bits above 1 are dropped).
    pub fn set_fb_enable(&mut self, bits: u8) {
        self.fb_enable = bits & 0x03;
    }

    /// WDTYMASK.
    pub fn mask(&self) -> u16 {
        self.mask
    }

    /// Sets WDTYMASK.
    pub fn set_mask(&mut self, mask: u16) {
        self.mask = mask;
    }

    /// WDTFIRED.
    pub fn fired(&self) -> bool {
        self.fired
    }

    /// WDTFB.
    pub fn fired_by_feedback(&self) -> bool {
        self.cause_fb
    }

    /// WDTCOMM.
    pub fn fired_by_comm(&self) -> bool {
        self.cause_comm
    }

    /// WFLAGS as the text protocol reads it.
    pub fn wflags(&self) -> u16 {
        let bit = |on: bool, b: u16| if on { b } else { 0 };
        bit(self.fired, WFLAGS_FIRED)
            | bit(self.cause_fb, WFLAGS_FB)
            | bit(self.cause_comm, WFLAGS_COMM)
    }

    /// The module time at which the communication check fires, if it is armed.
    pub fn deadline_ms(&self) -> Option<u64> {
        (self.time > 0 && !self.fired)
            .then(|| self.last_valid_ms.saturating_add(u64::from(self.time) * 10))
    }

    /// Whether it must fire at module time `now_ms` with feedback bits `feedbacks` (bit 0 =
    /// FB1), and why; `None` when it holds or has already fired.
    pub fn due(&self, now_ms: u64, feedbacks: u8) -> Option<Cause> {
        if self.fired {
            None
        } else if feedbacks & self.fb_enable != 0 {
            Some(Cause::Feedback)
        } else if self.deadline_ms().is_some_and(|d| now_ms >= d) {
            Some(Cause::Comm)
        } else {
            None
        }
    }

    /// Fires for `cause` (no effect if already fired).
    pub fn fire(&mut self, cause: Cause) {
        if self.fired {
            return;
        }
        self.fired = true;
        self.cause_fb = cause == Cause::Feedback;
        self.cause_comm = cause == Cause::Comm;
    }

    /// The master's reset at `now_ms`.
    pub fn reset(&mut self, now_ms: u64) {
        self.fired = false;
        self.cause_fb = false;
        self.cause_comm = false;
        self.last_valid_ms = now_ms;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn disabled_at_power_up() {
        let w = Watchdog::new(0);
        assert_eq!(w.deadline_ms(), None);
        assert_eq!(w.due(1_000_000, 0b11), None, "FBENABLE is 0");
        assert!(!w.fired());
    }

    #[test]
    fn communication_timeout_counts_from_the_last_valid_command() {
        let mut w = Watchdog::new(0);
        w.set_time(50); // 0.5 s
        w.feed(100);
        assert_eq!(w.deadline_ms(), Some(600));
        assert_eq!(w.due(599, 0), None);
        assert_eq!(w.due(600, 0), Some(Cause::Comm));
        w.fire(Cause::Comm);
        assert!(w.fired() && w.fired_by_comm() && !w.fired_by_feedback());
        assert_eq!(w.wflags(), WFLAGS_FIRED | WFLAGS_COMM);
        assert_eq!(w.deadline_ms(), None, "already fired");
        w.reset(700);
        assert_eq!(w.wflags(), 0);
        assert_eq!(w.deadline_ms(), Some(1200));
    }

    #[test]
    fn feedback_fires_only_when_enabled() {
        let mut w = Watchdog::new(0);
        w.set_fb_enable(0b10);
        assert_eq!(w.due(1, 0b01), None);
        assert_eq!(w.due(2, 0b10), Some(Cause::Feedback));
        w.fire(Cause::Feedback);
        assert_eq!(w.due(3, 0b10), None, "already fired");
        assert_eq!(w.wflags(), WFLAGS_FIRED | WFLAGS_FB);
        w.set_fb_enable(0xFF);
        assert_eq!(w.fb_enable(), 0b11);
    }
}
