//! Event mode: a module whose event recording went off behind the master's back, told apart
//! from a line that lost an event.
//!
//! The start-up enables event recording (XEVMASK, EVFB1..2) without saving it, as it must not
//! make the project's settings permanent (MiniMod manual, "Configuration of Minimod": "AFTER
//! HAVING MODIFIED THE SETTINGS, remember to store them in memory"). A power cycle shorter than
//! the bus owner's `event_refresh` is then never seen as a loss, but brings the module back to
//! its saved settings ("Saving setting permanently": only saved preferences are "remembered on
//! subsequent power ups"): events off, and with them its tuned reply delay, latencies,
//! push-down tables and watchdog ("Internal watch-dog": "At power up, the watch-dog is
//! completely disabled"). From then on its inputs change with no event, and only a full read
//! shows it.
//!
//! A full read that finds an input word other than the one the events left is a suspicion,
//! not proof: on a noisy line the event's Collect reply may have been lost or corrupted, or
//! the change may be queued as an event that a later round brings. Missing events prove
//! nothing, so the driver asks the module itself: in its next cycle it reads XEVMASK back (FC 3,
//! holding register 5, 40006; "Modbus register map (read and write registers)"). A module that
//! still holds the mask its start-up wrote was not power-cycled: the full read has already put
//! the inputs right and nothing else happens. A module whose mask is no longer the one written
//! (the power-on value, 0, where nothing saved one) lost its unsaved settings: the driver asks
//! its bus owner for the start-up again ([`crate::driver::Driver::wants_restart`]), which sets
//! every setting again and writes every output. A read-back that fails (a lost or corrupted
//! reply) decides nothing: it is asked again the next cycle.
//!
//! So a power cycle is found at the first full read after the module's next input change
//! (within `event_refresh`, or `event_resync` while writes keep answering), one cycle later
//! the read-back shows the lost mask, and the start-up runs in the cycle after that.

use super::super::map;
use super::plan::XWORD_BITS;
use super::settings::SetupStep;
use super::{MiniModDriver, Tag};
use crate::driver::Transaction;
use crate::modbus::{Request, UnitId};
use crate::point::Value;

/// What the driver keeps between a suspicious full read and the module's answer.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct EventWatch {
    /// A full read found a change no event reported: XEVMASK is read back next cycle (and
    /// every cycle until a read-back is answered).
    suspect: bool,
}

impl MiniModDriver {
    /// A full read's input word, before it is applied: a change that no event reported makes
    /// the module suspect (event mode only).
    pub(super) fn watch_full_read(&mut self, word: u16) {
        if !self.events {
            return;
        }
        let known = self
            .values
            .get(map::point_index("XWORD").unwrap_or(usize::MAX))
            .copied()
            .flatten();
        if let Some(Value::U16(known)) = known {
            if known & XWORD_BITS != word & XWORD_BITS {
                self.event_watch.suspect = true;
            }
        }
    }

    /// An event came from the module: its recording is on.
    pub(super) fn watch_event(&mut self) {
        self.event_watch.suspect = false;
    }

    /// The module restarts: whatever was suspected, its start-up sets the mask again.
    pub(super) fn forget_event_watch(&mut self) {
        self.event_watch = EventWatch::default();
    }

    /// A cycle is planned: a suspect module's XEVMASK read-back goes with it.
    pub(super) fn plan_event_watch(&self, unit: UnitId, out: &mut Vec<Transaction>) {
        if self.event_watch.suspect && self.xevmask_written().is_some() {
            let request = Request::ReadHoldingRegisters {
                addr: map::XEVMASK.addr,
                count: 1,
            };
            out.push(self.modbus(unit, request, Tag::EventMaskProbe));
        }
    }

    /// The XEVMASK value the start-up wrote and read back (event mode always writes it).
    fn xevmask_written(&self) -> Option<u16> {
        self.setup.iter().find_map(|step| match step {
            SetupStep::Registers { values, names, .. } => names
                .iter()
                .position(|n| *n == map::XEVMASK.name)
                .and_then(|i| values.get(i).copied()),
            _ => None,
        })
    }

    /// The module's XEVMASK as the read-back found it: the evidence of a power-up, or of none.
    pub(super) fn on_event_mask(&mut self, found: u16) {
        self.event_watch.suspect = false;
        let Some(written) = self.xevmask_written() else {
            return;
        };
        let address = self.unit.map_or(0, UnitId::get);
        if found == written {
            tracing::debug!(
                address,
                "MiniMod at address {address}: a full read found an input change that no event \
                 reported; XEVMASK still reads {written}, as written: an event lost on the line, \
                 not a power cycle"
            );
            return;
        }
        tracing::warn!(
            address,
            "MiniMod at address {address}: a full read found an input change that no event \
             reported, and XEVMASK reads {found} where the start-up wrote {written}: the module \
             was powered up again on its saved settings; running its start-up again"
        );
        self.restart.request();
    }
}
