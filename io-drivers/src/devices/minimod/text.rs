//! The MiniMod text protocol, both sides: parsing commands and formatting replies (simulator),
//! formatting commands and parsing replies (driver).
//!
//! Manual, "Text commands protocol", "Slave addressing", "Read commands table (text mode)",
//! "Write commands table (text mode)" and "Configuration of Minimod":
//! - a command is ASCII ended by CR; spaces and LF are ignored; case does not matter;
//! - at most 76 characters: more, until the next CR, are discarded;
//! - `?ID` reads, `>ID=V` writes; an optional `@N` (N ≠ 0) addresses one slave;
//! - a read is answered `ID=value` with 1, 3 or 5 digits as the identifier's type says, a
//!   write `OK`; an error `Error` (`Error 1` for a failed `>WCONF=1`); a malformed packet (not
//!   starting with `?` or `>`) gets no reply;
//! - write values are unsigned decimal, leading zeros allowed: 0 or 1 for a bit (only a single
//!   digit for Y1..Y4), 0..=65535 otherwise; conditions are input names (`X1X2`, `X2-X3`),
//!   an empty value clears one.
//!
//! Choices where the manual is silent:
//! - Identifiers are those of the two tables (the read table lists what can be read: AON/AOFF
//!   conditions, SERLINE, RDELAYT, RDELAYM and WCONF are write-only and reading them is an
//!   `Error`; DEVICE, XWORD, X1..X10, FBACKS, SW3/SW4 are read-only and writing them is an
//!   `Error`).
//! - Widths: bits and FBENABLE 1 digit (the manual's "FBENABLE=3"), ADDRESS and WFLAGS 3
//!   (UINT8, "ADDRESS=034"), everything else 5 (UINT16, "XWORD=00003"). DEVICE answers
//!   `DEVICE=MINIMOD 1.1`.
//! - Ranges beyond 0..=65535: ADDRESS 1..=247 ("Setting the slave address"), RDELAYT and
//!   RDELAYM 0..=200, WCONF only 1, FBENABLE 0..=3, Y1PULSE..Y4PULSE 0..=65000 ("Pulse
//!   generation"; 0 stops a pulse).
//! - The 76 characters are counted after dropping spaces and LF (they are ignored, so never
//!   stored).
//! - `@N` accepts 1..=255 (MBADD makes 248..=255 reachable); `@0`, `@` without digits or
//!   more than three digits are malformed. Without `@` every module executes and answers,
//!   as the manual's single-device examples do.
//! - The manual's "To clear a condition ... `>Y2=`" is read as `>Y2AON1=` (an empty value
//!   for Y2 itself is an `Error`, since Y1..Y4 take exactly one digit).

use std::fmt;

use super::map::{parse_condition, ConditionError};
use super::serial_config::{LineMode, BAUD_RATES};

/// The byte that ends commands and replies.
pub(crate) const TERMINATOR: u8 = b'\r';
/// Longest message, in characters.
pub(crate) const MAX_MESSAGE: usize = 76;
/// What `?DEVICE` returns ("Device").
pub(crate) const DEVICE_NAME: &str = "MINIMOD 1.1";
/// Reply to a write that succeeded.
pub(crate) const OK: &str = "OK";
/// Reply to a refused command.
pub(crate) const ERROR: &str = "Error";
/// Reply to a `>WCONF=1` whose flash write failed.
pub(crate) const FLASH_ERROR: &str = "Error 1";

/// A text-protocol identifier. Indexes are 0-based (`X(0)` is X1, `AutoOn(2, 1)` is Y3AON2).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum TextId {
    /// ADDRESS: the slave address (read), or MBADD through it (write).
    Address,
    /// DEVICE: name and version.
    Device,
    /// XWORD: the inputs as a mask (X1..X3 in bits 0..2, X9/X10 in bits 8/9).
    Xword,
    /// X1..X3.
    X(u8),
    /// X9 = FB1.
    X9,
    /// X10 = FB2.
    X10,
    /// FBACKS: FB1 in bit 0, FB2 in bit 1.
    Fbacks,
    /// SW3: dip-switch 3.
    Sw3,
    /// SW4: dip-switch 4.
    Sw4,
    /// YWORD: the outputs as a mask.
    Yword,
    /// Y1..Y4.
    Y(u8),
    /// FBENABLE: feedbacks that fire the watchdog (WDTFB1..2).
    FbEnable,
    /// WDTTIME, 1/100 s.
    WdtTime,
    /// WDTMASK (register WDTYMASK).
    WdtMask,
    /// WFLAGS: internal flags, bit 1 = watchdog fired.
    Wflags,
    /// XCOUNT1..3.
    Xcount(u8),
    /// X1LATUP..X3LATUP (registers XLATUP1..3).
    XlatUp(u8),
    /// X1LATDN..X3LATDN (registers XLATDN1..3).
    XlatDn(u8),
    /// Y1LAMP..Y4LAMP (registers YLAMP1..4).
    Lamp(u8),
    /// Y1PULSE..Y4PULSE (registers YPULSE1..4).
    Pulse(u8),
    /// YnAONm: (output, condition).
    AutoOn(u8, u8),
    /// YnAOFFm: (output, condition).
    AutoOff(u8, u8),
    /// SERLINE: baud rate and parity.
    Serline,
    /// RDELAYT: reply delay, 1/100 s.
    RdelayT,
    /// RDELAYM: extra end-of-frame silence, 1/10 ms.
    RdelayM,
    /// WCONF: save the preferences to flash.
    Wconf,
}

/// How a written value is given.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteKind {
    /// A single digit 0 or 1.
    Bit,
    /// An unsigned number in `min..=max`.
    Number {
        /// Lowest value.
        min: u16,
        /// Highest value.
        max: u16,
    },
    /// `BAUD[E|O|N|X]`.
    Serline,
    /// Input names, each perhaps preceded by `-`; empty clears.
    Condition,
}

/// A value to write.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteValue {
    /// A number (bits as 0/1).
    Number(u16),
    /// A baud rate and, if given, the parity letter.
    Serline {
        /// One of the accepted baud rates.
        baud: u32,
        /// `None`: parity and stop bits stay as they are.
        mode: Option<LineMode>,
    },
    /// A condition mask (low byte: inputs checked, high byte: inputs inverted).
    Condition(u16),
}

impl TextId {
    /// Parses an identifier, in any case.
    pub fn parse(name: &str) -> Option<Self> {
        let upper = name.to_ascii_uppercase();
        let s = upper.as_str();
        let fixed = match s {
            "ADDRESS" => Some(TextId::Address),
            "DEVICE" => Some(TextId::Device),
            "XWORD" => Some(TextId::Xword),
            "X9" => Some(TextId::X9),
            "X10" => Some(TextId::X10),
            "FBACKS" => Some(TextId::Fbacks),
            "SW3" => Some(TextId::Sw3),
            "SW4" => Some(TextId::Sw4),
            "YWORD" => Some(TextId::Yword),
            "FBENABLE" => Some(TextId::FbEnable),
            "WDTTIME" => Some(TextId::WdtTime),
            "WDTMASK" => Some(TextId::WdtMask),
            "WFLAGS" => Some(TextId::Wflags),
            "SERLINE" => Some(TextId::Serline),
            "RDELAYT" => Some(TextId::RdelayT),
            "RDELAYM" => Some(TextId::RdelayM),
            "WCONF" => Some(TextId::Wconf),
            _ => None,
        };
        if fixed.is_some() {
            return fixed;
        }
        if let Some(rest) = s.strip_prefix("XCOUNT") {
            return index(rest, 3).map(TextId::Xcount);
        }
        if let Some(rest) = s.strip_prefix('X') {
            let (digit, tail) = rest.split_at_checked(1)?;
            let i = index(digit, 3)?;
            return match tail {
                "" => Some(TextId::X(i)),
                "LATUP" => Some(TextId::XlatUp(i)),
                "LATDN" => Some(TextId::XlatDn(i)),
                _ => None,
            };
        }
        let rest = s.strip_prefix('Y')?;
        let (digit, tail) = rest.split_at_checked(1)?;
        let y = index(digit, 4)?;
        match tail {
            "" => Some(TextId::Y(y)),
            "LAMP" => Some(TextId::Lamp(y)),
            "PULSE" => Some(TextId::Pulse(y)),
            _ => {
                if let Some(c) = tail.strip_prefix("AON") {
                    index(c, 3).map(|c| TextId::AutoOn(y, c))
                } else {
                    index(tail.strip_prefix("AOFF")?, 3).map(|c| TextId::AutoOff(y, c))
                }
            }
        }
    }

    /// Digits of a read reply's value; `None` for DEVICE (text) and write-only identifiers.
    pub fn read_width(self) -> Option<usize> {
        match self {
            TextId::X(_)
            | TextId::X9
            | TextId::X10
            | TextId::Sw3
            | TextId::Sw4
            | TextId::Y(_)
            | TextId::FbEnable => Some(1),
            TextId::Address | TextId::Wflags => Some(3),
            TextId::Xword
            | TextId::Fbacks
            | TextId::Yword
            | TextId::WdtTime
            | TextId::WdtMask
            | TextId::Xcount(_)
            | TextId::XlatUp(_)
            | TextId::XlatDn(_)
            | TextId::Lamp(_)
            | TextId::Pulse(_) => Some(5),
            TextId::Device
            | TextId::AutoOn(..)
            | TextId::AutoOff(..)
            | TextId::Serline
            | TextId::RdelayT
            | TextId::RdelayM
            | TextId::Wconf => None,
        }
    }

    /// Whether `?ID` is answered with a value.
    pub fn readable(self) -> bool {
        self == TextId::Device || self.read_width().is_some()
    }

    /// How a written value is given; `None` for read-only identifiers.
    pub fn write_kind(self) -> Option<WriteKind> {
        let number = |min, max| Some(WriteKind::Number { min, max });
        match self {
            TextId::Y(_) => Some(WriteKind::Bit),
            TextId::Address => number(1, 247),
            TextId::RdelayT | TextId::RdelayM => number(0, 200),
            TextId::Wconf => number(1, 1),
            TextId::FbEnable => number(0, 3),
            TextId::Pulse(_) => number(0, 65000),
            TextId::Yword
            | TextId::WdtTime
            | TextId::WdtMask
            | TextId::Wflags
            | TextId::Xcount(_)
            | TextId::XlatUp(_)
            | TextId::XlatDn(_)
            | TextId::Lamp(_) => number(0, u16::MAX),
            TextId::Serline => Some(WriteKind::Serline),
            TextId::AutoOn(..) | TextId::AutoOff(..) => Some(WriteKind::Condition),
            TextId::Device
            | TextId::Xword
            | TextId::X(_)
            | TextId::X9
            | TextId::X10
            | TextId::Fbacks
            | TextId::Sw3
            | TextId::Sw4 => None,
        }
    }

    /// Parses the text after `=` of a write (spaces already dropped).
    pub fn parse_value(self, text: &str) -> Result<WriteValue, Refusal> {
        let bad = Refusal::BadValue(self);
        match self.write_kind().ok_or(Refusal::NotWritable(self))? {
            WriteKind::Bit => match text {
                "0" => Ok(WriteValue::Number(0)),
                "1" => Ok(WriteValue::Number(1)),
                _ => Err(bad),
            },
            WriteKind::Number { min, max } => {
                let n = parse_decimal(text).ok_or(bad)?;
                u16::try_from(n)
                    .ok()
                    .filter(|n| (min..=max).contains(n))
                    .map(WriteValue::Number)
                    .ok_or(bad)
            }
            WriteKind::Serline => {
                let digits = text.bytes().take_while(u8::is_ascii_digit).count();
                let (number, letter) = text.split_at(digits);
                let mode = match letter.as_bytes() {
                    [] => None,
                    [c] => Some(LineMode::from_letter(*c).ok_or(bad)?),
                    _ => return Err(bad),
                };
                let baud = parse_decimal(number)
                    .filter(|b| BAUD_RATES.contains(b))
                    .ok_or(bad)?;
                Ok(WriteValue::Serline { baud, mode })
            }
            WriteKind::Condition => parse_condition(text)
                .map(WriteValue::Condition)
                .map_err(|_: ConditionError| bad),
        }
    }
}

/// `"1"..="max"` as a 0-based index.
fn index(digit: &str, max: u8) -> Option<u8> {
    match digit.as_bytes() {
        [d @ b'1'..=b'9'] if d - b'0' <= max => Some(d - b'1'),
        _ => None,
    }
}

/// Unsigned decimal, leading zeros allowed, at least one digit; `None` above `u32::MAX`.
fn parse_decimal(text: &str) -> Option<u32> {
    if text.is_empty() {
        return None;
    }
    text.bytes().try_fold(0u32, |acc, b| {
        let d = b.is_ascii_digit().then(|| u32::from(b - b'0'))?;
        acc.checked_mul(10)?.checked_add(d)
    })
}

impl fmt::Display for TextId {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let n = |i: u8| u32::from(i) + 1;
        match *self {
            TextId::Address => f.write_str("ADDRESS"),
            TextId::Device => f.write_str("DEVICE"),
            TextId::Xword => f.write_str("XWORD"),
            TextId::X(i) => write!(f, "X{}", n(i)),
            TextId::X9 => f.write_str("X9"),
            TextId::X10 => f.write_str("X10"),
            TextId::Fbacks => f.write_str("FBACKS"),
            TextId::Sw3 => f.write_str("SW3"),
            TextId::Sw4 => f.write_str("SW4"),
            TextId::Yword => f.write_str("YWORD"),
            TextId::Y(i) => write!(f, "Y{}", n(i)),
            TextId::FbEnable => f.write_str("FBENABLE"),
            TextId::WdtTime => f.write_str("WDTTIME"),
            TextId::WdtMask => f.write_str("WDTMASK"),
            TextId::Wflags => f.write_str("WFLAGS"),
            TextId::Xcount(i) => write!(f, "XCOUNT{}", n(i)),
            TextId::XlatUp(i) => write!(f, "X{}LATUP", n(i)),
            TextId::XlatDn(i) => write!(f, "X{}LATDN", n(i)),
            TextId::Lamp(i) => write!(f, "Y{}LAMP", n(i)),
            TextId::Pulse(i) => write!(f, "Y{}PULSE", n(i)),
            TextId::AutoOn(y, c) => write!(f, "Y{}AON{}", n(y), n(c)),
            TextId::AutoOff(y, c) => write!(f, "Y{}AOFF{}", n(y), n(c)),
            TextId::Serline => f.write_str("SERLINE"),
            TextId::RdelayT => f.write_str("RDELAYT"),
            TextId::RdelayM => f.write_str("RDELAYM"),
            TextId::Wconf => f.write_str("WCONF"),
        }
    }
}

/// Why a packet gets no reply at all.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum Malformed {
    /// Nothing but spaces and LF.
    #[error("empty packet")]
    Empty,
    /// A byte that is not printable ASCII.
    #[error("byte {0:#04x} is not printable ASCII")]
    NotText(u8),
    /// `@` without 1..=255.
    #[error("the slave address after @ must be 1..=255")]
    BadAddress,
    /// Neither `?` nor `>` where the command starts.
    #[error("a command starts with ? or >")]
    NoCommand,
}

/// Why a well-formed command is answered `Error`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Refusal {
    /// Not an identifier of the tables.
    #[error("unknown identifier")]
    UnknownIdentifier,
    /// A write-only identifier was read.
    #[error("{0} cannot be read")]
    NotReadable(TextId),
    /// A read-only identifier was written.
    #[error("{0} cannot be written")]
    NotWritable(TextId),
    /// `>ID` without `=`.
    #[error("a write needs =value")]
    MissingValue,
    /// The value does not fit the identifier.
    #[error("bad value for {0}")]
    BadValue(TextId),
}

/// What a command asks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Op {
    /// `?ID`.
    Read(TextId),
    /// `>ID=V`.
    Write(TextId, WriteValue),
}

/// A well-formed packet: whom it is for and what it asks (or why it is refused).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Command {
    /// `@N`; `None` for every module.
    pub to: Option<u8>,
    /// The operation, or why the addressed module answers `Error`.
    pub op: Result<Op, Refusal>,
}

/// Parses one packet, with or without its CR (anything after the first CR is ignored):
/// spaces and LF dropped, upper-cased, cut at [`MAX_MESSAGE`] characters. Never panics.
pub(crate) fn parse_command(packet: &[u8]) -> Result<Command, Malformed> {
    let mut text = String::with_capacity(MAX_MESSAGE);
    for &b in packet {
        match b {
            TERMINATOR => break,
            b' ' | b'\n' => {}
            0x21..=0x7E => {
                if text.len() < MAX_MESSAGE {
                    text.push(char::from(b.to_ascii_uppercase()));
                }
            }
            other => return Err(Malformed::NotText(other)),
        }
    }
    if text.is_empty() {
        return Err(Malformed::Empty);
    }
    let (to, body) = match text.strip_prefix('@') {
        Some(rest) => {
            let digits = rest.bytes().take_while(u8::is_ascii_digit).count();
            let (number, body) = rest.split_at(digits);
            let to = (1..=3)
                .contains(&number.len())
                .then(|| parse_decimal(number))
                .flatten()
                .and_then(|n| u8::try_from(n).ok())
                .filter(|&n| n != 0)
                .ok_or(Malformed::BadAddress)?;
            (Some(to), body)
        }
        None => (None, text.as_str()),
    };
    let op = if let Some(name) = body.strip_prefix('?') {
        match TextId::parse(name) {
            Some(id) if id.readable() => Ok(Op::Read(id)),
            Some(id) => Err(Refusal::NotReadable(id)),
            None => Err(Refusal::UnknownIdentifier),
        }
    } else if let Some(assignment) = body.strip_prefix('>') {
        match assignment.split_once('=') {
            None => match TextId::parse(assignment) {
                Some(_) => Err(Refusal::MissingValue),
                None => Err(Refusal::UnknownIdentifier),
            },
            Some((name, value)) => match TextId::parse(name) {
                Some(id) => id.parse_value(value).map(|v| Op::Write(id, v)),
                None => Err(Refusal::UnknownIdentifier),
            },
        }
    } else {
        return Err(Malformed::NoCommand);
    };
    Ok(Command { to, op })
}

/// The reply to a read of a numeric identifier: `X1=0`, `ADDRESS=034`, `XWORD=00003`. A
/// write-only identifier is printed with 5 digits (never sent by the simulator).
pub(crate) fn format_value(id: TextId, value: u16) -> String {
    let width = id.read_width().unwrap_or(5);
    format!("{id}={value:0width$}")
}

/// The reply to `?DEVICE`.
pub(crate) fn device_reply() -> String {
    format!("{}={DEVICE_NAME}", TextId::Device)
}

/// A condition mask as the text protocol writes it (`0x0203` → `X1-X2`, 0 → empty); `None`
/// when the mask cannot be written with input names (bits beyond X1..X3, or an inverted input
/// that is not checked).
pub(crate) fn format_condition(mask: u16) -> Option<String> {
    let [check, invert] = mask.to_le_bytes();
    if check & !0x07 != 0 || invert & !check != 0 {
        return None;
    }
    let mut out = String::new();
    for i in 0..3u8 {
        if check & (1 << i) != 0 {
            if invert & (1 << i) != 0 {
                out.push('-');
            }
            out.push('X');
            out.push(char::from(b'1' + i));
        }
    }
    Some(out)
}

/// Why a write value cannot be put in a command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("condition mask {0:#06x} cannot be written with input names")]
pub struct Unwritable(pub u16);

/// `@N?ID` + CR.
pub fn read_command(to: u8, id: TextId) -> Vec<u8> {
    format!("@{to}?{id}\r").into_bytes()
}

/// `@N>ID=V` + CR.
pub fn write_command(to: u8, id: TextId, value: WriteValue) -> Result<Vec<u8>, Unwritable> {
    let value = match value {
        WriteValue::Number(n) => n.to_string(),
        WriteValue::Serline { baud, mode } => match mode {
            Some(m) => format!("{baud}{}", m.letter()),
            None => baud.to_string(),
        },
        WriteValue::Condition(mask) => format_condition(mask).ok_or(Unwritable(mask))?,
    };
    Ok(format!("@{to}>{id}={value}\r").into_bytes())
}

/// A reply, as the driver reads it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum TextReply {
    /// `OK`.
    Ok,
    /// `Error` (or `Error 1`).
    Error,
    /// `ID=digits`.
    Value(TextId, u16),
    /// `DEVICE=...`.
    Device(String),
}

/// Why a reply could not be read.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum ReplyError {
    /// Not `OK`, `Error`, `DEVICE=...` or `ID=digits`.
    #[error("not a MiniMod reply")]
    Garbled,
    /// A number above 65535.
    #[error("value out of range")]
    OutOfRange,
}

/// Parses a reply (terminator stripped or not; spaces, CR and LF around it ignored).
pub(crate) fn parse_reply(bytes: &[u8]) -> Result<TextReply, ReplyError> {
    let text = std::str::from_utf8(bytes).map_err(|_| ReplyError::Garbled)?;
    let text = text.trim_matches(|c: char| c.is_ascii_whitespace());
    if text.eq_ignore_ascii_case(OK) {
        return Ok(TextReply::Ok);
    }
    if text
        .get(..ERROR.len())
        .is_some_and(|head| head.eq_ignore_ascii_case(ERROR))
    {
        return Ok(TextReply::Error);
    }
    let (name, value) = text.split_once('=').ok_or(ReplyError::Garbled)?;
    let name: String = name.chars().filter(|c| *c != ' ').collect();
    let id = TextId::parse(&name).ok_or(ReplyError::Garbled)?;
    if id == TextId::Device {
        return Ok(TextReply::Device(value.trim().to_string()));
    }
    let digits: String = value.chars().filter(|c| *c != ' ').collect();
    let n = parse_decimal(&digits).ok_or(ReplyError::Garbled)?;
    let n = u16::try_from(n).map_err(|_| ReplyError::OutOfRange)?;
    Ok(TextReply::Value(id, n))
}

/// Collects bytes into text packets, as the module's receiver does: CR ends a packet, spaces
/// and LF are ignored, characters past [`MAX_MESSAGE`] are discarded until the CR, and a byte
/// that is not printable ASCII (noise, a corrupted Modbus frame) throws the packet away.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct PacketReceiver {
    buf: Vec<u8>,
}

impl PacketReceiver {
    /// An empty receiver.
    pub(crate) fn new() -> Self {
        Self::default()
    }

    /// Feeds one byte; returns the packet it completes.
    pub(crate) fn push(&mut self, byte: u8) -> Option<Vec<u8>> {
        match byte {
            TERMINATOR => return Some(std::mem::take(&mut self.buf)),
            b' ' | b'\n' => {}
            0x21..=0x7E => {
                if self.buf.len() < MAX_MESSAGE {
                    self.buf.push(byte);
                }
            }
            _ => self.buf.clear(),
        }
        None
    }

    /// Drops a partial packet.
    pub(crate) fn clear(&mut self) {
        self.buf.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cmd(text: &str) -> Command {
        parse_command(text.as_bytes()).unwrap()
    }

    #[test]
    fn manual_read_example() {
        // "?X1<CR>(<LF>)" → "X1=0<CR>".
        assert_eq!(
            cmd("?X1\r\n"),
            Command {
                to: None,
                op: Ok(Op::Read(TextId::X(0)))
            }
        );
        assert_eq!(format_value(TextId::X(0), 0), "X1=0");
    }

    #[test]
    fn manual_write_example_and_slave_addressing() {
        assert_eq!(
            cmd(">Y1=1\r").op,
            Ok(Op::Write(TextId::Y(0), WriteValue::Number(1)))
        );
        assert_eq!(
            cmd("@25?DEVICE\r"),
            Command {
                to: Some(25),
                op: Ok(Op::Read(TextId::Device))
            }
        );
        assert_eq!(device_reply(), "DEVICE=MINIMOD 1.1");
        assert_eq!(parse_command(b"@0?DEVICE\r"), Err(Malformed::BadAddress));
        assert_eq!(parse_command(b"@?DEVICE\r"), Err(Malformed::BadAddress));
        assert_eq!(parse_command(b"@256?X1\r"), Err(Malformed::BadAddress));
        assert_eq!(parse_command(b"@0025?X1\r"), Err(Malformed::BadAddress));
    }

    #[test]
    fn manual_reply_widths() {
        assert_eq!(format_value(TextId::Address, 34), "ADDRESS=034");
        assert_eq!(format_value(TextId::Xword, 3), "XWORD=00003");
        assert_eq!(format_value(TextId::Fbacks, 3), "FBACKS=00003");
        assert_eq!(format_value(TextId::FbEnable, 3), "FBENABLE=3");
        assert_eq!(format_value(TextId::Wflags, 2), "WFLAGS=002");
        assert_eq!(format_value(TextId::XlatUp(2), 20), "X3LATUP=00020");
        assert_eq!(format_value(TextId::Pulse(0), 100), "Y1PULSE=00100");
    }

    #[test]
    fn case_spaces_and_lf_are_ignored() {
        assert_eq!(
            cmd(" ? x 1 l a t u p \n\r").op,
            Ok(Op::Read(TextId::XlatUp(0)))
        );
        assert_eq!(
            cmd(">xcount1 = 0\r").op,
            Ok(Op::Write(TextId::Xcount(0), WriteValue::Number(0)))
        );
        assert_eq!(
            cmd("@ 2 5 ? device\r").to,
            Some(25),
            "spaces are ignored everywhere"
        );
    }

    #[test]
    fn malformed_packets_get_no_reply() {
        for bad in ["X1\r", "\r", "  \n\r", "!X1\r", "=?X1\r"] {
            assert!(parse_command(bad.as_bytes()).is_err(), "{bad:?}");
        }
        assert_eq!(
            parse_command(&[b'?', 0x00, b'X', b'\r']),
            Err(Malformed::NotText(0))
        );
    }

    #[test]
    fn refusals_are_answered_error() {
        assert_eq!(cmd("?X4\r").op, Err(Refusal::UnknownIdentifier));
        assert_eq!(
            cmd("?Y1AON1\r").op,
            Err(Refusal::NotReadable(TextId::AutoOn(0, 0)))
        );
        assert_eq!(cmd(">X1=1\r").op, Err(Refusal::NotWritable(TextId::X(0))));
        assert_eq!(
            cmd(">DEVICE=1\r").op,
            Err(Refusal::NotWritable(TextId::Device))
        );
        assert_eq!(cmd(">Y1\r").op, Err(Refusal::MissingValue));
        assert_eq!(cmd(">Y2=\r").op, Err(Refusal::BadValue(TextId::Y(1))));
        assert_eq!(cmd(">Y1=01\r").op, Err(Refusal::BadValue(TextId::Y(0))));
        assert_eq!(cmd(">Y1=2\r").op, Err(Refusal::BadValue(TextId::Y(0))));
        assert_eq!(
            cmd(">WDTTIME=65536\r").op,
            Err(Refusal::BadValue(TextId::WdtTime))
        );
        assert_eq!(
            cmd(">WDTTIME=-1\r").op,
            Err(Refusal::BadValue(TextId::WdtTime))
        );
        assert_eq!(
            cmd(">ADDRESS=248\r").op,
            Err(Refusal::BadValue(TextId::Address))
        );
        assert_eq!(cmd(">WCONF=2\r").op, Err(Refusal::BadValue(TextId::Wconf)));
        assert_eq!(
            cmd(">RDELAYT=201\r").op,
            Err(Refusal::BadValue(TextId::RdelayT))
        );
        assert_eq!(
            cmd(">FBENABLE=4\r").op,
            Err(Refusal::BadValue(TextId::FbEnable))
        );
        assert_eq!(cmd("?X1=1\r").op, Err(Refusal::UnknownIdentifier));
    }

    #[test]
    fn leading_zeros_are_allowed() {
        assert_eq!(
            cmd(">WDTTIME=0000000000000050\r").op,
            Ok(Op::Write(TextId::WdtTime, WriteValue::Number(50)))
        );
        assert_eq!(
            cmd(">ADDRESS=0180\r").op,
            Ok(Op::Write(TextId::Address, WriteValue::Number(180)))
        );
    }

    #[test]
    fn conditions_of_the_manual() {
        assert_eq!(
            cmd(">Y1AON1=X1X2\r").op,
            Ok(Op::Write(
                TextId::AutoOn(0, 0),
                WriteValue::Condition(0x0003)
            ))
        );
        assert_eq!(
            cmd(">Y1AON2=X1-X3\r").op,
            Ok(Op::Write(
                TextId::AutoOn(0, 1),
                WriteValue::Condition(0x0405)
            ))
        );
        assert_eq!(
            cmd(">Y1AOFF1=-X1\r").op,
            Ok(Op::Write(
                TextId::AutoOff(0, 0),
                WriteValue::Condition(0x0101)
            ))
        );
        assert_eq!(
            cmd(">Y3AON2=X2-X3\r").op,
            Ok(Op::Write(
                TextId::AutoOn(2, 1),
                WriteValue::Condition(0x0406)
            ))
        );
        assert_eq!(
            cmd(">Y2AON1=\r").op,
            Ok(Op::Write(TextId::AutoOn(1, 0), WriteValue::Condition(0))),
            "an empty value clears the condition"
        );
        // "X1=1, X2=0" is the manual's mask "0000.0010-0000.0011".
        assert_eq!(format_condition(0x0203).as_deref(), Some("X1-X2"));
        assert_eq!(format_condition(0).as_deref(), Some(""));
        assert_eq!(format_condition(0x0100), None, "inverts an unchecked input");
        assert_eq!(format_condition(0x0008), None, "no X4");
        assert_eq!(
            cmd(">Y1AON1=X4\r").op,
            Err(Refusal::BadValue(TextId::AutoOn(0, 0)))
        );
        assert_eq!(
            cmd(">Y1AON1=7\r").op,
            Err(Refusal::BadValue(TextId::AutoOn(0, 0)))
        );
    }

    #[test]
    fn serline_values() {
        assert_eq!(
            cmd(">SERLINE=19200E\r").op,
            Ok(Op::Write(
                TextId::Serline,
                WriteValue::Serline {
                    baud: 19200,
                    mode: Some(LineMode::Even)
                }
            ))
        );
        assert_eq!(
            cmd(">serline=9600\r").op,
            Ok(Op::Write(
                TextId::Serline,
                WriteValue::Serline {
                    baud: 9600,
                    mode: None
                }
            ))
        );
        assert_eq!(
            cmd(">SERLINE=1200E\r").op,
            Err(Refusal::BadValue(TextId::Serline))
        );
        assert_eq!(
            cmd(">SERLINE=19200Z\r").op,
            Err(Refusal::BadValue(TextId::Serline))
        );
        assert_eq!(
            cmd("?SERLINE\r").op,
            Err(Refusal::NotReadable(TextId::Serline))
        );
    }

    #[test]
    fn every_identifier_of_both_tables() {
        let reads = [
            "ADDRESS", "DEVICE", "XWORD", "X1", "X2", "X3", "X9", "X10", "FBACKS", "SW3", "SW4",
            "YWORD", "Y1", "Y4", "FBENABLE", "WDTTIME", "WDTMASK", "WFLAGS", "XCOUNT1", "XCOUNT3",
            "X1LATUP", "X3LATUP", "X1LATDN", "X3LATDN", "Y1LAMP", "Y4LAMP", "Y1PULSE", "Y4PULSE",
        ];
        for name in reads {
            let id = TextId::parse(name).unwrap_or_else(|| panic!("{name}"));
            assert!(id.readable(), "{name}");
            assert_eq!(id.to_string(), name, "round trip");
        }
        let writes = [
            "ADDRESS", "SERLINE", "RDELAYT", "RDELAYM", "WCONF", "YWORD", "Y1", "Y4", "FBENABLE",
            "WDTTIME", "WDTMASK", "WFLAGS", "XCOUNT2", "X2LATUP", "X2LATDN", "Y2LAMP", "Y3PULSE",
            "Y1AON1", "Y4AON3", "Y1AOFF1", "Y4AOFF3",
        ];
        for name in writes {
            let id = TextId::parse(name).unwrap_or_else(|| panic!("{name}"));
            assert!(id.write_kind().is_some(), "{name}");
            assert_eq!(id.to_string(), name, "round trip");
        }
        for bad in [
            "X0", "X4", "Y5", "Y0", "XCOUNT4", "Y1AON4", "Y1AOFF0", "X1LAT", "", "Y", "X",
        ] {
            assert_eq!(TextId::parse(bad), None, "{bad}");
        }
    }

    #[test]
    fn the_76_character_limit() {
        // 8 + 34 × 2 = 76: fits exactly.
        let fits = format!(">Y1AON1={}\r", "X1".repeat(34));
        assert_eq!(
            parse_command(fits.as_bytes()).map(|c| c.op),
            Ok(Ok(Op::Write(
                TextId::AutoOn(0, 0),
                WriteValue::Condition(1)
            )))
        );
        // Two more: both are discarded, the condition is still X1.
        let longer = format!(">Y1AON1={}X2\r", "X1".repeat(34));
        assert_eq!(
            parse_command(longer.as_bytes()).map(|c| c.op),
            Ok(Ok(Op::Write(
                TextId::AutoOn(0, 0),
                WriteValue::Condition(1)
            )))
        );
        // 77 characters ending in "-X2": the cut leaves "-X", which is no condition.
        let cut = format!(">Y1AON1={}-X2\r", "X1".repeat(33));
        assert_eq!(
            parse_command(cut.as_bytes()).map(|c| c.op),
            Ok(Err(Refusal::BadValue(TextId::AutoOn(0, 0))))
        );
        let spaced = format!("?{}XWORD\r", " ".repeat(200));
        assert_eq!(
            cmd(&spaced).op,
            Ok(Op::Read(TextId::Xword)),
            "spaces do not count"
        );
    }

    #[test]
    fn driver_side_commands_and_replies() {
        assert_eq!(read_command(5, TextId::Xword), b"@5?XWORD\r");
        assert_eq!(
            write_command(5, TextId::Y(1), WriteValue::Number(1)).unwrap(),
            b"@5>Y2=1\r"
        );
        assert_eq!(
            write_command(7, TextId::AutoOn(2, 1), WriteValue::Condition(0x0406)).unwrap(),
            b"@7>Y3AON2=X2-X3\r"
        );
        assert_eq!(
            write_command(7, TextId::AutoOn(2, 1), WriteValue::Condition(0x0100)),
            Err(Unwritable(0x0100))
        );
        assert_eq!(parse_reply(b"OK"), Ok(TextReply::Ok));
        assert_eq!(parse_reply(b"Error"), Ok(TextReply::Error));
        assert_eq!(parse_reply(b"Error 1\r"), Ok(TextReply::Error));
        assert_eq!(
            parse_reply(b"XWORD=00003"),
            Ok(TextReply::Value(TextId::Xword, 3))
        );
        assert_eq!(
            parse_reply(b"\nADDRESS=034\r"),
            Ok(TextReply::Value(TextId::Address, 34))
        );
        assert_eq!(
            parse_reply(b"DEVICE=MINIMOD 1.1"),
            Ok(TextReply::Device("MINIMOD 1.1".into()))
        );
        assert_eq!(parse_reply(b"XWORD=99999"), Err(ReplyError::OutOfRange));
        for bad in [
            &b"X1="[..],
            b"=1",
            b"X4=1",
            b"X1=a",
            b"",
            b"\xff\xfe",
            b"OKAY",
        ] {
            assert!(parse_reply(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn receiver_collects_packets_like_the_module() {
        let mut r = PacketReceiver::new();
        let mut packets = Vec::new();
        for &b in b"?X\n1\r>Y1 = 1\r\n".iter() {
            packets.extend(r.push(b));
        }
        assert_eq!(packets, [b"?X1".to_vec(), b">Y1=1".to_vec()]);
        for &b in b"?X1".iter().chain(&[0x00]).chain(b"?X2\r") {
            if let Some(p) = r.push(b) {
                assert_eq!(p, b"?X2", "noise throws the partial packet away");
            }
        }
    }

    /// Arbitrary bytes never panic and either parse or are refused.
    #[test]
    fn parser_survives_arbitrary_bytes() {
        let mut seed = 0x9E37_79B9_u32;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 17;
            seed ^= seed << 5;
            seed
        };
        let alphabet = b"?>@=-0123456789XYAONFLTUPDWCSEIMRKB \n\r\x00\xff";
        for _ in 0..20_000 {
            let len = (next() % 90) as usize;
            let packet: Vec<u8> = (0..len)
                .map(|_| alphabet[(next() as usize) % alphabet.len()])
                .collect();
            let _ = parse_command(&packet);
            drop(parse_reply(&packet));
            let mut r = PacketReceiver::new();
            for b in &packet {
                drop(r.push(*b));
            }
        }
    }
}
