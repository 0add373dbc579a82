//! The RESI-16DI8RO internal logic functions (manual 10.1.1, L16432–L16750), run at every
//! 10 ms input sample.
//!
//! "The IO module offers internal logic functions, which are handled by the module
//! autonomous. … This internal logic functions can operate side by side with control commands
//! via MODBUS/RTU or ASCII." (L16434–L16437). For each relay ROx and each function there is a
//! 16-bit mask, bit n = DI(n+1) (L20986). "Only if this register contains 1, the internal
//! logic is executed" (ENABLE LOGIC FUNCTIONS, L16485, L22516).
//!
//! Per sample, while the logic is enabled, for RO1..RO8 in turn (later steps win; the order
//! of the register blocks, resi-spec §4.5):
//! 1. **SWITCH** (level): the relay takes the level of the mapped input(s) (L16510–L16512);
//!    see [`SwitchMode`] and [`Combine`] for what the manual leaves open.
//! 2. **TOGGLE**: a rising edge on a mapped input inverts the relay, once per sample even if
//!    several mapped inputs rise together (L16685).
//! 3. **SWITCH ON**: a rising edge switches it on (L16566).
//! 4. **SWITCH OFF**: a rising edge switches it off (L16623; "low (1)" at L19072 is a typo).
//! 5. **PULSE**: a rising edge switches it on and (re)starts its timer with PULSE TIME
//!    (1/10 s, L16722); "If you press one of the two buttons again, if the output relay is
//!    on, the time span of 30 seconds starts again" (L16749). When the timer runs out the
//!    relay is switched off (L19805–L19808). Timers count down before the functions run, so
//!    a retrigger in the sample where a pulse ends keeps the relay on. PULSE TIME 0 starts
//!    nothing (undocumented).
//!
//! While the logic is not enabled nothing runs and no timer is kept (writing ENABLE ≠ 1 ends
//! running pulses, the relays stay as they are). CLEAR ALL LOGIC FUNCTIONS zeroes every mask
//! and ENABLE (and PULSE TIME, see [`super::options::Options::clear_pulse_times`]).

use super::item::Func;
use super::options::{Combine, Options, SwitchMode};
use super::state::inputs::Sample;
use super::state::relays::Relays;

/// The logic tables (kept in FRAM, L16434) and the running pulse timers (not kept).
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub(crate) struct Logic {
    masks: [[u16; 8]; 5],
    pulse_time: [u32; 8],
    /// Remaining pulse time, ms; 0 = no pulse running.
    timer_ms: [u64; 8],
    enable: u16,
}

impl Logic {
    /// Whether the logic runs with this ENABLE value.
    pub(crate) fn enabled(&self, opts: &Options) -> bool {
        if opts.enable_exactly_one {
            self.enable == 1
        } else {
            self.enable != 0
        }
    }

    /// A mask of RO(r+1).
    pub(crate) fn mask(&self, f: Func, r: u8) -> Option<u16> {
        self.masks
            .get(f.slot())
            .and_then(|m| m.get(usize::from(r)))
            .copied()
    }

    /// Sets a mask of RO(r+1).
    pub(crate) fn set_mask(&mut self, f: Func, r: u8, mask: u16) {
        if let Some(m) = self
            .masks
            .get_mut(f.slot())
            .and_then(|m| m.get_mut(usize::from(r)))
        {
            *m = mask;
        }
    }

    /// PULSE TIME of RO(r+1), 1/10 s.
    pub(crate) fn pulse_time(&self, r: u8) -> Option<u32> {
        self.pulse_time.get(usize::from(r)).copied()
    }

    /// Sets PULSE TIME of RO(r+1); a running pulse keeps its time.
    pub(crate) fn set_pulse_time(&mut self, r: u8, tenths: u32) {
        if let Some(t) = self.pulse_time.get_mut(usize::from(r)) {
            *t = tenths;
        }
    }

    /// The remaining PULSE TIMER of RO(r+1) in 1/10 s, `idle_ms` after the last sample that
    /// ran (samples that change nothing are skipped, see [`super::state`]); rounded up so
    /// that it reads 0 only when no pulse runs (L21663).
    pub(crate) fn pulse_timer(&self, r: u8, idle_ms: u64) -> Option<u32> {
        self.timer_ms.get(usize::from(r)).map(|ms| {
            let left = if *ms > 0 {
                ms.saturating_sub(idle_ms).max(1)
            } else {
                0
            };
            u32::try_from(left.div_ceil(100)).unwrap_or(u32::MAX)
        })
    }

    /// ENABLE LOGIC FUNCTIONS.
    pub(crate) fn enable(&self) -> u16 {
        self.enable
    }

    /// Writes ENABLE LOGIC FUNCTIONS; running pulses end unless the logic stays enabled.
    pub(crate) fn set_enable(&mut self, value: u16, opts: &Options) {
        self.enable = value;
        if !self.enabled(opts) {
            self.timer_ms = [0; 8];
        }
    }

    /// CLEAR ALL LOGIC FUNCTIONS (4x21002) / `RSTSPCMODE`.
    pub(crate) fn clear(&mut self, opts: &Options) {
        self.masks = [[0; 8]; 5];
        self.enable = 0;
        self.timer_ms = [0; 8];
        if opts.clear_pulse_times {
            self.pulse_time = [0; 8];
        }
    }

    /// A host write switched RO(r+1): a write of 0 ends its pulse (option).
    pub(crate) fn host_wrote(&mut self, r: u8, on: bool, opts: &Options) {
        if !on && opts.host_off_ends_pulse {
            if let Some(t) = self.timer_ms.get_mut(usize::from(r)) {
                *t = 0;
            }
        }
    }

    /// The shortest remaining pulse, ms, if a pulse runs.
    pub(crate) fn next_expiry(&self) -> Option<u64> {
        self.timer_ms.iter().copied().filter(|&t| t > 0).min()
    }

    /// Power-on: the tables are kept; running pulses are lost, and their relays are switched
    /// off or left as they are ([`super::options::PulseAtBoot`]).
    pub(crate) fn boot(&mut self, relays: &mut Relays, opts: &Options) {
        for r in 0..8u8 {
            let running = self.timer_ms.get(usize::from(r)).is_some_and(|&t| t > 0);
            if running && opts.pulse_at_boot == super::options::PulseAtBoot::Off {
                relays.set(r, false);
            }
        }
        self.timer_ms = [0; 8];
    }

    /// One input sample, `elapsed_ms` after the previous one.
    pub(crate) fn scan(
        &mut self,
        s: &Sample,
        elapsed_ms: u64,
        relays: &mut Relays,
        opts: &Options,
    ) {
        if !self.enabled(opts) {
            self.timer_ms = [0; 8];
            return;
        }
        let (now, before, rise) = (s.now as u16, s.before as u16, s.rise as u16);
        for r in 0..relays.count().min(8) {
            let ri = usize::from(r);
            if let Some(t) = self.timer_ms.get_mut(ri) {
                if *t > 0 {
                    *t = t.saturating_sub(elapsed_ms);
                    if *t == 0 {
                        relays.set(r, false);
                    }
                }
            }
            let mask = |f: Func| self.mask(f, r).unwrap_or(0);
            let sw = mask(Func::Switch);
            let changed = (now ^ before) & sw != 0;
            if sw != 0 && (opts.switch == SwitchMode::Level || changed) {
                let on = match opts.combine {
                    Combine::Any => now & sw != 0,
                    // Each mapped input writes its level, DI1 first: the highest one stays.
                    Combine::Last => now & (1 << (15 - sw.leading_zeros())) != 0,
                };
                relays.set(r, on);
            }
            if rise & mask(Func::Toggle) != 0 {
                relays.set(r, !relays.is_on(r));
            }
            if rise & mask(Func::SwitchOn) != 0 {
                relays.set(r, true);
            }
            if rise & mask(Func::SwitchOff) != 0 {
                relays.set(r, false);
            }
            let tenths = self.pulse_time(r).unwrap_or(0);
            if rise & mask(Func::Pulse) != 0 && tenths > 0 {
                relays.set(r, true);
                if let Some(t) = self.timer_ms.get_mut(ri) {
                    *t = u64::from(tenths) * 100;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample(now: u32, before: u32) -> Sample {
        Sample {
            now,
            before,
            rise: now & !before,
            fall: !now & before,
        }
    }

    fn enabled() -> (Logic, Relays, Options) {
        let opts = Options::default();
        let mut l = Logic::default();
        l.set_enable(1, &opts);
        (l, Relays::new(8), opts)
    }

    #[test]
    fn switch_follows_the_level_and_wins_over_host_writes() {
        let (mut l, mut r, opts) = enabled();
        l.set_mask(Func::Switch, 0, 0x0001);
        l.scan(&sample(1, 0), 10, &mut r, &opts);
        assert!(r.is_on(0));
        r.set(0, false); // host write
        l.scan(&sample(1, 1), 10, &mut r, &opts);
        assert!(r.is_on(0), "level mode: forced back at the next sample");
        let change = Options {
            switch: SwitchMode::Change,
            ..Options::default()
        };
        r.set(0, false);
        l.scan(&sample(1, 1), 10, &mut r, &change);
        assert!(!r.is_on(0), "change mode: host write sticks");
        l.scan(&sample(0, 1), 10, &mut r, &opts);
        assert!(!r.is_on(0));
    }

    #[test]
    fn switch_with_several_inputs() {
        let (mut l, mut r, opts) = enabled();
        l.set_mask(Func::Switch, 0, 0b11);
        l.scan(&sample(0b01, 0), 10, &mut r, &opts);
        assert!(!r.is_on(0), "last: DI2 decides");
        let any = Options {
            combine: Combine::Any,
            ..Options::default()
        };
        l.scan(&sample(0b01, 0b01), 10, &mut r, &any);
        assert!(r.is_on(0));
    }

    #[test]
    fn edges_toggle_switch_on_and_off() {
        let (mut l, mut r, opts) = enabled();
        l.set_mask(Func::Toggle, 3, 0b11);
        l.scan(&sample(0b11, 0), 10, &mut r, &opts);
        assert!(r.is_on(3), "two inputs rising together toggle once");
        l.scan(&sample(0b01, 0b11), 10, &mut r, &opts);
        assert!(r.is_on(3), "falling edges do nothing");
        l.scan(&sample(0b11, 0b01), 10, &mut r, &opts);
        assert!(!r.is_on(3));
        l.set_mask(Func::SwitchOn, 1, 0x8000);
        l.set_mask(Func::SwitchOff, 1, 0x4000);
        l.scan(&sample(0x8000, 0), 10, &mut r, &opts);
        assert!(r.is_on(1));
        l.scan(&sample(0xC000, 0x8000), 10, &mut r, &opts);
        assert!(!r.is_on(1));
    }

    #[test]
    fn pulse_is_a_retriggerable_off_delay() {
        let (mut l, mut r, opts) = enabled();
        l.set_mask(Func::Pulse, 0, 0b11);
        l.set_pulse_time(0, 300);
        l.scan(&sample(1, 0), 10, &mut r, &opts);
        assert!(r.is_on(0));
        assert_eq!(l.pulse_timer(0, 0), Some(300));
        l.scan(&sample(0, 1), 20_000, &mut r, &opts);
        assert_eq!(l.pulse_timer(0, 0), Some(100));
        l.scan(&sample(2, 0), 10, &mut r, &opts);
        assert_eq!(l.pulse_timer(0, 0), Some(300), "retriggered");
        l.scan(&sample(2, 2), 29_990, &mut r, &opts);
        assert!(r.is_on(0));
        assert_eq!(l.pulse_timer(0, 0), Some(1));
        l.scan(&sample(2, 2), 10, &mut r, &opts);
        assert!(!r.is_on(0));
        assert_eq!(l.pulse_timer(0, 0), Some(0));
        assert_eq!(l.next_expiry(), None);
    }

    #[test]
    fn enable_must_be_exactly_one() {
        let opts = Options::default();
        let mut l = Logic::default();
        let mut r = Relays::new(8);
        l.set_mask(Func::SwitchOn, 0, 0x8000);
        l.set_enable(0x8000, &opts); // erratum 3
        l.scan(&sample(0x8000, 0), 10, &mut r, &opts);
        assert!(!r.is_on(0));
        let nonzero = Options {
            enable_exactly_one: false,
            ..Options::default()
        };
        l.scan(&sample(0x8000, 0), 10, &mut r, &nonzero);
        assert!(r.is_on(0));
    }

    #[test]
    fn clear_and_disable_end_pulses() {
        let (mut l, mut r, opts) = enabled();
        l.set_mask(Func::Pulse, 0, 1);
        l.set_pulse_time(0, 10);
        l.scan(&sample(1, 0), 10, &mut r, &opts);
        l.set_enable(0, &opts);
        assert_eq!(l.pulse_timer(0, 0), Some(0));
        assert!(r.is_on(0), "the relay stays as it is");
        l.set_enable(1, &opts);
        l.clear(&opts);
        assert_eq!(
            (l.mask(Func::Pulse, 0), l.enable(), l.pulse_time(0)),
            (Some(0), 0, Some(0))
        );
    }
}
