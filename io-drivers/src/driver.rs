//! The sans-IO device driver: plans transactions, decodes replies into points.
//!
//! A driver never touches a port. The bus owner of its line (`crate::line::bus`) executes
//! the transactions the driver plans and hands each reply back. One driver instance serves one
//! module; its point table is the model's ([`crate::devices::ModelSpec::points`]).

use std::fmt::Debug;
use std::time::Duration;

use crate::line::LineSettings;
use crate::time::LineInstant;

use crate::modbus::{ExceptionCode, Request, Response, UnitId};
use crate::point::Value;

/// One exchange on the line, as a driver plans it.
#[derive(Debug, Clone, PartialEq)]
pub struct Transaction {
    /// What goes on the wire.
    pub frame: Outgoing,
    /// The driver's own label, handed back with the reply.
    pub tag: u32,
}

/// The request of a transaction.
#[derive(Debug, Clone, PartialEq)]
pub enum Outgoing {
    /// A Modbus RTU request to one unit.
    Modbus {
        /// The addressed unit.
        unit: UnitId,
        /// The request PDU.
        request: Request,
    },
    /// A line of a module's text protocol, sent as given; the reply ends with `terminator`.
    Text {
        /// The bytes to send, terminator included.
        line: Vec<u8>,
        /// The byte that ends the reply (CR for MiniMod and RESI ASCII).
        terminator: u8,
        /// Whether the reply carries a check of its own (a DCON checksum) or none (MiniMod
        /// and RESI text, DCON without checksum).
        integrity: Integrity,
    },
    /// Bytes sent as given that nothing answers: a DCON broadcast (`#**`, `~**`) or the
    /// EX-9053D-M's Modbus "host OK". The bus owner keeps t3.5 of silence after them and
    /// goes on; the driver gets no [`Driver::on_reply`] for them.
    NoReply {
        /// The whole frame (terminator or CRC included).
        bytes: Vec<u8>,
    },
}

impl Outgoing {
    /// Whether the reply to this request carries an integrity check: Modbus RTU's CRC-16
    /// (Modbus TCP: the TCP checksum), or what a text request says.
    pub fn integrity(&self) -> Integrity {
        match self {
            Outgoing::Text { integrity, .. } => *integrity,
            Outgoing::Modbus { .. } | Outgoing::NoReply { .. } => Integrity::Checked,
        }
    }
}

/// Whether a reply frame carries a check that catches a character garbled on the wire.
///
/// It decides what a read-back that differs from what was written means
/// ([`DecodeError::Mismatch`]). Behind a check that catches every single flipped bit (Modbus
/// RTU's CRC-16, a DCON checksum: a sum of bytes modulo 256 changes with any one bit), a
/// reply that passed is what the device holds, and it is believed at once. A text reply
/// without a check (MiniMod text protocol, RESI ASCII, DCON without checksum) can carry a
/// character with a flipped bit that reads as another plausible digit (`WDTTIME=00131` for
/// `00133`: `'3'` 0x33 with bit 1 flipped is `'1'` 0x31): the MiniMod manual allows lines
/// without parity (`SERLINE=19200N` or `X`), and parity, where the line has it, misses two
/// flipped bits in one character; so the bus owner asks again before it believes it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Integrity {
    /// The frame carries a check that the codec or the driver verifies.
    Checked,
    /// The frame carries none: a garbled character can read as a valid answer.
    Unchecked,
}

/// A module's place in its line's FC 70 Collect round ([`Driver::collect_membership`]) and
/// the two periods of its full refresh ([`Driver::plan_refresh`]).
///
/// An idle Collect round is silence whether the module is there or not, and a module whose
/// event recording was switched off (a power cycle back to saved settings that do not enable
/// it) stays silent too. So the bus owner reads a member in full when nothing addressed to it
/// has been answered for `answer_within` (a write's echo counts: it proves the module is there
/// and hears its address, which also feeds a watchdog that counts only such messages), and at
/// least every `resync` whatever answered (the bound on how long inputs can stay wrong after
/// events were lost without a gap in SLVSEQ).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Membership {
    /// The unit that answers in the round.
    pub unit: UnitId,
    /// The longest the module goes without an answered exchange addressed to it.
    pub answer_within: Duration,
    /// The longest it goes without a full read.
    pub resync: Duration,
    /// How much longer than the line's own end-of-request silence the module waits before it
    /// takes a request as ended (MiniMod RDELAYM, "Setting the Modbus communication timeout"):
    /// its slot in a Collect window starts that much later, so the owner listens that much
    /// longer.
    pub frame_timeout: Duration,
}

/// A reply to a transaction, as the bus owner hands it to the driver.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    /// A verified Modbus response (exceptions included: the device answered).
    Modbus(Response),
    /// A text reply, terminator stripped.
    Text(Vec<u8>),
}

/// Why a driver could not use a reply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The device refused the request.
    #[error("device answered with exception {0}")]
    Exception(ExceptionCode),
    /// The reply does not fit the request (other function, count, or value out of range).
    #[error("unexpected reply to transaction {tag}")]
    Unexpected {
        /// The transaction's tag.
        tag: u32,
    },
    /// A start-up setting read back differs from what was written. Over a reply without an
    /// integrity check the bus owner asks again before it believes it ([`Integrity`]).
    #[error("register {register} reads back {found}, expected {expected}")]
    Mismatch {
        /// The manual's register name.
        register: &'static str,
        /// What was written.
        expected: u32,
        /// What the module holds.
        found: u32,
    },
}

/// A module driver. All methods are cheap and never block.
pub trait Driver: Send + Debug {
    /// The unit (or text-protocol) address of the module.
    fn address(&self) -> u8;

    /// Transactions that configure the module at start-up and verify it by reading back; sent
    /// once before the first scan. A [`DecodeError`] from their replies stops the start.
    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        let _ = out;
    }

    /// Transactions that read this cycle's inputs (and read back outputs), in the fewest
    /// exchanges the map allows.
    fn plan_read(&mut self, out: &mut Vec<Transaction>);

    /// Transactions that bring the module's outputs to `desired`, indexed like the model's
    /// points (`None`: not an output, or not owned by the program). Drivers write on change and,
    /// when `refresh` is set, everything again.
    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>);

    /// Whether the writes the last [`Driver::plan_write`] planned bring every output the
    /// program owns to its desired value (a write on change that happens to cover them all,
    /// or a refresh): the bus owner then counts them as the module's output refresh, and the
    /// periodic rewrite of that module waits a full period again.
    fn planned_full_write(&self) -> bool {
        false
    }

    /// Applies a reply to one of this driver's transactions.
    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError>;

    /// The bus owner believes a read-back that differs ([`DecodeError::Mismatch`]) from
    /// transaction `tag`: its reply carried an integrity check, or a check-less reply said the
    /// same twice in a row (see [`Integrity`]). The driver says here, not in
    /// [`Driver::on_reply`], whatever explains the mismatch to a user, so that a garbled reply
    /// that a second ask corrects is never reported as the module's word.
    fn on_confirmed_mismatch(&mut self, tag: u32, mismatch: DecodeError) {
        let _ = (tag, mismatch);
    }

    /// Tells the driver a transaction got no usable reply (timeout, CRC, ...): a write must be
    /// planned again next cycle.
    fn on_failure(&mut self, tag: u32) {
        let _ = tag;
    }

    /// The module answers again after it was lost (a pulled cable, a power cycle, a watchdog
    /// that fired) or after [`Driver::wants_restart`] asked for it: the bus owner then runs
    /// [`Driver::plan_startup`] again and writes every output. The driver forgets what it
    /// believed the module held (written outputs, read-back state) and clears its request.
    fn on_restart(&mut self) {}

    /// Whether the module needs its start-up sequence again now: a write was refused because
    /// the module holds its own safe state (a fired watchdog refuses writes with exception 04,
    /// MiniMod manual, "Watchdog"). The bus owner reads it after every exchange; while it is
    /// set the module's outputs count as not written.
    fn wants_restart(&self) -> bool {
        false
    }

    /// Whether the module takes part in its line's FC 70 Collect round, as which unit and with
    /// which refresh periods ([`Membership`], `crate::line::collect`). A member's
    /// [`Driver::plan_read`] then holds only what it reads every cycle; the bus owner asks
    /// [`Driver::plan_refresh`] for the rest when a refresh is due, and hands every event of
    /// the module to [`Driver::on_reply`] as a [`Response::Collect`] under
    /// `crate::line::collect::EVENT_TAG`.
    fn collect_membership(&self) -> Option<Membership> {
        None
    }

    /// A Collect member's full refresh (its inputs and read-back, whatever the events said),
    /// planned after this cycle's [`Driver::plan_read`]; run on the first cycle, when a period
    /// of its [`Membership`] is up and after anything that may have lost an event. Never asked
    /// of a non-member.
    fn plan_refresh(&mut self, out: &mut Vec<Transaction>) {
        let _ = out;
    }

    /// Current values, indexed like the model's points; `None` until first read.
    fn values(&self) -> &[Option<Value>];

    /// The device's reply delay as configured (used for the line's budget).
    fn reply_delay(&self) -> Duration;

    /// The line's time now, told before each [`Driver::plan_read`] (a driver whose points
    /// have their own poll periods plans from it).
    fn advance_to(&mut self, now: LineInstant) {
        let _ = now;
    }

    /// How long the device may take to reply, when it needs other than its line's
    /// `response_timeout` (a device profile's `reply_timeout`).
    fn response_timeout(&self) -> Option<Duration> {
        None
    }

    /// The silence the device needs before a request to it, from the end of the last frame
    /// on a line at `settings`, when it needs more than the line's t3.5 (a device profile's
    /// `frame_gap`; a MiniMod's 28 bit times + RDELAYM, or it hears the request as the end of
    /// the traffic before it).
    fn frame_gap(&self, settings: LineSettings) -> Option<Duration> {
        let _ = settings;
        None
    }
}
