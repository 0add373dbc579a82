//! Serial settings and the wire-time model of DESIGN.md ("Timing model").

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

/// Parity of a character.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parity {
    /// No parity bit.
    None,
    /// Even parity.
    Even,
    /// Odd parity.
    Odd,
}

/// The character format: data bits, parity, stop bits (`8E1`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SerialFormat {
    /// 7 or 8.
    pub data_bits: u8,
    /// Parity.
    pub parity: Parity,
    /// 1 or 2.
    pub stop_bits: u8,
}

impl SerialFormat {
    /// 8 data bits, even parity, 1 stop bit: the Modbus recommendation and MiniMod's default.
    pub const EVEN_8E1: Self = Self {
        data_bits: 8,
        parity: Parity::Even,
        stop_bits: 1,
    };

    /// Bits per character on the wire: start + data + parity + stop.
    pub fn bits_per_char(self) -> u32 {
        1 + u32::from(self.data_bits)
            + u32::from(self.parity != Parity::None)
            + u32::from(self.stop_bits)
    }
}

/// Why a format string was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("serial format must look like 8E1, 8N1, 8N2 or 8O1 (data bits 7|8, parity N|E|O, stop bits 1|2)")]
pub struct BadFormat;

impl FromStr for SerialFormat {
    type Err = BadFormat;

    fn from_str(s: &str) -> Result<Self, BadFormat> {
        let b = s.as_bytes();
        if b.len() != 3 {
            return Err(BadFormat);
        }
        let data_bits = match b[0] {
            b'7' => 7,
            b'8' => 8,
            _ => return Err(BadFormat),
        };
        let parity = match b[1].to_ascii_uppercase() {
            b'N' => Parity::None,
            b'E' => Parity::Even,
            b'O' => Parity::Odd,
            _ => return Err(BadFormat),
        };
        let stop_bits = match b[2] {
            b'1' => 1,
            b'2' => 2,
            _ => return Err(BadFormat),
        };
        Ok(Self {
            data_bits,
            parity,
            stop_bits,
        })
    }
}

impl fmt::Display for SerialFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = match self.parity {
            Parity::None => 'N',
            Parity::Even => 'E',
            Parity::Odd => 'O',
        };
        write!(f, "{}{}{}", self.data_bits, p, self.stop_bits)
    }
}

/// Baud rate and format of a line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineSettings {
    /// Bits per second.
    pub baud: u32,
    /// Character format.
    pub format: SerialFormat,
}

impl LineSettings {
    /// 19200 8E1.
    pub const DEFAULT: Self = Self {
        baud: 19200,
        format: SerialFormat::EVEN_8E1,
    };

    /// Time of one character on the wire.
    pub fn char_time(self) -> Duration {
        Duration::from_nanos(
            u64::from(self.format.bits_per_char()) * 1_000_000_000 / u64::from(self.baud),
        )
    }

    /// Time of `n` characters.
    pub fn chars(self, n: usize) -> Duration {
        Duration::from_nanos(
            n as u64 * u64::from(self.format.bits_per_char()) * 1_000_000_000
                / u64::from(self.baud),
        )
    }

    /// The inter-frame silence t3.5: 3.5 characters up to 19200 Bd, a fixed 1.75 ms above
    /// (Modbus over serial line, 2.5.1.1).
    pub fn t3_5(self) -> Duration {
        if self.baud > 19200 {
            Duration::from_micros(1750)
        } else {
            self.chars(7) / 2
        }
    }

    /// The inter-character limit t1.5: 1.5 characters up to 19200 Bd, 0.75 ms above.
    pub fn t1_5(self) -> Duration {
        if self.baud > 19200 {
            Duration::from_micros(750)
        } else {
            self.chars(3) / 2
        }
    }

    /// Silence inside a reply (or an echo) after which it is taken as ended. Modbus says
    /// t1.5; USB adapters and ptys deliver bytes in chunks, so allow some milliseconds.
    pub fn chunk_allowance(self) -> Duration {
        (self.t1_5() * 10).max(Duration::from_millis(5))
    }

    /// One transaction: request + device reply delay + reply + t3.5 (DESIGN.md). With no reply
    /// (a broadcast) the master still keeps the line quiet for the device's turnaround.
    pub fn transaction(
        self,
        request_len: usize,
        reply_delay: Duration,
        reply_len: usize,
    ) -> Duration {
        self.chars(request_len) + reply_delay + self.chars(reply_len) + self.t3_5()
    }
}

impl fmt::Display for LineSettings {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.baud, self.format)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn character_time_at_19200_8e1_is_11_bits() {
        let s = LineSettings::DEFAULT;
        assert_eq!(s.char_time(), Duration::from_nanos(572_916));
        // 3.5 characters at 19200 8E1 = 2.005 ms.
        assert_eq!(s.t3_5(), Duration::from_nanos(2_005_208));
    }

    #[test]
    fn t3_5_is_fixed_above_19200() {
        let s = LineSettings {
            baud: 57600,
            format: SerialFormat::EVEN_8E1,
        };
        assert_eq!(s.t3_5(), Duration::from_micros(1750));
        assert_eq!(s.t1_5(), Duration::from_micros(750));
    }

    #[test]
    fn parses_and_prints_formats() {
        for f in ["8E1", "8N1", "8N2", "8O1", "7E1"] {
            assert_eq!(f.parse::<SerialFormat>().unwrap().to_string(), f);
        }
        assert_eq!("8X1".parse::<SerialFormat>(), Err(BadFormat));
        assert_eq!("8N1".parse::<SerialFormat>().unwrap().bits_per_char(), 10);
    }

    #[test]
    fn transaction_time_sums_the_parts() {
        // FC2 read: 8-byte request, 10 ms delay, 6-byte reply at 19200 8E1.
        let s = LineSettings::DEFAULT;
        let t = s.transaction(8, Duration::from_millis(10), 6);
        assert_eq!(t, s.chars(14) + Duration::from_millis(10) + s.t3_5());
    }
}
