//! The bus owner: the one thing that touches a line (DESIGN.md principle 3).
//!
//! It runs the transactions its drivers plan, one at a time, with the line's discipline:
//! - a t3.5 silence before every request (measured from the end of the last traffic);
//! - a response timeout for the first byte, then an inter-character timeout;
//! - after a timeout or a bad reply, a guard time and an input flush, so a late reply can
//!   never be read as the answer to the next request;
//! - verification of every reply (address, function, length, CRC) by the RTU codec;
//! - retries, and per-module counters (requests, timeouts, CRC errors, exceptions, ...).
//!
//! [`BusOwner`] is synchronous; [`BusThread`] runs one on its own OS thread and talks to the
//! scan over crossbeam channels. On a virtual clock the scan calls the owner directly instead,
//! so lines replay deterministically (each line's time starts at the cycle's start: lines are
//! parallel in virtual time too).

use std::thread::JoinHandle;
use std::time::Duration;

use crate::time::LineInstant;

use crossbeam_channel::{Receiver, Sender};

use crate::driver::{DecodeError, Driver, Outgoing, Reply, Transaction};
use crate::line::collect::CollectState;
use crate::line::echo::{self, EchoFault};
use crate::line::health::{Health, HealthEvent, HealthLimits};
use crate::line::housekeeping::{Pick, Urgency};
use crate::line::read_back::ReadBackVote;
use crate::line::settings::LineSettings;
use crate::line::transport::{LineError, LineFault, Transport};
use crate::modbus::master::{encode_request, Progress, ReplyAssembler, ReplyError};
use crate::modbus::{Request, Response};
use crate::point::{Quality, Value};
use crate::wire::trace::{Discard, Verdict, WireEvent, WireTap};

/// Longest reply any module sends (an RTU ADU is at most 256 bytes; text replies are shorter).
const MAX_REPLY: usize = 512;

/// Settings of a bus owner's discipline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Discipline {
    /// Wait for the first reply byte.
    pub response_timeout: Duration,
    /// Attempts after a failed one.
    pub retries: u8,
    /// Full output refresh period.
    pub output_refresh: Duration,
    /// Consecutive failed cycles after which a module is lost (its points turn bad) and is
    /// retried with a backoff from `reconnect_min` doubling to `reconnect_max`.
    pub fail_limit: u32,
    /// First retry interval of a lost module (and of a failed port).
    pub reconnect_min: Duration,
    /// Longest retry interval.
    pub reconnect_max: Duration,
    /// What the port's adapter holds received bytes back (a USB adapter's latency timer, as
    /// the port reported it when opened): a wait that ends by silence rather than by a
    /// timeout (a Collect window) must last that much longer, or a reply in its last slot is
    /// still inside the adapter when the owner stops listening.
    pub adapter_latency: Duration,
}

impl Discipline {
    fn health_limits(&self) -> HealthLimits {
        HealthLimits {
            fail_limit: self.fail_limit,
            reconnect_min: self.reconnect_min,
            reconnect_max: self.reconnect_max,
        }
    }
}

impl Default for Discipline {
    fn default() -> Self {
        Self {
            response_timeout: Duration::from_millis(100),
            retries: 1,
            output_refresh: Duration::from_secs(1),
            fail_limit: 3,
            reconnect_min: Duration::from_secs(1),
            reconnect_max: Duration::from_secs(30),
            adapter_latency: Duration::ZERO,
        }
    }
}

/// Per-module counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Counters {
    /// Requests sent (retries included).
    pub requests: u64,
    /// Requests that got no reply in time.
    pub timeouts: u64,
    /// Replies with a bad CRC.
    pub crc_errors: u64,
    /// Replies that were not the answer to the request (address, function, length, echo).
    pub bad_replies: u64,
    /// Exception replies (the device said no).
    pub exceptions: u64,
    /// Replies the driver could not use.
    pub decode_errors: u64,
    /// Bytes dropped by a flush or after a complete reply.
    pub dropped_bytes: u64,
    /// Input flushes that failed (each one a line failure: the port is reopened).
    pub flush_failures: u64,
    /// Requests whose echo was wrong or missing (`echo: discard`), or came back as the reply
    /// on a bus without it: line errors, retried like a bad reply.
    pub echo_errors: u64,
    /// Round trip of the last good transaction: end of request to end of reply.
    pub last_round_trip: Duration,
    /// FC 70 Collect broadcasts of its line's rounds (event mode). A broadcast is addressed to
    /// no module: each is counted once, on the member with the lowest address of its round,
    /// so that a line's modules' `requests` and `collect_requests` add up to every request on
    /// its wire.
    pub collect_requests: u64,
}

impl Counters {
    /// All failures.
    pub fn errors(&self) -> u64 {
        self.timeouts
            + self.crc_errors
            + self.bad_replies
            + self.exceptions
            + self.decode_errors
            + self.echo_errors
    }
}

/// Why one transaction failed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum TxError {
    /// No reply before the response timeout.
    #[error("no reply within {0:?}")]
    Timeout(Duration),
    /// A reply arrived but failed verification.
    #[error("bad reply: {0}")]
    BadReply(ReplyError),
    /// The driver refused the reply (includes exceptions).
    #[error(transparent)]
    Decode(#[from] DecodeError),
    /// The request could not be encoded (a driver bug, reported rather than sent).
    #[error("request cannot be encoded")]
    Encode,
    /// The line failed (the port is then reopened with a backoff).
    #[error("line failed: {0}")]
    Line(LineFault),
    /// The port failed earlier and is not open again yet: nothing was sent.
    #[error("line failed: the port is down")]
    PortDown,
    /// The request's echo was wrong or missing, or an echo came back unasked (`line/echo.rs`):
    /// the line is suspect for this exchange, not down (no reopen).
    #[error("line error: {0}")]
    Echo(EchoFault),
}

impl TxError {
    /// Whether the module answered and said no: an exception, or a read-back that differs
    /// and is believed (`line/read_back.rs`). A reply that does not fit
    /// ([`DecodeError::Unexpected`]) is not one even when the retries are spent: it was
    /// garbled or not meant for this request, so a module back after it was lost that meets
    /// it fails like one that did not answer and is retried, and is not said to refuse. The
    /// first start does the same: one burst of noise at power-up must not keep the machine
    /// from starting; a module that never answers intelligibly (set up otherwise, e.g. a DCON
    /// checksum it does not have) stays lost, and its reason is in the log and in `status`.
    pub fn is_refusal(&self) -> bool {
        matches!(
            self,
            TxError::Decode(DecodeError::Exception(_) | DecodeError::Mismatch { .. })
        )
    }
}

/// A request as [`BusOwner::exchange`] sends it.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Frame<'a> {
    /// A Modbus request to `address` (0: a broadcast; a Collect broadcast is answered).
    Modbus {
        /// The unit address, 0 for a broadcast.
        address: u8,
        /// The request PDU.
        request: &'a Request,
    },
    /// A text-protocol line; the reply ends with `terminator`.
    Text {
        /// The bytes to send.
        line: &'a [u8],
        /// The byte that ends the reply.
        terminator: u8,
    },
    /// Bytes nothing answers.
    NoReply(&'a [u8]),
}

/// What silence through an exchange's wait means.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Silence {
    /// A timeout: the guard and a flush follow.
    Timeout,
    /// An answer in itself (a Collect window nobody replied in): the line is free after t3.5.
    Answer,
}

/// Why an exchange brought no reply.
#[derive(Debug)]
pub(crate) enum Miss {
    /// The request could not be encoded; nothing was sent.
    Encode,
    /// The line failed.
    Line(LineError),
    /// Nothing came.
    Silence,
    /// Part of a reply, then silence.
    Cut,
    /// A reply that failed verification, or one without end.
    Bad(ReplyError),
    /// The request's echo was wrong or missing, or came back as the reply.
    Echo(EchoFault),
}

/// How one exchange went, for the caller's counters.
#[derive(Debug)]
pub(crate) struct Exchanged {
    /// When the request's last character left; `None` if it was not sent.
    pub(crate) sent: Option<LineInstant>,
    /// End of request to end of a good reply.
    pub(crate) round_trip: Option<Duration>,
    /// Bytes dropped: stray ones before the request, extra after the reply, the guard's flush.
    pub(crate) dropped: usize,
    /// An input flush failed (the outcome is then [`Miss::Line`]).
    pub(crate) flush_failed: bool,
    /// The reply (`None`: nothing answers the frame), or why none.
    pub(crate) outcome: Result<Option<Reply>, Miss>,
}

impl Exchanged {
    /// Before anything was sent.
    pub(crate) fn nothing_yet() -> Self {
        Self {
            sent: None,
            round_trip: None,
            dropped: 0,
            flush_failed: false,
            outcome: Ok(None),
        }
    }
}

/// A module's state as one cycle left it.
#[derive(Debug, Clone, PartialEq)]
pub struct ModuleSnapshot {
    /// Values by point index (the model's order); `None` until first read.
    pub values: Vec<Option<Value>>,
    /// Quality of this cycle's read.
    pub quality: Quality,
    /// Counters so far.
    pub counters: Counters,
    /// The last failure, if the last cycle had one.
    pub last_error: Option<TxError>,
    /// Whether the module holds what the program last asked of its outputs: good once it
    /// acknowledged them (its start-up's write of every output, a write, the periodic
    /// rewrite); bad before that, while a write failed or was refused and has not been made
    /// good, and while the module waits for its start-up sequence (back from a power cycle, a
    /// fired watchdog); stale while it is lost after it had acknowledged them (the last values
    /// it held, which nobody can confirm now).
    pub outputs: Quality,
}

/// The result of a read cycle on one line.
#[derive(Debug, Clone, PartialEq)]
pub struct InputFrame {
    /// One snapshot per module, in the order the owner was given them.
    pub modules: Vec<ModuleSnapshot>,
    /// When the cycle started and ended on the line's time.
    pub started: LineInstant,
    /// End of the last transaction.
    pub finished: LineInstant,
}

/// Desired outputs for one line: per module, per point (`None`: not driven).
#[derive(Debug, Clone, PartialEq, Default)]
pub struct OutputFrame {
    /// Per module, per point.
    pub modules: Vec<Vec<Option<Value>>>,
}

/// The result of a write cycle.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct WriteReport {
    /// Transactions sent.
    pub transactions: u32,
    /// Transactions that failed.
    pub failures: u32,
    /// End of the last transaction on the line's time.
    pub finished: LineInstant,
}

/// A module on the line.
#[derive(Debug)]
pub struct Module {
    /// Its name, for logs.
    pub name: String,
    /// Its driver.
    pub driver: Box<dyn Driver>,
    pub(crate) counters: Counters,
    pub(crate) health: Health,
    /// Came back after being lost: write every output again.
    refresh_pending: bool,
    /// Its start-up sequence must run before it is read or written again: it did not answer
    /// at start-up, it was lost (it may have been power-cycled back to its saved settings), or
    /// its driver asked ([`Driver::wants_restart`]).
    pub(crate) startup_pending: bool,
    /// A write failed or was refused and has not been made good since.
    output_fault: bool,
    /// It acknowledged every output it was given at least once (a write of every output, or a
    /// write that made a failed one good): what lets its outputs be good, and stale rather
    /// than bad once it is lost.
    outputs_acknowledged: bool,
    pub(crate) last_error: Option<TxError>,
    /// When the module last answered an exchange addressed to it (a reply or an exception:
    /// it is there and hears its address), on the line's time.
    pub(crate) last_answered: Option<LineInstant>,
    /// When every output it owns was last written (a refresh, or a write on change that
    /// covered them all): its periodic rewrite runs from there (`line/housekeeping.rs`).
    last_full_write: Option<LineInstant>,
}

impl Module {
    /// A module with fresh counters.
    pub fn new(name: impl Into<String>, driver: Box<dyn Driver>) -> Self {
        Self {
            name: name.into(),
            driver,
            counters: Counters::default(),
            health: Health::default(),
            refresh_pending: false,
            startup_pending: false,
            output_fault: false,
            outputs_acknowledged: false,
            last_error: None,
            last_answered: None,
            last_full_write: None,
        }
    }

    /// Its state now, with `quality` for this cycle's read.
    fn snapshot(&self, quality: Quality) -> ModuleSnapshot {
        ModuleSnapshot {
            values: self.driver.values().to_vec(),
            quality,
            counters: self.counters,
            last_error: self.last_error,
            outputs: self.output_quality(),
        }
    }

    /// The quality of its outputs (see [`ModuleSnapshot::outputs`]).
    fn output_quality(&self) -> Quality {
        if self.health.is_lost() {
            // What it held when it went away is the last usable value, if it held anything.
            if self.outputs_acknowledged {
                Quality::Stale
            } else {
                Quality::Bad
            }
        } else if self.output_fault
            || self.startup_pending
            || self.refresh_pending
            || !self.outputs_acknowledged
        {
            Quality::Bad
        } else {
            Quality::Good
        }
    }
}

/// The owner of one line.
#[derive(Debug)]
pub struct BusOwner {
    name: String,
    pub(crate) transport: Box<dyn Transport>,
    pub(crate) settings: LineSettings,
    pub(super) discipline: Discipline,
    pub(crate) modules: Vec<Module>,
    pub(crate) line_free_at: LineInstant,
    /// FC 70 Collect rounds for the modules in event mode (line/collect.rs).
    pub(crate) collect: CollectState,
    /// The port's own health: a failed port is reopened with a backoff.
    port_health: Health,
    /// Modules the last [`BusOwner::read_answering`] left for [`BusOwner::read_deferred`].
    deferred: Vec<usize>,
    plan: Vec<Transaction>,
    tx_buf: Vec<u8>,
    rx_buf: Vec<u8>,
    /// Where every frame is reported, when traced (`bus/tap.rs`).
    tap: Option<std::sync::Arc<dyn WireTap>>,
}

/// A start-up check that failed.
#[derive(Debug, thiserror::Error)]
#[error("module {module}: {error}")]
pub struct StartupError {
    /// The module.
    pub module: String,
    /// What failed.
    pub error: TxError,
}

impl BusOwner {
    /// An owner for `transport` and its modules.
    pub fn new(
        name: impl Into<String>,
        transport: Box<dyn Transport>,
        discipline: Discipline,
        modules: Vec<Module>,
    ) -> Self {
        let settings = transport.settings();
        Self {
            name: name.into(),
            transport,
            settings,
            discipline,
            modules,
            line_free_at: LineInstant::ZERO,
            collect: CollectState::default(),
            port_health: Health::default(),
            deferred: Vec::new(),
            plan: Vec::new(),
            tx_buf: Vec::with_capacity(256),
            rx_buf: Vec::with_capacity(256),
            tap: None,
        }
    }

    /// The line's name.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// The modules.
    pub fn modules(&self) -> &[Module] {
        &self.modules
    }

    /// Aligns the line's time with the scan (virtual clocks only): `t` is the scan's time on
    /// the line's clock ([`ScanInstant::on_line_clock`](crate::time::ScanInstant::on_line_clock)).
    pub fn sync(&mut self, t: LineInstant) {
        self.transport.sync(t);
    }

    /// The line's time: the end of its last transaction, or later (on a virtual line the
    /// scan starts once the start-up traffic has ended).
    pub fn now(&self) -> LineInstant {
        self.transport.now()
    }

    /// When the line is free for the next request: the end of its last traffic and the t3.5
    /// of silence after it.
    pub fn free_at(&self) -> LineInstant {
        self.line_free_at.max(self.transport.now())
    }

    /// Sends every module's start-up transactions and checks the replies.
    ///
    /// A module that answers and refuses its configuration (an exception, a setting that reads
    /// back wrong: most likely another model at that address) fails the start. A module that
    /// does not answer (absent, powered off, a dead line), or whose replies it cannot use
    /// even after the retries (noise), does not: it starts lost, its points bad, and its
    /// start-up runs when it first answers, like a module that comes back.
    pub fn startup(&mut self) -> Result<(), StartupError> {
        let limits = self.discipline.health_limits();
        if self.port_health.is_lost() {
            // The port is not there yet (`port_down_at_start`): the start-up sequences run
            // once it opens.
            return Ok(());
        }
        for m in 0..self.modules.len() {
            match self.run_startup(m, self.discipline.retries) {
                Ok(()) => {}
                Err(error @ TxError::Encode) => {
                    return Err(StartupError {
                        module: self.modules[m].name.clone(),
                        error,
                    });
                }
                Err(error) if error.is_refusal() => {
                    return Err(StartupError {
                        module: self.modules[m].name.clone(),
                        error,
                    });
                }
                Err(error) => {
                    let now = self.transport.now();
                    let module = &mut self.modules[m];
                    module.health.mark_lost(now, &limits);
                    module.startup_pending = true;
                    let what = if matches!(error, TxError::Decode(_)) {
                        "answered its start-up with a reply it could not use (noise on the line, \
                         or a module set up otherwise than the project says)"
                    } else {
                        "did not answer at start-up"
                    };
                    tracing::warn!(
                        "line {}: module {} {what} ({error}); its points are bad until it \
                         answers, retried every {:?} at first",
                        self.name,
                        module.name,
                        limits.reconnect_min
                    );
                    module.last_error = Some(error);
                }
            }
        }
        Ok(())
    }

    /// Runs module `m`'s start-up sequence; the first exchange gets `first_retries` retries
    /// (none for the probe of a lost module: a dead module costs the line one timeout per
    /// probe), the others the line's.
    fn run_startup(&mut self, m: usize, first_retries: u8) -> Result<(), TxError> {
        let mut plan = std::mem::take(&mut self.plan);
        plan.clear();
        self.modules[m].driver.plan_startup(&mut plan);
        let mut result = Ok(());
        for (i, tx) in plan.iter().enumerate() {
            let retries = if i == 0 {
                first_retries
            } else {
                self.discipline.retries
            };
            if let Err(e) = self.execute_with(m, tx, retries) {
                result = Err(e);
                break;
            }
        }
        self.plan = plan;
        if result.is_ok() {
            let module = &mut self.modules[m];
            module.startup_pending = false;
            module.refresh_pending = true;
        }
        result
    }

    /// Retries for module `m`'s exchanges: the line's, or none while it is failing.
    fn retries_for(&self, m: usize) -> u8 {
        if self.modules[m].health.is_failing() {
            0
        } else {
            self.discipline.retries
        }
    }

    /// Brings module `m` back: the driver forgets what it believed the module held, the
    /// start-up sequence runs again, and every output is written at the next write.
    fn restart(&mut self, m: usize) -> Result<(), TxError> {
        self.modules[m].driver.on_restart();
        let result = self.run_startup(m, self.retries_for(m));
        if let Some(e) = result.as_ref().err().filter(|e| e.is_refusal()) {
            // It answered and refused: worth a line each time (it stays bad and is retried).
            tracing::error!(
                "line {}: module {} refused its start-up configuration: {e}",
                self.name,
                self.modules[m].name
            );
        }
        result
    }

    /// Reads every module's inputs. Lost modules are polled only when their backoff allows;
    /// a failed port is reopened first. The same as [`Self::read_answering`] then
    /// [`Self::read_deferred`], with the deferred modules' results in the frame.
    pub fn read_inputs(&mut self) -> InputFrame {
        let mut frame = self.read_answering();
        self.read_deferred(Some(&mut frame));
        frame
    }

    /// Reads the modules that answered their last cycle, in one pass, and returns their
    /// frame; a module that failed its last cycle (or is lost, or waits for its start-up
    /// sequence) keeps its last snapshot, marked stale or bad, and is read by
    /// [`Self::read_deferred`] after the frame has gone to the scan. So a module that stops answering delays its line's inputs once, not every cycle
    /// until it is lost, and a lost module's probe never delays the others.
    pub fn read_answering(&mut self) -> InputFrame {
        let started = self.transport.now();
        let port_up = self.port_ready(started);
        // One FC 70 Collect round for the modules in event mode, before any poll (an RS-485
        // line's time slots: never on a Modbus TCP bus, where the build refuses event mode).
        if port_up && !self.carries_pdus() {
            self.collect_pass(started);
        }
        let mut plan = std::mem::take(&mut self.plan);
        let mut snapshots = Vec::with_capacity(self.modules.len());
        self.deferred.clear();
        for m in 0..self.modules.len() {
            let module = &self.modules[m];
            // A restart (a start-up sequence of many exchanges) must not age the others' values.
            if port_up
                && !self.port_health.is_lost()
                && (module.health.is_failing() || module.startup_pending)
            {
                self.deferred.push(m);
                // Not read in this pass: its values are last cycle's at best.
                let quality = match module.health.quality() {
                    Quality::Good => Quality::Stale,
                    q => q,
                };
                snapshots.push(module.snapshot(quality));
                continue;
            }
            snapshots.push(self.read_module(m, port_up, &mut plan));
        }
        self.plan = plan;
        InputFrame {
            modules: snapshots,
            started,
            finished: self.transport.now(),
        }
    }

    /// Reads the modules [`Self::read_answering`] left for later (failing, lost, restarting);
    /// their snapshots go into `frame` when given, else into the next frame.
    pub fn read_deferred(&mut self, mut frame: Option<&mut InputFrame>) {
        let mut plan = std::mem::take(&mut self.plan);
        let deferred = std::mem::take(&mut self.deferred);
        for &m in &deferred {
            let snapshot = self.read_module(m, true, &mut plan);
            if let Some(f) = frame.as_deref_mut() {
                if let Some(slot) = f.modules.get_mut(m) {
                    *slot = snapshot;
                }
                f.finished = self.transport.now();
            }
        }
        self.deferred = deferred;
        self.plan = plan;
    }

    /// One module's read (its restart first when it waits for one), recorded in its health.
    fn read_module(
        &mut self,
        m: usize,
        port_up: bool,
        plan: &mut Vec<Transaction>,
    ) -> ModuleSnapshot {
        let now = self.transport.now();
        // A port that failed during this cycle is not tried again for the next modules.
        let port_up = port_up && !self.port_health.is_lost();
        let polled = port_up && self.modules[m].health.due(now);
        let mut error = None;
        if polled {
            plan.clear();
            if self.modules[m].startup_pending {
                error = self.restart(m).err();
            }
            if error.is_none() {
                self.modules[m].driver.advance_to(now);
                self.read_plan(m, plan);
                // A module that failed its last cycle (a lost one's probe included) gets one
                // attempt per exchange until it answers again: retries are for noise, not for
                // a module that is gone, and each costs the line a response timeout.
                let retries = self.retries_for(m);
                for tx in plan.iter() {
                    if let Err(e) = self.execute_with(m, tx, retries) {
                        error = Some(e);
                        break;
                    }
                }
            }
            if let Some(e @ TxError::Line(_)) = &error {
                let e = *e;
                self.port_failed(&e);
            }
        } else if !port_up {
            error = Some(TxError::PortDown);
        }
        let limits = self.discipline.health_limits();
        let line = &self.name;
        let module = &mut self.modules[m];
        // While the port is down a module goes stale, then bad; once lost, its backoff is
        // left alone (the port's own backoff paces the retries).
        let record = polled || (!port_up && !module.health.is_lost());
        let quality = if record {
            let (quality, event) = module.health.record(error.is_none(), now, &limits);
            match event {
                Some(HealthEvent::Lost) => {
                    // It may come back from a power cycle, with its saved settings only.
                    module.startup_pending = true;
                    tracing::warn!(
                        "line {line}: module {} lost ({}); retrying every {:?} at first",
                        module.name,
                        error.as_ref().map(ToString::to_string).unwrap_or_default(),
                        limits.reconnect_min
                    )
                }
                Some(HealthEvent::Back(after)) => {
                    module.refresh_pending = true;
                    tracing::info!(
                        "line {line}: module {} is back after {after:.1?}",
                        module.name
                    );
                }
                None => {}
            }
            module.last_error = error;
            quality
        } else {
            module.health.skipped_quality()
        };
        module.snapshot(quality)
    }

    /// Whether the port can be used this cycle; reopens a failed one when its backoff allows.
    fn port_ready(&mut self, now: LineInstant) -> bool {
        if !self.port_health.is_lost() {
            return true;
        }
        if !self.port_health.due(now) {
            return false;
        }
        let limits = HealthLimits {
            fail_limit: 1,
            ..self.discipline.health_limits()
        };
        match self.transport.reopen() {
            Ok(()) => {
                if let (_, Some(HealthEvent::Back(after))) =
                    self.port_health.record(true, now, &limits)
                {
                    tracing::info!("line {}: port reopened after {after:.1?}", self.name);
                }
                for m in &mut self.modules {
                    m.health.retry_now();
                }
                true
            }
            Err(e) => {
                self.port_health.record(false, now, &limits);
                tracing::debug!("line {}: port still unavailable: {e}", self.name);
                false
            }
        }
    }

    /// The port could not be opened at start (`error`, a USB adapter not enumerated yet): the
    /// line starts as an unplugged one does, every module lost and waiting for its start-up,
    /// and the port is reopened with the backoff of a lost port until it opens. Said once.
    pub fn port_down_at_start(&mut self, error: &LineError) {
        let limits = HealthLimits {
            fail_limit: 1,
            ..self.discipline.health_limits()
        };
        let now = self.transport.now();
        self.port_health.record(false, now, &limits);
        for module in &mut self.modules {
            module
                .health
                .mark_lost(now, &self.discipline.health_limits());
            module.startup_pending = true;
            module.last_error = Some(TxError::Line(LineFault::from(error)));
        }
        tracing::error!(
            "line {}: {error}; its modules are lost until the port opens, tried every {:?} at \
             first",
            self.name,
            limits.reconnect_min
        );
    }

    pub(crate) fn port_failed(&mut self, error: &TxError) {
        let limits = HealthLimits {
            fail_limit: 1,
            ..self.discipline.health_limits()
        };
        let now = self.transport.now();
        if let (_, Some(HealthEvent::Lost)) = self.port_health.record(false, now, &limits) {
            tracing::error!(
                "line {}: {error}; reopening the port every {:?} at first",
                self.name,
                limits.reconnect_min
            );
        }
    }

    /// Writes outputs that changed, and every output of a module whose refresh period has
    /// passed (`Discipline::output_refresh`, spread over cycles: `line/housekeeping.rs`).
    pub fn write_outputs(&mut self, frame: &OutputFrame) -> WriteReport {
        self.write(frame, false)
    }

    /// Writes the safe state: every output again (not only changes), and to lost modules too,
    /// once, in case they are back (stop, fault).
    pub fn write_safe(&mut self, frame: &OutputFrame) -> WriteReport {
        for module in &mut self.modules {
            module.last_full_write = None;
        }
        self.write(frame, true)
    }

    /// The modules whose outputs are all written again this cycle: those back from a loss or
    /// a start-up, and the periodic rewrites `line/housekeeping.rs` chooses.
    fn output_refreshes(&mut self, now: LineInstant) -> Vec<bool> {
        let period = self.discipline.output_refresh;
        let mut pick = Pick::default();
        for (m, module) in self.modules.iter().enumerate() {
            if module.refresh_pending {
                pick.taken();
            } else {
                pick.offer(m, Urgency::of(module.last_full_write, period, now));
            }
        }
        let mut refresh: Vec<bool> = self.modules.iter().map(|m| m.refresh_pending).collect();
        for m in pick.chosen() {
            refresh[m] = true;
        }
        refresh
    }

    fn write(&mut self, frame: &OutputFrame, include_lost: bool) -> WriteReport {
        let now = self.transport.now();
        let refreshes = self.output_refreshes(now);
        let mut report = WriteReport {
            transactions: 0,
            failures: 0,
            finished: now,
        };
        let mut plan = std::mem::take(&mut self.plan);
        for (m, desired) in frame.modules.iter().enumerate().take(self.modules.len()) {
            let module = &mut self.modules[m];
            // A lost module gets no bus time; when it comes back, everything is written again.
            // One waiting for its start-up would refuse the writes (a fired watchdog).
            if !include_lost
                && (module.health.is_lost() || module.startup_pending || self.port_health.is_lost())
            {
                continue;
            }
            module.refresh_pending = false;
            let refresh_module = refreshes[m];
            plan.clear();
            module.driver.plan_write(desired, refresh_module, &mut plan);
            let full = refresh_module || module.driver.planned_full_write();
            let mut failed = false;
            let retries = self.retries_for(m);
            for tx in &plan {
                report.transactions += 1;
                if let Err(e) = self.execute_with(m, tx, retries) {
                    if matches!(e, TxError::Line(_)) {
                        self.port_failed(&e);
                    }
                    report.failures += 1;
                    failed = true;
                    self.modules[m].driver.on_failure(tx.tag);
                }
            }
            let module = &mut self.modules[m];
            if failed || module.startup_pending {
                if !module.output_fault {
                    tracing::warn!(
                        "line {}: module {}: outputs not written{}",
                        self.name,
                        module.name,
                        if module.startup_pending {
                            "; restarting it"
                        } else {
                            ""
                        }
                    );
                }
                module.output_fault = true;
            } else if module.output_fault && (refresh_module || !plan.is_empty()) {
                module.output_fault = false;
                module.outputs_acknowledged = true;
            } else if refresh_module {
                // Every output written and answered: the module holds them all.
                module.outputs_acknowledged = true;
            }
            if full && !failed && !module.startup_pending {
                module.last_full_write = Some(now);
            }
        }
        self.plan = plan;
        report.finished = self.transport.now();
        report
    }

    /// Runs one transaction with `retries` retries; the reply goes to the module's driver.
    fn execute_with(&mut self, m: usize, tx: &Transaction, retries: u8) -> Result<(), TxError> {
        let result = self.execute_once(m, tx, retries);
        let module = &mut self.modules[m];
        if module.driver.wants_restart() && !module.startup_pending {
            module.startup_pending = true;
            tracing::warn!(
                "line {}: module {} holds its own safe state; running its start-up again",
                self.name,
                module.name
            );
        }
        result
    }

    /// Runs one transaction: `retries` more attempts after a timeout or noise. A read-back
    /// that differs from what was written ([`DecodeError::Mismatch`]) is the module's word at
    /// once behind a check (Modbus's CRC-16, a DCON checksum); over a frame without one
    /// (text, DCON without checksum: [`Integrity`](crate::driver::Integrity)) a garbled digit
    /// reads as another value, so it is asked again before it is believed ([`ReadBackVote`]).
    fn execute_once(&mut self, m: usize, tx: &Transaction, retries: u8) -> Result<(), TxError> {
        let mut last = TxError::Timeout(self.discipline.response_timeout);
        let mut vote = ReadBackVote::new(tx.frame.integrity(), retries);
        while vote.next_attempt() {
            match self.attempt(m, tx) {
                Ok(None) => return Ok(()),
                Ok(Some(reply)) => {
                    let now = self.transport.now();
                    let module = &mut self.modules[m];
                    module.last_answered = Some(now);
                    if let Reply::Modbus(Response::Exception { code, .. }) = &reply {
                        module.counters.exceptions += 1;
                        // The device answered: retrying the same request gets the same "no".
                        let e = TxError::Decode(DecodeError::Exception(*code));
                        let _ = module.driver.on_reply(tx.tag, &reply);
                        return Err(e);
                    }
                    let result = module.driver.on_reply(tx.tag, &reply);
                    let noise = match result {
                        Ok(()) => return Ok(()),
                        // A reply that passed every frame check but does not fit the
                        // transaction (a duplicate of an earlier reply of the same function
                        // and length, heard after the flush) is noise like a CRC error: the
                        // guard time and a flush, then the retry.
                        Err(e @ DecodeError::Unexpected { .. }) => e,
                        // A read-back that differs, over a reply with no check, not yet said
                        // twice: maybe a garbled digit, asked again the same way.
                        Err(e @ DecodeError::Mismatch { .. }) if !vote.believes(e) => e,
                        Err(e) => {
                            module.counters.decode_errors += 1;
                            if let DecodeError::Mismatch { .. } = e {
                                module.driver.on_confirmed_mismatch(tx.tag, e);
                            }
                            return Err(TxError::Decode(e));
                        }
                    };
                    module.counters.decode_errors += 1;
                    last = TxError::Decode(noise);
                    self.recover_from_noise(m)?;
                }
                Err(e @ TxError::Line(_)) => return Err(e),
                Err(e) => last = e,
            }
        }
        Err(last)
    }

    /// After a reply that passed the frame checks but is taken for noise: the guard time and
    /// a flush, as after a CRC error, so a late copy is never read as the next answer.
    fn recover_from_noise(&mut self, m: usize) -> Result<(), TxError> {
        let now = self.transport.now();
        let timeout = self.discipline.response_timeout;
        match self.recover(now, timeout) {
            Ok(n) => {
                self.modules[m].counters.dropped_bytes += n as u64;
                Ok(())
            }
            Err(e) => {
                self.modules[m].counters.flush_failures += 1;
                Err(line_err(&e))
            }
        }
    }

    /// One attempt: `Ok(None)` for a broadcast (no reply expected).
    fn attempt(&mut self, m: usize, tx: &Transaction) -> Result<Option<Reply>, TxError> {
        let frame = match &tx.frame {
            Outgoing::Modbus { unit, request } => Frame::Modbus {
                address: unit.get(),
                request,
            },
            Outgoing::Text {
                line, terminator, ..
            } => Frame::Text {
                line,
                terminator: *terminator,
            },
            Outgoing::NoReply { bytes } => Frame::NoReply(bytes),
        };
        // A device may need a longer reply timeout or inter-frame gap than its line's.
        let driver = &self.modules[m].driver;
        let timeout = driver
            .response_timeout()
            .unwrap_or(self.discipline.response_timeout);
        if let Some(gap) = driver.frame_gap(self.settings) {
            self.line_free_at += gap.saturating_sub(self.settings.t3_5());
        }
        let done = self.exchange(frame, timeout, Silence::Timeout);
        let counters = &mut self.modules[m].counters;
        counters.dropped_bytes += done.dropped as u64;
        counters.flush_failures += u64::from(done.flush_failed);
        if done.sent.is_some() {
            counters.requests += 1;
        }
        match done.outcome {
            Ok(reply) => {
                if let Some(round_trip) = done.round_trip {
                    counters.last_round_trip = round_trip;
                }
                Ok(reply)
            }
            Err(Miss::Encode) => Err(TxError::Encode),
            Err(Miss::Line(e)) => Err(line_err(&e)),
            Err(Miss::Echo(fault)) => {
                counters.echo_errors += 1;
                Err(TxError::Echo(fault))
            }
            Err(Miss::Silence) => {
                counters.timeouts += 1;
                Err(TxError::Timeout(timeout))
            }
            Err(Miss::Cut) => {
                // Part of a reply, then silence: it was cut, not missing.
                counters.bad_replies += 1;
                Err(TxError::Timeout(timeout))
            }
            Err(Miss::Bad(e)) => {
                if matches!(e, ReplyError::Crc { .. }) {
                    counters.crc_errors += 1;
                } else {
                    counters.bad_replies += 1;
                }
                Err(TxError::BadReply(e))
            }
        }
    }

    /// One exchange on the line, the only way anything is sent: waits for the line to be free,
    /// drops what arrived meanwhile, sends `frame`, waits `wait` for the first byte, then
    /// takes bytes until the reply is complete, verified, or given up on. A good reply leaves
    /// t3.5 of silence before the next request; a bad one, a cut one or (unless
    /// [`Silence::Answer`]) silence, the guard time for `wait` and a flush, so a late or
    /// babbling reply is never read as the answer to the next request.
    pub(crate) fn exchange(
        &mut self,
        frame: Frame<'_>,
        wait: Duration,
        silence: Silence,
    ) -> Exchanged {
        if let Frame::Modbus { address, request } = frame {
            if self.carries_pdus() {
                return self.exchange_pdu(address, request, wait);
            }
        }
        let mut done = Exchanged::nothing_yet();
        self.tx_buf.clear();
        let (mut assembler, terminator) = match frame {
            Frame::Modbus { address, request } => {
                if encode_request(address, request, &mut self.tx_buf).is_err() {
                    done.outcome = Err(Miss::Encode);
                    return done;
                }
                (Some(ReplyAssembler::new(address, request)), None)
            }
            Frame::Text { line, terminator } => {
                self.tx_buf.extend_from_slice(line);
                (None, Some(terminator))
            }
            Frame::NoReply(bytes) => {
                self.tx_buf.extend_from_slice(bytes);
                (None, None)
            }
        };
        self.transport.wait_until(self.line_free_at);
        // Whatever arrived while the line was idle belongs to nobody; a line that cannot drop
        // it could hand it over as the reply, so nothing is sent.
        match self.transport.flush_input() {
            Ok(n) => {
                done.dropped += n;
                self.trace_discard(self.transport.now(), n, Discard::BeforeRequest);
            }
            Err(e) => {
                // A network pipe connects here; only a failed flush is counted as one.
                done.flush_failed = matches!(e, LineError::Flush(_));
                done.outcome = Err(Miss::Line(e));
                return done;
            }
        }
        let started = self.transport.now();
        match self.transport.write_frame(&self.tx_buf) {
            Ok(()) => {}
            // Sent, but its echo came back wrong: the guard and flush as after a bad reply.
            Err(LineError::Echo(fault)) => {
                self.trace(started, WireEvent::Sent(&self.tx_buf));
                let now = self.transport.now();
                done.sent = Some(now);
                self.rx_buf.clear();
                return self.recovered(done, now, wait, Miss::Echo(fault));
            }
            Err(e) => {
                done.outcome = Err(Miss::Line(e));
                return done;
            }
        }
        self.trace(started, WireEvent::Sent(&self.tx_buf));
        let sent = self.transport.now();
        done.sent = Some(sent);
        if assembler.is_none() && terminator.is_none() {
            self.line_free_at = sent + self.settings.t3_5();
            return done;
        }

        self.rx_buf.clear();
        let mut deadline = sent + wait;
        let inter_char = self.inter_char_timeout();
        // However the bytes trickle in, a reply ends by then.
        let hard_deadline = deadline + self.settings.chars(MAX_REPLY) + inter_char;
        let miss = loop {
            let before = self.rx_buf.len();
            let n = match self.transport.read_until(&mut self.rx_buf, deadline) {
                Ok(n) => n,
                Err(e) => {
                    done.outcome = Err(Miss::Line(e));
                    return done;
                }
            };
            let now = self.transport.now();
            if n == 0 {
                if self.rx_buf.is_empty() {
                    if silence == Silence::Answer {
                        self.trace(now, WireEvent::Timeout { waited: wait });
                        self.line_free_at = now + self.settings.t3_5();
                        done.outcome = Err(Miss::Silence);
                        return done;
                    }
                    break Miss::Silence;
                }
                break Miss::Cut;
            }
            if self.rx_buf.len() > MAX_REPLY || now > hard_deadline {
                // A transmitter stuck on, or noise without end: stop listening.
                break Miss::Bad(ReplyError::Malformed {
                    offset: self.rx_buf.len(),
                });
            }
            deadline = now + inter_char;
            if let Some(term) = terminator {
                if let Some(end) = self.rx_buf.iter().position(|b| *b == term) {
                    if self.rx_buf[..=end] == self.tx_buf[..] {
                        // The command line itself: the adapter's echo, not the module's reply.
                        break Miss::Echo(EchoFault::Unexpected);
                    }
                    self.trace_reply(now, &self.rx_buf[..=end], Verdict::Good);
                    let reply = self.rx_buf[..end].to_vec();
                    self.finish(&mut done, sent, now, Reply::Text(reply));
                    return done;
                }
                continue;
            }
            let Some(asm) = assembler.as_mut() else {
                continue;
            };
            match asm.push(&self.rx_buf[before..]) {
                Progress::NeedMore => {}
                Progress::Complete { response, extra } => {
                    done.dropped += extra;
                    let frame = self.rx_buf.len().saturating_sub(extra);
                    self.trace_reply(now, &self.rx_buf[..frame], Verdict::Good);
                    self.trace_discard(now, extra, Discard::AfterReply);
                    self.finish(&mut done, sent, now, Reply::Modbus(response));
                    return done;
                }
                Progress::Failed(e) => break Miss::Bad(e),
            }
        };
        let now = self.transport.now();
        self.recovered(done, now, wait, miss)
    }

    /// Ends a failed exchange with the guard and a flush ([`Self::recover`]); a failure that
    /// began with the request's own bytes is the adapter's echo on a bus without
    /// `echo: discard`, and says so.
    fn recovered(
        &mut self,
        mut done: Exchanged,
        now: LineInstant,
        wait: Duration,
        miss: Miss,
    ) -> Exchanged {
        let miss = match miss {
            Miss::Bad(_) | Miss::Cut if echo::begins_with_request(&self.tx_buf, &self.rx_buf) => {
                Miss::Echo(EchoFault::Unexpected)
            }
            miss => miss,
        };
        self.trace_miss(now, &miss, wait);
        done.outcome = match self.recover(now, wait) {
            Ok(dropped) => {
                done.dropped += dropped;
                self.trace_discard(self.transport.now(), dropped, Discard::AfterGuard);
                Err(miss)
            }
            // The late reply may still be there for the next request: the line has failed.
            Err(e) => {
                done.flush_failed = true;
                Err(Miss::Line(e))
            }
        };
        done
    }

    /// After a good reply: record the round trip and keep t3.5 of silence before the next.
    fn finish(&mut self, done: &mut Exchanged, sent: LineInstant, now: LineInstant, reply: Reply) {
        done.round_trip = Some(now - sent);
        done.outcome = Ok(Some(reply));
        self.line_free_at = now + self.settings.t3_5();
    }

    /// After a timeout or a bad reply to an exchange that waited `wait` for its first byte:
    /// wait out the guard time so a late or babbling reply ends, then drop whatever came;
    /// returns how many bytes.
    fn recover(&mut self, now: LineInstant, wait: Duration) -> Result<usize, LineError> {
        let guard = crate::line::budget::guard_time(self.settings, wait);
        self.transport.wait_until(now + guard);
        let dropped = self.transport.flush_input();
        self.line_free_at = self.transport.now() + self.settings.t3_5();
        dropped
    }

    /// Silence inside a reply after which it is taken as ended. Modbus says t1.5; USB adapters
    /// and ptys deliver in chunks, so allow some milliseconds.
    pub(crate) fn inter_char_timeout(&self) -> Duration {
        (self.settings.t1_5() * 10).max(Duration::from_millis(5))
    }
}

pub(crate) fn line_err(e: &LineError) -> TxError {
    TxError::Line(LineFault::from(e))
}

/// A command to a bus thread.
#[derive(Debug)]
pub enum BusCommand {
    /// Read every module; answer with [`BusEvent::Inputs`].
    Read,
    /// Write outputs; answer with [`BusEvent::Written`].
    Write(OutputFrame),
    /// Write the safe state: every output, lost modules included ([`BusOwner::write_safe`]).
    WriteSafe(OutputFrame),
    /// Stop the thread after writing this last frame (the safe state).
    Stop(Option<OutputFrame>),
}

/// What a bus thread answers.
#[derive(Debug)]
pub enum BusEvent {
    /// A read cycle's result.
    Inputs(InputFrame),
    /// A write cycle's result.
    Written(WriteReport),
}

/// A bus owner on its own OS thread.
///
/// Every command carries a sequence number and its answer echoes it, so an answer that comes
/// too late for one cycle is recognised and dropped, never taken for the next cycle's. The scan
/// never blocks on the thread: commands are queued with `try_send` (a full queue means the
/// line is far behind, and the cycle goes on with stale inputs), answers queue without bound
/// (one per command), and stopping waits at most its deadline.
#[derive(Debug)]
pub struct BusThread {
    commands: Sender<(u64, BusCommand)>,
    events: Receiver<(u64, BusEvent)>,
    handle: Option<JoinHandle<BusOwner>>,
    /// Sequence number of the last command sent.
    last_sent: u64,
    /// The line's name, for what is logged about the thread once the owner is inside it.
    name: String,
}

impl BusThread {
    /// Starts a thread that owns `owner`.
    pub fn spawn(mut owner: BusOwner) -> std::io::Result<Self> {
        let (commands, cmd_rx) = crossbeam_channel::bounded::<(u64, BusCommand)>(8);
        let (ev_tx, events) = crossbeam_channel::unbounded::<(u64, BusEvent)>();
        let name = owner.name.clone();
        let handle = std::thread::Builder::new()
            .name(format!("bus-{name}"))
            .spawn(move || {
                for (seq, cmd) in cmd_rx {
                    let event = match cmd {
                        BusCommand::Read => {
                            // The answering modules' inputs go to the scan at once; failing
                            // and lost ones are read after (see `read_answering`).
                            let frame = owner.read_answering();
                            if ev_tx.send((seq, BusEvent::Inputs(frame))).is_err() {
                                break;
                            }
                            owner.read_deferred(None);
                            continue;
                        }
                        BusCommand::Write(frame) => BusEvent::Written(owner.write_outputs(&frame)),
                        BusCommand::WriteSafe(frame) => BusEvent::Written(owner.write_safe(&frame)),
                        BusCommand::Stop(last) => {
                            if let Some(frame) = last {
                                let report = owner.write_safe(&frame);
                                // `BusThread::stop` only drains events while it waits, and
                                // gives up at its deadline: no one may be listening.
                                drop(ev_tx.send((seq, BusEvent::Written(report))));
                            }
                            break;
                        }
                    };
                    if ev_tx.send((seq, event)).is_err() {
                        break;
                    }
                }
                owner
            })?;
        Ok(Self {
            commands,
            events,
            handle: Some(handle),
            last_sent: 0,
            name,
        })
    }

    /// The name of the line this thread runs.
    pub fn name(&self) -> &str {
        &self.name
    }

    /// Whether the thread has ended (a driver panicked, or it was stopped).
    pub fn is_finished(&self) -> bool {
        self.handle.as_ref().is_none_or(|h| h.is_finished())
    }

    /// Queues a command without waiting; false when the line is too far behind to take it.
    pub fn send(&mut self, cmd: BusCommand) -> bool {
        self.try_send(cmd).is_ok()
    }

    /// Queues a command without waiting; its sequence number, or the command back when the
    /// queue is full (or the thread has ended).
    pub fn try_send(&mut self, cmd: BusCommand) -> Result<u64, BusCommand> {
        let seq = self.last_sent + 1;
        match self.commands.try_send((seq, cmd)) {
            Ok(()) => {
                self.last_sent = seq;
                Ok(seq)
            }
            Err(e) => Err(e.into_inner().1),
        }
    }

    /// Sequence number of the last command sent (0 before the first).
    pub fn last_sent(&self) -> u64 {
        self.last_sent
    }

    /// The next answer that has already come, with its command's sequence number.
    pub fn try_recv(&self) -> Option<(u64, BusEvent)> {
        self.events.try_recv().ok()
    }

    /// The next answer, waiting at most until `deadline`.
    pub fn recv_deadline(&self, deadline: std::time::Instant) -> Option<(u64, BusEvent)> {
        self.events.recv_deadline(deadline).ok()
    }

    /// Waits at most `timeout` for the answer to the last command sent; answers to earlier
    /// commands that arrive meanwhile are dropped.
    pub fn recv(&self, timeout: Duration) -> Option<BusEvent> {
        let deadline = std::time::Instant::now() + timeout;
        loop {
            match self.events.recv_deadline(deadline) {
                Ok((seq, event)) if seq == self.last_sent => return Some(event),
                Ok(_) => continue,
                Err(_) => return None,
            }
        }
    }

    /// Stops the thread, writing `last` first; waits at most `timeout` and returns the owner
    /// back if the thread ended in time.
    pub fn stop(mut self, last: Option<OutputFrame>, timeout: Duration) -> Option<BusOwner> {
        let deadline = std::time::Instant::now() + timeout;
        let seq = self.last_sent + 1;
        // Not sent means the thread has ended (channel closed) or is stuck past the deadline:
        // either way the wait below says which.
        drop(
            self.commands
                .send_deadline((seq, BusCommand::Stop(last)), deadline),
        );
        let handle = self.handle.take()?;
        while !handle.is_finished() {
            if std::time::Instant::now() >= deadline {
                // The line is stuck (a port that blocks): leave the thread, do not hang the PLC.
                return None;
            }
            // A 5 ms pause between looks; the events themselves are for no one now.
            drop(self.events.recv_timeout(Duration::from_millis(5)));
        }
        handle.join().ok()
    }
}

mod pdu;
mod tap;
#[cfg(test)]
mod tests;
