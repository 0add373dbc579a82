//! The MiniMod's preferences: serial line, slave address offset, reply delays, and their copy
//! in flash.
//!
//! Manual, chapter "Configuration of Minimod":
//! - "Setting the communication parameters": `>SERLINE=19200E`; 4800, 9600, 19200, 38400 or
//!   57600 Bd; `E` even parity + 1 stop bit, `O` odd + 1 stop, `N` no parity + 2 stop bits, `X`
//!   no parity + 1 stop; without a letter the parity and stop bits stay. The module replies
//!   with the old settings; the new ones apply only after the `OK`.
//! - "Setting the slave address": the address is the rotary selector (position 0 counts as
//!   16, "RS-485 serial interface") plus MBADD; `>ADDRESS=180` sets MBADD = 180 − selector.
//! - "Setting the reply delay": RDELAYT, 0..=200 hundredths of a second, power-on 1.
//! - "Setting the Modbus communication timeout": RDELAYM, 0..=200 tenths of a millisecond
//!   added to the 28-bit end-of-frame silence.
//! - "Saving setting permanently": `>WCONF=1` writes the preferences to flash; `OK`, or
//!   `Error 1` when the flash fails.
//! - "RS-485 port reset": moving dip-switch 3 from off to on while running loads 19200 8E1
//!   until the next power-up.
//!
//! Choices where the manual is silent:
//! - `>ADDRESS=N` with N below the selector's value stores MBADD = N − selector modulo 256, so
//!   selector + MBADD (wrapping) is still N.
//! - Dip-switch 3 restores the baud rate and the character format only; MBADD and the reply
//!   delays stay.
//! - The flash holds SERLINE, MBADD, RDELAYT and RDELAYM; everything else (latencies, watchdog,
//!   event masks) returns to its power-on value at every power-up.

use std::fmt;

use crate::line::settings::{LineSettings, Parity, SerialFormat};

/// Baud rates `>SERLINE=` accepts.
pub const BAUD_RATES: [u32; 5] = [4800, 9600, 19200, 38400, 57600];

/// Highest RDELAYT and RDELAYM value.
pub const MAX_RDELAY: u8 = 200;

/// Power-on reply delay, hundredths of a second ("Setting the reply delay").
pub const FACTORY_RDELAYT: u8 = 1;

/// The letter after the baud rate of `>SERLINE=`: parity and stop bits (8 data bits always).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum LineMode {
    /// `E`: even parity, 1 stop bit (8E1).
    Even,
    /// `O`: odd parity, 1 stop bit (8O1).
    Odd,
    /// `N`: no parity, 2 stop bits (8N2).
    NoneTwoStops,
    /// `X`: no parity, 1 stop bit (8N1).
    NoneOneStop,
}

impl LineMode {
    /// The manual's letter.
    pub fn letter(self) -> char {
        match self {
            LineMode::Even => 'E',
            LineMode::Odd => 'O',
            LineMode::NoneTwoStops => 'N',
            LineMode::NoneOneStop => 'X',
        }
    }

    /// The mode of a letter (either case).
    pub fn from_letter(c: u8) -> Option<Self> {
        match c.to_ascii_uppercase() {
            b'E' => Some(LineMode::Even),
            b'O' => Some(LineMode::Odd),
            b'N' => Some(LineMode::NoneTwoStops),
            b'X' => Some(LineMode::NoneOneStop),
            _ => None,
        }
    }

    /// The mode whose character format is `format`, if the module has one (8 data bits; even
    /// or odd parity with 1 stop bit, or no parity with 1 or 2).
    pub fn of_format(format: SerialFormat) -> Option<Self> {
        [
            LineMode::Even,
            LineMode::Odd,
            LineMode::NoneTwoStops,
            LineMode::NoneOneStop,
        ]
        .into_iter()
        .find(|m| m.format() == format)
    }

    /// The character format.
    pub fn format(self) -> SerialFormat {
        let (parity, stop_bits) = match self {
            LineMode::Even => (Parity::Even, 1),
            LineMode::Odd => (Parity::Odd, 1),
            LineMode::NoneTwoStops => (Parity::None, 2),
            LineMode::NoneOneStop => (Parity::None, 1),
        };
        SerialFormat {
            data_bits: 8,
            parity,
            stop_bits,
        }
    }
}

/// Why a serial setting was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SerialError {
    /// Not one of [`BAUD_RATES`].
    #[error("baud rate {0} is not 4800, 9600, 19200, 38400 or 57600")]
    Baud(u32),
    /// Not `BAUD` followed by an optional `E`, `O`, `N` or `X`.
    #[error("expected a baud rate and an optional E, O, N or X")]
    Syntax,
}

/// Baud rate and mode, as `>SERLINE=` sets them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct SerialParams {
    /// One of [`BAUD_RATES`].
    pub baud: u32,
    /// Parity and stop bits.
    pub mode: LineMode,
}

impl SerialParams {
    /// 19200 Bd, 8E1: the factory setting and what dip-switch 3 restores.
    pub const FACTORY: Self = Self {
        baud: 19200,
        mode: LineMode::Even,
    };

    /// The line settings these parameters mean.
    pub fn line_settings(self) -> LineSettings {
        LineSettings {
            baud: self.baud,
            format: self.mode.format(),
        }
    }

    /// The parameters for `settings`, if `>SERLINE=` can set them (one of [`BAUD_RATES`] and a
    /// format of [`LineMode`]).
    pub fn of_line_settings(settings: LineSettings) -> Option<Self> {
        let mode = LineMode::of_format(settings.format)?;
        BAUD_RATES.contains(&settings.baud).then_some(Self {
            baud: settings.baud,
            mode,
        })
    }

    /// The parameters a `>SERLINE=` value gives when the current mode is `current` (no letter:
    /// "parity and stop bits remain as before").
    pub fn from_write(baud: u32, mode: Option<LineMode>, current: LineMode) -> Self {
        Self {
            baud,
            mode: mode.unwrap_or(current),
        }
    }

    /// Parses `19200E`, `9600` (the mode then comes from `current`), `57600x`.
    pub fn parse(text: &str, current: LineMode) -> Result<Self, SerialError> {
        let bytes = text.trim().as_bytes();
        let digits = bytes.iter().take_while(|b| b.is_ascii_digit()).count();
        let (number, rest) = bytes.split_at(digits);
        let mode = match rest {
            [] => current,
            [letter] => LineMode::from_letter(*letter).ok_or(SerialError::Syntax)?,
            _ => return Err(SerialError::Syntax),
        };
        if number.is_empty() || number.len() > 6 {
            return Err(SerialError::Syntax);
        }
        let baud = number
            .iter()
            .fold(0u32, |acc, d| acc * 10 + u32::from(d - b'0'));
        if !BAUD_RATES.contains(&baud) {
            return Err(SerialError::Baud(baud));
        }
        Ok(Self { baud, mode })
    }
}

impl fmt::Display for SerialParams {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}{}", self.baud, self.mode.letter())
    }
}

/// The preferences that `>WCONF=1` stores in flash.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Preferences {
    /// Serial line.
    pub serial: SerialParams,
    /// Offset added to the rotary selector.
    pub mbadd: u8,
    /// Reply delay, hundredths of a second.
    pub rdelayt: u8,
    /// Extra end-of-frame silence, tenths of a millisecond.
    pub rdelaym: u8,
}

impl Preferences {
    /// Factory preferences with MBADD = `mbadd`.
    pub fn factory(mbadd: u8) -> Self {
        Self {
            serial: SerialParams::FACTORY,
            mbadd,
            rdelayt: FACTORY_RDELAYT,
            rdelaym: 0,
        }
    }
}

/// Why `>WCONF=1` failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("flash write failed")]
pub struct FlashError;

/// The preferences in use and in flash.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SerialConfig {
    active: Preferences,
    stored: Preferences,
    /// Injected flash failure: `>WCONF=1` answers `Error 1`, FLASHFAIL reads 1.
    flash_broken: bool,
}

impl SerialConfig {
    /// A module whose flash holds `stored`, just powered on.
    pub fn new(stored: Preferences) -> Self {
        Self {
            active: stored,
            stored,
            flash_broken: false,
        }
    }

    /// Power-up: the preferences in flash become active.
    pub fn power_up(&mut self) {
        self.active = self.stored;
    }

    /// The preferences in use.
    pub fn active(&self) -> &Preferences {
        &self.active
    }

    /// The preferences in flash.
    pub fn stored(&self) -> &Preferences {
        &self.stored
    }

    /// The slave address with the rotary selector at `rotary` (0..=15; 0 counts as 16).
    pub fn address(&self, rotary: u8) -> u8 {
        selector_value(rotary).wrapping_add(self.active.mbadd)
    }

    /// `>ADDRESS=N`: MBADD becomes N − selector (wrapping), so the address is N.
    pub fn set_address(&mut self, rotary: u8, address: u8) {
        self.active.mbadd = address.wrapping_sub(selector_value(rotary));
    }

    /// `>SERLINE=`: takes effect at once; the caller has already built its reply.
    pub fn set_serial(&mut self, serial: SerialParams) {
        self.active.serial = serial;
    }

    /// The module is installed for `serial`: set with `>SERLINE=` and saved with `>WCONF=1`
    /// before it went on the line, so it is in use and in flash (a power-up keeps it).
    pub fn install_serial(&mut self, serial: SerialParams) {
        self.active.serial = serial;
        self.stored.serial = serial;
    }

    /// `>RDELAYT=n` (values above 200 are clamped).
    pub fn set_rdelayt(&mut self, hundredths: u8) {
        self.active.rdelayt = hundredths.min(MAX_RDELAY);
    }

    /// `>RDELAYM=n` (values above 200 are clamped).
    pub fn set_rdelaym(&mut self, tenths_ms: u8) {
        self.active.rdelaym = tenths_ms.min(MAX_RDELAY);
    }

    /// Dip-switch 3 moved to on while running: 19200 8E1 until the next power-up.
    pub fn restore_default_serial(&mut self) {
        self.active.serial = SerialParams::FACTORY;
    }

    /// `>WCONF=1`: the active preferences go to flash.
    pub fn save(&mut self) -> Result<(), FlashError> {
        if self.flash_broken {
            return Err(FlashError);
        }
        self.stored = self.active;
        Ok(())
    }

    /// Breaks (or repairs) the flash.
    pub fn set_flash_broken(&mut self, broken: bool) {
        self.flash_broken = broken;
    }

    /// FLASHFAIL.
    pub fn flash_broken(&self) -> bool {
        self.flash_broken
    }
}

/// The address the rotary selector gives: positions 1..=15 as they are, 0 as 16 ("RS-485
/// serial interface").
pub(crate) fn selector_value(rotary: u8) -> u8 {
    match rotary & 0x0F {
        0 => 16,
        n => n,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn serline_forms_of_the_manual() {
        let p = SerialParams::parse("19200E", LineMode::Odd).unwrap();
        assert_eq!(p, SerialParams::FACTORY);
        assert_eq!(p.line_settings(), LineSettings::DEFAULT);
        assert_eq!(p.to_string(), "19200E");
        let keep = SerialParams::parse("9600", LineMode::Odd).unwrap();
        assert_eq!(
            keep.mode,
            LineMode::Odd,
            "no letter: parity and stop bits stay"
        );
        let n = SerialParams::parse("57600n", LineMode::Even).unwrap();
        assert_eq!(n.line_settings().format.to_string(), "8N2");
        let x = SerialParams::parse("4800X", LineMode::Even).unwrap();
        assert_eq!(x.line_settings().format.to_string(), "8N1");
        assert_eq!(
            SerialParams::parse("14400E", LineMode::Even),
            Err(SerialError::Baud(14400))
        );
        for bad in ["", "E", "19200EE", "19200Q", "9999999999", "-9600"] {
            assert!(SerialParams::parse(bad, LineMode::Even).is_err(), "{bad}");
        }
    }

    #[test]
    fn address_is_selector_plus_mbadd() {
        let mut c = SerialConfig::new(Preferences::factory(0));
        assert_eq!(c.address(5), 5);
        assert_eq!(c.address(0), 16);
        c.set_address(0, 180);
        assert_eq!(c.active().mbadd, 164);
        assert_eq!(c.address(0), 180);
        assert_eq!(c.address(1), 165, "the selector still moves the address");
        c.set_address(9, 3);
        assert_eq!(c.address(9), 3, "below the selector: MBADD wraps");
    }

    #[test]
    fn flash_keeps_what_wconf_saved() {
        let mut c = SerialConfig::new(Preferences::factory(0));
        c.set_rdelayt(5);
        c.set_serial(SerialParams::parse("9600N", LineMode::Even).unwrap());
        c.power_up();
        assert_eq!(*c.active(), Preferences::factory(0), "not saved: lost");
        c.set_rdelayt(5);
        c.save().unwrap();
        c.restore_default_serial();
        c.power_up();
        assert_eq!(c.active().rdelayt, 5);
        c.set_flash_broken(true);
        assert_eq!(c.save(), Err(FlashError));
    }
}
