//! DCON ASCII (manual chapter 2): framing with the optional checksum, every command of the
//! EX-9053D and its answers, parsed and formatted both ways. The driver formats commands and
//! parses answers; the simulator parses commands and formats answers, with the same code.
//!
//! A line is `(body)[CHK](cr)`. With the checksum enabled (data format bit 6, §1.10) `CHK` is
//! two upper-case hexadecimal characters, the sum of every body character modulo 256, in both
//! directions. Addresses are two hexadecimal characters, 00..FF.
//!
//! Input data follows §1.10 "Read Digital Input/Output Data Format": the first data byte is
//! DI8..DI15, the second DI0..DI7, each as two hexadecimal digits. As a `u16`, bit n is DIn, so
//! `{:04X}` gives the manual's order.
//!
//! Where the manual contradicts itself, the example wins over the syntax line:
//! - `#AAN` answers `!AA(Data)` with five decimal digits (§2.3 example `!0300103`), not
//!   `>(Data)` as its "Response" line says.
//! - `$AA4` answers `!S(Data)` with Data = first, second, `00` (§2.2 example `!10F0000`); the
//!   §2.5 example `!100F000` has one digit shifted and contradicts its own text ("0F00").

use std::fmt;

/// The terminator of every DCON line.
pub(crate) const CR: u8 = b'\r';

/// The DCON checksum: the sum of `bytes` modulo 256 (§1.10, data format bit 6).
pub(crate) fn checksum(bytes: &[u8]) -> u8 {
    bytes.iter().fold(0u8, |acc, b| acc.wrapping_add(*b))
}

/// The whole line for `body`: the body, its checksum when enabled, CR.
pub(crate) fn encode_line(body: &str, with_checksum: bool) -> Vec<u8> {
    let mut line = Vec::with_capacity(body.len() + 3);
    line.extend_from_slice(body.as_bytes());
    if with_checksum {
        let sum = checksum(body.as_bytes());
        line.extend_from_slice(format!("{sum:02X}").as_bytes());
    }
    line.push(CR);
    line
}

/// Why a line (its terminator already removed) is not a usable DCON line.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum FrameError {
    /// A byte that is not printable ASCII: noise, or another protocol on the line.
    #[error("byte {byte:#04x} at {at} is not printable ASCII")]
    NotText {
        /// Its position.
        at: usize,
        /// The byte.
        byte: u8,
    },
    /// The checksum is enabled and the line is too short to carry one.
    #[error("line of {len} characters has no room for a checksum")]
    MissingChecksum {
        /// The line's length.
        len: usize,
    },
    /// The checksum characters are not two hexadecimal digits.
    #[error("checksum characters are not hexadecimal")]
    NotHexChecksum,
    /// The checksum does not match the body.
    #[error("checksum {found:02X}, computed {expected:02X}")]
    BadChecksum {
        /// The sum of the body.
        expected: u8,
        /// What the line carries.
        found: u8,
    },
}

/// Checks a line without its terminator: printable ASCII, and with the checksum enabled, a
/// correct checksum, which is removed. Returns the body.
pub fn check_line(line: &[u8], with_checksum: bool) -> Result<&[u8], FrameError> {
    if let Some((at, &byte)) = line
        .iter()
        .enumerate()
        .find(|(_, b)| !(0x20..0x7F).contains(*b))
    {
        return Err(FrameError::NotText { at, byte });
    }
    if !with_checksum {
        return Ok(line);
    }
    let len = line.len();
    let split = len
        .checked_sub(2)
        .filter(|&n| n > 0)
        .ok_or(FrameError::MissingChecksum { len })?;
    let (body, chk) = line.split_at(split);
    let found = hex_u8(chk).ok_or(FrameError::NotHexChecksum)?;
    let expected = checksum(body);
    if found == expected {
        Ok(body)
    } else {
        Err(FrameError::BadChecksum { expected, found })
    }
}

/// The value of one hexadecimal digit (either case).
pub(crate) fn hex_digit(b: u8) -> Option<u8> {
    char::from(b)
        .to_digit(16)
        .and_then(|d| u8::try_from(d).ok())
}

/// Exactly two hexadecimal digits.
pub(crate) fn hex_u8(two: &[u8]) -> Option<u8> {
    match two {
        [h, l] => Some((hex_digit(*h)? << 4) | hex_digit(*l)?),
        _ => None,
    }
}

/// Exactly four hexadecimal digits.
pub(crate) fn hex_u16(four: &[u8]) -> Option<u16> {
    match four {
        [a, b, c, d] => Some(u16::from_be_bytes([hex_u8(&[*a, *b])?, hex_u8(&[*c, *d])?])),
        _ => None,
    }
}

/// A DCON command of the EX-9053D / EX-9053D-M (manual §2.1..§2.21).
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Command {
    /// `%AANNTTCCFF`: set address, type, baud code and data format (§2.1).
    SetConfig {
        /// AA.
        address: u8,
        /// NN, the new address.
        new_address: u8,
        /// TT.
        type_code: u8,
        /// CC (§1.10).
        baud_code: u8,
        /// FF (§1.10).
        format: u8,
    },
    /// `#**`: synchronized sampling, broadcast, no answer (§2.2).
    SyncSample,
    /// `#AAN`: read the counter of channel N, one hexadecimal digit (§2.3).
    ReadCounter {
        /// AA.
        address: u8,
        /// N.
        channel: u8,
    },
    /// `$AA2`: read the configuration (§2.4).
    ReadConfig {
        /// AA.
        address: u8,
    },
    /// `$AA4`: read the synchronized data (§2.5).
    ReadSync {
        /// AA.
        address: u8,
    },
    /// `$AA5`: read (and clear) the reset status (§2.6).
    ReadResetStatus {
        /// AA.
        address: u8,
    },
    /// `$AA6`: read the digital I/O status (§2.7).
    ReadInputStatus {
        /// AA.
        address: u8,
    },
    /// `$AAF`: read the firmware version (§2.8).
    ReadFirmware {
        /// AA.
        address: u8,
    },
    /// `$AAM`: read the module name (§2.9).
    ReadName {
        /// AA.
        address: u8,
    },
    /// `$AAC`: clear the latched inputs (§2.10).
    ClearLatches {
        /// AA.
        address: u8,
    },
    /// `$AACN`: clear the counter of channel N (§2.11).
    ClearCounter {
        /// AA.
        address: u8,
        /// N.
        channel: u8,
    },
    /// `$AALS`: read the latch-high (S = 1) or latch-low (S = 0) inputs (§2.12).
    ReadLatches {
        /// AA.
        address: u8,
        /// S = 1.
        high: bool,
    },
    /// `@AA`: read the digital I/O status (§2.13).
    ReadInputs {
        /// AA.
        address: u8,
    },
    /// `~AAO(Data)`: set the module name, 1..=6 characters (§2.14).
    SetName {
        /// AA.
        address: u8,
        /// The new name.
        name: String,
    },
    /// `$AAP`: read the protocol stored for the next power-on, EX-9053D-M only (§2.15).
    ReadProtocol {
        /// AA.
        address: u8,
    },
    /// `$AAPN`: store the protocol for the next power-on, EX-9053D-M in INIT* only (§2.16).
    SetProtocol {
        /// AA.
        address: u8,
        /// N = 1: Modbus RTU; N = 0: DCON ("Normal mode").
        modbus: bool,
    },
    /// `~**`: host OK, broadcast, no answer (§2.17).
    HostOk,
    /// `~AA0`: read the module status (§2.18).
    ReadModuleStatus {
        /// AA.
        address: u8,
    },
    /// `~AA1`: reset the module status (§2.19).
    ResetModuleStatus {
        /// AA.
        address: u8,
    },
    /// `~AA2`: read the host watchdog (§2.20).
    ReadWatchdog {
        /// AA.
        address: u8,
    },
    /// `~AA3EVV`: set the host watchdog, VV in 0.1 s (§2.21).
    SetWatchdog {
        /// AA.
        address: u8,
        /// E.
        enabled: bool,
        /// VV.
        value: u8,
    },
}

/// Why a line is not a command this module acts on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum ParseError {
    /// No delimiter and address could be read: a module cannot tell whom it is for, so no one
    /// answers.
    #[error("not a DCON command: no delimiter and address")]
    NoAddress,
    /// A command for `address` that the module does not have: the addressed module answers
    /// `?AA` (§2, "Invalid Command").
    #[error("invalid command for address {address:02X}")]
    Invalid {
        /// AA.
        address: u8,
    },
}

impl Command {
    /// The address the command is sent to; `None` for the broadcasts `#**` and `~**`.
    pub fn address(&self) -> Option<u8> {
        use Command::*;
        match self {
            SyncSample | HostOk => None,
            SetConfig { address, .. }
            | ReadCounter { address, .. }
            | ReadConfig { address }
            | ReadSync { address }
            | ReadResetStatus { address }
            | ReadInputStatus { address }
            | ReadFirmware { address }
            | ReadName { address }
            | ClearLatches { address }
            | ClearCounter { address, .. }
            | ReadLatches { address, .. }
            | ReadInputs { address }
            | SetName { address, .. }
            | ReadProtocol { address }
            | SetProtocol { address, .. }
            | ReadModuleStatus { address }
            | ResetModuleStatus { address }
            | ReadWatchdog { address }
            | SetWatchdog { address, .. } => Some(*address),
        }
    }

    /// The address the answer carries: NN for `%AANNTTCCFF` (§2.1 example `!02`), AA for the
    /// rest; `None` for broadcasts, which get no answer.
    pub fn reply_address(&self) -> Option<u8> {
        match self {
            Command::SetConfig { new_address, .. } => Some(*new_address),
            other => other.address(),
        }
    }

    /// Parses a body (checksum and terminator removed). Command letters are case-sensitive,
    /// as the manual spells them; hexadecimal digits are not.
    pub fn parse(body: &[u8]) -> Result<Command, ParseError> {
        let (&delimiter, rest) = body.split_first().ok_or(ParseError::NoAddress)?;
        if !matches!(delimiter, b'%' | b'#' | b'$' | b'@' | b'~') {
            return Err(ParseError::NoAddress);
        }
        if rest == b"**" {
            return match delimiter {
                b'#' => Ok(Command::SyncSample),
                b'~' => Ok(Command::HostOk),
                _ => Err(ParseError::NoAddress),
            };
        }
        let address = rest
            .get(..2)
            .and_then(hex_u8)
            .ok_or(ParseError::NoAddress)?;
        let args = rest.get(2..).unwrap_or_default();
        let invalid = ParseError::Invalid { address };
        let hex = |b: &u8| hex_digit(*b).ok_or(invalid);
        let byte = |at: usize| args.get(at..at + 2).and_then(hex_u8).ok_or(invalid);
        let cmd = match (delimiter, args) {
            (b'%', _) if args.len() == 8 => Command::SetConfig {
                address,
                new_address: byte(0)?,
                type_code: byte(2)?,
                baud_code: byte(4)?,
                format: byte(6)?,
            },
            (b'#', [n]) => Command::ReadCounter {
                address,
                channel: hex(n)?,
            },
            (b'$', b"2") => Command::ReadConfig { address },
            (b'$', b"4") => Command::ReadSync { address },
            (b'$', b"5") => Command::ReadResetStatus { address },
            (b'$', b"6") => Command::ReadInputStatus { address },
            (b'$', b"F") => Command::ReadFirmware { address },
            (b'$', b"M") => Command::ReadName { address },
            (b'$', b"C") => Command::ClearLatches { address },
            (b'$', [b'C', n]) => Command::ClearCounter {
                address,
                channel: hex(n)?,
            },
            (b'$', [b'L', s @ (b'0' | b'1')]) => Command::ReadLatches {
                address,
                high: *s == b'1',
            },
            (b'$', b"P") => Command::ReadProtocol { address },
            (b'$', [b'P', n @ (b'0' | b'1')]) => Command::SetProtocol {
                address,
                modbus: *n == b'1',
            },
            (b'@', []) => Command::ReadInputs { address },
            (b'~', b"0") => Command::ReadModuleStatus { address },
            (b'~', b"1") => Command::ResetModuleStatus { address },
            (b'~', b"2") => Command::ReadWatchdog { address },
            (b'~', [b'3', e @ (b'0' | b'1'), v @ ..]) => Command::SetWatchdog {
                address,
                enabled: *e == b'1',
                value: hex_u8(v).ok_or(invalid)?,
            },
            (b'~', [b'O', name @ ..])
                if (1..=super::tables::MAX_NAME_LEN).contains(&name.len()) =>
            {
                Command::SetName {
                    address,
                    // check_line let only printable ASCII through; a direct caller may not.
                    name: String::from_utf8(name.to_vec()).map_err(|_| invalid)?,
                }
            }
            _ => return Err(invalid),
        };
        Ok(cmd)
    }

    /// The body as sent (no checksum, no terminator), hexadecimal in upper case.
    pub fn body(&self) -> String {
        use Command::*;
        match self {
            SetConfig {
                address,
                new_address,
                type_code,
                baud_code,
                format,
            } => {
                format!("%{address:02X}{new_address:02X}{type_code:02X}{baud_code:02X}{format:02X}")
            }
            SyncSample => "#**".to_string(),
            ReadCounter { address, channel } => format!("#{address:02X}{channel:X}"),
            ReadConfig { address } => format!("${address:02X}2"),
            ReadSync { address } => format!("${address:02X}4"),
            ReadResetStatus { address } => format!("${address:02X}5"),
            ReadInputStatus { address } => format!("${address:02X}6"),
            ReadFirmware { address } => format!("${address:02X}F"),
            ReadName { address } => format!("${address:02X}M"),
            ClearLatches { address } => format!("${address:02X}C"),
            ClearCounter { address, channel } => format!("${address:02X}C{channel:X}"),
            ReadLatches { address, high } => format!("${address:02X}L{}", u8::from(*high)),
            ReadInputs { address } => format!("@{address:02X}"),
            SetName { address, name } => format!("~{address:02X}O{name}"),
            ReadProtocol { address } => format!("${address:02X}P"),
            SetProtocol { address, modbus } => format!("${address:02X}P{}", u8::from(*modbus)),
            HostOk => "~**".to_string(),
            ReadModuleStatus { address } => format!("~{address:02X}0"),
            ResetModuleStatus { address } => format!("~{address:02X}1"),
            ReadWatchdog { address } => format!("~{address:02X}2"),
            SetWatchdog {
                address,
                enabled,
                value,
            } => format!("~{address:02X}3{}{value:02X}", u8::from(*enabled)),
        }
    }

    /// The whole line: body, checksum when enabled, CR.
    pub fn encode(&self, with_checksum: bool) -> Vec<u8> {
        encode_line(&self.body(), with_checksum)
    }
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.body())
    }
}

/// An answer of the module. The shape depends on the command: [`Answer::parse`] takes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Answer {
    /// `!AA`: done.
    Ack,
    /// `?AA`: invalid command.
    Invalid,
    /// `!AATTCCFF` (§2.4).
    Config {
        /// TT.
        type_code: u8,
        /// CC.
        baud_code: u8,
        /// FF.
        format: u8,
    },
    /// `!S(Data)`: Data = first, second, `00` (§2.5, §1.10).
    Sync {
        /// S = 1: first read of this sample.
        first: bool,
        /// The sample, bit n = DIn.
        inputs: u16,
    },
    /// `!AAS` (§2.6).
    ResetStatus(bool),
    /// `!(Data)` of `$AA6`: first, second, `00` (§2.7).
    InputStatus(u16),
    /// `!AA(Data)` of `$AAF` and `$AAM` (§2.8, §2.9).
    Text(String),
    /// `!AA(Data)` of `#AAN`: five decimal digits (§2.3 example).
    Counter(u32),
    /// `!(Data)` of `$AALS`: first, second, `00`; bit n = 1: DIn latched (§2.12).
    Latches(u16),
    /// `>(Data)` of `@AA`: first, second (§2.13).
    Inputs(u16),
    /// `!AAS` of `$AAP`, S = `10` (DCON) or `11` (Modbus RTU) (§2.15).
    Protocol {
        /// S = 11.
        modbus: bool,
    },
    /// `!AASS` (§2.18).
    ModuleStatus(u8),
    /// `!AAEVV` (§2.20).
    Watchdog {
        /// E.
        enabled: bool,
        /// VV, in 0.1 s.
        value: u8,
    },
}

/// Why an answer does not fit its command.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum AnswerError {
    /// The command was a broadcast: nothing answers it.
    #[error("a broadcast gets no answer")]
    Broadcast,
    /// Another module's address.
    #[error("answer from address {found:02X}, expected {expected:02X}")]
    WrongAddress {
        /// The command's address.
        expected: u8,
        /// The answer's.
        found: u8,
    },
    /// Not the command's answer shape.
    #[error("answer of {len} characters does not have the command's shape")]
    Malformed {
        /// The answer's length.
        len: usize,
    },
}

impl Answer {
    /// The body the module sends at `address` (no checksum, no terminator).
    pub fn body(&self, address: u8) -> String {
        match self {
            Answer::Ack => format!("!{address:02X}"),
            Answer::Invalid => format!("?{address:02X}"),
            Answer::Config {
                type_code,
                baud_code,
                format,
            } => format!("!{address:02X}{type_code:02X}{baud_code:02X}{format:02X}"),
            Answer::Sync { first, inputs } => format!("!{}{inputs:04X}00", u8::from(*first)),
            Answer::ResetStatus(set) => format!("!{address:02X}{}", u8::from(*set)),
            Answer::InputStatus(v) | Answer::Latches(v) => format!("!{v:04X}00"),
            Answer::Text(text) => format!("!{address:02X}{text}"),
            Answer::Counter(n) => format!("!{address:02X}{n:05}"),
            Answer::Inputs(v) => format!(">{v:04X}"),
            Answer::Protocol { modbus } => format!("!{address:02X}1{}", u8::from(*modbus)),
            Answer::ModuleStatus(s) => format!("!{address:02X}{s:02X}"),
            Answer::Watchdog { enabled, value } => {
                format!("!{address:02X}{}{value:02X}", u8::from(*enabled))
            }
        }
    }

    /// Parses the answer body (checksum and terminator removed) to `cmd`. `?AA` from the
    /// right address is [`Answer::Invalid`].
    pub fn parse(cmd: &Command, body: &[u8]) -> Result<Answer, AnswerError> {
        let expected = cmd.reply_address().ok_or(AnswerError::Broadcast)?;
        let malformed = AnswerError::Malformed { len: body.len() };
        let from = |prefix: u8| -> Result<&[u8], AnswerError> {
            match body {
                [p, a, b, rest @ ..] if *p == prefix => {
                    let found = hex_u8(&[*a, *b]).ok_or(malformed)?;
                    if found == expected {
                        Ok(rest)
                    } else {
                        Err(AnswerError::WrongAddress { expected, found })
                    }
                }
                _ => Err(malformed),
            }
        };
        if body.first() == Some(&b'?') {
            return from(b'?')
                .and_then(|rest| rest.is_empty().then_some(Answer::Invalid).ok_or(malformed));
        }
        let bit = |b: &[u8]| match b {
            b"0" => Ok(false),
            b"1" => Ok(true),
            _ => Err(malformed),
        };
        // `(first)(second)00`: the trailing pair is not checked beyond being hexadecimal.
        let data00 = |d: &[u8]| match d {
            [w @ .., x, y] if hex_u8(&[*x, *y]).is_some() => hex_u16(w).ok_or(malformed),
            _ => Err(malformed),
        };
        use Command::*;
        Ok(match cmd {
            SyncSample | HostOk => return Err(AnswerError::Broadcast),
            SetConfig { .. }
            | ClearLatches { .. }
            | ClearCounter { .. }
            | SetName { .. }
            | SetProtocol { .. }
            | ResetModuleStatus { .. }
            | SetWatchdog { .. } => {
                let rest = from(b'!')?;
                rest.is_empty().then_some(Answer::Ack).ok_or(malformed)?
            }
            ReadConfig { .. } => match from(b'!')? {
                [t1, t2, c1, c2, f1, f2] => Answer::Config {
                    type_code: hex_u8(&[*t1, *t2]).ok_or(malformed)?,
                    baud_code: hex_u8(&[*c1, *c2]).ok_or(malformed)?,
                    format: hex_u8(&[*f1, *f2]).ok_or(malformed)?,
                },
                _ => return Err(malformed),
            },
            ReadSync { .. } => match body {
                [b'!', s, data @ ..] => Answer::Sync {
                    first: bit(&[*s])?,
                    inputs: data00(data)?,
                },
                _ => return Err(malformed),
            },
            ReadResetStatus { .. } => Answer::ResetStatus(bit(from(b'!')?)?),
            ReadInputStatus { .. } | ReadLatches { .. } => match body {
                [b'!', data @ ..] => {
                    let v = data00(data)?;
                    if matches!(cmd, ReadLatches { .. }) {
                        Answer::Latches(v)
                    } else {
                        Answer::InputStatus(v)
                    }
                }
                _ => return Err(malformed),
            },
            ReadFirmware { .. } | ReadName { .. } => {
                let rest = from(b'!')?;
                Answer::Text(String::from_utf8(rest.to_vec()).map_err(|_| malformed)?)
            }
            ReadCounter { .. } => {
                let rest = from(b'!')?;
                if rest.len() != 5 || !rest.iter().all(u8::is_ascii_digit) {
                    return Err(malformed);
                }
                let n = rest
                    .iter()
                    .fold(0u32, |acc, d| acc * 10 + u32::from(d - b'0'));
                Answer::Counter(n)
            }
            ReadInputs { .. } => match body {
                [b'>', data @ ..] => Answer::Inputs(hex_u16(data).ok_or(malformed)?),
                _ => return Err(malformed),
            },
            ReadProtocol { .. } => match from(b'!')? {
                [b'1', n] => Answer::Protocol {
                    modbus: bit(&[*n])?,
                },
                _ => return Err(malformed),
            },
            ReadModuleStatus { .. } => Answer::ModuleStatus(hex_u8(from(b'!')?).ok_or(malformed)?),
            ReadWatchdog { .. } => match from(b'!')? {
                [e, v @ ..] => Answer::Watchdog {
                    enabled: bit(&[*e])?,
                    value: hex_u8(v).ok_or(malformed)?,
                },
                _ => return Err(malformed),
            },
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checksum_is_the_byte_sum() {
        // "$012": 0x24 + 0x30 + 0x31 + 0x32 = 0xB7.
        assert_eq!(checksum(b"$012"), 0xB7);
        assert_eq!(encode_line("$012", true), b"$012B7\r");
        assert_eq!(encode_line("$012", false), b"$012\r");
        assert_eq!(check_line(b"$012B7", true), Ok(&b"$012"[..]));
        assert_eq!(check_line(b"$012b7", true), Ok(&b"$012"[..]));
        assert_eq!(
            check_line(b"$012B8", true),
            Err(FrameError::BadChecksum {
                expected: 0xB7,
                found: 0xB8
            })
        );
        assert_eq!(check_line(b"$012", false), Ok(&b"$012"[..]));
        assert_eq!(check_line(b"$012XY", true), Err(FrameError::NotHexChecksum));
        assert_eq!(
            check_line(b"B7", true),
            Err(FrameError::MissingChecksum { len: 2 })
        );
        assert_eq!(
            check_line(b"$0\x012", false),
            Err(FrameError::NotText { at: 2, byte: 1 })
        );
    }

    #[test]
    fn every_command_round_trips() {
        let all = [
            Command::SetConfig {
                address: 1,
                new_address: 2,
                type_code: 0x24,
                baud_code: 6,
                format: 0,
            },
            Command::SyncSample,
            Command::ReadCounter {
                address: 3,
                channel: 2,
            },
            Command::ReadConfig { address: 1 },
            Command::ReadSync { address: 1 },
            Command::ReadResetStatus { address: 1 },
            Command::ReadInputStatus { address: 1 },
            Command::ReadFirmware { address: 1 },
            Command::ReadName { address: 1 },
            Command::ClearLatches { address: 1 },
            Command::ClearCounter {
                address: 1,
                channel: 15,
            },
            Command::ReadLatches {
                address: 1,
                high: true,
            },
            Command::ReadLatches {
                address: 1,
                high: false,
            },
            Command::ReadInputs { address: 0xAB },
            Command::SetName {
                address: 1,
                name: "9053".into(),
            },
            Command::ReadProtocol { address: 1 },
            Command::SetProtocol {
                address: 1,
                modbus: true,
            },
            Command::HostOk,
            Command::ReadModuleStatus { address: 1 },
            Command::ResetModuleStatus { address: 1 },
            Command::ReadWatchdog { address: 1 },
            Command::SetWatchdog {
                address: 1,
                enabled: true,
                value: 0x64,
            },
        ];
        let bodies = [
            "%0102240600",
            "#**",
            "#032",
            "$012",
            "$014",
            "$015",
            "$016",
            "$01F",
            "$01M",
            "$01C",
            "$01CF",
            "$01L1",
            "$01L0",
            "@AB",
            "~01O9053",
            "$01P",
            "$01P1",
            "~**",
            "~010",
            "~011",
            "~012",
            "~013164",
        ];
        for (cmd, body) in all.iter().zip(bodies) {
            assert_eq!(cmd.body(), body);
            assert_eq!(Command::parse(body.as_bytes()).as_ref(), Ok(cmd), "{body}");
        }
    }

    #[test]
    fn invalid_commands_name_their_address_and_garbage_names_none() {
        for body in [
            "$01X",
            "$01c",
            "#02G",
            "$01L2",
            "~013",
            "~01O",
            "~01O1234567",
            "@01FF",
        ] {
            assert_eq!(
                Command::parse(body.as_bytes()),
                Err(ParseError::Invalid {
                    address: if body.starts_with("#02") { 2 } else { 1 }
                }),
                "{body}"
            );
        }
        for body in ["", "$", "$0", "$G12", "!01", "$**", "\u{1}\u{3}"] {
            assert_eq!(
                Command::parse(body.as_bytes()),
                Err(ParseError::NoAddress),
                "{body}"
            );
        }
        // Lower-case hexadecimal addresses are read.
        assert_eq!(
            Command::parse(b"@ab"),
            Ok(Command::ReadInputs { address: 0xAB })
        );
    }

    #[test]
    fn answers_round_trip() {
        let cases: [(Command, Answer, &str); 13] = [
            (
                Command::ReadConfig { address: 1 },
                Answer::Config {
                    type_code: 0x40,
                    baud_code: 6,
                    format: 0,
                },
                "!01400600",
            ),
            (
                Command::ReadSync { address: 1 },
                Answer::Sync {
                    first: true,
                    inputs: 0x0F00,
                },
                "!10F0000",
            ),
            (
                Command::ReadResetStatus { address: 1 },
                Answer::ResetStatus(true),
                "!011",
            ),
            (
                Command::ReadInputStatus { address: 1 },
                Answer::InputStatus(0x000F),
                "!000F00",
            ),
            (
                Command::ReadFirmware { address: 1 },
                Answer::Text("D04.03".into()),
                "!01D04.03",
            ),
            (
                Command::ReadCounter {
                    address: 3,
                    channel: 2,
                },
                Answer::Counter(103),
                "!0300103",
            ),
            (
                Command::ReadLatches {
                    address: 1,
                    high: true,
                },
                Answer::Latches(0x0123),
                "!012300",
            ),
            (
                Command::ReadInputs { address: 1 },
                Answer::Inputs(0x000F),
                ">000F",
            ),
            (
                Command::ReadProtocol { address: 1 },
                Answer::Protocol { modbus: false },
                "!0110",
            ),
            (
                Command::ReadModuleStatus { address: 1 },
                Answer::ModuleStatus(0x04),
                "!0104",
            ),
            (
                Command::ReadWatchdog { address: 1 },
                Answer::Watchdog {
                    enabled: true,
                    value: 0x64,
                },
                "!01164",
            ),
            (
                Command::SetConfig {
                    address: 1,
                    new_address: 2,
                    type_code: 0x40,
                    baud_code: 6,
                    format: 0,
                },
                Answer::Ack,
                "!02",
            ),
            (
                Command::ReadCounter {
                    address: 2,
                    channel: 5,
                },
                Answer::Invalid,
                "?02",
            ),
        ];
        for (cmd, answer, text) in cases {
            let address = cmd.reply_address().unwrap();
            assert_eq!(answer.body(address), text);
            assert_eq!(Answer::parse(&cmd, text.as_bytes()), Ok(answer), "{text}");
        }
    }

    #[test]
    fn answers_of_the_wrong_shape_or_address_are_refused() {
        let read = Command::ReadInputs { address: 1 };
        assert_eq!(
            Answer::parse(&read, b">00F"),
            Err(AnswerError::Malformed { len: 4 })
        );
        assert_eq!(
            Answer::parse(&Command::ReadName { address: 1 }, b"!029053"),
            Err(AnswerError::WrongAddress {
                expected: 1,
                found: 2
            })
        );
        assert_eq!(
            Answer::parse(&Command::SyncSample, b""),
            Err(AnswerError::Broadcast)
        );
        let counter = Command::ReadCounter {
            address: 1,
            channel: 0,
        };
        assert!(Answer::parse(&counter, b"!010012A").is_err());
        assert!(Answer::parse(&counter, b"!01001234").is_err());
        assert!(Answer::parse(&Command::ReadSync { address: 1 }, b"!20F0000").is_err());
        assert!(Answer::parse(&Command::ReadConfig { address: 1 }, b"!014006").is_err());
        // Arbitrary bytes never panic.
        for cmd in [read, counter, Command::ReadWatchdog { address: 1 }] {
            for junk in [&b""[..], b"!", b"?", b"?0", b"!0", b">", b"!01\xff\xfe"] {
                drop(Answer::parse(&cmd, junk));
            }
        }
    }
}
