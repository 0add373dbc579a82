//! The bus owner's optional frame trace ([`crate::wire::trace`]): the one exchange path
//! reports what it sends, what comes back, its timeouts and the bytes it drops. Without a tap
//! each report is one `Option` test: nothing is formatted or allocated.

use std::sync::Arc;
use std::time::Duration;

use super::{BusOwner, Miss};
use crate::time::LineInstant;
use crate::wire::trace::{Discard, Verdict, WireEvent, WireTap};

impl BusOwner {
    /// Reports every frame of this line to `tap` from now on (`softplc run --trace-bus`).
    pub fn set_wire_tap(&mut self, tap: Arc<dyn WireTap>) {
        self.tap = Some(tap);
    }

    /// Reports `event` at the line's time `at`.
    pub(super) fn trace(&self, at: LineInstant, event: WireEvent<'_>) {
        if let Some(tap) = &self.tap {
            tap.record(&self.name, at, &event);
        }
    }

    /// Reports `count` dropped bytes, if any.
    pub(super) fn trace_discard(&self, at: LineInstant, count: usize, why: Discard) {
        if count > 0 {
            self.trace(at, WireEvent::Discarded { count, why });
        }
    }

    /// Reports the reply `bytes` to the request in the transmit buffer.
    pub(super) fn trace_reply(&self, at: LineInstant, bytes: &[u8], verdict: Verdict) {
        self.trace(
            at,
            WireEvent::Received {
                bytes,
                request: &self.tx_buf,
                verdict,
            },
        );
    }

    /// Reports how an exchange that waited `wait` missed its reply.
    pub(super) fn trace_miss(&self, at: LineInstant, miss: &Miss, wait: Duration) {
        if self.tap.is_none() {
            return;
        }
        match miss {
            Miss::Silence => self.trace(at, WireEvent::Timeout { waited: wait }),
            Miss::Cut => self.trace_reply(at, &self.rx_buf, Verdict::Cut),
            Miss::Encode | Miss::Line(_) => {}
            Miss::Echo(fault) => {
                if !self.rx_buf.is_empty() {
                    self.trace_reply(at, &self.rx_buf, Verdict::Refused);
                }
                self.trace(at, WireEvent::Echo(*fault));
            }
            Miss::Bad(_) => self.trace_reply(at, &self.rx_buf, Verdict::Refused),
        }
    }
}
