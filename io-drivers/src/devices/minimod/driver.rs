//! The MiniMod driver (sans-IO), Modbus RTU or text protocol, polled or in event mode.
//!
//! ## Per cycle, Modbus (`protocol: modbus`, the default)
//!
//! - **Inputs**: one FC 2 read of discrete inputs 0..=9 (10001..10010): X1..X3 and X9/X10
//!   (= FB1/FB2). Request `uu 02 00 00 00 0A` + CRC, 8 bytes; reply `uu 02 02 b0 b1` + CRC,
//!   7 bytes. The alternative, FC 4 input register 0 (all 16 inputs as one word), is 8 + 7
//!   bytes too: an FC 2 reply is 6 bytes only when at most 8 bits are read, and X9/X10 are
//!   bits 8/9. With equal wire time, FC 2 is chosen because it reads exactly the points, by
//!   the manual's register table. XWORD is built from the same bits.
//! - **Outputs**: written on change, in one transaction per cycle at most, and never touching
//!   an output the program does not own (so its level stays what the module's AON/AOFF
//!   conditions make of it): FC 6 YWORD (holding register 0, 40001) when the program owns all
//!   of Y1..Y4; FC 5 on the coil (00001..00004) when one owned output is to be written; FC 22
//!   Mask Write on YWORD for two or three (10 + 10 bytes instead of 8 + 8). With `refresh`
//!   every owned output is written again. The echo is taken as the module's output state (the
//!   values of Y1..Y4 and YWORD). A failed write (an exception 04 while the module's watchdog
//!   fires included) is planned again (all owned outputs) next cycle; a refused one (exception
//!   04, text `Error`) also asks the bus owner to run the start-up again ([`restart`]).
//! - **Read-back** of Y1..Y4 (setting `readback`): FC 1 coils 0..=3. It shows what the
//!   module's own logic (AON/AOFF) did to the outputs; for an output the program owns, a
//!   difference is then written back at the next write phase. Coils 0..=3 and YWORD are the
//!   outputs' status ("Y1..Y4": "Shows the status of the indicated output"): a running pulse
//!   (YPULSEn) reads on, and off once it is over, whatever the output was before ("Pulse
//!   generation"); a blinker does not show in them. Writing back an owned output while its
//!   pulse runs does not cut the pulse (pulsers have priority, "Power outputs, blinkers,
//!   pulsers, and feedbacks").
//! - **Counters** (setting `counters`): FC 3 holding registers 11..=13 (XCOUNT1..3).
//! - **Status** (setting `status`): FC 2 discrete inputs 17..=129 (EVENTSPRS, GENERICFAIL,
//!   FLASHFAIL, WDTFB, WDTCOMM, SW3, SW4 in one 20-byte reply) and FC 1 coil 160 (WDTFIRED).
//!
//! ## Text protocol (`protocol: text`)
//!
//! The same points through the text protocol ("Text commands protocol"), always addressed
//! (`@5?XWORD` + CR, reply `XWORD=00003` + CR): inputs `?XWORD` (X1..X3 in bits 0..2, X9/X10 in
//! bits 8/9, as input register 0); outputs `>YWORD=n` when the program owns all four, else one
//! `>Yn=0|1` per changed output (the text protocol has no masked write), each answered `OK`;
//! read-back `?YWORD`; counters `?XCOUNT1..3`; status `?WFLAGS` (WDTFIRED only: bit 1 is the
//! only flag the manual documents). Start-up settings use text where the write table has the
//! identifier (and a condition can be written with input names), and are read back where the
//! read table has it (latencies, blinkers, WDTTIME, WDTMASK, FBENABLE); conditions are
//! write-only in text and counters count while read back, so their `OK` is their check. The
//! rest (XEVMASK, YEVMASK, EVFB1..2, a single WDTFB coil, conditions that need a raw mask) go
//! through Modbus, which the manual allows on the same line at the same time.
//!
//! ## Event mode (`events: true`)
//!
//! The inputs come from FC 70 Collect ("The Modbus function Collect"): after the status and
//! counter reads, the read plan holds a membership transaction
//! ([`crate::line::collect::membership`]) the bus owner turns into one broadcast Collect round
//! for every event-mode module of the line, and every event of this module comes back through
//! [`Driver::on_reply`] as a [`Response::Collect`]: TYPE 2 is the input
//! word (X1..X3, X9/X10), TYPE 1 the output levels (Y1..Y4 point values only: they include
//! pulsers and blinkers, so they never feed the write phase's comparison). After the
//! membership comes the full input read (FC 2, or `?XWORD`) and the read-back: the owner runs
//! them on the first cycle, every `event_refresh` (default 1 s), after a lost event, a failed
//! round or a failed cycle, so a lost event cannot leave the image wrong for long. At start-up
//! event mode writes XEVMASK = 7 and EVFB1 = EVFB2 = 1 unless the project sets them.
//!
//! ## Start-up settings
//!
//! See [`super::settings`]. Contiguous holding registers are written with one FC 16 and read
//! back with one FC 3; contiguous coils with FC 15 and FC 1; `RDELAYT` / `RDELAYM` are sent last
//! as text (`@5>RDELAYT=5`), whatever the protocol, since no register holds them. A read-back
//! difference is [`DecodeError::Mismatch`] with the register's name. When the project sets the
//! watchdog (WDTTIME, WDTYMASK, FBENABLE, WDTFB1..2), start-up also resets it (WDTFIRED = 0,
//! read back): a watchdog that fired when the last run stopped would otherwise keep the outputs
//! locked, and a feedback that fires it again at once stops the start, by name. Before any of
//! it, the start-up reads why the watchdog fired and logs it once ([`restart`]); the same
//! sequence runs when the module comes back after it was lost or refused a write, and every
//! output is then written again.
//!
//! The logic registers (AON/AOFF conditions, blinkers, pulsers) come last: all cleared and read
//! back, then the pushed-down outputs' initial values, then the settings' own tables (the
//! order and why: [`logic`]), so tables left by a run that crashed never drive the outputs
//! under this one.

use std::time::Duration;

use super::map::{self, Item, Space, POINTS};
use super::settings::{Readback, Setting, DEFAULT_EVENT_REFRESH};
use super::text::{self, TextId, TextReply, WriteValue};
use crate::devices::{DeviceConfig, Protocol};
use crate::driver::{DecodeError, Driver, Outgoing, Reply, Transaction};
use crate::line::collect;
use crate::modbus::{ExceptionCode, Request, Response, UnitId};
use crate::point::Value;

pub use super::settings::{check_setting, SettingError};

mod logic;
pub use logic::{CLEARED as LOGIC_CLEARED_AT_STARTUP, INITIAL_PREFIX};
mod restart;

/// Builds a driver from a validated module entry (the catalog's constructor). Settings were
/// checked before; one that still fails is logged and ignored. An address outside 1..=247
/// (refused by project validation) gives a driver that plans nothing.
pub fn build(config: &DeviceConfig) -> Box<dyn Driver> {
    let mut settings = Vec::with_capacity(config.settings.len());
    for (key, value) in &config.settings {
        // The push-down planner's `initial_Yn` (see `logic`).
        if let Some(s) = logic::initial_output(key, value) {
            settings.push(s);
            continue;
        }
        match Setting::parse(key, value) {
            Ok(s) => settings.push(s),
            Err(e) => tracing::error!(module = %config.name, key = %key, "ignored setting: {e}"),
        }
    }
    let unit = UnitId::new(config.address);
    if unit.is_none() {
        tracing::error!(module = %config.name, address = config.address, "not a unit address");
    }
    Box::new(MiniModDriver::with_protocol(
        unit,
        config.protocol,
        &settings,
    ))
}

/// Indexes in [`POINTS`] of what the driver reads every cycle.
const IDX_X: [usize; 3] = [0, 1, 2];
const IDX_X9: usize = 3;
const IDX_X10: usize = 4;
const IDX_FB1: usize = 5;
const IDX_FB2: usize = 6;
const IDX_Y: [usize; 4] = [7, 8, 9, 10];
const IDX_YWORD: usize = 11;

/// Discrete inputs of the status read: EVENTSPRS (10018) ..= SW4 (10130).
const DI_STATUS_FIRST: u16 = 17;
const DI_STATUS_COUNT: u16 = 113;
/// Coil WDTFIRED (00161).
const COIL_WDTFIRED: u16 = 160;
/// Holding register XCOUNT1 (40012).
const HR_XCOUNT1: u16 = 11;
/// Coils EVFB1..2 (00089).
const COIL_EVFB1: u16 = 88;
/// Holding register XEVMASK (40006).
const HR_XEVMASK: u16 = 5;

/// What a transaction was for, carried in its tag: a kind in the high half, an index in the
/// low half.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tag {
    Inputs,
    Readback,
    WriteOutputs,
    SetupWrite(u16),
    SetupVerify(u16),
    Counters,
    Counter(u16),
    Status,
    StatusFired,
    /// Text `>Yn=v`: index = y << 1 | v.
    WriteY(u16),
    /// Text `>YWORD=w`: index = w.
    WriteYword(u16),
    /// FC 6 command to a read-write holding register: index = its protocol address.
    WriteRegister(u16),
}

impl Tag {
    fn encode(self) -> u32 {
        let (kind, index) = match self {
            Tag::Inputs => (1, 0),
            Tag::Readback => (2, 0),
            Tag::WriteOutputs => (3, 0),
            Tag::SetupWrite(i) => (4, i),
            Tag::SetupVerify(i) => (5, i),
            Tag::Counters => (6, 0),
            Tag::Counter(i) => (7, i),
            Tag::Status => (8, 0),
            Tag::StatusFired => (9, 0),
            Tag::WriteY(i) => (10, i),
            Tag::WriteYword(w) => (11, w),
            Tag::WriteRegister(a) => (12, a),
        };
        (kind << 16) | u32::from(index)
    }

    fn decode(tag: u32) -> Option<Self> {
        let index = (tag & 0xFFFF) as u16;
        Some(match tag >> 16 {
            1 => Tag::Inputs,
            2 => Tag::Readback,
            3 => Tag::WriteOutputs,
            4 => Tag::SetupWrite(index),
            5 => Tag::SetupVerify(index),
            6 => Tag::Counters,
            7 => Tag::Counter(index),
            8 => Tag::Status,
            9 => Tag::StatusFired,
            10 => Tag::WriteY(index),
            11 => Tag::WriteYword(index),
            12 => Tag::WriteRegister(index),
            _ => return None,
        })
    }

    fn is_write(self) -> bool {
        matches!(
            self,
            Tag::WriteOutputs | Tag::WriteY(_) | Tag::WriteYword(_)
        )
    }
}

/// One start-up step: a write and, where possible, its read-back.
#[derive(Debug, Clone, PartialEq, Eq)]
enum SetupStep {
    /// Contiguous holding registers: FC 16, then FC 3.
    Registers {
        addr: u16,
        values: Vec<u16>,
        names: Vec<&'static str>,
    },
    /// Contiguous coils: FC 15, then FC 1.
    Coils {
        addr: u16,
        values: Vec<bool>,
        names: Vec<&'static str>,
    },
    /// A text write; read back with `?ID` when `verify`.
    Text {
        id: TextId,
        /// The register table's name (for errors and point values).
        name: &'static str,
        value: WriteValue,
        number: u16,
        verify: bool,
    },
}

/// The text identifier a start-up register has, if the text write table has one.
/// Compares a start-up read-back with what was written, register by register (or coil by
/// coil): `None` when the reply has another length, else the first mismatch as an error.
/// `skip` names the items whose value moves on its own and is not compared.
fn read_back<T: Copy + PartialEq + Into<u32>>(
    written: &[T],
    found: &[T],
    names: &[&'static str],
    skip: impl Fn(&str) -> bool,
) -> Option<Result<(), DecodeError>> {
    if found.len() != written.len() {
        return None;
    }
    let mismatch = written
        .iter()
        .zip(found)
        .zip(names)
        .filter(|(_, name)| !skip(name))
        .find(|((want, got), _)| want != got);
    Some(match mismatch {
        Some(((&expected, &found), &register)) => Err(DecodeError::Mismatch {
            register,
            expected: expected.into(),
            found: found.into(),
        }),
        None => Ok(()),
    })
}

fn text_id(item: Item) -> Option<TextId> {
    Some(match item {
        Item::XlatUp(i) => TextId::XlatUp(i),
        Item::XlatDn(i) => TextId::XlatDn(i),
        Item::Xcount(i) => TextId::Xcount(i),
        Item::Lamp(i) => TextId::Lamp(i),
        Item::AutoOn(y, c) => TextId::AutoOn(y, c),
        Item::AutoOff(y, c) => TextId::AutoOff(y, c),
        Item::WdtTime => TextId::WdtTime,
        Item::WdtYMask => TextId::WdtMask,
        _ => return None,
    })
}

/// `(addr, value, name)` by address, the last of duplicates winning.
fn dedup<T: Copy>(items: Vec<(u16, T, &'static str)>) -> Vec<(u16, T, &'static str)> {
    let mut unique: Vec<(u16, T, &'static str)> = Vec::with_capacity(items.len());
    for item in items {
        unique.retain(|u| u.0 != item.0);
        unique.push(item);
    }
    unique.sort_by_key(|u| u.0);
    unique
}

/// Groups `(addr, value, name)` by address (the last of duplicates wins) into runs of
/// consecutive addresses.
fn runs<T: Copy>(items: Vec<(u16, T, &'static str)>) -> Vec<(u16, Vec<T>, Vec<&'static str>)> {
    let mut out: Vec<(u16, Vec<T>, Vec<&'static str>)> = Vec::new();
    for (addr, value, name) in dedup(items) {
        match out.last_mut() {
            Some((start, values, names))
                if usize::from(*start) + values.len() == usize::from(addr) =>
            {
                values.push(value);
                names.push(name);
            }
            _ => out.push((addr, vec![value], vec![name])),
        }
    }
    out
}

/// The name of a coil in the map.
fn coil_name(addr: u16) -> &'static str {
    map::MAP
        .iter()
        .find(|e| e.space == Space::Coil && e.addr == addr)
        .map_or("coil", |e| e.name)
}

/// Builds the start-up steps from the settings.
fn setup_steps(settings: &[Setting], protocol: Protocol, events: bool) -> Vec<SetupStep> {
    let mut registers: Vec<(u16, u16, &'static str)> = Vec::new();
    let mut coils: Vec<(u16, bool, &'static str)> = Vec::new();
    let mut delays: Vec<(TextId, u8)> = Vec::new();
    for s in settings {
        match *s {
            Setting::Register { name, addr, value } => registers.push((addr, value, name)),
            Setting::Coils {
                addr, count, bits, ..
            } => {
                for i in 0..u16::from(count) {
                    let a = addr + i;
                    coils.push((a, bits & (1 << i) != 0, coil_name(a)));
                }
            }
            Setting::ReplyDelay(n) => delays.push((TextId::RdelayT, n)),
            Setting::FrameTimeout(n) => delays.push((TextId::RdelayM, n)),
            _ => {}
        }
    }
    let watchdog = registers
        .iter()
        .any(|r| matches!(r.2, "WDTTIME" | "WDTYMASK"))
        || coils.iter().any(|c| (112..=113).contains(&c.0));
    if watchdog {
        // The project owns the watchdog: a fired one left by the last run is reset once the
        // new settings are in, so the timeout starts from this start-up.
        coils.push((COIL_WDTFIRED, false, "WDTFIRED"));
    }
    if events {
        // Event mode needs the module to record input variations: X1..X3 and FB1/FB2.
        if !registers.iter().any(|r| r.0 == HR_XEVMASK) {
            registers.insert(0, (HR_XEVMASK, 0b111, "XEVMASK"));
        }
        for a in [COIL_EVFB1, COIL_EVFB1 + 1] {
            if !coils.iter().any(|c| c.0 == a) {
                coils.insert(0, (a, true, coil_name(a)));
            }
        }
    }
    // Logic tables and the pushed-down outputs' initial values: a sequence of their own, after
    // the watchdog reset (see `logic`).
    let logic = logic::split(&mut registers, &mut coils);
    let mut steps = Vec::new();
    if protocol == Protocol::Text {
        let mut modbus_registers = Vec::new();
        for (addr, value, name) in dedup(registers) {
            let id = map::entry(name).and_then(|e| text_id(e.item));
            let wv = match id {
                Some(TextId::AutoOn(..) | TextId::AutoOff(..)) => WriteValue::Condition(value),
                _ => WriteValue::Number(value),
            };
            match id {
                Some(id) if text::write_command(1, id, wv).is_ok() => steps.push(SetupStep::Text {
                    id,
                    name,
                    value: wv,
                    number: value,
                    verify: id.readable() && !matches!(id, TextId::Xcount(_)),
                }),
                _ => modbus_registers.push((addr, value, name)),
            }
        }
        registers = modbus_registers;
        let wdtfb = |a: u16| coils.iter().rev().find(|c| c.0 == a).map(|c| c.1);
        if let (Some(fb1), Some(fb2)) = (wdtfb(112), wdtfb(113)) {
            coils.retain(|c| c.0 != 112 && c.0 != 113);
            let bits = u16::from(fb1) | (u16::from(fb2) << 1);
            steps.push(SetupStep::Text {
                id: TextId::FbEnable,
                name: "FBENABLE",
                value: WriteValue::Number(bits),
                number: bits,
                verify: true,
            });
        }
    }
    for (addr, values, names) in runs(registers) {
        steps.push(SetupStep::Registers {
            addr,
            values,
            names,
        });
    }
    for (addr, values, names) in runs(coils) {
        steps.push(SetupStep::Coils {
            addr,
            values,
            names,
        });
    }
    steps.extend(logic);
    for (id, n) in delays {
        let name = if id == TextId::RdelayT {
            "RDELAYT"
        } else {
            "RDELAYM"
        };
        steps.push(SetupStep::Text {
            id,
            name,
            value: WriteValue::Number(u16::from(n)),
            number: u16::from(n),
            verify: false,
        });
    }
    steps
}

/// The MiniMod driver.
#[derive(Debug, Clone)]
pub struct MiniModDriver {
    unit: Option<UnitId>,
    protocol: Protocol,
    readback: Readback,
    counters: Readback,
    status: Readback,
    events: bool,
    event_refresh: Duration,
    rdelayt: u8,
    rdelaym: u8,
    setup: Vec<SetupStep>,
    values: Vec<Option<Value>>,
    /// The module's commanded outputs as far as known (echo or read-back).
    y: [Option<bool>; 4],
    /// A write failed: write every owned output at the next write phase.
    rewrite: bool,
    cycle: u64,
    /// Refused writes, restarts and the watchdog's status at start-up (see `restart`).
    restart: restart::Restart,
}

impl MiniModDriver {
    /// A Modbus driver for the module at `unit` (`None`: plans nothing) with validated
    /// settings.
    pub fn new(unit: Option<UnitId>, settings: &[Setting]) -> Self {
        Self::with_protocol(unit, Protocol::Modbus, settings)
    }

    /// A driver speaking `protocol`.
    pub fn with_protocol(unit: Option<UnitId>, protocol: Protocol, settings: &[Setting]) -> Self {
        let mut d = Self {
            unit,
            protocol,
            readback: Readback::Off,
            counters: Readback::Off,
            status: Readback::Off,
            events: false,
            event_refresh: DEFAULT_EVENT_REFRESH,
            rdelayt: super::state::POWER_ON_RDELAYT,
            rdelaym: 0,
            setup: Vec::new(),
            values: vec![None; POINTS.len()],
            y: [None; 4],
            rewrite: false,
            cycle: 0,
            restart: restart::Restart::default(),
        };
        for s in settings {
            match *s {
                Setting::Readback(r) => d.readback = r,
                Setting::Counters(r) => d.counters = r,
                Setting::Status(r) => d.status = r,
                Setting::Events(on) => d.events = on,
                Setting::EventRefresh(t) => d.event_refresh = t,
                Setting::ReplyDelay(n) => d.rdelayt = n,
                Setting::FrameTimeout(n) => d.rdelaym = n,
                Setting::Register { .. } | Setting::Coils { .. } => {}
            }
        }
        d.setup = setup_steps(settings, protocol, d.events);
        d
    }

    /// Whether the driver runs in event mode.
    pub fn event_mode(&self) -> bool {
        self.events
    }

    fn modbus(&self, unit: UnitId, request: Request, tag: Tag) -> Transaction {
        Transaction {
            frame: Outgoing::Modbus { unit, request },
            tag: tag.encode(),
        }
    }

    fn text_tx(line: Vec<u8>, tag: Tag) -> Transaction {
        Transaction {
            frame: Outgoing::Text {
                line,
                terminator: text::TERMINATOR,
            },
            tag: tag.encode(),
        }
    }

    fn read_tx(&self, unit: UnitId, id: TextId, tag: Tag) -> Transaction {
        Self::text_tx(text::read_command(unit.get(), id), tag)
    }

    fn set_value(&mut self, index: usize, value: Value) {
        if let Some(slot) = self.values.get_mut(index) {
            *slot = Some(value);
        }
    }

    fn set_named(&mut self, name: &str, value: Value) {
        if let Some(i) = map::point_index(name) {
            self.set_value(i, value);
        }
    }

    fn set_y(&mut self, y: usize, on: bool) {
        if let Some(slot) = self.y.get_mut(y) {
            *slot = Some(on);
        }
        if let Some(&i) = IDX_Y.get(y) {
            self.set_value(i, Value::Bool(on));
        }
        if let Some(word) = self
            .y
            .iter()
            .enumerate()
            .try_fold(0u16, |acc, (i, b)| b.map(|on| acc | (u16::from(on) << i)))
        {
            self.set_value(IDX_YWORD, Value::U16(word));
        }
    }

    fn set_yword(&mut self, word: u16) {
        for y in 0..4 {
            self.set_y(y, word & (1 << y) != 0);
        }
    }

    /// The inputs as input register 0 / XWORD / a TYPE 2 event carry them.
    fn apply_input_word(&mut self, word: u16) {
        for (x, &i) in IDX_X.iter().enumerate() {
            self.set_value(i, Value::Bool(word & (1 << x) != 0));
        }
        let (x9, x10) = (word & (1 << 8) != 0, word & (1 << 9) != 0);
        self.set_value(IDX_X9, Value::Bool(x9));
        self.set_value(IDX_FB1, Value::Bool(x9));
        self.set_value(IDX_X10, Value::Bool(x10));
        self.set_value(IDX_FB2, Value::Bool(x10));
        self.set_named("XWORD", Value::U16(word & 0x0307));
    }

    fn apply_inputs(&mut self, tag: u32, bits: &[bool]) -> Result<(), DecodeError> {
        if bits.len() != usize::from(map::DI_READ_COUNT) {
            return Err(DecodeError::Unexpected { tag });
        }
        let word = bits
            .iter()
            .enumerate()
            .fold(0u16, |acc, (i, &b)| acc | (u16::from(b) << i));
        self.apply_input_word(word);
        Ok(())
    }

    fn apply_status(&mut self, tag: u32, bits: &[bool]) -> Result<(), DecodeError> {
        if bits.len() != usize::from(DI_STATUS_COUNT) {
            return Err(DecodeError::Unexpected { tag });
        }
        for (name, addr) in [
            ("EVENTSPRS", 17u16),
            ("GENERICFAIL", 19),
            ("FLASHFAIL", 22),
            ("WDTFB", 24),
            ("WDTCOMM", 25),
            ("SW3", 128),
            ("SW4", 129),
        ] {
            let bit = bits
                .get(usize::from(addr - DI_STATUS_FIRST))
                .copied()
                .unwrap_or(false);
            self.set_named(name, Value::Bool(bit));
        }
        Ok(())
    }

    /// An event from the Collect round.
    fn apply_event(&mut self, tag: u32, kind: u8, data: u16) -> Result<(), DecodeError> {
        match kind {
            super::events::KIND_INPUTS => self.apply_input_word(data),
            super::events::KIND_OUTPUTS => {
                for (y, &i) in IDX_Y.iter().enumerate() {
                    self.set_value(i, Value::Bool(data & (1 << y) != 0));
                }
            }
            _ => return Err(DecodeError::Unexpected { tag }),
        }
        Ok(())
    }

    /// Values of start-up registers once verified.
    fn record_setup(&mut self, step: usize) {
        let Some(step) = self.setup.get(step).cloned() else {
            return;
        };
        match step {
            SetupStep::Registers { values, names, .. } => {
                for (v, n) in values.into_iter().zip(names) {
                    self.set_named(n, Value::U16(v));
                }
            }
            SetupStep::Coils { values, names, .. } => {
                for (v, n) in values.into_iter().zip(names) {
                    self.set_named(n, Value::Bool(v));
                }
            }
            SetupStep::Text { name, number, .. } => {
                if let Some(i) = map::point_index(name) {
                    let value = match POINTS[i].ty {
                        crate::point::ValueType::Bool => Value::Bool(number != 0),
                        _ => Value::U16(number),
                    };
                    self.set_value(i, value);
                } else if name == "FBENABLE" {
                    self.set_named("WDTFB1", Value::Bool(number & 1 != 0));
                    self.set_named("WDTFB2", Value::Bool(number & 2 != 0));
                }
            }
        }
    }

    fn plan_startup_step(
        &self,
        unit: UnitId,
        i: u16,
        step: &SetupStep,
        out: &mut Vec<Transaction>,
    ) {
        match step {
            SetupStep::Registers { addr, values, .. } => {
                let request = Request::WriteMultipleRegisters {
                    addr: *addr,
                    values: values.clone(),
                };
                out.push(self.modbus(unit, request, Tag::SetupWrite(i)));
                let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
                let request = Request::ReadHoldingRegisters { addr: *addr, count };
                out.push(self.modbus(unit, request, Tag::SetupVerify(i)));
            }
            SetupStep::Coils { addr, values, .. } => {
                let request = Request::WriteMultipleCoils {
                    addr: *addr,
                    values: values.clone(),
                };
                out.push(self.modbus(unit, request, Tag::SetupWrite(i)));
                let count = u16::try_from(values.len()).unwrap_or(u16::MAX);
                let request = Request::ReadCoils { addr: *addr, count };
                out.push(self.modbus(unit, request, Tag::SetupVerify(i)));
            }
            SetupStep::Text {
                id, value, verify, ..
            } => {
                // Steps are built only from values the text protocol can carry.
                if let Ok(line) = text::write_command(unit.get(), *id, *value) {
                    out.push(Self::text_tx(line, Tag::SetupWrite(i)));
                }
                if *verify {
                    out.push(self.read_tx(unit, *id, Tag::SetupVerify(i)));
                }
            }
        }
    }

    fn on_modbus(&mut self, tag: u32, response: &Response) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        match (Tag::decode(tag), response) {
            (Some(Tag::Inputs), Response::ReadDiscreteInputs(bits)) => self.apply_inputs(tag, bits),
            (Some(Tag::Readback), Response::ReadCoils(bits)) if bits.len() == 4 => {
                for (y, &on) in bits.iter().enumerate() {
                    self.set_y(y, on);
                }
                Ok(())
            }
            (Some(Tag::Counters), Response::ReadHoldingRegisters(regs)) if regs.len() == 3 => {
                for (i, &v) in regs.iter().enumerate() {
                    self.set_named(["XCOUNT1", "XCOUNT2", "XCOUNT3"][i], Value::U16(v));
                }
                Ok(())
            }
            (Some(Tag::Status), Response::ReadDiscreteInputs(bits)) => self.apply_status(tag, bits),
            (Some(Tag::StatusFired), Response::ReadCoils(bits)) if bits.len() == 1 => {
                self.set_named("WDTFIRED", Value::Bool(bits[0]));
                Ok(())
            }
            (Some(Tag::WriteRegister(a)), Response::WriteSingleRegister { addr, value })
                if *addr == a =>
            {
                if let Some(e) = map::MAP
                    .iter()
                    .find(|e| e.space == Space::HoldingRegister && e.addr == a)
                {
                    self.set_named(e.name, Value::U16(*value));
                }
                Ok(())
            }
            (Some(Tag::WriteOutputs), Response::WriteSingleRegister { addr, value })
                if *addr == map::HR_YWORD =>
            {
                self.set_yword(*value);
                self.rewrite = false;
                Ok(())
            }
            (Some(Tag::WriteOutputs), Response::WriteSingleCoil { addr, value })
                if (map::COIL_Y1..map::COIL_Y1 + 4).contains(addr) =>
            {
                self.set_y(usize::from(addr - map::COIL_Y1), *value);
                self.rewrite = false;
                Ok(())
            }
            (
                Some(Tag::WriteOutputs),
                Response::MaskWriteRegister {
                    addr,
                    and_mask,
                    or_mask,
                },
            ) if *addr == map::HR_YWORD => {
                for y in 0..4 {
                    if and_mask & (1 << y) == 0 {
                        self.set_y(y, or_mask & (1 << y) != 0);
                    }
                }
                self.rewrite = false;
                Ok(())
            }
            (Some(Tag::SetupWrite(i)), Response::WriteMultipleRegisters { addr, count }) => {
                match self.setup.get(usize::from(i)) {
                    Some(SetupStep::Registers {
                        addr: a, values, ..
                    }) if a == addr && usize::from(*count) == values.len() => Ok(()),
                    _ => Err(unexpected),
                }
            }
            (Some(Tag::SetupWrite(i)), Response::WriteMultipleCoils { addr, count }) => {
                match self.setup.get(usize::from(i)) {
                    Some(SetupStep::Coils {
                        addr: a, values, ..
                    }) if a == addr && usize::from(*count) == values.len() => Ok(()),
                    _ => Err(unexpected),
                }
            }
            (Some(Tag::SetupVerify(i)), Response::ReadHoldingRegisters(found)) => {
                let Some(SetupStep::Registers { values, names, .. }) =
                    self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                // A counter counts while it is read back: its write echo is its check.
                read_back(values, found, names, |name| name.starts_with("XCOUNT"))
                    .ok_or(unexpected)??;
                self.record_setup(usize::from(i));
                Ok(())
            }
            (Some(Tag::SetupVerify(i)), Response::ReadCoils(found)) => {
                let Some(SetupStep::Coils { values, names, .. }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                read_back(values, found, names, |_| false).ok_or(unexpected)??;
                self.record_setup(usize::from(i));
                Ok(())
            }
            _ => Err(unexpected),
        }
    }

    fn on_text(&mut self, tag: u32, bytes: &[u8]) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let reply = text::parse_reply(bytes).map_err(|_| unexpected.clone())?;
        match (Tag::decode(tag), reply) {
            (Some(Tag::Inputs), TextReply::Value(TextId::Xword, w)) => {
                self.apply_input_word(w);
                Ok(())
            }
            (Some(Tag::Readback), TextReply::Value(TextId::Yword, w)) => {
                self.set_yword(w);
                Ok(())
            }
            (Some(Tag::Counter(i)), TextReply::Value(TextId::Xcount(c), v))
                if u16::from(c) == i =>
            {
                self.set_named(
                    ["XCOUNT1", "XCOUNT2", "XCOUNT3"][usize::from(c.min(2))],
                    Value::U16(v),
                );
                Ok(())
            }
            (Some(Tag::Status), TextReply::Value(TextId::Wflags, v)) => {
                self.set_named(
                    "WDTFIRED",
                    Value::Bool(v & super::watchdog::WFLAGS_FIRED != 0),
                );
                Ok(())
            }
            (Some(Tag::WriteY(i)), TextReply::Ok) => {
                self.set_y(usize::from(i >> 1), i & 1 != 0);
                self.rewrite = false;
                Ok(())
            }
            (Some(Tag::WriteYword(w)), TextReply::Ok) => {
                self.set_yword(w);
                self.rewrite = false;
                Ok(())
            }
            // The text protocol's "no" to an output write: what Modbus says with exception 04
            // (a fired watchdog, see `restart`).
            (Some(t), TextReply::Error) if t.is_write() => {
                Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
            }
            (Some(Tag::SetupWrite(i)), answer) => {
                let Some(SetupStep::Text { name, verify, .. }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                match answer {
                    TextReply::Ok => {
                        if !verify {
                            self.record_setup(usize::from(i));
                        }
                        Ok(())
                    }
                    // A refused write that is read back shows as a mismatch there, by name.
                    TextReply::Error if *verify => Ok(()),
                    TextReply::Error => {
                        tracing::error!(register = *name, "the module refused the setting");
                        Err(DecodeError::Exception(ExceptionCode::IllegalDataValue))
                    }
                    _ => Err(unexpected),
                }
            }
            (Some(Tag::SetupVerify(i)), TextReply::Value(id, found)) => {
                let Some(SetupStep::Text {
                    id: want_id,
                    name,
                    number,
                    ..
                }) = self.setup.get(usize::from(i))
                else {
                    return Err(unexpected);
                };
                if id != *want_id {
                    return Err(unexpected);
                }
                if found != *number {
                    return Err(DecodeError::Mismatch {
                        register: name,
                        expected: u32::from(*number),
                        found: u32::from(found),
                    });
                }
                self.record_setup(usize::from(i));
                Ok(())
            }
            _ => Err(unexpected),
        }
    }
}

impl Driver for MiniModDriver {
    fn address(&self) -> u8 {
        self.unit.map_or(0, UnitId::get)
    }

    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        // Why the watchdog fired, before the settings reset it (see `restart`).
        self.plan_watchdog_status(unit, out);
        for (i, step) in self.setup.iter().enumerate() {
            let Ok(i) = u16::try_from(i) else { break };
            self.plan_startup_step(unit, i, step, out);
        }
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        let cycle = self.cycle;
        self.cycle = self.cycle.wrapping_add(1);
        let text = self.protocol == Protocol::Text;
        if self.status.due(cycle) {
            if text {
                out.push(self.read_tx(unit, TextId::Wflags, Tag::Status));
            } else {
                let request = Request::ReadDiscreteInputs {
                    addr: DI_STATUS_FIRST,
                    count: DI_STATUS_COUNT,
                };
                out.push(self.modbus(unit, request, Tag::Status));
                let request = Request::ReadCoils {
                    addr: COIL_WDTFIRED,
                    count: 1,
                };
                out.push(self.modbus(unit, request, Tag::StatusFired));
            }
        }
        if self.counters.due(cycle) {
            if text {
                for c in 0..3u8 {
                    out.push(self.read_tx(unit, TextId::Xcount(c), Tag::Counter(u16::from(c))));
                }
            } else {
                let request = Request::ReadHoldingRegisters {
                    addr: HR_XCOUNT1,
                    count: 3,
                };
                out.push(self.modbus(unit, request, Tag::Counters));
            }
        }
        // Event mode: what follows the membership is the full refresh, run when the bus
        // owner's Collect round says so.
        if self.events {
            out.push(collect::membership(unit, self.event_refresh));
        }
        if text {
            out.push(self.read_tx(unit, TextId::Xword, Tag::Inputs));
        } else {
            let request = Request::ReadDiscreteInputs {
                addr: map::DI_X1,
                count: map::DI_READ_COUNT,
            };
            out.push(self.modbus(unit, request, Tag::Inputs));
        }
        if self.readback.due(cycle) {
            if text {
                out.push(self.read_tx(unit, TextId::Yword, Tag::Readback));
            } else {
                let request = Request::ReadCoils {
                    addr: map::COIL_Y1,
                    count: 4,
                };
                out.push(self.modbus(unit, request, Tag::Readback));
            }
        }
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        // Read-write holding registers (pulsers YPULSEn, blinkers, conditions, ...): a `Some`
        // is a command, written once with FC 6 whatever the protocol (the manual allows Modbus
        // beside the text protocol), before the outputs. The scan sets it for one cycle (a
        // pulser started by a push-down trigger, tables cleared at stop).
        for (i, spec) in POINTS.iter().enumerate() {
            let Some(Some(v)) = desired.get(i) else {
                continue;
            };
            let Some(e) = map::entry(spec.name).filter(|e| {
                e.space == Space::HoldingRegister && spec.access == crate::point::Access::ReadWrite
            }) else {
                continue;
            };
            let value = match *v {
                Value::U16(n) => n,
                Value::I32(n) => u16::try_from(n).unwrap_or(0),
                other => u16::from(other.as_bool()),
            };
            let request = Request::WriteSingleRegister {
                addr: e.addr,
                value,
            };
            out.push(self.modbus(unit, request, Tag::WriteRegister(e.addr)));
        }
        let all = refresh || self.rewrite;
        let (mut owned, mut write, mut word) = (0u16, 0u16, 0u16);
        for (y, &i) in IDX_Y.iter().enumerate() {
            if let Some(Some(v)) = desired.get(i) {
                let on = v.as_bool();
                owned |= 1 << y;
                word |= u16::from(on) << y;
                if all || self.y.get(y).copied().flatten() != Some(on) {
                    write |= 1 << y;
                }
            }
        }
        if write == 0 {
            return;
        }
        if self.protocol == Protocol::Text {
            if owned == 0x0F {
                let value = WriteValue::Number(word);
                if let Ok(line) = text::write_command(unit.get(), TextId::Yword, value) {
                    out.push(Self::text_tx(line, Tag::WriteYword(word)));
                }
                return;
            }
            for y in (0..4u8).filter(|y| write & (1 << y) != 0) {
                let on = word & (1 << y) != 0;
                let value = WriteValue::Number(u16::from(on));
                if let Ok(line) = text::write_command(unit.get(), TextId::Y(y), value) {
                    let index = (u16::from(y) << 1) | u16::from(on);
                    out.push(Self::text_tx(line, Tag::WriteY(index)));
                }
            }
            return;
        }
        let request = if owned == 0x0F {
            Request::WriteSingleRegister {
                addr: map::HR_YWORD,
                value: word,
            }
        } else if write.count_ones() == 1 {
            let y = write.trailing_zeros() as u16;
            Request::WriteSingleCoil {
                addr: map::COIL_Y1 + y,
                value: word & write != 0,
            }
        } else {
            Request::MaskWriteRegister {
                addr: map::HR_YWORD,
                and_mask: !write,
                or_mask: word & write,
            }
        };
        out.push(self.modbus(unit, request, Tag::WriteOutputs));
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        if let Some(result) = self.on_watchdog_reply(tag, reply) {
            return result;
        }
        let result = match reply {
            Reply::Modbus(Response::Exception { code, .. }) => Err(DecodeError::Exception(*code)),
            // Events come back under the membership's tag.
            Reply::Modbus(Response::Collect { kind, data, .. }) => {
                self.apply_event(tag, *kind, *data)
            }
            Reply::Modbus(response) => self.on_modbus(tag, response),
            Reply::Text(bytes) => self.on_text(tag, bytes),
        };
        self.after_reply(tag, &result);
        result
    }

    fn on_restart(&mut self) {
        self.restart_now();
    }

    fn wants_restart(&self) -> bool {
        self.restart.wants()
    }

    fn on_failure(&mut self, tag: u32) {
        if Tag::decode(tag).is_some_and(Tag::is_write) {
            self.rewrite = true;
        }
    }

    fn values(&self) -> &[Option<Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        Duration::from_millis(10 * u64::from(self.rdelayt))
            + Duration::from_micros(100 * u64::from(self.rdelaym))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modbus::crc::append_crc;
    use crate::modbus::master::{encode_request, Progress, ReplyAssembler};
    use crate::sim::SimDevice;

    use super::super::sim::MiniModSim;

    const UNIT: u8 = 5;

    fn unit() -> UnitId {
        UnitId::new(UNIT).unwrap()
    }

    fn driver(settings: &[(&str, &str)]) -> MiniModDriver {
        let settings: Vec<Setting> = settings
            .iter()
            .map(|(k, v)| Setting::parse(k, v).unwrap())
            .collect();
        MiniModDriver::new(Some(unit()), &settings)
    }

    fn frame(bytes: &[u8]) -> Vec<u8> {
        let mut f = bytes.to_vec();
        append_crc(&mut f);
        f
    }

    fn wire(tx: &Transaction) -> Vec<u8> {
        let Outgoing::Modbus { unit, request } = &tx.frame else {
            panic!("not modbus")
        };
        let mut out = Vec::new();
        encode_request(unit.get(), request, &mut out).unwrap();
        out
    }

    /// Runs a transaction against the simulator at time `t`, as a bus owner would.
    fn exchange(
        d: &mut MiniModDriver,
        sim: &mut MiniModSim,
        tx: &Transaction,
        t: Duration,
    ) -> Result<(), DecodeError> {
        let (unit, request) = match &tx.frame {
            Outgoing::Modbus { unit, request } => (unit, request),
            Outgoing::Text { line, terminator } => {
                let reply = sim.on_frame(line, t).expect("a text reply");
                let end = reply.bytes.iter().position(|b| b == terminator).unwrap();
                return d.on_reply(tx.tag, &Reply::Text(reply.bytes[..end].to_vec()));
            }
            Outgoing::NoReply { .. } => panic!("the MiniMod driver plans no unanswered frame"),
        };
        let reply = sim.on_frame(&wire(tx), t).expect("a reply");
        let mut asm = ReplyAssembler::new(unit.get(), request);
        let Progress::Complete { response, extra: 0 } = asm.push(&reply.bytes) else {
            panic!("reply not verified: {:?}", reply.bytes)
        };
        d.on_reply(tx.tag, &Reply::Modbus(response))
    }

    fn value(d: &MiniModDriver, name: &str) -> Option<Value> {
        map::point_index(name).and_then(|i| d.values()[i])
    }

    fn desired(outputs: &[(&str, bool)]) -> Vec<Option<Value>> {
        let mut v = vec![None; POINTS.len()];
        for (name, on) in outputs {
            v[map::point_index(name).unwrap()] = Some(Value::Bool(*on));
        }
        v
    }

    #[test]
    fn point_indexes_match_the_table() {
        for (name, i) in [
            ("X1", IDX_X[0]),
            ("X3", IDX_X[2]),
            ("X9", IDX_X9),
            ("X10", IDX_X10),
        ] {
            assert_eq!(map::point_index(name), Some(i));
        }
        assert_eq!(map::point_index("FB1"), Some(IDX_FB1));
        assert_eq!(map::point_index("FB2"), Some(IDX_FB2));
        assert_eq!(map::point_index("Y1"), Some(IDX_Y[0]));
        assert_eq!(map::point_index("Y4"), Some(IDX_Y[3]));
        assert_eq!(map::point_index("YWORD"), Some(IDX_YWORD));
    }

    #[test]
    fn read_plan_is_one_fc2_byte_exact() {
        let mut d = driver(&[]);
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(plan.len(), 1);
        assert_eq!(wire(&plan[0]), frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]));
        assert_eq!(
            wire(&plan[0]),
            [0x05, 0x02, 0x00, 0x00, 0x00, 0x0A, 0xF9, 0x89]
        );
    }

    #[test]
    fn reads_inputs_from_the_simulator() {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X1", Value::Bool(true)).unwrap();
        sim.set("X3", Value::Bool(true)).unwrap();
        sim.command(&["fault", "Y4", "open"]).unwrap();
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(value(&d, "X1"), None, "nothing before the first read");
        exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(20)).unwrap();
        assert_eq!(value(&d, "X1"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "X2"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "X3"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "X9"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "X10"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "FB2"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "Y1"), None, "no read-back by default");
        assert_eq!(value(&d, "XCOUNT1"), None);
    }

    #[test]
    fn writes_yword_on_change_only_and_records_the_echo() {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        let want = desired(&[("Y1", true), ("Y2", false), ("Y3", true), ("Y4", false)]);
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(plan.len(), 1);
        assert_eq!(wire(&plan[0]), frame(&[0x05, 0x06, 0x00, 0x00, 0x00, 0x05]));
        exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
        assert_eq!(value(&d, "Y1"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "YWORD"), Some(Value::U16(5)));
        assert_eq!(sim.get("Y3"), Ok(Value::Bool(true)));
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert!(plan.is_empty(), "no change, no write");
        d.plan_write(&want, true, &mut plan);
        assert_eq!(plan.len(), 1, "refresh writes again");
    }

    #[test]
    fn a_read_write_register_is_a_command_written_once() {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        let mut want = vec![None; POINTS.len()];
        want[map::point_index("YPULSE2").unwrap()] = Some(Value::U16(50));
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        // FC 6 on holding register 84 (40085, YPULSE2) = 50.
        assert_eq!(plan.len(), 1);
        assert_eq!(wire(&plan[0]), frame(&[0x05, 0x06, 0x00, 0x54, 0x00, 0x32]));
        exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
        assert_eq!(sim.get("Y2"), Ok(Value::Bool(true)), "the pulser runs");
        assert_eq!(value(&d, "YPULSE2"), Some(Value::U16(50)));
        plan.clear();
        d.plan_write(&vec![None; POINTS.len()], false, &mut plan);
        assert!(plan.is_empty(), "written only while the scan asks");
    }

    #[test]
    fn readback_shows_a_pulse_while_it_runs_and_off_after_it() {
        let mut d = driver(&[("readback", "every")]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("Y2", Value::Bool(true)).unwrap(); // on before the pulse
        let mut want = vec![None; POINTS.len()];
        want[map::point_index("YPULSE2").unwrap()] = Some(Value::U16(100));
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(10)).unwrap();
        let mut read = Vec::new();
        d.plan_read(&mut read);
        assert_eq!(wire(&read[1]), frame(&[0x05, 0x01, 0x00, 0x00, 0x00, 0x04]));
        let coils = |sim: &mut MiniModSim, t: u64| {
            sim.on_frame(&wire(&read[1]), Duration::from_millis(t))
                .unwrap()
                .bytes
        };
        // During the pulse the coils read Y2 on; the driver's image agrees.
        assert_eq!(coils(&mut sim, 60), frame(&[0x05, 0x01, 0x01, 0x02]));
        exchange(&mut d, &mut sim, &read[1], Duration::from_millis(61)).unwrap();
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "YWORD"), Some(Value::U16(0b0010)));
        // After 100 ms: off, although it was on before.
        assert_eq!(coils(&mut sim, 110), frame(&[0x05, 0x01, 0x01, 0x00]));
        exchange(&mut d, &mut sim, &read[1], Duration::from_millis(111)).unwrap();
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "YWORD"), Some(Value::U16(0)));
    }

    #[test]
    fn partial_ownership_writes_only_owned_outputs() {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("Y4", Value::Bool(true)).unwrap(); // set by the module's own logic
                                                   // Two owned outputs to write: one FC 22 on YWORD.
        let want = desired(&[("Y1", true), ("Y2", false)]);
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(
            wire(&plan[0]),
            frame(&[0x05, 0x16, 0x00, 0x00, 0xFF, 0xFC, 0x00, 0x01])
        );
        exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b1001)), "Y4 untouched");
        assert_eq!(value(&d, "Y1"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "Y4"), None);
        // One changed: FC 5 on its coil.
        let want = desired(&[("Y1", true), ("Y2", true)]);
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(wire(&plan[0]), frame(&[0x05, 0x05, 0x00, 0x01, 0xFF, 0x00]));
        exchange(&mut d, &mut sim, &plan[0], Duration::ZERO).unwrap();
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b1011)));
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
        // Refresh: both owned again, still one transaction.
        plan.clear();
        d.plan_write(&want, true, &mut plan);
        assert_eq!(
            wire(&plan[0]),
            frame(&[0x05, 0x16, 0x00, 0x00, 0xFF, 0xFC, 0x00, 0x03])
        );
    }

    #[test]
    fn a_failed_write_is_planned_again() {
        let mut d = driver(&[]);
        let want = desired(&[("Y1", true), ("Y2", true), ("Y3", true), ("Y4", true)]);
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        d.on_failure(plan[0].tag);
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(plan.len(), 1);
        // An exception counts as failed too (the bus reports it and calls on_failure).
        let exception = Reply::Modbus(Response::Exception {
            function: 6,
            code: ExceptionCode::ServerDeviceFailure,
        });
        assert_eq!(
            d.on_reply(plan[0].tag, &exception),
            Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
        );
    }

    #[test]
    fn readback_every_nth_cycle() {
        let mut d = driver(&[("readback", "3")]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("Y2", Value::Bool(true)).unwrap();
        let mut counts = Vec::new();
        for cycle in 0..6u64 {
            let mut plan = Vec::new();
            d.plan_read(&mut plan);
            counts.push(plan.len());
            for tx in &plan {
                exchange(&mut d, &mut sim, tx, Duration::from_millis(cycle * 50)).unwrap();
            }
        }
        assert_eq!(counts, [2, 1, 1, 2, 1, 1]);
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "Y1"), Some(Value::Bool(false)));
        let mut plan = Vec::new();
        driver(&[("readback", "every")]).plan_read(&mut plan);
        assert_eq!(wire(&plan[1]), frame(&[0x05, 0x01, 0x00, 0x00, 0x00, 0x04]));
    }

    #[test]
    fn unexpected_replies_are_typed_errors() {
        let mut d = driver(&[]);
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        let tag = plan[0].tag;
        let short = Reply::Modbus(Response::ReadDiscreteInputs(vec![true; 3]));
        assert_eq!(
            d.on_reply(tag, &short),
            Err(DecodeError::Unexpected { tag })
        );
        let other = Reply::Modbus(Response::ReadCoils(vec![true; 10]));
        assert_eq!(
            d.on_reply(tag, &other),
            Err(DecodeError::Unexpected { tag })
        );
        let text = Reply::Text(b"X1=1".to_vec());
        assert_eq!(d.on_reply(tag, &text), Err(DecodeError::Unexpected { tag }));
        assert_eq!(
            d.on_reply(0xDEAD_BEEF, &short),
            Err(DecodeError::Unexpected { tag: 0xDEAD_BEEF })
        );
        let echo = Reply::Modbus(Response::WriteSingleRegister { addr: 7, value: 1 });
        let wtag = Tag::WriteOutputs.encode();
        assert_eq!(
            d.on_reply(wtag, &echo),
            Err(DecodeError::Unexpected { tag: wtag })
        );
    }

    #[test]
    fn startup_writes_and_verifies_settings() {
        let mut d = driver(&[
            ("XLATUP1", "5"),
            ("XLATUP2", "0x10"),
            ("XLATDN1", "500"),
            ("Y1AON1", "X1-X2"),
            ("readback", "off"),
        ]);
        let mut sim = MiniModSim::new(UNIT);
        let mut plan = Vec::new();
        d.plan_startup(&mut plan);
        assert_eq!(
            plan.len(),
            10,
            "runs 19..20 and 35, the logic clear (51..=78, 83..=86), then 51"
        );
        assert_eq!(
            wire(&plan[0]),
            frame(&[0x05, 0x10, 0x00, 0x13, 0x00, 0x02, 0x04, 0x00, 0x05, 0x00, 0x10])
        );
        assert_eq!(wire(&plan[1]), frame(&[0x05, 0x03, 0x00, 0x13, 0x00, 0x02]));
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        assert_eq!(sim.get("XLATDN1"), Ok(Value::U16(500)));
        assert_eq!(sim.get("Y1AON1"), Ok(Value::U16(0x0203)));
        // A module that holds something else is a mismatch.
        sim.set("XLATUP2", Value::U16(7)).unwrap();
        assert_eq!(
            exchange(&mut d, &mut sim, &plan[1], Duration::ZERO),
            Err(DecodeError::Mismatch {
                register: "XLATUP2",
                expected: 16,
                found: 7
            })
        );
    }

    #[test]
    fn reply_delay_follows_the_settings() {
        assert_eq!(
            driver(&[("RDELAYT", "5")]).reply_delay(),
            Duration::from_millis(50)
        );
        assert_eq!(
            driver(&[("RDELAYT", "0"), ("RDELAYM", "15")]).reply_delay(),
            Duration::from_micros(1500)
        );
        assert_eq!(driver(&[]).reply_delay(), Duration::from_millis(10));
    }

    #[test]
    fn catalog_entry() {
        let m = crate::devices::model("minimod").unwrap();
        assert_eq!(m.protocols, [Protocol::Modbus, Protocol::Text]);
        assert_eq!(m.max_baud, 57600);
        assert_eq!(m.default_reply_delay, Duration::from_millis(10));
        let config = DeviceConfig {
            name: "mm1".into(),
            address: UNIT,
            protocol: Protocol::Modbus,
            settings: vec![("readback".into(), "every".into())],
        };
        let mut d = (m.driver)(&config);
        assert_eq!(d.address(), UNIT);
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(plan.len(), 2);
        assert_eq!((m.simulator)(UNIT).address(), UNIT);
    }

    /// Polls X1 every 100 ms around a 30 ms pulse at 130..160 ms; returns the polls that saw
    /// it.
    fn polls_seeing_a_30_ms_pulse(settings: &[(&str, &str)]) -> Vec<u64> {
        let mut d = driver(settings);
        let mut sim = MiniModSim::new(UNIT);
        let mut setup = Vec::new();
        d.plan_startup(&mut setup);
        for tx in &setup {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        let mut seen = Vec::new();
        for t in (100..=900).step_by(100) {
            if t == 200 {
                sim.advance_to(Duration::from_millis(130));
                sim.set("X1", Value::Bool(true)).unwrap();
                sim.advance_to(Duration::from_millis(160));
                sim.set("X1", Value::Bool(false)).unwrap();
            }
            let mut plan = Vec::new();
            d.plan_read(&mut plan);
            exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(t)).unwrap();
            if value(&d, "X1") == Some(Value::Bool(true)) {
                seen.push(t);
            }
        }
        seen
    }

    #[test]
    fn a_500_ms_falling_latency_lets_a_100_ms_scan_see_a_30_ms_pulse() {
        assert_eq!(
            polls_seeing_a_30_ms_pulse(&[]),
            Vec::<u64>::new(),
            "20 ms latencies: the pulse falls between two polls"
        );
        assert_eq!(
            polls_seeing_a_30_ms_pulse(&[("XLATDN1", "500")]),
            [200, 300, 400, 500, 600],
            "cooked from 150 ms to 659 ms"
        );
    }

    fn text_driver(settings: &[(&str, &str)]) -> MiniModDriver {
        let settings: Vec<Setting> = settings
            .iter()
            .map(|(k, v)| Setting::parse(k, v).unwrap())
            .collect();
        MiniModDriver::with_protocol(Some(unit()), Protocol::Text, &settings)
    }

    fn line(tx: &Transaction) -> &[u8] {
        match &tx.frame {
            Outgoing::Text { line, terminator } => {
                assert_eq!(*terminator, b'\r');
                line
            }
            _ => panic!("not text"),
        }
    }

    #[test]
    fn text_protocol_reads_and_writes_the_same_points() {
        let mut d = text_driver(&[("readback", "every")]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("X2", Value::Bool(true)).unwrap();
        sim.command(&["fault", "Y1", "open"]).unwrap();
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(line(&plan[0]), b"@5?XWORD\r");
        assert_eq!(line(&plan[1]), b"@5?YWORD\r");
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::from_millis(20)).unwrap();
        }
        assert_eq!(value(&d, "X1"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "X2"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "X9"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "FB1"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "XWORD"), Some(Value::U16(0x0102)));
        assert_eq!(value(&d, "YWORD"), Some(Value::U16(0)));
        // All four owned: one >YWORD=.
        let want = desired(&[("Y1", true), ("Y2", false), ("Y3", true), ("Y4", false)]);
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(plan.len(), 1);
        assert_eq!(line(&plan[0]), b"@5>YWORD=5\r");
        exchange(&mut d, &mut sim, &plan[0], Duration::from_millis(30)).unwrap();
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(5)));
        assert_eq!(value(&d, "Y3"), Some(Value::Bool(true)));
        // Two owned, both changed: one >Yn= each.
        let mut d = text_driver(&[]);
        let want = desired(&[("Y2", true), ("Y4", false)]);
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        let lines: Vec<&[u8]> = plan.iter().map(line).collect();
        assert_eq!(lines, [&b"@5>Y2=1\r"[..], b"@5>Y4=0\r"]);
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::from_millis(40)).unwrap();
        }
        assert_eq!(sim.get("YWORD"), Ok(Value::U16(0b0111)), "Y1, Y3 untouched");
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "Y1"), None);
    }

    #[test]
    fn text_write_refused_while_the_watchdog_fires_is_planned_again() {
        let mut d = text_driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("WDTFIRED", Value::Bool(true)).unwrap();
        let want = desired(&[("Y1", true)]);
        let mut plan = Vec::new();
        d.plan_write(&want, false, &mut plan);
        let r = exchange(&mut d, &mut sim, &plan[0], Duration::ZERO);
        assert_eq!(
            r,
            Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure)),
            "Error: the module said no, as exception 04 does"
        );
        assert!(
            d.wants_restart(),
            "a fired watchdog: the start-up must run again"
        );
        d.on_failure(plan[0].tag);
        plan.clear();
        d.plan_write(&want, false, &mut plan);
        assert_eq!(plan.len(), 1);
    }

    #[test]
    fn modbus_write_refused_while_the_watchdog_fires() {
        let mut d = driver(&[]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("WDTFIRED", Value::Bool(true)).unwrap();
        let mut plan = Vec::new();
        d.plan_write(&desired(&[("Y1", true)]), false, &mut plan);
        assert_eq!(
            exchange(&mut d, &mut sim, &plan[0], Duration::ZERO),
            Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure))
        );
    }

    #[test]
    fn watchdog_and_event_masks_at_start_up() {
        let mut d = driver(&[
            ("WDTTIME", "50"),
            ("WDTMASK", "0b1000"),
            ("FBENABLE", "3"),
            ("XEVMASK", "7"),
            ("YEVMASK", "0xF"),
            ("RDELAYT", "2"),
        ]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("WDTFIRED", Value::Bool(true)).unwrap(); // left by the last run
        let mut plan = Vec::new();
        d.plan_startup(&mut plan);
        let mut wires: Vec<Vec<u8>> = plan
            .iter()
            .map(|tx| match &tx.frame {
                Outgoing::Text { line, .. } => line.clone(),
                _ => wire(tx),
            })
            .collect();
        // The logic registers are cleared after the watchdog reset (see `logic`).
        let clear: Vec<Vec<u8>> = wires.drain(12..16).collect();
        assert_eq!(clear, logic::tests::clear_frames(UNIT));
        assert_eq!(
            wires,
            [
                // Why it fired, before anything resets it (see `restart`): WDTFIRED (coil
                // 160), WDTFB and WDTCOMM (discrete inputs 24..=25).
                frame(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
                frame(&[0x05, 0x02, 0x00, 0x18, 0x00, 0x02]),
                frame(&[0x05, 0x10, 0x00, 0x05, 0x00, 0x02, 0x04, 0x00, 0x07, 0x00, 0x0F]),
                frame(&[0x05, 0x03, 0x00, 0x05, 0x00, 0x02]),
                frame(&[0x05, 0x10, 0x00, 0x80, 0x00, 0x01, 0x02, 0x00, 0x32]),
                frame(&[0x05, 0x03, 0x00, 0x80, 0x00, 0x01]),
                frame(&[0x05, 0x10, 0x00, 0x90, 0x00, 0x01, 0x02, 0x00, 0x08]),
                frame(&[0x05, 0x03, 0x00, 0x90, 0x00, 0x01]),
                frame(&[0x05, 0x0F, 0x00, 0x70, 0x00, 0x02, 0x01, 0x03]),
                frame(&[0x05, 0x01, 0x00, 0x70, 0x00, 0x02]),
                frame(&[0x05, 0x0F, 0x00, 0xA0, 0x00, 0x01, 0x01, 0x00]),
                frame(&[0x05, 0x01, 0x00, 0xA0, 0x00, 0x01]),
                b"@5>RDELAYT=2\r".to_vec(),
            ]
        );
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        assert_eq!(sim.get("WDTTIME"), Ok(Value::U16(50)));
        assert_eq!(sim.get("WDTFB2"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("WDTFIRED"), Ok(Value::Bool(false)), "reset");
        assert_eq!(sim.state().rdelayt(), 2);
        assert_eq!(value(&d, "WDTTIME"), Some(Value::U16(50)));
        assert_eq!(value(&d, "WDTFB1"), Some(Value::Bool(true)));
        // A module that holds something else names the register.
        sim.set("WDTFB1", Value::Bool(false)).unwrap();
        assert_eq!(
            exchange(&mut d, &mut sim, &plan[9], Duration::ZERO),
            Err(DecodeError::Mismatch {
                register: "WDTFB1",
                expected: 1,
                found: 0
            })
        );
        // An enabled feedback that holds fires it again at once: the start stops, by name.
        sim.set("WDTFB1", Value::Bool(true)).unwrap();
        sim.command(&["fault", "Y1", "open"]).unwrap();
        exchange(&mut d, &mut sim, &plan[10], Duration::from_millis(10)).unwrap();
        assert_eq!(
            exchange(&mut d, &mut sim, &plan[11], Duration::from_millis(11)),
            Err(DecodeError::Mismatch {
                register: "WDTFIRED",
                expected: 0,
                found: 1
            })
        );
    }

    #[test]
    fn text_start_up_uses_text_where_the_tables_allow() {
        let mut d = text_driver(&[
            ("X1LATUP", "5"),
            ("Y3AON2", "X2-X3"),
            ("Y1AON1", "0x0100"), // conditions go through Modbus, read back
            ("FBENABLE", "2"),
            ("XCOUNT1", "100"),
            ("XEVMASK", "1"), // no text identifier: Modbus
        ]);
        let mut sim = MiniModSim::new(UNIT);
        let mut plan = Vec::new();
        d.plan_startup(&mut plan);
        let texts: Vec<&[u8]> = plan
            .iter()
            .filter_map(|tx| match &tx.frame {
                Outgoing::Text { line, .. } => Some(line.as_slice()),
                _ => None,
            })
            .collect();
        assert_eq!(
            texts,
            [
                &b"@5?WFLAGS\r"[..], // why the watchdog fired, before the reset (`restart`)
                b"@5>XCOUNT1=100\r",
                b"@5>X1LATUP=5\r",
                b"@5?X1LATUP\r",
                b"@5>FBENABLE=2\r",
                b"@5?FBENABLE\r",
            ]
        );
        assert_eq!(
            plan.len(),
            texts.len() + 13,
            "Modbus: WDTFB/WDTCOMM (why the watchdog fired), XEVMASK, WDTFIRED (the watchdog \
             reset), the logic clear (two runs), then Y1AON1 and Y3AON2 (conditions cannot be \
             read back in text, see `logic`)"
        );
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        assert_eq!(sim.get("Y3AON2"), Ok(Value::U16(0x0406)));
        assert_eq!(sim.get("Y1AON1"), Ok(Value::U16(0x0100)));
        assert_eq!(sim.get("XEVMASK"), Ok(Value::U16(1)));
        assert_eq!(sim.get("WDTFB2"), Ok(Value::Bool(true)));
        assert_eq!(value(&d, "XLATUP1"), Some(Value::U16(5)));
        sim.set("XLATUP1", Value::U16(9)).unwrap();
        let verify = plan
            .iter()
            .find(|tx| matches!(&tx.frame, Outgoing::Text { line, .. } if line == b"@5?X1LATUP\r"))
            .unwrap();
        assert_eq!(
            exchange(&mut d, &mut sim, verify, Duration::ZERO),
            Err(DecodeError::Mismatch {
                register: "XLATUP1",
                expected: 5,
                found: 9
            })
        );
    }

    #[test]
    fn counters_and_status_every_nth_cycle() {
        let mut d = driver(&[("counters", "2"), ("status", "every")]);
        let mut sim = MiniModSim::new(UNIT);
        sim.set("XLATUP1", Value::U16(0)).unwrap();
        sim.set("XLATDN1", Value::U16(0)).unwrap();
        for k in 0..3u64 {
            sim.set("X1", Value::Bool(true)).unwrap();
            sim.advance_to(Duration::from_millis(10 * k + 5));
            sim.set("X1", Value::Bool(false)).unwrap();
            sim.advance_to(Duration::from_millis(10 * k + 10));
        }
        sim.set("SW4", Value::Bool(true)).unwrap();
        sim.command(&["flash", "broken"]).unwrap();
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(plan.len(), 4, "status (2), counters, inputs");
        assert_eq!(wire(&plan[0]), frame(&[0x05, 0x02, 0x00, 0x11, 0x00, 0x71]));
        for tx in &plan {
            exchange(&mut d, &mut sim, tx, Duration::from_millis(40)).unwrap();
        }
        assert_eq!(value(&d, "XCOUNT1"), Some(Value::U16(3)));
        assert_eq!(value(&d, "SW4"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "FLASHFAIL"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "WDTFIRED"), Some(Value::Bool(false)));
        plan.clear();
        d.plan_read(&mut plan);
        assert_eq!(plan.len(), 3, "no counters in the second cycle");
        // Text: ?WFLAGS and ?XCOUNTn.
        let mut t = text_driver(&[("counters", "every"), ("status", "every")]);
        sim.set("WDTFIRED", Value::Bool(true)).unwrap();
        plan.clear();
        t.plan_read(&mut plan);
        assert_eq!(line(&plan[0]), b"@5?WFLAGS\r");
        assert_eq!(line(&plan[3]), b"@5?XCOUNT3\r");
        for tx in &plan {
            exchange(&mut t, &mut sim, tx, Duration::from_millis(50)).unwrap();
        }
        assert_eq!(value(&t, "WDTFIRED"), Some(Value::Bool(true)));
        assert_eq!(value(&t, "XCOUNT1"), Some(Value::U16(3)));
    }

    #[test]
    fn event_mode_plans_a_membership_then_the_refresh() {
        let mut d = driver(&[("events", "true"), ("event_refresh", "250ms")]);
        assert!(d.event_mode());
        let mut plan = Vec::new();
        d.plan_read(&mut plan);
        assert_eq!(plan.len(), 2);
        assert_eq!(
            collect::membership_of(&plan[0]),
            Some((unit(), Duration::from_millis(250)))
        );
        assert_eq!(wire(&plan[1]), frame(&[0x05, 0x02, 0x00, 0x00, 0x00, 0x0A]));
        // Start-up enables the input events.
        let mut setup = Vec::new();
        d.plan_startup(&mut setup);
        let mut sim = MiniModSim::new(UNIT);
        for tx in &setup {
            exchange(&mut d, &mut sim, tx, Duration::ZERO).unwrap();
        }
        assert_eq!(sim.get("XEVMASK"), Ok(Value::U16(7)));
        assert_eq!(sim.get("EVFB1"), Ok(Value::Bool(true)));
        assert_eq!(sim.get("EVFB2"), Ok(Value::Bool(true)));
        // Events arrive under the membership's tag.
        let event = Reply::Modbus(Response::Collect {
            slave: UNIT,
            seq: 1,
            kind: 2,
            data: 0x0205,
        });
        d.on_reply(plan[0].tag, &event).unwrap();
        assert_eq!(value(&d, "X1"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "X2"), Some(Value::Bool(false)));
        assert_eq!(value(&d, "X3"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "X10"), Some(Value::Bool(true)));
        assert_eq!(value(&d, "FB2"), Some(Value::Bool(true)));
        let outputs = Reply::Modbus(Response::Collect {
            slave: UNIT,
            seq: 2,
            kind: 1,
            data: 0b0010,
        });
        d.on_reply(plan[0].tag, &outputs).unwrap();
        assert_eq!(value(&d, "Y2"), Some(Value::Bool(true)));
        let bad = Reply::Modbus(Response::Collect {
            slave: UNIT,
            seq: 3,
            kind: 9,
            data: 0,
        });
        assert!(d.on_reply(plan[0].tag, &bad).is_err());
        // A write is still planned from the program's desire: output events never feed it.
        let mut w = Vec::new();
        d.plan_write(&desired(&[("Y2", true)]), false, &mut w);
        assert_eq!(w.len(), 1);
    }
}
