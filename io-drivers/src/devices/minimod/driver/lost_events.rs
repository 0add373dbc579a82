//! Event mode: a module whose event recording went off behind the master's back.
//!
//! The start-up enables event recording (XEVMASK, EVFB1..2) without saving it, as it must not
//! make the project's settings permanent ("AFTER HAVING MODIFIED THE SETTINGS, remember to
//! store them in memory"). A power cycle shorter than the bus owner's `event_refresh` is then
//! never seen as a loss, but brings the module back to its saved settings: events off, and
//! with them its tuned reply delay, latencies, push-down tables and watchdog. From then on its
//! inputs change with no event, and only a full read shows it. So a full read that finds an
//! input word other than the one the events left is a suspicion; it is not proof, since a
//! change may be queued as an event that the next round brings. If the next round brings no
//! event from the module, its event recording is off: the driver asks its bus owner for the
//! start-up again ([`crate::driver::Driver::wants_restart`]), which sets every setting again
//! and writes every output.

use super::plan::XWORD_BITS;
use super::MiniModDriver;
use crate::point::Value;

/// What the driver keeps between a suspicious full read and the next round.
#[derive(Debug, Clone, Copy, Default)]
pub(super) struct EventWatch {
    /// Cycles planned since a full read found a change no event reported.
    suspect: Option<u8>,
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
            .get(super::super::map::point_index("XWORD").unwrap_or(usize::MAX))
            .copied()
            .flatten();
        if let Some(Value::U16(known)) = known {
            if known & XWORD_BITS != word & XWORD_BITS {
                self.event_watch.suspect = Some(0);
            }
        }
    }

    /// An event came from the module: its recording is on.
    pub(super) fn watch_event(&mut self) {
        self.event_watch.suspect = None;
    }

    /// A cycle is planned: after a whole round without the event a suspicious full read
    /// waited for, the module's start-up runs again.
    pub(super) fn watch_cycle(&mut self) {
        match self.event_watch.suspect {
            Some(0) => self.event_watch.suspect = Some(1),
            Some(_) => {
                self.event_watch.suspect = None;
                let address = self.unit.map_or(0, crate::modbus::UnitId::get);
                tracing::warn!(
                    address,
                    "MiniMod at address {address}: a full read found an input change that no \
                     event reported, and the next round brought none: its event recording is \
                     off (a power cycle back to its saved settings); running its start-up again"
                );
                self.restart.request();
            }
            None => {}
        }
    }
}
