//! Cutting a passively heard byte stream into frames, sans-IO: fed with bytes and the time
//! they arrived, it says where each frame starts and ends and how long the line was silent
//! before it. The monitor feeds it from a serial port; the tests feed it synthetic times.
//!
//! - Modbus RTU frames end at a silence of t3.5 (Modbus over Serial Line v1.02 §2.5.1.1: 3.5
//!   characters up to 19200 Bd, 1.75 ms above), as [`LineSettings::t3_5`] computes it.
//! - Text lines (MiniMod "Text commands protocol", RESI §2.1, DCON chapter 2) end at CR. An
//!   LF right after a CR (terminals send CR LF) is not a frame of its own.
//! - In [`Framing::Auto`] a CR ends the frame only while every byte of it so far is printable
//!   ASCII and there is text before it: a CR inside a binary RTU frame is data (resi-spec §2.9 tells the two protocols
//!   apart the same way).
//! - RTU frames that arrive without the silence between them are split where their CRCs say
//!   ([`unglue`]).
//! - A frame never grows past [`MAX_FRAME`] bytes (a stuck transmitter, noise without a
//!   pause): it is cut there, so memory stays bounded whatever the line does.

use std::time::Duration;

use crate::line::settings::LineSettings;
use crate::modbus::crc::check_crc;

/// The longest frame kept: an RTU ADU is at most 256 bytes, text lines are shorter.
pub const MAX_FRAME: usize = 512;

/// How frames are told apart.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Framing {
    /// By content: text lines end at CR, everything else at silence.
    Auto,
    /// Modbus RTU only: silence ends a frame.
    Rtu,
    /// Text only: CR ends a line (silence ends a line cut short).
    Text,
}

/// What ended a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FrameEnd {
    /// The line was silent for the frame gap.
    Silence,
    /// Its CR.
    Terminator,
    /// It reached [`MAX_FRAME`] bytes.
    Overflow,
    /// The capture ended.
    Finished,
    /// No silence was seen after it: it arrived glued to the next RTU frame, and the CRCs
    /// told where it ends ([`unglue`]).
    Glued,
}

/// A frame as it was heard.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct HeardFrame {
    /// Its bytes, terminator included.
    pub bytes: Vec<u8>,
    /// When its first byte arrived.
    pub start: Duration,
    /// When its last byte arrived.
    pub end: Duration,
    /// Silence between the end of the frame before and this one's start (`None` for the
    /// first frame, and for one read together with the frame before: no silence was seen).
    pub gap: Option<Duration>,
    /// What ended it.
    pub ended_by: FrameEnd,
}

/// The framing state machine.
#[derive(Debug, Clone)]
pub struct Framer {
    framing: Framing,
    silence: Duration,
    buf: Vec<u8>,
    start: Duration,
    last_byte: Duration,
    prev_end: Option<Duration>,
    /// The frame before ended at a CR: a LF now belongs to it.
    after_cr: bool,
}

impl Framer {
    /// A framer whose frames end at `silence` (see [`frame_gap`]).
    pub fn new(framing: Framing, silence: Duration) -> Self {
        Self {
            framing,
            silence,
            buf: Vec::with_capacity(MAX_FRAME),
            start: Duration::ZERO,
            last_byte: Duration::ZERO,
            prev_end: None,
            after_cr: false,
        }
    }

    /// The silence that ends a frame.
    pub fn silence(&self) -> Duration {
        self.silence
    }

    /// Takes `bytes` that arrived at `at` (times never go back); appends the frames they end,
    /// a frame that a silence before them ended first.
    pub fn push(&mut self, bytes: &[u8], at: Duration, out: &mut Vec<HeardFrame>) {
        if bytes.is_empty() {
            return;
        }
        out.extend(self.poll(at));
        for &b in bytes {
            if self.buf.is_empty() {
                if std::mem::take(&mut self.after_cr) && b == b'\n' {
                    continue;
                }
                self.start = at;
            }
            self.buf.push(b);
            self.last_byte = at;
            if b == b'\r' && self.ends_at_cr() {
                out.push(self.take(FrameEnd::Terminator));
                self.after_cr = true;
            } else if self.buf.len() >= MAX_FRAME {
                out.push(self.take(FrameEnd::Overflow));
            }
        }
    }

    /// The frame a silence has ended by `now`, if any.
    pub fn poll(&mut self, now: Duration) -> Option<HeardFrame> {
        if self.buf.is_empty() {
            // A LF long after its CR is noise of its own.
            if now >= self.last_byte + self.silence {
                self.after_cr = false;
            }
            return None;
        }
        (now >= self.last_byte + self.silence).then(|| self.take(FrameEnd::Silence))
    }

    /// When [`Framer::poll`] can next end a frame: `None` with nothing held.
    pub fn deadline(&self) -> Option<Duration> {
        (!self.buf.is_empty()).then_some(self.last_byte + self.silence)
    }

    /// The frame held when the capture ends.
    pub fn finish(&mut self) -> Option<HeardFrame> {
        (!self.buf.is_empty()).then(|| self.take(FrameEnd::Finished))
    }

    fn ends_at_cr(&self) -> bool {
        match self.framing {
            Framing::Rtu => false,
            Framing::Text => true,
            // A CR alone is no line: it may be the address byte of unit 13.
            Framing::Auto => self.buf.len() > 1 && super::decode::is_text(&self.buf),
        }
    }

    fn take(&mut self, ended_by: FrameEnd) -> HeardFrame {
        let frame = HeardFrame {
            bytes: std::mem::replace(&mut self.buf, Vec::with_capacity(MAX_FRAME)),
            start: self.start,
            end: self.last_byte,
            // Known only when this frame's first byte came in a later read than the last byte
            // of the one before: two frames read at once (a reader late on a loaded machine)
            // show no silence between them, which is not a silence of zero.
            gap: self
                .prev_end
                .filter(|&end| self.start > end)
                .map(|end| self.start - end),
            ended_by,
        };
        self.prev_end = Some(self.last_byte);
        frame
    }
}

/// The most RTU frames [`unglue`] finds in one piece of silence.
const MAX_GLUED: usize = 8;

/// RTU frames that came without the silence between them (a reader late by more than the
/// frame gap on a loaded machine, a USB adapter's burst), split where the CRCs say: only when
/// the whole is not one frame with a good CRC and divides completely into frames that each
/// have one (noise does so by chance once in 2^32 per split). Text lines and anything else
/// come back whole. The pieces keep the whole's times; every piece but the last ends
/// [`FrameEnd::Glued`] and every piece but the first has no gap.
pub fn unglue(frame: HeardFrame) -> Vec<HeardFrame> {
    if super::decode::is_text(&frame.bytes) || check_crc(&frame.bytes) {
        return vec![frame];
    }
    let Some(lengths) = partition(&frame.bytes, MAX_GLUED) else {
        return vec![frame];
    };
    let mut pieces = Vec::with_capacity(lengths.len());
    let mut at = 0;
    let last = lengths.len() - 1;
    for (i, len) in lengths.into_iter().enumerate() {
        pieces.push(HeardFrame {
            bytes: frame.bytes.get(at..at + len).unwrap_or_default().to_vec(),
            start: frame.start,
            end: frame.end,
            gap: if i == 0 { frame.gap } else { None },
            ended_by: if i == last {
                frame.ended_by
            } else {
                FrameEnd::Glued
            },
        });
        at += len;
    }
    pieces
}

/// The lengths of at most `most` frames with good CRCs that `bytes` is made of, shortest
/// first; `None` if it is not.
fn partition(bytes: &[u8], most: usize) -> Option<Vec<usize>> {
    if check_crc(bytes) {
        return Some(vec![bytes.len()]);
    }
    if most < 2 {
        return None;
    }
    // The shortest RTU frame is 4 bytes (an address, a function and the CRC).
    (4..bytes.len().saturating_sub(3)).find_map(|len| {
        let head = bytes.get(..len)?;
        if !check_crc(head) {
            return None;
        }
        let mut rest = partition(bytes.get(len..)?, most - 1)?;
        rest.insert(0, len);
        Some(rest)
    })
}

/// The silence that ends an RTU frame on a line: t3.5 from its baud and format.
pub fn frame_gap(settings: LineSettings) -> Duration {
    settings.t3_5()
}
