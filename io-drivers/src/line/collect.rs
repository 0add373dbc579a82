//! FC 70 Collect on the master side: one broadcast round per read cycle for the modules of a
//! line that run in event mode (MiniMod manual, "Modbus function “Collect” (event
//! management)" and "The Modbus function Collect").
//!
//! The protocol: the master broadcasts `00 46 FIRST LAST SLVACK SLVSEQ`; the slaves in the
//! window FIRST..=LAST may reply, in ascending address order, 3 ms each, and only one of them
//! (the first that has events) does: `SLAVE 46 SLVSEQ TYPE DATH DATL 00`. The master then
//! acknowledges it in the next Collect (SLVACK = SLAVE, SLVSEQ as received) whose window starts
//! after that slave, and so on until a Collect goes by in silence. The manual's example: window
//! 1–16, slave 4 replies, then window 5–16 acknowledging slave 4.
//!
//! - [`CollectRound`] is the sans-IO planner of one round: the next request, and what a reply,
//!   a silence or a failure does to the window and the acknowledgement.
//! - A driver asks to be in the round with [`Driver::collect_membership`]: its read plan then
//!   runs every cycle, and its full refresh ([`Driver::plan_refresh`]) when the owner decides.
//!   The owner hands the module's events back to the driver under [`EVENT_TAG`], as
//!   [`Response::Collect`] replies.
//! - `BusOwner::collect_pass` runs the round at the start of a read cycle, on the bus owner's
//!   line, and decides for each member whether its refresh runs this cycle: at once on its
//!   first cycle, after a gap in its SLVSEQ (lost events), after a failed round, and after a
//!   cycle of its own that failed; and when a period of its [`Membership`] is up: nothing
//!   addressed to it answered for `answer_within`, or no full read for `resync`. Those
//!   periodic refreshes are spread over cycles, one a cycle (`line/housekeeping.rs`), so a
//!   line's modules never all refresh in the same cycle. A member that delivered an event
//!   this round has its periodic refresh put off to a later cycle, so the program sees the
//!   event before the refresh overwrites it with the present state.
//!
//! Choices where the manual is silent:
//! - The window is the lowest to the highest member address; a round gives each slave at
//!   most one event, so every variation is seen by the program for one cycle at least.
//! - A reply from the window's last address leaves no window to acknowledge it in; the
//!   acknowledgement goes with the first Collect of the next round. The owner then keeps the
//!   line until that slave's slot and a reply's length have passed, so nothing is still on its
//!   way when the ordinary polls start (on the virtual line a slave cannot hear another one's
//!   reply, so a slave that a real line would have blocked may answer an earlier Collect too).
//! - The wait for a reply is the window's slots (3 ms each) plus 1 ms, the manual's "nominal
//!   timeout", plus the members' largest [`Membership::frame_timeout`] (a MiniMod's RDELAYM:
//!   a slave that waits longer for the end of a request starts its slot that much later),
//!   plus one character time ([`first_char_margin`]): a reply that starts at the
//!   window's last instant is heard once its first character is in. The floor of a round
//!   ([`floor::CollectFloor`]) counts the window alone, so the owner's idle round is that
//!   floor and one character above it. Each Collect is one exchange of the owner's (`BusOwner::exchange`), with
//!   the discipline of every other: t3.5 before it, the input flushed, and after a bad reply
//!   the guard time for that wait, then a flush. Silence is the round's normal end, not a
//!   timeout: no guard follows it.
//! - A reply from a slave in the window that is not a member (a MiniMod polled normally with
//!   events enabled) is acknowledged and dropped. A reply that repeats the SLVSEQ last seen from
//!   that slave (our acknowledgement was lost) is acknowledged again and not delivered twice.

use std::time::Duration;

use crate::time::LineInstant;

#[cfg(doc)]
use crate::driver::Driver;
use crate::driver::{Membership, Reply, Transaction};
use crate::line::bus::{line_err, BusOwner, Frame, Miss, Silence};
use crate::line::housekeeping::{Pick, Urgency};
use crate::line::settings::LineSettings;
use crate::modbus::{Request, Response};

/// Reply slot of one address ("Each slave has 3 ms of time for replying").
pub(crate) const SLOT: Duration = Duration::from_millis(3);
/// Margin after the last slot ("plus 1 for safety").
pub(crate) const SAFETY: Duration = Duration::from_millis(1);

/// How long after a Collect's reply window the owner still listens for a reply to begin: one
/// character time. The window (3 ms a slot "plus 1 for safety") is when a slave may start
/// to answer; a reply begun at its very end is heard once its first character has been
/// received, one character later. Less would cut off a reply the manual allows; more (the
/// owner once waited its inter-character allowance, 8.6 ms at 19200) only makes every
/// silent window, the normal end of every round, longer than the manual's timeout.
pub(crate) fn first_char_margin(settings: LineSettings) -> Duration {
    settings.char_time()
}

/// The tag under which a member's events are handed to its driver: no transaction a driver
/// plans carries it, so an event is never taken for the answer to one.
pub(crate) const EVENT_TAG: u32 = u32::MAX;

/// The SLVSEQ that follows `seq` (a MiniMod counts 1..=255 and skips 0).
pub(crate) fn next_seq(seq: u8) -> u8 {
    if seq == u8::MAX {
        1
    } else {
        seq + 1
    }
}

/// One Collect round, sans IO.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(crate) struct CollectRound {
    /// FIRST of the next request.
    next: u8,
    /// LAST of every request.
    last: u8,
    /// SLVACK, SLVSEQ for the next request.
    ack: Option<(u8, u8)>,
    done: bool,
    failed: bool,
}

impl CollectRound {
    /// A round over the window `first..=last` (1..=247), carrying the acknowledgement the last
    /// round could not send. `None` for an empty window.
    pub(crate) fn new(first: u8, last: u8, pending_ack: Option<(u8, u8)>) -> Option<Self> {
        (1..=last).contains(&first).then_some(Self {
            next: first,
            last,
            ack: pending_ack,
            done: false,
            failed: false,
        })
    }

    /// A round over every address in `members`; `None` when there is none.
    pub(crate) fn over(members: &[u8], pending_ack: Option<(u8, u8)>) -> Option<Self> {
        let first = members.iter().copied().filter(|&a| a != 0).min()?;
        let last = members.iter().copied().max()?;
        Self::new(first, last, pending_ack)
    }

    /// The next Collect to broadcast; `None` when the round is over.
    pub(crate) fn request(&self) -> Option<Request> {
        if self.done {
            return None;
        }
        let (slave_ack, slave_seq) = self.ack.unwrap_or((0, 0));
        Some(Request::Collect {
            first: self.next,
            last: self.last,
            slave_ack,
            slave_seq,
        })
    }

    /// How long the slaves of the next request's window have to start a reply, from the end
    /// of the request: 3 ms per address plus 1 ms.
    pub(crate) fn reply_window(&self) -> Duration {
        let slots = u32::from(self.last.saturating_sub(self.next)) + 1;
        SLOT * slots + SAFETY
    }

    /// The time from the end of the next request to the end of `slave`'s slot in it.
    pub(crate) fn slot_end(&self, slave: u8) -> Duration {
        SLOT * (u32::from(slave.saturating_sub(self.next)) + 1)
    }

    /// Slave `slave` answered the last request with SLVSEQ `seq`: it is acknowledged by the
    /// next request, whose window starts after it; after the window's last address the round
    /// is over and the next round acknowledges it.
    pub(crate) fn on_reply(&mut self, slave: u8, seq: u8) {
        self.ack = Some((slave, seq));
        if slave >= self.last {
            self.done = true;
        } else {
            self.next = self.next.max(slave + 1);
        }
    }

    /// The last request's window passed in silence: no slave left with events.
    pub(crate) fn on_silence(&mut self) {
        self.ack = None;
        self.done = true;
    }

    /// The last request got a reply that could not be read (a collision, noise): the round
    /// ends and the members must be read in full.
    pub(crate) fn on_failure(&mut self) {
        self.ack = None;
        self.done = true;
        self.failed = true;
    }

    /// Whether the round is over.
    pub(crate) fn is_done(&self) -> bool {
        self.done
    }

    /// Whether the round ended on a failure.
    pub(crate) fn failed(&self) -> bool {
        self.failed
    }

    /// The acknowledgement no request of this round carried (the reply came from the window's
    /// last address); the next round sends it.
    pub(crate) fn pending_ack(&self) -> Option<(u8, u8)> {
        if self.done && !self.failed {
            self.ack
        } else {
            None
        }
    }
}

/// Counters of a line's Collect rounds.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CollectStats {
    /// Rounds run.
    pub rounds: u64,
    /// Collect requests sent.
    pub requests: u64,
    /// Events delivered to drivers.
    pub events: u64,
    /// Replies that repeated an event already delivered.
    pub duplicates: u64,
    /// Gaps in a slave's SLVSEQ (events lost in the module).
    pub gaps: u64,
    /// Replies from slaves that are not members.
    pub foreign: u64,
    /// Rounds that ended on an unreadable reply or a line failure.
    pub failures: u64,
    /// Full refreshes of members.
    pub refreshes: u64,
    /// Events a driver could not use.
    pub decode_errors: u64,
    /// Bytes dropped (stray bytes before a request, extra bytes after a reply).
    pub dropped_bytes: u64,
    /// Input flushes that failed (each one a line failure: the port is reopened).
    pub flush_failures: u64,
}

/// What a bus owner keeps between Collect rounds.
#[derive(Debug, Clone, Default)]
pub(crate) struct CollectState {
    /// Per module: the read plan made before the round (the refresh appended when due), and
    /// whether it is there.
    stash: Vec<Vec<Transaction>>,
    planned: Vec<bool>,
    /// Per module: when its last full refresh was decided.
    last_refresh: Vec<Option<LineInstant>>,
    /// Per slave address: the last SLVSEQ seen.
    last_seq: Vec<Option<u8>>,
    /// The acknowledgement the last round could not send.
    pending_ack: Option<(u8, u8)>,
    stats: CollectStats,
    /// End of the last Collect request on the line.
    last_sent: LineInstant,
}

impl CollectState {
    fn prepare(&mut self, modules: usize) {
        self.stash.resize_with(modules, Vec::new);
        self.planned.resize(modules, false);
        self.last_refresh.resize(modules, None);
        self.last_seq.resize(256, None);
    }
}

/// A module in this cycle's round.
#[derive(Debug, Clone, Copy)]
struct Member {
    module: usize,
    unit: u8,
    periods: Membership,
    delivered: bool,
    gap: bool,
}

/// Why one Collect exchange ended without an event.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Exchange {
    /// The window passed in silence.
    Silence,
    /// An unreadable reply, an exception, or the line failed.
    Failure,
}

/// An event as it came off the line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Heard {
    slave: u8,
    seq: u8,
    kind: u8,
    data: u16,
}

impl BusOwner {
    /// Counters of this line's Collect rounds.
    pub fn collect_stats(&self) -> CollectStats {
        self.collect.stats
    }

    /// Plans every module that is due at `now` and runs one Collect round for the members.
    /// [`Self::read_plan`] then hands each module the rest of its plan.
    pub(crate) fn collect_pass(&mut self, now: LineInstant) {
        let n = self.modules.len();
        self.collect.prepare(n);
        let mut members: Vec<Member> = Vec::new();
        for m in 0..n {
            self.collect.planned[m] = false;
            // A module waiting for its start-up joins the round once it has run.
            if !self.modules[m].health.due(now) || self.modules[m].startup_pending {
                continue;
            }
            let plan = &mut self.collect.stash[m];
            plan.clear();
            self.modules[m].driver.plan_read(plan);
            // Its driver found the module lost its settings (event recording off after a
            // power cycle): its start-up runs in this cycle's read, and it joins the next round.
            if self.modules[m].driver.wants_restart() {
                self.modules[m].startup_pending = true;
                plan.clear();
                continue;
            }
            self.collect.planned[m] = true;
            if let Some(periods) = self.modules[m].driver.collect_membership() {
                members.push(Member {
                    module: m,
                    unit: periods.unit.get(),
                    periods,
                    delivered: false,
                    gap: false,
                });
            }
        }
        let units: Vec<u8> = members.iter().map(|m| m.unit).collect();
        let Some(mut round) = CollectRound::over(&units, self.collect.pending_ack.take()) else {
            return;
        };
        self.collect.stats.rounds += 1;
        let requests_before = self.collect.stats.requests;
        // A member that waits longer for the end of a request answers that much later.
        let late = members
            .iter()
            .map(|m| m.periods.frame_timeout)
            .max()
            .unwrap_or_default();
        while let Some(request) = round.request() {
            match self.collect_exchange(&request, round.reply_window() + late) {
                Ok(heard) => {
                    let slot_end = round.slot_end(heard.slave);
                    round.on_reply(heard.slave, heard.seq);
                    self.deliver(heard, &mut members);
                    if round.is_done() {
                        self.quiet_after_last_slot(slot_end);
                    }
                }
                Err(Exchange::Silence) => round.on_silence(),
                Err(Exchange::Failure) => {
                    self.collect.stats.failures += 1;
                    round.on_failure();
                }
            }
        }
        self.collect.pending_ack = round.pending_ack();
        // The round's broadcasts, on the member that opens its window (see `Counters`).
        if let Some(first) = members.iter().min_by_key(|m| m.unit) {
            self.modules[first.module].counters.collect_requests +=
                self.collect.stats.requests - requests_before;
        }
        let after = self.transport.now();
        let mut pick = Pick::default();
        let mut now_refreshed = Vec::new();
        for member in &members {
            let m = member.module;
            let last_full = self.collect.last_refresh[m];
            // What may have lost an event is repaired at once.
            if last_full.is_none()
                || round.failed()
                || member.gap
                || self.modules[m].last_error.is_some()
            {
                now_refreshed.push(m);
                pick.taken();
                continue;
            }
            // Its event first: the refresh would overwrite it before the program saw it.
            if member.delivered {
                continue;
            }
            let answered = self.modules[m].last_answered.max(last_full);
            let urgency = Urgency::of(last_full, member.periods.resync, after).max(Urgency::of(
                answered,
                member.periods.answer_within,
                after,
            ));
            pick.offer(m, urgency);
        }
        now_refreshed.extend(pick.chosen());
        for m in now_refreshed {
            let plan = &mut self.collect.stash[m];
            self.modules[m].driver.plan_refresh(plan);
            self.collect.last_refresh[m] = Some(after);
            self.collect.stats.refreshes += 1;
        }
    }

    /// Module `m`'s read plan for this cycle: what [`Self::collect_pass`] left of it, or, for a
    /// module that became due after the pass, a fresh plan with its full refresh.
    pub(crate) fn read_plan(&mut self, m: usize, plan: &mut Vec<Transaction>) {
        if self.collect.planned.get(m).copied().unwrap_or(false) {
            self.collect.planned[m] = false;
            plan.append(&mut self.collect.stash[m]);
            return;
        }
        let driver = &mut self.modules[m].driver;
        driver.plan_read(plan);
        if driver.collect_membership().is_some() {
            driver.plan_refresh(plan);
        }
    }

    /// Routes one event: acknowledged in any case, delivered once to the member it is from.
    fn deliver(&mut self, heard: Heard, members: &mut [Member]) {
        let slot = usize::from(heard.slave);
        let last = self.collect.last_seq.get(slot).copied().flatten();
        if let Some(s) = self.collect.last_seq.get_mut(slot) {
            *s = Some(heard.seq);
        }
        let Some(member) = members.iter_mut().find(|m| m.unit == heard.slave) else {
            self.collect.stats.foreign += 1;
            return;
        };
        if last == Some(heard.seq) {
            self.collect.stats.duplicates += 1;
            return;
        }
        if last.is_some_and(|prev| next_seq(prev) != heard.seq) {
            self.collect.stats.gaps += 1;
            member.gap = true;
        }
        member.delivered = true;
        self.collect.stats.events += 1;
        let reply = Reply::Modbus(Response::Collect {
            slave: heard.slave,
            seq: heard.seq,
            kind: heard.kind,
            data: heard.data,
        });
        if self.modules[member.module]
            .driver
            .on_reply(EVENT_TAG, &reply)
            .is_err()
        {
            self.collect.stats.decode_errors += 1;
        }
    }

    /// After a reply from the window's last address ends the round: keeps the line until that
    /// slave's slot (from the end of the last request) and a reply's length have passed, then
    /// drops whatever came, so no late or repeated reply meets the next poll.
    fn quiet_after_last_slot(&mut self, slot_end: Duration) {
        let end = self.collect.last_sent + slot_end + self.settings.chars(floor::REPLY_LEN);
        self.transport.wait_until(end);
        match self.transport.flush_input() {
            Ok(n) => self.collect.stats.dropped_bytes += n as u64,
            Err(e) => {
                // What it could not drop would meet the next poll: the line has failed.
                self.collect.stats.flush_failures += 1;
                self.port_failed(&line_err(&e));
            }
        }
        self.line_free_at = self
            .line_free_at
            .max(self.transport.now() + self.settings.t3_5());
    }

    /// Broadcasts one Collect and listens through its reply window, as one exchange of the
    /// owner's.
    fn collect_exchange(&mut self, request: &Request, window: Duration) -> Result<Heard, Exchange> {
        // The adapter holds the first character back up to its latency timer.
        let wait = window + first_char_margin(self.settings) + self.discipline.adapter_latency;
        // A Collect round ends when a window passes in silence: that is no timeout.
        let frame = Frame::Modbus {
            address: 0,
            request,
        };
        let done = self.exchange(frame, wait, Silence::Answer);
        let stats = &mut self.collect.stats;
        stats.dropped_bytes += done.dropped as u64;
        stats.flush_failures += u64::from(done.flush_failed);
        if let Some(sent) = done.sent {
            stats.requests += 1;
            self.collect.last_sent = sent;
        }
        match done.outcome {
            Ok(Some(Reply::Modbus(Response::Collect {
                slave,
                seq,
                kind,
                data,
            }))) => Ok(Heard {
                slave,
                seq,
                kind,
                data,
            }),
            Err(Miss::Silence) => Err(Exchange::Silence),
            Err(Miss::Line(e)) => {
                // As for any other exchange: the port is reopened with its backoff.
                self.port_failed(&line_err(&e));
                Err(Exchange::Failure)
            }
            // Another answer, an unreadable one, or the line failed: the round ends.
            Ok(_) | Err(_) => Err(Exchange::Failure),
        }
    }
}

pub(crate) mod floor;

#[cfg(test)]
mod tests;
