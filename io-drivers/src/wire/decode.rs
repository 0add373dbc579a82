//! One frame in, one typed decoding out: [`decode_request`] for what a master sends,
//! [`decode_reply`] for what answers it, [`Conversation`] for a line heard passively, where
//! nobody says which is which.

use std::fmt;

use super::rtu::{self, Rtu};
use super::text::{self, Dcon, MiniMod, Resi};

/// A frame, decoded.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Decoded {
    /// Modbus RTU.
    Rtu(Rtu),
    /// MiniMod text.
    MiniMod(MiniMod),
    /// RESI ASCII.
    Resi(Resi),
    /// DCON (EX-9053D).
    Dcon(Dcon),
    /// Nothing softplc knows; the hex says what it was.
    Unrecognised(Unrecognised),
}

/// Why a frame was not recognised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Unrecognised {
    /// No bytes.
    Empty,
    /// Printable text of none of the protocols.
    Text,
    /// Printable text without its terminator (CR): cut, or still coming.
    Unterminated,
    /// Binary, but no Modbus frame (too short, an unknown function, a wrong length).
    Binary,
}

impl Decoded {
    /// Whether a device answers this frame.
    pub fn expects_reply(&self) -> bool {
        match self {
            Decoded::Rtu(r) => r.expects_reply(),
            Decoded::MiniMod(MiniMod::Command(_)) => true,
            Decoded::Resi(r) => !r.answer,
            Decoded::Dcon(Dcon::Command { command, .. }) => command.reply_address().is_some(),
            _ => false,
        }
    }
}

/// Whether every byte is printable ASCII (or CR, LF): a text line rather than RTU.
pub(crate) fn is_text(frame: &[u8]) -> bool {
    !frame.is_empty()
        && frame
            .iter()
            .all(|b| (0x20..0x7F).contains(b) || matches!(b, b'\r' | b'\n'))
}

/// A frame as a master sends it.
pub fn decode_request(frame: &[u8]) -> Decoded {
    if frame.is_empty() {
        return Decoded::Unrecognised(Unrecognised::Empty);
    }
    if is_text(frame) {
        return text_request(frame).unwrap_or_else(|| unrecognised_text(frame));
    }
    match rtu::request(frame) {
        Some(r) => Decoded::Rtu(r),
        None => Decoded::Unrecognised(Unrecognised::Binary),
    }
}

/// A frame as the answer to `request` (the request's bytes as sent). A frame that does not
/// answer it is decoded on its own.
pub fn decode_reply(frame: &[u8], request: &[u8]) -> Decoded {
    paired_reply(frame, &decode_request(request)).unwrap_or_else(|| decode_alone(frame))
}

/// A text line as a request; every protocol's lines end with CR, so one without is none.
fn text_request(line: &[u8]) -> Option<Decoded> {
    if !terminated(line) {
        return None;
    }
    if text::is_dcon_hash(line) {
        return text::dcon_command(line).map(Decoded::Dcon);
    }
    if line.first() == Some(&b'#') {
        return text::resi(line).map(Decoded::Resi);
    }
    text::minimod_command(line)
        .map(Decoded::MiniMod)
        .or_else(|| text::dcon_command(line).map(Decoded::Dcon))
}

fn terminated(line: &[u8]) -> bool {
    line.ends_with(b"\r") || line.ends_with(b"\r\n")
}

fn unrecognised_text(line: &[u8]) -> Decoded {
    let why = if terminated(line) {
        Unrecognised::Text
    } else {
        Unrecognised::Unterminated
    };
    Decoded::Unrecognised(why)
}

/// `frame` as the answer to `request`, if it is one.
fn paired_reply(frame: &[u8], request: &Decoded) -> Option<Decoded> {
    match request {
        Decoded::Rtu(Rtu::Request { unit, request }) if !is_text(frame) => {
            rtu::reply_to(frame, *unit, request).map(Decoded::Rtu)
        }
        _ if !terminated(frame) => None,
        Decoded::MiniMod(MiniMod::Command(_)) => text::minimod_reply(frame).map(Decoded::MiniMod),
        Decoded::Resi(request) => text::resi_answer(frame, request).map(Decoded::Resi),
        Decoded::Dcon(Dcon::Command { command, checksum }) => {
            text::dcon_answer(frame, command, *checksum).map(Decoded::Dcon)
        }
        _ => None,
    }
}

/// A frame with no request to pair it with: a request, or a reply decoded from itself.
fn decode_alone(frame: &[u8]) -> Decoded {
    if is_text(frame) {
        return text_request(frame)
            .or_else(|| {
                terminated(frame)
                    .then(|| text::minimod_reply(frame).map(Decoded::MiniMod))
                    .flatten()
            })
            .unwrap_or_else(|| unrecognised_text(frame));
    }
    match decode_request(frame) {
        Decoded::Rtu(r @ Rtu::Request { .. }) => Decoded::Rtu(r),
        other => rtu::reply_alone(frame).map(Decoded::Rtu).unwrap_or(other),
    }
}

/// A line heard passively: each frame is taken as the answer to the request before it when it
/// is one, else as a request (or, failing that, a reply whose request was not heard).
#[derive(Debug, Clone, Default)]
pub struct Conversation {
    /// The last request that expects an answer, as it came.
    pending: Option<Decoded>,
}

impl Conversation {
    /// A conversation that has heard nothing yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Decodes the next frame heard.
    pub fn frame(&mut self, frame: &[u8]) -> Decoded {
        if let Some(request) = self.pending.take() {
            if let Some(reply) = paired_reply(frame, &request) {
                return reply;
            }
        }
        let decoded = decode_alone(frame);
        if decoded.expects_reply() {
            self.pending = Some(decoded.clone());
        }
        decoded
    }
}

impl fmt::Display for Unrecognised {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Unrecognised::Empty => "unrecognised: no bytes",
            Unrecognised::Text => "unrecognised text",
            Unrecognised::Unterminated => "unrecognised: text without its CR",
            Unrecognised::Binary => "unrecognised: no Modbus RTU frame",
        })
    }
}

impl fmt::Display for Decoded {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Decoded::Rtu(r) => write!(f, "rtu {r}"),
            Decoded::MiniMod(m) => m.fmt(f),
            Decoded::Resi(r) => r.fmt(f),
            Decoded::Dcon(d) => d.fmt(f),
            Decoded::Unrecognised(u) => u.fmt(f),
        }
    }
}
