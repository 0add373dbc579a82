//! The bus owner's frame trace: every frame it sends and receives, every timeout and every
//! byte it throws away, handed to a [`WireTap`] as it happens, on the line's own clock.
//!
//! The tap is optional: a bus owner without one does no formatting and no allocation for it
//! (one `Option` test per event). The events borrow the owner's buffers; a tap that keeps
//! anything copies it.

use std::fmt::{self, Write as _};
use std::time::Duration;

use crate::time::LineInstant;

use super::decode::{decode_reply, decode_request};
use super::Shown;
use crate::line::echo::EchoFault;

/// Where the bus owner reports its traffic.
pub trait WireTap: Send + Sync + fmt::Debug {
    /// One event on the line `bus`, at the line's time `at`.
    fn record(&self, bus: &str, at: LineInstant, event: &WireEvent<'_>);
}

/// What happened on a line.
#[derive(Debug, Clone, Copy)]
pub enum WireEvent<'a> {
    /// A frame was sent; `at` is when its transmission started.
    Sent(&'a [u8]),
    /// Bytes came back for `request`; `at` is when the last of them arrived.
    Received {
        /// The bytes (a whole reply, or what came before it was given up on).
        bytes: &'a [u8],
        /// The request they answer, as sent.
        request: &'a [u8],
        /// What the bus owner made of them.
        verdict: Verdict,
    },
    /// Nothing came within `waited` after the request.
    Timeout {
        /// The response timeout waited.
        waited: Duration,
    },
    /// The request's echo was wrong or missing, or came back as the reply (`echo:` of the
    /// bus, `line/echo.rs`).
    Echo(EchoFault),
    /// Bytes the bus owner dropped.
    Discarded {
        /// How many.
        count: usize,
        /// When and why.
        why: Discard,
    },
}

/// How the bus owner took a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Verdict {
    /// A complete, verified reply.
    Good,
    /// Part of a reply, then silence.
    Cut,
    /// Refused (CRC, another unit or function, no end).
    Refused,
}

/// Why bytes were dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Discard {
    /// They arrived while the line was idle, before a request (a late reply, noise).
    BeforeRequest,
    /// They followed a complete reply.
    AfterReply,
    /// They came during the guard time after a timeout or a bad reply (a late reply).
    AfterGuard,
}

/// One trace line: `t=<line time>  <bus>  <dir>  <hex>  | <decoding>`. TX frames decode as
/// requests, RX frames as the answer to their request.
pub fn format_event(bus: &str, at: LineInstant, event: &WireEvent<'_>) -> String {
    let mut line = String::with_capacity(128);
    let _ = write!(line, "t={}  {bus}  ", LineTime(at.since_origin()));
    let _ = match event {
        WireEvent::Sent(bytes) => write!(line, "TX  {}  | {}", Shown(bytes), decode_request(bytes)),
        WireEvent::Received {
            bytes,
            request,
            verdict,
        } => {
            let note = match verdict {
                Verdict::Good => "",
                Verdict::Cut => " (cut: then silence)",
                Verdict::Refused => " (refused)",
            };
            write!(
                line,
                "RX  {}  | {}{note}",
                Shown(bytes),
                decode_reply(bytes, request)
            )
        }
        WireEvent::Timeout { waited } => {
            write!(line, "--  timeout: no reply within {}", LineTime(*waited))
        }
        WireEvent::Echo(fault) => write!(line, "--  {fault}"),
        WireEvent::Discarded { count, why } => {
            let why = match why {
                Discard::BeforeRequest => "arrived while the line was idle",
                Discard::AfterReply => "followed the reply",
                Discard::AfterGuard => "came late, flushed after the guard time",
            };
            write!(line, "--  discarded {count} byte(s): {why}")
        }
    };
    line
}

/// A line time as seconds with microseconds: `12.345678s`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LineTime(pub Duration);

impl fmt::Display for LineTime {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}.{:06}s", self.0.as_secs(), self.0.subsec_micros())
    }
}
