//! The simulator of a profiled device: a register bank holding the profile's points (their
//! power-on values from the profile), served over Modbus RTU, with the profile's simple
//! behaviour (a point that follows another with a first-order lag).
//!
//! Addresses no point names answer exception 02, unless the profile says the device reads
//! gaps (`read_gaps: true`), where they read 0. A write to an address no writable point names
//! is refused with exception 02; a value is stored as written (the device's own range checks
//! are not in a profile).

use super::{value, Behaviour, Profile, Table};
use crate::devices::ModelSpec;
use crate::modbus::crc::check_crc;
use crate::modbus::server::{
    decode_request, encode_response, exception_frame, serve, RegisterBank,
};
use crate::modbus::ExceptionCode;
use crate::point::{PointSpec, Value};
use crate::sim::{SimDevice, SimError, SimReply};
use crate::time::LineInstant;
use std::collections::BTreeMap;

/// The simulator asked for by the fn pointer of a profile model, which cannot carry the
/// profile: a device with no points. [`ModelSpec::simulate`] builds the real one.
pub(crate) fn unbound(address: u8) -> Box<dyn SimDevice> {
    Box::new(ProfileSim::new(
        super::model_of(super::catalog::empty().clone()),
        address,
    ))
}

/// The four tables of a simulated device.
#[derive(Debug, Clone, Default)]
struct Bank {
    coils: BTreeMap<u16, bool>,
    discretes: BTreeMap<u16, bool>,
    inputs: BTreeMap<u16, u16>,
    holding: BTreeMap<u16, u16>,
    /// Holding registers and coils a master may write.
    writable: std::collections::BTreeSet<(bool, u16)>,
    gaps: bool,
}

impl Bank {
    fn read<T: Copy + Default>(
        &self,
        map: &BTreeMap<u16, T>,
        addr: u16,
    ) -> Result<T, ExceptionCode> {
        match map.get(&addr) {
            Some(v) => Ok(*v),
            None if self.gaps => Ok(T::default()),
            None => Err(ExceptionCode::IllegalDataAddress),
        }
    }
}

impl RegisterBank for Bank {
    fn read_coil(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(&self.coils, addr)
    }

    fn read_discrete_input(&self, addr: u16) -> Result<bool, ExceptionCode> {
        self.read(&self.discretes, addr)
    }

    fn read_holding_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(&self.holding, addr)
    }

    fn read_input_register(&self, addr: u16) -> Result<u16, ExceptionCode> {
        self.read(&self.inputs, addr)
    }

    fn write_coil(&mut self, addr: u16, value: bool) -> Result<(), ExceptionCode> {
        if !self.writable.contains(&(true, addr)) {
            return Err(ExceptionCode::IllegalDataAddress);
        }
        self.coils.insert(addr, value);
        Ok(())
    }

    fn write_holding_register(&mut self, addr: u16, value: u16) -> Result<(), ExceptionCode> {
        if !self.writable.contains(&(false, addr)) {
            return Err(ExceptionCode::IllegalDataAddress);
        }
        self.holding.insert(addr, value);
        Ok(())
    }
}

/// A simulated profiled device.
#[derive(Debug, Clone)]
pub(crate) struct ProfileSim {
    spec: &'static ModelSpec,
    profile: &'static Profile,
    address: u8,
    bank: Bank,
    now: LineInstant,
    /// The exact state of each following point (engineering units), so a lag advanced in
    /// many small steps gives what one step gives.
    followers: Vec<f64>,
}

impl ProfileSim {
    /// The simulator of profile model `spec` at unit `address` (a model without a profile
    /// has no points).
    pub(crate) fn new(spec: &'static ModelSpec, address: u8) -> Self {
        let profile = spec.profile.unwrap_or_else(super::catalog::empty);
        let mut sim = Self {
            spec,
            profile,
            address,
            bank: Bank::default(),
            now: LineInstant::ZERO,
            followers: Vec::new(),
        };
        sim.power_on();
        sim
    }

    fn power_on(&mut self) {
        let mut bank = Bank {
            gaps: self.profile.limits.read_gaps,
            ..Bank::default()
        };
        for p in &self.profile.points {
            let words = value::encode(p, p.initial);
            for (k, w) in words.iter().enumerate() {
                let addr = p.address.wrapping_add(k as u16);
                match p.table {
                    Table::Coil => {
                        bank.coils.insert(addr, *w != 0);
                    }
                    Table::Discrete => {
                        bank.discretes.insert(addr, *w != 0);
                    }
                    Table::Input => {
                        bank.inputs.insert(addr, *w);
                    }
                    Table::Holding => {
                        bank.holding.insert(addr, *w);
                    }
                }
                if p.table.is_writable() && p.access.writes() {
                    bank.writable.insert((p.table == Table::Coil, addr));
                }
            }
        }
        self.bank = bank;
        self.followers = self
            .profile
            .behaviours
            .iter()
            .map(|Behaviour::Follow { point, .. }| self.profile.points[*point].initial)
            .collect();
    }

    /// A point's registers (or bit as 0/1).
    fn words(&self, point: usize) -> Vec<u16> {
        let p = &self.profile.points[point];
        (0..p.width())
            .map(|k| {
                let addr = p.address.wrapping_add(k);
                match p.table {
                    Table::Coil => u16::from(self.bank.coils.get(&addr).copied().unwrap_or(false)),
                    Table::Discrete => {
                        u16::from(self.bank.discretes.get(&addr).copied().unwrap_or(false))
                    }
                    Table::Input => self.bank.inputs.get(&addr).copied().unwrap_or(0),
                    Table::Holding => self.bank.holding.get(&addr).copied().unwrap_or(0),
                }
            })
            .collect()
    }

    fn store(&mut self, point: usize, words: &[u16]) {
        let p = &self.profile.points[point];
        for (k, w) in words.iter().enumerate() {
            let addr = p.address.wrapping_add(k as u16);
            match p.table {
                Table::Coil => {
                    self.bank.coils.insert(addr, *w != 0);
                }
                Table::Discrete => {
                    self.bank.discretes.insert(addr, *w != 0);
                }
                Table::Input => {
                    self.bank.inputs.insert(addr, *w);
                }
                Table::Holding => {
                    self.bank.holding.insert(addr, *w);
                }
            }
        }
    }

    /// A point's engineering value.
    fn engineering(&self, point: usize) -> f64 {
        let p = &self.profile.points[point];
        value::raw(p, &self.words(point)).map_or(0.0, |(raw, _)| value::engineering(p, raw))
    }

    fn reply(&self, bytes: Vec<u8>) -> SimReply {
        SimReply {
            bytes,
            delay: self.profile.timing.reply_delay,
        }
    }

    fn unknown(&self, point: &str) -> SimError {
        SimError::UnknownPoint {
            model: self.spec.name,
            point: point.to_string(),
        }
    }

    /// The entry named `point`.
    fn entry(&self, point: &str) -> Result<super::Entry, SimError> {
        let i = self
            .spec
            .point_index(point)
            .ok_or_else(|| self.unknown(point))?;
        self.profile
            .entries()
            .get(i)
            .copied()
            .ok_or_else(|| self.unknown(point))
    }
}

impl SimDevice for ProfileSim {
    fn model(&self) -> &'static str {
        self.spec.name
    }

    fn address(&self) -> u8 {
        self.address
    }

    fn advance_to(&mut self, t: LineInstant) {
        if t <= self.now {
            return;
        }
        let dt = (t - self.now).as_secs_f64();
        self.now = t;
        for (k, b) in self.profile.behaviours.iter().enumerate() {
            let Behaviour::Follow {
                point,
                source,
                time_constant,
            } = *b;
            let target = self.engineering(source);
            let tau = time_constant.as_secs_f64();
            let y = self.followers[k];
            let y = if tau <= 0.0 {
                target
            } else {
                target + (y - target) * (-dt / tau).exp()
            };
            self.followers[k] = y;
            let words = value::encode(&self.profile.points[point], y);
            self.store(point, &words);
        }
    }

    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        self.advance_to(t);
        if !check_crc(frame) {
            return None;
        }
        let (unit, req) = match decode_request(frame) {
            Ok(decoded) => decoded,
            Err(e) => {
                let (unit, out) = exception_frame(&e)?;
                return (unit == self.address).then(|| self.reply(out));
            }
        };
        if unit != 0 && unit != self.address {
            return None;
        }
        let resp = serve(&mut self.bank, &req);
        if unit == 0 {
            return None;
        }
        let mut out = Vec::new();
        encode_response(unit, &resp, &mut out);
        Some(self.reply(out))
    }

    fn points(&self) -> &'static [PointSpec] {
        self.spec.points
    }

    fn get(&self, point: &str) -> Result<Value, SimError> {
        let e = self.entry(point)?;
        let p = &self.profile.points[e.point];
        let words = self.words(e.point);
        let (raw, bits) = value::raw(p, &words).ok_or_else(|| self.unknown(point))?;
        Ok(match e.bits {
            Some(b) => {
                let f = &p.bits[b];
                value::typed(f.value_type(), f64::from(f.extract(bits)))
            }
            None => value::to_value(p, value::engineering(p, raw)),
        })
    }

    fn set(&mut self, point: &str, v: Value) -> Result<(), SimError> {
        let e = self.entry(point)?;
        let p = &self.profile.points[e.point];
        match e.bits {
            Some(b) => {
                let f = &p.bits[b];
                let words = self.words(e.point);
                let (_, bits) = value::raw(p, &words).ok_or_else(|| self.unknown(point))?;
                let mask = f.extract(u32::MAX) << f.bit;
                let n = (value::number(v).max(0.0) as u32) << f.bit;
                let bits = (bits & !mask) | (n & mask);
                let words = match p.data.words() {
                    1 => vec![bits as u16],
                    _ => p.order.split(bits).to_vec(),
                };
                self.store(e.point, &words);
            }
            None => {
                let n = value::number(v);
                let words = value::encode(p, n);
                self.store(e.point, &words);
                for (k, b) in self.profile.behaviours.iter().enumerate() {
                    let Behaviour::Follow { point, .. } = *b;
                    if point == e.point {
                        self.followers[k] = n;
                    }
                }
            }
        }
        Ok(())
    }

    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        match words {
            ["power-cycle"] => {
                self.power_on();
                Ok("powered up with the profile's initial values".into())
            }
            _ => Err(SimError::UnknownCommand(words.join(" "))),
        }
    }

    fn command_help(&self) -> &'static str {
        "power-cycle   every point back to the profile's initial value"
    }
}
