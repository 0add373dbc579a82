//! RESI-2RTD channels (chapter 7), simulated at the register level: the temperature at each
//! sensor is what `softplc sim` sets; the module reports it in the channel's unit with its
//! zero offset added. Not simulated: the ADC, excitation currents, linearisation tables and
//! the measurement rhythm ("around 1 time per second", L5102).
//!
//! - VALID_TEMP is the last valid value, REAL_TEMP the last measurement; a sensor fault makes
//!   REAL_TEMP −999.0 and STATUS the fault bits, VALID_TEMP keeps the last valid value
//!   (L6790–L6812; "-999.0 -> -9990 in °C").
//! - AVG_TEMP is −999.0 until the first AVG_INTERVAL after boot has passed, then the valid
//!   temperature (a constant input averages to itself) (L7140–L7150).
//! - Configuration (SENSOR_TYPE, ZERO_OFFSET, AVG_INTERVAL at 4x06021.., L8714) is stored in
//!   FLASH and is "valid after a REBOOT": writes change the stored value, the module uses it
//!   from the next boot on.

/// The sentinel for "no value" (L6792).
pub(crate) const NO_VALUE: f64 = -999.0;

/// STATUS bit 0: the measurement is valid (L6921).
pub(crate) const STATUS_VALID: u16 = 1;

/// STATUS bit 7: SENSOR HARD FAULT (L6970).
pub(crate) const STATUS_HARD_FAULT: u16 = 0x80;

/// One channel's FLASH configuration.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub(crate) struct Config {
    /// SENSOR_TYPE bitfields: TYPE 0..3, CURRENT 4..7, LINEARISATION 8..11, UNIT 12..15.
    pub sensor_type: u16,
    /// ZERO_OFFSET, °C.
    pub offset: f64,
    /// AVG_INTERVAL, s.
    pub interval: u32,
}

/// One channel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Channel {
    celsius: f64,
    fault: u16,
    last_valid: f64,
    /// Stored in FLASH.
    pub flash: Config,
    active: Config,
}

impl Default for Channel {
    fn default() -> Self {
        Self {
            celsius: 20.0,
            fault: 0,
            last_valid: 20.0,
            flash: Config::default(),
            active: Config::default(),
        }
    }
}

impl Channel {
    fn in_unit(&self, celsius: f64) -> f64 {
        match self.active.sensor_type >> 12 {
            1 => celsius * 9.0 / 5.0 + 32.0,
            2 => celsius + 273.15,
            _ => celsius,
        }
    }

    /// Sets the temperature at the sensor, °C; clears a fault.
    pub(crate) fn set_celsius(&mut self, celsius: f64) {
        self.celsius = celsius;
        self.fault = 0;
        self.last_valid = celsius;
    }

    /// Injects a fault (STATUS bits other than VALID), or clears it with 0.
    pub(crate) fn set_fault(&mut self, bits: u16) {
        self.fault = bits & !STATUS_VALID;
    }

    /// REAL_TEMP in the channel's unit.
    pub(crate) fn real(&self) -> f64 {
        if self.fault != 0 {
            NO_VALUE
        } else {
            self.in_unit(self.celsius + self.active.offset)
        }
    }

    /// VALID_TEMP in the channel's unit.
    pub(crate) fn valid(&self) -> f64 {
        self.in_unit(self.last_valid + self.active.offset)
    }

    /// AVG_TEMP `since_boot_s` seconds after boot.
    pub(crate) fn avg(&self, since_boot_s: u64) -> f64 {
        if since_boot_s < u64::from(self.active.interval) {
            NO_VALUE
        } else {
            self.valid()
        }
    }

    /// AVG_COUNT: measurements in the running window (one per second).
    pub(crate) fn avg_count(&self, since_boot_s: u64) -> u32 {
        match self.active.interval {
            0 => 0,
            i => u32::try_from(since_boot_s % u64::from(i)).unwrap_or(u32::MAX),
        }
    }

    /// AVG_SUM: the sum of the running window.
    pub(crate) fn avg_sum(&self, since_boot_s: u64) -> f64 {
        f64::from(self.avg_count(since_boot_s)) * self.valid()
    }

    /// STATUS.
    pub(crate) fn status(&self) -> u16 {
        if self.fault != 0 {
            self.fault
        } else {
            STATUS_VALID
        }
    }

    /// Boot: the FLASH configuration becomes active.
    pub(crate) fn boot(&mut self) {
        self.active = self.flash;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn units_offset_and_faults() {
        let mut c = Channel::default();
        c.set_celsius(21.5);
        assert_eq!(c.real(), 21.5);
        c.flash.sensor_type = 0x1000;
        c.flash.offset = 0.5;
        assert_eq!(c.real(), 21.5, "FLASH config is valid after a reboot");
        c.boot();
        assert_eq!(c.real(), 22.0 * 9.0 / 5.0 + 32.0);
        c.set_fault(STATUS_HARD_FAULT);
        assert_eq!((c.real(), c.status()), (NO_VALUE, STATUS_HARD_FAULT));
        assert_eq!(c.valid(), 22.0 * 9.0 / 5.0 + 32.0, "last valid kept");
        c.flash.interval = 60;
        c.boot();
        assert_eq!(c.avg(59), NO_VALUE);
        assert_eq!(c.avg(60), c.valid());
        assert_eq!(c.avg_count(61), 1);
    }
}
