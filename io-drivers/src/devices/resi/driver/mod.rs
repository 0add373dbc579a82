//! The RESI driver, one for every model, over Modbus RTU or the RESI ASCII protocol (sans-IO).
//!
//! - **Start-up** ([`settings`]): command registers first (CLEAR ALL LOGIC FUNCTIONS, RESET
//!   COUNTER); on a module with internal logic (16DI8RO) the logic disarmed and every table
//!   cleared, then the relays' `initial_ROn` values (see `startup.rs` for the order and why);
//!   then every read-write setting, in address order (so ENABLE LOGIC FUNCTIONS,
//!   4x21001, comes after the masks and PULSE TIMEs it enables). Modbus: contiguous registers
//!   with one FC 16 (32-bit values in the block listed first, high word first for the
//!   16DI8RO), then one FC 3 to read them back. ASCII: the set command (`SSON1:15`), then its
//!   get command (`GSON1`). A read-back that differs stops the start ([`DecodeError::Mismatch`]).
//! - **Each cycle** ([`plan`]): the `poll` points in the fewest exchanges (16DI8RO by default:
//!   one FC 1 of DI1..DI16 and RO1..RO8, 8 + 8 bytes; ASCII `GDIS` and `GROS`).
//! - **Outputs**: written when the program's value differs from the last one written, and
//!   every output again when the bus asks for a refresh (except the model's one-shot outputs,
//!   8CO `PULSE_ROn`, which would restart their pulse). Modbus: runs of adjacent owned coils
//!   with one FC 5 / FC 15, registers with FC 6 / FC 16. ASCII: `SROS` when every relay is
//!   owned and written, otherwise one `SROx` each. A relay the module's own logic switches
//!   (16DI8RO) is best left unowned: an owned one is set back at the next change or refresh.
//! - 1RO with `SOFFDLY`: see [`settings`].
//!
//! Errors: an exception is [`DecodeError::Exception`]; an answer that does not fit the request
//! (other function, count, ASCII keyword or address) is [`DecodeError::Unexpected`]; silence is
//! the bus owner's timeout (the modules answer nothing to what they do not understand).
//!
//! Where the manual is silent the driver assumes as little as it can (the simulator's choices
//! are listed in [`super`]):
//! - it never polls or writes to address 0, and always sends its address, so an answer to a
//!   broadcast never happens (resi-spec §2.2, §7);
//! - ASCII: short command names only, decimal numbers, its address in decimal; `OK` is taken
//!   with or without the address; an unknown or malformed answer is an error, not a value;
//! - 32-bit values are written with one FC 16 over both words (the manual: "Writing a 32 bit
//!   value on both registers stores the new time", L21478), never half by half;
//! - FC 16 carries at most 123 registers (the manual allows 125, L1991; the standard 123);
//! - a module whose logic drives a relay should not have that relay bound to a program output:
//!   the driver would set it back at the next change or refresh, and the manual leaves open
//!   which of the two the module keeps (resi-spec §4.4).
//!
//! ## Registers the manual gives two ways
//!
//! What the driver writes where the manual (resi-spec.md's digest of it) says two things, the
//! reading chosen, and how start-up confirms it:
//!
//! | register | reading 1 | reading 2 | chosen | confirmed at start-up |
//! |---|---|---|---|---|
//! | ENABLE LOGIC FUNCTIONS (4x21001) | logic runs "Only if this register contains 1" (L22516) | the central-light example writes 0x8000 (L16615, erratum 3): any non-zero value | 1, which both readings run (the push-down writes 1 and refuses a project value other than 1 for a module it places logic in); 0 to disarm, which both stop | read back (FC 3 / `GSMODE`); the simulator's option `enable nonzero` serves reading 2 |
//! | CLEAR ALL LOGIC FUNCTIONS (4x21002) | "write the value 1" (10.1.1.2, L16504) | "Writing a value" (L22531) | the project's value, when it names the register (1 satisfies both); the start-up's own clear writes each table to 0 instead (its reach over PULSE TIME is open too, resi-spec §4.1) | each table read back 0 |
//! | PULSE TIME ROn (32 bits) | high word first, 4x20065+2(n−1) (L21469) | low word first, 4x20081+2(n−1) (L21566); the PULSE example's "4x20066" should be 20082 (erratum 2) | the high-word-first view, both words in one FC 16, as "Writing a 32 bit value on both registers" says | both words read back from the same view |
//! | PULSE example's relay | RO1 (prose start, the Modbus lines) | RO4 (prose end, the ASCII lines; erratum 1) | the register table: PULSE ROn = 4x20032+n | — (no example is written) |
//! | 8CO ROS | 4x00001 (L31474) | 4x00101 printed "I:0" (L31496, erratum 6) | 4x00001 (protocol address 0): ROS whichever the second entry's address is | the write's echo; RO1..RO8 are polled every cycle |
//! | SWITCH OFF | "sets the corresponding relay output to low (1)" (L19072, L21276) | low means 0 | 0 (erratum 5) | the relay's state, read every cycle |
//!
//! The coils RO1..RO8 and the other models' registers the driver writes (1RO DO1 and OFFDLY,
//! 8CO PULSE ROn) have one address each in the manual. The 1RO's `SOFFDLY` is in ms in both
//! places that give it (`SOFFDLY`, L4096–L4110; 4x00005 OFFDLY, L4291–L4295).

pub(crate) mod ascii;
pub(crate) mod plan;
pub(crate) mod settings;
mod startup;
mod write;

pub use startup::CLEARED as LOGIC_CLEARED_AT_STARTUP;

use std::time::Duration;

use plan::Read;
use settings::Setting;

use super::map::Entry;
use super::model::Model;
use super::value::Num;
use crate::devices::{DeviceConfig, ModuleSettings, Protocol, PushDown};
use crate::driver::{DecodeError, Driver, Outgoing, Reply, Transaction};
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

/// Builds a driver for `model` from a validated module entry: the module's own settings, then
/// what the push-down planner added ([`super::push_down::LogicTable::settings`]). A
/// configuration of another family (never built by project validation, which parses the
/// settings with this model) gives the model's defaults.
pub(crate) fn build(model: &'static Model, config: &DeviceConfig) -> Box<dyn Driver> {
    let own = match &config.settings {
        ModuleSettings::Resi(s) => s.clone(),
        _ => settings::Settings::default(),
    };
    let mut parsed = own.items().to_vec();
    if let PushDown::Resi(table) = &config.push_down {
        parsed.extend(table.settings(model, &own));
    }
    let d = ResiDriver::new(model, config.protocol, config.address.get(), &parsed);
    for p in &d.unreadable {
        if let Some(spec) = model.points.get(*p) {
            // A poll list is checked against the model, not the protocol: the one place
            // where a setting meets the protocol is here.
            let point = spec.name;
            tracing::error!(module = %config.name, point, "no ASCII command reads this point");
        }
    }
    Box::new(d)
}

/// What a transaction was for, carried in its tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tag {
    Read(usize),
    Write(usize),
    Setup(usize),
}

impl Tag {
    fn encode(self) -> u32 {
        let (kind, i) = match self {
            Tag::Read(i) => (1u32, i),
            Tag::Write(i) => (2, i),
            Tag::Setup(i) => (3, i),
        };
        (kind << 24) | (u32::try_from(i).unwrap_or(0xFF_FFFF) & 0xFF_FFFF)
    }

    fn decode(tag: u32) -> Option<Self> {
        let i = (tag & 0xFF_FFFF) as usize;
        Some(match tag >> 24 {
            1 => Tag::Read(i),
            2 => Tag::Write(i),
            3 => Tag::Setup(i),
            _ => return None,
        })
    }
}

/// How a start-up or write exchange is checked.
#[derive(Debug, Clone, PartialEq)]
enum Check {
    /// The write's echo (Modbus).
    Echo(Request),
    /// `OK` (ASCII).
    Ok,
    /// The registers read back hold these values at these offsets.
    Registers(Vec<(usize, Entry, Num)>),
    /// The coil read back holds this value.
    Bit(Entry, bool),
    /// The ASCII get answer holds this value at this position.
    Answer {
        command: &'static super::ascii::command::Command,
        x: u8,
        at: usize,
        entry: Entry,
        expected: Num,
    },
}

/// One exchange of the start-up or of a write phase.
#[derive(Debug, Clone, PartialEq)]
struct Step {
    frame: Outgoing,
    check: Check,
    /// Points whose value the exchange sets when it succeeds.
    sets: Vec<(usize, Value)>,
}

/// The RESI driver.
#[derive(Debug, Clone)]
pub(crate) struct ResiDriver {
    model: &'static Model,
    protocol: Protocol,
    address: u8,
    unit: Option<UnitId>,
    reads: Vec<Read>,
    unreadable: Vec<usize>,
    setup: Vec<Step>,
    writes: Vec<Step>,
    watchdog: Option<u16>,
    reply_delay: Duration,
    values: Vec<Option<Value>>,
    /// The last value written to each output.
    written: Vec<Option<Value>>,
}

impl ResiDriver {
    /// A driver for the module of `model` at `address`, speaking `protocol`.
    pub(crate) fn new(
        model: &'static Model,
        protocol: Protocol,
        address: u8,
        settings: &[Setting],
    ) -> Self {
        let mut poll = None;
        let mut reply_delay = Duration::from_millis(2);
        let mut watchdog = None;
        let mut writes = Vec::new();
        let mut initial = Vec::new();
        for s in settings {
            match s {
                Setting::Poll(points) => poll = Some(points.clone()),
                Setting::ReplyDelay(d) => reply_delay = *d,
                Setting::Watchdog(ms) => watchdog = Some(*ms),
                Setting::Initial { entry, on } => {
                    initial.retain(|(e, _): &(Entry, Num)| e.name != entry.name);
                    initial.push((*entry, Num::Int(i64::from(*on))));
                }
                Setting::Write { entry, value } => {
                    writes.retain(|(e, _): &(Entry, Num)| e.name != entry.name);
                    writes.push((*entry, *value));
                }
            }
        }
        let poll = poll.unwrap_or_else(|| settings::select(model, model.poll).unwrap_or_default());
        let (reads, unreadable) = match protocol {
            Protocol::Modbus => (plan::modbus(model, &poll), Vec::new()),
            Protocol::Text => plan::ascii(model, &poll),
        };
        let unit = UnitId::new(address);
        let mut d = Self {
            model,
            protocol,
            address,
            unit,
            reads,
            unreadable,
            setup: Vec::new(),
            writes: Vec::new(),
            watchdog,
            reply_delay,
            values: vec![None; model.points.len()],
            written: vec![None; model.points.len()],
        };
        d.setup = startup::steps(&d, &writes, &initial);
        d
    }

    /// Whether the driver can talk at all (a Modbus driver needs a unit address 1..=247).
    fn can_talk(&self) -> bool {
        self.protocol == Protocol::Text || self.unit.is_some()
    }

    fn modbus(&self, request: Request) -> Option<Outgoing> {
        self.unit.map(|unit| Outgoing::Modbus { unit, request })
    }

    fn set_value(&mut self, point: usize, n: Num) {
        let ty = self.model.points.get(point).map(|p| p.ty);
        if let (Some(slot), Some(ty)) = (self.values.get_mut(point), ty) {
            *slot = Some(n.to_value(ty));
        }
    }

    fn apply_read(&mut self, i: usize, reply: &Reply, tag: u32) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let read = self.reads.get(i).cloned().ok_or(unexpected)?;
        match (&read, reply) {
            (
                Read::Bits { count, targets, .. },
                Reply::Modbus(Response::ReadCoils(bits) | Response::ReadDiscreteInputs(bits)),
            ) if bits.len() == usize::from(*count) => {
                for t in targets {
                    let b = bits.get(t.at).copied().unwrap_or(false);
                    self.set_value(t.point, Num::Int(b.into()));
                }
                Ok(())
            }
            (
                Read::Regs { count, targets, .. },
                Reply::Modbus(Response::ReadHoldingRegisters(words)),
            ) if words.len() == usize::from(*count) => {
                for t in targets {
                    let w = words.get(t.at..t.at + usize::from(t.enc.words()));
                    if let Some(n) = w.and_then(|w| t.enc.decode(w)) {
                        self.set_value(t.point, n);
                    }
                }
                Ok(())
            }
            (
                Read::Ascii {
                    command,
                    x,
                    targets,
                },
                Reply::Text(text),
            ) => {
                let values = ascii::answer_values(text, self.address, command, *x)
                    .map_err(|_| unexpected)?;
                let decoded: Vec<(usize, Num)> = targets
                    .iter()
                    .map(|t| ascii::value(&values, t.at, t.part).map(|n| (t.point, n)))
                    .collect::<Option<_>>()
                    .ok_or(unexpected)?;
                for (p, n) in decoded {
                    self.set_value(p, n);
                }
                Ok(())
            }
            (_, Reply::Modbus(Response::Exception { code, .. })) => {
                Err(DecodeError::Exception(*code))
            }
            _ => Err(unexpected),
        }
    }

    fn check(&self, step: &Step, reply: &Reply, tag: u32) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let mismatch = |entry: &Entry, expected: Num, found: Num| DecodeError::Mismatch {
            register: entry.name,
            expected: u32::try_from(expected.int()).unwrap_or(u32::MAX),
            found: u32::try_from(found.int()).unwrap_or(u32::MAX),
        };
        if let Reply::Modbus(Response::Exception { code, .. }) = reply {
            return Err(DecodeError::Exception(*code));
        }
        match (&step.check, reply) {
            (Check::Echo(req), Reply::Modbus(resp)) => {
                write::echoes(req, resp).then_some(()).ok_or(unexpected)
            }
            (Check::Ok, Reply::Text(text)) => ascii::is_ok(text, self.address)
                .then_some(())
                .ok_or(unexpected),
            (Check::Registers(expected), Reply::Modbus(Response::ReadHoldingRegisters(words))) => {
                for (at, entry, want) in expected {
                    let got = words
                        .get(*at..*at + usize::from(entry.words()))
                        .and_then(|w| entry.enc.decode(w))
                        .ok_or(unexpected)?;
                    if entry.enc.encode(got) != entry.enc.encode(*want) {
                        return Err(mismatch(entry, *want, got));
                    }
                }
                Ok(())
            }
            (Check::Bit(entry, want), Reply::Modbus(Response::ReadCoils(bits))) => {
                let got = *bits.first().ok_or(unexpected)?;
                if got == *want {
                    Ok(())
                } else {
                    Err(mismatch(
                        entry,
                        Num::Int((*want).into()),
                        Num::Int(got.into()),
                    ))
                }
            }
            (
                Check::Answer {
                    command,
                    x,
                    at,
                    entry,
                    expected,
                },
                Reply::Text(text),
            ) => {
                let values = ascii::answer_values(text, self.address, command, *x)
                    .map_err(|_| unexpected)?;
                let got = ascii::value(&values, *at, None).ok_or(unexpected)?;
                if entry.enc.encode(got) == entry.enc.encode(*expected) {
                    Ok(())
                } else {
                    Err(mismatch(entry, *expected, got))
                }
            }
            _ => Err(unexpected),
        }
    }
}

impl Driver for ResiDriver {
    fn address(&self) -> u8 {
        self.address
    }

    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        if !self.can_talk() {
            return;
        }
        for (i, step) in self.setup.iter().enumerate() {
            out.push(Transaction {
                frame: step.frame.clone(),
                tag: Tag::Setup(i).encode(),
            });
        }
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        if !self.can_talk() {
            return;
        }
        for (i, read) in self.reads.iter().enumerate() {
            let frame = match read {
                Read::Bits {
                    addr,
                    count,
                    coils: true,
                    ..
                } => self.modbus(Request::ReadCoils {
                    addr: *addr,
                    count: *count,
                }),
                Read::Bits { addr, count, .. } => self.modbus(Request::ReadDiscreteInputs {
                    addr: *addr,
                    count: *count,
                }),
                Read::Regs { addr, count, .. } => self.modbus(Request::ReadHoldingRegisters {
                    addr: *addr,
                    count: *count,
                }),
                Read::Ascii { command, x, .. } => {
                    Some(ascii::request(self.address, command, *x, &[]))
                }
            };
            if let Some(frame) = frame {
                out.push(Transaction {
                    frame,
                    tag: Tag::Read(i).encode(),
                });
            }
        }
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        self.writes.clear();
        if !self.can_talk() {
            return;
        }
        self.writes = write::plan(self, desired, refresh);
        for (i, step) in self.writes.iter().enumerate() {
            out.push(Transaction {
                frame: step.frame.clone(),
                tag: Tag::Write(i).encode(),
            });
        }
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        match Tag::decode(tag) {
            Some(Tag::Read(i)) => self.apply_read(i, reply, tag),
            Some(Tag::Setup(i)) => {
                let step = self
                    .setup
                    .get(i)
                    .cloned()
                    .ok_or(DecodeError::Unexpected { tag })?;
                self.check(&step, reply, tag)
            }
            Some(Tag::Write(i)) => {
                let step = self
                    .writes
                    .get(i)
                    .cloned()
                    .ok_or(DecodeError::Unexpected { tag })?;
                self.check(&step, reply, tag)?;
                for (p, v) in step.sets {
                    if let Some(slot) = self.written.get_mut(p) {
                        *slot = Some(v);
                    }
                    if let Some(slot) = self.values.get_mut(p) {
                        *slot = Some(v);
                    }
                }
                Ok(())
            }
            None => Err(DecodeError::Unexpected { tag }),
        }
    }

    fn values(&self) -> &[Option<Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        self.reply_delay
    }
}

#[cfg(test)]
mod tests;
