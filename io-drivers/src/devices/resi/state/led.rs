//! RESI-1LED / RESI-4LED PWM channels (chapters 8, 9), simulated at the register level: each
//! group of three channels has a MODE (0 OFF, 1 ON, 2 FLASH, 3 FADE, 4 RANDOM, 5 SEQUENCE,
//! L11692–L11722) and the current outputs CLOn follow from it in closed form, so no tick runs:
//!
//! - OFF: 0; ON: LOn.
//! - FLASH: LOn for MINTIME, 0 for MAXTIME, in 1/10 s (L9573–L9578), from the moment the
//!   mode was set.
//! - FADE: from the output value at the last change towards LOn by FADESPEED steps every
//!   1/100 s (L11731–L11737); ISFADING while on the way.
//! - RANDOM and SEQUENCE: not simulated; outputs and RLOn show LOn.
//!
//! "After reset the module starts always in mode ON!" (L9552); the set points and times are
//! kept (undocumented).

/// The largest set point (0x0FFF = 100 %, L11700).
pub(crate) const MAX_LO: u16 = 4095;

/// The highest MODE.
pub(crate) const MAX_MODE: u16 = 5;

/// The LED channels of a module.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct Leds {
    groups: u8,
    lo: [u16; 12],
    mode: [u16; 4],
    fade: [u16; 4],
    min: [u16; 4],
    max: [u16; 4],
    /// Output value when the channel's fade started.
    from: [u16; 12],
    /// When the channel's fade started, ms.
    fade_since: [u64; 12],
    /// When the group's mode was set, ms.
    mode_since: [u64; 4],
}

/// A value the LED registers refuse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct OutOfRange;

/// A group setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GroupSetting {
    /// MODE.
    Mode,
    /// FADESPEED.
    FadeSpeed,
    /// MINTIME.
    MinTime,
    /// MAXTIME.
    MaxTime,
}

impl Leds {
    /// `groups` groups of three channels (at most 4).
    pub(crate) fn new(groups: u8) -> Self {
        Self {
            groups: groups.min(4),
            lo: [0; 12],
            mode: [1; 4],
            fade: [MAX_LO; 4],
            min: [10; 4],
            max: [10; 4],
            from: [0; 12],
            fade_since: [0; 12],
            mode_since: [0; 4],
        }
    }

    fn channels(&self) -> u8 {
        self.groups * 3
    }

    /// LOn (n 0-based).
    pub(crate) fn lo(&self, n: u8) -> Option<u16> {
        (n < self.channels())
            .then(|| self.lo.get(usize::from(n)).copied())
            .flatten()
    }

    /// A group setting of group g (0-based).
    pub(crate) fn group(&self, s: GroupSetting, g: u8) -> Option<u16> {
        if g >= self.groups {
            return None;
        }
        let table = match s {
            GroupSetting::Mode => &self.mode,
            GroupSetting::FadeSpeed => &self.fade,
            GroupSetting::MinTime => &self.min,
            GroupSetting::MaxTime => &self.max,
        };
        table.get(usize::from(g)).copied()
    }

    /// CLOn at `now`.
    pub(crate) fn clo(&self, n: u8, now: u64) -> Option<u16> {
        let lo = self.lo(n)?;
        let i = usize::from(n);
        let g = usize::from(n / 3);
        let mode = *self.mode.get(g)?;
        Some(match mode {
            0 => 0,
            2 => {
                let on = u64::from(*self.min.get(g)?) * 100;
                let off = u64::from(*self.max.get(g)?) * 100;
                let since = *self.mode_since.get(g)?;
                if on + off == 0 || now.saturating_sub(since) % (on + off) < on {
                    lo
                } else {
                    0
                }
            }
            3 => {
                let from = *self.from.get(i)?;
                let ticks = now.saturating_sub(*self.fade_since.get(i)?) / 10;
                let moved = ticks.saturating_mul(u64::from(*self.fade.get(g)?));
                let moved = u16::try_from(moved).unwrap_or(u16::MAX);
                if from < lo {
                    from.saturating_add(moved).min(lo)
                } else {
                    from.saturating_sub(moved).max(lo)
                }
            }
            _ => lo,
        })
    }

    /// ISFADING of group g at `now`.
    pub(crate) fn is_fading(&self, g: u8, now: u64) -> Option<bool> {
        let mode = self.group(GroupSetting::Mode, g)?;
        Some(mode == 3 && (g * 3..g * 3 + 3).any(|n| self.clo(n, now) != self.lo(n)))
    }

    fn restart_fade(&mut self, n: u8, now: u64) {
        let current = self.clo(n, now).unwrap_or(0);
        let i = usize::from(n);
        if let (Some(f), Some(s)) = (self.from.get_mut(i), self.fade_since.get_mut(i)) {
            *f = current;
            *s = now;
        }
    }

    /// Writes LOn at `now`.
    pub(crate) fn set_lo(&mut self, n: u8, value: u16, now: u64) -> Result<(), OutOfRange> {
        if n >= self.channels() || value > MAX_LO {
            return Err(OutOfRange);
        }
        self.restart_fade(n, now);
        if let Some(l) = self.lo.get_mut(usize::from(n)) {
            *l = value;
        }
        Ok(())
    }

    /// Writes a group setting of group g at `now`.
    pub(crate) fn set_group(
        &mut self,
        s: GroupSetting,
        g: u8,
        value: u16,
        now: u64,
    ) -> Result<(), OutOfRange> {
        let ok = g < self.groups
            && match s {
                GroupSetting::Mode => value <= MAX_MODE,
                GroupSetting::FadeSpeed => value >= 1,
                GroupSetting::MinTime | GroupSetting::MaxTime => true,
            };
        if !ok {
            return Err(OutOfRange);
        }
        for n in g * 3..g * 3 + 3 {
            self.restart_fade(n, now);
        }
        let gi = usize::from(g);
        let table = match s {
            GroupSetting::Mode => {
                if let Some(t) = self.mode_since.get_mut(gi) {
                    *t = now;
                }
                &mut self.mode
            }
            GroupSetting::FadeSpeed => &mut self.fade,
            GroupSetting::MinTime => &mut self.min,
            GroupSetting::MaxTime => &mut self.max,
        };
        if let Some(v) = table.get_mut(gi) {
            *v = value;
        }
        Ok(())
    }

    /// Reset: every group in mode ON.
    pub(crate) fn boot(&mut self, now: u64) {
        self.mode = [1; 4];
        self.mode_since = [now; 4];
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes() {
        let mut l = Leds::new(1);
        l.set_lo(0, 4095, 0).unwrap();
        assert_eq!(l.clo(0, 5), Some(4095), "ON");
        l.set_group(GroupSetting::Mode, 0, 0, 10).unwrap();
        assert_eq!(l.clo(0, 10), Some(0), "OFF");
        l.set_group(GroupSetting::FadeSpeed, 0, 1, 10).unwrap();
        l.set_group(GroupSetting::Mode, 0, 3, 100).unwrap();
        assert_eq!(l.clo(0, 100), Some(0));
        assert_eq!(l.clo(0, 200), Some(10), "10 steps in 1/10 s");
        assert_eq!(l.is_fading(0, 200), Some(true));
        assert_eq!(
            l.clo(0, 100 + 40_950),
            Some(4095),
            "40.95 s full scale (L11735)"
        );
        assert_eq!(l.is_fading(0, 100 + 40_950), Some(false));
        l.set_group(GroupSetting::MinTime, 0, 5, 0).unwrap();
        l.set_group(GroupSetting::MaxTime, 0, 5, 0).unwrap();
        l.set_group(GroupSetting::Mode, 0, 2, 1000).unwrap();
        assert_eq!(l.clo(0, 1499), Some(4095), "FLASH on");
        assert_eq!(l.clo(0, 1500), Some(0), "FLASH off");
        assert_eq!(l.clo(0, 2000), Some(4095));
        assert_eq!(l.set_lo(0, 4096, 0), Err(OutOfRange));
        assert_eq!(l.set_group(GroupSetting::Mode, 0, 6, 0), Err(OutOfRange));
        assert_eq!(
            l.set_group(GroupSetting::FadeSpeed, 0, 0, 0),
            Err(OutOfRange)
        );
        assert_eq!(l.lo(3), None);
        l.boot(0);
        assert_eq!(l.group(GroupSetting::Mode, 0), Some(1));
    }
}
