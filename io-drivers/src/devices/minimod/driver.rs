//! The MiniMod driver (Modbus RTU, sans-IO).
//!
//! ## Per cycle
//!
//! - **Inputs**: one FC 2 read of discrete inputs 0..=9 (10001..10010): X1..X3 and X9/X10
//!   (= FB1/FB2). Request `uu 02 00 00 00 0A` + CRC, 8 bytes; reply `uu 02 02 b0 b1` + CRC,
//!   7 bytes. The alternative, FC 4 input register 0 (all 16 inputs as one word), is 8 + 7
//!   bytes too: an FC 2 reply is 6 bytes only when at most 8 bits are read, and X9/X10 are
//!   bits 8/9. With equal wire time, FC 2 is chosen because it reads exactly the points, by
//!   the manual's register table.
//! - **Outputs**: written on change, in one transaction per cycle at most, and never touching
//!   an output the program does not own (so its level stays what the module's AON/AOFF
//!   conditions make of it): FC 6 YWORD (holding register 0, 40001) when the program owns all
//!   of Y1..Y4; FC 5 on the coil (00001..00004) when one owned output is to be written; FC 22
//!   Mask Write on YWORD for two or three (10 + 10 bytes instead of 8 + 8). With `refresh`
//!   every owned output is written again. The echo is taken as the module's output state (the
//!   values of Y1..Y4 and YWORD). A failed write is planned again (all owned outputs) next
//!   cycle.
//! - **Read-back** of Y1..Y4 (setting `readback`, default `off`): FC 1 coils 0..=3 (reply 6
//!   bytes, one shorter than FC 3 YWORD), in a second transaction after the inputs, every
//!   cycle or every Nth. It shows what the module's own logic (AON/AOFF) did to the outputs;
//!   for an output the program owns, a difference is then written back at the next write
//!   phase (leave an output unowned to let the module's logic own it). YWORD is the commanded
//!   state: pulsers and blinkers do not show in it.
//!
//! ## Start-up settings (project file `settings`)
//!
//! - `readback`: `off` | `every` | N (every Nth cycle, 1..=65535).
//! - `RDELAYT`: the module's configured reply delay in 1/100 s (0..=200, default 1), for the
//!   line budget only: it is set with the text protocol ("Setting the reply delay"), not
//!   written by this driver.
//! - Registers written at start-up and read back (a difference stops the start):
//!   `XLATUP1..3`, `XLATDN1..3` (ms), `Y1AON1..Y4AON3`, `Y1AOFF1..Y4AOFF3` (a number, or the
//!   text protocol's form such as `X1-X2`), `YLAMP1..4`. Numbers are decimal, `0x` hex or
//!   `0b` binary. Contiguous registers are written with one FC 16 and read back with one FC 3.
//!
//! Watchdog (WDTTIME, WDTYMASK) and event (XEVMASK, YEVMASK) settings come with the watchdog
//! and Collect issues.

use std::time::Duration;

use super::map::{self, parse_condition, Item, Space, POINTS};
use crate::devices::DeviceConfig;
use crate::driver::{DecodeError, Driver, Outgoing, Reply, Transaction};
use crate::modbus::{Request, Response, UnitId};
use crate::point::Value;

/// How often Y1..Y4 are read back.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Readback {
    /// Never: the outputs' values are the last write's echo.
    #[default]
    Off,
    /// Every Nth cycle (1 = every cycle).
    Every(u16),
}

/// Why a setting was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum SettingError {
    /// Not a MiniMod setting.
    #[error(
        "not a minimod setting; accepted: readback, RDELAYT, XLATUP1..3, XLATDN1..3, \
         Y1AON1..Y4AON3, Y1AOFF1..Y4AOFF3, YLAMP1..4"
    )]
    UnknownKey,
    /// The value does not fit the setting.
    #[error("{key} takes {expected}")]
    BadValue {
        /// The setting, as the manual names it.
        key: &'static str,
        /// What it accepts.
        expected: &'static str,
    },
}

/// One validated setting.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Setting {
    /// `readback`.
    Readback(Readback),
    /// `RDELAYT`, hundredths of a second.
    ReplyDelay(u8),
    /// A holding register written at start-up.
    Register {
        /// The manual's name.
        name: &'static str,
        /// Protocol address (0-based).
        addr: u16,
        /// The value.
        value: u16,
    },
}

fn parse_number(text: &str) -> Option<u64> {
    let t = text.trim();
    if let Some(hex) = t.strip_prefix("0x").or_else(|| t.strip_prefix("0X")) {
        u64::from_str_radix(hex, 16).ok()
    } else if let Some(bin) = t.strip_prefix("0b").or_else(|| t.strip_prefix("0B")) {
        u64::from_str_radix(&bin.replace(['.', '_', '-'], ""), 2).ok()
    } else {
        t.parse().ok()
    }
}

impl Setting {
    /// Parses a `key: value` pair of the project file. Keys are case-insensitive.
    pub fn parse(key: &str, value: &str) -> Result<Self, SettingError> {
        if key.eq_ignore_ascii_case("readback") {
            let bad = SettingError::BadValue {
                key: "readback",
                expected: "off, every or 1..=65535",
            };
            return match value.trim() {
                "off" => Ok(Setting::Readback(Readback::Off)),
                "every" => Ok(Setting::Readback(Readback::Every(1))),
                n => parse_number(n)
                    .and_then(|n| u16::try_from(n).ok())
                    .filter(|&n| n > 0)
                    .map(|n| Setting::Readback(Readback::Every(n)))
                    .ok_or(bad),
            };
        }
        if key.eq_ignore_ascii_case("RDELAYT") {
            return parse_number(value)
                .and_then(|n| u8::try_from(n).ok())
                .filter(|&n| n <= 200)
                .map(Setting::ReplyDelay)
                .ok_or(SettingError::BadValue {
                    key: "RDELAYT",
                    expected: "0..=200 (1/100 s)",
                });
        }
        let upper = key.to_ascii_uppercase();
        let entry = map::entry(&upper)
            .filter(|e| e.space == Space::HoldingRegister)
            .ok_or(SettingError::UnknownKey)?;
        let word = |expected| {
            parse_number(value)
                .and_then(|n| u16::try_from(n).ok())
                .ok_or(SettingError::BadValue {
                    key: entry.name,
                    expected,
                })
        };
        let value = match entry.item {
            Item::XlatUp(_) | Item::XlatDn(_) => word("0..=65535 (ms)")?,
            Item::Lamp(_) => word("a 16-bit mask")?,
            Item::AutoOn(..) | Item::AutoOff(..) => match parse_number(value) {
                Some(n) => u16::try_from(n).map_err(|_| SettingError::BadValue {
                    key: entry.name,
                    expected: "a 16-bit mask or a condition such as X1-X2",
                })?,
                None => parse_condition(value).map_err(|_| SettingError::BadValue {
                    key: entry.name,
                    expected: "a 16-bit mask or a condition such as X1-X2",
                })?,
            },
            _ => return Err(SettingError::UnknownKey),
        };
        Ok(Setting::Register {
            name: entry.name,
            addr: entry.addr,
            value,
        })
    }
}

/// Checks one setting (the catalog's `check_setting`).
pub fn check_setting(key: &str, value: &str) -> Result<(), String> {
    Setting::parse(key, value)
        .map(|_| ())
        .map_err(|e| e.to_string())
}

/// Builds a driver from a validated module entry (the catalog's constructor). Settings were
/// checked before; one that still fails is logged and ignored. An address outside 1..=247
/// (refused by project validation) gives a driver that plans nothing.
pub fn build(config: &DeviceConfig) -> Box<dyn Driver> {
    let mut settings = Vec::with_capacity(config.settings.len());
    for (key, value) in &config.settings {
        match Setting::parse(key, value) {
            Ok(s) => settings.push(s),
            Err(e) => tracing::error!(module = %config.name, key = %key, "ignored setting: {e}"),
        }
    }
    let unit = UnitId::new(config.address);
    if unit.is_none() {
        tracing::error!(module = %config.name, address = config.address, "not a unit address");
    }
    Box::new(MiniModDriver::new(unit, &settings))
}

/// Indexes in [`POINTS`] of what the driver reads.
const IDX_X: [usize; 3] = [0, 1, 2];
const IDX_X9: usize = 3;
const IDX_X10: usize = 4;
const IDX_FB1: usize = 5;
const IDX_FB2: usize = 6;
const IDX_Y: [usize; 4] = [7, 8, 9, 10];
const IDX_YWORD: usize = 11;

/// What a transaction was for, carried in its tag.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tag {
    Inputs,
    Readback,
    WriteOutputs,
    SetupWrite(u16),
    SetupVerify(u16),
}

impl Tag {
    fn encode(self) -> u32 {
        match self {
            Tag::Inputs => 1 << 16,
            Tag::Readback => 2 << 16,
            Tag::WriteOutputs => 3 << 16,
            Tag::SetupWrite(i) => (4 << 16) | u32::from(i),
            Tag::SetupVerify(i) => (5 << 16) | u32::from(i),
        }
    }

    fn decode(tag: u32) -> Option<Self> {
        let index = (tag & 0xFFFF) as u16;
        Some(match tag >> 16 {
            1 => Tag::Inputs,
            2 => Tag::Readback,
            3 => Tag::WriteOutputs,
            4 => Tag::SetupWrite(index),
            5 => Tag::SetupVerify(index),
            _ => return None,
        })
    }
}

/// Contiguous start-up registers: one FC 16 and one FC 3.
#[derive(Debug, Clone, PartialEq, Eq)]
struct Run {
    addr: u16,
    values: Vec<u16>,
    names: Vec<&'static str>,
}

/// Groups register settings by address (the last of duplicates wins) into contiguous runs.
fn runs(settings: &[Setting]) -> Vec<Run> {
    let mut regs: Vec<(u16, u16, &'static str)> = Vec::new();
    for s in settings {
        if let Setting::Register { name, addr, value } = *s {
            regs.retain(|r| r.0 != addr);
            regs.push((addr, value, name));
        }
    }
    regs.sort_by_key(|r| r.0);
    let mut out: Vec<Run> = Vec::new();
    for (addr, value, name) in regs {
        match out.last_mut() {
            Some(run) if usize::from(run.addr) + run.values.len() == usize::from(addr) => {
                run.values.push(value);
                run.names.push(name);
            }
            _ => out.push(Run {
                addr,
                values: vec![value],
                names: vec![name],
            }),
        }
    }
    out
}

/// The MiniMod driver.
#[derive(Debug, Clone)]
pub struct MiniModDriver {
    unit: Option<UnitId>,
    readback: Readback,
    rdelayt: u8,
    setup: Vec<Run>,
    values: Vec<Option<Value>>,
    /// The module's commanded outputs as far as known (echo or read-back).
    y: [Option<bool>; 4],
    /// A write failed: write every owned output at the next write phase.
    rewrite: bool,
    cycle: u64,
}

impl MiniModDriver {
    /// A driver for the module at `unit` (`None`: plans nothing) with validated settings.
    pub fn new(unit: Option<UnitId>, settings: &[Setting]) -> Self {
        let mut readback = Readback::Off;
        let mut rdelayt = super::state::POWER_ON_RDELAYT;
        for s in settings {
            match *s {
                Setting::Readback(r) => readback = r,
                Setting::ReplyDelay(d) => rdelayt = d,
                Setting::Register { .. } => {}
            }
        }
        Self {
            unit,
            readback,
            rdelayt,
            setup: runs(settings),
            values: vec![None; POINTS.len()],
            y: [None; 4],
            rewrite: false,
            cycle: 0,
        }
    }

    fn tx(&self, unit: UnitId, request: Request, tag: Tag) -> Transaction {
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

    fn apply_inputs(&mut self, tag: u32, bits: &[bool]) -> Result<(), DecodeError> {
        if bits.len() != usize::from(map::DI_READ_COUNT) {
            return Err(DecodeError::Unexpected { tag });
        }
        let bit = |addr: u16| bits.get(usize::from(addr)).copied().unwrap_or(false);
        for (x, &i) in IDX_X.iter().enumerate() {
            self.set_value(i, Value::Bool(bit(map::DI_X1 + x as u16)));
        }
        let (x9, x10) = (bit(map::DI_X9), bit(map::DI_X10));
        self.set_value(IDX_X9, Value::Bool(x9));
        self.set_value(IDX_FB1, Value::Bool(x9));
        self.set_value(IDX_X10, Value::Bool(x10));
        self.set_value(IDX_FB2, Value::Bool(x10));
        Ok(())
    }
}

impl Driver for MiniModDriver {
    fn address(&self) -> u8 {
        self.unit.map_or(0, UnitId::get)
    }

    fn plan_startup(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        for (i, run) in self.setup.iter().enumerate() {
            let Ok(i) = u16::try_from(i) else { break };
            let request = Request::WriteMultipleRegisters {
                addr: run.addr,
                values: run.values.clone(),
            };
            out.push(self.tx(unit, request, Tag::SetupWrite(i)));
            let count = u16::try_from(run.values.len()).unwrap_or(u16::MAX);
            let request = Request::ReadHoldingRegisters {
                addr: run.addr,
                count,
            };
            out.push(self.tx(unit, request, Tag::SetupVerify(i)));
        }
    }

    fn plan_read(&mut self, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
        let request = Request::ReadDiscreteInputs {
            addr: map::DI_X1,
            count: map::DI_READ_COUNT,
        };
        out.push(self.tx(unit, request, Tag::Inputs));
        if let Readback::Every(n) = self.readback {
            if self.cycle % u64::from(n.max(1)) == 0 {
                let request = Request::ReadCoils {
                    addr: map::COIL_Y1,
                    count: 4,
                };
                out.push(self.tx(unit, request, Tag::Readback));
            }
        }
        self.cycle = self.cycle.wrapping_add(1);
    }

    fn plan_write(&mut self, desired: &[Option<Value>], refresh: bool, out: &mut Vec<Transaction>) {
        let Some(unit) = self.unit else { return };
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
        let request = if write == 0 {
            return;
        } else if owned == 0x0F {
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
        out.push(self.tx(unit, request, Tag::WriteOutputs));
    }

    fn on_reply(&mut self, tag: u32, reply: &Reply) -> Result<(), DecodeError> {
        let unexpected = DecodeError::Unexpected { tag };
        let Reply::Modbus(response) = reply else {
            return Err(unexpected);
        };
        if let Response::Exception { code, .. } = response {
            return Err(DecodeError::Exception(*code));
        }
        match (Tag::decode(tag), response) {
            (Some(Tag::Inputs), Response::ReadDiscreteInputs(bits)) => self.apply_inputs(tag, bits),
            (Some(Tag::Readback), Response::ReadCoils(bits)) if bits.len() == 4 => {
                for (y, &on) in bits.iter().enumerate() {
                    self.set_y(y, on);
                }
                Ok(())
            }
            (Some(Tag::WriteOutputs), Response::WriteSingleRegister { addr, value })
                if *addr == map::HR_YWORD =>
            {
                for y in 0..4 {
                    self.set_y(y, value & (1 << y) != 0);
                }
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
                let run = self.setup.get(usize::from(i)).ok_or(unexpected.clone())?;
                let ok = *addr == run.addr && usize::from(*count) == run.values.len();
                ok.then_some(()).ok_or(unexpected)
            }
            (Some(Tag::SetupVerify(i)), Response::ReadHoldingRegisters(found)) => {
                let run = self.setup.get(usize::from(i)).ok_or(unexpected.clone())?;
                if found.len() != run.values.len() {
                    return Err(unexpected);
                }
                let mismatch = run
                    .values
                    .iter()
                    .zip(found)
                    .zip(&run.names)
                    .find(|((want, got), _)| want != got);
                match mismatch {
                    Some(((&expected, &found), &register)) => Err(DecodeError::Mismatch {
                        register,
                        expected: u32::from(expected),
                        found: u32::from(found),
                    }),
                    None => Ok(()),
                }
            }
            _ => Err(unexpected),
        }
    }

    fn on_failure(&mut self, tag: u32) {
        if Tag::decode(tag) == Some(Tag::WriteOutputs) {
            self.rewrite = true;
        }
    }

    fn values(&self) -> &[Option<Value>] {
        &self.values
    }

    fn reply_delay(&self) -> Duration {
        Duration::from_millis(10 * u64::from(self.rdelayt))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::devices::Protocol;
    use crate::modbus::crc::append_crc;
    use crate::modbus::master::{encode_request, Progress, ReplyAssembler};
    use crate::modbus::ExceptionCode;
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
        let Outgoing::Modbus { unit, request } = &tx.frame else {
            panic!("not modbus")
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
        assert_eq!(plan.len(), 6, "three runs: 19..20, 35, 51");
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
    fn settings_are_checked() {
        assert_eq!(check_setting("readback", "every"), Ok(()));
        assert_eq!(check_setting("xlatup3", "65535"), Ok(()));
        assert_eq!(check_setting("Y4AOFF3", "-X3"), Ok(()));
        assert_eq!(check_setting("YLAMP2", "0b0000.0000.1111.1111"), Ok(()));
        assert_eq!(check_setting("RDELAYT", "200"), Ok(()));
        assert!(check_setting("RDELAYT", "201").is_err());
        assert!(check_setting("XLATUP1", "65536").is_err());
        assert!(check_setting("Y1AON1", "X7").is_err());
        assert!(check_setting("readback", "0").is_err());
        assert!(check_setting("YWORD", "1")
            .unwrap_err()
            .contains("not a minimod setting"));
        assert!(check_setting("YPULSE1", "1").is_err());
        assert!(check_setting("baud", "1").is_err());
        assert_eq!(
            driver(&[("RDELAYT", "5")]).reply_delay(),
            Duration::from_millis(50)
        );
        assert_eq!(driver(&[]).reply_delay(), Duration::from_millis(10));
    }

    #[test]
    fn catalog_entry() {
        let m = crate::devices::model("minimod").unwrap();
        assert_eq!(m.protocols, [Protocol::Modbus]);
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
}
