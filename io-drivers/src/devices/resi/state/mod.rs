//! The inside of a simulated RESI module, protocol-free: every [`Item`] of the catalogue, read
//! and written as the host would, on the module's own clock.
//!
//! - Inputs are sampled every 10 ms on a fixed grid (L16833); the 16DI8RO logic runs at each
//!   sample ([`super::logic`]). Time is advanced lazily: a sample that can change nothing
//!   (no terminal or host change since the last one, no pulse running out) is skipped, and a
//!   running pulse is jumped to its end, so hours of idle time cost nothing.
//! - 8CO pulses and the 1RO off-delay end at their exact millisecond.
//! - [`Module::power_cycle`] keeps what the manual says is kept in FRAM or FLASH (16DI8RO:
//!   relay states, logic tables, PULSE TIME, ENABLE, switching counters, L15764–L15768,
//!   L16434; FLASH unit address) and resets the rest (edge counters, L20312; pulse timers;
//!   monostable relays).

pub(crate) mod inputs;
pub(crate) mod led;
pub(crate) mod one_ro;
pub(crate) mod relays;
pub(crate) mod rtd;
pub(crate) mod system;

use super::item::{Item, Kind, Temp};
use super::logic::Logic;
use super::model::{Model, RelayKind};
use super::options::Options;
use super::value::Num;
use inputs::Inputs;
use led::{GroupSetting, Leds};
use one_ro::OneRelay;
use relays::Relays;
use rtd::Channel;
use system::System;

/// The input sampling period, ms (L16833).
pub(crate) const SAMPLE_MS: u64 = 10;

/// Why an access was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum AccessError {
    /// The model has no such item.
    #[error("no such item on this model")]
    Absent,
    /// The item cannot be written.
    #[error("read-only")]
    ReadOnly,
    /// The value does not fit the item.
    #[error("value out of range")]
    OutOfRange,
}

/// A simulated RESI module.
#[derive(Debug, Clone)]
pub(crate) struct Module {
    model: &'static Model,
    /// The simulator options.
    pub opts: Options,
    now: u64,
    booted: u64,
    last_sample: u64,
    /// Something changed that the next sample must see.
    dirty: bool,
    sys: System,
    inputs: Inputs,
    relays: Relays,
    logic: Logic,
    one: OneRelay,
    rtd: [Channel; 2],
    leds: Leds,
}

fn group(kind: Kind) -> Option<GroupSetting> {
    Some(match kind {
        Kind::Mode => GroupSetting::Mode,
        Kind::FadeSpeed => GroupSetting::FadeSpeed,
        Kind::MinTime => GroupSetting::MinTime,
        Kind::MaxTime => GroupSetting::MaxTime,
        _ => return None,
    })
}

fn bit(v: u32, n: u8) -> i64 {
    i64::from(n < 32 && v & (1u32 << n) != 0)
}

impl Module {
    /// A module of `model` just powered on, with FLASH address `address`.
    pub(crate) fn new(model: &'static Model, address: u8) -> Self {
        let opts = Options {
            system_registers: model.system_registers,
            ..Options::default()
        };
        let mut m = Self {
            model,
            opts,
            now: 0,
            booted: 0,
            last_sample: 0,
            dirty: false,
            sys: System::new(model.series, address),
            inputs: Inputs::new(model.hw.inputs),
            relays: Relays::new(model.hw.relays),
            logic: Logic::default(),
            one: OneRelay::default(),
            rtd: [Channel::default(); 2],
            leds: Leds::new(model.hw.led_groups),
        };
        m.boot();
        m
    }

    /// The model.
    pub(crate) fn model(&self) -> &'static Model {
        self.model
    }

    /// Module time, ms.
    pub(crate) fn now(&self) -> u64 {
        self.now
    }

    /// DIP switches and addresses.
    pub(crate) fn system(&self) -> &System {
        &self.sys
    }

    /// The address the module answers at.
    pub(crate) fn address(&self) -> u8 {
        self.sys.address()
    }

    /// Power-on or reboot: volatile state reset, FRAM / FLASH kept.
    fn boot(&mut self) {
        self.sys.boot();
        self.inputs.boot();
        if self.model.hw.relay == RelayKind::Monostable {
            self.relays.drop_all();
        }
        self.logic.boot(&mut self.relays, &self.opts);
        self.one.boot();
        for c in &mut self.rtd {
            c.boot();
        }
        self.leds.boot(self.now);
        self.booted = self.now;
        self.last_sample = self.now;
        self.dirty = false;
    }

    /// Switches the module off and on again.
    pub(crate) fn power_cycle(&mut self) {
        self.boot();
    }

    /// Sets the DIP switches; the module restarts (L17759).
    pub(crate) fn set_dip(&mut self, dip: u8) {
        self.sys.set_dip(dip);
        self.boot();
    }

    /// The DIP switches for changes of address, baud or parity; the module restarts after.
    pub(crate) fn change_switches(&mut self, change: impl FnOnce(&mut System) -> bool) -> bool {
        let ok = change(&mut self.sys);
        if ok {
            self.boot();
        }
        ok
    }

    /// Sets the level at terminal DI(n+1); seen at the next 10 ms sample.
    pub(crate) fn set_terminal(&mut self, n: u8, high: bool) {
        self.inputs.set_terminal(n, high);
        self.dirty = true;
    }

    /// Sets the temperature at sensor `ch` (0-based), °C.
    pub(crate) fn set_temperature(&mut self, ch: u8, celsius: f64) -> Result<(), AccessError> {
        let c = self.channel_mut(ch)?;
        c.set_celsius(celsius);
        Ok(())
    }

    /// Injects a sensor fault (STATUS bits) on channel `ch`, 0 to clear.
    pub(crate) fn set_sensor_fault(&mut self, ch: u8, bits: u16) -> Result<(), AccessError> {
        self.channel_mut(ch)?.set_fault(bits);
        Ok(())
    }

    fn channel(&self, ch: u8) -> Result<&Channel, AccessError> {
        if ch >= self.model.hw.rtd {
            return Err(AccessError::Absent);
        }
        self.rtd.get(usize::from(ch)).ok_or(AccessError::Absent)
    }

    fn channel_mut(&mut self, ch: u8) -> Result<&mut Channel, AccessError> {
        if ch >= self.model.hw.rtd {
            return Err(AccessError::Absent);
        }
        self.rtd.get_mut(usize::from(ch)).ok_or(AccessError::Absent)
    }

    /// When the next input sample must run, if one can change anything.
    fn sample_due(&self) -> Option<u64> {
        if self.model.hw.inputs == 0 {
            return None;
        }
        let grid_next = (self.now / SAMPLE_MS)
            .saturating_add(1)
            .saturating_mul(SAMPLE_MS);
        if self.dirty {
            return Some(grid_next);
        }
        if !self.logic.enabled(&self.opts) {
            return None;
        }
        let ms = self.logic.next_expiry()?;
        let due = ms.div_ceil(SAMPLE_MS).saturating_mul(SAMPLE_MS);
        Some(self.last_sample.saturating_add(due).max(grid_next))
    }

    fn sample(&mut self, t: u64) {
        let elapsed = t.saturating_sub(self.last_sample);
        let s = self.inputs.sample();
        if self.model.hw.logic {
            self.logic.scan(&s, elapsed, &mut self.relays, &self.opts);
        }
        self.last_sample = t;
        self.dirty = false;
    }

    /// Runs the module up to `t` ms; earlier times are ignored.
    pub(crate) fn advance_to(&mut self, t: u64) {
        // At the end of time (saturated arithmetic) a sample may fall on the last one: stop.
        while let Some(due) = self
            .sample_due()
            .filter(|&d| d <= t && (d > self.last_sample || self.dirty))
        {
            self.now = due;
            self.sample(due);
        }
        self.now = self.now.max(t);
        self.relays.expire(self.now);
        self.one.expire(self.now);
    }

    fn has_inputs(&self, n: u8) -> Result<(), AccessError> {
        (n < self.inputs.count())
            .then_some(())
            .ok_or(AccessError::Absent)
    }

    fn has_relay(&self, n: u8) -> Result<(), AccessError> {
        (n < self.relays.count())
            .then_some(())
            .ok_or(AccessError::Absent)
    }

    fn need(&self, present: bool) -> Result<(), AccessError> {
        present.then_some(()).ok_or(AccessError::Absent)
    }

    /// Reads an item as the host would.
    pub(crate) fn read(&self, item: Item) -> Result<Num, AccessError> {
        let n = item.index;
        let hw = self.model.hw;
        let levels = self.inputs.levels();
        let now = self.now;
        let since_boot_s = now.saturating_sub(self.booted) / 1000;
        let int = |v: i64| Ok(Num::Int(v));
        match item.kind {
            Kind::Di => self.has_inputs(n).and_then(|()| int(bit(levels, n))),
            Kind::Dis => self
                .need(hw.inputs > 0)
                .and_then(|()| int(i64::from(levels))),
            Kind::DisWord => self.has_inputs(n.saturating_mul(16)).and_then(|()| {
                let shifted = levels.checked_shr(u32::from(n) * 16).unwrap_or(0);
                int(i64::from(shifted & 0xFFFF))
            }),
            Kind::NegDi => self.has_inputs(n).and_then(|()| int(1 - bit(levels, n))),
            Kind::NegDis => self.need(hw.inputs > 0).and_then(|()| {
                let mask = (1u32 << hw.inputs.min(31)) - 1;
                int(i64::from(!levels & mask))
            }),
            Kind::OrDis => self
                .need(hw.inputs > 0)
                .and_then(|()| int(i64::from(levels != 0))),
            Kind::XorDis => self
                .need(hw.inputs > 0)
                .and_then(|()| int(i64::from(levels.count_ones() % 2 == 1))),
            Kind::AndDis => self.need(hw.inputs > 0).and_then(|()| {
                let mask = (1u32 << hw.inputs.min(31)) - 1;
                int(i64::from(levels & mask == mask))
            }),
            Kind::Rise => self
                .inputs
                .rises(n)
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
            Kind::Fall => self
                .inputs
                .falls(n)
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
            Kind::ResetCounter => self.need(hw.inputs > 0).and_then(|()| int(0)),
            Kind::ClearLogic => self.need(hw.logic).and_then(|()| int(0)),
            Kind::Free | Kind::ResetSystem => int(0),
            Kind::Ro => self
                .has_relay(n)
                .and_then(|()| int(i64::from(self.relays.is_on(n)))),
            Kind::Ros => self
                .need(hw.relays > 0)
                .and_then(|()| int(i64::from(self.relays.bits()))),
            Kind::RoCounter => self.need(hw.relay_counters).and_then(|()| {
                self.relays
                    .counter(n)
                    .map(|c| Num::Int(c.into()))
                    .ok_or(AccessError::Absent)
            }),
            Kind::RelayPulse => self
                .need(hw.relay_pulses)
                .and_then(|()| self.has_relay(n))
                .and_then(|()| {
                    int(i64::try_from(self.relays.pulse_left(n, now).div_ceil(100))
                        .unwrap_or(i64::MAX))
                }),
            Kind::RelayPulseLeft => self
                .need(hw.relay_pulses)
                .and_then(|()| self.has_relay(n))
                .and_then(|()| {
                    int(i64::try_from(self.relays.pulse_left(n, now)).unwrap_or(i64::MAX))
                }),
            Kind::Mask(f) => self.need(hw.logic).and_then(|()| {
                self.logic
                    .mask(f, n)
                    .map(|m| Num::Int(m.into()))
                    .ok_or(AccessError::Absent)
            }),
            Kind::PulseTime => self.need(hw.logic).and_then(|()| {
                self.logic
                    .pulse_time(n)
                    .map(|m| Num::Int(m.into()))
                    .ok_or(AccessError::Absent)
            }),
            Kind::PulseTimer => self.need(hw.logic).and_then(|()| {
                // Samples between the last one that ran and now only counted down.
                let idle = now.saturating_sub(self.last_sample) / SAMPLE_MS * SAMPLE_MS;
                self.logic
                    .pulse_timer(n, idle)
                    .map(|m| Num::Int(m.into()))
                    .ok_or(AccessError::Absent)
            }),
            Kind::EnableLogic => self
                .need(hw.logic)
                .and_then(|()| int(self.logic.enable().into())),
            Kind::Do => self
                .need(hw.one_relay)
                .and_then(|()| int(self.one.output().into())),
            Kind::NegDo => self
                .need(hw.one_relay)
                .and_then(|()| int((!self.one.output()).into())),
            Kind::TrueDo => self
                .need(hw.one_relay)
                .and_then(|()| int(self.one.relay(now).into())),
            Kind::NegTrueDo => self
                .need(hw.one_relay)
                .and_then(|()| int((!self.one.relay(now)).into())),
            Kind::Dos => self.need(hw.one_relay).and_then(|()| {
                int(i64::from(self.one.output()) | (i64::from(self.one.relay(now)) << 1))
            }),
            Kind::NegDos => self.need(hw.one_relay).and_then(|()| {
                int(i64::from(!self.one.output()) | (i64::from(!self.one.relay(now)) << 1))
            }),
            Kind::OffDelayOn => self
                .need(hw.one_relay)
                .and_then(|()| int(self.one.delaying(now).into())),
            Kind::OffDelay => self
                .need(hw.one_relay)
                .and_then(|()| int(self.one.off_delay(now).into())),
            Kind::Dip => self
                .need(n < self.model.series.dips())
                .and_then(|()| int(bit(self.sys.dip().into(), n))),
            Kind::DipWord => int(self.sys.dip().into()),
            Kind::UnitAddress | Kind::SmbAdr => int(self.sys.flash().into()),
            Kind::BusAddress => int(self.sys.address().into()),
            Kind::Temp(t) => self.channel(n).map(|c| {
                Num::Real(match t {
                    Temp::Valid => c.valid(),
                    Temp::Real => c.real(),
                    Temp::Avg => c.avg(since_boot_s),
                })
            }),
            Kind::Status => self.channel(n).map(|c| Num::Int(c.status().into())),
            Kind::AvgSum => self.channel(n).map(|c| Num::Real(c.avg_sum(since_boot_s))),
            Kind::AvgCount => self
                .channel(n)
                .map(|c| Num::Int(c.avg_count(since_boot_s).into())),
            Kind::SensorType => self
                .channel(n)
                .map(|c| Num::Int(c.flash.sensor_type.into())),
            Kind::ZeroOffset => self.channel(n).map(|c| Num::Real(c.flash.offset)),
            Kind::AvgInterval => self.channel(n).map(|c| Num::Int(c.flash.interval.into())),
            Kind::Lo | Kind::Rlo => self
                .leds
                .lo(n)
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
            Kind::Clo => self
                .leds
                .clo(n, now)
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
            Kind::IsFading => self
                .leds
                .is_fading(n, now)
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
            Kind::Mode | Kind::FadeSpeed | Kind::MinTime | Kind::MaxTime => group(item.kind)
                .and_then(|s| self.leds.group(s, n))
                .map(|v| Num::Int(v.into()))
                .ok_or(AccessError::Absent),
        }
    }

    /// Writes an item as the host would (Modbus or ASCII).
    pub(crate) fn write(&mut self, item: Item, value: Num) -> Result<(), AccessError> {
        // Whether the item exists decides between "absent" and the checks below.
        self.read(item)?;
        let n = item.index;
        let now = self.now;
        let v = value.int();
        let in_range = |max: i64| {
            (0..=max)
                .contains(&v)
                .then_some(())
                .ok_or(AccessError::OutOfRange)
        };
        let word = || u16::try_from(v).map_err(|_| AccessError::OutOfRange);
        self.dirty = true;
        match item.kind {
            Kind::Ro => {
                self.host_relay(n, v != 0);
            }
            Kind::Ros => {
                in_range(0xFFFF)?;
                for r in 0..self.relays.count() {
                    self.host_relay(r, v & (1 << r) != 0);
                }
            }
            // A non-zero write resets; 0 does nothing (undocumented, resi-spec §3.2).
            Kind::ResetCounter => {
                in_range(0xFFFF)?;
                if v != 0 {
                    self.inputs.reset_counters();
                }
            }
            // "Writing a value onto this register clears" (L22531): any value.
            Kind::ClearLogic => {
                in_range(0xFFFF)?;
                self.logic.clear(&self.opts);
            }
            Kind::Mask(f) => self.logic.set_mask(f, n, word()?),
            Kind::PulseTime => {
                in_range(0xFFFF_FFFF)?;
                self.logic.set_pulse_time(n, v as u32);
            }
            Kind::EnableLogic => self.logic.set_enable(word()?, &self.opts),
            Kind::RelayPulse => {
                let tenths = word()?;
                let until = (tenths > 0).then(|| now.saturating_add(u64::from(tenths) * 100));
                self.relays.pulse(n, until);
            }
            Kind::Do => self.one.set_output(v != 0),
            Kind::OffDelay => self.one.set_off_delay(word()?, now),
            Kind::ResetSystem => {
                in_range(0xFFFF)?;
                self.boot();
            }
            Kind::UnitAddress => self.sys.set_unit_address(word()?),
            Kind::SmbAdr => {
                in_range(255)?;
                self.sys.smbadr(v as u8);
            }
            Kind::SensorType => {
                let w = word()?;
                self.channel_mut(n)?.flash.sensor_type = w;
            }
            Kind::ZeroOffset => {
                let r = value.real();
                if !r.is_finite() || r.abs() > 21_000.0 {
                    return Err(AccessError::OutOfRange);
                }
                self.channel_mut(n)?.flash.offset = r;
            }
            Kind::AvgInterval => {
                in_range(0xFFFF_FFFF)?;
                self.channel_mut(n)?.flash.interval = v as u32;
            }
            Kind::Lo => {
                let w = word()?;
                self.leds
                    .set_lo(n, w, now)
                    .map_err(|_| AccessError::OutOfRange)?;
            }
            Kind::Mode | Kind::FadeSpeed | Kind::MinTime | Kind::MaxTime => {
                let w = word()?;
                let s = group(item.kind).ok_or(AccessError::Absent)?;
                self.leds
                    .set_group(s, n, w, now)
                    .map_err(|_| AccessError::OutOfRange)?;
            }
            _ => return Err(AccessError::ReadOnly),
        }
        Ok(())
    }

    /// A host write to RO(n+1): it takes over from a running 8CO pulse, and a write of 0
    /// ends a running 16DI8RO PULSE (option `host-off-ends-pulse`).
    fn host_relay(&mut self, n: u8, on: bool) {
        self.relays.cancel_pulse(n);
        self.relays.set(n, on);
        self.logic.host_wrote(n, on, &self.opts);
    }

    /// `RC` / RESET COUNTER.
    pub(crate) fn reset_counters(&mut self) -> Result<(), AccessError> {
        self.need(self.model.hw.inputs > 0)?;
        self.inputs.reset_counters();
        Ok(())
    }

    /// `RSTSPCMODE` / CLEAR ALL LOGIC FUNCTIONS.
    pub(crate) fn clear_logic(&mut self) -> Result<(), AccessError> {
        self.need(self.model.hw.logic)?;
        self.logic.clear(&self.opts);
        self.dirty = true;
        Ok(())
    }

    /// `RST`: a soft reset.
    pub(crate) fn reset(&mut self) {
        self.boot();
    }
}

#[cfg(test)]
mod tests;
