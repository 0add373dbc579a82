//! The RESI ASCII frame: `#[<ADR>,]<Command>[:<p1>,<p2>...]<CR>` (L2029–L2037), answered
//! `#[<ADR>,]<Answer><CR>`. No LF, no checksum, no escapes (resi-spec §2.1).
//!
//! - The address is decimal or `0x` + hexadecimal and is echoed as it arrived (`#0x2B,VER` →
//!   `#0x2B,VERSION:3.0.0`, L2072–L2098), so [`Address`] keeps its spelling.
//! - Numbers are decimal or `0x` + hex (L2012–L2015); the manual allows only `A`–`F`, this
//!   parser also takes `a`–`f`. Answers write hex as `0x` + upper-case digits without padding
//!   (`GSMODE:1,0x1`, L16498).
//! - Real numbers (2RTD) use a `.` (L5430).

use super::super::value::Num;

/// Why a frame is not a RESI ASCII frame. The simulator stays silent on all of them: the
/// manual documents no error answer (resi-spec §2.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub(crate) enum FrameError {
    /// No `#`.
    #[error("no start character #")]
    NoStart,
    /// No CR at the end.
    #[error("no end character CR")]
    NoEnd,
    /// A byte that is not printable ASCII at this offset of the frame body.
    #[error("byte {at} of the frame is not printable ASCII")]
    NotPrintable {
        /// Offset after the `#`.
        at: usize,
    },
    /// The part before the first `,` is not a number.
    #[error("bad bus address")]
    BadAddress,
    /// No command name.
    #[error("empty command")]
    Empty,
}

/// A bus address as it arrived.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Address<'a> {
    /// Its spelling (`43`, `0x2B`).
    pub text: &'a str,
    /// Its value (may exceed 255; then it addresses nobody).
    pub value: u32,
}

/// A parsed request or answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Frame<'a> {
    /// The address, if the frame has one.
    pub address: Option<Address<'a>>,
    /// The command (or the answer's keyword), spaces included.
    pub keyword: &'a str,
    /// The text after `:`, if any.
    pub params: Option<&'a str>,
}

impl<'a> Frame<'a> {
    /// Parses a whole frame, CR included. A frame cut short by a new `#` is dropped: parsing
    /// starts at the last `#` (resi-spec §2.4: "discard a partial frame when a new `#`
    /// arrives"). An LF after the CR is tolerated, as terminals send CR LF.
    pub(crate) fn parse(bytes: &'a [u8]) -> Result<Self, FrameError> {
        let start = bytes
            .iter()
            .rposition(|&b| b == b'#')
            .ok_or(FrameError::NoStart)?;
        let rest = bytes.get(start + 1..).unwrap_or_default();
        let rest = rest.strip_suffix(b"\n").unwrap_or(rest);
        let body = rest.strip_suffix(b"\r").ok_or(FrameError::NoEnd)?;
        Self::parse_body(body)
    }

    /// Parses the text between `#` and CR (an answer as the bus owner hands it over, with its
    /// `#` and without CR, goes through [`Frame::parse_answer`]).
    pub(crate) fn parse_body(body: &'a [u8]) -> Result<Self, FrameError> {
        if let Some(at) = body.iter().position(|b| !(0x20..0x7F).contains(b)) {
            return Err(FrameError::NotPrintable { at });
        }
        let text = std::str::from_utf8(body).map_err(|_| FrameError::NotPrintable { at: 0 })?;
        let (head, params) = match text.split_once(':') {
            Some((h, p)) => (h, Some(p)),
            None => (text, None),
        };
        let (address, keyword) = match head.split_once(',') {
            Some((a, k)) => {
                let value = parse_address(a).ok_or(FrameError::BadAddress)?;
                (Some(Address { text: a, value }), k)
            }
            None => (None, head),
        };
        if keyword.is_empty() {
            return Err(FrameError::Empty);
        }
        Ok(Self {
            address,
            keyword,
            params,
        })
    }

    /// Parses an answer as the bus owner hands it over: `#...` with the CR stripped; spaces
    /// after the `:` are tolerated (printed so at L11470).
    pub(crate) fn parse_answer(bytes: &'a [u8]) -> Result<Self, FrameError> {
        let start = bytes
            .iter()
            .rposition(|&b| b == b'#')
            .ok_or(FrameError::NoStart)?;
        let body = bytes.get(start + 1..).unwrap_or_default();
        let body = body.strip_suffix(b"\r").unwrap_or(body);
        Self::parse_body(body)
    }

    /// The parameters split at `,`, trimmed; empty without `:`.
    pub(crate) fn values(&self) -> Vec<&'a str> {
        match self.params {
            None => Vec::new(),
            Some(p) => p.split(',').map(str::trim).collect(),
        }
    }
}

fn parse_address(text: &str) -> Option<u32> {
    match parse_number(text)? {
        Num::Int(v) => u32::try_from(v).ok(),
        Num::Real(_) => None,
    }
}

/// A number as the protocol writes it: decimal (optionally signed), `0x` + hex, or a real
/// with a `.`.
pub fn parse_number(text: &str) -> Option<Num> {
    let t = text.trim();
    if let Some(hex) = t.strip_prefix("0x") {
        if hex.is_empty() || hex.len() > 16 || !hex.bytes().all(|b| b.is_ascii_hexdigit()) {
            return None;
        }
        return u64::from_str_radix(hex, 16)
            .ok()
            .and_then(|v| i64::try_from(v).ok())
            .map(Num::Int);
    }
    let digits = t.strip_prefix('-').unwrap_or(t);
    if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit() || b == b'.') {
        return None;
    }
    if digits.contains('.') {
        t.parse::<f64>()
            .ok()
            .filter(|f| f.is_finite())
            .map(Num::Real)
    } else {
        t.parse::<i64>().ok().map(Num::Int)
    }
}

/// `0x` + upper-case hex without padding (`0x1`, `0x7B`); negative numbers as their 32-bit
/// two's complement.
pub(crate) fn hex(v: i64) -> String {
    if v < 0 {
        format!("0x{:X}", v as i32 as u32)
    } else {
        format!("0x{v:X}")
    }
}

/// A real number with a `.` and at most five decimals (the registers carry 1/100000), at
/// least one (`21.5`, `-999.0`).
pub(crate) fn real(v: f64) -> String {
    let s = format!("{v:.5}");
    let s = s.trim_end_matches('0');
    if s.ends_with('.') {
        format!("{s}0")
    } else {
        s.to_string()
    }
}

/// A whole frame: `#`, the address as it arrived and `,` if there was one, the body, CR.
pub fn frame(address: Option<&str>, body: &str) -> Vec<u8> {
    let mut out = Vec::with_capacity(body.len() + 8);
    out.push(b'#');
    if let Some(a) = address {
        out.extend_from_slice(a.as_bytes());
        out.push(b',');
    }
    out.extend_from_slice(body.as_bytes());
    out.push(b'\r');
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parses_the_manual_forms() {
        let f = Frame::parse(b"#SET SWITCH1:0x0001\r").unwrap();
        assert_eq!(f.address, None);
        assert_eq!(f.keyword, "SET SWITCH1");
        assert_eq!(f.values(), ["0x0001"]);
        let f = Frame::parse(b"#0x2B,VER\r").unwrap();
        assert_eq!(
            f.address,
            Some(Address {
                text: "0x2B",
                value: 43
            })
        );
        assert_eq!(f.keyword, "VER");
        let f = Frame::parse(b"#5,SAIS:10,20\r").unwrap();
        assert_eq!(f.values(), ["10", "20"]);
        let f = Frame::parse(b"#CRE\r").unwrap();
        assert_eq!((f.keyword, f.params), ("CRE", None));
        // A frame cut short by a new one, and CR LF from a terminal.
        let f = Frame::parse(b"#GDI#7,GDIS\r\n").unwrap();
        assert_eq!((f.address.map(|a| a.value), f.keyword), (Some(7), "GDIS"));
    }

    #[test]
    fn refuses_what_is_not_a_frame() {
        assert_eq!(Frame::parse(b"VER\r"), Err(FrameError::NoStart));
        assert_eq!(Frame::parse(b"#VER"), Err(FrameError::NoEnd));
        assert_eq!(Frame::parse(b"#X,VER\r"), Err(FrameError::BadAddress));
        assert_eq!(Frame::parse(b"#5,\r"), Err(FrameError::Empty));
        assert_eq!(
            Frame::parse(b"#V\x00R\r"),
            Err(FrameError::NotPrintable { at: 1 })
        );
        assert_eq!(
            Frame::parse(b"#\xFF\r"),
            Err(FrameError::NotPrintable { at: 0 })
        );
        assert_eq!(Frame::parse(b"#:\r"), Err(FrameError::Empty));
    }

    #[test]
    fn numbers() {
        assert_eq!(parse_number("37"), Some(Num::Int(37)));
        assert_eq!(parse_number("0x000F"), Some(Num::Int(15)));
        assert_eq!(parse_number("0xff"), Some(Num::Int(255)));
        assert_eq!(parse_number("-1.5"), Some(Num::Real(-1.5)));
        assert_eq!(parse_number("0x"), None);
        assert_eq!(parse_number("1e5"), None);
        assert_eq!(parse_number("-"), None);
        assert_eq!(parse_number("0xFFFFFFFFFFFFFFFFF"), None);
        assert_eq!(parse_number("99999999999999999999"), None);
        assert_eq!(hex(1), "0x1");
        assert_eq!(hex(0x7B), "0x7B");
        assert_eq!(hex(-1), "0xFFFFFFFF");
        assert_eq!(real(21.5), "21.5");
        assert_eq!(real(-999.0), "-999.0");
        assert_eq!(real(0.123456), "0.12346");
        assert_eq!(
            frame(Some("0x2B"), "VERSION:3.0.0"),
            b"#0x2B,VERSION:3.0.0\r"
        );
        assert_eq!(frame(None, "OK"), b"#OK\r");
    }

    #[test]
    fn answers() {
        let a = Frame::parse_answer(b"#5,GCLOS: 1,2,3,0x1,0x2,0x3").unwrap();
        assert_eq!(a.keyword, "GCLOS");
        assert_eq!(a.values(), ["1", "2", "3", "0x1", "0x2", "0x3"]);
        let a = Frame::parse_answer(b"#OK").unwrap();
        assert_eq!((a.address, a.keyword), (None, "OK"));
    }
}
