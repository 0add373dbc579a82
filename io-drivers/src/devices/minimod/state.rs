//! The MiniMod's inside: inputs with latencies and counters, outputs with pulsers, blinkers
//! and automatic conditions, feedbacks, the watchdog, the Collect event queue, the
//! preferences, and the register values, on the module's own 1 ms tick.
//!
//! Protocol-free: the Modbus side ([`super::sim`]) and the text protocol
//! ([`super::sim_text`]) both read and write through [`MiniModState::read`] and
//! [`MiniModState::write`], addressed by [`Item`], plus a few text-only accessors. Time is
//! counted in whole ticks of 1 ms since power-on.
//!
//! Behaviour, after the manual:
//! - "Input conditioning": inputs are sampled once a millisecond; a new level must persist for
//!   XLATUP (rising) or XLATDN (falling) ms before the cooked input follows. Modelled as a
//!   per-input counter of consecutive samples that differ from the cooked level; the cooked
//!   level changes at the sample where the counter reaches the latency (a latency of 0 follows
//!   at the next sample). Power-on latencies are 20 ms.
//! - "Digital inputs, latencies and counters": XCOUNT1..3 count rising edges of the cooked
//!   inputs (wrapping at 65536).
//! - "Pulse generation" / "Y1pulse": writing N > 0 turns the output on at once ("will turn on
//!   Y1 (if not already on)": its YWORD bit is set); the pulser counts down every ms and the
//!   output is on while it is non-zero, so it is on for N ms (when written on a tick
//!   boundary); when the pulser reaches 0 the output is turned off ("and, after 100 ms, will
//!   turn it off"; "set high for 50 ms, and then turned off"): its YWORD bit is cleared, also
//!   when it was on before the pulse. Pulsers have priority over blinkers ("Power outputs,
//!   blinkers, pulsers, and feedbacks") and so over the normal usage: a master write to the
//!   output while the pulse runs changes the YWORD bit but not the terminal, and the pulse's
//!   end turns the output off all the same (the manual is silent on such writes). Writing 0
//!   while a pulse runs ends it there, off. While it runs, the output's status (Y1..Y4, coils
//!   0..3, YWORD, holding register 0: "Shows the status of the indicated output: 1=on, 0=off";
//!   YWORD "Outputs Y1..Y4 status") reads on. A blinker does not show in the status (the
//!   manual does not say it does; the status stays the commanded bit).
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
//! - "Internal watch-dog": see [`super::watchdog`]; checked at every tick after the outputs
//!   settle. While fired the outputs show WDTYMASK.
//! - "Modbus function Collect": see [`super::events`]; variations are looked for at every tick,
//!   after everything else.
//! - "Configuration of Minimod": see [`super::serial_config`]. The simulator also keeps the
//!   serial settings the master uses ([`MiniModState::line`]): while they differ from the
//!   module's own, the module hears only garbage and neither acts nor answers.

use std::time::Duration;

use super::events::{Event, Events};
use super::map::{condition_holds, Item};
use super::serial_config::{FlashError, Preferences, SerialConfig, SerialParams};
use super::watchdog::{Cause, Watchdog, WFLAGS_FIRED};

/// Bit times of silence that end a Modbus request ("Setting the Modbus communication
/// timeout"), before RDELAYM.
pub(crate) const FRAME_SILENCE_BITS: u64 = 28;
/// The silence that ends a request at `baud` for a module that waits `frame_timeout`
/// (RDELAYM) longer than 28 bit times: the simulator frames by it, and the driver leaves it
/// before a request, so the request is not heard as the end of the traffic before it.
pub(crate) fn end_of_request_silence(baud: u32, frame_timeout: Duration) -> Duration {
    Duration::from_nanos(FRAME_SILENCE_BITS * 1_000_000_000 / u64::from(baud.max(1)))
        + frame_timeout
}

/// Length of one tick of the module's sampling clock, in ms.
pub(crate) const TICK_MS: u64 = 1;
/// Length of one blinker step, in ticks ("about a tenth of a second").
pub(crate) const BLINK_STEP_MS: u64 = 100;
/// Power-on value of XLATUP1..3 and XLATDN1..3, ms ("Digital inputs, latencies and counters").
pub(crate) const POWER_ON_LATENCY_MS: u16 = 20;
/// Highest pulser value the manual allows ("Pulse generation": 1 to 65000 ms).
pub(crate) const MAX_PULSE_MS: u16 = 65000;
/// Power-on reply delay, hundredths of a second ("Setting the reply delay": RDELAYT).
pub(crate) const POWER_ON_RDELAYT: u8 = super::serial_config::FACTORY_RDELAYT;

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
    /// The watchdog fires: the outputs cannot be changed until it is reset.
    #[error("the watchdog has fired; outputs are locked until it is reset")]
    WatchdogFired,
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
    watchdog: Watchdog,
    events: Events,
    serial: SerialConfig,
    faults: [Fault; 4],
    sw3: bool,
    sw4: bool,
    /// Rotary selector position, 0..=15.
    rotary: u8,
    /// The serial settings the master talks with (the simulator's view of the line).
    line: SerialParams,
    /// The automatic conditions must be evaluated at the next tick (inputs, outputs or
    /// conditions changed since the last evaluation).
    auto_dirty: bool,
    /// Something changed from outside since the last tick (a write, a terminal, a fault): the
    /// next tick must run in full so the watchdog and the event queue see it.
    touched: bool,
}

impl MiniModState {
    /// A module just powered on, with its selector and MBADD set so that it answers at
    /// `address` (1..=15: that selector position; 16: position 0; above: position 0 and
    /// MBADD = address − 16), factory serial settings, and a master on the same settings.
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
            watchdog: Watchdog::new(0),
            events: Events::new(0, 0),
            serial: SerialConfig::new(Preferences::factory(mbadd)),
            faults: [Fault::None; 4],
            sw3: false,
            sw4: false,
            rotary,
            line: SerialParams::FACTORY,
            auto_dirty: false,
            touched: false,
        }
    }

    /// Switches the module off and on again at the current time: volatile state returns to
    /// its power-on values and the preferences to what the flash holds; the terminals,
    /// injected faults, switches, selector, flash and the master's line settings stay.
    pub fn power_cycle(&mut self) {
        let keep = self.clone();
        *self = Self::new(0);
        self.ms = keep.ms;
        self.raw = keep.raw;
        self.faults = keep.faults;
        self.sw3 = keep.sw3;
        self.sw4 = keep.sw4;
        self.rotary = keep.rotary;
        self.line = keep.line;
        self.serial = keep.serial;
        self.serial.power_up();
        self.watchdog = Watchdog::new(self.ms);
        self.events = Events::new(self.input_word(), u16::from(self.outputs()));
    }

    /// The module's time: ticks run since power-on, in ms.
    pub fn time_ms(&self) -> u64 {
        self.ms
    }

    /// The slave address: the selector's value (position 0 counts as 16) plus MBADD.
    pub fn address(&self) -> u8 {
        self.serial.address(self.rotary)
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
        self.serial.active().rdelayt
    }

    /// Sets the reply delay (0..=200 hundredths; higher values are clamped to 200).
    pub fn set_rdelayt(&mut self, hundredths: u8) {
        self.serial.set_rdelayt(hundredths);
    }

    /// The silence before a reply: RDELAYT hundredths of a second ("Setting the reply delay")
    /// plus RDELAYM tenths of a millisecond, by which the module waits longer for the end of
    /// the request ("Setting the Modbus communication timeout").
    pub fn reply_delay(&self) -> Duration {
        let p = self.serial.active();
        Duration::from_millis(10 * u64::from(p.rdelayt)) + self.frame_timeout()
    }

    /// The silence that ends a request on a line at `baud` (manual, "Setting the Modbus
    /// communication timeout": "a silence on the line, lasting 28 bits or more", enlarged "by
    /// a number of tenths of milliseconds comprised between 0 and 200", RDELAYM).
    pub fn frame_silence(&self, baud: u32) -> Duration {
        end_of_request_silence(baud, self.frame_timeout())
    }

    /// RDELAYM: how much longer than 28 bit times the module waits for the end of a request.
    pub fn frame_timeout(&self) -> Duration {
        Duration::from_micros(100 * u64::from(self.serial.active().rdelaym))
    }

    /// The preferences and the flash.
    pub fn serial(&self) -> &SerialConfig {
        &self.serial
    }

    /// `>ADDRESS=N`: MBADD becomes N − selector.
    pub fn set_address(&mut self, address: u8) {
        self.serial.set_address(self.rotary, address);
    }

    /// `>SERLINE=`: the module's serial settings (in effect for the next frame).
    pub fn set_serial(&mut self, params: SerialParams) {
        self.serial.set_serial(params);
    }

    /// The module is installed for `params` (in use and in flash, see
    /// `SerialConfig::install_serial`), on a line whose master uses them too.
    pub fn install_serial(&mut self, params: SerialParams) {
        self.serial.install_serial(params);
        self.line = params;
    }

    /// `>RDELAYM=n`.
    pub fn set_rdelaym(&mut self, tenths_ms: u8) {
        self.serial.set_rdelaym(tenths_ms);
    }

    /// `>WCONF=1`.
    pub fn save_preferences(&mut self) -> Result<(), FlashError> {
        self.serial.save()
    }

    /// Breaks (or repairs) the flash memory (FLASHFAIL, `Error 1`).
    pub fn set_flash_broken(&mut self, broken: bool) {
        self.serial.set_flash_broken(broken);
    }

    /// The serial settings the master uses on the line.
    pub fn line(&self) -> SerialParams {
        self.line
    }

    /// The master now talks with `params`.
    pub fn set_line(&mut self, params: SerialParams) {
        self.line = params;
    }

    /// Whether the module understands the line: its serial settings are the master's.
    pub fn listening(&self) -> bool {
        self.serial.active().serial == self.line
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
            self.touched = true;
        }
    }

    /// The fault injected on output `y`.
    pub fn fault(&self, y: usize) -> Fault {
        self.faults.get(y).copied().unwrap_or_default()
    }

    /// Sets dip switch 3 or 4 (`n`); other numbers are ignored. Moving switch 3 from off to
    /// on restores 19200 8E1 until the next power-up ("RS-485 port reset").
    pub fn set_switch(&mut self, n: u8, on: bool) {
        match n {
            3 => {
                if on && !self.sw3 {
                    self.serial.restore_default_serial();
                }
                self.sw3 = on;
            }
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
        if self.watchdog.fired() {
            return bit(self.watchdog.mask());
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

    /// FBACKS: FB1 in bit 0, FB2 in bit 1.
    pub fn feedbacks(&self) -> u8 {
        u8::from(self.feedback(0)) | (u8::from(self.feedback(1)) << 1)
    }

    /// Discrete inputs 0..15 as one word (input register 0, text XWORD): X1..X3 in bits 0..2,
    /// FB1/FB2 (X9/X10) in bits 8/9, the rest 0 ("Digital inputs, latencies and counters").
    pub fn input_word(&self) -> u16 {
        u16::from(self.inputs())
            | (u16::from(self.feedback(0)) << 8)
            | (u16::from(self.feedback(1)) << 9)
    }

    /// The watchdog.
    pub fn watchdog(&self) -> &Watchdog {
        &self.watchdog
    }

    /// FBENABLE (text protocol): WDTFB1..2 as bits 0..1.
    pub fn fb_enable(&self) -> u8 {
        self.watchdog.fb_enable()
    }

    /// Writes FBENABLE.
    pub fn set_fb_enable(&mut self, bits: u8) {
        self.watchdog.set_fb_enable(bits);
        self.touched = true;
    }

    /// WFLAGS (text protocol; see `super::watchdog`).
    pub fn wflags(&self) -> u16 {
        self.watchdog.wflags()
    }

    /// Writes WFLAGS: bit 1 clear resets the watchdog (`>WFLAGS=0`), set fires it by hand.
    pub fn write_wflags(&mut self, value: u16) {
        if value & WFLAGS_FIRED != 0 {
            self.fire(Cause::Manual);
        } else {
            self.reset_watchdog();
        }
    }

    /// The event queue.
    pub fn events(&self) -> &Events {
        &self.events
    }

    /// A valid command for this module arrived now: the communication watchdog starts again.
    pub fn on_valid_command(&mut self) {
        self.watchdog.feed(self.ms);
    }

    /// A Collect this module must look at (broadcast or its address): applies the
    /// acknowledgement and returns the event to reply with and the reply's delay in ms.
    pub fn collect(&mut self, first: u8, last: u8, ack: u8, seq: u8) -> Option<(Event, u64)> {
        let me = self.address();
        self.events.collect(me, first, last, ack, seq)
    }

    fn fire(&mut self, cause: Cause) {
        if self.watchdog.fired() {
            return;
        }
        self.watchdog.fire(cause);
        // The outputs stay in the safe state after a reset too, until the master writes them.
        self.yword = self.watchdog.mask() & 0x0F;
        self.pulse = [0; 4];
        self.touched = true;
    }

    fn reset_watchdog(&mut self) {
        self.watchdog.reset(self.ms);
        self.auto_dirty = true;
        self.touched = true;
    }

    /// The outputs' status (YWORD as read): the commanded bits, and on for every output whose
    /// pulser runs ("Y1..Y4": "Shows the status of the indicated output").
    fn status_word(&self) -> u16 {
        let pulsing = self
            .pulse
            .iter()
            .enumerate()
            .fold(0u16, |acc, (y, &p)| acc | (u16::from(p > 0) << y));
        self.yword | pulsing
    }

    /// A pulse of output `y` is over: the output is turned off ("Pulse generation": "and then
    /// turned off"); the automatic conditions look again.
    fn end_pulse(&mut self, y: usize) {
        if y < 4 {
            self.yword &= !(1 << y);
        }
        self.auto_dirty = true;
        self.touched = true;
    }

    /// Counts every running pulser down by `n` ms; a pulse that reaches 0 ends.
    fn count_pulses(&mut self, n: u16) {
        for y in 0..self.pulse.len() {
            let p = self.pulse[y];
            if p > 0 {
                self.pulse[y] = p.saturating_sub(n);
                if self.pulse[y] == 0 {
                    self.end_pulse(y);
                }
            }
        }
    }

    /// Reads an item: bits as 0/1, words as they are.
    pub fn read(&self, item: Item) -> u16 {
        let bit = |word: u16, i: u8| u16::from(i < 16 && word & (1 << i) != 0);
        let idx = |i: u8| usize::from(i);
        let wd = &self.watchdog;
        match item {
            Item::Input(i) => u16::from(self.cooked.get(idx(i)).copied().unwrap_or(false)),
            Item::Feedback(i) => u16::from(self.feedback(idx(i))),
            Item::Output(i) => bit(self.status_word(), i),
            Item::Yword => self.status_word(),
            Item::InputWord => self.input_word(),
            Item::Xcount(i) => self.xcount.get(idx(i)).copied().unwrap_or(0),
            Item::XlatUp(i) => self.xlatup.get(idx(i)).copied().unwrap_or(0),
            Item::XlatDn(i) => self.xlatdn.get(idx(i)).copied().unwrap_or(0),
            Item::AutoOn(y, c) => cond(&self.aon, y, c).copied().unwrap_or(0),
            Item::AutoOff(y, c) => cond(&self.aoff, y, c).copied().unwrap_or(0),
            Item::Lamp(i) => self.lamp.get(idx(i)).copied().unwrap_or(0),
            Item::Pulse(i) => self.pulse.get(idx(i)).copied().unwrap_or(0),
            Item::XevMask => self.events.xevmask(),
            Item::YevMask => self.events.yevmask(),
            Item::EvX(i) => bit(self.events.xevmask(), i),
            Item::EvFb(i) => bit(u16::from(self.events.evfb()), i),
            Item::EvY(i) => bit(self.events.yevmask(), i),
            Item::WdtFbEnable(i) => bit(u16::from(wd.fb_enable()), i),
            Item::WdtY(i) => bit(wd.mask(), i),
            Item::WdtFired => u16::from(wd.fired()),
            Item::WdtTime => wd.time(),
            Item::WdtYMask => wd.mask(),
            Item::EventsPresent => u16::from(self.events.present()),
            // The simulated hardware never fails on its own.
            Item::GenericFail => 0,
            Item::FlashFail => u16::from(self.serial.flash_broken()),
            Item::WdtFb => u16::from(wd.fired_by_feedback()),
            Item::WdtComm => u16::from(wd.fired_by_comm()),
            Item::Sw3 => u16::from(self.sw3),
            Item::Sw4 => u16::from(self.sw4),
            Item::RotSw => u16::from(self.rotary),
        }
    }

    /// Writes an item as the master does (a bit item takes 0 or non-zero).
    pub fn write(&mut self, item: Item, value: u16) -> Result<(), WriteError> {
        let on = value != 0;
        let with_bit = |word: u16, i: u8| -> u16 {
            match (i < 16, on) {
                (false, _) => word,
                (true, true) => word | (1 << i),
                (true, false) => word & !(1 << i),
            }
        };
        let idx = |i: u8| usize::from(i);
        let locked = self.watchdog.fired();
        match item {
            Item::Output(_) | Item::Yword | Item::Pulse(_) if locked => {
                return Err(WriteError::WatchdogFired)
            }
            Item::Output(i) => self.yword = with_bit(self.yword, i) & 0x0F,
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
                let y = idx(i);
                let running = self.pulse.get(y).is_some_and(|&p| p > 0);
                if value > 0 {
                    // "will turn on Y1 (if not already on)".
                    self.yword = with_bit(self.yword, i) & 0x0F;
                    store(&mut self.pulse, y, value);
                } else if running {
                    store(&mut self.pulse, y, 0);
                    self.end_pulse(y);
                }
            }
            Item::XevMask => self.events.set_xevmask(value),
            Item::YevMask => self.events.set_yevmask(value),
            Item::EvX(i) => self.events.set_xevmask(with_bit(self.events.xevmask(), i)),
            Item::EvY(i) => self.events.set_yevmask(with_bit(self.events.yevmask(), i)),
            Item::EvFb(i) => {
                let w = with_bit(u16::from(self.events.evfb()), i);
                self.events.set_evfb((w & 0x03) as u8);
            }
            Item::WdtFbEnable(i) => {
                let w = with_bit(u16::from(self.watchdog.fb_enable()), i);
                self.watchdog.set_fb_enable((w & 0x03) as u8);
            }
            Item::WdtY(i) => self.watchdog.set_mask(with_bit(self.watchdog.mask(), i)),
            Item::WdtFired => {
                if on {
                    self.fire(Cause::Manual);
                } else {
                    self.reset_watchdog();
                }
            }
            Item::WdtTime => self.watchdog.set_time(value),
            Item::WdtYMask => self.watchdog.set_mask(value),
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
        self.touched = true;
        Ok(())
    }

    /// Runs every tick up to and including tick `target_ms` (the module's time becomes
    /// `target_ms`); earlier targets are ignored. Stretches where nothing can change (no
    /// latency counting, no pulser running, no blinker step, no watchdog deadline, conditions
    /// settled) are jumped over, and pending timers are advanced arithmetically to the tick
    /// where they act, so the cost is per event, not per millisecond.
    pub fn advance_to_ms(&mut self, target_ms: u64) {
        while self.ms < target_ms {
            let remaining = target_ms - self.ms;
            if self.auto_dirty || self.touched {
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
    /// automatic conditions, count the pulsers down, run the watchdog, record events.
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
        // Pulsers first, so a pulse that ends here and a condition that holds settle in the
        // same tick.
        self.count_pulses(1);
        if self.auto_dirty {
            // While fired the outputs are locked, conditions included; a reset re-evaluates.
            if !self.watchdog.fired() {
                self.apply_conditions();
            }
            self.auto_dirty = false;
        }
        if let Some(cause) = self.watchdog.due(self.ms, self.feedbacks()) {
            self.fire(cause);
        }
        self.events
            .observe(self.input_word(), u16::from(self.outputs()));
        self.touched = false;
    }

    /// Ticks until the next one that changes something other than counters (an input's
    /// latency expires, a pulser reaches 0, a blinker steps, the watchdog's deadline comes);
    /// `None` when nothing is pending.
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
        let blink = (!self.watchdog.fired() && self.lamp.iter().any(|&m| m != 0))
            .then(|| BLINK_STEP_MS - self.ms % BLINK_STEP_MS);
        let watchdog = self
            .watchdog
            .deadline_ms()
            .map(|d| d.saturating_sub(self.ms).max(1));
        inputs.chain(pulses).chain(blink).chain(watchdog).min()
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
        // No pulser reaches 0 here (that tick is an event), but a pulse that ended would end
        // as in a tick.
        self.count_pulses(u16::try_from(n).unwrap_or(u16::MAX));
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
        assert_eq!(s.read(Item::Yword), 0, "off after the pulse");
    }

    #[test]
    fn the_status_reads_on_while_a_pulse_runs() {
        let mut s = state();
        s.write(Item::Pulse(1), 30).unwrap();
        for t in [0, 1, 29] {
            s.advance_to_ms(t);
            assert_eq!(s.read(Item::Output(1)), 1, "Y2 status at {t} ms");
            assert_eq!(s.read(Item::Yword), 0b0010, "YWORD at {t} ms");
        }
        s.advance_to_ms(30);
        assert_eq!(s.read(Item::Output(1)), 0);
        assert_eq!(s.read(Item::Yword), 0);
        assert!(!s.output_level(1));
    }

    #[test]
    fn a_pulse_on_an_output_already_on_turns_it_off_at_its_end() {
        // "`>Y1PULSE=100` will turn on Y1 (if not already on) and, after 100 ms, will turn it
        // off."
        let mut s = state();
        s.write(Item::Yword, 0b0101).unwrap();
        s.write(Item::Pulse(0), 100).unwrap();
        s.advance_to_ms(99);
        assert!(s.output_level(0));
        assert_eq!(s.read(Item::Yword), 0b0101);
        s.advance_to_ms(100);
        assert!(!s.output_level(0), "off after 100 ms");
        assert_eq!(s.read(Item::Yword), 0b0100, "Y3 untouched");
        s.advance_to_ms(10_000);
        assert_eq!(s.outputs(), 0b0100, "and it stays off");
    }

    #[test]
    fn writes_during_a_pulse() {
        let mut s = state();
        s.write(Item::Pulse(0), 50).unwrap();
        s.advance_to_ms(10);
        // The pulser has priority over the normal usage: Y1 = 0 does not cut the pulse.
        s.write(Item::Output(0), 0).unwrap();
        assert!(s.output_level(0));
        assert_eq!(s.read(Item::Output(0)), 1, "the status shows the pulse");
        // Y1 = 1 during the pulse: the end of the pulse turns it off all the same.
        s.write(Item::Output(0), 1).unwrap();
        s.advance_to_ms(50);
        assert!(!s.output_level(0));
        // YPULSE1 = 0 ends a running pulse at once; with none running it changes nothing.
        s.write(Item::Pulse(0), 5000).unwrap();
        s.advance_to_ms(60);
        s.write(Item::Pulse(0), 0).unwrap();
        assert!(!s.output_level(0));
        assert_eq!(s.read(Item::Yword), 0);
        s.write(Item::Output(2), 1).unwrap();
        s.write(Item::Pulse(2), 0).unwrap();
        assert_eq!(s.read(Item::Yword), 0b0100);
    }

    #[test]
    fn a_holding_condition_turns_the_output_on_again_in_the_tick_the_pulse_ends() {
        let mut s = state();
        s.write(Item::XlatUp(0), 0).unwrap();
        s.set_terminal(0, true);
        s.write(Item::AutoOn(0, 0), 0x0001).unwrap(); // Y1 on while X1
        s.advance_to_ms(5);
        assert!(s.output_level(0));
        s.write(Item::Pulse(0), 20).unwrap();
        let mut levels = Vec::new();
        for t in 6..40 {
            s.advance_to_ms(t);
            levels.push(s.output_level(0));
        }
        assert!(levels.iter().all(|&on| on), "no off glitch: {levels:?}");
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
        assert!(
            !s.output_level(0),
            "mask 0: YWORD again, where the pulse turned Y1 off"
        );
        assert!(s.output_level(1), "Y2 as written");
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
        assert_eq!(
            s.read(Item::WdtComm) + s.read(Item::WdtFb),
            0,
            "fired by hand"
        );
        s.write(Item::WdtFired, 0).unwrap();
        assert_eq!(
            s.outputs(),
            0b0100,
            "still safe after the reset, until written"
        );
        s.write(Item::Yword, 0b0011).unwrap();
        assert_eq!(s.outputs(), 0b0011);
    }

    #[test]
    fn watchdog_is_disabled_at_power_up() {
        let mut s = state();
        s.set_fault(0, Fault::OpenLoad);
        s.advance_to_ms(3_600_000);
        assert_eq!(s.read(Item::WdtFired), 0);
        assert_eq!(s.read(Item::WdtTime), 0);
    }

    #[test]
    fn watchdog_fires_wdttime_after_the_last_valid_command_and_holds_the_mask() {
        let mut s = state();
        s.write(Item::Yword, 0b1111).unwrap();
        s.write(Item::Pulse(1), 5000).unwrap();
        s.write(Item::WdtYMask, 0b1000).unwrap();
        s.write(Item::WdtTime, 25).unwrap(); // 250 ms
        s.on_valid_command();
        s.advance_to_ms(100);
        s.on_valid_command(); // a poll at 100 ms
        s.advance_to_ms(349);
        assert_eq!(s.read(Item::WdtFired), 0, "249 ms of silence");
        s.advance_to_ms(350);
        assert_eq!(
            s.read(Item::WdtFired),
            1,
            "250 ms after the last valid command"
        );
        assert_eq!(s.read(Item::WdtComm), 1);
        assert_eq!(s.read(Item::WdtFb), 0);
        assert_eq!(s.outputs(), 0b1000);
        assert_eq!(s.read(Item::Pulse(1)), 0, "pulsers stop");
        // Locked: outputs cannot be changed until reset.
        assert_eq!(s.write(Item::Yword, 1), Err(WriteError::WatchdogFired));
        assert_eq!(s.write(Item::Output(0), 1), Err(WriteError::WatchdogFired));
        assert_eq!(s.write(Item::Pulse(0), 50), Err(WriteError::WatchdogFired));
        s.on_valid_command();
        s.advance_to_ms(10_000);
        assert_eq!(s.outputs(), 0b1000, "a valid command does not reset it");
        assert_eq!(
            s.wflags(),
            0b1010,
            "WFLAGS: fired (bit 1) by WDTCOMM (bit 3)"
        );
        // ">WFLAGS=0" resets it; the timeout starts again from there.
        s.write_wflags(0);
        assert_eq!(s.read(Item::WdtFired), 0);
        assert_eq!(s.read(Item::WdtComm), 0);
        s.write(Item::Yword, 0b0001).unwrap();
        s.advance_to_ms(10_249);
        assert_eq!(s.outputs(), 0b0001);
        s.advance_to_ms(10_250);
        assert_eq!(s.outputs(), 0b1000, "fires again without commands");
    }

    #[test]
    fn watchdog_fires_from_an_enabled_feedback() {
        let mut s = state();
        s.write(Item::WdtYMask, 0).unwrap();
        s.write(Item::WdtFbEnable(1), 1).unwrap(); // WDTFB2: Y3 + Y4
        s.set_fault(0, Fault::OpenLoad); // FB1: not enabled
        s.advance_to_ms(10);
        assert_eq!(s.read(Item::WdtFired), 0);
        s.write(Item::Yword, 0b0100).unwrap();
        s.set_fault(2, Fault::Overload); // Y3 on and overloaded: FB2
        s.advance_to_ms(11);
        assert_eq!(s.read(Item::WdtFired), 1);
        assert_eq!(s.read(Item::WdtFb), 1);
        assert_eq!(s.outputs(), 0, "WDTYMASK = 0: all off");
        assert_eq!(
            s.feedbacks(),
            0b01,
            "Y3 off: the overload is not seen any more"
        );
        s.write(Item::WdtFired, 0).unwrap();
        s.advance_to_ms(12);
        assert_eq!(s.read(Item::WdtFired), 0, "FB2 is 0 now: stays reset");
    }

    #[test]
    fn automatic_outputs_wait_while_fired() {
        let mut s = state();
        s.write(Item::XlatUp(0), 0).unwrap();
        s.write(Item::AutoOn(0, 0), 0x0001).unwrap();
        s.write(Item::WdtFired, 1).unwrap();
        s.set_terminal(0, true);
        s.advance_to_ms(5);
        assert_eq!(s.read(Item::Yword), 0);
        s.write(Item::WdtFired, 0).unwrap();
        s.advance_to_ms(6);
        assert_eq!(s.read(Item::Yword), 1, "re-evaluated after the reset");
    }

    #[test]
    fn events_record_variations_for_collect() {
        let mut s = state();
        s.write(Item::XlatUp(0), 0).unwrap();
        s.write(Item::XlatDn(0), 0).unwrap();
        s.write(Item::XevMask, 0b001).unwrap();
        s.write(Item::YevMask, 0b0001).unwrap();
        s.write(Item::EvFb(0), 1).unwrap();
        s.set_terminal(0, true);
        s.advance_to_ms(1);
        assert_eq!(s.read(Item::EventsPresent), 1);
        s.write(Item::Pulse(0), 10).unwrap();
        s.advance_to_ms(20);
        s.set_fault(1, Fault::OpenLoad);
        s.advance_to_ms(30);
        let seen: Vec<_> = s
            .events()
            .queued()
            .map(|e| (e.seq, e.kind, e.data))
            .collect();
        assert_eq!(
            seen,
            [
                (1, 2, 0x0001),
                (2, 1, 0b0001),
                (3, 1, 0b0000),
                (4, 2, 0x0101)
            ],
            "X1 up, Y1 pulse on and off, FB1"
        );
        let (event, delay) = s.collect(1, 16, 0, 0).unwrap();
        assert_eq!(
            (event.seq, delay),
            (1, 4 * 3 + 1),
            "slave 5 in window 1..16"
        );
        assert_eq!(
            s.collect(6, 16, 5, 1),
            None,
            "acknowledged, not in window 6..16"
        );
        assert_eq!(s.events().queued().count(), 3);
    }

    #[test]
    fn dip_switch_3_restores_the_serial_line_until_power_up() {
        use super::super::serial_config::{LineMode, SerialParams};
        let mut s = state();
        let slow = SerialParams {
            baud: 9600,
            mode: LineMode::NoneTwoStops,
        };
        s.set_serial(slow);
        s.save_preferences().unwrap();
        assert!(!s.listening(), "the master still talks 19200E");
        s.set_switch(3, true);
        assert!(s.listening(), "19200 8E1 again");
        s.set_switch(3, false);
        s.set_switch(3, true);
        assert!(s.listening());
        s.power_cycle();
        assert_eq!(
            s.serial().active().serial,
            slow,
            "the flash wins at power-up"
        );
        assert!(!s.listening());
        s.set_line(slow);
        assert!(s.listening());
    }

    #[test]
    fn power_cycle_keeps_only_what_wconf_saved() {
        let mut s = MiniModState::new(16);
        s.set_address(180);
        s.set_rdelayt(3);
        assert_eq!((s.address(), s.rdelayt()), (180, 3));
        s.power_cycle();
        assert_eq!((s.address(), s.rdelayt()), (16, 1), "not saved");
        s.set_address(180);
        s.set_rdelaym(20);
        s.save_preferences().unwrap();
        s.power_cycle();
        assert_eq!(s.address(), 180);
        assert_eq!(s.reply_delay(), Duration::from_millis(12));
        s.set_flash_broken(true);
        assert!(s.save_preferences().is_err());
        assert_eq!(s.read(Item::FlashFail), 1);
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
        for s in [&mut ticked, &mut jumped] {
            s.write(Item::XevMask, 0b111).unwrap();
            s.write(Item::YevMask, 0b1111).unwrap();
            s.write(Item::EvFb(0), 1).unwrap();
            s.write(Item::EvFb(1), 1).unwrap();
        }
        for _ in 0..600 {
            // A random action, applied to both at the same time.
            let x = rand(3) as usize;
            let action = rand(11);
            let value = rand(80) as u16;
            for s in [&mut ticked, &mut jumped] {
                // A write refused while the watchdog fires is refused by both.
                let _ = match action {
                    0 | 1 => {
                        s.set_terminal(x, !s.terminal(x));
                        Ok(())
                    }
                    2 => s.write(Item::XlatUp(x as u8), value),
                    3 => s.write(Item::XlatDn(x as u8), value),
                    4 => s.write(Item::Pulse(x as u8), value),
                    5 => s.write(Item::AutoOn(x as u8, 0), value & 0x0707),
                    6 => s.write(Item::Lamp(x as u8), value * 811),
                    7 => {
                        let fault = [Fault::None, Fault::OpenLoad, Fault::Overload][x];
                        s.set_fault(usize::from(value as u8 % 4), fault);
                        Ok(())
                    }
                    8 => s.write(Item::WdtTime, value / 4),
                    9 => s.write(Item::WdtFbEnable(x as u8 % 2), value % 2),
                    _ => {
                        s.on_valid_command();
                        s.write(Item::WdtFired, 0)
                    }
                };
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
            assert_eq!(ticked.wflags(), jumped.wflags(), "watchdog at {t}");
            assert_eq!(ticked.events(), jumped.events(), "events at {t}");
        }
    }
}
