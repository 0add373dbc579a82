//! What the driver does when the module comes back, or refuses an output write: find out
//! whether its watchdog fired and why, say so once, reset it, and write every output again.
//!
//! Manual, "Internal watch-dog (security and coherency check)": when the watchdog fires, "the
//! modules goes in a state where the outputs have a known, programmable configuration which
//! can not be changed without resetting the watch-dog"; WDTFIRED (coil 160, 00161) "Must be
//! reset by the master"; WDTFB (discrete input 24, 10025) "The watch-dog has fired because an
//! output feedback (FB1 or FB2) is active"; WDTCOMM (discrete input 25, 10026) "The watch-dog
//! has fired because a connection loss with the computer/PLC"; "Wflags": "bit 1 (the second
//! bit of weight 2) indicates that the watch-dog has fired".
//!
//! - A write of an output (Y1..Y4, YWORD, a pulser) refused with exception 04, or `Error` on
//!   the text protocol, is what a fired watchdog answers: the driver asks its bus owner for a
//!   restart ([`crate::driver::Driver::wants_restart`]). A refusal that the restart does not
//!   explain (the watchdog had not fired) is logged once and asks no more restarts until a
//!   write succeeds again, so a module that refuses for another reason is not restarted every
//!   cycle; its outputs stay bad (the bus owner's side).
//! - [`crate::driver::Driver::on_restart`] (the bus owner calls it when the module answers
//!   again after it was lost, or after such a request) makes the driver forget the outputs it
//!   wrote and read back, so the writes after the start-up set every owned output again.
//! - The start-up, when the driver owns the watchdog (a watchdog setting, as every project
//!   gives by default) or after a refusal, begins by reading why, before anything resets it:
//!   Modbus FC 1 coil 160 (WDTFIRED), or `?WFLAGS` on the text protocol; then FC 2 discrete
//!   inputs 24..=25 (WDTFB, WDTCOMM), over Modbus on both protocols (the text protocol has no
//!   identifier for the cause; the manual allows Modbus beside it on the same line). A firing
//!   is logged once, with the module's address and the cause in the manual's words. The reset
//!   itself is the start-up's WDTFIRED = 0, read back (see the driver's "Start-up settings"),
//!   before the logic tables, whose pulser and output writes a fired watchdog would refuse;
//!   after a refusal on a module whose settings do not own the watchdog, the reset is planned
//!   here, right after the reads: FC 5 coil 160 ← 0, read back with FC 1.
//!
//! Event mode (Collect) needs nothing more: the bus owner's Collect round, the refresh and the
//! writes all go through the same start-up and write paths.

use super::{MiniModDriver, SetupStep, Tag, IDX_Y, IDX_YWORD};
use crate::devices::Protocol;
use crate::driver::{DecodeError, Integrity, Outgoing, Reply, Transaction};
use crate::modbus::{ExceptionCode, Request, Response, UnitId};
use crate::point::Value;

use super::super::map;
use super::super::text::{self, TextId, TextReply};
use super::super::watchdog::WFLAGS_FIRED;

/// Coil WDTFIRED (00161).
const COIL_WDTFIRED: u16 = map::WDTFIRED.addr;
/// Discrete input WDTFB (10025); WDTCOMM (10026) follows it.
const DI_WDTFB: u16 = map::WDTFB.addr;

/// Tag kinds (the tag's high half) of the transactions planned here; the driver's own
/// [`Tag`] kinds are small numbers.
const KIND_FIRED: u32 = 0x40;
const KIND_CAUSE: u32 = 0x41;
const KIND_RESET: u32 = 0x42;
const KIND_RESET_VERIFY: u32 = 0x43;

fn tag(kind: u32) -> u32 {
    kind << 16
}

/// The driver's side of a restart.
#[derive(Debug, Clone, Default)]
pub(super) struct Restart {
    /// The bus owner should run the start-up again (a write was refused).
    requested: bool,
    /// A refusal asked for the last restart and no write has succeeded since.
    refusal_pending: bool,
    /// The next start-up resets the watchdog even where the settings do not own it.
    reset_needed: bool,
    /// WDTFIRED as the last start-up read it.
    fired: Option<bool>,
    /// This firing has been logged (until a write succeeds or a start-up finds it clear).
    logged: bool,
    /// Why the driver was last restarted (for the log's wording).
    reason: Option<Reason>,
    /// The pending request is for settings the module lost, not for a refused write.
    lost_settings: bool,
}

/// Why the bus owner restarted the module.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Reason {
    /// It answers again after it was lost.
    Back,
    /// An output write was refused.
    Refused,
}

impl Restart {
    /// Whether the driver asks for its start-up again.
    pub(super) fn wants(&self) -> bool {
        self.requested
    }

    /// Asks for the start-up again for a reason other than a refused write (the module was
    /// powered up again on its saved settings, `lost_events`): the watchdog is reset by the start-up as ever, not read first.
    pub(super) fn request(&mut self) {
        self.requested = true;
        self.lost_settings = true;
    }
}

/// Whether `tag` writes an output or a pulser: what a fired watchdog refuses.
fn is_output_write(tag: u32) -> bool {
    Tag::decode(tag).is_some_and(|t| t.is_write() || matches!(t, Tag::WriteRegister(_)))
}

/// The cause of a firing, in the register table's words.
fn cause(fb: bool, comm: bool) -> &'static str {
    match (fb, comm) {
        (false, true) => "because a connection loss with the computer/PLC (WDTCOMM)",
        (true, false) => "because an output feedback (FB1 or FB2) is active (WDTFB)",
        (true, true) => {
            "because a connection loss with the computer/PLC (WDTCOMM) and an output feedback \
             (FB1 or FB2) is active (WDTFB)"
        }
        (false, false) => {
            "with neither WDTCOMM nor WDTFB set: fired by a master (WDTFIRED or WFLAGS written)"
        }
    }
}

impl MiniModDriver {
    /// Whether the settings' start-up resets the watchdog (it owns it).
    fn owns_watchdog(&self) -> bool {
        self.setup
            .iter()
            .any(|s| matches!(s, SetupStep::Coils { names, .. } if names.contains(&"WDTFIRED")))
    }

    /// The bus owner restarts the module: forget what it holds.
    pub(super) fn restart_now(&mut self) {
        self.y = [None; 4];
        // The start-up clears every blinker: the scan's mask is written again after it.
        self.lamp = [None; 4];
        for i in IDX_Y.into_iter().chain([IDX_YWORD]) {
            if let Some(slot) = self.values.get_mut(i) {
                *slot = None;
            }
        }
        self.rewrite = true;
        self.cycle = 0;
        self.forget_event_watch();
        let r = &mut self.restart;
        r.reason = Some(if r.requested && !r.lost_settings {
            Reason::Refused
        } else {
            Reason::Back
        });
        r.reset_needed |= r.requested && !r.lost_settings;
        r.requested = false;
        r.lost_settings = false;
    }

    /// The first transactions of the start-up: why the watchdog fired, before it is reset.
    pub(super) fn plan_watchdog_status(&self, unit: UnitId, out: &mut Vec<Transaction>) {
        let owned = self.owns_watchdog();
        if !owned && !self.restart.reset_needed {
            return;
        }
        let modbus = |request| Transaction {
            frame: Outgoing::Modbus { unit, request },
            tag: 0,
        };
        let fired = if self.protocol == Protocol::Text {
            Transaction {
                frame: Outgoing::Text {
                    line: text::read_command(unit.get(), TextId::Wflags),
                    terminator: text::TERMINATOR,
                    integrity: Integrity::Unchecked,
                },
                tag: 0,
            }
        } else {
            modbus(Request::ReadCoils {
                addr: COIL_WDTFIRED,
                count: 1,
            })
        };
        out.push(Transaction {
            tag: tag(KIND_FIRED),
            ..fired
        });
        out.push(Transaction {
            tag: tag(KIND_CAUSE),
            ..modbus(Request::ReadDiscreteInputs {
                addr: DI_WDTFB,
                count: 2,
            })
        });
        if !owned {
            out.push(Transaction {
                tag: tag(KIND_RESET),
                ..modbus(Request::WriteSingleCoil {
                    addr: COIL_WDTFIRED,
                    value: false,
                })
            });
            out.push(Transaction {
                tag: tag(KIND_RESET_VERIFY),
                ..modbus(Request::ReadCoils {
                    addr: COIL_WDTFIRED,
                    count: 1,
                })
            });
        }
    }

    /// A reply to a transaction planned here; `None` when `tag` is not one of them.
    pub(super) fn on_watchdog_reply(
        &mut self,
        tag: u32,
        reply: &Reply,
    ) -> Option<Result<(), DecodeError>> {
        let kind = tag >> 16;
        if !(KIND_FIRED..=KIND_RESET_VERIFY).contains(&kind) {
            return None;
        }
        let unexpected = DecodeError::Unexpected { tag };
        Some(match (kind, reply) {
            (_, Reply::Modbus(Response::Exception { code, .. })) => {
                Err(DecodeError::Exception(*code))
            }
            (KIND_FIRED, Reply::Modbus(Response::ReadCoils(bits))) => match bits.as_slice() {
                [on] => {
                    self.watchdog_read(*on);
                    Ok(())
                }
                _ => Err(unexpected),
            },
            (KIND_FIRED, Reply::Text(bytes)) => match text::parse_reply(bytes) {
                Ok(TextReply::Value(TextId::Wflags, v)) => {
                    self.watchdog_read(v & WFLAGS_FIRED != 0);
                    Ok(())
                }
                _ => Err(unexpected),
            },
            (KIND_CAUSE, Reply::Modbus(Response::ReadDiscreteInputs(bits))) => {
                match bits.as_slice() {
                    [fb, comm] => {
                        self.watchdog_cause(*fb, *comm);
                        Ok(())
                    }
                    _ => Err(unexpected),
                }
            }
            (KIND_RESET, Reply::Modbus(Response::WriteSingleCoil { addr, value }))
                if *addr == COIL_WDTFIRED && !*value =>
            {
                Ok(())
            }
            (KIND_RESET_VERIFY, Reply::Modbus(Response::ReadCoils(bits))) => {
                match bits.as_slice() {
                    [false] => {
                        self.restart.reset_needed = false;
                        for name in ["WDTFIRED", "WDTFB", "WDTCOMM"] {
                            self.set_named(name, Value::Bool(false));
                        }
                        Ok(())
                    }
                    [true] => Err(DecodeError::Mismatch {
                        register: "WDTFIRED",
                        expected: 0,
                        found: 1,
                    }),
                    _ => Err(unexpected),
                }
            }
            _ => Err(unexpected),
        })
    }

    fn watchdog_read(&mut self, fired: bool) {
        self.restart.fired = Some(fired);
        self.set_named("WDTFIRED", Value::Bool(fired));
        if !fired {
            self.restart.logged = false;
        }
    }

    fn watchdog_cause(&mut self, fb: bool, comm: bool) {
        self.set_named("WDTFB", Value::Bool(fb));
        self.set_named("WDTCOMM", Value::Bool(comm));
        let address = self.unit.map_or(0, UnitId::get);
        let r = &mut self.restart;
        if r.fired == Some(true) {
            // The refusal is explained; a refusal after this reset is a new firing.
            r.refusal_pending = false;
        }
        match r.fired {
            Some(true) if !r.logged => {
                r.logged = true;
                let when = match r.reason {
                    None => " at start-up",
                    Some(Reason::Back) => " is back",
                    Some(Reason::Refused) => " refused an output write",
                };
                tracing::warn!(
                    address,
                    "MiniMod at address {address}{when}: its watch-dog had fired {}; its \
                     outputs were held in the watch-dog's configuration (WDTYMASK); resetting \
                     the watch-dog (WDTFIRED = 0) and writing every output again",
                    cause(fb, comm)
                );
            }
            Some(false) if r.refusal_pending => {
                tracing::warn!(
                    address,
                    "MiniMod at address {address} refused an output write although its \
                     watch-dog had not fired (WDTFIRED = 0); its outputs stay bad until a \
                     write succeeds"
                );
            }
            _ => {}
        }
        r.fired = None;
    }

    /// After every reply but the restart's own: a refused output write asks for a restart
    /// (once per run of refusals), a good one ends the run.
    pub(super) fn after_reply(&mut self, tag: u32, result: &Result<(), DecodeError>) {
        if !is_output_write(tag) {
            return;
        }
        let r = &mut self.restart;
        match result {
            Ok(()) => {
                r.refusal_pending = false;
                r.logged = false;
            }
            Err(DecodeError::Exception(ExceptionCode::ServerDeviceFailure)) => {
                if !r.refusal_pending {
                    r.refusal_pending = true;
                    r.requested = true;
                }
            }
            Err(_) => {}
        }
    }
}
