//! The RESI simulator, one for every model: Modbus RTU and ASCII on the same port ("MODBUS/RTU
//! slave and ASCII slave", L746), over the model's tables and the module state.
//!
//! - A frame that starts with `#` (after a stray LF) and holds only printable characters up to
//!   its CR is ASCII (resi-spec §2.9); anything else with a good CRC is Modbus RTU; the rest
//!   is noise and gets no answer. With the option `ascii off` (the `-MODBUS` variant) ASCII
//!   frames are ignored.
//! - Modbus: the module's unit address answers; unit 0 (broadcast, undocumented) is executed
//!   and never answered; a frame for another unit or with a bad CRC is ignored; exceptions as
//!   [`bank`] says.
//! - Every answer waits the reply delay (option `reply-delay`, 2 ms by default; the manual
//!   gives no figure).
//! - The UART runs at what the DIP switches select (resi-spec §1.3: baud BR0..BR2 and PARITY
//!   on compact modules, DIP1+2 and the stored parity on slim ones; 8 data bits, 1 stop bit):
//!   on a served line ([`SimDevice::master_line`]) a master at another baud, or a known other
//!   format, is not heard. A module installed for a line ([`SimDevice::set_uart`]) gets its
//!   switches set to it.

pub(crate) mod bank;
pub(crate) mod console;

use super::ascii;
use super::item::Kind;
use super::model::Model;
use super::state::Module;
use super::value::Num;
use crate::line::settings::{LineSettings, SerialFormat};
use crate::modbus::crc::check_crc;
use crate::modbus::server::{decode_request, encode_response, exception_frame, serve};
use crate::modbus::{ExceptionCode, Request, Response};
use crate::point::{PointSpec, Value};
use crate::sim::{SimDevice, SimError, SimReply};
use crate::time::LineInstant;

/// A simulated RESI module.
#[derive(Debug, Clone)]
pub(crate) struct ResiSim {
    m: Module,
    /// The master's baud and format on a served line, when known.
    master: crate::sim::device::MasterLine,
}

/// Whether a frame is a RESI ASCII line.
fn is_ascii(frame: &[u8]) -> bool {
    let body = frame.strip_suffix(b"\n").unwrap_or(frame);
    let body = body.strip_prefix(b"\n").unwrap_or(body);
    body.first() == Some(&b'#')
        && body.ends_with(b"\r")
        && body
            .iter()
            .all(|&b| b == b'\r' || (0x20..0x7F).contains(&b))
}

impl ResiSim {
    /// A module of `model` just powered on, at FLASH address `address` with the address
    /// switches at 0.
    pub(crate) fn new(model: &'static Model, address: u8) -> Self {
        Self {
            m: Module::new(model, address),
            master: None,
        }
    }

    /// The baud and format the DIP switches select now.
    pub(crate) fn uart(&self) -> LineSettings {
        let s = self.m.system();
        LineSettings {
            baud: s.baud(),
            format: SerialFormat {
                data_bits: 8,
                parity: s.parity(),
                stop_bits: 1,
            },
        }
    }

    /// Whether the module's UART can read what the master sends.
    fn hears_master(&self) -> bool {
        crate::sim::device::hears(self.uart(), self.master)
    }

    /// The module, to change it directly (tests, options).
    #[cfg(test)]
    pub(crate) fn module_mut(&mut self) -> &mut Module {
        &mut self.m
    }

    fn reply(&self, bytes: Vec<u8>) -> SimReply {
        SimReply {
            bytes,
            delay: self.m.opts.reply_delay,
        }
    }

    fn on_modbus(&mut self, frame: &[u8]) -> Option<SimReply> {
        let me = self.m.address();
        let (unit, req) = match decode_request(frame) {
            Ok(decoded) => decoded,
            Err(e) => {
                let (unit, out) = exception_frame(&e)?;
                return (unit == me).then(|| self.reply(out));
            }
        };
        if unit != 0 && unit != me {
            return None;
        }
        // FC 1, 2, 3, 4, 5, 6, 15, 16 only (L1971–L1994).
        let resp = if matches!(
            req,
            Request::MaskWriteRegister { .. } | Request::Collect { .. }
        ) {
            Response::Exception {
                function: req.function().code(),
                code: ExceptionCode::IllegalFunction,
            }
        } else {
            serve(&mut bank::Bank::new(&mut self.m), &req)
        };
        if unit == 0 {
            return None;
        }
        let mut out = Vec::new();
        encode_response(unit, &resp, &mut out);
        Some(self.reply(out))
    }

    fn spec(&self, point: &str) -> Result<&'static PointSpec, SimError> {
        self.m
            .model()
            .points
            .iter()
            .find(|p| p.name == point)
            .ok_or_else(|| SimError::UnknownPoint {
                model: self.m.model().name,
                point: point.to_string(),
            })
    }
}

impl SimDevice for ResiSim {
    fn model(&self) -> &'static str {
        self.m.model().name
    }

    fn address(&self) -> u8 {
        self.m.address()
    }

    fn advance_to(&mut self, t: LineInstant) {
        // The module ticks in milliseconds since the line's origin.
        self.m
            .advance_to(u64::try_from(t.since_origin().as_millis()).unwrap_or(u64::MAX));
    }

    fn set_uart(&mut self, settings: LineSettings) -> bool {
        let f = settings.format;
        if f.data_bits != 8 || f.stop_bits != 1 {
            return false;
        }
        self.m
            .change_switches(|s| match s.baud_bits(settings.baud) {
                Some(bits) if s.set_parity(f.parity) => {
                    let mask = s.baud_mask();
                    s.set_dip((s.dip() & !mask) | bits);
                    true
                }
                _ => false,
            })
    }

    fn master_line(&mut self, baud: u32, format: Option<SerialFormat>) {
        self.master = Some((baud, format));
    }

    fn on_frame(&mut self, frame: &[u8], t: LineInstant) -> Option<SimReply> {
        self.advance_to(t);
        if !self.hears_master() {
            return None;
        }
        if is_ascii(frame) {
            if !self.m.opts.ascii {
                return None;
            }
            let bytes = ascii::serve::answer(&mut self.m, frame)?;
            return Some(self.reply(bytes));
        }
        if check_crc(frame) {
            return self.on_modbus(frame);
        }
        None
    }

    fn points(&self) -> &'static [PointSpec] {
        self.m.model().points
    }

    fn get(&self, point: &str) -> Result<Value, SimError> {
        let spec = self.spec(point)?;
        let unknown = || SimError::UnknownPoint {
            model: self.m.model().name,
            point: point.to_string(),
        };
        let entry = self.m.model().map.by_name(point).ok_or_else(unknown)?;
        let n = self.m.read(entry.item).map_err(|_| unknown())?;
        Ok(n.to_value(spec.ty))
    }

    fn set(&mut self, point: &str, value: Value) -> Result<(), SimError> {
        let spec = self.spec(point)?;
        let bad = || SimError::BadValue {
            point: point.to_string(),
            value: value.to_string(),
        };
        if value.value_type() != spec.ty {
            return Err(bad());
        }
        let entry = self.m.model().map.by_name(point).ok_or_else(bad)?;
        let item = entry.item;
        let n = Num::from_value(value);
        match item.kind {
            Kind::Di => self.m.set_terminal(item.index, value.as_bool()),
            Kind::Dip => {
                let bit = 1u8.checked_shl(u32::from(item.index)).ok_or_else(bad)?;
                let dip = self.m.system().dip();
                self.m.set_dip(if value.as_bool() {
                    dip | bit
                } else {
                    dip & !bit
                });
            }
            Kind::DipWord => {
                let dip = u8::try_from(n.int()).map_err(|_| bad())?;
                self.m.set_dip(dip);
            }
            Kind::Temp(_) => self
                .m
                .set_temperature(item.index, n.real())
                .map_err(|_| bad())?,
            _ => {
                if !entry.enc.fits(n) {
                    return Err(bad());
                }
                self.m.write(item, n).map_err(|_| bad())?;
            }
        }
        Ok(())
    }

    fn command(&mut self, words: &[&str]) -> Result<String, SimError> {
        console::command(&mut self.m, words)
    }

    fn command_help(&self) -> &'static str {
        console::HELP
    }
}

#[cfg(test)]
mod tests;
