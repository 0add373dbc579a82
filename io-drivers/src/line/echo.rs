//! Adapters that hear their own transmission, and discarding what they hear (`echo: discard`).
//!
//! On a 2-wire RS-485 line the transceiver's receiver sees the bus, the master's own frame
//! included. Many USB adapters (FTDI reference designs keep RE enabled: "the data transmitted
//! … is also present on the receive path") and boards whose receiver is always enabled hand
//! that echo to the host; a UART in kernel RS-485 mode without `RX_DURING_TX` does not. With
//! `echo: discard` the master reads back exactly the bytes it sent, checks them, and only then
//! listens for the reply, as pymodbus' `handle_local_echo` and j2mod's `echo` do.
//!
//! The echo arrives while the frame is sent, so it costs the line nothing beyond the frame's
//! own wire time (plus an adapter's latency timer, which delays the reply the same way; see
//! [`crate::line::latency`]): the budget counts nothing extra for it.

use std::fmt;
use std::str::FromStr;
use std::time::Duration;

use crate::time::LineInstant;

use crate::line::settings::LineSettings;
use crate::line::transport::{LineError, Transport};

/// Whether the line's adapter hears its own transmission, and what the master does about it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EchoMode {
    /// The adapter does not echo: what arrives after a request is the reply (the default).
    #[default]
    None,
    /// The adapter echoes every frame: read it back, verify it, then wait for the reply.
    Discard,
}

/// Why an echo setting was refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("echo must be none or discard")]
pub struct BadEchoMode;

impl FromStr for EchoMode {
    type Err = BadEchoMode;

    fn from_str(s: &str) -> Result<Self, BadEchoMode> {
        match s {
            "none" => Ok(Self::None),
            "discard" => Ok(Self::Discard),
            _ => Err(BadEchoMode),
        }
    }
}

impl fmt::Display for EchoMode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::None => "none",
            Self::Discard => "discard",
        })
    }
}

/// How the echo of a request went wrong (a line error: nothing a device said).
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum EchoFault {
    /// `echo: discard`, and fewer bytes than were sent came back in time: the adapter does not
    /// echo (the setting is wrong for it), or the line is broken between the adapter's
    /// transmitter and its receiver.
    #[error(
        "echo missing: {got} of the request's {sent} bytes came back (does this adapter echo? \
         set echo: none if it does not)"
    )]
    Missing {
        /// Bytes that came back.
        got: u16,
        /// Bytes sent.
        sent: u16,
    },
    /// `echo: discard`, and the bytes that came back differ from those sent, from byte
    /// `offset` (0-based): a collision with another transmitter, or noise.
    #[error("echo differs from the request at byte {offset} (a collision or noise on the line)")]
    Mismatch {
        /// First differing byte, 0-based.
        offset: u16,
    },
    /// No `echo: discard`, and what came back after a request began with the request itself:
    /// the adapter echoes what it sends.
    #[error(
        "the reply began with the request's own bytes: the adapter hears its own transmission \
         (set echo: discard on this bus)"
    )]
    Unexpected,
}

/// Compares what came back with what was sent: `Ok(())` when the first `sent.len()` bytes of
/// `heard` are the request.
pub(crate) fn verify(sent: &[u8], heard: &[u8]) -> Result<(), EchoFault> {
    let clip = |n: usize| u16::try_from(n).unwrap_or(u16::MAX);
    if let Some(offset) = sent.iter().zip(heard).position(|(a, b)| a != b) {
        return Err(EchoFault::Mismatch {
            offset: clip(offset),
        });
    }
    if heard.len() < sent.len() {
        return Err(EchoFault::Missing {
            got: clip(heard.len()),
            sent: clip(sent.len()),
        });
    }
    Ok(())
}

/// Whether a failed reply `heard` is the request `sent` coming back: the two agree on at least
/// three bytes (a Modbus reply to a read is refused at its third, the byte count) and on all
/// of the shorter one. Only asked of replies that failed: a good reply to FC 5 or 6 is the
/// request's copy by the protocol.
pub(crate) fn begins_with_request(sent: &[u8], heard: &[u8]) -> bool {
    let common = sent.iter().zip(heard).take_while(|(a, b)| a == b).count();
    common >= 3.min(sent.len()) && common == sent.len().min(heard.len()) && common > 0
}

/// How long after a frame has left the echo may still be on its way: bytes reach the host in
/// chunks (a USB adapter's packets, a pty's scheduling), the same allowance the bus owner
/// gives between a reply's characters, plus the adapter's latency timer, which holds received
/// bytes back.
pub fn echo_margin(settings: LineSettings, adapter_latency: Duration) -> Duration {
    settings.chunk_allowance() + adapter_latency
}

/// A transport whose adapter echoes: [`Transport::write_frame`] sends the frame and returns
/// once its echo has come back and matched; a bad or missing echo is
/// [`LineError::Echo`], after which the bus owner keeps its guard time and flushes, as after
/// a bad reply. Bytes that arrive after the echo (a reply already under way) are kept for the
/// next read.
#[derive(Debug)]
pub struct EchoDiscard {
    inner: Box<dyn Transport>,
    margin: Duration,
    /// What came after the echo, not yet read.
    pending: Vec<u8>,
    heard: Vec<u8>,
}

impl EchoDiscard {
    /// Wraps `inner`; the echo may come up to `margin` after the frame's wire time
    /// ([`echo_margin`]).
    pub fn new(inner: Box<dyn Transport>, margin: Duration) -> Self {
        Self {
            inner,
            margin,
            pending: Vec::new(),
            heard: Vec::with_capacity(256),
        }
    }
}

impl Transport for EchoDiscard {
    fn settings(&self) -> LineSettings {
        self.inner.settings()
    }

    fn now(&self) -> LineInstant {
        self.inner.now()
    }

    fn sync(&mut self, t: LineInstant) {
        self.inner.sync(t);
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let start = self.inner.now();
        self.pending.clear();
        self.inner.write_frame(frame)?;
        let deadline = start + self.settings().chars(frame.len()) + self.margin;
        self.heard.clear();
        while self.heard.len() < frame.len() {
            if self.inner.read_until(&mut self.heard, deadline)? == 0 {
                break;
            }
        }
        let split = self.heard.len().min(frame.len());
        self.pending.extend_from_slice(&self.heard[split..]);
        verify(frame, &self.heard[..split]).map_err(LineError::Echo)
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        if !self.pending.is_empty() {
            let n = self.pending.len();
            buf.append(&mut self.pending);
            return Ok(n);
        }
        self.inner.read_until(buf, deadline)
    }

    fn wait_until(&mut self, t: LineInstant) {
        self.inner.wait_until(t);
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        let kept = std::mem::take(&mut self.pending).len();
        Ok(kept + self.inner.flush_input()?)
    }

    fn reopen(&mut self) -> Result<(), LineError> {
        self.pending.clear();
        self.inner.reopen()
    }
}

#[cfg(test)]
mod tests;
