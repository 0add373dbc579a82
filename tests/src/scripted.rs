//! A scripted line: a fake [`Transport`] on a virtual time cursor.
//!
//! Each request the bus owner writes takes the next [`Answer`] of the script: chunks of reply
//! bytes, each arriving a given time after the request's last character has left. Time moves
//! only when the owner writes (the request's wire time), reads (to the next arrival or its
//! deadline) or waits, so every test replays exactly. The [`ScriptHandle`] stays with the test
//! to add answers and to inspect what was written, when, and what was left unread.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Duration;

use softplc_io::line::{LineError, LineSettings, Transport};

use crate::frames::hex;
use softplc_io::time::LineInstant;

/// Reply bytes arriving `after` the end of the request.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Chunk {
    /// Delay from the end of the request's last character.
    pub after: Duration,
    /// The bytes, all arriving at that instant.
    pub bytes: Vec<u8>,
}

/// What the line does after one request.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Answer {
    /// The chunks, in any order.
    pub chunks: Vec<Chunk>,
}

impl Answer {
    /// No reply at all.
    pub fn silence() -> Self {
        Self::default()
    }

    /// `bytes` arriving together, `after` the request.
    pub fn at(after: Duration, bytes: &[u8]) -> Self {
        Self::silence().then(after, bytes)
    }

    /// `bytes` as a real line delivers them: the device waits `delay`, then each byte arrives
    /// when its last bit has (byte `i` at `delay + chars(i + 1)`), each in its own read.
    pub fn on_wire(settings: LineSettings, delay: Duration, bytes: &[u8]) -> Self {
        let chunks = bytes
            .iter()
            .enumerate()
            .map(|(i, b)| Chunk {
                after: delay + settings.chars(i + 1),
                bytes: vec![*b],
            })
            .collect();
        Self { chunks }
    }

    /// `bytes` one at a time: the first `first` after the request, then one every `gap`.
    pub fn fragments(first: Duration, gap: Duration, bytes: &[u8]) -> Self {
        let chunks = bytes
            .iter()
            .enumerate()
            .map(|(i, b)| Chunk {
                after: first + gap * i as u32,
                bytes: vec![*b],
            })
            .collect();
        Self { chunks }
    }

    /// Adds `bytes` arriving `after` the request.
    pub fn then(mut self, after: Duration, bytes: &[u8]) -> Self {
        self.chunks.push(Chunk {
            after,
            bytes: bytes.to_vec(),
        });
        self
    }
}

/// A request the owner wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// When its first character started.
    pub start: Duration,
    /// When its last character had left.
    pub end: Duration,
    /// The frame.
    pub bytes: Vec<u8>,
}

#[derive(Debug)]
struct Script {
    settings: LineSettings,
    now: Duration,
    answers: VecDeque<Answer>,
    /// Bytes on their way in, with their arrival times, sorted by time.
    inbound: Vec<(Duration, u8)>,
    written: Vec<Written>,
    flushed: usize,
}

/// The test's side of a [`ScriptedTransport`].
#[derive(Debug, Clone)]
pub struct ScriptHandle(Arc<Mutex<Script>>);

/// The bus owner's side: a [`Transport`] that plays the script.
#[derive(Debug)]
pub struct ScriptedTransport(Arc<Mutex<Script>>);

/// A scripted line with `settings`, its time at zero, and no answer scripted yet.
pub fn scripted(settings: LineSettings) -> (ScriptedTransport, ScriptHandle) {
    let script = Arc::new(Mutex::new(Script {
        settings,
        now: Duration::ZERO,
        answers: VecDeque::new(),
        inbound: Vec::new(),
        written: Vec::new(),
        flushed: 0,
    }));
    (ScriptedTransport(script.clone()), ScriptHandle(script))
}

fn lock(script: &Mutex<Script>) -> MutexGuard<'_, Script> {
    script.lock().unwrap_or_else(|e| e.into_inner())
}

impl ScriptHandle {
    /// Appends the answer to the next unanswered request.
    pub fn push(&self, answer: Answer) {
        lock(&self.0).answers.push_back(answer);
    }

    /// Every request written so far.
    pub fn written(&self) -> Vec<Written> {
        lock(&self.0).written.clone()
    }

    /// The line's time.
    pub fn now(&self) -> Duration {
        lock(&self.0).now
    }

    /// Answers scripted but not used yet.
    pub fn answers_left(&self) -> usize {
        lock(&self.0).answers.len()
    }

    /// Bytes that arrived (by now) or are still due and that nobody read or flushed.
    pub fn unread(&self) -> usize {
        lock(&self.0).inbound.len()
    }

    /// Bytes the owner dropped with `flush_input`.
    pub fn flushed(&self) -> usize {
        lock(&self.0).flushed
    }
}

impl Script {
    fn arrived_by(&self, t: Duration) -> usize {
        self.inbound.iter().take_while(|(at, _)| *at <= t).count()
    }
}

impl Transport for ScriptedTransport {
    fn settings(&self) -> LineSettings {
        lock(&self.0).settings
    }

    // The script keeps the line's time as a duration since the line's origin.
    fn now(&self) -> LineInstant {
        LineInstant::after_origin(lock(&self.0).now)
    }

    fn sync(&mut self, t: LineInstant) {
        let mut s = lock(&self.0);
        s.now = s.now.max(t.since_origin());
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), LineError> {
        let mut s = lock(&self.0);
        let start = s.now;
        let end = start + s.settings.chars(frame.len());
        s.now = end;
        let n = s.written.len() + 1;
        let Some(answer) = s.answers.pop_front() else {
            drop(s);
            panic!("request #{n} `{}` has no scripted answer", hex(frame));
        };
        s.written.push(Written {
            start,
            end,
            bytes: frame.to_vec(),
        });
        for chunk in answer.chunks {
            for b in chunk.bytes {
                s.inbound.push((end + chunk.after, b));
            }
        }
        // Stable: bytes of one chunk keep their order.
        s.inbound.sort_by_key(|(at, _)| *at);
        Ok(())
    }

    fn read_until(&mut self, buf: &mut Vec<u8>, deadline: LineInstant) -> Result<usize, LineError> {
        let deadline = deadline.since_origin();
        let mut s = lock(&self.0);
        match s.inbound.first().map(|(at, _)| *at) {
            Some(at) if at <= deadline => {
                s.now = s.now.max(at);
                let n = s.arrived_by(s.now);
                buf.extend(s.inbound.drain(..n).map(|(_, b)| b));
                Ok(n)
            }
            _ => {
                s.now = s.now.max(deadline);
                Ok(0)
            }
        }
    }

    fn wait_until(&mut self, t: LineInstant) {
        let mut s = lock(&self.0);
        s.now = s.now.max(t.since_origin());
    }

    fn flush_input(&mut self) -> Result<usize, LineError> {
        let mut s = lock(&self.0);
        let n = s.arrived_by(s.now);
        s.inbound.drain(..n);
        s.flushed += n;
        Ok(n)
    }
}
