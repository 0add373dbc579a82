//! Seeing the wire: one frame decoder for the bus owner's frame trace (`softplc run
//! --trace-bus`) and the passive bus monitor (`softplc monitor`).
//!
//! - [`decode_request`], [`decode_reply`]: a frame's bytes in, a typed [`Decoded`] out: Modbus
//!   RTU (through the codec of [`crate::modbus`]), MiniMod text, RESI ASCII and DCON (through
//!   the families' own parsers). What none of them knows is [`Decoded::Unrecognised`], never a
//!   panic.
//! - [`Framer`]: a passively heard byte stream cut into frames by silence (t3.5) and
//!   terminators, sans-IO (bytes and their arrival time in, frames out).
//! - [`WireTap`]: the optional tap the bus owner reports every frame, timeout and discarded
//!   byte to, and the trace line format ([`format_event`]).

mod dcon;
pub(crate) mod decode;
pub(crate) mod framer;
pub(crate) mod rtu;
pub(crate) mod text;
pub(crate) mod trace;

#[cfg(test)]
mod tests;

use std::fmt;

pub use decode::{decode_reply, decode_request, Conversation, Decoded, Unrecognised};
pub use framer::{frame_gap, unglue, FrameEnd, MAX_FRAME};
pub use framer::{Framer, Framing, HeardFrame};
pub use rtu::Rtu;
pub use text::{Dcon, MiniMod, Resi};
pub use trace::{format_event, Discard, LineTime, Verdict};
pub use trace::{WireEvent, WireTap};

/// A frame as the trace and the monitor print it: its hex, and for a text line its text too
/// (CR and LF written `\r`, `\n`).
#[derive(Debug, Clone, Copy)]
pub struct Shown<'a>(pub &'a [u8]);

impl fmt::Display for Shown<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        Hex(self.0).fmt(f)?;
        if decode::is_text(self.0) {
            f.write_str("  \"")?;
            for &b in self.0 {
                match b {
                    b'\r' => f.write_str("\\r")?,
                    b'\n' => f.write_str("\\n")?,
                    b => write!(f, "{}", char::from(b))?,
                }
            }
            f.write_str("\"")?;
        }
        Ok(())
    }
}

/// Bytes as upper-case hex pairs separated by spaces: `01 03 00 00`.
#[derive(Debug, Clone, Copy)]
pub struct Hex<'a>(pub &'a [u8]);

impl fmt::Display for Hex<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, b) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str(" ")?;
            }
            write!(f, "{b:02X}")?;
        }
        Ok(())
    }
}
