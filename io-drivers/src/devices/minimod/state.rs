//! The MiniMod's inside: inputs with latencies and counters, outputs with pulsers, blinkers
//! and automatic conditions, feedbacks, and the register values, on the module's own 1 ms tick.
//!
//! Protocol-free: the Modbus side ([`super::sim`]) and, later, the text protocol both read and
//! write through [`MiniModState::read`] and [`MiniModState::write`], addressed by
//! [`Item`]. Time is counted in whole ticks of 1 ms since power-on.
//!
//! Behaviour, after the manual:
//! - "Input conditioning": inputs are sampled once a millisecond; a new level must persist for
//!   XLATUP (rising) or XLATDN (falling) ms before the cooked input follows. Modelled as a
//!   per-input counter of consecutive samples that differ from the cooked level; the cooked
//!   level changes at the sample where the counter reaches the latency (a latency of 0 follows
//!   at the next sample). Power-on latencies are 20 ms.
//! - "Digital inputs, latencies and counters": XCOUNT1..3 count rising edges of the cooked
//!   inputs (wrapping at 65536).
//! - "Pulse generation" / "Y1pulse": writing N > 0 turns the output on at once; the pulser counts
//!   down every ms and the output is on while it is non-zero, so it is on for N ms (when written
//!   on a tick boundary). Pulsers have priority over blinkers.
//! - "Automatic continuous blinking": a non-zero YLAMP mask overrides the normal output; bit
//!   *k* is shown during the *k*-th step of about 100 ms. The step index is common to all
//!   outputs and runs freely from power-on (the manual does not say when a pattern starts);
//!   the register reads back as written.
//! - "Automatic output management": at every tick, for each output, if one of its three OFF
//!   conditions holds the output's YWORD bit is cleared, else if one of its ON conditions holds
//!   it is set (OFF has precedence). Conditions are levels, evaluated on the cooked inputs, so
//!   a master write against a holding condition is undone at the next tick.
//! - "Outputs feedback": a feedback bit is 1 while one of its two outputs shows its injected
//!   fault: an open load while the output is off, an overload while it is on.
//! - "Internal watch-dog": while WDTFIRED is set the outputs show WDTYMASK. What fires it
//!   (WDTTIME, feedbacks) is not simulated yet.

use super::map::{condition_holds, Item};

/// Length of one tick of the module's sampling clock, in ms.
pub const TICK_MS: u64 = 1;
/// Length of one blinker step, in ticks ("about a tenth of a second").
pub const BLINK_STEP_MS: u64 = 100;
/// Power-on value of XLATUP1..3 and XLATDN1..3, ms ("Digital inputs, latencies and counters").
pub const POWER_ON_LATENCY_MS: u16 = 20;
/// Highest pulser value the manual allows ("Pulse generation": 1 to 65000 ms).
pub const MAX_PULSE_MS: u16 = 65000;
/// Power-on reply delay, hundredths of a second ("Setting the reply delay": RDELAYT).
pub const POWER_ON_RDELAYT: u8 = 1;

/// A fault injected on an output's load, seen by the module's output monitoring.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fault {
    /// The load is fine.
    #[default]
    None,
    /// Broken load: detected while the output is off.
    OpenLoad,
    /// Over-current or thermal warning: detected while the output is on.
    Overload,
}

/// Why a write was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum WriteError {
    /// The item is read-only (an input, a status bit, the selector).
    #[error("read-only")]
    ReadOnly,
    /// The value is outside the item's range (pulsers: 0..=65000).
    #[error("value {0} out of range")]
    OutOfRange(u16),
}

/// The module's complete state.
#[derive(Debug, Clone)]
pub struct MiniModState {
    /// Ticks run since power-on (the module's time, ms).
    ms: u64,
    /// Levels at the input terminals.
    raw: [bool; 3],
    /// Inputs after latency (X1..X3 as read).
    cooked: [bool; 3],
    /// Consecutive samples where `raw` differed from `cooked`.
    pending: [u32; 3],
    xcount: [u16; 3],
    xlatup: [u16; 3],
    xlatdn: [u16; 3],
    /// Commanded outputs, bits 0..3.
    yword: u16,
    pulse: [u16; 4],
    lamp: [u16; 4],
    aon: [[u16; 3]; 4],
    aoff: [[u16; 3]; 4],
    xevmask: u16,
    yevmask: u16,
    /// EVFB1..2, bits 0..1.
    evfb: u8,
    /// WDTFB1..2 (text FBENABLE), bits 0..1.
    fbenable: u8,
    wdt_fired: bool,
    wdttime: u16,
    wdtymask: u16,
    faults: [Fault; 4],
    sw3: bool,
    sw4: bool,
    /// Rotary selector position, 0..=15.
    rotary: u8,
    /// Address offset (MBADD, "Setting the slave address").
    mbadd: u8,
    /// Reply delay in hundredths of a second.
    rdelayt: u8,
    /// The automatic conditions must be evaluated at the next tick (inputs, outputs or
    /// conditions changed since the last evaluation).
    auto_dirty: bool,
}

impl MiniModState {
    /// A module just powered on, with its selector and MBADD set so that it answers at
    /// `address` (1..=15: that selector position; 16: position 0; above: position 0 and
    /// MBADD = address − 16).
    pub fn new(address: u8) -> Self {
        let (rotary, mbadd) = match address {
            1..=15 => (address, 0),
            _ => (0, address.wrapping_sub(16)),
        };
        Self {
            ms: 0,
            raw: [false; 3],
            cooked: [false; 3],
            pending: [0; 3],
            xcount: [0; 3],
            xlatup: [POWER_ON_LATENCY_MS; 3],
            xlatdn: [POWER_ON_LATENCY_MS; 3],
            yword: 0,
            pulse: [0; 4],
            lamp: [0; 4],
            aon: [[0; 3]; 4],
            aoff: [[0; 3]; 4],
            xevmask: 0,
            yevmask: 0,
            evfb: 0,
            fbenable: 0,
            wdt_fired: false,
            wdttime: 0,
            wdtymask: 0,
            faults: [Fault::None; 4],
            sw3: false,
            sw4: false,
            rotary,
            mbadd,
            rdelayt: POWER_ON_RDELAYT,
            auto_dirty: false,
        }
    }

    /// Switches the module off and on again at the current time: volatile state returns to
    /// its power-on values; the terminals, injected faults, switches and stored preferences
    /// (selector, MBADD, RDELAYT) stay.
    pub fn power_cycle(&mut self) {
        let keep = self.clone();
        *self = Self::new(0);
        self.ms = keep.ms;
        self.raw = keep.raw;
        self.faults = keep.faults;
        self.sw3 = keep.sw3;
        self.sw4 = keep.sw4;
        self.rotary = keep.rotary;
        self.mbadd = keep.mbadd;
        self.rdelayt = keep.rdelayt;
    }

    /// The module's time: ticks run since power-on, in ms.
    pub fn time_ms(&self) -> u64 {
        self.ms
    }

    /// The slave address: the selector's value (position 0 counts as 16) plus MBADD.
    pub fn address(&self) -> u8 {
        let selector = if self.rotary == 0 { 16 } else { self.rotary };
        selector.wrapping_add(self.mbadd)
    }

    /// The rotary selector position, 0..=15.
    pub fn rotary(&self) -> u8 {
        self.rotary
    }

    /// Turns the rotary selector to `position` (0..=15; higher values keep the low 4 bits).
    pub fn set_rotary(&mut self, position: u8) {
        self.rotary = position & 0x0F;
    }

    /// The reply delay setting, in hundredths of a second.
    pub fn rdelayt(&self) -> u8 {
        self.rdelayt
    }

    /// Sets the reply delay (0..=200 hundredths; higher values are clamped to 200).
    pub fn set_rdelayt(&mut self, hundredths: u8) {
        self.rdelayt = hundredths.min(200);
    }

    /// Sets the level at input terminal `x` (0 = X1); other indexes are ignored. The cooked
    /// input follows after the latency.
    pub fn set_terminal(&mut self, x: usize, level: bool) {
        if let Some(r) = self.raw.get_mut(x) {
            *r = level;
        }
    }

    /// The level at input terminal `x` (0 = X1).
    pub fn terminal(&self, x: usize) -> bool {
        self.raw.get(x).copied().unwrap_or(false)
    }

    /// Injects (or clears) a fault on output `y` (0 = Y1); other indexes are ignored.
    pub fn set_fault(&mut self, y: usize, fault: Fault) {
        if let Some(f) = self.faults.get_mut(y) {
            *f = fault;
        }
    }

    /// The fault injected on output `y`.
    pub fn fault(&self, y: usize) -> Fault {
        self.faults.get(y).copied().unwrap_or_default()
    }

    /// Sets dip switch 3 or 4 (`n`); other numbers are ignored.
    pub fn set_switch(&mut self, n: u8, on: bool) {
        match n {
            3 => self.sw3 = on,
            4 => self.sw4 = on,
            _ => {}
        }
    }

    /// The cooked inputs as bits (bit 0 = X1).
    pub fn inputs(&self) -> u8 {
        self.cooked
            .iter()
            .enumerate()
            .fold(0, |acc, (i, &c)| acc | (u8::from(c) << i))
    }

    /// The current blinker step, 0..=15: the bit of YLAMP shown now.
    pub fn blink_step(&self) -> u32 {
        // The remainder is below 16.
        ((self.ms / BLINK_STEP_MS) % 16) as u32
    }

    /// The level at output terminal `y` (0 = Y1): the watchdog's mask while it fires, else the
    /// pulser while it runs, else the blinker when its mask is non-zero, else YWORD.
    pub fn output_level(&self, y: usize) -> bool {
        let bit = |word: u16| y < 16 && word & (1 << y) != 0;
        if self.wdt_fired {
            return bit(self.wdtymask);
        }
        if self.pulse.get(y).is_some_and(|&p| p > 0) {
            return true;
        }
        match self.lamp.get(y) {
            Some(&mask) if mask != 0 => mask & (1 << self.blink_step()) != 0,
            _ => bit(self.yword),
        }
    }

    /// The output terminals as bits (bit 0 = Y1).
    pub fn outputs(&self) -> u8 {
        (0..4).fold(0, |acc, y| acc | (u8::from(self.output_level(y)) << y))
    }

    /// Feedback FB1 (`i` = 0, Y1 + Y2) or FB2 (`i` = 1, Y3 + Y4).
    pub fn feedback(&self, i: usize) -> bool {
        let shows = |y: usize| match self.fault(y) {
            Fault::None => false,
            Fault::OpenLoad => !self.output_level(y),
            Fault::Overload => self.output_level(y),
        };
        i < 2 && (shows(2 * i) || shows(2 * i + 1))
    }

    /// Discrete inputs 0..15 as one word (input register 0): X1..X3 in bits 0..2, FB1/FB2
    /// (X9/X10) in bits 8/9, the rest 0 ("Digital inputs, latencies and counters").
    pub fn input_word(&self) -> u16 {
        u16::from(self.inputs())
            | (u16::from(self.feedback(0)) << 8)
            | (u16::from(self.feedback(1)) << 9)
    }

    /// Reads an item: bits as 0/1, words as they are.
    pub fn read(&self, item: Item) -> u16 {
        let bit = |word: u16, i: u8| u16::from(i < 16 && word & (1 << i) != 0);
        let idx = |i: u8| usize::from(i);
        match item {
            Item::Input(i) => u16::from(self.cooked.get(idx(i)).copied().unwrap_or(false)),
            Item::Feedback(i) => u16::from(self.feedback(idx(i))),
            Item::Output(i) => bit(self.yword, i),
            Item::Yword => self.yword,
            Item::InputWord => self.input_word(),
            Item::Xcount(i) => self.xcount.get(idx(i)).copied().unwrap_or(0),
            Item::XlatUp(i) => self.xlatup.get(idx(i)).copied().unwrap_or(0),
            Item::XlatDn(i) => self.xlatdn.get(idx(i)).copied().unwrap_or(0),
            Item::AutoOn(y, c) => cond(&self.aon, y, c).copied().unwrap_or(0),
            Item::AutoOff(y, c) => cond(&self.aoff, y, c).copied().unwrap_or(0),
            Item::Lamp(i) => self.lamp.get(idx(i)).copied().unwrap_or(0),
            Item::Pulse(i) => self.pulse.get(idx(i)).copied().unwrap_or(0),
            Item::XevMask => self.xevmask,
            Item::YevMask => self.yevmask,
            Item::EvX(i) => bit(self.xevmask, i),
            Item::EvFb(i) => bit(u16::from(self.evfb), i),
            Item::EvY(i) => bit(self.yevmask, i),
            Item::WdtFbEnable(i) => bit(u16::from(self.fbenable), i),
            Item::WdtY(i) => bit(self.wdtymask, i),
            Item::WdtFired => u16::from(self.wdt_fired),
            Item::WdtTime => self.wdttime,
            Item::WdtYMask => self.wdtymask,
            // No Collect event queue, no hardware errors, no watchdog firing cause yet.
            Item::EventsPresent
            | Item::GenericFail
            | Item::FlashFail
            | Item::WdtFb
            | Item::WdtComm => 0,
            Item::Sw3 => u16::from(self.sw3),
            Item::Sw4 => u16::from(self.sw4),
            Item::RotSw => u16::from(self.rotary),
        }
    }

    /// Writes an item as the master does (a bit item takes 0 or non-zero).
    pub fn write(&mut self, item: Item, value: u16) -> Result<(), WriteError> {
        let on = value != 0;
        let set_bit = |word: &mut u16, i: u8| {
            if i < 16 {
                if on {
                    *word |= 1 << i;
                } else {
                    *word &= !(1 << i);
                }
            }
        };
        let idx = |i: u8| usize::from(i);
        match item {
            Item::Output(i) => {
                set_bit(&mut self.yword, i);
                self.yword &= 0x0F;
            }
            Item::Yword => self.yword = value & 0x0F,
            Item::Xcount(i) => store(&mut self.xcount, idx(i), value),
            Item::XlatUp(i) => store(&mut self.xlatup, idx(i), value),
            Item::XlatDn(i) => store(&mut self.xlatdn, idx(i), value),
            Item::AutoOn(y, c) => {
                if let Some(m) = cond_mut(&mut self.aon, y, c) {
                    *m = value;
                }
            }
            Item::AutoOff(y, c) => {
                if let Some(m) = cond_mut(&mut self.aoff, y, c) {
                    *m = value;
                }
            }
            Item::Lamp(i) => store(&mut self.lamp, idx(i), value),
            Item::Pulse(i) => {
                if value > MAX_PULSE_MS {
                    return Err(WriteError::OutOfRange(value));
                }
                store(&mut self.pulse, idx(i), value);
            }
            Item::XevMask => self.xevmask = value,
            Item::YevMask => self.yevmask = value,
            Item::EvX(i) => set_bit(&mut self.xevmask, i),
            Item::EvY(i) => set_bit(&mut self.yevmask, i),
            Item::EvFb(i) => {
                let mut w = u16::from(self.evfb);
                set_bit(&mut w, i);
                self.evfb = (w & 0x03) as u8;
            }
            Item::WdtFbEnable(i) => {
                let mut w = u16::from(self.fbenable);
                set_bit(&mut w, i);
                self.fbenable = (w & 0x03) as u8;
            }
            Item::WdtY(i) => set_bit(&mut self.wdtymask, i),
            Item::WdtFired => self.wdt_fired = on,
            Item::WdtTime => self.wdttime = value,
            Item::WdtYMask => self.wdtymask = value,
            Item::Input(_)
            | Item::Feedback(_)
            | Item::InputWord
            | Item::EventsPresent
            | Item::GenericFail
            | Item::FlashFail
            | Item::WdtFb
            | Item::WdtComm
            | Item::Sw3
            | Item::Sw4
            | Item::RotSw => return Err(WriteError::ReadOnly),
        }
        // Any write may change what the automatic conditions decide.
        self.auto_dirty = true;
        Ok(())
    }

    /// Runs every tick up to and including tick `target_ms` (the module's time becomes
    /// `target_ms`); earlier targets are ignored. Stretches where nothing can change (no
    /// latency counting, no pulser running, conditions settled) are jumped over, and pending
    /// timers are advanced arithmetically to the tick where they act, so the cost is per
    /// event, not per millisecond.
    pub fn advance_to_ms(&mut self, target_ms: u64) {
        while self.ms < target_ms {
            let remaining = target_ms - self.ms;
            if self.auto_dirty {
                self.tick();
                continue;
            }
            match self.ticks_to_next_event() {
                Some(k) if k <= remaining => {
                    self.skip(k - 1);
                    self.tick();
                }
                _ => self.skip(remaining),
            }
        }
    }

    /// One full tick of 1 ms: sample the inputs, apply latencies and counters, evaluate the
    /// automatic conditions, count the pulsers down.
    pub fn tick(&mut self) {
        self.ms += TICK_MS;
        for i in 0..3 {
            let (raw, cooked) = (self.raw[i], self.cooked[i]);
            if raw == cooked {
                self.pending[i] = 0;
                continue;
            }
            self.pending[i] = self.pending[i].saturating_add(1);
            let latency = if raw { self.xlatup[i] } else { self.xlatdn[i] };
            if self.pending[i] >= u32::from(latency) {
                self.cooked[i] = raw;
                self.pending[i] = 0;
                if raw {
                    self.xcount[i] = self.xcount[i].wrapping_add(1);
                }
                self.auto_dirty = true;
            }
        }
        if self.auto_dirty {
            self.apply_conditions();
            self.auto_dirty = false;
        }
        for p in &mut self.pulse {
            *p = p.saturating_sub(1);
        }
    }

    /// Ticks until the next one that changes something other than counters (an input's
    /// latency expires, a pulser reaches 0); `None` when nothing is pending.
    fn ticks_to_next_event(&self) -> Option<u64> {
        let inputs = (0..3).filter(|&i| self.raw[i] != self.cooked[i]).map(|i| {
            let latency = if self.raw[i] {
                self.xlatup[i]
            } else {
                self.xlatdn[i]
            };
            u64::from(u32::from(latency).saturating_sub(self.pending[i]).max(1))
        });
        let pulses = self.pulse.iter().filter(|&&p| p > 0).map(|&p| u64::from(p));
        inputs.chain(pulses).min()
    }

    /// `n` ticks in which no event happens (see [`Self::ticks_to_next_event`]).
    fn skip(&mut self, n: u64) {
        if n == 0 {
            return;
        }
        self.ms += n;
        let step = u32::try_from(n).unwrap_or(u32::MAX);
        for i in 0..3 {
            if self.raw[i] == self.cooked[i] {
                self.pending[i] = 0;
            } else {
                self.pending[i] = self.pending[i].saturating_add(step);
            }
        }
        let step = u16::try_from(n).unwrap_or(u16::MAX);
        for p in &mut self.pulse {
            *p = p.saturating_sub(step);
        }
    }

    /// "Automatic output management": OFF conditions first, then ON.
    fn apply_conditions(&mut self) {
        let inputs = self.inputs();
        for y in 0..4 {
            let holds = |set: &[u16; 3]| set.iter().any(|&m| condition_holds(m, inputs));
            if holds(&self.aoff[y]) {
                self.yword &= !(1 << y);
            } else if holds(&self.aon[y]) {
                self.yword |= 1 << y;
            }
        }
    }
}

fn cond(table: &[[u16; 3]; 4], y: u8, c: u8) -> Option<&u16> {
    table
        .get(usize::from(y))
        .and_then(|row| row.get(usize::from(c)))
}

fn cond_mut(table: &mut [[u16; 3]; 4], y: u8, c: u8) -> Option<&mut u16> {
    table
        .get_mut(usize::from(y))
        .and_then(|row| row.get_mut(usize::from(c)))
}

fn store<const N: usize>(array: &mut [u16; N], i: usize, value: u16) {
    if let Some(slot) = array.get_mut(i) {
        *slot = value;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn state() -> MiniModState {
        MiniModState::new(5)
    }

    /// The cooked level of X1 after every tick up to `until`, advancing one ms at a time.
    fn trace_x1(s: &mut MiniModState, until: u64) -> Vec<bool> {
        let mut out = Vec::new();
        while s.time_ms() < until {
            s.advance_to_ms(s.time_ms() + 1);
            out.push(s.read(Item::Input(0)) != 0);
        }
        out
    }

    #[test]
    fn power_on_values() {
        let s = state();
        assert_eq!(s.read(Item::XlatUp(0)), 20);
        assert_eq!(s.read(Item::XlatDn(2)), 20);
        assert_eq!(s.read(Item::Yword), 0);
        assert_eq!(s.read(Item::RotSw), 5);
        assert_eq!(s.address(), 5);
        assert_eq!(s.rdelayt(), 1);
        assert_eq!(MiniModState::new(16).rotary(), 0);
        assert_eq!(MiniModState::new(16).address(), 16);
        assert_eq!(MiniModState::new(180).address(), 180);
    }

    #[test]
    fn rising_latency_of_20_ms() {
        let mut s = state();
        s.set_terminal(0, true);
        s.advance_to_ms(19);
        assert_eq!(s.read(Item::Input(0)), 0);
        s.advance_to_ms(20);
        assert_eq!(s.read(Item::Input(0)), 1);
        assert_eq!(s.read(Item::Xcount(0)), 1);
    }

    #[test]
    fn spike_of_15_ms_never_shows_with_20_ms_rising_latency() {
        let mut s = state();
        s.set_terminal(0, true);
        let mut seen = trace_x1(&mut s, 15);
        s.set_terminal(0, false);
        seen.extend(trace_x1(&mut s, 100));
        assert!(seen.iter().all(|&x| !x));
        assert_eq!(s.read(Item::Xcount(0)), 0);
    }

    #[test]
    fn falling_latency_of_500_ms_stretches_a_30_ms_pulse() {
        let mut s = state();
        s.write(Item::XlatDn(0), 500).unwrap();
        s.set_terminal(0, true);
        let mut seen = trace_x1(&mut s, 30);
        s.set_terminal(0, false);
        seen.extend(trace_x1(&mut s, 600));
        // seen[k] is the level after tick k + 1: on from tick 20 to tick 529 inclusive.
        let on: Vec<usize> = (0..seen.len())
            .filter(|&k| seen[k])
            .map(|k| k + 1)
            .collect();
        assert_eq!(on.first(), Some(&20));
        assert_eq!(on.last(), Some(&529));
        assert_eq!(on.len(), 510);
    }

    #[test]
    fn zero_latency_follows_at_the_next_sample() {
        let mut s = state();
        s.write(Item::XlatUp(1), 0).unwrap();
        s.set_terminal(1, true);
        assert_eq!(s.read(Item::Input(1)), 0);
        s.advance_to_ms(1);
        assert_eq!(s.read(Item::Input(1)), 1);
    }

    #[test]
    fn counters_count_cooked_rising_edges() {
        let mut s = state();
        for k in 0..5 {
            s.set_terminal(2, true);
            s.advance_to_ms(100 * k + 50);
            s.set_terminal(2, false);
            s.advance_to_ms(100 * k + 100);
        }
        // A spike shorter than the latency is no edge.
        s.set_terminal(2, true);
        s.advance_to_ms(510);
        s.set_terminal(2, false);
        s.advance_to_ms(600);
        assert_eq!(s.read(Item::Xcount(2)), 5);
        s.write(Item::Xcount(2), 0).unwrap();
        assert_eq!(s.read(Item::Xcount(2)), 0);
    }

    #[test]
    fn pulser_keeps_the_output_on_for_exactly_n_ms() {
        let mut s = state();
        s.advance_to_ms(7);
        s.write(Item::Pulse(0), 50).unwrap();
        assert!(s.output_level(0), "on at once");
        let mut off_at = None;
        while s.time_ms() < 200 && off_at.is_none() {
            s.advance_to_ms(s.time_ms() + 1);
            if s.time_ms() == 7 + 49 {
                assert_eq!(s.read(Item::Pulse(0)), 1, "reads back the remaining count");
            }
            if !s.output_level(0) {
                off_at = Some(s.time_ms());
            }
        }
        assert_eq!(off_at, Some(7 + 50), "on from 7 ms to 57 ms");
        assert_eq!(s.read(Item::Pulse(0)), 0);
        assert_eq!(s.read(Item::Yword), 0, "the pulser does not touch YWORD");
    }

    #[test]
    fn pulser_range_is_checked() {
        let mut s = state();
        assert_eq!(
            s.write(Item::Pulse(3), 65001),
            Err(WriteError::OutOfRange(65001))
        );
        assert_eq!(s.write(Item::Pulse(3), 65000), Ok(()));
    }

    #[test]
    fn blinker_rotates_one_bit_per_100_ms() {
        let mut s = state();
        s.write(Item::Lamp(1), 0x00FF).unwrap();
        s.write(Item::Yword, 0).unwrap();
        let mut levels = Vec::new();
        for t in 0..3200 {
            s.advance_to_ms(t);
            levels.push(s.output_level(1));
        }
        // 0x00FF: on for steps 0..7 (800 ms), off for steps 8..15 (800 ms), period 1.6 s.
        assert!(levels[..800].iter().all(|&l| l));
        assert!(levels[800..1600].iter().all(|&l| !l));
        assert!(levels[1600..2400].iter().all(|&l| l));
        assert!(levels[2400..3200].iter().all(|&l| !l));
        assert_eq!(
            s.read(Item::Lamp(1)),
            0x00FF,
            "the mask reads back as written"
        );
    }

    #[test]
    fn blinker_overrides_yword_and_pulser_overrides_blinker() {
        let mut s = state();
        s.write(Item::Yword, 0x0F).unwrap();
        s.write(Item::Lamp(0), 0x0002).unwrap(); // off during step 0
        assert!(!s.output_level(0));
        s.write(Item::Pulse(0), 10).unwrap();
        assert!(s.output_level(0));
        s.advance_to_ms(10);
        assert!(!s.output_level(0));
        s.advance_to_ms(100);
        assert!(s.output_level(0), "step 1 shows bit 1");
        s.write(Item::Lamp(0), 0).unwrap();
        s.advance_to_ms(150);
        assert!(s.output_level(0), "mask 0: YWORD again");
    }

    #[test]
    fn automatic_outputs_off_has_precedence() {
        let mut s = state();
        s.write(Item::XlatUp(0), 0).unwrap();
        s.write(Item::XlatUp(1), 0).unwrap();
        s.write(Item::XlatDn(0), 0).unwrap();
        s.write(Item::XlatDn(1), 0).unwrap();
        // Y1 on when X1; off when X2.
        s.write(Item::AutoOn(0, 0), 0x0001).unwrap();
        s.write(Item::AutoOff(0, 1), 0x0002).unwrap();
        s.set_terminal(0, true);
        s.advance_to_ms(1);
        assert!(s.output_level(0));
        s.set_terminal(1, true);
        s.advance_to_ms(2);
        assert!(!s.output_level(0), "both hold: OFF wins");
        s.set_terminal(1, false);
        s.advance_to_ms(3);
        assert!(s.output_level(0), "only ON holds");
        s.set_terminal(0, false);
        s.advance_to_ms(4);
        assert!(
            s.output_level(0),
            "no condition holds: the output keeps its state"
        );
        s.write(Item::Output(0), 0).unwrap();
        s.advance_to_ms(1000);
        assert!(!s.output_level(0));
    }

    #[test]
    fn manual_condition_example_drives_y1() {
        let mut s = state();
        for i in 0..3 {
            s.write(Item::XlatUp(i), 0).unwrap();
            s.write(Item::XlatDn(i), 0).unwrap();
        }
        // "0000.0010-0000.0011": X1 on and X2 off.
        s.write(Item::AutoOn(0, 0), 0x0203).unwrap();
        s.write(Item::AutoOff(0, 0), 0x0101).unwrap(); // off when X1 is off
        s.set_terminal(0, true);
        s.set_terminal(1, true);
        s.advance_to_ms(5);
        assert!(!s.output_level(0), "X2 on: no");
        s.set_terminal(1, false);
        s.advance_to_ms(6);
        assert!(s.output_level(0), "X1 on, X2 off: on");
        s.set_terminal(0, false);
        s.advance_to_ms(7);
        assert!(!s.output_level(0));
    }

    #[test]
    fn a_master_write_against_a_holding_off_condition_is_undone() {
        let mut s = state();
        s.write(Item::AutoOff(2, 0), 0x0101).unwrap(); // Y3 off while X1 is off
        s.advance_to_ms(1);
        s.write(Item::Output(2), 1).unwrap();
        assert!(s.output_level(2));
        s.advance_to_ms(2);
        assert!(!s.output_level(2));
    }

    #[test]
    fn feedbacks_follow_injected_faults() {
        let mut s = state();
        s.set_fault(1, Fault::OpenLoad);
        assert!(s.feedback(0), "Y2 off with an open load");
        assert_eq!(s.input_word(), 0x0100);
        s.write(Item::Output(1), 1).unwrap();
        assert!(!s.feedback(0), "an open load is not seen while on");
        s.set_fault(3, Fault::Overload);
        assert!(!s.feedback(1));
        s.write(Item::Yword, 0b1010).unwrap(); // Y2 stays on
        assert!(s.feedback(1));
        assert_eq!(s.read(Item::Feedback(1)), 1);
        assert_eq!(s.input_word(), 0x0200);
    }

    #[test]
    fn watchdog_fired_shows_wdtymask() {
        let mut s = state();
        s.write(Item::Yword, 0b0011).unwrap();
        s.write(Item::WdtYMask, 0b0100).unwrap();
        s.write(Item::WdtFired, 1).unwrap();
        assert_eq!(s.outputs(), 0b0100);
        assert_eq!(s.read(Item::WdtY(2)), 1);
        s.write(Item::WdtFired, 0).unwrap();
        assert_eq!(s.outputs(), 0b0011);
    }

    #[test]
    fn bit_aliases_share_their_word() {
        let mut s = state();
        s.write(Item::EvX(1), 1).unwrap();
        assert_eq!(s.read(Item::XevMask), 0b010);
        s.write(Item::YevMask, 0b1001).unwrap();
        assert_eq!(s.read(Item::EvY(3)), 1);
        assert_eq!(s.read(Item::EvY(1)), 0);
        s.write(Item::WdtFbEnable(1), 1).unwrap();
        assert_eq!(s.read(Item::WdtFbEnable(1)), 1);
        assert_eq!(s.write(Item::Sw3, 1), Err(WriteError::ReadOnly));
    }

    #[test]
    fn idle_time_is_jumped_over() {
        let mut s = state();
        s.advance_to_ms(10_000_000_000);
        assert_eq!(s.time_ms(), 10_000_000_000);
        s.set_terminal(0, true);
        s.write(Item::Pulse(2), 65000).unwrap();
        s.advance_to_ms(20_000_000_000);
        assert_eq!(s.read(Item::Input(0)), 1);
        assert_eq!(s.read(Item::Pulse(2)), 0);
    }

    /// Jumping must give exactly what ticking one ms at a time gives.
    #[test]
    fn jumping_equals_ticking() {
        let mut seed = 0x2545_F491_u32;
        let mut rand = move |n: u32| {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed % n
        };
        let mut ticked = state();
        let mut jumped = state();
        let mut t = 0u64;
        for _ in 0..400 {
            // A random action, applied to both at the same time.
            let x = rand(3) as usize;
            let action = rand(6);
            let value = rand(80) as u16;
            for s in [&mut ticked, &mut jumped] {
                match action {
                    0 | 1 => s.set_terminal(x, !s.terminal(x)),
                    2 => s.write(Item::XlatUp(x as u8), value).unwrap(),
                    3 => s.write(Item::XlatDn(x as u8), value).unwrap(),
                    4 => s.write(Item::Pulse(x as u8), value).unwrap(),
                    _ => s.write(Item::AutoOn(x as u8, 0), value & 0x0707).unwrap(),
                }
            }
            t += u64::from(rand(120));
            while ticked.time_ms() < t {
                ticked.tick();
            }
            jumped.advance_to_ms(t);
            assert_eq!(ticked.inputs(), jumped.inputs(), "inputs at {t}");
            assert_eq!(ticked.outputs(), jumped.outputs(), "outputs at {t}");
            for i in 0..3 {
                assert_eq!(ticked.read(Item::Xcount(i)), jumped.read(Item::Xcount(i)));
            }
            for i in 0..4 {
                assert_eq!(ticked.read(Item::Pulse(i)), jumped.read(Item::Pulse(i)));
            }
        }
    }
}
