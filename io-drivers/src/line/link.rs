//! How the scan drives a line: one interface, whichever clock the PLC runs on.
//!
//! The scan starts every line's work at once, then collects the answers against one deadline
//! for all of them, derived from its period. A line that has not delivered by then is left to
//! finish in its own time: the scan goes on with that line's last values (their quality says
//! how old they are), and the line takes no new read until it is done. So a dead line, whose
//! every request ends in a response timeout, never holds the scan longer than the deadline.
//!
//! - [`LineLink::thread`]: on the real clock, the bus owner runs on its own OS thread
//!   ([`BusThread`]); answers are paired with their commands by sequence number
//!   (`tests/tests/bus_threads.rs` drives it on the real clock).
//! - [`LineLink::inline`]: on a virtual clock the scan runs the bus owner itself, from the
//!   line's own time, and the same rules are applied in virtual time: an answer is delivered
//!   when its line time has come, so a whole project (a dead line included) replays bit for bit.
//!
//! The rules both follow, so a test on the virtual clock shows what the threads do:
//! - a line has at most one read and one write outstanding; a read is started only when the
//!   last one has been answered, so a slow line is never handed more work than it can do;
//! - an answer to a read that came after its cycle's deadline is not dropped: it is the line's
//!   freshest input, delivered in the next cycle unless that cycle's own read arrives in time;
//! - a write goes to the line at once (behind a read still running, so the modules that
//!   answer get their outputs within the cycle); while an earlier write is still outstanding it
//!   waits in the link, merged with any later one (the latest value of every point wins;
//!   one-shot commands of the earlier frame are kept), and goes out when that one is done;
//! - the safe state is queued behind whatever the line is doing, never merged away.
//!
//! One difference the virtual clock cannot hide: a line it runs inline does its work at once,
//! in its own time, so a busy line (modules restarting after an outage) is ahead of the scan's
//! clock. A change a test makes to the simulated world at the scan's time then takes effect at
//! the world's time, which may be later (`SimWorld::now`); the soak counts from there.

use std::sync::Arc;
use std::time::{Duration, Instant};

use crate::line::bus::{
    BusCommand, BusEvent, BusOwner, BusThread, InputFrame, OutputFrame, WriteReport,
};
use crate::time::{Clock, LineInstant, ScanInstant};

/// What a line handed the scan by a deadline.
#[derive(Debug, Clone, PartialEq)]
pub struct Delivery<T> {
    /// The answer; `None` when the line had nothing new by the deadline.
    pub answer: Option<T>,
    /// When the scan had it, on the PLC's clock: the answer's arrival, or the deadline.
    pub at: ScanInstant,
}

/// The end of a write the scan stopped waiting for at its cycle's end (the period was over):
/// that cycle's work ran past its period.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum WriteEnd {
    /// Known now: a line the scan runs itself ends it at this time, on the PLC's clock.
    At(ScanInstant),
    /// The line's thread is still at it: its end comes with the answer to the first write
    /// from this sequence number on ([`LineLink::late_write_end`]).
    Later(u64),
}

/// How many write answers a threaded line keeps for [`LineLink::late_write_end`]: more than
/// the cycles a scan keeps open waiting for them.
const KEPT_WRITE_ENDS: usize = 64;

/// One line as the scan sees it.
#[derive(Debug)]
pub struct LineLink {
    kind: Kind,
    /// A write that waits for the line to be idle.
    pending: Option<OutputFrame>,
}

#[derive(Debug)]
enum Kind {
    Inline(Box<Inline>),
    Thread(Box<Threaded>),
    Stopped,
}

/// A bus owner run by the scan in virtual time.
#[derive(Debug)]
struct Inline {
    owner: BusOwner,
    /// Line time when its current work ends.
    busy_until: LineInstant,
    /// The answer to the current read, available at its `finished` time.
    read: Option<InputFrame>,
    /// An answer that came after its cycle's deadline and before the current read started.
    late: Option<InputFrame>,
    /// The answer to the last write.
    written: Option<WriteReport>,
}

/// A bus owner on its own thread.
#[derive(Debug)]
struct Threaded {
    thread: BusThread,
    clock: Arc<dyn Clock>,
    /// Sequence number of the last command whose answer has come.
    answered: u64,
    /// Sequence number of the outstanding read.
    read_seq: Option<u64>,
    /// Sequence number of the outstanding write.
    write_seq: Option<u64>,
    /// A read's answer not yet delivered.
    read: Option<InputFrame>,
    /// A write's answer not yet delivered.
    written: Option<WriteReport>,
    /// The last write answers: sequence number and end, oldest first.
    write_ends: std::collections::VecDeque<(u64, ScanInstant)>,
}

impl LineLink {
    /// A line the scan runs itself (virtual clock).
    pub fn inline(owner: BusOwner) -> Self {
        let busy_until = owner.now();
        Self {
            kind: Kind::Inline(Box::new(Inline {
                owner,
                busy_until,
                read: None,
                late: None,
                written: None,
            })),
            pending: None,
        }
    }

    /// A line on its own OS thread (real clock).
    pub fn thread(owner: BusOwner, clock: Arc<dyn Clock>) -> std::io::Result<Self> {
        Ok(Self {
            kind: Kind::Thread(Box::new(Threaded {
                thread: BusThread::spawn(owner)?,
                clock,
                answered: 0,
                read_seq: None,
                write_seq: None,
                read: None,
                written: None,
                write_ends: std::collections::VecDeque::new(),
            })),
            pending: None,
        })
    }

    /// Whether the line's thread has ended on its own (a driver bug): its points are lost.
    pub fn is_dead(&self) -> bool {
        match &self.kind {
            Kind::Thread(t) => t.thread.is_finished(),
            Kind::Inline(_) | Kind::Stopped => false,
        }
    }

    /// Starts a read at `now` unless the last one is still running (a waiting write goes
    /// first).
    pub fn start_read(&mut self, now: ScanInstant) {
        match &mut self.kind {
            Kind::Inline(l) => {
                if l.read
                    .as_ref()
                    .is_some_and(|f| f.finished.on_scan_clock() > now)
                {
                    return;
                }
                if l.written
                    .as_ref()
                    .is_none_or(|w| w.finished.on_scan_clock() <= now)
                {
                    if let Some(frame) = self.pending.take() {
                        l.write(&frame, now, false);
                    }
                }
                l.owner.sync(now.on_line_clock().max(l.busy_until));
                let frame = l.owner.read_answering();
                l.owner.read_deferred(None);
                l.busy_until = l.owner.now();
                l.late = l.read.replace(frame);
            }
            Kind::Thread(t) => {
                t.drain();
                if t.read_seq.is_some() {
                    return;
                }
                if t.write_seq.is_none() {
                    if let Some(frame) = self.pending.take() {
                        t.send_write(frame, &mut self.pending);
                    }
                }
                if let Ok(seq) = t.thread.try_send(BusCommand::Read) {
                    t.read_seq = Some(seq);
                }
            }
            Kind::Stopped => {}
        }
    }

    /// The line's freshest input by `deadline`: the answer to its current read if it comes in
    /// time, else one that came late for the last cycle, else nothing (its values go stale).
    pub fn finish_read(&mut self, deadline: ScanInstant) -> Delivery<InputFrame> {
        match &mut self.kind {
            Kind::Inline(l) => match l.read.take() {
                Some(frame) if frame.finished.on_scan_clock() <= deadline => {
                    l.late = None;
                    Delivery {
                        at: frame.finished.on_scan_clock(),
                        answer: Some(frame),
                    }
                }
                current => {
                    l.read = current;
                    Delivery {
                        answer: l.late.take(),
                        at: deadline,
                    }
                }
            },
            Kind::Thread(t) => {
                t.wait(deadline, |t| t.read_seq.is_none());
                let late = t.read.take();
                Delivery {
                    answer: late,
                    at: t.clock.now().min(deadline),
                }
            }
            Kind::Stopped => Delivery {
                answer: None,
                at: deadline,
            },
        }
    }

    /// Starts writing `frame` at `now`, behind a read still running; while the last write
    /// is still outstanding it waits, merged with later frames.
    pub fn start_write(&mut self, frame: &OutputFrame, now: ScanInstant) {
        let frame = match self.pending.take() {
            Some(mut earlier) => {
                merge(&mut earlier, frame);
                earlier
            }
            None => frame.clone(),
        };
        match &mut self.kind {
            Kind::Inline(l) => {
                if l.written
                    .as_ref()
                    .is_some_and(|w| w.finished.on_scan_clock() > now)
                {
                    self.pending = Some(frame);
                } else {
                    l.write(&frame, now, false);
                }
            }
            Kind::Thread(t) => {
                t.drain();
                if t.write_seq.is_some() {
                    self.pending = Some(frame);
                } else {
                    t.send_write(frame, &mut self.pending);
                }
            }
            Kind::Stopped => {}
        }
    }

    /// Queues the safe state behind whatever the line is doing: every output, lost modules
    /// included. A waiting write is dropped: the safe state replaces it.
    pub fn start_safe_write(&mut self, frame: &OutputFrame, now: ScanInstant) {
        self.pending = None;
        match &mut self.kind {
            Kind::Inline(l) => l.write(frame, now, true),
            Kind::Thread(t) => {
                if let Ok(seq) = t.thread.try_send(BusCommand::WriteSafe(frame.clone())) {
                    t.write_seq = Some(seq);
                }
            }
            Kind::Stopped => {}
        }
    }

    /// The answer to the write started last, if it comes by `deadline`.
    pub fn finish_write(&mut self, deadline: ScanInstant) -> Delivery<WriteReport> {
        match &mut self.kind {
            Kind::Inline(l) => match l.written.take() {
                Some(report) if report.finished.on_scan_clock() <= deadline => Delivery {
                    at: report.finished.on_scan_clock(),
                    answer: Some(report),
                },
                outstanding => {
                    // Still running: it stays the line's outstanding write.
                    l.written = outstanding;
                    Delivery {
                        answer: None,
                        at: deadline,
                    }
                }
            },
            Kind::Thread(t) => {
                t.wait(deadline, |t| t.write_seq.is_none());
                Delivery {
                    answer: t.written.take(),
                    at: t.clock.now().min(deadline),
                }
            }
            Kind::Stopped => Delivery {
                answer: None,
                at: deadline,
            },
        }
    }

    /// After [`LineLink::finish_write`]: the write it did not deliver by its deadline, when
    /// the line is still at one (a write waiting behind it included), with its end when
    /// known. The scan counts the cycle's work as running until then, on either clock: the
    /// real clock waits for it up to the deadline and wakes just after, the virtual clock at
    /// the deadline itself, so only this, not the instant of waking, can say the same thing on
    /// both.
    pub fn unfinished_write(&self) -> Option<WriteEnd> {
        match &self.kind {
            Kind::Inline(l) => l
                .written
                .as_ref()
                .map(|w| WriteEnd::At(w.finished.on_scan_clock())),
            Kind::Thread(t) => match t.write_seq {
                Some(seq) => Some(WriteEnd::Later(seq)),
                // A write waiting in the link goes out later, under a later number.
                None => self
                    .pending
                    .is_some()
                    .then(|| WriteEnd::Later(t.thread.last_sent() + 1)),
            },
            Kind::Stopped => None,
        }
    }

    /// When the first write from sequence number `seq` on ended ([`WriteEnd::Later`]), once
    /// its answer has come (never waits).
    pub fn late_write_end(&mut self, seq: u64) -> Option<ScanInstant> {
        match &mut self.kind {
            Kind::Thread(t) => {
                t.drain();
                t.write_ends
                    .iter()
                    .find(|(s, _)| *s >= seq)
                    .map(|(_, end)| *end)
            }
            Kind::Inline(_) | Kind::Stopped => None,
        }
    }

    /// Stops the line's thread, waiting at most `timeout` (a stuck port leaves it behind).
    pub fn stop(&mut self, timeout: Duration) {
        if let Kind::Thread(t) = std::mem::replace(&mut self.kind, Kind::Stopped) {
            let name = t.thread.name().to_owned();
            // The owner given back closes its port here. One not given back is a thread
            // stuck on its port (or ended by a driver bug): the user is told, since that port
            // stays open and the line's last exchange may not have ended.
            if t.thread.stop(None, timeout).is_none() {
                tracing::warn!(
                    "line {name}: its thread did not stop within {timeout:?}; left behind with \
                     its port open"
                );
            }
        }
    }
}

impl Inline {
    /// Runs a write from `now`, or from the end of the line's current work.
    fn write(&mut self, frame: &OutputFrame, now: ScanInstant, safe: bool) {
        self.owner.sync(now.on_line_clock().max(self.busy_until));
        let report = if safe {
            self.owner.write_safe(frame)
        } else {
            self.owner.write_outputs(frame)
        };
        self.busy_until = report.finished;
        self.written = Some(report);
    }
}

impl Threaded {
    /// Queues a write; a full queue (a line far behind) keeps it waiting in `pending`.
    fn send_write(&mut self, frame: OutputFrame, pending: &mut Option<OutputFrame>) {
        match self.thread.try_send(BusCommand::Write(frame)) {
            Ok(seq) => self.write_seq = Some(seq),
            Err(BusCommand::Write(frame)) => *pending = Some(frame),
            Err(_) => {}
        }
    }

    /// Takes every answer that has come, without waiting.
    fn drain(&mut self) {
        while let Some((seq, event)) = self.thread.try_recv() {
            self.take(seq, event);
        }
    }

    /// Waits until `done` or `deadline` (on the PLC's clock), taking answers as they come.
    fn wait(&mut self, deadline: ScanInstant, done: impl Fn(&Self) -> bool) {
        self.drain();
        let until = Instant::now() + (deadline - self.clock.now());
        while !done(self) {
            match self.thread.recv_deadline(until) {
                Some((seq, event)) => self.take(seq, event),
                None => break,
            }
        }
    }

    fn take(&mut self, seq: u64, event: BusEvent) {
        self.answered = self.answered.max(seq);
        match event {
            BusEvent::Inputs(frame) => {
                if self.read_seq == Some(seq) {
                    self.read_seq = None;
                }
                // An older read is superseded by a newer one only if that one has come.
                self.read = Some(frame);
            }
            BusEvent::Written(report) => {
                if self.write_seq == Some(seq) {
                    self.write_seq = None;
                }
                if self.write_ends.len() == KEPT_WRITE_ENDS {
                    self.write_ends.pop_front();
                }
                // A line on its own thread keeps the PLC's time.
                self.write_ends
                    .push_back((seq, report.finished.on_scan_clock()));
                self.written = Some(report);
            }
        }
    }
}

/// Lays `later` over `earlier`: every point `later` drives takes its value; points only
/// `earlier` drives (a one-shot command not yet sent) keep theirs.
fn merge(earlier: &mut OutputFrame, later: &OutputFrame) {
    for (e, l) in earlier.modules.iter_mut().zip(&later.modules) {
        for (ep, lp) in e.iter_mut().zip(l) {
            if lp.is_some() {
                *ep = *lp;
            }
        }
    }
}
