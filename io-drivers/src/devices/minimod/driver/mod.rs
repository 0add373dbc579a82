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
//! The inputs come from FC 70 Collect ("The Modbus function Collect"): the driver is a member
//! of its line's round ([`Driver::collect_membership`]), which the bus owner runs as one
//! broadcast Collect for every event-mode module of the line, and every event of this module
//! comes back through [`Driver::on_reply`] as a [`Response::Collect`]: TYPE 2 is the input
//! word (X1..X3, X9/X10), TYPE 1 the output levels (Y1..Y4 point values only: they include
//! pulsers and blinkers, so they never feed the write phase's comparison). The read plan then
//! holds the status and counter reads only; the full input read (FC 2, or `?XWORD`) and the
//! read-back are the refresh ([`Driver::plan_refresh`]): the owner runs them on the first
//! cycle, after a lost event, a failed round or a failed cycle, when nothing addressed to the
//! module was answered for `event_refresh` (default 1 s: a write's echo counts) and at least
//! every `event_resync` (default 30 s), so a lost event cannot leave the image wrong for long
//! (see [`Membership`]). At start-up
//! event mode writes XEVMASK = 7 and EVFB1 = EVFB2 = 1 unless the project sets them.
//!
//! ## Start-up settings
//!
//! See [`super::settings`]. Contiguous holding registers are written with one FC 16 and read
//! back with one FC 3; contiguous coils with FC 15 and FC 1; `RDELAYT` / `RDELAYM` are sent last
//! as text (`@5>RDELAYT=5`), whatever the protocol, since no register holds them. WDTTIME and
//! WDTYMASK are set and read back by name as text (`@5>WDTTIME=50`, `@5?WDTTIME`), whatever
//! the protocol, since the manual gives their registers two ways ([`watchdog`]). A read-back
//! difference is [`DecodeError::Mismatch`] with the register's name. When the project sets the
//! watchdog (WDTTIME, WDTYMASK, FBENABLE, WDTFB1..2), start-up also resets it (WDTFIRED = 0,
//! read back): a watchdog that fired when the last run stopped would otherwise keep the outputs
//! locked, and a feedback that fires it again at once stops the start, by name. Before any of
//! it, the start-up reads why the watchdog fired and logs it once ([`restart`]); the same
//! sequence runs when the module comes back after it was lost or refused a write, and every
//! output is then written again.
//!
//! ## Registers the manual gives two ways
//!
//! Every register the driver writes, against the manual's places: only the watchdog's words
//! differ between two readings, and they are armed so that either works.
//!
//! | register | reading 1 | reading 2 | chosen | confirmed at start-up |
//! |---|---|---|---|---|
//! | WDTTIME | 40129, holding register 128 (table "Modbus register map (read and write registers)") | holding register 8: "coil *n* = bit *n* % 16 of holding register *n* / 16", which YWORD/Y1..Y4, XEVMASK/EVX1..3 and YEVMASK/EVY1..4 follow in the same table | neither: by name, `>WDTTIME=` (text table "WDTtime") | `?WDTTIME` reads the value back; a difference stops the start, logged with both readings |
//! | WDTYMASK | 40145, holding register 144 (the table) | holding register 9, whose bits would be WDTY1..4 (00145..00148) | neither: by name, `>WDTMASK=` ("WDTmask") | `?WDTMASK`, as above |
//! | WDTFB1..2 / FBENABLE | coils 112/113 (00113..00114; prose "Power outputs, blinkers, pulsers, and feedbacks": "The Single Coil at address 112") | text FBENABLE bits 0/1 ("FBEnable") | the coils (FBENABLE in text mode) | read back (FC 1, or `?FBENABLE`) |
//! | WDTFIRED | coil 160 (00161) | text WFLAGS bit 1 ("Wflags") | the coil to reset it, WFLAGS to read it in text mode | the coil read back 0; a fired watchdog's reason read first ([`restart`]) |
//! | XLATUP/XLATDN, XCOUNT, AON/AOFF, YLAMP, YPULSE, XEVMASK, YEVMASK, YWORD | prose ("Digital inputs, latencies and counters", "Power outputs, ...", "Automatic output management"): 19..21, 35..37, 11..13, 51..74, 75..78, 83..86 | the table: 40020.., 40036.., 40012.., 40052..40075, 40076.., 40084.., 40006, 40007, 40001 | the same registers (the two agree, and agree with the aliasing rule) | read back (counters by their echo: they count) |
//!
//! The manual also writes `>Y2=` as its example of clearing a condition ("To clear a condition
//! an empty value is used, i.e. >Y2="): that is output Y2's identifier, not a condition's, so
//! conditions are cleared by writing 0 to their registers and reading them back ([`logic`]).
//!
//! The logic registers (AON/AOFF conditions, blinkers, pulsers) come last: all cleared and read
//! back, then the pushed-down outputs' initial values, then the settings' own tables (the
//! order and why: [`logic`]), so tables left by a run that crashed never drive the outputs
//! under this one.

//!
//! ## Where each part lives
//!
//! [`settings`]: the start-up steps built from the settings; [`startup`]: running them and
//! checking their read-backs; [`plan`]: each cycle's reads and their answers; [`write`]: the
//! write phase and its echoes; [`text`]: the text protocol's transactions and the parsing of
//! its answers; [`logic`]: the logic tables' start-up; [`restart`]: refused writes and the
//! watchdog's status; [`watchdog`]: arming the watchdog by name.

use std::time::Duration;

use super::map::{self, POINTS};
use super::settings::{Readback, Setting, Settings, DEFAULT_EVENT_REFRESH, DEFAULT_EVENT_RESYNC};
use crate::devices::{DeviceConfig, ModuleSettings, Protocol};
use crate::driver::{DecodeError, Driver, Membership, Outgoing, Reply, Transaction};
use crate::line::LineSettings;
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

mod logic;
mod lost_events;
pub use logic::CLEARED as LOGIC_CLEARED_AT_STARTUP;
mod plan;
mod restart;
mod settings;
mod startup;
mod text;
mod watchdog;
mod write;

use settings::{runs, setup_steps, SetupStep};

/// Builds a driver from a validated module entry (the catalog's constructor): the module's
/// own settings, then what the push-down planner added
/// ([`super::push_down::PushDown::settings`]). A configuration of another family (never built by project validation, which parses the
/// settings with this model) gives the module's defaults. An address that is no Modbus unit
/// (refused by the model's range, 1..=247) gives a driver that plans nothing.
pub(crate) fn build(config: &DeviceConfig) -> Box<dyn Driver> {
    let own = match &config.settings {
        ModuleSettings::MiniMod(s) => s.clone(),
        _ => Settings::default(),
    };
    let mut settings = own.items().to_vec();
    if let crate::devices::PushDown::MiniMod(push) = &config.push_down {
        settings.extend(push.settings(&own));
    }
    Box::new(MiniModDriver::with_protocol(
        config.address.unit(),
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
    /// Text `>WDTTIME=v` command (see `watchdog`): index = v.
    WdtTimeByName(u16),
    /// Text `>WDTMASK=v` command: index = v.
    WdtMaskByName(u16),
    /// FC 3 XEVMASK read back after an input change no event reported (see `lost_events`).
    EventMaskProbe,
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
            Tag::WdtTimeByName(v) => (13, v),
            Tag::WdtMaskByName(v) => (14, v),
            Tag::EventMaskProbe => (15, 0),
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
            13 => Tag::WdtTimeByName(index),
            14 => Tag::WdtMaskByName(index),
            15 => Tag::EventMaskProbe,
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
    event_resync: Duration,
    rdelayt: u8,
    rdelaym: u8,
    setup: Vec<SetupStep>,
    values: Vec<Option<Value>>,
    /// The module's commanded outputs as far as known (echo or read-back).
    y: [Option<bool>; 4],
    /// The blinker masks (YLAMP1..4) last written, as far as known: a mask is written when
    /// it changes, not every cycle the scan asks for it (see `write`).
    lamp: [Option<u16>; 4],
    /// A write failed: write every owned output at the next write phase.
    rewrite: bool,
    /// The last write plan covers every owned output ([`Driver::planned_full_write`]).
    full_write: bool,
    cycle: u64,
    /// Whether the read-back is due in this cycle's full read (event mode plans it apart).
    refresh_readback: bool,
    /// Refused writes, restarts and the watchdog's status at start-up (see `restart`).
    restart: restart::Restart,
    /// Event mode: whether its event recording is still on (see `lost_events`).
    event_watch: lost_events::EventWatch,
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
            event_resync: DEFAULT_EVENT_RESYNC,
            rdelayt: super::state::POWER_ON_RDELAYT,
            rdelaym: 0,
            setup: Vec::new(),
            values: vec![None; POINTS.len()],
            y: [None; 4],
            lamp: [None; 4],
            rewrite: false,
            full_write: false,
            cycle: 0,
            refresh_readback: false,
            restart: restart::Restart::default(),
            event_watch: lost_events::EventWatch::default(),
        };
        for s in settings {
            match *s {
                Setting::Readback(r) => d.readback = r,
                Setting::Counters(r) => d.counters = r,
                Setting::Status(r) => d.status = r,
                Setting::Events(on) => d.events = on,
                Setting::EventRefresh(t) => d.event_refresh = t,
                Setting::EventResync(t) => d.event_resync = t,
                Setting::ReplyDelay(n) => d.rdelayt = n,
                Setting::FrameTimeout(n) => d.rdelaym = n,
                Setting::Register { .. } | Setting::Coils { .. } => {}
            }
        }
        d.setup = setup_steps(settings, protocol, d.events);
        d
    }

    /// RDELAYM tenths of a millisecond: how much longer than 28 bit times the module waits
    /// for the end of a request ("Setting the Modbus communication timeout").
    fn frame_timeout(&self) -> Duration {
        Duration::from_micros(100 * u64::from(self.rdelaym))
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

    /// Output `y` (0-based) is known to be `on`: its point, and YWORD once all four are known.
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

    /// All four outputs from YWORD.
    fn set_yword(&mut self, word: u16) {
        for y in 0..4 {
            self.set_y(y, word & (1 << y) != 0);
        }
    }

    fn on_modbus(&mut self, tag: u32, response: &Response) -> Result<(), DecodeError> {
        match Tag::decode(tag) {
            Some(t @ (Tag::SetupWrite(_) | Tag::SetupVerify(_))) => {
                self.on_setup_modbus(tag, t, response)
            }
            Some(t @ (Tag::WriteOutputs | Tag::WriteRegister(_))) => {
                self.on_write_modbus(tag, t, response)
            }
            Some(t) => self.on_read_modbus(tag, t, response),
            None => Err(DecodeError::Unexpected { tag }),
        }
    }
}

impl Driver for MiniModDriver {
    fn address(&self) -> u8 {
        self.unit.map_or(0, UnitId::get)
    }

    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        self.plan_startup_steps(unit, out);
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        self.plan_reads(unit, out);
    }

    fn collect_membership(&self) -> Option<Membership> {
        self.unit.filter(|_| self.events).map(|unit| Membership {
            unit,
            answer_within: self.event_refresh,
            resync: self.event_resync,
            frame_timeout: self.frame_timeout(),
        })
    }

    fn planned_full_write(&self) -> bool {
        self.full_write
    }

    fn plan_refresh(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit.filter(|_| self.events) else {
            return;
        };
        self.plan_full_read(unit, out);
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        self.full_write = false;
        let Some(unit) = self.unit else { return };
        self.plan_writes(unit, desired, refresh, out);
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        if let Some(result) = self.on_watchdog_reply(tag, reply) {
            return result;
        }
        let result = match reply {
            Reply::Modbus(Response::Exception { code, .. }) => Err(DecodeError::Exception(*code)),
            // Events of the line's Collect round.
            Reply::Modbus(Response::Collect { kind, data, .. }) => {
                self.apply_event(tag, *kind, *data)
            }
            Reply::Modbus(response) => self.on_modbus(tag, response),
            Reply::Text(bytes) => self.on_text(tag, bytes),
        };
        self.after_reply(tag, &result);
        result
    }

    fn on_confirmed_mismatch(&mut self, _tag: u32, mismatch: DecodeError) {
        if let DecodeError::Mismatch {
            register,
            expected,
            found,
        } = mismatch
        {
            watchdog::explain_mismatch(self.address(), register, expected, found);
        }
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

    /// RDELAYT ("Setting the reply delay") and RDELAYM: the module waits RDELAYM longer for
    /// the end of a request, so it turns round that much later.
    fn reply_delay(&self) -> Duration {
        Duration::from_millis(10 * u64::from(self.rdelayt)) + self.frame_timeout()
    }

    /// A request that follows other traffic (another module's reply, a Collect) by less than
    /// the module's 28 bit times + RDELAYM is heard as the end of that traffic ("Setting the
    /// Modbus communication timeout"): the owner leaves that silence before it.
    fn frame_gap(&self, settings: LineSettings) -> Option<Duration> {
        Some(super::state::end_of_request_silence(
            settings.baud,
            self.frame_timeout(),
        ))
    }
}

#[cfg(test)]
mod tests;
